"""``--dask`` on clusters as Dask's own commands start them (``dask scheduler``, ``dask worker ADDRESS``), and on
clusters that cannot grade: each said in one line, never a traceback."""

from __future__ import annotations

import importlib.util
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

if importlib.util.find_spec("distributed") is None:  # the optional extra: autonomy[cluster]
    pytest.skip("dask.distributed is not installed", allow_module_level=True)

from autonomy.classroom.cluster import NO_WORKER_WAIT_S
from tests.classroom.test_dask import ENV, ROOT

DASK = str(Path(sys.executable).with_name("dask"))
GARAGE = str(ROOT / "exercises" / "garage.yaml")
SOLUTION = ROOT / "exercises" / "solutions" / "garage.yaml"
WRONG = ROOT / "exercises" / "wrong" / "garage_full_speed.yaml"


class Started:
    """A process of Dask's own command, in a session of its own (a worker's nanny and worker end together)."""

    def __init__(self, folder: Path, name: str, *args: str, env: dict[str, str] | None = None) -> None:
        self.log = folder / f"{name}.log"
        with self.log.open("w") as log:
            self.process = subprocess.Popen(
                [DASK, *args], stdout=log, stderr=subprocess.STDOUT, cwd=folder, env=env or ENV, start_new_session=True
            )

    def said(self, pattern: str, timeout_s: float = 60.0) -> re.Match:
        deadline = time.monotonic() + timeout_s
        while not (found := re.search(pattern, self.log.read_text())):
            assert self.process.poll() is None and time.monotonic() < deadline, self.log.read_text()[-2000:]
            time.sleep(0.1)
        return found

    def end(self) -> None:
        try:
            os.killpg(self.process.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self.process.wait(timeout=30)


@pytest.fixture
def dask_here(tmp_path):
    """Starts ``dask scheduler`` (on loopback, any port) and ``dask worker``s as asked; ends them all after."""
    started: list[Started] = []

    def start(*args: str, env: dict[str, str] | None = None) -> Started:
        process = Started(tmp_path, f"dask-{len(started)}", *args, env=env)
        started.append(process)
        return process

    yield start
    for process in reversed(started):
        process.end()


def scheduler(start) -> str:
    return start("scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard").said(
        r"Scheduler at:\s+(tcp://127\.0\.0\.1:\d+)"
    )[1]


def grade(folder: Path, *args: str, timeout_s: float = 180) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "autonomy", "grade", GARAGE, *args],
        capture_output=True, text=True, timeout=timeout_s, cwd=folder, env=ENV,
    )  # fmt: skip


def one_line(done: subprocess.CompletedProcess, said: str) -> None:
    assert done.returncode == 2 and done.stdout == "", (done.stdout, done.stderr)
    assert done.stderr.count("\n") == 1 and said in done.stderr and "Traceback" not in done.stderr, done.stderr


def test_a_dask_worker_with_no_settings_grades_as_here_and_every_worker_gone_mid_class_is_one_line(dask_here, tmp_path):
    address = scheduler(dask_here)
    worker = dask_here("worker", address)  # as a Dask user starts one: no settings at all
    files = [str(SOLUTION), str(WRONG)]
    here = grade(tmp_path, *files, "--csv", "here.csv", "--quiet")
    there = grade(tmp_path, *files, "--dask", address, "--csv", "there.csv", "--quiet")
    assert here.returncode == there.returncode == 0 and "Traceback" not in there.stderr, there.stderr
    assert (tmp_path / "there.csv").read_bytes() == (tmp_path / "here.csv").read_bytes()
    # a class of 300 on its one worker: the worker (and its nanny) killed once the grading is under way (300
    # take some 15 s there on a quiet machine, and more on a busy one: the kill at 3 s comes mid-grading)
    (tmp_path / "class").mkdir()
    for n in range(300):
        (tmp_path / "class" / f"s{n:03}.yaml").write_bytes(SOLUTION.read_bytes())
    grading = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "grade", GARAGE, *sorted(map(str, (tmp_path / "class").iterdir()))]
        + ["--dask", address, "--csv", "class.csv"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path, env=ENV,
    )  # fmt: skip
    assert grading.stdout.readline().startswith("Grading 300 submissions")
    time.sleep(3.0)  # the cluster found fit (a second), the grading under way
    worker.end()
    out, err = grading.communicate(timeout=NO_WORKER_WAIT_S + 90)
    assert grading.returncode == 2 and "wrote" not in out, (out, err)
    assert err.count("\n") == 1 and "lost its workers mid-grading" in err and "Traceback" not in err, err
    assert not (tmp_path / "class.csv").exists()  # no marks written from a class half graded


def test_a_cluster_with_no_worker_or_a_worker_without_this_autonomy_is_refused_in_one_line(dask_here, tmp_path):
    nobody = scheduler(dask_here)
    refused = grade(tmp_path, str(SOLUTION), "--dask", nobody, "--quiet")
    one_line(refused, f"the Dask scheduler at {nobody} has no worker")
    # a worker whose Python has no autonomy (a package of that name that is not there), and one with another
    for name, package, said in (
        ("none", 'raise ModuleNotFoundError("No module named \'autonomy\'", name="autonomy")\n', "cannot import"),
        ("other", '__version__ = "0.0.1"\n', "runs another autonomy (0.0.1)"),
    ):
        (tmp_path / name / "autonomy").mkdir(parents=True)
        (tmp_path / name / "autonomy" / "__init__.py").write_text(package)
        address = scheduler(dask_here)
        dask_here("worker", address, env={**ENV, "PYTHONPATH": str(tmp_path / name)})
        one_line(grade(tmp_path, str(SOLUTION), "--dask", address, "--quiet"), said)
        roster = tmp_path / "roster.csv"
        roster.write_text("id,name,submission\n1001,Ada Lovelace,ada\n")
        served = subprocess.run(  # the live class, too, says so at its start, and does not start
            [sys.executable, "-m", "autonomy", "class", "serve", "garage", "--roster", str(roster)]
            + ["--dir", str(tmp_path / f"class-{name}"), "--port", "0", "--dask", address],
            capture_output=True, text=True, timeout=120, cwd=tmp_path, env=ENV,
        )  # fmt: skip
        one_line(served, said)

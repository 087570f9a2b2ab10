"""``autonomy test`` and the processes it starts: a plugin that ends its process, Ctrl-C, SIGTERM, a kill outright."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

PLUGIN = """\
import os
import time

from py_trees.common import Status

from autonomy.behaviours import RobotAction


class Exiter(RobotAction):
    node_type = "exiter"
    doc = "Ends its process."

    def update(self) -> Status:
        os._exit(0)


class Sleeper(RobotAction):
    node_type = "sleeper"
    doc = "Sleeps for an hour."

    def update(self) -> Status:
        time.sleep(3600)
        return Status.SUCCESS
"""


def missions(folder: Path, **trees: str) -> Path:
    """A mission for each of ``trees`` (its root's children), with the plugin, and a scenario file of two for each."""
    (folder / "tricks.py").write_text(PLUGIN)
    for name, children in trees.items():
        (folder / f"{name}.yaml").write_text(f"mission: {name}\nplugins: [tricks]\ntree:\n  sequence: [{children}]\n")
        (folder / f"{name}.test.yaml").write_text(
            "scenarios:\n"
            f"  - {{name: {name} once, world: box, expect: {{within_s: 5}}}}\n"
            f"  - {{name: {name} again, world: box, expect: {{within_s: 5}}}}\n"
        )
    return folder


def descendants(pid: int) -> set[int]:
    """The processes under ``pid``, from /proc."""
    parents = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parents[int(entry.name)] = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
    found, frontier = set(), {pid}
    while frontier:
        frontier = {child for child, parent in parents.items() if parent in frontier} - found
        found |= frontier
    return found


def gone_within(pids: set[int], seconds: float) -> set[int]:
    """Those of ``pids`` still running after ``seconds`` (zombies do not count)."""
    deadline = time.monotonic() + seconds
    while True:
        left = set()
        for pid in pids:
            try:
                state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
            except (OSError, IndexError):
                continue
            if state != "Z":
                left.add(pid)
        if not left or time.monotonic() > deadline:
            return left
        time.sleep(0.1)


def test_a_plugin_that_ends_its_process_fails_its_own_scenarios_and_the_others_run(tmp_path):
    missions(tmp_path, ends="exiter", fine="beep")
    done = subprocess.run(
        [sys.executable, "-m", "autonomy", "test", str(tmp_path)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr
    lines = done.stdout.splitlines()
    assert [line.split(": ", 1)[-1] for line in lines if line.startswith(("ok", "FAIL"))] == [
        "ends once", "ends again", "fine once (1 seed, 0.0 simulated s)", "fine again (1 seed, 0.0 simulated s)"
    ]  # fmt: skip
    assert (
        lines.count("      the scenario's process ended while it ran (a plugin's os._exit, or killed): no outcome") == 2
    )
    assert "4 scenarios: 2 passed, 2 failed" in done.stdout


@pytest.mark.parametrize("how", ["ctrl-c", "sigterm", "kill"])
def test_stopping_a_run_whose_plugin_sleeps_ends_it_and_every_worker(tmp_path, how):
    missions(tmp_path, sleeps="sleeper")
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "test", str(tmp_path), "-j", "2"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    deadline = time.monotonic() + 60
    while len(descendants(process.pid)) < 3 and time.monotonic() < deadline:  # the workers are asleep in the plugin
        time.sleep(0.2)
    time.sleep(1.0)
    workers = descendants(process.pid)
    assert len(workers) >= 3, workers
    if how == "ctrl-c":
        os.killpg(process.pid, signal.SIGINT)  # as a terminal sends it: to the whole group
    elif how == "sigterm":
        process.terminate()
    else:
        process.kill()
    out, err = process.communicate(timeout=30)
    if how == "kill":
        assert process.returncode == -signal.SIGKILL
    else:
        assert process.returncode == 130 and "Traceback" not in err, err
        assert "autonomy: interrupted after 0 of 2 scenarios" in err
    assert gone_within(workers, 5.0) == set()  # none left asleep, whoever ended the command

"""Grading on a Dask cluster (a LocalCluster on loopback): the same marks as grading here, byte for byte."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

if importlib.util.find_spec("distributed") is None:  # the optional extra: autonomy[cluster]
    pytest.skip("dask.distributed is not installed", allow_module_level=True)

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


@pytest.fixture(scope="module")
def cluster():
    """The scheduler's address of a LocalCluster run in a process of its own (not this one: see dask_cluster.py)."""
    yield from _cluster()


@pytest.fixture(scope="module")
def default_cluster():
    """A LocalCluster as Dask starts one by default: its workers are daemons."""
    yield from _cluster("daemon")


def _cluster(*how: str):
    process = subprocess.Popen(
        [sys.executable, str(Path(__file__).with_name("dask_cluster.py")), *how],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=ENV,
    )  # fmt: skip
    try:
        address = process.stdout.readline().strip()
        assert address.startswith("tcp://127.0.0.1:"), address
        yield address
    finally:
        process.stdin.close()
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def _grade(folder: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "autonomy", "grade", *args],
        capture_output=True, text=True, timeout=120, cwd=folder, env=ENV,
    )  # fmt: skip


def test_a_class_graded_on_a_dask_cluster_gets_the_same_bytes_as_graded_here(cluster, tmp_path):
    (tmp_path / "class" / "carol").mkdir(parents=True)
    for student, source in (
        ("alice.yaml", "solutions/garage.yaml"),
        ("bob.yaml", "wrong/garage_fixed_distance.yaml"),
        ("carol/mission.yaml", "wrong/garage_park_then_beep.yaml"),
    ):
        (tmp_path / "class" / student).write_text((ROOT / "exercises" / source).read_text())
    (tmp_path / "class" / "dan.yaml").write_text("mission: dan\ntree:\n  mvoe: {}\n")  # not graded: its problems
    absolute = tmp_path / "elsewhere" / "eve.yaml"  # given by its absolute path
    absolute.parent.mkdir()
    absolute.write_text((ROOT / "exercises" / "wrong" / "garage_until_bump.yaml").read_text())
    given = ["class/alice.yaml", "class/bob.yaml", "class/carol", "class/dan.yaml", str(absolute)]
    exercise = str(ROOT / "exercises" / "garage.yaml")
    here = _grade(tmp_path, exercise, *given, "--json", "here.json", "--quiet")
    there = _grade(tmp_path, exercise, *given, "--dask", cluster, "--json", "there.json", "--quiet")
    assert here.returncode == there.returncode == 0, there.stderr
    assert (tmp_path / "there.json").read_bytes() == (tmp_path / "here.json").read_bytes()
    students = json.loads((tmp_path / "there.json").read_text())["students"]
    assert [s["total"] for s in students] == [10, 2.5, 8, 0, 0]
    assert students[3]["problems"][0].startswith("class/dan.yaml:3:3:") and students[4]["file"] == str(absolute)
    assert sorted(p.name for p in (tmp_path / "class").iterdir()) == ["alice.yaml", "bob.yaml", "carol", "dan.yaml"]


def test_autonomy_grade_dask_writes_the_same_gradebook_and_says_what_is_wrong(cluster, tmp_path):
    exercise = str(ROOT / "exercises" / "bump.yaml")
    files = [str(ROOT / "exercises" / "solutions" / "bump.yaml"), str(ROOT / "exercises" / "wrong" / "bump_push.yaml")]
    here = _grade(tmp_path, exercise, *files, "--csv", "here.csv", "--quiet")
    there = _grade(tmp_path, exercise, *files, "--dask", cluster, "--csv", "there.csv", "--quiet")
    assert here.returncode == there.returncode == 0, there.stderr
    assert (tmp_path / "there.csv").read_bytes() == (tmp_path / "here.csv").read_bytes()
    nowhere = _grade(tmp_path, exercise, *files, "--dask", "tcp://127.0.0.1:9", "--quiet")  # the discard port
    assert nowhere.returncode == 2 and "no Dask scheduler answers there" in nowhere.stderr
    assert "Traceback" not in nowhere.stderr
    both = _grade(tmp_path, exercise, *files, "--dask", cluster, "--feedback", "pages")
    assert both.returncode == 2 and "grade without --dask for them" in both.stderr
    missing = subprocess.run(  # without the optional extra: one line saying how to get it
        [sys.executable, "-c", "import sys; sys.modules['distributed'] = None; from autonomy.cli import run; "
         f"sys.argv = ['autonomy', 'grade', {exercise!r}, {files[0]!r}, '--dask', {cluster!r}]; run()"],
        capture_output=True, text=True, timeout=60, cwd=tmp_path, env=ENV,
    )  # fmt: skip
    assert missing.returncode == 2 and missing.stderr.strip().endswith(
        "--dask needs dask.distributed: pip install 'autonomy[cluster]'"
    )


def test_a_default_cluster_whose_workers_are_daemons_grades_the_same_bytes(default_cluster, tmp_path):
    exercise = str(ROOT / "exercises" / "garage.yaml")
    files = [
        str(ROOT / "exercises" / "solutions" / "garage.yaml"),
        str(ROOT / "exercises" / "wrong" / "garage_full_speed.yaml"),
    ]
    here = _grade(tmp_path, exercise, *files, "--csv", "here.csv", "--quiet")
    there = _grade(tmp_path, exercise, *files, "--dask", default_cluster, "--csv", "there.csv", "--quiet")
    assert here.returncode == there.returncode == 0 and "Traceback" not in there.stderr, there.stderr
    assert (tmp_path / "there.csv").read_bytes() == (tmp_path / "here.csv").read_bytes()

"""``autonomy class serve --dask``: runs and hand-ins graded on a Dask cluster (a LocalCluster on loopback)."""

from __future__ import annotations

import importlib.util
import json
import re
import signal
import subprocess
import sys
import urllib.request

import pytest

if importlib.util.find_spec("distributed") is None:  # the optional extra: autonomy[cluster]
    pytest.skip("dask.distributed is not installed", allow_module_level=True)

from autonomy.classroom.exercise import load_exercise
from autonomy.classroom.secret import read_secret
from autonomy.liveclass.work import grade_text
from tests.classroom.test_dask import ENV, ROOT, cluster  # noqa: F401 - the cluster fixture, shared
from tests.liveclass.test_class_cli import SOLUTION, post, serve

WRONG = (ROOT / "autonomy" / "exercises" / "wrong" / "garage_full_speed.yaml").read_text()


def test_a_class_graded_on_a_cluster_gets_the_marks_and_pages_graded_here_would(cluster, tmp_path):  # noqa: F811
    (tmp_path / "roster.csv").write_text("id,name,submission\n1001,Ada Lovelace,ada\n")
    process, port, _ = serve(tmp_path, "--dask", cluster, env=ENV)
    try:
        assert f"graded on a Dask cluster at {cluster}" in process.said, process.said
        code = (tmp_path / "class" / "codes.csv").read_text().splitlines()[1].split(",")[2]
        ran = post(port, "/api/run", {"mission": WRONG}, code)
        handed = post(port, "/api/handin", {"mission": SOLUTION}, code)
        with urllib.request.urlopen(f"http://127.0.0.1:{port}{handed['page']}", timeout=30) as answer:
            page = answer.read()
    finally:
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=60)
    assert process.returncode == 0 and "Traceback" not in err, err
    secret = read_secret(tmp_path / "class" / "secret")  # as the server read it
    exercise = load_exercise(ROOT / "exercises" / "garage.yaml").with_secret(secret)
    here = tmp_path / "here"
    for given, number, hand_in in ((ran, ran["number"], False), (handed, handed["number"], True)):
        label = "hand-in 1" if hand_in else "run 1"
        report, path = grade_text(exercise, "1001", WRONG if not hand_in else SOLUTION, here, number, hand_in, label)
        assert (given["total"], [s["outcome"] for s in given["seeds"]]) == (
            report.total,
            [s.outcome for s in report.seeds],
        )
    assert ran["total"] < ran["max_points"] and handed["total"] == handed["max_points"] == 10
    assert page == path.read_bytes()  # the hand-in's page, made on the cluster, byte for byte
    assert re.search(rb"hidden seed 12", page) and json.loads(json.dumps(handed))["kind"] == "handin"


def test_serve_with_no_scheduler_at_the_address_says_so_in_one_line(tmp_path):
    (tmp_path / "roster.csv").write_text("id,name,submission\n1001,Ada Lovelace,ada\n")
    done = subprocess.run(
        [sys.executable, "-m", "autonomy", "class", "serve", "garage", "--roster", str(tmp_path / "roster.csv")]
        + ["--dir", str(tmp_path / "class"), "--port", "0", "--dask", "tcp://127.0.0.1:9"],
        cwd=ROOT, capture_output=True, text=True, timeout=60, env=ENV,
    )  # fmt: skip
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.count("\n") == 1 and "no Dask scheduler answers there" in done.stderr


#: Run on each worker of the cluster: the process ids of the grading workers it keeps warm.
WARM_PIDS = "[w.pid for g in __import__('autonomy.liveclass.work', fromlist=['_WARM'])._WARM.values() for w in g._all]"


def test_a_cluster_s_workers_keep_their_grading_workers_from_one_work_to_the_next(cluster, tmp_path):  # noqa: F811
    from autonomy.liveclass.work import WARM_EXERCISES, DaskGrader

    exercise = load_exercise(ROOT / "exercises" / "garage.yaml").with_secret(b"a class's secret")
    grader = DaskGrader(cluster)
    try:
        assert grader.slots == 2  # the cluster's two workers, a thread each: the server's two lanes
        first = [grader(exercise, "ada", SOLUTION, tmp_path, k, False, "run")[0] for k in range(1, 5)]
        warm = grader._client.run(eval, WARM_PIDS)
        later = [grader(exercise, "ada", WRONG, tmp_path, k, True, "hand-in")[0] for k in range(5, 9)]
        still = grader._client.run(eval, WARM_PIDS)
    finally:
        grader.close()
    here = grade_text(exercise, "ada", WRONG, tmp_path / "here", 9, True, "hand-in")[0]
    assert [r.total for r in first] == [10.0] * 4 and {r.total for r in later} == {here.total}
    kept = {pid for pids in warm.values() for pid in pids if pid is not None}
    assert kept  # started at a worker's first grading of the class
    after = {pid for pids in still.values() for pid in pids if pid is not None}
    assert kept <= after  # and kept for the works after (a worker whose first it was then started its own)
    assert len(after - kept) <= len(still) and all(len(pids) <= WARM_EXERCISES for pids in still.values())

"""Workers kept warm between works: the same marks, pages and limits as a worker started for each."""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import pytest

from autonomy.classroom import find_submissions, grade_class, load_exercise
from autonomy.classroom.child import alive
from autonomy.classroom.limits import WALL_PER_CPU, cpu_used_up_why
from autonomy.classroom.pool import _wall_why
from autonomy.classroom.results import page_path
from autonomy.classroom.warm import WarmWorkers
from tests.views.conftest import ROOT

EXERCISES = ROOT / "exercises"
GARAGE = load_exercise(EXERCISES / "garage.yaml")
WORKS = [
    EXERCISES / "solutions" / "garage.yaml",
    EXERCISES / "wrong" / "garage_fixed_distance.yaml",
    EXERCISES / "wrong" / "garage_park_then_beep.yaml",
]
#: A mission that keeps the CPU busy until its grading's time is up (a tree of many parallel waits).
#: A tree that needs several seconds of CPU time to grade on a fast machine (4.3 s on 2026-12-03, whose 450 waits
#: took 1.07 s: a limit of 1 s did not always cut it short).
SPIN = "mission: spin\ntree:\n  parallel:\n    children:\n" + "      - wait: {seconds: 100}\n" * 1800


@pytest.fixture
def warm():
    workers = WarmWorkers({"garage": GARAGE})
    yield workers
    workers.close()


def test_one_worker_grades_work_after_work_with_the_marks_and_the_pages_of_a_new_worker_for_each(warm, tmp_path):
    (tmp_path / "cold").mkdir()
    cold = grade_class(GARAGE, find_submissions(WORKS), workers=1, feedback=tmp_path / "cold", by_name=True)
    warm.start()
    first = warm.pid
    for path, alone in zip(WORKS * 2, cold * 2, strict=True):  # each twice, in turn
        pages = tmp_path / "warm" / f"{time.monotonic_ns()}"
        pages.mkdir(parents=True)
        report = warm.grade("garage", alone.student, path, pages, alone.student)
        assert (report.total, report.marks, report.problems) == (alone.total, alone.marks, alone.problems)
        assert report.file == path.name  # named by its name alone, as a class's server names it
        assert page_path(pages, alone.student).read_bytes() == page_path(tmp_path / "cold", alone.student).read_bytes()
        assert warm.pid == first  # the same process all along: no start paid for any of them
    assert cold[0].total == GARAGE.max_points and len({report.total for report in cold}) == 3  # three marks apart


def test_a_work_that_uses_up_its_cpu_time_scores_nothing_and_the_next_gets_a_new_worker(warm, tmp_path):
    spin = tmp_path / "spin.yaml"
    spin.write_text(SPIN)
    warm.grade("garage", "ada", WORKS[0], tmp_path, "ada")  # a worker that graded before
    first = warm.pid
    started_s = time.process_time()
    report = warm.grade("garage", "bob", spin, tmp_path, "bob", cpu_s=0.5)
    assert report.total == 0 and report.problems == [cpu_used_up_why(0.5)]
    assert report.cpu_s == pytest.approx(0.5, abs=0.5)
    assert time.process_time() - started_s < 0.5  # its CPU time was the worker's, not the caller's
    assert "used more than" in page_path(tmp_path, "bob").read_text()  # its page says why
    assert warm.pid not in (None, first)  # whatever it left behind is gone with its worker
    again = warm.grade("garage", "ada", WORKS[0], tmp_path, "ada")
    assert again.total == GARAGE.max_points


def test_a_worker_that_died_between_works_costs_the_next_work_nothing(warm, tmp_path):
    warm.grade("garage", "ada", WORKS[0], tmp_path, "ada")
    os.kill(warm.pid, signal.SIGKILL)  # as the kernel's out-of-memory killer would, while it waited
    time.sleep(0.2)
    report = warm.grade("garage", "bob", WORKS[0], tmp_path, "bob")
    assert report.total == GARAGE.max_points and not report.problems  # graded again, in a new worker


def test_closing_ends_the_worker_even_during_a_grading_and_no_grading_is_taken_after(tmp_path):
    warm = WarmWorkers({"garage": GARAGE})
    spin = tmp_path / "spin.yaml"
    spin.write_text(SPIN)
    warm.start()
    pid = warm.pid
    failed: list[BaseException] = []

    def grade() -> None:
        try:
            warm.grade("garage", "bob", spin, tmp_path, "bob", cpu_s=30)
        except RuntimeError as err:
            failed.append(err)

    grading = threading.Thread(target=grade)
    grading.start()
    time.sleep(0.5)
    warm.close()
    grading.join(10)
    assert not grading.is_alive() and len(failed) == 1  # told, at once, not after its 30 s
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)
    with pytest.raises(RuntimeError, match="closed"):
        warm.grade("garage", "ada", WORKS[0], tmp_path, "ada")


def test_closing_while_a_worker_is_being_started_leaves_none_behind(tmp_path):
    warm = WarmWorkers({"garage": GARAGE})
    made = []
    new = warm._new

    def slow_start():  # the moment a worker takes to start, made long
        worker = new()
        made.append(worker)
        time.sleep(0.5)
        return worker

    warm._new = slow_start
    starting = threading.Thread(target=warm.start)
    starting.start()
    time.sleep(0.1)
    warm.close()  # while it starts
    starting.join(10)
    assert warm.pid is None and len(made) == 1
    made[0].process.join(5)
    assert not made[0].process.is_alive()  # ended as it was kept, not left idle for good


def test_a_retired_class_s_workers_finish_the_grading_under_way_and_the_next_is_graded_cold(tmp_path):
    from autonomy.liveclass.work import LocalGrader

    grader = LocalGrader(GARAGE, lanes=1)
    text = WORKS[0].read_text()
    answers = []
    grading = threading.Thread(target=lambda: answers.append(grader(GARAGE, "ada", SPIN, tmp_path, 1, True, cpu_s=1.0)))
    grading.start()
    time.sleep(0.3)
    grader.retire()  # waits for that grading, then ends its worker
    grading.join(30)
    ((report, _),) = answers
    # graded to its end, not cut off: out of its CPU time (or, on a machine too busy to give it 1 s of CPU in 10 s,
    # of its wall time)
    assert report.total == 0 and report.problems in ([cpu_used_up_why(1.0)], [_wall_why(WALL_PER_CPU * 1.0, 1.0)])
    again, page = grader(GARAGE, "bob", text, tmp_path, 2, True)  # after: in a worker of its own
    assert again.total == GARAGE.max_points and page.is_file()
    grader.close()
    with pytest.raises(RuntimeError, match="closed"):
        grader(GARAGE, "cy", text, tmp_path, 3, True)


def test_a_worker_ended_by_two_threads_at_once_is_ended_once():
    """The grading that waited on it and the closing grader may end one worker together: its pipe is closed once."""
    from autonomy.classroom.pool import _end

    warm = WarmWorkers({"garage": GARAGE})
    worker = warm._new()
    closes = []
    close = worker.channel.close

    def slow_close() -> None:  # the moment between a pipe's close and its being marked closed, made long
        closes.append(threading.current_thread().name)
        time.sleep(0.3)
        close()

    worker.channel.close = slow_close
    enders = [threading.Thread(target=_end, args=(worker,)) for _ in range(2)]
    for ender in enders:
        ender.start()
    for ender in enders:
        ender.join(10)
    assert len(closes) == 1 and worker.ended and not worker.process.is_alive()
    warm.close()


@pytest.mark.parametrize("starting", [False, True], ids=["while it grades", "while it still starts"])
def test_a_grading_child_ends_soon_after_the_process_that_started_it_is_killed(tmp_path, starting):
    """A Dask daemon's grading child (classroom/child.py) whose worker was killed outright does not live on.

    Killed while the child still imports, the worker leaves it adopted by another process: it must still end.
    """
    import subprocess
    import sys

    script = tmp_path / "parent.py"
    script.write_text(
        "import pickle, subprocess, sys, time\n"
        "from autonomy.classroom.child import child_command\n"
        "child = subprocess.Popen(child_command(), stdin=subprocess.PIPE)\n"
        "child.stdin.write(pickle.dumps((time.sleep, (3600,))))\n"  # a call that takes an hour, as a long grading
        "child.stdin.close()\n"
        "print(child.pid, flush=True)\n"
        "time.sleep(3600)\n"
    )
    parent = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True)
    child = int(parent.stdout.readline())
    if not starting:
        time.sleep(1.0)
        assert alive(child)  # waiting on its hour-long call
    parent.kill()
    parent.wait(10)
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline:
        try:
            os.kill(child, 0)
        except ProcessLookupError:
            break
        state = open(f"/proc/{child}/stat").read().rsplit(")", 1)[1].split()[0]
        if state == "Z":
            break
        time.sleep(0.1)
    else:
        os.kill(child, signal.SIGKILL)
        raise AssertionError("the grading child lived on after its parent was killed")


def test_grading_workers_forked_side_by_side_end_soon_after_their_grader_is_killed(tmp_path):
    """Each holds the other's channel: their grader killed outright, neither would ever read the end of its own."""
    import subprocess
    import sys

    script = tmp_path / "grader.py"
    script.write_text(
        "import multiprocessing, time\n"
        "from autonomy.classroom import load_exercise\n"
        "from autonomy.classroom.pool import _start\n"
        "if __name__ == '__main__':\n"
        "    exercise = load_exercise('exercises/garage.yaml')\n"
        "    context = multiprocessing.get_context('fork')\n"
        "    workers = [_start(context, {'garage': exercise}, False, 512, 10.0, None, None, None, None, True, 0)\n"
        "               for _ in range(2)]\n"
        "    print(*(w.process.pid for w in workers), flush=True)\n"
        "    time.sleep(3600)\n"
    )
    root = Path(__file__).resolve().parents[2]
    grader = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True, cwd=root)
    pids = [int(pid) for pid in grader.stdout.readline().split()]
    time.sleep(1.0)
    for pid in pids:
        os.kill(pid, 0)  # waiting for work, alive
    grader.kill()
    grader.wait(10)
    deadline = time.monotonic() + 5
    left = set(pids)
    while left and time.monotonic() < deadline:
        for pid in list(left):
            try:
                os.kill(pid, 0)
                if open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()[0] == "Z":
                    left.discard(pid)
            except ProcessLookupError:
                left.discard(pid)
        time.sleep(0.1)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    assert left == set(), "grading workers lived on after their grader was killed"

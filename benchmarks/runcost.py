"""What one run costs the class's server, against the same grading done in this process, side by side.

Starts ``autonomy class serve garage`` (a process of its own, on loopback) with a roster of 20,
then, one request at a time, has the students take turns to "Run" the exercise's solution
(its public seeds), and, right beside each run, grades the same text here, in a warm
interpreter, as :func:`~autonomy.classroom.job.grade_one` does. Taking turns puts the same
noise of a shared machine on both.

Where a run's answer goes is measured in this process, stage by stage (each timed apart, the
median of the same number of repeats):
  - the grading alone (``grade_one``): the simulation and the judging;
  - the same, keeping each seed's run for the replay;
  - the feedback page written from them;
  - ``grade_text`` as the server calls it: the grading in a limited worker, its page, the text kept.

Reports the median and 95th percentile of the run's answer (from before it is sent to its
whole answer), the in-process grading's median, their ratio (target: at most 1.3), and the
server's own CPU time a run (its process alone, not its workers: what the server's loop and
threads spend on one).

Usage: python benchmarks/runcost.py [--runs N]
"""

from __future__ import annotations

import argparse
import http.client
import json
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from autonomy.classroom.exercise import load_exercise  # noqa: E402
from autonomy.classroom.job import grade_one  # noqa: E402
from autonomy.classroom.report import write_feedback_page  # noqa: E402
from autonomy.liveclass.work import grade_text, public_only  # noqa: E402
from autonomy.views.page import ReplayMaker  # noqa: E402
from benchmarks.liveclass import cpu_s  # noqa: E402 - a process's own CPU time, as the class benchmark reads it
from tests.liveclass.test_class_cli import serve  # noqa: E402

SOLUTION_PATH = ROOT / "exercises" / "solutions" / "garage.yaml"
STUDENTS = 20


def run(port: int, code: str) -> float:
    """One "Run" of the solution by the student of ``code``: the seconds to its whole answer."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=120)
    try:
        body = json.dumps({"mission": SOLUTION_PATH.read_text()}).encode()
        sent = time.perf_counter()
        conn.request("POST", "/api/run", body=body, headers={"Authorization": f"Bearer {code}"})
        answer = conn.getresponse()
        answer.read()
        took = time.perf_counter() - sent
    finally:
        conn.close()
    if answer.status != 200:
        raise SystemExit(f"a run was answered {answer.status}")
    return took


def timed(call: Callable[[], object]) -> float:
    started = time.perf_counter()
    call()
    return time.perf_counter() - started


def stages(repeats: int, folder: Path) -> dict[str, float]:
    """Each stage of a run, done here: its median time in seconds."""
    exercise = load_exercise(ROOT / "exercises" / "garage.yaml")
    public = public_only(exercise)
    text = SOLUTION_PATH.read_text()
    runs: list[ReplayMaker] = []
    folder.mkdir(parents=True, exist_ok=True)

    def kept() -> None:
        runs.clear()
        grade_one(public, "s", SOLUTION_PATH, runs=runs, name="s")

    report = grade_one(public, "s", SOLUTION_PATH, runs=runs, name="s")
    numbers = iter(range(1, 10**6))
    made = {
        "grading alone": lambda: grade_one(public, "s", SOLUTION_PATH),
        "keeping each seed's run": kept,
        "the feedback page": lambda: write_feedback_page(public, report, folder, runs, "s"),
        "grade_text (worker, page, text)": lambda: grade_text(exercise, "s", text, folder, next(numbers), False),
    }
    return {name: statistics.median(timed(call) for _ in range(repeats)) for name, call in made.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--runs", type=int, default=60, help="runs answered (default 60)")
    options = parser.parse_args()
    exercise = public_only(load_exercise(ROOT / "exercises" / "garage.yaml"))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "roster.csv").write_text(
            "id,name,submission\n" + "".join(f"s{i},Student {i},s{i}\n" for i in range(STUDENTS))
        )
        process, port, _ = serve(folder)
        try:
            codes = [row["code"] for row in _codes(folder)]
            for code in codes[:2]:  # the server's first gradings start what later ones keep
                run(port, code)
                grade_one(exercise, "s", SOLUTION_PATH)
            answers, here = [], []
            cpu_before = cpu_s(process.pid)
            for k in range(options.runs):
                answers.append(run(port, codes[k % STUDENTS]))
                here.append(timed(lambda: grade_one(exercise, "s", SOLUTION_PATH)))
                time.sleep(6.0 / STUDENTS)  # each student within their runs a minute
            server_cpu_s = (cpu_s(process.pid) - cpu_before) / options.runs
        finally:
            process.terminate()
            process.wait(30)
        parts = stages(max(9, options.runs // 4), folder / "stages")
    answer_ms, here_ms = statistics.median(answers) * 1e3, statistics.median(here) * 1e3
    p95_ms = sorted(answers)[int(0.95 * (len(answers) - 1))] * 1e3
    print(f"garage, {len(exercise.seeds)} public seeds, {options.runs} runs one at a time")
    print(f"  a run's answer:        median {answer_ms:.1f} ms, p95 {p95_ms:.1f} ms")
    print(f"  grade_one in process:  median {here_ms:.1f} ms")
    print(f"  ratio:                 {answer_ms / here_ms:.2f} (target: at most 1.3)")
    print(f"  the server's own CPU:  {server_cpu_s * 1e3:.1f} ms a run")
    print("where a run's time goes, done here (medians):")
    for name, took_s in parts.items():
        print(f"  {name:34} {took_s * 1e3:7.1f} ms")


def _codes(folder: Path) -> list[dict[str, str]]:
    """The students' codes, as ``class serve`` wrote them beside the roster."""
    import csv

    with (folder / "class" / "codes.csv").open(newline="") as stream:
        return list(csv.DictReader(stream))


if __name__ == "__main__":
    main()

"""How fast a class is graded.

Measures:
  - a class: 30 submissions x 3 seeds of a 60 s exercise (the wander mission in the
    obstacles world, 5,400 simulated seconds in all), graded with one worker a core: wall
    time, and simulated seconds per wall second across the class (target: 1000x, 5.4 s).
    The class is graded ``--classes`` times (default 5), and the target is judged on the
    median: this 2-core machine is a shared virtual one whose speed moves by a fifth from
    one minute to the next, and one run of a few seconds lands anywhere in that. Each run's
    figure is printed too, the slowest included;
  - one student's `autonomy grade` (a fresh process, the bump exercise, 4 public seeds of its
    reference solution): wall time, median of 5 (target: under 1 s).

Usage: python benchmarks/grading.py [--classes N]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from autonomy.classroom import find_submissions, grade_class, load_exercise

ROOT = Path(__file__).resolve().parents[1]
STUDENTS = 30
EXERCISE = """\
exercise: wander
title: Wander for a minute without a bump
world: obstacles
time_limit_s: 60
seeds: [1, 2, 3]
criteria:
  - max_collisions: 0
  - max_distance_mm: 20000
"""


def interpreter() -> str:
    """The Python running this: how it was built moves these figures by a third (docs/performance.md)."""
    return f"Python {platform.python_version()}, {os.path.realpath(sys.executable)}"


def grade_classes(classes: int) -> list[tuple[float, float]]:
    """Grades the class ``classes`` times; prints each run; returns each run's wall seconds and speed.

    The speed is simulated seconds per wall second across the class.
    """
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "wander.yaml").write_text(EXERCISE)
        mission = (ROOT / "missions" / "wander.yaml").read_text()
        files = []
        for index in range(STUDENTS):  # thirty students, each turning away a little differently
            path = folder / f"student{index:02d}.yaml"
            path.write_text(mission.replace("turn: {right: 70}", f"turn: {{right: {50 + index}}}"))
            files.append(path)
        exercise = load_exercise(folder / "wander.yaml")
        workers = os.cpu_count() or 1
        for run in range(classes):
            started = time.perf_counter()
            reports = grade_class(exercise, find_submissions(files), workers=workers)
            elapsed = time.perf_counter() - started
            simulated = sum(seed.time_s for report in reports for seed in report.seeds)
            assert all(not r.problems for r in reports) and simulated > 0.99 * STUDENTS * 3 * 60
            runs.append((elapsed, simulated / elapsed))
            print(
                f"a class ({run + 1}/{classes}): {STUDENTS} submissions x 3 seeds x 60 s "
                f"({simulated:,.0f} simulated s), {workers} workers: {elapsed:.2f} s wall, "
                f"{simulated / elapsed:,.0f}x real time"
            )
    return runs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--classes", type=int, default=5, help="how many times the class is graded (default 5; an odd number)"
    )
    classes = parser.parse_args().classes
    if classes < 1:
        parser.error(f"--classes must be 1 or more, not {classes}")
    print(interpreter())
    runs = sorted(grade_classes(classes), key=lambda run: run[1])
    wall_s, speed = runs[(len(runs) - 1) // 2]  # the median run (the lower of the middle two, for an even number)
    print(
        f"a class, median of {classes}: {wall_s:.2f} s wall, {speed:,.0f}x real time "
        f"(slowest {runs[0][1]:,.0f}x, fastest {runs[-1][1]:,.0f}x; target 1000x: 5.4 s): "
        f"{'meets target' if wall_s <= 5.4 and speed >= 1000 else 'MISSES target'}"
    )

    times = []
    for _ in range(5):
        started = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "autonomy", "grade", "bump", "exercises/solutions/bump.yaml", "--quiet"],
            cwd=ROOT,
            check=True,
        )
        times.append(time.perf_counter() - started)
    print(
        "one student's autonomy grade, bump (4 public seeds of about 20 s; a fresh process): "
        f"median {statistics.median(times):.2f} s (target < 1 s)"
    )


if __name__ == "__main__":
    main()

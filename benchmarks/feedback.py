"""What the students' feedback pages cost: the time they add to grading a class, and their size.

Grades a class of 300 submissions (three kinds of mission, as benchmarks/cluster.py has) with
`autonomy grade`, run as a teacher runs it, with and without `--feedback DIR`, taking turns,
three times each; prints the median of each, what the pages add to the wall time (target: at
most 20%) and to the CPU time of the grader and its workers (steadier on a shared machine), and
the pages' size.

Usage: python benchmarks/feedback.py [--students N] [--exercise NAME] [--runs N]
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
KINDS = {
    "garage": ("solutions/garage.yaml", "wrong/garage_fixed_distance.yaml", "wrong/garage_park_then_beep.yaml"),
    "square": ("solutions/square.yaml", "wrong/square_turns_85.yaml", "wrong/square_triangle.yaml"),
}


def _grade(exercise: str, files: list[Path], extra: list[str]) -> tuple[float, float]:
    """Grades the class; returns the wall time, and the CPU time of the grader and its workers."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-m", "autonomy", "grade", str(ROOT / "exercises" / f"{exercise}.yaml"), *map(str, files)]
        + ["--quiet", "--workers", "2", *extra],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        check=False,
    )
    if result.returncode not in (0, 1):  # 1: some student did not get every point
        raise SystemExit(f"autonomy grade failed: {result.stderr.strip()}")
    wall_s = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall_s, (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)


def main() -> None:
    """Prints the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--students", type=int, default=300)
    parser.add_argument("--exercise", choices=sorted(KINDS), default="garage")
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp())
    folder, pages = work / "class", work / "pages"
    folder.mkdir()
    kinds = KINDS[args.exercise]
    files = [folder / f"s{index:04d}.yaml" for index in range(args.students)]
    for index, file in enumerate(files):
        file.write_text((ROOT / "exercises" / kinds[index % len(kinds)]).read_text())
    without: list[tuple[float, float]] = []
    with_pages: list[tuple[float, float]] = []
    for _ in range(args.runs):
        without.append(_grade(args.exercise, files, []))
        shutil.rmtree(pages, ignore_errors=True)
        with_pages.append(_grade(args.exercise, files, ["--feedback", str(pages)]))
    plain_s, paged_s = (statistics.median(wall for wall, _ in runs) for runs in (without, with_pages))
    plain_cpu_s, paged_cpu_s = (statistics.median(cpu for _, cpu in runs) for runs in (without, with_pages))
    extra, extra_cpu = paged_s / plain_s - 1, paged_cpu_s / plain_cpu_s - 1
    sizes = [page.stat().st_size for page in pages.iterdir()]
    verdict = "meets target" if extra <= 0.20 else "MISSES target"
    print(
        f"{args.students} submissions of {args.exercise}, two workers, median of {args.runs}: "
        f"{plain_s:.2f} s without pages, {paged_s:.2f} s with --feedback ({extra:+.0%}; target at most +20%): "
        f"{verdict}; CPU time {plain_cpu_s:.2f} s and {paged_cpu_s:.2f} s ({extra_cpu:+.0%})"
    )
    print(
        f"pages: {len(sizes)}, {statistics.mean(sizes) / 1e3:.0f} KB each on average (largest "
        f"{max(sizes) / 1e3:.0f} KB), {sum(sizes) / 1e6:.1f} MB in all"
    )
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()

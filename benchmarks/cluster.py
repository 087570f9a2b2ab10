"""Grading a large class here and on a Dask cluster of two workers on the same machine.

Measures a class of 300 submissions of the garage exercise (three kinds of mission, 4 seeds
each), graded with `grade_class` (two workers) and with `grade_on_dask` on a LocalCluster of two
worker processes on loopback: wall time of each, and what the cluster adds (target: at most
15%). The marks must be the same bytes.

Usage: python benchmarks/cluster.py [--students N]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from autonomy.classroom import find_submissions, grade_class, load_exercise
from autonomy.classroom.cluster import grade_on_dask
from autonomy.classroom.report import to_json

ROOT = Path(__file__).resolve().parents[1]
KINDS = ("solutions/garage.yaml", "wrong/garage_fixed_distance.yaml", "wrong/garage_park_then_beep.yaml")


def main() -> None:
    """Prints the figures."""
    import dask
    import distributed

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--students", type=int, default=300)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    for index in range(args.students):
        (folder / f"s{index:04d}.yaml").write_text((ROOT / "exercises" / KINDS[index % 3]).read_text())
    exercise = load_exercise(ROOT / "exercises" / "garage.yaml")
    submissions = find_submissions(sorted(folder.iterdir()))
    with dask.config.set({"distributed.worker.daemon": False}):
        with distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
        ) as cluster:
            for run in range(3):
                started = time.perf_counter()
                here = grade_class(exercise, submissions, workers=2)
                local_s = time.perf_counter() - started
                started = time.perf_counter()
                there = grade_on_dask(exercise, submissions, cluster.scheduler_address)
                dask_s = time.perf_counter() - started
                same = "the same bytes" if to_json(exercise, here) == to_json(exercise, there) else "DIFFERENT marks"
                extra = dask_s / local_s - 1
                verdict = "meets target" if extra <= 0.15 and same == "the same bytes" else "MISSES target"
                print(
                    f"{args.students} submissions ({run + 1}/3): here {local_s:.2f} s, on a two-worker LocalCluster "
                    f"{dask_s:.2f} s ({extra:+.0%}; target at most +15%), {same}: {verdict}"
                )


if __name__ == "__main__":
    main()

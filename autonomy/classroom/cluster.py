"""The Dask executor: submissions graded on a Dask cluster, each task as the local executor grades (:mod:`pool`).

Any cluster as it comes: a worker that runs as a daemon (Dask's default) grades in a process of
its own (:mod:`autonomy.classroom.child`), which may start the limited workers.
"""

from __future__ import annotations

import math
import multiprocessing
from collections.abc import Callable
from pathlib import Path
from typing import Any

from autonomy.classroom.exercise import Exercise
from autonomy.classroom.limits import DEFAULT_CPU_S, DEFAULT_MEMORY_MB, WALL_PER_CPU
from autonomy.classroom.pool import grade_class
from autonomy.classroom.results import Report


def _bundle(path: Path) -> list[tuple[str, bytes]]:
    """A submission's files as they are given (a file, or a folder's own regular files), to send elsewhere."""
    if path.is_file() and not path.is_symlink():
        return [(path.name, path.read_bytes())]
    if path.is_dir():
        return [
            (item.name, item.read_bytes())
            for item in sorted(path.iterdir())
            if item.is_file() and not item.is_symlink() and item.stat().st_size <= 4 * 2**20
        ]
    return []  # missing, or a link: graded where it lands, which says so


def in_a_daemon() -> bool:
    """Whether this process is a daemon (a Dask worker by default): it may start subprocesses, not multiprocessing's."""
    return bool(multiprocessing.current_process().daemon)


def _dask_job(
    exercise: Exercise, jobs: list[tuple[str, str, list[tuple[str, bytes]], bool]], options: dict[str, Any]
) -> list[Report]:
    """The job of some submissions on a Dask worker: the same as a local worker's, in a limited process of their own.

    Each submission's files are put back in a folder of their own, under this job's, and the lot
    are graded there by :func:`grade_class` with one worker (which grades one after another as a
    local worker does, in a new process when anything of one could change the next); each report
    then names its files as they were given, so that its bytes are the same as a local grading's.
    Nothing of this changes the worker's own folder, which its other threads go on using.
    """
    import tempfile

    if in_a_daemon():  # graded in a process of its own, which may start the submissions' (see child.py)
        from autonomy.classroom.child import call_in_child

        return call_in_child(_dask_job, exercise, jobs, options)
    with tempfile.TemporaryDirectory(prefix="autonomy-grade-") as folder:
        places: list[Path] = []
        for index, (_, given, files, is_folder) in enumerate(jobs):
            place = Path(folder) / str(index) / (Path(given).name or "submission")
            if files and is_folder:
                place.mkdir(parents=True)
                for name, data in files:
                    (place / name).write_bytes(data)
            elif files:
                place.parent.mkdir(parents=True)
                place.write_bytes(files[0][1])
            places.append(place)
        reports = grade_class(
            exercise, [(job[0], place) for job, place in zip(jobs, places, strict=True)], workers=1, **options
        )
    for report, place, (_, given, _, _) in zip(reports, places, jobs, strict=True):
        # the folder it was put back in is no part of what the student sees: named as given, as here
        names = [(str(place), given)]
        if report.file and report.file != str(place) and report.file.startswith(str(place)):
            names.insert(0, (report.file, str(Path(given) / Path(report.file).relative_to(place))))
        for inside, shown in names:
            report.file = report.file.replace(inside, shown)
            report.problems = [problem.replace(inside, shown) for problem in report.problems]
    return reports


def grade_on_dask(
    exercise: Exercise,
    submissions: list[tuple[str, Path]],
    address: str,
    *,
    cpu_s: float = DEFAULT_CPU_S,
    wall_s: float | None = None,
    memory_mb: int = DEFAULT_MEMORY_MB,
    allow_plugins: bool = False,
    on_report: Callable[[Report], None] | None = None,
) -> list[Report]:
    """Grades every submission on the Dask cluster at ``address``: :func:`grade_class`'s job, another executor.

    The submissions go to the workers with their files, a few to a task (four tasks a worker
    thread, so that a slow one does not hold the rest back), and each task grades its own with
    :func:`grade_class` in a limited process, with the same limits as here: the marks are those
    of a local grading, byte for byte.

    Raises:
        ImportError: ``dask.distributed`` is not installed (``pip install 'autonomy[cluster]'``).
        OSError: no scheduler answers at ``address``.
    """
    from distributed import Client, as_completed

    options = {
        "cpu_s": cpu_s,
        "wall_s": WALL_PER_CPU * cpu_s if wall_s is None else wall_s,
        "memory_mb": memory_mb,
        "allow_plugins": allow_plugins,
    }
    with Client(address, timeout="5s") as client:
        threads = max(1, sum(client.nthreads().values()))
        size = max(1, math.ceil(len(submissions) / (4 * threads)))
        futures = {}
        for first in range(0, len(submissions), size):
            jobs = [
                (student, str(path), _bundle(path), path.is_dir())
                for student, path in submissions[first : first + size]
            ]
            task = client.submit(_dask_job, exercise, jobs, options, key=f"grade-{first}", pure=False)
            futures[task] = first
        reports: dict[int, Report] = {}
        for done in as_completed(futures):
            for offset, report in enumerate(done.result()):
                reports[futures[done] + offset] = report
                if on_report is not None:
                    on_report(report)
    return [reports[i] for i in range(len(submissions))]

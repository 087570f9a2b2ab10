"""The Dask executor: submissions graded on a Dask cluster, each task as the local executor grades (:mod:`pool`).

Any cluster as it comes: a worker that runs as a daemon (Dask's default) grades in a process of
its own (:mod:`autonomy.classroom.child`), which may start the limited workers. A cluster that
cannot grade is said in one line (:class:`ClusterUnfit`), before any grading when it can be
known then (:func:`connect`: no worker, a worker without autonomy, or with another autonomy,
whose marks could differ), or as soon as it shows (every worker gone mid-grading, a task that
failed on its workers).
"""

from __future__ import annotations

import math
import multiprocessing
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from autonomy.classroom.exercise import Exercise
from autonomy.classroom.limits import DEFAULT_CPU_S, DEFAULT_MEMORY_MB, WALL_PER_CPU
from autonomy.classroom.pool import grade_class
from autonomy.classroom.results import Report
from autonomy.clock import RealClock

#: How long a grading waits for a worker when the cluster has none, seconds: at the start, or after every
#: worker went away (one that restarts, or a new one, takes over the tasks left).
NO_WORKER_WAIT_S = 10.0
#: How often a grading that waits on the cluster looks whether it still has workers, seconds.
LOOK_EVERY_S = 0.5


class ClusterUnfit(RuntimeError):
    """A Dask cluster that cannot grade (or grade as here): the message says why, and what to do, in one line."""


def _autonomy_probe() -> Callable[[], tuple[str, str] | None]:
    """A function to run on a worker: the autonomy it imports there, as (version, digest of its Python files).

    None: it cannot import autonomy. The function imports all it needs when it runs, so that Dask
    sends it whole (by value): a worker without autonomy runs it too.
    """

    def autonomy_there() -> tuple[str, str] | None:
        import hashlib
        import importlib
        from pathlib import Path as Where

        try:
            package = importlib.import_module("autonomy")
        except ImportError:
            return None
        root = Where(str(package.__file__)).parent
        digest = hashlib.sha256()
        for path in sorted(root.rglob("*.py")):
            digest.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
        return str(getattr(package, "__version__", "?")), digest.hexdigest()

    return autonomy_there


def connect(address: str, wait_s: float = NO_WORKER_WAIT_S) -> Any:
    """A Dask client of the scheduler at ``address``, once its workers are known to grade as this machine does.

    Each worker must import autonomy, and the same autonomy as here (its version and its Python
    files alike): another would grade another way, and its marks could differ.

    Raises:
        ImportError: ``dask.distributed`` is not installed (``pip install 'autonomy[cluster]'``).
        OSError: no scheduler answers at ``address``.
        ClusterUnfit: no worker came within ``wait_s``, or a worker has no autonomy, or another one.
    """
    from distributed import Client

    client = Client(address, timeout="5s")
    try:
        try:
            client.wait_for_workers(1, timeout=wait_s)
        except TimeoutError:
            raise ClusterUnfit(
                f"the Dask scheduler at {address} has no worker (none came in {wait_s:g} s): "
                f"start one with 'dask worker {address}'"
            ) from None
        probe = _autonomy_probe()
        here = probe()
        for worker, there in sorted(client.run(probe, on_error="return").items()):
            if isinstance(there, BaseException):  # gone since it was listed, or could not run it
                raise ClusterUnfit(f"the Dask worker at {worker} did not answer ({type(there).__name__}): try again")
            if there is None:
                raise ClusterUnfit(
                    f"the Dask worker at {worker} cannot import autonomy: install autonomy {here[0] if here else ''} "
                    "(this one) where each worker runs"
                )
            if there != here:
                same = here is not None and there[0] == here[0]
                raise ClusterUnfit(
                    f"the Dask worker at {worker} runs another autonomy ({there[0]}"
                    + (", other files" if same else "")
                    + f") than this one ({here[0] if here else '?'}): its marks could differ; install this one "
                    "where each worker runs"
                )
    except BaseException:
        client.close()
        raise
    return client


def results(
    client: Any, futures: list[Any], address: str, wait_s: float = NO_WORKER_WAIT_S
) -> Iterator[tuple[Any, Any]]:
    """Each future and its result as it comes; while none comes, the cluster is looked at.

    Raises:
        ClusterUnfit: the cluster has had no worker for ``wait_s`` (every one gone mid-grading), or a
            task failed there (a worker that died each time it took the task, a grading process
            that ended without a result).
    """
    from distributed import wait

    clock = RealClock()
    pending = list(futures)
    alone_since: float | None = None
    while pending:
        try:
            done, _ = wait(pending, timeout=LOOK_EVERY_S, return_when="FIRST_COMPLETED")
        except TimeoutError:
            done = set()
        for future in [f for f in pending if f in done]:
            pending.remove(future)
            try:
                yield future, future.result()
            except Exception as err:  # noqa: BLE001 - said in one line: what failed there, not where in Dask
                said = str(err).strip().splitlines()
                raise ClusterUnfit(
                    f"a grading failed on the Dask cluster at {address}: {type(err).__name__}"
                    + (f": {said[0][:200]}" if said else "")
                ) from None
        if done:
            alone_since = None
        elif client.scheduler_info().get("workers"):
            alone_since = None
        elif alone_since is None:
            alone_since = clock.now()
        elif clock.now() - alone_since >= wait_s:
            raise ClusterUnfit(
                f"the Dask cluster at {address} lost its workers mid-grading (none for {wait_s:g} s): "
                f"{len(pending)} task(s) left ungraded; grade again once workers are back"
            )


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
        ClusterUnfit: the cluster cannot grade, or cannot grade as here (see :func:`connect` and :func:`results`).
    """
    options = {
        "cpu_s": cpu_s,
        "wall_s": WALL_PER_CPU * cpu_s if wall_s is None else wall_s,
        "memory_mb": memory_mb,
        "allow_plugins": allow_plugins,
    }
    with connect(address) as client:
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
        for done, graded in results(client, list(futures), address):
            for offset, report in enumerate(graded):
                reports[futures[done] + offset] = report
                if on_report is not None:
                    on_report(report)
    return [reports[i] for i in range(len(submissions))]

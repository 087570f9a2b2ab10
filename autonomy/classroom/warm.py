"""Workers kept warm: a server's gradings, one work at a time, without starting a process for each.

A class's server grades works as they come, one at a time in each of its lanes. Starting a worker
for each costs more than a small mission's grading. :class:`WarmWorkers` keeps one worker process
from one work to the next, with the limits and the isolation of :func:`~autonomy.classroom.pool.grade_class`:
the same CPU time a work (counted in the worker, from where its grading starts), the same memory,
the same wall time for one that waits without working, and a new worker after any work that could
have changed it (see :func:`~autonomy.classroom.pool._worker`). A work whose grading failed in a
worker that had graded another before is graded again in a new one, and that result stands. The
next worker is started as soon as one ends, so that its start is not the next work's wait.
"""

from __future__ import annotations

import multiprocessing
import threading
from dataclasses import replace
from multiprocessing.connection import wait
from pathlib import Path

from autonomy.classroom.exercise import Exercise
from autonomy.classroom.limits import DEFAULT_CPU_S, DEFAULT_MEMORY_MB, WALL_PER_CPU
from autonomy.classroom.pool import Job, _end, _feedback_page, _outcome, _Running, _start, _wall_why
from autonomy.classroom.results import Report


class WarmWorkers:
    """One worker process kept from one grading to the next; gradings from any thread, one at a time.

    Each work is graded from its own folder, its file named by its name alone (as ``grade_class``'s
    ``by_name``), and its feedback page written in the folder the work names.

    Args:
        exercises: The exercises a work may be graded on, by name (a hand-in on every seed, a run on
            the public ones).
        memory_mb: Memory (address space) the worker may take (as ``grade_class``'s).
        niceness: How far behind the machine's other work the worker runs (``os.nice``).
        allow_plugins: Whether missions may load Python plugins (a worker then grades one work alone).
        start_method: How the worker starts (``forkserver``: from a clean process, for a server with threads).
    """

    def __init__(
        self,
        exercises: dict[str, Exercise],
        *,
        memory_mb: int = DEFAULT_MEMORY_MB,
        niceness: int = 0,
        allow_plugins: bool = False,
        start_method: str = "forkserver",
    ) -> None:
        self._exercises = exercises
        self._memory_mb = memory_mb
        self._niceness = niceness
        self._allow_plugins = allow_plugins
        self._context = multiprocessing.get_context(start_method)
        if start_method == "forkserver":  # its workers are forked with the grader's modules loaded
            self._context.set_forkserver_preload(["autonomy.classroom.pool"])
        self._lock = threading.Lock()
        self._ready: _Running | None = None
        self._busy: _Running | None = None
        self._closed = False
        #: Guards the workers ready and busy, and whether they were closed (``close`` takes it too, not ``_lock``).
        self._state = threading.Lock()

    def start(self) -> None:
        """Starts the worker now, if none is ready: the first work does not wait for its start."""
        with self._lock:
            self._prestart()

    def _prestart(self) -> None:
        """A worker ready for the next work, started now unless one is (or the workers were closed)."""
        with self._state:
            if self._ready is not None or self._closed:
                return
        self._keep_ready(self._new())

    def _keep_ready(self, worker: _Running) -> None:
        """Keeps ``worker`` for the next work; ends it if one is kept already, or the workers were closed."""
        with self._state:
            if self._ready is None and not self._closed:
                self._ready = worker
                return
        _end(worker)

    def _take(self) -> _Running:
        """The worker ready (a new one if none is), now busy; raises if the workers were closed."""
        with self._state:
            if self._closed:
                raise RuntimeError("the grading workers were closed")
            worker, self._ready = self._ready, None
        worker = worker or self._new()
        with self._state:
            if not self._closed:
                self._busy = worker
                return worker
        _end(worker)
        raise RuntimeError("the grading workers were closed")

    @property
    def closed(self) -> bool:
        """Whether the workers were closed (gradings raise)."""
        return self._closed

    @property
    def pid(self) -> int | None:
        """The process id of the worker ready for the next work (None: none is yet)."""
        ready = self._ready
        return ready.process.pid if ready is not None else None

    def grade(
        self,
        exercise: str,
        student: str,
        path: Path,
        feedback: Path,
        name: str,
        cpu_s: float = DEFAULT_CPU_S,
        wall_s: float | None = None,
    ) -> Report:
        """Grades the mission file ``path`` on the exercise named ``exercise``; writes its page in ``feedback``.

        Args:
            exercise: Which of the exercises.
            student: Who it is from (the report's).
            path: The mission file (graded from its folder, named by its name alone).
            feedback: The folder its feedback page is written in, as ``page_path(feedback, name)``.
            name: What the report's page is named, and its runs.
            cpu_s: The CPU time its grading may take.
            wall_s: The wall time it may take (default: ``WALL_PER_CPU`` times ``cpu_s``).

        Returns:
            Its report: a zero with the reason when it could not be graded (its page says so too).

        Raises:
            RuntimeError: the workers were closed.
        """
        wall_s = WALL_PER_CPU * cpu_s if wall_s is None else wall_s
        job = Job(student, path.resolve(), exercise, cpu_s, feedback.resolve(), name)
        with self._lock:
            try:
                outcome = self._graded(job, wall_s)
                if outcome is None:  # failed where another was graded before: again, in a new worker
                    outcome = self._graded(job, wall_s)
            finally:
                self._prestart()  # the next one starts while nothing waits on it
        if isinstance(outcome, Report):
            return outcome
        why, counted_s = outcome if outcome is not None else ("the grading failed twice", 0.0)
        return replace(self._zero(job, why), cpu_s=counted_s)

    def _graded(self, job: Job, wall_s: float) -> Report | tuple[str, float] | None:
        """One grading in the worker ready (a new one if none is): as :func:`~autonomy.classroom.pool._outcome`."""
        worker = self._take()
        try:
            try:
                worker.channel.send(job)
            except OSError:  # gone: reading from it says so
                pass
            if not wait([worker.channel], timeout=wall_s):
                _end(worker)
                return _wall_why(wall_s, job.cpu_s or DEFAULT_CPU_S), 0.0
            try:
                result, last = worker.channel.recv()
            except (EOFError, OSError, ValueError, TypeError):
                result, last = None, True
        finally:
            with self._state:
                self._busy = None
        if self._closed:  # ended meanwhile: this grading is not answered
            _end(worker)
            raise RuntimeError("the grading workers were closed")
        if last or not isinstance(result, Report):
            _end(worker)
        else:
            self._keep_ready(worker)
        outcome = _outcome(worker, result, job.cpu_s or DEFAULT_CPU_S)
        worker.used = True
        return outcome

    def _new(self) -> _Running:
        # by name: a work's report, page and runs name its file alone
        args = (self._exercises, self._allow_plugins, self._memory_mb, DEFAULT_CPU_S, None, None, None, None, True)
        return _start(self._context, *args, self._niceness)

    def _zero(self, job: Job, why: str) -> Report:
        """The report of a work that could not be graded, and its page saying why."""
        exercise = self._exercises[job.exercise]
        report = Report(job.student, job.path.name, 0.0, exercise.max_points, [0.0] * len(exercise.criteria), [why])
        _feedback_page(exercise, report, job.feedback or Path("."), [], job.name, None)
        return report

    def close(self) -> None:
        """Ends the workers, the one grading now too (its grading raises, as any after this does)."""
        with self._state:
            self._closed = True
            ending = [worker for worker in (self._busy, self._ready) if worker is not None]
            self._ready = None
        for worker in ending:
            _end(worker)

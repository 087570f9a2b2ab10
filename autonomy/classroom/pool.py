"""The local executor: submissions graded by :func:`~autonomy.classroom.job.grade_one` in limited worker processes.

Each submission has a CPU-time limit and each worker a memory limit (:mod:`~autonomy.classroom.limits`),
so that an endless loop, a crash or a huge file costs that student a zero with the reason, never
the batch. Wall time, ten times as long, only ends one that waits without working (a plugin that
sleeps). A worker grades one submission after another while nothing of them could have changed
it, and is replaced otherwise (see :func:`_worker`).
"""

from __future__ import annotations

import gc
import multiprocessing
import os
import resource
import signal
import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Any, NamedTuple, cast

from py_trees.blackboard import Blackboard

from autonomy.classroom.child import end_with
from autonomy.classroom.exercise import Exercise
from autonomy.classroom.job import grade_one
from autonomy.classroom.limits import (
    ALARM,
    CPU_EXIT_CODE,
    CPU_GRACE_S,
    DEFAULT_CPU_S,
    DEFAULT_MEMORY_MB,
    RETIRE_GROWTH_MB,
    WALL_PER_CPU,
    CpuExhausted,
    address_space_mb,
    cap_what_it_starts,
    cpu_used_up_why,
    on_cpu_limit,
)
from autonomy.classroom.results import Report, file_names
from autonomy.clock import RealClock, cpu_alarm, cpu_time_s
from autonomy.views.page import ReplayMaker


def _graded(
    exercise: Exercise,
    student: str,
    path: Path,
    allow_plugins: bool,
    memory_mb: int,
    cpu_s: float,
    traces: Path | None = None,
    feedback: Path | None = None,
    name: str = "",
    corrections: list[tuple[float, str]] | None = None,
) -> tuple[Report | str, bool]:
    """One submission's report, or why it could not be graded (this student's zero); and whether the worker ends.

    A submission that used up its CPU time gets its report of zero here, whatever became of the
    exception that told it (code that catches everything may have turned it into another, or
    kept it): it is not graded again.
    """
    ALARM.rung = 0
    started_cpu_s = cpu_time_s()
    result: Report | str
    runs: list[ReplayMaker] | None = None
    try:
        ALARM.armed = True
        cpu_alarm(cpu_s, again_s=CPU_GRACE_S)  # again, should a plugin's ``except BaseException`` keep it
        try:
            runs = [] if feedback is not None else None
            if traces is None and runs is None:
                result = grade_one(exercise, student, path, allow_plugins)
            else:
                result = grade_one(exercise, student, path, allow_plugins, traces=traces, runs=runs, name=name)
        finally:
            ALARM.armed = False  # first: a signal on its way now is let go
            cpu_alarm(None)
    except MemoryError:
        result = f"used more than {memory_mb} MiB of memory"
    except (CpuExhausted, Exception, SystemExit, KeyboardInterrupt) as err:  # noqa: BLE001 - this student's zero
        last = traceback.extract_tb(err.__traceback__)[-1:] if err.__traceback__ else []
        at = f" at {Path(last[0].filename).name}:{last[0].lineno}" if last else ""
        result = f"grading stopped with {type(err).__name__}: {err}{at}"
    if ALARM.rung:  # its runs are not replayed: the page says why it scores nothing
        zero = [0.0] * len(exercise.criteria)
        result, runs = Report(student, str(path), 0.0, exercise.max_points, zero, [cpu_used_up_why(cpu_s)]), None
    ends = isinstance(result, str) or bool(ALARM.rung)
    if feedback is not None and isinstance(result, Report):  # in the worker: as many pages at once as workers
        _feedback_page(exercise, result, feedback, runs or [], name or file_names([student])[student], corrections)
    if isinstance(result, Report):
        result.cpu_s = cpu_time_s() - started_cpu_s
    return result, ends


def _feedback_page(
    exercise: Exercise,
    report: Report,
    folder: Path,
    runs: list[ReplayMaker],
    name: str,
    corrections: list[tuple[float, str]] | None,
) -> None:
    """Writes the student's feedback page, with the mark the gradebook will show (the teacher's corrections in it)."""
    from autonomy.classroom.report import write_feedback_page  # the reports' module builds on this one

    shown = report
    if corrections:
        extra = sum(points for points, _ in corrections)
        shown = replace(report, adjustments=list(corrections), total=round(report.total + extra, 2))
    try:
        write_feedback_page(exercise, shown, folder, runs, name)
    except (OSError, ValueError) as err:
        report.notes.append(f"its feedback page could not be written: {err}")


#: The share of its memory a worker has room for beyond what it was forked holding, whatever that was.
ROOM_SHARE = 0.5


class Job(NamedTuple):
    """A submission sent to a worker, and how it is graded there (None or empty: as the worker was started)."""

    student: str
    path: Path
    exercise: str = ""  # which of the worker's exercises
    cpu_s: float | None = None
    feedback: Path | None = None
    name: str = ""


def _worker(
    exercises: Exercise | dict[str, Exercise],
    allow_plugins: bool,
    memory_mb: int,
    cpu_s: float,
    channel: Connection,
    traces: Path | None = None,
    feedback: Path | None = None,
    names: dict[str, str] | None = None,
    corrections: dict[str, list[tuple[float, str]]] | None = None,
    by_name: bool = False,
    niceness: int = 0,
) -> None:
    """A worker process's body: limits its memory, then grades the submissions it is sent, one at a time.

    Each submission may use ``cpu_s`` of CPU time, counted by the kernel from where it starts.
    ``exercises`` is the exercise, or several by name: a :class:`Job` says which (and may give its
    own ``cpu_s``, feedback folder and name, for a worker kept from one work to the next).

    It leads a process group of its own, so that whatever a plugin starts goes with it. Each
    submission comes as (student, path) and goes back as (report or why not, whether the
    worker ends now). A worker grades one submission after another while nothing of them
    could have changed it: it ends after a submission whose grading failed, after any
    submission when plugins are allowed (a plugin's Python may change anything), and after
    one that left it holding more memory than it started with (``RETIRE_GROWTH_MB``). The
    next submission then gets a new worker.
    """
    os.setpgid(0, 0)
    # it ends with the grader: a grader killed outright cannot end it, and a worker forked beside others holds
    # their channels' other ends too, so that none of them ever reads the end of its own
    end_with(os.getppid())
    if isinstance(exercises, Exercise):
        exercises = {"": exercises}
    if niceness:  # behind whatever the machine does meanwhile (the class's server answering its checks)
        os.nice(niceness)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the grader ends its workers; a Ctrl-C is for the grader
    signal.signal(signal.SIGPROF, on_cpu_limit)
    # What the worker was forked with (modules, the exercise) lives as long as it does: left out of
    # the garbage collector's passes, which the records of each seed would otherwise repeat over it
    # (and each pass would copy the pages it touches from the grader).
    gc.freeze()
    # what it was forked holding is not the submission's: a grader that grew (threads reserve memory) leaves
    # each submission as much room as a small one does
    inherited_mb = address_space_mb() or 0.0
    limit = int(max(memory_mb, inherited_mb + memory_mb * ROOM_SHARE) * 2**20)
    try:
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    except (ValueError, OSError):
        pass
    started_mb = address_space_mb()
    while True:
        try:
            job = channel.recv()
        except Exception:  # noqa: BLE001 - the grader gone, or no memory left to read with: this worker ends
            return
        if job is None:
            return
        job = Job(*job)
        student, path = job.student, job.path
        budget_s = cpu_s if job.cpu_s is None else job.cpu_s
        if by_name:  # graded from its own folder: the report, the page and the runs name the file alone
            os.chdir(path.parent)
            path = Path(path.name)
        Blackboard.clear()  # as a new worker has it: nothing of the last submission's trees
        if allow_plugins:  # what a plugin starts inherits it
            cap_what_it_starts(budget_s)
        report, failed = _graded(
            exercises[job.exercise],
            student,
            path,
            allow_plugins,
            memory_mb,
            budget_s,
            traces,
            job.feedback or feedback,
            job.name or (names or {}).get(student, ""),
            (corrections or {}).get(student),
        )
        cpu_alarm(None)  # whatever happened in there, nothing goes off between submissions
        try:
            gc.collect()  # the last submission's trees (cycles of parents and children) let go now
            now_mb = address_space_mb()
            grown = started_mb is None or now_mb is None or now_mb - started_mb > RETIRE_GROWTH_MB
        except MemoryError:  # no memory left even to look: the report still goes, and this worker ends
            grown = True
        last = allow_plugins or failed or grown
        try:
            channel.send((report, last))
        except (OSError, MemoryError, ValueError):
            os._exit(3)
        if last:
            channel.close()
            return


def _start(context: Any, *args: Any) -> _Running:
    """A new worker process, given :func:`_worker`'s arguments but its channel."""
    mine, theirs = context.Pipe(duplex=True)
    exercises, allow_plugins, memory_mb, cpu_s, *rest = args
    process = context.Process(
        target=_worker, args=(exercises, allow_plugins, memory_mb, cpu_s, theirs, *rest), daemon=True
    )
    process.start()
    theirs.close()
    return _Running(process, mine)


def _outcome(worker: _Running, result: object, cpu_s: float) -> Report | tuple[str, float] | None:
    """What a worker's answer comes to, once a worker that ended is joined.

    Returns:
        The report; or why it was not graded, with the CPU time to count it (a zero, not graded
        again); or None: it failed in a worker that had graded another before, and is graded again
        in a new one (perhaps what came before was the cause).
    """
    if result is None and worker.process.exitcode in (CPU_EXIT_CODE, -signal.SIGXCPU):  # not graded again
        return cpu_used_up_why(cpu_s), cpu_s
    if not isinstance(result, Report) and worker.used:
        return None
    if isinstance(result, Report):
        return result
    if isinstance(result, str):
        return result, 0.0
    return f"the grading process ended without a report (exit code {worker.process.exitcode})", 0.0


def _wall_why(wall_s: float, cpu_s: float) -> str:
    """Why a submission that took all its wall time scores nothing."""
    why = f"took more than {wall_s:g} s of wall time" + (
        ", waiting rather than working (a plugin that sleeps?)" if wall_s >= cpu_s else ""
    )
    return f"{why} (--wall-seconds gives more)"


def _end(worker: _Running) -> None:
    """Ends a worker, and whatever its submission started; once, whoever else ends it at the same time.

    Two threads may end the same worker at once (the grading that waited on it, and the grader being
    closed): the second waits for the first, then finds it ended (its channel closed twice would close
    whatever file had taken its number meanwhile).
    """
    with worker.ending:
        if worker.ended:
            return
        _kill_group(worker.process)  # first: whatever the submission started ends with it
        worker.process.join(5)
        worker.channel.close()
        worker.ended = True


@dataclass
class _Running:
    """A worker process, the submission it grades (None while it waits for one), and whether it graded one before."""

    process: Any
    channel: Connection
    index: int | None = None
    deadline_s: float = 0.0
    used: bool = False
    ended: bool = False
    ending: threading.Lock = field(default_factory=threading.Lock)


def grade_class(
    exercise: Exercise,
    submissions: list[tuple[str, Path]],
    *,
    workers: int | None = None,
    cpu_s: float = DEFAULT_CPU_S,
    wall_s: float | None = None,
    memory_mb: int = DEFAULT_MEMORY_MB,
    allow_plugins: bool = False,
    on_report: Callable[[Report], None] | None = None,
    traces: Path | None = None,
    feedback: Path | None = None,
    corrections: dict[str, list[tuple[float, str]]] | None = None,
    start_method: str = "fork",
    by_name: bool = False,
    niceness: int = 0,
) -> list[Report]:
    """Grades every submission in worker processes, at most ``workers`` at once.

    A worker grades one submission after another (see :func:`_worker` for when it is replaced
    by a new one). A submission whose grading failed (or whose worker died) in a worker that
    had graded another before is graded again in a new worker, and that result stands: what
    a submission before left behind (memory, above all) never costs a student their marks, and
    the marks are those of a new worker for each, whatever the order or the number of
    workers. Each submission has ``cpu_s`` of CPU time, and ``wall_s`` of wall time for one that
    waits without working; one that takes longer costs that student a zero (not graded again: an
    endless loop would cost twice the time).

    Args:
        exercise: The exercise.
        submissions: (student, path) pairs, as :func:`find_submissions` gives them.
        workers: Processes at once (default: the machine's cores).
        cpu_s: CPU time a submission may take, all its seeds together.
        wall_s: Wall time a submission may take (default: ``WALL_PER_CPU`` times ``cpu_s``).
        memory_mb: Memory (address space) a worker process may take, and at least :data:`ROOM_SHARE` of it
            more than it was forked holding.
        allow_plugins: Whether submissions may load Python plugins.
        on_report: Called with each report as it is ready (for a progress bar).
        traces: A folder to keep each run's trace in (see :func:`trace_path`), for its replay.
        feedback: A folder to write each student's feedback page in (see :func:`page_path`), by the workers.
        corrections: The teacher's corrections by student, which their feedback pages show (the
            reports themselves do not get them: see :func:`autonomy.classroom.gradebook.apply_adjustments`).
        start_method: How workers start: ``fork`` (the grader is one thread), or ``forkserver`` for a
            process with threads of its own (a server), whose workers are forked from a clean process.
        by_name: Each submission is graded from its own folder, its file named by its name alone in
            the report, the page and the runs (a class's server: where it keeps the file is none of the
            student's business). The submissions are files.
        niceness: How far behind the machine's other work the workers run (``os.nice``): a class's
            server's gradings let its answers to students go first. CPU time is counted the same.

    Returns:
        The reports, in the order of ``submissions``.
    """
    workers = max(1, workers or os.cpu_count() or 1)
    wall_s = WALL_PER_CPU * cpu_s if wall_s is None else wall_s
    if by_name:  # a worker grades from each file's folder: every other place is told whole
        submissions = [(student, path.resolve()) for student, path in submissions]
        traces, feedback = (None if f is None else f.resolve() for f in (traces, feedback))
    names = file_names(student for student, _ in submissions) if traces is not None or feedback is not None else {}
    context = multiprocessing.get_context(start_method)
    if start_method == "forkserver":  # its workers are forked with the grader's modules loaded, not each importing them
        context.set_forkserver_preload(["autonomy.classroom.pool"])
    clock = RealClock()
    reports: dict[int, Report] = {}
    pending = list(range(len(submissions)))
    pool: list[_Running] = []
    zero = [0.0] * len(exercise.criteria)

    def failed(index: int, why: str) -> Report:
        student, path = submissions[index]
        report = Report(student, path.name if by_name else str(path), 0.0, exercise.max_points, list(zero), [why])
        if feedback is not None:  # its worker made no page (it ran out of time, or ended): the page says why
            name = names.get(student) or file_names([student])[student]
            _feedback_page(exercise, report, feedback, [], name, (corrections or {}).get(student))
        return report

    def finish(index: int, report: Report) -> None:
        reports[index] = report
        if on_report is not None:
            on_report(report)

    def give(worker: _Running, index: int) -> None:
        worker.index, worker.deadline_s = index, clock.now() + wall_s
        try:
            worker.channel.send(Job(*submissions[index]))
        except OSError:  # the worker is gone: reading from it says so, and the submission is graded again
            pass

    def end(worker: _Running) -> None:
        _end(worker)
        if worker in pool:
            pool.remove(worker)

    def start(index: int) -> None:
        args = (exercise, allow_plugins, memory_mb, cpu_s, traces, feedback, names, corrections, by_name, niceness)
        worker = _start(context, *args)
        pool.append(worker)
        give(worker, index)

    try:
        while pending or any(worker.index is not None for worker in pool):
            for worker in pool:
                if worker.index is None and pending:
                    give(worker, pending.pop(0))
            while pending and len(pool) < workers:
                start(pending.pop(0))
            busy = [worker for worker in pool if worker.index is not None]
            soonest = min(worker.deadline_s for worker in busy)
            ready = wait([worker.channel for worker in busy], timeout=max(0.0, soonest - clock.now()))
            for worker in busy:
                if worker.channel not in ready:
                    continue
                index = cast(int, worker.index)
                worker.index = None
                try:
                    result, last = worker.channel.recv()
                except (EOFError, OSError, ValueError, TypeError):
                    result, last = None, True
                if last or not isinstance(result, Report):
                    end(worker)
                outcome = _outcome(worker, result, cpu_s)
                if outcome is None:
                    start(index)  # a new worker, in the place it left
                elif isinstance(outcome, Report):
                    finish(index, outcome)
                else:
                    finish(index, replace(failed(index, outcome[0]), cpu_s=outcome[1]))
                worker.used = True
            now = clock.now()
            for worker in list(pool):
                if worker.index is not None and now >= worker.deadline_s:
                    index = worker.index
                    end(worker)
                    finish(index, failed(index, _wall_why(wall_s, cpu_s)))
    finally:
        # a second Ctrl-C must not cut the clean-up short and leave workers behind
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM, signal.SIGHUP})
        try:
            for worker in list(pool):
                end(worker)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
    return [reports[i] for i in range(len(submissions))]


def _kill_group(process: Any) -> None:
    """Ends a worker and every process in its group (what a plugin may have started)."""
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):  # gone, or not yet leading its group
        pass
    try:
        process.kill()
    except (OSError, ValueError):
        pass

"""A grading request: what to grade, with which limits, on which executor, and what to write from the results.

``autonomy grade`` reads its arguments into a :class:`GradeRequest` (every file of the
teacher's read and checked before any grading: :func:`read_request`), has it graded
(:func:`grade`: the job on the local pool or on Dask), and writes each output the request names
from the results alone (:data:`OUTPUTS`, one table of kinds)::

    request = read_request(exercise, submissions, limits, outputs, teacher_files)
    reports = grade(request)
    graded = settle(request, reports)          # corrections applied, the roster matched, pages found
    text = OUTPUTS["csv"](graded, "marks.csv")

The composition root of the classroom: it imports the executors and the outputs; nothing of
the classroom imports it.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from autonomy.classroom.exercise import Exercise
from autonomy.classroom.gradebook import (
    Adjustment,
    Earlier,
    GradebookError,
    RosterEntry,
    RosterMatch,
    apply_adjustments,
    match_roster,
    read_adjustments,
    read_earlier,
    read_expected,
    read_roster,
    unknown_students,
)
from autonomy.classroom.gradescope import to_gradescope
from autonomy.classroom.limits import DEFAULT_MEMORY_MB, WALL_PER_CPU, default_cpu_s
from autonomy.classroom.report import to_csv, to_html, to_json
from autonomy.classroom.results import Report, file_names, page_path
from autonomy.emulator.world import SHIPPED


@dataclass(frozen=True)
class Limits:
    """What one submission's grading may cost, and how many are graded at once.

    Attributes:
        cpu_s: CPU time a submission may take, all its seeds together (None: the exercise's default).
        wall_s: Wall time a submission may take (None: ``WALL_PER_CPU`` times its CPU time).
        memory_mb: Memory a worker process may take, MiB.
        allow_plugins: Whether submissions may load Python plugins.
        workers: Submissions graded at once here (None: the machine's cores).
    """

    cpu_s: float | None = None
    wall_s: float | None = None
    memory_mb: int = DEFAULT_MEMORY_MB
    allow_plugins: bool = False
    workers: int | None = None


@dataclass
class GradeRequest:
    """What ``autonomy grade`` is asked: the exercise, the submissions, the limits, the executor, the outputs.

    Attributes:
        exercise: The exercise, with its hidden seeds when the teacher's secret was given.
        submissions: (student, path) pairs, as :func:`~autonomy.classroom.submissions.find_submissions` gives them.
        limits: What each submission's grading may cost.
        dask: A Dask scheduler's address to grade on (None: here, in the local pool).
        traces: A folder for each run's trace (the local pool alone).
        feedback: A folder for each student's feedback page (the local pool alone).
        outputs: (kind, file) for each file to write: a kind of :data:`OUTPUTS`.
        roster: The class's roster, and the folder its paths are relative to.
        adjustments: The teacher's corrections, and the file they came from.
        earlier: An earlier grading's marks to compare with, and its file.
        expected: Each student's band of fair marks (lo, hi, line), and its file (``--expect``).
    """

    exercise: Exercise
    submissions: list[tuple[str, Path]]
    limits: Limits = field(default_factory=Limits)
    dask: str | None = None
    traces: Path | None = None
    feedback: Path | None = None
    outputs: list[tuple[str, Path]] = field(default_factory=list)
    roster: tuple[list[RosterEntry], Path] | None = None
    adjustments: tuple[list[Adjustment], str] = ([], "")
    earlier: tuple[Earlier, str] | None = None
    expected: tuple[dict[str, tuple[float, float, int]], str] | None = None

    @property
    def cpu_s(self) -> float:
        """The CPU time each submission gets."""
        return self.limits.cpu_s or default_cpu_s(self.exercise)

    @property
    def corrections(self) -> dict[str, list[tuple[float, str]]]:
        """The teacher's corrections by student, (points, reason) each, as their feedback pages show them."""
        out: dict[str, list[tuple[float, str]]] = {}
        for adjustment in self.adjustments[0]:
            out.setdefault(adjustment.student, []).append((adjustment.points, adjustment.reason))
        return out


class RequestInvalid(ValueError):
    """A request that cannot be graded as asked: the problems of the teacher's files (``FILE:LINE: ...``)."""

    def __init__(self, problems: list[str]) -> None:
        super().__init__("\n".join(problems))
        self.problems = problems


class RequestRefused(ValueError):
    """A request that cannot be graded as asked, for one reason: the message says it in one line."""


def read_request(
    exercise: Exercise,
    exercise_file: Path,
    submissions: list[tuple[str, Path]],
    given: list[str],
    *,
    limits: Limits | None = None,
    dask: str | None = None,
    traces: str | None = None,
    feedback: str | None = None,
    outputs: list[tuple[str, str]] | None = None,
    roster: str | None = None,
    adjust: str | None = None,
    compare: str | None = None,
    expect: str | None = None,
) -> GradeRequest:
    """The request, its teacher's files read and its outputs checked, before hours of grading and not after.

    Args:
        exercise: The exercise (with its hidden seeds, when the secret was given).
        exercise_file: The exercise's file.
        submissions: The submissions found in ``given``.
        given: The submissions' paths as the teacher gave them.
        limits: What each submission's grading may cost.
        dask: A Dask scheduler's address to grade on.
        traces: A folder for each run's trace.
        feedback: A folder for each student's feedback page.
        outputs: (kind, file) for each file to write.
        roster: The roster's file.
        adjust: The corrections' file.
        compare: An earlier grading's CSV or JSON.
        expect: The marks expected, each student's band (``student,lo,hi``).

    Raises:
        RequestRefused: the request asks for what cannot be (Gradescope's results of a class), or
            an output cannot be written where it is asked.
        RequestInvalid: the teacher's files have problems (every one of them at once).
    """
    if outputs and any(kind == "gradescope" for kind, _ in outputs) and len(submissions) != 1:
        raise RequestRefused("--gradescope writes one submission's results: give one submission")
    if dask and (traces or feedback):
        raise RequestRefused("--traces and --feedback need the runs here: grade without --dask for them")
    problems: list[str] = []

    def read(reader: Callable[..., Any], path: str | None, *more: Any) -> Any:
        """A teacher's file read, or None (none given, or its problems kept to be said with the others)."""
        try:
            return reader(path, *more) if path else None
        except GradebookError as err:
            problems.extend(err.problems)
            return None

    entries: list[RosterEntry] | None = read(read_roster, roster)
    adjustments: list[Adjustment] = read(read_adjustments, adjust) or []
    earlier: Earlier | None = read(read_earlier, compare, exercise)
    expected: dict[str, tuple[float, float, int]] | None = read(read_expected, expect)
    problems += unknown_students(adjustments, {student for student, _ in submissions}, adjust or "")
    if problems:
        raise RequestInvalid(problems)
    request = GradeRequest(
        exercise,
        submissions,
        limits or Limits(),
        dask,
        Path(traces) if traces else None,
        Path(feedback) if feedback else None,
        [(kind, Path(target)) for kind, target in outputs or []],
        (entries, Path(roster).parent) if entries is not None and roster else None,
        (adjustments, adjust or ""),
        (earlier, compare or "") if earlier is not None and compare else None,
        (expected, expect or "") if expected is not None and expect else None,
    )
    inputs = {Path(p).resolve() for p in (exercise_file, *given, roster, adjust, compare, expect) if p}
    _check_outputs(request, inputs)
    return request


def _check_outputs(request: GradeRequest, inputs: set[Path]) -> None:
    """Each output goes to a file of its own, that can be written, and that is none of the files read."""
    inputs |= {p.resolve() for _, p in request.submissions}
    world = request.exercise.world_ref
    inputs |= {Path(world).resolve()} if world not in SHIPPED else set()  # a world's file
    inputs |= {Path(request.exercise.robot_ref).resolve()} if request.exercise.robot_ref else set()  # its robot
    for _, given in request.submissions:  # a folder's files: a mission, a plugin
        try:
            inputs |= {p.resolve() for p in given.iterdir()} if given.is_dir() else set()
        except OSError:  # a folder that cannot be listed: its student's report says so
            pass
    pages: set[Path] = set()
    if request.feedback is not None:  # each student's page is an output too
        names = file_names(student for student, _ in request.submissions)
        pages = {page_path(request.feedback, name).resolve() for name in names.values()}
    chosen: set[Path] = set()
    for _, target in request.outputs:
        where = target.resolve()
        if where in inputs:
            raise RequestRefused(f"{target} is one of the files to grade: write the marks elsewhere")
        if where in chosen:
            raise RequestRefused(f"{target} is given for two outputs: give each its own file")
        if where in pages:
            raise RequestRefused(f"{target} is where a student's feedback page goes: write it elsewhere")
        chosen.add(where)
        if target.is_dir() or not target.parent.is_dir() or not os.access(target.parent, os.W_OK):
            raise RequestRefused(f"cannot write {target}: no such folder, or not writable")


def grade(request: GradeRequest, on_report: Callable[[Report], None] | None = None) -> list[Report]:
    """Grades the request's submissions on its executor: the local pool, or Dask at its address.

    Raises:
        ImportError: Dask is asked for and ``dask.distributed`` is not installed.
        OSError: no Dask scheduler answers at the address.
    """
    limits = {
        "cpu_s": request.cpu_s,
        "wall_s": request.limits.wall_s or WALL_PER_CPU * request.cpu_s,
        "memory_mb": request.limits.memory_mb,
        "allow_plugins": request.limits.allow_plugins,
        "on_report": on_report,
    }
    if request.dask:
        from autonomy.classroom.cluster import grade_on_dask

        return grade_on_dask(request.exercise, request.submissions, request.dask, **limits)
    from autonomy.classroom.pool import grade_class

    for folder in (request.traces, request.feedback):
        if folder is not None:
            folder.mkdir(parents=True, exist_ok=True)
    return grade_class(
        request.exercise,
        request.submissions,
        traces=request.traces,
        feedback=request.feedback,
        corrections=request.corrections,
        workers=request.limits.workers,
        **limits,
    )


@dataclass
class Graded:
    """A request's results, settled: the corrections in the reports, the roster matched, the pages found.

    Attributes:
        request: The request.
        reports: The reports, the teacher's corrections applied.
        matched: The roster matched with the reports (None: no roster).
        pages: Each student's feedback page that was written, by student.
    """

    request: GradeRequest
    reports: list[Report]
    matched: RosterMatch | None
    pages: dict[str, Path]


def settle(request: GradeRequest, reports: list[Report]) -> Graded:
    """The results as the outputs read them: corrections applied, the roster matched, the pages found."""
    adjustments, source = request.adjustments
    apply_adjustments(reports, adjustments, source)
    matched = match_roster(request.roster[0], reports, request.roster[1]) if request.roster is not None else None
    pages: dict[str, Path] = {}
    if request.feedback is not None:  # written by the workers, as they graded
        names = file_names([r.student for r in reports])
        pages = {r.student: page_path(request.feedback, names[r.student]) for r in reports}
        pages = {student: page for student, page in pages.items() if page.is_file()}
    return Graded(request, reports, matched, pages)


def _html(graded: Graded, target: Path) -> str:
    where = target.resolve().parent  # each student linked to their page, from where the class page is
    pages = {name: os.path.relpath(page, where) for name, page in graded.pages.items()}
    return to_html(graded.request.exercise, graded.reports, pages)


#: Each kind of file a request may write: its text, from the settled results (and where it goes).
OUTPUTS: dict[str, Callable[[Graded, Path], str]] = {
    "csv": lambda graded, _: to_csv(graded.request.exercise, graded.reports, graded.matched),
    "json": lambda graded, _: to_json(graded.request.exercise, graded.reports, graded.matched),
    "html": _html,
    "gradescope": lambda graded, _: to_gradescope(graded.request.exercise, graded.reports[0]),
}

"""What a teacher does with a class's marks: a roster of student ids, corrections by hand, and what changed.

- A roster (``id,name``, and perhaps ``submission``, which is the id without it) puts each
  student's id first in the gradebook, lists a student who handed in nothing as such, and
  reports a submission on no roster line.
- An adjustment (``student,points,reason``) is a teacher's correction: added to the mark, and
  shown with its reason wherever the mark is.
- A comparison says what changed since an earlier grading's JSON: new, missing and changed
  students, and for each changed mark the criteria that moved.
- Similar submissions: pairs whose trees are the same but for numbers and names, or differ by
  a node or two, listed as a hint for the teacher to look at (never a verdict).

Files are read like every other input: a problem is ``FILE:LINE: message``, all of them at once.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from autonomy.classroom.exercise import Exercise
from autonomy.classroom.results import Report
from autonomy.errors import AutonomyError
from autonomy.source import UnreadableFile, control_character, read_text
from autonomy.words import plural

ROSTER_COLUMNS = ("id", "name")  # and, if it has one, "submission" (default: the id)
ADJUST_COLUMNS = ("student", "points", "reason")
EXPECT_COLUMNS = ("student", "lo", "hi")
#: How many rows a roster or an adjustment file may have.
MOST_ROWS = 100_000


class GradebookError(AutonomyError):
    """A roster, adjustment or earlier grading that cannot be used; :attr:`problems` has every one."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = problems
        super().__init__("\n".join(problems))


@dataclass(frozen=True)
class RosterEntry:
    """One student of a roster: their id (as the school's gradebook knows them), name, and submission."""

    id: str
    name: str
    submission: str
    line: int


@dataclass(frozen=True)
class Adjustment:
    """A teacher's correction of one student's mark, with why."""

    student: str
    points: float
    reason: str
    line: int


def _rows(path: str | Path, columns: tuple[str, ...], what: str, perhaps: str = "") -> list[tuple[int, dict[str, str]]]:
    """The rows of a CSV file with a header naming ``columns`` (others are let be), numbered as in the file.

    ``perhaps`` names a column it may have besides, for the message that says which it must.
    """
    label = str(path)
    try:
        text = read_text(Path(path))
    except UnreadableFile as err:
        raise GradebookError([f"{label}:{err.line}: cannot read the {what}: {err.reason}"]) from None
    lines = text.removeprefix("\ufeff").splitlines(keepends=True)  # a byte-order mark first, as in "CSV UTF-8"
    reader = csv.reader(lines)
    try:
        header = [cell.strip() for cell in next(reader)]
    except StopIteration:
        raise GradebookError(
            [f"{label}:1: the {what} is empty: its first line names the columns {','.join(columns)}"]
        ) from None
    except csv.Error as err:
        raise GradebookError([f"{label}:1: not a CSV file: {err}"]) from None
    missing = [column for column in columns if column not in header]
    if missing:
        raise GradebookError(
            [
                f"{label}:1: the {what}'s first line must name the columns {','.join(columns)}"
                + (f" (and perhaps {perhaps})" if perhaps else "")
                + "; "
                f"missing: {', '.join(missing)} (got {','.join(header) or 'nothing'})"
            ]
        )
    rows = []
    try:
        while True:
            number = reader.line_num + 1  # the row's first line
            try:
                cells = next(reader)
            except StopIteration:
                break
            if any("\n" in cell.rstrip("\r\n") for cell in cells):  # a quote left open took the lines after it
                raise GradebookError([f'{label}:{number}: a quote (") is opened and not closed on this line'])
            if not any(cell.strip() for cell in cells):
                continue
            if len(rows) >= MOST_ROWS:
                raise GradebookError([f"{label}:{number}: more than {MOST_ROWS:,} rows"])
            rows.append((number, {name: (cells[i].strip() if i < len(cells) else "") for i, name in enumerate(header)}))
    except csv.Error as err:
        raise GradebookError([f"{label}:{reader.line_num}: not a CSV file: {err}"]) from None
    return rows


def read_roster(path: str | Path) -> list[RosterEntry]:
    """Reads a roster: ``id,name`` and perhaps ``submission`` (a student as graded, or a path to their file).

    Without a submission column, a student's submission is their id (``alice``: ``alice.yaml``, or
    the folder ``alice/``); a live class reads the id and the name alone.

    Raises:
        GradebookError: every problem, ``FILE:LINE: message``.
    """
    problems, entries, seen, handed = [], [], {}, {}
    for number, row in _rows(path, ROSTER_COLUMNS, "roster", perhaps="submission"):
        ident, name = row["id"], row["name"]
        given = "submission" in row  # else each student's submission is their id (told apart as ids are)
        submission = row["submission"] if given else ident
        if not ident or control_character(ident):
            problems.append(f"{path}:{number}: a student needs an id (printable text)")
        elif ident in seen:
            problems.append(f"{path}:{number}: id '{ident}' is on line {seen[ident]} already")
        else:
            seen[ident] = number
        if given and submission and submission in handed:
            problems.append(f"{path}:{number}: submission '{submission}' is on line {handed[submission]} already")
        elif given and submission:
            handed[submission] = number
        entries.append(RosterEntry(ident, name, submission, number))
    if problems:
        raise GradebookError(problems)
    return entries


def read_adjustments(path: str | Path) -> list[Adjustment]:
    """Reads corrections: ``student,points,reason`` (points may be negative; a reason is needed).

    Raises:
        GradebookError: every problem, ``FILE:LINE: message``.
    """
    problems, out = [], []
    for number, row in _rows(path, ADJUST_COLUMNS, "adjustment file"):
        student, raw, reason = row["student"], row["points"], row["reason"]
        try:
            points = float(raw)
        except ValueError:
            points = math.nan
        if not student:
            problems.append(f"{path}:{number}: which student? the 'student' column is empty")
        if not math.isfinite(points) or abs(points) > 1000:
            problems.append(f"{path}:{number}: points must be a number from -1000 to 1000, got {raw!r}")
        if not reason:
            problems.append(f"{path}:{number}: a correction needs its reason, which the student will read")
        out.append(Adjustment(student, points, reason, number))
    if problems:
        raise GradebookError(problems)
    return out


def read_expected(path: str | Path) -> dict[str, tuple[float, float, int]]:
    """Reads the marks a teacher expects, each student's fair band: ``student,lo,hi`` (``--expect``).

    Returns:
        Each student's (lo, hi, line).

    Raises:
        GradebookError: every problem, ``FILE:LINE: message``.
    """
    problems: list[str] = []
    out: dict[str, tuple[float, float, int]] = {}
    for number, row in _rows(path, EXPECT_COLUMNS, "expected marks"):
        student, bounds = row["student"], []
        for column in ("lo", "hi"):
            try:
                bounds.append(float(row[column]))
            except ValueError:
                bounds.append(math.nan)
        lo, hi = bounds
        if not student:
            problems.append(f"{path}:{number}: which student? the 'student' column is empty")
        elif student in out:
            problems.append(f"{path}:{number}: '{student}' is on line {out[student][2]} already")
        if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo <= hi <= 10_000):
            problems.append(
                f"{path}:{number}: lo and hi must be numbers, 0 <= lo <= hi, got {row['lo']!r}, {row['hi']!r}"
            )
        out.setdefault(student, (lo, hi, number))
    if problems:
        raise GradebookError(problems)
    return out


def outside_bands(
    exercise: Exercise, reports: list[Report], expected: dict[str, tuple[float, float, int]]
) -> list[str]:
    """Each student whose mark lies outside the band the teacher expects, with the criteria that put it there.

    Below the band: the criteria that lost points; above it: those that earned them. A student
    expected and not graded is listed too. The last line counts those within their bands.
    """
    lines = []
    graded = {report.student: report for report in reports}
    within = 0
    for student, (lo, hi, _) in sorted(expected.items()):
        report = graded.get(student)
        if report is None:
            lines.append(f"{student}: expected {lo:g} to {hi:g}, but has no submission")
            continue
        if lo - 0.005 <= report.total <= hi + 0.005:
            within += 1
            continue
        below = report.total < lo
        why = [
            f"{criterion.label} ({mark:g} of {criterion.points:g})"
            for criterion, mark in zip(exercise.criteria, report.marks, strict=False)
            if (mark < criterion.points if below else mark > 0)
        ]
        told = f"{'lost' if below else 'earned'} {', '.join(why)}" if why else "; ".join(report.problems[:1])
        lines.append(f"{student}: {report.total:g}, expected {lo:g} to {hi:g}: {told}")
    lines.append(f"{within} of {len(expected)} students within the band expected")
    return lines


def unknown_students(adjustments: list[Adjustment], students: set[str], source: str) -> list[str]:
    """A problem (``FILE:LINE: ...``) for each correction that names no student among ``students``."""
    return [
        f"{source}:{a.line}: no student '{a.student}' among the submissions given"
        for a in adjustments
        if a.student not in students
    ]


def apply_adjustments(reports: list[Report], adjustments: list[Adjustment], source: str = "") -> list[Report]:
    """Each report with the corrections for its student added to its total (and listed in it).

    Raises:
        GradebookError: a correction names no student of the class.
    """
    by_student = {report.student: report for report in reports}
    unknown = unknown_students(adjustments, set(by_student), source)
    if unknown:
        raise GradebookError(unknown)
    for adjustment in adjustments:
        report = by_student[adjustment.student]
        report.adjustments.append((adjustment.points, adjustment.reason))
        report.total = round(report.total + adjustment.points, 2)
    return reports


@dataclass(frozen=True)
class RosterMatch:
    """The roster and the class matched.

    Attributes:
        listed: Each roster line with its student's report (None: nothing handed in).
        unlisted: The reports of submissions on no roster line.
    """

    listed: list[tuple[RosterEntry, Report | None]]
    unlisted: list[Report]


def match_roster(roster: list[RosterEntry], reports: list[Report], roster_folder: Path) -> RosterMatch:
    """Pairs each roster line with its student's report: by the student's name as graded, or by the file's path.

    A path is taken as the roster's folder has it, or as given.
    """
    by_student = {report.student: report for report in reports}
    by_path: dict[str, Report] = {}
    for report in reports:
        if report.file:
            by_path[str(Path(report.file).resolve())] = report
    listed, used = [], set()
    for entry in roster:
        found = by_student.get(entry.submission)
        if found is None and entry.submission:
            for candidate in (roster_folder / entry.submission, Path(entry.submission)):
                found = by_path.get(str(candidate.resolve()))
                if found is None and candidate.is_dir():  # a student's folder: their mission inside it
                    inside = [r for p, r in by_path.items() if Path(p).parent == candidate.resolve()]
                    found = inside[0] if len(inside) == 1 else None
                if found is not None:
                    break
        if found is not None and id(found) in used:
            found = None  # two roster lines for one submission: the first has it
        if found is not None:
            used.add(id(found))
        listed.append((entry, found))
    return RosterMatch(listed, [report for report in reports if id(report) not in used])


@dataclass(frozen=True)
class Earlier:
    """An earlier grading, as its ``--json`` has it: each student's entry, and the criteria's labels."""

    students: dict[str, dict[str, Any]]
    labels: list[str]


def read_earlier(path: str | Path, exercise: Exercise) -> Earlier:
    """Reads an earlier grading's ``--json``, which must be of ``exercise``.

    Raises:
        GradebookError: the file cannot be read, is not a grading's JSON, or grades another exercise.
    """
    label = str(path)
    try:
        document = json.loads(read_text(Path(path)))
        students = {s["student"]: s for s in document["students"]}
        labels = [c["label"] for c in document["criteria"]]
        graded = document["exercise"]
    except UnreadableFile as err:
        raise GradebookError([f"{label}:{err.line}: cannot read the earlier grading: {err.reason}"]) from None
    except (ValueError, KeyError, TypeError, AttributeError):
        raise GradebookError([f"{label}:1: not the JSON of an earlier grading (autonomy grade --json)"]) from None
    if graded != exercise.name:
        raise GradebookError([f"{label}:1: it grades exercise '{graded}', not '{exercise.name}'"])
    return Earlier(students, labels)


def compare(exercise: Exercise, reports: list[Report], earlier: Earlier) -> list[str]:
    """What changed since an earlier grading: one line each, then how many stayed the same."""
    students, labels = earlier.students, earlier.labels
    lines, same = [], 0
    now = {report.student: report for report in reports}
    for report in reports:
        before = students.get(report.student)
        if before is None:
            lines.append(f"new: {report.student}, {report.total:g}")
            continue
        old_total = before.get("total")
        moved = []
        old_marks = dict(zip(labels, before.get("marks", []), strict=False))
        for criterion, mark in zip(exercise.criteria, report.marks, strict=True):
            was = old_marks.get(criterion.label)
            if was is None:
                moved.append(f"{criterion.label} new, {mark:g}")
            elif was != mark:
                moved.append(f"{criterion.label} {was:g} -> {mark:g}")
        moved += [f"{name} gone" for name in old_marks if name not in {c.label for c in exercise.criteria}]
        if old_total != report.total or moved:
            why = f" ({'; '.join(moved)})" if moved else " (a correction by hand)"
            lines.append(f"changed: {report.student}, {old_total:g} -> {report.total:g}{why}")
        else:
            same += 1
    lines += [f"missing: {name}, was {s.get('total', 0):g}" for name, s in students.items() if name not in now]
    lines.append(f"the same: {same} of {len(reports)}")
    return lines


#: Trees whose shapes (:func:`autonomy.classroom.job.tree_shape`) differ by at most this many nodes are similar.
SIMILAR_NODES = 2
#: Trees of fewer nodes than this are too small to say anything by being alike (a lone move).
SIMILAR_MOST_NODES_LEAST = 5


def _nodes_apart(a: tuple[str, ...], b: tuple[str, ...], most: int) -> int:
    """How many tokens must change, go or come to make ``a`` into ``b`` (more than ``most``: ``most + 1``)."""
    if abs(len(a) - len(b)) > most:
        return most + 1
    previous = list(range(len(b) + 1))
    for i, token in enumerate(a, start=1):
        current = [i] + [0] * len(b)
        low, high = max(1, i - most), min(len(b), i + most)
        for j in range(1, len(b) + 1):
            if j < low or j > high:
                current[j] = most + 1
                continue
            current[j] = min(previous[j] + 1, current[j - 1] + 1, previous[j - 1] + (token != b[j - 1]))
        if min(current) > most:
            return most + 1
        previous = current
    return min(previous[-1], most + 1)


def similar(reports: list[Report]) -> list[tuple[str, str, str]]:
    """Pairs of students whose trees look alike: (one, other, how), sorted. A hint to look at, not a verdict."""
    shaped = [
        (r.student, tuple(r.shape))
        for r in reports
        if len([t for t in r.shape if t not in "()"]) >= SIMILAR_MOST_NODES_LEAST
    ]
    out = []
    for index, (one, mine) in enumerate(shaped):
        for other, theirs in shaped[index + 1 :]:
            first, second = sorted((one, other))
            if mine == theirs:
                out.append((first, second, "the same tree but for numbers and names"))
                continue
            apart = _nodes_apart(mine, theirs, SIMILAR_NODES)
            if apart <= SIMILAR_NODES:
                out.append((first, second, f"trees {plural(apart, 'node')} apart, numbers and names aside"))
    return sorted(out)

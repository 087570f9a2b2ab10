"""``autonomy grade`` and ``autonomy gradescope``: marking missions against an exercise."""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from autonomy.cli.common import (
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_USAGE,
    _bounded,
    _fail,
    _interrupt,
    _problems,
    _shown,
)


def exercise_folders() -> list[Path]:
    """Where an exercise's name is looked for: the teacher's own (./exercises/), then those shipped with autonomy."""
    from importlib import resources

    return [Path("exercises"), Path(str(resources.files("autonomy").joinpath("exercises")))]


def _exercise_path(text: str) -> tuple[str, str]:
    """An exercise given by path, or by name: from ./exercises/ (a teacher's own), else those shipped with autonomy.

    Returns:
        Its path, or empty and why there is none of that name.
    """
    from autonomy.source import suggest

    if Path(text).is_file() or "/" in text or text.endswith((".yaml", ".yml")):
        return text, ""
    for folder in exercise_folders():
        if (folder / f"{text}.yaml").is_file():
            return str(folder / f"{text}.yaml"), ""
    names = sorted({found.stem for folder in exercise_folders() for found in folder.glob("*.yaml")})
    shown = text if len(text) <= 40 else text[:40] + "..."  # made printable where it is printed (_fail)
    return "", (
        f"no exercise named '{shown}'{suggest(text, names)}: use one of {', '.join(names)} "
        "(./exercises/ and those shipped with autonomy), or give the exercise file's path"
    )


def _exercise(text: str) -> tuple[Any, str] | int:
    """The exercise a command names (a file, or a name) and its path; or, if none, the exit code."""
    from autonomy.classroom import ExerciseInvalid, load_exercise

    path, missing = _exercise_path(text)
    if missing:
        return _fail(missing, EXIT_USAGE)
    try:
        return load_exercise(path), path
    except ExerciseInvalid as err:
        return _problems(err.problems)


def cmd_grade(args: argparse.Namespace) -> int:
    """Grades mission files against an exercise: marks, feedback, a gradebook."""
    from autonomy.classroom.cluster import ClusterUnfit
    from autonomy.classroom.request import OUTPUTS, grade, settle

    asked = _grade_request(args)
    if isinstance(asked, int):
        return asked
    request, note = asked
    if not args.quiet:
        _announce(request, note)
    for ending in (signal.SIGTERM, signal.SIGHUP):  # a closed terminal ends the workers as Ctrl-C does
        signal.signal(ending, _interrupt)
    with _progress(len(request.submissions), shown=not args.quiet) as advance:
        try:
            reports = grade(request, advance)
        except KeyboardInterrupt:
            return _fail("grading interrupted", EXIT_INTERRUPTED)
        except ImportError:
            return _fail("--dask needs dask.distributed: pip install 'autonomy[cluster]'", EXIT_USAGE)
        except OSError as err:  # no scheduler there
            return _fail(f"--dask {args.dask}: no Dask scheduler answers there ({err})", EXIT_USAGE)
        except ClusterUnfit as err:  # no worker, a worker with no or another autonomy, every worker gone
            return _fail(str(err), EXIT_USAGE)
    graded = settle(request, reports)
    if not args.quiet:
        _print_graded(graded)
    # a student checking their own mission learns from the exit code too that nothing of it ran
    code = EXIT_USAGE if len(reports) == 1 and reports[0].problems else EXIT_OK
    if request.expected is not None:  # said even with --quiet: it is what was asked
        from autonomy.classroom.gradebook import outside_bands

        told = outside_bands(request.exercise, graded.reports, request.expected[0])
        for line in told:
            print(_shown(line))
        code = EXIT_FAILED if len(told) > 1 else code
    for kind, target in request.outputs:  # one that fails does not keep the others from being written
        try:
            # a problem quoting a path that is not UTF-8 (a folder from another system) has '?' for its bytes
            target.write_text(OUTPUTS[kind](graded, target), encoding="utf-8", errors="replace")
        except OSError as err:
            code = _fail(f"cannot write {target}: {err.strerror or err}", EXIT_USAGE)
            continue
        if not args.quiet:
            print(_shown(f"wrote {target}"))
    return code


def _grade_request(args: argparse.Namespace) -> tuple[Any, str] | int:
    """What ``autonomy grade`` is asked, every file of the teacher's read and checked, and a note to print.

    The note is on the exercise's hidden seeds. If it cannot be graded as asked: the exit code (why said).
    """
    from pathlib import Path

    from autonomy.classroom import find_submissions
    from autonomy.classroom.request import Limits, RequestInvalid, RequestRefused, read_request
    from autonomy.classroom.secret import SecretError, read_secret

    found = _exercise(args.exercise)
    if isinstance(found, int):
        return found
    exercise, path = found
    note = ""
    if args.secret_file:
        try:
            secret = read_secret(args.secret_file)
        except SecretError as err:
            return _fail(str(err), EXIT_USAGE)
        if not exercise.hidden_seeds:
            note = "This exercise has no hidden seeds: the secret changes nothing."
        exercise = exercise.with_secret(secret)
    elif exercise.hidden_seeds:
        note = (
            f"This exercise also has {exercise.hidden_seeds} hidden seeds, which the teacher's marks use "
            f"(autonomy grade --secret-file): these marks are from its {len(exercise.seeds)} public seeds only."
        )
    kinds = (("csv", args.csv), ("json", args.json), ("html", args.html), ("gradescope", args.gradescope))
    limits = Limits(args.cpu_seconds, args.wall_seconds, args.memory_mb, args.allow_plugins, args.workers)
    try:
        request = read_request(
            exercise, Path(path), find_submissions(args.submissions), args.submissions, limits=limits,
            dask=args.dask, traces=args.traces, feedback=args.feedback, roster=args.roster, adjust=args.adjust,
            compare=args.compare, expect=args.expect, outputs=[(kind, target) for kind, target in kinds if target],
        )  # fmt: skip
    except RequestRefused as err:
        return _fail(str(err), EXIT_USAGE)
    except RequestInvalid as err:
        return _problems(err.problems)
    return request, note


def _announce(request: Any, note: str) -> None:
    """Says what is about to be graded: how many submissions, the exercise, its world and seeds."""
    exercise = request.exercise
    public = [s for s in exercise.seeds if not s.hidden]
    seeds = ", ".join(str(s.seed) for s in public)
    hidden = len(exercise.seeds) - len(public)
    many = len(request.submissions) != 1
    print(
        f"Grading {len(request.submissions)} submission{'s' if many else ''} for '{exercise.title}' "
        f"in world '{exercise.world.name}', seeds {seeds}"
        + (f" and {hidden} hidden" if hidden else "")
        + f", {exercise.time_limit_s:g} s a run.",
        flush=True,
    )
    if note:
        print(note, flush=True)


@contextlib.contextmanager
def _progress(total: int, shown: bool) -> Iterator[Any]:
    """A progress bar on a terminal's standard error while a class (more than one) is graded: what advances it."""
    if total < 2 or not shown or not sys.stderr.isatty():
        yield None
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    bar = TextColumn("grading"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn()
    progress = Progress(*bar, console=Console(file=sys.stderr), transient=True)
    task = progress.add_task("grading", total=total)
    progress.start()
    try:
        yield lambda _: progress.advance(task)
    finally:
        progress.stop()


def _print_graded(graded: Any) -> None:
    """The results in the terminal: one student's feedback, or the class's marks.

    Then the corrections, the roster's gaps, what changed since an earlier grading, and where the pages are.
    """
    from autonomy.classroom.gradebook import compare
    from autonomy.classroom.report import feedback

    request, reports = graded.request, graded.reports
    if len(reports) == 1:
        for line in feedback(request.exercise, reports[0]):
            print(line)
    else:
        _print_marks(request.exercise, reports)
        for report in reports:
            for points, reason in report.adjustments:
                print(_shown(f"correction: {report.student} {points:+g} ({reason})"))
    if graded.matched is not None:
        for entry, report in graded.matched.listed:
            if report is None:
                print(_shown(f"no submission: {entry.id} {entry.name} (roster line {entry.line})"))
        for report in graded.matched.unlisted:
            print(_shown(f"not on the roster: {report.student} ({report.file or 'no file'})"))
    if request.earlier is not None:
        earlier, source = request.earlier
        print(_shown(f"Since {source}:"))
        for line in compare(request.exercise, reports, earlier):
            print(_shown(f"  {line}"))
    if request.feedback is not None:
        print(_shown(f"wrote {len(graded.pages)} feedback pages in {request.feedback}"))


def cmd_gradescope(args: argparse.Namespace) -> int:
    """Packs an exercise, with this package, as the autograder zip Gradescope takes."""
    from pathlib import Path

    from autonomy.classroom.gradescope import AutograderError, build_autograder
    from autonomy.classroom.secret import SecretError, read_secret

    found = _exercise(args.exercise)
    if isinstance(found, int):
        return found
    exercise, path = found
    try:
        secret = read_secret(args.secret_file) if args.secret_file else None
    except SecretError as err:
        return _fail(str(err), EXIT_USAGE)
    try:
        data = build_autograder(exercise, Path(path), secret)
    except AutograderError as err:
        return _fail(str(err), EXIT_USAGE)
    try:
        Path(args.output).write_bytes(data)
    except OSError as err:
        return _fail(f"cannot write {args.output}: {err.strerror or err}", EXIT_USAGE)
    hidden = f", {exercise.hidden_seeds} hidden seeds from the secret" if secret and exercise.hidden_seeds else ""
    print(_shown(f"wrote {args.output}: the autograder for '{exercise.title}' ({len(data):,} bytes{hidden})"))
    return EXIT_OK


def _print_marks(exercise: Any, reports: list[Any]) -> None:
    """The class's marks as a table in the terminal; why a student was not graded, below it.

    Criteria are named in the table's head when that fits the terminal, else numbered there
    and named under the table.
    """
    from rich.cells import cell_len
    from rich.console import Console
    from rich.table import Table

    console = Console(highlight=False)
    labels = [f"{_shown(c.label)} ({c.points:g})" for c in exercise.criteria]
    names = [_shown(report.student) for report in reports]
    cells = [len(f"{m:g}") for report in reports for m in report.marks]
    student = max([len("student"), *map(cell_len, names)])  # on screen: a Chinese character takes two cells
    total = max([len("total"), *(len(f"{report.total:g}") for report in reports)])

    def width(heads: list[str]) -> int:  # the table's width with these heads over the criteria
        return student + total + sum(max(cell_len(head), *cells, 1) for head in heads) + 3 * (len(heads) + 2) + 1

    numbers = [f"#{index}" for index in range(1, len(labels) + 1)]
    title = f"{_shown(exercise.title)}: marks out of {exercise.max_points:g}"
    heads = labels if width(labels) <= console.width else numbers
    console.print(title, soft_wrap=True)
    if width(numbers) > console.width:  # too narrow even for a table: a line a student
        for name, report in zip(names, reports, strict=True):
            marks = ", ".join(f"{number} {m:g}" for number, m in zip(numbers, report.marks, strict=True))
            console.print(f"{name}: {report.total:g} ({marks})", soft_wrap=True)
    else:
        table = Table()
        table.add_column("student", no_wrap=True)
        table.add_column("total", justify="right", no_wrap=True)
        for head in heads:
            table.add_column(head, justify="right", no_wrap=True)
        for name, report in zip(names, reports, strict=True):
            table.add_row(name, f"{report.total:g}", *[f"{m:g}" for m in report.marks])
        console.print(table)
    if heads is not labels:
        for number, label in zip(numbers, labels, strict=True):
            console.print(f"  {number} {label}", soft_wrap=True)
    troubled = [(name, report) for name, report in zip(names, reports, strict=True) if report.problems]
    if troubled:
        console.print("Not graded (the mark is 0):", soft_wrap=True)
        for name, report in troubled:
            more = f" (+{len(report.problems) - 1} more)" if len(report.problems) > 1 else ""
            console.print(f"  {name}: {_shown(report.problems[0])}{more}", soft_wrap=True)


def add_parsers(sub: Any) -> None:
    """Adds this module's commands to the command line's subparsers."""
    grade = sub.add_parser("grade", help="run mission files against an exercise and mark them")
    grade.add_argument("exercise", metavar="EXERCISE", help="an exercise file, or a name (./exercises/, or shipped)")
    grade.add_argument(
        "submissions", nargs="+", metavar="SUBMISSION", help="mission files, or folders of one student's files"
    )
    grade.add_argument(
        "--workers",
        type=_bounded(int, 1, 256, "a number of processes"),
        metavar="N",
        help="processes at once (default: the machine's cores)",
    )
    grade.add_argument("--allow-plugins", action="store_true", help="run the Python plugins submissions load")
    grade.add_argument(
        "--cpu-seconds",
        type=_bounded(float, 1, 86400, "a number of seconds"),
        metavar="S",
        help="CPU time a submission may take, all its seeds (default: 60, more for long exercises)",
    )
    grade.add_argument(
        "--wall-seconds",
        type=_bounded(float, 1, 864000, "a number of seconds"),
        metavar="S",
        help="wall time a submission may take, for one that waits rather than works (default: 10 times --cpu-seconds)",
    )
    grade.add_argument(
        "--memory-mb",
        type=_bounded(int, 256, 1 << 20, "a number of MiB"),
        default=1024,
        metavar="MB",
        help="memory a submission may take (default 1024)",
    )
    grade.add_argument(
        "--secret-file",
        metavar="FILE",
        help="the teacher's secret, which draws the exercise's hidden seeds: they are graded too",
    )
    grade.add_argument(
        "--roster",
        metavar="FILE.csv",
        help="the class list (columns id,name and perhaps submission, which is the id without it): ids first in "
        "the gradebook, missing students listed",
    )
    grade.add_argument(
        "--adjust",
        metavar="FILE.csv",
        help="the teacher's corrections (columns student,points,reason): added to the marks, shown with the reason",
    )
    grade.add_argument("--compare", metavar="OLD.json", help="say what changed since an earlier grading's --json")
    grade.add_argument(
        "--expect",
        metavar="EXPECTED.csv",
        help="the marks expected (student,lo,hi): list each student outside their band, and why; exit 1 if any",
    )
    grade.add_argument("--csv", metavar="FILE", help="write a gradebook: student, total, one column per criterion")
    grade.add_argument("--json", metavar="FILE", help="write every mark, verdict and path as JSON")
    grade.add_argument("--html", metavar="FILE", help="write one page: the class table, each student's runs on maps")
    grade.add_argument(
        "--gradescope", metavar="FILE", help="write one submission's results as Gradescope's autograder results.json"
    )
    grade.add_argument(
        "--feedback",
        metavar="DIR",
        help="write one page per student into DIR, to hand to them: their file, marks, and each run to replay",
    )
    grade.add_argument("--traces", metavar="DIR", help="keep each run's trace in DIR/STUDENT/, for autonomy replay")
    grade.add_argument(
        "--dask",
        metavar="ADDRESS",
        help="grade on the Dask cluster with its scheduler at ADDRESS (tcp://host:8786; needs autonomy[cluster])",
    )
    grade.add_argument("--quiet", action="store_true", help="print nothing but errors (write the files)")
    grade.set_defaults(func=cmd_grade)
    scope = sub.add_parser("gradescope", help="pack an exercise as the autograder zip Gradescope takes")
    scope.add_argument("exercise", metavar="EXERCISE", help="an exercise file, or a name (./exercises/, or shipped)")
    scope.add_argument("-o", "--output", metavar="FILE.zip", default="autograder.zip", help="default autograder.zip")
    scope.add_argument("--secret-file", metavar="FILE", help="the teacher's secret, for the exercise's hidden seeds")
    scope.set_defaults(func=cmd_gradescope)

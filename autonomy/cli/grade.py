"""``autonomy grade`` and ``autonomy gradescope``: marking missions against an exercise."""

from __future__ import annotations

import argparse
import os
import signal
import sys
from typing import Any

from autonomy.cli.common import EXIT_INTERRUPTED, EXIT_OK, EXIT_USAGE, _bounded, _fail, _interrupt, _problems, _shown


def _exercise_path(text: str) -> tuple[str, str]:
    """An exercise given by path, or by name: from ./exercises/ (a teacher's own), else those shipped with autonomy.

    Returns:
        Its path, or empty and why there is none of that name.
    """
    from importlib import resources
    from pathlib import Path

    from autonomy.source import suggest

    if Path(text).is_file() or "/" in text or text.endswith((".yaml", ".yml")):
        return text, ""
    shipped = Path(str(resources.files("autonomy").joinpath("exercises")))
    for folder in (Path("exercises"), shipped):
        if (folder / f"{text}.yaml").is_file():
            return str(folder / f"{text}.yaml"), ""
    names = sorted({found.stem for folder in (Path("exercises"), shipped) for found in folder.glob("*.yaml")})
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
    from pathlib import Path

    from autonomy.classroom import find_submissions, grade_class
    from autonomy.classroom.exercise import SecretError, read_secret
    from autonomy.classroom.grade import WALL_PER_CPU, default_cpu_s
    from autonomy.classroom.gradebook import (
        GradebookError,
        apply_adjustments,
        compare,
        match_roster,
        read_adjustments,
        read_earlier,
        read_roster,
        unknown_students,
    )
    from autonomy.classroom.report import feedback, to_csv, to_gradescope, to_html, to_json
    from autonomy.emulator.world import SHIPPED

    found = _exercise(args.exercise)
    if isinstance(found, int):
        return found
    exercise, path = found
    hidden_note = ""
    if args.secret_file:
        try:
            secret = read_secret(args.secret_file)
        except SecretError as err:
            return _fail(str(err), EXIT_USAGE)
        if not exercise.hidden_seeds:
            hidden_note = "This exercise has no hidden seeds: the secret changes nothing."
        exercise = exercise.with_secret(secret)
    elif exercise.hidden_seeds:
        hidden_note = (
            f"This exercise also has {exercise.hidden_seeds} hidden seeds, which the teacher's marks use "
            f"(autonomy grade --secret-file): these marks are from its {len(exercise.seeds)} public seeds only."
        )
    submissions = find_submissions(args.submissions)
    alone = len(submissions) == 1
    if args.gradescope and not alone:
        return _fail("--gradescope writes one submission's results: give one submission", EXIT_USAGE)
    if args.dask and (args.traces or args.feedback):
        return _fail("--traces and --feedback need the runs here: grade without --dask for them", EXIT_USAGE)
    # the teacher's own files, before any grading: every problem of every one of them at once, FILE:LINE
    problems: list[str] = []
    roster, adjustments = None, []
    try:
        roster = read_roster(args.roster) if args.roster else None
    except GradebookError as err:
        problems += err.problems
    try:
        adjustments = read_adjustments(args.adjust) if args.adjust else []
    except GradebookError as err:
        problems += err.problems
    known = {student for student, _ in submissions}
    problems += unknown_students(adjustments, known, args.adjust or "")
    earlier = None
    try:
        earlier = read_earlier(args.compare, exercise) if args.compare else None
    except GradebookError as err:
        problems += err.problems
    if problems:
        return _problems(problems)
    corrections: dict[str, list[tuple[float, str]]] = {}
    for adjustment in adjustments:
        corrections.setdefault(adjustment.student, []).append((adjustment.points, adjustment.reason))
    kinds = (("csv", args.csv), ("json", args.json), ("html", args.html), ("gradescope", args.gradescope))
    targets = [(target, kind) for kind, target in kinds if target]
    # every file read (the exercise, its world, each submission's mission, a folder's files) is kept from harm
    inputs = {Path(p).resolve() for p in (path, *args.submissions)} | {p.resolve() for _, p in submissions}
    inputs |= {Path(p).resolve() for p in (args.roster, args.adjust, args.compare) if p}
    inputs |= {Path(exercise.world_ref).resolve()} if exercise.world_ref not in SHIPPED else set()  # a file
    for _, given in submissions:
        try:
            inputs |= {p.resolve() for p in given.iterdir()} if given.is_dir() else set()
        except OSError:  # a folder that cannot be listed: its student's report says so
            pass
    chosen: set[Path] = set()
    student_pages: set[Path] = set()
    if args.feedback:  # each student's page is an output too
        from autonomy.classroom.results import file_names, page_path

        student_pages = {page_path(Path(args.feedback), name).resolve() for name in file_names(known).values()}
    for target, _ in targets:  # before hours of grading, not after
        where = Path(target)
        if where.resolve() in inputs:
            return _fail(f"{target} is one of the files to grade: write the marks elsewhere", EXIT_USAGE)
        if where.resolve() in chosen:
            return _fail(f"{target} is given for two outputs: give each its own file", EXIT_USAGE)
        if where.resolve() in student_pages:
            return _fail(f"{target} is where a student's feedback page goes: write it elsewhere", EXIT_USAGE)
        chosen.add(where.resolve())
        if where.is_dir() or not where.parent.is_dir() or not os.access(where.parent, os.W_OK):
            return _fail(f"cannot write {target}: no such folder, or not writable", EXIT_USAGE)
    if not args.quiet:
        public = [s for s in exercise.seeds if not s.hidden]
        seeds = ", ".join(str(s.seed) for s in public)
        hidden = len(exercise.seeds) - len(public)
        print(
            f"Grading {len(submissions)} submission{'s' if not alone else ''} for '{exercise.title}' "
            f"in world '{exercise.world.name}', seeds {seeds}"
            + (f" and {hidden} hidden" if hidden else "")
            + f", {exercise.time_limit_s:g} s a run.",
            flush=True,
        )
        if hidden_note:
            print(hidden_note, flush=True)
    for ending in (signal.SIGTERM, signal.SIGHUP):  # a closed terminal ends the workers as Ctrl-C does
        signal.signal(ending, _interrupt)
    progress = None
    if not alone and not args.quiet and sys.stderr.isatty():
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        progress = Progress(
            TextColumn("grading"),
            BarColumn(),
            MofNCompleteColumn(),
            TimeElapsedColumn(),
            console=Console(file=sys.stderr),
            transient=True,
        )
        task = progress.add_task("grading", total=len(submissions))
        progress.start()
    try:
        traces = Path(args.traces) if args.traces else None
        feedback_folder = Path(args.feedback) if args.feedback else None
        for folder in (traces, feedback_folder):
            if folder is not None:
                folder.mkdir(parents=True, exist_ok=True)
        limits = {
            "cpu_s": (cpu_s := args.cpu_seconds or default_cpu_s(exercise)),
            "wall_s": args.wall_seconds or WALL_PER_CPU * cpu_s,
            "memory_mb": args.memory_mb,
            "allow_plugins": args.allow_plugins,
            "on_report": (lambda _: progress.advance(task)) if progress is not None else None,
        }
        if args.dask:
            from autonomy.classroom.grade import grade_on_dask

            reports = grade_on_dask(exercise, submissions, args.dask, **limits)
        else:
            reports = grade_class(
                exercise,
                submissions,
                traces=traces,
                feedback=feedback_folder,
                corrections=corrections,
                workers=args.workers,
                **limits,
            )
    except KeyboardInterrupt:
        return _fail("grading interrupted", EXIT_INTERRUPTED)
    except ImportError:
        return _fail("--dask needs dask.distributed: pip install 'autonomy[cluster]'", EXIT_USAGE)
    except OSError as err:  # no scheduler there
        return _fail(f"--dask {args.dask}: no Dask scheduler answers there ({err})", EXIT_USAGE)
    finally:
        if progress is not None:
            progress.stop()
    apply_adjustments(reports, adjustments, args.adjust or "")
    matched = match_roster(roster, reports, Path(args.roster).parent) if roster is not None else None
    if alone and not args.quiet:
        for line in feedback(exercise, reports[0]):
            print(line)
    elif not args.quiet:
        _print_marks(exercise, reports)
        for report in reports:
            for points, reason in report.adjustments:
                print(_shown(f"correction: {report.student} {points:+g} ({reason})"))
    if matched is not None and not args.quiet:
        for entry, report in matched.listed:
            if report is None:
                print(_shown(f"no submission: {entry.id} {entry.name} (roster line {entry.line})"))
        for report in matched.unlisted:
            print(_shown(f"not on the roster: {report.student} ({report.file or 'no file'})"))
    if earlier is not None and not args.quiet:
        print(_shown(f"Since {args.compare}:"))
        for line in compare(exercise, reports, earlier):
            print(_shown(f"  {line}"))
    # a student checking their own mission learns from the exit code too that nothing of it ran
    code = EXIT_USAGE if alone and reports[0].problems else EXIT_OK
    pages: dict[str, str] = {}
    if args.feedback:  # written by the workers, as they graded
        from autonomy.classroom.results import file_names, page_path

        names = file_names([r.student for r in reports])
        pages = {r.student: str(page_path(Path(args.feedback), names[r.student])) for r in reports}
        pages = {student: page for student, page in pages.items() if Path(page).is_file()}
        if not args.quiet:
            print(_shown(f"wrote {len(pages)} feedback pages in {args.feedback}"))

    def made(kind: str, target: str) -> str:
        if kind == "csv":
            return to_csv(exercise, reports, matched)
        if kind == "json":
            return to_json(exercise, reports, matched)
        if kind == "gradescope":
            return to_gradescope(exercise, reports[0])
        where = Path(target).resolve().parent  # each student linked to their page, from where the class page is
        return to_html(exercise, reports, {name: os.path.relpath(page, where) for name, page in pages.items()})

    for target, kind in targets:  # one that fails does not keep the others from being written
        try:
            # a problem quoting a path that is not UTF-8 (a folder from another system) has '?' for its bytes
            Path(target).write_text(made(kind, target), encoding="utf-8", errors="replace")
        except OSError as err:
            code = _fail(f"cannot write {target}: {err.strerror or err}", EXIT_USAGE)
            continue
        if not args.quiet:
            print(f"wrote {target}")
    return code


def cmd_gradescope(args: argparse.Namespace) -> int:
    """Packs an exercise, with this package, as the autograder zip Gradescope takes."""
    from pathlib import Path

    from autonomy.classroom.exercise import SecretError, read_secret
    from autonomy.classroom.gradescope import AutograderError, build_autograder

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
        help="the class list (columns id,name,submission): ids first in the gradebook, missing students listed",
    )
    grade.add_argument(
        "--adjust",
        metavar="FILE.csv",
        help="the teacher's corrections (columns student,points,reason): added to the marks, shown with the reason",
    )
    grade.add_argument("--compare", metavar="OLD.json", help="say what changed since an earlier grading's --json")
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

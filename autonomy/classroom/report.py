"""A class's marks as a gradebook (CSV), JSON, one self-contained HTML page, and terminal text.

Everything here depends only on the reports and the exercise, never on the time or the
machine, so grading the same files twice writes the same bytes.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterator
from dataclasses import replace
from html import escape
from pathlib import Path, PurePath
from urllib.parse import parse_qsl, urlencode, urlsplit, urlunsplit

from autonomy.classroom.exercise import Exercise, seed_points
from autonomy.classroom.gradebook import RosterMatch, similar
from autonomy.classroom.overview import class_overview
from autonomy.classroom.results import Report, SeedResult, page_path
from autonomy.record import RunHeader
from autonomy.source import UnreadableFile, read_text
from autonomy.views.blocksvg import mission_blocks_svg
from autonomy.views.lines import printable
from autonomy.views.mapsvg import world_svg
from autonomy.views.page import ReplayMaker, runs_host_head, script_json, static_text


def _number(value: float) -> str:
    return f"{value:g}"


def cell_text(text: str) -> str:
    """Text a spreadsheet will not run as a formula (a file may be named ``=HYPERLINK(...)``)."""
    text = printable(text)
    return "'" + text if text[:1] in ("=", "+", "-", "@") else text


def to_csv(
    exercise: Exercise,
    reports: list[Report],
    roster: RosterMatch | None = None,
    on_robot: dict[str, float] | None = None,
) -> str:
    """The gradebook: student, total, out of, one column per criterion, corrections, then why a submission did not run.

    With a roster, the student's id and name come first (as Moodle's grade import maps them: ``id``
    to the "ID number" field, ``total`` to the assignment), every roster line has its row (``no
    submission`` for a student who handed in nothing), and a submission on no roster line keeps
    its row, with no id and ``not on the roster``. ``on_robot``: each student's best mark of a run on a
    robot, the teacher's (a live class with ``robot_points``): a column of its own, counted in the total.
    """
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    robot = on_robot is not None and exercise.robot_points > 0
    criteria = [c.label for c in exercise.criteria] + ["on_robot"] * robot
    tail = ["adjustment", "adjustment_reasons", "problems"]

    def cells(report: Report | None, student: str) -> list[str]:  # no submission: no marks but the robot's
        robot_mark = [(on_robot or {}).get(student, 0.0)] * robot
        report = report or Report(student, "", 0.0, exercise.max_points, [0.0] * len(exercise.criteria))
        return [
            _number(report.total + sum(robot_mark)),
            _number(report.max_points + exercise.robot_points * robot),
            *[_number(m) for m in [*report.marks, *robot_mark]],
            _number(sum(points for points, _ in report.adjustments)),
            cell_text(" | ".join(reason for _, reason in report.adjustments)),
            cell_text(" | ".join(report.problems)),
        ]

    if roster is None:
        writer.writerow(["student", "total", "out_of", *criteria, *tail])
        for report in reports:
            writer.writerow([cell_text(report.student), *cells(report, report.student)])
        return out.getvalue()
    writer.writerow(["id", "name", "student", "total", "out_of", *criteria, *tail])
    for entry, report in roster.listed:
        row = cells(report, entry.id)
        if report is None:
            row[-1] = "no submission"
        writer.writerow([cell_text(entry.id), cell_text(entry.name), cell_text(report.student) if report else "", *row])
    for report in roster.unlisted:
        row = cells(report, report.student)
        row[-1] = cell_text(" | ".join(["not on the roster", *report.problems]))
        writer.writerow(["", "", cell_text(report.student), *row])
    return out.getvalue()


def to_json(exercise: Exercise, reports: list[Report], roster: RosterMatch | None = None) -> str:
    """Every mark, every seed's verdicts and path, as one JSON document (with the roster's ids, if given)."""
    document = {
        "exercise": exercise.name,
        "title": exercise.title,
        "world": exercise.world.name,
        "time_limit_s": exercise.time_limit_s,
        "seeds": [s.label for s in exercise.seeds],
        "criteria": [{"label": c.label, "points": c.points} for c in exercise.criteria],
        "max_points": exercise.max_points,
        "students": [r.to_json() for r in reports],
        "similar": [{"students": [one, other], "how": how} for one, other, how in similar(reports)],
    }
    if roster is not None:
        document["roster"] = [
            {"id": entry.id, "name": entry.name, "student": report.student if report is not None else None}
            for entry, report in roster.listed
        ]
        document["not_on_the_roster"] = [report.student for report in roster.unlisted]
    return json.dumps(document, indent=1, sort_keys=False, ensure_ascii=False) + "\n"


def feedback(exercise: Exercise, report: Report) -> list[str]:
    """What a student reads: the total, then each criterion with its mark and each seed's line."""
    lines = [
        f"{printable(report.student)}: {_number(report.total)} / {_number(report.max_points)} "
        f"in '{printable(exercise.title)}'"
    ]
    lines += [
        f"  Correction by the teacher: {points:+g} ({printable(reason)})" for points, reason in report.adjustments
    ]
    if report.problems:
        lines.append("  Not graded, and the mark is 0" + (" before the correction:" if report.adjustments else ":"))
        lines += [f"  {printable(p)}" for p in report.problems]
        return lines
    lines += [f"  Note: {printable(note)}" for note in report.notes]
    for index, criterion in enumerate(exercise.criteria):
        verdicts = [seed.verdicts[index] for seed in report.seeds]
        mark = "ok  " if all(held for held, _ in verdicts) else "MISS"
        lines.append(f"  {mark} {criterion.shown}: {_number(report.marks[index])} / {_number(criterion.points)} points")
        for seed, (held, line) in zip(report.seeds, verdicts, strict=True):
            lines.append(f"         {seed.seed}: {'yes' if held else 'no '} {printable(line)}")
    return lines


# ---------------------------------------------------------------------------- HTML

_STYLE = """
body { font-family: "DejaVu Sans", sans-serif; margin: 1em 2em; color: #212529; }
table { border-collapse: collapse; margin: .5em 0 1.5em; }
th, td { border: 1px solid #dee2e6; padding: .25em .6em; text-align: right; }
th:first-child, td:first-child { text-align: left; }
td:first-child, th { max-width: 22em; } td, h2, p, li { overflow-wrap: anywhere; } th { overflow-wrap: break-word; }
td.hint { color: #495057; font-style: italic; }
td.full { background: #d3f9d8; } td.part { background: #fff3bf; } td.none { background: #ffe3e3; }
td.notgraded { background: #e9ecef; color: #495057; font-style: italic; }
th button { font: inherit; font-weight: bold; border: none; background: none; cursor: pointer; padding: 0; }
th[aria-sort="ascending"] button::after { content: " ▲"; } th[aria-sort="descending"] button::after { content: " ▼"; }
section.student { border-top: 2px solid #343a40; margin-top: 1.5em; }
.seeds { display: flex; flex-wrap: wrap; gap: 1em; }
.seed { border: 1px solid #dee2e6; padding: .4em; max-width: 620px; }
.seed svg { width: 600px; max-width: 100%; height: auto; }
.yes { color: #237032; } .no { color: #c92a2a; }
pre.problems { background: #fff5f5; padding: .5em; white-space: pre-wrap; }
"""


def seed_heading(exercise: Exercise, seed: SeedResult) -> str:
    """A seed's heading, what it earned first: ``seed 8: 0 of 10 points (the run: succeeded after 9.8 s)``.

    Then how the run ended: a run that ended by itself with no points must not read as a pass.
    """
    earned = round(seed_points(exercise, seed), 2)
    out_of = _number(exercise.max_points)
    return f"{seed.seed}: {_number(earned)} of {out_of} points (the run: {seed.outcome} after {seed.time_s:g} s)"


def _cell(mark: float, points: float, held: tuple[int, int] = (0, 0)) -> str:
    """A mark's cell; a criterion of no points (a hint) tells on how many of the ``held`` seeds it held instead."""
    if points <= 0:
        return f'<td class="hint" data-sort="{held[0] / (held[1] or 1):g}">held on {held[0]} of {held[1]}</td>'
    kind = "full" if mark >= points else "none" if mark <= 0 else "part"
    return f'<td class="{kind}" data-sort="{mark:g}">{_number(mark)}</td>'


#: Sorts the class table by the column whose head is clicked (again: the other way), by number where it can.
_SORTING = """
document.querySelectorAll("table.marks th button").forEach((button) => {
  button.addEventListener("click", () => {
    const table = button.closest("table"), column = Number(button.dataset.column);
    const head = button.parentElement, up = head.getAttribute("aria-sort") !== "ascending";
    table.querySelectorAll("th").forEach((th) => th.setAttribute("aria-sort", "none"));
    head.setAttribute("aria-sort", up ? "ascending" : "descending");
    const body = table.tBodies[0], rows = Array.from(body.rows);
    const key = (row) => row.cells[column].dataset.sort;
    rows.sort((a, b) => {
      const x = key(a), y = key(b), nx = Number(x), ny = Number(y);
      const order = !isNaN(nx) && !isNaN(ny) ? nx - ny : x.localeCompare(y);
      return up ? order : -order;
    });
    rows.forEach((row) => body.appendChild(row));
  });
});
"""


def _seed_svg(exercise: Exercise, seed: SeedResult, title: str) -> str:
    """The seed's world (as that seed drew it), the true path, and a mark at each collision, beep and turn.

    Each mark has a title (what happened, when): a browser shows it when the pointer rests on it.
    """
    svg = world_svg(exercise.world.for_seed(seed.world_seed).as_dict(), title)
    points = " ".join(f"{x:g},{y:g}" for x, y in seed.path)
    marks = []
    for time_s, x, y, degrees in seed.turns:
        side = "left" if degrees > 0 else "right"
        marks.append(
            f'<circle cx="{x:g}" cy="{y:g}" r="22" fill="none" stroke="#1971c2" stroke-width="2" '
            f'vector-effect="non-scaling-stroke" class="turn"><title>turned {side} {abs(degrees):g} deg '
            f"at {time_s:g} s</title></circle>"
        )
    for time_s, x, y in seed.beeps:
        marks.append(
            f'<circle cx="{x:g}" cy="{y:g}" r="14" fill="#f59f00" stroke="#e67700" stroke-width="1" '
            f'vector-effect="non-scaling-stroke" class="beep"><title>beep at {time_s:g} s</title></circle>'
        )
    for time_s, x, y, *speed in seed.collisions:
        how = f" at {speed[0]:g} mm/s" if speed else ""
        marks.append(
            f'<path d="M{x - 50:g},{y - 50:g}L{x + 50:g},{y + 50:g}M{x - 50:g},{y + 50:g}L{x + 50:g},{y - 50:g}" '
            'stroke="#e03131" stroke-width="3" vector-effect="non-scaling-stroke" class="collision">'
            f"<title>collision at {time_s:g} s{how}</title></path>"
        )
    drawn = (
        f'<polyline points="{points}" fill="none" stroke="#2b8a3e" stroke-width="2.5" '
        f'vector-effect="non-scaling-stroke" class="path"/>{"".join(marks)}'
    )
    return svg.replace('<g id="paths"></g>', f'<g id="paths">{drawn}</g>')


def _overview(exercise: Exercise, reports: list[Report], pages: dict[str, str] | None) -> list[str]:
    """The class at a glance (:func:`class_overview`), drawn by the desk's own script: each map links to the student."""
    links: list[str | None] = [(pages or {}).get(r.student) or f"#s-{index}" for index, r in enumerate(reports)]
    data = json.dumps(class_overview(exercise, reports, links), separators=(",", ":"))
    return [
        f"<style>{static_text('overview.css')}</style>",
        '<section class="overview" aria-labelledby="overview-title"><h2 id="overview-title">The class at a glance</h2>',
        '<div id="overview"></div></section>',
        f'<script type="application/json" id="overview-data">{script_json(data)}</script>',
        f"<script>{static_text('overview.js')}\n"
        "drawOverview(document.getElementById('overview'), "
        "JSON.parse(document.getElementById('overview-data').textContent));</script>",
    ]


def to_html(exercise: Exercise, reports: list[Report], pages: dict[str, str] | None = None) -> str:
    """One page with nothing to fetch: the class table, then each student's seeds, maps and verdicts.

    Args:
        exercise: The exercise.
        reports: The class's reports.
        pages: Each student's feedback page (``--feedback``), as a link from this page, if any.
    """
    title = escape(printable(exercise.title))
    heads = ["student", f"total<br>({_number(exercise.max_points)})"]
    heads += [f"{escape(printable(c.label))}<br>({_number(c.points)})" for c in exercise.criteria]
    head = "".join(
        f'<th aria-sort="none"><button type="button" data-column="{k}">{text}</button></th>'
        for k, text in enumerate(heads)
    )
    rows = []
    for index, report in enumerate(reports):
        name = escape(printable(report.student))
        if report.problems:  # not graded: told apart from a graded zero, with why
            why = escape(printable(report.problems[0]))
            extra = sum(points for points, _ in report.adjustments)
            shown = "not graded" + (f" ({extra:+g} by hand)" if extra else "")
            cells = f'<td class="notgraded" data-sort="{report.total - 1000:g}" title="{why}">{shown}</td>'
            cells += '<td class="notgraded" data-sort="-1">–</td>' * len(exercise.criteria)
        else:
            held = [sum(s.shares[k] >= 1 for s in report.seeds if k < len(s.shares)) for k in range(len(report.marks))]
            cells = _cell(report.total, report.max_points) + "".join(
                _cell(m, c.points, (n, len(report.seeds)))
                for m, c, n in zip(report.marks, exercise.criteria, held, strict=True)
            )
        rows.append(f'<tr><td data-sort="{name}"><a href="#s-{index}">{name}</a></td>{cells}</tr>')
    pairs = similar(reports)
    alike = []
    if pairs:
        alike = ["<h2>Similar submissions</h2><p>Trees that look alike: a hint to look at, not a verdict.</p>"]
        alike.append('<ul class="similar">')
        alike += [
            f"<li>{escape(printable(one))} and {escape(printable(other))}: {escape(how)}</li>"
            for one, other, how in pairs
        ]
        alike.append("</ul>")
    parts = [
        "<!doctype html>",
        '<html lang="en"><head><meta charset="utf-8">',
        # nothing is fetched, and only the page's own script and style run
        '<meta http-equiv="Content-Security-Policy" content="default-src \'none\'; '
        "style-src 'unsafe-inline'; script-src 'unsafe-inline'\">",
        f"<title>autonomy grades: {title}</title><style>{_STYLE}</style></head><body>",
        f"<h1>{title}</h1>",
        f"<p>{escape(printable(exercise.description))}</p>",
        *_overview(exercise, reports, pages),
        f"<p>World <b>{escape(printable(exercise.world.name))}</b>, {exercise.time_limit_s:g} s a run, "
        f"{len(exercise.seeds)} seeds: {escape(', '.join(s.label for s in exercise.seeds))}. "
        "A criterion's mark is its points times its mean share over the seeds: one that holds on a run earns "
        "it all there, one over several zones each zone's part.</p>",
        f'<table class="marks"><thead><tr>{head}</tr></thead><tbody>',
        *rows,
        "</tbody></table>",
        *alike,
        f"<script>{_SORTING}</script>",
    ]
    for index, report in enumerate(reports):
        parts.append(f'<section class="student" id="s-{index}">')
        parts.append(
            f"<h2>{escape(printable(report.student))}: {_number(report.total)} / {_number(report.max_points)}</h2>"
        )
        parts.append(f"<p>{escape(printable(report.file))}</p>")
        if pages and report.student in pages:
            parts.append(f'<p><a class="feedback" href="{escape(pages[report.student])}">their feedback page</a></p>')
        parts += [
            f'<p class="adjustment">Correction by the teacher: {points:+g} ({escape(printable(reason))})</p>'
            for points, reason in report.adjustments
        ]
        parts += [f'<p class="note">Note: {escape(printable(note))}</p>' for note in report.notes]
        if report.problems:
            text = "\n".join(printable(p) for p in report.problems)
            parts.append(f'<p>Not graded:</p><pre class="problems">{escape(text)}</pre></section>')
            continue
        parts.append('<div class="seeds">')
        for number, seed in enumerate(report.seeds, start=1):  # s-K-seed-N: where the overview's map opens
            verdicts = "".join(
                f'<li class="{"yes" if held else "no"}">{"✓" if held else "✗"} {escape(printable(line))}</li>'
                for held, line in seed.verdicts
            )
            picture = _seed_svg(exercise, seed, f"{report.student}, {seed.seed}")
            heading = escape(seed_heading(exercise, seed))
            parts.append(
                f'<div class="seed" id="s-{index}-seed-{number}"><h3>{heading}</h3>{picture}<ul>{verdicts}</ul></div>'
            )
        parts.append("</div></section>")
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


#: Opens the mission's blocks of a page opened at ``#as-blocks``.
_OPEN_BLOCKS = "if (location.hash === '#as-blocks') document.getElementById('as-blocks').open = true;"
_FEEDBACK_STYLE = """
body { font-family: "DejaVu Sans", sans-serif; margin: 1em 2em; color: #212529; }
pre.marks { white-space: pre-wrap; overflow-wrap: anywhere; }
pre.source { background: #f8f9fa; padding: .5em 0; border: 1px solid #dee2e6; overflow-x: auto; }
pre.source span.line { display: block; padding: 0 .6em; }
pre.source span.line::before { content: attr(data-line); display: inline-block; width: 3em; color: #868e96; }
pre.source span.problem { background: #ffe3e3; }
pre.source span.why { display: block; color: #c92a2a; padding-left: 3.6em; }
.seed { border-top: 1px solid #dee2e6; margin-top: 1em; }
.seed svg { width: 600px; max-width: 100%; height: auto; float: left; margin-right: 1em; }
.seed iframe { width: 100%; height: 640px; border: 1px solid #dee2e6; clear: both; display: block; }
.yes { color: #237032; } .no { color: #c92a2a; }
"""


def _problem_lines(report: Report) -> dict[int, list[str]]:
    """The report's problems by the line of the student's file they stand at (``FILE:LINE:COL: ...``)."""
    by_line: dict[int, list[str]] = {}
    prefix = f"{report.file}:"
    for problem in report.problems:
        if not problem.startswith(prefix):
            continue
        place, _, message = problem[len(prefix) :].partition(": ")
        line = place.split(":")[0]
        if line.isdigit():
            by_line.setdefault(int(line), []).append(message)
    return by_line


def feedback_page(
    exercise: Exercise, report: Report, source: str | None, runs: list[ReplayMaker | None]
) -> Iterator[str]:
    """One student's page, for them alone, with nothing to fetch: its text, piece by piece.

    Their file with its lines numbered and its problems marked where they stand; their mark,
    criterion by criterion; then each seed's run: the map of what really happened (collisions,
    beeps and turns marked), each criterion's line, and the run's replay (the tree coloured by
    status, the path, play and the slider), opened on its last tick.

    Args:
        exercise: The exercise.
        report: The student's report.
        source: Their mission file's text (None: it could not be read).
        runs: For each seed, its run to replay, or None.
    """
    report = for_the_student(report)
    name = escape(printable(report.student))
    yield "<!doctype html>\n"
    yield '<html lang="en"><head><meta charset="utf-8">\n'
    # nothing is fetched, and only the page's own script and style run (in its frames too, which have its policy)
    yield (
        '<meta http-equiv="Content-Security-Policy" content="default-src \'none\'; '
        "style-src 'unsafe-inline'; script-src 'unsafe-inline'; img-src data:\">\n"
    )
    yield f"<title>{name}: {escape(printable(exercise.title))}</title><style>{_FEEDBACK_STYLE}</style>\n"
    if any(run is not None and run.header is not None for run in runs):
        yield runs_host_head()  # the viewer, once: each seed's frame gets it, and its run from this page
    yield "\n</head><body>\n"
    yield f"<h1>{name}: {_number(report.total)} / {_number(report.max_points)}</h1>\n"
    yield f"<p>{escape(printable(exercise.title))}: {escape(printable(exercise.description))}</p>\n"
    yield '<h2>Marks</h2><pre class="marks">' + escape("\n".join(feedback(exercise, report)[1:])) + "</pre>\n"
    yield f"<h2>Your file</h2><p>{escape(printable(report.file or 'no file'))}</p>\n"
    if source is None:
        yield "<p>The file could not be read.</p>\n"
    else:
        problems = _problem_lines(report)
        texts = source.splitlines() or [""]
        for beyond in [n for n in problems if n > len(texts)]:  # at the end of the file: on its last line
            problems.setdefault(len(texts), []).extend(problems.pop(beyond))
        lines = []
        for number, text in enumerate(texts, start=1):
            marked = " problem" if number in problems else ""
            why = "".join(f'<span class="why">{escape(printable(m))}</span>' for m in problems.get(number, []))
            lines.append(f'<span class="line{marked}" data-line="{number}">{escape(printable(text))}{why}</span>')
        yield '<pre class="source">' + "".join(lines) + "</pre>\n"
        # the same mission as its blocks: open at once on a page opened at #as-blocks (one built from blocks)
        drawn = (
            None if report.problems else mission_blocks_svg(source, f"{printable(report.student)}'s mission as blocks")
        )
        if drawn is not None:
            yield f'<details id="as-blocks"><summary>Your mission as blocks</summary>{drawn}</details>\n'
            yield f"<script>{_OPEN_BLOCKS}</script>\n"
    for number, (seed, run) in enumerate(zip(report.seeds, runs, strict=True), start=1):
        verdicts = "".join(
            f'<li class="{"yes" if held else "no"}">{"&#10003;" if held else "&#10007;"} {escape(printable(line))}</li>'
            for held, line in seed.verdicts
        )
        yield f'<section class="seed" id="seed-{number}"><h2>{escape(seed_heading(exercise, seed))}</h2>\n'
        yield _seed_svg(exercise, seed, f"{report.student}, {seed.seed}") + f"<ul>{verdicts}</ul>\n"
        if seed.rest_s is not None and seed.rest_s > seed.time_s + 0.05:  # it rolled on after the mission's end
            yield (
                f"<p>The replay ends where the mission ended, at {seed.time_s:g} s; the robot rolled on and came "
                f"to rest at {seed.rest_s:g} s, which the marks judge (the map above shows it).</p>\n"
            )
        if run is not None and run.header is not None:
            try:
                marks = {"beeps": seed.beeps, "turns": seed.turns}  # the replay's map marks them as it plays
                pieces = run.payload_parts(at_end=True, header=_shown_header(run.header, seed), marks=marks)
            except ValueError as err:  # a number JSON cannot hold: the run is not replayed, the page is made
                yield f"<p>This run cannot be replayed: {escape(printable(str(err)))}.</p>\n"
            else:
                yield f'<script id="run-{number}" type="application/json">'
                yield from (script_json(piece) for piece in pieces)
                yield f'</script>\n<iframe title="the run on {escape(seed.seed)}" data-run="run-{number}"></iframe>\n'
        yield "</section>\n"
    yield "</body></html>\n"


def for_the_student(report: Report) -> Report:
    """The report as a student is shown it: their file named by its name alone, in its problems too.

    Where the teacher keeps the file (a folder of their machine) is none of the student's business.
    """
    name = PurePath(report.file).name if report.file else ""
    if name == report.file:
        return report
    return replace(report, file=name, problems=[problem.replace(report.file, name) for problem in report.problems])


def _emulator_shown(port: str) -> str:
    """An ``emu://`` address with its world named by its file's name alone (a world file's folder is the teacher's)."""
    if not port.startswith("emu://"):
        return port
    parts = urlsplit(port)
    query = [(key, PurePath(value).name if key == "world" else value) for key, value in parse_qsl(parts.query)]
    return urlunsplit(parts._replace(query=urlencode(query)))


def _shown_header(header: RunHeader, seed: SeedResult) -> RunHeader:
    """A run's header as a student's page shows it.

    No date (grading twice writes the same page), no folder of the teacher's machine (the mission
    file and each node's file by their names, the world's too), and a hidden seed's number
    nowhere, neither the seed nor the emulator's address: with it, the run could be made again.
    """
    nodes = [replace(node, file=PurePath(node.file).name) if node.file else node for node in header.nodes]
    shown = replace(header, date="", nodes=nodes, mission_file=PurePath(header.mission_file).name)
    if not seed.seed.startswith("hidden"):
        return replace(shown, port=_emulator_shown(header.port))
    return replace(shown, seed=None, port=f"the exercise's emulator, {seed.seed}")


def write_feedback_page(exercise: Exercise, report: Report, folder: Path, runs: list[ReplayMaker], name: str) -> Path:
    """Writes ``report``'s student's page (:func:`feedback_page`) in ``folder``, with each seed's run to replay.

    Returns:
        The page's path.
    """
    source = None
    if report.file:
        try:
            source = read_text(Path(report.file))
        except (UnreadableFile, OSError):
            source = None
    shown: list[ReplayMaker | None] = [*runs[: len(report.seeds)]]
    shown += [None] * (len(report.seeds) - len(shown))
    page = page_path(folder, name)
    with page.open("w", encoding="utf-8", errors="replace") as stream:  # written as made: never whole in memory
        stream.writelines(feedback_page(exercise, report, source, shown))
    return page

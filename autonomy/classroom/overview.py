"""The class at a glance: what a teacher sees above the class table, live in class and in the class page.

Plain data from the class's reports: the marks' spread, each criterion's share of the class, the nodes
that were running when marks were lost, and one small map per student of the seed they did worst on.
``views/static/overview.js`` draws it, the same on the teacher's desk and in ``autonomy grade --html``.
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import PurePath
from typing import Any

from autonomy.classroom.exercise import Exercise, seed_points
from autonomy.classroom.results import Report
from autonomy.emulator.world import Box, Shape
from autonomy.runner import clipped
from autonomy.views.lines import printable

#: Points of a path on a small map: enough to show where it went.
MAP_POINTS = 80
#: Node types listed as where marks were lost, the most points first.
NODES_SHOWN = 5
#: Criteria named under each such node, the most students first.
CRITERIA_PER_NODE = 3
#: Longest account of why a student's work was not graded, under their map.
WHY_CHARS = 80


def _shape(shape: Shape) -> list[Any]:
    """A shape as the picture draws it: ``["box", x, y, width, height]`` or ``["circle", x, y, radius]``, mm."""
    if isinstance(shape, Box):
        width_mm, height_mm = shape.x_max_mm - shape.x_min_mm, shape.y_max_mm - shape.y_min_mm
        return ["box", round(shape.x_min_mm), round(shape.y_min_mm), round(width_mm), round(height_mm)]
    return ["circle", round(shape.x_mm), round(shape.y_mm), round(shape.radius_mm)]


def _world(exercise: Exercise, world_seed: int) -> dict[str, Any]:
    world = exercise.world.for_seed(world_seed)
    return {
        "arena_mm": [round(world.width_mm), round(world.height_mm)],
        "obstacles": [_shape(obstacle) for obstacle in world.obstacles],
        "zones": [[zone.name, *_shape(zone.shape)] for zone in world.zones],
    }


def _thinned(path: list[tuple[float, float]]) -> list[list[int]]:
    """At most :data:`MAP_POINTS` of the path, evenly taken, its first and last kept."""
    if len(path) <= MAP_POINTS:
        return [[round(x), round(y)] for x, y in path]
    step = (len(path) - 1) / (MAP_POINTS - 1)
    return [[round(path[round(k * step)][0]), round(path[round(k * step)][1])] for k in range(MAP_POINTS)]


def seed_anchor(link: str, number: int) -> str:
    """Where ``link`` opens at a student's ``number``-th seed (from 1).

    A link to a part of the class page (``#s-3``) goes to that seed in it (``#s-3-seed-2``); one to a feedback page
    (``page.html``, ``page.html#as-blocks``) to that seed's section of the page (``page.html#seed-2``).
    """
    if link.startswith("#"):
        return f"{link}-seed-{number}"
    return f"{link.split('#')[0]}#seed-{number}"


def _outcome(mark: float, out_of: float) -> str:
    return "full" if mark >= out_of - 1e-9 else "none" if mark <= 1e-9 else "part"


def _mean_share(report: Report, index: int) -> float:
    """The share of a criterion's points a report earned, over its seeds (what a criterion of no points earned too)."""
    shares = [seed.shares[index] for seed in report.seeds if index < len(seed.shares)]
    return sum(shares) / len(shares) if shares else 0.0


def _bins(max_points: float) -> list[tuple[float, float]]:
    """The marks' bins: a point each up to 20 points, else ten alike; the last holds full marks."""
    count = int(max_points) if max_points == int(max_points) and 1 <= max_points <= 20 else 10
    width = max_points / count if max_points > 0 else 1.0
    return [(k * width, (k + 1) * width) for k in range(count)]


def class_overview(
    exercise: Exercise, reports: list[Report], links: list[str | None] | None = None, about: str = ""
) -> dict[str, Any]:
    """What the class's reports add up to, as ``overview.js`` draws it.

    Args:
        exercise: The exercise.
        reports: Each student's report (their latest, in class), in the order their maps are shown.
        links: Where each report's runs can be replayed (its feedback page), in the reports' order; None: nowhere.
        about: What the reports are, said over the maps (``each student's latest graded run or hand-in``).

    Returns:
        ``students``, ``graded`` (the reports without problems), ``max_points``, ``median`` (None: none graded),
        ``full_marks`` and ``no_marks`` (students);
        ``bins``: ``[from, to, students]``; ``criteria``: ``{label, title, points, full, part, none}`` (students);
        ``nodes``: ``{node, students, points_lost, criteria: [[label, students]...]}``, the most points first;
        ``lost``: ``{points, shown, unnamed}``, the points lost across the class (each student's mean over their
        seeds, added up), those the rows shown hold (the nodes', and the last), and a row as ``nodes``' of those
        lost while no node was named (a criterion of the whole run, or one counting only with another);
        ``worlds``: each seed's world drawn, by key;
        ``maps``: ``{student, seed, world, path, collisions, beeps, outcome, mark, total, why, link}``:
        the seed they earned least on, ``outcome`` (``full``, ``part``, ``none``, or ``notgraded``,
        ``why`` saying why) and ``mark`` that seed's, ``total`` their mark, ``link`` opening at that seed
        (:func:`seed_anchor`); ``about``.
    """
    graded = [r for r in reports if not r.problems]
    bins = [[lo, hi, 0] for lo, hi in _bins(exercise.max_points)]
    for report in graded:
        index = min(len(bins) - 1, max(0, math.floor(report.total / (bins[0][1] or 1.0))))
        bins[index][2] += 1
    criteria = []
    for index, criterion in enumerate(exercise.criteria):
        told = Counter(_outcome(_mean_share(r, index), 1.0) for r in graded)
        words = {"label": printable(criterion.label), "title": printable(criterion.title), "points": criterion.points}
        criteria.append({**words, "full": told["full"], "part": told["part"], "none": told["none"]})
    lost_points: Counter[str] = Counter()  # "" for the points lost while no node is named
    lost_by: Counter[str] = Counter()  # students, by node type
    lost_on: dict[str, Counter[str]] = {}  # students, by node type and criterion
    for report in graded:
        count = len(report.seeds) or 1
        theirs: set[tuple[str, str]] = set()  # each node and criterion once a student, however many seeds
        for seed in report.seeds:
            for index, criterion in enumerate(exercise.criteria[: len(seed.shares)]):
                points = criterion.points * (1.0 - seed.shares[index]) / count
                if points <= 0:
                    continue
                node = seed.lost_while[index] if index < len(seed.lost_while) else ""
                lost_points[node] += points
                theirs.add((node, printable(criterion.title or criterion.label)))
        for node in {node for node, _ in theirs}:
            lost_by[node] += 1
        for node, label in theirs:
            lost_on.setdefault(node, Counter())[label] += 1

    def lost_row(node: str) -> dict[str, Any]:
        named = sorted(lost_on.get(node, Counter()).items(), key=lambda kv: (-kv[1], kv[0]))[:CRITERIA_PER_NODE]
        points = round(lost_points[node], 2)
        return {"node": node, "students": lost_by[node], "points_lost": points, "criteria": [list(kv) for kv in named]}

    by_points = sorted((kv for kv in lost_points.items() if kv[0] and kv[1] > 0.005), key=lambda kv: (-kv[1], kv[0]))
    nodes = [lost_row(node) for node, _ in by_points[:NODES_SHOWN]]
    lost = {
        "points": round(sum(lost_points.values()), 2),
        "shown": round(sum(lost_points[row["node"]] for row in nodes) + lost_points[""], 2),
        "unnamed": lost_row(""),
    }
    worlds: dict[str, dict[str, Any]] = {}
    maps = []
    for index, report in enumerate(reports):
        shown = {"student": printable(report.student), "link": links[index] if links and index < len(links) else None}
        if report.problems or not report.seeds:
            said = report.problems[0] if report.problems else "no run"
            if report.file and said.startswith(report.file):  # its folder takes the room of what went wrong
                said = PurePath(report.file).name + said[len(report.file) :]
            why = clipped(printable(said), WHY_CHARS)
            maps.append({**shown, "seed": "", "world": "", "path": [], "collisions": [], "beeps": [],
                         "outcome": "notgraded", "mark": "not graded", "total": "", "why": why})  # fmt: skip
            continue
        earned = [seed_points(exercise, seed) for seed in report.seeds]
        number = earned.index(min(earned))  # the first of the worst
        worst, worst_points = report.seeds[number], round(earned[number], 2)
        key = str(worst.world_seed)
        if key not in worlds:
            worlds[key] = _world(exercise, worst.world_seed)
        maps.append({
            **shown,
            "seed": worst.seed.split(" (")[0],
            "world": key,
            "path": _thinned(worst.path),
            "collisions": [[round(c[1]), round(c[2])] for c in worst.collisions],
            "beeps": [[round(b[1]), round(b[2])] for b in worst.beeps],
            "outcome": _outcome(worst_points, report.max_points),
            "mark": f"{worst_points:g} / {report.max_points:g}",
            "total": f"{report.total:g} / {report.max_points:g}",
            "why": "",
            "link": seed_anchor(shown["link"], number + 1) if shown["link"] else None,
        })  # fmt: skip
    totals = sorted(r.total for r in graded)
    middle = len(totals) // 2
    median = None if not totals else totals[middle] if len(totals) % 2 else (totals[middle - 1] + totals[middle]) / 2
    return {
        "students": len(reports),
        "graded": len(graded),
        "max_points": exercise.max_points,
        "median": None if median is None else round(median, 2),
        "full_marks": sum(_outcome(r.total, r.max_points) == "full" for r in graded),
        "no_marks": sum(_outcome(r.total, r.max_points) == "none" for r in graded),
        "bins": [[round(lo, 2), round(hi, 2), n] for lo, hi, n in bins],
        "criteria": criteria,
        "nodes": nodes,
        "lost": lost,
        "worlds": worlds,
        "maps": maps,
        "about": about,
    }

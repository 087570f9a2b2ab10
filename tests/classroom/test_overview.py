"""The class at a glance, from a class graded for real: every figure of it checked against the reports."""

from __future__ import annotations

import json

import pytest

from autonomy.classroom import find_submissions, grade_class, load_exercise
from autonomy.classroom.overview import MAP_POINTS, class_overview
from tests.views.conftest import ROOT

GARAGE = ROOT / "exercises" / "garage.yaml"
CLASS = ["solutions/garage.yaml", "wrong/garage_full_speed.yaml", "wrong/garage_park_then_beep.yaml",
         "wrong/garage_stops_short.yaml", "wrong/garage_fixed_distance.yaml"]  # fmt: skip


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    folder = tmp_path_factory.mktemp("typo")
    (folder / "typo.yaml").write_text("mission: typo\ntree:\n  mvoe: {speed: 2}\n")
    exercise = load_exercise(GARAGE)
    files = [ROOT / "exercises" / name for name in CLASS] + [folder / "typo.yaml"]
    return exercise, grade_class(exercise, find_submissions(files), workers=2)


def by_name(reports):
    return {r.student: r for r in reports}


def test_each_lost_mark_keeps_the_type_of_the_node_that_was_running_and_a_kept_mark_none(graded):
    exercise, reports = graded
    labels = [c.label for c in exercise.criteria]
    crash, time = labels.index("max_collisions 0"), labels.index("finish_within_s 30")
    full_speed, beeper = by_name(reports)["garage_full_speed"], by_name(reports)["garage_park_then_beep"]
    for seed in full_speed.seeds:  # it rolls into the wall after its one move ended: that move is named
        assert seed.shares[crash] < 1 and seed.lost_while[crash] == "move"
        assert "while move until < 60 mm (line 8) was running" in seed.verdicts[crash][1]
    for seed in beeper.seeds:  # its time ran out while it waited between beeps
        assert seed.lost_while[time] == "wait" and seed.lost_while[crash] == ""
    for seed in by_name(reports)["garage"].seeds:
        assert seed.lost_while == [""] * len(labels)


def test_the_overview_adds_up_the_reports_figure_by_figure(graded):
    exercise, reports = graded
    seen = class_overview(exercise, reports, [f"page-{k}" for k in range(len(reports))], "the class")
    marked = [r for r in reports if not r.problems]
    assert (seen["students"], seen["graded"], seen["about"]) == (6, 5, "the class")
    # the spread: a bin a point; each total in the bin it lies in, full marks in the last
    assert [(lo, hi) for lo, hi, _ in seen["bins"]] == [(k, k + 1) for k in range(10)]
    counts = [0] * 10
    for report in marked:
        counts[min(9, int(report.total))] += 1
    assert [n for _, _, n in seen["bins"]] == counts and sum(counts) == 5
    totals = sorted(r.total for r in marked)
    assert seen["median"] == totals[2]
    # each criterion: who earned it on every seed, who on some, who on none
    for index, shown in enumerate(seen["criteria"]):
        assert shown["label"] == exercise.criteria[index].label
        held = [sum(s.shares[index] for s in r.seeds) / len(r.seeds) for r in marked]
        assert (shown["full"], shown["part"], shown["none"]) == (
            sum(h >= 1 for h in held), sum(0 < h < 1 for h in held), sum(h <= 0 for h in held))  # fmt: skip
    # the nodes: points lost while each was running, the most first, each student once
    lost: dict[str, float] = {}
    for report in marked:
        for seed in report.seeds:
            for index, node in enumerate(seed.lost_while):
                if node:
                    points = exercise.criteria[index].points * (1 - seed.shares[index]) / len(report.seeds)
                    lost[node] = lost.get(node, 0.0) + points
    assert [(n["node"], n["points_lost"]) for n in seen["nodes"]] == sorted(
        ((node, round(points, 2)) for node, points in lost.items() if points > 0.005), key=lambda kv: -kv[1]
    )
    move = seen["nodes"][0]
    assert move["node"] == "move" and move["students"] == 3  # all but the solution and the beeper
    assert ["No crash", 2] in move["criteria"]  # the full speed one, and the fixed distance one
    wait = next(n for n in seen["nodes"] if n["node"] == "wait")
    assert (wait["students"], wait["points_lost"], wait["criteria"]) == (1, 2.0, [["Done within 30 s", 1]])
    # every point lost is told: the nodes' rows, then those lost with no node named, out of all lost
    every = sum(exercise.max_points - r.total for r in marked)
    assert seen["lost"]["points"] == pytest.approx(every, abs=0.02)
    unnamed = seen["lost"]["unnamed"]
    rows = sum(n["points_lost"] for n in seen["nodes"]) + unnamed["points_lost"]
    assert seen["lost"]["shown"] == pytest.approx(rows, abs=0.02) == pytest.approx(every, abs=0.02)
    assert unnamed["node"] == "" and unnamed["points_lost"] == pytest.approx(every - sum(lost.values()), abs=0.02)
    assert (seen["full_marks"], seen["no_marks"]) == (
        sum(r.total >= 10 for r in marked), sum(r.total <= 0 for r in marked))  # fmt: skip


def test_each_student_has_a_map_of_their_worst_seed_in_the_class_s_order_with_their_link(graded):
    exercise, reports = graded
    seen = class_overview(exercise, reports, [f"page-{k}" for k in range(len(reports))])
    assert [m["student"] for m in seen["maps"]] == [r.student for r in reports]
    assert seen["maps"][-1]["link"] == f"page-{len(reports) - 1}"  # the typo's: its page, saying why
    for shown, report in zip(seen["maps"], reports, strict=True):
        if report.problems:
            assert (shown["outcome"], shown["mark"], shown["path"]) == ("notgraded", "not graded", [])
            assert "mvoe" in shown["why"] and len(shown["why"]) <= 80
            continue
        points = [sum(c.points * s for c, s in zip(exercise.criteria, r.shares, strict=True)) for r in report.seeds]
        worst = report.seeds[points.index(min(points))]
        assert shown["seed"] == worst.seed.split(" (")[0] and shown["world"] == str(worst.world_seed)
        assert 2 <= len(shown["path"]) <= MAP_POINTS
        assert shown["path"][0] == [round(v) for v in worst.path[0]]
        assert shown["path"][-1] == [round(v) for v in worst.path[-1]]  # where it came to rest
        assert len(shown["collisions"]) == len(worst.collisions)
        # coloured and marked by what that seed earned, their mark said beside it
        least = round(min(points), 2)
        outcome = "full" if least >= 10 else "none" if least <= 0 else "part"
        assert (shown["outcome"], shown["mark"]) == (outcome, f"{least:g} / 10")
        assert shown["total"] == f"{report.total:g} / 10"
        assert shown["link"] == f"page-{reports.index(report)}#seed-{points.index(min(points)) + 1}"
        assert shown["beeps"] == [[round(b[1]), round(b[2])] for b in worst.beeps]
        world = seen["worlds"][shown["world"]]
        wall = world["obstacles"][0]  # the seed's own end wall, where that seed put it
        drawn = exercise.world.for_seed(worst.world_seed).obstacles[0]
        assert wall == ["box", round(drawn.x_min_mm), round(drawn.y_min_mm), 50, 1200]
        assert [z[0] for z in world["zones"]] == ["garage"]
    # made twice, the same to the byte: what the class page and the desk show does not move
    again = class_overview(exercise, reports, [f"page-{k}" for k in range(len(reports))])
    assert json.dumps(again) == json.dumps(seen)


def test_a_class_with_nothing_graded_has_an_empty_spread_and_no_nodes(graded):
    exercise, reports = graded
    typo = [r for r in reports if r.problems]
    seen = class_overview(exercise, typo)
    assert seen["graded"] == 0 and seen["median"] is None and seen["nodes"] == []
    assert sum(n for _, _, n in seen["bins"]) == 0 and seen["maps"][0]["link"] is None
    assert all(c["full"] == c["part"] == c["none"] == 0 for c in seen["criteria"])

"""What a mark measures, principle by principle: for each, a mission that breaks it and one that meets it.

1. Stopped means stopped by itself: a robot the wall stopped did not park, and how hard it hit counts.
2. A beep is a sound: a beep at volume 0 is none; "beep while standing there" can be asked.
3. A collision is a contact: touching again after backing off a little is another collision,
   pushing on against the wall is not.
4. No single miss zeroes the rest: a criterion requires only what it depends on, and earns the part
   that one earned; a zone missed by a little earns a part, on the teacher's scale (near_mm), none
   for a robot resting against a wall; all or nothing is the teacher's to ask (requires_all, near_mm: 0).
5. A teacher can say what their text asks: stop at a zone on the way, turn round there, come to
   rest at a distance from what is ahead, use the front sensor.

Each is graded by the real pipeline (grade_one, on the emulator) in a world of the test's own: a
hall 2 m long whose east wall the dock touches, with a checkpoint half-way.
"""

from pathlib import Path

import pytest

from autonomy.classroom import ExerciseInvalid, grade_one, load_exercise
from autonomy.classroom.job import check_submission, run_seed

WORLD = """\
name: dock
description: A hall 2 m long; a checkpoint half-way, the dock against the east wall.
arena_mm: [2000, 1000]
start: {x_mm: 300, y_mm: 500, heading_deg: 0}
zones:
  mid: {box: {from_mm: [900, 400], to_mm: [1100, 600]}}
  dock: {box: {from_mm: [1700, 400], to_mm: [2000, 600]}}
"""

#: Each criterion alone is what a test looks at, by its label: its points do not matter here.
EXERCISE = """\
exercise: dock
description: Principles, one criterion each.
world: dock.yaml
time_limit_s: 60
seeds: [1]
criteria:
  - rest_in_zone: dock
  - max_collisions: 0
    over_mm_s: 150
  - beeps_in: [dock]
  - beep_near: mid
    standing: true
  - stop_in_zone: mid
    for_s: 1
  - turns: 180
    at: mid
  - rest_distance_ahead_mm: [100, 200]
  - uses_nodes: [obstacle_within, move.until_obstacle_mm]
  - max_collisions: 3
  - finish_within_s: 20
"""


@pytest.fixture(scope="module")
def dock(tmp_path_factory):
    folder = tmp_path_factory.mktemp("dock")
    (folder / "dock.yaml").write_text(WORLD)
    (folder / "ex.yaml").write_text(EXERCISE)
    return load_exercise(folder / "ex.yaml"), folder


def sequence(*nodes: str) -> str:
    """A sequence of nodes, each written as flow YAML: ``sequence("move: {speed: 2}", "beep: {}")``."""
    return "sequence:\n" + "".join(f"  - {node}\n" for node in nodes)


SENSOR = "uses_nodes obstacle_within move.until_obstacle_mm"
AHEAD = "rest_distance_ahead_mm 100 200"


def verdicts(dock, name: str, tree: str) -> dict[str, tuple[bool, str, float]]:
    """Each criterion's verdict on seed 1, by its label: (held, line, share)."""
    exercise, folder = dock
    path = folder / f"{name}.yaml"
    path.write_text(f"mission: {name}\ntree:\n" + "".join(f"  {line}\n" for line in tree.strip().splitlines()))
    report = grade_one(exercise, name, path)
    assert report.problems == [], report.problems
    (seed,) = report.seeds
    return {
        c.label: (held, line, share)
        for c, (held, line), share in zip(exercise.criteria, seed.verdicts, seed.shares, strict=True)
    }


# ---------------------------------------------------------------- 1. stopped means stopped by itself


def test_a_robot_stopped_by_the_wall_it_ran_into_did_not_park_there(dock):
    rammed = verdicts(dock, "rams", "move: {speed: 4}")  # full speed until the wall stops it, in the dock
    held, line, _ = rammed["rest_in_zone dock"]
    assert not held and line.startswith("dock: came to rest inside it at ")
    assert line.endswith(
        ", but only because it hit a wall at 427 mm/s (stopped by it, not by itself); it got there while move (line 3) "
        "was running"
    )
    parked = verdicts(dock, "parks", "move: {speed: 2, until_obstacle_mm: 60}")  # stops itself before the wall
    assert parked["rest_in_zone dock"][0] and parked["max_collisions 0"][0]


def test_a_robot_caught_standing_between_two_moves_by_the_time_limit_had_not_come_to_rest():
    from autonomy.classroom.facts import STILL_AT_LIMIT_S, moving_at_time_limit
    from autonomy.runner import SUCCEEDED, TIME_LIMIT

    assert moving_at_time_limit(TIME_LIMIT, 59.97, 60.0)  # a beat of its wiggle: luck, not a rest
    assert moving_at_time_limit(TIME_LIMIT, 60.0, 60.0)  # still moving
    assert not moving_at_time_limit(TIME_LIMIT, 60.0 - STILL_AT_LIMIT_S - 0.01, 60.0)  # parked, then beeping on
    assert not moving_at_time_limit(SUCCEEDED, 59.97, 60.0)  # its mission ended: it stopped itself


def test_a_robot_that_parks_then_wiggles_until_its_time_runs_out_did_not_park(dock):
    wiggles = verdicts(
        dock,
        "wiggles",
        sequence(
            "move: {speed: 2, until_obstacle_mm: 60}",
            "repeat: {times: 1000, do: {sequence: [turn: {left: 15}, wait: {seconds: 0.2}, turn: {right: 15}]}}",
        ),
    )
    held, line, _ = wiggles["rest_in_zone dock"]
    assert not held and (line.endswith("still moving when its time ran out (60 s)") or "standing only" in line)


def test_how_hard_a_robot_hits_counts_a_crash_is_not_a_touch(dock):
    crash = verdicts(dock, "crash", "move: {speed: 4}")["max_collisions 0"]
    assert not crash[0] and crash[1].startswith("collisions faster than 150 mm/s: 1, allowed 0, the first at ")
    assert crash[1].endswith(" s at 427 mm/s, while move (line 3) was running")
    touch = verdicts(dock, "touch", "move: {speed: 1}")["max_collisions 0"]
    assert touch[0] and touch[1] == (
        "collisions faster than 150 mm/s: 0, allowed 0 (1 touch at 150 mm/s or slower not counted)"
    )


# ---------------------------------------------------------------- 2. a beep is a sound


def test_a_beep_at_volume_0_is_silent_and_no_beep(dock):
    to_dock = "move: {speed: 2, until_obstacle_mm: 60}"
    silent = verdicts(dock, "silent", f"sequence:\n  - {to_dock}\n  - beep: {{tones: [5, 7, 9], volume: 0}}")
    held, line, share = silent["beeps_in dock"]
    assert (
        not held
        and share == 0
        and line
        == (
            "no beep at any of them; none at dock; 0 extra beeps, allowed 0; 1 silent beep (volume 0) not counted "
            "at a zone"
        )
    )
    heard = verdicts(dock, "heard", f"sequence:\n  - {to_dock}\n  - beep: {{tones: [5, 7, 9], volume: 1}}")
    assert heard["beeps_in dock"][:2] == (True, "beeped at dock; 0 extra beeps, allowed 0")


def test_a_beep_can_be_asked_for_while_standing_there(dock):
    # driving through the checkpoint at speed 1 (107 mm/s), beeping half-way through it
    on_the_way = """
parallel:
  - move: {speed: 1, distance_mm: 1000}
  - sequence: [{wait: {seconds: 6.5}}, {beep: {tones: [5, 7, 9]}}]
"""
    held, line, _ = verdicts(dock, "on_the_way", on_the_way)["beep_near mid"]
    assert not held and line == (
        "beep at mid: no beep counted; 1 beep made while driving or turning not counted at a zone"
    )
    stopped = "sequence:\n  - move: {speed: 2, distance_mm: 700}\n  - beep: {tones: [5, 7, 9]}"
    held, line, _ = verdicts(dock, "stopped", stopped)["beep_near mid"]  # braking to a stop is standing
    assert held and line.startswith("beep at mid: beeped inside it at ")


# ---------------------------------------------------------------- 3. a collision is a contact


def _collisions(dock, name: str, tree: str):
    exercise, folder = dock
    path = folder / f"{name}.yaml"
    path.write_text(f"mission: {name}\ntree:\n" + "".join(f"  {line}\n" for line in tree.strip().splitlines()))
    spec, problems = check_submission(exercise, path, False)
    assert problems == []
    return run_seed(exercise, spec, exercise.seeds[0])


TOUCH_AND_BACK = """
repeat:
  times: 4
  do:
    sequence:
      - force_success: {do: {move: {speed: 1}}}
      - move: {speed: 1, direction: backward, distance_mm: %d}
"""


def test_touching_backing_off_a_little_and_touching_again_is_a_collision_each_time(dock):
    facts = _collisions(dock, "four_touches", TOUCH_AND_BACK % 15)  # 15 mm back: well within the old 30 mm
    assert len(facts.collisions) == 4 and len(facts.impacts) == 4
    assert all(90 < c.speed_mm_s < 110 for c in facts.collisions)  # speed 1: 107 mm/s, or just under
    held, line, _ = verdicts(dock, "four_touches", TOUCH_AND_BACK % 15)["max_collisions 3"]
    assert not held and line.startswith("collisions: 4, allowed 3, the first at ")


def test_pushing_on_against_the_wall_is_one_collision(dock):
    pushes = "repeat:\n  times: 4\n  do: {force_success: {do: {move: {speed: 1}}}}"  # to the wall, then on
    facts = _collisions(dock, "pushes", pushes)
    assert len(facts.impacts) >= 2 and len(facts.collisions) == 1  # impacts, but never clear of the wall
    assert facts.collisions[0].impacts == len(facts.impacts)


# ---------------------------------------------------------------- 5. what a text asks


def test_stopping_at_a_zone_on_the_way_is_a_stop_there_for_so_long(dock):
    pause = sequence(
        "move: {speed: 2, distance_mm: 700}", "wait: {seconds: 2}", "move: {speed: 2, until_obstacle_mm: 60}"
    )
    held, line, _ = verdicts(dock, "pause", pause)["stop_in_zone mid"]
    assert held and line.startswith("mid: stopped in it at ") and line.endswith(" s")
    through = verdicts(dock, "through", "move: {speed: 2, until_obstacle_mm: 60}")["stop_in_zone mid"]
    assert not through[0] and through[1].startswith("mid: never stopped in it; the nearest stop was ")
    brief = sequence("move: {speed: 2, distance_mm: 700}", "wait: {seconds: 0.3}", "move: {speed: 2, distance_mm: 300}")
    held, line, _ = verdicts(dock, "brief", brief)["stop_in_zone mid"]
    assert not held and line.startswith("mid: stood in it ") and line.endswith(" s at most (needed 1 s)")


def test_turning_round_at_a_zone_counts_there_only(dock):
    there = "sequence:\n  - move: {speed: 2, distance_mm: 700}\n  - turn: {left: 180}"
    held, line, _ = verdicts(dock, "round_there", there)["turns 180"]
    assert held and line == "turned left 180 ± 10 degrees at mid 1 time, needed 1"
    at_start = "sequence:\n  - turn: {left: 180}\n  - turn: {left: 180}\n  - move: {speed: 2, distance_mm: 700}"
    held, line, _ = verdicts(dock, "round_at_start", at_start)["turns 180"]
    assert not held and line == "turned left 180 ± 10 degrees at mid 0 times, needed 1"


def test_coming_to_rest_at_a_distance_from_what_is_ahead(dock):
    held, line, _ = verdicts(dock, "at_15cm", "move: {speed: 1, until_obstacle_mm: 160}")[
        "rest_distance_ahead_mm 100 200"
    ]
    assert (
        held
        and line.startswith("came to rest with ")
        and line.endswith(" mm ahead of its front (needed 100 to 200 mm)")
    )
    held, line, _ = verdicts(dock, "at_6cm", "move: {speed: 2, until_obstacle_mm: 60}")[
        "rest_distance_ahead_mm 100 200"
    ]
    assert not held
    held, line, _ = verdicts(dock, "rammed", "move: {speed: 4}")[AHEAD]
    assert not held and line.startswith("came to rest with 0 mm ahead")


def test_using_the_front_sensor_is_a_node_that_reads_it_in_the_tree(dock):
    sensed = verdicts(dock, "sensed", "move: {speed: 2, until_obstacle_mm: 60}")[
        "uses_nodes obstacle_within move.until_obstacle_mm"
    ]
    assert sensed[:2] == (True, "uses move.until_obstacle_mm")
    counted = verdicts(dock, "counted", "move: {speed: 2, distance_mm: 1500}")[
        "uses_nodes obstacle_within move.until_obstacle_mm"
    ]
    assert counted[:2] == (False, "uses none of obstacle_within or move.until_obstacle_mm (needed one)")


@pytest.mark.parametrize(
    ("criterion", "message"),
    [
        ("uses_nodes: [subtree]", "a subtree is its steps when graded: name the nodes its steps use"),
        (
            "max_collisions: 0\n  - max_collisions: 0",
            "the same criterion as criteria[0] ('max_collisions 0'): give it once",
        ),
        ("uses_nodes: [obstacle_withn]", "unknown node type 'obstacle_withn' (did you mean 'obstacle_within'?)"),
        (
            "uses_nodes: [move.until_obstacle]",
            "move has no parameter 'until_obstacle' (did you mean 'until_obstacle_mm'?)",
        ),
        ("rest_distance_ahead_mm: [200, 100]", "the nearer distance first: [100, 200]"),
        ("rest_distance_ahead_mm: 150", "expected two distances in mm, the nearer first, e.g. [100, 200]"),
        ("beep_near: mid\n    standing: yes please", "standing takes true or false, got 'yes please'"),
        ("turns: 180\n    at: middle", "world 'dock' has no zone 'middle' (did you mean 'mid'?)"),
        ("turns: 360", "criteria[0].turns: must be from -180 to 180, got 360"),  # a whole turn is no change
        ("turns: 8", "a turn of 8 ± 10 degrees would count a robot that never turned"),
        ("turns: 30\n    tolerance_deg: 30", "a turn of 30 ± 30 degrees would count a robot that never turned"),
        ("end_heading_deg: 0\n    tolerance_deg: 100000", "tolerance_deg: must be from 0 to 90, got 100000"),
        ("stop_in_zone: mid\n    for_s: 0", "for_s: must be from 0.05 to 3,600, got 0"),
    ],
)
def test_the_new_criteria_are_checked_at_their_place(dock, criterion, message):
    _, folder = dock
    path = folder / "bad.yaml"
    path.write_text(EXERCISE.split("criteria:")[0] + f"criteria:\n  - {criterion}\n")
    with pytest.raises(ExerciseInvalid) as caught:
        load_exercise(path)
    assert message in str(caught.value) and f"{path}:" in str(caught.value)


def test_the_shipped_solutions_make_their_stops_and_beeps_by_themselves(dock):
    """The facts a shipped solution gives: its rest by itself, its beeps sounded, no contact it did not mean."""
    from autonomy.classroom import load_exercise as load

    root = Path(__file__).resolve().parents[2] / "exercises"
    for name in ("square", "garage", "slalom", "opening"):
        exercise = load(root / f"{name}.yaml")
        spec, _ = check_submission(exercise, root / "solutions" / f"{name}.yaml", False)
        facts = run_seed(exercise, spec, exercise.seeds[0])
        assert facts.rest_by_itself and facts.collisions == [] and all(b.audible for b in facts.beeps), name


# ---------------------------------------------------------------- feedback that names the node


def test_a_lost_mark_names_the_node_that_was_running_when_it_was_lost(dock):
    named = sequence(
        "move: {speed: 2, distance_mm: 700, name: to the middle}",
        "move: {speed: 4, name: to the end}",
    )
    lines = {label: line for label, (_, line, _) in verdicts(dock, "named", named).items()}
    assert lines["max_collisions 0"].endswith(" at 427 mm/s, while 'to the end' (move, line 5) was running")
    assert lines["rest_in_zone dock"].endswith("; it got there while 'to the end' (move, line 5) was running")
    out_of_time = sequence("move: {speed: 2, distance_mm: 700}", "wait: {seconds: 100, name: forever}")
    finish = verdicts(dock, "slow", out_of_time)["finish_within_s 20"][1]
    assert finish.startswith("did not succeed (stopped at the time limit after 60.0 s") and finish.endswith(
        "), while 'forever' (wait, line 5) was running"
    )


def test_a_robot_let_go_at_speed_names_the_mission_s_last_node_and_says_it_ended_too_soon():
    from autonomy.classroom import load_exercise as load

    root = Path(__file__).resolve().parents[2] / "exercises"
    exercise = load(root / "garage.yaml")
    (seed, *_) = grade_one(exercise, "fast", root / "wrong" / "garage_full_speed.yaml").seeds
    lines = dict(zip([c.label for c in exercise.criteria], [line for _, line in seed.verdicts], strict=True))
    assert lines["max_collisions 0"] == (
        "collisions: 1, allowed 0, the first at 4.6 s at 210 mm/s, while move until < 60 mm (line 8) was running: "
        "the mission ended before the robot could stop"
    )


# ---------------------------------------------------------------- from a review's attack on the above


def test_a_stop_the_wall_made_or_the_time_limit_forced_is_no_stop(dock):
    rammed = verdicts(dock, "rammed_still", sequence("force_success: {do: {move: {speed: 4}}}", "wait: {seconds: 3}"))
    assert not rammed["stop_in_zone mid"][0]
    exercise, folder = dock
    (folder / "dockstop.yaml").write_text(EXERCISE.split("criteria:")[0] + "criteria:\n  - stop_in_zone: dock\n")
    stop_dock = load_exercise(folder / "dockstop.yaml")
    (folder / "rams2.yaml").write_text("mission: rams2\ntree:\n  move: {speed: 4}\n")
    (seed,) = grade_one(stop_dock, "rams2", folder / "rams2.yaml").seeds
    assert seed.verdicts[0][0] is False  # at rest in the dock, but only where the wall stopped it
    spin = sequence("move: {speed: 2, until_obstacle_mm: 160}", "repeat: {do: {turn: {left: 90}}}")
    spun = verdicts(dock, "spin", spin)
    assert spun[AHEAD][:2] == (False, "the robot was still moving when its time ran out (60 s)")


def test_the_node_named_is_the_one_that_drove_whatever_the_tick_rate_and_however_the_mission_ended(dock):
    exercise, folder = dock
    for hz in (7, 20, 200):
        path = folder / f"hz{hz}.yaml"
        path.write_text(
            f"mission: hz{hz}\ntick_hz: {hz}\ntree:\n  sequence:\n"
            "    - force_success: {do: {move: {speed: 4, name: into the wall}}}\n"
            "    - wait: {seconds: 1, name: after the hit}\n"
        )
        (seed,) = grade_one(exercise, f"hz{hz}", path).seeds
        assert seed.verdicts[1][1].endswith(", while 'into the wall' (move, line 5) was running"), (
            hz,
            seed.verdicts[1],
        )
    rolled = sequence("move: {speed: 4, distance_mm: 1600, name: to the wall}", "log: {message: done}")
    line = verdicts(dock, "rolled", rolled)["max_collisions 0"][1]
    assert line.endswith(
        ", while 'to the wall' (move, line 4) was running: the mission ended before the robot could stop"
    )


def test_a_parameter_at_its_default_is_not_one_given(dock):
    lines = verdicts(dock, "bare", sequence("move: {speed: 2, distance_mm: 300}", "beep"))
    (folder := dock[1] / "params.yaml").write_text(
        EXERCISE.split("criteria:")[0] + "criteria:\n  - uses_nodes: [move.direction, beep.volume]\n"
    )
    (seed,) = grade_one(load_exercise(folder), "bare", dock[1] / "bare.yaml").seeds
    assert seed.verdicts[0] == (False, "uses none of move.direction or beep.volume (needed one)")
    assert lines[SENSOR][0] is False


def test_beeps_made_while_driving_still_count_against_the_extra_beeps(dock):
    exercise, folder = dock
    (folder / "spam.yaml").write_text(
        EXERCISE.split("criteria:")[0] + "criteria:\n  - beeps_in: [dock]\n    standing: true\n"
    )
    spam = sequence(
        "parallel: [{move: {speed: 1, distance_mm: 1200}}, "
        "{repeat: {times: 10, do: {sequence: [{wait: {seconds: 0.5}}, beep]}}}]",
        "move: {speed: 2, until_obstacle_mm: 60}",
        "beep",
    )
    (folder / "spammer.yaml").write_text("mission: spammer\ntree:\n" + "".join(f"  {x}\n" for x in spam.splitlines()))
    (seed,) = grade_one(load_exercise(folder / "spam.yaml"), "spammer", folder / "spammer.yaml").seeds
    held, line = seed.verdicts[0]
    assert not held and line.startswith("beeped at dock; 10 extra beeps, allowed 0: no points for beeps")


def test_criteria_alike_but_for_an_option_are_labelled_with_it(dock):
    _, folder = dock
    (folder / "two.yaml").write_text(
        EXERCISE.split("criteria:")[0]
        + "criteria:\n  - turns: 180\n    at: mid\n  - turns: 180\n    at: dock\n  - beep_near: mid\n"
        "  - beep_near: mid\n    standing: true\n"
    )
    labels = [c.label for c in load_exercise(folder / "two.yaml").criteria]
    assert labels == ["turns 180 at mid", "turns 180 at dock", "beep_near mid", "beep_near mid standing"]


def test_a_mission_with_a_plugin_s_node_is_graded_when_plugins_are_allowed():
    """The tree's nodes are read for uses_nodes: a plugin's node, which the built-in registry lacks, among them."""
    root = Path(__file__).resolve().parents[2]
    exercise = load_exercise(root / "exercises" / "opening.yaml")
    report = grade_one(exercise, "explore", root / "missions" / "explore.yaml", allow_plugins=True)
    assert report.problems == [] and len(report.seeds) == len(exercise.seeds)


def test_a_node_s_long_name_is_clipped_in_a_verdict_line(dock):
    long_name = "x" * 1000
    line = verdicts(dock, "long_name", f"move: {{speed: 4, name: {long_name}}}")["max_collisions 0"][1]
    assert line.endswith(f", while '{'x' * 59}…' (move, line 3) was running") and len(line) < 200


# ---------------------------------------------------------------- 4. no single miss zeroes the rest

SHIPPED = Path(__file__).resolve().parents[2] / "exercises"
SECOND_CLASS = Path(__file__).resolve().parent / "second_class"


def test_one_miss_costs_what_depends_on_it_not_every_other_point(tmp_path):
    short = SECOND_CLASS / "open_short.yaml"  # through the opening cleanly, then 13 cm short of the goal
    report = grade_one(load_exercise(SHIPPED / "opening.yaml"), "open_short", short)
    assert report.marks == [2, 0, 2, 2] and report.total == 6  # the goal's points, nothing else
    # gated on the goal instead, all or nothing, the same robot would keep only "through the opening"
    gated = (SHIPPED / "opening.yaml").read_text().replace("requires: reach_zone", "requires_all: rest_in_zone")
    (tmp_path / "gated.yaml").write_text(gated.replace("solution: solutions/opening.yaml", ""))
    report = grade_one(load_exercise(tmp_path / "gated.yaml"), "open_short", short)
    assert report.total == 2
    line = report.seeds[0].verdicts[2][1]
    assert line == "collisions: 0, allowed 0, but this counts only with Stopped in the goal, which did not hold"


def _dock_variant(dock, near: str) -> object:
    exercise, folder = dock
    (folder / "near.yaml").write_text(EXERCISE.replace("  - rest_in_zone: dock\n", f"  - rest_in_zone: dock\n{near}"))
    return load_exercise(folder / "near.yaml"), folder


@pytest.mark.parametrize(("near", "scale_mm"), [("", 100.0), ("    near_mm: 200\n", 200.0), ("    near_mm: 0\n", 0.0)])
def test_a_zone_missed_by_a_little_earns_a_part_on_the_teacher_s_scale(dock, near, scale_mm):
    short = verdicts(_dock_variant(dock, near), "short", "move: {speed: 2, distance_mm: 1350}")
    held, line, share = short["rest_in_zone dock"]
    gap_mm = float(line.split("came to rest ")[1].split(" mm outside")[0])
    assert not held and 30 <= gap_mm <= 70  # about 5 cm west of the dock
    assert share == pytest.approx(max(0.0, 1 - gap_mm / scale_mm) if scale_mm else 0.0, abs=0.01)
    if scale_mm:
        assert f"of its points, for resting within {scale_mm:g} mm of it, clear of all" in line
    # what requires it earns that same part
    assert short["finish_within_s 20"][2] == pytest.approx(1.0)  # requires nothing here


def test_a_near_miss_against_a_wall_earns_nothing_and_a_bump_backed_off_from_is_no_bar(tmp_path):
    rammed = tmp_path / "rammed.yaml"  # a fixed 2.4 m: into the end wall on seed 8, 4 cm past the garage
    rammed.write_text("mission: rammed\ntree:\n  move: {speed: 2, distance_mm: 2400}\n")
    garage = load_exercise(SHIPPED / "garage.yaml")
    seed = grade_one(garage, "rammed", rammed).seeds[0]
    assert seed.shares[0] == 0 and "at rest clear of walls and obstacles" in seed.verdicts[0][1]
    bump = load_exercise(SHIPPED / "bump.yaml")  # bumps the box as asked, backs off, stops 48 mm short
    report = grade_one(bump, "bump_short", SECOND_CLASS / "bump_short.yaml")
    assert all(s.shares[1] == pytest.approx(0.52, abs=0.01) for s in report.seeds)
    assert all(s.shares[3] == s.shares[1] for s in report.seeds)  # the time, in the goal's part
    assert report.marks[0] == 2 and report.marks[2] == 1  # the bump, and only that one

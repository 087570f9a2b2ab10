"""Exercises graded on the emulator: references score full marks, wrong solutions lose marks for the right reason."""

import dataclasses
import json
import os
import re
import signal
import time
from pathlib import Path

import pytest

from autonomy.classroom import ExerciseInvalid, find_submissions, grade_class, grade_one, limits, load_exercise, pool
from autonomy.classroom.job import PLUGINS_REFUSED
from autonomy.classroom.report import feedback, to_csv, to_html, to_json
from tests.classroom.fixed_plans import FIXED_PLANS

ROOT = Path(__file__).resolve().parents[2]
EXERCISES = ROOT / "exercises"
SHIPPED = ("square", "garage", "slalom", "bump", "opening")

#: For each wrong solution: the criteria it must lose marks on, and those it keeps in full.
WRONG = {
    "square_turns_right": (
        {"visit_in_order corner_1 corner_2 corner_3", "beeps_in corner_1 corner_2 corner_3 home", "rest_in_zone home"},
        set(),
    ),
    "square_no_beeps": (
        {"beeps_in corner_1 corner_2 corner_3 home"},
        {"visit_in_order corner_1 corner_2 corner_3", "rest_in_zone home"},
    ),
    "square_mid_side_beeps": (
        {"beeps_in corner_1 corner_2 corner_3 home"},
        {"visit_in_order corner_1 corner_2 corner_3", "rest_in_zone home"},
    ),
    "square_beep_spam": (
        {"beeps_in corner_1 corner_2 corner_3 home"},
        {"visit_in_order corner_1 corner_2 corner_3", "rest_in_zone home"},
    ),
    "square_triangle": ({"visit_in_order corner_1 corner_2 corner_3", "rest_in_zone home"}, set()),
    "square_turns_85": ({"rest_in_zone home"}, {"visit_in_order corner_1 corner_2 corner_3"}),
    "garage_fixed_distance": ({"rest_in_zone garage"}, set()),
    "garage_until_bump": ({"rest_in_zone garage", "max_collisions 0"}, set()),
    "garage_full_speed": ({"rest_in_zone garage", "max_collisions 0"}, set()),
    "garage_park_then_beep": ({"finish_within_s 30"}, {"rest_in_zone garage", "max_collisions 0"}),
    "slalom_straight": ({"rest_in_zone exit", "reach_zone past_post"}, set()),
    "slalom_blind": ({"rest_in_zone exit", "max_collisions 0"}, set()),
    "slalom_stops_short": ({"rest_in_zone exit"}, {"reach_zone past_post", "max_collisions 0"}),
    "bump_push": ({"rest_in_zone goal", "finish_within_s 60"}, {"min_collisions 1"}),
    "bump_no_return": ({"rest_in_zone goal"}, {"min_collisions 1"}),
    "opening_straight": ({"rest_in_zone goal"}, set()),
    "opening_fixed": ({"rest_in_zone goal"}, set()),
}

#: A class of tricks, graded by hand first: what a fair teacher gives each out of 10, and why. The tool
#: must give each within one point of it (on the exercise's public seeds, with default options).
FAIR = {
    # square: the corners in order 3, a beep at each corner and home 2, home for good having made the
    # square's left turns 3, no collision 1, ending on its own 1 (these two only with every corner).
    "square_mid_side_beeps": 7,  # the square and home are right; no beep is where it was asked
    "square_beep_spam": 7,  # 20 beeps, one every 10 cm, "so one is at a corner": the beeps say nothing
    "square_triangle": 4.5,  # two corners of three and their beeps; a triangle is not the square asked for
    "square_turns_85": 6,  # the corners and their beeps, untouched, on time; the square does not close at home
    "square_turned_first": 4,  # a square, beeping and back home, but on the wrong side: one corner of three
    "square_turns_right": 2,  # a square the wrong way round: corner 1 only, beeps elsewhere, home after no square
    "square_back_and_forth": 4,  # corners 1 and 2, then back home the way it came: corner 3 never
    "square_beeps_at_home": 0.5,  # beeps four times where it starts and never moves
    "square_no_beeps": 8,  # the square right, no beep at all
    "square_one_spoke": 2,  # out to corner 3 and back, beeping at both: no square, so nothing for home
    "square_two_spokes": 3,  # out to corner 1 and back, out to corner 3 and back: two corners, no square
    "square_then_spin": 6.5,  # the square right, then spins at home until the time runs out
    "square_tiny_turns": 2,  # four quarter-turns nudged in a tiny square at home, then out to corner 3 and back
    # garage: parked for good 5, no collision 3, ending on its own 2 (the last two only for one that parked)
    "garage_fixed_distance": 3,  # right only on the seeds whose hall happens to be that long
    "garage_park_then_beep": 7,  # parks perfectly and stays, then beeps once a second: it never ends
    "garage_full_speed": 1,  # reached the garage but rolled on into the wall after the mission ended
    "garage_until_bump": 0.5,  # drives into the wall every time
    "garage_stops_short": 7.5,  # stops a centimetre or so before the garage, touching nothing: a near miss
    # bump: a bump into the box 2, at rest in the goal 5, exactly one bump 1, ending on its own 2 (in the goal)
    "bump_push": 3,  # bumps and goes on pushing the box: the bump, nothing else
    "bump_no_return": 3,  # bumps, backs off, goes round, but never comes back to the goal
    "bump_wall_behind": 7,  # backs into the wall for its bump, then goes round the box it never touched
    "bump_last": 8,  # goes round with the sensor, then bumps the box's far side: the bump found nothing
    "bump_feel_along": 8.5,  # feels along the box's face, bumping it every 2 cm, then goes round: five collisions
    # opening: through the opening 2, at rest in the goal 4, no collision 2 and ending on its own 2 once through
    "opening_fixed": 2,  # a fixed distance north: through the opening on the odd seed, into the wall on the rest
    "opening_straight": 0,  # straight ahead into the wall
    # slalom: past the post 2, at rest in the exit 4, no collision 2 and ending on its own 2 once past
    "slalom_stops_short": 6,  # past the post untouched, then stops 70 cm before the exit
    "slalom_straight": 0.5,  # stops safely in front of the post: never past it
    "slalom_blind": 0,  # straight into the post
}


def marks_by_label(exercise, report):
    return {c.label: (mark, c.points) for c, mark in zip(exercise.criteria, report.marks, strict=True)}


@pytest.mark.parametrize("name", SHIPPED)
def test_the_reference_solution_scores_full_marks_on_every_seed(name):
    exercise = load_exercise(EXERCISES / f"{name}.yaml")
    assert len(exercise.seeds) >= 3 and exercise.description
    report = grade_one(exercise, name, EXERCISES / "solutions" / f"{name}.yaml")
    assert report.problems == []
    failing = [(s.seed, line) for s in report.seeds for held, line in s.verdicts if not held]
    assert failing == [] and report.total == exercise.max_points


@pytest.mark.parametrize("wrong", sorted(WRONG))
def test_a_wrong_solution_loses_marks_for_the_right_reason(wrong):
    name = wrong.split("_")[0]
    exercise = load_exercise(EXERCISES / f"{name}.yaml")
    report = grade_one(exercise, wrong, EXERCISES / "wrong" / f"{wrong}.yaml")
    assert report.problems == []
    marks = marks_by_label(exercise, report)
    must_lose, must_keep = WRONG[wrong]
    for label in must_lose:
        mark, points = marks[label]
        assert mark < points, (label, [s.verdicts for s in report.seeds])
    for label in must_keep:
        mark, points = marks[label]
        assert mark == points, (label, [s.verdicts for s in report.seeds])
    assert report.total < exercise.max_points


def test_a_class_of_tricks_scores_what_a_fair_teacher_gives_within_one_point():
    marks = {}
    for name in FAIR:
        exercise = load_exercise(EXERCISES / f"{name.split('_')[0]}.yaml")
        report = grade_one(exercise, name, EXERCISES / "wrong" / f"{name}.yaml")
        assert report.problems == [] and exercise.max_points == 10, name
        marks[name] = report.total
    far = {name: (marks[name], fair) for name, fair in FAIR.items() if abs(marks[name] - fair) > 1}
    assert far == {}, marks


#: A second class, of tricks and slips none of the above names, written and marked by hand by a teacher who
#: read only the exercises' texts and saw what really happened on each public seed (where the robot went,
#: what it hit and when, where it came to rest), never the grader's marks.
#: The second class's bands, each student's fair mark give or take a point, written (with why) before grading.
SECOND_CLASS = Path(__file__).parent / "second_class" / "expected.csv"
EXERCISE_OF = {"sq": "square", "gar": "garage", "bump": "bump", "open": "opening", "sl": "slalom"}


def test_a_second_class_marked_by_hand_is_within_the_bands_written_first():
    """As autonomy grade --expect says it, exercise by exercise: no student outside their band."""
    from autonomy.classroom.gradebook import outside_bands, read_expected

    bands = read_expected(SECOND_CLASS)
    outside = []
    for short, name in EXERCISE_OF.items():
        exercise = load_exercise(EXERCISES / f"{name}.yaml")
        students = [student for student in bands if student.split("_")[0] == short]
        reports = [grade_one(exercise, s, SECOND_CLASS.parent / f"{s}.yaml") for s in students]
        assert [r.problems for r in reports] == [[]] * len(reports), name
        told = outside_bands(exercise, reports, {s: bands[s] for s in students})
        assert told[-1].endswith(f" of {len(students)} students within the band expected")
        outside += told[:-1]
    assert len(bands) == 26 and outside == []


#: A third class, written blind: by a teacher who read the docs and the exercises' texts alone (never the grader's
#: code, its tests or its marks), ten students each for garage, bump and an exercise of their own (deliver, in a
#: world of their own), tricks of each principle among them; the bands (with why) written, and their SHA-256 kept,
#: before any was graded. All 30 were within their bands at their first grading.
BLIND_CLASS = Path(__file__).parent / "blind_class"


def test_a_class_written_blind_is_within_the_bands_written_first_on_the_shipped_exercises_and_the_teacher_s_own():
    from autonomy.classroom.gradebook import outside_bands, read_expected

    bands = read_expected(BLIND_CLASS / "expected.csv")
    outside = []
    for short, path in (
        ("g", EXERCISES / "garage.yaml"),
        ("b", EXERCISES / "bump.yaml"),
        ("w", BLIND_CLASS / "deliver.yaml"),
    ):
        exercise = load_exercise(path)
        students = [student for student in bands if student.split("_")[0] == short]
        reports = [grade_one(exercise, s, BLIND_CLASS / f"{s}.yaml") for s in students]
        assert [r.problems for r in reports] == [[]] * len(reports), path.name
        told = outside_bands(exercise, reports, {s: bands[s] for s in students})
        assert told[-1].endswith(f" of {len(students)} students within the band expected")
        outside += told[:-1]
    assert len(bands) == 30 and outside == []


def test_every_wrong_file_says_what_a_fair_teacher_gives_it():
    """The tricks shipped in exercises/wrong/ carry their fair mark, the one the test above holds the tool to."""
    for name, fair in FAIR.items():
        text = " ".join((EXERCISES / "wrong" / f"{name}.yaml").read_text(encoding="utf-8").split())
        said = re.search(r"A fair mark: (\d+)(?:/10| or (\d+) out of 10)", text)
        assert said is not None, name
        assert float(said.group(1)) <= fair <= float(said.group(2) or said.group(1)), (name, fair, said.group(0))


def test_a_node_type_the_exercise_does_not_allow_is_refused_where_it_stands():
    exercise = load_exercise(EXERCISES / "square.yaml")
    path = EXERCISES / "wrong" / "square_wander.yaml"
    report = grade_one(exercise, "wander", path)
    assert report.total == 0 and report.seeds == []
    assert report.problems[0].startswith(f"{path}:5:3: tree.selector: 'selector' is not allowed in this exercise")
    assert any(": tree.selector[0].collided: 'collided' is not allowed" in p for p in report.problems)


def test_an_invalid_mission_scores_zero_and_its_report_is_its_errors(tmp_path):
    exercise = load_exercise(EXERCISES / "garage.yaml")
    path = tmp_path / "carol.yaml"
    path.write_text("mission: oops\ntree:\n  mvoe: {speed: 2}\n")
    report = grade_one(exercise, "carol", path)
    assert report.total == 0
    assert report.problems == [f"{path}:3:3: tree.mvoe: unknown node 'mvoe' (did you mean 'move'?)"]
    assert "  Not graded, and the mark is 0:" in feedback(exercise, report)


def test_plugins_are_refused_before_anything_of_them_is_imported(tmp_path):
    exercise = load_exercise(EXERCISES / "garage.yaml")
    marker = tmp_path / "imported"
    (tmp_path / "evil.py").write_text(f"open({str(marker)!r}, 'w').write('ran')\n")
    path = tmp_path / "dave.yaml"
    path.write_text("mission: sneaky\nplugins: [evil]\ntree:\n  move: {speed: 2, until_obstacle_mm: 150}\n")
    report = grade_one(exercise, "dave", path)
    assert report.total == 0 and "unless the teacher allows them" in report.problems[0]
    assert report.problems[0].startswith(f"{path}:2:10: plugins")
    assert not marker.exists()


def test_a_node_of_a_refused_plugin_is_said_to_be_one_and_a_likely_typo_gets_its_hint_too(tmp_path):
    exercise = load_exercise(EXERCISES / "square.yaml")
    (tmp_path / "beh.py").write_text("raise SystemExit('imported')\n")
    path = tmp_path / "eve.yaml"
    path.write_text("mission: t\nplugins: [beh]\ntree:\n  sequence:\n    - drive_square\n    - sequnce: []\n")
    report = grade_one(exercise, "eve", path)
    assert report.problems == [
        f"{path}:2:10: plugins: {PLUGINS_REFUSED}",
        f"{path}:5:7: tree.sequence[0]: 'drive_square' is no built-in node: if a plugin of yours defines it, "
        "plugins are not run here",
        f"{path}:6:7: tree.sequence[1].sequnce: 'sequnce' is no built-in node (did you mean 'sequence'?): if a plugin "
        "of yours defines it, plugins are not run here",
    ]


@pytest.mark.parametrize("name", ["mission.yaml", "mission.xml"])
def test_plugins_named_in_a_behaviortree_xml_submission_are_refused_too(tmp_path, name):
    """A submission may be BehaviorTree.CPP XML, whatever its name: its ``_plugins`` are refused as ``plugins:`` are."""
    exercise = load_exercise(EXERCISES / "garage.yaml")
    marker = tmp_path / "imported"
    (tmp_path / "p.py").write_text(f"open({str(marker)!r}, 'w').write('ran')\n")
    path = tmp_path / name
    path.write_text(
        '<?xml version="1.0" encoding="UTF-8"?>\n<root BTCPP_format="4" main_tree_to_execute="x">\n'
        '  <BehaviorTree ID="x" _plugins="p"><move speed="2" until_obstacle_mm="150"/></BehaviorTree>\n</root>\n'
    )
    report = grade_one(exercise, "mallory", path)
    assert report.total == 0 and not marker.exists()
    assert any(p.startswith(f"{path}:3:") and "unless the teacher allows them" in p for p in report.problems)


def endless_plugin(folder: Path) -> Path:
    (folder / "spin.py").write_text(
        "import py_trees\nfrom autonomy.behaviours import RobotAction\n\n"
        "class Spin(RobotAction):\n"
        '    """Never returns."""\n\n'
        "    node_type = 'spin'\n\n"
        "    def update(self):\n"
        "        while True:\n"
        "            pass\n"
    )
    path = folder / "mission.yaml"
    path.write_text("mission: spin\nplugins: [spin]\ntree:\n  spin: {}\n")
    return path


def test_an_endless_loop_or_a_crash_costs_that_student_a_zero_never_the_batch(tmp_path):
    exercise = load_exercise(EXERCISES / "garage.yaml")
    (tmp_path / "erin").mkdir()
    endless_plugin(tmp_path / "erin")
    (tmp_path / "frank").mkdir()
    (tmp_path / "frank" / "boom.py").write_text("import os\nos._exit(9)\n")
    (tmp_path / "frank" / "mission.yaml").write_text("mission: boom\nplugins: [boom]\ntree:\n  wait: {seconds: 1}\n")
    good = EXERCISES / "solutions" / "garage.yaml"
    submissions = find_submissions([tmp_path / "erin", tmp_path / "frank", good])
    assert [s for s, _ in submissions] == ["erin", "frank", "garage"]
    pages = tmp_path / "pages"
    pages.mkdir()
    reports = grade_class(exercise, submissions, workers=2, cpu_s=2, allow_plugins=True, feedback=pages)
    erin, frank, garage = reports
    assert erin.total == 0 and erin.problems == [
        "used more than 2 s of CPU time: an endless loop, or a tree too big to run in time (--cpu-seconds gives more)"
    ]
    assert frank.total == 0 and "ended without a report (exit code 9)" in frank.problems[0]
    assert garage.total == exercise.max_points
    # each gets a page: the two whose workers made none are told why by the grader
    assert sorted(page.name for page in pages.iterdir()) == ["erin.html", "frank.html", "garage.html"]
    assert "used more than 2 s of CPU time" in (pages / "erin.html").read_text()
    assert "ended without a report (exit code 9)" in (pages / "frank.html").read_text()


def heavy_mission(checks: int) -> str:
    """The garage's solution behind ``checks`` conditions made again every tick, at 200 Hz: valid, and slow to run."""
    made_again = "".join("            - invert: {do: collided}\n" for _ in range(checks))
    return (
        "mission: heavy\ntick_hz: 200\ntree:\n  sequence:\n    memory: false\n    children:\n"
        f"      - sequence:\n          memory: false\n          children:\n{made_again}"
        "      - move: {speed: 2, until_obstacle_mm: 150}\n"
    )


def test_heavy_missions_get_the_same_marks_from_one_worker_as_from_four_on_two_cores(tmp_path):
    # Each takes about 1.4 s of CPU time here (a third of the limit: a busy machine's CPU time grows a
    # little too). The grader and its workers are held to one core, as four workers on a busy two-core
    # machine are: four at once take 5 s or more of wall time each, so under a limit of 4 s of wall
    # time all would score 0 with four workers and 10 with one. CPU time does not grow while a worker
    # waits for a core.
    exercise = load_exercise(EXERCISES / "garage.yaml")
    for name in ("ann", "ben", "cat", "dan"):
        (tmp_path / f"{name}.yaml").write_text(heavy_mission(25))
    submissions = find_submissions(sorted(tmp_path.glob("*.yaml")))
    cores = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(cores)})  # the workers, forked, keep it
    try:
        one = grade_class(exercise, submissions, workers=1, cpu_s=4)
        four = grade_class(exercise, submissions, workers=4, cpu_s=4)
    finally:
        os.sched_setaffinity(0, cores)
    assert to_json(exercise, one) == to_json(exercise, four)
    assert [report.total for report in one] == [exercise.max_points] * 4


def test_a_plugin_that_keeps_the_end_of_its_cpu_time_to_itself_is_ended_all_the_same(tmp_path):
    exercise = load_exercise(EXERCISES / "garage.yaml")
    (tmp_path / "kim").mkdir()
    (tmp_path / "kim" / "keep.py").write_text(
        "from autonomy.behaviours import RobotAction\n\n"
        "class Keep(RobotAction):\n"
        '    """Swallows whatever it is told, and goes on."""\n\n'
        "    node_type = 'keep'\n\n"
        "    def update(self):\n"
        "        while True:\n"
        "            try:\n"
        "                while True:\n"
        "                    pass\n"
        "            except BaseException:\n"
        "                pass\n"
    )
    (tmp_path / "kim" / "mission.yaml").write_text("mission: keep\nplugins: [keep]\ntree:\n  keep: {}\n")
    submissions = find_submissions([tmp_path / "kim", EXERCISES / "solutions" / "garage.yaml"])
    garage, kim = grade_class(exercise, submissions, workers=2, cpu_s=1, wall_s=60, allow_plugins=True)
    assert kim.total == 0 and kim.problems == [
        "used more than 1 s of CPU time: an endless loop, or a tree too big to run in time (--cpu-seconds gives more)"
    ]
    assert garage.total == exercise.max_points


def test_what_a_plugin_starts_has_about_the_same_cpu_time(tmp_path):
    # A plugin that waits on a busy process of its own uses no CPU time itself: the process it
    # started has its own limit, inherited, and ends with SIGXCPU (or SIGKILL) when it is used up.
    (tmp_path / "one_seed.yaml").write_text(
        "world: garage\ntime_limit_s: 30\nseeds: [1]\ncriteria:\n  - succeed: true\n"
    )
    exercise = load_exercise(tmp_path / "one_seed.yaml")
    (tmp_path / "lou").mkdir()
    said = tmp_path / "child.txt"
    (tmp_path / "lou" / "busy.py").write_text(
        "import subprocess, sys\nfrom autonomy.behaviours import RobotAction\n\n"
        "class Busy(RobotAction):\n"
        '    """Waits on a process that never stops working."""\n\n'
        "    node_type = 'busy'\n\n"
        "    def update(self):\n"
        "        ended = subprocess.run([sys.executable, '-c', 'while True: pass'])\n"
        f"        open({str(said)!r}, 'w').write(str(ended.returncode))\n"
        "        raise RuntimeError('its process ended')\n"
    )
    (tmp_path / "lou" / "mission.yaml").write_text("mission: busy\nplugins: [busy]\ntree:\n  busy: {}\n")
    [lou] = grade_class(exercise, find_submissions([tmp_path / "lou"]), cpu_s=1, wall_s=60, allow_plugins=True)
    assert said.read_text() in (str(-signal.SIGXCPU), str(-signal.SIGKILL))
    assert lou.total == 0 and not lou.problems  # graded: the mission crashed on every seed


def test_grading_twice_writes_the_same_bytes():
    exercise = load_exercise(EXERCISES / "garage.yaml")
    files = [EXERCISES / "solutions" / "garage.yaml", EXERCISES / "wrong" / "garage_fixed_distance.yaml"]
    first = grade_class(exercise, find_submissions(files), workers=2)
    second = grade_class(exercise, find_submissions(reversed(files)), workers=1)
    assert to_json(exercise, first) == to_json(exercise, second)
    assert to_csv(exercise, first) == to_csv(exercise, second)
    assert to_html(exercise, first) == to_html(exercise, second)
    rows = to_csv(exercise, first).splitlines()
    assert rows[0] == (
        "student,total,out_of,rest_in_zone garage,max_collisions 0,finish_within_s 30,reach_zone garage,adjustment,"
        "adjustment_reasons,problems"
    )
    assert rows[1].startswith("garage,10,10,5,3,2,0,0,,")
    assert rows[2].startswith("garage_fixed_distance,2.5,10,1.25,0.75,0.5,")
    document = json.loads(to_json(exercise, first))
    assert [s["student"] for s in document["students"]] == ["garage", "garage_fixed_distance"]


def test_the_json_lists_every_collision_beep_and_turn_with_its_time_and_place():
    exercise = load_exercise(EXERCISES / "bump.yaml")
    report = grade_one(exercise, "bump", EXERCISES / "solutions" / "bump.yaml")
    seed = json.loads(to_json(exercise, [report]))["students"][0]["seeds"][0]
    assert len(seed["collisions"]) == 1 and len(seed["turns"]) == 4 and seed["beeps"] == []
    (time_s, x, y, speed), box = seed["collisions"][0], exercise.world.for_seed(exercise.seeds[0].seed).obstacles[0]
    assert 0 < time_s < seed["time_s"] and box.gap(x, y) == pytest.approx(60, abs=1)  # touching the box's west face
    assert 0 < speed <= 430  # how hard it hit, mm/s: at most the fastest drive
    assert [turn[3] for turn in seed["turns"]] == pytest.approx([90, -90, -90, 90], abs=3)  # left, right, right, left
    assert seed["world_seed"] == exercise.seeds[0].seed and seed["rest_s"] <= exercise.time_limit_s
    square = load_exercise(EXERCISES / "square.yaml")
    beeps = json.loads(to_json(square, [grade_one(square, "s", EXERCISES / "solutions" / "square.yaml")]))
    assert len(beeps["students"][0]["seeds"][0]["beeps"]) == 4


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "world: garage\ntime_limit_s: 30\nseeds: [1]\ncriteria:\n  - max_colisions: 0\n",
            "5:5: criteria[0].max_colisions: unknown criterion 'max_colisions' (did you mean 'max_collisions'?)",
        ),
        (
            "world: garage\ntime_limit_s: 30\nseeds: [1]\ncriteria:\n  - end_in_zone: garag\n",
            "5:18: criteria[0].end_in_zone: world 'garage' has no zone 'garag' (did you mean 'garage'?)",
        ),
        (
            "world: garag\ntime_limit_s: 30\nseeds: [1]\ncriteria:\n  - succeed: true\n",
            "1:8: world: no world named 'garag' (did you mean 'garage'?)",
        ),
        (
            "world: garage\ntime_limit_s: .nan\nseeds: [1, 1]\ncriteria:\n  - succeed: true\n",
            "2:15: time_limit_s: must be from 0.1 to 3,600",
        ),
        (
            "world: garage\ntime_limit_s: 1e3\nseeds: [1]\ncriteria:\n  - succeed: true\n",
            "2:15: time_limit_s: expected a number, got '1e3' (YAML reads 1e3 as text: write it out, or with a",
        ),
        (
            "world: garage\ntime_limit_s: 30\nseeds: [1, 1]\ncriteria:\n  - succeed: true\n",
            "3:8: seeds: a seed is given twice",
        ),
        (
            "world: garage\ntime_limit_s: 30\nseeds: [1]\nallowed_nodes: [move, trun]\ncriteria:\n  - succeed: true\n",
            "4:23: allowed_nodes[1]: unknown node type 'trun' (did you mean 'turn'?)",
        ),
        (
            "world: garage\ntime_limt_s: 30\nseeds: [1]\ncriteria:\n  - succeed: true\n",
            "2:1: time_limt_s: unknown key 'time_limt_s' (did you mean 'time_limit_s'?)",
        ),
    ],
)
def test_exercise_files_are_checked_like_missions(tmp_path, text, message):
    path = tmp_path / "ex.yaml"
    path.write_text(text)
    with pytest.raises(ExerciseInvalid) as caught:
        load_exercise(path)
    assert any(line.startswith(f"{path}:{message}") for line in str(caught.value).splitlines()), str(caught.value)


def test_a_memory_hog_or_a_huge_file_costs_that_student_a_zero(tmp_path):
    exercise = load_exercise(EXERCISES / "garage.yaml")
    (tmp_path / "gina").mkdir()
    (tmp_path / "gina" / "hog.py").write_text("hoard = bytearray(3 * 1024**3)\n")
    (tmp_path / "gina" / "mission.yaml").write_text("mission: hog\nplugins: [hog]\ntree:\n  wait: {seconds: 1}\n")
    huge = tmp_path / "hank.yaml"
    huge.write_text("mission: huge\n# " + "x" * 1_100_000 + "\ntree:\n  wait: {seconds: 1}\n")
    reports = grade_class(
        exercise, find_submissions([tmp_path / "gina", huge]), workers=2, memory_mb=512, allow_plugins=True
    )
    gina, hank = reports
    assert gina.total == 0
    assert gina.problems == [
        f"{tmp_path / 'gina' / 'mission.yaml'}:2:11: plugins[0]: cannot import plugin 'hog': MemoryError"
    ]
    assert hank.total == 0 and hank.problems == [f"{huge}:1:1: cannot read the file: larger than 500,000 bytes"]


def test_seeds_with_sensor_noise_and_a_lossy_link_are_graded_too(tmp_path):
    exercise_file = tmp_path / "noisy.yaml"
    exercise_file.write_text(
        (EXERCISES / "garage.yaml")
        .read_text()
        .replace("seeds: [8, 52, 56, 80]", 'seeds: [8, {seed: 52, noise_mm: 2}, {seed: 56, faults: "drop=0.002"}]')
    )
    exercise = load_exercise(exercise_file)
    assert [s.label for s in exercise.seeds] == ["seed 8", "seed 52 (noise 2 mm)", "seed 56 (faults drop=0.002)"]
    report = grade_one(exercise, "ref", EXERCISES / "solutions" / "garage.yaml")
    assert report.total == exercise.max_points, [s.verdicts for s in report.seeds]


@pytest.mark.parametrize("name", SHIPPED)
def test_a_mission_that_does_nothing_scores_nothing(tmp_path, name):
    lazy = tmp_path / "lazy.yaml"
    lazy.write_text("mission: lazy\ntree:\n  move: {speed: 1, distance_mm: 1}\n")
    exercise = load_exercise(EXERCISES / f"{name}.yaml")
    report = grade_one(exercise, "lazy", lazy)
    assert report.total == 0, [s.verdicts for s in report.seeds]
    assert any(", but this counts only with " in line for _, line in report.seeds[0].verdicts)


def test_grading_never_reads_the_file_a_mission_names_as_its_world(tmp_path):
    secret = tmp_path / "secret.txt"
    secret.write_text("password: hunter2\n")
    mission = tmp_path / "ivy.yaml"
    mission.write_text(f"mission: nosy\nworld: {secret}\ntree:\n  move: {{speed: 2, until_obstacle_mm: 150}}\n")
    report = grade_one(load_exercise(EXERCISES / "garage.yaml"), "ivy", mission)
    assert report.total == 10 and "hunter2" not in str(report.to_json())


def test_links_devices_and_hidden_files_are_not_read_as_submissions(tmp_path):
    exercise = load_exercise(EXERCISES / "garage.yaml")
    link = tmp_path / "jo.yaml"
    link.symlink_to(EXERCISES / "solutions" / "garage.yaml")
    assert grade_one(exercise, "jo", link).problems == [
        f"{link}:1:1: a link, not a file: hand in the mission file itself"
    ]
    device = tmp_path / "kim.yaml"
    device.symlink_to("/dev/zero")
    assert "a link, not a file" in grade_one(exercise, "kim", device).problems[0]
    folder = tmp_path / "lee"
    folder.mkdir()
    (folder / "park.yaml").write_text((EXERCISES / "solutions" / "garage.yaml").read_text())
    (folder / "._park.yaml").write_bytes(b"\x00\x05\x16\x07")  # a zip made on a Mac
    assert grade_one(exercise, "lee", folder).total == 10
    with pytest.raises(ExerciseInvalid, match="not a regular file"):
        load_exercise(tmp_path / "kim.yaml")


def test_a_requirement_must_name_one_other_criterion(tmp_path):
    path = tmp_path / "ex.yaml"
    path.write_text(
        "world: garage\ntime_limit_s: 30\nseeds: [1]\ncriteria:\n"
        "  - end_in_zone: garage\n    requires: max_collisions\n"
        "  - max_collisions: 0\n    requires: end_in_zone\n"
        "  - succeed: true\n    requires: end_in_zon\n"
    )
    with pytest.raises(ExerciseInvalid) as caught:
        load_exercise(path)
    lines = str(caught.value).splitlines()
    assert f"{path}:6:15: criteria[0].requires: requirements go round in a circle" in lines
    assert any(
        line.startswith(f"{path}:10:15: criteria[2].requires: 'end_in_zon' names no other criterion") for line in lines
    )


def test_deep_nesting_is_a_problem_at_its_place_not_a_crash(tmp_path):
    path = tmp_path / "deep.yaml"
    path.write_text("world: garage\ndescription: " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(ExerciseInvalid, match="nested more than 100 levels deep"):
        load_exercise(path)


def test_a_requirement_holds_only_where_its_own_requirements_held_too(tmp_path):
    from autonomy.classroom.job import _with_requirements
    from autonomy.classroom.judge import Verdict

    path = tmp_path / "ex.yaml"
    path.write_text(
        "world: garage\ntime_limit_s: 30\nseeds: [1]\ncriteria:\n"
        "  - succeed: true\n    requires_all: max_collisions\n"  # requires one listed after it
        "  - max_collisions: 0\n    requires_all: end_in_zone\n"
        "  - end_in_zone: garage\n"
    )
    exercise = load_exercise(path)
    verdicts = _with_requirements(exercise, [Verdict(True, "a"), Verdict(True, "b"), Verdict(False, "c")])
    assert verdicts == [
        Verdict(False, "a, but this counts only with max_collisions 0, which did not count"),  # b held, but c did not
        Verdict(False, "b, but this counts only with end_in_zone garage, which did not hold"),
        Verdict(False, "c"),
    ]
    near = Verdict(False, "c, 60 mm out", 0.4)  # all or nothing: a near miss of c counts for nothing above it
    assert [v.share for v in _with_requirements(exercise, [Verdict(True, "a"), Verdict(True, "b"), near])] == [
        0.0, 0.0, 0.4]  # fmt: skip
    # without requires_all, a near miss counts for what depends on it in its own part, down the chain
    parts = load_exercise(_mission(tmp_path, "parts", path.read_text().replace("requires_all", "requires")))
    verdicts = _with_requirements(parts, [Verdict(True, "a"), Verdict(False, "b", 0.5), near])
    assert [v.share for v in verdicts] == [pytest.approx(0.2), pytest.approx(0.2), 0.4]
    assert verdicts[1].line == "b, counted at 40% as end_in_zone garage was"
    assert verdicts[0].line == "a, counted at 20% as max_collisions 0 was"
    nothing = _with_requirements(parts, [Verdict(True, "a"), Verdict(True, "b"), Verdict(False, "c")])
    assert nothing[1] == Verdict(False, "b, but this counts only with end_in_zone garage, which earned nothing")


def _mission(tmp_path, name, text):
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return path


TWO_BUMPS = """mission: two bumps
tick_hz: {hz}
tree:
  repeat:
    times: 2
    do:
      sequence:
        - force_success: {{do: {{move: {{speed: 3}}}}}}
        - move: {{speed: 1, direction: backward, distance_mm: 100}}
"""


def test_collisions_are_counted_from_the_emulator_the_same_at_any_tick_rate(tmp_path):
    """Two bumps into the end wall, backing off 10 cm between: two collisions at 1, 20 and 200 Hz.

    What the mission itself saw of them (the collision flag, read once a tick) is not: at 1 Hz the
    flag, held half a second, is over before it is read.
    """
    from autonomy.classroom.facts import Gatherer
    from autonomy.classroom.job import check_submission, run_seed
    from autonomy.client import Client
    from autonomy.runner import Runner

    exercise = load_exercise(EXERCISES / "garage.yaml")
    counted, seen = {}, {}
    for hz in (1, 20, 200):
        spec, problems = check_submission(exercise, _mission(tmp_path, f"m{hz}", TWO_BUMPS.format(hz=hz)), False)
        assert problems == []
        facts = run_seed(exercise, spec, exercise.seeds[0])
        counted[hz] = (len(facts.collisions), len(facts.impacts), facts.outcome)
        client = Client.open(f"emu://?world=garage&seed={exercise.seeds[0].seed}&time=virtual")
        gathered = Gatherer()
        Runner.for_mission(spec, client, listeners=[gathered]).run()
        client.close()
        seen[hz] = gathered.end.summary["collisions"]
    assert counted == {hz: (2, 2, "succeeded") for hz in (1, 20, 200)}
    assert seen[1] == 0 and seen[20] == 2  # what the mission read: not the same at every rate


def test_collisions_with_a_named_obstacle_are_told_from_the_rest():
    from autonomy.classroom.exercise import Criterion
    from autonomy.classroom.judge import hit, judge
    from autonomy.record import Pose

    world = load_world_of("bump").for_seed(3)
    box = world.obstacles[0]
    at_box = Pose(box.x_min_mm - 60.0, 750.0, 0.0)
    at_wall = Pose(60.0, 750.0, 180.0)
    assert hit(world, at_box) == "box" and hit(world, at_wall) == "a wall"
    bumped = Criterion("min_collisions", 1, 2.0, {"with": "box"}, "min_collisions 1")
    wall_only = _facts([(0.0, Pose(300, 750, 0)), (1.0, at_wall)], collisions=[(1.0, at_wall)])
    verdict = judge(bumped, wall_only, world)
    assert (
        not verdict.held and verdict.line == "collisions with box: 0, needed at least 1 (and 1 collision with a wall)"
    )
    both = _facts([(0.0, Pose(300, 750, 0))], collisions=[(1.0, at_wall), (2.0, at_box)])
    assert judge(bumped, both, world).line.startswith("collisions with box: 1, needed at least 1, the first at 2.0 s")


def test_turns_count_a_heading_s_change_at_one_place():
    from autonomy.classroom.exercise import Criterion
    from autonomy.classroom.judge import judge
    from autonomy.record import Pose

    world = load_world_of("square")
    lefts = Criterion("turns", 90, 0.0, {"count": 3.0, "tolerance_deg": 10.0}, "turns 90")
    square = [(0.0, Pose(700, 700, 0)), (2.0, Pose(1200, 700, 0)), (2.5, Pose(1200, 700, 85))]
    square += [(4.0, Pose(1200, 1200, 85)), (4.5, Pose(1200, 1200, 175 + 360)), (6.0, Pose(700, 1200, 535))]
    square += [(6.5, Pose(700, 1200, 535 - 180))]  # a half-turn right: not a left quarter
    verdict = judge(lefts, _facts(square), world)
    assert verdict.share == pytest.approx(2 / 3) and verdict.line == (
        "turned left 90 ± 10 degrees 2 times, needed 3 (its other turns: right 180)"
    )  # 85 is within 10 of 90; 450 left is a quarter-turn left as the path sees it


def test_a_half_turn_is_said_the_way_it_was_turned():
    from autonomy.classroom.exercise import Criterion
    from autonomy.classroom.judge import _turn_text, judge
    from autonomy.record import Pose

    assert [_turn_text(d) for d in (180.0, -180.0, 540.0, 179.6, -179.6, 450.0, -90.0)] == [
        "left 180", "right 180", "left 180", "left 180", "right 180", "left 90", "right 90"
    ]  # fmt: skip
    world = load_world_of("square")
    about = Criterion("turns", 180, 0.0, {"count": 1.0, "tolerance_deg": 10.0}, "turns 180")
    back = _facts([(0.0, Pose(700, 700, 0)), (2.0, Pose(700, 700, 180))])  # turned round to the left
    assert judge(about, back, world).line == "turned left 180 ± 10 degrees 1 time, needed 1"


def test_a_robot_still_moving_when_its_time_ran_out_did_not_come_to_rest():
    from autonomy.classroom.exercise import Criterion
    from autonomy.classroom.judge import judge
    from autonomy.record import Pose

    world = load_world_of("square")
    home = Criterion("rest_in_zone", "home", 3.0, {"after": "", "near_mm": 0.0}, "rest_in_zone home")
    spinning = _facts([(0.0, Pose(700, 700, 0)), (40.0, Pose(700, 700, 9000))], outcome="time limit", rest_s=40.0)
    spinning.time_s = 40.0
    assert judge(home, spinning, world).line == "home: the robot was still moving when its time ran out (40 s)"
    parked = _facts([(0.0, Pose(700, 700, 0)), (5.0, Pose(700, 700, 90))], outcome="time limit", rest_s=5.0)
    parked.time_s = 40.0
    assert judge(home, parked, world).held  # it stood still from 5 s on: the mission's not ending is another matter


def test_a_robot_that_ends_at_full_speed_rolls_on_and_what_it_then_hits_counts():
    from autonomy.classroom.job import check_submission, run_seed

    exercise = load_exercise(EXERCISES / "garage.yaml")
    spec, _ = check_submission(exercise, EXERCISES / "wrong" / "garage_full_speed.yaml", False)
    facts = run_seed(exercise, spec, exercise.seeds[0])
    assert facts.outcome == "succeeded" and len(facts.collisions) == 1
    assert facts.collisions[0].time_s > facts.time_s  # after the mission ended
    assert facts.rest_s is not None and facts.rest_s > facts.time_s
    assert facts.rest_hit == facts.collisions[0] and not facts.rest_by_itself  # the wall stopped it
    end = facts.path[-1][1]  # at rest against the end wall, its body touching it
    wall = exercise.world.for_seed(exercise.seeds[0].seed).obstacles[0]
    assert wall.gap(end.x_mm, end.y_mm) == pytest.approx(60.0, abs=0.01)


def test_a_zone_crossed_between_two_ticks_is_reached(tmp_path):
    """At 1 Hz at full speed the robot is in corner_1 at no tick, but its path goes through it."""
    from autonomy.classroom.exercise import Criterion
    from autonomy.classroom.job import check_submission, run_seed
    from autonomy.classroom.judge import judge

    exercise = load_exercise(EXERCISES / "square.yaml")
    fast = _mission(tmp_path, "fast", "mission: fast\ntick_hz: 1\ntree:\n  move: {speed: 4, distance_mm: 1000}\n")
    spec, _ = check_submission(exercise, fast, False)
    facts = run_seed(exercise, spec, exercise.seeds[0])
    world = exercise.world.for_seed(exercise.seeds[0].seed)
    corner = world.zone("corner_1")
    reach = Criterion("reach_zone", "corner_1", 1.0, {}, "reach_zone corner_1")
    assert judge(reach, facts, world).held
    # the path is the start and its straight drive's ends: no point of it is in the zone, a segment is
    assert not any(corner.contains(p.x_mm, p.y_mm) for _, p in facts.path)


def test_facts_need_a_header_and_an_end():
    from autonomy.classroom.facts import Gatherer, facts_of
    from autonomy.emulator.robot import Robot
    from autonomy.emulator.world import load_world

    with pytest.raises(ValueError, match="header and its end"):
        facts_of(Gatherer(), Robot(load_world("box")))


def test_students_of_the_same_name_are_told_apart_by_as_many_folders_as_it_takes(tmp_path, monkeypatch):
    given = ["hw/alice/hw2/mission.yaml", "hw/bob/hw2/mission.yaml", "a/x/eve.yaml", "b/x/eve.yaml", "c/alice.yml"]
    for where in (*given, "c/alice/mission.yaml"):
        (tmp_path / where).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / where).write_text("mission: m\ntree:\n  beep: {}\n")
    (tmp_path / "d").mkdir()
    strange = [os.fsdecode(b"d/lat\xe9in.yaml"), os.fsdecode(b"d/lat\xe8in.yaml")]  # from another system's zip
    for name in strange:
        (tmp_path / name).write_text("mission: m\ntree:\n  beep: {}\n")
    monkeypatch.chdir(tmp_path)
    found = find_submissions([*given, "c/alice", *strange])
    assert [name for name, _ in found] == [
        "a/x/eve",
        "alice/hw2/mission",
        "b/x/eve",
        "bob/hw2/mission",
        "c/alice",
        "c/alice.yml",
        "lat\\xe8in",
        "lat\\xe9in",
    ]
    monkeypatch.chdir(tmp_path / "c" / "alice")
    assert find_submissions(["."]) == [("alice", Path("."))]  # the folder "." names


def test_an_exercise_in_a_folder_whose_name_is_not_utf8_runs_in_its_own_world_file(tmp_path):
    folder = tmp_path / os.fsdecode(b"cours\xe9")
    folder.mkdir()
    (folder / "lab.yaml").write_text((EXERCISES.parent / "autonomy/emulator/worlds/garage.yaml").read_text())
    (folder / "ex.yaml").write_text(
        "world: lab.yaml\ntime_limit_s: 30\nseeds: [1]\ncriteria:\n  - end_in_zone: garage\n"
    )
    exercise = load_exercise(folder / "ex.yaml")
    report = grade_one(exercise, "ada", EXERCISES / "solutions" / "garage.yaml")
    assert report.problems == [] and report.total == exercise.max_points


def test_a_seed_whose_faults_leave_no_link_scores_nothing_on_that_seed_alone(tmp_path):
    path = tmp_path / "ex.yaml"
    path.write_text(
        "world: garage\ntime_limit_s: 30\nseeds:\n  - {seed: 1, faults: 'drop=0.3'}\n  - 2\n"
        "criteria:\n  - end_in_zone: garage\n"
    )
    exercise = load_exercise(path)
    report = grade_one(exercise, "ada", EXERCISES / "solutions" / "garage.yaml")
    assert report.problems == [] and report.total == 0.5
    first, second = report.seeds
    assert first.outcome == "no run" and first.verdicts == [
        (False, "no run: under this seed's faults the link failed before the mission started (ReplyTimeout)")
    ]
    assert second.verdicts == [(True, "garage: ended inside it")]


def _facts(path, beeps=(), collisions=(), outcome="succeeded", rest_s=3.0, **more):
    """Facts for a judge: beeps and collisions as (time_s, pose), or as themselves (Beep, Contact)."""
    from autonomy.classroom.facts import Beep, Contact, RunFacts

    beeps = [b if isinstance(b, Beep) else Beep(*b) for b in beeps]
    contacts = [c if isinstance(c, Contact) else Contact(*c, speed_mm_s=200.0, end_s=c[0]) for c in collisions]
    impacts = [(c.time_s, c.pose) for c in contacts]
    return RunFacts(1, outcome, "", 3.0, list(path), beeps, impacts, contacts, rest_s, 30.0, **more)


def test_verdict_lines_read_as_a_person_would_write_them():
    from autonomy.classroom.exercise import Criterion
    from autonomy.classroom.judge import judge
    from autonomy.record import Pose

    world = load_world_of("garage")
    facts = _facts([(3.0, Pose(500.0, 500.0, -0.3))])
    facing = Criterion("end_heading_deg", 0, 1.0, {"tolerance_deg": 10.0}, "end_heading_deg 0")
    assert judge(facing, facts, world).line == "ended facing 0 deg, needed 0 ± 10 (off by 0)"  # not 360 deg
    nodes = Criterion("max_nodes", 3, 1.0, {}, "max_nodes 3")
    assert judge(nodes, facts, world).line == "uses 1 node, allowed 3"
    # the garage (as the world file has it) is the box x 2240..2400, y 420..780: from (2000, 1100)
    # its nearest point (2240, 780) is sqrt(240^2 + 320^2) = 400 mm away, 53 degrees below east
    wandered = _facts([(1.0, Pose(500, 500, 0)), (2.0, Pose(2000, 1100, 0))])
    reach = Criterion("reach_zone", "garage", 1.0, {}, "reach_zone garage")
    assert judge(reach, wandered, world).line == (
        "garage: never reached; garage is 400 mm south-east of where the robot came closest (2000, 1100 mm)"
    )
    beeped = _facts([(2.5, Pose(2300, 600, 0))], [(2.5, Pose(2300, 600, 0))])
    beep = Criterion("beep_near", "garage", 1.0, {"within_mm": 0.0}, "beep_near garage")
    assert judge(beep, beeped, world).line == "beep at garage: beeped inside it at 2.5 s"
    rest = Criterion("rest_in_zone", "garage", 1.0, {"after": ""}, "rest_in_zone garage")
    short = _facts([(0.0, Pose(400, 600, 0)), (2.0, Pose(2200, 600, 0))])
    assert judge(rest, short, world).line == "garage: came to rest 40 mm outside it (it lies east; needed inside)"
    late = _facts([(0.0, Pose(400, 600, 0)), (31.0, Pose(2300, 600, 0))], rest_s=31.0)
    assert judge(rest, late, world).line == "garage: came to rest only at 31.00 s, after the 30 s allowed"
    rolling = _facts([(0.0, Pose(400, 600, 0))], rest_s=None)
    assert judge(rest, rolling, world).line.startswith("garage: the robot never came to rest")


def load_world_of(name):
    from autonomy.emulator.world import load_world

    return load_world(name)


def test_corners_count_in_order_each_its_share():
    from autonomy.classroom.exercise import Criterion
    from autonomy.classroom.judge import judge
    from autonomy.record import Pose

    world = load_world_of("square")
    corners = Criterion("visit_in_order", ("corner_1", "corner_2", "corner_3"), 3.0, {}, "visit_in_order")
    square = [(0.0, Pose(700, 700, 0)), (2.0, Pose(1200, 700, 90)), (4.0, Pose(1200, 1200, 180))]
    square += [(6.0, Pose(700, 1200, 270)), (8.0, Pose(700, 700, 360))]
    verdict = judge(corners, _facts(square), world)
    assert verdict.held and verdict.share == 1.0
    # each corner's zone reaches 120 mm toward the corner before it: entered a quarter of a side early
    assert verdict.line == "in order, 3 of 3: corner_1 at 1.5 s; corner_2 at 3.5 s; corner_3 at 5.5 s"
    backwards = [(0.0, Pose(700, 700, 90)), (2.0, Pose(700, 1200, 0)), (4.0, Pose(1200, 1200, 270))]
    backwards += [(6.0, Pose(1200, 700, 180)), (8.0, Pose(700, 700, 180))]
    verdict = judge(corners, _facts(backwards), world)  # corner_3, then 2, then 1: one of them is in order
    assert verdict.share == pytest.approx(1 / 3) and not verdict.held
    assert verdict.line.count("only out of order") == 2
    # corner_2, corner_3, then corner_1: the first two count, though corner_1 came last
    late = [(0.0, Pose(700, 700, 0)), (2.0, Pose(1200, 1200, 0)), (4.0, Pose(700, 1200, 0))]
    late += [(6.0, Pose(1200, 700, 0))]
    verdict = judge(corners, _facts(late), world)
    assert verdict.share == pytest.approx(2 / 3) and "corner_1 only out of order, at 5.7 s" in verdict.line
    nowhere = judge(corners, _facts([(0.0, Pose(700, 700, 0))]), world)
    assert nowhere.share == 0 and "corner_1 never: corner_1 is 380 mm east of where the robot came closest" in (
        nowhere.line
    )


def test_beeps_count_for_the_zone_they_are_at_and_extra_beeps_past_the_allowance_cost_them_all():
    from autonomy.classroom.exercise import Criterion
    from autonomy.classroom.judge import judge
    from autonomy.record import Pose

    world = load_world_of("square")
    beeps = Criterion(
        "beeps_in", ("corner_1", "corner_2"), 2.0, {"within_mm": 0.0, "extra_beeps": 1.0}, "beeps_in corner_1 corner_2"
    )
    at_one = [(1.0, Pose(1200, 700, 0))]
    verdict = judge(beeps, _facts(at_one, at_one), world)
    assert verdict.share == 0.5 and verdict.line.startswith("beeped at corner_1; none at corner_2 (it is 380 mm north")
    # 121 mm from corner_1's centre is 1 mm outside it: an extra beep, and one extra beep is allowed
    near = [*at_one, (2.0, Pose(1321, 700, 0)), (3.0, Pose(1200, 1200, 0))]
    verdict = judge(beeps, _facts(near, near), world)
    assert verdict.held and verdict.line.endswith("1 extra beep, allowed 1")
    spam = [*near, (4.0, Pose(1000, 700, 0))]
    verdict = judge(beeps, _facts(spam, spam), world)
    assert verdict.share == 0 and verdict.line.endswith("2 extra beeps, allowed 1: no points for beeps")
    twice = [*at_one, (3.0, Pose(1200, 1200, 0)), (4.0, Pose(1210, 710, 0)), (5.0, Pose(1190, 1190, 0))]
    verdict = judge(beeps, _facts(twice, twice), world)  # a second round: its beeps at the corners are extra
    assert verdict.share == 0 and verdict.line.endswith("2 extra beeps, allowed 1: no points for beeps")


def test_coming_to_rest_after_a_zone_needs_that_zone_visited_first():
    from autonomy.classroom.exercise import Criterion
    from autonomy.classroom.judge import judge
    from autonomy.record import Pose

    world = load_world_of("square")
    home = Criterion("rest_in_zone", "home", 3.0, {"after": "corner_3"}, "rest_in_zone home")
    stayed = _facts([(0.0, Pose(700, 700, 0))])
    assert judge(home, stayed, world).line == (
        "home: came to rest inside it, but never after corner_3 (needed after it)"
    )
    round_trip = _facts([(0.0, Pose(700, 700, 90)), (2.0, Pose(700, 1200, 270)), (4.0, Pose(700, 700, 270))])
    assert judge(home, round_trip, world).held


@pytest.mark.parametrize(
    ("to_x", "to_y", "said"),
    [(1, 0, "east"), (1, 1, "north-east"), (0, 1, "north"), (-1, 1, "north-west"), (-1, 0, "west")]
    + [(-1, -1, "south-west"), (0, -1, "south"), (1, -1, "south-east"), (1, 0.41, "east"), (1, 0.42, "north-east")],
)
def test_a_bearing_is_the_nearest_of_eight_points_of_the_compass(to_x, to_y, said):
    from autonomy.classroom.judge import bearing

    assert bearing(0, 0, to_x, to_y) == said  # tan(22.5 degrees) = 0.414: east up to there


def _record_workers(monkeypatch, tmp_path, actions=None):
    """Has every worker note which process graded which student (and do what ``actions`` says for some)."""
    log = tmp_path / "workers.log"
    graded = pool.grade_one

    def noting(exercise, student, path, allow_plugins=False):
        with open(log, "a") as out:
            out.write(f"{student} {os.getpid()}\n")
        if actions and student in actions:
            actions[student]()
        return graded(exercise, student, path, allow_plugins)

    monkeypatch.setattr(pool, "grade_one", noting)  # the workers are forked with it

    def pids():
        """Each student's workers, in the order they graded them (a student graded again has two)."""
        seen: dict[str, list[str]] = {}
        for line in log.read_text().splitlines():
            student, pid = line.split()
            seen.setdefault(student, []).append(pid)
        return seen

    return pids


def _class_of(tmp_path, names):
    """Copies of the garage exercise's reference solution, one a student."""
    folder = tmp_path / "class"
    folder.mkdir()
    text = (EXERCISES / "solutions" / "garage.yaml").read_text()
    for name in names:
        (folder / f"{name}.yaml").write_text(text)
    return find_submissions(sorted(folder.iterdir()))


def test_a_worker_grades_one_submission_after_another_and_marks_are_as_a_new_worker_gives_them(monkeypatch, tmp_path):
    exercise = load_exercise(EXERCISES / "garage.yaml")
    submissions = _class_of(tmp_path, ["ann", "ben", "cat", "dan", "eve"])
    pids = _record_workers(monkeypatch, tmp_path)
    shared = grade_class(exercise, submissions, workers=2)
    assert len({pid for graded in pids().values() for pid in graded}) <= 2
    (tmp_path / "workers.log").unlink()
    # with plugins allowed every submission has a worker of its own (a plugin may change anything)
    alone = grade_class(exercise, submissions, workers=2, allow_plugins=True)
    assert len({pid for graded in pids().values() for pid in graded}) == 5
    assert to_json(exercise, shared) == to_json(exercise, alone)
    assert all(report.total == exercise.max_points for report in shared)


def test_a_worker_is_replaced_after_a_submission_that_failed_or_left_it_holding_memory(monkeypatch, tmp_path):
    exercise = load_exercise(EXERCISES / "garage.yaml")
    submissions = _class_of(tmp_path, ["a_first", "b_boom", "c_after_boom", "d_hoard", "e_after_hoard", "f_last"])
    kept = []

    def boom():
        raise RuntimeError("boom")

    def hoard():
        kept.append(bytearray(2 * limits.RETIRE_GROWTH_MB * 2**20))

    pids = _record_workers(monkeypatch, tmp_path, {"b_boom": boom, "d_hoard": hoard})
    reports = grade_class(exercise, submissions, workers=1)
    seen = pids()
    # the failure came in a worker used before: graded again in a new one (which it also ends)
    (first,), (used, again), (after_boom,) = seen["a_first"], seen["b_boom"], seen["c_after_boom"]
    assert first == used and len({first, again, after_boom}) == 3
    assert seen["d_hoard"] == [after_boom] and seen["e_after_hoard"] == seen["f_last"] != [after_boom]
    totals = {report.student: report.total for report in reports}
    assert totals == {name: (0.0 if name == "b_boom" else exercise.max_points) for name in totals}
    assert reports[1].problems[0].startswith("grading stopped with RuntimeError: boom at test_grading.py:")


def test_a_worker_that_takes_too_long_is_ended_and_the_rest_are_graded_by_a_new_one(monkeypatch, tmp_path):
    exercise = load_exercise(EXERCISES / "garage.yaml")
    submissions = _class_of(tmp_path, ["a_first", "b_endless", "c_after"])
    pids = _record_workers(monkeypatch, tmp_path, {"b_endless": lambda: time.sleep(60)})
    reports = grade_class(exercise, submissions, workers=1, cpu_s=2, wall_s=3)
    seen = pids()
    assert seen["a_first"] == seen["b_endless"] != seen["c_after"]  # not graded again: it would take as long
    assert [report.total for report in reports] == [exercise.max_points, 0.0, exercise.max_points]
    assert reports[1].problems == [
        "took more than 3 s of wall time, waiting rather than working (a plugin that sleeps?) "
        "(--wall-seconds gives more)"
    ]


def test_a_submission_that_fails_only_after_another_is_graded_again_in_a_new_worker(monkeypatch, tmp_path):
    # What a submission leaves in a worker (memory, above all) must not cost the next student
    # their marks: a failure in a worker used before is graded again in a new one, whose result stands.
    exercise = load_exercise(EXERCISES / "garage.yaml")
    submissions = _class_of(tmp_path, ["a_first", "b_fragile", "c_after"])
    graded_here = []

    def count():
        graded_here.append(1)

    def fragile():
        count()
        if len(graded_here) > 1:  # this worker graded someone before
            raise MemoryError

    pids = _record_workers(monkeypatch, tmp_path, {"a_first": count, "b_fragile": fragile, "c_after": count})
    for workers in (1, 2):
        (tmp_path / "workers.log").unlink(missing_ok=True)
        reports = grade_class(exercise, submissions, workers=workers)
        assert [report.total for report in reports] == [exercise.max_points] * 3, [r.problems for r in reports]
        if workers == 1:  # it failed after a_first, and was graded again in a new worker
            assert pids()["b_fragile"][0] == pids()["a_first"][0] != pids()["b_fragile"][1]


def test_hidden_seeds_are_drawn_from_the_teacher_s_secret():
    from autonomy.classroom.exercise import hidden_seed

    exercise = load_exercise(EXERCISES / "garage.yaml")
    assert exercise.hidden_seeds == 12 and len(exercise.seeds) == 4  # a student's grading: the public ones only
    mine, again, theirs = (
        exercise.with_secret(s) for s in (b"one secret of sixteen", b"one secret of sixteen", b"x" * 16)
    )
    assert [s.seed for s in mine.seeds] == [s.seed for s in again.seeds]  # the same secret, the same seeds
    hidden = [s for s in mine.seeds if s.hidden]
    assert mine.seeds[:4] == exercise.seeds and len(hidden) == 12
    assert [s.label for s in hidden] == [f"hidden seed {k}" for k in range(1, 13)]  # never their numbers
    assert {s.seed for s in hidden}.isdisjoint(s.seed for s in theirs.seeds if s.hidden)
    assert hidden[0].seed == hidden_seed(b"one secret of sixteen", "garage", 1) < 2**31
    assert hidden_seed(b"one secret of sixteen", "opening", 1) != hidden[0].seed  # each exercise its own


@pytest.mark.parametrize("name", SHIPPED)
def test_the_reference_solution_scores_full_marks_on_hidden_seeds_too(name):
    exercise = load_exercise(EXERCISES / f"{name}.yaml")
    if not exercise.hidden_seeds:
        exercise = dataclasses.replace(exercise, hidden_seeds=12)
    graded = exercise.with_secret(b"a teacher's secret, for the test")
    report = grade_one(graded, name, EXERCISES / "solutions" / f"{name}.yaml")
    failing = [(s.seed, line) for s in report.seeds for held, line in s.verdicts if not held]
    assert failing == [] and report.total == exercise.max_points


@pytest.mark.parametrize("name", sorted(FIXED_PLANS))
def test_a_fixed_plan_tuned_to_the_public_seeds_earns_at_most_40_percent(tmp_path, name):
    """A student tunes a fixed plan by grading it on the public seeds again and again; the best one
    still earns at most 40% there, and at most 40% of the teacher's marks, hidden seeds included."""
    exercise = load_exercise(EXERCISES / f"{name}.yaml")
    text, distances = FIXED_PLANS[name]
    tried = []
    for distance in distances:
        plan = tmp_path / f"plan_{distance}.yaml"
        plan.write_text(text.format(d=distance))
        tried.append((grade_one(exercise, plan.stem, plan).total, distance))
    best, distance = max(tried)
    assert 0 < best <= 4.0, tried  # some distance is right somewhere, none nearly everywhere
    teacher = exercise.with_secret(b"a teacher's secret, for the test")
    assert grade_one(teacher, "tuned", tmp_path / f"plan_{distance}.yaml").total <= 4.0


def test_similar_submissions_are_trees_alike_but_for_numbers_names_or_a_node_or_two(tmp_path):
    from autonomy.classroom.gradebook import _nodes_apart, similar

    exercise = load_exercise(EXERCISES / "square.yaml")
    renamed = tmp_path / "renamed.yaml"  # the reference, its subtree renamed and its numbers changed
    renamed.write_text(
        "mission: mine\nsubtrees:\n  edge:\n    sequence:\n      - move: {speed: 3, distance_mm: 480}\n"
        "      - beep: {tones: [1, 2, 3]}\n      - turn: {left: 88}\n"
        "tree:\n  repeat:\n    times: 4\n    do: {subtree: edge}\n"
    )
    extra = tmp_path / "extra.yaml"  # and one more node
    extra.write_text(
        renamed.read_text().replace("      - turn: {left: 88}\n", "      - turn: {left: 88}\n      - beep: {}\n")
    )
    other = tmp_path / "other.yaml"  # another way altogether
    other.write_text(
        "mission: other\ntree:\n  sequence:\n"
        + "".join(
            "    - move: {speed: 2, distance_mm: 500}\n    - beep: {}\n    - turn: {left: 90}\n" for _ in range(4)
        )
    )
    reports = [
        grade_one(exercise, "ref", EXERCISES / "solutions" / "square.yaml"),
        grade_one(exercise, "renamed", renamed),
        grade_one(exercise, "extra", extra),
        grade_one(exercise, "other", other),
    ]
    assert similar(reports) == [
        ("extra", "ref", "trees 1 node apart, numbers and names aside"),
        ("extra", "renamed", "trees 1 node apart, numbers and names aside"),
        ("ref", "renamed", "the same tree but for numbers and names"),
    ]
    assert "shape" not in reports[0].to_json()  # a hint's material, not part of the marks
    assert _nodes_apart(("a", "b", "c"), ("a", "c"), 2) == 1 and _nodes_apart(("a",) * 9, ("b",) * 9, 2) == 3


def test_a_turn_counts_for_a_square_only_after_a_side_was_driven():
    from autonomy.classroom.exercise import Criterion
    from autonomy.classroom.judge import judge
    from autonomy.record import Pose

    world = load_world_of("square")
    corners = Criterion("turns", 90, 0.0, {"count": 3.0, "tolerance_deg": 10.0, "after_drive_mm": 300.0}, "turns 90")
    nudged = [(0.0, Pose(700, 700, 0))]  # a tiny square: a quarter-turn after each 10 mm
    for k in range(1, 5):
        nudged.append((k * 1.0, Pose(700 + 10 * (k % 2), 700, 90 * k)))
    verdict = judge(corners, _facts(nudged), world)
    assert verdict.share == 0 and verdict.line.startswith(
        "turned left 90 ± 10 degrees after a drive of 300 mm 0 times, needed 3"
    )
    shuttle = [(0.0, Pose(700, 700, 0))]  # 30 cm out and back again before each quarter-turn, at home
    for k in range(1, 4):
        shuttle += [(3 * k - 2.0, Pose(700 + 300, 700, 90 * (k - 1))), (3 * k - 1.0, Pose(700, 700, 90 * (k - 1)))]
        shuttle.append((3.0 * k, Pose(700, 700, 90 * k)))
    assert judge(corners, _facts(shuttle), world).share == 0
    sides = [(0.0, Pose(700, 700, 0)), (2.0, Pose(1200, 700, 90)), (4.0, Pose(1200, 1200, 180))]
    sides += [(6.0, Pose(700, 1200, 270))]
    assert judge(corners, _facts(sides), world).held


def test_a_bump_counts_where_the_exercise_says_the_robot_drives_up_to_the_box():
    from autonomy.classroom.exercise import Criterion
    from autonomy.classroom.judge import judge
    from autonomy.record import Pose

    world = load_world_of("bump").for_seed(3)
    box = world.obstacles[0]
    front = Pose(box.x_min_mm - 60.0, 750.0, 0.0)
    behind = Pose(box.x_max_mm + 60.0, 750.0, 180.0)
    bump = Criterion("min_collisions", 1, 2.0, {"with": "box", "at": "box_front"}, "min_collisions 1")
    late = _facts([(0.0, Pose(300, 750, 0))], collisions=[(9.0, behind)])
    assert judge(bump, late, world).line == (
        "collisions with box at box_front: 0, needed at least 1 (and 1 collision elsewhere with box)"
    )
    assert judge(bump, _facts([(0.0, Pose(300, 750, 0))], collisions=[(3.0, front)]), world).held


def test_a_near_miss_earns_its_part_of_what_requires_some_of_it(tmp_path):
    from autonomy.classroom.job import _with_requirements
    from autonomy.classroom.judge import Verdict

    path = tmp_path / "ex.yaml"
    path.write_text(
        "world: garage\ntime_limit_s: 30\nseeds: [1]\ncriteria:\n"
        "  - rest_in_zone: garage\n    near_mm: 50\n    points: 5\n"
        "  - max_collisions: 0\n    points: 3\n    requires_some: rest_in_zone\n"
        "  - succeed: true\n    points: 2\n    requires_all: rest_in_zone\n"
    )
    exercise = load_exercise(path)
    near = Verdict(False, "garage: came to rest 10 mm outside it", 0.8)
    verdicts = _with_requirements(exercise, [near, Verdict(True, "no collision"), Verdict(True, "succeeded")])
    assert [v.share for v in verdicts] == [0.8, pytest.approx(0.8), 0.0]  # in part; all or nothing
    assert verdicts[1].line == "no collision, counted at 80% as rest_in_zone garage was"
    far = Verdict(False, "garage: came to rest 90 mm outside it")
    assert _with_requirements(exercise, [far, Verdict(True, "no collision"), Verdict(True, "x")])[1].line == (
        "no collision, but this counts only with rest_in_zone garage, which earned nothing"
    )
    both = tmp_path / "both.yaml"
    both.write_text(
        path.read_text().replace(
            "requires_some: rest_in_zone", "requires_some: rest_in_zone\n    requires: rest_in_zone"
        )
    )
    with pytest.raises(ExerciseInvalid, match="give one of requires, requires_some, requires_all, not 2"):
        load_exercise(both)


def test_the_job_grades_a_mission_s_text_as_the_file_it_came_in_is_graded(tmp_path):
    from autonomy.classroom import grade_mission

    exercise = load_exercise(EXERCISES / "garage.yaml")
    for source in (EXERCISES / "solutions" / "garage.yaml", EXERCISES / "wrong" / "garage_full_speed.yaml"):
        (tmp_path / "alice.yaml").write_bytes(source.read_bytes())
        from_file = grade_one(exercise, "alice", tmp_path / "alice.yaml")
        from_text = grade_mission(exercise, "alice", source.read_text(), str(tmp_path / "alice.yaml"), tmp_path)
        assert from_text.to_json() == from_file.to_json() and from_file.seeds
    typo = grade_mission(exercise, "bob", "mission: park\ntree: mvoe\n", "bob.yaml", tmp_path)
    assert typo.total == 0 and typo.problems[0].startswith("bob.yaml:2:7: ") and typo.file == "bob.yaml"


def test_a_run_that_ended_by_itself_with_no_points_is_headed_by_its_points_not_as_a_pass(tmp_path):
    from autonomy.classroom import grade_mission
    from autonomy.classroom.report import seed_heading, write_feedback_page

    exercise = load_exercise(EXERCISES / "garage.yaml")
    report = grade_mission(exercise, "alice", "mission: idle\ntree: stop\n", "alice.yaml", tmp_path)
    first = report.seeds[0]
    assert first.outcome == "succeeded" and report.total == 0
    heading = f"{first.seed}: 0 of 10 points (the run: succeeded after {first.time_s:g} s)"
    assert seed_heading(exercise, first) == heading
    page = write_feedback_page(exercise, report, tmp_path, [None] * len(report.seeds), "alice").read_text()
    assert f"<h2>{first.seed}: 0 of 10 points (the run: succeeded" in page
    assert not re.search(r"<h2>seed \d+: succeeded", page)


def test_an_exercise_s_world_named_bare_is_its_file_beside_the_exercise_and_a_missing_file_is_said_so(tmp_path):
    (tmp_path / "hall").mkdir()  # a folder that happens to share the world's name
    (tmp_path / "hall.yaml").write_bytes((ROOT / "autonomy" / "emulator" / "worlds" / "garage.yaml").read_bytes())
    text = (EXERCISES / "garage.yaml").read_text()
    (tmp_path / "mine.yaml").write_text(text.replace("world: garage", "world: hall"))
    exercise = load_exercise(tmp_path / "mine.yaml")
    assert exercise.world_ref == str(tmp_path / "hall.yaml")
    (tmp_path / "gone.yaml").write_text(text.replace("world: garage", "world: halls.yaml"))
    with pytest.raises(ExerciseInvalid) as refused:
        load_exercise(tmp_path / "gone.yaml")
    assert f"world: the world file 'halls.yaml' is not there (beside the exercise: {tmp_path / 'halls.yaml'})" in str(
        refused.value.problems[0]
    )


def test_a_criterion_s_title_is_what_a_student_reads_and_its_label_what_the_teacher_s_gradebook_keeps(tmp_path):
    from autonomy.classroom.report import feedback, to_csv

    exercise = load_exercise(EXERCISES / "garage.yaml")
    assert [(c.label, c.shown) for c in exercise.criteria] == [
        ("rest_in_zone garage", "Parked in the garage"),
        ("max_collisions 0", "No crash"),
        ("finish_within_s 30", "Done within 30 s"),
        ("reach_zone garage", "Drove up to the garage"),
    ]
    report = grade_one(exercise, "alice", EXERCISES / "solutions" / "garage.yaml")
    assert "  ok   Parked in the garage: 5 / 5 points" in feedback(exercise, report)
    assert (
        to_csv(exercise, [report])
        .splitlines()[0]
        .endswith(
            ",rest_in_zone garage,max_collisions 0,finish_within_s 30,reach_zone garage,adjustment,"
            "adjustment_reasons,problems"
        )
    )
    base = "world: garage\ntime_limit_s: 30\nseeds: [1]\ncriteria:\n  - succeed: true\n"
    (tmp_path / "plain.yaml").write_text(base)
    assert load_exercise(tmp_path / "plain.yaml").criteria[0].shown == "succeed"  # no title: its label
    (tmp_path / "long.yaml").write_text(base + "    title: " + "word " * 20 + "\n")
    with pytest.raises(ExerciseInvalid) as refused:
        load_exercise(tmp_path / "long.yaml")
    assert "criteria[0].title: at most 80 characters: a few words" in str(refused.value.problems[0])

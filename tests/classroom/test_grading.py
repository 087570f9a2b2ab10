"""Exercises graded on the emulator: references score full marks, wrong solutions lose marks for the right reason."""

import json
import os
import signal
import time
from pathlib import Path

import msgspec
import pytest

from autonomy.classroom import ExerciseInvalid, find_submissions, grade_class, grade_one, load_exercise
from autonomy.classroom import grade as grade_module
from autonomy.classroom.grade import PLUGINS_REFUSED
from autonomy.classroom.report import feedback, to_csv, to_html, to_json

ROOT = Path(__file__).resolve().parents[2]
EXERCISES = ROOT / "exercises"
SHIPPED = ("square", "garage", "slalom", "bump", "opening")

#: For each wrong solution: the criteria it must lose marks on, and those it keeps in full.
WRONG = {
    "square_turns_right": ({"beep_near corner_2", "reach_zone corner_2", "end_in_zone home"}, {"beep_near corner_1"}),
    "square_no_beeps": ({"beep_near corner_1", "beep_near corner_2", "beep_near corner_3"}, {"end_in_zone home"}),
    "garage_fixed_distance": ({"end_in_zone garage", "max_collisions 0"}, set()),
    "garage_until_bump": ({"end_in_zone garage", "max_collisions 0"}, set()),
    "slalom_straight": ({"end_in_zone exit"}, set()),
    "slalom_blind": ({"end_in_zone exit", "max_collisions 0"}, set()),
    "bump_push": ({"end_in_zone goal", "finish_within_s 60"}, set()),
    "bump_no_return": ({"end_in_zone goal"}, set()),
    "opening_straight": ({"end_in_zone goal"}, set()),
    "opening_fixed": ({"end_in_zone goal"}, set()),
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
    reports = grade_class(exercise, submissions, workers=2, cpu_s=2, allow_plugins=True)
    erin, frank, garage = reports
    assert erin.total == 0 and erin.problems == [
        "used more than 2 s of CPU time: an endless loop, or a tree too big to run in time (--cpu-seconds gives more)"
    ]
    assert frank.total == 0 and "ended without a report (exit code 9)" in frank.problems[0]
    assert garage.total == exercise.max_points


def heavy_mission(checks: int) -> str:
    """The garage's solution behind ``checks`` conditions made again every tick, at 200 Hz: valid, and slow to run."""
    made_again = "".join("            - invert: {do: collided}\n" for _ in range(checks))
    return (
        "mission: heavy\ntick_hz: 200\ntree:\n  sequence:\n    memory: false\n    children:\n"
        f"      - sequence:\n          memory: false\n          children:\n{made_again}"
        "      - move: {speed: 2, until_obstacle_mm: 150}\n"
    )


def test_heavy_missions_get_the_same_marks_from_one_worker_as_from_four_on_two_cores(tmp_path):
    # Each takes about 1 s of CPU time. The grader and its workers are held to one core, as four
    # workers on a busy two-core machine are: four at once take 4 s or more of wall time each, so
    # under a limit of 3 s of wall time all would score 0 with four workers and 10 with one. CPU
    # time does not grow while a worker waits for a core.
    exercise = load_exercise(EXERCISES / "garage.yaml")
    for name in ("ann", "ben", "cat", "dan"):
        (tmp_path / f"{name}.yaml").write_text(heavy_mission(60))
    submissions = find_submissions(sorted(tmp_path.glob("*.yaml")))
    cores = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(cores)})  # the workers, forked, keep it
    try:
        one = grade_class(exercise, submissions, workers=1, cpu_s=3)
        four = grade_class(exercise, submissions, workers=4, cpu_s=3)
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
    assert rows[0] == "student,total,out_of,end_in_zone garage,max_collisions 0,finish_within_s 30,problems"
    assert rows[1].startswith("garage,10,10,5,3,2,")
    assert rows[2].startswith("garage_fixed_distance,7.5,10,3.75,2.25,1.5,")
    document = json.loads(to_json(exercise, first))
    assert [s["student"] for s in document["students"]] == ["garage", "garage_fixed_distance"]


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
        .replace("seeds: [1, 2, 3, 4]", 'seeds: [1, {seed: 2, noise_mm: 2}, {seed: 3, faults: "drop=0.002"}]')
    )
    exercise = load_exercise(exercise_file)
    assert [s.label for s in exercise.seeds] == ["seed 1", "seed 2 (noise 2 mm)", "seed 3 (faults drop=0.002)"]
    report = grade_one(exercise, "ref", EXERCISES / "solutions" / "garage.yaml")
    assert report.total == exercise.max_points, [s.verdicts for s in report.seeds]


@pytest.mark.parametrize("name", SHIPPED)
def test_a_mission_that_does_nothing_scores_nothing(tmp_path, name):
    lazy = tmp_path / "lazy.yaml"
    lazy.write_text("mission: lazy\ntree:\n  beep: {}\n")
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
    from autonomy.classroom.grade import _with_requirements
    from autonomy.classroom.judge import Verdict

    path = tmp_path / "ex.yaml"
    path.write_text(
        "world: garage\ntime_limit_s: 30\nseeds: [1]\ncriteria:\n"
        "  - succeed: true\n    requires: max_collisions\n"  # requires one listed after it
        "  - max_collisions: 0\n    requires: end_in_zone\n"
        "  - end_in_zone: garage\n"
    )
    exercise = load_exercise(path)
    verdicts = _with_requirements(exercise, [Verdict(True, "a"), Verdict(True, "b"), Verdict(False, "c")])
    assert verdicts == [
        Verdict(False, "a, but this counts only with max_collisions 0, which did not count"),  # b held, but c did not
        Verdict(False, "b, but this counts only with end_in_zone garage, which did not hold"),
        Verdict(False, "c"),
    ]


def test_a_trace_of_the_run_is_judged_as_the_live_run_was(tmp_path):
    """The grader gathers a run's facts as its records come; a trace of the same run gives the same verdicts."""
    from autonomy.classroom.grade import check_submission
    from autonomy.classroom.judge import Gatherer, gather, judge
    from autonomy.client import Client
    from autonomy.runner import Runner
    from autonomy.trace import TraceWriter, read_trace

    exercise = load_exercise(EXERCISES / "square.yaml")
    spec, problems = check_submission(exercise, EXERCISES / "wrong" / "square_turns_right.yaml", False)
    assert problems == []
    seed = exercise.seeds[0]
    client = Client.open(f"emu://?world={exercise.world_ref}&seed={seed.seed}&time=virtual&noise={seed.noise_mm}")
    live = Gatherer()
    path = tmp_path / "run.jsonl"
    with path.open("w", encoding="utf-8") as stream:
        Runner.for_mission(spec, client, listeners=[live, TraceWriter(stream)]).run()
    client.close()
    facts, again = live.facts(), gather(read_trace(path).records())
    assert len(again.path) == len(facts.path) > 100 and len(again.beeps) == len(facts.beeps) > 0
    assert (again.outcome, again.collisions) == (facts.outcome, facts.collisions)
    assert again.time_s == pytest.approx(facts.time_s, abs=1e-4)  # a trace holds times to 0.1 ms, poses to 0.1 mm
    held = [judge(c, facts, exercise.world).held for c in exercise.criteria]
    assert [judge(c, again, exercise.world).held for c in exercise.criteria] == held
    assert True in held and False in held  # a wrong solution: the verdicts compared are not all alike


def test_facts_need_a_header_an_end_and_the_truth():
    from autonomy.classroom.judge import gather
    from autonomy.client import Client
    from autonomy.mission import build_tree, load_mission
    from autonomy.runner import Runner

    records = []
    client = Client.open("emu://?world=box&time=virtual")
    spec = load_mission(ROOT / "missions" / "square.yaml")
    Runner(build_tree(spec), client, mission=spec.name, listeners=[records.append]).run()
    client.close()
    assert gather(records).outcome == "succeeded"
    with pytest.raises(ValueError, match="header and its end"):
        gather(records[:-1])
    last = len(records) - 1
    without_truth = [r if i in (0, last) else msgspec.structs.replace(r, truth=None) for i, r in enumerate(records)]
    with pytest.raises(ValueError, match="no truth pose"):
        gather(without_truth)


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
    assert second.verdicts == [(True, "garage: ended inside")]


def test_verdict_lines_read_as_a_person_would_write_them():
    from autonomy.classroom.exercise import Criterion
    from autonomy.classroom.judge import RunFacts, judge
    from autonomy.record import Pose

    world = load_exercise(EXERCISES / "garage.yaml").world
    facts = RunFacts(1, "succeeded", "", 3.0, [(3.0, Pose(500.0, 500.0, -0.3))], [], [], 0.0)
    facing = Criterion("end_heading_deg", 0, 1.0, {"tolerance_deg": 10.0}, "end_heading_deg 0")
    assert judge(facing, facts, world).line == "ended facing 0 deg, needed 0 ± 10 (off by 0)"  # not 360 deg
    nodes = Criterion("max_nodes", 3, 1.0, {}, "max_nodes 3")
    assert judge(nodes, facts, world).line == "uses 1 node, allowed 3"
    # the garage is the box x 2650..2900, y 420..780: from (2000, 1100) its nearest point (2650, 780)
    # is sqrt(650^2 + 320^2) = 724.5 mm away (724.499...), 26 degrees below east
    wandered = RunFacts(1, "succeeded", "", 3.0, [(1.0, Pose(500, 500, 0)), (2.0, Pose(2000, 1100, 0))], [], [], 0)
    reach = Criterion("reach_zone", "garage", 1.0, {}, "reach_zone garage")
    assert judge(reach, wandered, world).line == (
        "garage: never reached, 724 mm south-east of where the robot came closest (2000, 1100 mm)"
    )
    beeped = RunFacts(1, "succeeded", "", 3.0, [(2.5, Pose(2700, 600, 0))], [(2.5, Pose(2700, 600, 0))], [], 0)
    beep = Criterion("beep_near", "garage", 1.0, {"within_mm": 150.0}, "beep_near garage")
    assert judge(beep, beeped, world).line == "beep near garage: beeped inside it at 2.5 s"


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
    graded = grade_module.grade_one

    def noting(exercise, student, path, allow_plugins=False):
        with open(log, "a") as out:
            out.write(f"{student} {os.getpid()}\n")
        if actions and student in actions:
            actions[student]()
        return graded(exercise, student, path, allow_plugins)

    monkeypatch.setattr(grade_module, "grade_one", noting)  # the workers are forked with it

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
        kept.append(bytearray(2 * grade_module.RETIRE_GROWTH_MB * 2**20))

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

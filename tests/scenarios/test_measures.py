"""A scenario's refusals, start pose, measures (beeps, distance, servos), reach windows and what a node can return."""

from __future__ import annotations

from pathlib import Path

import pytest

from autonomy.clock import VirtualClock
from autonomy.emulator import Emulator
from autonomy.emulator.script import SensorScript
from autonomy.record import NodeInfo
from autonomy.scenarios import Coverage, ScenariosInvalid, load_scenarios, run_scenario
from autonomy.scenarios.files import NodeCheck
from autonomy.scenarios.running import NodeWatch
from tests.emulator.test_firmware import exchange
from tests.scenarios.test_scenarios import MISSIONS, ROOT, scenario_file


def problems_of(path: Path) -> list[str]:
    with pytest.raises(ScenariosInvalid) as raised:
        load_scenarios(path)
    return [str(p).replace(str(path), "F") for p in raised.value.problems]


def test_a_script_s_refusals_are_answered_no_from_their_time_on_and_a_stop_never_is():
    emulator = Emulator("empty", clock=VirtualClock())
    robot = emulator.robot
    robot.script = SensorScript(refuses=(("move", 1.0), ("beep", 0.0), ("servo", 0.5)))
    assert exchange(emulator, b"F+100\n") == b"OK\n"  # at 0 s: moves are refused from 1 s on
    assert exchange(emulator, b"S1625\n") == b"NO\n"  # beeps from 0 s on: no beep was made
    assert robot.beeps == []
    assert exchange(emulator, b"M0+10\n") == b"OK\n"  # a servo at 0 s, before its 0.5 s
    robot.time_s = 1.0
    assert exchange(emulator, b"F+100\n") == b"NO\n"
    assert exchange(emulator, b"M0+20\n") == b"NO\n" and exchange(emulator, b"D0+05\n") == b"NO\n"  # both kinds
    assert exchange(emulator, b"T+005\n") == b"OK\n"  # turns are not refused here
    assert exchange(emulator, b"X0000\n") == b"OK\n"  # nor ever a stop
    assert [(servo, angle) for _, servo, angle in robot.servo_moves] == [(0, 10.0)]  # the refused ones not carried out


def test_refusals_start_pose_and_measures_are_read_with_every_problem_at_its_place(tmp_path):
    path = scenario_file(
        tmp_path,
        """\
scenarios:
  - name: one
    world: box
    start: {x_mm: 30, y_mm: 1000, heading: 90}
    sensors:
      refuses: {stop: 1, mve: 2, beep: -1}
    expect:
      beeps: {count: 1, volume: 0}
      distance_mm: [900, 800]
      servos:
        - {id: 0, angles: [10, 1.5]}
        - {id: 3, angles: []}
    nodes:
      - node: beep
        reaches: SUCCESS
        after_s: 4
        before_s: 3
      - node: beep
        runs: true
        after_s: 1
""",
    )
    assert problems_of(path) == [
        "F:4:12: scenarios[0].start: the robot (radius 60 mm) at (30, 1000) would touch a wall or an obstacle of "
        "the world 'box': start it further away",
        "F:4:35: scenarios[0].start.heading: unknown key 'heading' (did you mean 'heading_deg'?)",
        "F:6:17: scenarios[0].sensors.refuses.stop: a stop is never refused: the run's end stops the robot whatever "
        "a scenario says (refuses: takes beep, move, turn, servo)",
        "F:6:26: scenarios[0].sensors.refuses.mve: unknown command 'mve' (did you mean 'move'?): refuses: maps "
        "commands to the time they are refused from, e.g. {move: 12.5} (of beep, move, turn, servo)",
        "F:6:40: scenarios[0].sensors.refuses.beep: must be from 0 to 3,600, got -1",
        "F:8:33: scenarios[0].expect.beeps.volume: must be from 1 to 5, got 0",
        "F:9:20: scenarios[0].expect.distance_mm: the least, 900 mm, is more than the most, 800 mm",
        "F:11:32: scenarios[0].expect.servos[0].angles[1]: expected a whole number, got 1.5",
        "F:12:16: scenarios[0].expect.servos[1].id: must be from 0 to 2, got 3",
        "F:16:18: scenarios[0].nodes[0].after_s: after_s (4 s) must come before before_s (3 s): the window it is "
        "reached in",
        "F:20:18: scenarios[0].nodes[1].after_s: after_s goes with reaches: or never:",
    ]


def test_what_the_run_did_is_said_where_the_scenario_expects_otherwise(tmp_path):
    path = scenario_file(
        tmp_path,
        """\
scenarios:
  - name: asks for what the drive to the wall does not do
    world: box
    time_limit_s: 20
    expect:
      beeps: {count: 2, volume: 5}
      distance_mm: [100, 200]
      servos: [{id: 1, angles: [30]}]
  - name: asks for what it does
    world: box
    time_limit_s: 20
    expect:
      beeps: {count: 1, volume: 2}
      distance_mm: [870, 892]
      servos: [{id: 1, angles: []}]
""",
    )
    tests = load_scenarios(path)
    wrong, right = (run_scenario(tests, s) for s in tests.scenarios)
    assert wrong.seeds[0].failures == [
        "expected 2 beeps, but it beeped 1 time",
        "expected every beep at volume 5, but it beeped at volume 2 at 2.75 s",
        "expected it to drive 100 to 200 mm in all, but it drove 881 mm",
        "expected servo 1 sent to [30], but it was sent to [none]",
    ]
    assert right.passed, right.seeds[0].failures


def test_a_refused_command_fails_its_node_and_the_robot_is_still_stopped_at_the_end(tmp_path):
    path = scenario_file(
        tmp_path,
        """\
scenarios:
  - name: a refused beep
    world: box
    time_limit_s: 10
    sensors:
      refuses: {beep: 0}
    expect:
      outcome: failed
      beeps: 0
    nodes:
      - {node: beep, reaches: FAILURE}
      - {node: move until < 100 mm, reaches: SUCCESS}
  - name: a drive refused from the start, on lost replies too
    world: box
    seeds:
      - {seed: 3, faults: "drop=0.01"}
    time_limit_s: 10
    sensors:
      refuses: {move: 0}
    expect:
      outcome: failed
      distance_mm: [0, 0]
    nodes:
      - {node: move until < 100 mm, reaches: FAILURE, before_s: 2}
      - {node: beep, runs: false}
""",
    )
    tests = load_scenarios(path)
    for scenario in tests.scenarios:
        outcome = run_scenario(tests, scenario)
        assert outcome.passed, outcome.seeds[0].failures  # and "still told to drive" is among what a run checks


def test_a_scenario_s_start_pose_is_where_the_robot_starts_and_the_path_begins(tmp_path):
    from autonomy.classroom.job import run_seed

    path = scenario_file(
        tmp_path,
        """\
scenarios:
  - name: from the west wall, facing north
    world: box
    start: {x_mm: 300, y_mm: 500, heading_deg: 90}
    time_limit_s: 20
    expect:
      outcome: succeeded
      criteria:
        - end_heading_deg: 90
          tolerance_deg: 3
        - rest_distance_ahead_mm: [40, 140]
""",
    )
    tests = load_scenarios(path)
    scenario = tests.scenarios[0]
    facts = run_seed(scenario.exercise, tests.spec, scenario.exercise.seeds[0], start=scenario.start)
    first, last = facts.path[0][1], facts.path[-1][1]
    assert (first.x_mm, first.y_mm, first.heading_deg) == (300, 500, 90)
    assert last.x_mm == pytest.approx(300, abs=1) and 1750 < last.y_mm < 1900  # north, up to the wall at 2000
    assert run_scenario(tests, scenario).passed


def test_a_reach_window_holds_for_the_first_time_in_it_and_says_when_it_was_only_before():
    watch = NodeWatch()
    watch.changes = {0: [(0.0, "RUNNING"), (1.0, "SUCCESS"), (2.0, "RUNNING"), (5.0, "SUCCESS")]}
    watch.end_s = 6.0

    def check(from_s: float | None, before_s: float | None) -> tuple[bool, str]:
        return watch.holds(NodeCheck("n", (0,), "reaches", "SUCCESS", before_s, from_s=from_s))

    assert check(None, 1.5) == (True, "")
    assert check(0.5, 1.5) == (True, "")
    assert check(1.5, 4) == (False, "it first returned SUCCESS (from 1.5 s on) at 5 s")
    assert check(None, 0) == (False, "it first returned SUCCESS at 1 s")
    assert check(4, 5.5) == (True, "")
    # a status kept from before after_s is not reached after it: the node must turn to it from then on
    said = "it turned SUCCESS only before 5.5 s (last at 5 s), and not again from then on"
    assert check(5.5, None) == (False, said)
    assert (
        NodeCheck("n", (0,), "reaches", "SUCCESS", 4, from_s=1.5).words == "'n' reaches SUCCESS after 1.5 s before 4 s"
    )
    assert (
        NodeCheck("n", (0,), "reaches", "SUCCESS", 0.0, from_s=0.0).words == "'n' reaches SUCCESS after 0 s before 0 s"
    )


def _tree(*nodes: tuple[str, str, int | None, dict]) -> list[NodeInfo]:
    return [
        NodeInfo(k, kind, kind, category, params, parent) for k, (kind, category, parent, params) in enumerate(nodes)
    ]


@pytest.mark.parametrize(
    ("tree", "expected"),
    [
        # a sequence of conditions is never RUNNING; of things that never fail, never fails
        ([("sequence", "composite", None, {}), ("collided", "condition", 0, {}), ("healthy", "condition", 0, {})],
         ("SUCCESS", "FAILURE")),
        ([("sequence", "composite", None, {}), ("wait", "action", 0, {}), ("log", "action", 0, {})],
         ("SUCCESS", "RUNNING")),
        # a selector whose last child only succeeds never fails
        ([("selector", "composite", None, {}), ("collided", "condition", 0, {}), ("log", "action", 0, {})],
         ("SUCCESS",)),
        ([("repeat", "decorator", None, {"times": None}), ("move", "action", 0, {})], ("FAILURE", "RUNNING")),
        ([("repeat", "decorator", None, {"times": 3}), ("beep", "action", 0, {})], ("SUCCESS", "FAILURE", "RUNNING")),
        ([("repeat", "decorator", None, {"times": 1}), ("beep", "action", 0, {})], ("SUCCESS", "FAILURE")),
        ([("invert", "decorator", None, {}), ("log", "action", 0, {})], ("FAILURE",)),
        ([("force_success", "decorator", None, {}), ("collided", "condition", 0, {})], ("SUCCESS",)),
        ([("timeout", "decorator", None, {}), ("wait", "action", 0, {})], ("SUCCESS", "FAILURE", "RUNNING")),
        ([("parallel", "composite", None, {"policy": "one"}), ("wait", "action", 0, {}), ("log", "action", 0, {})],
         ("SUCCESS", "RUNNING")),
    ],
)  # fmt: skip
def test_what_a_composite_can_return_follows_from_what_its_children_can(tree, expected):
    from autonomy.mission import BUILTINS

    nodes = _tree(*tree)
    statuses = {n.type: BUILTINS.get(n.type).statuses for n in nodes}
    assert Coverage(nodes, statuses=statuses).possible(nodes[0]) == expected


def test_check_scenario_asserts_in_pytest_what_a_scenario_file_asserts_in_the_same_words(tmp_path):
    from autonomy.testing import check_scenario

    scenario = {
        "world": "box",
        "seeds": [1, 2],
        "expect": {"outcome": "succeeded", "beeps": {"count": 2}, "criteria": [{"max_collisions": 0}]},
        "nodes": [{"node": "beep", "reaches": "SUCCESS", "before_s": 10}],
    }
    outcome = check_scenario(MISSIONS / "move_until_wall.yaml", **scenario)
    assert not outcome.passed
    assert outcome.report.splitlines()[:2] == [
        "seed 1: expected 2 beeps, but it beeped 1 time",
        "seed 2: expected 2 beeps, but it beeped 1 time",
    ]
    import yaml

    path = scenario_file(tmp_path, yaml.safe_dump({"scenarios": [{"name": "as a file", **scenario}]}))
    tests = load_scenarios(path)
    assert run_scenario(tests, tests.scenarios[0]).report == outcome.report  # the same lines, word for word
    scenario["expect"]["beeps"] = 1
    assert check_scenario(MISSIONS / "move_until_wall.yaml", **scenario).passed
    with pytest.raises(ScenariosInvalid, match=r"scenarios\[0\]\.nodes\[0\]\.node: no node named 'bep'"):
        check_scenario(MISSIONS / "move_until_wall.yaml", world="box", nodes=[{"node": "bep", "runs": True}])


def test_the_check_scenario_example_of_the_docs_passes_as_it_stands(monkeypatch):
    import re

    block = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "testing.md").read_text(), re.S)[0]
    monkeypatch.chdir(ROOT)
    space: dict = {}
    exec(compile(block, "docs/testing.md", "exec"), space)  # noqa: S102 - the page's own example
    tests = [value for name, value in space.items() if name.startswith("test_")]
    assert len(tests) == 1
    tests[0]()  # raises with the report if it did not hold


#: The attributes the Cobertura DTD (coverage-04.dtd) requires of each element, and the elements each holds.
COBERTURA_REQUIRED = {
    "coverage": {"line-rate", "branch-rate", "lines-covered", "lines-valid", "branches-covered", "branches-valid",
                 "complexity", "version", "timestamp"},
    "package": {"name", "line-rate", "branch-rate", "complexity"},
    "class": {"name", "filename", "line-rate", "branch-rate", "complexity"},
    "line": {"number", "hits"},
}  # fmt: skip


def test_cobertura_xml_gives_each_mission_line_its_nodes_statuses_seen_as_ci_tools_read_them(tmp_path):
    import subprocess
    import sys
    import xml.etree.ElementTree as ET

    first_two = "".join((MISSIONS / "move_until_wall.test.yaml").read_text().splitlines(True)[:25])
    scenario_file(tmp_path, first_two)  # no scenario makes anything fail: 5 of the 8 statuses
    done = subprocess.run(
        [sys.executable, "-m", "autonomy", "test", "move_until_wall.test.yaml", "--cobertura", "cov.xml"],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    text = (tmp_path / "cov.xml").read_text()
    assert "<!DOCTYPE coverage SYSTEM 'http://cobertura.sourceforge.net/xml/coverage-04.dtd'>" in text
    root = ET.fromstring(text)
    for element in root.iter():
        assert COBERTURA_REQUIRED.get(element.tag, set()) <= set(element.attrib), element.tag
    assert [e.tag for e in root] == ["sources", "packages"]
    assert root.find("sources/source").text == str(tmp_path.resolve())
    (cls,) = root.iter("class")
    assert cls.get("filename") == "move_until_wall.yaml"
    lines = {int(line.get("number")): (line.get("hits"), line.get("condition-coverage")) for line in cls.iter("line")}
    # the sequence (line 5), the move (6) and the beep (7): each ran, none ever failed
    assert lines == {5: ("2", "66% (2/3)"), 6: ("2", "66% (2/3)"), 7: ("1", "50% (1/2)")}
    assert (root.get("lines-covered"), root.get("lines-valid")) == ("3", "3")
    assert (root.get("branches-covered"), root.get("branches-valid"), root.get("branch-rate")) == ("5", "8", "0.6250")


def test_sensors_scripted_by_where_the_robot_is_and_which_way_it_faces():
    from autonomy.emulator.script import Area
    from autonomy.emulator.world import Box, Circle
    from autonomy.record import Pose

    east_half = Area(Box(1000, 0, 2000, 2000), heading_deg=(-45, 45), front_mm=80)
    pit = Area(Circle(500, 500, 100), bump=True, tilt_deg=20)
    script = SensorScript(front_mm=((0.0, 200),), areas=(east_half, pit))
    assert script.front_at(1.0, Pose(1500, 500, 10)) == 80
    assert script.front_at(1.0, Pose(1500, 500, 350)) == 80  # the arc from -45 to 45 goes through 0
    assert script.front_at(1.0, Pose(1500, 500, 90)) == 200  # facing north there: the time's reading
    assert script.front_at(1.0, Pose(900, 500, 0)) == 200
    assert script.front_at(1.0) == 200  # no pose: the times alone
    assert script.bumped_at(1.0, 0.5, Pose(550, 500, 0)) and not script.bumped_at(1.0, 0.5, Pose(700, 500, 0))
    assert script.tilt_at(1.0, Pose(500, 600, 0)) == 20 and script.tilt_at(1.0, Pose(500, 601, 0)) is None
    assert Area(Box(0, 0, 1, 1), heading_deg=(300, 60)).holds(Pose(0.5, 0.5, 10))  # wraps through 0
    for whole in ((0, 360), (-180, 180), (-10, 360)):  # a full turn from one end to the other: every way
        assert all(Area(Box(0, 0, 1, 1), heading_deg=whole).holds(Pose(0.5, 0.5, h)) for h in range(0, 360, 15))


def test_a_wall_seen_only_in_one_part_of_the_floor_stops_the_drive_there(tmp_path):
    path = scenario_file(
        tmp_path,
        """\
scenarios:
  - name: an empty floor with a wall the sensor sees only past x 10500, facing east
    world: empty
    time_limit_s: 20
    sensors:
      where:
        - box: {from_mm: [10500, 0], to_mm: [20000, 20000]}
          heading_deg: [-45, 45]
          front_mm: 80
    expect:
      outcome: succeeded
      distance_mm: [500, 600]
      criteria:
        - max_collisions: 0
  - name: facing west, the same area says nothing, and the drive goes on to the time limit
    world: empty
    start: {x_mm: 15000, y_mm: 10000, heading_deg: 180}
    time_limit_s: 5
    sensors:
      where:
        - box: {from_mm: [10500, 0], to_mm: [20000, 20000]}
          heading_deg: [-45, 45]
          front_mm: 80
    expect:
      outcome: stopped at the time limit
""",
    )
    tests = load_scenarios(path)
    for scenario in tests.scenarios:
        outcome = run_scenario(tests, scenario)
        assert outcome.passed, outcome.report


def test_an_area_s_problems_are_each_at_its_place(tmp_path):
    path = scenario_file(
        tmp_path,
        """\
scenarios:
  - name: one
    world: garage
    sensors:
      where:
        - {zone: garag, front_mm: 80}
        - {box: {from_mm: [0, 0]}, bump: yes}
        - {circle: {center_mm: [1, 1], radius_mm: 5}}
        - {zone: garage, box: {from_mm: [0, 0], to_mm: [1, 1]}, tilt_deg: 5}
        - {zone: garage, front_mm: 80, heading_deg: [0]}
    expect: {outcome: succeeded}
""",
    )
    said = problems_of(path)
    assert said[0].startswith("F:6:18: scenarios[0].sensors.where[0].zone: no zone named 'garag' in the world ")
    assert "(did you mean 'garage'?)" in said[0]
    assert said[1:] == [
        "F:7:17: scenarios[0].sensors.where[1].box: 'to_mm' is missing",
        "F:8:11: scenarios[0].sensors.where[2]: an area says what the sensors report there: front_mm:, bump: true "
        "or tilt_deg:",
        "F:9:11: scenarios[0].sensors.where[3]: an area is one of zone: (a zone of the world), box: or circle: (as "
        "a world's)",
        "F:10:53: scenarios[0].sensors.where[4].heading_deg: heading_deg: is [FROM, TO], the arc counter-clockwise "
        "from FROM to TO it faces in, e.g. [-45, 45] for east",
    ]


def test_the_shipped_scenarios_cover_90_percent_catch_85_percent_and_each_survivor_is_explained():
    import json
    import re
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-m", "autonomy", "test", "missions/", "--mutate", "--json"],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    assert report["failed"] == 0 and len({c["mission"] for c in report["coverage"]}) == 7  # a file for each mission
    seen, possible = sum(c["seen"] for c in report["coverage"]), sum(c["possible"] for c in report["coverage"])
    assert seen / possible >= 0.9 and all(c["percent"] >= 90 for c in report["coverage"]), report["coverage"]
    caught = sum(len(m["caught"]) for m in report["mutation"])
    survived = [change for m in report["mutation"] for change in m["survived"]]
    assert caught / (caught + len(survived)) >= 0.85
    explained = re.sub(r"\s+", " ", (ROOT / "docs" / "testing.md").read_text())
    for change in survived:
        assert f"your tests pass even when {change}" in explained, change


def test_check_scenario_refuses_a_value_no_scenario_file_could_hold_with_its_own_error():
    from autonomy.testing import check_scenario

    with pytest.raises(ScenariosInvalid, match=r"check_scenario:1:1: a scenario's values are numbers, text"):
        check_scenario(MISSIONS / "move_until_wall.yaml", world="box", expect={"within_s": object()})


def test_ctrl_c_while_the_mutants_run_says_so_and_exits_130():
    import os
    import signal
    import subprocess
    import sys

    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "test", "missions/", "--mutate"],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},  # each line as it is said, not at the end
    )  # fmt: skip
    assert process.stdout is not None
    for line in process.stdout:  # the first mission's mutants are said: the six others' are being tried
        if line.startswith("mutants of beep_on_collision.yaml"):
            break
    process.send_signal(signal.SIGINT)  # Ctrl-C (the command takes it, even where a test runner had it ignored)
    _, errors = process.communicate(timeout=60)
    assert process.returncode == 130
    assert errors == "autonomy: interrupted while trying the mutants: no mutation score\n"


def test_the_command_s_own_interrupt_while_a_plugin_loads_or_builds_is_no_problem_of_its_file(tmp_path):
    from autonomy.errors import Interrupted
    from autonomy.mission import MissionInvalid, build_tree, validate_text

    (tmp_path / "slow.py").write_text("from autonomy.errors import Interrupted\nraise Interrupted\n")
    with pytest.raises(Interrupted):  # as if Ctrl-C came while it was imported: the command ends
        validate_text("mission: m\nplugins: [slow]\ntree: stop\n", "m.yaml", tmp_path)
    (tmp_path / "sneaky.py").write_text("raise KeyboardInterrupt\n")  # the plugin's own: its file's problem
    with pytest.raises(MissionInvalid, match="cannot import plugin 'sneaky': KeyboardInterrupt"):
        validate_text("mission: m\nplugins: [sneaky]\ntree: stop\n", "m.yaml", tmp_path)
    (tmp_path / "node.py").write_text(
        "from autonomy.behaviours import RobotAction\nfrom autonomy.errors import Interrupted\n\n\n"
        "class Halt(RobotAction):\n    node_type = 'halt'\n\n    def __init__(self, name, **args):\n"
        "        raise Interrupted\n\n    def update(self):\n        return None\n"
    )
    with pytest.raises(Interrupted):  # as if Ctrl-C came while its node was built
        build_tree(validate_text("mission: m\nplugins: [node]\ntree: halt\n", "m.yaml", tmp_path))

"""Scenario files and ``autonomy test``: read with every problem at its place, run, checked, covered, reported."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import junitparser
import pytest

from autonomy.client import Client
from autonomy.scenarios import Coverage, ScenariosInvalid, load_scenarios, run_scenario
from autonomy.scenarios.files import NodeCheck
from autonomy.scenarios.running import NodeWatch

ROOT = Path(__file__).resolve().parents[2]
MISSIONS = ROOT / "missions"


def scenario_file(folder: Path, text: str, mission: str = "move_until_wall") -> Path:
    """``text`` as ``MISSION.test.yaml`` beside a copy of the shipped mission."""
    shutil.copy(MISSIONS / f"{mission}.yaml", folder / f"{mission}.yaml")
    path = folder / f"{mission}.test.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def autonomy_test(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "autonomy", "test", *args], cwd=cwd, capture_output=True, text=True, timeout=120
    )


GOOD = """\
scenarios:
  - name: stops short of the wall and beeps
    world: box
    seeds: [1, 2]
    time_limit_s: 20
    expect:
      outcome: succeeded
      within_s: 10
      criteria:
        - max_collisions: 0
        - rest_distance_ahead_mm: [40, 140]
    nodes:
      - node: beep
        reaches: SUCCESS
        before_s: 10
      - node: sequence
        never: RUNNING
        after_s: 10
"""


def test_every_problem_of_a_scenario_file_is_at_its_line_and_column_with_a_did_you_mean(tmp_path):
    path = scenario_file(
        tmp_path,
        """\
scenarios:
  - name: one
    world: box
    seed: [1]
    expect:
      outcome: success
    nodes:
      - node: bep
        reaches: SUCCESS
      - node: beep
        reaches: DONE
      - node: beep
        runs: true
        before_s: 3
  - name: one
    world: nowhere
""",
    )
    with pytest.raises(ScenariosInvalid) as raised:
        load_scenarios(path)
    said = [str(p).replace(str(path), "F") for p in raised.value.problems]
    assert said == [
        "F:4:5: scenarios[0].seed: unknown key 'seed' (did you mean 'seeds'?)",
        "F:6:16: scenarios[0].expect.outcome: unknown outcome 'success' (did you mean 'succeeded'?): one of "
        "succeeded, failed, stopped at the time limit, lost the link, stopped by an error, interrupted",
        "F:8:15: scenarios[0].nodes[0].node: no node named 'bep' in the mission (did you mean 'beep'?)",
        "F:11:18: scenarios[0].nodes[1].reaches: unknown status 'DONE': one of SUCCESS, FAILURE, RUNNING",
        "F:14:19: scenarios[0].nodes[2].before_s: before_s goes with reaches:",
        "F:15:5: scenarios[1]: a scenario checks something: expect: (outcome, within_s, criteria, beeps, "
        "distance_mm, servos), nodes:, or both",
        "F:15:11: scenarios[1].name: another scenario is named 'one': each is told by its name",
        "F:16:12: scenarios[1].world: no world named 'nowhere': use one of box, empty, corridor, obstacles, square, "
        "garage, slalom, bump, opening, calibration, or a world file beside the scenario file (nowhere.yaml)",
    ]


def test_a_scenario_file_whose_mission_is_missing_or_broken_says_so_with_the_mission_s_own_problems(tmp_path):
    lonely = tmp_path / "gone.test.yaml"
    lonely.write_text(GOOD)
    with pytest.raises(ScenariosInvalid) as raised:
        load_scenarios(lonely)
    assert "gone.yaml" in str(raised.value)
    path = scenario_file(tmp_path, GOOD)
    (tmp_path / "move_until_wall.yaml").write_text("mission: m\ntree:\n  mvoe: {speed: 3}\n")
    with pytest.raises(ScenariosInvalid) as raised:
        load_scenarios(path)
    assert any("move_until_wall.yaml:3:3" in str(p) and "mvoe" in str(p) for p in raised.value.problems)


def test_a_mission_that_does_what_its_scenario_says_passes_on_every_seed_and_its_nodes_are_covered(tmp_path):
    tests = load_scenarios(scenario_file(tmp_path, GOOD))
    coverage = Coverage(tests.nodes, statuses=tests.statuses)
    (outcome,) = [run_scenario(tests, s, coverage) for s in tests.scenarios]
    assert outcome.passed, outcome.seeds
    assert [s.seed for s in outcome.seeds] == ["seed 1", "seed 2"]
    assert all(s.outcome == "succeeded" for s in outcome.seeds)
    # sequence, move and beep; each ran and succeeded, none failed
    assert coverage.seen == {0: {"RUNNING", "SUCCESS"}, 1: {"RUNNING", "SUCCESS"}, 2: {"SUCCESS"}}
    assert coverage.pairs == (5, 8)  # a beep answers at once: never RUNNING, its type says
    assert coverage.possible(tests.nodes[2]) == ("SUCCESS", "FAILURE")


def test_a_broken_mission_fails_its_scenario_with_what_was_expected_what_happened_and_the_node_running(tmp_path):
    path = scenario_file(tmp_path, GOOD)
    mission = tmp_path / "move_until_wall.yaml"
    mission.write_text(mission.read_text().replace("until_obstacle_mm: 100", "until_obstacle_mm: 5"))
    tests = load_scenarios(path)
    (outcome,) = [run_scenario(tests, s) for s in tests.scenarios]
    assert not outcome.passed
    seed = outcome.seeds[0]
    assert any(f.startswith("expected max_collisions 0: ") and "move until < 5 mm" in f for f in seed.failures), seed
    assert seed.running  # the node the run ended on is named


def test_a_node_s_checks_follow_its_status_from_one_change_to_the_next():
    watch = NodeWatch()
    watch.end_s = 10.0
    watch.changes = {3: [(1.0, "RUNNING"), (4.0, "SUCCESS"), (6.0, "RUNNING"), (8.0, "FAILURE")], 5: [(2.0, "INVALID")]}

    def holds(**given) -> tuple[bool, str]:
        return watch.holds(NodeCheck("n", given.pop("ids", (3,)), **given))

    assert holds(kind="reaches", status="SUCCESS", time_s=5.0) == (True, "")
    assert holds(kind="reaches", status="SUCCESS", time_s=3.0) == (False, "it first returned SUCCESS at 4 s")
    assert holds(kind="reaches", status="FAILURE") == (True, "")
    assert holds(kind="reaches", status="FAILURE", ids=(5,)) == (False, "it never returned FAILURE")
    # RUNNING from 6 s to 8 s: after 7 s it was still running, after 8 s it was not
    assert holds(kind="never", status="RUNNING", time_s=7.0) == (False, "it was RUNNING at 7 s")
    assert holds(kind="never", status="RUNNING", time_s=8.0) == (True, "")
    assert holds(kind="never", status="FAILURE", time_s=9.0) == (False, "it was FAILURE at 9 s")  # until the end
    assert holds(kind="runs", expected=True, ids=(5,)) == (False, "it never ran")  # only ever INVALID
    assert holds(kind="runs", expected=False) == (False, "it ran at 1 s")
    assert holds(kind="runs", expected=False, ids=(5,)) == (True, "")


def test_a_run_whose_last_stop_never_reached_the_robot_fails_its_scenario_whatever_else_held(tmp_path, monkeypatch):
    path = scenario_file(
        tmp_path,
        """\
scenarios:
  - name: drives until the time is up
    world: empty
    time_limit_s: 2
    expect:
      outcome: stopped at the time limit
""",
        mission="square",
    )
    tests = load_scenarios(path)
    (outcome,) = [run_scenario(tests, s) for s in tests.scenarios]
    assert outcome.passed, outcome.seeds  # the runner's stop reached the robot
    # every stop lost on the way, the tree's and the runner's last one: the robot drives on
    monkeypatch.setattr(Client, "stop", lambda self: None)
    monkeypatch.setattr(Client, "safe_stop", lambda self: False)
    (outcome,) = [run_scenario(tests, s) for s in tests.scenarios]
    assert outcome.seeds[0].failures == [
        "the run ended with the robot still told to drive: the stop at the end never reached it"
    ]


def test_autonomy_test_says_a_line_a_scenario_and_exits_0_when_all_hold(tmp_path):
    scenario_file(tmp_path, GOOD)
    done = autonomy_test(str(tmp_path))
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("ok    ") and lines[0].endswith(
        "move_until_wall.test.yaml:2: stops short of the wall and beeps (2 seeds, 5.5 simulated s)"
    )
    assert lines[1].startswith("1 scenario: 1 passed, 0 failed (2 runs, 5.5 simulated s in ")
    assert lines[2] == "coverage of move_until_wall.yaml: 5 of 8 node statuses seen (62.5%)"


def test_autonomy_test_fails_with_each_miss_on_its_own_line_and_writes_junit_a_junit_reader_reads(tmp_path):
    path = scenario_file(tmp_path, GOOD.replace("within_s: 10", "within_s: 2"))
    junit = tmp_path / "results.xml"
    done = autonomy_test(str(path), "--junit", str(junit))
    assert done.returncode == 1
    assert "FAIL  " in done.stdout
    assert "      seed 1: expected it to end within 2 s, but it ended at 2.75 s" in done.stdout.splitlines()
    read = junitparser.JUnitXml.fromfile(str(junit))
    (suite,) = list(read)
    (case,) = list(suite)
    assert (suite.tests, suite.failures, case.name) == (1, 1, "stops short of the wall and beeps")
    (failure,) = case.result
    assert isinstance(failure, junitparser.Failure)
    assert failure.message == "seed 1: expected it to end within 2 s, but it ended at 2.75 s"


def test_autonomy_test_json_holds_each_seed_and_the_coverage_node_by_node(tmp_path):
    scenario_file(tmp_path, GOOD)
    done = autonomy_test(str(tmp_path), "--json")
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    assert (out["passed"], out["failed"]) == (1, 0)
    (scenario,) = out["scenarios"]
    assert [s["outcome"] for s in scenario["seeds"]] == ["succeeded", "succeeded"]
    (coverage,) = out["coverage"]
    assert coverage["nodes"][2] == {
        "id": 2, "path": "sequence/beep", "type": "beep", "seen": ["SUCCESS"], "never": ["FAILURE"]
    }  # fmt: skip


def test_autonomy_test_fails_under_a_coverage_asked_for_and_refuses_what_it_cannot_take(tmp_path):
    scenario_file(tmp_path, GOOD)
    under = autonomy_test(str(tmp_path), "--fail-under", "90")
    assert under.returncode == 1
    assert "coverage under 90%: move_until_wall.yaml (62.5%)" in under.stderr
    assert autonomy_test(str(tmp_path), "--fail-under", "62.6").returncode == 1
    assert autonomy_test(str(tmp_path), "--fail-under", "62.5").returncode == 0
    nothing = autonomy_test(str(tmp_path / "nowhere"))
    assert (nothing.returncode, nothing.stdout) == (2, "")
    assert "no such scenario file" in nothing.stderr and "Traceback" not in nothing.stderr
    (tmp_path / "move_until_wall.test.yaml").write_text("scenarios: [{name: x, world: box, expect: {within_s: nan}}]\n")
    broken = autonomy_test(str(tmp_path))
    assert broken.returncode == 2 and "move_until_wall.test.yaml:1:" in broken.stderr
    assert "Traceback" not in broken.stderr


def test_the_shipped_missions_scenarios_pass():
    done = autonomy_test("missions/")
    assert done.returncode == 0, done.stdout + done.stderr
    assert " 0 failed " in done.stdout


def test_pytest_collects_scenario_files_a_test_a_scenario_with_what_did_not_hold(tmp_path):
    scenario_file(tmp_path, GOOD + GOOD.replace("scenarios:\n", "").replace("beeps", "beeps quickly").replace(
        "within_s: 10", "within_s: 2"))  # fmt: skip
    (tmp_path / "test_plain.py").write_text("def test_plain():\n    assert True\n")
    ran = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist", str(tmp_path)],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert ran.returncode == 1, ran.stdout + ran.stderr
    assert "1 failed, 2 passed" in ran.stdout  # the Python test and the scenario that holds; the one that does not
    assert "scenario 'stops short of the wall and beeps quickly' did not hold:" in ran.stdout
    assert "seed 1: expected it to end within 2 s, but it ended at 2.75 s" in ran.stdout
    assert "Traceback" not in ran.stdout
    (tmp_path / "move_until_wall.test.yaml").write_text("scenarios: [{name: x, world: box, expect: {within_s: -1}}]\n")
    broken = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist", str(tmp_path)],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert broken.returncode == 2 and "move_until_wall.test.yaml:1:" in broken.stdout, broken.stdout


def test_a_mission_s_mutants_each_change_one_thing_and_all_build():
    from autonomy.mission import build_tree, load_mission
    from autonomy.scenarios.mutants import mutants

    made = mutants(load_mission(MISSIONS / "beep_on_collision.yaml"))
    changes = [m.change for m in made]
    assert "'selector' (selector, line 11) is a sequence" in changes
    assert "'selector' (selector, line 11) has memory false" in changes
    assert "'bumped' (sequence, line 15) is a selector" in changes
    assert "'beep' (beep, line 18) is left out of 'bumped' (sequence, line 15)" in changes
    assert "'move backward 150 mm' (move, line 19) has distance_mm 120 instead of 150" in changes
    # the speed of 'move 20 s' is 2: 1.6 and 2.4 round to 2, no change; a beep's volume 5 has no room above
    assert "'beep' (beep, line 18) has volume 4 instead of 5" in changes and not any("volume 6" in c for c in changes)
    assert len(changes) == len(set(changes)) == 17
    for mutant in made:
        build_tree(mutant.spec)
    wander = [m.change for m in mutants(load_mission(MISSIONS / "wander.yaml"))]
    assert "'collided' (collided, line 23) is inverted" in wander
    assert (
        "'beep' (beep, line 11) is left out of 'recover from a bump' (sequence, line 8) (in subtree 'recover')"
        in wander
    )


def test_autonomy_test_mutate_says_each_change_no_scenario_notices_and_the_score(tmp_path):
    scenario_file(tmp_path, GOOD)
    done = autonomy_test(str(tmp_path), "--mutate")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    at = lines.index("mutants of move_until_wall.yaml: 4 of 7 caught (57.1%)")
    assert lines[at + 1 :] == [
        "  your tests pass even when 'move until < 100 mm' (move, line 6) has speed 2 instead of 3",
        "  your tests pass even when 'move until < 100 mm' (move, line 6) has until_obstacle_mm 80 instead of 100",
        "  your tests pass even when 'move until < 100 mm' (move, line 6) has until_obstacle_mm 120 instead of 100",
    ]
    # a scenario that tells where the robot stops catches the thresholds, and the slower drive (it brakes nearer)
    stricter = GOOD.replace("rest_distance_ahead_mm: [40, 140]", "rest_distance_ahead_mm: [50, 70]")
    scenario_file(tmp_path, stricter)
    out = json.loads(autonomy_test(str(tmp_path), "--mutate", "--json").stdout)
    (score,) = out["mutation"]
    assert (score["survived"], len(score["caught"]), score["percent"]) == ([], 7, 100.0)
    failing = GOOD.replace("within_s: 10", "within_s: 1")
    scenario_file(tmp_path, failing)
    tried = autonomy_test(str(tmp_path), "--mutate")
    assert tried.returncode == 1 and "mutants: not tried, as a scenario fails already" in tried.stdout


def test_a_scenario_s_battery_is_the_emulator_s_at_the_start(tmp_path):
    path = scenario_file(
        tmp_path,
        "scenarios:\n  - name: low\n    world: corridor\n    battery: 45\n    time_limit_s: 5\n"
        "    expect: {outcome: succeeded, within_s: 1}\n"
        "  - name: fit\n    world: corridor\n    time_limit_s: 5\n    expect: {outcome: stopped at the time limit}\n",
        mission="patrol",
    )
    tests = load_scenarios(path)
    assert [s.battery for s in tests.scenarios] == [45, None]
    assert all(run_scenario(tests, s).passed for s in tests.scenarios)  # below 50 the patrol ends at once
    path.write_text(path.read_text().replace("battery: 45", "battery: 256"))
    with pytest.raises(ScenariosInvalid, match=r"patrol.test.yaml:4:14: scenarios\[0\].battery: "):
        load_scenarios(path)


def test_scenarios_run_in_processes_of_their_own_say_the_same_in_the_same_order(tmp_path):
    two = GOOD + GOOD.replace("scenarios:\n", "").replace("and beeps", "and beeps, again")
    scenario_file(tmp_path, two)
    shutil.copy(MISSIONS / "patrol.yaml", tmp_path / "patrol.yaml")
    shutil.copy(MISSIONS / "patrol.test.yaml", tmp_path / "patrol.test.yaml")
    alone = autonomy_test(str(tmp_path), "-j", "1", "--json")
    apart = autonomy_test(str(tmp_path), "-j", "2", "--json")
    assert alone.returncode == apart.returncode == 0, apart.stderr
    assert json.loads(alone.stdout) == json.loads(apart.stdout)
    names = [s["name"] for s in json.loads(apart.stdout)["scenarios"]]
    assert names[:2] == ["stops short of the wall and beeps", "stops short of the wall and beeps, again"]
    shipped = load_scenarios(MISSIONS / "patrol.test.yaml").scenarios
    assert names[2:] == [s.name for s in shipped]  # and the patrol's, after them (the files in their order)


def test_the_first_scenarios_of_the_docs_are_the_ones_shipped_beside_their_mission():
    import re

    page = (ROOT / "docs" / "testing.md").read_text()
    first = re.findall(r"```yaml\n(.*?)```", page, re.S)[0]
    assert (MISSIONS / "move_until_wall.test.yaml").read_text().startswith(first)  # and one more, scripted


def test_scripted_sensors_say_what_the_scenario_says_from_each_time_on_whatever_the_world_holds(tmp_path):
    path = scenario_file(
        tmp_path,
        """\
scenarios:
  - name: a wall the sensor sees at 2 s stops the drive, on an empty floor
    world: empty
    time_limit_s: 10
    sensors:
      front_mm: [[0, 255], [2, 80]]
    expect:
      outcome: succeeded
      within_s: 2.2
      criteria:
        - max_collisions: 0
    nodes:
      - node: beep
        reaches: SUCCESS
        before_s: 2.2
""",
    )
    tests = load_scenarios(path)
    (outcome,) = [run_scenario(tests, s) for s in tests.scenarios]
    assert outcome.passed, outcome.seeds
    assert 2.0 <= outcome.seeds[0].time_s <= 2.2  # the drive ended at the first poll after 2 s
    # without the script, the empty floor's sensor sees nothing: the drive goes on to the time limit
    (unscripted,) = [run_scenario(tests, replace(s, script=None)) for s in tests.scenarios]
    assert unscripted.seeds[0].outcome == "stopped at the time limit"


def test_a_scripted_bump_sets_off_what_a_bump_would_and_is_no_impact_to_the_judge(tmp_path):
    path = scenario_file(
        tmp_path,
        """\
scenarios:
  - name: a bump at 3 s, with no wall
    world: empty
    time_limit_s: 12
    sensors:
      bumps_s: [3]
    expect:
      criteria:
        - max_collisions: 0
    nodes:
      - node: bumped
        reaches: RUNNING
        before_s: 3.2
      - node: move 20 s
        reaches: FAILURE
        before_s: 3.2
""",
        mission="beep_on_collision",
    )
    tests = load_scenarios(path)
    (outcome,) = [run_scenario(tests, s) for s in tests.scenarios]
    assert outcome.passed, outcome.seeds


def test_the_robot_reports_what_its_script_says_through_the_protocol_and_drives_as_its_world_lets_it():
    from autonomy.emulator.script import SensorScript

    client = Client.open("emu://?world=empty&time=virtual")
    try:
        robot = client.port.emulator.robot
        robot.script = SensorScript(front_mm=((1.0, 80), (2.0, 30)), bumps_s=(1.5,), tilt_deg=((2.5, -40),))
        robot.script_from_s = started_s = client.clock.now()  # the robot's model is brought to the clock's time
        hold_s = robot.params.collision_hold_s
        seen = []
        client.move(2)
        client.clock.sleep(0.05)  # polls between the script's times, never on one
        for _ in range(30):  # every 0.1 s for 3 s, the status packet as the protocol carries it
            asked_s = client.clock.now() - started_s
            status = client.status()
            seen.append((asked_s, status.front_distance_mm, status.collided, status.tilt_deg))
            client.clock.sleep(0.1)
        client.stop()
    finally:
        client.close()
    for time_s, front, collided, tilt in seen:
        assert front == (255 if time_s < 1.0 else 80 if time_s < 2.0 else 30), (time_s, front)
        assert collided == (1.5 <= time_s < 1.5 + hold_s), (time_s, collided)
        assert tilt == -40 if time_s >= 2.5 else abs(tilt) < 20, (time_s, tilt)  # before: its own lean, driving
    assert robot.impacts == [] and robot.odometer_mm > 300  # it drove on through the wall the sensor "saw"


def test_scripted_sensors_that_cannot_be_are_refused_at_their_place(tmp_path):
    path = scenario_file(
        tmp_path,
        "scenarios:\n  - name: x\n    world: empty\n    expect: {within_s: 5}\n    sensors:\n"
        "      front_mm: [[0, 255], [2, 300], [3, 100], [1, 80]]\n      bumps_s: [-1]\n      tlit_deg: [[0, 5]]\n",
    )
    with pytest.raises(ScenariosInvalid) as raised:
        load_scenarios(path)
    assert [str(p).replace(str(path), "F") for p in raised.value.problems] == [
        "F:6:32: scenarios[0].sensors.front_mm[1][1]: must be from 0 to 255, got 300",
        "F:6:48: scenarios[0].sensors.front_mm[3]: the times go up: 1 s comes after 3 s",
        "F:7:17: scenarios[0].sensors.bumps_s[0]: must be from 0 to 3,600, got -1",
        "F:8:7: scenarios[0].sensors.tlit_deg: unknown key 'tlit_deg' (did you mean 'tilt_deg'?)",
    ]


def test_what_a_node_can_return_is_its_type_s_and_a_plugin_s_node_may_say_it():
    from autonomy.behaviours.base import RobotAction
    from autonomy.mission import BUILTINS
    from autonomy.mission.registry import leaf_type

    said = {name: BUILTINS.get(name).statuses for name in ("beep", "stop", "servo", "wait", "log", "move", "collided")}
    assert said == {
        "beep": ("SUCCESS", "FAILURE"), "stop": ("SUCCESS", "FAILURE"), "servo": ("SUCCESS", "FAILURE"),
        "wait": ("SUCCESS", "RUNNING"), "log": ("SUCCESS",), "move": ("SUCCESS", "FAILURE", "RUNNING"),
        "collided": ("SUCCESS", "FAILURE"),
    }  # fmt: skip
    assert BUILTINS.get("force_success").statuses == ("SUCCESS", "RUNNING")
    wander = load_scenarios(MISSIONS / "wander.test.yaml")
    repeats = [n for n in wander.nodes if n.type == "repeat"]
    assert Coverage(wander.nodes, statuses=wander.statuses).possible(repeats[0]) == ("FAILURE", "RUNNING")  # forever
    square = load_scenarios(MISSIONS / "square.test.yaml")
    assert Coverage(square.nodes, statuses=square.statuses).possible(square.nodes[0]) == (
        "SUCCESS",
        "FAILURE",
        "RUNNING",
    )

    class Quick(RobotAction):
        node_type = "quick"
        statuses = ("SUCCESS",)

    assert leaf_type(Quick).statuses == ("SUCCESS",)

    class Wrong(RobotAction):
        node_type = "wrong"
        statuses = ("DONE",)

    with pytest.raises(ValueError, match=r"Wrong.statuses must name some of SUCCESS, FAILURE and RUNNING"):
        leaf_type(Wrong)


BOOM = """\
from py_trees.common import Status

from autonomy.behaviours import RobotAction


class Boom(RobotAction):
    node_type = "boom"
    doc = "Raises at once."

    def update(self) -> Status:
        raise ValueError("boom")
"""


def test_a_crash_or_a_lost_link_fails_a_scenario_that_did_not_ask_for_it_and_says_why(tmp_path):
    (tmp_path / "boom.py").write_text(BOOM)
    (tmp_path / "crash.yaml").write_text("mission: crash\nplugins: [boom]\ntree:\n  sequence: [boom]\n")
    (tmp_path / "crash.test.yaml").write_text(
        "scenarios:\n  - name: asks for nothing but no crash of a wall\n    world: box\n"
        "    expect: {criteria: [{max_collisions: 0}]}\n"
        "  - name: asks for the crash\n    world: box\n    expect: {outcome: stopped by an error}\n"
    )
    tests = load_scenarios(tmp_path / "crash.test.yaml")
    crashed, asked = [run_scenario(tests, s) for s in tests.scenarios]
    assert asked.passed
    (failure,) = crashed.seeds[0].failures
    assert (
        failure.startswith(
            "expected the outcome 'succeeded' or 'failed' or 'stopped at the time limit', "
            "but the mission was stopped by an error: "
        )
        and "ValueError: boom" in failure
    ), failure
    lost = scenario_file(
        tmp_path,
        "scenarios:\n  - name: a dead link\n    world: box\n    seeds: [{seed: 1, faults: 'drop=0.3'}]\n"
        "    expect: {criteria: [{max_collisions: 0}]}\n",
    )
    (outcome,) = [run_scenario(load_scenarios(lost), s) for s in load_scenarios(lost).scenarios]
    assert not outcome.passed and outcome.seeds[0].outcome in ("lost the link", "no run"), outcome.seeds


def test_within_s_asks_the_mission_to_end_by_itself_and_a_check_of_several_nodes_holds_for_each(tmp_path):
    path = scenario_file(
        tmp_path,
        "scenarios:\n  - name: never ends\n    world: empty\n    time_limit_s: 2\n    expect: {within_s: 100}\n"
        "  - name: every wait\n    world: box\n    time_limit_s: 2\n    nodes:\n"
        "      - {node: wait, reaches: SUCCESS}\n      - {node: fine steps back/wait 0.1 s, runs: false}\n",
        mission="servo_scan",
    )
    tests = load_scenarios(path)
    never, waits = [run_scenario(tests, s) for s in tests.scenarios]
    assert never.seeds[0].failures == [
        "expected it to end by itself within 100 s, but it was stopped at the time limit at 2 s"
    ]
    # the fine steps' wait is named by an ancestor and its own name; the waits after 2 s never ran
    (failure,) = waits.seeds[0].failures
    assert failure.startswith("expected 'wait' reaches SUCCESS, but '") and " (one of the " in failure, failure


def test_a_check_of_nothing_a_mission_given_for_its_tests_and_outputs_over_inputs_are_refused(tmp_path):
    path = scenario_file(tmp_path, "scenarios:\n  - name: nothing\n    world: box\n    expect: {}\n")
    with pytest.raises(ScenariosInvalid, match="a scenario checks something"):
        load_scenarios(path)
    given = autonomy_test(str(tmp_path / "move_until_wall.yaml"))  # the mission: its tests are beside it
    assert "a scenario checks something" in given.stderr
    path.unlink()
    alone = autonomy_test(str(tmp_path / "move_until_wall.yaml"))
    assert (
        alone.returncode == 2
        and "this is a mission, not its tests: they go in move_until_wall.test.yaml" in alone.stderr
    )
    scenario_file(tmp_path, GOOD)
    over = autonomy_test(str(tmp_path), "--junit", str(tmp_path / "move_until_wall.yaml"))
    assert over.returncode == 2 and "is a file the tests read" in over.stderr and over.stdout == ""
    assert (tmp_path / "move_until_wall.yaml").read_text().startswith("mission:")

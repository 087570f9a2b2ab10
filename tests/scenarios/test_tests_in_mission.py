"""A mission's own ``tests:`` list: found, checked, run and collected as a scenario file is.

A run ignores it, and a rewrite of the mission (the blocks' canonical text) keeps it as written.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from autonomy.mission import validate_text
from autonomy.mission.blocks import canonical_text, from_workspace, to_workspace, workspace_json
from autonomy.scenarios import ScenariosInvalid, find_scenario_files, load_scenarios

APPROACH = """\
mission: approach
description: Drive up to the wall, stop short of it, and beep.
world: box
tree:
  sequence:
    - move: {speed: 3, until_obstacle_mm: 100}  # up to the wall
    - beep: {tones: [9, 9, 9], volume: 2}
# its scenarios, which autonomy test runs
tests:
  - name: stops short of the wall and beeps
    world: box
    expect:
      outcome: succeeded
      beeps: 1
      distance_mm: [870, 892]
  - name: a refused beep fails it
    world: box
    sensors:
      refuses: {beep: 0}
    expect:
      outcome: failed
      beeps: 0
"""


def autonomy(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "autonomy", *args], cwd=cwd, capture_output=True, text=True, timeout=120
    )


def test_a_mission_s_tests_are_found_run_and_said_at_their_lines(tmp_path):
    (tmp_path / "approach.yaml").write_text(APPROACH)
    (tmp_path / "plain.yaml").write_text("mission: plain\ntree: stop\n")  # no tests: not a scenario file
    assert find_scenario_files([tmp_path]) == [tmp_path / "approach.yaml"]
    assert find_scenario_files([tmp_path / "approach.yaml"]) == [tmp_path / "approach.yaml"]
    quoted = APPROACH.replace("mission:", '"mission":').replace("\ntree:", "\n'tree':").replace("tests:", '"tests":')
    (tmp_path / "quoted.yaml").write_text(quoted)  # its keys quoted: a mission with tests all the same
    assert find_scenario_files([tmp_path]) == [tmp_path / "approach.yaml", tmp_path / "quoted.yaml"]
    (tmp_path / "quoted.yaml").unlink()
    done = autonomy("test", ".", cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.splitlines()[:3] == [
        "ok    approach.yaml:10: stops short of the wall and beeps (1 seed, 2.8 simulated s)",
        "ok    approach.yaml:16: a refused beep fails it (1 seed, 2.8 simulated s)",
        "2 scenarios: 2 passed, 0 failed (2 runs, 5.5 simulated s in " + done.stdout.splitlines()[2].split(" in ")[1],
    ]
    checked = autonomy("check", "approach.yaml", cwd=tmp_path)
    assert (
        checked.stdout
        == "approach.yaml: ok (mission 'approach', 3 nodes, 2 scenarios in its tests: autonomy test runs them)\n"
    )
    ran = autonomy("run", "approach.yaml", "--fast", cwd=tmp_path)  # a run ignores them
    assert ran.returncode == 0 and "Mission 'approach' succeeded" in ran.stdout, ran.stderr


def test_a_mission_s_tests_are_checked_with_the_mission_each_problem_at_its_place(tmp_path):
    path = tmp_path / "approach.yaml"
    path.write_text(
        APPROACH.replace("beeps: 0", "beeps: zero").replace("world: box\n    sensors", "wrld: box\n    sensors")
    )
    with pytest.raises(ScenariosInvalid) as raised:
        load_scenarios(path)
    said = [str(p).replace(str(path), "F") for p in raised.value.problems]
    assert said == [
        "F:16:5: tests[1]: 'world' is missing",
        "F:17:5: tests[1].wrld: unknown key 'wrld' (did you mean 'world'?)",
        "F:22:14: tests[1].expect.beeps: expected a whole number, got 'zero'",
    ]
    checked = autonomy("check", "approach.yaml", cwd=tmp_path)
    assert checked.returncode == 2
    assert "ok" not in checked.stdout  # not while its tests have problems
    assert "approach.yaml:22:14: tests[1].expect.beeps: expected a whole number, got 'zero'" in checked.stderr
    path.write_text("mission: plain\ntree: stop\n")
    said = r"this is a mission, not its tests: they go in approach.test.yaml beside it, or in a tests: list in it"
    with pytest.raises(ScenariosInvalid, match=said):
        load_scenarios(path)


def test_pytest_collects_a_mission_s_tests(tmp_path):
    (tmp_path / "approach.yaml").write_text(APPROACH.replace("beeps: 1", "beeps: 2"))
    ran = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist", str(tmp_path)],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert ran.returncode == 1 and "1 failed, 1 passed" in ran.stdout, ran.stdout + ran.stderr
    assert "seed 1: expected 2 beeps, but it beeped 1 time" in ran.stdout


def test_the_blocks_keep_a_mission_s_tests_as_written_and_take_no_other_text_for_them(tmp_path):
    spec = validate_text(APPROACH, "approach.yaml", check_world=False)
    tests = APPROACH[APPROACH.index("# its scenarios") :]  # the comment right above it is its too
    assert spec.tests_text == tests
    canonical = canonical_text(spec, APPROACH)
    assert canonical.endswith(tests) and canonical.count("tests:") == 1
    workspace = to_workspace(spec, APPROACH)
    back, again = from_workspace(workspace_json(workspace), "workspace.json")
    assert back == canonical and again.tests_text == tests
    (tmp_path / "approach.yaml").write_text(back)
    assert len(load_scenarios(tmp_path / "approach.yaml").scenarios) == 2  # they still run from the rewritten file
    mission = workspace["blocks"]["blocks"][0]
    mission["data"] = json.dumps({**json.loads(mission["data"]), "tests": "tests: []\ntree: stop\n"})
    from autonomy.mission import MissionInvalid

    with pytest.raises(MissionInvalid, match="the mission's tests are the text of its tests: block, as written"):
        from_workspace(workspace_json(workspace), "workspace.json")


def test_a_mission_s_file_and_its_own_tests_are_one_coverage_and_one_mutation_score(tmp_path):
    (tmp_path / "approach.yaml").write_text(APPROACH)
    (tmp_path / "approach.test.yaml").write_text(
        "scenarios:\n  - name: a refused move fails it\n    world: box\n    sensors: {refuses: {move: 0}}\n"
        "    expect: {outcome: failed}\n"
    )
    done = autonomy("test", ".", "--json", "--mutate", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    assert len(report["scenarios"]) == 3
    # the move's FAILURE is seen in the one file, the beep's in the other: together, all 8
    assert [(c["seen"], c["possible"]) for c in report["coverage"]] == [(8, 8)]
    assert [(len(m["caught"]), m["survived"]) for m in report["mutation"]] == [(7, [])]

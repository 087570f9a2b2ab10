"""The plugin example: Python behaviours declared, validated, catalogued and run like built-ins."""

from pathlib import Path

import pytest
from py_trees.common import Status

from autonomy.mission import BUILTINS, MissionInvalid, load_mission, validate_text
from autonomy.protocol import Turn
from tests.harness import Rig, tree_of
from tests.mission.test_missions import motions, run

MISSIONS = Path(__file__).resolve().parents[2] / "missions"


def plugin_tree(tree: str):
    spec = validate_text(f"mission: p\nplugins: [opening_finder]\ntree:\n{tree}", "p.yaml", MISSIONS)
    from autonomy.mission import build_tree

    return build_tree(spec), spec


def test_plugin_nodes_are_validated_like_built_ins():
    with pytest.raises(MissionInvalid) as info:
        plugin_tree("  turn_until_clear: {mm: 300, stpe_deg: 10}\n")
    assert [str(p) for p in info.value.problems] == [
        "p.yaml:4:26: tree.turn_until_clear.mm: turn_until_clear mm must be 1..255 mm, got 300 "
        "(free space wanted ahead)",
        "p.yaml:4:31: tree.turn_until_clear.stpe_deg: unknown parameter 'stpe_deg' for turn_until_clear "
        "(did you mean 'step_deg'?); it takes mm, step_deg, max_deg, name",
    ]


def test_plugins_do_not_leak_into_the_built_in_registry():
    _, spec = plugin_tree("  heading_near: {heading_deg: 90}\n")
    assert spec.registry.get("heading_near") is not None
    assert BUILTINS.get("heading_near") is None


def test_turn_until_clear_turns_in_steps_until_the_sensor_is_clear():
    root, _ = plugin_tree("  turn_until_clear: {mm: 250, step_deg: 30}\n")
    rig = Rig(root, "world=box")
    rig.emulator.robot.x_mm = 1850  # 90 mm from the east wall, facing it
    assert rig.tick_until_done() == Status.SUCCESS
    assert rig.sent() == [Turn(30), Turn(30), Turn(30)]  # 90 degrees: facing north, 880 mm clear
    assert rig.root.feedback_message.startswith("clear: 255 mm after 90 deg")


def test_turn_until_clear_gives_up():
    root, _ = plugin_tree("  turn_until_clear: {mm: 250, step_deg: 90, max_deg: 90}\n")
    rig = Rig(root, "world=corridor")  # east: the end wall; north: 240 mm to the side wall
    rig.emulator.robot.x_mm = 3850
    rig.emulator.robot.heading_deg = 0
    assert rig.tick_until_done() == Status.FAILURE
    assert rig.root.feedback_message == "no opening of 250 mm found"


def test_heading_near():
    root, _ = plugin_tree("  heading_near: {heading_deg: 350, tolerance_deg: 15}\n")
    assert Rig(root).tick() == Status.SUCCESS  # heading 0 is 10 degrees from 350


def test_explore_mission_runs_with_its_plugin():
    summary, emulator, messages = run("explore")
    assert summary.outcome == "succeeded" and not emulator.robot.impacts
    assert all(t.angle_deg == 45 for t in motions(emulator) if isinstance(t, Turn))
    assert messages and messages[-1].startswith("facing")


def test_a_plugin_that_cannot_be_imported_is_a_mission_error():
    with pytest.raises(MissionInvalid, match=r"p.yaml:2:11: plugins\[0\]: cannot import plugin 'no_such_module'"):
        validate_text("mission: p\nplugins: [no_such_module]\ntree: stop\n", "p.yaml", MISSIONS)


def test_a_plugin_may_not_redefine_a_built_in(tmp_path):
    (tmp_path / "clash_plugin.py").write_text(
        "from autonomy.behaviours import RobotAction\n\n"
        "class Move(RobotAction):\n    node_type = 'move'\n    doc = 'mine'\n"
    )
    with pytest.raises(MissionInvalid, match="node type 'move' is already defined"):
        validate_text("mission: p\nplugins: [clash_plugin]\ntree: stop\n", "p.yaml", tmp_path)


def test_tree_of_helper_builds_without_plugins():
    assert tree_of("  stop\n").name == "stop"


def test_a_plugin_that_exits_on_import_is_reported_not_obeyed(tmp_path):
    (tmp_path / "exiter.py").write_text("import sys\nsys.exit(3)\n")
    mission = tmp_path / "e.yaml"
    mission.write_text("mission: e\nplugins: [exiter]\ntree: stop\n")
    with pytest.raises(MissionInvalid) as caught:
        load_mission(mission)
    assert [str(p) for p in caught.value.problems] == [
        f"{mission}:2:11: plugins[0]: cannot import plugin 'exiter': SystemExit: 3"
    ]

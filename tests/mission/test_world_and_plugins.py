"""A mission's world and plugins, checked in-process: where they are looked for, and what is said."""

from __future__ import annotations

import sys

import pytest

from autonomy.mission import MissionInvalid, load_mission, validate_text
from autonomy.mission.validate import PluginNotFound, import_plugin

WORLD = "arena_mm: [2000, 1500]\nstart: {x_mm: 300, y_mm: 300, heading_deg: 0}\n"


def problems(text: str, base_dir=None) -> list[str]:
    with pytest.raises(MissionInvalid) as caught:
        validate_text(text, "m.yaml", base_dir)
    return [str(p) for p in caught.value.problems]


def test_a_shipped_world_is_taken_by_its_name(tmp_path):
    assert validate_text("mission: t\nworld: corridor\ntree: stop\n", "m.yaml", tmp_path).world == "corridor"


def test_a_world_file_beside_the_mission_is_found_there_and_named_by_its_path(tmp_path):
    (tmp_path / "room.yaml").write_text(WORLD)
    spec = validate_text("mission: t\nworld: room.yaml\ntree: stop\n", "m.yaml", tmp_path)
    assert spec.world == str(tmp_path / "room.yaml")


def test_a_world_given_by_an_absolute_path_is_used_as_it_is(tmp_path):
    (tmp_path / "room.yaml").write_text(WORLD)
    other = tmp_path / "elsewhere"
    other.mkdir()
    spec = validate_text(f"mission: t\nworld: {tmp_path / 'room.yaml'}\ntree: stop\n", "m.yaml", other)
    assert spec.world == str(tmp_path / "room.yaml")


def test_an_unknown_world_is_named_with_a_did_you_mean_and_the_choices(tmp_path):
    assert problems("mission: t\nworld: boxx\ntree: stop\n", tmp_path) == [
        "m.yaml:2:8: world: no world named 'boxx' (did you mean 'box'?): use one of box, empty, corridor, "
        "obstacles, square, garage, slalom, bump, opening, calibration, or a world file beside the mission (boxx.yaml)"
    ]


def test_a_world_named_bare_is_its_file_beside_the_mission_not_a_folder_of_that_name(tmp_path):
    (tmp_path / "hall").mkdir()  # a folder that happens to share the world's name
    (tmp_path / "hall.yaml").write_text("arena_mm: [2000, 1500]\n")
    spec = validate_text("mission: t\nworld: hall\ntree: stop\n", "m.yaml", tmp_path)
    assert spec.world == str(tmp_path / "hall.yaml")
    assert problems("mission: t\nworld: halls.yaml\ntree: stop\n", tmp_path) == [
        f"m.yaml:2:8: world: the world file 'halls.yaml' is not there (beside the mission: {tmp_path / 'halls.yaml'})"
    ]  # a missing file is named as one


def test_a_world_file_with_problems_is_reported_with_each_of_them_at_its_place(tmp_path):
    (tmp_path / "bad.yaml").write_text("arena_mm: [2000, 1500]\nstart: {x_mm: 5000, y_mm: 300}\nwals: []\n")
    found = problems("mission: t\nworld: bad.yaml\ntree: stop\n", tmp_path)
    mine = [p for p in found if p.startswith("m.yaml")]
    theirs = [p.split(": ", 1)[0] for p in found if not p.startswith("m.yaml")]
    assert mine == [f"m.yaml:2:8: world: the world file {tmp_path / 'bad.yaml'} is not valid (2 listed with its name)"]
    assert theirs == [f"{tmp_path / 'bad.yaml'}:2:8", f"{tmp_path / 'bad.yaml'}:3:1"]


def test_a_world_that_cannot_be_read_is_one_problem(tmp_path):
    (tmp_path / "folder.yaml").mkdir()
    assert problems("mission: t\nworld: folder.yaml\ntree: stop\n", tmp_path) == [
        "m.yaml:2:8: world: 'folder.yaml' is not a world file (a folder, a device or a pipe)"
    ]
    assert problems("mission: t\nworld: /dev/zero\ntree: stop\n", tmp_path) == [
        "m.yaml:2:8: world: '/dev/zero' is not a world file (a folder, a device or a pipe)"
    ]


def test_the_world_is_not_looked_at_when_grading_asks_not_to(tmp_path):
    spec = validate_text("mission: t\nworld: boxx\ntree: stop\n", "m.yaml", tmp_path, check_world=False)
    assert spec.world == "boxx"


def write_plugin(folder, module: str, node: str) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{module}.py").write_text(
        "from autonomy.behaviours import RobotCondition\n\n"
        f"class Node(RobotCondition):\n    node_type = '{node}'\n    doc = 'holds'\n"
        "    def check(self):\n        return True\n"
    )


def test_two_missions_with_plugins_of_one_name_each_get_their_own(tmp_path):
    write_plugin(tmp_path / "a", "beh", "alpha_cond")
    write_plugin(tmp_path / "b", "beh", "beta_cond")
    first = validate_text("mission: a\nplugins: [beh]\ntree: alpha_cond\n", "a.yaml", tmp_path / "a")
    second = validate_text("mission: b\nplugins: [beh]\ntree: beta_cond\n", "b.yaml", tmp_path / "b")
    assert first.registry.get("alpha_cond") and not first.registry.get("beta_cond")
    assert second.registry.get("beta_cond") and not second.registry.get("alpha_cond")
    assert "beh" not in sys.modules and str(tmp_path / "a") not in sys.path


def test_a_plugin_package_beside_the_mission_is_loaded(tmp_path):
    write_plugin(tmp_path / "pkg", "__init__", "pkg_cond")
    module = import_plugin("pkg", tmp_path)
    assert module.Node.node_type == "pkg_cond"
    assert import_plugin("pkg", tmp_path) is module  # loaded once


@pytest.mark.parametrize(("name", "said"), [("this", "there is no this.py in"), ("os.path", "is not a module name")])
def test_only_files_beside_the_mission_are_plugins(tmp_path, name, said):
    with pytest.raises(PluginNotFound, match=said):
        import_plugin(name, tmp_path)


def test_a_plugin_that_fails_to_load_can_be_loaded_once_mended(tmp_path):
    (tmp_path / "flaky.py").write_text("raise RuntimeError('not yet')\n")
    with pytest.raises(RuntimeError):
        import_plugin("flaky", tmp_path)
    assert not [m for m in sys.modules if m.endswith("_flaky")]


def test_a_mission_file_that_cannot_be_read_is_one_problem_at_its_place(tmp_path):
    (tmp_path / "m.yaml").write_bytes(b"mission: t\ntree: stop # caf\xe9\n")
    with pytest.raises(MissionInvalid) as caught:
        load_mission(tmp_path / "m.yaml")
    [problem] = caught.value.problems
    assert (problem.file, problem.line, problem.column) == (str(tmp_path / "m.yaml"), 2, 17)
    assert problem.message.startswith("cannot read the file: the byte 0xe9 here is not UTF-8 text")


@pytest.mark.parametrize(
    ("value", "shown"),
    [
        ("true", "true (true/false)"),
        ("~", "nothing"),
        ("[1]", "a list"),
        ("{a: 1}", "a mapping"),
        ("'x'", "'x' (text)"),
    ],
)
def test_a_value_of_the_wrong_kind_is_named_as_a_student_would(value, shown):
    assert problems(f"mission: t\ntree:\n  move: {{speed: {value}}}\n") == [
        f"m.yaml:3:17: tree.move.speed: move speed must be a whole number, got {shown}"
    ]


def test_a_plugin_may_import_the_files_beside_it_and_a_package_its_own_modules(tmp_path):
    (tmp_path / "shared_helpers_for_test.py").write_text("ANSWER = 42\n")
    (tmp_path / "uses_helper.py").write_text("from shared_helpers_for_test import ANSWER\n")
    assert import_plugin("uses_helper", tmp_path).ANSWER == 42
    package = tmp_path / "pkgplug"
    package.mkdir()
    (package / "inner.py").write_text("VALUE = 'inner'\n")
    (package / "__init__.py").write_text("from .inner import VALUE\n")
    assert import_plugin("pkgplug", tmp_path).VALUE == "inner"
    assert str(tmp_path) not in sys.path  # the folder is on the path only while a plugin loads
    sys.modules.pop("shared_helpers_for_test", None)


def test_plugins_of_the_wrong_shape_are_each_said_where_they_stand(tmp_path):
    assert problems("mission: m\nplugins: 5\ntree: stop\n", tmp_path) == [
        "m.yaml:2:10: plugins: plugins is a list of Python module names, e.g. [my_behaviours]"
    ]
    assert problems("mission: m\nplugins: [5]\ntree: stop\n", tmp_path) == [
        "m.yaml:2:11: plugins[0]: a plugin is a module name, got 5"
    ]
    (tmp_path / "empty.py").write_text("X = 1\n")
    assert problems("mission: m\nplugins: [empty]\ntree: stop\n", tmp_path) == [
        "m.yaml:2:11: plugins[0]: plugin 'empty' declares no behaviours "
        "(RobotAction/RobotCondition subclasses with a node_type)"
    ]


def test_a_plugin_that_is_not_there_does_not_stop_the_next_one_from_loading(tmp_path):
    write_plugin(tmp_path, "good", "good_cond")
    (tmp_path / "broken.py").write_text("raise ValueError('not today')\n")
    found = problems("mission: m\nplugins: [nothere, broken, good]\ntree: good_cond\n", tmp_path)
    assert len(found) == 2, found  # the tree's good_cond is known: the third plugin was loaded
    assert found[0].startswith("m.yaml:2:11: plugins[0]: cannot import plugin 'nothere': no plugin 'nothere': ")
    assert found[1] == "m.yaml:2:20: plugins[1]: cannot import plugin 'broken': ValueError: not today"

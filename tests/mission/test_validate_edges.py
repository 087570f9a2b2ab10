"""The edges of the mission checks: limits met exactly, shapes written oddly, files that move."""

from __future__ import annotations

import sys

import pytest

from autonomy.emulator.world import WorldError
from autonomy.mission import MissionInvalid, validate_file, validate_text
from autonomy.mission import validate as validate_module
from autonomy.mission.validate import MAX_TEXT_CHARS, MAX_TREE_DEPTH, MAX_TREE_NODES, _from_attribute
from tests.mission.test_hostile import subtree_chain


def problems(text: str, base_dir=None) -> list[str]:
    with pytest.raises(MissionInvalid) as caught:
        validate_text(text, "m.yaml", base_dir)
    return [str(p) for p in caught.value.problems]


def count_nodes(spec, subtrees) -> int:
    if spec.type.category == "reference":
        return count_nodes(subtrees[spec.args["subtree"]], subtrees)
    return 1 + sum(count_nodes(child, subtrees) for child in spec.children)


# ---------------------------------------------------------------- size limits, met exactly


def test_a_tree_exactly_as_deep_as_allowed_is_accepted_and_one_more_level_is_not():
    spec = validate_text(subtree_chain(MAX_TREE_DEPTH - 1, wrap=True), "m.yaml")  # 49 sequences and a stop
    assert spec.subtrees["s0"].children[0].args == {"subtree": "s1"}
    found = problems(subtree_chain(MAX_TREE_DEPTH, wrap=True))
    assert len(found) == 1 and f"the tree is {MAX_TREE_DEPTH + 1} nodes deep" in found[0]


def sized_tree(extra: str) -> str:
    """A tree of 1 + 3 x 999 nodes (a subtree used three times) and ``extra`` children after them."""
    stops = ", ".join(["stop"] * 998)
    return (
        f"mission: big\nsubtrees:\n  s: {{sequence: [{stops}]}}\n"
        f"tree: {{sequence: [{{subtree: s}}, {{subtree: s}}, {{subtree: s}}, {extra}]}}\n"
    )


def test_a_tree_of_exactly_the_most_nodes_allowed_is_accepted_and_one_more_node_is_not():
    spec = validate_text(sized_tree("stop, stop"), "m.yaml")
    assert count_nodes(spec.tree, spec.subtrees) == MAX_TREE_NODES
    assert problems(sized_tree("stop, stop, stop")) == [
        f"m.yaml:4:8: tree: the tree has more than {MAX_TREE_NODES:,} nodes with its subtrees expanded "
        "(each use of a subtree is a copy)"
    ]


def test_a_subtree_the_reader_refused_adds_nothing_to_the_depth_or_the_size():
    """The refused subtree's own problem is the only one: it neither deepens nor enlarges the tree."""
    refused = "*nowhere"  # an alias without its anchor: the reader refuses the value, and says why
    deep = subtree_chain(MAX_TREE_DEPTH, wrap=True).replace(f"s{MAX_TREE_DEPTH}: stop", f"s{MAX_TREE_DEPTH}: {refused}")
    found = problems(deep)
    assert len(found) == 1 and "the alias *nowhere has no anchor" in found[0], found
    large = sized_tree("stop, stop, {subtree: bad}").replace("subtrees:\n", f"subtrees:\n  bad: {refused}\n")
    found = problems(large)
    assert len(found) == 1 and "the alias *nowhere has no anchor" in found[0], found


def test_the_depth_problem_follows_the_deepest_branch_whichever_child_it_is():
    chain = subtree_chain(60, wrap=True)
    many = ", ".join(["stop"] * 100)
    for tree in (
        f"{{sequence: [stop, {{subtree: s0}}, {{sequence: [{many}]}}]}}",
        f"{{sequence: [{{sequence: [{many}]}}, {{subtree: s0}}, stop]}}",
    ):
        found = problems(chain.replace("tree: {subtree: s0}", f"tree: {tree}"))
        # level 1 is the tree's sequence, so level 51 is the sequence of s49, on line 3 + 49
        assert len(found) == 1 and found[0].startswith(f"m.yaml:{3 + 49}:"), found
        assert f"this node is level {MAX_TREE_DEPTH + 1} from the root" in found[0]


# ---------------------------------------------------------------- settings and text


@pytest.mark.parametrize("value", ["1", "200", "1.0", "200.0"])
def test_tick_hz_accepts_both_ends_of_its_range(value):
    assert validate_text(f"mission: t\ntick_hz: {value}\ntree: stop\n", "m.yaml").tick_hz == float(value)


def test_text_exactly_as_long_as_allowed_is_accepted_and_one_character_more_is_not():
    spec = validate_text(f"mission: t\ndescription: {'d' * MAX_TEXT_CHARS}\ntree: stop\n", "m.yaml")
    assert len(spec.description) == MAX_TEXT_CHARS
    assert problems(f"mission: t\ndescription: {'d' * (MAX_TEXT_CHARS + 1)}\ntree: stop\n") == [
        f"m.yaml:2:14: description: is {MAX_TEXT_CHARS + 1:,} characters long; at most {MAX_TEXT_CHARS:,}"
    ]


def test_xml_is_recognised_by_its_first_character_after_a_bom_and_blank_lines():
    for text in ("\ufeff<root/>", "\n \t<root/>", "\r\n<root/>\n"):
        assert [p.split(": ", 1)[1] for p in problems(text)] == ['no <BehaviorTree ID="..."> in this file']


# ---------------------------------------------------------------- nodes written oddly


def test_a_subtree_used_where_none_are_defined_says_so():
    assert problems("mission: t\ntree: {subtree: corner}\n") == [
        "m.yaml:2:17: tree.subtree: unknown subtree 'corner'; this mission defines no subtrees"
    ]


@pytest.mark.parametrize(("body", "shown"), [("[a]", "a list"), ("3", "3"), ("{a: 1}", "a mapping")])
def test_a_subtree_reference_is_a_name(body, shown):
    assert problems(f"mission: t\ntree: {{subtree: {body}}}\n") == [
        f"m.yaml:2:17: tree.subtree: subtree takes the name of a subtree, e.g. subtree: corner; got {shown}"
    ]


@pytest.mark.parametrize(
    ("name", "said"),
    [
        ('""', "a subtree needs a name that is not blank"),
        ('" "', "a subtree needs a name that is not blank"),
        ('"a\\x07"', "contains the control character '\\x07'; write plain text"),
    ],
)
def test_a_subtree_needs_a_plain_name(name, said):
    found = problems(f"mission: t\nsubtrees:\n  {name}: {{sequence: [stop]}}\ntree: stop\n")
    assert found == [f"m.yaml:3:3: subtrees: {said}"]


def test_a_subtree_with_a_blank_name_is_not_taken_for_the_tree():
    """The tree's references are its own, apart from any subtree's: a blank name used to make a cycle."""
    found = problems('mission: t\nsubtrees:\n  "": {sequence: [stop]}\ntree: {subtree: ""}\n')
    assert found == [
        "m.yaml:3:3: subtrees: a subtree needs a name that is not blank",
        "m.yaml:4:17: tree.subtree: unknown subtree ''; this mission defines no subtrees",
    ]


def test_a_node_with_two_keys_names_them_without_a_hint_when_neither_is_a_type():
    assert problems("mission: t\ntree: {colour: red, size: 3}\n") == [
        "m.yaml:2:7: tree: a node has exactly one key, its type; found colour, size"
    ]


def test_a_node_without_parameters_may_be_written_with_an_empty_body_but_not_with_a_value():
    assert validate_text("mission: t\ntree:\n  stop:\n", "m.yaml").tree.type.name == "stop"
    found = problems("mission: t\ntree:\n  stop: 3\n")
    assert len(found) == 1 and found[0].startswith("m.yaml:3:9: tree.stop: stop takes its parameters as a mapping")


def test_an_attribute_number_of_at_most_40_characters_is_read_as_a_number():
    assert _from_attribute("number", "1." + "0" * 38) == 1.0  # 40 characters
    assert _from_attribute("number", "1." + "0" * 39) == "1." + "0" * 39  # 41: left as text, refused as such


# ---------------------------------------------------------------- plugins and worlds


def test_every_plugin_entry_is_checked_after_one_that_is_not_a_name(tmp_path):
    found = problems("mission: t\nplugins: [3, nowhere]\ntree: stop\n", tmp_path)
    assert [f.split(": ", 2)[1] for f in found] == ["plugins[0]", "plugins[1]"]
    assert "no plugin 'nowhere'" in found[1]


def test_a_plugin_that_exits_without_a_code_is_named_without_a_dangling_colon(tmp_path):
    (tmp_path / "quiet_exit.py").write_text("import sys\nsys.exit()\n")
    assert problems("mission: t\nplugins: [quiet_exit]\ntree: stop\n", tmp_path) == [
        "m.yaml:2:11: plugins[0]: cannot import plugin 'quiet_exit': SystemExit"
    ]


def test_a_plugin_package_imports_its_own_modules(tmp_path):
    package = tmp_path / "pkg_beh"
    package.mkdir()
    (package / "parts.py").write_text(
        "from autonomy.behaviours.base import RobotCondition\n\n"
        "class Always(RobotCondition):\n    node_type = 'always_pkg'\n\n"
        "    def check(self, status):\n        return True\n"
    )
    (package / "__init__.py").write_text("from .parts import Always\n")
    before = set(sys.modules)
    try:
        spec = validate_text("mission: t\nplugins: [pkg_beh]\ntree: always_pkg\n", "m.yaml", tmp_path)
    finally:
        for name in set(sys.modules) - before:  # the plugin's modules go with the test
            del sys.modules[name]
    assert spec.tree.type.name == "always_pkg"


def test_a_world_file_that_goes_between_the_check_and_the_load_is_a_problem_at_the_world_line(tmp_path, monkeypatch):
    (tmp_path / "room.yaml").write_text("arena_mm: [2000, 2000]\n")

    def vanished(path):
        raise WorldError(f"no world named '{path}'")

    monkeypatch.setattr(validate_module, "load_world", vanished)
    assert problems("mission: t\nworld: room.yaml\ntree: stop\n", tmp_path) == [
        f"m.yaml:2:8: world: no world named '{tmp_path / 'room.yaml'}'"
    ]


def test_a_world_given_by_its_absolute_path_is_used_as_it_is(tmp_path):
    world = tmp_path / "elsewhere" / "room.yaml"
    world.parent.mkdir()
    world.write_text("arena_mm: [2000, 2000]\n")
    spec = validate_text(f"mission: t\nworld: {world}\ntree: stop\n", "m.yaml", tmp_path / "missions")
    assert spec.world == str(world)


def test_a_mission_file_is_checked_with_its_world_unless_told_not_to(tmp_path):
    mission = tmp_path / "m.yaml"
    mission.write_text("mission: t\nworld: nowhere.yaml\ntree: stop\n")
    with pytest.raises(MissionInvalid, match="the world file 'nowhere.yaml' is not there"):
        validate_file(mission)
    assert validate_file(mission, check_world=False).world == "nowhere.yaml"


def test_a_subtree_that_only_leads_to_a_loop_is_not_said_to_include_itself():
    text = (
        "mission: t\nsubtrees:\n"
        "  outer: {sequence: [{subtree: loop}, {subtree: leaf}]}\n"
        "  loop: {sequence: [{subtree: loop}]}\n"
        "  leaf: stop\n"
        "tree: {subtree: outer}\n"
    )
    assert problems(text) == [
        "m.yaml:3:32: subtrees.outer.sequence[0].subtree: subtree 'loop' includes itself "
        "(directly or through other subtrees)"
    ]


def test_every_node_knows_its_path_in_the_file():
    spec = validate_text(
        "mission: t\nsubtrees:\n  s: stop\ntree:\n  sequence:\n    - beep\n    - {subtree: s}\n"
        "    - {timeout: {seconds: 1, do: {wait: {seconds: 2}}}}\n",
        "m.yaml",
    )
    paths = []
    todo = [spec.tree]
    while todo:
        node = todo.pop(0)
        paths.append(node.path)
        todo += node.children
    assert paths == [
        "tree.sequence",
        "tree.sequence[0].beep",
        "tree.sequence[1].subtree",
        "tree.sequence[2].timeout",
        "tree.sequence[2].timeout.do.wait",
    ]
    assert spec.subtrees["s"].path == "subtrees.s.stop"


def test_a_plugin_file_is_a_module_not_a_package(tmp_path):
    """A relative import needs a package: a plugin that is one file cannot make one."""
    (tmp_path / "helpers.py").write_text("VALUE = 1\n")
    (tmp_path / "relative.py").write_text("from . import helpers\n")
    found = problems("mission: t\nplugins: [relative]\ntree: stop\n", tmp_path)
    assert found == [
        "m.yaml:2:11: plugins[0]: cannot import plugin 'relative': "
        "ImportError: attempted relative import with no known parent package"
    ]


@pytest.mark.parametrize(("value", "shown"), [("3", "3"), ('""', "'' (text)"), ("[a]", "a list")])
def test_a_node_name_must_be_text(value, shown):
    found = problems(f"mission: t\ntree:\n  beep: {{name: {value}}}\n")
    assert found == [f"m.yaml:3:16: tree.beep.name: name must be text, got {shown}"]


def test_a_subtree_name_refused_does_not_hide_the_subtrees_after_it():
    found = problems('mission: t\nsubtrees:\n  "": stop\n  "a\\x07": stop\n  b: stop\ntree: {subtree: b}\n')
    assert [f.split(": ", 2)[1] for f in found] == ["subtrees", "subtrees"], found


def test_a_subtree_that_includes_itself_through_a_decorator_is_found():
    found = problems("mission: t\nsubtrees:\n  s: {repeat: {times: 2, do: {subtree: s}}}\ntree: {subtree: s}\n")
    assert found == [
        "m.yaml:3:40: subtrees.s.repeat.do.subtree: subtree 's' includes itself (directly or through other subtrees)"
    ]


def test_a_text_larger_than_a_mission_file_is_refused_before_it_is_read():
    from autonomy.source import MAX_FILE_BYTES

    for text in ("x" * 2_000_000, "mission: m\ntree: {log: {message: '" + "é" * (MAX_FILE_BYTES // 2) + "'}}\n"):
        with pytest.raises(MissionInvalid) as refused:
            validate_text(text, "big.yaml")
        (problem,) = refused.value.problems
        assert (problem.line, problem.column) == (1, 1) and f"at most {MAX_FILE_BYTES:,}" in problem.message

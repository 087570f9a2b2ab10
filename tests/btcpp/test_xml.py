"""Missions in BehaviorTree.CPP 4 XML: exported, read back with the same checks as YAML, and imported to YAML."""

from __future__ import annotations

from pathlib import Path

import pytest

from autonomy.mission import MissionInvalid, load_mission, validate_text
from autonomy.mission.btcpp import ExportError, export_xml, palette_xml, to_yaml
from autonomy.mission.registry import BUILTINS
from tests.harness import mission_files

MISSIONS = mission_files(Path("missions").glob("*.yaml"))


def shape(spec):
    """A node as plain data (type, name, arguments, children), to compare two missions' trees."""
    args = sorted((k, tuple(v) if isinstance(v, list) else v) for k, v in spec.args.items())
    return (spec.type.name, spec.name, args, [shape(child) for child in spec.children])


def tree_of(spec):
    return shape(spec.tree), {name: shape(sub) for name, sub in spec.subtrees.items()}


def settings_of(spec):
    return spec.name, spec.description.strip(), spec.tick_hz, spec.world, spec.plugins


@pytest.mark.parametrize("path", MISSIONS, ids=lambda p: p.stem)
def test_yaml_to_xml_to_yaml_gives_the_same_mission(path):
    spec = load_mission(path)
    from_xml = validate_text(export_xml(spec), str(path.with_suffix(".xml")), path.parent)
    back = validate_text(to_yaml(from_xml), str(path), path.parent)
    assert tree_of(from_xml) == tree_of(spec) == tree_of(back)
    assert settings_of(from_xml) == settings_of(spec) == settings_of(back)


def problems(xml: str) -> list[str]:
    with pytest.raises(MissionInvalid) as caught:
        validate_text(xml, "tree.xml")
    return [str(p) for p in caught.value.problems]


def one(body: str, main: str = "m", extra: str = "") -> str:
    head = f'<root BTCPP_format="4" main_tree_to_execute="{main}">\n  <BehaviorTree ID="m">\n'
    return f"{head}{body}\n  </BehaviorTree>{extra}\n</root>\n"


def test_a_drawn_tree_checks_like_yaml_with_line_column_and_did_you_mean():
    xml = one(
        '    <Sequence>\n      <mvoe speed="2"/>\n      <move sped="2"/>\n      <turn left="ninety"/>\n    </Sequence>'
    )
    assert problems(xml) == [
        "tree.xml:4:7: tree.sequence.children[0].mvoe: unknown node 'mvoe' (did you mean 'move'?)",
        "tree.xml:5:7: tree.sequence.children[1].move: move needs 'speed' (speed setting, 1 slow .. 4 very fast)",
        "tree.xml:5:13: tree.sequence.children[1].move.sped: unknown parameter 'sped' for move "
        "(did you mean 'speed'?); it takes speed, direction, distance_mm, seconds, until_obstacle_mm, name",
        "tree.xml:6:13: tree.sequence.children[2].turn.left: turn left must be a whole number, got 'ninety' (text)",
    ]


def test_values_are_read_as_their_parameters_kind():
    xml = one(
        '    <Sequence>\n      <beep tones="1;5;9" volume="0"/>\n'
        '      <move speed="+3" seconds="1.5e0"/>\n    </Sequence>'
    )
    spec = validate_text(xml, "tree.xml")
    beep, move = spec.tree.children
    assert beep.args["tones"] == [1, 5, 9] and beep.args["volume"] == 0
    assert move.args["speed"] == 3 and move.args["seconds"] == 1.5
    assert problems(one('    <beep tones="1;5"/>'))[0].endswith(
        "beep tones must be three tones 1..9, as in [5, 7, 9]; got '1;5'"
    )


def test_behaviortree_cpp_structure_maps_to_ours():
    xml = one(
        """    <ReactiveFallback name="top">
      <Repeat num_cycles="-1"><Timeout msec="2500"><move speed="1"/></Timeout></Repeat>
      <RetryUntilSuccessful num_attempts="3"><Inverter><collided/></Inverter></RetryUntilSuccessful>
      <Parallel success_count="1" failure_count="1">
        <ForceSuccess><stop/></ForceSuccess><RunOnce then_skip="false"><beep/></RunOnce>
      </Parallel>
      <Action ID="turn" left="90"/>
      <Condition ID="collided" name="hit"/>
    </ReactiveFallback>"""
    )
    spec = validate_text(xml, "tree.xml")
    top = spec.tree
    assert (top.type.name, top.args["memory"], top.name) == ("selector", False, "top")
    repeat, retry, parallel, turn, hit = top.children
    assert (repeat.type.name, repeat.args["times"]) == ("repeat", None)
    assert (repeat.children[0].type.name, repeat.children[0].args["seconds"]) == ("timeout", 2.5)
    assert (retry.args["attempts"], retry.children[0].type.name) == (3, "invert")
    assert parallel.args["policy"] == "one"
    assert [c.type.name for c in parallel.children] == ["force_success", "once"]
    assert (turn.type.name, turn.args["left"], hit.type.name, hit.name) == ("turn", 90, "collided", "hit")


@pytest.mark.parametrize(
    ("body", "expected"),
    [
        ('<Parallel success_count="2"><stop/><stop/></Parallel>', "3:15: autonomy's parallel succeeds when all"),
        ('<Delay delay_msec="5"><stop/></Delay>', "3:5: BehaviorTree.CPP's Delay has no autonomy equivalent: use"),
        ('<Timeout msec="soon"><stop/></Timeout>', "3:14: Timeout msec must be a whole number, got 'soon'"),
        ("<Inverter><stop/><stop/></Inverter>", "3:5: Inverter takes exactly one child, got 2"),
        ('<stop _skipIf="x"/>', "3:11: BehaviorTree.CPP's _skipIf"),
        ("<stop><stop/></stop>", "3:5: <stop> has children, but it is a leaf here"),
        ('<SubTree ID="x" goal="{g}"/>', '3:21: goal="{g}" reads a blackboard entry'),
        ('<SubTree ID="x" goal="g"/>', "3:21: SubTree port 'goal': autonomy has no blackboard to remap"),
        ("<Action/>", '3:5: <Action> needs ID="..."'),
        ("<RunOnce><stop/></RunOnce>", '3:5: RunOnce needs then_skip="false": autonomy\'s once gives'),
        ('<RunOnce then_skip="true"><stop/></RunOnce>', "3:14: RunOnce needs then_skip"),
        ('<log message="{msg}"/>', '3:10: message="{msg}" reads a blackboard entry; autonomy has no blackboard'),
        (
            '<RetryUntilSuccessful num_attempts="-1"><stop/></RetryUntilSuccessful>',
            "3:27: RetryUntilSuccessful num_attempts -1",
        ),
        (
            "<Sequnce><stop/></Sequnce>",
            "3:5: <Sequnce> has children, but it is not a control or decorator node autonomy knows "
            "(did you mean 'Sequence'?)",
        ),
        ("<Fallbak/>", "3:5: unknown node 'Fallbak' (did you mean 'Fallback'?)"),
        ("<LoopInt><stop/></LoopInt>", "3:5: BehaviorTree.CPP's LoopInt has no autonomy equivalent"),
        ("<Sequence/>", "3:5: <Sequence> needs at least one child"),
        ('<SubTree ID="m"/>', "3:14: SubTree 'm' is the main tree: it would hold itself"),
        ('<Timeout msec="0"><stop/></Timeout>', "3:14: Timeout msec must be above 0, got 0"),
    ],
)
def test_what_behaviortree_cpp_has_and_autonomy_does_not_is_said_where_it_stands(body, expected):
    found = problems(one("    " + body))
    assert any(expected in p for p in found), found


@pytest.mark.parametrize(
    ("xml", "expected"),
    [
        ("", "tree.xml:1:1: the file is empty"),
        ("hello", "tree.xml:1:1: not XML: a BehaviorTree.CPP file starts with"),
        ("<root><BehaviorTree ID='m'><stop></BehaviorTree></root>", "tree.xml:1:36: this closing tag does not match"),
        ('<!DOCTYPE r [<!ENTITY a "aaaa">]><root/>', "tree.xml:1:1: a DOCTYPE"),
        ("<root/>", 'tree.xml:1:1: no <BehaviorTree ID="..."> in this file'),
        ("<tree/>", 'tree.xml:1:1: expected <root BTCPP_format="4">, found <tree>'),
        ('<root BTCPP_format="3"><BehaviorTree ID="m"><stop/></BehaviorTree></root>', "tree.xml:1:7: BTCPP_format '3'"),
        (
            "<root><BehaviorTree ID='a'><stop/></BehaviorTree><BehaviorTree ID='b'><stop/></BehaviorTree></root>",
            "tree.xml:1:1: several trees: say which is the mission",
        ),
        (
            '<root main_tree_to_execute="x"><BehaviorTree ID="m"><stop/></BehaviorTree></root>',
            'tree.xml:1:7: no <BehaviorTree ID="x"> in this file',
        ),
        ("<root><BehaviorTree ID='m'><stop/>text</BehaviorTree></root>", "text inside <BehaviorTree>"),
        (
            "<root><BehaviorTree ID='m'>\u200b<stop/></BehaviorTree></root>",
            "tree.xml:1:28: an invisible zero width space",
        ),
    ],
)
def test_a_file_that_is_not_a_tree_says_so_where_it_goes_wrong(xml, expected):
    found = problems(xml)
    assert any(expected in p for p in found), found


def test_a_billion_laughs_or_a_deep_or_huge_tree_is_refused_without_expanding():
    laughs = (
        '<?xml version="1.0"?><!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;">]><root>&lol2;</root>'
    )
    assert "a DOCTYPE" in problems(laughs)[0]
    deep = "<Inverter>" * 150 + "<stop/>" + "</Inverter>" * 150
    assert "nested more than 100 levels deep" in problems(one(deep))[0]
    many = "<Sequence>" + "<stop/>" * 10_001 + "</Sequence>"
    assert "more than 10,000 elements" in problems(one(many))[0]


def test_subtrees_and_the_missions_settings_come_back():
    xml = one(
        '    <SubTree ID="corner"/>',
        extra='\n  <BehaviorTree ID="corner"><Sequence><turn left="90"/><beep/></Sequence></BehaviorTree>',
    ).replace('<BehaviorTree ID="m">', '<BehaviorTree ID="m" _tick_hz="50" _description="a square" _world="box">')
    spec = validate_text(xml, "tree.xml")
    assert (spec.name, spec.tick_hz, spec.description, spec.world) == ("m", 50.0, "a square", "box")
    assert spec.tree.type.name == "subtree" and list(spec.subtrees) == ["corner"]
    bad = xml.replace('_tick_hz="50"', '_tick_hz="fast"').replace('SubTree ID="corner"', 'SubTree ID="cornr"')
    found = problems(bad)
    assert any("tree.xml:2:24: tick_hz: tick_hz must be a number, got 'fast' (text)" in p for p in found), found
    assert any("unknown subtree 'cornr' (did you mean 'corner'?)" in p for p in found), found


def test_a_timeout_of_a_fraction_of_a_millisecond_is_not_exported_as_a_lie():
    spec = validate_text("mission: m\ntree:\n  timeout: {seconds: 0.0005, do: stop}\n", "m.yaml")
    with pytest.raises(ExportError, match="not a whole number of milliseconds"):
        export_xml(spec)


def test_the_palette_declares_every_leaf_with_its_ports_and_nothing_behaviortree_cpp_knows():
    text = palette_xml(BUILTINS)
    for node_type in BUILTINS:
        if node_type.category in ("action", "condition"):
            tag = "Action" if node_type.category == "action" else "Condition"
            assert f'<{tag} ID="{node_type.name}">' in text
            for param in node_type.params:
                assert f'<input_port name="{param.name}"' in text
    assert "While" not in text and "Sequence" not in text  # our while is BehaviorTree.CPP's own ReactiveSequence


def test_every_problem_of_a_drawn_tree_comes_at_once():
    xml = one(
        '    <Sequence>\n      <Delay delay_msec="5"><stop/></Delay>\n      <move speed="9"/>\n'
        '      <stop _skipIf="x"/>\n      <mvoe/>\n    </Sequence>'
    )
    found = problems(xml)
    assert len(found) == 4, found
    assert [p.split(": ")[0] for p in found] == ["tree.xml:4:7", "tree.xml:5:13", "tree.xml:6:13", "tree.xml:7:7"]


def test_ports_groot2_leaves_empty_count_as_not_given():
    xml = one('    <move speed="2" distance_mm="300" seconds="" until_obstacle_mm=" "/>')
    move = validate_text(xml, "tree.xml").tree
    assert (move.args["distance_mm"], move.args["seconds"], move.args["until_obstacle_mm"]) == (300, None, None)
    turn = validate_text(one('    <turn left="90" right=""/>').replace('ID="m"', 'ID="m" _description=""'), "t.xml")
    assert turn.tree.args["left"] == 90 and turn.description == ""


def test_a_plugin_leaf_named_like_a_behaviortree_cpp_node_is_exported_in_the_explicit_form():
    from autonomy.behaviours import Param, RobotAction
    from autonomy.mission.registry import leaf_type

    class Timeout(RobotAction):
        node_type = "Timeout"
        params = (Param("msec", "int", "how long"),)

    registry = BUILTINS.copy()
    registry.add(leaf_type(Timeout, "plugin"))
    spec = validate_text("mission: m\ntree:\n  Timeout: {msec: 5}\n", "m.yaml", registry=registry)
    xml = export_xml(spec)
    assert '<Action ID="Timeout" msec="5"/>' in xml
    back = validate_text(xml, "m.xml", registry=registry)
    assert shape(back.tree) == shape(spec.tree)


def test_a_sub_millisecond_timeout_runs_logged_to_the_nearest_millisecond():
    from autonomy.mission.btcpp import instance

    spec = validate_text("mission: m\ntree:\n  timeout: {seconds: 0.0015, do: stop}\n", "m.yaml")
    assert 'msec="2"' in instance(spec).xml


def test_columns_count_characters_on_a_long_line_of_several_byte_ones():
    body = '<Sequence name="' + "é" * 900 + '">' + "<stop/>" * 2500 + '<turn lft="90"/></Sequence>'
    text = "\ufeff" + one(body).replace("\n", "")  # one line, a byte-order mark first
    found = problems(text)
    column = text.index('lft="90"')  # characters before it, the mark not counted, from 1
    said = [p for p in found if "unknown parameter 'lft'" in p]
    assert len(said) == 1 and said[0].startswith(f"tree.xml:1:{column}: "), found


@pytest.mark.parametrize(
    ("kind", "text", "value"),
    [
        ("bool", "true", True),
        ("bool", "FALSE", False),
        ("bool", "1", True),
        ("bool", " 0 ", False),
        ("bool", "yes", "yes"),
        ("int", "+3", 3),
        ("int", "3.0", "3.0"),
        ("number", "-2", -2),
        ("number", "1.5e3", 1500.0),
        ("number", ".5", 0.5),
        ("number", "INF", float("inf")),
        ("number", "1" * 41 + ".0", "1" * 41 + ".0"),  # longer than any number a mission holds: left as text
        ("number", "1" * 38 + ".0", float("1" * 38)),
        ("tones", "1;5;9", [1, 5, 9]),
        ("tones", "1;5;x", "1;5;x"),
        ("string", "0", "0"),
    ],
)
def test_an_attribute_is_read_as_its_parameters_kind_or_left_as_text_for_the_check_to_name(kind, text, value):
    from autonomy.mission.validate import _from_attribute

    got = _from_attribute(kind, text)
    assert got == value and type(got) is type(value)


def test_a_subtree_given_something_else_than_a_name_says_so_where_it_stands():
    found = problems(one("    <SubTree/>"))
    assert found == ['tree.xml:3:5: <SubTree> needs ID="...", the node type']
    with pytest.raises(MissionInvalid) as caught:
        validate_text("mission: m\ntree:\n  subtree: [a, b]\n", "m.yaml")
    (problem,) = caught.value.problems
    assert (problem.line, problem.column, problem.path) == (3, 12, "tree.subtree")
    assert problem.message == "subtree takes the name of a subtree, e.g. subtree: corner; got a list"


def test_the_nodes_under_a_refused_node_and_beside_a_missing_main_tree_are_checked_too():
    found = problems(
        one(
            "    <Sequence>\n      <Sequnce><mvoe/></Sequnce>\n"
            '      <Delay delay_msec="1"><move speed="true"/></Delay>\n'
            '      <RunOnce><move speed="9" distance_m="1"/></RunOnce>\n    </Sequence>'
        )
    )
    said = "\n".join(found)
    for expected in (
        "4:7: <Sequnce> has children",
        "4:16: tree.sequence.children[0].sequence.children[0].mvoe: unknown node 'mvoe'",
        "5:7: BehaviorTree.CPP's Delay",
        "move speed must be a whole number, got 'true' (text)",
        "6:7: RunOnce needs then_skip",
        "unknown parameter 'distance_m' for move (did you mean 'distance_mm'?)",
    ):
        assert expected in said, found
    two = (
        '<root><BehaviorTree ID="a"><move speed="2" distance_m="1"/></BehaviorTree>'
        '<BehaviorTree ID="b"><stop/></BehaviorTree></root>'
    )
    found = problems(two)
    assert any("several trees" in p for p in found) and any("distance_m" in p for p in found), found


@pytest.mark.parametrize(
    ("body", "said"),
    [
        ('<Repeat num_cycles=""><stop/></Repeat>', "3:5: Repeat needs num_cycles (-1: forever)"),
        ("<Repeat><stop/></Repeat>", "3:5: Repeat needs num_cycles (-1: forever)"),
    ],
)
def test_a_repeat_says_how_often_as_behaviortree_cpp_requires(body, said):
    assert any(said in p for p in problems(one("    " + body)))


def test_then_skip_zero_is_false_and_braces_around_nothing_are_text():
    spec = validate_text(
        one('    <Sequence><RunOnce then_skip="0"><stop/></RunOnce><log message="{}"/></Sequence>'), "t.xml"
    )
    once, log = spec.tree.children
    assert once.type.name == "once" and log.args["message"] == "{}"


def test_export_refuses_text_that_behaviortree_cpp_would_read_as_a_blackboard_entry():
    spec = validate_text('mission: y\ntree:\n  log: {message: "{hello}"}\n', "y.yaml")
    with pytest.raises(ExportError, match=r"'\{hello\}' would be read by BehaviorTree.CPP as a blackboard entry"):
        export_xml(spec)

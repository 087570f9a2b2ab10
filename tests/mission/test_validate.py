"""Every class of mission error: file, line, column, YAML path and message, all at once."""

import textwrap

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from autonomy.mission import MissionInvalid, validate_file, validate_text


def problems(text: str) -> list[str]:
    with pytest.raises(MissionInvalid) as info:
        validate_text(textwrap.dedent(text), "m.yaml")
    return [str(p) for p in info.value.problems]


def one(text: str) -> str:
    found = problems(text)
    assert len(found) == 1, found
    return found[0]


def test_unknown_node_suggests_the_right_one():
    assert (
        one("""\
        mission: t
        tree:
          sequence:
            - trun: {left: 90}
        """)
        == "m.yaml:4:7: tree.sequence[0].trun: unknown node 'trun' (did you mean 'turn'?)"
    )


def test_unknown_parameter_suggests_and_lists():
    assert one("mission: t\ntree:\n  move: {sped: 2, speed: 1}\n") == (
        "m.yaml:3:10: tree.move.sped: unknown parameter 'sped' for move (did you mean 'speed'?); "
        "it takes speed, direction, distance_mm, seconds, until_obstacle_mm, name"
    )


@pytest.mark.parametrize(
    ("node", "column", "message"),
    [
        ("move: {speed: fast}", 17, "tree.move.speed: move speed must be a whole number, got 'fast' (text)"),
        ("move: {speed: 2.5}", 17, "tree.move.speed: move speed must be a whole number, got 2.5"),
        ("move: {speed: true}", 17, "tree.move.speed: move speed must be a whole number, got true (true/false)"),
        (
            "sequence: {memory: yes please, children: [stop]}",
            22,
            "tree.sequence.memory: sequence memory must be true or false",
        ),
        ("beep: {tones: 5}", 17, "tree.beep.tones: beep tones must be three tones 1..9, as in [5, 7, 9]; got 5"),
        ("log: {message: 12}", 18, "tree.log.message: log message must be text, got 12"),
        ("parallel: {policy: some, children: [stop]}", 22, "tree.parallel.policy: parallel policy must be all or one"),
    ],
)
def test_wrong_types(node, column, message):
    found = one(f"mission: t\ntree:\n  {node}\n")
    assert found.startswith(f"m.yaml:3:{column}: {message}")


@pytest.mark.parametrize(
    ("node", "message"),
    [
        ("move: {speed: 5}", "move speed must be 1..4, got 5 (speed setting, 1 slow .. 4 very fast)"),
        ("turn: {left: 1000}", "turn left must be 0..999 deg, got 1000"),
        ("beep: {tones: [0, 5, 9]}", "beep tones must be three tones 1..9"),
        ("beep: {volume: 6}", "beep volume must be 0..5, got 6"),
        ("servo: {id: 3, angle: 0}", "servo id must be 0..2, got 3"),
        ("servo: {id: 0, angle: -100}", "servo angle must be -99..99 deg, got -100"),
        ("servo: {id: 0, by: 10}", "servo by must be -9..9 deg, got 10"),
        ("move: {speed: 1, until_obstacle_mm: 300}", "move until_obstacle_mm must be 1..255 mm, got 300"),
        ("wait: {seconds: 0}", "wait seconds must be above 0, at most 3,600 s, got 0"),
        ("obstacle_within: {mm: 0}", "obstacle_within mm must be 1..255 mm, got 0"),
        ("battery_above: {level: 256}", "battery_above level must be 0..255, got 256"),
        ("repeat: {times: 0, do: stop}", "repeat times must be 1..1,000,000, got 0"),
    ],
)
def test_values_outside_the_protocols_range(node, message):
    assert message in one(f"mission: t\ntree:\n  {node}\n")


def test_missing_required_parameters_point_at_the_node():
    assert one("mission: t\ntree:\n  sequence:\n    - move: {direction: backward}\n") == (
        "m.yaml:4:7: tree.sequence[0].move: move needs 'speed' (speed setting, 1 slow .. 4 very fast)"
    )
    assert "timeout needs 'seconds'" in one("mission: t\ntree:\n  timeout: {do: stop}\n")
    assert "retry needs 'do'" in one("mission: t\ntree:\n  retry: {attempts: 2}\n")


def test_exactly_one_of():
    assert "turn takes one of left, right" in one("mission: t\ntree:\n  turn: {}\n")
    assert "turn takes only one of left, right" in one("mission: t\ntree:\n  turn: {left: 1, right: 1}\n")


@pytest.mark.parametrize(
    ("tree", "message"),
    [
        ("sequence: []", "tree.sequence: sequence needs at least one child"),
        ("selector: {children: []}", "tree.selector.children: selector needs at least one child"),
        ("repeat: {do: [stop, beep]}", "tree.repeat.do: do takes one node; to do several things, wrap them"),
        ("sequence: stop", "tree.sequence: sequence takes a list of children"),
        ("selector: {children: 5}", "m.yaml:3:24: tree.selector.children: selector takes a list of children, got 5"),
        ("invert: stop", "tree.invert: invert takes a mapping, e.g. invert: {do: NODE}"),
        ("repeat: 3", "tree.repeat: repeat takes a mapping, e.g. repeat: {times: ..., do: NODE}"),
        ("while: collided", "tree.while: while takes a mapping, e.g. while: {condition: ..., do: NODE}"),
    ],
)
def test_wrong_number_or_shape_of_children(tree, message):
    assert message in one(f"mission: t\ntree:\n  {tree}\n")


def test_bare_strings_that_need_parameters():
    assert one("mission: t\ntree:\n  sequence: [stop, turn]\n") == (
        "m.yaml:3:20: tree.sequence[1].turn: 'turn' needs parameters (left or right); write it as turn: {left: 90}"
    )
    assert "'repeat' needs parameters" in one("mission: t\ntree: repeat\n")


def test_unknown_and_recursive_subtrees():
    found = problems("""\
        mission: t
        subtrees:
          corner: {sequence: [{turn: {left: 90}}, {subtree: corner}]}
          a: {subtree: b}
          b: {subtree: a}
        tree:
          sequence: [{subtree: cornr}, {subtree: a}]
        """)
    assert found == [
        "m.yaml:3:53: subtrees.corner.sequence[1].subtree: subtree 'corner' includes itself "
        "(directly or through other subtrees)",
        "m.yaml:4:16: subtrees.a.subtree: subtree 'b' includes itself (directly or through other subtrees)",
        "m.yaml:5:16: subtrees.b.subtree: subtree 'a' includes itself (directly or through other subtrees)",
        "m.yaml:7:24: tree.sequence[0].subtree: unknown subtree 'cornr' (did you mean 'corner'?); "
        "the subtrees are corner, a, b",
    ]


def test_a_node_with_two_keys_hints_at_indentation():
    assert one("mission: t\ntree:\n  sequence:\n    - move:\n      speed: 2\n") == (
        "m.yaml:4:7: tree.sequence[0]: a node has exactly one key, its type; found move, speed; "
        "are the parameters of 'move' indented under it?"
    )


def test_top_level_problems():
    found = problems("misson: t\ntick_hz: 0\nworld: 3\n")
    assert found == [
        "m.yaml:1:1: misson: unknown key 'misson' (did you mean 'mission'?)",
        "m.yaml:1:1: missing 'mission:'",
        "m.yaml:1:1: missing 'tree:', the root node of the mission",
        "m.yaml:2:10: tick_hz: tick_hz must be from 1 to 200, got 0",
        "m.yaml:3:8: world: world must be text, got 3",
    ]


def test_yaml_syntax_errors_have_a_position():
    assert one("mission: t\ntree:\n  sequence: [stop, beep\n").startswith(
        "m.yaml:4:1: a '[' list is not closed with ']'"
    )
    assert one("mission: t\ntree: stop\nmission: u\n") == "m.yaml:3:1: 'mission' is given twice (first on line 1)"
    assert one("") == "m.yaml:1:1: the file is empty"
    assert one("- just a list\n") == "m.yaml:1:1: a mission file is a mapping with at least 'mission:' and 'tree:'"


def test_every_problem_is_reported_at_once():
    found = problems("""\
        mission: t
        tree:
          sequence:
            - move: {speed: 9}
            - trun: {left: 90}
            - beep: {volume: -1}
            - wait
        """)
    assert [p.split(": ", 1)[0] for p in found] == ["m.yaml:4:21", "m.yaml:5:7", "m.yaml:6:22", "m.yaml:7:7"]


def test_unreadable_file(tmp_path):
    with pytest.raises(MissionInvalid, match="cannot read the file"):
        validate_file(tmp_path / "missing.yaml")


def test_only_safe_yaml():
    found = problems("mission: !!python/object/apply:os.system ['true']\ntree: stop\n")
    assert (
        found[0]
        == "m.yaml:1:10: the tag tag:yaml.org,2002:python/object/apply:os.system is not allowed: plain YAML only"
    )
    assert "python/name:os.system is not allowed: plain YAML only" in one(
        "mission: !!python/name:os.system\ntree: stop\n"
    )


def test_valid_mission_fills_defaults():
    spec = validate_text("mission: t\ntree:\n  move: {speed: 2}\n")
    assert spec.tick_hz == 20 and spec.tree.args["direction"] == "forward" and spec.tree.args["seconds"] is None


yaml_scalars = st.one_of(
    st.none(), st.booleans(), st.integers(-2000, 2000), st.floats(allow_nan=False), st.text(max_size=8)
)
words = st.sampled_from(
    [
        "move",
        "turn",
        "speed",
        "left",
        "do",
        "sequence",
        "selector",
        "repeat",
        "times",
        "children",
        "beep",
        "tones",
        "subtree",
        "while",
        "condition",
        "stop",
        "collided",
        "name",
        "x",
    ]
)
documents = st.recursive(
    yaml_scalars | words,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(words, inner, max_size=3),
    max_leaves=20,
)


@settings(max_examples=300, deadline=None)
@given(documents)
def test_any_document_gives_a_spec_or_problems_never_a_crash(tree):
    import yaml

    text = yaml.safe_dump({"mission": "fuzz", "tree": tree})
    try:
        validate_text(text, "fuzz.yaml")
    except MissionInvalid as err:
        assert err.problems and all(p.line >= 1 and p.column >= 1 for p in err.problems)


def test_control_characters_in_text_are_refused_where_they_stand():
    text = (
        'mission: "evil\\e[2J"\ntree:\n  sequence:\n    - log: {message: "hi\\u202e"}\n    - {beep: {name: "b\\x00"}}\n'
    )
    assert problems(text) == [
        "m.yaml:1:10: mission: contains the control character '\\x1b'; write plain text",
        "m.yaml:4:22: tree.sequence[0].log.message: contains the control character '\\u202e'; write plain text",
        "m.yaml:5:21: tree.sequence[1].beep.name: contains the control character '\\x00'; write plain text",
    ]


@pytest.mark.parametrize(
    ("path", "said"),
    [
        ("exercises/bump.yaml", "1:1: this is an exercise file, not a mission: use it with autonomy grade"),
        (
            "autonomy/emulator/worlds/box.yaml",
            "2:1: this is a world file, not a mission: use it with a mission's world:",
        ),
    ],
)
def test_an_exercise_or_a_world_file_checked_as_a_mission_says_what_it_is(path, said):
    from pathlib import Path

    from autonomy.mission import MissionInvalid, load_mission

    file = Path(__file__).resolve().parents[2] / path
    with pytest.raises(MissionInvalid) as caught:
        load_mission(file)
    assert len(caught.value.problems) == 1 and str(caught.value).startswith(f"{file}:{said}")


def test_a_number_of_any_parameter_is_at_most_a_billion_and_one_of_any_kind_says_which_kind():
    from autonomy.behaviours import Param, RobotAction
    from autonomy.mission.registry import BUILTINS, leaf_type

    class Far(RobotAction):
        node_type = "far"
        params = (Param("mm", "number", "as far as you like"),)

    registry = BUILTINS.copy()
    registry.add(leaf_type(Far, "plugin"))
    spec = validate_text("mission: m\ntree:\n  far: {mm: 1000000000}\n", "m.yaml", registry=registry)
    assert spec.tree.args["mm"] == 1_000_000_000
    with pytest.raises(MissionInvalid, match="must be a finite number of at most 1,000,000,000, got 1000000001"):
        validate_text("mission: m\ntree:\n  far: {mm: 1000000001}\n", "m.yaml", registry=registry)
    with pytest.raises(MissionInvalid, match=r"wait seconds must be a number, got 'soon' \(text\)"):
        validate_text("mission: m\ntree:\n  wait: {seconds: soon}\n", "m.yaml")
    # a parameter with a range of its own says that range, not the limit on every number
    with pytest.raises(MissionInvalid, match=r"move distance_mm must be above 0, at most 100,000 mm, got inf \(stop"):
        validate_text("mission: m\ntree:\n  move: {speed: 2, distance_mm: .inf}\n", "m.yaml")

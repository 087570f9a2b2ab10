"""Hostile mission files: each is refused with FILE:LINE:COL problems, never an exception of another kind."""

from __future__ import annotations

import pytest

from autonomy.mission import MissionInvalid, load_mission, validate_text
from autonomy.mission.validate import MAX_TREE_DEPTH, MAX_TREE_NODES
from autonomy.source import MAX_DEPTH, control_character


def problems(text: str) -> list[str]:
    with pytest.raises(MissionInvalid) as caught:
        validate_text(text, "m.yaml")
    return [str(p) for p in caught.value.problems]


@pytest.mark.parametrize(
    ("char", "name"),
    [("\x00", "NUL"), ("\x07", "BEL"), ("\x7f", "DEL"), ("\x85", "NEL"), ("\x9b", "U+009B"), ("\x1b", "ESC")],
)
@pytest.mark.parametrize("where", ["value", "comment"])
def test_a_control_character_anywhere_is_named_where_it_stands(char, name, where):
    text = f"mission: t{char}x\ntree: stop\n" if where == "value" else f"mission: tx\ntree: stop # {char}\n"
    found = problems(text)
    place = "m.yaml:1:11" if where == "value" else "m.yaml:2:14"
    assert found == [f"{place}: the control character {name}" + found[0].split(name, 1)[1]]
    assert "remove it" in found[0]


def test_a_lone_surrogate_is_refused_in_the_text_and_in_an_escape():
    assert problems("mission: t\ud800\ntree: stop\n")[0].startswith("m.yaml:1:11: a lone surrogate (U+D800)")
    escaped = problems('mission: "t\\ud800x"\ntree: stop\n')
    assert len(escaped) == 1 and "an escape for a code that is not a character" in escaped[0]
    assert "not a character" in problems('mission: t\ntree: {log: {message: "a\\udfffb"}}\n')[0]
    assert control_character("name\ud800") == "'\\ud800'"  # for values that reach a check some other way


def test_deep_flow_nesting_is_refused_where_it_crosses_the_limit():
    found = problems("mission: t\ntree: " + "[" * 1000 + "]" * 1000 + "\n")
    assert found == [f"m.yaml:2:{7 + MAX_DEPTH - 1}: nested more than {MAX_DEPTH} levels deep"]
    assert problems("x: " + "[" * 200_000)[0].endswith(f"nested more than {MAX_DEPTH} levels deep")


def test_deeply_nested_nodes_are_refused_at_their_place():
    text = "mission: t\ntree:\n"
    for level in range(300):
        text += "  " * (level + 1) + "sequence:\n" + "  " * (level + 1) + "- "  # one node per level
        text = text[: -len("- ")] + "  " * 0 + "- "
        text += "\n"
    found = problems(text)
    assert len(found) == 1 and f"nested more than {MAX_DEPTH} levels deep" in found[0]
    assert not found[0].startswith("m.yaml:1:1:")


def subtree_chain(length: int, wrap: bool) -> str:
    lines = ["mission: chain", "subtrees:"]
    for index in range(length):
        body = f"{{sequence: [{{subtree: s{index + 1}}}]}}" if wrap else f"{{subtree: s{index + 1}}}"
        lines.append(f"  s{index}: {body}")
    lines += [f"  s{length}: stop", "tree: {subtree: s0}"]
    return "\n".join(lines) + "\n"


def test_a_chain_of_2000_subtrees_is_checked_and_built_without_recursion(tmp_path):
    mission = tmp_path / "chain.yaml"
    mission.write_text(subtree_chain(2000, wrap=False))
    spec = load_mission(mission)
    from autonomy.mission import build_tree

    assert build_tree(spec).name == "s0"


def test_subtrees_cannot_get_round_the_depth_limit():
    found = problems(subtree_chain(300, wrap=True))
    assert len(found) == 1
    assert f"m.yaml:{3 + MAX_TREE_DEPTH}:" in found[0] and f"at most {MAX_TREE_DEPTH} levels" in found[0]


def test_a_subtree_used_twice_at_every_level_cannot_blow_up():
    lines = ["mission: bomb", "subtrees:"]
    lines += [f"  s{i}: {{sequence: [{{subtree: s{i + 1}}}, {{subtree: s{i + 1}}}]}}" for i in range(30)]
    lines += ["  s30: stop", "tree: {subtree: s0}"]
    found = problems("\n".join(lines) + "\n")
    assert found == [
        f"m.yaml:34:8: tree: the tree has more than {MAX_TREE_NODES:,} nodes with its subtrees expanded "
        "(each use of a subtree is a copy)"
    ]


@pytest.mark.parametrize("block", ["3", "[a, b]", "", "'text'"])
def test_subtrees_that_are_not_a_mapping(block):
    assert problems(f"mission: t\nsubtrees: {block}\ntree: stop\n") == [
        f"m.yaml:2:{11 if block else 10}: subtrees: subtrees is a mapping of names to trees"
    ]


@pytest.mark.parametrize(
    "number",
    ["9" * 5000, "0x" + "f" * 5000, "0b" + "1" * 20000, "0" + "7" * 5000, "1" * 5000 + ".5", "1:" * 3000 + "1"],
)
@pytest.mark.parametrize("where", ["tree:\n  wait: {seconds: %s}\n", "tick_hz: %s\ntree: stop\n"])
def test_numbers_written_with_thousands_of_digits(number, where):
    found = problems("mission: t\n" + where % number)
    assert len(found) == 1 and "digits" in found[0]


@pytest.mark.parametrize("value", [".nan", ".NaN", ".inf", ".Inf", "-.inf", "1e400", "1.0e+400"])
@pytest.mark.parametrize(
    "node", ["wait: {seconds: %s}", "move: {speed: 1, seconds: %s}", "timeout: {seconds: %s, do: stop}"]
)
def test_every_number_is_finite(value, node):
    found = problems("mission: t\ntree:\n  " + node % value + "\n")
    assert len(found) == 1 and "seconds" in found[0], found


@pytest.mark.parametrize(("value", "shown"), [("1.0e-300", "1e-300"), (".nan", "nan"), ("0.5", "0.5"), ("201", "201")])
def test_tick_hz_has_a_documented_range(value, shown):
    assert problems(f"mission: t\ntick_hz: {value}\ntree: stop\n") == [
        f"m.yaml:2:10: tick_hz: tick_hz must be from 1 to 200, got {shown}"
    ]


@pytest.mark.parametrize(
    ("text", "place", "words"),
    [
        ("mission: t\ntree:\n  sequence:\n\t- stop\n", "4:1", "a tab: indent with spaces"),
        ("mission: t\ntree:\n  sequence:\n    - stop\n   - beep\n", "5:4", "does not line up"),
        ("mission: t: u\ntree: stop\n", "1:11", "put the value in quotes"),
        ("mission: 't\ntree: stop\n", "3:1", "a quoted text is not closed"),
        ('mission: "a\\qb"\ntree: stop\n', "1:", "unknown escape"),
        ("mission: *x\ntree: stop\n", "1:10", "no anchor &x"),
        ("mission: t\n---\ntree: stop\n", "2:1", "a second document"),
    ],
)
def test_yaml_mistakes_are_said_in_plain_words(text, place, words):
    found = problems(text)
    assert len(found) == 1 and found[0].startswith(f"m.yaml:{place}") and words in found[0], found
    assert "<block" not in found[0] and "token" not in found[0]


def test_a_latin1_file_is_refused_at_the_line_and_column_of_its_first_odd_byte(tmp_path):
    mission = tmp_path / "m.yaml"
    mission.write_bytes("mission: t\ndescription: caf\xe9 au lait\ntree: stop\n".encode("latin-1"))
    with pytest.raises(MissionInvalid) as caught:
        load_mission(mission)
    [problem] = caught.value.problems
    assert (problem.line, problem.column) == (2, 17) and "0xe9" in problem.message and "UTF-8" in problem.message


@pytest.mark.parametrize(
    ("data", "said"),
    [
        (
            "mission: t\ndescription: “quoted” – 20°\ntree: stop\n".encode("cp1252"),
            "2:14: the byte 0x93 here is not UTF-8 text (a file saved as Latin-1 or Windows-1252?): save it as UTF-8",
        ),
        ("mission: t\ntree: stop\n".encode("utf-16"), "1:1: the byte 0xff here starts a UTF-16 byte-order mark"),
        (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", "1:1: the byte 0x89 here is not text, nor are others in the file"),
        (
            b"mission: t\n" + bytes(range(0x80, 0x100)),
            "2:1: the byte 0x80 here is not UTF-8 text: save the file as UTF-8",
        ),
    ],
)
def test_bytes_that_are_not_utf8_are_named_for_what_they_look_like(tmp_path, data, said):
    mission = tmp_path / "m.yaml"
    mission.write_bytes(data)
    with pytest.raises(MissionInvalid) as caught:
        load_mission(mission)
    [problem] = caught.value.problems
    assert f"{problem.line}:{problem.column}: {problem.message}".startswith(
        said.replace(": ", ": cannot read the file: ", 1)
    )
    assert ("Latin-1" in problem.message) == ("Latin-1" in said)


def test_a_refused_tag_is_the_only_problem_reported():
    assert problems('mission: t\ntree: !!python/object/apply:os.system ["echo hi"]\n') == [
        "m.yaml:2:7: the tag tag:yaml.org,2002:python/object/apply:os.system is not allowed: plain YAML only"
    ]


def test_anchors_aliases_and_merge_keys_still_work():
    spec = validate_text(
        "mission: t\nsubtrees:\n  a: &corner {sequence: [{move: &fwd {speed: 2, distance_mm: 100}}, "
        "{move: {<<: *fwd, speed: 3}}]}\ntree: *corner\n"
    )
    first, second = spec.tree.children
    assert first.args["speed"] == 2 and second.args["speed"] == 3 and second.args["distance_mm"] == 100


@pytest.mark.parametrize(
    ("value", "said"),
    [
        ("!!bool 'maybe'", "'maybe' is not a bool: write a plain value"),
        ("!!bool ''", "'' is not a bool"),
        ("!!int ''", "'' is not a int"),
        ("!!int '-'", "'-' is not a int"),
        ("!!float '_'", "'_' is not a float"),
        ("!!timestamp 'x'", "the tag tag:yaml.org,2002:timestamp is not allowed"),
        ("!!binary 'a'", "the tag tag:yaml.org,2002:binary is not allowed"),
        ("!!seq x", "the tag tag:yaml.org,2002:seq is not allowed"),
        ("!!merge x", "the tag tag:yaml.org,2002:merge is not allowed"),
    ],
)
def test_a_value_forced_by_a_tag_is_one_plain_problem(value, said):
    found = problems(f"mission: t\ntree:\n  wait: {{seconds: {value}}}\n")
    assert len(found) == 1 and said in found[0] and "\\n" not in found[0], found


def test_a_bad_number_inside_a_list_is_reported_once():
    found = problems("mission: t\ntree:\n  beep: {tones: [0x" + "f" * 5000 + ", 1, 1]}\n")
    assert len(found) == 1 and "5,002 digits" in found[0]


@pytest.mark.parametrize("text", ["1e3", "2E2", "-1e3", "1.5e2"])
def test_a_number_yaml_reads_as_text_gets_a_hint(text):
    [found] = problems(f"mission: t\ntree:\n  move: {{speed: 1, distance_mm: {text}}}\n")
    assert f"YAML reads {text} as text" in found


@pytest.mark.parametrize("separator", ["\\L", "\\P"])
def test_a_line_separator_in_a_name_is_refused(separator):
    [found] = problems(f'mission: "a{separator}b"\ntree: stop\n')
    assert "control character" in found


def test_text_is_at_most_1000_characters_and_problems_quote_it_short():
    [found] = problems(f"mission: {'n' * 900_00}\ntree: stop\n")
    assert found.endswith("is 90,000 characters long; at most 1,000")
    [key] = problems(f"mission: t\n? {'k' * 450_000}\n: 1\ntree: stop\n")  # within a file's size
    assert len(key) < 1000 and "(450,000 characters)" in key


@pytest.mark.parametrize(
    ("body", "said"),
    [
        ("node_type = 5", "node_type must be a name such as 'turn_until_clear', got 5"),
        ("node_type = 'bad name'", "node_type must be a name"),
        ("node_type = 'p5'\n    params = 5", "params must be a tuple of Param(...), got 5"),
        ("node_type = 'p6'\n    doc = 7", "doc must be one line of text, got 7"),
    ],
)
def test_a_plugin_class_declared_wrongly_is_a_problem_of_the_file(tmp_path, body, said):
    (tmp_path / "beh.py").write_text(
        f"from autonomy.behaviours import RobotCondition\n\nclass C(RobotCondition):\n    {body}\n"
    )
    [found] = problems_in(tmp_path, "mission: t\nplugins: [beh]\ntree: stop\n")
    assert found.startswith("m.yaml:2:11: plugins[0]: plugin 'beh': C.") and said in found


def problems_in(folder, text: str) -> list[str]:
    with pytest.raises(MissionInvalid) as caught:
        validate_text(text, "m.yaml", folder)
    return [str(p) for p in caught.value.problems]


def test_a_plugin_class_without_doc_or_docstring_is_named_by_its_type(tmp_path):
    (tmp_path / "beh.py").write_text(
        "from autonomy.behaviours import RobotCondition\n\nclass C(RobotCondition):\n    node_type = 'quiet'\n"
        "    def check(self):\n        return True\n"
    )
    spec = validate_text("mission: t\nplugins: [beh]\ntree: quiet\n", "m.yaml", tmp_path)
    assert spec.registry.get("quiet").doc == "quiet (from plugin beh)"

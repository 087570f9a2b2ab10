"""A mission as blocks and back: the same canonical text and the same tree, for every mission we ship and 2,000 more."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from autonomy.behaviours import Param, RobotAction
from autonomy.mission import BUILTINS, MissionInvalid, validate_text
from autonomy.mission.blocks import (
    DEFINE_BLOCK,
    MISSION_BLOCK,
    block_at_line,
    block_definitions,
    block_type,
    canonical_text,
    comments_in,
    from_workspace,
    load_words,
    to_workspace,
    toolbox,
    variants,
    workspace_json,
)
from autonomy.mission.registry import leaf_type
from tests.harness import mission_files

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = mission_files([*ROOT.glob("missions/*.yaml"), *ROOT.glob("autonomy/exercises/solutions/*.yaml")])


def shape(spec) -> list:
    """A tree as what it runs: each node's type, arguments, name and children (subtrees written out where used)."""

    def node(n) -> list:
        if n.type.category == "reference":
            return ["subtree", node(spec.subtrees[n.args["subtree"]])]
        return [n.type.name, sorted(n.args.items()), n.name, [node(c) for c in n.children]]

    return [spec.name, spec.description.strip(), spec.tick_hz, spec.world, node(spec.tree)]


def round_trip(text: str, source: str = "m.yaml", base_dir: Path | None = None) -> tuple[str, str]:
    """The text's canonical text, and what its blocks give back; the trees of the three compared."""
    spec = validate_text(text, source, base_dir, check_world=False)
    canonical = canonical_text(spec, text)
    back, again = from_workspace(workspace_json(to_workspace(spec, text)), "workspace.json", base_dir=base_dir)
    assert shape(again) == shape(spec) == shape(validate_text(canonical, source, base_dir, check_world=False))
    assert canonical_text(again, back) == back  # the canonical text is its own
    return canonical, back


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_every_shipped_mission_goes_to_blocks_and_back_losing_nothing(path):
    canonical, back = round_trip(path.read_text(), str(path), path.parent)
    assert back == canonical


def yaml_blocks_in_docs() -> list[tuple[str, str]]:
    found = []
    for doc in sorted([ROOT / "README.md", *ROOT.glob("docs/*.md")]):
        for index, block in enumerate(re.findall(r"```yaml\n(.*?)```", doc.read_text(), re.S)):
            if re.search(r"^tree:", block, re.M) and re.search(r"^mission:", block, re.M):
                found.append((f"{doc.name}#{index}", block))
    return found


def test_every_mission_in_the_docs_goes_to_blocks_and_back_losing_nothing():
    checked = 0
    for label, text in yaml_blocks_in_docs():
        try:
            validate_text(text, label, ROOT / "missions", check_world=False)
        except MissionInvalid:
            continue  # a mission shown with a mistake in it, on purpose
        canonical, back = round_trip(text, label, ROOT / "missions")
        assert back == canonical, label
        checked += 1
    assert checked >= 6  # README, missions.md and the tutorial


def test_the_canonical_text_of_a_shipped_mission_reads_as_it_was_written():
    text = (ROOT / "missions" / "square.yaml").read_text()
    canonical = canonical_text(validate_text(text, check_world=False), text)
    assert "    - move: {speed: 2, distance_mm: 300}\n" in canonical  # the registry's order, on one line
    assert "      - beep: {tones: [5, 7, 9], volume: 3}\n" in canonical  # given, though the defaults: kept


COMMENTED = """\
# The square, with notes.
mission: square   # its name
world: box
subtrees:
  # a corner: turn, then beep
  corner:
    sequence:
      - turn: {left: 90}  # a right angle
      # now the beep
      - beep
tree:
  repeat:
    times: 4  # four sides
    do:
      sequence:
        - move: {speed: 2, distance_mm: 300}
        - subtree: corner
# the end
"""


def test_comments_survive_as_block_comments_before_their_nodes():
    spec = validate_text(COMMENTED, check_world=False)
    workspace = to_workspace(spec, COMMENTED)
    text = workspace_json(workspace)
    assert '"text":"a corner: turn, then beep"' in text and '"text":"a right angle"' in text
    canonical, back = round_trip(COMMENTED)
    assert back == canonical
    assert canonical.startswith("# The square, with notes.\n# its name\n# the end\nmission: square\n")
    assert "  corner:\n    # a corner: turn, then beep\n    sequence:\n" in canonical
    assert "      # a right angle\n      - turn: {left: 90}\n      # now the beep\n      - beep\n" in canonical
    assert "tree:\n  # four sides\n  repeat:\n    times: 4\n" in canonical  # beside a parameter: before its node


def test_a_hash_in_a_text_is_no_comment():
    text = 'mission: m\ndescription: "#1 of #2"\ntree:\n  log: {message: "# not a comment"}  # one\n'
    assert [words for _, _, words, _ in comments_in(text)] == ["one"]
    canonical, back = round_trip(text)
    assert back == canonical and "# one\n" in canonical and "'# not a comment'" in canonical


def test_every_node_type_is_a_block_with_every_parameter_and_its_forms():
    defined = {block["type"]: block for block in block_definitions(BUILTINS)}
    assert MISSION_BLOCK in defined and DEFINE_BLOCK in defined
    for node_type in BUILTINS:
        for chosen in variants(node_type):
            block = defined[block_type(node_type, chosen)]
            fields = {a["name"].split(".")[0] for a in block["args0"]}
            inputs = {a["name"] for k, args in block.items() if k.startswith("args") and k != "args0" for a in args}
            for param in node_type.params:
                if param.kind in ("node", "nodes"):
                    assert param.name in inputs, (node_type.name, param.name)
                elif param.required or param.default is not None or param.name in chosen:
                    assert param.name in fields, (node_type.name, param.name)
            assert block["tooltip"] == node_type.doc
            assert block["message0"].count("%") - 2 * block["message0"].count("%%") == len(block["args0"])
    assert defined["move+distance_mm"]["message0"] == "move %1 at speed %2 for %3 mm"
    assert [a["type"] for a in defined["move+distance_mm"]["args0"]] == ["field_dropdown", "field_number"] * 1 + [
        "field_number"
    ]
    speed = defined["move"]["args0"][1]
    assert (speed["min"], speed["max"], speed["precision"]) == (1, 4, 1)
    assert {"turn+left", "turn+right", "repeat", "repeat+times", "servo+angle", "servo+by"} <= set(defined)
    assert "turn" not in defined  # a turn is left or right: one of them
    shown = {c["name"]: [b["type"] for b in c["contents"]] for c in toolbox(BUILTINS)["contents"]}
    assert "move+distance_mm" in shown["Do"] and "obstacle_within" in shown["Check"]
    allowed = toolbox(BUILTINS, allowed=("sequence", "move"))
    assert [b["type"] for c in allowed["contents"] for b in c["contents"]][:2] == ["sequence", "move"]


class Honk(RobotAction):
    """A node no block was written for: it comes from the registry alone."""

    node_type = "honk"
    doc = "Honk the horn loudly."
    params = (
        Param("times", "int", "how many honks", required=True, minimum=1, maximum=5),
        Param("tune", "choice", "which tune", default="short", choices=("short", "long")),
        Param("pause_s", "number", "between honks", unit="s"),
    )


def test_a_node_added_to_the_registry_is_a_block_with_no_block_code_written_for_it():
    registry = BUILTINS.copy()
    registry.add(leaf_type(Honk, origin="plugin honks"))
    defined = {block["type"]: block for block in block_definitions(registry)}
    assert defined["honk"]["message0"] == "honk times %1 tune %2"
    assert defined["honk+pause_s"]["message0"] == "honk times %1 tune %2 pause s %3 s"
    assert defined["honk"]["args0"][1]["options"] == [["short", "short"], ["long", "long"]]
    assert defined["honk"]["tooltip"] == "Honk the horn loudly."


def test_a_plugin_s_node_is_a_block_and_goes_back_to_its_mission(tmp_path):
    (tmp_path / "honks.py").write_text(
        "from autonomy.behaviours import Param, RobotAction\n"
        "from autonomy.behaviours.base import Status\n"
        "class Honk(RobotAction):\n"
        "    node_type = 'honk'\n"
        "    doc = 'Honk.'\n"
        "    params = (Param('times', 'int', 'honks', required=True, minimum=1, maximum=5),)\n"
        "    def update(self):\n"
        "        return Status.SUCCESS\n"
    )
    text = "mission: h\nplugins: [honks]\ntree:\n  sequence:\n    - honk: {times: 3}\n    - stop\n"
    (tmp_path / "h.yaml").write_text(text)
    canonical, back = round_trip(text, str(tmp_path / "h.yaml"), tmp_path)
    assert back == canonical and "honk: {times: 3}" in back
    run = subprocess.run(
        [sys.executable, "-m", "autonomy", "blocks", str(tmp_path / "h.yaml"), "--palette"],
        capture_output=True, text=True, timeout=60, cwd=tmp_path,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert "honk" in [b["type"] for b in json.loads(run.stdout)["blocks"]]


def test_the_words_come_from_one_catalogue_a_teacher_can_translate(tmp_path):
    english = load_words()
    assert english.nodes["move"] == "move %direction at speed %speed"
    french = tmp_path / "fr.yaml"
    french.write_text(
        "nodes:\n  move: 'avancer %direction à la vitesse %speed'\nparams:\n  move.distance_mm: 'sur %distance_mm mm'\n"
        "choices:\n  forward: 'en avant'\n"
    )
    defined = {b["type"]: b for b in block_definitions(BUILTINS, load_words(french))}
    assert defined["move+distance_mm"]["message0"] == "avancer %1 à la vitesse %2 sur %3 mm"
    assert defined["move"]["args0"][0]["options"][0] == ["en avant", "forward"]
    (tmp_path / "bad.yaml").write_text("nodes: [1, 2]\n")
    with pytest.raises(MissionInvalid, match=r"bad.yaml:1:8: nodes: nodes maps names to words"):
        load_words(tmp_path / "bad.yaml")


def test_a_workspace_s_problems_are_said_at_its_blocks(tmp_path):
    spec = validate_text((ROOT / "missions" / "square.yaml").read_text(), check_world=False)
    workspace = to_workspace(spec)
    text = workspace_json(workspace).replace('"speed":2', '"speed":7')
    with pytest.raises(MissionInvalid) as raised:
        from_workspace(text, "w.json")
    (problem,) = raised.value.problems
    assert text.splitlines()[problem.line - 1][problem.column - 1 :].startswith('"id":"b')
    assert "speed must be 1..4, got 7" in problem.message
    loose = json.loads(workspace_json(workspace))
    loose["blocks"]["blocks"].append({"type": "stop", "id": "lost"})
    with pytest.raises(MissionInvalid, match="a 'stop' block lies outside the mission"):
        from_workspace(json.dumps(loose), "w.json")
    with pytest.raises(MissionInvalid, match="no node makes a block 'flying'"):
        from_workspace(text.replace('"turn+left"', '"flying"'), "w.json")
    with pytest.raises(MissionInvalid, match=r"w.json:1:1: not a workspace: nested deeper than blocks go"):
        from_workspace("[" * 100_000, "w.json")
    with pytest.raises(MissionInvalid, match=r"w.json:1:11: not JSON"):
        from_workspace('{"blocks" 3}', "w.json")


def test_several_blocks_where_one_goes_are_done_in_order():
    workspace = json.loads(workspace_json(to_workspace(validate_text("mission: m\ntree:\n  invert: {do: healthy}\n"))))
    invert = workspace["blocks"]["blocks"][0]["inputs"]["tree"]["block"]
    invert["inputs"]["do"]["block"]["next"] = {"block": {"type": "stop", "id": "x"}}
    back, _ = from_workspace(json.dumps(workspace))
    assert back == "mission: m\ntree:\n  invert:\n    do:\n      sequence:\n        - healthy\n        - stop\n"


def test_a_long_chain_of_blocks_is_read_and_written():
    text = "mission: long\ntree:\n  sequence:\n" + "    - stop\n" * 2_999
    canonical, back = round_trip(text)
    assert back == canonical


def test_autonomy_blocks_goes_both_ways_as_a_command(tmp_path):
    mission = tmp_path / "square.yaml"
    mission.write_text((ROOT / "missions" / "square.yaml").read_text())
    common = {"capture_output": True, "text": True, "timeout": 60, "cwd": tmp_path}
    there = subprocess.run([sys.executable, "-m", "autonomy", "blocks", "square.yaml", "-o", "w.json"], **common)
    back = subprocess.run([sys.executable, "-m", "autonomy", "blocks", "w.json", "-o", "again.yaml"], **common)
    assert there.returncode == back.returncode == 0, there.stderr + back.stderr
    assert (tmp_path / "again.yaml").read_text() == canonical_text(
        validate_text(mission.read_text()), mission.read_text()
    )
    check = subprocess.run([sys.executable, "-m", "autonomy", "check", "again.yaml"], **common)
    assert check.returncode == 0 and "ok" in check.stdout
    (tmp_path / "w.json").write_text((tmp_path / "w.json").read_text().replace('"speed":2', '"speed":9'))
    bad = subprocess.run([sys.executable, "-m", "autonomy", "blocks", "w.json"], **common)
    assert bad.returncode == 2 and bad.stdout == "" and "Traceback" not in bad.stderr
    assert re.match(r"w\.json:\d+:\d+: .*speed must be 1\.\.4, got 9", bad.stderr)


# --------------------------------------------------------------------------- 2,000 random missions

TEXT = st.text(st.characters(codec="utf-8", categories=("L", "N", "P", "Zs")), min_size=1, max_size=12).filter(
    lambda t: t.strip() == t and t
)


def value_of(param: Param) -> st.SearchStrategy:
    if param.kind == "int":
        return st.integers(int(param.minimum if param.minimum is not None else -1000), int(param.maximum or 1000))
    if param.kind == "number":
        low = param.minimum if param.minimum is not None else (0.001 if param.positive else -1000.0)
        high = param.maximum if param.maximum is not None else 1000.0
        return st.integers(max(1, int(low)) if param.positive else int(low), int(high)) | st.floats(
            low, high, allow_nan=False, allow_infinity=False, exclude_min=param.positive
        ).map(lambda v: round(v, 3)).filter(lambda v: v > 0 or not param.positive)
    if param.kind == "bool":
        return st.booleans()
    if param.kind == "choice":
        return st.sampled_from(param.choices)
    if param.kind == "tones":
        return st.lists(st.integers(1, 9), min_size=3, max_size=3)
    return TEXT


@st.composite
def nodes(draw, depth: int = 0, subtrees: tuple[str, ...] = ()) -> object:
    kinds = [t for t in BUILTINS if depth < 4 or t.category not in ("composite", "decorator")]
    kinds = [t for t in kinds if t.category != "reference" or subtrees]
    node_type = draw(st.sampled_from(kinds))
    if node_type.category == "reference":
        return {"subtree": draw(st.sampled_from(subtrees))}
    chosen = draw(st.sampled_from(variants(node_type)))
    body: dict[str, object] = {}
    if draw(st.booleans()) and draw(st.booleans()):
        body["name"] = draw(TEXT)
    for param in node_type.params:
        if param.kind == "nodes":
            body[param.name] = draw(st.lists(nodes(depth + 1, subtrees), min_size=1, max_size=3))
        elif param.kind == "node":
            body[param.name] = draw(nodes(depth + 1, subtrees))
        elif param.required or param.name in chosen or (param.default is not None and draw(st.booleans())):
            body[param.name] = draw(value_of(param))
    if not body and not node_type.needs_parameters and draw(st.booleans()):
        return node_type.name
    if node_type.category == "composite" and list(body) == ["children"] and draw(st.booleans()):
        return {node_type.name: body["children"]}  # the short form
    return {node_type.name: body}


@st.composite
def missions(draw) -> str:
    names = draw(st.lists(st.sampled_from(["corner", "scan", "escape"]), max_size=2, unique=True))
    subtrees = {}
    for index, name in enumerate(names):
        subtrees[name] = draw(nodes(1, tuple(names[:index])))
    doc: dict[str, object] = {"mission": draw(TEXT)}
    if draw(st.booleans()):
        doc["description"] = draw(st.text(st.characters(codec="utf-8", categories=("L", "Zs", "P")), max_size=150))
    if draw(st.booleans()):
        doc["tick_hz"] = draw(st.sampled_from([10, 20, 25.5, 50]))
    if draw(st.booleans()):
        doc["world"] = draw(st.sampled_from(["box", "corridor", "empty"]))
    if subtrees:
        doc["subtrees"] = subtrees
    doc["tree"] = draw(nodes(0, tuple(names)))
    return yaml.safe_dump(
        doc, sort_keys=False, allow_unicode=True, default_flow_style=draw(st.sampled_from([None, False]))
    )


@settings(max_examples=2_000, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(missions())
def test_random_missions_go_to_blocks_and_back_losing_nothing(text):
    try:
        validate_text(text, check_world=False)
    except MissionInvalid as err:  # the strategy's texts are meant to be valid: say which was not
        assume("description" in text and "control character" in str(err))
        return
    canonical, back = round_trip(text)
    assert back == canonical


# --------------------------------------------------------------------------- what an attacker sent


def workspace_of(*blocks: dict) -> str:
    return json.dumps({"blocks": {"languageVersion": 0, "blocks": list(blocks)}})


def mission_block(tree: dict | None = None, **more) -> dict:
    block = {"type": "@mission", "id": "m", "fields": {"name": "m", "world": "", "tick_hz": 20}, **more}
    if tree is not None:
        block["inputs"] = {"tree": {"block": tree}}
    return block


def test_a_comment_of_the_blocks_stays_a_comment_whatever_line_breaks_it_holds():
    stop = {"type": "stop", "id": "s", "icons": {"comment": {"text": "x\r    - log: {message: injected}"}}}
    text, spec = from_workspace(workspace_of(mission_block(stop, icons={"comment": {"text": "note\rworld: box"}})))
    assert spec.world is None and spec.tree.type.name == "stop", text
    assert text == "# note\n# world: box\nmission: m\ntree:\n  # x\n  #     - log: {message: injected}\n  stop\n"


def test_a_subtree_s_name_is_one_line_of_at_most_200_characters():
    for name in ("a\nb", "'" * 201):
        text = f"mission: m\nsubtrees: {{{json.dumps(name)}: stop}}\ntree: {{subtree: {json.dumps(name)}}}\n"
        with pytest.raises(MissionInvalid, match="a subtree's name is one line of at most 200 characters"):
            validate_text(text)
    round_trip("mission: m\nsubtrees: {\"'''\": stop}\ntree: {subtree: \"'''\"}\n")


def test_a_description_with_indented_lines_comes_back_as_it_was():
    text = "mission: m\ndescription: |\n  first line\n    indented " + "word " * 20 + "end\ntree: stop\n"
    canonical, back = round_trip(text)
    assert validate_text(back).description == validate_text(text).description


def beep(**tones) -> dict:
    return {"type": "beep", "id": "b", "fields": {"tones.0": 5, "tones.1": 5, "tones.2": 5, "volume": 3, **tones}}


STOP = {"type": "stop", "id": "s"}


@pytest.mark.parametrize(
    "blocks",
    [
        [mission_block(fields="x")],
        [mission_block(inputs="x")],
        [mission_block(STOP), {"type": "@define", "id": "d", "fields": {"name": "a"}, "inputs": "x"}],
        [mission_block({"type": "subtree", "id": "c", "fields": ["s"]})],
        [{**mission_block(STOP), "fields": {"name": "m", "tick_hz": 10**400}}],
        [mission_block(beep(**{"tones.0": "x"}))],
        [mission_block(beep(**{"tones.0": []}))],
        [mission_block(beep(**{"tones.0": 1.9, "tones.1": True, "tones.2": "9"}))],
        [mission_block({**STOP, "data": json.dumps({"given": 5})})],
        [mission_block(STOP, data=json.dumps({"plugins": 5, "description": 3}))],
    ],
    ids=["fields", "inputs", "define inputs", "subtree fields", "tick_hz", "tone text", "tone list", "tone kinds",
         "given", "mission data"],
)  # fmt: skip
def test_a_workspace_of_the_wrong_shapes_is_said_wrong_at_its_blocks_never_a_traceback(blocks):
    with pytest.raises(MissionInvalid) as raised:
        from_workspace(workspace_of(*blocks), "w.json")
    assert all(str(problem).startswith("w.json:") for problem in raised.value.problems)


def test_blocks_nested_deeper_than_a_mission_goes_are_said_so():
    block: dict = {"type": "stop", "id": "s"}
    for n in range(1000):
        block = {"type": "sequence", "id": f"q{n}", "inputs": {"children": {"block": block}}}
    deep = workspace_json({"blocks": {"languageVersion": 0, "blocks": [mission_block(block)]}})
    with pytest.raises(MissionInvalid, match="nested deeper"):
        from_workspace(deep, "w.json")


def test_empty_comments_a_byte_order_mark_and_comments_beside_keys_are_kept_where_they_were():
    for text in ("mission: m\ntree:\n  #\n  stop\n", "\ufeff# top comment\nmission: m\ntree: stop\n"):
        canonical, back = round_trip(text)
        assert back == canonical and "#" in back, back
    text = (
        "mission: m\nsubtrees:  # the steps\n  a:  # about a\n    sequence: [stop]\ntree:  # main tree\n"
        "  sequence:\n    - stop\n    -  # about wait\n      wait: {seconds: 1}\n    - subtree: a\n"
    )
    canonical, back = round_trip(text)
    assert back == canonical
    assert "  a:\n    # the steps\n    # about a\n    sequence:" in canonical
    assert "tree:\n  # main tree\n  sequence:\n    - stop\n    # about wait\n    - wait:" in canonical


def test_an_xml_mission_s_text_is_not_read_for_yaml_comments():
    text = (
        '<root BTCPP_format="4">\n<!-- drive, then stop -->\n<BehaviorTree ID="m">\n<Sequence>\n'
        '<log message="step #1"/>\n<stop/>\n</Sequence>\n</BehaviorTree>\n</root>\n'
    )
    spec = validate_text(text, "m.xml", check_world=False)
    canonical = canonical_text(spec, text)
    assert "\n#" not in canonical and "# " not in canonical and comments_in(text) == []
    assert "log: {message: 'step #1'}" in canonical


def test_a_comment_on_named_steps_comes_back_before_them():
    spec = validate_text("mission: m\nsubtrees:\n  a: stop\ntree: {subtree: a}\n", check_world=False)
    workspace = json.loads(workspace_json(to_workspace(spec)))
    workspace["blocks"]["blocks"][1]["icons"] = {"comment": {"text": "the steps"}}
    back, _ = from_workspace(json.dumps(workspace))
    assert "subtrees:\n  a:\n    # the steps\n    stop\n" in back


def test_a_problem_of_the_mission_block_is_said_at_the_mission_block():
    text = workspace_json(to_workspace(validate_text("mission: m\ntree: stop\n"))).replace(
        '"tick_hz":20.0', '"tick_hz":500'
    )
    with pytest.raises(MissionInvalid) as raised:
        from_workspace(text, "w.json")
    (problem,) = raised.value.problems
    assert text.splitlines()[0][problem.column - 1 :].startswith('"id":"b1"') and "tick_hz" in problem.message


def blocks_of(workspace: dict) -> dict[str, dict]:
    """Every block of a workspace, by its id."""
    found: dict[str, dict] = {}
    stack = list(workspace["blocks"]["blocks"])
    while stack:
        state = stack.pop()
        found[state["id"]] = state
        stack += [held["block"] for held in state.get("inputs", {}).values()]
        stack += [state["next"]["block"]] if "next" in state else []
    return found


def test_the_cursor_s_node_is_the_same_node_as_blocks_and_back_as_text():
    text = (ROOT / "missions" / "square.yaml").read_text()
    lines = text.splitlines()
    spec = validate_text(text, check_world=False)
    placed: dict[str, tuple[int, int]] = {}
    workspace = to_workspace(spec, text, placed)
    blocks = blocks_of(workspace)
    move_line = next(n for n, line in enumerate(lines, 1) if "- move:" in line)
    turn_line = next(n for n, line in enumerate(lines, 1) if "- turn:" in line)
    assert blocks[block_at_line(placed, move_line)]["type"] == "move+distance_mm"
    assert blocks[block_at_line(placed, turn_line)]["type"] == "turn+left"
    assert blocks[block_at_line(placed, turn_line + 1)]["type"] == "beep"  # the beep's line
    assert block_at_line(placed, 1) is None  # the mission's name: no node there
    # and back: each block's node begins on its line of the text the blocks give
    written: dict[str, int] = {}
    back, _ = from_workspace(workspace_json(workspace), lines=written)
    back_lines = back.splitlines()
    for block_id, state in blocks.items():
        if state["type"] in (MISSION_BLOCK, DEFINE_BLOCK):
            assert block_id not in written
            continue
        node = state["type"].split("+")[0]
        assert back_lines[written[block_id] - 1].lstrip("- ").startswith(node), (block_id, state["type"])
    assert len(written) == len(placed)

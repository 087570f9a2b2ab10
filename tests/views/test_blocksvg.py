"""A mission's blocks drawn as a picture for the feedback pages: what the blocks say, nested as they are."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from autonomy.mission import BUILTINS, validate_text
from autonomy.mission.blocks import block_definitions, to_workspace
from autonomy.views.blocksvg import MAX_BLOCKS, blocks_svg, mission_blocks_svg
from tests.views.conftest import ROOT

SVG = "{http://www.w3.org/2000/svg}"


def words(element: ET.Element) -> list[str]:
    """The texts drawn in an element, in order."""
    return [t.text or "" for t in element.iter(f"{SVG}text")]


def test_the_square_is_drawn_as_its_blocks_say_it_nested_as_they_are():
    text = (ROOT / "missions" / "square.yaml").read_text()
    drawn = ET.fromstring(mission_blocks_svg(text, "the square as blocks"))
    assert drawn.get("role") == "img" and drawn.get("aria-label") == "the square as blocks"
    said = words(drawn)
    for run in (["mission", "square", "in the world", "box"], ["repeat", "4", "times"], ["turn left", "90", "degrees"]):
        at = said.index(run[0])
        assert said[at : at + len(run)] == run, said
    assert said[said.index("move") + 1] == "forward ▾"  # a dropdown's choice, as its block shows it
    assert "✓" in said  # a checkbox (the sequence's memory)
    # the move is drawn inside the repeat's block, which is inside the mission's
    groups = [g for g in drawn.iter(f"{SVG}g") if "repeat" in words(g) and "move" in words(g)]
    assert groups and all("mission" in words(g) or "repeat" in words(g)[0:1] for g in groups)
    mission = drawn.find(f"{SVG}g")
    assert "move" in words(mission) and "turn left" not in words(mission)  # the corner's steps: a block of their own


def test_every_text_is_escaped_and_nothing_is_run_or_fetched():
    text = 'mission: "<script>alert(1)</script>"\ndescription: "a & b"\ntree:\n  log: {message: "</svg><img src=x>"}\n'
    svg = mission_blocks_svg(text, 'a "label" <b>')
    assert "<script" not in svg and "<img" not in svg and "href" not in svg
    drawn = ET.fromstring(svg)
    assert "<script>alert(1)</script>" in words(drawn) and drawn.get("aria-label") == 'a "label" <b>'


def test_a_mission_with_plugins_or_problems_is_not_drawn_and_its_plugins_never_imported(tmp_path, monkeypatch):
    (tmp_path / "boom.py").write_text("raise SystemExit('imported')\n")
    monkeypatch.chdir(tmp_path)  # where a plugin would be looked for
    assert mission_blocks_svg("mission: m\nplugins: [boom]\ntree: stop\n", "x") is None
    assert mission_blocks_svg("mission: m\ntree:\n  mvoe: {speed: 2}\n", "x") is None
    assert mission_blocks_svg("not: [a mission", "x") is None


def test_a_huge_mission_is_drawn_to_a_bound():
    leaves = "".join("    - beep\n" for _ in range(MAX_BLOCKS + 500))
    text = f"mission: big\ntree:\n  sequence:\n{leaves}"
    spec = validate_text(text, check_world=False)
    svg = blocks_svg(to_workspace(spec, text), block_definitions(BUILTINS), "big")
    assert words(ET.fromstring(svg)).count("beep the tones") < MAX_BLOCKS and "..." in svg

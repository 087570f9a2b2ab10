"""Every YAML block of the README and the docs is a file the tools take, as it stands."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from autonomy.classroom import load_exercise
from autonomy.emulator import load_world
from autonomy.mission import validate_text

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCKS = [
    (page, number, block)
    for page in PAGES
    for number, block in enumerate(re.findall(r"```yaml\n(.*?)```", page.read_text(encoding="utf-8"), re.S), 1)
]


def test_the_docs_have_yaml_blocks_to_check():
    assert len(BLOCKS) >= 4 and {page.name for page, _, _ in BLOCKS} >= {"README.md", "missions.md"}


@pytest.mark.parametrize(("page", "number", "block"), BLOCKS, ids=lambda v: v.name if isinstance(v, Path) else "")
def test_a_yaml_block_of_the_docs_is_taken_as_it_stands(page, number, block, tmp_path):
    first = block.lstrip().split(":", 1)[0]
    where = f"{page.name}, YAML block {number}"
    if first == "mission":
        spec = validate_text(block, where, base_dir=ROOT / "missions")  # raises with every problem
        assert spec.name
    elif first == "exercise":
        (tmp_path / "exercise.yaml").write_text(block)
        assert load_exercise(tmp_path / "exercise.yaml").criteria
    elif first == "name":
        (tmp_path / "world.yaml").write_text(block)
        assert load_world(tmp_path / "world.yaml").width_mm > 0
    else:
        pytest.fail(f"{where} is not a mission, an exercise or a world: say which, so that it can be checked")


def test_each_tree_picture_of_the_tutorial_is_the_mission_above_it_as_autonomy_show_draws_it():
    from autonomy.behaviours.tree import describe_tree
    from autonomy.mission import build_tree
    from autonomy.views.treesvg import svg_tree

    page = (ROOT / "docs" / "tutorial.md").read_text(encoding="utf-8")
    pictures = re.findall(r"\(images/(tutorial-[\w-]+\.svg)\)", page)
    assert len(pictures) >= 2
    for picture in pictures:
        above = re.findall(r"```yaml\n(.*?)```", page[: page.index(f"images/{picture}")], re.S)[-1]
        named = picture.removeprefix("tutorial-").replace(".svg", ".yaml")  # the file the tutorial saves it as
        spec = validate_text(above, named)
        drawn = svg_tree(describe_tree(build_tree(spec)), spec.name)
        shown = (ROOT / "docs" / "images" / picture).read_text(encoding="utf-8")
        assert drawn == shown, f"docs/images/{picture} is not the mission above it: autonomy show ... -o it again"

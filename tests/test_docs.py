"""Every YAML block of the README and the docs is a file the tools take, as it stands."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from autonomy.classroom import load_exercise
from autonomy.emulator import load_profile, load_world
from autonomy.mission import validate_text

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCKS = [
    (page, number, block)
    for page in PAGES
    for number, block in enumerate(re.findall(r"```yaml\n(.*?)```", page.read_text(encoding="utf-8"), re.S), 1)
]


def python_blocks(page: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", page.read_text(encoding="utf-8"), re.S)


def test_the_docs_have_yaml_blocks_to_check():
    assert len(BLOCKS) >= 4 and {page.name for page, _, _ in BLOCKS} >= {"README.md", "missions.md"}


@pytest.mark.parametrize(("page", "number", "block"), BLOCKS, ids=lambda v: v.name if isinstance(v, Path) else "")
def test_a_yaml_block_of_the_docs_is_taken_as_it_stands(page, number, block, tmp_path):
    first = block.lstrip().split(":", 1)[0]
    where = f"{page.name}, YAML block {number}"
    scenarios = re.match(r"# (\w+\.test\.yaml)\n", block)
    if scenarios:  # a scenario file, named in its first line, beside the shipped missions
        from autonomy.scenarios import load_scenarios

        for mission in (m for m in (ROOT / "missions").iterdir() if m.is_file()):
            shutil.copy(mission, tmp_path / mission.name)
        for other in BLOCKS:  # the page's own missions too, as the page names them
            named = re.match(r"mission: (\w+)\n", other[2]) if other[0] == page else None
            if named:
                (tmp_path / f"{named.group(1)}.yaml").write_text(other[2])
        (tmp_path / scenarios.group(1)).write_text(block)
        assert load_scenarios(tmp_path / scenarios.group(1)).scenarios  # raises with every problem
    elif first == "mission":
        base = ROOT / "missions"
        plugins = re.search(r"^plugins: \[(\w+)\]", block, re.M)
        if plugins:  # the plugin the page shows, saved beside the mission as the page says
            (tmp_path / f"{plugins.group(1)}.py").write_text(python_blocks(page)[0])
            base = tmp_path
        spec = validate_text(block, where, base_dir=base)  # raises with every problem
        assert spec.name
    elif first == "exercise":
        robot = re.search(r"^robot: ([\w.-]+)", block, re.M)
        if robot:  # the robot profile it names, beside it as the page says
            (tmp_path / robot.group(1)).write_text("name: robot\n")
        (tmp_path / "exercise.yaml").write_text(block)
        assert load_exercise(tmp_path / "exercise.yaml").criteria
    elif first == "name" and not re.search(r"^arena_mm:", block, re.M):  # a robot profile
        (tmp_path / "robot.yaml").write_text(block)
        assert load_profile(tmp_path / "robot.yaml").name
    elif first == "name":
        (tmp_path / "world.yaml").write_text(block)
        assert load_world(tmp_path / "world.yaml").width_mm > 0
    else:
        pytest.fail(
            f"{where} is not a mission, an exercise, a world, a robot profile or a scenario file "
            "(# NAME.test.yaml first): say which"
        )


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


def test_the_readme_s_mistake_is_what_check_says_of_its_mission_with_that_typo(tmp_path):
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    mission = re.findall(r"```yaml\n(.*?)```", readme, re.S)[0]
    said = next(line for line in readme.splitlines() if "unknown node 'trun'" in line)
    (tmp_path / "square.yaml").write_text(mission.replace("- turn:", "- trun:"))
    result = subprocess.run(
        [sys.executable, "-m", "autonomy", "check", "square.yaml"], capture_output=True, text=True, cwd=tmp_path
    )
    assert result.returncode == 2 and result.stderr.strip() == said


def test_the_plugin_of_the_docs_runs_its_mission_and_passes_its_own_tests(tmp_path):
    page = ROOT / "docs" / "plugins.md"
    plugin, test = python_blocks(page)
    mission = re.findall(r"```yaml\n(.*?)```", page.read_text(encoding="utf-8"), re.S)[0]
    (tmp_path / "approach.py").write_text(plugin)
    (tmp_path / "approach.yaml").write_text(mission)
    (tmp_path / "test_approach.py").write_text(test)
    ran = subprocess.run(
        [sys.executable, "-m", "autonomy", "run", "approach.yaml", "--fast", "--quiet"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=60,
    )
    assert ran.returncode == 0 and "succeeded" in ran.stdout, ran.stdout + ran.stderr
    tested = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:randomly", "-p", "no:cacheprovider", "test_approach.py"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=120,
    )
    assert tested.returncode == 0 and "2 passed" in tested.stdout, tested.stdout + tested.stderr
    schema = subprocess.run(
        [sys.executable, "-m", "autonomy", "schema", "approach.yaml"], capture_output=True, text=True, cwd=tmp_path
    )
    assert schema.returncode == 0 and '"approach"' in schema.stdout and '"facing"' in schema.stdout
    plain = subprocess.run([sys.executable, "-m", "autonomy", "schema"], capture_output=True, text=True, cwd=tmp_path)
    assert '"approach"' not in plain.stdout  # an editor knows a mission's plugins only when told the mission


def test_a_run_s_nodes_are_asked_for_by_name_or_type_and_a_wrong_one_says_which_there_are():
    from autonomy.testing import run_mission

    run = run_mission(ROOT / "missions" / "square.yaml", max_seconds=3)
    assert run.outcome == "stopped at the time limit" and len(run.path) == len(run.ticks) > 50
    assert run.statuses("move 300 mm")[0] == "RUNNING" and run.statuses("move") == run.statuses("move 300 mm")
    with pytest.raises(KeyError, match="no node named .mvoe.: the nodes are repeat x4, sequence, move 300 mm"):
        run.statuses("mvoe")

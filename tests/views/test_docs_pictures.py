"""The docs' pictures of the blocks and the text, taken in Chromium from the pages as they are.

Each run of the suite takes them again (into a folder of its own) and checks them; ``make pictures``
takes them into docs/images (``AUTONOMY_PICTURES``), where the docs show them.
"""

from __future__ import annotations

import os
import re
import struct
from pathlib import Path

import pytest

from tests.views.test_editor import ROOT, TEXT, until

DOCS = ROOT / "docs"
#: The pages' size in the pictures.
VIEWPORT = {"width": 1200, "height": 720}


def step_mission(number: int) -> str:
    """The tutorial's mission of its step ``number`` (the YAML under ``### Step N``)."""
    page = (DOCS / "tutorial.md").read_text(encoding="utf-8")
    section = page[page.index(f"### Step {number}:") :]
    return re.findall(r"```yaml\n(.*?)```", section, re.S)[0]


def png_size(path: Path) -> tuple[int, int]:
    """A PNG's width and height, read from its header (and that it is a PNG)."""
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR", path
    return struct.unpack(">II", head[16:24])


@pytest.fixture
def pictures(tmp_path) -> Path:
    """Where the pictures go: docs/images for ``make pictures``, else a folder of the test's own."""
    chosen = os.environ.get("AUTONOMY_PICTURES")
    return Path(chosen) if chosen else tmp_path


def page_for(browser, url: str):
    page = browser.new_page(viewport=VIEWPORT)
    page.goto(url)
    page.wait_for_selector("body[data-ready=yes]", timeout=30_000)
    return page


def test_the_pictures_of_the_blocks_are_taken_from_the_pages_the_docs_show(browser, editing, pictures):
    taken: dict[str, tuple[int, int]] = {}
    for step in (1, 3):  # the tutorial's blocks track: its missions as blocks
        url, _ = editing(step_mission(step), f"step{step}.yaml")
        page = page_for(browser, url)
        try:
            name = f"tutorial-blocks-{step}.png"
            page.locator("#blocks").screenshot(path=pictures / name)
            taken[name] = png_size(pictures / name)
        finally:
            page.close()
    url, _ = editing(step_mission(3), "walls.yaml")
    page = page_for(browser, url)
    try:
        page.screenshot(path=pictures / "blocks-editor.png")  # blocks and text side by side
        lines = step_mission(3).splitlines()
        turn = next(n for n, line in enumerate(lines) if "- turn:" in line)
        lines.insert(turn + 1, lines[turn].split("-")[0] + "- ")  # a new item of the list, after the turn
        page.locator(TEXT).fill("\n".join(lines) + "\n")
        page.evaluate(f"text.goTo({turn + 2}, 100)")
        page.keyboard.press("Control+Space")
        page.wait_for_selector(".cm-tooltip-autocomplete li", timeout=30_000)
        page.keyboard.type("tu")
        until(page, "document.querySelectorAll('.cm-tooltip-autocomplete li').length === 1")
        page.wait_for_selector(".cm-completionInfo", timeout=30_000)
        box = page.locator("#text").bounding_box()
        clip = {"x": 380, "y": box["y"], "width": VIEWPORT["width"] - 380, "height": 360}
        page.screenshot(path=pictures / "blocks-completion.png", clip=clip)  # the text's completions
        page.keyboard.press("Escape")
        page.keyboard.press("Control+z")
        page.get_by_role("button", name="High contrast").click()
        page.screenshot(path=pictures / "blocks-contrast.png")
        assert page.evaluate("document.documentElement.classList.contains('contrast')")
    finally:
        page.close()
    for name in ("blocks-editor.png", "blocks-completion.png", "blocks-contrast.png"):
        taken[name] = png_size(pictures / name)
    assert taken["blocks-editor.png"] == taken["blocks-contrast.png"] == (VIEWPORT["width"], VIEWPORT["height"])
    assert all(width > 300 and height > 200 for width, height in taken.values()), taken
    # the docs show each of them, and what they show was taken by this test (its sizes)
    shown = {
        name
        for page in ("blocks.md", "tutorial.md")
        for name in re.findall(r"\(images/((?:blocks|tutorial-blocks)[\w-]*\.png)\)", (DOCS / page).read_text())
    }
    assert shown == set(taken)
    for name, size in taken.items():
        assert png_size(DOCS / "images" / name) == size, f"docs/images/{name} is old: make pictures"


def test_the_blocks_track_s_steps_are_the_tutorial_s_missions():
    from autonomy.mission import validate_text

    for step in (1, 3):
        assert validate_text(step_mission(step), check_world=False).name == "four walls"

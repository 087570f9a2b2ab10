"""The student's text is a code editor (CodeMirror 6, vendored): highlighted, completed from the schema, problems
marked where they are, and the keys the page always had; in real headless Chromium, the class served by the CLI.
"""

from __future__ import annotations

import hashlib
import json
import urllib.request

from autonomy.classroom.exercise import load_exercise
from autonomy.liveclass.work import palette
from autonomy.mission import BUILTINS
from autonomy.mission.catalogue import json_schema
from autonomy.views.editor import vendored
from tests.axe import violations
from tests.liveclass.test_blocks_page import focused, keys, signed_in
from tests.liveclass.test_pages import FIXED, WAIT_MS, until
from tests.views.conftest import ROOT

TEXT = "#mission .cm-content"


def offered(page) -> list[str]:
    """The completions the editor offers now, once it offers some."""
    until(page, "document.querySelectorAll('.cm-tooltip-autocomplete li').length > 0")
    return page.locator(".cm-tooltip-autocomplete li .cm-completionLabel").all_text_contents()


# CodeMirror takes no Enter on a list of completions drawn less than this long ago (its `interactionDelay`, 75 ms:
# a list that appears under a key already on its way is not taken by it)
LIST_SETTLES_MS = 200


def take_completion(page) -> None:
    """Takes the completion selected, as a person does: with Enter, once the list is drawn and has stood a moment."""
    until(page, "missionText.completing() === 'active'")
    page.wait_for_timeout(LIST_SETTLES_MS)
    keys(page, "Enter")


def test_the_served_codemirror_is_the_one_recorded_and_pinned(classroom):
    student_url, _, _ = classroom
    record = vendored("codemirror")
    lock = json.loads((ROOT / "package-lock.json").read_text())
    pinned = json.loads((ROOT / "package.json").read_text())["devDependencies"]
    assert record["name"] == "codemirror" and record["licence"] == "MIT"
    assert lock["packages"]["node_modules/codemirror"]["version"] == record["version"] == pinned["codemirror"]
    for name, bundled in record["bundled"].items():  # each package in the bundle: its locked version, its licence
        assert lock["packages"][f"node_modules/{name}"]["version"] == bundled["version"], name
        assert (
            bundled["licence"] == "MIT"
            and f"{name} {bundled['version']} (MIT)"
            in (ROOT / "autonomy" / "views" / "static" / "vendor" / "codemirror" / "LICENSE").read_text()
        )
    assert {"@codemirror/view", "@codemirror/lang-yaml", "@codemirror/autocomplete", "@codemirror/lint"} <= set(
        record["bundled"]
    )
    with urllib.request.urlopen(f"{student_url}vendor/codemirror/codemirror.js", timeout=30) as served:
        body = served.read()
    assert hashlib.sha256(body).hexdigest() == record["files"]["codemirror.js"]
    assert b"new Function" not in body and b"eval(" not in body  # the page's policy runs no eval


def test_the_completions_come_from_the_exercise_s_schema():
    square = load_exercise(ROOT / "autonomy" / "exercises" / "square.yaml")
    schema = palette(square)["schema"]
    allowed = {"sequence", "repeat", "move", "turn", "beep", "subtree"}
    assert set(schema["$defs"]) - {"bare", "node"} == allowed
    assert schema["$defs"]["bare"]["enum"] == ["beep"]
    assert schema["$defs"]["move"] == json_schema(BUILTINS)["$defs"]["move"]  # each node as `autonomy schema` has it


def test_the_text_is_highlighted_completed_and_marked_and_keeps_its_keys(browser, classroom):
    errors: list[str] = []
    page = signed_in(browser, classroom, errors)
    try:
        page.click(TEXT)
        page.keyboard.insert_text("mission: park\ntree:\n  sequence:\n    - ")
        # where a node goes: the nodes, each with its description
        keys(page, "Control+Space")
        nodes = offered(page)
        assert {"move", "turn", "sequence", "obstacle_within", "beep"} <= set(nodes)
        assert "speed" not in nodes
        page.keyboard.type("mo")
        until(page, "!document.querySelector('.cm-tooltip-autocomplete').textContent.includes('sequence')")
        assert offered(page)[0] == "move"
        assert "Drive straight" in page.text_content(".cm-completionInfo")  # the help the docs show
        take_completion(page)
        assert page.evaluate("missionText.value").endswith("    - move: ")
        # within a node's mapping: its parameters, with their ranges
        page.keyboard.type("{")
        keys(page, "Control+Space")
        params = offered(page)
        assert {"speed", "direction", "distance_mm", "until_obstacle_mm"} <= set(params) and "move" not in params
        page.keyboard.type("spe")
        until(page, "document.querySelectorAll('.cm-tooltip-autocomplete li').length === 1")
        assert "from 1, to 4" in page.text_content(".cm-tooltip-autocomplete li[aria-selected=true]")
        assert violations(page) == []  # the list of completions open
        take_completion(page)
        page.keyboard.type("2, until_obstacle_mm: 150}")
        keys(page, "Escape")  # the list closes, if it is open
        assert page.evaluate("missionText.value") == FIXED.rstrip("\n")
        until(page, "!document.getElementById('tree').hidden")
        # highlighted as YAML: keys blue, values green, in colours of enough contrast
        colours = page.evaluate(
            "(() => { const out = {}; for (const span of document.querySelectorAll('#mission .cm-line span'))"
            " out[span.textContent] = getComputedStyle(span).color; return out; })()"
        )
        assert colours["mission"] == "rgb(28, 78, 128)" and colours["150"] == "rgb(23, 99, 43)", colours
        # a mistake: marked on its word, at its line; the list of problems takes the cursor there
        page.fill(TEXT, FIXED.replace("speed: 2", "speed: 9"))
        until(page, "document.querySelectorAll('#mission .cm-lintRange-error').length === 1")
        assert page.text_content("#mission .cm-lintRange-error") == "9"
        page.locator("#problems li").first.press("Enter")
        assert page.evaluate("missionText.cursorLine()") == 4 and page.evaluate("missionText.value").count("\n") == 4
        # Tab writes two spaces; Escape then Tab leaves the text; Ctrl+Enter runs
        page.fill(TEXT, "")
        keys(page, "Tab")
        assert page.evaluate("missionText.value") == "  " and "cm-content" in page.evaluate(
            "document.activeElement.className"
        )
        page.fill(TEXT, FIXED)
        until(page, "missionText.completing() === null")  # (an Escape would first put away the completions)
        keys(page, "Escape", "Tab")
        assert "cm-content" not in page.evaluate("document.activeElement.className"), focused(page)
        page.click(TEXT)
        keys(page, "Control+Enter")
        until(page, "document.getElementById('result-title').textContent.includes('/ 10')", WAIT_MS)
        assert page.text_content("#result-title") == "Your run, on the public seeds: 10 / 10"
        assert violations(page) == []
        assert page.evaluate("window.breaches") == [] and errors == []  # CodeMirror's styles came with the nonce
    finally:
        page.close()


def test_each_page_s_style_nonce_is_new_and_in_its_policy(classroom):
    student_url, _, _ = classroom
    seen = set()
    for _ in range(2):
        with urllib.request.urlopen(student_url, timeout=30) as answer:
            page, policy = answer.read().decode(), answer.headers["Content-Security-Policy"]
        nonce = page.split('<meta name="style-nonce" content="')[1].split('"')[0]
        assert f"style-src 'self' 'nonce-{nonce}'" in policy and "unsafe-eval" not in policy
        assert len(nonce) >= 24 and answer.headers["Cache-Control"] == "no-store"
        seen.add(nonce)
    assert len(seen) == 2


def colour_of(page, selector: str, prop: str = "color") -> str:
    return page.evaluate(f"getComputedStyle(document.querySelector({selector!r})).{prop}")


def test_high_contrast_is_a_button_away_on_the_text_and_the_blocks_and_axe_finds_nothing(browser, classroom):
    errors: list[str] = []
    page = signed_in(browser, classroom, errors)
    try:
        page.fill(TEXT, FIXED)
        until(page, "!document.getElementById('tree').hidden")
        assert colour_of(page, "body", "backgroundColor") != "rgb(0, 0, 0)"
        page.get_by_role("button", name="High contrast").click()
        assert page.get_attribute("#contrast", "aria-pressed") == "true"
        assert colour_of(page, "body", "backgroundColor") == "rgb(0, 0, 0)"
        assert colour_of(page, "#mission .cm-editor", "backgroundColor") == "rgb(0, 0, 0)"
        keys_colour = page.evaluate(
            "getComputedStyle([...document.querySelectorAll('#mission .cm-line span')]"
            ".find((s) => s.textContent === 'mission')).color"
        )
        assert keys_colour == "rgb(255, 235, 59)"  # the text's keys yellow on black
        assert violations(page) == []
        page.click("#mode-blocks")
        until(page, "document.getElementById('mode-blocks').getAttribute('aria-pressed') === 'true'")
        assert colour_of(page, "#blocks .blocklyBlockCanvas .blocklyPath", "fill") == "rgb(0, 0, 0)"
        assert colour_of(page, "#blocks .blocklyBlockCanvas .blocklyPath", "stroke") == "rgb(255, 235, 59)"
        assert colour_of(page, "#blocks .blocklyBlockCanvas .blocklyText", "fill") == "rgb(255, 255, 255)"
        assert colour_of(page, "#blocks .blocklyMainBackground", "fill") == "rgb(0, 0, 0)"
        assert violations(page) == []
        page.reload()  # kept in the browser
        until(page, "!document.getElementById('desk').hidden")
        assert page.get_attribute("#contrast", "aria-pressed") == "true"
        page.get_by_role("button", name="High contrast").click()
        assert colour_of(page, "body", "backgroundColor") != "rgb(0, 0, 0)"
        assert page.evaluate("window.breaches") == [] and errors == []
    finally:
        page.close()


def test_a_system_that_asks_for_more_contrast_gets_it_with_no_choice_made(browser, classroom):
    student_url, teacher_url, _ = classroom
    context = browser.new_context(contrast="more")
    try:
        for url in (student_url, teacher_url):
            page = context.new_page()
            page.goto(url)
            until(page, "document.documentElement.classList.contains('contrast')")
            assert page.get_attribute("#contrast", "aria-pressed") == "true"
            assert violations(page) == []
    finally:
        context.close()

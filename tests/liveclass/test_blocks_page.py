"""A student writes their mission as blocks in the class's page: with the keyboard alone, run for full marks.

The page is served by ``autonomy class serve`` as a teacher starts it, in real headless Chromium.
"""

from __future__ import annotations

import csv
import json
import signal
import urllib.error
import urllib.request

import pytest

from autonomy.classroom.exercise import load_exercise
from autonomy.liveclass.work import as_text, palette
from autonomy.mission.blocks import DEFINE_BLOCK, MISSION_BLOCK
from tests.axe import violations
from tests.liveclass.test_class_cli import serve, table
from tests.liveclass.test_pages import FIXED, MISTAKE, WAIT_MS, new_page, sign_in, until
from tests.views.conftest import ROOT

#: Set before the page's scripts run: every breach of the page's policy is kept to be read.
WATCH_POLICY = (
    "window.breaches = []; document.addEventListener('securitypolicyviolation', "
    "(e) => window.breaches.push(`${e.violatedDirective} ${e.blockedURI}`));"
)


def focused(page) -> str:
    return page.evaluate(
        "(() => { const a = document.activeElement;"
        " return `${a.tagName} ${a.id} ${a.getAttribute('aria-label') || a.textContent.slice(0, 40)}`; })()"
    )


def keys(page, *pressed: str) -> None:
    """Presses keys one after another, each once what the last did has been drawn."""
    for key in pressed:
        page.keyboard.press(key)
        page.wait_for_timeout(50)


def press_until(page, key: str, wanted: str, most: int = 30) -> None:
    """Presses ``key`` until what has the focus is named with ``wanted``."""
    for _ in range(most):
        if wanted in focused(page):
            return
        page.keyboard.press(key)
        page.wait_for_timeout(50)
    raise AssertionError(f"{wanted!r} never had the focus; {focused(page)!r} has it")


def signed_in(browser, classroom, errors: list[str], student: str = "1001"):
    """A student's page of the ``classroom`` fixture's class, signed in with the code of ``student``."""
    student_url, _, codes = classroom
    page = student_page(browser, student_url, errors)
    sign_in(page, codes[student])
    until(page, "!document.getElementById('desk').hidden")
    return page


def student_page(browser, url: str, errors: list[str]):
    """A new student's page at ``url``, every breach of its policy kept (``window.breaches``)."""
    page = new_page(browser, errors)
    page.add_init_script(WATCH_POLICY)
    page.goto(url)
    return page


def test_a_student_builds_the_garage_solution_with_the_keyboard_alone_and_runs_it_for_full_marks(browser, classroom):
    student_url, teacher_url, codes = classroom
    errors: list[str] = []
    page = student_page(browser, student_url, errors)
    try:
        page.keyboard.type(codes["1001"])
        page.keyboard.press("Enter")
        until(page, "!document.getElementById('desk').hidden")
        press_until(page, "Tab", "mode-blocks")
        page.keyboard.press("Enter")
        until(page, "document.getElementById('mode-blocks').getAttribute('aria-pressed') === 'true'")
        press_until(page, "Tab", "Order")  # the toolbox
        keys(page, "w")  # the workspace: the mission's block, empty
        press_until(page, "ArrowDown", "End mission")  # the place inside it
        keys(page, "t", "ArrowDown", "ArrowDown", "ArrowRight")  # the toolbox's Do, its first block
        press_until(page, "ArrowDown", "until an obstacle is within")
        keys(page, "Enter", "Enter")  # taken, and left at the place marked
        press_until(page, "ArrowRight", "Edit number: 150")  # its distance (typed again, from the keyboard)
        keys(page, "Enter", "Control+a", "1", "5", "0", "Enter")
        until(page, "missionText.value.includes('until_obstacle_mm: 150')")
        built = page.evaluate("missionText.value")
        assert built == "mission: my-mission\ntree:\n  move: {speed: 2, until_obstacle_mm: 150}\n"
        until(page, "!document.getElementById('tree').hidden")  # checked, and its tree drawn, as a text is
        assert violations(page) == []
        keys(page, "Escape")
        press_until(page, "Tab", "run")
        keys(page, "Enter")
        until(page, "document.getElementById('result-title').textContent.includes('/ 10')", WAIT_MS)
        assert page.text_content("#result-title") == "Your run, on the public seeds: 10 / 10"
        # made from blocks: its page opens on them, drawn as the student saw them, for the teacher too
        assert page.get_attribute("#replay", "src").endswith("#as-blocks")
        frame = page.frame_locator("#replay")
        frame.locator("#as-blocks[open] svg").wait_for(timeout=30_000)
        assert "until an obstacle is within" in frame.locator("#as-blocks svg").text_content()
        port, token = int(teacher_url.split(":")[2].split("/")[0]), teacher_url.split("#")[1]
        rows = table(port, token)["students"]
        assert next(r for r in rows if r["name"] == "Ada Lovelace")["latest_page"].endswith("#as-blocks")
        assert page.evaluate("window.breaches") == [] and errors == []
    finally:
        page.close()


def test_a_text_with_a_problem_stays_text_and_blocks_changed_are_the_text(browser, classroom):
    errors: list[str] = []
    page = signed_in(browser, classroom, errors, "1002")
    try:
        page.fill("#mission .cm-content", MISTAKE)
        page.click("#mode-blocks")
        until(page, "document.getElementById('message').textContent.includes('stays text')")
        assert "line 4, column 7" in page.text_content("#message")
        assert page.get_attribute("#mode-text", "aria-pressed") == "true" and page.is_visible("#mission")
        page.fill("#mission .cm-content", FIXED)
        page.click("#mode-blocks")
        until(page, "document.getElementById('mode-blocks').getAttribute('aria-pressed') === 'true'")
        assert page.is_hidden("#mission") and page.is_visible("#blocks")
        page.evaluate(
            "Blockly.getMainWorkspace().getAllBlocks(false).find((b) => b.type === 'move+until_obstacle_mm')"
            ".setFieldValue(3, 'speed')"
        )
        until(page, "missionText.value.includes('speed: 3')")
        page.click("#mode-text")
        until(page, "!document.getElementById('text-panel').hidden")
        assert page.evaluate("missionText.value") == (
            "mission: park\ntree:\n  sequence:\n    - move: {speed: 3, until_obstacle_mm: 150}\n"
        )
        assert violations(page) == [] and page.evaluate("window.breaches") == [] and errors == []
    finally:
        page.close()


def test_the_toolbox_holds_the_exercise_s_allowed_nodes_alone():
    square = load_exercise(ROOT / "exercises" / "square.yaml")
    shown = {block["type"].split("+")[0] for c in palette(square)["toolbox"]["contents"] for block in c["contents"]}
    assert shown == {*square.allowed_nodes, DEFINE_BLOCK, MISSION_BLOCK}
    assert {b["type"] for b in palette(square)["blocks"]} >= {"while", "obstacle_within"}  # any mission is shown


def test_blocks_of_a_node_the_exercise_does_not_allow_are_said_so():
    square = load_exercise(ROOT / "exercises" / "square.yaml")
    workspace = {
        "blocks": {
            "languageVersion": 0,
            "blocks": [
                {"type": "@mission", "id": "m", "fields": {"name": "m", "world": "", "tick_hz": 20},
                 "inputs": {"tree": {"block": {"type": "wait", "id": "w", "fields": {"seconds": 1}}}}},
            ],
        }
    }  # fmt: skip
    answer = as_text(square, json.dumps({"workspace": workspace}).encode())
    assert not answer["ok"] and "'wait' is not allowed in this exercise" in answer["problems"][0]["message"]
    assert as_text(square, b"[" * 100_000)["problems"][0]["message"].startswith("the body is JSON")


def test_the_blocks_routes_take_a_student_s_code_and_one_request_at_a_time(classroom):
    student_url, _, codes = classroom
    for path, body in (("api/blocks", {"mission": FIXED}), ("api/text", {"workspace": {}}), ("api/palette", None)):
        data = json.dumps(body).encode() if body is not None else None
        request = urllib.request.Request(student_url + path, data=data, method="POST" if data else "GET")
        try:
            urllib.request.urlopen(request, timeout=30)
            raise AssertionError(f"{path} answered without a code")
        except urllib.error.HTTPError as refused:
            assert refused.code == 401
        request.add_header("Authorization", f"Bearer {codes['1001']}")
        with urllib.request.urlopen(request, timeout=30) as answer:
            shown = json.loads(answer.read())
        assert shown.get("ok", "toolbox" in shown) == (path != "api/text"), shown


def test_a_student_signs_in_from_their_link_with_no_code_typed(browser, classroom, tmp_path):
    student_url, _, codes = classroom
    with (tmp_path / "class" / "links.csv").open() as stream:
        links = {row["id"]: row["link"] for row in csv.DictReader(stream)}
    assert links["1001"] == f"{student_url}#code={codes['1001']}"
    assert (tmp_path / "class" / "links.csv").stat().st_mode & 0o777 == 0o600
    errors: list[str] = []
    page = new_page(browser, errors)
    try:
        page.goto(links["1001"])
        until(page, "!document.getElementById('desk').hidden")
        assert page.text_content("#who") == "Ada Lovelace" and "#" not in page.url  # the code left the address
        assert errors == []
    finally:
        page.close()


def test_switching_between_text_and_blocks_keeps_the_cursor_s_node(browser, classroom):
    errors: list[str] = []
    page = signed_in(browser, classroom, errors, "1001")
    try:
        text = "mission: park\ntree:\n  sequence:\n    - beep\n    - move: {speed: 2, until_obstacle_mm: 150}\n"
        text += "    - stop\n"
        page.fill("#mission .cm-content", text)
        page.evaluate("missionText.goTo(5, 9)")  # the cursor on the move's line
        page.click("#mode-blocks")
        until(page, "document.getElementById('mode-blocks').getAttribute('aria-pressed') === 'true'")
        until(page, "Blockly.getFocusManager().getFocusedNode()?.type === 'move+until_obstacle_mm'")  # its block
        keys(page, "ArrowDown")  # with the keys, to the next block: the stop
        until(page, "Blockly.getFocusManager().getFocusedNode()?.type === 'stop'")
        page.click("#mode-text")
        until(page, "!document.getElementById('text-panel').hidden")
        assert page.evaluate("missionText.cursorLine()") == 6  # the stop's line, the cursor on its word
        assert page.evaluate("document.activeElement.classList.contains('cm-content')")
        page.keyboard.type("x")
        assert page.evaluate("missionText.value").endswith("    - xstop\n")
        assert errors == [] and page.evaluate("window.breaches") == []
    finally:
        page.close()


@pytest.fixture
def square_class(tmp_path):
    """``autonomy class serve square`` for Ada: (student's URL, her code)."""
    (tmp_path / "roster.csv").write_text("id,name,submission\n1001,Ada Lovelace,ada\n")
    process, port, _ = serve(tmp_path, exercise="square")
    with (tmp_path / "class" / "codes.csv").open() as stream:
        code = next(csv.DictReader(stream))["code"]
    yield f"http://127.0.0.1:{port}/", code
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=30)
    assert process.returncode == 0 and "Traceback" not in err, err


def test_a_student_builds_the_square_with_the_keyboard_alone_and_runs_it_for_full_marks(browser, square_class):
    student_url, code = square_class
    errors: list[str] = []
    page = student_page(browser, student_url, errors)

    def from_toolbox(category: str, block: str) -> None:
        """Opens the toolbox at ``category``, and takes ``block`` from it to the place marked."""
        keys(page, "t", *["ArrowUp"] * 5)
        press_until(page, "ArrowDown", category)
        keys(page, "ArrowRight")
        press_until(page, "ArrowDown", block)
        keys(page, "Enter", "Enter")  # taken, and left at the place marked

    try:
        page.keyboard.type(code)
        page.keyboard.press("Enter")
        until(page, "!document.getElementById('desk').hidden")
        press_until(page, "Tab", "mode-blocks")
        page.keyboard.press("Enter")
        until(page, "document.getElementById('mode-blocks').getAttribute('aria-pressed') === 'true'")
        press_until(page, "Tab", "Order")  # the toolbox
        keys(page, "w")  # the workspace: the mission's block, empty
        press_until(page, "ArrowDown", "End mission")
        from_toolbox("Change", "repeat, 4, times")
        press_until(page, "ArrowDown", "End repeat, 4, times, do")
        from_toolbox("Order", "do these one after another")
        press_until(page, "ArrowDown", "End do these one after another")
        from_toolbox("Do", "for, 300, mm")
        press_until(page, "ArrowRight", "Edit number: 300")  # a side is 50 cm
        keys(page, "Enter", "Control+a", "5", "0", "0", "Enter")
        press_until(page, "ArrowDown", "End do these one after another")
        from_toolbox("Do", "beep the tones")
        press_until(page, "ArrowDown", "End do these one after another")
        from_toolbox("Do", "turn left, 90")
        until(page, "missionText.value.includes('turn: {left: 90}')")
        assert page.evaluate("missionText.value") == (
            "mission: my-mission\ntree:\n  repeat:\n    times: 4\n    do:\n      sequence:\n"
            "        - move: {speed: 2, distance_mm: 500}\n        - beep\n        - turn: {left: 90}\n"
        )
        keys(page, "Escape")
        press_until(page, "Tab", "run")
        keys(page, "Enter")
        until(page, "document.getElementById('result-title').textContent.includes('/ 10')", WAIT_MS)
        assert page.text_content("#result-title") == "Your run, on the public seeds: 10 / 10"
        assert page.evaluate("window.breaches") == [] and errors == []
    finally:
        page.close()

"""``autonomy edit``: the mission as blocks and as text side by side, in real Chromium, the command run as a process."""

from __future__ import annotations

import hashlib
import json
import re
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from autonomy.mission import validate_text
from autonomy.mission.blocks import canonical_text
from autonomy.views.editor import vendored
from tests.axe import violations
from tests.mission.test_blocks import SHIPPED, shape
from tests.views.conftest import until as wait_until

ROOT = Path(__file__).resolve().parents[2]
#: The text's editor (CodeMirror's), where keys and pasted text go.
TEXT = "#text .cm-content"
#: Set before the page's scripts run: every breach of the page's policy is kept to be read.
WATCH_POLICY = (
    "window.breaches = []; document.addEventListener('securitypolicyviolation', "
    "(e) => window.breaches.push(`${e.violatedDirective} ${e.blockedURI}`));"
)


def open_page_unready(browser, url: str):
    """The editor's page, as soon as it is loaded (whether or not the editor could start)."""
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    page.add_init_script(WATCH_POLICY)
    page.goto(url)
    return page


def open_page(browser, url: str):
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    page.add_init_script(WATCH_POLICY)
    page.goto(url)
    page.wait_for_selector("body[data-ready=yes]", timeout=30_000)
    return page


def until(page, expression: str) -> None:
    """Waits until ``expression`` holds in the page (30 s at most, as a busy machine may need)."""
    wait_until(page, expression, 30_000)


def test_the_served_blockly_is_the_one_recorded_and_pinned(editing):
    url, _ = editing((ROOT / "missions" / "square.yaml").read_text())
    record = vendored()
    lock = json.loads((ROOT / "package-lock.json").read_text())
    assert record["name"] == "blockly" and record["licence"] == "Apache-2.0"
    assert lock["packages"]["node_modules/blockly"]["version"] == record["version"]
    assert json.loads((ROOT / "package.json").read_text())["devDependencies"]["blockly"] == record["version"]
    axe = json.loads((ROOT / "tests" / "vendor" / "axe-core" / "VENDOR.json").read_text())  # the tests' axe-core too
    assert lock["packages"]["node_modules/axe-core"]["version"] == axe["version"] and axe["licence"] == "MPL-2.0"
    base = url.split("#")[0]
    for name, digest in record["files"].items():
        if name == "LICENSE":  # kept beside the files, not served
            body = (ROOT / "autonomy" / "views" / "static" / "vendor" / "blockly" / name).read_bytes()
        else:
            with urllib.request.urlopen(f"{base}vendor/blockly/{name}", timeout=30) as served:
                body = served.read()
        assert hashlib.sha256(body).hexdigest() == digest, name
    with pytest.raises(urllib.error.HTTPError) as missing:
        urllib.request.urlopen(f"{base}vendor/blockly/../editor.py", timeout=30)
    assert missing.value.code == 404


def test_the_api_needs_the_page_s_key(editing):
    url, path = editing((ROOT / "missions" / "square.yaml").read_text())
    base, key = url.split("#")
    for given in ("", "Bearer wrong", f"Bearer {key}x", key, f"Basic {key}"):
        request = urllib.request.Request(f"{base}api/save", data=b'{"text": "mission: x"}', method="POST")
        if given:
            request.add_header("Authorization", given)
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(request, timeout=30)
        assert refused.value.code == 401
    request = urllib.request.Request(f"{base}api/save", data=b'{"text": "mission: x"}', method="POST")
    request.add_header("Authorization", f"Bearer {key}")
    request.add_header("Origin", "http://evil.example")
    with pytest.raises(urllib.error.HTTPError) as foreign:
        urllib.request.urlopen(request, timeout=30)
    assert foreign.value.code == 403 and "mission: square" in path.read_text()


def test_a_student_edits_blocks_and_text_and_saves_a_file_check_accepts(browser, editing):
    original = (ROOT / "missions" / "square.yaml").read_text()
    url, path = editing(original)
    page = open_page(browser, url)
    try:
        canvas = page.locator(".blocklyMainBackground ~ .blocklyBlockCanvas, .blocklyBlockCanvas").last
        assert canvas.locator(".blocklyDraggable").count() > 5  # the blocks are drawn
        drawn = "".join(canvas.evaluate("(canvas) => canvas.textContent").replace("▾", "").split())
        assert "moveforwardatspeed2for300mm" in drawn and "turnleft90degrees" in drawn, drawn  # the sentences
        # a block changed: the text follows
        page.evaluate(
            "Blockly.getMainWorkspace().getAllBlocks(false).find(b => b.type === 'move+distance_mm')"
            ".setFieldValue(3, 'speed')"
        )
        until(page, "text.value.includes('speed: 3')")
        # a mistake in the text: it stays text, said at its line and column; the blocks stay as they were
        text = page.locator(TEXT)
        text.fill(page.evaluate("text.value").replace("- move:", "- mvoe:"))
        until(page, "document.getElementById('problems').textContent.includes('mvoe')")
        problem = page.locator("#problems li").first.inner_text()
        assert problem.startswith("line 14, column 11:") and "mvoe" in problem, problem
        assert "line 14, column 11" in page.locator("#blocks-note").inner_text()
        assert page.evaluate("Blockly.getMainWorkspace().getAllBlocks(false).some(b => b.type === 'move+distance_mm')")
        # mended: the blocks are the text again
        text.fill(page.evaluate("text.value").replace("- mvoe:", "- move:").replace("volume: 3", "volume: 5"))
        until(page, "document.getElementById('blocks-note').hidden")
        until(page, "Blockly.getMainWorkspace().getAllBlocks(false).some(b => b.getFieldValue('volume') === 5)")
        page.get_by_role("button", name="Save").click()
        until(page, "document.getElementById('status').textContent.startsWith('Saved')")
        assert page.evaluate("window.breaches") == []  # Blockly ran under the page's strict policy
    finally:
        page.close()
    saved = path.read_text()
    assert "speed: 3" in saved and "volume: 5" in saved
    check = subprocess.run([sys.executable, "-m", "autonomy", "check", str(path)], capture_output=True, text=True)
    assert check.returncode == 0 and "ok" in check.stdout
    before, after = validate_text(original, check_world=False), validate_text(saved, check_world=False)
    assert shape(after)[:4] == shape(before)[:4]  # the same mission but what was changed


@pytest.mark.parametrize("source", SHIPPED[:4] + SHIPPED[-2:], ids=lambda p: p.name)
def test_a_shipped_mission_loaded_switched_to_blocks_and_back_and_saved_is_its_canonical_text(browser, editing, source):
    text = source.read_text()
    url, path = editing(text, source.name)
    if source.name == "explore.yaml":
        (path.parent / "opening_finder.py").write_text((source.parent / "opening_finder.py").read_text())
    page = open_page(browser, url)
    try:
        page.get_by_role("button", name="Write the blocks as text").click()
        until(page, "document.getElementById('status').textContent.includes('The text is the blocks')")
        page.get_by_role("button", name="Show the text as blocks").click()
        until(page, "document.getElementById('status').textContent.includes('The blocks are the text')")
        page.get_by_role("button", name="Write the blocks as text").click()
        until(page, "document.getElementById('status').textContent.includes('The text is the blocks')")
        page.get_by_role("button", name="Save").click()
        until(page, "document.getElementById('status').textContent.startsWith('Saved')")
        assert page.evaluate("window.breaches") == []
    finally:
        page.close()
    spec = validate_text(text, str(source), source.parent, check_world=False)
    assert path.read_text() == canonical_text(spec, text)


def test_the_editor_s_script_puts_what_it_receives_in_as_text_never_as_markup():
    from autonomy.views.page import static_text

    script = static_text("editor.js")
    for sink in ("innerHTML", "outerHTML", "insertAdjacentHTML", "document.write", "eval(", "srcdoc"):
        assert sink not in script, sink
    assert "textContent" in script


def focused(page) -> str:
    """What has the keyboard's focus, as a screen reader names it."""
    return page.evaluate(
        "(() => { const a = document.activeElement;"
        " return `${a.tagName} ${a.id} ${a.getAttribute('aria-label') || a.textContent.slice(0, 40)}`; })()"
    )


def press(page, key: str, until_focused: str = "") -> None:
    """Presses a key; with ``until_focused``, waits until what has the focus is named so."""
    page.keyboard.press(key)
    if until_focused:
        deadline = time.monotonic() + 30
        while until_focused not in focused(page):
            assert time.monotonic() < deadline, f"after {key}: {focused(page)}, not {until_focused}"
            threading.Event().wait(0.05)


def test_a_block_is_added_and_the_file_saved_with_the_keyboard_alone(browser, editing):
    url, path = editing("mission: m\ntree:\n  sequence:\n    - stop\n")
    page = open_page(browser, url)
    try:
        for _ in range(6):  # the buttons (Stop is off: no run), then the toolbox
            press(page, "Tab")
        assert "blocklyToolbox" in page.evaluate("document.activeElement.className")
        press(page, "w", "stack of blocks")  # the workspace
        press(page, "ArrowDown", "mission")
        press(page, "ArrowDown", "do these one after another")
        press(page, "ArrowDown", "stop")
        press(page, "ArrowDown", "End do these one after another")  # the place after the stop
        press(page, "t")  # the toolbox: Order, Change, Do
        press(page, "ArrowDown")
        press(page, "ArrowDown")
        press(page, "ArrowRight", "move, forward, at speed")  # the first of Do's blocks
        press(page, "Enter")  # taken, at the place marked
        press(page, "Enter")  # and left there
        until(page, "text.value.includes('- move: {speed: 2}')")
        page.keyboard.press("Shift+Tab")
        while "save" not in focused(page):
            page.keyboard.press("Shift+Tab")
        press(page, "Enter")
        until(page, "document.getElementById('status').textContent.startsWith('Saved')")
        assert violations(page) == []
    finally:
        page.close()
    assert path.read_text() == "mission: m\ntree:\n  sequence:\n    - stop\n    - move: {speed: 2}\n"


def test_a_mission_s_own_tests_stay_as_written_when_a_block_is_added_and_saved_with_the_keyboard(browser, editing):
    tests = "# its scenario\ntests:\n  - name: it stops\n    world: box\n    expect: {outcome: succeeded}  # at once\n"
    url, path = editing("mission: m\ntree:\n  sequence:\n    - stop\n" + tests)
    page = open_page(browser, url)
    try:
        for _ in range(6):  # the buttons, then the toolbox
            press(page, "Tab")
        press(page, "w", "stack of blocks")
        press(page, "ArrowDown", "mission")
        press(page, "ArrowDown", "do these one after another")
        press(page, "ArrowDown", "stop")
        press(page, "ArrowDown", "End do these one after another")
        press(page, "t")
        press(page, "ArrowDown")
        press(page, "ArrowDown")
        press(page, "ArrowRight", "move, forward, at speed")
        press(page, "Enter")
        press(page, "Enter")
        until(page, "text.value.includes('- move: {speed: 2}')")
        page.screenshot(path=str(path.with_suffix(".png")))
        page.keyboard.press("Shift+Tab")
        while "save" not in focused(page):
            page.keyboard.press("Shift+Tab")
        press(page, "Enter")
        until(page, "document.getElementById('status').textContent.startsWith('Saved')")
        assert violations(page) == []
    finally:
        page.close()
    assert path.read_text() == "mission: m\ntree:\n  sequence:\n    - stop\n    - move: {speed: 2}\n" + tests


def test_axe_finds_nothing_on_the_editor_with_blocks_a_problem_and_the_toolbox_open(browser, editing):
    url, _ = editing((ROOT / "missions" / "patrol.yaml").read_text())
    page = open_page(browser, url)
    try:
        assert violations(page) == []
        page.locator(".blocklyToolboxCategory").filter(has_text=re.compile("^Do$")).click()  # a category's blocks
        page.wait_for_selector(".blocklyFlyout .blocklyDraggable", timeout=30_000)
        assert violations(page) == []
        page.locator(TEXT).fill("mission: m\ntree:\n  sequence:\n    - mvoe: {speed: 2}\n")
        page.wait_for_selector("#problems li", timeout=30_000)
        assert violations(page) == []
        page.get_by_role("button", name="High contrast").click()  # and in high contrast
        assert page.evaluate("document.documentElement.classList.contains('contrast')")
        assert violations(page) == []
    finally:
        page.close()


def test_the_text_waits_untouched_while_it_has_a_problem_and_a_warned_block_is_deleted_cleanly(browser, editing):
    url, path = editing("mission: m\ntree:\n  sequence:\n    - stop\n")
    errors: list[str] = []
    page = open_page(browser, url)
    page.on("pageerror", lambda error: errors.append(str(error)))
    try:
        typed = "mission: m\ntree:\n  sequence:\n    - trun: {left: 90}\n    - wait: {seconds: 2}\n"
        page.locator(TEXT).fill(typed)
        until(page, "!document.getElementById('blocks-note').hidden")
        assert page.evaluate("document.getElementById('blocks').inert")  # the blocks take no change meanwhile
        assert page.evaluate("text.value") == typed
        page.locator(TEXT).fill(typed.replace("trun", "turn"))
        until(page, "!document.getElementById('blocks').inert")
        # a block left outside the mission is a problem on its block; Save says so, and saves nothing
        page.evaluate(
            "(() => { const b = Blockly.getMainWorkspace().newBlock('stop'); b.initSvg(); b.render();"
            " b.moveBy(300, 300); })()"
        )
        until(page, "document.getElementById('status').textContent.includes('problem')")
        page.get_by_role("button", name="Save").click()
        until(page, "document.getElementById('status').textContent.startsWith('Not saved')")
        assert path.read_text() == "mission: m\ntree:\n  sequence:\n    - stop\n"
        page.evaluate(
            "(() => { const b = Blockly.getMainWorkspace().getAllBlocks(false).find((b) => b.type === 'stop'"
            " && !b.getParent()); Blockly.getFocusManager().focusNode(b); })()"
        )
        page.keyboard.press("Delete")
        until(page, "document.getElementById('status').textContent === 'The text is the blocks.'")
        page.keyboard.press("Control+s")
        until(page, "document.getElementById('status').textContent.startsWith('Saved')")
        assert errors == [] and page.evaluate("window.breaches") == []
    finally:
        page.close()
    assert "turn: {left: 90}" in path.read_text() and "wait: {seconds: 2}" in path.read_text()


def test_a_new_file_starts_with_the_mission_s_block(browser, editing, tmp_path):
    url, path = editing("", "new.yaml")
    page = open_page(browser, url)
    try:
        assert "is new" in page.text_content("#status")
        assert page.evaluate("Blockly.getMainWorkspace().getAllBlocks(false).map((b) => b.type)") == ["@mission"]
    finally:
        page.close()


def test_a_file_larger_than_a_mission_file_is_said_so_on_the_page_and_not_read_whole(browser, editing):
    url, path = editing("mission: m\ntree:\n  sequence:\n" + "    - stop\n" * 70_000, "huge.yaml")
    page = open_page_unready(browser, url)
    try:
        until(page, "document.getElementById('status').textContent.includes('cannot read huge.yaml')")
        assert page.text_content("#status") == "cannot read huge.yaml: larger than 500,000 bytes"
    finally:
        page.close()


def test_the_buttons_keep_the_cursor_s_node_between_text_and_blocks(browser, editing):
    original = (ROOT / "missions" / "square.yaml").read_text()
    turn = next(n for n, line in enumerate(original.splitlines(), 1) if "- turn:" in line)
    url, _ = editing(original)
    page = open_page(browser, url)
    try:
        page.evaluate(f"text.goTo({turn}, 12)")
        page.get_by_role("button", name="Show the text as blocks").click()
        until(page, "Blockly.getFocusManager().getFocusedNode()?.type === 'turn+left'")
        page.evaluate(
            "Blockly.getFocusManager().focusNode("
            "Blockly.getMainWorkspace().getAllBlocks(false).find((b) => b.type === 'move+distance_mm'))"
        )
        page.get_by_role("button", name="Write the blocks as text").click()
        until(page, "document.activeElement.classList.contains('cm-content')")
        line = page.evaluate("text.value").splitlines()[page.evaluate("text.cursorLine()") - 1]
        assert line.strip().startswith("- move:"), line  # the move's line of the text the blocks wrote
    finally:
        page.close()


def test_the_editor_runs_its_mission_on_the_emulator_in_the_live_view_and_stops_it(browser, editing):
    url, path = editing("mission: short\ntree:\n  sequence:\n    - beep\n    - move: {speed: 2, seconds: 1}\n")
    page = open_page(browser, url)
    try:
        page.get_by_role("button", name="Run on the emulator").click()
        until(page, "!document.getElementById('run-pane').hidden")
        view = page.frame_locator("#view")
        view.locator("#mission").filter(has_text="short").wait_for(timeout=30_000)  # the live view, framed
        until(page, "document.getElementById('run-state').textContent.includes('succeeded')")
        assert page.evaluate("document.getElementById('stop').disabled")
        shown = page.text_content("#run-state")
        page.keyboard.press("Control+s")  # saved, the file runs as the page's run did
        until(page, "document.getElementById('status').textContent.startsWith('Saved')")
        ran = subprocess.run(
            [sys.executable, "-m", "autonomy", "run", "--fast", str(path)], capture_output=True, text=True, timeout=120
        )
        assert ran.returncode == 0 and "succeeded" in ran.stdout and "succeeded" in shown, (ran.stdout, shown)
        # a long run is stopped from the page: the robot stopped, the run said interrupted
        page.locator(TEXT).fill("mission: long\ntree:\n  move: {speed: 1, seconds: 200}\n")
        until(page, "document.getElementById('blocks-note').hidden")
        page.keyboard.press("Control+Enter")
        view.locator("#mission").filter(has_text="long").wait_for(timeout=30_000)  # the view follows the new run
        until(page, "!document.getElementById('stop').disabled")
        page.get_by_role("button", name="Stop").click()
        until(page, "document.getElementById('run-state').textContent.includes('stopped from the editor')")
        assert violations(page) == [] and page.evaluate("window.breaches") == []
        # a text that cannot run is said so, and not run
        page.locator(TEXT).fill("mission: m\nworld: nowhere\ntree: stop\n")
        page.get_by_role("button", name="Run on the emulator").click()
        until(page, "document.getElementById('status').textContent.startsWith('Not run')")
        assert "nowhere" in page.text_content("#problems")
    finally:
        page.close()
    assert path.read_text().startswith("mission: short")  # the runs after the save saved nothing


def test_a_run_that_cannot_start_says_why_in_one_line_and_the_view_is_framed_by_the_editor_alone(editing):
    url, path = editing("mission: m\ntree: stop\n")
    base, key = url.split("#")
    port = int(base.rstrip("/").rsplit(":", 1)[1])

    def run(text: str) -> dict:
        request = urllib.request.Request(
            f"{base}api/run", data=json.dumps({"text": text}).encode(), method="POST"
        )  # fmt: skip
        request.add_header("Authorization", f"Bearer {key}")
        with urllib.request.urlopen(request, timeout=30) as answer:
            assert answer.headers["Content-Type"].startswith("application/json")
            return json.loads(answer.read())

    (path.parent / "w.yaml").write_text("name: w\narena_mm: [.nan, 2000]\n")
    answer = run("mission: m\nworld: w.yaml\ntree: stop\n")  # the world's problem: said with its file
    assert answer["ok"] is False and "problems" not in answer and "w.yaml:2:" in answer["error"], answer
    (path.parent / "broken.py").write_text(
        "import sys\nfrom autonomy.behaviours import RobotAction\n\n\n"
        "class Broken(RobotAction):\n    node_type = 'broken'\n    doc = 'never made'\n    params = ()\n\n"
        "    def __init__(self, name, **args):\n        sys.exit(7)\n\n"
        "    def update(self):\n        return None\n"
    )
    answer = run("mission: m\nplugins: [broken]\ntree: broken\n")  # a node that cannot be made: at its line
    assert answer["ok"] is False and answer["problems"][0]["line"] == 3, answer
    assert "SystemExit: 7" in answer["problems"][0]["message"]
    # the view's page may be framed by the editor's page alone (by this machine's names of it)
    view = run("mission: m\ntree: stop\n")["view"]
    with urllib.request.urlopen(view, timeout=30) as answer:
        policy = answer.headers["Content-Security-Policy"]
    ancestors = policy.split("frame-ancestors ")[1].split(";")[0].split()
    assert ancestors == [f"http://127.0.0.1:{port}", f"http://localhost:{port}"]  # no IPv6: a policy has none
    for wrong in ("%C2%B2", "-1", "abc", "1e3"):  # a line that is no line is no line, never a 500
        body = b'{"text": "mission: m\\ntree: stop\\n"}'
        request = urllib.request.Request(f"{base}api/blocks?line={wrong}", data=body)
        request.add_header("Authorization", f"Bearer {key}")
        with urllib.request.urlopen(request, timeout=30) as answer:
            assert json.loads(answer.read())["selected"] is None


def test_a_value_changed_in_the_text_or_on_the_blocks_changes_that_field_alone(browser, editing):
    url, _ = editing((ROOT / "missions" / "square.yaml").read_text())
    page = open_page(browser, url)
    find = "Blockly.getMainWorkspace().getAllBlocks(false).find((b) => b.type === 'move+distance_mm')"
    try:
        page.evaluate(f"{find}.kept = 'the same block'")  # a mark on the block object itself
        page.locator(TEXT).fill(page.evaluate("text.value").replace("speed: 2", "speed: 3"))
        until(page, f"{find}.getFieldValue('speed') === 3")
        assert page.evaluate(f"{find}.kept") == "the same block"  # changed in place, not made again
        # a change made on the blocks, written as text; the text's next change is put in place all the same
        page.evaluate(f"{find}.setFieldValue(4, 'speed')")
        until(page, "text.value.includes('speed: 4')")
        page.locator(TEXT).fill(page.evaluate("text.value").replace("speed: 4", "speed: 1"))
        until(page, f"{find}.getFieldValue('speed') === 1")
        assert page.evaluate(f"{find}.kept") == "the same block"
        assert page.evaluate("window.breaches") == []
    finally:
        page.close()


def test_an_editor_served_on_every_interface_says_its_runs_can_be_watched_by_anyone(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text("mission: m\ntree: stop\n")
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "edit", str(path), "--host", "0.0.0.0", "--port", "0"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        warned = process.stderr.readline()
        assert warned.startswith("warning: the editor's runs are served on 0.0.0.0: anyone"), warned
    finally:
        process.terminate()
        _, err = process.communicate(timeout=30)
    assert "Traceback" not in err


#: The blocks of the workspace as Blockly saves them, bar ids and places: what a student sees.
SHOWN = """(space) => {
  const bare = (value) => {
    if (Array.isArray(value)) return value.map(bare);
    if (value && typeof value === 'object') {
      return Object.fromEntries(Object.entries(value).filter(([key]) => !['id', 'x', 'y'].includes(key))
        .map(([key, inner]) => [key, bare(inner)]));
    }
    return value;
  };
  return bare(Blockly.serialization.workspaces.save(space));
}"""

#: The same text loaded whole in a workspace of its own (the server's conversion, Blockly's load).
LOADED_WHOLE = """async () => {
  const answer = await api('/api/blocks', {text: text.value});
  const space = new Blockly.Workspace();
  Blockly.serialization.workspaces.load(answer.workspace, space);
  const shown = (SHOWN)(space);
  space.dispose();
  return shown;
}""".replace("SHOWN", SHOWN)


def test_a_text_changed_anywhere_is_put_in_place_as_the_blocks_a_whole_load_makes(browser, editing):
    """Each change of the text (a node more, fewer, another, nested, a comment, a named step) changes those blocks
    alone; the blocks are then those of the text loaded whole, and the cursor's node is found among the blocks kept."""
    url, _ = editing((ROOT / "missions" / "square.yaml").read_text())
    page = open_page(browser, url)
    mission = "Blockly.getMainWorkspace().getTopBlocks(true)[0]"
    move = "Blockly.getMainWorkspace().getAllBlocks(false).find((b) => b.type === 'move+distance_mm')"
    edits = [  # each a change of the text before it
        (
            "        - move: {speed: 2, distance_mm: 300}\n",
            "        - beep\n        - move: {speed: 2, distance_mm: 300}\n",
        ),
        ("      - turn: {left: 90}\n", ""),  # the step's first node gone
        ("        - beep\n", "        - wait: {seconds: 1}\n"),  # a node of another kind
        ("        - subtree: corner\n", "        - subtree: corner\n        - selector:\n            - stop\n"),
        ("            - stop\n", "            - stop\n            - beep\n"),  # inside a new composite
        ("        - wait: {seconds: 1}\n", "        # first, a pause\n        - wait: {seconds: 1}\n"),  # a comment
        ("        - selector:\n            - stop\n            - beep\n", ""),
        ("times: 4", "times: 3"),
    ]
    try:
        page.evaluate(f"{mission}.kept = 'kept'; {move}.kept = 'kept'")
        for old, new in edits:
            written = page.evaluate("text.value")
            assert old in written, old
            changed = written.replace(old, new, 1)
            page.evaluate(f"text.value = {json.dumps(changed)}")
            cursor = next(n for n, line in enumerate(changed.splitlines(), 1) if "- move:" in line)
            page.evaluate(f"text.goTo({cursor}, 12)")
            page.evaluate("document.getElementById('status').textContent = ''")
            page.get_by_role("button", name="Show the text as blocks").click()
            until(page, "document.getElementById('status').textContent === 'The blocks are the text.'")
            assert page.evaluate(f"({SHOWN})(Blockly.getMainWorkspace())") == page.evaluate(LOADED_WHOLE), new
            assert page.evaluate(f"[{mission}.kept, {move}.kept]") == ["kept", "kept"], new  # not made again
            until(page, f"Blockly.getFocusManager().getFocusedNode() === {move}")  # the cursor's node, kept
        # a named step more, then fewer: a stack of its own made, or disposed
        for old, new in (("subtrees:", "subtrees:\n  idle: stop"), ("  corner:", "  turning:"), ("  idle: stop\n", "")):
            changed = page.evaluate("text.value").replace(old, new, 1)
            changed = changed.replace("subtree: corner", "subtree: turning") if "turning:" in changed else changed
            page.evaluate(f"text.value = {json.dumps(changed)}")
            page.evaluate("document.getElementById('status').textContent = ''")
            page.get_by_role("button", name="Show the text as blocks").click()
            until(page, "document.getElementById('status').textContent === 'The blocks are the text.'")
            assert page.evaluate(f"({SHOWN})(Blockly.getMainWorkspace())") == page.evaluate(LOADED_WHOLE), new
            assert page.evaluate(f"[{mission}.kept, {move}.kept]") == ["kept", "kept"], new
        assert page.evaluate("window.breaches") == []
    finally:
        page.close()


def test_blocks_moved_turned_off_or_folded_then_a_text_change_give_the_blocks_a_whole_load_makes(browser, editing):
    """Neighbours swapped or gone together, named steps dragged out of order, a block turned off or folded on the
    blocks, a comment above the mission: each text change after is put in place (nothing loaded whole), and the
    blocks are those of a whole load, in its order; the cursor's node keeps the focus once Blockly is done."""
    text = "mission: m\nsubtrees:\n  a: stop\n  b: beep\ntree:\n  sequence: [{subtree: a}, {subtree: b}, stop, beep]\n"
    url, _ = editing(text)
    page = open_page(browser, url)
    warned: list[str] = []
    page.on("console", lambda message: warned.append(message.text) if message.type == "warning" else None)
    space = "Blockly.getMainWorkspace()"
    mission = f"{space}.getAllBlocks(false).find((b) => b.type === '@mission')"

    def shown_as(changed: str, cursor_line: int | None = None) -> None:
        page.evaluate(f"text.value = {json.dumps(changed)}")
        if cursor_line:
            page.evaluate(f"text.goTo({cursor_line}, 7)")
        page.evaluate("document.getElementById('status').textContent = ''")
        page.evaluate("toBlocks(true)")
        until(page, "document.getElementById('status').textContent === 'The blocks are the text.'")
        assert page.evaluate(f"({SHOWN})({space})") == page.evaluate(LOADED_WHOLE), changed

    try:
        page.evaluate(f"{mission}.kept = 'kept'")
        shown_as(text.replace("stop, beep]", "beep, stop]"))  # two neighbours of two kinds swapped
        shown_as(text.replace(", stop, beep]", "]"))  # two neighbours gone together
        # the named step b dragged above a, on the blocks: the text keeps a then b, and so do the blocks after
        page.evaluate(
            f"const [a, b] = {space}.getTopBlocks(false).filter((x) => x.type === '@define');"
            "b.moveTo(new Blockly.utils.Coordinate(20, a.getRelativeToSurfaceXY().y - 10))"
        )
        shown_as(text.replace("mission: m", "mission: n"))
        page.evaluate(f"{mission}.setFieldValue('n2', 'name')")  # a change on the blocks, written as text
        until(page, "text.value.includes('mission: n2')")
        assert page.evaluate("text.value").index("  a: stop") < page.evaluate("text.value").index("  b: beep")
        # a block turned off and one folded, on the blocks; then the text changes elsewhere
        page.evaluate(
            f"const s = {space}.getAllBlocks(false).find((x) => x.type === 'stop');"
            "s.setDisabledReason(true, 'MANUALLY_DISABLED');"
            f"{space}.getAllBlocks(false).find((x) => x.type === 'sequence').setCollapsed(true)"
        )
        shown_as(page.evaluate("text.value").replace("b: beep", "b: {beep: {volume: 2}}"))
        noted = "# the mission, with a note above it\n" + page.evaluate("text.value")  # a comment above it all
        shown_as(noted, cursor_line=noted.splitlines().index("    - subtree: b") + 1)  # its block has the focus
        assert page.evaluate(f"{mission}.kept") == "kept"  # none of it made the mission's blocks again
        # that block goes: the cursor's node has the focus, and keeps it once the block gone has handed its own on
        changed = noted.replace("    - subtree: b\n", "    - wait: {seconds: 1}\n")
        shown_as(changed, cursor_line=len(changed.splitlines()))  # on the last beep
        page.wait_for_timeout(200)
        assert page.evaluate("Blockly.getFocusManager().getFocusedNode()?.type") == "beep"
        # the block with the focus goes after a text with a problem: Blockly hands its focus on a moment later
        first = "mission: m\ntree:\n  sequence:\n    - stop\n    - invert:\n        do:\n          beep\n    - moving\n"
        for changed, line in ((first, 7), (first.replace("tree:", "tree:\n  bogus: 1"), 7), (first, 7)):
            page.evaluate(f"text.value = {json.dumps(changed)}; text.goTo({line}, 11); toBlocks(true)")
            until(page, "document.getElementById('status').textContent.startsWith('The ')")
            page.evaluate("document.getElementById('status').textContent = ''")
        shown_as(first.replace("    - invert:\n        do:\n          beep\n", "    - wait: {seconds: 1}\n"), 5)
        page.wait_for_timeout(200)
        assert page.evaluate("Blockly.getFocusManager().getFocusedNode()?.type") == "wait"
        assert not [w for w in warned if "loaded whole" in w], warned
    finally:
        page.close()

"""The class's pages in a real headless Chromium, served by ``autonomy class serve`` as a teacher starts it.

A student signs in, types a mission with a mistake and sees it at its line, fixes it, runs it,
hands it in and sees the marks; the teacher's page, open all along, shows the hand-in without a
reload; the projector view shows the class.
"""

from __future__ import annotations

import csv
import io
import re
import zipfile

from tests.views.conftest import until as until_in

#: Longest wait for what the server does (a busy machine grades slowly; a wait that holds returns at once).
WAIT_MS = 60_000


def until(page, expression: str, timeout: float = WAIT_MS) -> None:
    """Waits until ``expression`` holds; if it never does, says what the page said meanwhile."""
    try:
        until_in(page, expression, timeout)
    except AssertionError as err:
        said = page.evaluate("[...document.querySelectorAll('[role=alert], [role=status]')].map(e => e.textContent)")
        raise AssertionError(f"{err}; the page says {said}") from None


MISTAKE = "mission: park\ntree:\n  sequence:\n    - mvoe: {speed: 2, until_obstacle_mm: 150}\n"
FIXED = MISTAKE.replace("mvoe", "move")


def watching(browser, teacher_url: str, errors: list[str]):
    """The teacher's page, once it shows the class."""
    teacher = new_page(browser, errors)
    teacher.goto(teacher_url)
    until(teacher, "document.querySelectorAll('#class-table tbody tr').length === 2")
    return teacher


def sign_in(page, code: str) -> None:
    """Signs in on the student's page as a student does: the code typed, the button pressed."""
    page.fill("#code", code)
    page.click("#sign-in-form button")  # waits until the button is on: a moment after a wrong code


def press(page, selector: str) -> None:
    """Presses a button from the keyboard, as a keyboard user does.

    Once a page holds a replay's frame, a click right after the page scrolled may be routed by
    where the frame stood before (Chromium's hit testing of frames in other processes lags a
    scroll on a busy machine); a key goes to the button that has the focus.
    """
    page.focus(selector)
    page.keyboard.press("Enter")


def new_page(browser, errors: list[str]):
    context = browser.new_context(viewport={"width": 1400, "height": 1000}, accept_downloads=True)
    page = context.new_page()
    page.on("pageerror", lambda error: errors.append(str(error)))
    page.on("console", lambda message: errors.append(message.text) if message.type == "error" else None)
    return page


def test_a_student_writes_runs_and_hands_in_while_the_teacher_watches(browser, classroom):
    student_url, teacher_url, codes = classroom
    errors: list[str] = []
    teacher = watching(browser, teacher_url, errors)
    assert "#" not in teacher.url  # the token is out of the address bar before anything is shown
    names = teacher.locator("#class-table tbody td:first-child").all_text_contents()
    assert names == ["Ada Lovelace", "Bob <b>Jones</b>"]  # a name is text, never markup

    student = new_page(browser, errors)
    student.goto(student_url)
    sign_in(student, "wrong-code")
    until(student, "document.getElementById('sign-in-error').textContent !== ''")
    assert "no student has this sign-in code" in student.text_content("#sign-in-error")
    sign_in(student, f"{codes['1001'][:4]} {codes['1001'][4:]}".upper())  # as read off a sheet
    until(student, "!document.getElementById('desk').hidden")
    assert student.text_content("#who") == "Ada Lovelace"
    assert "Park in the garage" in student.text_content("#exercise-title")
    assert student.evaluate("document.getElementById('world').naturalWidth") > 100  # the world is drawn
    student.click("#node-help summary")  # the nodes, each with an example, for a first-timer
    assert "move: {speed: 2}" in student.locator("#nodes dt").all_text_contents()

    student.click("#mission .cm-content")
    student.keyboard.insert_text(MISTAKE)  # as pasted (typed, each new line would be indented as the last)
    until(student, "document.querySelectorAll('#mission .cm-lintRange-error').length > 0")
    marked = student.evaluate(
        "[...document.querySelectorAll('#mission .cm-line')].flatMap((line, i) =>"
        " [...line.querySelectorAll('.cm-lintRange-error')].map((mark) => `${i + 1} ${mark.textContent}`))"
    )
    assert marked == ["4 mvoe"]  # at its line and column, the word marked
    assert student.locator("#mission .cm-gutter-lint .cm-lint-marker-error").count() == 1  # and in the gutter
    assert student.text_content("#problems li").startswith("line 4, column 7:")
    assert student.locator("#tree").is_hidden()

    student.fill("#mission .cm-content", FIXED)
    until(student, "!document.querySelector('#mission .cm-lintRange-error') && !document.getElementById('tree').hidden")
    assert student.evaluate("document.getElementById('tree').naturalWidth") > 50  # the tree is drawn

    student.click("#run")
    until(student, "!document.getElementById('result').hidden")
    assert "run, on the public seeds" in student.text_content("#result-title")
    assert len(student.locator("#outcomes li").all()) == 4  # the 4 public seeds
    frame = student.frame_locator("#replay")
    frame.locator("h1").wait_for(timeout=WAIT_MS)  # the feedback page, with each seed's replay
    assert len(frame.locator("iframe[data-run]").all()) == 4
    until(teacher, "document.querySelector('#class-table tbody tr').cells[3].textContent === '1'")  # the run, live

    press(student, "#handin")
    until(student, "document.getElementById('result-title').textContent.includes('hand-in')")
    title = student.text_content("#result-title")
    assert re.search(r"hand-in 1, on every seed: \d+(\.\d+)? / 10", title), title
    assert len(student.locator("#outcomes li").all()) == 16  # 4 public and 12 hidden seeds
    hidden = student.locator("#outcomes li").all_text_contents()[-1]
    assert hidden.startswith("hidden seed") and not re.search(r"seed \d{3,}", hidden)
    assert len(student.locator("#handins li").all()) == 1
    mark = title.split(": ")[1]

    # the teacher's page, never reloaded, shows the hand-in and its mark
    until(teacher, "document.querySelector('#class-table tbody tr').cells[4].textContent === '1'")
    ada = teacher.locator("#class-table tbody tr").first
    assert ada.locator("td.mark").text_content() == mark
    ada.locator("button", has_text="Replay").focus()
    teacher.keyboard.press("Enter")
    teacher.frame_locator("#viewer-frame").locator("h1").wait_for(timeout=WAIT_MS)

    # the projector shows the class: every student, Ada's mark; then Ada's run
    press(teacher, "#projector")
    assert teacher.locator("#desk").is_hidden() and teacher.locator("#board").is_visible()
    cards = teacher.locator("#board .student")
    assert cards.count() == 2
    assert cards.first.locator(".name").text_content() == "Ada Lovelace"
    assert cards.first.locator(".mark").text_content() == mark
    assert cards.nth(1).locator(".mark").text_content() == "-"
    assert codes["1001"] not in teacher.content()  # no code, no token on the projector
    teacher.keyboard.press("Escape")
    press(teacher, "#viewer-project")
    teacher.frame_locator("#board-frame").locator("h1").wait_for(timeout=WAIT_MS)
    assert teacher.text_content("#board-run-title") == "Ada Lovelace: latest run"
    projected = teacher.frame_locator("#board-frame").locator("h1").text_content()
    assert projected.startswith("hand-in 1: ") and "1001" not in projected  # no id on the projector

    # the exports: the gradebook with ids, each student's feedback page
    teacher.keyboard.press("Escape")
    with teacher.expect_download() as got:
        press(teacher, "#export-csv")
    rows = list(csv.DictReader(io.StringIO(open(got.value.path()).read())))
    assert [(row["id"], row["total"]) for row in rows] == [("1001", mark.split(" / ")[0]), ("1002", "0")]
    with teacher.expect_download() as got:
        press(teacher, "#export-feedback")
    assert zipfile.ZipFile(got.value.path()).namelist() == ["1001.html"]
    with teacher.expect_download() as got:
        press(teacher, "#export-gradescope")
    assert "setup.sh" in zipfile.ZipFile(got.value.path()).namelist()

    # a student signed in again gets their mission and hand-ins back
    student.reload()
    until(student, "!document.getElementById('desk').hidden")
    assert student.evaluate("missionText.value") == FIXED
    assert len(student.locator("#handins li").all()) == 1
    assert [e for e in errors if "status of 401" not in e] == [] and len(errors) == 1  # the wrong code's refusal


def test_the_teacher_closes_hand_ins_and_the_student_is_told(browser, classroom):
    student_url, teacher_url, codes = classroom
    errors: list[str] = []
    teacher = watching(browser, teacher_url, errors)
    student = new_page(browser, errors)
    student.goto(student_url)
    sign_in(student, codes["1002"])
    until(student, "!document.getElementById('desk').hidden")
    assert student.text_content("#who") == "Bob <b>Jones</b>"
    teacher.click("#close-now")
    until(teacher, "document.getElementById('deadline-state').textContent.includes('closed')")
    student.fill("#mission .cm-content", FIXED)
    until(student, "document.getElementById('handin').disabled")
    assert "Hand-ins are closed" in student.text_content("#deadline")
    student.evaluate("document.getElementById('handin').disabled = false")  # a page that was not told
    student.click("#handin")
    until(student, "document.getElementById('message').textContent.includes('closed')")
    assert student.locator("#handins li").count() == 0 and student.locator("#handin").is_disabled()
    teacher.click("#reopen")
    until(teacher, "document.getElementById('deadline-state').textContent === 'Hand-ins are open.'")
    student.fill("#mission .cm-content", FIXED + "\n")
    until(student, "!document.getElementById('handin').disabled")
    assert [e for e in errors if "status of 403" not in e] == []  # the refused hand-in's line


def test_the_teacher_page_without_its_token_says_where_to_find_it(browser, classroom):
    _, teacher_url, _ = classroom
    errors: list[str] = []
    teacher = new_page(browser, errors)
    teacher.goto(teacher_url.split("#")[0] + "#not-the-token")
    until(teacher, "!document.getElementById('no-token').hidden")
    assert "not the class's" in teacher.text_content("#token-why")
    assert teacher.locator("#class-table tbody tr").count() == 0
    assert [e for e in errors if "401" not in e] == []  # the refused request is the console's one line


def run_as(student_url: str, code: str, mission: str) -> dict:
    """A run sent as a student's page sends it."""
    import json
    import urllib.request

    request = urllib.request.Request(
        student_url + "api/run", data=json.dumps({"mission": mission}).encode(), method="POST"
    )
    request.add_header("Content-Type", "application/json")
    request.add_header("Authorization", f"Bearer {code}")
    with urllib.request.urlopen(request, timeout=120) as answer:
        return json.loads(answer.read())


def test_the_teacher_sees_the_class_at_a_glance_live_and_opens_a_run_from_its_map(browser, classroom):
    from tests.axe import violations

    student_url, teacher_url, codes = classroom
    errors: list[str] = []
    teacher = watching(browser, teacher_url, errors)
    until(teacher, "document.querySelectorAll('#overview li.map').length === 2")
    assert teacher.locator("#overview li.map.notgraded").count() == 2  # nothing graded yet, said so
    assert teacher.text_content("#overview .says").startswith("0 students graded of 2")
    parked = run_as(student_url, codes["1001"], FIXED)
    crash = "mission: crash\ntree:\n  move: {speed: 4, until_obstacle_mm: 60}\n"
    crashed = run_as(student_url, codes["1002"], crash)
    # live: the page is never reloaded
    until(teacher, "document.querySelectorAll('#overview li.map.notgraded').length === 0")
    assert teacher.text_content("#overview .says").startswith("2 students graded of 2")
    ada, bob = teacher.locator("#overview li.map").nth(0), teacher.locator("#overview li.map").nth(1)
    assert ada.locator(".who").text_content() == "Ada Lovelace"
    assert bob.locator(".who").text_content() == "Bob <b>Jones</b>"  # a name is text, never markup
    assert ada.locator(".mark").text_content().startswith(f"{'✓' if parked['total'] == 10 else '◐'} ")
    assert bob.get_attribute("class") in ("map part", "map none") and crashed["total"] < parked["total"]
    assert bob.locator("path.collision").count() >= 1  # where he hit the wall
    moves = teacher.locator("#overview table.nodes tbody tr").first
    assert moves.locator("th").text_content() == "move" and "No crash" in moves.text_content()
    assert teacher.locator("#overview table.shares tbody tr").count() == 4
    assert violations(teacher) == []
    # a map, from the keyboard, opens that student's run in the desk's viewer
    bob.locator("button").focus()
    teacher.keyboard.press("Enter")
    until(teacher, "!document.getElementById('viewer').hidden")
    seed = bob.locator(".mark").text_content().split(" on ")[-1]  # the seed his map shows
    assert teacher.text_content("#viewer-title") == f"Bob <b>Jones</b>: latest run, {seed}"
    src = teacher.get_attribute("#viewer-frame", "src")
    assert re.fullmatch(re.escape(crashed["page"].split("#")[0]) + r"#seed-\d+", src), src
    opened = teacher.frame_locator("#viewer-frame").locator(f"section#{src.split('#')[1]}")  # that seed's part of it
    opened.locator("h2").wait_for(timeout=WAIT_MS)
    assert opened.locator("h2").text_content().startswith(f"{seed}: ")
    teacher.click("#contrast")
    assert violations(teacher) == []
    assert errors == []

"""A run on one of the class's robots, as a student and the teacher see it in a real headless Chromium, with the
keyboard alone: the student asks for it and sees their place, the teacher starts it at the desk and shows it on the
projector, the student watches it live and finds it kept, "on robot a", beside the same mission on the emulator
calibrated to that robot; axe finds nothing on either page."""

from __future__ import annotations

import csv
import signal

from tests.axe import violations
from tests.cli.test_cli import ROOT
from tests.liveclass.test_class_cli import post, serve
from tests.liveclass.test_pages import FIXED, new_page, press, sign_in, until, watching
from tests.liveclass.test_robots import PROFILE, ended, robot_process


def test_a_student_asks_for_a_robot_the_teacher_starts_it_both_watch_it_live_and_it_is_kept(browser, tmp_path):
    robot, url = robot_process(profile=PROFILE)  # a robot, calibrated
    (tmp_path / "roster.csv").write_text("id,name\n1001,Ada Lovelace\n1002,Bob Jones\n")
    exercise = tmp_path / "garage.yaml"  # whose runs on robots the teacher marks
    exercise.write_text((ROOT / "exercises" / "garage.yaml").read_text() + "robot_points: 5\n")
    process, port, token = serve(
        tmp_path, "--robot", f"a={url}", "--robot-profile", f"a={PROFILE}", exercise=str(exercise)
    )
    try:
        with (tmp_path / "class" / "codes.csv").open() as stream:
            codes = {row["id"]: row["code"] for row in csv.DictReader(stream)}
        errors: list[str] = []
        teacher = watching(browser, f"http://127.0.0.1:{port}/teacher#{token}", errors)
        until(teacher, "!document.getElementById('robots').hidden")
        until(teacher, "document.querySelector('#robots-table tbody tr').cells[1].textContent === 'free'")
        assert teacher.text_content("#queue-empty") == "Nobody is waiting for a robot."

        student = new_page(browser, errors)
        student.goto(f"http://127.0.0.1:{port}/")
        sign_in(student, codes["1001"])
        until(student, "!document.getElementById('desk').hidden && !document.getElementById('robot').hidden")
        student.fill("#mission .cm-content", FIXED)
        press(student, "#robot-ask")  # before it ran: told to run it first
        until(student, "document.getElementById('robot-state').textContent.includes('run this mission first')")
        press(student, "#run")
        until(student, "!document.getElementById('result').hidden")
        press(student, "#robot-ask")
        until(student, "document.getElementById('robot-state').textContent.includes('1st in the queue')")
        assert "your teacher starts it" in student.text_content("#robot-state")
        assert student.locator("#robot-cancel").is_visible()
        assert violations(student) == []

        until(teacher, "document.querySelectorAll('#queue li').length === 1")
        assert teacher.text_content("#queue li").startswith("Ada Lovelace (1001), waiting")
        assert violations(teacher) == []
        press(teacher, "#robots-table button:has-text('Start on a')")
        until(teacher, "document.querySelector('#robots-table tbody tr').cells[1].textContent === 'running'")
        assert teacher.text_content("#robots-table tbody tr td:nth-child(3)").startswith("Ada Lovelace")

        # live on the student's page: the robot's own view, framed, its tree drawn as it runs
        until(student, "document.getElementById('robot-state').textContent.includes('running on robot a')")
        live = student.frame_locator("#robot-view")
        live.locator("#tree svg").first.wait_for(timeout=30_000)
        assert live.locator("#mission").text_content().strip().startswith("park")
        # and on the projector, from the desk
        press(teacher, "#robots-table button:has-text('Show on the projector')")
        assert teacher.locator("#board").is_visible() and teacher.locator("#board-live").is_visible()
        assert teacher.text_content("#board-run-title") == "Ada Lovelace: on robot a"
        teacher.frame_locator("#board-live").locator("#tree svg").first.wait_for(timeout=30_000)
        teacher.keyboard.press("Escape")

        # it ends (the garage's time limit, or the mission's end), the robot stopped, and it is kept
        until(student, "document.getElementById('robot-state').textContent.includes('Your run on robot a:')", 90_000)
        assert "It was stopped at the end." in student.text_content("#robot-state")
        until(student, "document.querySelectorAll('#robot-runs li').length === 1")
        assert student.text_content("#robot-runs li").startswith("On robot a")
        # beside it, the same mission on the emulator calibrated to robot a: side by side, each drawn
        until(student, "!document.getElementById('robot-emulated').hidden")
        assert student.locator("#robot-emulated-note").is_visible()
        student.frame_locator("#robot-emulated").locator("#tree svg").first.wait_for(timeout=30_000)
        left, right = student.locator("#robot-view").bounding_box(), student.locator("#robot-emulated").bounding_box()
        assert left["x"] + left["width"] <= right["x"] and abs(left["y"] - right["y"]) < 1
        assert violations(student) == []
        press(student, "#robot-runs li button")  # its replay, a page of its own
        student.frame_locator("#robot-view").locator("#tree svg").first.wait_for(timeout=30_000)
        until(teacher, "document.querySelector('#robots-table tbody tr').cells[1].textContent === 'free'")
        assert "Your teacher marks it, up to 5 points" in student.text_content("#robot-marks")
        assert student.text_content("#robot-runs li").endswith("(not marked yet)replay")

        # the teacher marks it, having watched it: typed, and Enter, at the desk
        until(teacher, "document.querySelectorAll('#robot-runs-table tbody tr').length === 1")
        assert teacher.text_content("#robot-runs-table tbody tr td:nth-child(5)") == "not marked"
        assert "worth up to 5 points" in teacher.text_content("#robot-marks-how")
        mark = teacher.locator("#robot-runs-table input")
        assert mark.get_attribute("aria-label").startswith("Mark of run")
        mark.focus()
        teacher.keyboard.type("9")
        teacher.keyboard.press("Enter")  # more than the exercise gives: refused, said
        until(teacher, "document.getElementById('robots-message').textContent.includes('from 0 to 5')")
        teacher.keyboard.press("Backspace")
        teacher.keyboard.type("4")
        press(teacher, "#robot-runs-table button:has-text('Save mark')")
        cell = "document.querySelector('#robot-runs-table tbody tr td:nth-child(5)').textContent"
        until(teacher, f"{cell} === '4 / 5'")
        # what is not a number (a box of numbers reads it as empty) is said, and takes no mark back
        mark = teacher.locator("#robot-runs-table input")
        mark.focus()
        teacher.keyboard.press("Control+A")
        teacher.keyboard.type("-")
        teacher.keyboard.press("Enter")
        until(teacher, "document.getElementById('robots-message').textContent.includes('a mark is a number')")
        assert teacher.evaluate(cell) == "4 / 5"
        # a mark given elsewhere (another desk) shows in a box nobody typed in, and is not saved over
        teacher.keyboard.press("Control+A")
        teacher.keyboard.type("4")
        press(teacher, "#robot-runs-table button:has-text('Save mark')")
        until(teacher, "document.getElementById('robots-message').textContent.includes('mark saved')")
        run = int(teacher.evaluate("document.querySelector('#robot-runs-table input').dataset.run"))
        marked = post(port, "/api/robots/mark", {"run": run, "points": 3}, token)
        assert marked["runs"][0]["points"] == 3
        until(teacher, f"{cell} === '3 / 5' && document.querySelector('#robot-runs-table input').value === '3'")
        press(teacher, "#robot-runs-table button:has-text('Save mark')")
        until(teacher, "document.getElementById('robots-message').textContent.includes('mark saved')")
        assert teacher.evaluate(cell) == "3 / 5"
        post(port, "/api/robots/mark", {"run": run, "points": 4}, token)
        until(teacher, f"{cell} === '4 / 5'")
        row = "document.querySelector('#class-table tbody tr')"
        until(teacher, f"{row}.cells[5].textContent.includes('4 / 5 on a robot')")
        assert violations(teacher) == []
        student.reload()
        until(student, "document.querySelectorAll('#robot-runs li').length === 1")
        assert "(your teacher's mark: 4 of 5)" in student.text_content("#robot-runs li")
        assert [e for e in errors if "status of 409" not in e] == []  # the refusal before it ran, said on the page
    finally:
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=30)
        ended(robot)
    assert process.returncode == 0 and "Traceback" not in err, err

"""The class inside an LMS, in a real headless Chromium: the teacher and a student follow the course's link (the
LMS's login, the tool's, the LMS's signed answer posted back: LTI 1.3's whole dance, cookies and all), the
teacher lands on the desk and a student on their page; the teacher adds the class to a course's page (deep
linking); the desk shows the course, its roster (read before anyone
signed in) and the marks sent to its gradebook; the keyboard alone reads the roster again; axe finds nothing."""

from __future__ import annotations

import urllib.parse

from tests.axe import violations
from tests.liveclass.lms_platform import FakeLms
from tests.liveclass.test_lms import open_class
from tests.liveclass.test_pages import new_page, press, until
from tests.liveclass.test_server import GARAGE


def test_the_teacher_and_a_student_follow_the_course_s_link_and_the_desk_shows_the_lms(browser, tmp_path):
    platform = FakeLms()
    platform.enrol(3)
    server, store = open_class(tmp_path, platform, public_url="")  # the tool's address: the browser's
    try:
        errors: list[str] = []
        link = f"{platform.base}/course?tool={urllib.parse.quote(server.url)}&who="
        teacher = new_page(browser, errors)
        teacher.goto(link + "t-1")
        teacher.wait_for_selector("#lms-roster-read", state="attached", timeout=60_000)  # through the LMS's pages
        until(teacher, "!document.getElementById('desk').hidden && !document.getElementById('lms').hidden")
        assert urllib.parse.urlsplit(teacher.url).path == "/teacher" and "#" not in teacher.url  # no token shown
        assert "the class is course Robotics 7's. Its instructors: Grace Hopper." in teacher.text_content("#lms-course")
        until(teacher, "document.getElementById('lms-roster').textContent.includes('3 students, 1 instructor')")
        until(teacher, "document.querySelectorAll('#class-table tbody tr').length === 3")  # before they sign in
        assert teacher.text_content("#lms-scores") == "0 sent, 0 waiting."

        student = new_page(browser, errors)
        student.goto(link + "u-1")
        student.wait_for_selector("#sign-out", state="attached", timeout=60_000)
        until(student, "!document.getElementById('desk').hidden")
        assert "Student 1" in student.text_content("#who")
        student.goto(f"{server.url}teacher")  # a learner never has the desk
        student.wait_for_selector("#no-token", state="attached")
        until(student, "!document.getElementById('no-token').hidden")

        store.add_work("00001", "handin", "mission", {}, 7.5, GARAGE.max_points)
        server._lms_mark("00001")  # as a graded hand-in is: its mark queued, then sent
        until(teacher, "document.getElementById('lms-scores').textContent === '1 sent, 0 waiting.'")
        cells = teacher.locator("#lms-table tbody tr").first.locator("td").all_text_contents()
        assert cells[:2] == ["Student 1 (00001)", f"7.5 / {GARAGE.max_points:g}"] and cells[3].startswith("sent at")
        (sent,) = platform.sent()
        assert sent["userId"] == "u-1" and sent["scoreGiven"] == 7.5

        platform.members.append({"user_id": "u-77", "name": "Late Joiner", "roles": [], "status": "Active"})
        press(teacher, "#lms-roster-read")  # the keyboard alone
        until(teacher, "document.querySelectorAll('#class-table tbody tr').length === 4")
        assert violations(teacher) == []

        # the teacher adds the class to another of the course's pages: the LMS's "add external tool"
        adding = new_page(browser, errors)
        adding.goto(link + "t-1&hint=deep")
        adding.wait_for_selector("#add", timeout=60_000)
        assert adding.text_content("h1") == GARAGE.title and violations(adding) == []
        press(adding, "#add button")  # the keyboard alone
        adding.wait_for_selector("#added", timeout=60_000)  # the LMS's page, once the form took the browser there
        (added,) = platform.deep_links
        (item,) = added["https://purl.imsglobal.org/spec/lti-dl/claim/content_items"]
        assert item["url"] == f"{server.url}lti/launch" and item["lineItem"]["resourceId"] == "autonomy:garage"
        assert errors == []
    finally:
        server.stop()
        store.close()
        platform.close()

"""The class's LMS beyond the sign-in (LTI Advantage), against an LMS run in the test process: its roster read
(Names and Roles) and shown before anyone signs in, and marks sent back to its gradebook (Assignment and Grades):
one line item, found again after a restart, and every score sent exactly once, though the LMS was down."""

from __future__ import annotations

import collections
import json

import pytest

from autonomy.clock import VirtualClock
from autonomy.liveclass import lms
from autonomy.liveclass.lti import LtiTool, ToolKey
from autonomy.liveclass.server import TEACHER_TOKEN, ClassServer
from autonomy.liveclass.store import ClassStore, token_digest
from tests.liveclass.lms_platform import COURSE, INSTRUCTOR, LTI, FakeLms
from tests.liveclass.test_lti import code_of, launch, never_graded
from tests.liveclass.test_robots import until
from tests.liveclass.test_server import GARAGE, SOLUTION, TYPO, call

PUBLIC = "https://class.school.example"


@pytest.fixture
def platform():
    made = FakeLms()
    yield made
    made.close()


def open_class(folder, platform: FakeLms, grader=never_graded, public_url=PUBLIC) -> tuple[ClassServer, ClassStore]:
    store = ClassStore(folder)
    store.set_setting(TEACHER_TOKEN, token_digest("teacher-token"))
    tool = LtiTool(platform.platform(), ToolKey(folder))
    server = ClassServer(GARAGE, store, folder, port=0, grader=grader, lti=tool, public_url=public_url)
    server.start()
    platform.tool_jwks_url = f"{server.url}lti/jwks"  # where the LMS checks the tool's assertions
    return server, store


def teacher_opens(server, platform: FakeLms) -> str:
    """The teacher's launch from the course (the class tied to it; its roster asked for); their desk's token."""
    status, headers, _ = launch(server, platform, sub="t-1", name="Grace Hopper",
                                **{LTI + "roles": [INSTRUCTOR], LTI + "lis": None})  # fmt: skip
    assert status == 303
    return code_of(headers, "/teacher#")


def desk(server) -> dict:
    status, said = call(server, "/api/lms", code="teacher-token", method="GET")
    assert status == 200, said
    return said


def test_a_300_student_roster_is_imported_and_the_class_table_shows_them_before_they_sign_in(tmp_path, platform):
    platform.enrol(300)
    server, store = open_class(tmp_path, platform)
    try:
        teacher_opens(server, platform)
        roster = until(lambda: desk(server)["roster"])
        assert roster["learners"] == 300 and roster["instructors"] == 1 and roster["clashes"] == []
        status, table = call(server, "/api/class", code="teacher-token", method="GET")
        rows = table["students"]
        assert len(rows) == 300 and rows[0]["id"] == "00000" and rows[299]["name"] == "Student 299"
        assert not any(row["signed_in"] for row in rows)  # shown before anyone signed in
        assert platform.asked_for.count("GET /courses/7/members") == 4  # 301 members, in pages of 100
        # a learner signs in as the student the roster made (no second row for them)
        status, headers, _ = launch(server, platform, sub="u-7", **{LTI + "lis": {"person_sourcedid": "00007"}})
        me = call(server, "/api/me", code=code_of(headers, "/#"), method="GET")[1]
        assert me["student"]["id"] == "00007"
        assert len(call(server, "/api/class", code="teacher-token", method="GET")[1]["students"]) == 300
        # a learner the LMS says left the course leaves the class table (their work is kept); a new one is in
        platform.members[3]["status"] = "Inactive"
        platform.members.append({"user_id": "u-900", "name": "Newcomer", "roles": [], "status": "Active"})
        assert call(server, "/api/lms/roster", code="teacher-token")[0] == 202
        until(lambda: desk(server)["roster"]["left"] == 1)
        ids = [row["id"] for row in call(server, "/api/class", code="teacher-token", method="GET")[1]["students"]]
        assert "00003" not in ids and "lms:u-900" in ids and len(ids) == 300
        assert desk(server)["instructors"] == ["Grace Hopper"]
        assert call(server, "/api/lms/roster", code="not-the-teacher")[0] == 401
    finally:
        server.stop()
        store.close()


def test_a_hand_in_s_mark_goes_to_one_line_item_with_its_feedback_and_a_restart_makes_no_second(tmp_path, platform):
    platform.enrol(3)
    server, store = open_class(tmp_path, platform, grader=None)  # the class's own grader: a real hand-in
    try:
        teacher_opens(server, platform)
        until(lambda: desk(server)["roster"])
        status, headers, _ = launch(server, platform, sub="u-1", **{LTI + "lis": {"person_sourcedid": "00001"}})
        code = code_of(headers, "/#")
        status, graded = call(server, "/api/handin", {"mission": SOLUTION}, code)
        assert status == 200 and graded["ok"], graded
        (score,) = until(platform.sent)
        assert score["userId"] == "u-1" and score["scoreGiven"] == graded["total"]
        assert score["scoreMaximum"] == GARAGE.max_points and score["gradingProgress"] == "FullyGraded"
        assert f"Feedback: {PUBLIC}{graded['page']}" in score["comment"]
        (item,) = platform.items.values()
        assert item["resourceId"] == "autonomy:garage" and item["scoreMaximum"] == GARAGE.max_points
        said = until(lambda: desk(server)["scores"]["sent"] == 1 and desk(server))
        assert said["scores"]["waiting"] == 0 and said["scores"]["last"][0]["id"] == "00001"
    finally:
        server.stop()
        store.close()
    # the class served again; its kept line item is used (and had it been lost, it is found again, not made)
    for lost in (False, True):
        if lost:
            kept = ClassStore(tmp_path)
            kept.set_setting(lms.LINEITEM_URL, "")
            kept.close()
        server, store = open_class(tmp_path, platform)
        try:
            store.add_work("00002", "handin", "mission", {}, 4.0, GARAGE.max_points)
            server._lms_mark("00002")
            until(lambda lost=lost: len(platform.sent()) == 2 + lost)
        finally:
            server.stop()
            store.close()
    assert len(platform.items) == 1 and platform.asked_for.count("POST /courses/7/lineitems") == 1


def test_300_scores_are_sent_each_once_and_an_lms_down_for_a_minute_gets_each_once_when_it_returns(tmp_path, platform):
    platform.enrol(300)
    server, store = open_class(tmp_path, platform)
    server.lms_link.stop()  # this test drives the link itself, in virtual time
    try:
        teacher_opens(server, platform)
        link = lms.LmsLink(store, lms.LmsServices(server.lti), "autonomy:garage", "Park", 10.0, VirtualClock())
        link.nudge(roster=True)
        link.round(0.0)
        assert len(store.students()) == 300
        for k in range(300):
            lms.queue_score(store, f"{k:05d}", k % 11, 10.0, f"hand-in of {k}")
        assert link.round(0.0) > 0 and len(platform.sent()) == 300  # all sent, then nothing more to do
        assert collections.Counter(s["userId"] for s in platform.sent()) == {f"u-{k}": 1 for k in range(300)}
        # the LMS goes down for a minute; the class marks everyone again meanwhile
        platform.down()
        for k in range(300):
            lms.queue_score(store, f"{k:05d}", (k + 1) % 11, 10.0, f"again {k}")
        tries, now_s = 0, 0.0
        while now_s < 60.0:
            wait_s = link.round(now_s)
            tries += 1
            assert "cannot be reached" in link.problem and len(lms.waiting(store)) == 300
            now_s += wait_s
        assert 5 <= tries <= 8  # tried again after 1, 2, 4, 8, 16, 30 s: not a flood
        platform.up()
        assert link.round(now_s) > 0 and link.problem == ""
        again = platform.sent()[300:]
        assert collections.Counter(s["userId"] for s in again) == {f"u-{k}": 1 for k in range(300)}
        assert all(s["scoreGiven"] == (int(s["userId"][2:]) + 1) % 11 for s in again)
        assert link.round(now_s + 1000) > 0 and len(platform.sent()) == 600  # and nothing sent twice
        assert lms.scores_said(store)["sent"] == 600 and lms.scores_said(store)["waiting"] == 0
    finally:
        server.stop()
        store.close()


def test_a_score_the_lms_refuses_is_kept_refused_and_what_is_the_link_s_fault_keeps_the_marks_waiting(
    tmp_path, platform
):
    platform.enrol(2)
    server, store = open_class(tmp_path, platform)
    server.lms_link.stop()
    try:
        teacher_opens(server, platform)
        link = lms.LmsLink(store, lms.LmsServices(server.lti), "autonomy:garage", "Park", 10.0, VirtualClock())
        link.nudge(roster=True)
        link.round(0.0)
        lms.take_roster(store, [lms.Member("u-gone", "Gone", "", False, True)])  # the LMS does not know them now
        assert lms.queue_score(store, "lms:u-gone", 5, 10, "x") and not lms.queue_score(store, "nobody", 5, 10, "x")
        link.round(0.0)
        said = lms.scores_said(store)
        assert said["refused"] == 1 and "422" in said["last"][0]["refused"] and said["waiting"] == 0
        asked = len(platform.asked_for)
        link.round(1000.0)
        assert len(platform.asked_for) == asked  # not sent again
        # the link's faults are not the marks': each waits, and is sent once the link is mended
        lms.queue_score(store, "00000", 7, 10, "y")
        for fault, said in ((lambda: setattr(platform, "moved", True), "(302"),
                            (lambda: setattr(platform, "broken_items", True), "not JSON")):  # fmt: skip
            platform.moved = platform.broken_items = False
            store.set_setting(lms.LINEITEM_URL, "")
            fault()
            link.round(2000.0)
            assert said in link.problem and lms.scores_said(store)["waiting"] == 1, link.problem
        platform.moved = platform.broken_items = False
        assert "/moved" not in [asked.split()[1] for asked in platform.asked_for]  # no redirect followed
        store.set_setting(lms.LINEITEM_URL, f"{platform.base}/courses/7/lineitems/99")  # the column deleted
        link.round(3000.0)
        assert lms.scores_said(store)["waiting"] == 1 and store.setting(lms.LINEITEM_URL) == ""
        link.round(4000.0)  # found or made anew
        assert [s["userId"] for s in platform.sent()] == ["u-0"] and lms.scores_said(store)["refused"] == 1
        assert link.send_again() == 1 and lms.scores_said(store)["waiting"] == 1  # the teacher's "send again"
    finally:
        server.stop()
        store.close()


def test_a_link_whose_round_fails_unforeseen_keeps_going_and_says_why(tmp_path, platform):
    server, store = open_class(tmp_path, platform)
    try:
        link = server.lms_link

        def broken(now_s: float) -> float:
            raise RuntimeError("a fault nobody foresaw")

        link.round, kept = broken, link.round
        link.nudge()
        until(lambda: "RuntimeError: a fault nobody foresaw" in link.problem)
        assert link._thread.is_alive()
        link.round = kept
    finally:
        server.stop()
        store.close()


def test_the_tool_s_assertion_is_checked_and_a_course_without_services_says_so(tmp_path, platform):
    server, store = open_class(tmp_path, platform)
    try:
        platform.tool_jwks_url = platform.jwks_url  # the LMS checks against other keys: the tool is not trusted
        teacher_opens(server, platform)
        said = until(lambda: desk(server)["problem"])
        assert "refused an access token (401" in said
        assert json.loads(store.setting(lms.COURSE))["id"] == COURSE
        # a mark meanwhile waits (the token is the link's fault, not the mark's), and goes once the LMS trusts the tool
        platform.enrol(1)
        lms.take_roster(store, [lms.Member("u-0", "Student 0", "00000", False, True)])
        store.add_work("00000", "handin", "mission", {}, 6.0, GARAGE.max_points)
        server._lms_mark("00000")
        until(lambda: desk(server)["scores"]["waiting"] == 1)
        assert desk(server)["scores"]["refused"] == 0
        platform.tool_jwks_url = f"{server.url}lti/jwks"
        assert call(server, "/api/lms/again", code="teacher-token")[0] == 200  # the desk's button tries again now
        until(lambda: len(platform.sent()) == 1)
    finally:
        server.stop()
        store.close()


def test_a_class_served_again_with_its_roster_file_keeps_the_lms_s_students(tmp_path, platform):
    store = ClassStore(tmp_path)
    store.enrol([("s1", "Bob")])
    lms.take_roster(store, [lms.Member("u-1", "Ada", "1001", False, True), lms.Member("u-2", "Cy", "", False, False)])
    assert [s.id for s in store.students()] == ["s1", "1001"]  # an inactive member is not on the roster
    store.enrol([("s1", "Bob")])  # class serve --roster, again: the LMS's students stay
    assert [s.id for s in store.students()] == ["s1", "1001"]
    assert lms.admit(store, "u-1", "9999", "Ada L.") == "1001"  # who they are stays what it was first
    with pytest.raises(lms.LaunchRefused):
        lms.admit(store, "u-3", "1001", "Mallory")
    store.close()


def test_the_mark_sent_and_shown_is_the_gradebook_s_though_a_hand_in_with_a_problem_came_after(tmp_path, platform):
    import csv
    import io

    platform.enrol(1)
    server, store = open_class(tmp_path, platform, grader=None)
    try:
        teacher_opens(server, platform)
        until(lambda: desk(server)["roster"])
        status, headers, _ = launch(server, platform, sub="u-0", **{LTI + "lis": {"person_sourcedid": "00000"}})
        code = code_of(headers, "/#")
        status, graded = call(server, "/api/handin", {"mission": SOLUTION}, code)
        assert status == 200 and graded["ok"], graded
        assert call(server, "/api/handin", {"mission": TYPO}, code)[0] == 422  # a hand-in with a problem, after
        (row,) = store.summary(["00000"])
        assert (row["total"], row["handins"]) == (graded["total"], 2) and "mvoe" in row["last_problem"]
        (line,) = csv.DictReader(io.StringIO(server._gradebook()))
        assert float(line["total"]) == graded["total"]  # the table's mark is the gradebook's
        (sent,) = until(platform.sent)
        assert sent["scoreGiven"] == graded["total"]
        store.add_work("00000", "handin", "x", {}, problem="line 1, column 1: no tree")  # another, kept as it was
        server._lms_mark("00000")  # as a robot's mark or a launch would: the same mark, not sent again, nor nothing
        assert lms.scores_said(store)["waiting"] == 0 and len(platform.sent()) == 1
    finally:
        server.stop()
        store.close()


def test_a_class_ends_at_once_though_the_lms_never_answers_and_its_mark_waits_for_the_next_start(tmp_path, platform):
    import socket
    import time

    platform.enrol(1)
    server, store = open_class(tmp_path, platform)
    silent = socket.socket()  # an LMS that takes the connection and never answers
    silent.bind(("127.0.0.1", 0))
    silent.listen(8)
    try:
        teacher_opens(server, platform)
        until(lambda: desk(server)["roster"])
        store.set_setting(lms.LINEITEM_URL, f"http://127.0.0.1:{silent.getsockname()[1]}/lineitems/1")
        store.add_work("00000", "handin", "mission", {}, 6.0, GARAGE.max_points)
        server._lms_mark("00000")
        time.sleep(0.5)  # its score is being sent, and no answer comes
        started = time.monotonic()
        server.stop()
        assert time.monotonic() - started < lms.STOP_WAIT_S + 2.0
        assert len(lms.waiting(store)) == 1  # not lost: sent at the next start
    finally:
        silent.close()
        store.close()

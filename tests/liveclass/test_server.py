"""The class's API, served on loopback: a student checks, runs and hands in; the teacher sees the class.

Each safety rule is tried as an attack that fails: a wrong code, guessing, another's work, a huge body,
running too often, a hand-in after the deadline.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import os
import re
import socket
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
import zipfile

import pytest

from autonomy.classroom.exercise import load_exercise
from autonomy.clock import VirtualClock
from autonomy.liveclass.server import (
    CLASS_WAITERS,
    DEADLINE,
    MAX_PAGE_BYTES,
    QUICK_GRADING_CPU_S,
    RUN_PAGES_KEPT,
    RUNS_PER_MINUTE,
    TEACHER_TOKEN,
    ClassServer,
)
from autonomy.liveclass.store import ClassStore, token_digest
from autonomy.liveclass.work import MAX_NODES, page_file, work_file
from autonomy.views.web import address_group
from tests.crowd import memory_mb, non_readers
from tests.views.conftest import ROOT

GARAGE = load_exercise(ROOT / "exercises" / "garage.yaml").with_secret(b"the teacher's secret")
SOLUTION = (ROOT / "exercises" / "solutions" / "garage.yaml").read_text()
TYPO = "mission: park\ntree:\n  sequence:\n    - mvoe: {speed: 2, seconds: 1}\n"


@pytest.fixture
def served(tmp_path):
    store = ClassStore(tmp_path)
    codes = store.enrol([("s1", "Ada"), ("s2", "Bob")])
    store.set_setting(TEACHER_TOKEN, token_digest("teacher-token"))
    server = ClassServer(GARAGE, store, tmp_path, port=0)
    server.start()
    yield server, codes
    server.stop()
    store.close()


def call(server, path: str, body: object = None, code: str = "", method: str = "POST") -> tuple[int, dict]:
    data = body if isinstance(body, bytes) else json.dumps(body).encode() if body is not None else None
    request = urllib.request.Request(server.url + path.lstrip("/"), data=data, method=method)
    request.add_header("Content-Type", "application/json")
    if code:
        request.add_header("Authorization", f"Bearer {code}")
    try:
        with urllib.request.urlopen(request, timeout=60) as answer:
            return answer.status, json.loads(answer.read())
    except urllib.error.HTTPError as refused:
        text = refused.read()
        return refused.code, json.loads(text) if text.startswith(b"{") else {"text": text.decode()}


def test_a_student_checks_runs_and_hands_in_and_the_teacher_sees_it(served):
    server, codes = served
    status, checked = call(server, "/api/check", {"mission": TYPO}, codes["s1"])
    assert (
        status == 200
        and not checked["ok"]
        and (checked["problems"][0]["line"], checked["problems"][0]["column"]) == (4, 7)
    )
    status, fixed = call(server, "/api/check", {"mission": SOLUTION}, codes["s1"])
    assert status == 200 and fixed["ok"] and fixed["tree_svg"].startswith("<svg")
    status, run = call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])
    assert status == 200 and run["kind"] == "run" and run["total"] == run["max_points"] == GARAGE.max_points
    assert [s["seed"] for s in run["seeds"]] == [s.label for s in GARAGE.seeds if not s.hidden]  # public seeds
    status, handin = call(server, "/api/handin", {"mission": SOLUTION}, codes["s1"])
    assert status == 200 and len(handin["seeds"]) == len(GARAGE.seeds)
    assert all(not s["seed"].startswith("seed ") for s in handin["seeds"][4:])  # hidden seeds never by number
    assert str(GARAGE.seeds[-1].seed) not in json.dumps(handin)
    status, table = call(server, "/api/class", code="teacher-token", method="GET")
    ada, bob = table["students"]
    assert status == 200 and (ada["runs"], ada["handins"], ada["total"]) == (1, 1, GARAGE.max_points)
    assert (bob["runs"], bob["handins"]) == (0, 0)
    assert [w.kind for w in server.store.works("s1")] == ["run", "handin"]


def test_the_teacher_s_token_on_a_student_s_route_is_told_so_and_costs_the_address_nothing(served):
    server, codes = served
    for _ in range(3):  # the teacher trying a student's page from the desk, behind the class's router
        status, refused = call(server, "/api/check", {"mission": TYPO}, "teacher-token")
        assert status == 403 and "signs in as no student" in refused["error"]
    assert call(server, "/api/check", {"mission": TYPO}, codes["s1"])[0] == 200  # no wait: it was no guess
    assert call(server, "/api/me", code="teacher-token", method="GET")[0] == 200  # the exercise, to the teacher


def test_a_wrong_code_is_refused_and_the_next_try_from_there_waits_longer_each_time(served):
    server, codes = served
    server._clock = clock = VirtualClock(1000.0)  # the server's time, moved by the test
    status, refused = call(server, "/api/check", {"mission": TYPO}, "aaaaaaaa")
    assert status == 401 and "sign-in code" in refused["error"]
    for wait_s in (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 8.0):  # each wrong code: the next try waits twice as long
        clock.advance_to(clock.now() + wait_s - 0.01)
        status, refused = call(server, "/api/check", {"mission": TYPO}, codes["s2"])  # even a right one
        assert status == 429 and "try again in" in refused["error"] and refused["retry_after_s"] >= 1
        clock.advance_to(clock.now() + 0.02)
        assert call(server, "/api/check", {"mission": TYPO}, "bbbbbbbb")[0] == 401
    clock.advance_to(clock.now() + 8.0)
    assert call(server, "/api/check", {"mission": TYPO}, codes["s2"])[0] == 200
    assert call(server, "/api/check", {"mission": TYPO}, "")[0] == 401
    assert call(server, "/api/class", code=codes["s1"], method="GET")[0] == 401  # a student's code is not the teacher's
    assert call(server, "/api/class", code="teacher-tokem", method="GET")[0] == 401


def test_a_student_signed_in_from_an_address_is_not_held_back_by_another_s_wrong_codes_from_there(served):
    server, codes = served
    server._clock = VirtualClock(1000.0)
    assert call(server, "/api/check", {"mission": TYPO}, codes["s1"])[0] == 200  # Ada signs in, behind the router
    for _ in range(5):
        call(server, "/api/check", {"mission": TYPO}, "wrongcode")  # Bob mistypes his, again and again
    assert call(server, "/api/check", {"mission": TYPO}, codes["s1"])[0] == 200  # Ada goes on
    assert call(server, "/api/check", {"mission": TYPO}, codes["s2"])[0] == 429  # Bob waits his turn
    assert call(server, "/api/check", {"mission": TYPO}, f" {codes['s1'][:4]} {codes['s1'][4:].upper()}")[0] == 200


def test_a_body_over_a_megabyte_is_refused_and_a_body_not_json_is_told_what_to_send(served):
    server, codes = served
    status, refused = call(server, "/api/check", {"mission": "#" * 1_100_000}, codes["s1"])
    assert status == 413 and "1,048,576 bytes" in refused["error"]
    status, refused = call(server, "/api/check", b"not json", codes["s1"])
    assert status == 400 and '{"mission"' in refused["error"]


def test_runs_past_the_minute_s_share_are_refused_with_when_to_run_again_and_checks_never_are(served):
    server, codes = served
    for _ in range(RUNS_PER_MINUTE):
        assert call(server, "/api/run", {"mission": TYPO}, codes["s2"])[0] == 422  # a run with a problem counts
    status, refused = call(server, "/api/run", {"mission": SOLUTION}, codes["s2"])
    assert status == 429 and 50 <= refused["retry_after_s"] <= 61 and "run again in" in refused["error"]
    assert call(server, "/api/run", {"mission": TYPO}, codes["s1"])[0] == 422  # another student runs on
    assert call(server, "/api/check", {"mission": TYPO}, codes["s2"])[0] == 200
    assert server.store.summary()[1]["last_problem"].startswith("line 4, column 7: ")


def test_a_hand_in_after_the_deadline_is_refused_and_not_kept(served):
    server, codes = served
    server.store.set_setting(DEADLINE, str(time.time() - 1))
    status, refused = call(server, "/api/handin", {"mission": SOLUTION}, codes["s1"])
    assert status == 403 and "closed" in refused["error"]
    assert server.store.works("s1") == []


def test_a_request_that_cannot_be_kept_is_refused_and_the_next_student_s_hand_in_is_kept(served):
    """A lone surrogate left a transaction open, and the next student's hand-in failed with a 500."""
    server, codes = served
    status, refused = call(server, "/api/handin", b'{"mission": "tree: beep\\ud800"}', codes["s2"])
    assert status == 400 and "not text" in refused["error"]
    status, deep = call(server, "/api/check", b"[" * 100_000 + b"]" * 100_000, codes["s2"])
    assert status == 400  # nested deeper than a reader goes: told what to send, no 500
    status, kept = call(server, "/api/handin", {"mission": SOLUTION}, codes["s1"])
    assert status == 200 and kept["total"] == GARAGE.max_points


def test_one_request_at_a_time_per_student_hand_ins_a_minute_and_what_is_kept_of_a_refused_text(served):
    from autonomy.liveclass.server import HANDINS_PER_MINUTE
    from autonomy.liveclass.work import MAX_MISSION_CHARS

    server, codes = served
    server._busy.add("s1")  # noqa: SLF001 - as while a run of Ada's is graded
    for route in ("/api/check", "/api/run", "/api/handin"):
        status, refused = call(server, route, {"mission": SOLUTION}, codes["s1"])
        assert status == 429 and "still under way" in refused["error"]
    assert call(server, "/api/check", {"mission": TYPO}, codes["s2"])[0] == 200  # Bob is not held up
    server._busy.discard("s1")  # noqa: SLF001
    assert call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])[0] == 200
    for _ in range(HANDINS_PER_MINUTE):
        assert call(server, "/api/handin", {"mission": TYPO}, codes["s2"])[0] == 422
    status, refused = call(server, "/api/handin", {"mission": TYPO}, codes["s2"])
    assert status == 429 and "hand in again in" in refused["error"]
    long_typo = TYPO + "#" * 200_000
    call(server, "/api/run", {"mission": long_typo}, codes["s1"])
    assert len(server.store.works("s1")[-1].source) == MAX_MISSION_CHARS  # kept, cut to what a mission may be


def test_a_student_is_signed_in_by_their_first_request_and_the_class_is_the_teacher_s_alone_on_disk(served):
    import stat

    server, codes = served
    assert [s["signed_in"] for s in server.store.summary()] == ["", ""]
    call(server, "/api/check", {"mission": TYPO}, codes["s2"])
    ada, bob = server.store.summary()
    assert ada["signed_in"] == "" and bob["signed_in"] != ""
    assert stat.S_IMODE(server.folder.stat().st_mode) == 0o700
    assert stat.S_IMODE((server.folder / "class.sqlite").stat().st_mode) == 0o600


def test_guesses_sent_side_by_side_are_refused_at_once_unchecked_and_hold_no_connection(served):
    from concurrent.futures import ThreadPoolExecutor

    server, codes = served
    server._clock = VirtualClock(1000.0)  # the server's time stands still: the first wrong code's wait never ends
    started = time.monotonic()
    guesses = [f"wrong{k:03d}" for k in range(200)] + [codes["s1"]]  # a right one among them
    with ThreadPoolExecutor(16) as pool:
        statuses = list(pool.map(lambda code: call(server, "/api/check", {"mission": TYPO}, code)[0], guesses))
    assert time.monotonic() - started < 30  # none of them waited
    assert statuses.count(401) == 1 and statuses[-1] == 429  # one checked, the rest (the right one too) unchecked
    assert server._guesses and server._known == {}


def fetch(server, path: str, token: str = "") -> tuple[int, dict[str, str], bytes]:
    request = urllib.request.Request(server.url + path.lstrip("/"))
    if token:
        request.add_header("Authorization", f"Bearer {token}")
    try:
        with urllib.request.urlopen(request, timeout=60) as answer:
            return answer.status, dict(answer.headers), answer.read()
    except urllib.error.HTTPError as refused:
        return refused.code, dict(refused.headers), refused.read()


def test_a_feedback_page_is_served_to_who_has_its_address_alone_in_a_sandbox(served):
    server, codes = served
    status, ran = call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])
    assert status == 200 and re.fullmatch(rf"/pages/{ran['number']}-[0-9a-f]{{32}}\.html", ran["page"])
    status, headers, page = fetch(server, ran["page"])
    assert status == 200 and b"<iframe" in page
    assert "sandbox allow-scripts" in headers["Content-Security-Policy"]  # its own origin: it reaches no API
    assert "frame-ancestors 'self'" in headers["Content-Security-Policy"]
    number, key = ran["page"][len("/pages/") : -len(".html")].split("-")
    forged = [
        f"/pages/{number}-{'0' * 32}.html",  # a guessed key
        f"/pages/{int(number) + 1}-{key}.html",  # the key of one work, for another's
        f"/pages/{number}-{key.upper()}.html",
        f"/pages/{number}-{key}.html/../x",
        "/pages/..%2Fclass.sqlite",
        f"/pages/{number}-{key}",
    ]
    for path in forged:
        assert fetch(server, path)[0] == 404, path
    _, handed = call(server, "/api/handin", {"mission": SOLUTION}, codes["s1"])
    status, mine = call(server, "/api/me", code=codes["s1"], method="GET")
    assert [work["page"] for work in mine["works"]] == [handed["page"]]  # their hand-ins' (runs are not listed)
    status, theirs = call(server, "/api/me", code=codes["s2"], method="GET")
    assert status == 200 and theirs["works"] == [] and theirs["student"] == {"id": "s2", "name": "Bob"}


def test_what_a_student_is_shown_of_the_exercise_names_no_hidden_seed(served):
    server, codes = served
    status, me = call(server, "/api/me", code=codes["s1"], method="GET")
    exercise = me["exercise"]
    assert status == 200 and exercise["public_seeds"] == 4 and exercise["hidden_seeds"] == 12
    assert exercise["world_svg"].startswith("<svg") and me["mission"] == ""
    assert {"sequence", "move", "obstacle_within"} <= {node["name"] for node in exercise["nodes"]}
    text = json.dumps(me)
    hidden = [seed for seed in GARAGE.seeds if seed.hidden]
    assert len(hidden) == 12 and not any(re.search(rf"\b{seed.seed}\b", text) for seed in hidden)
    assert call(server, "/api/me", code="not-a-code", method="GET")[0] == 401


def test_the_teacher_s_routes_refuse_a_student_s_code_and_a_forged_token(served):
    server, codes = served
    for token in (codes["s1"], "Teacher-Token", "teacher-toke", "teacher-token\u00e9", ""):
        for path in ("/api/export/grades.csv", "/api/export/feedback.zip", "/api/class?after=0"):
            assert fetch(server, path, token)[0] == 401, (path, token)
        assert call(server, "/api/deadline", {"deadline_s": None}, token)[0] == 401
    assert fetch(server, "/api/export/autograder.zip", "teacher-token")[0] == 404  # not offered by this server
    assert fetch(server, "/api/export/class.sqlite", "teacher-token")[0] == 404


def test_the_deadline_is_set_closed_now_and_lifted_and_a_bad_one_is_refused(served):
    server, codes = served
    for body in ({"deadline_s": "tomorrow"}, {"deadline_s": True}, {}, [1], b"{\"deadline_s\": NaN}",
                 b"{\"deadline_s\": Infinity}", b"not json"):  # fmt: skip
        status, said = call(server, "/api/deadline", body, "teacher-token")
        assert status == 400 and "deadline_s" in said["error"], body
    status, said = call(server, "/api/deadline", {"deadline_s": "now"}, "teacher-token")
    assert status == 200 and abs(said["deadline_s"] - time.time()) < 60
    assert call(server, "/api/handin", {"mission": SOLUTION}, codes["s1"])[0] == 403
    assert call(server, "/api/deadline", {"deadline_s": None}, "teacher-token") == (200, {"deadline_s": None})
    assert call(server, "/api/handin", {"mission": SOLUTION}, codes["s1"])[0] == 200


def test_the_teacher_s_table_waits_for_a_change_and_at_most_so_many_pages_wait(served):
    server, codes = served
    _, first = call(server, "/api/class", code="teacher-token", method="GET")
    answers: list[tuple[int, dict]] = []
    waiting = [
        threading.Thread(
            target=lambda: answers.append(
                call(server, f"/api/class?after={first['version']}", code="teacher-token", method="GET")
            )
        )  # fmt: skip
        for _ in range(CLASS_WAITERS)
    ]
    for thread in waiting:
        thread.start()
    deadline = time.monotonic() + 30
    while server._class_waiters < CLASS_WAITERS and time.monotonic() < deadline:  # every one waits
        time.sleep(0.05)
    assert answers == [] and server._class_waiters == CLASS_WAITERS
    status, said = call(server, f"/api/class?after={first['version']}", code="teacher-token", method="GET")
    assert status == 429 and str(CLASS_WAITERS) in said["error"]
    assert call(server, "/api/check", {"mission": SOLUTION}, codes["s2"])[0] == 200  # Bob signs in: a change
    for thread in waiting:
        thread.join(timeout=30)
    assert len(answers) == CLASS_WAITERS
    assert all(status == 200 and said["version"] > first["version"] for status, said in answers)
    bob = answers[0][1]["students"][1]
    assert bob["id"] == "s2" and bob["signed_in"]


def test_the_class_at_a_glance_is_each_student_s_latest_graded_work_made_once_a_version(served):
    server, codes = served
    made: list[int] = []
    making = server._overview_now
    server._overview_now = lambda version: (made.append(version), making(version))[1]
    crash = "mission: crash\ntree:\n  move: {speed: 4, until_obstacle_mm: 60}\n"
    assert call(server, "/api/run", {"mission": crash}, codes["s1"])[1]["total"] < 5
    status, run = call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])  # Ada's latest: full marks
    assert status == 200 and run["total"] == 10
    call(server, "/api/check", {"mission": TYPO}, codes["s2"])  # Bob signed in, nothing graded
    assert call(server, "/api/overview", code=codes["s1"], method="GET")[0] == 401  # the teacher's alone
    answers: list[tuple[int, dict]] = []
    asking = [
        threading.Thread(
            target=lambda: answers.append(call(server, "/api/overview", code="teacher-token", method="GET"))
        )
        for _ in range(8)
    ]  # the desk and the projector, asking again and again while the class stands still
    for thread in asking:
        thread.start()
    for thread in asking:
        thread.join(timeout=60)
    assert len(answers) == 8 and all(answer == answers[0] for answer in answers)
    assert made == [server._version]  # made once for that version, however many asked
    status, seen = answers[0]
    assert status == 200 and seen["version"] == server._version
    assert (seen["students"], seen["graded"], seen["median"]) == (2, 1, 10)
    ada, bob = seen["maps"]
    assert (ada["student"], ada["outcome"], ada["mark"]) == ("Ada", "full", "10 / 10")
    assert ada["link"] == f"{run['page'].split('#')[0]}#seed-1"  # a click opens her latest run's page at that seed
    assert (bob["student"], bob["outcome"], bob["why"], bob["link"]) == ("Bob", "notgraded", "no graded run yet", None)
    assert seen["nodes"] == []  # her latest lost nothing: her first run's crash is not counted
    call(server, "/api/run", {"mission": crash}, codes["s2"])  # Bob crashes: a new version
    status, seen = call(server, "/api/overview", code="teacher-token", method="GET")
    assert len(made) == 2 and seen["graded"] == 2 and seen["maps"][1]["outcome"] in ("part", "none")
    assert seen["nodes"][0]["node"] == "move" and seen["nodes"][0]["students"] == 1
    assert seen["maps"][1]["collisions"] and seen["worlds"][seen["maps"][1]["world"]]["arena_mm"] == [3000, 1200]


def test_the_class_table_reads_again_the_rows_of_the_students_who_changed_alone(served):
    server, codes = served
    read: list[object] = []
    summary = server.store.summary
    server.store.summary = lambda students=None: (read.append(students and sorted(students)), summary(students))[1]
    status, first = call(server, "/api/class", code="teacher-token", method="GET")
    assert status == 200 and read == [None]  # the first table reads every row
    assert call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])[0] == 200  # Ada signs in and runs
    status, table = call(server, "/api/class", code="teacher-token", method="GET")
    assert read == [None, ["s1"]] and table["version"] > first["version"]  # her row alone is read again
    ada, bob = table["students"]
    assert (ada["id"], ada["runs"], ada["signed_in"] != "", ada["latest_page"] is not None) == ("s1", 1, True, True)
    assert (bob["id"], bob["runs"], bob["signed_in"]) == ("s2", 0, "")
    assert call(server, "/api/class", code="teacher-token", method="GET")[1] == {**table, "now_s": ANY_NUMBER}
    assert read == [None, ["s1"]]  # nothing changed: nothing read
    assert call(server, "/api/deadline", {"deadline_s": None}, "teacher-token")[0] == 200  # any row may change
    call(server, "/api/class", code="teacher-token", method="GET")
    assert read[-1] is None


class _AnyNumber:
    def __eq__(self, other: object) -> bool:
        return isinstance(other, float)


ANY_NUMBER = _AnyNumber()


def test_the_class_at_a_glance_is_made_at_most_every_few_seconds_and_shows_the_class_as_it_is_then(served, monkeypatch):
    import autonomy.liveclass.server as server_module

    monkeypatch.setattr(server_module, "OVERVIEW_EVERY_S", 1.0)
    server, codes = served
    made: list[int] = []
    making = server._overview_now
    server._overview_now = lambda version: (made.append(version), making(version))[1]
    asked_s = time.monotonic()  # before the first making: the second starts a second after it, at the soonest
    assert call(server, "/api/overview", code="teacher-token", method="GET")[1]["graded"] == 0
    assert call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])[0] == 200  # a change, and another
    assert call(server, "/api/run", {"mission": SOLUTION}, codes["s2"])[0] == 200
    status, seen = call(server, "/api/overview", code="teacher-token", method="GET")
    assert status == 200 and seen["graded"] == 2 and seen["version"] == server._version  # not an older making
    assert len(made) == 2 and time.monotonic() - asked_s >= 1.0  # the second waited for its turn: both changes in it


def test_the_exports_hold_each_student_s_last_hand_in(served):
    server, codes = served
    call(server, "/api/handin", {"mission": TYPO.replace("mvoe", "move")}, codes["s1"])
    status, handed = call(server, "/api/handin", {"mission": SOLUTION}, codes["s1"])
    assert status == 200 and handed["total"] == 10
    status, headers, body = fetch(server, "/api/export/grades.csv", "teacher-token")
    assert status == 200 and headers["Content-Disposition"] == 'attachment; filename="garage-grades.csv"'
    rows = list(csv.DictReader(io.StringIO(body.decode())))
    assert [(row["id"], row["name"], row["total"], row["problems"]) for row in rows] == [
        ("s1", "Ada", "10", ""),
        ("s2", "Bob", "0", "no submission"),
    ]
    status, _, body = fetch(server, "/api/export/feedback.zip", "teacher-token")
    archive = zipfile.ZipFile(io.BytesIO(body))
    assert archive.namelist() == ["s1.html"]
    assert archive.read("s1.html") == fetch(server, handed["page"])[2]


def test_clients_that_never_read_a_big_page_hold_a_piece_of_it_not_the_page(served):
    server, codes = served
    status, ran = call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])
    page = page_file(server.folder, "s1", ran["number"])
    page.write_bytes(b"<!doctype html>" + b"x" * (MAX_PAGE_BYTES - 100))  # as large as a page is kept
    before_mb = memory_mb(os.getpid())["VmRSS"]
    crowd = non_readers(server.port, 30, requests=3, path=ran["page"])
    try:
        time.sleep(1.0)
        grown_mb = memory_mb(os.getpid())["VmRSS"] - before_mb
        assert grown_mb < 60, grown_mb  # read whole, the 30 answers would hold 240 MB
    finally:
        for conn in crowd:
            conn.close()
    assert fetch(server, ran["page"])[0] == 200  # and the page is served on


def test_a_page_too_large_is_not_kept_and_a_student_s_older_run_pages_go(served, monkeypatch):
    server, codes = served
    graded = server._grader

    def huge_page(*args, **kwargs):
        report, page = graded(*args, **kwargs)
        if args[4] == 3:  # the third work: its page grows past the most kept
            page.write_bytes(b"x" * (MAX_PAGE_BYTES + 1))
        return report, page

    server._grader = huge_page
    answers = [call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])[1] for _ in range(RUN_PAGES_KEPT + 3)]
    assert answers[2]["page"] is None and "too large to keep" in answers[2]["page_problem"]
    assert answers[2]["total"] == 10  # the marks stand
    pages = sorted(path.name for path in (server.folder / "pages").iterdir())
    assert pages == sorted(page_file(server.folder, "s1", a["number"]).name for a in answers[-RUN_PAGES_KEPT:])
    kept = [page_file(server.folder, "s1", answer["number"]).is_file() for answer in answers]
    assert kept == [False] * 3 + [True] * RUN_PAGES_KEPT


def test_a_student_s_pages_are_kept_within_their_bytes_and_old_runs_keep_their_marks_alone(served, monkeypatch):
    import autonomy.liveclass.server as server_module

    server, codes = served
    _, first = call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])
    size = page_file(server.folder, "s1", first["number"]).stat().st_size
    monkeypatch.setattr(server_module, "RUN_PAGE_BYTES_KEPT", int(2.5 * size))  # room for two of them, not five
    monkeypatch.setattr(server_module, "RUN_RESULTS_KEPT", 3)
    numbers = [first["number"]] + [
        call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])[1]["number"] for _ in range(5)
    ]
    kept = [page_file(server.folder, "s1", n).is_file() for n in numbers]
    assert kept == [False] * 4 + [True] * 2  # the newest first, within the bytes
    works = [server.store.work(n) for n in numbers]
    assert [bool(w.result) for w in works] == [False] * 3 + [True] * 3  # the last runs' results alone
    assert all(w.total == 10 and w.problem == "" for w in works)  # the older keep their marks
    assert server.store.summary(["s1"])[0]["runs"] == 6  # and are counted


def test_a_result_too_large_to_keep_loses_its_maps_and_keeps_its_marks():
    from autonomy.liveclass.server import MAX_RESULT_BYTES, _bounded

    seed = {"seed": 1, "shares": [1.0], "path": [[0.0, 0.0]] * 20_000, "collisions": [], "beeps": [], "turns": []}
    result = {"total": 7.5, "max_points": 10, "marks": [7.5], "problems": [], "seeds": [seed] * 3}
    kept = _bounded(result)
    assert len(json.dumps(kept)) <= MAX_RESULT_BYTES < len(json.dumps(result))
    assert (kept["total"], kept["marks"]) == (7.5, [7.5]) and kept["seeds"][0] == {**seed, "path": []}
    assert _bounded({**result, "seeds": [seed]}) == {**result, "seeds": [{**seed, "path": []}]}
    small = {**result, "seeds": [{**seed, "path": [[1.0, 2.0]]}]}
    assert _bounded(small) is small  # within the bound: kept whole


def test_a_student_hands_in_so_many_times_an_hour_and_is_told_when_again(served, monkeypatch):
    import autonomy.liveclass.server as server_module

    server, codes = served
    monkeypatch.setattr(server_module, "HANDINS_PER_HOUR", 2)
    assert [call(server, "/api/handin", {"mission": SOLUTION}, codes["s1"])[0] for _ in range(2)] == [200, 200]
    status, said = call(server, "/api/handin", {"mission": SOLUTION}, codes["s1"])
    assert status == 429 and said["error"].startswith("2 hand-ins an hour at most: you can hand in again in 60 min")
    assert call(server, "/api/handin", {"mission": SOLUTION}, codes["s2"])[0] == 200  # another's are their own


def test_the_disk_a_lesson_may_take_is_said_from_the_bounds_it_is_kept_within():
    from autonomy.liveclass import server as bounds

    at_once, hourly, lesson = bounds.disk_bound(300, 2.0)
    pages = bounds.RUN_PAGE_BYTES_KEPT + bounds.HANDIN_PAGE_BYTES_KEPT + 2 * bounds.MAX_PAGE_BYTES
    assert at_once >= pages + bounds.RUN_TEXTS_KEPT * bounds.MAX_TEXT_BYTES
    assert hourly >= bounds.HANDINS_PER_HOUR * (2 * bounds.MAX_TEXT_BYTES + bounds.MAX_RESULT_BYTES)
    assert lesson == 300 * (at_once + 2 * hourly) + bounds.WAL_BYTES
    said = bounds.disk_said(300)
    assert said.startswith(f"disk: at most {lesson / 2**30:.1f} GB for a 2-hour lesson of 300 students")
    assert "\n" not in said


def costing(graded, cpu_s: float, wall_s: float = 0.0, clock: VirtualClock | None = None):
    """The grader ``graded``, its gradings said to have taken ``cpu_s`` of CPU time and ``wall_s`` on ``clock``."""

    def grader(*args, **kwargs):
        if clock is not None:
            clock.advance_to(clock.now() + wall_s)
        report, page = graded(*args, **kwargs)
        return dataclasses.replace(report, cpu_s=cpu_s), page

    return grader


def test_a_student_whose_grading_took_long_waits_as_long_before_the_next(served):
    server, codes = served
    server._clock = clock = VirtualClock(1000.0)
    graded = server._grader
    server._grader = costing(graded, cpu_s=30.0)  # a mission that spins until its CPU time is up
    assert call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])[0] == 200
    status, held = call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])
    assert status == 429 and "took long" in held["error"] and held["retry_after_s"] == 30
    assert call(server, "/api/handin", {"mission": SOLUTION}, codes["s1"])[0] == 429
    assert call(server, "/api/check", {"mission": SOLUTION}, codes["s1"])[0] == 200  # checks are not held
    clock.advance_to(clock.now() + 30.0)
    server._grader = graded
    assert call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])[0] == 200


def test_a_grading_that_took_long_in_wall_time_alone_holds_no_one_back(served):
    """A busy machine stretches every grading's wall time: a student whose grading used little CPU goes on."""
    server, codes = served
    server._clock = clock = VirtualClock(1000.0)
    server._grader = costing(server._grader, cpu_s=0.2, wall_s=60.0, clock=clock)
    for path in ("/api/run", "/api/handin", "/api/run"):
        status, answer = call(server, path, {"mission": SOLUTION}, codes["s1"])
        assert status == 200 and answer["total"] == 10, answer
    assert server._long == {}


def test_real_gradings_on_a_machine_two_busy_processes_load_are_told_by_their_cpu_time(served):
    server, codes = served
    graded = server._grader
    took = []

    def grader(*args, **kwargs):
        report, page = graded(*args, **kwargs)
        took.append(report.cpu_s)
        return report, page

    server._grader = grader
    spin = "import os\nos.nice(-5) if os.geteuid() == 0 else None\nwhile True: pass"
    busy = [subprocess.Popen([sys.executable, "-c", spin]) for _ in range(2)]  # both cores taken
    try:
        answers = [call(server, path, {"mission": SOLUTION}, codes["s1"]) for path in ("/api/run", "/api/handin")]
        answers += [call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])]
    finally:
        for process in busy:
            process.kill()
            process.wait()
    assert [(status, answer["total"]) for status, answer in answers] == [(200, 10)] * 3
    assert len(took) == 3 and all(0.0 < cpu_s < 5.0 for cpu_s in took), took  # counted in the worker
    assert server._long == {}  # no one held back, whatever the wall time was
    assert "cpu_s" not in json.dumps(server.store.works("s1")[0].result)  # never kept


def test_a_mission_of_too_many_nodes_is_refused_where_it_starts(served):
    server, codes = served
    many = "mission: m\ntree:\n  sequence:\n" + "    - wait: {seconds: 1}\n" * MAX_NODES
    status, checked = call(server, "/api/check", {"mission": many}, codes["s1"])
    assert status == 200 and not checked["ok"] and checked["tree_svg"] == ""
    assert checked["problems"][0]["line"] == 1 and f"at most {MAX_NODES}" in checked["problems"][0]["message"]
    assert call(server, "/api/run", {"mission": many}, codes["s1"])[0] == 422


def test_guesses_are_counted_by_address_and_an_ipv6_machine_by_its_network():
    assert address_group("127.0.0.1") == "127.0.0.1"
    assert address_group("2001:db8::1") == address_group("2001:db8::ffff:1234") == "2001:db8::/64"
    assert address_group("2001:db8:0:1::1") != address_group("2001:db8::1")
    assert address_group("::ffff:192.0.2.7") == "192.0.2.7"


def test_the_pages_have_a_strict_policy_and_another_site_s_page_or_name_is_refused(served):
    server, codes = served
    for path in ("/", "/teacher", "/static/class.js"):
        status, headers, _ = fetch(server, path)
        policy = headers["Content-Security-Policy"]
        # style attributes alone may be inline (Blockly writes one); no script, no <style> element, no eval
        allowed = policy.replace("style-src-attr 'unsafe-inline'", "")
        assert status == 200 and "script-src 'self'" in policy and "unsafe" not in allowed, path
        assert "frame-ancestors 'none'" in policy and headers["X-Content-Type-Options"] == "nosniff"
    assert fetch(server, "/static/student.html")[0] == 404 and fetch(server, "/static/../store.py")[0] == 404
    for header, value in (("Origin", "http://evil.example"), ("Host", "evil.example"), ("Origin", "null")):
        request = urllib.request.Request(
            server.url + "api/check", data=json.dumps({"mission": SOLUTION}).encode(), method="POST"
        )
        request.add_header("Authorization", f"Bearer {codes['s1']}")
        request.add_header(header, value)
        try:
            urllib.request.urlopen(request, timeout=30)
            raise AssertionError(f"{header}: {value} was served")
        except urllib.error.HTTPError as refused:
            assert refused.code == 403, (header, value)


def test_the_pages_scripts_put_what_they_receive_in_as_text_never_as_markup():
    from autonomy.liveclass.server import PAGE_FILES, page_text

    for name in PAGE_FILES:
        if name.endswith(".js"):
            text = page_text(name)
            for sink in ("innerHTML", "outerHTML", "insertAdjacentHTML", "document.write", "eval(", "srcdoc"):
                assert sink not in text, (name, sink)
            # blocks.js and text.js hand what they get to Blockly and CodeMirror; contrast.js gets nothing
            assert "textContent" in text or name in ("blocks.js", "text.js", "contrast.js")


def test_a_long_history_is_listed_without_its_texts(served):
    server, codes = served
    store = server.store
    for number in range(300):  # an hour of runs, each a long text
        store.add_work("s1", "run", f"# {number}\n" + "#" * 90_000, {}, 5.0, 10.0)
    status, headers, body = fetch(server, "/api/me", codes["s1"])
    me = json.loads(body)
    assert status == 200 and headers["Cache-Control"] == "no-store"
    assert len(body) < 150_000 and me["mission"].startswith("# 299\n")  # the last text alone
    assert me["works"] == []  # runs are not listed: their hand-ins alone are (below)


def test_one_address_gets_its_share_of_the_pages_on_their_way_and_another_is_served(served):
    server, codes = served
    server.max_pages_per_address = 3
    status, ran = call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])
    page_file(server.folder, "s1", ran["number"]).write_bytes(b"<!doctype html>" + b"x" * (MAX_PAGE_BYTES - 100))
    crowd = non_readers(server.port, 6, requests=1, path=ran["page"])
    try:
        time.sleep(0.5)
        answers = sorted(conn.recv(64).split(b"\r\n")[0] for conn in crowd)
        assert answers == [b"HTTP/1.1 200 OK"] * 3 + [b"HTTP/1.1 503 Service Unavailable"] * 3
        other = socket.create_connection(("127.0.0.1", server.port), source_address=("127.0.0.2", 0))
        with other:
            other.sendall(f"GET {ran['page']} HTTP/1.1\r\nHost: 127.0.0.1:{server.port}\r\n\r\n".encode())
            assert other.recv(64).startswith(b"HTTP/1.1 200 OK")  # another machine is served
    finally:
        for conn in crowd:
            conn.close()


def test_slow_readers_of_pages_from_five_addresses_hold_the_pages_share_and_every_check_is_answered(served):
    """Slow readers of a 7.75 MB page from 5 addresses refused 83 of 92 honest checks when pages were answers."""
    from autonomy.views.web import MAX_PAGES_PER_ADDRESS, MAX_PAGES_SENDING

    server, codes = served
    status, ran = call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])
    page_file(server.folder, "s1", ran["number"]).write_bytes(b"<!doctype html>" + b"x" * (MAX_PAGE_BYTES - 100))
    crowd = []
    try:
        for k in range(5):  # 64 readers an address, who never read: more than every answer's slot before
            crowd += non_readers(server.port, 64, requests=1, path=ran["page"], source=f"127.0.0.{10 + k}")
        time.sleep(1.0)
        heads = [conn.recv(64).split(b"\r\n")[0] for conn in crowd]
        served_pages = heads.count(b"HTTP/1.1 200 OK")
        assert served_pages == min(MAX_PAGES_SENDING, 5 * MAX_PAGES_PER_ADDRESS)  # the pages' share, no more
        assert heads.count(b"HTTP/1.1 503 Service Unavailable") == len(crowd) - served_pages
        for _ in range(20):  # an honest student's checks, each with its tree: an answer sent in pieces too
            status, checked = call(server, "/api/check", {"mission": SOLUTION}, codes["s2"])
            assert status == 200 and checked["ok"] and checked["tree_svg"].startswith("<svg")
    finally:
        for conn in crowd:
            conn.close()


def test_a_page_read_too_slowly_over_the_whole_of_it_is_let_go(served, monkeypatch, caplog):
    import autonomy.views.web as web_module

    server, codes = served
    monkeypatch.setattr(web_module, "ANSWER_STALL_S", 1.0)
    monkeypatch.setattr(web_module, "MIN_ANSWER_BYTES_PER_S", 4 * 2**20)  # 8 MB: 1 s of stall, and 2 s for it
    status, ran = call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])
    page_file(server.folder, "s1", ran["number"]).write_bytes(b"<!doctype html>" + b"x" * (MAX_PAGE_BYTES - 100))
    (reader,) = non_readers(server.port, 1, requests=1, path=ran["page"])
    read, started, held = 0, time.monotonic(), []
    try:
        reader.settimeout(5)
        while time.monotonic() - started < 6:  # a piece every half second: it never stalls a whole second
            read += len(reader.recv(4096))
            held.append(server._pages_sending)
            time.sleep(0.5)
    finally:
        reader.close()
    # it was being sent, then let go at its deadline (what the kernel had taken still comes, and no more)
    assert held[0] == 1 and held[-1] == 0 and read < MAX_PAGE_BYTES // 8
    assert any("read it too slowly" in r.getMessage() for r in caplog.records)


def test_students_whose_gradings_spin_hold_one_lane_and_the_class_is_graded_in_the_other(served):
    server, codes = served
    server._clock = clock = VirtualClock(1000.0)
    graded, released, budgets = server._grader, threading.Event(), []

    def grader(*args, **kwargs):
        if args[1] == "s1":
            budgets.append(kwargs.get("cpu_s"))
        if args[1] == "s1" and len(budgets) == 1:  # Ada's first: 30 s of CPU time, were it let
            report, page = graded(*args, **kwargs)
            return dataclasses.replace(report, cpu_s=30.0), page
        if args[1] == "s1" and len(budgets) == 3:  # her next spins until it is released
            released.wait(60)
        return graded(*args, **kwargs)

    server._grader = grader
    assert call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])[0] == 200
    assert budgets == [QUICK_GRADING_CPU_S, None]  # the quick budget first, then graded again with the whole
    clock.advance_to(clock.now() + 31.0)  # her hold is over: she runs again, and spins
    ada = threading.Thread(target=call, args=(server, "/api/run", {"mission": SOLUTION}, codes["s1"]))
    ada.start()
    try:
        deadline = time.monotonic() + 30
        while len(budgets) < 3 and time.monotonic() < deadline:  # her grading started, in its lane's thread
            time.sleep(0.01)
        assert server._waiting == [1, 0] and budgets == [QUICK_GRADING_CPU_S, None, None]  # in the lane for anyone
        assert call(server, "/api/run", {"mission": SOLUTION}, codes["s2"])[0] == 200  # Bob is graded meanwhile
    finally:
        released.set()
        ada.join(60)


def test_a_run_s_text_is_kept_in_the_database_alone_and_only_the_last_ones(served, monkeypatch):
    import autonomy.liveclass.server as server_module

    server, codes = served
    monkeypatch.setattr(server_module, "RUN_TEXTS_KEPT", 2)
    numbers = [call(server, "/api/run", {"mission": SOLUTION + f"# {k}\n"}, codes["s1"])[1]["number"] for k in range(4)]
    _, handed = call(server, "/api/handin", {"mission": SOLUTION}, codes["s1"])
    assert [server.store.work(n).source != "" for n in numbers] == [False, False, True, True]
    assert [w.source for w in server.store.works("s1", "handin")] == [SOLUTION]  # a hand-in's, for good
    assert not any(work_file(server.folder, "s1", n, hand_in=False).exists() for n in numbers)
    assert work_file(server.folder, "s1", handed["number"], hand_in=True).read_text() == SOLUTION


def test_a_refused_run_s_text_counts_among_the_runs_texts_kept(served, monkeypatch):
    import autonomy.liveclass.server as server_module

    server, codes = served
    monkeypatch.setattr(server_module, "RUN_TEXTS_KEPT", 2)
    wrong = "mission: m\ntree:\n  mvoe: {speed: 2}\n" + "# a long text\n" * 1000
    refused = []
    for _ in range(4):
        status, _ = call(server, "/api/run", {"mission": wrong}, codes["s1"])
        assert status == 422
        refused.append(max(work["number"] for work in server.store.work_list("s1")))
    assert [server.store.work(n).source != "" for n in refused] == [False, False, True, True]
    assert [server.store.work(n).problem for n in refused] == [server.store.work(refused[-1]).problem] * 4


def test_a_run_whose_grading_failed_keeps_its_text_among_the_last_runs_alone(served, monkeypatch):
    import autonomy.liveclass.server as server_module

    server, codes = served
    monkeypatch.setattr(server_module, "RUN_TEXTS_KEPT", 2)

    def broken(*args, **kwargs):
        raise RuntimeError("the grader broke")

    server._grader = broken
    failed = []
    for k in range(4):
        status, answer = call(server, "/api/run", {"mission": SOLUTION + f"# {k}\n"}, codes["s1"])
        assert (status, answer["error"]) == (500, "the grading failed: RuntimeError")
        failed.append(max(work["number"] for work in server.store.work_list("s1")))
    assert [server.store.work(n).source != "" for n in failed] == [False, False, True, True]
    assert not any(work_file(server.folder, "s1", n, hand_in=False).exists() for n in failed)


def test_a_long_history_of_runs_is_not_listed_by_api_me(served):
    server, codes = served
    for number in range(3000):  # hours of runs, at the rate limits
        server.store.add_work("s1", "run", "", {"problems": []}, problem=f"run {number}")
    _, handed = call(server, "/api/handin", {"mission": SOLUTION}, codes["s1"])
    status, me = call(server, "/api/me", code=codes["s1"], method="GET")
    assert status == 200 and [w["kind"] for w in me["works"]] == ["handin"]
    assert me["works"][0]["number"] == handed["number"] and me["works"][0]["count"] == 1
    assert me["works"][0]["page"] == handed["page"]
    assert "source" not in me["works"][0] and "result" not in me["works"][0]


def test_a_cluster_that_lost_its_workers_is_said_to_the_student_and_the_teacher_in_one_line(tmp_path):
    from autonomy.classroom.cluster import ClusterUnfit

    def gone(*_: object, **__: object) -> None:  # as DaskGrader says, once the cluster has had no worker a while
        raise ClusterUnfit("the Dask cluster at tcp://10.0.0.9:8786 lost its workers mid-grading (none for 10 s)")

    store = ClassStore(tmp_path)
    codes = store.enrol([("s1", "Ada")])
    server = ClassServer(GARAGE, store, tmp_path, port=0, grader=gone)
    server.start()
    try:
        status, answer = call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])
        assert status == 500 and answer["error"].endswith("lost its workers mid-grading (none for 10 s)"), answer
        (work,) = store.work_list("s1", "run")
        assert "lost its workers" in work["problem"]  # the teacher's table says why that run has no marks
        status, _ = call(server, "/api/check", {"mission": SOLUTION}, codes["s1"])
        assert status == 200  # the class goes on: checks need no cluster
    finally:
        server.stop()
        store.close()

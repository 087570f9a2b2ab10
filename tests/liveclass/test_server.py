"""The class's API, served on loopback: a student checks, runs and hands in; the teacher sees the class.

Each safety rule is tried as an attack that fails: a wrong code, guessing, another's work, a huge body,
running too often, a hand-in after the deadline.
"""

from __future__ import annotations

import json
import time
import urllib.error
import urllib.request

import pytest

from autonomy.classroom.exercise import load_exercise
from autonomy.liveclass.server import DEADLINE, GUESS_WAIT_S, RUNS_PER_MINUTE, TEACHER_TOKEN, ClassServer
from autonomy.liveclass.store import ClassStore, code_digest
from tests.views.conftest import ROOT

GARAGE = load_exercise(ROOT / "exercises" / "garage.yaml").with_secret(b"the teacher's secret")
SOLUTION = (ROOT / "exercises" / "solutions" / "garage.yaml").read_text()
TYPO = "mission: park\ntree:\n  sequence:\n    - mvoe: {speed: 2, seconds: 1}\n"


@pytest.fixture
def served(tmp_path):
    store = ClassStore(tmp_path)
    codes = store.enrol([("s1", "Ada"), ("s2", "Bob")])
    store.set_setting(TEACHER_TOKEN, code_digest("teacher-token"))
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


def test_a_wrong_code_is_refused_and_guessing_again_slows_down_and_a_student_never_sees_the_class(served):
    server, codes = served
    waits = []
    for _ in range(3):
        started = time.monotonic()
        status, refused = call(server, "/api/check", {"mission": TYPO}, "aaaaaaaa")
        waits.append(time.monotonic() - started)
        assert status == 401 and "sign-in code" in refused["error"]
    assert waits[2] >= 4 * GUESS_WAIT_S  # 0.25 s, 0.5 s, 1 s: each wrong guess waits twice as long
    assert call(server, "/api/check", {"mission": TYPO}, "")[0] == 401
    assert call(server, "/api/class", code=codes["s1"], method="GET")[0] == 401  # a student's code is not the teacher's
    assert call(server, "/api/class", code="teacher-tokem", method="GET")[0] == 401


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

"""``autonomy class serve`` as a teacher runs it: codes handed out, and a hand-in that survives kill -9."""

from __future__ import annotations

import csv
import json
import re
import signal
import subprocess
import sys
import urllib.error
import urllib.request

from autonomy.classroom.secret import read_secret
from tests.views.conftest import ROOT

SOLUTION = (ROOT / "exercises" / "solutions" / "garage.yaml").read_text()


def serve(
    folder, *more: str, env: dict[str, str] | None = None, exercise: str = "garage"
) -> tuple[subprocess.Popen, int, str]:
    """``autonomy class serve EXERCISE`` of ``folder/roster.csv`` in ``folder/class``: the process, its port, its token.

    Its first two lines on standard error (the class, the teacher's address) are kept as ``process.said``.
    """
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "class", "serve", exercise, "--roster", str(folder / "roster.csv")]
        + ["--dir", str(folder / "class"), "--port", "0", *more],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip
    said = process.stderr.readline() + process.stderr.readline()
    process.said = said
    token = re.search(r"/teacher#(\S+)", said).group(1)
    port = int(process.stdout.readline().strip().rstrip("/").rsplit(":", 1)[1])
    return process, port, token


def post(port: int, path: str, body: dict, code: str) -> dict:
    request = urllib.request.Request(f"http://127.0.0.1:{port}{path}", data=json.dumps(body).encode(), method="POST")
    request.add_header("Authorization", f"Bearer {code}")
    with urllib.request.urlopen(request, timeout=60) as answer:
        return json.loads(answer.read())


def refused(port: int, code: str) -> int:
    """The status a check with ``code`` is refused with (the test fails if it is taken)."""
    try:
        post(port, "/api/check", {"mission": SOLUTION}, code)
    except urllib.error.HTTPError as refusal:
        return refusal.code
    raise AssertionError(f"the code {code} signs in")


def table(port: int, token: str) -> dict:
    request = urllib.request.Request(f"http://127.0.0.1:{port}/api/class")
    request.add_header("Authorization", f"Bearer {token}")
    with urllib.request.urlopen(request, timeout=30) as answer:
        return json.loads(answer.read())


def test_a_hand_in_acknowledged_right_before_a_kill_9_is_there_with_its_marks_after_a_restart(tmp_path):
    (tmp_path / "roster.csv").write_text("id,name,submission\n1001,Ada Lovelace,ada\n1002,Bob Jones,bob\n")
    server, port, token = serve(tmp_path)
    try:
        with (tmp_path / "class" / "codes.csv").open() as stream:
            codes = {row["id"]: row["code"] for row in csv.DictReader(stream)}
        assert set(codes) == {"1001", "1002"} and len(set(codes.values())) == 2
        acknowledged = post(port, "/api/handin", {"mission": SOLUTION}, codes["1001"])
    finally:
        server.send_signal(signal.SIGKILL)  # the moment after the answer
        server.wait()
    assert acknowledged["ok"] and acknowledged["total"] == acknowledged["max_points"]
    again, port, token = serve(tmp_path)
    try:
        ada, bob = table(port, token)["students"]
        assert (ada["id"], ada["handins"], ada["total"]) == ("1001", 1, acknowledged["total"])
        assert bob["handins"] == 0
        assert post(port, "/api/check", {"mission": SOLUTION}, codes["1002"])["ok"]  # the same codes still sign in
        with (tmp_path / "class" / "codes.csv").open() as stream:
            assert len(list(csv.DictReader(stream))) == 2  # no new codes for the same students
    finally:
        again.send_signal(signal.SIGINT)
        _, said = again.communicate(timeout=30)
    assert again.returncode == 0 and "Traceback" not in said


def test_serve_says_at_its_start_what_a_lesson_of_the_class_may_keep_on_disk(tmp_path):
    from autonomy.liveclass.server import disk_said

    (tmp_path / "roster.csv").write_text("id,name,submission\n1001,Ada Lovelace,ada\n1002,Bob Jones,bob\n")
    server, _, _ = serve(tmp_path)
    try:
        lines = [server.stderr.readline().rstrip("\n") for _ in range(2)]  # the links' line, then the disk's
    finally:
        server.send_signal(signal.SIGINT)
        server.communicate(timeout=30)
    assert lines[-1] == disk_said(2) and "GB for a 2-hour lesson of 2 students" in lines[-1]


def test_a_deadline_given_to_serve_closes_hand_ins_and_is_said(tmp_path):
    (tmp_path / "roster.csv").write_text("id,name,submission\n1001,Ada Lovelace,ada\n")
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "class", "serve", "garage", "--roster", str(tmp_path / "roster.csv")]
        + ["--dir", str(tmp_path / "class"), "--port", "0", "--deadline", "2000-01-01T00:00"],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        said = process.stderr.readline()
        port = int(process.stdout.readline().strip().rstrip("/").rsplit(":", 1)[1])
        with (tmp_path / "class" / "codes.csv").open() as stream:
            code = next(csv.DictReader(stream))["code"]
        try:
            post(port, "/api/handin", {"mission": SOLUTION}, code)
            refused = None
        except urllib.error.HTTPError as err:
            refused = err.code, json.loads(err.read())
    finally:
        process.send_signal(signal.SIGINT)
        process.communicate(timeout=30)
    assert "hand-ins close at 2000-01-01T00:00" in said
    assert refused is not None and refused[0] == 403 and "closed" in refused[1]["error"]
    bad = subprocess.run(
        [sys.executable, "-m", "autonomy", "class", "serve", "garage", "--roster", str(tmp_path / "roster.csv")]
        + ["--dir", str(tmp_path / "class"), "--deadline", "friday"],
        cwd=ROOT, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert bad.returncode == 2 and "expected a date and time such as 2026-11-27T15:00" in bad.stderr


def run_autonomy(*args: str) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "autonomy", *args]
    return subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=60)


def test_a_lost_code_is_replaced_and_the_old_one_signs_in_no_more(tmp_path):
    (tmp_path / "roster.csv").write_text("id,name,submission\n1001,Ada Lovelace,ada\n1002,Bob Jones,bob\n")
    server, port, token = serve(tmp_path)
    codes_file = tmp_path / "class" / "codes.csv"
    try:
        with codes_file.open() as stream:
            old = {row["id"]: row["code"] for row in csv.DictReader(stream)}
        renewed = run_autonomy("class", "codes", "1001", "--dir", str(tmp_path / "class"))
        assert renewed.returncode == 0 and "1 new codes" in renewed.stderr
        with codes_file.open() as stream:
            new = {row["id"]: row["code"] for row in csv.DictReader(stream)}
        assert set(new) == {"1001", "1002"} and new["1002"] == old["1002"] and new["1001"] != old["1001"]
        assert oct(codes_file.stat().st_mode & 0o777) == "0o600"
        assert post(port, "/api/check", {"mission": SOLUTION}, new["1001"])["ok"]  # the running server takes it
        assert refused(port, old["1001"]) == 401
    finally:
        server.send_signal(signal.SIGINT)
        server.communicate(timeout=30)
    unknown = run_autonomy("class", "codes", "9999", "--dir", str(tmp_path / "class"))
    assert unknown.returncode == 2 and unknown.stderr.count("\n") == 1 and "9999" in unknown.stderr
    (tmp_path / "roster.csv").write_text("id,name,submission\n1001,Ada Lovelace,ada\n")  # Bob leaves the class
    server, _, _ = serve(tmp_path)
    server.send_signal(signal.SIGINT)
    server.communicate(timeout=30)
    gone = run_autonomy("class", "codes", "1002", "--dir", str(tmp_path / "class"))
    assert gone.returncode == 2 and "not in the class: 1002" in gone.stderr  # a code for him would go nowhere
    nothing = run_autonomy("class", "codes", "--dir", str(tmp_path / "nowhere"))
    assert nothing.returncode == 2 and "no class is kept there" in nothing.stderr
    assert not (tmp_path / "nowhere").exists()


def test_a_class_folder_is_of_one_exercise_and_keeps_its_secret_as_text(tmp_path):
    (tmp_path / "roster.csv").write_text("id,name,submission\n1001,Ada Lovelace,ada\n")
    server, _, _ = serve(tmp_path)
    server.send_signal(signal.SIGINT)
    server.communicate(timeout=30)
    # text, as autonomy grade --secret-file takes it: all of it is the secret (random bytes could end in a
    # line end or a vertical tab, which a secret file's reader lets go, and draw other hidden seeds than kept)
    kept = (tmp_path / "class" / "secret").read_bytes()
    assert re.fullmatch(rb"[0-9a-f]{64}\n", kept) and read_secret(tmp_path / "class" / "secret") == kept[:-1]
    other = run_autonomy(
        "class", "serve", "slalom", "--roster", str(tmp_path / "roster.csv"), "--dir", str(tmp_path / "class")
    )
    assert other.returncode == 2 and "holds a class of another exercise ('garage'" in other.stderr
    assert other.stderr.count("\n") == 1 and other.stdout == ""


def test_the_roster_s_changes_are_the_class_s_at_the_next_start(tmp_path):
    (tmp_path / "roster.csv").write_text("id,name,submission\n1001,Ada Lovelace,ada\n1002,Bob Jones,bob\n")
    server, _, _ = serve(tmp_path)
    server.send_signal(signal.SIGINT)
    server.communicate(timeout=30)
    with (tmp_path / "class" / "codes.csv").open() as stream:
        codes = {row["id"]: row["code"] for row in csv.DictReader(stream)}
    (tmp_path / "roster.csv").write_text("id,name\n1001,Ada King\n1003,Cy Young\n")  # as serve --help says
    server, port, token = serve(tmp_path)
    try:
        assert [(s["id"], s["name"]) for s in table(port, token)["students"]] == [
            ("1001", "Ada King"),
            ("1003", "Cy Young"),
        ]
        assert refused(port, codes["1002"]) == 401  # no longer on the roster
    finally:
        server.send_signal(signal.SIGINT)
        server.communicate(timeout=30)
    with (tmp_path / "class" / "codes.csv").open() as stream:
        assert [row["id"] for row in csv.DictReader(stream)] == ["1001", "1002", "1003"]


def test_codes_csv_names_no_formula_a_spreadsheet_would_run(tmp_path):
    (tmp_path / "roster.csv").write_text('id,name,submission\n1001,"=HYPERLINK(""http://x"",""a"")",ada\n+1002,Bob,b\n')
    server, _, _ = serve(tmp_path)
    server.send_signal(signal.SIGINT)
    server.communicate(timeout=30)
    with (tmp_path / "class" / "codes.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    shown = [(row["id"], row["name"]) for row in rows]
    assert shown == [("1001", '\'=HYPERLINK("http://x","a")'), ("'+1002", "Bob")]
    renewed = run_autonomy("class", "codes", "+1002", "--dir", str(tmp_path / "class"))
    assert renewed.returncode == 0
    with (tmp_path / "class" / "codes.csv").open() as stream:
        again = list(csv.DictReader(stream))
    assert [row["id"] for row in again] == ["1001", "'+1002"] and again[1]["code"] != rows[1]["code"]

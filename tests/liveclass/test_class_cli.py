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

from tests.views.conftest import ROOT

SOLUTION = (ROOT / "exercises" / "solutions" / "garage.yaml").read_text()


def serve(folder) -> tuple[subprocess.Popen, int, str]:
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "class", "serve", "garage", "--roster", str(folder / "roster.csv")]
        + ["--dir", str(folder / "class"), "--port", "0"],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    said = process.stderr.readline() + process.stderr.readline()
    token = re.search(r"token (\S+)", said).group(1)
    port = int(process.stdout.readline().strip().rstrip("/").rsplit(":", 1)[1])
    return process, port, token


def post(port: int, path: str, body: dict, code: str) -> dict:
    request = urllib.request.Request(f"http://127.0.0.1:{port}{path}", data=json.dumps(body).encode(), method="POST")
    request.add_header("Authorization", f"Bearer {code}")
    with urllib.request.urlopen(request, timeout=60) as answer:
        return json.loads(answer.read())


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

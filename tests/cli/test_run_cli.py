"""autonomy run / check / show / behaviours / schema as subprocesses: output and exit codes."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

from tests.cli.test_cli import ROOT, assert_one_line_error, autonomy


def test_run_fast_succeeds_with_a_live_view_and_a_summary():
    result = autonomy("run", "missions/square.yaml", "--fast")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.strip().splitlines()
    assert "repeat x4 > sequence > move 300 mm" in lines[0]
    assert "turn left 90 deg" in result.stdout
    assert lines[-1].startswith("Mission 'square' succeeded after 10.2 s")
    assert "It was stopped at the end." in lines[-1]


def test_run_failure_exits_1(tmp_path):
    mission = tmp_path / "crash.yaml"
    mission.write_text("mission: crash\nworld: box\ntree:\n  move: {speed: 3}\n")
    result = autonomy("run", str(mission), "--fast", "--quiet")
    assert result.returncode == 1
    assert "failed after" in result.stdout and "collided" in result.stdout


def test_run_time_limit_exits_1():
    result = autonomy("run", "missions/wander.yaml", "--fast", "--quiet", "--max-seconds", "3")
    assert result.returncode == 1 and "stopped at the time limit" in result.stdout


def test_run_invalid_mission_exits_2_with_every_problem(tmp_path):
    mission = tmp_path / "bad.yaml"
    mission.write_text("mission: bad\ntree:\n  sequence:\n    - trun: {left: 90}\n    - move: {speed: 7}\n")
    result = autonomy("run", str(mission), "--fast")
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert result.stderr.splitlines() == [
        f"{mission}:4:7: tree.sequence[0].trun: unknown node 'trun' (did you mean 'turn'?)",
        f"{mission}:5:21: tree.sequence[1].move.speed: move speed must be 1..4, got 7 "
        "(speed setting, 1 slow .. 4 very fast)",
    ]
    assert result.stdout == ""


def test_run_link_error_exits_3():
    result = autonomy("run", "missions/square.yaml", "--port", "/dev/ttyNOPE0")
    assert_one_line_error(result, 3, "no such port")


def test_run_fast_needs_the_emulator():
    result = autonomy("run", "missions/square.yaml", "--port", "socket://127.0.0.1:9", "--fast")
    assert_one_line_error(result, 2, "--fast runs in virtual time")


def test_run_writes_a_trace(tmp_path):
    trace = tmp_path / "run.jsonl"
    result = autonomy("run", "missions/move_until_wall.yaml", "--fast", "--quiet", "--trace", str(trace))
    assert result.returncode == 0
    lines = [json.loads(line) for line in trace.read_text().splitlines()]
    assert lines[0]["mission"] == "move until wall"
    sent = [c["sent"] for line in lines[1:] for c in line["commands"] if not c["sent"].startswith("G")]
    assert sent[:3] == ["F+300", "X0000", "S9992"]


def test_ctrl_c_stops_the_robot_and_exits_130(tmp_path):
    trace = tmp_path / "run.jsonl"
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "run", "missions/patrol.yaml", "--trace", str(trace)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    assert "move until < 150 mm" in process.stdout.readline()  # driving, in real time
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=20)
    assert process.returncode == 130, err
    assert "interrupted" in out and "It was stopped at the end." in out
    commands = [c for line in trace.read_text().splitlines()[1:] for c in json.loads(line)["commands"]]
    assert {"sent": "F+300", "reply": "OK"} in commands


def test_sigterm_is_handled_like_ctrl_c():
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "run", "missions/patrol.yaml"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    process.stdout.readline()
    process.send_signal(signal.SIGTERM)
    out, _ = process.communicate(timeout=20)
    assert process.returncode == 130 and "It was stopped at the end." in out


def test_check_reports_each_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("mission: bad\ntree: turn\n")
    result = autonomy("check", "missions/square.yaml", str(bad), "missions/wander.yaml")
    assert result.returncode == 2
    assert result.stdout.splitlines() == [
        "missions/square.yaml: ok (mission 'square', 6 nodes)",
        "missions/wander.yaml: ok (mission 'wander', 14 nodes)",
    ]
    assert (
        result.stderr.strip()
        == f"{bad}:2:7: tree.turn: 'turn' needs parameters (left or right); write it as turn: {{left: 90}}"
    )
    assert autonomy("check", "missions/square.yaml").returncode == 0


@pytest.mark.parametrize("fmt", ["unicode", "dot", "svg"])
def test_show_formats(fmt):
    result = autonomy("show", "missions/square.yaml", "--format", fmt)
    assert result.returncode == 0, result.stderr
    if fmt == "unicode":
        assert "repeat x4" in result.stdout and "turn left 90 deg" in result.stdout
    elif fmt == "dot":
        assert result.stdout.startswith('digraph "square"') and "n0 -> n1;" in result.stdout
    else:
        svg = ET.fromstring(result.stdout)
        texts = [t.text for t in svg.iter("{http://www.w3.org/2000/svg}text")]
        assert texts == ["move 300 mm", "turn left 90 deg", "beep", "corner", "sequence", "repeat x4"]


def test_behaviours_and_schema():
    listing = autonomy("behaviours")
    assert listing.returncode == 0 and "  move " in listing.stdout and "until_obstacle_mm" in listing.stdout
    with_plugin = autonomy("behaviours", "missions/explore.yaml")
    assert "turn_until_clear" in with_plugin.stdout and "[plugin opening_finder]" in with_plugin.stdout
    schema = json.loads(autonomy("schema").stdout)
    assert schema["required"] == ["mission", "tree"] and "move" in schema["$defs"]

"""The ``autonomy`` command run as a subprocess, as a student runs it."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def autonomy(*args: str, timeout: float = 60) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "autonomy", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=ROOT,
    )


def assert_one_line_error(result: subprocess.CompletedProcess, code: int, *fragments: str) -> None:
    assert result.returncode == code, result.stderr
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    for fragment in fragments:
        assert fragment in lines[0]


@pytest.fixture
def served(request):
    """Starts ``autonomy emulator`` with the given arguments; yields (process, first line)."""
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "emulator", *request.param],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    url = process.stdout.readline().strip()
    yield process, url
    if process.poll() is None:
        process.kill()
        process.wait()


def test_probe_json_has_every_field():
    result = autonomy("probe", "--port", "emu://?time=virtual&world=corridor", "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["firmware"] == "E10" and report["battery"] == 230 and report["healthy"] is True
    assert set(report["status"]) == {
        "mode",
        "auto_mode",
        "collided",
        "moving",
        "tilt_deg",
        "heading_deg",
        "front_distance_mm",
        "odometer_mm",
        "raw",
    }
    assert report["status"]["raw"].startswith("62 10")


def test_probe_text_names_what_it_shows():
    result = autonomy("probe", "--port", "emu://?time=virtual&battery=30")
    assert result.returncode == 0, result.stderr
    assert "battery         30 / 255" in result.stdout
    assert "health          NOT OK" in result.stdout
    assert "front_distance_mm 255" in result.stdout


def test_probe_missing_port_is_one_line_and_exit_3():
    result = autonomy("probe", "--port", "/dev/ttyNOPE0")
    assert_one_line_error(result, 3, "cannot open /dev/ttyNOPE0: no such port")


def test_probe_wrong_baud_rate_is_one_line_and_exit_3():
    result = autonomy("probe", "--port", "emu://?time=virtual", "--baud", "115200")
    assert_one_line_error(result, 3, "no answer", "115200 baud", "is the robot set to 57600 baud?")


def test_probe_over_an_emulated_link_too_lossy_to_answer_names_its_faults_not_the_baud_rate():
    result = autonomy("probe", "--port", "emu://?time=virtual&faults=drop=0.3")
    assert_one_line_error(result, 3, "no answer", "the emulator injects link faults (drop=0.3)")
    assert "baud?" not in result.stderr


def test_probe_silent_robot_is_one_line_and_exit_3():
    result = autonomy("probe", "--port", "emu://?time=virtual&boot=60", "--wait", "1")
    assert_one_line_error(result, 3, "nothing came back")


def test_unsupported_baud_rate_is_a_usage_error():
    result = autonomy("probe", "--port", "emu://", "--baud", "9600")
    assert_one_line_error(result, 2, "invalid choice: 9600")


def test_probe_needs_a_port():
    result = autonomy("probe")
    assert result.returncode == 2 and "--port" in result.stderr and "Traceback" not in result.stderr


@pytest.mark.parametrize("served", [["--tcp", "127.0.0.1:0", "--world", "corridor"]], indirect=True)
def test_emulator_over_tcp_answers_a_probe_from_another_process(served):
    process, url = served
    assert url.startswith("socket://127.0.0.1:")
    result = autonomy("probe", "--port", url, "--json")
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["firmware"] == "E10"
    process.send_signal(signal.SIGTERM)
    assert process.wait(timeout=10) == 0


@pytest.mark.parametrize("served", [["--pty", "--faults", "pace"]], indirect=True)
def test_emulator_on_a_pty_answers_a_probe(served):
    process, device = served
    assert device.startswith("/dev/") and os.path.exists(device)
    result = autonomy("probe", "--port", device)
    assert result.returncode == 0, result.stderr
    assert "firmware        E10" in result.stdout
    process.send_signal(signal.SIGINT)
    assert process.wait(timeout=10) == 0
    assert not os.path.exists(device) or device.startswith("/dev/pts/")


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["--world", "mars"], "no world named 'mars'"),
        (["--faults", "drip=1"], "unknown fault 'drip'"),
        (["--tcp", "localhost:notaport"], "expected HOST:PORT"),
    ],
)
def test_emulator_bad_arguments_are_one_line_and_exit_2(args, fragment):
    result = autonomy("emulator", *args, timeout=20)
    assert_one_line_error(result, 2, fragment)


def test_emulator_port_in_use_is_one_line_and_exit_3():
    import socket

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        sock.listen()
        port = sock.getsockname()[1]
        result = autonomy("emulator", "--tcp", f"127.0.0.1:{port}", timeout=20)
    assert_one_line_error(result, 3, f"cannot serve on 127.0.0.1:{port}")


@pytest.mark.parametrize("served", [["--tcp", "0.0.0.0:0"]], indirect=True)
def test_emulator_serving_every_address_warns_of_the_risk(served):
    process, url = served
    assert url.startswith("socket://0.0.0.0:")
    warning = process.stderr.readline()
    assert warning.startswith("autonomy: warning: serving on every network address") and "anyone" in warning


def _network_address() -> str:
    """This machine's address on its network (the way out's), found without sending anything."""
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.connect(("192.0.2.1", 9))  # an address for documentation: a datagram socket sends nothing
            return probe.getsockname()[0]
    except OSError:
        return ""


def test_emulator_serving_a_network_address_warns_and_a_loopback_one_does_not():
    from autonomy.emulator import Emulator
    from autonomy.emulator.servers import TcpServer

    with TcpServer(Emulator("box"), "127.0.0.2", 0) as loopback:  # any of 127/8 is this machine only
        assert not loopback.public
    address = _network_address()
    if not address or address.startswith("127."):
        pytest.skip("this machine has no network address to serve on")
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "emulator", "--tcp", f"{address}:0"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
    )  # fmt: skip
    try:
        assert process.stdout.readline().startswith(f"socket://{address}:")
        warning = process.stderr.readline()
    finally:
        process.kill()
        process.wait()
    assert warning.startswith(f"autonomy: warning: serving on a network address ({address}): anyone who can reach")


@pytest.mark.parametrize("served", [["--tcp", "127.0.0.1:0"]], indirect=True)
def test_a_second_client_hears_that_the_emulator_is_busy(served):
    process, url = served
    from autonomy.client import Client

    first = Client.open(url)
    try:
        result = autonomy("probe", "--port", url)
    finally:
        first.close()
    assert_one_line_error(result, 3, "BUSY: another client is connected")


@pytest.mark.parametrize("value", ["nan", "inf", "-1", "0"])
def test_max_seconds_must_be_a_finite_positive_number(value):
    result = autonomy("run", "missions/square.yaml", "--max-seconds", value)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "--max-seconds" in result.stderr and "above 0" in result.stderr


def test_probe_of_a_robot_that_only_says_ok_is_one_line_and_exit_3():
    import socket
    import threading

    listener = socket.create_server(("127.0.0.1", 0))

    def serve() -> None:
        conn, _ = listener.accept()
        with conn:
            while conn.recv(64):
                conn.sendall(b"OK\n")  # the wrong kind of reply to every request for a value

    threading.Thread(target=serve, daemon=True).start()
    try:
        result = autonomy("probe", "--port", f"socket://127.0.0.1:{listener.getsockname()[1]}", timeout=30)
    finally:
        listener.close()
    assert_one_line_error(result, 3, "no answer from", "lines of text but none the reply asked for", "'OK'")


def test_a_command_started_with_its_output_closed_still_runs_and_stops_the_robot(tmp_path):
    """``autonomy run ... >&-``: nothing can be said, the run and its trace are whole."""
    trace = tmp_path / "run.jsonl"
    result = subprocess.run(
        [sys.executable, "-m", "autonomy", "run", "missions/square.yaml", "--fast", "--trace", str(trace)],
        stderr=subprocess.PIPE,
        text=True,
        timeout=60,
        cwd=ROOT,
        preexec_fn=lambda: os.close(1),  # noqa: PLW1509 - the child's own output, closed before it starts
    )
    assert result.returncode == 0 and result.stderr == ""
    end = json.loads(trace.read_text().splitlines()[-1])
    assert end["type"] == "end" and end["outcome"] == "succeeded" and end["stopped"] is True


@pytest.mark.parametrize("debug", [[], ["--debug"]])
def test_a_behaviours_exception_with_control_characters_changes_nothing_on_the_screen(tmp_path, debug):
    (tmp_path / "evil.py").write_text(
        "from autonomy.behaviours import RobotAction\n\n\nclass Evil(RobotAction):\n"
        '    """Raises with control characters."""\n\n    node_type = "evil"\n\n'
        "    def update(self):\n"
        '        raise RuntimeError("boom \\x1b[31m in evil\\n second line")\n'
    )
    mission = tmp_path / "evil.yaml"
    mission.write_text("mission: evil\nplugins: [evil]\ntree:\n  evil: {}\n")
    result = autonomy("run", str(mission), "--fast", *debug)
    assert result.returncode == 1 and "\x1b" not in result.stdout + result.stderr
    assert f"raised RuntimeError: boom �[31m in evil� second line at {tmp_path}/evil.py:10 in update." in result.stdout


def test_live_without_a_terminal_says_so_and_prints_lines():
    result = autonomy("run", "missions/square.yaml", "--fast", "--live")
    assert result.returncode == 0 and result.stderr == "autonomy: --live needs a terminal; printing lines instead\n"
    assert result.stdout.startswith("Running 'square'") and "move 300 mm" in result.stdout


def test_a_usage_error_shows_no_control_character_of_what_was_typed():
    result = autonomy("replay", "x.jsonl", "--speed", "\x1b[31mred\x07")
    assert result.returncode == 2 and "\x1b" not in result.stderr and "\x07" not in result.stderr
    assert "expected a playback speed, got '�[31mred�'" in result.stderr


def test_check_takes_a_world_file_and_a_scenario_file_as_it_takes_missions_and_exercises(tmp_path):
    world = tmp_path / "hall.yaml"
    world.write_text(
        "name: hall\narena_mm: [3000, 1000]\nzones:\n  station: {box: {from_mm: [2500, 0], to_mm: [3000, 900]}}\n"
    )
    done = autonomy("check", str(world), "missions/square.test.yaml")
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == [
        f"{world}: ok (world 'hall', 3 x 1 m, 0 obstacles, zones station)",
        "missions/square.test.yaml: ok (4 scenarios of missions/square.yaml; autonomy test runs them)",
    ]
    world.write_text("name: hall\narena_mm: [3000, 1000]\nobstacels: []\n")
    assert_one_line_error(
        autonomy("check", str(world)), 2, f"{world}:3:1: obstacels: unknown key 'obstacels' (did you mean 'obstacles'?)"
    )


def test_show_writes_a_tree_as_svg_dot_or_text_and_refuses_a_picture_s_name_it_could_not_be(tmp_path):
    for name in ("tree.png", "tree.jpg", "tree.pdf"):
        refused = autonomy("show", "missions/square.yaml", "-o", str(tmp_path / name))
        assert_one_line_error(refused, 2, "a tree is written as .svg (a picture), .dot (Graphviz) or .txt")
        assert not (tmp_path / name).exists()
    written = autonomy("show", "missions/square.yaml", "-o", str(tmp_path / "tree.svg"))
    assert written.returncode == 0 and (tmp_path / "tree.svg").read_text().startswith("<svg")

"""BehaviorTree.CPP and Groot2 from the command line: export, import, XML missions, .btlog files, live Groot2."""

from __future__ import annotations

import json
import re
import struct
import subprocess
import sys
from pathlib import Path

import yaml
import zmq

from tests.btcpp import reference
from tests.cli.test_cli import ROOT, assert_one_line_error, autonomy


def test_export_check_show_run_and_import_an_xml_mission(tmp_path):
    xml = tmp_path / "wander.xml"
    result = autonomy("export", "missions/wander.yaml", "-o", str(xml))
    assert result.returncode == 0, result.stderr
    assert xml.read_text().startswith('<?xml version="1.0" encoding="UTF-8"?>\n<root BTCPP_format="4"')
    check = autonomy("check", str(xml))
    assert check.returncode == 0 and "ok (mission 'wander', 14 nodes)" in check.stdout, check.stdout + check.stderr
    shown, original = autonomy("show", str(xml)), autonomy("show", "missions/wander.yaml")
    assert shown.stdout == original.stdout and "recover from a bump" in shown.stdout
    back = tmp_path / "back.yaml"
    assert autonomy("import", str(xml), "-o", str(back)).returncode == 0
    assert yaml.safe_load(back.read_text())["tree"]["parallel"]["name"] == "wander for a minute"
    assert autonomy("show", str(back)).stdout == original.stdout
    ran = autonomy("run", str(xml), "--fast", "--max-seconds", "3", "--quiet")
    assert ran.returncode == 1 and "stopped at the time limit after 3.0 s" in ran.stdout, ran.stdout + ran.stderr


def test_an_xml_mission_with_a_mistake_is_reported_at_its_line_and_column(tmp_path):
    xml = tmp_path / "drawn.xml"
    xml.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="m">\n <BehaviorTree ID="m">\n'
        '  <Sequence>\n   <move speed="2" distance_m="300"/>\n  </Sequence>\n </BehaviorTree>\n</root>\n'
    )
    for command in ("check", "run", "show", "import"):
        result = autonomy(command, str(xml))
        assert result.returncode == 2 and "Traceback" not in result.stderr
        assert f"{xml}:4:20: tree.sequence.children[0].move.distance_m: unknown parameter 'distance_m'" in result.stderr
        assert "(did you mean 'distance_mm'?)" in result.stderr


def test_the_palette_lists_a_missions_plugins_too(tmp_path):
    result = autonomy("export", "--palette", "missions/explore.yaml")
    assert result.returncode == 0 and '<Action ID="move">' in result.stdout
    plugins = yaml.safe_load(Path(ROOT, "missions/explore.yaml").read_text()).get("plugins", [])
    assert plugins and re.search(r'<(Action|Condition) ID="\w+"', result.stdout)
    builtins = autonomy("export", "--palette").stdout
    assert len(result.stdout) > len(builtins)
    assert_one_line_error(autonomy("export"), 2, "export needs a MISSION, or --palette")
    assert_one_line_error(autonomy("export", "missions/square.yaml", "-o", "/nonexistent/x.xml"), 2, "cannot write")


def test_run_writes_a_btlog_that_replays_and_that_behaviortree_cpp_would_read(tmp_path):
    log = tmp_path / "run.btlog"
    ran = autonomy("run", "missions/square.yaml", "--fast", "--quiet", "--btlog", str(log))
    assert ran.returncode == 0, ran.stderr
    magic, xml, start, records = reference.read_btlog(log)
    assert magic == b"BTCPP4-FileLogger2\x01" and start > 1_700_000_000_000_000
    shape = reference.tree_shape(xml)
    assert [row[1] for row in shape] == ["Repeat", "Sequence", "move", "SubTree", "Sequence", "turn", "beep"]
    assert {uid for _, uid, _ in records} == set(range(1, 8))
    assert records[-1][2] in (2, 0) and all(code in (0, 1, 2, 3) for _, _, code in records)
    assert [t for t, _, _ in records] == sorted(t for t, _, _ in records)
    replay = autonomy("replay", str(log), "--lines", "--speed", "50")
    assert replay.returncode == 0, replay.stderr
    assert "turn left 90 deg" in replay.stdout and "front" not in replay.stdout  # no telemetry is made up
    assert "root SUCCESS" in replay.stdout
    assert_one_line_error(autonomy("replay", str(tmp_path / "none.btlog")), 2, "none.btlog")
    log.write_bytes(log.read_bytes()[:40])
    assert_one_line_error(autonomy("replay", str(log)), 2, "cut off in its tree")


def test_groot2_attaches_to_a_running_mission_on_this_machine_only():
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "autonomy",
            "run",
            "missions/square.yaml",
            "--groot",
            "--groot-port",
            "0",
            "--quiet",
            "--max-seconds",
            "3",
        ],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = process.stderr.readline()
        match = re.match(r"groot2: attach to 127\.0\.0\.1 port (\d+)", line)
        assert match, line
        context = zmq.Context()
        socket = context.socket(zmq.REQ)
        socket.setsockopt(zmq.RCVTIMEO, 5000)
        socket.setsockopt(zmq.LINGER, 0)
        socket.connect(f"tcp://127.0.0.1:{match.group(1)}")
        socket.send(b"\x02T\x01\x00\x00\x00")
        header, xml = socket.recv_multipart()
        assert header[:6] == b"\x02T\x01\x00\x00\x00" and len(header) == 22
        assert [row[1] for row in reference.tree_shape(xml.decode())][:3] == ["Repeat", "Sequence", "move"]
        socket.send(b"\x02S\x02\x00\x00\x00")
        _, statuses = socket.recv_multipart()
        assert [struct.unpack_from("<H", statuses, i)[0] for i in range(0, len(statuses), 3)] == list(range(1, 8))
        assert statuses[2] in (0, 1)  # the repeat runs (or has not started yet)
        socket.close()
        context.term()
        out, err = process.communicate(timeout=60)
        assert process.returncode == 1 and "time limit" in out, out + err
    finally:
        process.kill()
        process.wait()


def test_a_taken_groot2_port_is_one_line_and_another_interface_a_warning():
    context = zmq.Context()
    taken = context.socket(zmq.REP)
    port = taken.bind_to_random_port("tcp://127.0.0.1", min_port=20000, max_port=60000)
    try:
        result = autonomy("run", "missions/square.yaml", "--fast", "--groot", "--groot-port", str(port))
        assert_one_line_error(result, 2, f"cannot publish to Groot2 on 127.0.0.1:{port}")
    finally:
        taken.close(linger=0)
        context.term()
    result = autonomy(
        "run", "missions/square.yaml", "--fast", "--quiet", "--groot", "--groot-host", "0.0.0.0", "--groot-port", "0"
    )
    assert result.returncode == 0, result.stderr
    assert "warning: Groot2 is served on 0.0.0.0: anyone who can reach this machine can watch the run" in result.stderr


def test_a_btlog_is_not_plotted_as_if_it_had_telemetry_and_one_file_is_not_two_recordings(tmp_path):
    log = tmp_path / "run.btlog"
    assert autonomy("run", "missions/square.yaml", "--fast", "--quiet", "--btlog", str(log)).returncode == 0
    assert_one_line_error(autonomy("plot", str(log), "-o", str(tmp_path / "p.png")), 2, "node statuses only")
    page = autonomy("plot", str(log), "-o", str(tmp_path / "p.html"))
    data = (tmp_path / "p.html").read_text().split('id="run-data" type="application/json">')[1].split("</script>")[0]
    assert page.returncode == 0 and "<svg" in json.loads(data)["tree_svg"]  # the tree, drawn
    same = autonomy("run", "missions/square.yaml", "--fast", "--trace", str(log), "--btlog", str(log))
    assert_one_line_error(same, 2, "--trace and --btlog need files of their own")
    assert_one_line_error(autonomy("replay", "/dev/zero"), 2, "not a recording (a folder, a device or a pipe)")
    assert_one_line_error(autonomy("run", "missions/square.yaml", "--groot", "--groot-port", "65535"), 2, "0..65534")


def test_a_file_with_thousands_of_problems_shows_the_first_hundred_and_a_count(tmp_path):
    xml = tmp_path / "many.xml"
    xml.write_text(
        '<root BTCPP_format="4"><BehaviorTree ID="m"><Sequence>'
        + '<move sped="1"/>' * 300
        + "</Sequence></BehaviorTree></root>"
    )
    result = autonomy("check", str(xml))
    lines = result.stderr.splitlines()
    assert result.returncode == 2 and len(lines) == 101
    assert lines[-1] == "... and 500 more problems, not shown"  # two a move: the typo, and speed missing


def test_a_file_that_is_neither_a_trace_nor_a_btlog_says_what_each_would_be(tmp_path):
    noise = tmp_path / "noise.btlog"
    noise.write_bytes(bytes(range(256)) * 40)
    assert_one_line_error(autonomy("replay", str(noise)), 2, "not a recording", "BTCPP4-FileLogger2")

"""autonomy run / check / show / behaviours / schema as subprocesses: output and exit codes."""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

import pytest

from tests.cli.test_cli import ROOT, assert_one_line_error, autonomy


def test_run_fast_succeeds_with_a_live_view_and_a_summary():
    result = autonomy("run", "missions/square.yaml", "--fast")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.strip().splitlines()
    assert lines[0] == "Running 'square' in world 'box' (the mission's) on the built-in emulator, in virtual time."
    assert lines[1].endswith("move 300 mm (0 mm, front 255 mm)")
    assert "turn left 90 deg (90 deg to go)" in result.stdout
    ticks = lines[1:-1]
    assert all(len(line) <= 100 and line[7:9] == " s" and line.index("front") == 11 for line in ticks)
    assert lines[-1].startswith("Mission 'square' succeeded after 10.2 s")
    assert "It was stopped at the end." in lines[-1]


def test_the_summary_says_where_the_robot_came_to_rest_after_the_stop_and_what_it_hit(tmp_path):
    # ended at full speed 6 cm from the wall: the run sees no collision, the robot rolls on into the wall
    fast = autonomy("run", "autonomy/exercises/wrong/garage_full_speed.yaml", "--fast", "--quiet")
    assert fast.returncode == 0, fast.stderr
    summary = fast.stdout.strip().splitlines()[-1]
    assert "with no collisions" in summary and re.search(
        r"It was stopped at the end\. After the stop it rolled on \d+ mm and came to rest [\d.]+ s later at "
        r"\(\d+, \d+\) mm, hitting end_wall on the way\. Link: ",
        summary,
    ), fast.stdout
    calm = autonomy("run", "missions/square.yaml", "--fast", "--quiet")
    assert "After the stop it came to rest where it stopped, at (" in calm.stdout, calm.stdout
    emulator = subprocess.Popen(  # an emulator over a link: nothing is known of what comes after the stop
        [sys.executable, "-m", "autonomy", "emulator", "--tcp", "127.0.0.1:0", "--world", "garage"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
    )  # fmt: skip
    try:
        address = re.search(r"socket://\S+", emulator.stdout.readline())[0]
        linked = autonomy("run", "autonomy/exercises/wrong/garage_full_speed.yaml", "--port", address, "--quiet")
        assert linked.returncode == 0 and "After the stop" not in linked.stdout, linked.stdout
    finally:
        emulator.terminate()
        emulator.communicate(timeout=30)


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
    assert lines[0]["type"] == "header" and lines[0]["mission"] == "move until wall"
    assert lines[0]["mission_file"] == "missions/move_until_wall.yaml" and len(lines[0]["mission_sha256"]) == 64
    assert lines[-1]["type"] == "end" and lines[-1]["outcome"] == "succeeded" and lines[-1]["stopped"]
    sent = [c[0] for line in lines[1:] for c in line.get("wire", []) if not c[0].startswith("G")]
    assert sent[:3] == ["F+300", "X0000", "S9992"]
    assert sum(1 for line in lines[1:] for c in line.get("wire", []) if c[2] == 0) == lines[-1]["summary"]["requests"]


def test_ctrl_c_stops_the_robot_and_exits_130(tmp_path):
    trace = tmp_path / "run.jsonl"
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "run", "missions/patrol.yaml", "--trace", str(trace)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    seen = [process.stdout.readline() for _ in range(2)]  # Running 'patrol' ..., then the first tick
    while "move until < 150 mm" not in seen[-1] and seen[-1] and len(seen) < 50:  # a loaded machine may log first
        seen.append(process.stdout.readline())
    assert "move until < 150 mm" in seen[-1], seen  # driving, in real time
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert "interrupted" in out and "It was stopped at the end." in out
    records = [json.loads(line) for line in trace.read_text().splitlines()]
    assert ["F+300", "OK", 0] in [c for record in records[1:] for c in record.get("wire", [])]
    assert records[-1]["type"] == "end" and records[-1]["outcome"] == "interrupted" and records[-1]["stopped"]


def test_sigterm_is_handled_like_ctrl_c():
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "run", "missions/patrol.yaml"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    seen = [process.stdout.readline() for _ in range(2)]  # Running 'patrol' ..., then the first tick
    while "move until" not in seen[-1] and seen[-1] and len(seen) < 50:  # a loaded machine may log first
        seen.append(process.stdout.readline())
    assert "move until" in seen[-1], seen  # driving, in real time
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
        assert result.stdout.splitlines()[:6] == [
            "◈ repeat x4  [repeat 4 times]",
            "    → sequence, memory",
            "        • move 300 mm  [move speed=2 distance_mm=300 direction=forward]",
            "        → corner  [sequence, memory]",
            "            • turn left 90 deg  [turn left=90]",
            "            • beep tones=[5, 7, 9] volume=3",
        ]
        assert result.stdout.rstrip().splitlines()[-1].startswith("legend: → sequence  ? selector  ⇉ parallel")
    elif fmt == "dot":
        assert result.stdout.startswith('digraph "square"') and "n0 -> n1;" in result.stdout
        assert 'label="◈ repeat x4\\nrepeat 4 times"' in result.stdout
    else:
        svg = ET.fromstring(result.stdout)
        ns = "{http://www.w3.org/2000/svg}"
        texts = [t.text for g in svg.iter(f"{ns}g") if g.get("class") == "node" for t in g.iter(f"{ns}text")]
        assert texts == [
            "• move 300 mm",
            "move speed=2 distance_mm=300",  # the parameters wrapped, none cut
            "direction=forward",
            "• turn left 90 deg",
            "turn left=90",
            "• beep tones=[5, 7, 9] volume=3",
            "→ corner",
            "sequence, memory",
            "→ sequence, memory",
            "◈ repeat x4",
            "repeat 4 times",
        ]
        legend = [t.text for g in svg.iter(f"{ns}g") if g.get("class") == "legend" for t in g.iter(f"{ns}text")]
        assert legend[0].startswith("symbols: → sequence") and "condition" in legend


def test_behaviours_and_schema():
    listing = autonomy("behaviours")
    assert listing.returncode == 0 and "  move " in listing.stdout and "until_obstacle_mm" in listing.stdout
    with_plugin = autonomy("behaviours", "missions/explore.yaml")
    assert "turn_until_clear" in with_plugin.stdout and "[plugin opening_finder]" in with_plugin.stdout
    schema = json.loads(autonomy("schema").stdout)
    assert schema["required"] == ["mission", "tree"] and "move" in schema["$defs"]


def test_version():
    result = autonomy("--version")
    assert result.returncode == 0 and result.stdout.strip() == "autonomy 0.1.0"


def test_a_closed_pipe_ends_the_run_quietly_with_the_robot_stopped(tmp_path):
    trace = tmp_path / "run.jsonl"
    command = [sys.executable, "-m", "autonomy", "run", "missions/wander.yaml", "--trace", str(trace)]
    first = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert first.stdout.readline().startswith("Running 'wander'")
    first.stdout.close()  # what `| head -1` does
    _, err = first.communicate(timeout=20)
    assert "Traceback" not in err and "BrokenPipeError" not in err
    end = json.loads(trace.read_text().splitlines()[-1])
    assert end["type"] == "end" and end["reason"] == "its output was closed" and end["stopped"]


def test_the_world_in_use_is_said_and_a_conflict_refused(tmp_path):
    world = tmp_path / "lab.yaml"
    world.write_text("name: lab\narena_mm: [1000, 1000]\n")
    ran = autonomy("run", "missions/square.yaml", "--fast", "--world", str(world), "--max-seconds", "0.1")
    assert ran.stdout.startswith(f"Running 'square' in world '{world}' (from --world, not the mission's 'box')")
    conflict = autonomy("run", "missions/square.yaml", "--world", str(world), "--port", "emu://?world=corridor")
    assert_one_line_error(conflict, 2, f"--world {world} and world=corridor in --port disagree")
    from_port = autonomy(
        "run", "missions/square.yaml", "--fast", "--port", "emu://?world=corridor", "--max-seconds", "0.1"
    )
    assert from_port.stdout.startswith("Running 'square' in world 'corridor' (from --port, not the mission's 'box')")
    remote = autonomy("run", "missions/square.yaml", "--port", "socket://127.0.0.1:9", "--world", "box")
    assert_one_line_error(remote, 2, "--world applies to the built-in emulator; socket://127.0.0.1:9 has its own")


def test_a_remote_emulator_is_told_to_not_get_the_missions_world():
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "emulator", "--tcp", "127.0.0.1:0", "--battery", "30", "--mode", "manual"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        url = process.stdout.readline().strip()
        result = autonomy("run", "missions/square.yaml", "--port", url, "--max-seconds", "0.5")
        assert result.stdout.startswith(f"Running 'square' on {url}; the mission's world 'box' is not applied there")
        probe = json.loads(autonomy("probe", "--port", url, "--json").stdout)
        assert probe["battery"] <= 30 and probe["status"]["auto_mode"] is False  # --battery and --mode applied
    finally:
        process.send_signal(signal.SIGINT)
        process.communicate(timeout=10)


@pytest.mark.parametrize(("presses", "gap_s"), [(10, 0.0), (6, 0.05)])
def test_a_second_ctrl_c_does_not_cut_the_final_stop_short(tmp_path, presses, gap_s):
    trace = tmp_path / "run.jsonl"
    slow_link = "emu://?faults=pace,delay=1,delay_s=0.2"  # every reply 0.2 s late: the stop takes a while
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "run", "missions/patrol.yaml", "--port", slow_link, "--trace", str(trace)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    process.stdout.readline()  # Running 'patrol' ...
    assert "move until" in process.stdout.readline()
    for _ in range(presses):
        process.send_signal(signal.SIGINT)
        time.sleep(gap_s)
    # Presses that reach the process before Python has run the handler of the first are one
    # press (the kernel and Python each keep one of a signal pending), which a busy machine makes
    # likely. So it goes on pressing until the process ends: the stop waits 0.2 s or more for its
    # reply, and a press while it waits is a second press, however busy the machine.
    deadline = time.monotonic() + 20
    while process.poll() is None and time.monotonic() < deadline:
        process.send_signal(signal.SIGINT)
        time.sleep(0.05)
    out, err = process.communicate(timeout=20)
    assert process.returncode == 130 and "It was stopped at the end." in out
    assert "stopping the robot first" in err and "Traceback" not in err
    end = json.loads(trace.read_text().splitlines()[-1])
    assert end["type"] == "end" and end["stopped"] and end["wire"][-1][:2] == ["X0000", "OK"]


def test_a_ctrl_c_as_the_run_ends_ends_the_command_and_its_view(tmp_path):
    # The run is over (its end record is in the trace), the link is closed, stopping the robot,
    # over a slow link: a Ctrl-C now waits for the stop, and then ends the command, view included,
    # rather than be forgotten while the view waits for one more.
    trace = tmp_path / "run.jsonl"
    (tmp_path / "beep.yaml").write_text("mission: beep\nworld: box\ntree:\n  sequence:\n    - beep: {}\n")
    slow_link = "emu://?faults=pace,delay=1,delay_s=0.2"  # every reply 0.2 s late: closing the link takes a while
    command = ["run", str(tmp_path / "beep.yaml"), "--quiet", "--view", "--view-port", "0", "--port", slow_link]
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", *command, "--trace", str(trace)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    try:
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and process.poll() is None:
            lines = trace.read_text().splitlines() if trace.exists() else []
            if lines and json.loads(lines[-1])["type"] == "end":
                break
            time.sleep(0.01)
        time.sleep(0.05)  # past the end of the run, well within the stop's 0.2 s wait for its reply
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=20)
    finally:
        process.kill()
    assert process.returncode == 0 and "Mission 'beep' succeeded" in out and "Traceback" not in err


def test_a_trace_that_cannot_be_written_is_said_once_and_the_run_goes_on():
    result = autonomy("run", "missions/square.yaml", "--fast", "--trace", "/dev/full")
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert "Mission 'square' succeeded" in result.stdout and "It was stopped at the end." in result.stdout
    assert result.stderr.strip() == "autonomy: the trace /dev/full is incomplete: No space left on device"


@pytest.mark.parametrize(
    "name, columns", [("", 60), ("a_mission_named_with_one_long_word_and_no_space_to_fold_it_at_all", 30)]
)
def test_the_summary_is_folded_between_words_on_a_terminal_and_one_line_in_a_pipe(tmp_path, name, columns):
    import os
    import pty

    mission = "missions/square.yaml"
    if name:  # a word longer than the terminal is wide stays whole, on a line of its own
        (tmp_path / "long.yaml").write_text(f"mission: {name}\ntree:\n  sequence:\n    - beep: {{}}\n")
        mission = str(tmp_path / "long.yaml")
    command = [sys.executable, "-m", "autonomy", "run", mission, "--fast", "--quiet"]
    piped = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert piped.returncode == 0 and piped.stdout.count("\n") == 1  # one line, for grep and scripts
    words = piped.stdout.split()
    leader, follower = pty.openpty()
    process = subprocess.Popen(
        command, cwd=ROOT, stdout=follower, stderr=subprocess.DEVNULL, env={**os.environ, "COLUMNS": str(columns)}
    )
    os.close(follower)
    seen = b""
    while True:
        try:
            chunk = os.read(leader, 4096)
        except OSError:  # the other end closed
            break
        if not chunk:
            break
        seen += chunk
    os.close(leader)
    assert process.wait(timeout=60) == 0
    lines = seen.decode().splitlines()
    assert len(lines) > 3 and all(len(line) < columns or " " not in line.strip() for line in lines)
    assert " ".join(lines).split() == words  # no word cut in two


def test_a_second_ctrl_c_as_the_live_view_ends_leaves_exit_code_130(tmp_path):
    # The second Ctrl-C lands as the process shuts down: it must not end it by the signal itself
    # (a shell running it would stop too), but with the code an interrupted run has.
    import os
    import pty
    import select

    trace = tmp_path / "run.jsonl"
    command = [sys.executable, "-m", "autonomy", "run", "missions/wander.yaml", "--live", "--trace", str(trace)]
    pid, terminal = pty.fork()
    if pid == 0:  # the child: the live view on a terminal of its own
        os.chdir(ROOT)
        os.execv(sys.executable, command)
    seen = b""

    def read_for(seconds: float) -> None:
        nonlocal seen
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            if select.select([terminal], [], [], 0.05)[0]:
                try:
                    seen += os.read(terminal, 65536)
                except OSError:  # the child has gone
                    return

    read_for(3)  # the view is up, the robot driving
    os.kill(pid, signal.SIGINT)
    time.sleep(0.05)
    os.kill(pid, signal.SIGINT)
    read_for(10)
    _, status = os.waitpid(pid, 0)
    os.close(terminal)
    assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 130, f"ended by signal {os.WTERMSIG(status)}"
    said = seen.replace(b"\r\n", b" ")  # the summary, folded to the terminal's width
    assert b"interrupted after" in said and b"It was stopped at the end." in said and b"Traceback" not in said
    assert json.loads(trace.read_text().splitlines()[-1])["stopped"]


def test_a_run_as_an_exercise_grades_it_on_one_seed_says_the_grader_s_marks(tmp_path):
    wrong = "autonomy/exercises/wrong/garage_full_speed.yaml"
    graded = autonomy("grade", "garage", wrong, "--json", str(tmp_path / "marks.json"), "--quiet")
    assert graded.returncode == 0, graded.stderr
    (report,) = json.loads((tmp_path / "marks.json").read_text())["students"]
    points = [c["points"] for c in json.loads((tmp_path / "marks.json").read_text())["criteria"]]
    for seed in report["seeds"][:2]:
        number = int(seed["seed"].split()[1])
        ran = autonomy("run", wrong, "--exercise", "garage", "--seed", str(number), "--fast", "--quiet")
        assert ran.returncode == 0, ran.stderr
        earned = sum(p * share for p, share in zip(points, seed["shares"], strict=True))
        assert f"As the grader marks it, seed {number}: {earned:.4g} of 10 points" in ran.stdout, ran.stdout
        said = [line.split(": ", 1)[1] for line in ran.stdout.splitlines() if line.startswith(("  yes ", "  no  "))]
        assert said == [line for _, line in seed["verdicts"]]  # the grader's own lines, word for word
    refused = autonomy("run", wrong, "--exercise", "garage", "--seed", "3", "--fast")
    assert_one_line_error(refused, 2, "the exercise 'garage' has no public seed 3: its seeds are 8, 52, 56, 80")
    refused = autonomy("run", wrong, "--exercise", "garage", "--world", "box")
    assert_one_line_error(refused, 2, "leave out --port and --world")


def test_a_run_as_an_exercise_takes_the_exercise_s_world_not_the_one_its_mission_names(tmp_path):
    # a student's mission naming the teacher's world, which is beside the exercise and not beside the mission
    mission = tmp_path / "mine.yaml"
    mission.write_text((ROOT / "exercises" / "solutions" / "garage.yaml").read_text().replace("world: garage", "")
                       .replace("mission:", "world: the_teachers_hall\nmission:", 1))  # fmt: skip
    assert "world: the_teachers_hall" in mission.read_text()
    alone = autonomy("run", str(mission), "--fast", "--quiet")
    assert alone.returncode == 2 and "no world named 'the_teachers_hall'" in alone.stderr
    ran = autonomy("run", str(mission), "--exercise", "garage", "--fast", "--quiet")
    assert ran.returncode == 0, ran.stderr
    assert "As the grader marks it, seed 8: 10 of 10 points" in ran.stdout


def test_a_run_says_what_its_trace_and_log_hold_and_a_collision_once(tmp_path):
    trace, btlog = tmp_path / "run.jsonl", tmp_path / "run.btlog"
    ran = autonomy("run", "missions/beep_on_collision.yaml", "--fast", "--trace", str(trace), "--btlog", str(btlog))
    assert ran.returncode == 0, ran.stderr
    ticks = sum(1 for line in trace.read_text().splitlines() if '"tick"' in line.split(",", 1)[0])
    said = ran.stdout.splitlines()
    assert said[-2] == f"trace: {trace}, {ticks} ticks" and ticks > 500  # after the summary
    assert re.fullmatch(rf"btlog: {re.escape(str(btlog))}, \d+ status changes of 7 nodes", said[-1])
    collisions = [line.strip() for line in ran.stdout.splitlines() if "collision (front sensor" in line]
    assert len(collisions) == 3 and all(line.startswith("collision (front sensor") for line in collisions)
    quiet = autonomy("run", "missions/square.yaml", "--fast", "--quiet", "--trace", str(trace))
    assert quiet.returncode == 0 and quiet.stderr == "" and "trace:" not in quiet.stdout

"""The terminal views as a person sees them: the full-screen view in tmux at 80x24, the line output."""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
import time
from itertools import pairwise

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from autonomy.record import NodeInfo, NodeState, RunHeader
from autonomy.views.treetext import tree_lines
from tests.views.conftest import ROOT

pytestmark = pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed")


#: A tmux server of this test process's own: sessions of another run of the tests on the machine are not ours.
TMUX = ["tmux", "-L", f"autonomy-tests-{os.getpid()}"]


class Tmux:
    def __init__(self, name: str, command: str) -> None:
        self.name = name
        subprocess.run(
            [*TMUX, "new-session", "-d", "-s", name, "-x", "80", "-y", "24", f"cd {ROOT} && {command}; sleep 30"],
            check=True,
        )

    def screen(self) -> list[str]:
        out = subprocess.run([*TMUX, "capture-pane", "-p", "-t", self.name], capture_output=True, text=True)
        return out.stdout.splitlines()

    def wait_for(self, text: str, seconds: float = 15) -> list[str]:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            screen = self.screen()
            if any(text in line for line in screen):
                return screen
            time.sleep(0.1)
        raise AssertionError(f"{text!r} never showed:\n" + "\n".join(self.screen()))

    def keys(self, *keys: str) -> None:
        subprocess.run([*TMUX, "send-keys", "-t", self.name, *keys], check=True)

    def close(self) -> None:
        subprocess.run([*TMUX, "kill-session", "-t", self.name], capture_output=True)


@pytest.fixture
def tmux(request):
    sessions: list[Tmux] = []

    def start(command: str) -> Tmux:
        session = Tmux(f"autonomy-test-{len(sessions)}-{request.node.name[:20]}", command)
        sessions.append(session)
        return session

    yield start
    for session in sessions:
        session.close()


def command(*args: str) -> str:
    return shlex.join([sys.executable, "-m", "autonomy", *args])


def test_live_view_shows_the_whole_tree_and_the_robot_in_80x24_and_ctrl_c_stops(tmux):
    session = tmux(command("run", "missions/wander.yaml", "--live"))
    screen = session.wait_for("● • move until < 150 mm")
    text = "\n".join(screen)
    assert len(screen) <= 24 and all(len(line) <= 80 for line in screen)
    assert screen[0].lstrip().startswith("wander") and "live" in screen[0] and "Ctrl-C stops the robot" in screen[0]
    # both RUNNING branches of the parallel show, with their feedback
    assert any("● ⇉ wander for a minute" in line for line in screen)
    assert any("● • wait 60 s" in line and "s left" in line for line in screen)
    assert any("● ◈ repeat forever" in line for line in screen)
    for label in ("front", "heading", "odometer", "tilt", "speed", "battery", "health", "mode"):
        assert f"│ {label}" in text
    assert "● running  ✔ succeeded  ✘ failed" in text
    session.keys("C-c")
    screen = session.wait_for("It was stopped at the end.")
    assert "Mission 'wander' interrupted" in "".join(screen)


def test_replay_plays_a_trace_in_the_terminal_view(tmp_path, tmux):
    trace = tmp_path / "run.jsonl"
    subprocess.run(
        [sys.executable, "-m", "autonomy", "run", "missions/square.yaml", "--fast", "--quiet", "--trace", str(trace)],
        cwd=ROOT,
        check=True,
        capture_output=True,
    )
    session = tmux(command("replay", str(trace), "--speed", "4"))
    screen = session.wait_for("replay x4")
    assert any("repeat x4" in line for line in screen)
    session.wait_for("✔ ◈ repeat x4", seconds=20)
    # the header says how it ended once the end record is drawn: a frame after the last tick's, at most
    # (a replay stays named one: a screen read late, the replay over, still says what it is)
    screen = session.wait_for(" square  replay x4  succeeded ", seconds=5)
    assert " square  replay x4  succeeded " in screen[0] and any("✔ ◈ repeat x4" in line for line in screen)
    screen = session.wait_for("Mission 'square' succeeded after 10.2 s")  # the screen is given back


def test_a_btlog_replays_in_the_terminal_view_with_no_made_up_telemetry(tmp_path, tmux):
    log = tmp_path / "run.btlog"
    subprocess.run(
        [sys.executable, "-m", "autonomy", "run", "missions/square.yaml", "--fast", "--quiet", "--btlog", str(log)],
        cwd=ROOT,
        check=True,
        capture_output=True,
    )
    session = tmux(command("replay", str(log), "--speed", "4"))
    screen = session.wait_for("not recorded")  # where the telemetry would be
    text = "\n".join(screen)
    assert "replay x4" in text and "repeat x4" in text and "move 300 mm" in text  # named as a trace names them
    assert "front" not in text and "battery" not in text
    session.wait_for("root SUCCESS", seconds=20)


def test_replay_without_a_terminal_prints_the_lines(tmp_path):
    trace = tmp_path / "run.jsonl"
    subprocess.run(
        [sys.executable, "-m", "autonomy", "run", "missions/square.yaml", "--fast", "--trace", str(trace)],
        cwd=ROOT,
        check=True,
        capture_output=True,
    )
    live = subprocess.run(
        [sys.executable, "-m", "autonomy", "run", "missions/square.yaml", "--fast"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    replayed = subprocess.run(
        [sys.executable, "-m", "autonomy", "replay", str(trace), "--speed", "10000"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert replayed.returncode == 0, replayed.stderr
    # the same lines, less "Running ..." and where the robot came to rest after the stop (past the run's records)
    lines = live.stdout.splitlines()[1:]
    rest = re.search(r" After the stop it came to rest where it stopped, at \(\d+, \d+\) mm\.", lines[-1])
    assert rest, lines[-1]
    assert replayed.stdout.splitlines() == [*lines[:-1], lines[-1].replace(rest[0], "")]


def big_header(children_per_node: int = 4, depth: int = 4) -> RunHeader:
    nodes: list[NodeInfo] = []

    def add(parent: int | None, level: int) -> None:
        node_id = len(nodes)
        leaf = level == depth
        nodes.append(
            NodeInfo(
                node_id, f"n{node_id}", "move" if leaf else "sequence", "action" if leaf else "composite", {}, parent
            )
        )
        if not leaf:
            for _ in range(children_per_node):
                add(node_id, level + 1)

    add(None, 0)
    return RunHeader("big", nodes, 20.0)


def test_a_big_tree_folds_to_fit_keeping_what_runs():
    header = big_header()
    assert len(header.nodes) == 341
    states = {n.id: NodeState("SUCCESS") for n in header.nodes}
    running_path = [0, 1, 2, 3, 4]  # the first child at each level, down to a leaf
    for node_id in running_path:
        states[node_id] = NodeState("RUNNING")
    lines = tree_lines(header, states, 14)
    assert len(lines) <= 14
    shown = [line.node for line in lines]
    assert shown[:5] == running_path  # the running branch, whole
    assert all(
        line.folded > 0
        for line in lines
        if line.node not in running_path and header.nodes[line.node].category == "composite"
    )
    assert len(tree_lines(header)) == 341  # unfolded when there is no limit


def test_line_output_never_writes_control_characters():
    from autonomy.protocol import Status as Packet
    from autonomy.record import Event, Pose, TickRecord
    from autonomy.views.lines import LinePrinter

    written: list[str] = []
    printer = LinePrinter(written.append)
    printer(RunHeader("m", [NodeInfo(0, "drive\x1b[2J", "move", "action", {}, None)], 20.0))
    packet = Packet(0, True, False, False, 0, 0, 255, 0)
    printer(
        TickRecord(
            1,
            0.0,
            packet,
            200,
            True,
            0.0,
            Pose(0, 0, 0),
            nodes={0: NodeState("RUNNING", "at \x07 once")},
            events=[Event("log", "bell\x07 and \u202eflip")],
        )
    )
    assert written and all(line.isprintable() for line in written)
    assert written[0].endswith("drive�[2J (at � once)") and written[1].endswith("log: bell� and �flip")


def test_grading_a_class_in_a_terminal_shows_a_progress_bar_then_the_marks_table(tmux):
    files = " ".join(
        shlex.quote(str(ROOT / "exercises" / folder / f"{name}.yaml"))
        for folder, name in (("solutions", "opening"), ("wrong", "opening_fixed"), ("wrong", "opening_straight"))
    )
    session = tmux(f"{shlex.quote(sys.executable)} -m autonomy grade opening {files} --workers 1")
    progress = session.wait_for("grading", seconds=20)
    assert any("/3" in line for line in progress), progress  # done / total while it works
    session.wait_for("marks out of 10", seconds=60)
    screen = session.wait_for("└", seconds=10)  # the table's last line: every row is drawn
    text = "\n".join(screen)
    assert "grading ━" not in text  # the bar is gone once the table is there
    rows = [[cell.strip() for cell in line.split("│")[1:-1]] for line in screen if line.startswith("│ opening")]
    assert rows == [
        ["opening", "10", "2", "4", "2", "2"],
        ["opening_fixed", "1.67", "0.33", "0.67", "0.33", "0.33"],
        ["opening_straight", "0", "0", "0", "0", "0"],
    ], screen
    assert all(len(line) <= 80 for line in screen)


@pytest.mark.parametrize("now", [1, 2, 20, 27, 39, 40])
def test_a_long_sequence_shows_the_step_that_runs_whatever_its_place(now):
    nodes = [NodeInfo(0, "root", "sequence", "composite", {}, None)]
    nodes += [NodeInfo(i, f"wait {i}", "wait", "action", {}, 0) for i in range(1, 41)]
    header = RunHeader("waits", nodes, 20.0)
    states = {i: NodeState("SUCCESS" if i < now else "INVALID") for i in range(1, 41)}
    states[0] = states[now] = NodeState("RUNNING")
    lines = tree_lines(header, states, 12)
    shown = [line.node for line in lines]
    assert len(lines) <= 12 and shown[0] == 0 and now in shown
    assert sum(line.folded for line in lines if line.node < 0) + len(shown) - shown.count(-1) == 41  # all accounted for
    at = shown.index(now)
    assert shown[at - 1] in (now - 1, -1, 0) and (at + 1 == len(shown) or shown[at + 1] in (now + 1, -1))


def test_a_terminal_too_small_for_the_live_view_says_what_size_it_needs():
    import io

    from rich.console import Console
    from rich.text import Text

    from autonomy.views.terminal import LiveView

    small = LiveView(Console(file=io.StringIO(), width=20, height=10, force_terminal=True))
    small.header = big_header()
    shown = small.render()
    assert isinstance(shown, Text)
    assert shown.plain == "big\nthe terminal is 20x10; the live view needs 60x16: make it bigger"
    enough = LiveView(Console(file=io.StringIO(), width=60, height=16, force_terminal=True))
    enough.header = big_header()
    assert not isinstance(enough.render(), Text)  # the whole view


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_folding_any_tree_keeps_the_limit_and_the_node_that_runs(data):
    size = data.draw(st.integers(1, 60))
    parents = [None] + [data.draw(st.integers(max(0, i - 3), i - 1)) for i in range(1, size)]
    nodes = [NodeInfo(i, f"n{i}", "sequence", "composite", {}, p) for i, p in enumerate(parents)]
    header = RunHeader("m", nodes, 20.0)
    deepest = data.draw(st.integers(0, size - 1))
    states = {i: NodeState(data.draw(st.sampled_from(["SUCCESS", "FAILURE", "INVALID"]))) for i in range(size)}
    node = deepest
    while node is not None:  # a running chain, the root down to one node
        states[node], node = NodeState("RUNNING"), parents[node]
    limit = data.draw(st.integers(1, 30))
    lines = tree_lines(header, states, limit)
    assert len(lines) <= limit
    assert deepest in [line.node for line in lines]  # the node that runs now is always on screen
    assert all(line.folded > 1 for line in lines if line.node < 0)  # one line left out is shown instead
    assert not any(a.node < 0 and b.node < 0 for a, b in pairwise(lines))

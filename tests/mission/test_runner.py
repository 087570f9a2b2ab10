"""The runner ends every run with the robot stopped, and says how it went."""

import io
import json

from py_trees.common import Status

from autonomy.behaviours import RobotAction
from autonomy.client import Client
from autonomy.emulator import Emulator
from autonomy.emulator.servers import TcpServer
from autonomy.protocol import Get, Move, Stop
from autonomy.runner import CRASHED, FAILED, INTERRUPTED, LINK_LOST, SUCCEEDED, TIME_LIMIT, Runner
from tests.harness import tree_of


def run(tree: str, query: str = "world=empty", **kwargs):
    client = Client.open(f"emu://?time=virtual&{query}")
    summary = Runner(tree_of(tree), client, mission="t", **kwargs).run()
    return summary, client.port.emulator


def last_motion(emulator: Emulator):
    return [c for c in emulator.commands() if not isinstance(c, Get)][-1]


class Explodes(RobotAction):
    node_type = ""

    def __init__(self, name: str, error: BaseException, after_ticks: int) -> None:
        super().__init__(name)
        self.error, self.after_ticks, self.ticks = error, after_ticks, 0

    def update(self) -> Status:
        self.ticks += 1
        if self.ticks > self.after_ticks:
            raise self.error
        return Status.RUNNING


def run_with(node, query: str = "world=empty") -> tuple:
    from py_trees.common import ParallelPolicy
    from py_trees.composites import Parallel

    client = Client.open(f"emu://?time=virtual&{query}")
    root = Parallel("p", policy=ParallelPolicy.SuccessOnAll(), children=[tree_of("  move: {speed: 2}\n"), node])
    return Runner(root, client, mission="t").run(), client.port.emulator


def test_success_ends_with_a_stop():
    summary, emulator = run("  move: {speed: 2, distance_mm: 100}\n")
    assert summary.outcome == SUCCEEDED and summary.stopped
    assert last_motion(emulator) == Stop()


def test_failure_names_the_failing_node_and_stops():
    summary, emulator = run("  sequence: [{move: {speed: 2}}]\n", "world=box")
    assert summary.outcome == FAILED
    assert summary.reason.startswith("'move' failed (collided after")
    assert summary.stopped and last_motion(emulator) == Stop()
    assert "1 collision" in summary.paragraph


def test_time_limit_halts_the_tree_and_stops():
    summary, emulator = run("  move: {speed: 1}\n", max_seconds=2.0)
    assert summary.outcome == TIME_LIMIT and 2.0 <= summary.time_s <= 2.1
    assert [c for c in emulator.commands() if not isinstance(c, Get)] == [Move(1), Stop(), Stop()]
    assert emulator.robot.mode == 0


def test_ctrl_c_stops_the_robot():
    summary, emulator = run_with(Explodes("boom", KeyboardInterrupt(), after_ticks=10))
    assert summary.outcome == INTERRUPTED and summary.stopped
    assert last_motion(emulator) == Stop() and emulator.robot.mode == 0


def test_an_exception_in_a_behaviour_stops_the_robot_and_is_reported():
    summary, emulator = run_with(Explodes("boom", ZeroDivisionError("plugin bug"), after_ticks=5))
    assert summary.outcome == CRASHED and summary.reason == "ZeroDivisionError: plugin bug"
    assert summary.stopped and last_motion(emulator) == Stop()


def test_a_lost_link_ends_the_run_without_hanging():
    server = TcpServer(Emulator("empty"), port=0).start()
    client = Client.open(server.url, timeout_s=0.1)
    root = tree_of("  sequence: [{move: {speed: 1}}]\n")
    runner = Runner(root, client, mission="t", on_tick=lambda r: server.stop() if r.tick == 3 else None)
    summary = runner.run()
    assert summary.outcome == LINK_LOST and "lost the link" in summary.reason
    assert summary.stopped is False and "NOT be confirmed" in summary.paragraph


def test_trace_has_a_header_and_a_line_per_tick():
    trace = io.StringIO()
    summary, _ = run("  sequence: [beep, {wait: {seconds: 0.2}}, {log: {message: done}}]\n", trace=trace)
    lines = [json.loads(line) for line in trace.getvalue().splitlines()]
    header, ticks = lines[0], lines[1:]
    assert [n["name"] for n in header["nodes"]] == ["sequence", "beep", "wait 0.2 s", "log done"]
    assert header["nodes"][1]["parent"] == 0
    assert len(ticks) == summary.ticks
    first = ticks[0]
    assert first["nodes"] == {"0": "RUNNING", "1": "SUCCESS", "2": "RUNNING"}
    assert first["commands"][:4] == [
        {"sent": "Gb000", "reply": "status"},
        {"sent": "GB000", "reply": "B230"},
        {"sent": "GR000", "reply": "OK"},
        {"sent": "S5793", "reply": "OK"},
    ]
    assert set(first["status"]) >= {"heading_deg", "front_distance_mm", "odometer_mm", "collided"}
    assert ticks[-1]["log"] == ["done"] and ticks[-1]["nodes"]["0"] == "SUCCESS"


def test_summary_paragraph_reads_well():
    summary, _ = run("  sequence: [{move: {speed: 2, distance_mm: 200}}, {turn: {left: 90}}, beep]\n")
    text = summary.paragraph
    assert text.startswith("Mission 't' succeeded after")
    assert "turned 90 degrees" in text and "1 move, 1 beep, 1 turn" in text and "It was stopped at the end." in text

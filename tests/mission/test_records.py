"""What each tick record says about the robot, checked against the packets and the clock behind it."""

from __future__ import annotations

import itertools
import math
import signal

import py_trees
import pytest
from py_trees.common import Status

from autonomy.behaviours import BATTERY_KEY, HEALTHY_KEY, STATUS_KEY, RobotAction
from autonomy.client import Client
from autonomy.clock import VirtualClock
from autonomy.emulator import Emulator
from autonomy.emulator.servers import TcpServer
from autonomy.runner import CRASHED, Runner
from tests.behaviours.test_actions import move
from tests.harness import Recorder, Rig, tree_of


def recorded(tree: str, url: str = "emu://?time=virtual&world=empty", **kwargs) -> tuple[Recorder, Runner]:
    recorder = Recorder()
    client = Client.open(url, clock=kwargs.pop("clock", None))
    runner = Runner(tree_of(tree), client, mission="t", listeners=[recorder], **kwargs)
    runner.run()
    return recorder, runner


def test_speed_is_the_odometer_step_over_the_time_step_and_nothing_on_the_first_tick():
    recorder, _ = recorded("  move: {speed: 3, seconds: 1}\n", clock=VirtualClock(1000.0))
    ticks = recorder.ticks
    assert ticks[0].time_s == 0.0 and ticks[0].speed_mm_s == 0.0
    for before, after in itertools.pairwise(ticks):
        step_mm = after.status.odometer_mm - before.status.odometer_mm
        assert after.speed_mm_s == pytest.approx(step_mm / (after.time_s - before.time_s))
    assert max(t.speed_mm_s for t in ticks) > 100


def test_over_a_lossy_link_the_speed_is_taken_between_the_packets_not_the_ticks():
    # A poll that needs retries brings a packet a quarter second or more after its tick began.
    recorder, _ = recorded(
        "  move: {speed: 2, seconds: 8}\n", "emu://?time=virtual&world=empty&faults=drop=0.02&seed=4"
    )
    retried = [t for t in recorder.ticks if any(e.attempt for e in t.wire)]
    assert retried and all(abs(t.speed_mm_s) <= 300 for t in recorder.ticks), max(
        abs(t.speed_mm_s) for t in recorder.ticks
    )


def test_the_dead_reckoned_heading_is_the_reported_heading_every_tick():
    recorder, _ = recorded("  sequence: [{turn: {right: 200}}, {move: {speed: 2, distance_mm: 100}}]\n")
    assert max(t.status.heading_deg for t in recorder.ticks) > 300  # it went past 0 to the right
    assert all(t.dead_reckoning.heading_deg == float(t.status.heading_deg) for t in recorder.ticks)


def test_a_run_on_a_robot_of_unknown_start_reckons_from_the_origin():
    server = TcpServer(Emulator("empty"), port=0).start()
    try:
        recorder, _ = recorded("  wait: {seconds: 0.1}\n", server.url)
    finally:
        server.stop()
    first = recorder.ticks[0]
    assert (first.dead_reckoning.x_mm, first.dead_reckoning.y_mm) == (0.0, 0.0) and first.truth is None


def test_a_collision_is_counted_once_and_logged_with_what_the_robot_read():
    recorder, runner = recorded("  move: {speed: 2}\n", "emu://?time=virtual&world=box")
    assert runner.summary.collisions == 1
    [said] = recorder.events("collision")
    status = next(t.status for t in recorder.ticks if t.status.collided)
    assert said == f"collision (front sensor {status.front_distance_mm} mm, heading {status.heading_deg} deg)"


def test_a_robot_already_against_a_wall_when_the_run_starts_counts_that_collision_once():
    first = Rig(move(speed=2), "world=box")
    first.tick_until_done()
    assert first.client.status().collided  # the flag is held while it touches the wall
    recorder = Recorder()
    runner = Runner(tree_of("  wait: {seconds: 0.2}\n"), first.client, mission="t", listeners=[recorder])
    summary = runner.run()
    assert summary.collisions == 1 and recorder.events("collision") == []


def test_a_jump_in_the_readings_is_logged_and_not_counted():
    rig = Rig(move(speed=1, seconds=0.5), "world=empty")
    recorder = Recorder()
    rig.runner.listeners.append(recorder)
    rig.tick()
    rig.robot.odometer_mm += 20000
    rig.tick_until_done()
    assert recorder.events("warning") == [
        "two status packets in a row disagreed with the one believed before: counting from them"
    ]
    jump = next(t for t in recorder.ticks if t.status.odometer_mm > 20000)
    assert jump.dead_reckoning.heading_deg == float(jump.status.heading_deg)


class ReadsBoard(RobotAction):
    """A behaviour written against the blackboard, as py_trees users do."""

    node_type = ""

    def update(self) -> Status:
        board = self.blackboard
        self.seen = (board.get(STATUS_KEY), board.get(BATTERY_KEY), board.get(HEALTHY_KEY))
        return Status.RUNNING


def test_the_blackboard_and_the_context_hold_what_was_polled_before_the_tick():
    node = ReadsBoard("board")
    rig = Rig(node, "world=empty&battery=77")
    recorder = Recorder()
    rig.runner.listeners.append(recorder)
    rig.tick(2)
    tick = recorder.ticks[-1]
    assert node.seen == (tick.status, tick.battery, tick.healthy) == rig.runner.context.polled
    assert tick.battery == 77 and tick.healthy is True


def test_with_py_trees_activity_stream_on_the_runner_s_writes_are_recorded_there():
    node = ReadsBoard("board")
    rig = Rig(node, "world=empty")
    py_trees.blackboard.Blackboard.enable_activity_stream()
    try:
        rig.tick(2)
        writes = [
            item.key
            for item in py_trees.blackboard.Blackboard.activity_stream.data
            if item.activity_type in ("WRITE", "INITIALISED")
        ]
    finally:
        py_trees.blackboard.Blackboard.disable_activity_stream()
    assert writes.count(STATUS_KEY) == 2 and node.seen[0] == rig.runner.context.polled[0]


def test_battery_and_health_are_asked_once_a_second_on_the_second():
    recorder, _ = recorded("  wait: {seconds: 10}\n", tick_hz=4.0, max_seconds=3.0)
    polled = [t.tick for t in recorder.ticks if "GB000" in [e.sent for e in t.wire]]
    healthy = [t.tick for t in recorder.ticks if "GR000" in [e.sent for e in t.wire]]
    assert len(recorder.ticks) == 13 and polled == healthy == [1, 5, 9, 13]  # at 0, 1, 2 and 3 s


def test_the_wire_shows_each_reply_as_text_and_a_lost_one_as_its_error():
    recorder, _ = recorded("  turn: {left: 160}\n", "emu://?time=virtual&world=empty&seed=1&faults=drop=0.01")
    replies = {exchange.reply for tick in recorder.ticks for exchange in tick.wire}
    assert {"status", "OK", "B230"} <= replies, replies  # a packet, an acknowledgement, the battery
    assert any(reply.startswith("error: no reply to ") for reply in replies), replies


class Interrupts(RobotAction):
    node_type = ""

    def update(self) -> Status:
        raise KeyboardInterrupt


def test_a_keyboard_interrupt_raised_by_a_behaviour_while_ctrl_c_is_handled_elsewhere_is_a_crash():
    """With a SIGINT handler of the program's own, a real Ctrl-C never reaches a behaviour as this."""
    previous = signal.signal(signal.SIGINT, lambda number, frame: None)
    try:
        recorder = Recorder()
        client = Client.open("emu://?time=virtual")
        summary = Runner(Interrupts("sneaky"), client, mission="t", listeners=[recorder]).run()
    finally:
        signal.signal(signal.SIGINT, previous)
    assert summary.outcome == CRASHED and summary.reason.startswith("node 'sneaky' ")
    assert "raised KeyboardInterrupt" in summary.reason and summary.stopped


def test_a_run_whose_setup_fails_lasted_no_time():
    from tests.mission.test_runner import SetupFails

    client = Client.open("emu://?time=virtual", clock=VirtualClock(50.0))
    summary = Runner(SetupFails("f"), client, mission="t", max_seconds=1.0).run()
    assert summary.outcome == CRASHED and summary.time_s == 0.0


def test_dead_reckoning_takes_each_step_along_the_heading_halfway_through_it():
    """A robot that turns as it drives (an arc): each step goes out at the mean of its two headings."""
    from tests.client.fakes import ScriptedPort
    from tests.client.test_client_faults import packet

    readings = [(90, 1000), (98, 1020), (106, 1040), (114, 1060), (122, 1075)]
    packets = [packet(odometer_mm=odometer, heading_deg=heading, moving=True) for heading, odometer in readings]
    packets.insert(0, packets[0])  # the first packet is asked twice: two must agree before one is believed

    def robot(frame: bytes) -> bytes:
        port.clock.sleep(0.05)  # a tick apart: the steps are plausible for a real robot
        if frame.startswith(b"Gb"):
            return packets.pop(0)
        return b"B200\n" if frame.startswith(b"GB") else b"OK\n"

    port = ScriptedPort(responder=robot)
    recorder = Recorder()
    runner = Runner(tree_of("  wait: {seconds: 60}\n"), Client(port, name="arc"), mission="t", listeners=[recorder])
    runner.setup()
    for _ in readings:
        runner.tick()
    x_mm = y_mm = 0.0
    for (before, odometer_before), (after, odometer_after) in itertools.pairwise(readings):
        middle = math.radians(before + (after - before) / 2)
        x_mm += (odometer_after - odometer_before) * math.cos(middle)
        y_mm += (odometer_after - odometer_before) * math.sin(middle)
    end = recorder.ticks[-1].dead_reckoning
    assert (end.x_mm, end.y_mm, end.heading_deg) == (
        pytest.approx(x_mm, abs=1e-9),
        pytest.approx(y_mm, abs=1e-9),
        122.0,
    )


def test_the_header_says_on_what_link_clock_and_faults_the_run_went():
    import autonomy
    from tests.client.fakes import ScriptedPort

    faulty, _ = recorded("  wait: {seconds: 0.1}\n", "emu://?time=virtual&world=empty&faults=drop=0.01")
    header = faulty.header
    assert (header.faults, header.baud, header.clock) == ("drop=0.01", 57600, "virtual")
    assert header.autonomy_version == autonomy.__version__ and header.world["name"] == "empty"
    clean, _ = recorded("  wait: {seconds: 0.05}\n", "emu://?world=empty")  # in real time
    assert (clean.header.faults, clean.header.clock) == ("none", "real")
    recorder = Recorder()
    port = ScriptedPort(responder=lambda frame: b"OK\n" if not frame.startswith(b"G") else None)
    runner = Runner(tree_of("  wait: {seconds: 1}\n"), Client(port, name="bare"), mission="t", listeners=[recorder])
    runner.setup()
    bare = recorder.header
    assert (bare.faults, bare.baud, bare.world, bare.seed, bare.port) == ("", 0, None, None, "bare")


def test_the_true_pose_is_the_emulators_heading_included():
    recorder, runner = recorded("  turn: {left: 90}\n")
    truth = recorder.ticks[-1].truth
    robot = runner.client.port.emulator.robot
    assert (truth.x_mm, truth.y_mm, truth.heading_deg) == pytest.approx((robot.x_mm, robot.y_mm, robot.heading_deg))
    assert 87 <= truth.heading_deg <= 93


def test_every_refused_command_is_counted():
    _, runner = recorded(
        "  selector: [{move: {speed: 1, seconds: 1}}, {move: {speed: 2, seconds: 1}}, beep]\n",
        "emu://?time=virtual&world=empty&mode=manual",
    )
    assert runner.summary.refused == 2 and runner.summary.commands["S"] == 1


def test_a_run_without_node_states_records_the_same_ticks_with_no_nodes():
    # What a grader runs: the records it judges (time, packets, poses, the wire, events) are the
    # run's own; only the nodes' changes are left out.
    tree = "  sequence: [{beep: {}}, {move: {speed: 2, distance_mm: 300}}, {turn: {left: 90}}]\n"
    url = "emu://?time=virtual&world=box&seed=3"
    full, _ = recorded(tree, url)
    bare, runner = recorded(tree, url, node_states=False)
    assert any(t.nodes for t in full.ticks) and not any(t.nodes for t in bare.ticks)
    assert len(bare.ticks) == len(full.ticks) > 20 and runner.summary.outcome == "succeeded"
    for a, b in zip(full.ticks, bare.ticks, strict=True):
        assert (a.tick, a.time_s, a.status, a.truth, a.dead_reckoning, a.speed_mm_s) == (
            b.tick,
            b.time_s,
            b.status,
            b.truth,
            b.dead_reckoning,
            b.speed_mm_s,
        )
        assert (a.wire, a.events) == (b.wire, b.events)


def _feedback_each_tick(tree: str, url: str, node_states: bool) -> tuple[list[dict[str, str]], Runner]:
    """Each leaf's feedback after every tick, as the tree holds it (whether or not records carry it)."""
    client = Client.open(url)
    seen: list[dict[str, str]] = []
    runner = Runner(tree_of(tree), client, mission="t", node_states=node_states)
    runner.listeners.append(
        lambda record: (
            seen.append({n.name: n.feedback_message for n in runner.root.iterate() if not n.children})
            if getattr(record, "tick", None) is not None
            else None
        )
    )
    runner.run()
    return seen, runner


def test_an_unwatched_run_leaves_out_what_nodes_say_while_running_but_never_why_they_ended():
    tree = "  sequence: [{wait: {seconds: 0.5}}, {move: {speed: 2, distance_mm: 200}}, {turn: {left: 90}}]\n"
    url = "emu://?time=virtual&world=empty"
    watched, _ = _feedback_each_tick(tree, url, node_states=True)
    unwatched, runner = _feedback_each_tick(tree, url, node_states=False)
    assert len(watched) == len(unwatched) and runner.summary.outcome == "succeeded"
    said = {name: {tick[name] for tick in watched} for name in watched[0]}
    quiet = {name: {tick[name] for tick in unwatched} for name in unwatched[0]}
    assert "0.3 s left" in said["wait 0.5 s"] and any(text.endswith("deg to go") for text in said["turn left 90 deg"])
    assert any(text.endswith("mm, front 255 mm") for text in said["move 200 mm"])
    assert quiet["wait 0.5 s"] == {"", "0.0 s left"}
    assert quiet["move 200 mm"] - {""} == {text for text in said["move 200 mm"] if text.startswith("drove")}
    assert quiet["turn left 90 deg"] - {""} == {text for text in said["turn left 90 deg"] if text.startswith("turned")}
    # why a run failed is the same either way
    crash = "  move: {speed: 4}\n"
    endings = [_feedback_each_tick(crash, "emu://?time=virtual&world=box", node_states=flag)[1] for flag in (1, 0)]
    assert endings[0].summary.reason == endings[1].summary.reason
    assert "failed (collided after" in endings[0].summary.reason


class Unprintable:
    def __str__(self) -> str:
        raise ValueError("no text")


class Mumbles(RobotAction):
    """Logs, and leaves a feedback of its own type that cannot be made text."""

    node_type = ""

    def update(self) -> Status:
        self.context.log("hello from the tick")
        self.feedback_message = Unprintable()
        return Status.SUCCESS


@pytest.mark.parametrize("node_states", [True, False])
def test_a_feedback_that_cannot_be_text_is_named_and_the_run_goes_on_whether_or_not_nodes_are_recorded(node_states):
    # a grader (no node states) and a run (node states) must end the same way
    recorder = Recorder()
    client = Client.open("emu://?time=virtual")
    runner = Runner(Mumbles("odd"), client, mission="t", listeners=[recorder], node_states=node_states)
    assert runner.run().outcome == "succeeded"
    shown = [t.nodes[0].feedback for t in recorder.ticks if 0 in t.nodes]
    assert shown == (["(a Unprintable that cannot be shown as text: ValueError)"] if node_states else [])


def test_a_tick_whose_record_fails_leaves_its_wire_and_events_to_the_end(monkeypatch):
    recorder = Recorder()
    client = Client.open("emu://?time=virtual")
    runner = Runner(Mumbles("odd"), client, mission="t", listeners=[recorder])

    calls = []

    def fails_once() -> None:  # in the first tick's record; the end's is asked for again
        calls.append(1)
        if len(calls) == 1:
            raise RuntimeError("no truth today")

    monkeypatch.setattr(runner, "_truth", fails_once)
    summary = runner.run()
    assert summary.outcome == CRASHED and "no truth today" in summary.reason and summary.stopped
    assert not recorder.ticks
    end = recorder.records[-1]
    assert [e.sent for e in end.wire][:3] == ["Gb000", "Gb000", "GB000"] and end.wire[-1].sent == "X0000"
    assert "hello from the tick" in [e.message for e in end.events]


def test_a_robot_standing_at_minus_zero_is_reckoned_at_zero_as_each_step_adds_its_nothing():
    from autonomy.emulator.world import Pose as WorldPose
    from autonomy.emulator.world import World

    client = Client.open("emu://?time=virtual")
    port = client.port
    port.emulator = Emulator(World("edge", 1000.0, 1000.0, WorldPose(-0.0, -0.0, 0.0)), clock=port.clock)
    recorder = Recorder()
    Runner(tree_of("  wait: {seconds: 0.2}\n"), client, mission="t", listeners=[recorder]).run()
    later = [t.dead_reckoning for t in recorder.ticks[1:]]
    assert later and all(math.copysign(1.0, p.x_mm) == 1.0 == math.copysign(1.0, p.y_mm) for p in later)

"""The runner ends every run with the robot stopped, and says how it went."""

import math
import signal

import pytest
from py_trees.common import Status

from autonomy.behaviours import RobotAction
from autonomy.client import Client
from autonomy.emulator import Emulator
from autonomy.emulator.servers import TcpServer
from autonomy.mission import build_tree, load_mission
from autonomy.protocol import Get, Move, Stop
from autonomy.record import TickRecord
from autonomy.runner import CRASHED, FAILED, INTERRUPTED, LINK_LOST, SUCCEEDED, TIME_LIMIT, Runner, settled_heap
from tests.harness import Recorder, tree_of


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


def test_ctrl_c_stops_the_robot(monkeypatch):
    # Ctrl-C as Python's own SIGINT handler raises it (a test runner may have installed its own).
    monkeypatch.setattr(signal, "getsignal", lambda signum: signal.default_int_handler)
    summary, emulator = run_with(Explodes("boom", KeyboardInterrupt(), after_ticks=10))
    assert summary.outcome == INTERRUPTED and summary.stopped and summary.reason == "Ctrl-C or SIGTERM"
    assert last_motion(emulator) == Stop() and emulator.robot.mode == 0


def test_an_exception_in_a_behaviour_stops_the_robot_and_is_reported():
    summary, emulator = run_with(Explodes("boom", ZeroDivisionError("plugin bug"), after_ticks=5))
    assert summary.outcome == CRASHED
    assert summary.reason.startswith("node 'boom' (explodes) raised ZeroDivisionError: plugin bug at tests/mission/")
    assert summary.stopped and last_motion(emulator) == Stop()


def test_a_lost_link_ends_the_run_without_hanging():
    server = TcpServer(Emulator("empty"), port=0).start()
    client = Client.open(server.url, timeout_s=0.1)
    root = tree_of("  sequence: [{move: {speed: 1}}]\n")
    stop_at_tick_3 = lambda r: server.stop() if isinstance(r, TickRecord) and r.tick == 3 else None  # noqa: E731
    runner = Runner(root, client, mission="t", listeners=[stop_at_tick_3])
    summary = runner.run()
    assert summary.outcome == LINK_LOST and "lost the link" in summary.reason
    assert summary.stopped is False and "NOT be confirmed" in summary.paragraph


def test_records_a_header_a_record_per_tick_and_an_end():
    recorder = Recorder()
    summary, _ = run("  sequence: [beep, {wait: {seconds: 0.2}}, {log: {message: done}}]\n", listeners=[recorder])
    header, ticks, end = recorder.header, recorder.ticks, recorder.end
    assert [n.name for n in header.nodes] == ["sequence", "beep", "wait 0.2 s", "log done"]
    assert [(n.type, n.parent, n.file, n.line) for n in header.nodes] == [
        ("sequence", None, "test.yaml", 3),
        ("beep", 0, "test.yaml", 3),
        ("wait", 0, "test.yaml", 3),
        ("log", 0, "test.yaml", 3),
    ]
    assert header.world["name"] == "empty" and header.seed == 0 and header.clock == "virtual"
    assert header.port.startswith("emu://") and header.baud == 57600 and header.date[:2] == "20"
    assert len(ticks) == summary.ticks and [t.tick for t in ticks] == list(range(1, summary.ticks + 1))
    first = ticks[0]
    assert {k: v.status for k, v in first.nodes.items()} == {0: "RUNNING", 1: "SUCCESS", 2: "RUNNING"}
    assert first.nodes[2].feedback.endswith("s left")
    assert [(e.sent, e.reply) for e in first.wire[:5]] == [
        ("Gb000", "status"),
        ("Gb000", "status"),  # the link's first packet is trusted once a second agrees
        ("GB000", "B230"),
        ("GR000", "OK"),
        ("S5793", "OK"),
    ]
    assert 0 not in ticks[1].nodes and 1 not in ticks[1].nodes  # only what changed is recorded
    assert ticks[-1].events[0].message == "done" and ticks[-1].nodes[0].status == "SUCCESS"
    assert end.outcome == SUCCEEDED and end.stopped and [e.sent for e in end.wire] == ["X0000"]
    assert end.summary["requests"] == summary.requests == sum(1 for r in [*ticks, end] for e in r.wire if not e.attempt)


def test_every_request_and_retry_the_summary_counts_is_recorded():
    recorder = Recorder()
    summary, _ = run("  move: {speed: 2, seconds: 1}\n", "world=empty&faults=drop=0.05&seed=4", listeners=[recorder])
    wire = [e for r in recorder.records[1:] for e in r.wire]
    assert summary.retries > 0
    assert summary.requests == sum(1 for e in wire if e.attempt == 0)
    assert summary.retries == sum(1 for e in wire if e.attempt > 0)
    assert summary.commands["F"] == sum(1 for e in wire if e.sent.startswith("F") and e.attempt == 0)


def test_manual_mode_counts_intended_commands_and_retries_apart():
    summary, _ = run("  move: {speed: 2, seconds: 1}\n", "world=empty&mode=manual")
    assert summary.commands["F"] == 1 and summary.retries == 3 and summary.refused == 1
    assert "1 move" in summary.paragraph and "3 retries, 1 refused" in summary.paragraph


def test_dead_reckoning_follows_the_truth_on_a_square():
    recorder = Recorder()
    tree = (
        "  repeat:\n    times: 4\n    do:\n      sequence: [{move: {speed: 2, distance_mm: 300}}, {turn: {left: 90}}]\n"
    )
    run(tree, "world=box", listeners=[recorder])
    for tick in recorder.ticks:
        assert abs(tick.dead_reckoning.x_mm - tick.truth.x_mm) < 15
        assert abs(tick.dead_reckoning.y_mm - tick.truth.y_mm) < 15
    xs = [t.truth.x_mm for t in recorder.ticks]
    assert max(xs) - min(xs) > 300  # it drove a square of about 325 mm sides
    last = recorder.ticks[-1]
    assert math.hypot(last.truth.x_mm - 1000, last.truth.y_mm - 1000) < 40


def test_a_plugin_exception_names_the_node_file_and_line(tmp_path):
    (tmp_path / "crashing.py").write_text(
        "from py_trees.common import Status\nfrom autonomy.behaviours import RobotAction\n\n\n"
        "class Divide(RobotAction):\n    node_type = 'divide'\n    doc = 'Divides by zero.'\n\n"
        "    def update(self):\n        self.feedback_message = 'dividing'\n        return 1 / 0\n"
    )
    mission = tmp_path / "m.yaml"
    mission.write_text("mission: m\nplugins: [crashing]\ntree:\n  sequence:\n    - beep\n    - divide\n")
    spec = load_mission(mission)
    recorder = Recorder()
    client = Client.open("emu://?time=virtual")
    summary = Runner(build_tree(spec), client, mission="m", listeners=[recorder]).run()
    assert summary.outcome == CRASHED and summary.stopped
    [event] = [e for e in recorder.end.events if e.kind == "exception"]
    assert event.node == 2 and event.where == f"{mission}:6"
    assert event.message.startswith(f"node 'divide' (divide, {mission}:6) raised ZeroDivisionError: division by zero")
    assert event.frames[-1].endswith("crashing.py:11 in update: return 1 / 0")
    assert "Traceback (most recent call last)" in event.traceback


def test_summary_paragraph_reads_well():
    summary, _ = run("  sequence: [{move: {speed: 2, distance_mm: 200}}, {turn: {left: 90}}, beep]\n")
    text = summary.paragraph
    assert text.startswith("Mission 't' succeeded after")
    assert "turned 90 degrees" in text and "1 move, 1 beep, 1 turn" in text and "It was stopped at the end." in text


def test_a_plugin_calling_sys_exit_ends_the_run_as_an_error_with_the_robot_stopped(tmp_path):
    (tmp_path / "quitter.py").write_text(
        "import sys\nfrom autonomy.behaviours import RobotAction\n\n\n"
        "class Quit(RobotAction):\n    node_type = 'quit'\n    doc = 'Exits.'\n\n"
        "    def update(self):\n        sys.exit(0)\n"
    )
    mission = tmp_path / "q.yaml"
    mission.write_text("mission: q\nplugins: [quitter]\ntree:\n  parallel:\n    - move: {speed: 1}\n    - quit\n")
    client = Client.open("emu://?time=virtual")
    summary = Runner(build_tree(load_mission(mission)), client, mission="q").run()
    assert summary.outcome == CRASHED and "raised SystemExit: 0" in summary.reason
    assert summary.stopped and last_motion(client.port.emulator) == Stop()


def test_the_time_limit_is_kept_when_ticks_are_further_apart_than_it():
    summary, _ = run("  wait: {seconds: 30}\n", tick_hz=1.0, max_seconds=0.3)
    assert summary.outcome == TIME_LIMIT and summary.time_s == pytest.approx(0.3, abs=0.01)


def test_a_crash_deep_in_a_plugin_shows_its_last_three_frames_and_the_whole_traceback(tmp_path):
    (tmp_path / "deep.py").write_text(
        "from autonomy.behaviours import RobotAction\n\n\n"
        "def one():\n    return two()\n\n\ndef two():\n    return three()\n\n\ndef three():\n    return 1 / 0\n\n\n"
        "class Deep(RobotAction):\n    node_type = 'deep'\n\n    def update(self):\n        return one()\n"
    )
    mission = tmp_path / "m.yaml"
    mission.write_text("mission: m\nplugins: [deep]\ntree: deep\n")
    recorder = Recorder()
    client = Client.open("emu://?time=virtual")
    summary = Runner.for_mission(load_mission(mission), client, listeners=[recorder]).run()
    [event] = [e for e in recorder.end.events if e.kind == "exception"]
    assert [frame.rsplit(":", 1)[0].split(" in ")[1] for frame in event.frames] == ["one", "two", "three"]
    assert event.frames[-1].endswith("deep.py:13 in three: return 1 / 0")
    assert summary.reason == event.message and event.message.endswith(
        "raised ZeroDivisionError: division by zero at " + event.frames[-1].split(": ", 1)[0]
    )
    assert event.traceback.startswith("Traceback (most recent call last)")
    assert event.traceback.rstrip().endswith("ZeroDivisionError: division by zero")


def test_a_runner_for_a_mission_carries_its_name_file_hash_rate_and_limit(tmp_path):
    mission = tmp_path / "m.yaml"
    mission.write_text("mission: named\ntick_hz: 10\ntree:\n  wait: {seconds: 30}\n")
    spec = load_mission(mission)
    recorder = Recorder()
    client = Client.open("emu://?time=virtual")
    runner = Runner.for_mission(spec, client, max_seconds=0.5, listeners=[recorder])
    summary = runner.run()
    header = recorder.header
    assert (header.mission, header.mission_file, header.mission_sha256) == ("named", str(mission), spec.sha256)
    assert len(spec.sha256) == 64 and header.tick_hz == 10 and summary.tick_hz == 10
    assert summary.outcome == TIME_LIMIT and summary.time_s == pytest.approx(0.5, abs=0.11)


def test_a_crash_in_a_helper_object_is_still_put_on_the_node_that_called_it(tmp_path):
    (tmp_path / "helped.py").write_text(
        "from autonomy.behaviours import RobotAction\n\n\n"
        "class Helper:\n    def compute(self):\n        return {}['missing']\n\n\n"
        "class Helped(RobotAction):\n    node_type = 'helped'\n\n"
        "    def update(self):\n        return Helper().compute()\n"
    )
    mission = tmp_path / "m.yaml"
    mission.write_text("mission: m\nplugins: [helped]\ntree: {sequence: [beep, helped]}\n")
    recorder = Recorder()
    summary = Runner.for_mission(load_mission(mission), Client.open("emu://?time=virtual"), listeners=[recorder]).run()
    [event] = [e for e in recorder.end.events if e.kind == "exception"]
    assert event.node == 2 and event.message.startswith("node 'helped' (helped, ")
    assert "raised KeyError: 'missing'" in summary.reason


def test_a_crash_in_a_generator_over_other_nodes_is_put_on_the_node_whose_code_raised(tmp_path):
    # the generator's frame has no self, and a local called node that is another node of the tree
    (tmp_path / "limits.py").write_text(
        "from autonomy.behaviours import RobotCondition\n\n\n"
        "class Limit(RobotCondition):\n    node_type = 'limit'\n\n"
        "    def check(self):\n"
        "        return 0 < min(node.args['mm'] for node in self.parent.children)\n"
    )
    mission = tmp_path / "m.yaml"
    mission.write_text("mission: m\nplugins: [limits]\ntree: {sequence: [beep, limit]}\n")
    summary = Runner.for_mission(load_mission(mission), Client.open("emu://?time=virtual")).run()
    assert summary.outcome == CRASHED and summary.reason.startswith("node 'limit' (limit, "), summary.reason


def test_the_failing_node_named_is_the_leaf_that_failed_not_a_sibling_it_stopped():
    summary, _ = run("  sequence: [{move: {speed: 2}}, beep, stop]\n", "world=box")
    assert summary.outcome == FAILED and summary.reason.startswith("'move' failed (collided after")


def test_a_listener_that_raises_ends_the_run_as_a_crash_with_the_robot_stopped():
    def listener(record):
        if isinstance(record, TickRecord) and record.tick == 3:
            raise RuntimeError("the disk caught fire")

    client = Client.open("emu://?time=virtual&world=empty")
    recorder = Recorder()
    summary = Runner(tree_of("  move: {speed: 2}\n"), client, mission="t", listeners=[listener, recorder]).run()
    assert (summary.outcome, summary.reason, summary.stopped) == (CRASHED, "RuntimeError: the disk caught fire", True)
    assert last_motion(client.port.emulator) == Stop()
    crash = [e for e in recorder.end.events if e.kind == "exception"]
    assert [e.message for e in crash] == ["RuntimeError: the disk caught fire"]
    assert "Traceback" in crash[0].traceback and "RuntimeError: the disk caught fire" in crash[0].traceback
    assert client.listeners == []  # the runner's own listener is taken off the client


def test_a_runner_for_a_mission_carries_its_name_file_hash_rate_and_time_limit():
    spec = load_mission("missions/square.yaml")
    client = Client.open("emu://?time=virtual&world=box")
    recorder = Recorder()
    summary = Runner.for_mission(spec, client, max_seconds=1.0, listeners=[recorder]).run()
    header = recorder.header
    assert (header.mission, header.mission_file, header.mission_sha256) == (spec.name, spec.source, spec.sha256)
    assert header.tick_hz == spec.tick_hz == 20 and len(spec.sha256) == 64
    assert summary.outcome == TIME_LIMIT and summary.time_s == pytest.approx(1.0, abs=0.06)
    assert summary.reason == "the mission was still running after 1 s"
    assert summary.to_json()["commands"] == {"F": 1, "X": 2}  # the move, its stop, the final stop


def test_link_errors_counted_are_this_runs_only():
    client = Client.open("emu://?time=virtual&world=empty")
    client.stats.framing_errors, client.stats.implausible = 5, 7  # what an earlier run on this link saw
    summary = Runner(tree_of("  move: {speed: 2, seconds: 1}\n"), client, mission="t").run()
    assert (summary.framing_errors, summary.implausible) == (0, 0)
    client.stats.framing_errors += 2
    assert Runner(tree_of("  beep\n"), client, mission="t").run().framing_errors == 0


def test_a_crash_inside_a_built_in_node_still_shows_the_frames_where_it_happened():
    """Every frame is the package's own: they are shown all the same, ending where it raised."""
    from autonomy.behaviours.actions import Beep

    recorder = Recorder()
    client = Client.open("emu://?time=virtual")
    summary = Runner(Beep("beep", tones=None, volume=3), client, mission="t", listeners=[recorder]).run()
    [event] = [e for e in recorder.end.events if e.kind == "exception"]
    assert summary.outcome == CRASHED and 1 <= len(event.frames) <= 3  # mutation testing adds frames of its own
    assert "tuple(self.args" in event.traceback  # where it raised, in actions.py
    assert event.message.startswith("node 'beep' (beep) raised TypeError: ")
    assert event.message.endswith(" at " + event.frames[-1].split(": ", 1)[0])


def test_a_crashed_behaviour_error_reads_as_its_event():
    from autonomy.record import Event
    from autonomy.runner import BehaviourCrashed

    event = Event("exception", "node 'x' (x) raised ValueError: no", 0, "", (), "")
    assert str(BehaviourCrashed(event)) == "node 'x' (x) raised ValueError: no"


def test_a_decorator_that_fails_over_a_child_that_succeeded_is_the_one_named():
    summary, _ = run("  sequence: [beep, {invert: {do: stop}}]\n")
    assert summary.outcome == FAILED and summary.reason == "'invert' failed (success -> failure)"


def test_the_end_record_says_what_the_summary_says():
    recorder = Recorder()
    client = Client.open("emu://?time=virtual&world=empty")
    summary = Runner(tree_of("  move: {speed: 2, distance_mm: 100}\n"), client, mission="t", listeners=[recorder]).run()
    end = recorder.end
    assert (end.outcome, end.reason, end.stopped, end.time_s) == (
        summary.outcome,
        summary.reason,
        summary.stopped,
        summary.time_s,
    )
    assert end.paragraph == summary.paragraph and "It was stopped at the end." in end.paragraph
    robot = client.port.emulator.robot
    assert end.truth is not None and (end.truth.x_mm, end.truth.y_mm) == pytest.approx((robot.x_mm, robot.y_mm), abs=1)
    assert recorder.events("stop") == ["the robot acknowledged the stop"]


def test_a_stop_the_robot_never_acknowledged_is_logged_as_such():
    from tests.mission.test_blind_spots import Meddling

    recorder = Recorder()
    client = Client(Meddling(refuse_stop=True), retries=0, stop_tries=2)
    summary = Runner(tree_of("  wait: {seconds: 0.2}\n"), client, mission="t", listeners=[recorder]).run()
    assert not summary.stopped and recorder.events("stop") == ["the robot did not acknowledge the stop"]


class SetupFails(RobotAction):
    node_type = ""

    def setup(self, **kwargs) -> None:
        raise RuntimeError("no servo here")

    def update(self) -> Status:
        return Status.SUCCESS


def test_a_run_whose_setup_fails_still_records_how_it_began_and_ended():
    recorder = Recorder()
    client = Client.open("emu://?time=virtual")
    summary = Runner(SetupFails("fussy"), client, mission="t", tick_hz=10, listeners=[recorder]).run()
    assert summary.outcome == CRASHED and summary.reason == "RuntimeError: no servo here"
    header, end = recorder.header, recorder.end
    assert (header.mission, header.tick_hz, [n.name for n in header.nodes]) == ("t", 10, ["fussy"])
    assert recorder.records == [header, end] and end.reason == summary.reason and end.stopped


class HaltFails(RobotAction):
    node_type = ""

    def update(self) -> Status:
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID:
            raise RuntimeError("stuck")


def test_halting_leaves_every_node_invalid_and_a_node_that_raises_is_logged_not_obeyed():
    client = Client.open("emu://?time=virtual")
    root = tree_of("  sequence: [beep, {parallel: {children: [{move: {speed: 1}}, {wait: {seconds: 9}}]}}]\n")
    runner = Runner(root, client, mission="t", max_seconds=0.5)
    assert runner.run().outcome == TIME_LIMIT
    assert [node.status for node in root.iterate()] == [Status.INVALID] * len(list(root.iterate()))
    recorder = Recorder()
    summary = Runner(HaltFails("sticky"), client, mission="t", max_seconds=0.5, listeners=[recorder]).run()
    assert summary.outcome == TIME_LIMIT and summary.stopped
    assert recorder.events("warning") == ["halting the tree raised RuntimeError: stuck"]


def test_a_settled_heap_collects_first_then_leaves_everything_out_of_collections_until_it_ends():
    import gc
    import weakref

    class Cycle:
        pass

    garbage = Cycle()
    garbage.me = garbage  # garbage only a collection finds
    gone = weakref.ref(garbage)
    del garbage
    frozen_during = []

    class Looks(RobotAction):
        node_type = ""

        def update(self) -> Status:
            frozen_during.append(gc.get_freeze_count())
            raise RuntimeError("boom")

    before = gc.get_freeze_count()
    with settled_heap():
        assert gone() is None  # collected before the rest was frozen
        summary = Runner(Looks("looks"), Client.open("emu://?time=virtual"), mission="t").run()
    assert frozen_during and frozen_during[0] > before and gc.get_freeze_count() == before
    assert summary.outcome == CRASHED and summary.stopped


def test_a_run_itself_leaves_collections_alone_so_runs_one_after_another_free_their_garbage():
    import gc

    frozen_during = []

    class Looks(RobotAction):
        node_type = ""

        def update(self) -> Status:
            frozen_during.append(gc.get_freeze_count())
            return Status.SUCCESS

    before = gc.get_freeze_count()
    for _ in range(3):  # as a grading worker runs its seeds
        Runner(Looks("looks"), Client.open("emu://?time=virtual"), mission="t").run()
    assert frozen_during == [before] * 3


def test_a_tick_before_setup_is_refused_in_words():
    runner = Runner(tree_of("  beep\n"), Client.open("emu://?time=virtual"), mission="t")
    with pytest.raises(RuntimeError, match=r"call setup\(\) first"):
        runner.tick()
    runner.setup()
    assert runner.tick() == Status.SUCCESS


def test_two_polls_at_the_same_instant_read_as_standing_still():
    # In virtual time an in-process emulator answers at once: two ticks without a sleep between
    # them poll at the same instant, and the speed between them is 0, not a division by zero.
    recorder = Recorder()
    runner = Runner(tree_of("  move: {speed: 2}\n"), Client.open("emu://?time=virtual"), listeners=[recorder])
    runner.setup()
    runner.tick()
    runner.client.clock.sleep(0.5)
    runner.tick()
    runner.tick()
    assert recorder.ticks[1].speed_mm_s > 0 and recorder.ticks[2].speed_mm_s == 0.0


def _plugin_mission(tmp_path, source: str, tree: str):
    (tmp_path / "plug.py").write_text(source)
    mission = tmp_path / "m.yaml"
    mission.write_text(f"mission: m\nplugins: [plug]\ntree: {tree}\n")
    return load_mission(mission)


def test_a_crash_on_a_line_that_holds_a_colon_is_placed_by_its_file_and_line(tmp_path):
    spec = _plugin_mission(
        tmp_path,
        "from autonomy.behaviours import RobotAction\n\n\nclass Look(RobotAction):\n    node_type = 'look'\n\n"
        "    def update(self):\n        return {'a': 1}['b']\n",
        "{sequence: [beep, look]}",
    )
    recorder = Recorder()
    summary = Runner.for_mission(spec, Client.open("emu://?time=virtual"), listeners=[recorder]).run()
    [event] = [e for e in recorder.end.events if e.kind == "exception"]
    assert event.frames[-1].endswith("plug.py:8 in update: return {'a': 1}['b']")
    assert summary.reason.endswith("raised KeyError: 'b' at " + event.frames[-1].split(": ", 1)[0])
    assert summary.reason.endswith("plug.py:8 in update")
    lines = event.traceback.splitlines()  # the whole traceback, as Python prints it
    assert lines[0] == "Traceback (most recent call last):" and lines[-1] == "KeyError: 'b'"
    assert all(line.startswith(("Traceback", "  ", "KeyError")) for line in lines)


def test_a_crash_under_a_composite_with_its_own_tick_is_put_on_the_leaf_that_raised():
    from py_trees.composites import Sequence

    class Wrapped(Sequence):  # ticked through its own generator, not by the tick engine
        def tick(self):
            yield from super().tick()

    class Divide(RobotAction):
        node_type = ""

        def update(self) -> Status:
            return 1 / 0  # type: ignore[return-value]

    root = Wrapped("wrapped", memory=False, children=[Divide("divide")])
    summary = Runner(root, Client.open("emu://?time=virtual"), mission="t").run()
    assert summary.outcome == CRASHED and summary.reason.startswith("node 'divide'"), summary.reason


def test_a_crash_in_an_update_without_self_is_put_on_the_node_the_engine_was_settling():
    from py_trees.behaviours import Success
    from py_trees.composites import Sequence
    from py_trees.decorators import Decorator

    class Plain(Decorator):
        update = staticmethod(lambda: 1 / 0)  # no frame of its own holds the node as self

    root = Sequence("seq", memory=False, children=[Success("ok"), Plain("plain", child=Success("inner"))])
    summary = Runner(root, Client.open("emu://?time=virtual"), mission="t").run()
    assert summary.outcome == CRASHED and summary.reason.startswith("node 'plain'"), summary.reason

"""Trace files: written whole line by line, read back into the same records, cut-off traces, bad input."""

from __future__ import annotations

import io
import json
import math
import re
import signal
import subprocess
import sys
import time

import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from autonomy.client import Client
from autonomy.clock import VirtualClock
from autonomy.mission import build_tree, load_mission
from autonomy.protocol import Status as Packet
from autonomy.record import (
    RECORD_VERSION,
    Exchange,
    NodeInfo,
    NodeState,
    Pose,
    RunEnd,
    RunHeader,
    TickRecord,
    record_from_json,
    to_line,
)
from autonomy.runner import Runner
from autonomy.trace import FlushTimer, TraceError, TraceWriter, read_trace, replay
from tests.harness import Recorder
from tests.views.conftest import ROOT


def run_and_record(tmp_path, mission: str = "missions/beep_on_collision.yaml"):
    spec = load_mission(ROOT / mission)
    path = tmp_path / "run.jsonl"
    recorder = Recorder()
    client = Client.open(f"emu://?time=virtual&world={spec.world or 'box'}")
    with open(path, "w", encoding="utf-8") as stream:
        Runner(build_tree(spec), client, mission=spec.name, listeners=[recorder, TraceWriter(stream)]).run()
    return path, recorder


def test_a_replay_produces_the_same_records_as_the_run(tmp_path):
    path, recorder = run_and_record(tmp_path)
    trace = read_trace(path)
    assert trace.end is not None and trace.cut_off_line == 0
    replayed = Recorder()
    replay(trace, replayed)
    assert len(replayed.records) == len(recorder.records)
    for live, again in zip(recorder.records, replayed.records, strict=True):
        assert to_line(live) == to_line(again)
        assert json.loads(to_line(live)) == json.loads(json.dumps(live.to_json()))  # the fast encoder agrees
        if isinstance(live, TickRecord):  # every number exactly as the run had it: a replay is the run again
            assert again == live and again.status.raw == live.status.raw and len(live.status.raw) == 9
    assert replayed.ticks[5].status == recorder.ticks[5].status  # the packet itself, raw bytes included
    assert any(e.kind == "collision" for t in replayed.ticks for e in t.events)


def test_a_trace_of_record_version_1_is_still_read(tmp_path):
    # version 1 rounded its numbers, wrote a packet's bytes in hex and every tick's nodes and wire
    header = json.loads(to_line(RunHeader("m", [NodeInfo(0, "root", "sequence", "composite", {}, None)], 20.0)))
    tick = (
        '{"type":"tick","tick":1,"time_s":0.0500,"status":{"mode":1,"auto_mode":true,"collided":false,'
        '"moving":true,"tilt_deg":2,"heading_deg":45,"front_distance_mm":255,"odometer_mm":2,'
        '"raw":"625102002dff00020a"},"battery":230,"healthy":true,"speed_mm_s":40.0,'
        '"dead_reckoning":[501.4,501.4,45.0],"nodes":{"0":["RUNNING"]},"wire":[["Gb000","status"]],'
        '"truth":[501.5,501.5,45.0]}'
    )
    path = tmp_path / "old.jsonl"
    path.write_text(json.dumps(header | {"version": 1}) + "\n" + tick + "\n")
    old = read_trace(path).ticks[0]
    assert old.status.raw == bytes.fromhex("625102002dff00020a") and old.status.odometer_mm == 2
    assert old.nodes == {0: NodeState("RUNNING")} and old.wire == [Exchange("Gb000", "status")]
    assert old.truth == Pose(501.5, 501.5, 45.0)


def test_a_trace_cut_off_mid_line_is_read_to_its_last_whole_line(tmp_path):
    path, recorder = run_and_record(tmp_path)
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(lines[:50]) + lines[50][:37])
    trace = read_trace(path)
    assert trace.end is None and len(trace.ticks) == 49 and trace.cut_off_line == 51


def test_a_run_killed_with_sigkill_leaves_a_readable_trace(tmp_path):
    trace_path = tmp_path / "killed.jsonl"
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "run", "missions/wander.yaml", "--quiet", "--trace", str(trace_path)],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and (not trace_path.exists() or trace_path.read_text().count("\n") < 20):
        time.sleep(0.05)
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=10)
    trace = read_trace(trace_path)
    assert trace.header.mission == "wander" and len(trace.ticks) >= 19 and trace.end is None


@pytest.mark.parametrize(
    "content, message",
    [
        ("", "empty: no header line"),
        ('{"type": "tick"}\n', ":1: a tick record with a missing or malformed field"),
        ("not json\n{}\n", ":1: not JSON"),
        ('{"type": "header", "version": 99, "mission": "m", "nodes": [], "tick_hz": 20}\n', "record version 99"),
        ('{"type": "header", "mission": "m", "nodes": [], "tick_hz": NaN}\n', ":1: NaN is not a number a trace holds"),
        ("[1, 2]\n", ":1: not a record"),
    ],
)
def test_bad_traces_are_refused_with_file_and_line(tmp_path, content, message):
    path = tmp_path / "bad.jsonl"
    path.write_text(content)
    with pytest.raises(TraceError, match=message.replace("(", r"\(")) as caught:
        read_trace(path)
    assert str(caught.value).startswith(str(path))


#: Numbers written into a line as they are: one of more digits than Python turns into text by
#: default, and one too big for a float (JSON has no infinity; a reader takes 1e999 as one).
FIVE_THOUSAND_DIGITS, TOO_BIG = "<five thousand digits>", "<1e999>"
AS_WRITTEN = {FIVE_THOUSAND_DIGITS: "1" + "0" * 4999, TOO_BIG: "1e999"}
#: A line of a real trace changed (0: the header, 20: a tick, -1: the end), and what reading it then says.
DAMAGED = {
    "an unknown node": (
        20,
        lambda t: t.update(nodes={"99": ["RUNNING"]}),
        ":21: tick 20 names node 99, not in",
    ),
    "NaN in a pose": (20, lambda t: t.update(dead_reckoning=[float("nan"), 1, 2]), ":21: NaN is not a number"),
    "infinity": (20, lambda t: t.update(battery=float("inf")), ":21: Infinity is not a number a trace holds"),
    "a huge battery": (20, lambda t: t.update(battery=1e300), ":21: battery must be a whole number from 0 to 255"),
    "an unknown status": (
        20,
        lambda t: t.update(nodes={"1": ["SKIPPED"]}),
        ":21: a node's state is [status",
    ),
    "NaN in a parameter": (0, lambda h: h["nodes"][1]["params"].update(speed=float("nan")), ":1: NaN is not a number"),
    "an empty arena": (
        0,
        lambda h: h["world"].update(arena_mm=[0, 0]),
        ":1: the header's world is not valid: arena_mm[0]: must be from 1",
    ),
    "nodes numbered from 1": (
        0,
        lambda h: [n.update(id=n["id"] + 1) for n in h["nodes"]],
        ":1: the header's nodes are numbered 0, 1, 2... in order; node 0 is numbered 1",
    ),
    "a parent after its child": (
        0,
        lambda h: h["nodes"][1].update(parent=5),
        ":1: node 1's parent must be",
    ),
    "a world by name": (
        0,
        lambda h: h.update(world="box"),
        ":1: the header's world is a world file's",
    ),
    "an infinite truth": (
        20,
        lambda t: t.update(truth=[TOO_BIG, 1, 2]),
        ":21: a pose is [x_mm, y_mm, heading_deg], three",
    ),
    "a 400-digit pose": (20, lambda t: t.update(truth=[10**400, 1, 2]), ":21: a pose is [x_mm, y_mm, heading_deg]"),
    "a 400-digit time": (20, lambda t: t.update(time_s=10**400), ":21: time_s must be a finite number"),
    "a 5000-digit time": (20, lambda t: t.update(time_s=FIVE_THOUSAND_DIGITS), ":21: not a trace line a reader takes"),
    "an infinite end": (-1, lambda e: e.update(truth=[TOO_BIG, 1, 2]), ":{end}: a pose is [x_mm, y_mm, heading_deg]"),
    "an infinite summary": (-1, lambda e: e["summary"].update(distance_mm=TOO_BIG), ":{end}: summary.distance_mm must"),
    "a packet of 3 bytes": (20, lambda t: t["status"].update(raw="AAAA"), ":21: a status packet is 9 bytes"),
    "a wire entry that is a text": (20, lambda t: t.update(wire=["Gb000"]), ":21: a wire entry is [sent, reply, att"),
    "nodes that are null": (20, lambda t: t.update(nodes=None), ":21: nodes must be an object, got null"),
    "a feedback that is null": (20, lambda t: t.update(nodes={"1": ["RUNNING", None]}), ":21: a node's state is"),
    "a tick of 1.5": (20, lambda t: t.update(tick=1.5), ":21: tick must be a whole number, got 1.5"),
    "healthy as text": (20, lambda t: t.update(healthy="false"), ':21: healthy must be true or false, got "false"'),
    "frames as text": (
        -1,
        lambda e: e.update(events=[{"kind": "log", "message": "m", "frames": "abc"}]),
        ":{end}: an event is {kind, message} with texts",
    ),
}


@pytest.mark.parametrize("damage", sorted(DAMAGED))
def test_a_damaged_trace_is_refused_at_its_line_before_any_view_draws_it(tmp_path, damage):
    path, _ = run_and_record(tmp_path)
    lines = path.read_text().splitlines()
    index, change, message = DAMAGED[damage]
    record = json.loads(lines[index])
    change(record)
    lines[index] = json.dumps(record)
    for placeholder, text in AS_WRITTEN.items():
        lines[index] = lines[index].replace(json.dumps(placeholder), text)
    message = message.replace("{end}", str(len(lines)))
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(TraceError, match=re.escape(f"{path}{message}")):
        read_trace(path)
    result = subprocess.run(
        [sys.executable, "-m", "autonomy", "plot", str(path), "-o", str(tmp_path / "x.png")],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2 and result.stderr.startswith(f"autonomy: error: {path}{message}")


def test_the_replay_command_refuses_a_bad_trace_in_one_line(tmp_path):
    path = tmp_path / "bad.jsonl"
    root = '{"id": 0, "name": "r", "type": "wait", "category": "action", "params": {}, "parent": null}'
    path.write_text(f'{{"type": "header", "mission": "m", "nodes": [{root}], "tick_hz": 20}}\n\x00garbage\n')
    result = subprocess.run(
        [sys.executable, "-m", "autonomy", "replay", str(path)], cwd=ROOT, capture_output=True, text=True
    )
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert result.stderr.startswith(f"autonomy: error: {path}:2: not JSON")


def test_the_replay_command_says_when_a_trace_has_no_end_or_no_ticks(tmp_path):
    path, _ = run_and_record(tmp_path)
    lines = path.read_text().splitlines(keepends=True)
    for kept, says in ((len(lines) - 1, "has no closing record"), (1, "holds no ticks")):
        path.write_text("".join(lines[:kept]))  # killed between two lines: every line whole
        result = subprocess.run(
            [sys.executable, "-m", "autonomy", "replay", str(path), "--lines", "--speed", "1000"],  # not in real time
            cwd=ROOT,
            capture_output=True,
            text=True,
        )
        assert result.returncode == 0 and says in result.stderr and "Traceback" not in result.stderr


def test_records_round_trip_through_json():
    header = RunHeader("m", [], 20.0, world={"name": "w"}, seed=3)
    again = record_from_json(json.loads(to_line(header)))
    assert isinstance(again, RunHeader) and again.version == RECORD_VERSION and again.seed == 3
    end = RunEnd("succeeded", "", True, 1.5, {"requests": 3})
    assert record_from_json(json.loads(to_line(end))) == end
    assert isinstance(record_from_json({"type": "tick"} | json.loads(to_line(end)) | {"type": "end"}), RunEnd)
    with pytest.raises(Exception, match="tick"):
        record_from_json({"type": "tick", "tick": 1})
    assert set(TickRecord.__struct_fields__) >= {"dead_reckoning", "truth", "wire", "events", "nodes"}


def test_a_line_is_made_once_a_record_and_a_changed_copy_makes_its_own(tmp_path):
    _, recorder = run_and_record(tmp_path)
    tick = recorder.ticks[3]
    line = to_line(tick)
    assert to_line(tick) is line  # kept: the trace and the browser view share it
    assert tick == msgspec.structs.replace(tick) and "_line" not in line  # the kept line is not part of the record
    merged = msgspec.structs.replace(tick, nodes={}, wire=[])  # as the browser view merges a burst
    assert to_line(merged) != line and '"nodes"' not in to_line(merged) and '"wire"' not in to_line(merged)
    assert json.loads(to_line(merged)) == json.loads(json.dumps(merged.to_json()))
    again = record_from_json(json.loads(to_line(merged)))  # empty ones left out are read back empty
    assert again.nodes == {} and again.wire == [] and again == merged


class _FailingStream(io.StringIO):
    def write(self, text: str) -> int:
        raise OSError(28, "No space left on device")


def test_a_writer_that_cannot_write_says_why_and_the_run_goes_on(tmp_path):
    spec = load_mission(ROOT / "missions/square.yaml")
    writer = TraceWriter(_FailingStream())
    client = Client.open("emu://?time=virtual")
    summary = Runner(build_tree(spec), client, mission=spec.name, max_seconds=2, listeners=[writer]).run()
    assert writer.failure == "No space left on device" and summary.ticks > 30 and summary.stopped


def test_tick_lines_go_out_together_at_each_flush_the_header_and_end_at_once(tmp_path):
    _, recorder = run_and_record(tmp_path)
    header, ticks, end = recorder.records[0], recorder.ticks, recorder.records[-1]
    clock = VirtualClock()
    stream = io.StringIO()
    writer = TraceWriter(stream, clock)
    writer(header)
    assert stream.getvalue() == to_line(header) + "\n"  # at once: a reader knows the run from the start
    for tick in ticks[:5]:
        writer(tick)
    assert stream.getvalue().count("\n") == 1  # held back: less than FLUSH_S has passed
    clock.sleep(FlushTimer.FLUSH_S)
    writer(ticks[5])  # the first record after the interval takes the held ones with it
    assert stream.getvalue().splitlines() == [to_line(r) for r in [header, *ticks[:6]]]
    writer(ticks[6])
    writer.flush()  # as whoever ends a run some other way does
    assert stream.getvalue().splitlines() == [to_line(r) for r in [header, *ticks[:7]]]
    writer(ticks[7])
    writer(end)
    assert stream.getvalue().splitlines() == [to_line(r) for r in [header, *ticks[:8], end]]
    writer.flush()  # nothing held: nothing more written
    assert stream.getvalue().count("\n") == 10 and not writer.failure


def test_a_run_in_virtual_time_has_at_most_a_hundred_tick_lines_held_back(tmp_path):
    _, recorder = run_and_record(tmp_path)
    ticks = recorder.ticks
    assert len(ticks) > 2 * TraceWriter.MOST_HELD
    stream = io.StringIO()
    writer = TraceWriter(stream, VirtualClock())  # the clock never moves: only the count flushes
    writer(recorder.records[0])
    for count, tick in enumerate(ticks[: 2 * TraceWriter.MOST_HELD + 5], start=1):
        writer(tick)
        written = stream.getvalue().count("\n") - 1
        assert count - TraceWriter.MOST_HELD < written <= count  # a kill loses at most MOST_HELD lines
    assert stream.getvalue().splitlines()[1:] == [to_line(t) for t in ticks[: 2 * TraceWriter.MOST_HELD]]


def test_any_feedback_text_a_behaviour_gives_makes_a_line_that_can_be_written(tmp_path):
    # a lone surrogate cannot be encoded as UTF-8: that line is written with \\u escapes, as json.dumps does
    _, recorder = run_and_record(tmp_path)
    odd = "name \udc80 here, caf\u00e9, \x00\x1b[31m, \u2603"
    tick = msgspec.structs.replace(recorder.ticks[4], nodes={1: NodeState("RUNNING", odd)})
    plain = msgspec.structs.replace(recorder.ticks[5], nodes={1: NodeState("RUNNING", "caf\u00e9 \u2603 null")})
    path = tmp_path / "odd.jsonl"
    with open(path, "w", encoding="utf-8") as stream:
        writer = TraceWriter(stream)
        for record in [recorder.records[0], *recorder.ticks[:4], tick, plain, recorder.records[-1]]:
            writer(record)
    assert not writer.failure and path.read_text(encoding="utf-8").count("\n") == 8
    back = read_trace(path)
    assert back.ticks[4].nodes[1].feedback == odd and back.end is not None
    assert back.ticks[5].nodes[1].feedback == "caf\u00e9 \u2603 null" and back.ticks[5] == plain


@given(
    speed=st.floats(allow_nan=False, allow_infinity=False) | st.sampled_from([0.0, -0.0, 1e-9, -1e-9]),
    heading=st.floats(-720, 720, allow_nan=False) | st.sampled_from([0.0, -0.0, 0.05, -0.05]),
    time_s=st.floats(0, 1e9) | st.sampled_from([0.05, 0.1, 0.15]),
)
@settings(max_examples=300, deadline=None)
def test_every_number_of_a_tick_line_is_read_back_as_it_was_sign_and_all(speed, heading, time_s):
    packet = Packet(1, True, False, False, 0, 0, 255, 0)
    tick = TickRecord(1, time_s, packet, 200, True, speed, Pose(1.0, 2.0, heading), truth=Pose(-0.0, 3, heading))
    line = tick.to_line()
    assert json.loads(line) == json.loads(json.dumps(tick.to_json()))
    again = record_from_json(json.loads(line))
    assert again == tick and again.to_line() == line
    for got, want in ((again.speed_mm_s, speed), (again.dead_reckoning[2], heading), (again.truth[0], -0.0)):
        assert math.copysign(1, got) == math.copysign(1, want)


@given(
    packets=st.lists(
        st.builds(
            Packet,
            st.integers(0, 15),
            st.booleans(),
            st.booleans(),
            st.booleans(),
            st.just(0),
            st.just(90),
            st.just(255),
            st.just(7),
        ),
        min_size=1,
        max_size=6,
    )
)
@settings(max_examples=200, deadline=None)
def test_every_mode_and_flags_are_written_as_the_packet_holds_them(packets):
    # mode and flags are written from text kept by value: each packet still gets its own
    for packet in packets:
        tick = TickRecord(1, 0.05, packet, 200, True, 0.0, Pose(1.0, 2.0, 90.0))
        written = json.loads(tick.to_line())["status"]
        assert written == json.loads(json.dumps(tick.to_json()))["status"]
        assert record_from_json(json.loads(tick.to_line())).status == packet
        assert (written["mode"], written["auto_mode"], written["collided"], written["moving"]) == (
            packet.mode,
            packet.auto_mode,
            packet.collided,
            packet.moving,
        )


def test_a_record_with_a_number_json_cannot_hold_ends_the_trace_after_the_lines_before_it(tmp_path):
    _, recorder = run_and_record(tmp_path)
    header, ticks = recorder.records[0], recorder.ticks
    bad = msgspec.structs.replace(ticks[3], speed_mm_s=math.nan)
    stream = io.StringIO()
    writer = TraceWriter(stream)
    for record in [header, *ticks[:3], bad, ticks[4], recorder.records[-1]]:
        writer(record)
    assert stream.getvalue().splitlines() == [to_line(r) for r in [header, *ticks[:3]]]
    assert writer.failure == f"tick {bad.tick} holds a number that is not finite"


def traced_run(root, path):
    """Runs ``root`` on the in-process emulator in virtual time with a trace to ``path``; returns its summary."""
    client = Client.open("emu://?time=virtual")
    with open(path, "w", encoding="utf-8") as stream:
        summary = Runner(root, client, mission=root.name, listeners=[TraceWriter(stream)]).run()
    client.close()
    return summary


def test_a_behaviours_text_of_megabytes_is_clipped_so_its_trace_can_be_read(tmp_path):
    """One feedback, log line or exception of 5 MB would make a line no reader takes: each keeps 1,000 characters."""
    import py_trees

    from autonomy.runner import MAX_TEXT_CHARS

    huge = ",".join(map(str, range(800_000)))

    class Chatty(py_trees.behaviour.Behaviour):
        def update(self):
            if self.feedback_message:
                raise RuntimeError(huge)
            self.feedback_message = huge
            return py_trees.common.Status.RUNNING

    path = tmp_path / "run.jsonl"
    summary = traced_run(Chatty("chatty"), path)
    assert summary.outcome == "stopped by an error" and len(summary.paragraph) < 3 * MAX_TEXT_CHARS
    trace = read_trace(path)
    feedback = trace.ticks[0].nodes[0].feedback
    assert len(feedback) == MAX_TEXT_CHARS and feedback == huge[: MAX_TEXT_CHARS - 1] + "…"
    crash = next(e for e in trace.end.events if e.kind == "exception")
    assert len(crash.message) < 2 * MAX_TEXT_CHARS and "273… at " in crash.message
    assert len(crash.traceback) <= 20_000 and "in update\n    raise RuntimeError(huge)\n" in crash.traceback


def test_an_exception_of_megabytes_outside_a_tick_is_clipped_too(tmp_path):
    """A behaviour's setup raising: its text is kept to 1,000 characters, its traceback keeps its frames."""
    import py_trees

    from autonomy.runner import MAX_TEXT_CHARS, MAX_TRACEBACK_CHARS

    class Broken(py_trees.behaviour.Behaviour):
        def setup(self, **kwargs):
            raise RuntimeError("z" * 3_000_000)

        def update(self):
            return py_trees.common.Status.SUCCESS

    path = tmp_path / "run.jsonl"
    summary = traced_run(Broken("broken"), path)
    assert summary.outcome == "stopped by an error" and len(summary.reason) == MAX_TEXT_CHARS
    crash = next(e for e in read_trace(path).end.events if e.kind == "exception")
    assert len(crash.traceback) <= MAX_TRACEBACK_CHARS and "in setup\n" in crash.traceback
    assert path.stat().st_size < 100_000


def test_a_behaviours_own_text_type_is_written_as_text_and_the_run_goes_on(tmp_path):
    import py_trees

    class Label(str):
        pass

    class Labelled(py_trees.behaviour.Behaviour):
        def update(self):
            self.feedback_message = Label("looking around") if self.feedback_message != "looking around" else 42
            return py_trees.common.Status.SUCCESS if self.feedback_message == 42 else py_trees.common.Status.RUNNING

    class Itself(str):
        def __str__(self):
            return self  # str() of it is itself again: an encoder told to write it as text goes round

    class Stubborn(py_trees.behaviour.Behaviour):
        def update(self):
            self.feedback_message = Itself(f"tick {len(self.ticks)}")
            self.ticks.append(1)
            return py_trees.common.Status.SUCCESS if len(self.ticks) > 3 else py_trees.common.Status.RUNNING

    path = tmp_path / "run.jsonl"
    summary = traced_run(Labelled("labelled"), path)
    assert summary.outcome == "succeeded"
    feedbacks = [t.nodes[0].feedback for t in read_trace(path).ticks if 0 in t.nodes]
    assert feedbacks == ["looking around", "42"] and all(type(f) is str for f in feedbacks)
    stubborn = Stubborn("stubborn")
    stubborn.ticks = []
    assert traced_run(stubborn, path).outcome == "succeeded"
    trace = read_trace(path)
    assert [t.nodes[0].feedback for t in trace.ticks] == ["tick 0", "tick 1", "tick 2", "tick 3"] and trace.end


def test_a_record_the_encoder_cannot_write_ends_the_trace_not_the_run(tmp_path):
    from autonomy.record import tick_lines

    class Itself(str):
        def __str__(self):
            return self

    _, recorder = run_and_record(tmp_path)
    header, ticks, end = recorder.records[0], recorder.ticks, recorder.records[-1]
    bad = msgspec.structs.replace(ticks[3], nodes={1: NodeState("RUNNING", Itself("x"))})  # made by hand
    text, why = tick_lines([*ticks[:3], bad, ticks[4]])
    assert text == "".join(to_line(t) + "\n" for t in ticks[:3]) and why.startswith("tick 4 cannot be written")
    stream = io.StringIO()
    writer = TraceWriter(stream)
    for record in [header, *ticks[:3], bad, *ticks[4:8], end]:
        writer(record)  # never raises
    writer.flush()
    assert stream.getvalue().splitlines() == [to_line(r) for r in [header, *ticks[:3]]]
    assert writer.failure.startswith("tick 4 cannot be written")


def test_the_end_line_waits_on_the_writer_while_the_ticks_before_it_are_made_into_lines(tmp_path, monkeypatch):
    # a Ctrl-C while the held ticks are turned into lines leaves the end to the closing flush
    import autonomy.trace

    _, recorder = run_and_record(tmp_path)
    header, ticks, end = recorder.records[0], recorder.ticks, recorder.records[-1]
    stream = io.StringIO()
    writer = TraceWriter(stream, VirtualClock())
    for record in [header, *ticks[:5]]:
        writer(record)
    real = autonomy.trace.tick_lines

    def interrupted(held):
        monkeypatch.setattr(autonomy.trace, "tick_lines", real)
        raise KeyboardInterrupt

    monkeypatch.setattr(autonomy.trace, "tick_lines", interrupted)
    with pytest.raises(KeyboardInterrupt):
        writer(end)
    writer.flush()  # as `autonomy run` does on its way out
    assert stream.getvalue().splitlines() == [to_line(r) for r in [header, *ticks[:5], end]]


def test_a_trace_cut_off_in_the_middle_of_a_character_is_read_to_its_last_whole_line(tmp_path):
    _, recorder = run_and_record(tmp_path)
    snowman = msgspec.structs.replace(recorder.ticks[3], nodes={1: NodeState("RUNNING", "\u2603 caf\u00e9")})
    lines = [to_line(r) + "\n" for r in [recorder.records[0], *recorder.ticks[:3], snowman, recorder.ticks[4]]]
    data = "".join(lines).encode()
    cut = data.index("\u2603".encode()) + 1  # inside the snowman's three bytes
    path = tmp_path / "cut.jsonl"
    path.write_bytes(data[:cut])
    trace = read_trace(path)
    assert len(trace.ticks) == 3 and trace.cut_off_line == 5 and trace.end is None
    path.write_bytes(data)
    assert read_trace(path).ticks[3].nodes[1].feedback == "\u2603 caf\u00e9"


def test_a_tick_whose_numbers_add_up_past_a_float_and_whose_text_says_null_is_still_written():
    packet = Packet(1, True, False, False, 0, 0, 255, 0)
    tick = TickRecord(1, 0.05, packet, 200, True, 0.0, Pose(1e308, 1e308, 0.0), nodes={0: NodeState("RUNNING", "null")})
    assert record_from_json(json.loads(tick.to_line())) == tick
    with pytest.raises(ValueError, match="tick 1 holds a number that is not finite"):
        msgspec.structs.replace(tick, speed_mm_s=math.inf).to_line()
    odd = msgspec.structs.replace(tick, speed_mm_s=math.nan, nodes={0: NodeState("RUNNING", "\udc80")})
    with pytest.raises(ValueError, match="tick 1 holds a number that is not finite"):  # the json module's way too
        odd.to_line()
    with pytest.raises(ValueError, match="the run's end record holds a number that is not finite"):
        to_line(RunEnd("succeeded", "", True, math.nan))


def test_ticks_made_into_lines_together_are_the_lines_made_one_by_one(tmp_path):
    from autonomy.record import tick_lines

    _, recorder = run_and_record(tmp_path)
    ticks = recorder.ticks
    one_by_one = "".join(to_line(msgspec.structs.replace(t)) + "\n" for t in ticks)
    assert tick_lines(ticks) == (one_by_one, "")
    said = msgspec.structs.replace(ticks[2], nodes={1: NodeState("RUNNING", "null \udc80")})  # both slow ways
    bad = msgspec.structs.replace(ticks[4], truth=Pose(math.inf, 0.0, 0.0))
    text, why = tick_lines([*ticks[:2], said, ticks[3], bad, ticks[5]])
    assert text == "".join(to_line(t) + "\n" for t in [*ticks[:2], said, ticks[3]])
    assert why == f"tick {bad.tick} holds a number that is not finite"


def chain_trace(path, depth: int, ticks: int = 5, flips: int = 0):
    """A trace whose tree is a chain ``depth`` levels deep (every node RUNNING), then ``flips`` nodes under the
    root that change on every tick: a trace made to cost its readers, as an attacker would make one."""
    packet = Packet(0, True, False, False, 0, 0, 255, 0)
    nodes = [
        NodeInfo(i, f"n{i}", "sequence" if i < depth - 1 else "wait", "composite" if i < depth - 1 else "action",
                 {}, i - 1 if i else None)
        for i in range(depth)
    ]  # fmt: skip
    nodes += [NodeInfo(depth + k, f"f{k}", "wait", "action", {}, 0) for k in range(flips)]
    header = RunHeader("chain", nodes, 20.0)
    lines = [to_line(header)]
    for tick in range(1, ticks + 1):
        changes = {i: NodeState("RUNNING", "") for i in range(depth)} if tick == 1 else {}
        status = "RUNNING" if tick % 2 else "SUCCESS"
        changes.update({depth + k: NodeState(status, "") for k in range(flips)})
        lines.append(to_line(TickRecord(tick, tick * 0.05, packet, 200, True, 0.0, Pose(0, 0, 0), nodes=changes)))
    path.write_text("\n".join(lines) + "\n")
    return path


def _autonomy(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "autonomy", *args], cwd=ROOT, capture_output=True, text=True)


def test_a_tree_deeper_than_a_trace_holds_is_refused_in_one_line_by_every_reader(tmp_path):
    """600 levels made plot, the page's tree and the terminal replay fail with a RecursionError."""
    from autonomy.trace import MAX_DEPTH

    deep = chain_trace(tmp_path / "deep.jsonl", 600)
    said = f"autonomy: error: {deep}:1: the tree is more than {MAX_DEPTH} levels deep (node {MAX_DEPTH}); "
    for args in (
        ("plot", str(deep), "-o", str(tmp_path / "x.png")),
        ("replay", str(deep)),
        ("replay", "--view", str(deep)),
    ):
        result = _autonomy(*args)
        assert result.returncode == 2 and result.stderr.startswith(said) and result.stderr.count("\n") == 1, args


def test_a_tree_as_deep_as_a_trace_holds_is_drawn_by_every_view(tmp_path):
    from rich.console import Console

    from autonomy.trace import MAX_DEPTH
    from autonomy.views.page import run_payload
    from autonomy.views.terminal import LiveView

    deepest = read_trace(chain_trace(tmp_path / "deepest.jsonl", MAX_DEPTH))
    assert (
        json.loads(run_payload(deepest.header, deepest.ticks, deepest.end, "replay"))["tree_svg"].count('class="node')
        == MAX_DEPTH
    )
    screen = io.StringIO()
    live = LiveView(console=Console(file=screen, width=100, height=200, force_terminal=True), title="deep")
    replay(deepest, live)
    live.console.print(live.render())  # the terminal's tree: no RecursionError
    assert "n1" in screen.getvalue()  # drawn, as deep as the screen lets it
    assert _autonomy("plot", str(tmp_path / "deepest.jsonl"), "-o", str(tmp_path / "deepest.png")).returncode == 0


def test_traces_past_their_limits_of_nodes_ticks_and_bytes_are_refused_with_what_the_limit_is(tmp_path, monkeypatch):
    import autonomy.trace as trace_module

    path = chain_trace(tmp_path / "t.jsonl", 3, ticks=30, flips=10)
    monkeypatch.setattr(trace_module, "MAX_NODES", 12)
    with pytest.raises(TraceError, match=re.escape(f"{path}:1: the tree has 13 nodes; a trace holds at most 12")):
        read_trace(path)
    monkeypatch.setattr(trace_module, "MAX_NODES", 10_000)
    monkeypatch.setattr(trace_module, "MAX_TICKS", 28)  # its lines are counted first
    with pytest.raises(TraceError, match=re.escape(f"{path}: more than 28 ticks")):
        read_trace(path)
    monkeypatch.setattr(trace_module, "MAX_TICKS", 29)  # lines enough for 29 ticks, a header and an end: read
    with pytest.raises(TraceError, match=re.escape(f"{path}:31: more than 29 ticks")):
        read_trace(path)
    monkeypatch.setattr(trace_module, "MAX_TICKS", 1_000_000)
    monkeypatch.setattr(trace_module, "MAX_TRACE_BYTES", path.stat().st_size - 1)
    with pytest.raises(TraceError, match=re.escape(f"{path}: larger than {path.stat().st_size - 1:,} bytes")):
        read_trace(path)


def test_a_timeline_of_nodes_that_change_every_tick_is_drawn_with_a_few_collections_not_an_artist_a_change(tmp_path):
    """A 3 MB trace of 60 nodes flipping on each of 2,000 ticks cost `plot` 109 s and 1.5 GB when each span
    was an artist of its own: matplotlib's cost is per artist, so the count of artists is what is bounded."""
    from matplotlib.figure import Figure

    from autonomy.views.plot import MAX_TIMELINE_ROWS, OUTCOME_COLOURS, _timeline

    churn = read_trace(chain_trace(tmp_path / "churn.jsonl", 1, ticks=2000, flips=59))
    ax = Figure().add_subplot()
    _timeline(ax, churn, min(60, MAX_TIMELINE_ROWS))
    bars = sum(len(collection.get_paths()) for collection in ax.collections)
    assert bars >= 59 * 999  # every span is drawn
    assert len(ax.collections) <= 60 * len(OUTCOME_COLOURS) + len(OUTCOME_COLOURS) and not ax.lines


def test_a_name_of_a_megabyte_is_shown_clipped_and_times_past_a_float_s_resolution_are_plotted(tmp_path):
    """A node named with 3.9 M characters cost `plot` over 113 s and 2 GB; a tick at 1e17 s made it fail."""
    import dataclasses

    from matplotlib.figure import Figure

    from autonomy.views.plot import MAX_LABEL_CHARS, _timeline, mean_over

    trace = read_trace(chain_trace(tmp_path / "named.jsonl", 2))
    nodes = list(trace.header.nodes)
    nodes[1] = dataclasses.replace(nodes[1], name="n" * 1_000_000)
    named = dataclasses.replace(trace, header=dataclasses.replace(trace.header, nodes=nodes))
    ax = Figure().add_subplot()
    _timeline(ax, named, 2)
    labels = [label.get_text() for label in ax.get_yticklabels()]
    assert len(labels[1]) == 2 + MAX_LABEL_CHARS and labels[1].endswith("\u2026")  # indented, clipped
    assert mean_over([0.0, 1e17, 1e17 + 16], [1.0, 2.0, 4.0], 0.25) == [1.0, 2.0, 4.0]  # 1e17 - 0.25 is 1e17


def test_a_run_killed_at_any_moment_loses_at_most_the_tenth_of_a_second_the_docs_promise(tmp_path):
    """docs/trace.md and the README promise a run killed outright loses at most 0.1 s of its trace."""
    _, recorder = run_and_record(tmp_path)
    header, ticks = recorder.records[0], recorder.ticks
    clock = VirtualClock()
    stream = io.StringIO()
    writer = TraceWriter(stream, clock)
    writer(header)
    writer(ticks[0])
    clock.sleep(0.1)  # the promise itself, not the writer's own setting
    writer(ticks[1])
    assert stream.getvalue().splitlines() == [to_line(r) for r in [header, ticks[0], ticks[1]]]

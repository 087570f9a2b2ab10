"""Trace files: written whole line by line, read back into the same records, cut-off traces, bad input."""

from __future__ import annotations

import dataclasses
import json
import signal
import subprocess
import sys
import time

import pytest

from autonomy.client import Client
from autonomy.mission import build_tree, load_mission
from autonomy.record import RECORD_VERSION, RunEnd, RunHeader, TickRecord, record_from_json, to_line
from autonomy.runner import Runner
from autonomy.trace import TraceError, TraceWriter, read_trace, replay
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
    assert replayed.ticks[5].status == recorder.ticks[5].status  # the packet itself, raw bytes included
    assert any(e.kind == "collision" for t in replayed.ticks for e in t.events)


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
        ('{"type": "header", "mission": "m", "nodes": [], "tick_hz": NaN}\n', "tick_hz must be a finite number"),
        ("[1, 2]\n", ":1: not a record"),
    ],
)
def test_bad_traces_are_refused_with_file_and_line(tmp_path, content, message):
    path = tmp_path / "bad.jsonl"
    path.write_text(content)
    with pytest.raises(TraceError, match=message.replace("(", r"\(")) as caught:
        read_trace(path)
    assert str(caught.value).startswith(str(path))


def test_the_replay_command_refuses_a_bad_trace_in_one_line(tmp_path):
    path = tmp_path / "bad.jsonl"
    path.write_text('{"type": "header", "mission": "m", "nodes": [], "tick_hz": 20}\n\x00garbage\n')
    result = subprocess.run(
        [sys.executable, "-m", "autonomy", "replay", str(path)], cwd=ROOT, capture_output=True, text=True
    )
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert result.stderr.startswith(f"autonomy: error: {path}:2: not JSON")


def test_records_round_trip_through_json():
    header = RunHeader("m", [], 20.0, world={"name": "w"}, seed=3)
    again = record_from_json(json.loads(to_line(header)))
    assert isinstance(again, RunHeader) and again.version == RECORD_VERSION and again.seed == 3
    end = RunEnd("succeeded", "", True, 1.5, {"requests": 3})
    assert record_from_json(json.loads(to_line(end))) == end
    assert isinstance(record_from_json({"type": "tick"} | json.loads(to_line(end)) | {"type": "end"}), RunEnd)
    with pytest.raises(Exception, match="tick"):
        record_from_json({"type": "tick", "tick": 1})
    assert TickRecord.__dataclass_fields__.keys() >= {"dead_reckoning", "truth", "wire", "events", "nodes"}


def test_a_line_is_made_once_a_record_and_a_changed_copy_makes_its_own(tmp_path):
    _, recorder = run_and_record(tmp_path)
    tick = recorder.ticks[3]
    line = to_line(tick)
    assert to_line(tick) is line  # kept: the trace and the browser view share it
    assert tick == dataclasses.replace(tick)  # the kept line is not part of the record
    merged = dataclasses.replace(tick, nodes={}, wire=[])  # as the browser view merges a burst
    assert to_line(merged) != line and '"nodes":{}' in to_line(merged) and '"wire":[]' in to_line(merged)
    assert json.loads(to_line(merged)) == json.loads(json.dumps(merged.to_json()))

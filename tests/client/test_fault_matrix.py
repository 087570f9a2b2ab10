"""The fault matrix: a mission on an independent scripted robot, over a line with each kind of fault.

Whatever the line does, every run must end with a summary and the robot stopped (or the stop
said to be unconfirmed), no ``T`` or ``D`` frame may go out twice, and no status packet the
robot did not send may reach the tree or the summary.
"""

from __future__ import annotations

import threading

import pytest

from autonomy.client import Client
from autonomy.mission import build_tree, validate_text
from autonomy.record import TickRecord
from autonomy.runner import CRASHED, Runner
from tests.client.toyrobot import FaultyLine

MISSION = """\
mission: matrix
tree:
  repeat:
    times: 3
    do:
      sequence:
        - move: {speed: 2, distance_mm: 200}
        - turn: {left: 90}
        - servo: {id: 1, by: 5}
        - move: {speed: 1, seconds: 0.5}
        - turn: {right: 45}
"""
FAULTS = [("none", 0.0), ("drop", 0.01), ("corrupt", 0.01), ("delay", 0.05), ("garbage", 0.05), ("no", 0.05)]
SEEDS = range(10)


def run_on_line(fault: str, rate: float, seed: int):
    """Runs the mission over a faulty line; returns (summary, line, tick records)."""
    line = FaultyLine(fault, rate, seed)
    client = Client(line, clock=line.clock, name=f"toy:{fault}")
    records: list[TickRecord] = []
    spec = validate_text(MISSION)
    runner = Runner(build_tree(spec), client, mission="matrix", max_seconds=60.0, listeners=[records.append])
    summary = runner.run()
    client.close()
    return summary, line, [r for r in records if isinstance(r, TickRecord)]


@pytest.mark.parametrize(("fault", "rate"), FAULTS, ids=[f for f, _ in FAULTS])
def test_every_run_ends_stopped_with_no_move_sent_twice_and_no_made_up_packet(fault, rate):
    outcomes = []
    for seed in SEEDS:
        result: list = []
        worker = threading.Thread(
            target=lambda s=seed, out=result: out.append(run_on_line(fault, rate, s)), daemon=True
        )
        worker.start()
        worker.join(timeout=60)
        assert not worker.is_alive(), f"{fault} seed {seed}: the run hung"
        summary, line, ticks = result[0]
        robot = line.robot
        outcomes.append(summary.outcome)
        assert summary.outcome != CRASHED, f"{fault} seed {seed}: {summary.reason}"
        # stopped, or said not to be
        if summary.stopped:
            assert not robot.moving, f"{fault} seed {seed}: the stop was confirmed but the robot moves"
        # T and D: each request went out exactly once
        for letter in "TD":
            written = sum(1 for frame in line.writes if frame[:1] == letter.encode())
            assert written == summary.commands[letter], f"{fault} seed {seed}: {letter} written {written} times"
        # only what the robot could have sent reaches the tree: its flags, an odometer and heading near its own
        real = [(p[1], int.from_bytes(p[3:5], "big"), int.from_bytes(p[6:8], "big")) for p in robot.packets]
        for tick in ticks:
            raw = tick.status.raw
            flags, heading, odometer = raw[1], int.from_bytes(raw[3:5], "big"), int.from_bytes(raw[6:8], "big")
            assert any(f == flags and abs(h - heading) % 360 <= 15 and abs(o - odometer) <= 50 for f, h, o in real), (
                f"{fault} seed {seed} tick {tick.tick}: a made-up packet {raw.hex(' ')}"
            )
        assert summary.distance_mm <= robot.travelled_mm + 60, f"{fault} seed {seed}: {summary.distance_mm} mm"
        assert summary.turned_deg <= robot.turned_deg + 60, f"{fault} seed {seed}: {summary.turned_deg} deg"
    if fault == "none":
        assert set(outcomes) == {"succeeded"}

"""Mission engine benchmarks; the latest figures go in the README, their history in docs/performance.md.

Measures, in one run:
  - ticks per second of a compiled 200-node mission next to the same tree built by hand in raw
    py_trees, both against the same in-process emulator in virtual time, with the same polling
    (the status packet every tick, battery and health once a second): the engine's overhead;
  - ``autonomy check`` start-up time (a fresh process, median of several runs);
  - the square mission's wall time with ``--fast`` against its simulated duration, in-process
    and as a whole ``autonomy run`` process.

Usage: python benchmarks/missions.py [--quick]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

import py_trees
from py_trees.common import Access, Status

from autonomy.client import Client
from autonomy.mission import build_tree, load_mission, validate_text
from autonomy.runner import Runner

ROOT = Path(__file__).resolve().parents[1]
BRANCHES = 66  # 66 x (sequence, condition, turn) + root + wait = 200 nodes
TICK_HZ = 20.0


def mission_text() -> str:
    branch = "      - sequence: [{obstacle_within: {mm: 1}}, {turn: {left: 90}}]\n"
    return (
        f"mission: two hundred\ntick_hz: {TICK_HZ}\ntree:\n  selector:\n    children:\n"
        + branch * BRANCHES
        + "      - wait: {seconds: 3600}\n"
    )


# --------------------------------------------------------------------------- the same tree by hand


class RawObstacleWithin(py_trees.behaviour.Behaviour):
    def __init__(self, name: str, mm: int) -> None:
        super().__init__(name)
        self.mm = mm
        self.blackboard = self.attach_blackboard_client(name)
        self.blackboard.register_key(key="/raw/status", access=Access.READ)

    def update(self) -> Status:
        return Status.SUCCESS if self.blackboard.get("/raw/status").front_distance_mm < self.mm else Status.FAILURE


class RawTurn(py_trees.behaviour.Behaviour):
    def __init__(self, name: str, client: Client, angle_deg: int) -> None:
        super().__init__(name)
        self.client, self.angle_deg = client, angle_deg

    def initialise(self) -> None:
        self.client.turn(self.angle_deg)

    def update(self) -> Status:
        return Status.RUNNING


class RawWait(py_trees.behaviour.Behaviour):
    def __init__(self, name: str, client: Client, seconds: float) -> None:
        super().__init__(name)
        self.client, self.seconds, self.end_s = client, seconds, 0.0

    def initialise(self) -> None:
        self.end_s = self.client.clock.now() + self.seconds

    def update(self) -> Status:
        return Status.SUCCESS if self.client.clock.now() >= self.end_s else Status.RUNNING


def raw_ticks_per_s(ticks: int) -> float:
    client = Client.open("emu://?time=virtual&world=empty")
    children = [
        py_trees.composites.Sequence(
            "sequence", memory=True, children=[RawObstacleWithin("near", 1), RawTurn("turn", client, 90)]
        )
        for _ in range(BRANCHES)
    ]
    root = py_trees.composites.Selector("selector", memory=False, children=[*children, RawWait("wait", client, 3600)])
    writer = py_trees.blackboard.Client(name="raw")
    for key in ("/raw/status", "/raw/battery", "/raw/healthy"):
        writer.register_key(key=key, access=Access.WRITE)
    period, last_slow = 1.0 / TICK_HZ, -1e9
    start = time.perf_counter()
    for _ in range(ticks):
        now = client.clock.now()
        writer.set("/raw/status", client.status())
        if now - last_slow >= 1.0:
            writer.set("/raw/battery", client.battery())
            writer.set("/raw/healthy", client.healthy())
            last_slow = now
        root.tick_once()
        client.clock.sleep(period)
    elapsed = time.perf_counter() - start
    client.close()
    return ticks / elapsed


def compiled_ticks_per_s(ticks: int) -> tuple[float, int]:
    spec = validate_text(mission_text(), "two_hundred.yaml")
    root = build_tree(spec)
    nodes = sum(1 for _ in root.iterate())
    client = Client.open("emu://?time=virtual&world=empty")
    runner = Runner(root, client, mission=spec.name, tick_hz=spec.tick_hz, max_seconds=(ticks - 0.5) / TICK_HZ)
    start = time.perf_counter()
    summary = runner.run()
    elapsed = time.perf_counter() - start
    client.close()
    return summary.ticks / elapsed, nodes


def check_startup_s(runs: int) -> float:
    samples = []
    for _ in range(runs):
        start = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "autonomy", "check", "missions/square.yaml"],
            cwd=ROOT,
            check=True,
            capture_output=True,
        )
        samples.append(time.perf_counter() - start)
    return statistics.median(samples)


def square_fast() -> tuple[float, float, float]:
    spec = load_mission(ROOT / "missions" / "square.yaml")
    client = Client.open("emu://?time=virtual&world=box")
    start = time.perf_counter()
    summary = Runner(build_tree(spec), client, mission=spec.name, tick_hz=spec.tick_hz).run()
    in_process = time.perf_counter() - start
    client.close()
    start = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "autonomy", "run", "missions/square.yaml", "--fast", "--quiet"],
        cwd=ROOT,
        check=True,
        capture_output=True,
    )
    whole = time.perf_counter() - start
    return summary.time_s, in_process, whole


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repetitions")
    args = parser.parse_args()
    ticks = 300 if args.quick else 3000
    raw = max(raw_ticks_per_s(ticks) for _ in range(3))
    compiled, nodes = 0.0, 0
    for _ in range(3):
        rate, nodes = compiled_ticks_per_s(ticks)
        compiled = max(compiled, rate)
    startup = check_startup_s(3 if args.quick else 7)
    simulated, in_process, whole = square_fast()
    ratio = raw / compiled
    rows = [
        (f"ticks/s, compiled {nodes}-node mission", f"{compiled:,.0f}", "", None),
        ("ticks/s, same tree in raw py_trees", f"{raw:,.0f}", "", None),
        ("engine overhead (raw / compiled)", f"{ratio:.2f}x", "<= 1.3x", ratio <= 1.3),
        ("autonomy check start-up", f"{startup * 1000:.0f} ms", "", None),
        ("square --fast, in-process", f"{simulated / in_process:,.0f}x", ">= 100x", simulated / in_process >= 100),
        ("square --fast, whole process", f"{simulated / whole:,.0f}x", f"({simulated:.1f} s in {whole:.2f} s)", None),
    ]
    for name, value, target, ok in rows:
        verdict = "" if ok is None else ("meets target" if ok else "MISSES target")
        print(f"{name:<38}{value:>10}   {target:<24}{verdict}")


if __name__ == "__main__":
    main()

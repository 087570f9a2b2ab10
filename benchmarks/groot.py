"""What the Groot2 publisher costs a run: nobody attached, and a client polling as Groot2 does.

Runs the wander mission made to last 10 minutes (12,001 ticks) on the in-process emulator in
virtual time, as fast as the machine allows, in rounds: plain, plain again (the machine's own
noise), with the publisher and nobody attached, and with the publisher and a ZeroMQ client in
another process asking for the statuses (``S``) 10 times a second, as Groot2 does while it
watches. Each figure is the median over the rounds of how many fewer ticks a second than the
round's first plain run. Target: the publisher with nobody attached within 2%.

Timing whole runs cannot resolve much under the machine's noise, so the publisher's own work a
tick is measured apart too: the records of one run handed to it 20 times over, against a tick's
whole cost.

Usage: python benchmarks/groot.py [--rounds N]
"""

from __future__ import annotations

import argparse
import random
import statistics
import subprocess
import sys
import time
from pathlib import Path

from autonomy.client import Client
from autonomy.groot import GrootPublisher
from autonomy.mission import validate_text
from autonomy.mission.btcpp import instance
from autonomy.record import TickRecord
from autonomy.runner import Runner

ROOT = Path(__file__).resolve().parents[1]
MISSION = ROOT / "missions" / "wander.yaml"
POLLER = """
import sys, time, zmq
context = zmq.Context()
socket = context.socket(zmq.REQ)
socket.connect("tcp://127.0.0.1:" + sys.argv[1])
while True:
    socket.send(b"\\x02S\\x00\\x00\\x00\\x00")
    socket.recv_multipart()
    time.sleep(0.1)
"""


def long_wander():
    text = MISSION.read_text().replace("seconds: 60", "seconds: 600")
    return validate_text(text, str(MISSION), MISSION.parent)


def ticks_per_second(spec, listeners) -> float:
    client = Client.open("emu://?time=virtual&world=obstacles&seed=1")
    runner = Runner.for_mission(spec, client, listeners=listeners)
    start = time.perf_counter()
    summary = runner.run()
    elapsed = time.perf_counter() - start
    client.close()
    return summary.ticks / elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    spec = long_wander()
    tree = instance(spec)
    cost: dict[str, list[float]] = {
        "noise (plain vs plain)": [],
        "publisher, nobody attached": [],
        "publisher, polled 10/s": [],
    }
    rates: dict[str, list[float]] = {key: [] for key in ("plain", *cost)}
    for number in range(args.rounds):
        plain = ticks_per_second(spec, [])
        setups = list(cost)
        random.shuffle(setups)
        for setup in setups:
            if setup.startswith("noise"):
                rate = ticks_per_second(spec, [])
            else:
                publisher = GrootPublisher(tree, port=0).start()
                poller = None
                if "polled" in setup:
                    poller = subprocess.Popen([sys.executable, "-c", POLLER, str(publisher.port)])
                    time.sleep(0.5)
                try:
                    rate = ticks_per_second(spec, [publisher])
                finally:
                    if poller is not None:
                        poller.kill()
                        poller.wait()
                    answered = publisher.requests
                    publisher.stop()
                if poller is not None and answered == 0:
                    raise SystemExit("the poller was never answered")
            cost[setup].append(100 * (plain - rate) / plain)
            rates[setup].append(rate)
        rates["plain"].append(plain)
        print(f"round {number + 1}: plain {plain:,.0f} ticks/s", file=sys.stderr)
    records: list = []
    ticks_per_second(spec, [records.append])
    ticks = [r for r in records if isinstance(r, TickRecord)]
    publisher = GrootPublisher(tree, port=0).start()
    start = time.perf_counter()
    for _ in range(20):
        for tick in ticks:
            publisher(tick)
    own_us = (time.perf_counter() - start) / (20 * len(ticks)) * 1e6
    publisher.stop()
    tick_us = 1e6 / statistics.median(rates["plain"])
    print(f"wander for 600 s (12,001 ticks), virtual time, {args.rounds} rounds, medians")
    print(
        f"  the publisher's own work: {own_us:.2f} us a tick, {100 * own_us / tick_us:.2f}% of a {tick_us:.0f} us tick"
    )
    print(f"  plain run: {statistics.median(rates['plain']):,.0f} ticks/s")
    for setup, values in cost.items():
        print(f"  {setup}: {statistics.median(rates[setup]):,.0f} ticks/s, {statistics.median(values):+.1f}% fewer")


if __name__ == "__main__":
    main()

"""Link and emulator benchmarks; the latest figures go in the README, their history in docs/performance.md.

Measures, in one run:
  - request/reply round trips per second (Gb000 status polls) through emu:// (virtual time),
    through the TCP emulator and through the pty emulator (each ``autonomy emulator`` in its own
    process, real time, a real socket or terminal);
  - one status poll over the baud-paced 57600 emulator against its wire time (15 bytes = 2.6 ms),
    in-process and over a pty;
  - the emulator's simulated seconds per wall second while driving, in virtual time;
  - what the guardian (the process that stops the robot if the engine is killed) costs: round
    trips through one TCP emulator without it and with it, taking turns (median of 5 each), and
    the time it adds to opening the link.

Usage: python benchmarks/link.py [--quick] [--json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from contextlib import contextmanager

from autonomy.client import Client

WIRE_TIME_57600_S = 15 * 10 / 57600


def round_trips_per_s(client: Client, count: int) -> float:
    client.status()
    start = time.perf_counter()
    for _ in range(count):
        client.status()
    return count / (time.perf_counter() - start)


@contextmanager
def emulator_process(*args: str):
    """Runs ``autonomy emulator ARGS`` in its own process, as a user would; yields its URL."""
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "emulator", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        yield process.stdout.readline().strip()
    finally:
        process.terminate()
        process.wait(timeout=10)


def served_round_trips(count: int, *args: str, guardian: bool = False) -> float:
    with emulator_process(*args) as url:
        client = Client.open(url, guardian=guardian)
        try:
            return round_trips_per_s(client, count)
        finally:
            client.close()


def open_ms(url: str, guardian: bool, count: int) -> float:
    """The median time to open the link and close it again, in milliseconds."""
    samples = []
    for _ in range(count):
        start = time.perf_counter()
        client = Client.open(url, guardian=guardian)
        samples.append(time.perf_counter() - start)
        client.close()
    return statistics.median(samples) * 1000


def paced_poll_s(client: Client, count: int) -> float:
    samples = []
    for _ in range(count):
        start = time.perf_counter()
        client.status()
        samples.append(time.perf_counter() - start)
    return statistics.median(samples)


def speedup_while_driving(sim_s: float) -> float:
    client = Client.open("emu://?time=virtual&world=empty")
    clock = client.clock
    start_wall, start_sim = time.perf_counter(), clock.now()
    client.move(2)
    turned = False
    while clock.now() - start_sim < sim_s:
        clock.sleep(0.05)  # a 20 Hz mission loop: one status poll a tick
        status = client.status()
        if not turned and status.odometer_mm > 3000:
            client.turn(180)
            turned = True
        elif turned and not status.moving:
            client.move(2)
            turned = False
    wall = time.perf_counter() - start_wall
    client.close()
    return (clock.now() - start_sim) / wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repetitions")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args()
    n = 2000 if args.quick else 20000
    results: dict[str, float] = {}

    client = Client.open("emu://?time=virtual")
    results["emu_round_trips_per_s"] = round_trips_per_s(client, n)
    client.close()
    results["tcp_round_trips_per_s"] = served_round_trips(n // 4, "--tcp", "127.0.0.1:0")
    results["pty_round_trips_per_s"] = served_round_trips(n // 4, "--pty")
    with emulator_process("--tcp", "127.0.0.1:0") as url:  # with and without, taking turns on one emulator
        plain, guarded = [], []
        for _ in range(5):
            for guardian, into in ((False, plain), (True, guarded)):
                client = Client.open(url, guardian=guardian)
                into.append(round_trips_per_s(client, n // 10))
                client.close()
        results["tcp_round_trips_turns_per_s"] = statistics.median(plain)
        results["tcp_round_trips_guarded_per_s"] = statistics.median(guarded)
        results["open_ms"] = open_ms(url, False, 10 if args.quick else 50)
        results["open_guarded_ms"] = open_ms(url, True, 10 if args.quick else 50)

    paced = Client.open("emu://?faults=pace")
    results["paced_poll_emu_ms"] = paced_poll_s(paced, 200 if args.quick else 1000) * 1000
    paced.close()
    with emulator_process("--pty", "--faults", "pace") as url:
        paced = Client.open(url)
        results["paced_poll_pty_ms"] = paced_poll_s(paced, 200 if args.quick else 1000) * 1000
        paced.close()
    results["emulator_speedup_x"] = speedup_while_driving(60.0 if args.quick else 600.0)

    if args.json:
        print(json.dumps({k: round(v, 3) for k, v in results.items()}))
        return
    wire_ms = WIRE_TIME_57600_S * 1000
    rows = [
        (
            "round trips/s, emu:// in-process",
            f"{results['emu_round_trips_per_s']:,.0f}",
            ">= 10,000",
            results["emu_round_trips_per_s"] >= 10_000,
        ),
        ("round trips/s, TCP emulator", f"{results['tcp_round_trips_per_s']:,.0f}", "", None),
        ("round trips/s, pty emulator", f"{results['pty_round_trips_per_s']:,.0f}", "", None),
        (
            "round trips/s TCP, guardian no/yes",
            f"{results['tcp_round_trips_turns_per_s']:,.0f} / {results['tcp_round_trips_guarded_per_s']:,.0f}",
            "the same",
            None,
        ),
        (
            "open TCP, guardian: without / with",
            f"{results['open_ms']:.1f} / {results['open_guarded_ms']:.1f} ms",
            "",
            None,
        ),
        (
            "status poll, paced 57600, emu://",
            f"{results['paced_poll_emu_ms']:.3f} ms",
            f"{wire_ms:.3f} ms +-10%",
            abs(results["paced_poll_emu_ms"] / wire_ms - 1) <= 0.10,
        ),
        (
            "status poll, paced 57600, pty",
            f"{results['paced_poll_pty_ms']:.3f} ms",
            f"{wire_ms:.3f} ms +-10%",
            abs(results["paced_poll_pty_ms"] / wire_ms - 1) <= 0.10,
        ),
        (
            "emulator, simulated s per wall s",
            f"{results['emulator_speedup_x']:,.0f}x",
            ">= 200x",
            results["emulator_speedup_x"] >= 200,
        ),
    ]
    for name, value, target, ok in rows:
        verdict = "" if ok is None else ("meets target" if ok else "MISSES target")
        print(f"{name:<36}{value:>14}   {target:<18}{verdict}")


if __name__ == "__main__":
    main()

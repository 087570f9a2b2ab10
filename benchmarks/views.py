"""What watching and recording a run costs, and how fast the browser view jumps to a tick.

Measures, in one run:
  - ticks per second of the wander mission (60 s simulated, 1201 ticks) on the in-process
    emulator in virtual time, with no listener, with the trace writer, with the terminal
    view drawing (rich, 80x24, into a file), and with the browser view served and a real
    headless Chromium connected to it: what each costs;
  - in that Chromium, the replay page of the same run: the time to show any tick (the
    slider's work), over 60 ticks spread across the run.

Usage: python benchmarks/views.py [--rounds N]
"""

from __future__ import annotations

import argparse
import io
import os
import statistics
import tempfile
import time
from pathlib import Path

from rich.console import Console

from autonomy.client import Client
from autonomy.mission import build_tree, load_mission
from autonomy.runner import Runner
from autonomy.trace import TraceWriter, read_trace
from autonomy.views.terminal import LiveView
from autonomy.views.web import ViewServer

ROOT = Path(__file__).resolve().parents[1]
MISSION = ROOT / "missions" / "wander.yaml"
CHROMIUM = os.environ.get("AUTONOMY_CHROMIUM", "/usr/bin/chromium")
ARGS = ["--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking", "--disable-sync"]


def ticks_per_second(listeners_for) -> float:
    spec = load_mission(MISSION)
    client = Client.open("emu://?time=virtual&world=obstacles")
    listeners, cleanup = listeners_for()
    runner = Runner(build_tree(spec), client, mission=spec.name, listeners=listeners)
    started = time.perf_counter()
    summary = runner.run()
    elapsed = time.perf_counter() - started
    cleanup()
    client.close()
    return summary.ticks / elapsed


def nothing():
    return [], lambda: None


def trace_writer():
    stream = open(os.path.join(tempfile.mkdtemp(), "run.jsonl"), "w", encoding="utf-8", buffering=1)  # noqa: SIM115
    return [TraceWriter(stream)], stream.close


def terminal_view():
    console = Console(file=io.StringIO(), width=80, height=24, force_terminal=True, color_system="truecolor")
    view = LiveView(console)
    view.__enter__()
    return [view], lambda: view.__exit__(None, None, None)


def best(rounds: int, listeners_for) -> float:
    return max(ticks_per_second(listeners_for) for _ in range(rounds))


def main() -> None:
    from playwright.sync_api import sync_playwright

    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=5)
    rounds = parser.parse_args().rounds
    best(1, nothing)  # warm up
    plain = best(rounds, nothing)
    traced = best(rounds, trace_writer)
    drawn = best(rounds, terminal_view)
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        watched_rates = []
        for _ in range(rounds):
            server = ViewServer("127.0.0.1", 0)
            server.start()
            page = browser.new_page()
            page.goto(server.url)
            page.wait_for_selector("#state")

            def browser_view(server=server):
                return [server.hub], lambda: None

            watched_rates.append(ticks_per_second(browser_view))
            page.wait_for_function("document.querySelector('#state').textContent !== 'running'", timeout=30_000)
            shown = page.eval_on_selector("#slider", "el => +el.max + 1")
            assert shown == 1201, shown
            page.close()
            server.stop()
        watched = max(watched_rates)

        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "run.jsonl")
            spec = load_mission(MISSION)
            client = Client.open("emu://?time=virtual&world=obstacles")
            with open(path, "w", encoding="utf-8") as stream:
                Runner(build_tree(spec), client, mission=spec.name, listeners=[TraceWriter(stream)]).run()
            trace = read_trace(path)
            server = ViewServer("127.0.0.1", 0, mode="replay")
            server.start()
            for record in trace.records():
                server.hub(record)
            page = browser.new_page(viewport={"width": 1400, "height": 1000})
            page.goto(server.url)
            page.wait_for_selector("#controls:not([hidden])")
            count = len(trace.ticks)
            order = [(k * 617) % count for k in range(60)]  # spread over the run, not in order
            times_ms = [page.evaluate(f"window.autonomyView.show({i})") for i in order]
            server.stop()
        browser.close()

    def cost(rate: float) -> str:
        return f"{(1 - rate / plain) * 100:+.1f}%"

    print(f"ticks/s, wander (1201 ticks), no listener:          {plain:8,.0f}")
    added = plain / traced * 100 - 100
    print(f"ticks/s, with the trace writer:                     {traced:8,.0f}  tick time {added:+.1f}%")
    print(f"ticks/s, with the terminal view drawing (80x24):    {drawn:8,.0f}  ticks/s {cost(drawn)}")
    print(f"ticks/s, with the browser view and Chromium on it:  {watched:8,.0f}  ticks/s {cost(watched)}")
    print(
        f"replay page, show any of {count} ticks: median {statistics.median(times_ms):.1f} ms, "
        f"max {max(times_ms):.1f} ms (target < 100 ms)"
    )


if __name__ == "__main__":
    main()

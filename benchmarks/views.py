"""What watching and recording a run costs, and how fast the browser view jumps to a tick.

Measures, in one run:
  - ticks per second of the wander mission made to last 10 minutes (12,001 ticks) on the
    in-process emulator in virtual time, with no listener, with the trace writer, with the
    terminal view drawing (rich, 80x24, into a file), and with the browser view served and a
    real headless Chromium connected to it: what each costs;
  - in that Chromium, the replay page of the same run: the time to show any tick (the
    slider's work), over 60 ticks spread across the run.

The four set-ups take turns, N rounds. Each figure is a median over the rounds: ticks per
second; how many fewer ticks a second than the plain run of the same round (so that the
machine's slow drifts cancel); this process's CPU time a tick (the run and the view's
server). The browser runs in a process of its own, as it does for a person.

Usage: python benchmarks/views.py [--rounds N]
"""

from __future__ import annotations

import argparse
import io
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rich.console import Console

from autonomy.client import Client
from autonomy.mission import build_tree, load_mission, validate_text
from autonomy.runner import Runner
from autonomy.trace import TraceWriter, read_trace
from autonomy.views.terminal import LiveView
from autonomy.views.web import ViewServer

ROOT = Path(__file__).resolve().parents[1]
MISSION = ROOT / "missions" / "wander.yaml"
CHROMIUM = os.environ.get("AUTONOMY_CHROMIUM", "/usr/bin/chromium")
ARGS = ["--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking", "--disable-sync"]


LONG_S = 600


def long_wander():
    """missions/wander.yaml with its minute made ten."""
    text = MISSION.read_text().replace("seconds: 60", f"seconds: {LONG_S}")
    assert f"seconds: {LONG_S}" in text
    return validate_text(text, str(MISSION), MISSION.parent)


def ticks_per_second(listeners_for) -> tuple[float, float]:
    """Runs the long wander; returns its ticks per wall-clock second and this process's CPU us per tick."""
    spec = long_wander()
    client = Client.open("emu://?time=virtual&world=obstacles")
    listeners, cleanup = listeners_for()
    runner = Runner(build_tree(spec), client, mission=spec.name, listeners=listeners)
    started, cpu_started = time.perf_counter(), time.process_time()
    summary = runner.run()
    elapsed, cpu = time.perf_counter() - started, time.process_time() - cpu_started
    cleanup()
    client.close()
    return summary.ticks / elapsed, cpu / summary.ticks * 1e6


def nothing():
    return [], lambda: None


def trace_writer():
    stream = open(os.path.join(tempfile.mkdtemp(), "run.jsonl"), "w", encoding="utf-8")  # noqa: SIM115
    return [TraceWriter(stream)], stream.close


def terminal_view():
    console = Console(file=io.StringIO(), width=80, height=24, force_terminal=True, color_system="truecolor")
    view = LiveView(console)
    view.__enter__()
    return [view], lambda: view.__exit__(None, None, None)


def browse(url: str) -> None:
    """In a process of its own, as a person's browser is: opens the page, says how many ticks it got."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        page = browser.new_page()
        page.goto(url)
        page.wait_for_selector("#state")
        print("ready", flush=True)
        page.wait_for_function(  # looked at twice a second: a check every frame would load the machine
            "document.querySelector('#state').textContent === 'succeeded'", timeout=120_000, polling=500
        )
        print(page.evaluate("window.autonomyView.view.ticks.length"), flush=True)
        browser.close()


def watched_by_a_browser() -> tuple[float, float]:
    server = ViewServer("127.0.0.1", 0)
    server.start()
    viewer = subprocess.Popen([sys.executable, __file__, "--browse", server.url], stdout=subprocess.PIPE, text=True)
    assert viewer.stdout.readline().strip() == "ready"
    rate = ticks_per_second(lambda: ([server.hub], lambda: None))
    shown = int(viewer.stdout.readline())
    assert shown == LONG_S * 20 + 1, shown  # the page got every tick
    viewer.wait(timeout=30)
    server.stop()
    return rate


def main() -> None:
    from playwright.sync_api import sync_playwright

    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--browse", metavar="URL", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.browse:
        browse(args.browse)
        return
    rates: dict[str, list[tuple[float, float]]] = {"plain": [], "traced": [], "drawn": [], "watched": []}
    ticks_per_second(nothing)  # warm up
    for _ in range(args.rounds):  # the four in turn, so that the machine's moods fall on all of them
        rates["plain"].append(ticks_per_second(nothing))
        rates["traced"].append(ticks_per_second(trace_writer))
        rates["drawn"].append(ticks_per_second(terminal_view))
        rates["watched"].append(watched_by_a_browser())
    print("ticks/s by round:", {k: [round(r) for r, _ in v] for k, v in rates.items()})
    names = ("plain", "traced", "drawn", "watched")
    plain, traced, drawn, watched = (statistics.median(r for r, _ in rates[k]) for k in names)
    cpu = {k: statistics.median(c for _, c in rates[k]) for k in names}
    # each round's set-up against the plain run of the same round: slow drifts of the machine cancel
    lost = {
        k: statistics.median(1 - r / p for (r, _), (p, _) in zip(rates[k], rates["plain"], strict=True)) for k in names
    }

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=ARGS)
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

    def cost(rate: float, name: str) -> str:
        extra = cpu[name] / cpu["plain"] * 100 - 100
        return f"ticks/s, {lost[name] * 100:.1f}% fewer; CPU a tick {cpu[name]:.0f} us ({extra:+.1f}%)"

    print(f"wander for 10 min (12,001 ticks), alone:   {plain:7,.0f} ticks/s, CPU a tick {cpu['plain']:.0f} us")
    print(f"with the trace writer:                     {traced:7,.0f} {cost(traced, 'traced')}")
    print(f"with the terminal view drawing (80x24):    {drawn:7,.0f} {cost(drawn, 'drawn')}")
    print(f"with the browser view and Chromium on it:  {watched:7,.0f} {cost(watched, 'watched')}")
    print(
        f"replay page, show any of {count} ticks: median {statistics.median(times_ms):.1f} ms, "
        f"max {max(times_ms):.1f} ms (target < 100 ms)"
    )


if __name__ == "__main__":
    main()

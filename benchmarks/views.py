"""What watching and recording a run costs, and how fast the browser view jumps to a tick.

Measures, in one run (each run as `autonomy run` runs it, in a settled heap):
  - ticks per second of the wander mission made to last 10 minutes (12,001 ticks) on the
    in-process emulator in virtual time, with no listener, with the trace writer, with the
    terminal view drawing (rich, 80x24, into a file), and with the browser view served and a
    real headless Chromium (a process of its own, as a person's browser is) showing it: what
    each costs;
  - in that Chromium, the replay page of the same run: the time to show any tick (the
    slider's work), over 60 ticks spread across the run.

One Chromium stays open throughout, as it would in a class; for each watched run its tab
opens the page of that run's server (one server a run, as `autonomy run --view` has) before
the run starts, and the run starts once the page's event stream is open. In between, the tab
sits on the previous run's page, finished. Each round runs every set-up once, in a shuffled
order, and the plain run twice: the second plain run against the first is the machine's own
noise, the floor under every other figure. Each figure is a median over the rounds: ticks
per second; how many fewer ticks a second than the plain run of the same round (so that the
machine's slow drifts cancel); this process's CPU time a tick (the run and the view's server).

Usage: python benchmarks/views.py [--rounds N]
"""

from __future__ import annotations

import argparse
import io
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rich.console import Console

from autonomy.client import Client
from autonomy.mission import build_tree, load_mission, validate_text
from autonomy.runner import Runner, settled_heap
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


class Timed:
    """Wraps a listener and adds up the time spent in it (the runner's thread waits for it)."""

    def __init__(self, listener) -> None:
        self.listener, self.spent_s = listener, 0.0

    def __call__(self, record) -> None:
        started = time.perf_counter()
        self.listener(record)
        self.spent_s += time.perf_counter() - started


SHARES: dict[str, list[float]] = {}


def ticks_per_second(listeners_for, name: str = "", server=None) -> tuple[float, float]:
    """Runs the long wander; returns its ticks per wall-clock second and this process's CPU us per tick.

    Beside them it notes, under ``name``, the view's own share: the time spent in its listener,
    and for the browser view the CPU time of the server's thread, against the rest of the run.
    Both are taken in the same run, so the machine's moods, which move each round's ticks per
    second by several percent, fall on both sides of the ratio alike.
    """
    spec = long_wander()
    client = Client.open("emu://?time=virtual&world=obstacles")
    listeners, cleanup = listeners_for()
    timed = [Timed(listener) for listener in listeners]
    runner = Runner(build_tree(spec), client, mission=spec.name, listeners=timed)
    server_clock = time.pthread_getcpuclockid(server._thread.ident) if server is not None else None
    server_started = time.clock_gettime(server_clock) if server_clock is not None else 0.0
    with settled_heap():  # as `autonomy run` runs its mission; the collection it starts with is not timed
        started, cpu_started = time.perf_counter(), time.process_time()
        summary = runner.run()
        elapsed, cpu = time.perf_counter() - started, time.process_time() - cpu_started
    server_s = time.clock_gettime(server_clock) - server_started if server_clock is not None else 0.0
    cleanup()
    client.close()
    if name:
        spent_s = sum(t.spent_s for t in timed) + server_s
        SHARES.setdefault(name, []).append(spent_s / (elapsed - spent_s))
    return summary.ticks / elapsed, cpu / summary.ticks * 1e6


def nothing():
    return [], lambda: None


def empty_listener():
    return [lambda record: None], lambda: None


def trace_writer():
    stream = open(os.path.join(tempfile.mkdtemp(), "run.jsonl"), "w", encoding="utf-8")  # noqa: SIM115
    return [TraceWriter(stream)], stream.close


def terminal_view():
    console = Console(file=io.StringIO(), width=80, height=24, force_terminal=True, color_system="truecolor")
    view = LiveView(console)
    view.__enter__()
    return [view], lambda: view.__exit__(None, None, None)


def browse() -> None:
    """In a process of its own, as a person's browser is: one Chromium, one tab, for the whole
    benchmark. Told ``open URL``, it opens the page of a run about to start and says when the
    page is up; told ``check``, it waits until the page shows a run that succeeded and says how
    many ticks it holds."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        page = browser.new_page()
        for line in sys.stdin:
            command, _, url = line.strip().partition(" ")
            if command == "open":
                page.goto(url)
                page.wait_for_selector("#state")
                print("ready", flush=True)
            else:
                # waits on the page's own change, as a person does: polling from here would add work to the page
                page.wait_for_selector("#state.succeeded", timeout=120_000)
                print(page.evaluate("window.autonomyView.view.ticks.length"), flush=True)
        browser.close()


class Browser:
    """A Chromium with a tab open, for the whole benchmark; each watched run has a view server
    of its own, as each `autonomy run --view` has, and the tab opens its page before the run."""

    def __init__(self) -> None:
        self.viewer = subprocess.Popen(
            [sys.executable, __file__, "--browse"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
        )

    def _tell(self, line: str) -> str:
        self.viewer.stdin.write(line + "\n")
        self.viewer.stdin.flush()
        return self.viewer.stdout.readline().strip()

    def watched(self) -> tuple[float, float]:
        server = ViewServer("127.0.0.1", 0)
        server.start()
        assert self._tell(f"open {server.url}") == "ready"
        deadline = time.monotonic() + 10
        while not server.hub._waiters:  # noqa: SLF001 - the page's event stream is open: it watches
            assert time.monotonic() < deadline, "the page never opened its event stream"
            time.sleep(0.01)
        rate = ticks_per_second(lambda: ([server.hub], lambda: None), "watched", server)
        shown = int(self._tell("check"))
        assert shown == LONG_S * 20 + 1, shown  # the page got every tick
        server.stop()
        return rate

    def close(self) -> None:
        self.viewer.stdin.close()
        self.viewer.wait(timeout=30)


def main() -> None:
    from playwright.sync_api import sync_playwright

    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=15)
    parser.add_argument("--browse", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.browse:
        browse()
        return
    names = ("plain", "noise", "traced", "drawn", "watched")
    rates: dict[str, list[tuple[float, float]]] = {name: [] for name in names}
    browser = Browser()
    setups = {
        "plain": lambda: ticks_per_second(empty_listener, "plain"),  # what the timing itself costs
        "noise": lambda: ticks_per_second(nothing),  # a second plain run: the machine's noise
        "traced": lambda: ticks_per_second(trace_writer, "traced"),
        "drawn": lambda: ticks_per_second(terminal_view, "drawn"),
        "watched": browser.watched,
    }
    ticks_per_second(nothing)  # warm up
    shuffle = random.Random(1)
    for _ in range(args.rounds):  # every set-up each round, in a new order, so that the machine's moods fall on all
        order = list(names)
        shuffle.shuffle(order)
        for name in order:
            rates[name].append(setups[name]())
    browser.close()
    print("ticks/s by round:", {k: [round(r) for r, _ in v] for k, v in rates.items()})
    plain, noise, traced, drawn, watched = (statistics.median(r for r, _ in rates[k]) for k in names)
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
    print(f"the same again (the machine's noise):      {noise:7,.0f} {cost(noise, 'noise')}")
    print(f"with the trace writer:                     {traced:7,.0f} {cost(traced, 'traced')}")
    print(f"with the terminal view drawing (80x24):    {drawn:7,.0f} {cost(drawn, 'drawn')}")
    print(f"with the browser view and Chromium on it:  {watched:7,.0f} {cost(watched, 'watched')}")
    timing = statistics.median(SHARES["plain"])
    for name, what in (("traced", "the trace writer"), ("drawn", "the terminal view"), ("watched", "the browser view")):
        share = statistics.median(SHARES[name]) - timing
        low, high = (min(SHARES[name]) - timing) * 100, (max(SHARES[name]) - timing) * 100
        print(f"{what}'s own time against the rest of its run: {share * 100:.1f}% (rounds: {low:.1f}% to {high:.1f}%)")
    print(
        f"replay page, show any of {count} ticks: median {statistics.median(times_ms):.1f} ms, "
        f"max {max(times_ms):.1f} ms (target < 100 ms)"
    )


if __name__ == "__main__":
    main()

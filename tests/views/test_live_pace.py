"""How often the terminal view reads the clock and redraws: by the run's pace, not by its records."""

from __future__ import annotations

import io

import pytest
from rich.console import Console

from autonomy.client import Client
from autonomy.mission import build_tree, load_mission
from autonomy.record import TickRecord
from autonomy.runner import Runner
from autonomy.views.terminal import BURST_READS, BURST_S, DRAW_SHARE, MAX_REFRESH_HZ, LiveView
from tests.views.conftest import ROOT


class CountedClock:
    """A clock the test moves, counting how often it is read."""

    is_virtual = True

    def __init__(self) -> None:
        self.now_s = 0.0
        self.reads = 0

    def now(self) -> float:
        self.reads += 1
        return self.now_s


@pytest.fixture(scope="module")
def records():
    spec = load_mission(ROOT / "missions/square.yaml")
    kept: list = []
    Runner(build_tree(spec), Client.open("emu://?time=virtual"), mission=spec.name, listeners=[kept.append]).run()
    return kept


@pytest.mark.parametrize(("gap_s", "rounds"), [(0.05, 1), (0.001, 10)])
def test_the_view_draws_by_the_runs_pace_and_reads_the_clock_seldom_in_a_burst(records, gap_s, rounds):
    header, ticks, end = records[0], records[1:-1], records[-1]
    assert len(ticks) > 150 and all(type(t) is TickRecord for t in ticks)
    stream = [header, *ticks * rounds, end]
    clock, draw_s = CountedClock(), 0.002
    view = LiveView(Console(file=io.StringIO(), width=80, height=24, force_terminal=True), clock)
    draws: list[float] = []

    def update(renderable, refresh=False):
        draws.append(clock.now_s)
        clock.now_s += draw_s  # what drawing takes

    view._live.update = update
    for record in stream:
        view(record)
        clock.now_s += gap_s
    assert view.end is end and view.last is ticks[-1]
    assert draws[0] == 0.0 and draws[-1] >= (len(stream) - 2) * gap_s  # the header and the end are drawn
    paced = list(zip(draws[:-2], draws[1:-1], strict=True))  # the end is drawn at once
    if gap_s >= BURST_S:  # a run in real time: every record looked at, the screen drawn ten times a second
        assert clock.reads >= len(stream)
        assert all(b - a >= 1 / MAX_REFRESH_HZ - 1e-9 for a, b in paced)
        assert 0.6 * MAX_REFRESH_HZ <= len(draws) / clock.now_s <= MAX_REFRESH_HZ + 1
    else:  # flat out: the clock read once every BURST_READS records, drawing a 1/DRAW_SHARE of the time
        assert clock.reads <= 2 * len(draws) + len(stream) / BURST_READS + 4
        assert all(b - a >= draw_s * DRAW_SHARE for a, b in paced[1:])  # after the first 0.1 s
        assert len(draws) >= 5 and len(draws) * draw_s <= clock.now_s / DRAW_SHARE + 2 * draw_s

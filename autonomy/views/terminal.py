"""The full-screen terminal view of a run, live or replayed, built on rich.

The tree fills the left, each node with its status in colour and its feedback; RUNNING
branches of a parallel all show. The telemetry is on the right and the latest log lines
below. Finished subtrees fold to one line when the tree does not fit (it fits 80x24).
The screen is redrawn at most :data:`MAX_REFRESH_HZ` times a second, whatever the tick rate;
in a run in virtual time, drawing takes at most one part in :data:`DRAW_SHARE` of the time.
"""

from __future__ import annotations

from collections import deque

from rich.console import Console, Group
from rich.layout import Layout
from rich.live import Live
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from autonomy.clock import Clock, RealClock
from autonomy.record import Event, Record, RunEnd, RunHeader, TickRecord, TreeState
from autonomy.views.lines import event_text, fit, printable
from autonomy.views.treetext import (
    LEGEND_STATUS,
    SHAPE_SYMBOLS,
    STATUS_COLOURS,
    STATUS_SYMBOLS,
    shape_of,
    tree_lines,
)

MAX_REFRESH_HZ = 10.0
#: The smallest terminal the view is drawn on (the robot's panel takes TELEMETRY_WIDTH of it).
MIN_WIDTH, MIN_HEIGHT = 60, 16
#: In a run in virtual time, drawing takes at most one part in this many of the time.
DRAW_SHARE = 160.0
#: Records less than this far apart come from a run in virtual time.
BURST_S = 0.005
#: In a burst, the clock is read once this many records (well under BURST_S of them).
BURST_READS = 16
LOG_LINES = 4
TELEMETRY_WIDTH = 27
MODES = {0: "idle", 1: "moving", 2: "turning", 3: "fallen"}


class LiveView:
    """A listener that draws the run on the whole terminal.

    Use it as a context manager around the run: it takes the screen on entry and gives it
    back on exit (also on Ctrl-C or an error).

    Args:
        console: Where to draw (a rich console on the terminal).
        clock: Real time, to limit the refresh rate.
        title: What the view calls the run (``live`` or ``replay``).
    """

    def __init__(self, console: Console | None = None, clock: Clock | None = None, title: str = "live") -> None:
        self.console = console or Console()
        self.clock = clock or RealClock()
        self.title = title
        self.header: RunHeader | None = None
        self.state: TreeState | None = None
        self.last: TickRecord | None = None
        self.end: RunEnd | None = None
        self.log: deque[str] = deque(maxlen=LOG_LINES)
        self._live = Live(console=self.console, screen=True, auto_refresh=False, transient=False)
        self._drawn_s = -1.0
        self._interval_s = 1.0 / MAX_REFRESH_HZ
        self._record_s = -1.0
        self._unread = 0  # tick records since the clock was last read
        self._read_every = 1

    def __enter__(self) -> LiveView:
        self._live.__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        self._live.__exit__(None, None, None)

    def __call__(self, record: Record) -> None:
        """Takes one record; redraws when the last redraw is old enough (or the run ended).

        In a burst (a run in virtual time, records less than :data:`BURST_S` apart) the clock
        is read every :data:`BURST_READS` records only: a tick's record then costs the view
        little more than its changes.
        """
        if type(record) is TickRecord:  # nearly every record: looked for first
            if self.state is not None:
                if record.nodes:
                    self.state.apply(record)
                self.last = record
            if record.events:
                self._note(record.events)
            self._unread += 1
            if self._unread < self._read_every:
                return
        elif isinstance(record, RunHeader):
            self.header, self.state = record, TreeState(record)
        elif isinstance(record, RunEnd):
            self.end = record
            self._note(record.events)
        now = self.clock.now()
        burst = now - self._record_s < BURST_S * max(1, self._unread)
        self._record_s, self._unread = now, 0
        self._read_every = BURST_READS if burst else 1
        if isinstance(record, RunEnd) or now - self._drawn_s >= self._interval_s:
            self._live.update(self.render(), refresh=True)
            drawn_s = self.clock.now()
            # A run in real time is redrawn MAX_REFRESH_HZ a second. A run going flat out in
            # virtual time (records less than BURST_S apart) is drawn at most 1/DRAW_SHARE of the
            # time, so that it keeps its pace.
            self._interval_s = max(1.0 / MAX_REFRESH_HZ, (drawn_s - now) * DRAW_SHARE if burst else 0.0)
            self._drawn_s = drawn_s

    def _note(self, events: list[Event]) -> None:
        for event in events:
            self.log.append(printable(event_text(event.kind, event.message)))

    def render(self) -> Layout | Text:
        """The whole screen (or, on a terminal too small for it, what size it needs)."""
        width, height = self.console.size
        if width < MIN_WIDTH or height < MIN_HEIGHT:
            return Text(
                f"{fit(self.header.mission if self.header else '...', width)}\n"
                f"the terminal is {width}x{height}; the live view needs {MIN_WIDTH}x{MIN_HEIGHT}: make it bigger",
                style="bold",
            )
        layout = Layout()
        layout.split_column(
            Layout(self._title(), name="title", size=1),
            Layout(name="body"),
            Layout(self._log(), name="log", size=LOG_LINES + 2),
        )
        tree_rows = max(3, height - 1 - (LOG_LINES + 2) - 2 - 1)
        layout["body"].split_row(
            Layout(Panel(self._tree(tree_rows), title="tree", border_style="blue"), name="tree"),
            Layout(Panel(self._telemetry(), title="robot", border_style="blue"), name="robot", size=TELEMETRY_WIDTH),
        )
        return layout

    def _title(self) -> Text:
        """One line: the mission's name (cut to what the line leaves it), the outcome, time, world, what Ctrl-C does."""
        header, last = self.header, self.last
        rest = Text()
        if self.end is None or self.title != "live":  # a replay stays one once it has ended
            rest.append(f" {self.title} ", style="bold yellow")
        if self.end is not None:
            colour = "green" if self.end.outcome == "succeeded" else "red"
            rest.append(f" {self.end.outcome} ", style=f"bold {colour}")
        if last is not None:
            rest.append(f" {last.time_s:6.1f} s  tick {last.tick}")
        if header is not None and header.world:
            rest.append(fit(f"  world {header.world.get('name', '?')}", 24))
        rest.append("   Ctrl-C stops the robot" if self.title == "live" and self.end is None else "   Ctrl-C quits")
        room = max(8, self.console.size.width - len(rest.plain) - 2)
        text = Text(f" {fit(header.mission if header else '...', room)} ", style="bold reverse")
        text.append_text(rest)
        text.no_wrap, text.overflow = True, "ellipsis"
        return text

    def _tree(self, rows: int) -> Group:
        header, state = self.header, self.state
        if header is None or state is None:
            return Group(Text("waiting for the run to start..."))
        out = []
        for line in tree_lines(header, state.nodes, rows):
            if line.node < 0:
                out.append(Text(f"{'  ' * line.depth}… {line.folded} more lines", style="dim"))
                continue
            info = header.nodes[line.node]
            node_state = state.nodes[line.node]
            colour = STATUS_COLOURS[node_state.status]
            text = Text("  " * line.depth)
            text.append(STATUS_SYMBOLS[node_state.status] + " ", style=f"bold {colour}")
            text.append(SHAPE_SYMBOLS[shape_of(info)] + " ", style="dim")
            text.append(printable(info.name), style=colour if node_state.status != "INVALID" else "")
            if line.folded:
                text.append(f" (+{line.folded})", style="dim")
            if node_state.feedback:
                text.append(printable(f"  {node_state.feedback}"), style="italic cyan")
            text.no_wrap, text.overflow = True, "ellipsis"
            out.append(text)
        out.append(Text(LEGEND_STATUS, style="dim", no_wrap=True, overflow="ellipsis"))
        return Group(*out)

    def _telemetry(self) -> Table:
        table = Table.grid(padding=(0, 1))
        table.add_column(style="dim")
        table.add_column()
        last = self.last
        if last is None:
            table.add_row("status", "waiting")
            return table
        if self.header is not None and not self.header.telemetry:
            table.add_row("status", "not recorded")
            table.add_row("time", f"{last.time_s:.2f} s")
            return table
        s = last.status
        rows = [
            ("front", f"{s.front_distance_mm} mm"),
            ("heading", f"{s.heading_deg} deg"),
            ("odometer", f"{s.odometer_mm} mm"),
            ("tilt", f"{s.tilt_deg:+d} deg"),
            ("speed", f"{last.speed_mm_s:.0f} mm/s"),
            ("battery", f"{last.battery} / 255"),
            ("health", "ok" if last.healthy else "NOT OK"),
            ("mode", f"{'auto' if s.auto_mode else 'MANUAL'}, {MODES.get(s.mode, s.mode)}"),
        ]
        for name, value in rows:
            table.add_row(name, value)
        table.add_row("collided", Text("YES", style="bold red") if s.collided else Text("no"))
        pose = last.truth or last.dead_reckoning
        table.add_row("position", f"{pose.x_mm / 1000:.2f}, {pose.y_mm / 1000:.2f} m")
        return table

    def _log(self) -> Panel:
        lines = [Text(line, no_wrap=True, overflow="ellipsis") for line in self.log] or [Text("(nothing yet)", "dim")]
        if self.end is not None:
            paragraph = printable(self.end.paragraph)
            lines = lines[-(LOG_LINES - 1) :] + [Text(paragraph, style="bold", overflow="ellipsis")]
        return Panel(Group(*lines), title="log", border_style="blue")

"""The plain output of a run: one aligned line when what runs changes, and the log as it comes.

Each line starts with fixed-width columns (time and telemetry), so they stay aligned, and
ends with every RUNNING leaf and its feedback, the one that started last first (the one
acting: a move, rather than the wait around it), cut to fit :data:`WIDTH` characters. An
action done within one tick (a beep, a servo) gets a line of its own.
"""

from __future__ import annotations

from collections.abc import Callable

from autonomy.record import FAILURE, RUNNING, SUCCESS, Record, RunEnd, RunHeader, TickRecord, TreeState

#: Longest line written.
WIDTH = 100
#: A line is repeated at least this often (seconds of run time) while nothing changes.
REPEAT_S = 2.0


def printable(text: str) -> str:
    """``text`` with control and formatting characters shown as ``�``: nothing reaches a terminal raw."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else "�" for c in text)


def fit(text: str, width: int) -> str:
    """``text`` made printable and cut to ``width`` characters, with ``…`` when cut."""
    text = printable(text)
    return text if len(text) <= width else text[: width - 1] + "…"


def event_text(kind: str, message: str) -> str:
    """An event as a line says it: ``beep: 3 tones``.

    A message that names its kind already (``collision (front sensor 0 mm, ...)``) is said alone, not as
    ``collision: collision (...)``.
    """
    return message if message == kind or message.startswith(kind + " ") else f"{kind}: {message}"


def leaf_text(name: str, feedback: str) -> str:
    """A running leaf as the views show it: its name, and its feedback in parentheses."""
    return f"{name} ({feedback})" if feedback else name


class LinePrinter:
    """A listener that writes the line output.

    Args:
        write: Takes one line (without newline).
        quiet: Write nothing (the caller prints the summary).
    """

    def __init__(self, write: Callable[[str], None], quiet: bool = False) -> None:
        self.write = write
        self.quiet = quiet
        self.header: RunHeader | None = None
        self.state: TreeState | None = None
        self._leaves: list[int] = []
        self._actions: set[int] = set()
        self._started: dict[int, int] = {}  # a running leaf: the tick it started in
        self._shown: tuple[tuple[int, ...], float] = ((), -REPEAT_S * 10)

    def __call__(self, record: Record) -> None:
        """Takes one record."""
        if isinstance(record, RunHeader):
            self.header = record
            self.state = TreeState(record)
            parents = {n.parent for n in record.nodes}
            self._leaves = [n.id for n in record.nodes if n.id not in parents]
            self._actions = {n.id for n in record.nodes if n.id not in parents and n.category == "action"}
            self._started = {}
            return
        if self.quiet or self.header is None or self.state is None:
            return
        if isinstance(record, TickRecord):
            before = {i: self.state.nodes[i].status for i in record.nodes if i in self._actions}
            self.state.apply(record)
            self._done_at_once(record, before)
            self._tick(record)
        for event in record.events:
            if event.kind not in ("stop",) and not (isinstance(record, RunEnd) and event.kind == "exception"):
                self.write(fit(f"{'':10}{event_text(event.kind, event.message)}", WIDTH))

    def _columns(self, record: TickRecord) -> str:
        s = record.status
        return (
            f"{record.time_s:7.2f} s  front {s.front_distance_mm:3d} mm  hdg {s.heading_deg:3d}  "
            f"odo {s.odometer_mm:5d} mm  bat {record.battery:3d}  "
            if self.header is not None and self.header.telemetry
            else f"{record.time_s:7.2f} s  "
        )

    def _done_at_once(self, record: TickRecord, before: dict[int, str]) -> None:
        """A line for each action that started and ended in this tick (a beep, a servo): never RUNNING, never shown."""
        if self.header is None or self.state is None:
            return
        for i, was in before.items():
            node = self.state.nodes[i]
            if was != RUNNING and node.status in (SUCCESS, FAILURE):
                done = "done" if node.status == SUCCESS else "failed"
                self.write(
                    fit(self._columns(record) + leaf_text(f"{self.header.nodes[i].name}: {done}", node.feedback), WIDTH)
                )

    def _tick(self, record: TickRecord) -> None:
        if self.header is None or self.state is None:
            return
        nodes = self.state.nodes
        running = [i for i in self._leaves if nodes[i].status == RUNNING]
        self._started = {i: self._started.get(i, record.tick) for i in running}
        if not running:
            return
        running.sort(key=lambda i: (-self._started[i], -i))  # the leaf that started last acts: first (then the later)
        key = tuple(running)
        if key == self._shown[0] and record.time_s - self._shown[1] < REPEAT_S:
            return
        self._shown = (key, record.time_s)
        what = " | ".join(leaf_text(self.header.nodes[i].name, nodes[i].feedback) for i in running)
        self.write(fit(self._columns(record) + what, WIDTH))

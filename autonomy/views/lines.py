"""The plain output of a run: one aligned line when what runs changes, and the log as it comes.

Each line starts with fixed-width columns (time and telemetry), so they stay aligned, and
ends with every RUNNING leaf and its feedback, cut to fit :data:`WIDTH` characters.
"""

from __future__ import annotations

from collections.abc import Callable

from autonomy.record import RUNNING, Record, RunEnd, RunHeader, TickRecord, TreeState

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
        self._shown: tuple[tuple[int, ...], float] = ((), -REPEAT_S * 10)

    def __call__(self, record: Record) -> None:
        """Takes one record."""
        if isinstance(record, RunHeader):
            self.header = record
            self.state = TreeState(record)
            parents = {n.parent for n in record.nodes}
            self._leaves = [n.id for n in record.nodes if n.id not in parents]
            return
        if self.quiet or self.header is None or self.state is None:
            return
        if isinstance(record, TickRecord):
            self.state.apply(record)
            self._tick(record)
        for event in record.events:
            if event.kind not in ("stop",) and not (isinstance(record, RunEnd) and event.kind == "exception"):
                self.write(fit(f"{'':10}{event.kind}: {event.message}", WIDTH))

    def _tick(self, record: TickRecord) -> None:
        if self.header is None or self.state is None:
            return
        nodes = self.state.nodes
        running = [i for i in self._leaves if nodes[i].status == RUNNING]
        if not running:
            return
        key = tuple(running)
        if key == self._shown[0] and record.time_s - self._shown[1] < REPEAT_S:
            return
        self._shown = (key, record.time_s)
        what = " | ".join(leaf_text(self.header.nodes[i].name, nodes[i].feedback) for i in running)
        s = record.status
        columns = (
            f"{record.time_s:7.2f} s  front {s.front_distance_mm:3d} mm  hdg {s.heading_deg:3d}  "
            f"odo {s.odometer_mm:5d} mm  bat {record.battery:3d}  "
            if self.header.telemetry
            else f"{record.time_s:7.2f} s  "
        )
        self.write(fit(columns + what, WIDTH))

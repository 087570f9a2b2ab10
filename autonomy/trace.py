"""Trace files: tick records as JSON lines, written as a run goes and read back for a replay.

A trace is one :class:`~autonomy.record.RunHeader` line, one line per tick, and one
:class:`~autonomy.record.RunEnd` line. Lines are written whole, and flushed at least every
:data:`FlushTimer.FLUSH_S` of real time, so a trace cut off by a crash or ``kill -9`` can still
be read up to its last whole line;
:func:`read_trace` says when the end is missing. docs/trace.md describes every field.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

from autonomy.clock import Clock, RealClock
from autonomy.emulator.world import WorldInvalid, world_from_dict
from autonomy.errors import AutonomyError
from autonomy.record import (
    Listener,
    Record,
    RecordError,
    RunEnd,
    RunHeader,
    TickRecord,
    record_from_json,
    tick_lines,
    to_line,
)

#: Largest trace line read back (a 200-node tree's first tick is well under 100 kB).
MAX_LINE_CHARS = 4_000_000
#: What a trace may hold; a reader refuses more in one line (``autonomy`` exits 2). A run of a mission
#: has at most 3,000 nodes 50 levels deep; an hour of the wander mission at 20 Hz is 72,000 ticks and
#: 40 MB. A reader holds about ten times a trace's size while it reads it.
MAX_TRACE_BYTES = 100_000_000
MAX_NODES = 10_000
MAX_DEPTH = 100
MAX_TICKS = 500_000


class TraceError(AutonomyError):
    """A trace file that cannot be read; the message names the file and line."""


class FlushTimer:
    """Says when a file written as a run goes is due a flush.

    At most :data:`FLUSH_S` of real time after the last, so that a run killed at any moment
    loses at most that much of it.

    Args:
        clock: Real time.
    """

    FLUSH_S = 0.1

    def __init__(self, clock: Clock) -> None:
        self._now = clock.now
        self._flushed_s = self._now()

    def due(self, anyway: bool = False) -> bool:
        """Whether to flush now (always when ``anyway``); a True answer starts the wait anew."""
        now = self._now()
        if anyway or now - self._flushed_s >= self.FLUSH_S:
            self._flushed_s = now
            return True
        return False


class TraceWriter:
    """A listener that writes each record as one line of a trace file.

    Tick records are held back and written together, with a flush: at the header, at the end,
    whenever :data:`FlushTimer.FLUSH_S` of real time has passed since the last flush, and every
    :data:`MOST_HELD` ticks (a run in virtual time makes hundreds in 0.1 s). Their lines are made
    together too (:func:`~autonomy.record.tick_lines`): one call of the encoder and one write a
    batch cost a tick far less than one a line. So a run killed at any moment loses at most that
    much of its trace (and never a line in the middle: a reader stops at the last whole one).
    Whoever stops a run some other way calls :meth:`flush`.

    Args:
        stream: A text file open for writing.
        clock: Real time, for the flushes.
    """

    #: Most tick records held back before they are written.
    MOST_HELD = 100

    def __init__(self, stream: TextIO, clock: Clock | None = None) -> None:
        self.stream = stream
        self._flush = FlushTimer(clock or RealClock())
        self._held: list[TickRecord] = []
        #: The header's or the end's line, to follow the ticks held (kept until written).
        self._then = ""
        #: Why the trace stopped being written (a full disk, a number JSON cannot hold), or empty.
        #: The run goes on.
        self.failure = ""

    def __call__(self, record: Record) -> None:
        """Takes one record; once the file cannot be written to, notes why and writes no more."""
        if self.failure:
            return
        if type(record) is TickRecord:
            held = self._held
            held.append(record)
            if len(held) >= self.MOST_HELD or self._flush.due():
                self.flush()
            return
        try:  # the header and the end go out at once, after the ticks held before them
            line = to_line(record)
        except Exception as err:  # noqa: BLE001 - a number JSON cannot hold...: the lines before it are kept
            self.flush()
            self.failure = self.failure or str(err)
            return
        self._flush.due(anyway=True)
        self._then = line + "\n"
        self.flush()

    def flush(self) -> None:
        """Writes the ticks held back (and the header's or end's line after them), and flushes the file."""
        if self.failure:
            return
        held = self._held
        # made before the ticks are let go: a Ctrl-C in the middle leaves them held (one during
        # the write itself is raised once the write has returned: the batch went out whole)
        try:
            text, why = tick_lines(held) if held else ("", "")
        except Exception as err:  # noqa: BLE001 - never the run's end
            text, why = "", f"the trace's lines could not be made ({err!r:.200})"
        self._held = []
        if not why:
            text += self._then
        self._then = ""
        try:
            if text:
                self.stream.write(text)
            self.stream.flush()
        except (OSError, ValueError) as err:  # a full disk, a file that takes no writes, a closed stream
            self.failure = getattr(err, "strerror", None) or str(err)
        self.failure = self.failure or why


@dataclass
class Trace:
    """A whole trace, read back.

    Attributes:
        header: The run's header.
        ticks: The tick records, in order.
        end: The closing record, or None when the trace was cut off.
        cut_off_line: The line number of a partial last line that was left out (0: none).
    """

    header: RunHeader
    ticks: list[TickRecord]
    end: RunEnd | None
    cut_off_line: int = 0

    def records(self) -> Iterator[Record]:
        """The header, every tick, and the end when there is one."""
        yield self.header
        yield from self.ticks
        if self.end is not None:
            yield self.end


def read_trace(path: str | Path) -> Trace:
    """Reads a trace file.

    A last line without its newline, or one that is not whole JSON, is taken as the point
    where the run was cut off, and left out.

    Raises:
        TraceError: the file cannot be read, does not start with a header, or has a bad
            line before its last; the message says ``FILE:LINE: what``.
    """
    path = Path(path)
    try:
        with path.open("rb") as stream:
            data = stream.read(MAX_TRACE_BYTES + 1)
    except OSError as err:
        raise TraceError(f"{path}: cannot read the trace: {err.strerror or err}") from err
    if len(data) > MAX_TRACE_BYTES:
        raise TraceError(f"{path}: larger than {MAX_TRACE_BYTES:,} bytes, more than a trace reader takes")
    if data.count(b"\n") > MAX_TICKS + 2:  # said before a line is read: reading them all costs ten times the file
        raise TraceError(f"{path}: more than {MAX_TICKS:,} ticks, more than a trace reader takes")
    # Whole lines are UTF-8; a trace cut off in the middle of a character is read to its last whole line.
    whole = data.rfind(b"\n") + 1
    try:
        text = data[:whole].decode("utf-8") + data[whole:].decode("utf-8", "replace")
    except UnicodeDecodeError:
        raise TraceError(
            f"{path}: not a recording: a trace is JSON lines of text (run --trace), "
            "a .btlog starts with BTCPP4-FileLogger2 (run --btlog)"
        ) from None
    lines = text.split("\n")
    complete = text.endswith("\n")
    if complete:
        lines.pop()
    header: RunHeader | None = None
    ticks: list[TickRecord] = []
    end: RunEnd | None = None
    cut_off = 0
    for number, line in enumerate(lines, start=1):
        last = number == len(lines)
        if not line.strip():
            continue
        try:
            if len(line) > MAX_LINE_CHARS:
                raise RecordError(f"the line is longer than {MAX_LINE_CHARS} characters")
            record = record_from_json(json.loads(line, parse_constant=_not_a_number))
        except (ValueError, RecursionError) as err:  # not JSON, a bad record, a number of thousands of digits
            if last and not complete and isinstance(err, json.JSONDecodeError):
                cut_off = number
                break
            if isinstance(err, json.JSONDecodeError):
                what = f"not JSON ({err.msg})"
            elif isinstance(err, RecordError):
                what = str(err)
            else:
                what = f"not a trace line a reader takes ({err})"
            raise TraceError(f"{path}:{number}: {what}") from None
        if header is None:
            if not isinstance(record, RunHeader):
                raise TraceError(f"{path}:{number}: a trace starts with its header; this is a {type(record).__name__}")
            why = _header_problem(record)
            if why:
                raise TraceError(f"{path}:{number}: {why}")
            header = record
        elif isinstance(record, TickRecord):
            if end is not None:
                raise TraceError(f"{path}:{number}: a tick after the run's end")
            if len(ticks) >= MAX_TICKS:
                raise TraceError(f"{path}:{number}: more than {MAX_TICKS:,} ticks, more than a trace reader takes")
            unknown = [node_id for node_id in record.nodes if not 0 <= node_id < len(header.nodes)]
            if unknown:
                raise TraceError(f"{path}:{number}: tick {record.tick} names node {unknown[0]}, not in the header")
            ticks.append(record)
        elif isinstance(record, RunEnd):
            end = record
        else:
            raise TraceError(f"{path}:{number}: a second header")
    if header is None:
        raise TraceError(f"{path}: empty: no header line")
    return Trace(header, ticks, end, cut_off)


def _not_a_number(name: str) -> None:
    raise RecordError(f"{name} is not a number a trace holds")


def tree_problem(header: RunHeader) -> str:
    """Why a header's tree cannot be drawn (numbering, parents, size, depth), or empty."""
    if len(header.nodes) > MAX_NODES:
        return f"the tree has {len(header.nodes):,} nodes; a trace holds at most {MAX_NODES:,}"
    depth: list[int] = []
    for index, node in enumerate(header.nodes):
        if node.id != index:
            return f"the header's nodes are numbered 0, 1, 2... in order; node {index} is numbered {node.id}"
        if (node.parent is None) != (index == 0) or (node.parent is not None and not 0 <= node.parent < index):
            return f"node {index}'s parent must be a node before it (the root, 0, alone has none); got {node.parent}"
        depth.append(0 if node.parent is None else depth[node.parent] + 1)
        if depth[-1] >= MAX_DEPTH:
            return f"the tree is more than {MAX_DEPTH} levels deep (node {index}); a trace holds at most {MAX_DEPTH}"
    if not header.nodes:
        return "the header has no nodes"
    return ""


def _header_problem(header: RunHeader) -> str:
    """Why a header's tree or world cannot be drawn, or empty: the views take both as they are."""
    why = tree_problem(header)
    if why:
        return why
    if header.world is not None:
        if not isinstance(header.world, dict):
            return f"the header's world is a world file's content, got {type(header.world).__name__}"
        try:
            world_from_dict(header.world)
        except WorldInvalid as err:
            first = err.problems[0]
            return f"the header's world is not valid: {f'{first.path}: ' if first.path else ''}{first.message}"
    return ""


#: Longest wait between two ticks of a replay, in played seconds: a longer quiet spell is cut short.
MAX_QUIET_S = 5.0


def replay(trace: Trace, listener: Listener, clock: Clock | None = None, speed: float = 1.0) -> None:
    """Hands a trace's records to ``listener`` as a run would have, paced on ``clock``.

    A run's ticks come every tick period; a ``.btlog`` holds only changes, and a quiet spell of
    more than :data:`MAX_QUIET_S` between two of them is played as that long.

    Args:
        trace: The trace to play.
        listener: Receives every record in order.
        clock: Waits between ticks on this clock (None: no waiting at all).
        speed: 2.0 plays twice as fast as the run went.
    """
    listener(trace.header)
    start_s = clock.now() if clock is not None else 0.0
    skipped_s = previous_s = 0.0
    for tick in trace.ticks:
        if clock is not None:
            quiet_s = (tick.time_s - previous_s) / speed
            if quiet_s > MAX_QUIET_S:  # nothing happened for a long while (or a recording says so): go on
                skipped_s += quiet_s - MAX_QUIET_S
            previous_s = tick.time_s
            clock.sleep(start_s + tick.time_s / speed - skipped_s - clock.now())
        listener(tick)
    if trace.end is not None:
        listener(trace.end)

"""The tick record: what a run did, written once and read by everything that looks at a run.

A run is a stream of three kinds of record, in this order::

    RunHeader      once: the mission, its tree, the world, the link, the date
    TickRecord     once a tick: what the tree did, what the robot said, what went over the wire
    RunEnd         once: how the run ended, the summary, whether the stop was confirmed

The runner produces them; a replay of a trace file produces the same objects, so the trace
writer, the terminal and browser views, the plots and the grader cannot tell a live run from
a recorded one. Each record turns into one JSON object (:meth:`to_json`) and back
(:func:`record_from_json`); docs/trace.md describes the format. :data:`RECORD_VERSION` goes
up whenever a reader of an older version could misread a newer record.

A tick record carries only the nodes whose status or feedback changed in that tick (like
BehaviorTree.CPP's loggers); :class:`TreeState` folds them back into every node's state.
"""

from __future__ import annotations

import base64
import binascii
import json
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, fields
from typing import Any, NamedTuple, Union

import msgspec

from autonomy.protocol import STATUS_LENGTH
from autonomy.protocol import Status as Packet
from autonomy.source import finite_number

#: The version of the record format; a reader refuses records of a newer version. Version 2
#: writes numbers in full (version 1 rounded them), a packet's bytes in base64 (1: hex), and
#: leaves out a tick's ``nodes`` and ``wire`` when they are empty.
RECORD_VERSION = 2

RUNNING, SUCCESS, FAILURE, INVALID = "RUNNING", "SUCCESS", "FAILURE", "INVALID"


class RecordError(ValueError):
    """A JSON object that is not a record this version can read."""


@dataclass(frozen=True)
class NodeInfo:
    """One node of the tree, as the header describes it.

    Attributes:
        id: The node's number, 0 for the root, parents before children.
        name: The display name.
        type: The node type as a mission file writes it (``sequence``, ``move``...).
        category: composite, decorator, action or condition.
        params: The node's parameters (children left out), defaults filled in.
        parent: The parent's id (None for the root).
        file: The mission file the node was written in (empty when built in code).
        line: The line of that file (0 when unknown).
    """

    id: int
    name: str
    type: str
    category: str
    params: dict[str, Any]
    parent: int | None
    file: str = ""
    line: int = 0

    @property
    def where(self) -> str:
        """``file:line``, or empty when the node was not built from a file."""
        return f"{self.file}:{self.line}" if self.file and self.line else self.file


class Pose(NamedTuple):
    """A position estimate in the world's frame: mm, and degrees left of +x.

    A named tuple: two are made every tick and read by every consumer, and a tuple is made and
    read several times as fast as a frozen dataclass.
    """

    x_mm: float
    y_mm: float
    heading_deg: float

    def to_json(self) -> list[float]:
        """``[x_mm, y_mm, heading_deg]``."""
        return [self.x_mm, self.y_mm, self.heading_deg]

    @classmethod
    def from_json(cls, value: Any) -> Pose:
        """The inverse of :meth:`to_json`: each number as it was (a whole one stays whole)."""
        if not isinstance(value, list) or len(value) != 3 or not all(finite_number(v) for v in value):
            raise RecordError(f"a pose is [x_mm, y_mm, heading_deg], three finite numbers; got {_short(value)}")
        return cls(*value)


class Exchange(msgspec.Struct, frozen=True, array_like=True):
    """One attempt on the wire: the frame sent and what came back (in JSON, ``[sent, reply, attempt]``).

    Attributes:
        sent: The command, without its newline (``F+200``).
        reply: ``OK``, ``NO``, a parameter value, ``status``, or ``error: ...``.
        attempt: 0 for a request's first attempt, 1.. for its retries.
    """

    sent: str
    reply: str
    attempt: int = 0

    def to_json(self) -> list[Any]:
        """``[sent, reply, attempt]``."""
        return [self.sent, self.reply, self.attempt]

    @classmethod
    def from_json(cls, value: Any) -> Exchange:
        """The inverse of :meth:`to_json` (version 1 left out a first attempt's 0)."""
        if (
            not isinstance(value, list)
            or not 2 <= len(value) <= 3
            or not all(isinstance(v, str) for v in value[:2])
            or (len(value) == 3 and not (type(value[2]) is int and value[2] >= 0))
        ):
            raise RecordError(
                f"a wire entry is [sent, reply, attempt], two texts and a whole number; got {_short(value)}"
            )
        return cls(value[0], value[1], value[2] if len(value) > 2 else 0)


class Event(msgspec.Struct, frozen=True, omit_defaults=True):
    """Something that happened: a ``log`` message, a collision, a behaviour's exception...

    Attributes:
        kind: ``log``, ``collision``, ``exception``, ``warning`` or ``stop``.
        message: One line for the person watching.
        node: The node concerned (an id), if any.
        where: ``file:line`` of that node in the mission, if known.
        frames: For an exception: the last lines of its traceback, innermost last.
        traceback: For an exception: the whole traceback, as text.
    """

    kind: str
    message: str
    node: int | None = None
    where: str = ""
    frames: tuple[str, ...] = ()
    traceback: str = ""

    def to_json(self) -> dict[str, Any]:
        """The fields that are set."""
        out: dict[str, Any] = {"kind": self.kind, "message": self.message}
        if self.node is not None:
            out["node"] = self.node
        if self.where:
            out["where"] = self.where
        if self.frames:
            out["frames"] = list(self.frames)
        if self.traceback:
            out["traceback"] = self.traceback
        return out

    @classmethod
    def from_json(cls, value: dict[str, Any]) -> Event:
        """The inverse of :meth:`to_json`."""
        if not isinstance(value, dict):
            raise RecordError(f"an event is an object with kind and message; got {_short(value)}")
        node, frames = value.get("node"), value.get("frames", [])
        texts = [value.get(k, "") for k in ("kind", "message", "where", "traceback")]
        if (
            not all(isinstance(t, str) for t in texts)
            or not (node is None or (type(node) is int and node >= 0))
            or not (isinstance(frames, list) and all(isinstance(f, str) for f in frames))
        ):
            raise RecordError(
                "an event is {kind, message} with texts, and maybe a node id, where, frames (a list of texts) "
                f"and a traceback; got {_short(value)}"
            )
        kind, message, where, traceback = texts
        return cls(kind, message, node, where, tuple(frames), traceback)


class NodeState(msgspec.Struct, frozen=True, array_like=True):
    """A node's status and ``feedback_message`` after a tick (in JSON, ``[status, feedback]``)."""

    status: str
    feedback: str = ""


@dataclass
class RunHeader:
    """The first record: what ran, where, on what, when.

    Attributes:
        mission: The mission's name.
        mission_file: The mission file's path (empty when built in code).
        mission_sha256: The SHA-256 of the file's text.
        nodes: The tree, parents before children.
        world: The world (as a world file writes it) when the run is on the built-in
            emulator, else None.
        seed: The emulator's seed (None off the emulator).
        faults: The emulator's fault spec (empty off the emulator or without faults).
        port: The port URL.
        baud: The baud rate.
        tick_hz: Ticks per second.
        clock: ``real`` or ``virtual``.
        autonomy_version: The version of the package that ran it.
        date: When the run started, ISO 8601 with the time zone.
        telemetry: Whether the ticks carry what the robot reported (a BehaviorTree.CPP log
            read back has the tree's statuses only).
    """

    mission: str
    nodes: list[NodeInfo]
    tick_hz: float
    mission_file: str = ""
    mission_sha256: str = ""
    world: dict[str, Any] | None = None
    seed: int | None = None
    faults: str = ""
    port: str = ""
    baud: int = 0
    clock: str = "real"
    autonomy_version: str = ""
    date: str = ""
    telemetry: bool = True
    version: int = RECORD_VERSION

    def to_json(self) -> dict[str, Any]:
        """The header as one JSON object, to be written: its parameters and world are the record's own, not copies."""
        out: dict[str, Any] = {"type": "header"}
        for item in fields(self):
            out[item.name] = getattr(self, item.name)
        out["nodes"] = [{item.name: getattr(node, item.name) for item in fields(node)} for node in self.nodes]
        # in this version's form, as the ticks written after it are (a version-1 trace shown again)
        out["version"] = RECORD_VERSION
        return out

    def node(self, node_id: int) -> NodeInfo:
        """The node with id ``node_id``."""
        return self.nodes[node_id]

    def children(self) -> dict[int | None, list[int]]:
        """Each node's children's ids, in order (the root under None)."""
        out: dict[int | None, list[int]] = {}
        for node in self.nodes:
            out.setdefault(node.parent, []).append(node.id)
        return out


class TickRecord(msgspec.Struct, tag="tick", tag_field="type", omit_defaults=True, dict=True):
    """What one tick saw and did.

    Attributes:
        tick: 1 for the first tick.
        time_s: Seconds since the run started, when the tick began.
        status: The status packet polled before the tick.
        battery: The battery level (polled about once a second).
        healthy: The ``GR`` answer (polled with the battery).
        speed_mm_s: Speed along the odometer since the previous tick (negative: backward).
        dead_reckoning: Where the robot is by heading and odometer (works on a real robot).
        truth: Where the emulator says it is, on the built-in emulator only.
        nodes: The nodes whose status or feedback changed in this tick, by id.
        wire: Every attempt on the wire since the previous record, in order.
        events: Log messages and events of this tick.
    """

    tick: int
    time_s: float
    status: Packet
    battery: int
    healthy: bool
    speed_mm_s: float
    dead_reckoning: Pose
    truth: Pose | None = None
    nodes: dict[int, NodeState] = {}
    wire: list[Exchange] = []
    events: list[Event] = []
    #: The line :func:`to_line` made, kept on the record for the next listener. Not a field (no
    #: annotation): not written, compared or copied.
    _line = None

    def to_line(self) -> str:
        """:meth:`to_json` as one line of JSON, made by msgspec's encoder straight from the record.

        A run in virtual time writes thousands a second; the encoder, written in C, takes the
        record's fields as they are, several times faster than any line made in Python.

        Raises:
            ValueError: a number is not finite (NaN or infinity, which JSON cannot hold).
        """
        try:
            line = _encode(self)
        except UnicodeEncodeError:  # a behaviour's text holding a lone surrogate: escaped, as json does
            if not self.finite():
                raise ValueError(f"tick {self.tick} holds a number that is not finite") from None
            return json.dumps(self.to_json(), separators=(",", ":"))
        # the encoder writes NaN and infinity as null, which no field of a tick holds otherwise
        # (only a behaviour's text can spell it, and then the numbers are looked at)
        if b"null" in line and not self.finite():
            raise ValueError(f"tick {self.tick} holds a number that is not finite")
        return line.decode()

    def finite(self) -> bool:
        """Whether every number of the tick is finite (JSON holds neither NaN nor infinity)."""
        numbers = (self.time_s, self.speed_mm_s, *self.dead_reckoning, *(self.truth or ()))
        return all(math.isfinite(n) for n in numbers)

    def to_json(self) -> dict[str, Any]:
        """The tick as one JSON object (ids as text, as JSON writes them)."""
        out: dict[str, Any] = msgspec.to_builtins(self, str_keys=True)
        return out


_encode = msgspec.json.Encoder().encode


@dataclass
class RunEnd:
    """The last record: how the run ended.

    Attributes:
        outcome: succeeded, failed, interrupted...
        reason: Why, in a few words (empty when it simply succeeded).
        stopped: Whether the robot acknowledged the final stop.
        time_s: How long the run took.
        summary: The run's summary, as :class:`~autonomy.runner.RunSummary` counts it.
        paragraph: The summary in words.
        wire: Attempts on the wire after the last tick (halting nodes, the final stop).
        events: Events after the last tick, a behaviour's exception among them.
        truth: Where the emulator says the robot is once the final stop is answered, on the
            built-in emulator only.
    """

    outcome: str
    reason: str
    stopped: bool
    time_s: float
    summary: dict[str, Any] = field(default_factory=dict)
    paragraph: str = ""
    wire: list[Exchange] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)
    truth: Pose | None = None

    def to_json(self) -> dict[str, Any]:
        """The end as one JSON object."""
        out = {
            "type": "end",
            "outcome": self.outcome,
            "reason": self.reason,
            "stopped": self.stopped,
            "time_s": self.time_s,
            "summary": self.summary,
            "paragraph": self.paragraph,
            "wire": [e.to_json() for e in self.wire],
            "events": [e.to_json() for e in self.events],
        }
        if self.truth is not None:
            out["truth"] = self.truth.to_json()
        return out


Record = Union[RunHeader, TickRecord, RunEnd]
#: Anything that consumes records: the trace writer, the views, the grader.
Listener = Callable[[Record], None]


def _object(value: Any, what: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise RecordError(f"{what} must be an object, got {_short(value)}")
    return value


def _array(value: Any, what: str) -> list[Any]:
    if not isinstance(value, list):
        raise RecordError(f"{what} must be a list, got {_short(value)}")
    return value


def _status_from_json(value: dict[str, Any]) -> Packet:
    fields = {k: value[k] for k in Packet.__dataclass_fields__ if k != "raw"}
    return Packet(**fields, raw=_packet_bytes(value.get("raw") or ""))


def _packet_bytes(text: Any) -> bytes:
    """A packet's bytes as a trace writes them: base64 (version 2), or hex (version 1: 18 digits)."""
    if not isinstance(text, str):
        raise RecordError(f"a packet's raw bytes are text (base64), got {text!r}")
    try:  # 9 bytes are 18 hex digits, and 12 characters of base64 (18 is never whole base64)
        raw = bytes.fromhex(text) if len(text) == 2 * STATUS_LENGTH else base64.b64decode(text, validate=True)
    except (ValueError, binascii.Error):
        raise RecordError(f"a packet's raw bytes are base64 (hex before version 2), got {_short(text)}") from None
    if len(raw) not in (0, STATUS_LENGTH):
        raise RecordError(f"a status packet is 9 bytes (or none, for one made in code); raw holds {len(raw)}")
    return raw


def to_line(record: Record) -> str:
    """One record as one line of JSON (no newline); NaN and infinity are refused.

    The line is made once per record and kept on it, so the browser view's pages share the
    work. (The trace writer makes its lines a hundred at a time: :func:`tick_lines`.)
    """
    if type(record) is TickRecord:  # nearly every record: the short way first
        line = record._line
        if line is None:
            line = record._line = record.to_line()
        return line
    line = getattr(record, "_line", None)
    if line is None:
        if isinstance(record, TickRecord):
            line = record.to_line()
        else:
            try:
                line = json.dumps(record.to_json(), separators=(",", ":"), allow_nan=False)
            except ValueError:  # NaN or infinity: say which record
                kind = "header" if isinstance(record, RunHeader) else "end"
                raise ValueError(f"the run's {kind} record holds a number that is not finite") from None
        record._line = line  # type: ignore[union-attr]
    return line


def tick_lines(ticks: list[TickRecord]) -> tuple[str, str]:
    """The lines of ``ticks``, each with its newline, made in one call of the encoder.

    One call for a hundred ticks keeps the encoder's work together, which a run ticking in
    between would otherwise spread thin (and slow). The lines are those :func:`to_line` makes.
    Never raises for what a record holds: a trace problem ends the trace, not the run.

    Returns:
        The text, and why it stops short of the last tick (a number that is not finite, a text
        that cannot be written), or "".
    """
    try:
        data = _encode_lines(ticks)
    except Exception:  # noqa: BLE001 - a lone surrogate in a text, or what no encoder takes: line by line
        data = None
    # NaN and infinity are written as null; a behaviour's text can spell it too
    if data is not None and (b"null" not in data or all(tick.finite() for tick in ticks)):
        return data.decode(), ""
    lines = []
    for tick in ticks:
        try:
            lines.append(to_line(tick) + "\n")
        except Exception as err:  # noqa: BLE001 - what a trace cannot hold ends the trace, never the run
            why = str(err) if isinstance(err, ValueError) else f"tick {tick.tick} cannot be written ({err!r:.200})"
            return "".join(lines), why
    return "".join(lines), ""


_encode_lines = msgspec.json.Encoder().encode_lines


def ticks_json(ticks: list[TickRecord]) -> str:
    """``ticks`` as one JSON array, made in one call of the encoder: its items are the lines :func:`to_line` makes.

    Raises:
        ValueError: a number is not finite (NaN or infinity, which JSON cannot hold).
    """
    try:
        data = _encode(ticks)
    except Exception:  # noqa: BLE001 - a lone surrogate in a text, or what no encoder takes: line by line
        data = None
    if data is not None and (b"null" not in data or all(tick.finite() for tick in ticks)):
        return data.decode()
    return "[" + ",".join(to_line(tick) for tick in ticks) + "]"


def _battery(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 255:
        raise RecordError(f"battery must be a whole number from 0 to 255, got {value!r}")
    return value


def _node_state(value: Any) -> NodeState:
    if (
        not isinstance(value, list)
        or not 1 <= len(value) <= 2
        or value[0] not in (RUNNING, SUCCESS, FAILURE, INVALID)
        or (len(value) == 2 and not isinstance(value[1], str))
    ):
        raise RecordError(
            "a node's state is [status, feedback], the status RUNNING, SUCCESS, FAILURE or INVALID and the "
            f"feedback a text; got {_short(value)}"
        )
    return NodeState(value[0], value[1] if len(value) > 1 else "")


def _whole(value: Any, what: str) -> int:
    if type(value) is not int:
        raise RecordError(f"{what} must be a whole number, got {_short(value)}")
    return value


def _truth_value(value: Any, what: str) -> bool:
    if type(value) is not bool:
        raise RecordError(f"{what} must be true or false, got {_short(value)}")
    return value


def _short(value: Any) -> str:
    """``value`` as JSON, cut to a readable length for a message."""
    text = json.dumps(value, default=repr)
    return text if len(text) <= 80 else text[:77] + "..."


def _finite_numbers(value: Any, what: str) -> Any:
    """``value`` (a summary: numbers in objects), each number checked to be finite."""
    if isinstance(value, dict):
        for key, item in value.items():
            _finite_numbers(item, f"{what}.{key}")
    elif isinstance(value, list):
        for item in value:
            _finite_numbers(item, what)
    elif type(value) in (int, float) and not finite_number(value):
        raise RecordError(f"{what} must be a finite number, got {_short(value)}")
    return value


def _finite(value: Any, what: str) -> float:
    if not finite_number(value):
        raise RecordError(f"{what} must be a finite number, got {_short(value)}")
    return float(value)


def record_from_json(value: Any) -> Record:
    """Turns one JSON object back into its record.

    Raises:
        RecordError: not a record, a newer version, or a field missing or of the wrong kind.
    """
    if not isinstance(value, dict) or value.get("type") not in ("header", "tick", "end"):
        raise RecordError("not a record: expected an object with type header, tick or end")
    try:
        kind = value["type"]
        if kind == "header":
            version = int(value.get("version", 0))
            if version > RECORD_VERSION:
                raise RecordError(
                    f"this trace is of record version {version}; this autonomy reads up to {RECORD_VERSION}: upgrade it"
                )
            return RunHeader(
                mission=str(value["mission"]),
                nodes=[
                    NodeInfo(
                        int(n["id"]),
                        str(n["name"]),
                        str(n["type"]),
                        str(n["category"]),
                        dict(n.get("params") or {}),
                        None if n.get("parent") is None else int(n["parent"]),
                        str(n.get("file", "")),
                        int(n.get("line", 0)),
                    )
                    for n in value["nodes"]
                ],
                tick_hz=_finite(value["tick_hz"], "tick_hz"),
                mission_file=str(value.get("mission_file", "")),
                mission_sha256=str(value.get("mission_sha256", "")),
                world=value.get("world"),
                seed=value.get("seed"),
                faults=str(value.get("faults", "")),
                port=str(value.get("port", "")),
                baud=int(value.get("baud", 0)),
                clock=str(value.get("clock", "real")),
                autonomy_version=str(value.get("autonomy_version", "")),
                date=str(value.get("date", "")),
                telemetry=bool(value.get("telemetry", True)),
                version=version,
            )
        if kind == "tick":
            truth = value.get("truth")
            return TickRecord(
                tick=_whole(value["tick"], "tick"),
                time_s=_finite(value["time_s"], "time_s"),
                status=_status_from_json(value["status"]),
                battery=_battery(value["battery"]),
                healthy=_truth_value(value["healthy"], "healthy"),
                speed_mm_s=_finite(value["speed_mm_s"], "speed_mm_s"),
                dead_reckoning=Pose.from_json(value["dead_reckoning"]),
                truth=None if truth is None else Pose.from_json(truth),
                nodes={int(k): _node_state(v) for k, v in _object(value.get("nodes", {}), "nodes").items()},
                wire=[Exchange.from_json(e) for e in _array(value.get("wire", []), "wire")],
                events=[Event.from_json(e) for e in _array(value.get("events", []), "events")],
            )
        return RunEnd(
            outcome=str(value["outcome"]),
            reason=str(value.get("reason", "")),
            stopped=bool(value["stopped"]),
            time_s=_finite(value["time_s"], "time_s"),
            summary=_finite_numbers(dict(_object(value.get("summary") or {}, "summary")), "summary"),
            paragraph=str(value.get("paragraph", "")),
            wire=[Exchange.from_json(e) for e in _array(value.get("wire", []), "wire")],
            events=[Event.from_json(e) for e in _array(value.get("events", []), "events")],
            truth=None if value.get("truth") is None else Pose.from_json(value["truth"]),
        )
    except RecordError:
        raise
    except (KeyError, TypeError, ValueError, IndexError, AttributeError, OverflowError) as err:
        raise RecordError(f"a {value.get('type')} record with a missing or malformed field: {err!r}") from None


class TreeState:
    """Every node's latest state, folded from the changes that tick records carry.

    Args:
        header: The run's header (for the node count).
    """

    def __init__(self, header: RunHeader) -> None:
        self.nodes: dict[int, NodeState] = {n.id: NodeState(INVALID) for n in header.nodes}

    def apply(self, record: TickRecord) -> None:
        """Takes in one tick's changes."""
        self.nodes.update(record.nodes)

    def running(self) -> list[int]:
        """The ids of the RUNNING nodes, in tree order."""
        return [node_id for node_id, state in self.nodes.items() if state.status == RUNNING]


def fan_out(listeners: Iterable[Listener]) -> Listener:
    """One listener that hands each record to every one of ``listeners``, in order."""
    targets = list(listeners)

    def deliver(record: Record) -> None:
        for listener in targets:
            listener(record)

    return deliver

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

import json
import math
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
from json.encoder import encode_basestring_ascii
from typing import Any, NamedTuple, Union

from autonomy.protocol import Status as Packet

#: The version of the record format; a reader refuses records of a newer version.
RECORD_VERSION = 1

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
        """``[x_mm, y_mm, heading_deg]``, rounded to 0.1."""
        return [round(self.x_mm, 1), round(self.y_mm, 1), round(self.heading_deg, 1)]

    @classmethod
    def from_json(cls, value: Any) -> Pose:
        """The inverse of :meth:`to_json`."""
        x, y, heading = value
        return cls(float(x), float(y), float(heading))


@dataclass(frozen=True)
class Exchange:
    """One attempt on the wire: the frame sent and what came back.

    Attributes:
        sent: The command, without its newline (``F+200``).
        reply: ``OK``, ``NO``, a parameter value, ``status``, or ``error: ...``.
        attempt: 0 for a request's first attempt, 1.. for its retries.
    """

    sent: str
    reply: str
    attempt: int = 0
    #: Its JSON, kept on the value once made: the runner hands out the same exchange values again
    #: and again. Not a field (no annotation): ``fields``, ``asdict`` and ``astuple`` leave it out.
    _json = None

    def to_json(self) -> list[Any]:
        """``[sent, reply]``, with the attempt number third when it is a retry."""
        return [self.sent, self.reply, self.attempt] if self.attempt else [self.sent, self.reply]

    @classmethod
    def from_json(cls, value: Any) -> Exchange:
        """The inverse of :meth:`to_json`."""
        return cls(str(value[0]), str(value[1]), int(value[2]) if len(value) > 2 else 0)


@dataclass(frozen=True)
class Event:
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
        return cls(
            str(value["kind"]),
            str(value["message"]),
            value.get("node"),
            str(value.get("where", "")),
            tuple(value.get("frames", ())),
            str(value.get("traceback", "")),
        )


@dataclass(frozen=True)
class NodeState:
    """A node's status and ``feedback_message`` after a tick."""

    status: str
    feedback: str = ""

    def __init__(self, status: str, feedback: str = "") -> None:
        # Made for each node that changed, each tick: the fields set in the instance's dictionary
        # at once, where the frozen dataclass's own __init__ would set each through object.__setattr__.
        fields = self.__dict__
        fields["status"], fields["feedback"] = status, feedback


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
        """The header as one JSON object."""
        return {"type": "header", **asdict(self)}

    def node(self, node_id: int) -> NodeInfo:
        """The node with id ``node_id``."""
        return self.nodes[node_id]

    def children(self) -> dict[int | None, list[int]]:
        """Each node's children's ids, in order (the root under None)."""
        out: dict[int | None, list[int]] = {}
        for node in self.nodes:
            out.setdefault(node.parent, []).append(node.id)
        return out


@dataclass
class TickRecord:
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
    nodes: dict[int, NodeState] = field(default_factory=dict)
    wire: list[Exchange] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)
    #: The line :func:`to_line` made, kept for the next listener (a field, so that keeping it
    #: does not turn the record's attributes into a dictionary of their own).
    _line: str | None = field(default=None, init=False, repr=False, compare=False)

    def to_line(self) -> str:
        """:meth:`to_json` as one line of JSON, written out directly: a trace writes one per tick.

        It is the same JSON as ``json.dumps(self.to_json())`` (a test checks every field), made
        about three times faster, since a run in virtual time writes thousands a second.
        """
        s, truth, time_s, speed_mm_s = self.status, self.truth, self.time_s, self.speed_mm_s
        x_mm, y_mm, heading_deg = self.dead_reckoning  # poses are tuples: taken apart at once
        numbers = time_s + speed_mm_s + x_mm + y_mm + heading_deg
        if truth is not None:
            truth_x_mm, truth_y_mm, truth_heading_deg = truth
            numbers += truth_x_mm + truth_y_mm + truth_heading_deg
        if not math.isfinite(numbers):
            raise ValueError(f"tick {self.tick} holds a number that is not finite")
        nodes = ",".join(
            [
                f'"{k}":["{v.status}",{_text(v.feedback)}]' if v.feedback else f'"{k}":["{v.status}"]'
                for k, v in self.nodes.items()
            ]
        )
        exchanges = self.wire  # nearly always the status poll alone: no list to join
        if len(exchanges) == 1:
            wire = exchanges[0]._json or _exchange_json(exchanges[0])
        else:
            wire = ",".join([e._json or _exchange_json(e) for e in exchanges])
        tenths, raw = _TENTHS, s.raw
        fields = (
            self.tick,
            time_s,
            _FLAGS.get((s.mode, s.auto_mode, s.collided, s.moving)) or _flags_json(s),
            s.tilt_deg,
            s.heading_deg,
            s.front_distance_mm,
            s.odometer_mm,
            f",{_RAW}{raw.hex()}{_QUOTE}" if raw else "",
            self.battery,
            _JSON_BOOL[self.healthy],
            tenths.get(speed_mm_s) or _tenths(speed_mm_s),
            x_mm,
            y_mm,
            tenths.get(heading_deg) or _tenths(heading_deg),
            nodes,
            wire,
        )
        # One %-format for the whole line, the truth's included: several times faster than as
        # many f-string fields, or than formatting the truth apart and adding it on.
        if truth is None:
            line = _TICK_LINE % fields
        else:
            h = truth_heading_deg
            line = _TICK_LINE_TRUTH % (fields + (truth_x_mm, truth_y_mm, tenths.get(h) or _tenths(h)))
        if self.events:
            events = json.dumps([e.to_json() for e in self.events], separators=(",", ":"))
            line = f'{line[:-1]},"events":{events}}}'
        return line

    def to_json(self) -> dict[str, Any]:
        """The tick as one JSON object."""
        out: dict[str, Any] = {
            "type": "tick",
            "tick": self.tick,
            "time_s": round(self.time_s, 4),
            "status": _status_json(self.status),
            "battery": self.battery,
            "healthy": self.healthy,
            "speed_mm_s": round(self.speed_mm_s, 1),
            "dead_reckoning": self.dead_reckoning.to_json(),
            "nodes": {str(k): [v.status, v.feedback] if v.feedback else [v.status] for k, v in self.nodes.items()},
            "wire": [e.to_json() for e in self.wire],
        }
        if self.truth is not None:
            out["truth"] = self.truth.to_json()
        if self.events:
            out["events"] = [e.to_json() for e in self.events]
        return out


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
            "time_s": round(self.time_s, 4),
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


def _status_json(status: Packet) -> dict[str, Any]:
    out = status.as_dict()
    out.pop("raw", None)
    if status.raw:
        out["raw"] = status.raw.hex()
    return out


def _status_from_json(value: dict[str, Any]) -> Packet:
    raw = bytes.fromhex(value["raw"]) if value.get("raw") else b""
    fields = {k: value[k] for k in Packet.__dataclass_fields__ if k != "raw"}
    return Packet(**fields, raw=raw)


def to_line(record: Record) -> str:
    """One record as one line of JSON (no newline); NaN and infinity are refused.

    The line is made once per record and kept on it, so the trace writer and the browser
    view share the work.
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
            line = json.dumps(record.to_json(), separators=(",", ":"), allow_nan=False)
        record._line = line  # type: ignore[union-attr]
    return line


#: A string as JSON, quotes included, in ASCII as ``json.dumps`` writes the other lines: any text a
#: behaviour gives (a lone surrogate too) makes a line that can be written (the json module's own C encoder).
_text = encode_basestring_ascii
_TICK_LINE = (
    '{"type":"tick","tick":%d,"time_s":%.4f,"status":{%s,'
    '"tilt_deg":%d,"heading_deg":%d,"front_distance_mm":%d,"odometer_mm":%d%s},"battery":%d,"healthy":%s,'
    '"speed_mm_s":%s,"dead_reckoning":[%.1f,%.1f,%s],"nodes":{%s},"wire":[%s]}'
)
_TICK_LINE_TRUTH = _TICK_LINE[:-1] + ',"truth":[%.1f,%.1f,%s]}'
#: Headings and speeds written to a tenth, by value: a run holds the same few for many ticks,
#: and formatting a float takes several times as long as looking it up.
_TENTHS: dict[float, str] = {}
_MOST_TENTHS = 4096


def _tenths(value: float) -> str:
    text = f"{value:.1f}"
    if value and len(_TENTHS) < _MOST_TENTHS:  # 0.0 and -0.0 are one key, but two texts
        _TENTHS[value] = text
    return text


#: A packet's mode and flags as JSON, by value: a run holds the same few (at most 128) for many
#: ticks, and one field of the line costs less than four.
_FLAGS: dict[tuple[int, bool, bool, bool], str] = {}


def _flags_json(s: Packet) -> str:
    text = (
        f'"mode":{s.mode},"auto_mode":{_JSON_BOOL[s.auto_mode]},'
        f'"collided":{_JSON_BOOL[s.collided]},"moving":{_JSON_BOOL[s.moving]}'
    )
    _FLAGS[s.mode, s.auto_mode, s.collided, s.moving] = text
    return text


def _exchange_json(exchange: Exchange) -> str:
    e = exchange
    line = f"[{_text(e.sent)},{_text(e.reply)},{e.attempt}]" if e.attempt else f"[{_text(e.sent)},{_text(e.reply)}]"
    object.__setattr__(e, "_json", line)  # frozen, but the text is the value's own
    return line


_JSON_BOOL = {True: "true", False: "false"}
_RAW, _QUOTE = '"raw":"', '"'


def _battery(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 255:
        raise RecordError(f"battery must be a whole number from 0 to 255, got {value!r}")
    return value


def _node_state(value: Any) -> NodeState:
    if not isinstance(value, list) or not 1 <= len(value) <= 2 or value[0] not in (RUNNING, SUCCESS, FAILURE, INVALID):
        raise RecordError(
            f"a node's state is [status, feedback], the status RUNNING, SUCCESS, FAILURE or INVALID; got {value!r}"
        )
    return NodeState(value[0], str(value[1]) if len(value) > 1 else "")


def _finite(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise RecordError(f"{what} must be a finite number, got {value!r}")
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
                tick=int(value["tick"]),
                time_s=_finite(value["time_s"], "time_s"),
                status=_status_from_json(value["status"]),
                battery=_battery(value["battery"]),
                healthy=bool(value["healthy"]),
                speed_mm_s=_finite(value["speed_mm_s"], "speed_mm_s"),
                dead_reckoning=Pose.from_json(value["dead_reckoning"]),
                truth=None if truth is None else Pose.from_json(truth),
                nodes={int(k): _node_state(v) for k, v in value["nodes"].items()},
                wire=[Exchange.from_json(e) for e in value.get("wire", [])],
                events=[Event.from_json(e) for e in value.get("events", [])],
            )
        return RunEnd(
            outcome=str(value["outcome"]),
            reason=str(value.get("reason", "")),
            stopped=bool(value["stopped"]),
            time_s=_finite(value["time_s"], "time_s"),
            summary=dict(value.get("summary") or {}),
            paragraph=str(value.get("paragraph", "")),
            wire=[Exchange.from_json(e) for e in value.get("wire", [])],
            events=[Event.from_json(e) for e in value.get("events", [])],
            truth=None if value.get("truth") is None else Pose.from_json(value["truth"]),
        )
    except RecordError:
        raise
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as err:
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

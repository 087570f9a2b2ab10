"""BehaviorTree.CPP's FileLogger2 files (``.btlog``): written from tick records, and read back.

The format (BehaviorTree.CPP 4, what Groot2 opens)::

    "BTCPP4-FileLogger2"  a byte 1  XML length (4 bytes, little-endian)  the tree's XML
    start time: microseconds since the epoch (8 bytes, little-endian)
    then one 9-byte record per status change:
        microseconds since the start (6 bytes)  node uid (2 bytes)  status (1 byte)

Statuses are IDLE 0, RUNNING 1, SUCCESS 2, FAILURE 3, SKIPPED 4; uids count from 1 in the
order :func:`autonomy.mission.btcpp.instance` gives (a ``SubTree`` node has one too, and
changes with its subtree's root).

:class:`BtlogWriter` is a record listener, like the trace writer. :func:`read_btlog` reads a
file (ours or BehaviorTree.CPP's) into a :class:`~autonomy.trace.Trace`, so a replay, the
terminal view and the browser view play it like any trace; it has the tree and its statuses
only, no telemetry.
"""

from __future__ import annotations

import struct
from datetime import datetime
from pathlib import Path
from typing import Any, BinaryIO

from autonomy.clock import Clock, RealClock
from autonomy.errors import AutonomyError
from autonomy.mission.btcpp import Instance
from autonomy.mission.registry import BUILTINS
from autonomy.mission.xml_read import COMPOSITES, DECORATORS, WHILE_MARK, Element, XmlUnreadable, read_elements
from autonomy.protocol import Status as Packet
from autonomy.record import (
    FAILURE,
    INVALID,
    RUNNING,
    SUCCESS,
    NodeInfo,
    NodeState,
    Pose,
    Record,
    RunEnd,
    RunHeader,
    TickRecord,
)
from autonomy.trace import FlushTimer, Trace, tree_problem

MAGIC = b"BTCPP4-FileLogger2"
VERSION = 1
#: Our statuses as BehaviorTree.CPP's numbers, and back (SKIPPED reads as not run).
CODES = {INVALID: 0, RUNNING: 1, SUCCESS: 2, FAILURE: 3}
STATUSES = {0: INVALID, 1: RUNNING, 2: SUCCESS, 3: FAILURE, 4: INVALID}
#: Changes this close together are one tick when a file is read back.
SAME_TICK_US = 1000
#: Largest file read back: 555,000 status changes, hours of a run (each costs up to 0.5 kB once read).
MAX_BYTES = 5_000_000
_RECORD = struct.Struct("<6sHB")
#: One state object per status, shared by every tick read back.
_STATES = {status: NodeState(status) for status in (INVALID, RUNNING, SUCCESS, FAILURE)}


class BtlogError(AutonomyError):
    """A file that is not a FileLogger2 file this can read; the message says where and why."""


def epoch_us(iso_date: str) -> int:
    """An ISO 8601 date with its time zone as microseconds since the epoch (0 when there is none)."""
    try:
        return round(datetime.fromisoformat(iso_date).timestamp() * 1_000_000)
    except ValueError:
        return 0


class BtlogWriter:
    """A listener that writes a run as a FileLogger2 file.

    Args:
        stream: A binary file open for writing.
        tree: The mission's tree as BehaviorTree.CPP numbers it.
    """

    def __init__(self, stream: BinaryIO, tree: Instance, clock: Clock | None = None) -> None:
        self.stream = stream
        self.tree = tree
        self._flush = FlushTimer(clock or RealClock())
        self.uids: dict[int, list[int]] = {}
        for uid, record_id in enumerate(tree.record_ids, start=1):
            self.uids.setdefault(record_id, []).append(uid)
        #: The status code last written for each record node (a change of feedback alone is not written).
        self._written: dict[int, int] = {}
        self.failure = ""
        #: How many status changes were written.
        self.changes_written = 0

    def __call__(self, record: Record) -> None:
        """Writes the header, or one tick's changes; once writing fails, notes why and stops."""
        if self.failure:
            return
        try:
            if isinstance(record, RunHeader):
                xml = self.tree.xml.encode("utf-8")
                start = epoch_us(record.date)
                self.stream.write(
                    MAGIC + bytes([VERSION]) + struct.pack("<I", len(xml)) + xml + struct.pack("<Q", start)
                )
                self.stream.flush()
            elif isinstance(record, TickRecord) and record.nodes:
                written, changed = self._written, []
                for node_id, state in record.nodes.items():
                    code = CODES.get(state.status, 0)
                    if written.get(node_id, 0) != code:
                        written[node_id] = code
                        changed.append(node_id)
                if changed:
                    uids = self.uids
                    changes = sorted((uid, written[node_id]) for node_id in changed for uid in uids.get(node_id, ()))
                    self.write_changes(round(record.time_s * 1_000_000), changes)
                    self.changes_written += len(changes)
                if self._flush.due():
                    self.stream.flush()
            elif isinstance(record, RunEnd):
                self.stream.flush()
        except (OSError, ValueError) as err:
            self.failure = getattr(err, "strerror", None) or str(err)

    def write_changes(self, time_us: int, changes: list[tuple[int, int]]) -> None:
        """Writes status changes as they are: ``(uid, status code)`` at ``time_us`` after the start.

        Raises:
            OSError: the file cannot be written.
        """
        offset = min(max(0, time_us), (1 << 48) - 1).to_bytes(6, "little")
        self.stream.write(b"".join(_RECORD.pack(offset, uid, code) for uid, code in changes))


def _category(tag: str) -> str:
    if tag in COMPOSITES:
        return "composite"
    if tag in DECORATORS or tag == "SubTree":
        return "decorator"
    return "action"


def _port_value(param: Any, text: str) -> Any:
    """A port's text as the parameter's kind has it (what a mission file would have given)."""
    try:
        if param.kind == "int":
            return int(text)
        if param.kind == "number":  # a whole number stays one, as YAML reads it
            return int(text) if text.strip().lstrip("-").isdigit() else float(text)
        if param.kind == "bool":
            return text.strip().lower() in ("true", "1")
        if param.kind == "tones":
            return [int(part) for part in text.split(";")]
    except ValueError:
        return text
    return text


def _ours(tag: str, ports: dict[str, str]) -> tuple[str, str, str] | None:
    """One of our node types as BehaviorTree.CPP wrote it: (its type, category, name as a trace names it), or None."""
    args: dict[str, Any] = {}
    if tag in COMPOSITES:
        ours, fixed = COMPOSITES[tag]
        args.update(fixed)
    elif tag in DECORATORS:
        ours = DECORATORS[tag]
        if "num_cycles" in ports:  # BehaviorTree.CPP's ports, as our parameters
            cycles = ports.pop("num_cycles").strip()
            args["times"] = None if cycles == "-1" else int(cycles) if cycles.isdigit() else cycles
        if "num_attempts" in ports:
            args["attempts"] = ports.pop("num_attempts")
        if "msec" in ports:
            msec = ports.pop("msec")
            args["seconds"] = float(msec) / 1000 if msec.strip().isdigit() else msec
    else:
        ours = tag
    node_type = BUILTINS.get(ours)
    if node_type is None:
        return None
    for param in node_type.params:
        if param.name in ports:
            args[param.name] = _port_value(param, ports[param.name])
        args.setdefault(param.name, param.default)
    try:
        name = node_type.label(args)
    except Exception:  # noqa: BLE001 - a port our label cannot read: the node keeps BehaviorTree.CPP's name
        return None
    return node_type.name, node_type.category, name


def _nodes(root: Element, where: str) -> list[NodeInfo]:
    """The tree in the XML as nodes with ids uid - 1, subtrees under their ``SubTree`` nodes."""
    trees = {tree.attributes.get("_fullpath", ""): tree for tree in root.children if tree.tag == "BehaviorTree"}
    if "" not in trees:
        raise BtlogError(f'{where}: its XML has no main tree (a <BehaviorTree _fullpath="">)')
    found: dict[int, NodeInfo] = {}
    todo: list[tuple[Element, int | None]] = [(child, None) for child in reversed(trees[""].children)]
    while todo:
        element, parent = todo.pop()
        try:
            uid = int(element.attributes["_uid"])
        except (KeyError, ValueError):
            raise BtlogError(f"{where}: <{element.tag}> at XML line {element.line} has no _uid") from None
        if uid in found or not 1 <= uid <= 65535:
            raise BtlogError(f"{where}: uid {uid} at XML line {element.line} is given twice or out of range")
        tag = element.tag
        ports = {k: v for k, v in element.attributes.items() if not k.startswith("_") and k not in ("name", "ID")}
        if tag == "SubTree":
            name, category = element.attributes.get("ID", "SubTree"), _category(tag)
            inner = trees.get(element.attributes.get("_fullpath", ""))
            children = inner.children if inner is not None else []
        else:
            named = element.attributes.get("name", "")
            unnamed = not named or named == tag  # BehaviorTree.CPP names a node by its type when it has no name
            marked = tag == "ReactiveSequence" and element.attributes.get(WHILE_MARK[0]) == WHILE_MARK[1]
            ours = _ours("While" if marked else tag, dict(ports))
            if ours is not None:  # one of ours: its type, category and name as a trace of the run has them
                tag, category, label = ours
                name = label if unnamed else named
            else:
                category, name = _category(tag), named or tag
                if unnamed and ports:
                    name = f"{tag} " + " ".join(f"{k}={v}" for k, v in ports.items())
            children = element.children
        found[uid] = NodeInfo(uid - 1, name, tag, category, ports, parent)
        todo.extend((child, uid - 1) for child in reversed(children))
    if sorted(found) != list(range(1, len(found) + 1)):
        raise BtlogError(f"{where}: its uids are not 1..{len(found)}")
    return [found[uid] for uid in range(1, len(found) + 1)]


def read_btlog(path: str | Path) -> Trace:
    """Reads a FileLogger2 file as a trace: its tree, and one tick per burst of changes.

    Changes less than :data:`SAME_TICK_US` after the first of a tick are that tick; within it, a node that
    goes back to IDLE keeps the status it had (as Groot2 shows it, faded).

    Raises:
        BtlogError: not a FileLogger2 file, or one whose tree cannot be read.
    """
    path = Path(path)
    try:
        with open(path, "rb") as stream:
            data = stream.read(MAX_BYTES + 1)
    except OSError as err:
        raise BtlogError(f"{path}: cannot read it: {err.strerror or err}") from None
    if len(data) > MAX_BYTES:
        raise BtlogError(f"{path}: larger than {MAX_BYTES:,} bytes")
    if not data.startswith(MAGIC):
        raise BtlogError(f"{path}: not a BehaviorTree.CPP FileLogger2 file (it starts {data[:18]!r})")
    head = len(MAGIC)
    if len(data) < head + 5:
        raise BtlogError(f"{path}: cut off in its header")
    if data[head] != VERSION:
        raise BtlogError(f"{path}: FileLogger2 version {data[head]}; this reads version {VERSION}")
    (length,) = struct.unpack_from("<I", data, head + 1)
    xml_end = head + 5 + length
    if len(data) < xml_end + 8:
        raise BtlogError(f"{path}: cut off in its tree ({length:,} bytes of XML announced)")
    try:
        root = read_elements(data[head + 5 : xml_end].decode("utf-8"))
    except UnicodeDecodeError:
        raise BtlogError(f"{path}: its tree is not UTF-8 text") from None
    except XmlUnreadable as err:
        raise BtlogError(f"{path}: its tree's XML, line {err.error.line}: {err.error.message}") from None
    if root.tag != "root":
        raise BtlogError(f"{path}: its tree's XML is <{root.tag}>, not a BehaviorTree.CPP <root>")
    nodes = _nodes(root, str(path))
    (start_us,) = struct.unpack_from("<q", data, xml_end)  # BehaviorTree.CPP writes it signed
    try:
        date = datetime.fromtimestamp(start_us / 1_000_000).astimezone().isoformat() if start_us > 0 else ""
    except (ValueError, OverflowError, OSError):
        date = ""  # not a date this machine can show: the run's own times are all that matter
    header = RunHeader(
        mission=root.children[0].attributes.get("ID", path.stem) if root.children else path.stem,
        nodes=nodes,
        tick_hz=0.0,
        mission_file=str(path),
        port="btlog",
        date=date,
        clock="recorded",
        telemetry=False,
    )
    why = tree_problem(header)
    if why:
        raise BtlogError(f"{path}: {why}")
    ticks: list[TickRecord] = []
    body = memoryview(data)[xml_end + 8 :]
    whole = len(body) - len(body) % _RECORD.size
    group: dict[int, NodeState] = {}
    group_us = -1
    zero = Packet(
        mode=0,
        auto_mode=False,
        collided=False,
        moving=False,
        tilt_deg=0,
        heading_deg=0,
        front_distance_mm=0,
        odometer_mm=0,
    )
    pose = Pose(0.0, 0.0, 0.0)

    def close(at_us: int) -> None:
        if group:
            time_s = at_us / 1_000_000
            ticks.append(TickRecord(len(ticks) + 1, time_s, zero, 0, True, 0.0, pose, nodes=dict(group)))
            group.clear()

    for offset in range(0, whole, _RECORD.size):
        stamp, uid, code = _RECORD.unpack_from(body, offset)
        at_us = int.from_bytes(stamp, "little")
        if uid < 1 or uid > len(nodes) or code not in STATUSES:
            raise BtlogError(f"{path}: record {offset // _RECORD.size + 1} names uid {uid}, status {code}")
        if group and at_us - group_us >= SAME_TICK_US:
            close(group_us)
        if not group:
            group_us = at_us
        status = STATUSES[code]
        if status != INVALID or uid - 1 not in group:
            group[uid - 1] = _STATES[status]
    close(group_us)
    end_s = ticks[-1].time_s if ticks else 0.0
    root_state = next((t.nodes[0].status for t in reversed(ticks) if 0 in t.nodes), INVALID)
    outcome = {SUCCESS: "succeeded", FAILURE: "failed"}.get(root_state, "recorded")
    end = RunEnd(outcome, "", False, end_s, paragraph=f"{path.name}: {len(ticks)} ticks recorded, root {root_state}")
    return Trace(header, ticks, end)

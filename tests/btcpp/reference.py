"""BehaviorTree.CPP itself (``behaviortreepy``, 4.8.2 inside), as the reference our formats are checked against.

Its Python bindings register leaves without ports, so a copy of our XML with the leaves'
attributes taken off is what it loads (the ports are checked against the model apart).
"""

from __future__ import annotations

import re
import struct
import xml.etree.ElementTree as ET
from collections import deque
from pathlib import Path

import behaviortreepy as bt

from autonomy.mission import MissionSpec

S = bt.NodeStatus
CODES = {S.IDLE: 0, S.RUNNING: 1, S.SUCCESS: 2, S.FAILURE: 3}
NAMES = {"RUNNING": S.RUNNING, "SUCCESS": S.SUCCESS, "FAILURE": S.FAILURE}


def leaf_names(spec: MissionSpec) -> set[str]:
    return {t.name for t in spec.registry if t.category in ("action", "condition")}


def for_reference(xml: str, leaves: set[str]) -> str:
    """Our XML as the reference can load it: leaves without attributes (our while is its ReactiveSequence)."""

    def strip(match: re.Match) -> str:
        return f"<{match.group(1)}{match.group(3)}" if match.group(1) in leaves else match.group(0)

    return re.sub(r"<(\w+)((?:\s+\w+=\"[^\"]*\")*)\s*(/?>)", strip, xml)


def factory(spec: MissionSpec, script: dict[int, deque] | None = None) -> bt.BehaviorTreeFactory:
    """A factory with our leaves registered; with ``script``, each leaf returns its uid's next status."""
    made = bt.BehaviorTreeFactory()

    def next_status(node, exhausted):
        queue = script.get(node.uid()) if script else None
        return NAMES[queue.popleft()] if queue else exhausted

    for node_type in spec.registry:
        if node_type.category == "action":
            made.register_simple_stateful_action(
                node_type.name,
                lambda node: next_status(node, S.RUNNING),
                lambda node: next_status(node, S.RUNNING),
                lambda node: None,
            )
        elif node_type.category == "condition":
            made.register_simple_condition(node_type.name, lambda node: next_status(node, S.FAILURE))
    return made


def read_btlog(path: Path) -> tuple[bytes, str, int, list[tuple[int, int, int]]]:
    """A FileLogger2 file's parts: magic and version, XML, start time, (time, uid, status) records."""
    data = path.read_bytes()
    head = len(b"BTCPP4-FileLogger2")
    (length,) = struct.unpack_from("<I", data, head + 1)
    xml = data[head + 5 : head + 5 + length].decode()
    (start,) = struct.unpack_from("<Q", data, head + 5 + length)
    body = data[head + 5 + length + 8 :]
    records = [
        (int.from_bytes(body[i : i + 6], "little"), int.from_bytes(body[i + 6 : i + 8], "little"), body[i + 8])
        for i in range(0, len(body) - len(body) % 9, 9)
    ]
    return data[: head + 1], xml, start, records


def tree_shape(xml: str, with_ports: bool = True) -> list[tuple]:
    """Every node of a running tree's XML: (uid, tag, name, subtree path, parent uid, ports), by uid."""
    root = ET.fromstring(xml)
    trees = {t.get("_fullpath", ""): t for t in root.findall("BehaviorTree")}
    out = []

    def walk(element: ET.Element, parent: int) -> None:
        uid = int(element.get("_uid"))
        ports = {k: v for k, v in element.attrib.items() if not k.startswith("_") and k not in ("name", "ID")}
        out.append(
            (
                uid,
                element.tag,
                element.get("name") or element.get("ID"),
                element.get("_fullpath", ""),
                parent,
                tuple(sorted(ports.items())) if with_ports else (),
            )
        )
        children = list(trees[element.get("_fullpath")]) if element.tag == "SubTree" else list(element)
        for child in children:
            walk(child, uid)

    for child in trees[""]:
        walk(child, 0)
    return sorted(out)


def wait_for_records(logger, path: Path, at_least: int, within_s: float = 10.0) -> None:
    """Waits until BehaviorTree.CPP's FileLogger, which writes from a thread of its own, has written.

    The logger must stay alive meanwhile: destroyed, it drops what it had not written yet. Its thread
    flushes the file after each batch; the logger's own ``flush()`` is never called here, as it flushes
    the same stream from this thread without a lock, racing the writer (it once left a record of garbage).
    """
    import time

    del logger  # kept alive by the caller; only its thread touches the file
    deadline = time.monotonic() + within_s
    while len(_records_so_far(path)) < at_least or not _header_whole(path):
        assert time.monotonic() < deadline, f"{path}: FileLogger wrote fewer than {at_least} records"
        time.sleep(0.02)


def settled(logger, path: Path, quiet_s: float = 0.2, within_s: float = 10.0) -> None:
    """Waits until BehaviorTree.CPP's FileLogger has written all it will: no new record for ``quiet_s``.

    The logger must stay alive meanwhile: destroyed, it drops what it had not written yet. As in
    :func:`wait_for_records`, its racy ``flush()`` is left to its own thread.
    """
    import time

    del logger  # kept alive by the caller; only its thread touches the file
    deadline = time.monotonic() + within_s
    count = -1
    while True:
        now = len(_records_so_far(path))
        if now == count and _header_whole(path):
            return
        assert time.monotonic() < deadline, f"{path}: FileLogger still writing after {within_s} s"
        count = now
        time.sleep(quiet_s)


def _records_so_far(path: Path) -> list:
    """The records written so far; none while the header is still being written."""
    try:
        return read_btlog(path)[3]
    except (struct.error, UnicodeDecodeError):
        return []


def _header_whole(path: Path) -> bool:
    try:
        read_btlog(path)
    except (struct.error, UnicodeDecodeError):
        return False
    return True

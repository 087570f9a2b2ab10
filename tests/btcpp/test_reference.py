"""Our BehaviorTree.CPP formats against BehaviorTree.CPP itself: XML, FileLogger2 and the Groot2 protocol."""

from __future__ import annotations

import struct
import xml.etree.ElementTree as ET
from collections import deque
from pathlib import Path

import pytest
import zmq

from autonomy.behaviours.tree import preorder
from autonomy.btlog import BtlogWriter, read_btlog
from autonomy.client import Client
from autonomy.groot import GrootPublisher
from autonomy.mission import build_tree, load_mission, validate_text
from autonomy.mission.btcpp import export_xml, instance
from autonomy.record import RunHeader
from autonomy.runner import Runner
from tests.btcpp import reference
from tests.btcpp.reference import bt
from tests.harness import Recorder, mission_files

MISSIONS = mission_files(Path("missions").glob("*.yaml"))


def reference_tree(spec, script=None):
    made = reference.factory(spec, script)
    made.register_behavior_tree_from_text(reference.for_reference(export_xml(spec), reference.leaf_names(spec)))
    return made.create_tree(spec.name)


def logged_xml(tree, path: Path) -> str:
    logger = bt.FileLogger(tree, str(path))
    reference.wait_for_records(logger, path, 0)  # the header: it is written from a thread too
    del logger
    return reference.read_btlog(path)[1]


def leafless(shape: list[tuple], leaves: set[str]) -> list[tuple]:
    """Leaves without ports (the reference cannot declare them)."""
    out = []
    for uid, tag, name, path, parent, ports in shape:
        out.append((uid, tag, name, path, parent, () if tag in leaves else ports))
    return out


@pytest.mark.parametrize("path", MISSIONS, ids=lambda p: p.stem)
def test_every_mission_builds_the_same_tree_in_behaviortree_cpp(path, tmp_path):
    spec = load_mission(path)
    ours = instance(spec)
    theirs = logged_xml(reference_tree(spec), tmp_path / "ref.btlog")
    leaves = reference.leaf_names(spec)
    # Same nodes, uids, tags, names, subtree paths, parents, and the ports of BehaviorTree.CPP's own nodes.
    assert leafless(reference.tree_shape(ours.xml), leaves) == leafless(reference.tree_shape(theirs), leaves)
    assert len(ours.record_ids) == len(reference.tree_shape(theirs))


@pytest.mark.parametrize("path", MISSIONS, ids=lambda p: p.stem)
def test_every_leaf_attribute_is_a_port_of_the_model_with_a_value_of_its_type(path):
    spec = load_mission(path)
    root = ET.fromstring(export_xml(spec))
    model = {
        element.get("ID"): {port.get("name"): port for port in element.iter("input_port")}
        for element in root.find("TreeNodesModel")
    }
    leaves = reference.leaf_names(spec)
    used = [element for tree in root.findall("BehaviorTree") for element in tree.iter() if element.tag in leaves]
    assert used, "every shipped mission has leaves"
    for element in used:
        ports = model[element.tag]
        for key, value in element.attrib.items():
            if key == "name":
                continue
            assert key in ports, f"{element.tag}.{key} is not in the model"
            kind = ports[key].get("type")
            if kind == "int":
                int(value)
            elif kind == "double":
                float(value)
            elif kind == "bool":
                assert value in ("true", "false")
            elif kind == "std::vector<int>":
                assert all(part.isdigit() for part in value.split(";"))
    for node_type in spec.registry:
        if node_type.category in ("action", "condition") and node_type.name in model:
            for param in node_type.params:
                port = model[node_type.name][param.name]
                assert port.text and param.doc in port.text
                if param.default is not None:
                    assert port.get("default") is not None


#: Emulator options that let a mission end on its own within the time limit.
OPTIONS = {"patrol": "&battery=60"}


def recorded_run(spec, max_seconds=120.0):
    """Runs the mission on the emulator; every leaf's returned statuses, in order, by BehaviorTree.CPP uid."""
    root = build_tree(spec)
    returned: dict[int, list[str]] = {}
    for record_id, node in enumerate(preorder(root)):
        if not node.children:
            calls = returned.setdefault(record_id, [])
            original = node.update

            def update(original=original, calls=calls):
                status = original()
                calls.append(status.name)
                return status

            node.update = update
    client = Client.open(f"emu://?time=virtual&world={spec.world or 'box'}{OPTIONS.get(spec.name, '')}")
    recorder = Recorder()
    try:
        Runner(
            root, client, mission=spec.name, tick_hz=spec.tick_hz, max_seconds=max_seconds, listeners=[recorder]
        ).run()
    finally:
        client.close()
    root_status = next(t.nodes[0].status for t in reversed(recorder.ticks) if 0 in t.nodes)
    tree = instance(spec)
    script = {
        uid: deque(returned[record_id])
        for uid, record_id in enumerate(tree.record_ids, 1)
        if record_id in returned and tree.tags[uid - 1] != "SubTree"
    }
    return root_status, script


def tick_to_the_end(tree):
    status = reference.S.RUNNING
    for _ in range(50_000):
        status = tree.tick_once()
        if status != reference.S.RUNNING:
            break
    return status.name


@pytest.mark.parametrize("path", MISSIONS, ids=lambda p: p.stem)
def test_behaviortree_cpp_ticking_our_leaves_statuses_ends_with_our_root_status(path):
    spec = load_mission(path)
    ours, script = recorded_run(spec)
    assert ours == "SUCCESS"  # each shipped mission ends on its own
    assert tick_to_the_end(reference_tree(spec, script)) == ours


def test_a_run_that_fails_fails_in_behaviortree_cpp_too():
    text = (
        "mission: bump\nworld: box\ntree:\n  sequence:\n    - beep\n"
        "    - retry: {attempts: 2, do: {parallel: {policy: one, children: [{wait: {seconds: 30}}, "
        "{move: {speed: 2}}]}}}\n"
    )
    spec = validate_text(text, "bump.yaml")
    ours, script = recorded_run(spec)
    assert ours == "FAILURE"
    assert tick_to_the_end(reference_tree(spec, script)) == ours


def test_our_btlog_and_behaviortree_cpps_are_the_same_apart_from_timestamps(tmp_path):
    spec = load_mission("missions/square.yaml")
    _, script = recorded_run(spec)
    tree = reference_tree(spec, script)
    logger = bt.FileLogger(tree, str(tmp_path / "theirs.btlog"))
    assert tree.tick_while_running(1).name == "SUCCESS"
    reference.settled(logger, tmp_path / "theirs.btlog")
    del logger
    magic, their_xml, their_start, theirs = reference.read_btlog(tmp_path / "theirs.btlog")
    assert len(theirs) > 50
    # The same status changes, through our writer.
    ours_tree = instance(spec)
    with open(tmp_path / "ours.btlog", "wb") as stream:
        writer = BtlogWriter(stream, ours_tree)
        writer(RunHeader(spec.name, [], 20.0, date="2026-11-23T10:00:00+00:00"))
        for time_us, uid, code in theirs:
            writer.write_changes(time_us, [(uid, code)])
    our_magic, our_xml, our_start, ours = reference.read_btlog(tmp_path / "ours.btlog")
    assert our_magic == magic == b"BTCPP4-FileLogger2\x01"
    assert our_start == 1_795_428_000_000_000 and abs(their_start - our_start) < 86_400 * 1_000_000 * 366
    assert ours == theirs  # every record's time, uid and status, byte for byte
    data = (tmp_path / "ours.btlog").read_bytes()
    assert len(data) == len(magic) + 4 + len(our_xml.encode()) + 8 + 9 * len(theirs)
    leaves = reference.leaf_names(spec)
    assert leafless(reference.tree_shape(our_xml), leaves) == leafless(reference.tree_shape(their_xml), leaves)


def test_our_reader_reads_behaviortree_cpps_btlog_and_ours_alike(tmp_path):
    spec = load_mission("missions/square.yaml")
    _, script = recorded_run(spec)
    tree = reference_tree(spec, script)
    logger = bt.FileLogger(tree, str(tmp_path / "theirs.btlog"))
    tree.tick_while_running(1)
    reference.settled(logger, tmp_path / "theirs.btlog")
    del logger
    theirs = read_btlog(tmp_path / "theirs.btlog")
    # Ours, from a run of the same mission.
    client = Client.open("emu://?time=virtual&world=box")
    recorder = Recorder()
    with open(tmp_path / "ours.btlog", "wb") as stream:
        Runner.for_mission(spec, client, listeners=[BtlogWriter(stream, instance(spec)), recorder]).run()
    client.close()
    ours = read_btlog(tmp_path / "ours.btlog")
    shape = [(n.id, n.type, n.parent) for n in ours.header.nodes]
    assert shape == [(n.id, n.type, n.parent) for n in theirs.header.nodes]
    # our node types, named as a trace of the run names them; BehaviorTree.CPP's SubTree kept
    assert [n.type for n in ours.header.nodes] == ["repeat", "sequence", "move", "SubTree", "sequence", "turn", "beep"]
    assert [n.name for n in ours.header.nodes][:3] == ["repeat x4", "sequence", "move 300 mm"]
    assert not ours.header.telemetry and theirs.end.outcome == ours.end.outcome == "succeeded"
    # Our ticks come back one for one with the status changes each carried (a change of feedback alone is
    # not a change BehaviorTree.CPP logs), the SubTree node mirroring its subtree's root.
    last: dict[int, str] = {}
    changed = []
    for tick in recorder.ticks:
        statuses = {k: v.status for k, v in tick.nodes.items() if last.get(k, "INVALID") != v.status}
        last.update(statuses)
        if statuses:
            changed.append((tick.time_s, statuses))
    assert len(ours.ticks) == len(changed) >= 8  # each side: the move starts; it ends and the turn starts
    ids = instance(spec).record_ids
    for back, (time_s, statuses) in zip(ours.ticks, changed, strict=True):
        assert back.time_s == pytest.approx(time_s, abs=1e-6)
        assert {ids[i]: s.status for i, s in back.nodes.items()} == statuses


def free_port_pair() -> int:
    """A port that is free, with the next one free too (the reference binds both)."""
    import socket

    for _ in range(50):
        with socket.socket() as first, socket.socket() as second:
            first.bind(("0.0.0.0", 0))
            port = first.getsockname()[1]
            try:
                second.bind(("0.0.0.0", port + 1))
            except OSError:
                continue
            return port
    raise AssertionError("no two free ports in a row")


def _ask(port: int, kind: bytes, *more: bytes, request_id: int = 7) -> list[bytes]:
    """One request: a header of type ``kind``, then the frames ``more``."""
    context = zmq.Context()
    socket = context.socket(zmq.REQ)
    socket.setsockopt(zmq.RCVTIMEO, 5000)
    socket.setsockopt(zmq.LINGER, 0)
    socket.connect(f"tcp://127.0.0.1:{port}")
    try:
        socket.send_multipart([bytes([2]) + kind + struct.pack("<I", request_id), *more])
        return socket.recv_multipart()
    finally:
        socket.close()
        context.term()


def test_our_groot2_publisher_answers_as_behaviortree_cpps_does(tmp_path):
    spec = load_mission("missions/square.yaml")
    tree = reference_tree(spec)
    their_port = free_port_pair()
    publisher = bt.Groot2Publisher(tree, their_port)
    ours = GrootPublisher(instance(spec), port=0).start()
    try:
        for kind in (b"T", b"S"):
            theirs, mine = _ask(their_port, kind), _ask(ours.port, kind)
            assert [len(f) for f in theirs[:1]] == [len(f) for f in mine[:1]] == [22]
            assert len(theirs) == len(mine) == 2
            assert theirs[0][:6] == mine[0][:6] == bytes([2]) + kind + struct.pack("<I", 7)
        leaves = reference.leaf_names(spec)
        their_xml, my_xml = _ask(their_port, b"T")[1].decode(), _ask(ours.port, b"T")[1].decode()
        assert leafless(reference.tree_shape(my_xml), leaves) == leafless(reference.tree_shape(their_xml), leaves)
        their_s, my_s = _ask(their_port, b"S")[1], _ask(ours.port, b"S")[1]
        uids = lambda body: [int.from_bytes(body[i : i + 2], "little") for i in range(0, len(body), 3)]  # noqa: E731
        assert uids(their_s) == uids(my_s) == list(range(1, 8))
        assert set(their_s[2::3]) == set(my_s[2::3]) == {0}  # nothing has run yet: all IDLE
        # The same tree id on every answer, and the request's id echoed.
        assert _ask(ours.port, b"S", request_id=9)[0][2:6] == struct.pack("<I", 9)
        assert _ask(ours.port, b"S")[0][6:] == _ask(ours.port, b"T")[0][6:]
        names = b"square;corner::4"
        assert _ask(their_port, b"B", names)[1] == _ask(ours.port, b"B", names)[1]
        # Recording (Groot2 PRO) and breakpoints: nothing is kept, in either.
        for frames in ([b"t"], [b"r"], [b"r", b"1"], [b"t"], [b"r", b"0"], [b"D"], [b"X"], [b"A"]):
            theirs, mine = _ask(their_port, *frames), _ask(ours.port, *frames)
            assert [f[:6] for f in theirs] == [f[:6] for f in mine], frames
            assert [len(f) for f in theirs] == [len(f) for f in mine], frames
        for port in (their_port, ours.port):
            assert _ask(port, b"B") == [b"error", b"must be 2 parts message"]
            assert _ask(port, b"M") == [b"error", b"Request not recognized"]
    finally:
        ours.stop()
        del publisher


def test_groot2_is_told_each_node_status_and_a_finished_node_as_ten_plus_what_it_was():
    spec = load_mission("missions/square.yaml")
    ours = GrootPublisher(instance(spec), port=0).start()
    client = Client.open("emu://?time=virtual&world=box")
    seen = []

    def watch(record):
        ours(record)
        if getattr(record, "tick", 0) in (1, 60):
            seen.append(_ask(ours.port, b"S")[1])

    try:
        Runner.for_mission(spec, client, listeners=[watch]).run()
    finally:
        client.close()
    status = lambda body: {int.from_bytes(body[i : i + 2], "little"): body[i + 2] for i in range(0, len(body), 3)}  # noqa: E731
    first, later = status(seen[0]), status(seen[1])
    assert first == {1: 1, 2: 1, 3: 1, 4: 0, 5: 0, 6: 0, 7: 0}  # repeat, sequence and the move run; the corner waits
    assert later[4] == later[5] in (1, 12)  # a SubTree node shows its subtree's root
    assert 12 in later.values()  # a node that succeeded and was reset: 10 + SUCCESS
    ours.stop()

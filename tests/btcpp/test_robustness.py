"""The Groot2 publisher and .btlog files facing what a careless or hostile peer or file does."""

from __future__ import annotations

import struct

import pytest
import zmq

from autonomy.btlog import MAGIC, BtlogError, BtlogWriter, read_btlog
from autonomy.clock import VirtualClock
from autonomy.groot import GrootPublisher
from autonomy.mission import load_mission
from autonomy.mission.btcpp import instance
from autonomy.protocol import Status
from autonomy.record import NodeState, Pose, RunHeader, TickRecord
from autonomy.trace import MAX_QUIET_S, Trace, replay


@pytest.fixture
def publisher():
    made = GrootPublisher(instance(load_mission("missions/square.yaml")), port=0).start()
    yield made
    made.stop()


def ask(port: int, *frames: bytes) -> list[bytes]:
    context = zmq.Context()
    socket = context.socket(zmq.REQ)
    socket.setsockopt(zmq.RCVTIMEO, 5000)
    socket.setsockopt(zmq.LINGER, 0)
    socket.connect(f"tcp://127.0.0.1:{port}")
    try:
        socket.send_multipart(list(frames))
        return socket.recv_multipart()
    finally:
        socket.close()
        context.term()


def test_bad_requests_get_errors_and_the_publisher_goes_on_answering(publisher):
    many = b";".join(b"n%d" % i for i in range(70_000))[:60_000]
    assert ask(publisher.port, b"\x02B\x00\x00\x00\x00", many)[1] == b"\xc0"  # no such blackboards: nil
    assert ask(publisher.port, b"\x02B\x00\x00\x00\x00", b"x" * 60_000)[1] == b"\xc0"
    assert ask(publisher.port, b"\x02S\x00\x00\x00\x00\x00") == [b"error", b"wrong request header"]  # 7 bytes
    assert ask(publisher.port, b"\x02S") == [b"error", b"wrong request header"]
    assert ask(publisher.port, b"") == [b"error", b"wrong request header"]
    header, body = ask(publisher.port, b"\x09S\x01\x02\x03\x04")
    assert header[:6] == b"\x02S\x01\x02\x03\x04"  # the protocol answered is always 2, as BehaviorTree.CPP's
    assert len(body) == 21
    twice = ask(publisher.port, b"\x02B\x00\x00\x00\x00", b"square;square;corner::4;;")[1]
    assert twice == b"\x82\xa9corner::4\xc0\xa6square\xc0"  # each name once
    assert ask(publisher.port, b"\x02T\x00\x00\x00\x00")[1].startswith(b'<root BTCPP_format="4">')


def test_a_client_asking_past_its_share_is_dropped_and_groot2_is_answered_through_a_flood(publisher):
    """1,000 clients flooding and never reading kept a well-behaved client waiting 2 s, long after they left."""
    import time

    from autonomy.groot import PEER_REQUESTS_PER_S

    context = zmq.Context()
    greedy = context.socket(zmq.REQ)  # one client that asks faster than its share: each over it goes unanswered
    greedy.setsockopt(zmq.RCVTIMEO, 250)  # then the publisher is asked whether it dropped the request, or is slow
    greedy.setsockopt(zmq.LINGER, 0)
    greedy.setsockopt(zmq.SNDTIMEO, 10_000)  # a send that cannot go is a failure said, never a wait for ever
    greedy.setsockopt(zmq.REQ_RELAXED, 1)  # may ask again without its answer
    greedy.connect(f"tcp://127.0.0.1:{publisher.port}")
    flood = []
    for _ in range(100):
        dealer = context.socket(zmq.DEALER)
        dealer.setsockopt(zmq.LINGER, 0)
        dealer.connect(f"tcp://127.0.0.1:{publisher.port}")
        flood.append(dealer)
    try:
        answered, refused, dropped = 0, False, publisher.dropped
        give_up = time.monotonic() + 120
        while not refused and answered <= 3 * PEER_REQUESTS_PER_S and time.monotonic() < give_up:
            greedy.send(b"\x02S\x00\x00\x00\x00")
            while time.monotonic() < give_up:
                try:
                    greedy.recv_multipart()
                    answered += 1
                    break
                except zmq.Again:
                    if publisher.dropped > dropped:  # its request went unanswered: dropped, not late (a busy machine)
                        refused = True
                        break
        # its share of a second (of two, when a second ended while it asked), then nothing
        assert refused and PEER_REQUESTS_PER_S <= answered <= 2 * PEER_REQUESTS_PER_S, (refused, answered)
        for _ in range(50):
            for dealer in flood:
                dealer.send_multipart([b"", b"\x02T\x00\x00\x00\x00"], zmq.NOBLOCK)
        waited = time.monotonic()
        assert ask(publisher.port, b"\x02S\x00\x00\x00\x00")[0][:2] == b"\x02S"  # Groot2, among them
        assert time.monotonic() - waited < 3.0
    finally:
        context.destroy(linger=0)


def test_a_request_larger_than_any_groot2_sends_is_not_taken_in(publisher):
    context = zmq.Context()
    socket = context.socket(zmq.DEALER)
    socket.setsockopt(zmq.LINGER, 0)
    socket.connect(f"tcp://127.0.0.1:{publisher.port}")
    socket.send_multipart([b"", b"\x02S\x00\x00\x00\x00", b"x" * 200_000])  # ZeroMQ drops the peer
    socket.close()
    context.term()
    assert ask(publisher.port, b"\x02S\x00\x00\x00\x00")[0][:2] == b"\x02S"


def test_a_publisher_stopped_before_it_started_just_closes():
    made = GrootPublisher(instance(load_mission("missions/square.yaml")), port=0)
    made.stop()
    made.stop()


def btlog_bytes(start: bytes, records: bytes = b"", version: int = 1, xml: bytes | None = None) -> bytes:
    xml = (
        xml or b'<root><BehaviorTree _fullpath=""><Sequence _uid="1"><stop _uid="2"/></Sequence></BehaviorTree></root>'
    )
    return MAGIC + bytes([version]) + struct.pack("<I", len(xml)) + xml + start + records


@pytest.mark.parametrize("start", [2**63 + 5, 2**64 - 1, 2**62, 0])
def test_a_start_time_no_calendar_can_show_is_read_as_no_date(tmp_path, start):
    path = tmp_path / "x.btlog"
    path.write_bytes(btlog_bytes(struct.pack("<Q", start), (5).to_bytes(6, "little") + b"\x01\x00\x01"))
    trace = read_btlog(path)
    assert trace.header.date == "" and trace.ticks[0].nodes == {0: NodeState("RUNNING")}


@pytest.mark.parametrize(
    ("data", "said"),
    [
        (btlog_bytes(b"\x00" * 8, version=2), "FileLogger2 version 2; this reads version 1"),
        (btlog_bytes(b"\x00" * 8, xml=b"<tree/>"), "its tree's XML is <tree>"),
        (btlog_bytes(b"\x00" * 8, xml=b"<!DOCTYPE x><root/>"), "a DOCTYPE"),
    ],
)
def test_a_btlog_that_is_not_one_this_reads_says_why(tmp_path, data, said):
    path = tmp_path / "x.btlog"
    path.write_bytes(data)
    with pytest.raises(BtlogError, match=said):
        read_btlog(path)


def test_a_btlog_is_flushed_as_the_run_goes_so_a_killed_run_keeps_its_log(tmp_path):
    spec = load_mission("missions/square.yaml")
    clock = VirtualClock()
    path = tmp_path / "run.btlog"
    stream = open(path, "wb")  # noqa: SIM115 - left open, as a killed process leaves it
    writer = BtlogWriter(stream, instance(spec), clock=clock)
    writer(RunHeader(spec.name, [], 20.0, date="2026-11-23T10:00:00+00:00"))
    packet = Status(0, True, False, False, 0, 0, 200, 0)
    for tick in range(1, 4):
        clock.sleep(0.06)
        status = NodeState("RUNNING" if tick % 2 else "SUCCESS")
        writer(TickRecord(tick, tick * 0.05, packet, 200, True, 0.0, Pose(0, 0, 0), nodes={0: status}))
    # Not closed: what is on disk is what a kill -9 would leave.
    assert read_btlog(path).ticks[-1].tick >= 2
    stream.close()


def test_a_replay_cuts_long_quiet_spells_short():
    ticks = [
        TickRecord(n, t, Status(0, True, False, False, 0, 0, 200, 0), 200, True, 0.0, Pose(0, 0, 0))
        for n, t in ((1, 0.0), (2, 0.5), (3, 3_000_000.0), (4, 3_000_001.0))
    ]
    clock = VirtualClock()
    replay(Trace(RunHeader("m", [], 0.0), ticks, None), lambda record: None, clock)
    assert clock.now() == pytest.approx(0.5 + MAX_QUIET_S + 1.0)


def test_a_btlog_holds_status_changes_only_not_changes_of_feedback(tmp_path):
    spec = load_mission("missions/square.yaml")
    path = tmp_path / "run.btlog"
    with open(path, "wb") as stream:
        writer = BtlogWriter(stream, instance(spec), clock=VirtualClock())
        writer(RunHeader(spec.name, [], 20.0))
        packet = Status(0, True, False, False, 0, 0, 200, 0)
        for tick, feedback in enumerate(["10 mm", "20 mm", "30 mm"], start=1):
            node = NodeState("RUNNING", feedback)
            writer(TickRecord(tick, tick * 0.05, packet, 200, True, 0.0, Pose(0, 0, 0), nodes={2: node}))
        writer(TickRecord(4, 0.2, packet, 200, True, 0.0, Pose(0, 0, 0), nodes={2: NodeState("SUCCESS")}))
    records = [(t.time_s, dict(t.nodes)) for t in read_btlog(path).ticks]
    assert records == [(0.05, {2: NodeState("RUNNING")}), (0.2, {2: NodeState("SUCCESS")})]


def test_changes_read_back_are_one_tick_only_within_a_millisecond_of_the_ticks_first(tmp_path):
    records = b"".join(
        (700 * i).to_bytes(6, "little") + struct.pack("<HB", 1 + i % 2, 1) for i in range(6)
    )  # a change every 0.7 ms: chained, they would all be one tick
    path = tmp_path / "x.btlog"
    path.write_bytes(btlog_bytes(struct.pack("<q", 1), records))
    assert [t.time_s for t in read_btlog(path).ticks] == [0.0, 0.0014, 0.0028]

"""An in-process emulator answers a whole frame at once only when the wire would change nothing."""

from pathlib import Path

import pytest

from autonomy.client import Client
from autonomy.clock import VirtualClock
from autonomy.emulator import Emulator
from autonomy.mission import build_tree, load_mission
from autonomy.record import to_line
from autonomy.runner import Runner

MISSIONS = Path(__file__).resolve().parents[2] / "missions"

FRAMES = [b"Gb000\n", b"F+200\n", b"Q12345\n"[:5] + b"\n", b"T+090\n", b"GD000\n", b"S5793\n", b"M0+45\n", b"X00000"]


def through_the_wire(emulator: Emulator, frame: bytes) -> bytes:
    emulator.receive(frame)
    return emulator.read_ready()


def test_a_frame_answered_at_once_is_answered_as_over_the_wire():
    at_once, wired = Emulator("obstacles", clock=VirtualClock()), Emulator("obstacles", clock=VirtualClock())
    for frame in FRAMES:
        for emulator in (at_once, wired):
            emulator.clock.sleep(0.137)
        reply = at_once.answer_now(frame)
        if frame.endswith(b"\n"):
            assert reply == through_the_wire(wired, frame)
        else:  # not a whole frame: it takes the wire
            assert reply is None
            through_the_wire(at_once, frame)
            through_the_wire(wired, frame)
    for emulator in (at_once, wired):
        assert through_the_wire(emulator, b"\n") == b"NO\n"  # ends the cut frame
        emulator.set_auto_mode(False)  # the remote took over: motion is refused, the frame still parsed
    assert at_once.answer_now(b"F+200\n") == through_the_wire(wired, b"F+200\n") == b"NO\n"
    assert list(at_once.log) == list(wired.log)
    assert not at_once.log[-1].executed
    assert at_once.pose() == wired.pose() and at_once.robot.odometer_mm > 0


@pytest.mark.parametrize(
    ("make", "why"),
    [
        (lambda clock: Emulator(clock=clock, faults="drop=0.01"), "a fault"),
        (lambda clock: Emulator(clock=clock, faults="no=0.5"), "injected NO"),
        (lambda clock: Emulator(clock=clock, faults="pace"), "pacing"),
        (lambda clock: Emulator(clock=clock, boot_s=1.0), "booting"),
    ],
)
def test_the_wire_is_used_when_it_could_make_a_difference(make, why):
    emulator = make(VirtualClock())
    assert emulator.answer_now(b"Gb000\n") is None, why
    assert not emulator.log


def test_a_frame_waits_for_bytes_already_under_way_and_another_baud_rate():
    emulator = Emulator(clock=VirtualClock())
    emulator.receive(b"GB0")  # a partial frame
    assert emulator.answer_now(b"Gb000\n") is None
    emulator.receive(b"00\n")  # whole now, its reply waiting to be read
    assert emulator.answer_now(b"Gb000\n") is None
    assert emulator.read_ready() == b"B230\n"
    assert emulator.answer_now(b"GB000\n", baud=9600) is None
    assert emulator.answer_now(b"GB000\n", baud=emulator.baud) == b"B230\n"
    assert emulator.answer_now(b"GB000") is None and emulator.answer_now(b"G\nB000\n"[:6]) is None


def test_a_run_is_the_same_whether_frames_are_answered_at_once_or_sent_over_the_wire():
    spec = load_mission(MISSIONS / "wander.yaml")

    def run(at_once: bool) -> tuple[list[str], list]:
        client = Client.open("emu://?time=virtual&world=obstacles&seed=3&noise=2")
        if not at_once:
            client._answer_now = None
        records = []
        Runner(build_tree(spec), client, max_seconds=20, listeners=[records.append]).run()
        lines = [to_line(record) for record in records[1:]]  # the header's date differs
        return lines, list(client.port.emulator.log)

    at_once, wired = run(True), run(False)
    assert at_once == wired
    assert len(at_once[1]) > 400  # 20 s of polls and commands


@pytest.mark.parametrize(
    "answer",
    [
        bytes([0x62, 0x51, 0x00, 0x00, 0x7D, 0xFF, 0x11, 0xBD, 0x0A]),  # a packet as the firmware makes it
        bytes([0x62, 0xD1, 0x00, 0x00, 0x7D, 0xFF, 0x11, 0xBD, 0x0A]),  # the unused flag bit 7 set: garbled
        bytes([0x62, 0x51, 0x00, 0x00, 0x7D, 0xFF, 0x11, 0xBD, 0x0A, 0x4E]),  # a byte more: the decoder's way
        b"NO\n",
    ],
)
def test_a_status_answered_at_once_is_read_as_the_decoder_reads_it(answer):
    # The client reads a whole status packet answered at once without its reply decoder: the same
    # packet, the same error for a garbled one, the same counts.
    from autonomy.client import _GET
    from autonomy.errors import FramingError

    outcomes = []
    for short_way in (True, False):
        client = Client.open("emu://?time=virtual")
        frame = _GET["b"].encode()
        command = _GET["b"] if short_way else type(_GET["b"])("b")  # an equal request, not the one kept
        client._answer_now = lambda frame, answer=answer: answer
        try:
            outcome = client._exchange(command, frame)
        except FramingError as err:
            outcome = f"FramingError: {err}"
        stats = client.stats
        outcomes.append((repr(outcome), stats.bytes_received, stats.framing_errors, bytes(client._heard)))
        client.close()
    assert outcomes[0] == outcomes[1]

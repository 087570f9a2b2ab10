"""The emulator's firmware, byte for byte, and its wire: frames, resync, faults, baud rates."""

import dataclasses

import pytest

from autonomy.clock import VirtualClock
from autonomy.emulator import Emulator, FaultSpec, FaultSpecError
from autonomy.protocol import Move, Stop, decode_status


def exchange(emulator: Emulator, data: bytes) -> bytes:
    emulator.receive(data)
    return emulator.read_ready()


@pytest.fixture
def emu() -> Emulator:
    return Emulator("box", clock=VirtualClock())


@pytest.mark.parametrize(
    ("frame", "reply"),
    [
        (b"S1625\n", b"OK\n"),
        (b"X0000\n", b"OK\n"),
        (b"F+100\n", b"OK\n"),
        (b"M0+10\n", b"OK\n"),
        (b"D0+80\n", b"OK\n"),
        (b"T+005\n", b"OK\n"),
        (b"GF000\n", b"FE10\n"),
        (b"GD000\n", b"D255\n"),
        (b"GB000\n", b"B230\n"),
        (b"GV000\n", b"V+00\n"),
        (b"GA000\n", b"A+00\n"),
        (b"GR000\n", b"OK\n"),
    ],
)
def test_documented_commands_get_documented_replies(emu, frame, reply):
    assert exchange(emu, frame) == reply


def test_binary_status_is_nine_bytes(emu):
    reply = exchange(emu, b"Gb000\n")
    assert len(reply) == 9 and reply[0] == ord("b") and reply[8] == 0x0A
    assert decode_status(reply).auto_mode


@pytest.mark.parametrize(
    "frame",
    [
        b"Q0000\n",
        b"S0625\n",
        b"S1626\n",
        b"F+500\n",
        b"F+000\n",
        b"M3+10\n",
        b"D0+a0\n",
        b"T+9a9\n",
        b"GZ000\n",
        b"X000\n",
        b"X00000\n",
        b"\n",
    ],
)
def test_bad_frames_are_answered_no(emu, frame):
    assert exchange(emu, frame) == b"NO\n"


def test_garbage_costs_one_no_then_frames_are_read_again(emu):
    assert exchange(emu, b"\x00\xffzz-garbage-without-newline") == b""
    assert exchange(emu, b"X0000\n") == b"NO\n"  # the garbage and this frame were one line
    assert exchange(emu, b"F+200\n") == b"OK\n"
    assert emu.commands() == [Move(2)]


def test_frames_split_and_joined_across_writes(emu):
    assert exchange(emu, b"X00") == b""
    assert exchange(emu, b"00\nGD0") == b"OK\n"
    assert exchange(emu, b"00\nS1115\nX0000\n") == b"D255\nOK\nOK\n"


def test_log_records_what_was_received(emu):
    exchange(emu, b"F+300\nQ\nX0000\n")
    log = list(emu.log)
    assert [e.frame for e in log] == [b"F+300\n", b"Q\n", b"X0000\n"]
    assert [e.executed for e in log] == [True, False, True]
    assert emu.commands() == [Move(3), Stop()]


def test_wrong_baud_rate_is_noise_both_ways(emu):
    emu.receive(b"GF000\n", baud=115200)
    reply = emu.read_ready()
    assert reply and all(b >= 0x80 for b in reply)
    assert not emu.log  # the firmware never saw a frame


def test_boot_time_swallows_input():
    emu = Emulator("box", clock=VirtualClock(), boot_s=2.0)
    assert exchange(emu, b"GF000\n") == b""
    emu.clock.sleep(2.0)
    assert exchange(emu, b"GF000\n") == b"FE10\n"


def test_pacing_spreads_bytes_over_their_wire_time():
    clock = VirtualClock()
    emu = Emulator("box", clock=clock, faults="pace")
    byte_s = 10 / 57600
    emu.receive(b"Gb000\n")
    assert emu.read_ready() == b""
    clock.sleep(6 * byte_s + 4.5 * byte_s)
    assert len(emu.read_ready()) == 4  # the request took 6 byte times, then 4 reply bytes
    clock.sleep(5 * byte_s)
    assert len(emu.read_ready()) == 5


def test_a_paced_line_flooded_faster_than_its_wire_holds_a_uart_s_buffer_and_loses_the_rest():
    """18 MB sent at once used to cost 1.3 GB: an entry per byte, none ever dropped."""
    from autonomy.emulator.core import WIRE_BUFFER_BYTES

    clock = VirtualClock()
    emu = Emulator("box", clock=clock, faults="pace")
    for _ in range(100):
        emu.receive(b"GF000\n" * 10_000)  # 6 MB, far faster than 57600 baud carries it
    assert len(emu._inbox) == WIRE_BUFFER_BYTES  # noqa: SLF001
    clock.sleep(WIRE_BUFFER_BYTES * 10 / 57600 * 3)  # the buffer's wire time, and its replies'
    replies = b""
    while chunk := emu.read_ready():
        replies += chunk
        clock.sleep(1.0)
    assert replies == b"FE10\n" * (WIRE_BUFFER_BYTES // 6)  # what the buffer held was answered, the rest lost
    assert len(emu._outbox) == 0  # noqa: SLF001
    emu.receive(b"GF000\nGF000\n")  # and the line goes on: the frame the overrun cut costs one NO
    clock.sleep(1.0)
    assert emu.read_ready() == b"NO\nFE10\n"


def test_random_no_does_not_execute():
    emu = Emulator("box", clock=VirtualClock(), faults="no=1")
    assert exchange(emu, b"F+100\n") == b"NO\n"
    assert emu.robot.mode == 0 and emu.commands() == []


def test_delay_holds_replies_back():
    clock = VirtualClock()
    emu = Emulator("box", clock=clock, faults="delay=1,delay_s=0.2")
    assert exchange(emu, b"X0000\n") == b""
    clock.sleep(0.2)
    assert emu.read_ready() == b"OK\n"


def test_fault_spec_parses_and_prints():
    spec = FaultSpec.parse("drop=0.01, corrupt=0.02,delay=0.1,delay_s=0.5,garbage=0.03,no=0.04,pace")
    assert spec == FaultSpec(0.01, 0.02, 0.1, 0.5, 0.03, 0.04, True)
    assert FaultSpec.parse(str(spec)) == spec
    assert FaultSpec.parse("") == FaultSpec() == FaultSpec.parse("none")
    assert spec.active and not FaultSpec().active and FaultSpec.parse("pace").active
    assert "active" not in repr(spec) and FaultSpec(**dataclasses.asdict(spec)) == spec


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("drip=0.1", "unknown fault 'drip'"),
        ("active=1", r"unknown fault 'active' in 'active=1': use drop, corrupt, delay, delay_s, garbage, no, pace$"),
        ("drop=2", "probability 0..1"),
        ("drop=lots", "needs a number"),
        ("delay_s=-1", "negative"),
    ],
)
def test_fault_spec_errors_say_what_is_wrong(text, message):
    # (whether any fault is on is worked out, not given: it is no fault's name)
    with pytest.raises(FaultSpecError, match=message):
        FaultSpec.parse(text)


def test_a_frame_sent_again_is_answered_again_and_a_bad_one_stays_refused(emu):
    # the firmware keeps parsed frames: the same frame must still act each time, a bad one never becomes good
    for _ in range(3):
        assert exchange(emu, b"S1625\n") == b"OK\n"
        assert exchange(emu, b"T+999\n") == b"OK\n"
        assert exchange(emu, b"F+900\n") == b"NO\n"
    assert len(emu.robot.beeps) == 3
    assert [e.executed for e in emu.log] == [True, True, False] * 3


def test_frames_past_the_kept_ones_are_still_parsed(emu, monkeypatch):
    monkeypatch.setattr("autonomy.emulator.firmware.PARSED_LIMIT", 2)
    replies = [exchange(emu, f"M0+{angle:02d}\n".encode()) for angle in range(10)]
    assert replies == [b"OK\n"] * 10
    assert len(emu.firmware._parsed) == 2
    assert emu.robot.servo_target_deg[0] == 9.0


def test_a_whole_frame_after_a_partial_one_joins_it(emu):
    # the one-frame shortcut must not skip bytes left from an earlier write
    assert exchange(emu, b"GD0") == b""
    assert exchange(emu, b"S1625\n") == b"NO\n"  # "GD0S1625\n" is one line, too long
    assert exchange(emu, b"S1625\n") == b"OK\n"


def test_frames_may_come_as_any_bytes_like_object(emu):
    assert exchange(emu, memoryview(b"X0000\n")) == b"OK\n"
    assert exchange(emu, bytearray(b"F+100\n")) == b"OK\n"
    assert emu.firmware.execute(bytearray(b"X0000\n")) == (Stop(), b"OK\n")

"""Command frames: golden bytes from the protocol document, ranges, and the firmware's parse."""

import re

import pytest

from autonomy.errors import FramingError, InvalidCommand
from autonomy.protocol import (
    Beep,
    Get,
    Move,
    ReplyDecoder,
    ReplyKind,
    ServoBy,
    ServoTo,
    Status,
    Stop,
    Turn,
    decode_status,
    parse_command,
)

# Every example of the original document, and the command that produces it.
GOLDEN = [
    (Beep((1, 6, 2), 5), b"S1625\n"),
    (Stop(), b"X0000\n"),
    (Move(1), b"F+100\n"),
    (ServoTo(0, 10), b"M0+10\n"),
    (ServoBy(0, 8), b"D0+80\n"),
    (Turn(5), b"T+005\n"),
    (Get("b"), b"Gb000\n"),
]


@pytest.mark.parametrize(("command", "frame"), GOLDEN)
def test_documented_examples_encode_byte_for_byte(command, frame):
    assert command.encode() == frame
    assert len(frame) == 6


@pytest.mark.parametrize(("command", "frame"), GOLDEN)
def test_documented_examples_parse_back(command, frame):
    assert parse_command(frame) == command


@pytest.mark.parametrize(
    ("command", "frame"),
    [
        (Move(4, backward=True), b"F-400\n"),
        (ServoTo(2, -99), b"M2-99\n"),
        (ServoTo(1, 0), b"M1+00\n"),
        (ServoBy(1, -9), b"D1-90\n"),
        (Turn(-999), b"T-999\n"),
        (Turn(360), b"T+360\n"),
        (Get("R"), b"GR000\n"),
        (Get("F"), b"GF000\n"),
    ],
)
def test_signs_and_extremes(command, frame):
    assert command.encode() == frame


@pytest.mark.parametrize(
    "build",
    [
        lambda: Beep((0, 1, 1), 1),
        lambda: Beep((1, 1, 10), 1),
        lambda: Beep((1, 1, 1), 6),
        lambda: Beep((1, 1), 1),
        lambda: Move(0),
        lambda: Move(5),
        lambda: ServoTo(3, 0),
        lambda: ServoTo(0, 100),
        lambda: ServoTo(0, -100),
        lambda: ServoBy(0, 10),
        lambda: Turn(1000),
        lambda: Turn(-1000),
        lambda: Turn(1.5),
        lambda: Move(True),
        lambda: Get("Z"),
        lambda: Get("DB"),
    ],
)
def test_out_of_range_arguments_are_refused_when_built(build):
    with pytest.raises(InvalidCommand) as info:
        build()
    assert isinstance(info.value, ValueError)  # callers may catch it as a plain ValueError


def test_direction_byte_other_than_minus_means_forward_and_left():
    # "D = Direction, '-' for backward, any other value for forward."
    assert parse_command(b"F*200\n") == Move(2)
    assert parse_command(b"F0300\n") == Move(3)
    assert parse_command(b"TX090\n") == Turn(90)
    assert parse_command(b"M1 45\n") == ServoTo(1, 45)


def test_dont_care_bytes_are_ignored():
    assert parse_command(b"X****\n") == Stop()
    assert parse_command(b"Gb***\n") == Get("b")
    assert parse_command(b"F+2zz\n") == Move(2)
    assert parse_command(b"D2-5z\n") == ServoBy(2, -5)


@pytest.mark.parametrize(
    "frame", [b"Q0000\n", b"S0625\n", b"S1626\n", b"F+500\n", b"M3+10\n", b"M0+1a\n", b"T+0a5\n", b"GZ000\n"]
)
def test_firmware_parse_rejects_bad_arguments(frame):
    with pytest.raises(InvalidCommand):
        parse_command(frame)


@pytest.mark.parametrize("frame", [b"X000\n", b"X00000\n", b"X0000\r", b"", b"X0000\n\n"])
def test_firmware_parse_rejects_bad_framing(frame):
    with pytest.raises(FramingError, match=r"a command frame is 6 bytes ending in \\n, got ") as caught:
        parse_command(frame)
    assert caught.value.data == frame


@pytest.mark.parametrize(
    ("frame", "said"),
    [
        (b"S0625\n", "tone must be in 1..9, got 0"),
        (b"S6025\n", "tone must be in 1..9, got 0"),
        (b"S6205\n", "tone must be in 1..9, got 0"),
        (b"S6216\n", "volume must be in 0..5, got 6"),
        (b"F+500\n", "speed must be in 1..4, got 5"),
        (b"F+000\n", "speed must be in 1..4, got 0"),
        (b"M3+10\n", "servo id must be in 0..2, got 3"),
        (b"D3+10\n", "servo id must be in 0..2, got 3"),
        (b"T+0a5\n", "expected a digit, got b'a'"),
        (b"Q0000\n", "unknown command letter 'Q'"),
    ],
)
def test_what_the_firmware_refuses_it_says_in_the_words_of_the_commands_own_check(frame, said):
    with pytest.raises(InvalidCommand, match=re.escape(said)):
        parse_command(frame)


def test_a_turn_out_of_range_names_the_turn_angle():
    with pytest.raises(InvalidCommand, match=re.escape("turn angle must be in -999..999, got 1000")):
        Turn(1000)


@pytest.mark.parametrize(
    ("build", "said"),
    [
        (lambda: Beep((0, 5, 5), 3), "tone must be in 1..9, got 0"),
        (lambda: Beep((5, 5, 5), 6), "volume must be in 0..5, got 6"),
        (lambda: Beep((5, 5), 3), "a beep has exactly 3 tones, got 2"),
        (lambda: ServoTo(3, 0), "servo id must be in 0..2, got 3"),
        (lambda: ServoTo(0, 100), "servo angle must be in -99..99, got 100"),
        (lambda: ServoBy(3, 1), "servo id must be in 0..2, got 3"),
        (lambda: ServoBy(0, -10), "servo step must be in -9..9, got -10"),
        (lambda: ServoBy(0, 10), "servo step must be in -9..9, got 10"),
    ],
)
def test_a_command_out_of_range_says_which_value_and_its_range(build, said):
    with pytest.raises(InvalidCommand, match=re.escape(said)):
        build()


@pytest.mark.parametrize(("delta", "frame"), [(0, b"D0+00\n"), (1, b"D0+10\n"), (-1, b"D0-10\n"), (9, b"D0+90\n")])
def test_servo_steps_encode_their_sign(delta, frame):
    assert ServoBy(0, delta).encode() == frame


def test_a_status_packet_shows_its_bytes_as_spaced_hex():
    packet = Status(1, True, False, True, -4, 270, 10, 65535)
    assert packet.as_dict()["raw"] == "62 51 fc 01 0e 0a ff ff 0a"
    assert decode_status(packet.encode()).as_dict()["raw"] == "62 51 fc 01 0e 0a ff ff 0a"


def test_junk_is_handed_over_with_the_framing_error():
    decoder = ReplyDecoder(ReplyKind.ACK)
    decoder.feed(b"zz\nOK\n")
    with pytest.raises(FramingError, match=r"3 byte\(s\) that are not a valid reply: b'zz\\n'") as caught:
        decoder.next_reply()
    assert caught.value.data == b"zz\n"


@pytest.mark.parametrize(("angle", "frame"), [(0, b"T+000\n"), (1, b"T+001\n"), (-1, b"T-001\n")])
def test_turns_encode_their_sign(angle, frame):
    assert Turn(angle).encode() == frame

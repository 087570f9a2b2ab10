"""Command frames: golden bytes from the protocol document, ranges, and the firmware's parse."""

import pytest

from autonomy.errors import FramingError, InvalidCommand
from autonomy.protocol import Beep, Get, Move, ServoBy, ServoTo, Stop, Turn, parse_command

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
    with pytest.raises(FramingError):
        parse_command(frame)

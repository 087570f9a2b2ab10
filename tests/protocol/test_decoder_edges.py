"""How many bytes the decoder asks for, and where it picks up again after bytes that are no reply."""

from __future__ import annotations

import pytest

from autonomy.errors import FramingError, InvalidCommand
from autonomy.protocol import Ack, Get, Health, Parameter, ReplyDecoder, ReplyKind, Turn, parse_command
from tests.protocol.test_replies import decode_all

STATUS = bytes([0x01, 0, 0, 90, 200, 0, 1, 0x0A])  # a packet's eight bytes after its "b"

#: Every shape of reply each kind can get; the decoder must ask for no more bytes than the
#: shortest of them still needs (asking for more makes a read wait for bytes never sent).
FRAMES = {
    ReplyKind.STATUS: [b"b" + STATUS, b"NO\n"],
    ReplyKind.PARAMETER: [b"D123\n", b"NO\n"],
    ReplyKind.HEALTH: [b"OK\n", b"NO\n", b"ROK\n", b"RNO\n"],
    ReplyKind.ACK: [b"OK\n", b"NO\n"],
}


@pytest.mark.parametrize("kind", list(FRAMES))
def test_the_decoder_asks_for_exactly_the_bytes_the_shortest_possible_reply_still_needs(kind):
    frames = FRAMES[kind]
    for frame in frames:
        for taken in range(len(frame)):
            decoder = ReplyDecoder(kind, "D")
            decoder.feed(frame[:taken])
            left = [len(f) - taken for f in frames if f.startswith(frame[:taken])]
            assert decoder.bytes_needed() == min(left), (frame, taken)


def replies_and_junk(kind: ReplyKind, wire: bytes, parameter: str = "") -> tuple[list, list[bytes]]:
    decoder = ReplyDecoder(kind, parameter)
    decoder.feed(wire)
    found, dropped = [], []
    while True:
        try:
            reply = decoder.next_reply()
        except FramingError as err:
            dropped.append(err.data)
            continue
        if reply is None:
            return found, dropped
        found.append(reply)


@pytest.mark.parametrize(
    ("kind", "wire", "junk", "replies"),
    [
        (ReplyKind.STATUS, b"NxNO\nNO\n", [b"Nx"], [Ack(False), Ack(False)]),
        (ReplyKind.STATUS, b"xNO\n", [b"x"], [Ack(False)]),
        (ReplyKind.STATUS, b"xxb" + STATUS, [b"xx"], None),
    ],
)
def test_after_bytes_that_are_no_reply_the_next_one_in_the_same_read_is_kept(kind, wire, junk, replies):
    found, dropped = replies_and_junk(kind, wire)
    assert dropped == junk
    if replies is None:  # the status packet
        assert [type(r).__name__ for r in found] == ["Status"] and found[0].raw == b"b" + STATUS
    else:
        assert found == replies
    assert decode_all(ReplyDecoder(kind), wire, chunk=len(wire))[0] == found


def test_a_byte_after_nine_is_not_a_digit():
    with pytest.raises(InvalidCommand, match=r"expected a digit, got b':'"):
        parse_command(b"T+:00\n")


def test_a_command_value_that_is_not_a_whole_number_says_so():
    with pytest.raises(InvalidCommand, match=r"^turn angle must be a whole number, got 1\.5$"):
        Turn(1.5)  # type: ignore[arg-type]


def test_health_and_parameters_come_out_of_their_decoders():
    assert decode_all(ReplyDecoder(ReplyKind.HEALTH), b"RNO\n", chunk=4)[0] == [Health(False)]
    assert decode_all(ReplyDecoder(ReplyKind.PARAMETER, "D"), b"D123\n", chunk=5)[0] == [Parameter("D", 123)]


@pytest.mark.parametrize(
    ("parameter", "value", "said"),
    [
        ("X", 1, "not an ASCII parameter: 'X'"),
        ("F", "12", "firmware version is 3 characters, got '12'"),
        ("F", 123, "firmware version is 3 characters, got 123"),
        ("F", "1\x7f2", "firmware version must be printable, got '1\\x7f2'"),
        ("D", 256, "D must be in 0..255, got 256"),
        ("B", -1, "B must be in 0..255, got -1"),
        ("V", 100, "V must be in -99..99, got 100"),
        ("A", -100, "A must be in -99..99, got -100"),
        ("V", 1.5, "V must be a whole number, got 1.5"),
    ],
)
def test_a_value_reply_out_of_what_its_frame_carries_says_why(parameter, value, said):
    with pytest.raises(InvalidCommand) as caught:
        Parameter(parameter, value)
    assert str(caught.value) == said


@pytest.mark.parametrize(("parameter", "value"), [("D", 0), ("D", 255), ("V", -99), ("A", 99), ("F", " ~1")])
def test_value_replies_at_the_ends_of_their_ranges_are_made(parameter, value):
    assert Parameter(parameter, value).value == value


@pytest.mark.parametrize(
    ("parameter", "said"), [("bb", "parameter must be one letter, got 'bb'"), ("Z", "parameter must be one of")]
)
def test_a_request_for_an_unknown_parameter_says_why(parameter, said):
    with pytest.raises(InvalidCommand, match=said):
        Get(parameter)


def test_two_ascii_replies_in_one_read_come_out_one_by_one():
    assert replies_and_junk(ReplyKind.ACK, b"OK\nNO\n") == ([Ack(True), Ack(False)], [])


def test_a_line_without_a_newline_is_cut_after_sixteen_bytes_keeping_a_tail_that_may_start_a_frame():
    assert replies_and_junk(ReplyKind.PARAMETER, b"x" * 12 + b"D042", "D") == ([], [])  # 16 bytes: still waiting
    decoder = ReplyDecoder(ReplyKind.PARAMETER, "D")
    decoder.feed(b"x" * 13 + b"D042")  # 17 bytes and no newline
    with pytest.raises(FramingError) as caught:
        decoder.next_reply()
    assert caught.value.data == b"x" * 13 and decoder.buffered == 4
    decoder.feed(b"\n")
    assert decoder.next_reply() == Parameter("D", 42)


def test_a_health_form_is_a_reply_to_a_health_request_only():
    assert replies_and_junk(ReplyKind.HEALTH, b"B200\n") == ([], [b"B200\n"])
    assert replies_and_junk(ReplyKind.ACK, b"ROK\n") == ([Ack(True)], [b"R"])  # the OK at its end is taken

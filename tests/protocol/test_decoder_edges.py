"""How many bytes the decoder asks for, and where it picks up again after bytes that are no reply."""

from __future__ import annotations

import pytest

from autonomy.errors import FramingError, InvalidCommand
from autonomy.protocol import Ack, Health, Parameter, ReplyDecoder, ReplyKind, Turn, parse_command
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


@pytest.mark.parametrize(
    ("kind", "wire", "junk", "replies"),
    [
        (ReplyKind.STATUS, b"NxNO\nNO\n", [b"Nx"], [Ack(False), Ack(False)]),
        (ReplyKind.STATUS, b"xNO\n", [b"x"], [Ack(False)]),
        (ReplyKind.STATUS, b"xxb" + STATUS, [b"xx"], None),
    ],
)
def test_after_bytes_that_are_no_reply_the_next_one_in_the_same_read_is_kept(kind, wire, junk, replies):
    decoder = ReplyDecoder(kind)
    decoder.feed(wire)
    found, dropped = [], []
    while True:
        try:
            reply = decoder.next_reply()
        except FramingError as err:
            dropped.append(err.data)
            continue
        if reply is None:
            break
        found.append(reply)
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

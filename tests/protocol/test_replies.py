"""Replies: ASCII parameters, the binary status packet, and the incremental decoder."""

import re

import pytest

from autonomy.errors import FramingError
from autonomy.protocol import (
    Ack,
    Get,
    Health,
    Parameter,
    ReplyDecoder,
    ReplyKind,
    Status,
    Stop,
    decode_status,
    heading_delta_deg,
    odometer_delta_mm,
)


def decode_all(decoder: ReplyDecoder, data: bytes, chunk: int = 1):
    """Feeds data ``chunk`` bytes at a time; returns the replies and the number of framing errors."""
    replies, errors = [], 0
    for start in range(0, len(data), max(chunk, 1)):
        decoder.feed(data[start : start + chunk])
        while True:
            try:
                reply = decoder.next_reply()
            except FramingError:
                errors += 1
                continue
            if reply is None:
                break
            replies.append(reply)
    return replies, errors


@pytest.mark.parametrize(
    ("parameter", "wire", "value"),
    [
        ("D", b"D120\n", 120),
        ("D", b"D000\n", 0),
        ("B", b"B255\n", 255),
        ("F", b"F1.2\n", "1.2"),
        ("V", b"V+20\n", 20),
        ("V", b"V-99\n", -99),
        ("A", b"A-05\n", -5),
        ("A", b"A+00\n", 0),
    ],
)
def test_ascii_parameters_decode_and_encode(parameter, wire, value):
    replies, errors = decode_all(ReplyDecoder.for_command(Get(parameter)), wire)
    assert replies == [Parameter(parameter, value)] and errors == 0
    assert Parameter(parameter, value).encode() == wire


@pytest.mark.parametrize(("wire", "ok"), [(b"OK\n", True), (b"NO\n", False), (b"ROK\n", True), (b"RNO\n", False)])
def test_health_accepts_both_forms(wire, ok):
    assert decode_all(ReplyDecoder.for_command(Get("R")), wire) == ([Health(ok)], 0)


@pytest.mark.parametrize(("wire", "ok"), [(b"OK\n", True), (b"NO\n", False)])
def test_acks(wire, ok):
    assert decode_all(ReplyDecoder.for_command(Stop()), wire) == ([Ack(ok)], 0)


def test_status_packet_fields():
    # flags: mode 2 | auto | collided | moving; tilt -3; heading 0x0109 = 265; 10 mm (= '\n'); odometer 0x0A0A
    packet = bytes([0x62, 0x72, 0xFD, 0x01, 0x09, 0x0A, 0x0A, 0x0A, 0x0A])
    status = decode_status(packet)
    assert status == Status(
        mode=2,
        auto_mode=True,
        collided=True,
        moving=True,
        tilt_deg=-3,
        heading_deg=265,
        front_distance_mm=10,
        odometer_mm=2570,
    )
    assert status.raw == packet
    assert status.encode() == packet


def test_status_packet_full_of_newlines_is_read_by_length():
    packet = bytes([0x62, 0x0A, 0x0A, 0x0A, 0x0A, 0x0A, 0x0A, 0x0A, 0x0A])
    replies, errors = decode_all(ReplyDecoder.for_command(Get("b")), packet)
    assert errors == 0 and len(replies) == 1
    assert replies[0].front_distance_mm == 10 and replies[0].tilt_deg == 10 and replies[0].mode == 10


@pytest.mark.parametrize(
    ("raw", "heading"), [(0x0000, 0), (0x0167, 359), (0x0168, 0), (0xFFFF, 359), (0xFF4C, 180), (0x02D0, 0)]
)
def test_heading_is_signed_16_bit_normalised_to_0_359(raw, heading):
    packet = bytes([0x62, 0, 0, raw >> 8, raw & 0xFF, 255, 0, 0, 0x0A])
    assert decode_status(packet).heading_deg == heading


def test_tilt_is_twos_complement():
    assert decode_status(bytes([0x62, 0, 0x81, 0, 0, 0, 0, 0, 0x0A])).tilt_deg == -127
    assert decode_status(bytes([0x62, 0, 0x7F, 0, 0, 0, 0, 0, 0x0A])).tilt_deg == 127
    assert decode_status(bytes([0x62, 0, 0x80, 0, 0, 0, 0, 0, 0x0A])).tilt_deg == -127  # -128: out of range


@pytest.mark.parametrize(("earlier", "later", "delta"), [(100, 350, 250), (65500, 20, 56), (20, 65500, -56), (0, 0, 0)])
def test_odometer_compared_modulo_65536(earlier, later, delta):
    assert odometer_delta_mm(earlier, later) == delta


@pytest.mark.parametrize("packet", [b"c\x10\x00\x00\x00\xff\x00\x00\n", b"b\x10\x00\x00\x00\xff\x00\x00\r", b"b\n"])
def test_bad_status_packets_are_framing_errors(packet):
    with pytest.raises(FramingError):
        decode_status(packet)


def test_status_decoder_waits_for_nine_bytes_even_after_a_newline():
    decoder = ReplyDecoder(ReplyKind.STATUS)
    decoder.feed(b"b\x10\x00\x00\x0a")
    assert decoder.next_reply() is None
    assert decoder.bytes_needed() == 4
    decoder.feed(b"\xff\x00\x00\n")
    assert isinstance(decoder.next_reply(), Status)


def test_status_decoder_takes_no_as_refusal():
    assert decode_all(ReplyDecoder(ReplyKind.STATUS), b"NO\n") == ([Ack(False)], 0)


def test_decoder_skips_junk_before_a_status_packet():
    good = Status(0, True, False, False, 0, 90, 255, 7).encode()
    replies, errors = decode_all(ReplyDecoder(ReplyKind.STATUS), b"\x00\xffOK\n" + good)
    assert replies == [decode_status(good)] and errors >= 1


def test_decoder_finds_a_frame_at_the_end_of_a_junk_line():
    replies, errors = decode_all(ReplyDecoder.for_command(Get("D")), b"zzD042\n")
    assert replies == [Parameter("D", 42)] and errors == 1


def test_ascii_decoder_resyncs_after_a_corrupted_frame():
    replies, errors = decode_all(ReplyDecoder.for_command(Get("D")), b"D4x2\nD043\n")
    assert replies == [Parameter("D", 43)] and errors == 1


def test_ascii_decoder_bounds_a_line_without_newline():
    decoder = ReplyDecoder(ReplyKind.ACK)
    decoder.feed(b"x" * 40)
    with pytest.raises(FramingError):
        decoder.next_reply()
    assert decoder.buffered <= ReplyDecoder.MAX_LINE


@pytest.mark.parametrize(
    ("wire", "reason"), [(b"D256\n", "over 255"), (b"V+2x\n", "not a digit"), (b"F\x01ab\n", "not printable")]
)
def test_invalid_parameter_values_are_framing_errors(wire, reason):
    parameter = chr(wire[0])
    replies, errors = decode_all(ReplyDecoder.for_command(Get(parameter)), wire)
    assert replies == [] and errors == 1, reason


def decode_at_once(decoder: ReplyDecoder, data: bytes):
    """Feeds all of ``data`` in one go, as one read of a busy line brings it."""
    return decode_all(decoder, data, chunk=len(data))


@pytest.mark.parametrize("asked", ["D", "B", "V", "A", "F"])
def test_a_value_of_another_letter_is_not_the_one_asked_for(asked):
    other = {"D": b"B200\n", "B": b"D200\n", "V": b"A+20\n", "A": b"V+20\n", "F": b"D123\n"}[asked]
    assert decode_all(ReplyDecoder.for_command(Get(asked)), other) == ([], 1)
    assert decode_at_once(ReplyDecoder.for_command(Get(asked)), other) == ([], 1)


@pytest.mark.parametrize("noise", [b"\x00", b"\xff\x13", b"OK\n", b"b", b"N"])
def test_a_status_packet_in_the_same_read_as_noise_is_kept(noise):
    good = Status(1, True, False, True, -3, 271, 10, 513).encode()
    replies, errors = decode_at_once(ReplyDecoder(ReplyKind.STATUS), noise + good)
    assert replies == [decode_status(good)] and errors >= 1


@pytest.mark.parametrize("noise", [b"\x00", b"zz", b"OK", b"D4"])
def test_a_value_in_the_same_read_as_noise_is_kept(noise):
    replies, _ = decode_at_once(ReplyDecoder.for_command(Get("D")), noise + b"\nD042\n")
    assert replies == [Parameter("D", 42)]


@pytest.mark.parametrize(
    ("earlier", "later", "turned"),
    [(359, 0, 1), (0, 359, -1), (10, 190, -180), (190, 10, -180), (350, 10, 20), (10, 350, -20), (0, 179, 179)],
)
def test_heading_deltas_wrap_at_360(earlier, later, turned):
    assert heading_delta_deg(earlier, later) == turned


def _packet(**changes) -> bytes:
    from autonomy.protocol import Status

    fields = dict(
        mode=1,
        auto_mode=True,
        collided=False,
        moving=True,
        tilt_deg=1,
        heading_deg=90,
        front_distance_mm=200,
        odometer_mm=455,
    )
    fields.update(changes)
    return Status(**fields).encode()


def test_packets_and_refusals_arriving_together_each_come_out_whole():
    from autonomy.errors import FramingError
    from autonomy.protocol import Ack, ReplyDecoder, ReplyKind, decode_status

    first, second = _packet(odometer_mm=100), _packet(odometer_mm=200)
    decoder = ReplyDecoder(ReplyKind.STATUS)
    decoder.feed(b"zz" + first + b"NO\n" + second)  # one read: noise, a packet, a refusal, a packet
    with pytest.raises(FramingError) as caught:
        decoder.next_reply()
    assert caught.value.data == b"zz"
    assert decoder.next_reply() == decode_status(first)
    assert decoder.next_reply() == Ack(False)
    assert decoder.next_reply() == decode_status(second)
    assert decoder.next_reply() is None


@pytest.mark.parametrize(
    ("field", "value", "said"),
    [
        ("mode", 16, "mode must be in 0..15, got 16"),
        ("tilt_deg", 128, "tilt must be in -127..127, got 128"),
        ("tilt_deg", -128, "tilt must be in -127..127, got -128"),
        ("heading_deg", 360, "heading must be in 0..359, got 360"),
        ("front_distance_mm", 256, "front distance must be in 0..255, got 256"),
        ("odometer_mm", 65536, "odometer must be in 0..65535, got 65536"),
    ],
)
def test_a_status_out_of_what_the_packet_can_carry_names_the_field(field, value, said):
    from autonomy.errors import InvalidCommand

    with pytest.raises(InvalidCommand, match=re.escape(said)):
        _packet(**{field: value})
    _packet(**{field: value - 1 if value > 0 else value + 1})  # the edge itself is carried


@pytest.mark.parametrize("damage", ["length", "start", "end", "bit 7"])
def test_a_damaged_packet_travels_with_its_framing_error(damage):
    from autonomy.errors import FramingError
    from autonomy.protocol import decode_status

    packet = bytearray(_packet())
    if damage == "length":
        packet = packet[:8]
    elif damage == "start":
        packet[0] = ord("c")
    elif damage == "end":
        packet[8] = ord("x")
    else:
        packet[1] |= 0x80
    with pytest.raises(FramingError, match="bit 7" if damage == "bit 7" else "not a status packet") as caught:
        decode_status(bytes(packet))
    assert caught.value.data == bytes(packet)


def test_an_odometer_step_of_half_its_range_counts_as_backward():
    from autonomy.protocol import odometer_delta_mm

    assert odometer_delta_mm(0, 32767) == 32767
    assert odometer_delta_mm(0, 32768) == -32768
    assert odometer_delta_mm(65535, 0) == 1

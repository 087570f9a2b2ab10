"""Property tests: round trips, and decoders fed arbitrary bytes."""

import dataclasses
import re

import pytest
from hypothesis import given
from hypothesis import strategies as st

from autonomy.errors import FramingError, InvalidCommand
from autonomy.protocol import (
    Beep,
    Get,
    Move,
    Parameter,
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
from tests.protocol.test_replies import decode_all

tone = st.integers(1, 9)
commands = st.one_of(
    st.builds(Beep, st.tuples(tone, tone, tone), st.integers(0, 5)),
    st.just(Stop()),
    st.builds(Move, st.integers(1, 4), st.booleans()),
    st.builds(ServoTo, st.integers(0, 2), st.integers(-99, 99)),
    st.builds(ServoBy, st.integers(0, 2), st.integers(-9, 9)),
    st.builds(Turn, st.integers(-999, 999)),
    st.builds(Get, st.sampled_from("DBFVARb")),
)
statuses = st.builds(
    Status,
    mode=st.integers(0, 15),
    auto_mode=st.booleans(),
    collided=st.booleans(),
    moving=st.booleans(),
    tilt_deg=st.integers(-127, 127),
    heading_deg=st.integers(0, 359),
    front_distance_mm=st.integers(0, 255),
    odometer_mm=st.integers(0, 65535),
)
parameters = st.one_of(
    st.builds(Parameter, st.sampled_from("DB"), st.integers(0, 255)),
    st.builds(Parameter, st.sampled_from("VA"), st.integers(-99, 99)),
    st.builds(
        Parameter, st.just("F"), st.text(st.characters(min_codepoint=0x20, max_codepoint=0x7E), min_size=3, max_size=3)
    ),
)


@given(commands)
def test_every_command_is_six_bytes_and_parses_back(command):
    frame = command.encode()
    assert len(frame) == 6 and frame.endswith(b"\n") and frame.count(b"\n") == 1
    assert parse_command(frame) == command


@given(statuses)
def test_status_round_trip(status):
    decoded = decode_status(status.encode())
    assert decoded == status and hash(decoded) == hash(status) and repr(decoded) == repr(status)
    assert decoded.raw == status.encode()
    fields = {name: getattr(decoded, name) for name in decoded.__dataclass_fields__}
    assert Status(**fields) == decoded and Status(**fields).raw == decoded.raw  # what the checked path makes
    with pytest.raises(dataclasses.FrozenInstanceError):
        decoded.heading_deg = 0  # type: ignore[misc]


_FIELDS = {
    "mode": 1,
    "auto_mode": True,
    "collided": False,
    "moving": True,
    "tilt_deg": -3,
    "heading_deg": 90,
    "front_distance_mm": 120,
    "odometer_mm": 65535,
}


@pytest.mark.parametrize("field", ["mode", "tilt_deg", "heading_deg", "front_distance_mm", "odometer_mm"])
@pytest.mark.parametrize("value", [True, 1.0, "1"])
def test_a_status_field_that_is_not_a_whole_number_is_refused_even_in_range(field, value):
    with pytest.raises(InvalidCommand, match=re.escape(f"must be a whole number, got {value!r}")):
        Status(**{**_FIELDS, field: value})


def test_a_status_made_unchecked_is_the_checked_one_field_for_field():
    checked, unchecked = Status(**_FIELDS), Status.unchecked(*_FIELDS.values())
    assert unchecked == checked and unchecked.as_dict() == checked.as_dict() and unchecked.raw == b""


@given(parameters)
def test_parameter_round_trip(parameter):
    replies, errors = decode_all(ReplyDecoder(ReplyKind.PARAMETER, parameter.parameter), parameter.encode())
    assert replies == [parameter] and errors == 0


@given(st.binary(max_size=200), st.sampled_from(["ack", "health", "status", *"DBFVA"]), st.integers(1, 17))
def test_arbitrary_bytes_raise_only_framing_errors(data, kind, chunk):
    decoder = ReplyDecoder(ReplyKind.PARAMETER, kind) if len(kind) == 1 else ReplyDecoder(ReplyKind(kind))
    for start in range(0, len(data), chunk):
        decoder.feed(data[start : start + chunk])
        for _ in range(len(data) + 2):  # each call consumes bytes or returns None
            try:
                if decoder.next_reply() is None:
                    break
            except FramingError:
                continue
    assert decoder.buffered <= max(ReplyDecoder.MAX_LINE, 9)


@given(st.binary(max_size=60), parameters)
def test_ascii_decoder_resyncs_on_the_next_frame_after_a_newline(garbage, parameter):
    replies, _ = decode_all(
        ReplyDecoder(ReplyKind.PARAMETER, parameter.parameter), garbage + b"\n" + parameter.encode()
    )
    assert replies and replies[-1] == parameter


@given(st.binary(max_size=60).map(lambda b: b.replace(b"b", b"").replace(b"N", b"")), statuses)
def test_status_decoder_resyncs_on_the_next_packet(garbage, status):
    replies, errors = decode_all(ReplyDecoder(ReplyKind.STATUS), garbage + status.encode())
    assert replies == [status]
    assert errors >= (1 if garbage else 0)

"""The robot's serial protocol: bytes to typed values and back. No I/O, no clock.

Commands are frozen dataclasses that check their ranges when built and encode to exactly
the 6 bytes of docs/protocol.md. Replies decode into frozen dataclasses. Both sides of the
wire use this module: the client encodes commands and decodes replies, the emulator's
firmware parses commands and encodes replies.

:class:`ReplyDecoder` is incremental: feed it whatever bytes arrived and ask for the next
reply. Partial frames are an ordinary case (it returns ``None``); bytes that cannot be a
frame raise :class:`~autonomy.errors.FramingError` after being consumed, so the next call
carries on from the next candidate frame.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import ClassVar, Union

from autonomy.errors import FramingError, InvalidCommand

FRAME_LENGTH = 6
STATUS_LENGTH = 9
#: The status packet's first byte (``b``).
STATUS_START = 0x62
NEWLINE = 0x0A
OK = b"OK\n"
NO = b"NO\n"

#: Parameters that ``G`` answers with 5 ASCII bytes.
ASCII_PARAMETERS = "DBFVA"
#: Every parameter letter ``G`` accepts.
PARAMETERS = ASCII_PARAMETERS + "Rb"


def _check_int(name: str, value: int, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise InvalidCommand(f"{name} must be a whole number, got {value!r}")
    if not low <= value <= high:
        raise InvalidCommand(f"{name} must be in {low}..{high}, got {value}")
    return value


# --------------------------------------------------------------------------- commands


class ReplyKind(enum.Enum):
    """The shape of reply a command expects."""

    ACK = "ack"  # OK / NO
    PARAMETER = "parameter"  # P v2 v1 v0 \n
    HEALTH = "health"  # OK / NO (or ROK / RNO)
    STATUS = "status"  # 9-byte binary packet


@dataclass(frozen=True)
class Beep:
    """``S``: beep three tones, 1 (lowest) to 9, at ``volume`` 0 (silent) to 5."""

    tones: tuple[int, int, int]
    volume: int

    letter: ClassVar[str] = "S"
    retryable: ClassVar[bool] = True

    def __post_init__(self) -> None:
        if len(self.tones) != 3:
            raise InvalidCommand(f"a beep has exactly 3 tones, got {len(self.tones)}")
        for tone in self.tones:
            _check_int("tone", tone, 1, 9)
        _check_int("volume", self.volume, 0, 5)
        object.__setattr__(self, "tones", tuple(self.tones))

    def encode(self) -> bytes:
        """Returns the 6-byte frame, e.g. ``b"S1625\\n"``."""
        t1, t2, t3 = self.tones
        return f"S{t1}{t2}{t3}{self.volume}\n".encode("ascii")


@dataclass(frozen=True)
class Stop:
    """``X``: cancel every movement."""

    letter: ClassVar[str] = "X"
    retryable: ClassVar[bool] = True

    def encode(self) -> bytes:
        """Returns ``b"X0000\\n"``."""
        return b"X0000\n"


@dataclass(frozen=True)
class Move:
    """``F``: move at a fixed velocity, speed setting 1 (slow) to 4 (very fast)."""

    speed: int
    backward: bool = False

    letter: ClassVar[str] = "F"
    retryable: ClassVar[bool] = True

    def __post_init__(self) -> None:
        _check_int("speed", self.speed, 1, 4)

    def encode(self) -> bytes:
        """Returns e.g. ``b"F+100\\n"`` (forward, speed 1)."""
        return f"F{'-' if self.backward else '+'}{self.speed}00\n".encode("ascii")


@dataclass(frozen=True)
class ServoTo:
    """``M``: servo ``servo_id`` (0-2) to an absolute angle, -99..+99 degrees."""

    servo_id: int
    angle_deg: int

    letter: ClassVar[str] = "M"
    retryable: ClassVar[bool] = True

    def __post_init__(self) -> None:
        _check_int("servo id", self.servo_id, 0, 2)
        _check_int("servo angle", self.angle_deg, -99, 99)

    def encode(self) -> bytes:
        """Returns e.g. ``b"M0+10\\n"``."""
        sign = "-" if self.angle_deg < 0 else "+"
        return f"M{self.servo_id}{sign}{abs(self.angle_deg):02d}\n".encode("ascii")


@dataclass(frozen=True)
class ServoBy:
    """``D``: servo ``servo_id`` (0-2) by -9..+9 degrees from where it is now.

    Not retryable: a repeat after a lost ``OK`` would move the servo twice.
    """

    servo_id: int
    delta_deg: int

    letter: ClassVar[str] = "D"
    retryable: ClassVar[bool] = False

    def __post_init__(self) -> None:
        _check_int("servo id", self.servo_id, 0, 2)
        _check_int("servo step", self.delta_deg, -9, 9)

    def encode(self) -> bytes:
        """Returns e.g. ``b"D0+80\\n"`` (servo 0 by +8 degrees)."""
        sign = "-" if self.delta_deg < 0 else "+"
        return f"D{self.servo_id}{sign}{abs(self.delta_deg)}0\n".encode("ascii")


@dataclass(frozen=True)
class Turn:
    """``T``: turn in place; positive ``angle_deg`` turns left, negative right, |angle| <= 999.

    Not retryable: a repeat after a lost ``OK`` would turn twice.
    """

    angle_deg: int

    letter: ClassVar[str] = "T"
    retryable: ClassVar[bool] = False

    def __post_init__(self) -> None:
        _check_int("turn angle", self.angle_deg, -999, 999)

    def encode(self) -> bytes:
        """Returns e.g. ``b"T+005\\n"`` (left 5 degrees)."""
        sign = "-" if self.angle_deg < 0 else "+"
        return f"T{sign}{abs(self.angle_deg):03d}\n".encode("ascii")


@dataclass(frozen=True)
class Get:
    """``G``: ask for parameter ``D B F V A R`` (ASCII) or ``b`` (binary status)."""

    parameter: str

    letter: ClassVar[str] = "G"
    retryable: ClassVar[bool] = True

    def __post_init__(self) -> None:
        if not isinstance(self.parameter, str) or len(self.parameter) != 1:
            raise InvalidCommand(f"parameter must be one letter, got {self.parameter!r}")
        if self.parameter not in PARAMETERS:
            raise InvalidCommand(f"parameter must be one of {PARAMETERS}, got {self.parameter!r}")

    @property
    def reply_kind(self) -> ReplyKind:
        """What kind of reply this request gets."""
        if self.parameter == "b":
            return ReplyKind.STATUS
        if self.parameter == "R":
            return ReplyKind.HEALTH
        return ReplyKind.PARAMETER

    def encode(self) -> bytes:
        """Returns e.g. ``b"Gb000\\n"`` (made once for each parameter: the status is asked every tick)."""
        return _GET_FRAMES[self.parameter]


_GET_FRAMES = {parameter: f"G{parameter}000\n".encode("ascii") for parameter in PARAMETERS}

Command = Union[Beep, Stop, Move, ServoTo, ServoBy, Turn, Get]


def reply_kind(command: Command) -> ReplyKind:
    """Returns the kind of reply ``command`` expects."""
    return command.reply_kind if isinstance(command, Get) else ReplyKind.ACK


def _digit(byte: int) -> int:
    """One ASCII digit's value; the command's own checks then say which values it takes."""
    value = byte - 0x30
    if not 0 <= value <= 9:
        raise InvalidCommand(f"expected a digit, got {bytes([byte])!r}")
    return value


def parse_command(frame: bytes) -> Command:
    """Parses one command frame the way the robot's firmware does.

    Args:
        frame: Exactly 6 bytes ending in ``\\n``.

    Returns:
        The command.

    Raises:
        FramingError: ``frame`` is not 6 bytes ending in ``\\n``.
        InvalidCommand: an unknown command letter or an argument out of range; the
            firmware answers ``NO`` to both.
    """
    if len(frame) != FRAME_LENGTH or frame[-1] != NEWLINE:
        raise FramingError(f"a command frame is 6 bytes ending in \\n, got {frame!r}", frame)
    letter = chr(frame[0])
    a1, a2, a3, a4 = frame[1:5]
    if letter == "S":
        return Beep((_digit(a1), _digit(a2), _digit(a3)), _digit(a4))
    if letter == "X":
        return Stop()
    if letter == "F":
        return Move(_digit(a2), backward=a1 == ord("-"))
    if letter == "M":
        angle = _digit(a3) * 10 + _digit(a4)
        return ServoTo(_digit(a1), -angle if a2 == ord("-") else angle)
    if letter == "D":
        delta = _digit(a3)
        return ServoBy(_digit(a1), -delta if a2 == ord("-") else delta)
    if letter == "T":
        angle = _digit(a2) * 100 + _digit(a3) * 10 + _digit(a4)
        return Turn(-angle if a1 == ord("-") else angle)
    if letter == "G":
        return Get(chr(a1))
    raise InvalidCommand(f"unknown command letter {letter!r}")


# --------------------------------------------------------------------------- replies


@dataclass(frozen=True)
class Ack:
    """``OK`` (``ok=True``) or ``NO`` (``ok=False``)."""

    ok: bool

    def encode(self) -> bytes:
        """Returns ``b"OK\\n"`` or ``b"NO\\n"``."""
        return OK if self.ok else NO


@dataclass(frozen=True)
class Parameter:
    """An ASCII ``G`` reply: ``parameter`` is one of ``D B F V A``.

    ``value`` is an int for D and B (0..255) and for V and A (-99..+99), and a
    3-character string for F (the firmware version).
    """

    parameter: str
    value: int | str

    def __post_init__(self) -> None:
        p = self.parameter
        if p not in ASCII_PARAMETERS:
            raise InvalidCommand(f"not an ASCII parameter: {p!r}")
        if p == "F":
            if not (isinstance(self.value, str) and len(self.value) == 3):
                raise InvalidCommand(f"firmware version is 3 characters, got {self.value!r}")
            if not all(0x20 <= ord(c) <= 0x7E for c in self.value):
                raise InvalidCommand(f"firmware version must be printable, got {self.value!r}")
        elif p in "DB":
            _check_int(p, self.value, 0, 255)  # type: ignore[arg-type]
        else:
            _check_int(p, self.value, -99, 99)  # type: ignore[arg-type]

    def encode(self) -> bytes:
        """Returns the 5-byte reply, e.g. ``b"D120\\n"`` or ``b"A-05\\n"``."""
        p, v = self.parameter, self.value
        if p == "F":
            body = str(v)
        elif p in "DB":
            body = f"{v:03d}"
        else:
            body = f"{'-' if v < 0 else '+'}{abs(v):02d}"  # type: ignore[operator,arg-type]
        return f"{p}{body}\n".encode("ascii")


@dataclass(frozen=True)
class Health:
    """The ``GR`` reply: the platform is healthy (``OK``) or not (``NO``)."""

    ok: bool

    def encode(self) -> bytes:
        """Returns ``b"OK\\n"`` or ``b"NO\\n"`` (the robot's own form)."""
        return OK if self.ok else NO


#: How a frozen dataclass sets its fields (past its own guard).
_set = object.__setattr__


@dataclass(frozen=True)
class Status:
    """The 9-byte binary status packet (``Gb000``), decoded.

    Attributes:
        mode: Robot mode, bits 3-0 of the flags (0-15). The emulator's values are
            0 idle, 1 moving, 2 turning, 3 fallen.
        auto_mode: True in auto mode; in manual mode the robot refuses motion commands.
        collided: The collision flag.
        moving: The robot moves, on purpose or pushed.
        tilt_deg: Tilt angle, -127..+127 degrees.
        heading_deg: Heading 0..359 degrees, growing on left (counter-clockwise) turns.
        front_distance_mm: Front distance sensor, 0..255 mm (255: nothing closer).
        odometer_mm: Distance moved, 0..65535 mm, wrapping; see :func:`odometer_delta_mm`.
        raw: The 9 bytes as received (empty for a packet built in code).
    """

    mode: int
    auto_mode: bool
    collided: bool
    moving: bool
    tilt_deg: int
    heading_deg: int
    front_distance_mm: int
    odometer_mm: int
    raw: bytes = field(default=b"", compare=False, repr=False)

    def __post_init__(self) -> None:
        if (  # every packet is checked: plain ints in range pass at once, anything else is looked at in turn
            type(self.mode) is int
            and 0 <= self.mode <= 15
            and type(self.tilt_deg) is int
            and -127 <= self.tilt_deg <= 127
            and type(self.heading_deg) is int
            and 0 <= self.heading_deg <= 359
            and type(self.front_distance_mm) is int
            and 0 <= self.front_distance_mm <= 255
            and type(self.odometer_mm) is int
            and 0 <= self.odometer_mm <= 65535
        ):
            return
        _check_int("mode", self.mode, 0, 15)
        _check_int("tilt", self.tilt_deg, -127, 127)
        _check_int("heading", self.heading_deg, 0, 359)
        _check_int("front distance", self.front_distance_mm, 0, 255)
        _check_int("odometer", self.odometer_mm, 0, 65535)

    @classmethod
    def unchecked(
        cls,
        mode: int,
        auto_mode: bool,
        collided: bool,
        moving: bool,
        tilt_deg: int,
        heading_deg: int,
        front_distance_mm: int,
        odometer_mm: int,
        raw: bytes = b"",
    ) -> Status:
        """A packet from values already known to be plain ints in range, not checked again.

        For decoded bytes and clamped readings, which cannot be out of range: a status is
        made twice a tick, and the dataclass's own ``__init__`` checks every field again. The
        fields are set one by one, as that ``__init__`` sets them: a packet given a whole
        ``__dict__`` at once costs every later read of its fields several times as much
        (Python gives up the instance's compact form). The packet is the same as
        ``Status(...)`` would make.
        """
        packet = object.__new__(cls)
        _set(packet, "mode", mode)
        _set(packet, "auto_mode", auto_mode)
        _set(packet, "collided", collided)
        _set(packet, "moving", moving)
        _set(packet, "tilt_deg", tilt_deg)
        _set(packet, "heading_deg", heading_deg)
        _set(packet, "front_distance_mm", front_distance_mm)
        _set(packet, "odometer_mm", odometer_mm)
        _set(packet, "raw", raw)
        return packet

    def encode(self) -> bytes:
        """Returns the 9-byte packet."""
        return encode_status(
            self.mode,
            self.auto_mode,
            self.collided,
            self.moving,
            self.tilt_deg,
            self.heading_deg,
            self.front_distance_mm,
            self.odometer_mm,
        )

    def as_dict(self) -> dict[str, int | bool | str]:
        """Returns the named fields (and ``raw`` as hex), ready for JSON."""
        return {
            "mode": self.mode,
            "auto_mode": self.auto_mode,
            "collided": self.collided,
            "moving": self.moving,
            "tilt_deg": self.tilt_deg,
            "heading_deg": self.heading_deg,
            "front_distance_mm": self.front_distance_mm,
            "odometer_mm": self.odometer_mm,
            "raw": (self.raw or self.encode()).hex(" "),
        }


def encode_status(
    mode: int,
    auto_mode: bool,
    collided: bool,
    moving: bool,
    tilt_deg: int,
    heading_deg: int,
    front_distance_mm: int,
    odometer_mm: int,
) -> bytes:
    """The 9-byte status packet of these fields, each a plain int in its range (see :class:`Status`).

    The emulator answers every poll with it, without a :class:`Status` in between.
    """
    flags = mode | (0x10 if auto_mode else 0) | (0x20 if collided else 0) | (0x40 if moving else 0)
    return bytes(
        (
            STATUS_START,
            flags,
            tilt_deg & 0xFF,
            heading_deg >> 8,
            heading_deg & 0xFF,
            front_distance_mm,
            odometer_mm >> 8,
            odometer_mm & 0xFF,
            NEWLINE,
        )
    )


def decode_status(packet: bytes) -> Status:
    """Decodes one 9-byte status packet.

    Raises:
        FramingError: wrong length, byte 0 not ``b``, byte 8 not ``\\n``, or bit 7 of the
            flags set (it is unused and always 0: a packet with it set was damaged).
    """
    if len(packet) != STATUS_LENGTH:
        raise FramingError(f"not a status packet: {packet!r}", bytes(packet))
    # taken apart at once, and put together with shifts (every poll decodes one)
    start, flags, tilt, heading_high, heading_low, front, odometer_high, odometer_low, end = packet
    if start != STATUS_START or end != NEWLINE:
        raise FramingError(f"not a status packet: {packet!r}", bytes(packet))
    if flags & 0x80:
        raise FramingError(f"a status packet with the unused flag bit 7 set: {packet!r}", bytes(packet))
    heading = heading_high << 8 | heading_low
    if heading_high > 127:  # a signed 16-bit number
        heading -= 65536
    return Status.unchecked(  # each field is in its range by the way it is decoded
        flags & 0x0F,
        flags & 0x10 != 0,
        flags & 0x20 != 0,
        flags & 0x40 != 0,
        tilt if tilt < 128 else tilt - 256 if tilt > 128 else -127,  # signed; -128 is read as -127
        heading % 360,
        front,
        odometer_high << 8 | odometer_low,
        bytes(packet),
    )


def encode_heading(heading_deg: float) -> int:
    """Returns ``heading_deg`` (any real number) as the packet's 0..359 integer."""
    return int(round(heading_deg)) % 360


def odometer_delta_mm(earlier_mm: int, later_mm: int) -> int:
    """Returns the signed distance moved between two odometer readings.

    The odometer wraps modulo 65536 and counts down when moving backward, so readings
    are compared by their difference modulo 65536, taken as signed 16-bit.
    """
    delta = (later_mm - earlier_mm) % 65536
    return delta - 65536 if delta >= 32768 else delta


def heading_delta_deg(earlier_deg: int, later_deg: int) -> int:
    """Returns the signed turn between two headings, -180..179 (left positive).

    Headings wrap at 360, so 350 -> 10 is +20, not -340. Summing the deltas of readings
    taken less than half a turn apart follows a turn of any size.
    """
    return (later_deg - earlier_deg + 180) % 360 - 180


Reply = Union[Ack, Parameter, Health, Status]


def _parse_parameter(frame: bytes, parameter: str) -> Parameter | None:
    """Returns the reply in ``frame`` (5 bytes), or None when it is not a valid one."""
    if len(frame) != 5 or frame[0] != ord(parameter) or frame[4] != NEWLINE:
        return None
    body = frame[1:4]
    try:
        text = body.decode("ascii")
    except UnicodeDecodeError:
        return None
    if parameter == "F":
        return Parameter("F", text) if text.isprintable() else None
    if parameter in "DB":
        if not text.isdigit() or int(text) > 255:
            return None
        return Parameter(parameter, int(text))
    sign, digits = text[0], text[1:]
    if sign not in "+- 0" or not digits.isdigit():
        return None
    value = int(digits)
    return Parameter(parameter, -value if sign == "-" else value)


class ReplyDecoder:
    """Incremental decoder for the reply to one kind of request.

    Feed it bytes as they arrive; :meth:`next_reply` returns a reply once a whole frame
    is buffered, ``None`` while a frame is still incomplete, and raises
    :class:`FramingError` for bytes that cannot start a valid frame, after consuming
    them. Calling again after an error resumes at the next candidate frame.

    Args:
        kind: The kind of reply expected.
        parameter: For ``ReplyKind.PARAMETER``, the parameter letter asked for.
    """

    #: Longest run of bytes with no newline kept while waiting for an ASCII frame.
    MAX_LINE = 16

    def __init__(self, kind: ReplyKind, parameter: str = "") -> None:
        self.kind = kind
        self.parameter = parameter
        self._buffer = bytearray()

    @classmethod
    def for_command(cls, command: Command) -> ReplyDecoder:
        """Returns a decoder for the reply to ``command``."""
        return cls(reply_kind(command), command.parameter if isinstance(command, Get) else "")

    @property
    def buffered(self) -> int:
        """Bytes held that are not yet part of a returned reply."""
        return len(self._buffer)

    def feed(self, data: bytes) -> None:
        """Appends received bytes."""
        self._buffer += data

    def bytes_needed(self) -> int:
        """The fewest further bytes that could complete a frame (at least 1)."""
        buf = self._buffer
        if self.kind is ReplyKind.STATUS:
            if not buf:
                return 3  # "NO\n" is the shortest reply
            want = STATUS_LENGTH if buf[0] == ord("b") else 3
        elif self.kind is ReplyKind.PARAMETER:
            want = 5 if buf[:1] == self.parameter.encode() else 3
        elif self.kind is ReplyKind.HEALTH:
            want = 4 if buf[:1] == b"R" else 3
        else:
            want = 3
        return max(1, want - len(buf))

    def next_reply(self) -> Reply | None:
        """Returns the next complete reply, or None when more bytes are needed.

        Raises:
            FramingError: the bytes at the front cannot be a valid frame; they were
                consumed.
        """
        if self.kind is ReplyKind.STATUS:
            return self._next_status()
        return self._next_ascii()

    def _take(self, count: int) -> bytes:
        taken = bytes(self._buffer[:count])
        del self._buffer[:count]
        return taken

    def _junk(self, count: int) -> FramingError:
        junk = self._take(count)
        return FramingError(f"{len(junk)} byte(s) that are not a valid reply: {junk!r}", junk)

    def _valid_ascii(self, frame: bytes) -> Reply | None:
        if frame == OK:
            if self.kind is ReplyKind.PARAMETER:
                return None  # a value was asked for: an acknowledgement is a reply of the wrong kind
            return Health(True) if self.kind is ReplyKind.HEALTH else Ack(True)
        if frame == NO:
            return Health(False) if self.kind is ReplyKind.HEALTH else Ack(False)
        if self.kind is ReplyKind.HEALTH and frame in (b"ROK\n", b"RNO\n"):
            return Health(frame == b"ROK\n")
        if self.kind is ReplyKind.PARAMETER:
            return _parse_parameter(frame, self.parameter)
        return None

    def _next_ascii(self) -> Reply | None:
        buf = self._buffer
        end = buf.find(NEWLINE)
        if end < 0:
            if len(buf) > self.MAX_LINE:
                raise self._junk(len(buf) - 4)  # keep a tail that may start a frame
            return None
        line = bytes(buf[: end + 1])
        for length in (5, 4, 3):  # a valid frame may end a line that starts with junk
            if len(line) >= length:
                reply = self._valid_ascii(line[-length:])
                if reply is not None:
                    if len(line) == length:
                        self._take(length)
                        return reply
                    raise self._junk(len(line) - length)
        raise self._junk(len(line))

    def _next_status(self) -> Reply | None:
        buf = self._buffer
        if not buf:
            return None
        if buf[0] == ord("b"):
            if len(buf) < STATUS_LENGTH:
                return None
            if buf[8] == NEWLINE:
                return decode_status(self._take(STATUS_LENGTH))
            raise self._junk(1)
        if buf[0] == ord("N"):
            if len(buf) < 3 and NO.startswith(bytes(buf)):
                return None  # the start of a NO
            if buf[:3] == NO:
                self._take(3)
                return Ack(False)
        starts = [i for i in (buf.find(b"b"), buf.find(b"N", 1)) if i != -1]  # neither can be at 0 here
        raise self._junk(min(starts) if starts else len(buf))

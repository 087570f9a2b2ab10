"""What a fit is made from: the motion commands a robot was sent, and what it reported, each with its time.

A probe (:mod:`autonomy.calibration.probe`) records one as it drives; a trace of an earlier run
is read into one by :func:`from_trace`. The times are the client's own, in seconds.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from autonomy.errors import ProtocolError
from autonomy.protocol import Move, Stop, Turn, odometer_delta_mm, parse_command
from autonomy.trace import TraceError, read_trace

#: Longest run a trace may hold, seconds from its first tick: a day (a lesson's runs are minutes).
MAX_TRACE_S = 86_400.0


@dataclass(frozen=True)
class Sent:
    """A motion command the robot accepted.

    Attributes:
        time_s: When it was sent.
        kind: ``move``, ``turn`` or ``stop``.
        value: For a move, the speed setting, negative backward; for a turn, its angle in degrees.
    """

    time_s: float
    kind: str
    value: int = 0


@dataclass(frozen=True)
class Sample:
    """One status packet, and when it was read.

    Attributes:
        time_s: Halfway between the request and its answer.
        heading_deg: The packet's heading, 0..359.
        odometer_mm: The distance moved, unwrapped: signed millimetres since the recording began.
        front_mm: The front sensor's reading.
        moving: The packet's motion flag.
        gap_mm: The true distance from the robot's front to the wall ahead, where the recording knows it
            (a probe that started a known distance from a wall, driving straight at it); None elsewhere.
    """

    time_s: float
    heading_deg: int
    odometer_mm: float
    front_mm: int
    moving: bool
    gap_mm: float | None = None


@dataclass
class Recording:
    """Commands and samples, each in time order, with where they came from."""

    label: str
    sent: list[Sent] = field(default_factory=list)
    samples: list[Sample] = field(default_factory=list)
    #: The front sensor's largest reading (a reading of it sees nothing).
    sensor_max_mm: int = 255
    #: Whether each command's time is the moment it was sent (a probe's), so that how late each one acted is
    #: fitted; a trace's commands are timed by their ticks, and a fit of them knows the delay to within a tick.
    commands_timed: bool = True


def sent_of(command: object, time_s: float) -> Sent | None:
    """A motion command as a fit takes it (None: not a motion command)."""
    if isinstance(command, Move):
        return Sent(time_s, "move", -command.speed if command.backward else command.speed)
    if isinstance(command, Turn):
        return Sent(time_s, "turn", command.angle_deg)
    if isinstance(command, Stop):
        return Sent(time_s, "stop")
    return None


class Unwrapper:
    """Turns the packet's odometer (16 bits, wrapping) into signed millimetres since the first reading."""

    def __init__(self) -> None:
        self._last: int | None = None
        self.total_mm = 0.0

    def __call__(self, odometer_mm: int) -> float:
        """The distance since the first reading, signed."""
        if self._last is not None:
            self.total_mm += odometer_delta_mm(self._last, odometer_mm)
        self._last = odometer_mm
        return self.total_mm


def from_trace(path: str | Path) -> Recording:
    """The commands and samples of a trace (``autonomy run --trace``): each tick's status, the commands it sent.

    A tick's commands are taken as sent at the tick's time, its status as read then: a trace's
    times are its ticks', so a fit from traces knows the delay to within a tick.

    Raises:
        TraceError: the file is not a trace this version reads.
    """
    trace = read_trace(path)
    recording = Recording(str(path), commands_timed=False)
    unwrap = Unwrapper()
    before_s = 0.0
    for number, tick in enumerate(trace.ticks, start=1):
        if not before_s <= tick.time_s <= MAX_TRACE_S:  # NaN too
            where = "before the tick before it" if tick.time_s < before_s else f"past {MAX_TRACE_S / 3600:g} hours"
            raise TraceError(
                f"{path}: tick {number}: its time_s {tick.time_s!r} is {where}: this is not a trace as a run writes it"
            )
        before_s = tick.time_s
        status = tick.status
        recording.samples.append(
            Sample(tick.time_s, status.heading_deg, unwrap(status.odometer_mm), status.front_distance_mm, status.moving)
        )
        for exchange in tick.wire:
            if exchange.reply != "OK":
                continue
            try:
                command = parse_command(exchange.sent.encode("ascii") + b"\n")
            except (ProtocolError, UnicodeEncodeError):
                continue
            sent = sent_of(command, tick.time_s)
            if sent is not None and not (recording.sent and recording.sent[-1] == sent):  # a retry is one command
                recording.sent.append(sent)
    return recording

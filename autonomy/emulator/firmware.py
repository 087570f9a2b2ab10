"""The robot's firmware: command frames in, reply bytes out, exactly as docs/protocol.md says.

It splits the incoming byte stream into frames at each ``\\n`` and answers every frame.
A frame that is not 6 bytes, has an unknown letter or an argument out of range is answered
``NO``; since each ``\\n`` ends a frame, garbage costs one ``NO`` and the next frame is
read normally (resynchronisation). It reuses :mod:`autonomy.protocol` for both directions.
"""

from __future__ import annotations

from autonomy.emulator.robot import Robot
from autonomy.errors import ProtocolError
from autonomy.protocol import (
    FRAME_LENGTH,
    NEWLINE,
    NO,
    OK,
    Beep,
    Command,
    Get,
    Health,
    Move,
    Parameter,
    ServoBy,
    ServoTo,
    Status,
    Stop,
    Turn,
    encode_heading,
    encode_status,
    parse_command,
)

#: Commands that move something: refused in manual mode, fallen, or on a flat battery.
MOTION = (Move, Turn, ServoTo, ServoBy)
#: A command's name as a sensor script's refusals say it (:data:`~autonomy.emulator.script.REFUSABLE`).
_SCRIPTED: dict[type, str] = {Beep: "beep", Move: "move", Turn: "turn", ServoTo: "servo", ServoBy: "servo"}
#: Valid frames kept parsed (there are a few thousand possible; a run uses a handful).
PARSED_LIMIT = 4096


class Firmware:
    """Answers command frames for one :class:`Robot`.

    Args:
        robot: The robot the commands act on.
    """

    def __init__(self, robot: Robot) -> None:
        self.robot = robot
        self._line = bytearray()
        self._parsed: dict[bytes, Command] = {}

    def frames(self, data: bytes) -> list[bytes]:
        """Splits received bytes into frames; a frame ends at each ``\\n``.

        Bytes after the last ``\\n`` wait for the next call. A run longer than a frame
        keeps only its first bytes: it will be answered ``NO`` either way.
        """
        frames = []
        for byte in data:
            if len(self._line) <= FRAME_LENGTH:
                self._line.append(byte)
            if byte == NEWLINE:
                frames.append(bytes(self._line))
                self._line.clear()
        return frames

    @property
    def idle(self) -> bool:
        """True when no partial frame waits for the rest of its bytes."""
        return not self._line

    def execute(self, frame: bytes) -> tuple[Command | None, bytes]:
        """Carries out one frame.

        Returns:
            The parsed command (None when the frame was refused as invalid) and the
            reply bytes.
        """
        frame = bytes(frame)  # a bytearray cannot be a key
        command = self._parsed.get(frame)
        if command is None:
            try:
                command = parse_command(frame)
            except ProtocolError:
                return None, NO
            if len(self._parsed) < PARSED_LIMIT:  # a run sends the same few frames again and again
                self._parsed[frame] = command
        return command, self.answer(command)

    def answer(self, command: Command) -> bytes:
        """Acts on ``command`` and returns the reply bytes."""
        if isinstance(command, Get):  # first: the status poll, every tick (a request is no motion)
            return self._get(command.parameter)
        robot = self.robot
        if isinstance(command, MOTION) and not robot.can_move:
            return NO
        script = robot.script
        if (
            script is not None
            and script.refuses
            and script.refused(_SCRIPTED.get(type(command), ""), robot.script_time_s)
        ):
            return NO
        if isinstance(command, Beep):
            robot.beep(command.tones, command.volume)
        elif isinstance(command, Stop):
            robot.stop()
        elif isinstance(command, Move):
            robot.move(command.speed, command.backward)
        elif isinstance(command, Turn):
            robot.turn(command.angle_deg)
        elif isinstance(command, ServoTo):
            robot.servo_to(command.servo_id, command.angle_deg)
        elif isinstance(command, ServoBy):
            robot.servo_by(command.servo_id, command.delta_deg)
        return OK

    def _get(self, parameter: str) -> bytes:
        robot = self.robot
        if parameter == "b":  # every poll: the packet's bytes made at once
            fields = self._status_fields()
            try:
                return encode_status(*fields)
            except ValueError:  # a field out of its range (a sensor set to read past 255): Status says which
                return Status(*fields).encode()
        if parameter == "R":
            return Health(robot.healthy).encode()
        if parameter == "F":
            return Parameter("F", robot.params.firmware_version).encode()
        if parameter == "D":
            return Parameter("D", robot.front_distance_mm()).encode()
        if parameter == "B":
            return Parameter("B", round(robot.battery)).encode()
        if parameter == "V":
            return Parameter("V", robot.velocity_v()).encode()
        return Parameter("A", max(-99, min(99, round(robot.reported_tilt_deg)))).encode()

    def status(self) -> Status:
        """Returns the robot's state as a status packet."""
        return Status(*self._status_fields())

    def _status_fields(self) -> tuple[int, bool, bool, bool, int, int, int, int]:
        """The status packet's fields, in :class:`Status`'s order (the front distance as the sensor reads it)."""
        robot = self.robot
        return (
            robot.mode,
            robot.auto_mode,
            robot.collided,
            robot.moving,
            -127 if (tilt := round(robot.reported_tilt_deg)) < -127 else 127 if tilt > 127 else tilt,
            encode_heading(robot.heading_deg),
            robot.front_distance_mm(),
            round(robot.odometer_mm) % 65536,
        )

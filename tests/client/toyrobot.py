"""An independent scripted robot behind a faulty line, for the fault matrix.

It shares no code with the package: frames are parsed and packets built here by hand from
PROTOCOL.md, motion is a plain constant-rate model, and the faults are its own. So the
client is tested against a second reading of the protocol, not against its own emulator.
"""

from __future__ import annotations

import random
import struct
from dataclasses import dataclass, field

from autonomy.clock import VirtualClock

TURN_RATE_DEG_S = 120.0
SPEEDS_MM_S = {1: 100.0, 2: 200.0, 3: 300.0, 4: 400.0}


@dataclass
class ToyRobot:
    """A robot in an empty room: heading, odometer and three servos, nothing to hit."""

    time_s: float = 0.0
    heading_deg: float = 0.0
    odometer_mm: float = 0.0
    speed_mm_s: float = 0.0
    turn_left_deg: float = 0.0
    servos: list[int] = field(default_factory=lambda: [0, 0, 0])
    packets: set[bytes] = field(default_factory=set)  # every status packet it ever sent, as sent
    received: list[bytes] = field(default_factory=list)  # every frame it carried out
    travelled_mm: float = 0.0
    turned_deg: float = 0.0

    def advance(self, now_s: float) -> None:
        dt = max(0.0, now_s - self.time_s)
        self.time_s = now_s
        if self.turn_left_deg:
            step = min(abs(self.turn_left_deg), TURN_RATE_DEG_S * dt)
            step = step if self.turn_left_deg > 0 else -step
            self.heading_deg += step
            self.turn_left_deg -= step
            self.turned_deg += abs(step)
        if self.speed_mm_s:
            self.odometer_mm += self.speed_mm_s * dt
            self.travelled_mm += abs(self.speed_mm_s) * dt

    @property
    def moving(self) -> bool:
        return bool(self.speed_mm_s or self.turn_left_deg)

    def packet(self) -> bytes:
        flags = 0x10 | (0x40 if self.moving else 0) | (2 if self.turn_left_deg else 1 if self.speed_mm_s else 0)
        heading = round(self.heading_deg) % 360
        odometer = round(self.odometer_mm) % 65536
        packet = b"b" + struct.pack(">BbhBH", flags, 0, heading, 255, odometer) + b"\n"
        self.packets.add(packet)
        return packet

    def answer(self, frame: bytes) -> bytes:
        """The reply to one frame (its 6 bytes, newline included), carrying it out when valid."""
        text = frame.decode("ascii", "replace")
        if len(frame) != 6 or not text.endswith("\n"):
            return b"NO\n"
        letter, body = text[0], text[1:5]
        if letter == "G" and body[1:] == "000":
            values = {"D": b"D255\n", "B": b"B200\n", "F": b"FT01\n", "V": b"V+00\n", "A": b"A+00\n", "R": b"OK\n"}
            if body[0] == "b":
                return self.packet()
            return values.get(body[0], b"NO\n")
        if letter == "X" and body == "0000":
            self.speed_mm_s, self.turn_left_deg = 0.0, 0.0
        elif letter == "F" and body[0] in "+-" and body[1] in "1234" and body[2:] == "00":
            self.turn_left_deg = 0.0
            self.speed_mm_s = SPEEDS_MM_S[int(body[1])] * (-1 if body[0] == "-" else 1)
        elif letter == "T" and body[0] in "+-" and body[1:].isdigit():
            self.speed_mm_s = 0.0
            self.turn_left_deg = int(body[1:]) * (-1 if body[0] == "-" else 1)
        elif letter == "D" and body[0] in "012" and body[1] in "+-" and body[2].isdigit() and body[3] == "0":
            self.servos[int(body[0])] += int(body[2]) * (-1 if body[1] == "-" else 1)
        elif letter == "M" and body[0] in "012" and body[1] in "+-" and body[2:].isdigit():
            self.servos[int(body[0])] = int(body[2:]) * (-1 if body[1] == "-" else 1)
        elif letter == "S" and body[:3].isdigit() and "0" not in body[:3] and body[3] in "012345":
            pass
        else:
            return b"NO\n"
        self.received.append(frame)
        return b"OK\n"


class FaultyLine:
    """A pyserial-like port to a :class:`ToyRobot` that loses, damages, delays and adds bytes.

    Args:
        fault: ``drop``, ``corrupt``, ``delay``, ``garbage`` or ``no`` (or ``none``).
        rate: How often it strikes: per byte for drop and corrupt, per reply otherwise.
        seed: For the faults' random numbers.
    """

    def __init__(self, fault: str, rate: float, seed: int) -> None:
        self.clock = VirtualClock()
        self.robot = ToyRobot()
        self.fault, self.rate = fault, rate
        self.random = random.Random(f"{fault} {rate} {seed}")
        self.timeout = 0.25
        self.writes: list[bytes] = []
        self._line = bytearray()
        self._out: list[tuple[float, int]] = []  # (due time, byte)

    def _damage(self, data: bytes) -> bytes:
        out = bytearray()
        for byte in data:
            if self.fault == "drop" and self.random.random() < self.rate:
                continue
            if self.fault == "corrupt" and self.random.random() < self.rate:
                byte ^= 1 << self.random.randrange(8)
            out.append(byte)
        return bytes(out)

    def write(self, data: bytes) -> int:
        self.writes.append(bytes(data))
        now = self.clock.now()
        self.robot.advance(now)
        for byte in self._damage(data):
            self._line.append(byte)
            if byte == 0x0A:
                frame, self._line = bytes(self._line), bytearray()
                self._reply(frame, now)
        return len(data)

    def _reply(self, frame: bytes, now: float) -> None:
        if self.fault == "no" and self.random.random() < self.rate:
            reply = b"NO\n"
        else:
            reply = self.robot.answer(frame[-6:])
        due = now + 0.002
        if self.fault == "delay" and self.random.random() < self.rate:
            due += 0.3
        if self.fault == "garbage" and self.random.random() < self.rate:
            reply += bytes(self.random.randrange(256) for _ in range(self.random.randint(1, 4)))
        self._out += [(due, byte) for byte in self._damage(reply)]
        self._out.sort(key=lambda item: item[0])  # a delayed reply arrives after a later one

    def read(self, size: int = 1) -> bytes:
        now = self.clock.now()
        dues = [due for due, _ in self._out]
        if sum(due <= now for due in dues) < size:  # wait for enough bytes, or the time-out
            deadline = now + self.timeout
            wanted = dues[size - 1] if len(dues) >= size and dues[size - 1] <= deadline else deadline
            self.clock.sleep(max(0.0, wanted - now))
            now = self.clock.now()
        count = 0
        while count < min(size, len(self._out)) and self._out[count][0] <= now:
            count += 1
        taken = bytes(byte for _, byte in self._out[:count])
        del self._out[:count]
        self.robot.advance(now)
        return taken

    def reset_input_buffer(self) -> None:
        self._out = [(due, byte) for due, byte in self._out if due > self.clock.now()]

    def close(self) -> None:
        pass

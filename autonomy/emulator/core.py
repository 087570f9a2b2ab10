"""The emulator as a byte stream: bytes in at a time, reply bytes out when they are due.

:class:`Emulator` joins the robot model, its firmware and the wire between them (faults,
baud-rate pacing) on one clock. It is lazy: every call first catches the physics up with
the clock, so it needs no thread of its own. The ``emu://`` port, the TCP server and the
pty server are thin shells around it.
"""

from __future__ import annotations

import math
import random
import threading
from collections import deque
from dataclasses import replace
from pathlib import Path
from typing import Any, NamedTuple

from autonomy.clock import Clock, RealClock, VirtualClock
from autonomy.emulator.faults import FaultSpec
from autonomy.emulator.firmware import Firmware
from autonomy.emulator.profile import load_profile
from autonomy.emulator.robot import Robot, RobotParams
from autonomy.emulator.world import Pose, World, load_world
from autonomy.protocol import FRAME_LENGTH, NEWLINE, NO, Command

DEFAULT_EMULATOR_BAUD = 57600
#: Received frames kept in :attr:`Emulator.log`; older ones are dropped.
LOG_LIMIT = 100_000
#: With ``pace``, bytes on their way each way at most (0.7 s of wire at 57600 baud), as a UART's buffer
#: holds so many: past it, bytes a client sends faster than the wire carries are lost (an overrun).
WIRE_BUFFER_BYTES = 4096


class Exchange(NamedTuple):
    """One frame the emulator received and what it answered.

    Attributes:
        time_s: Simulated time the frame was complete, seconds since the emulator started.
        frame: The frame's bytes as received (after any injected faults).
        command: The parsed command, or None when the frame was invalid.
        reply: The reply bytes sent (before any injected faults).
        executed: False when the command was not carried out (invalid, refused, or an
            injected ``NO``).

    A named tuple: one is made for every frame, and a tuple is the cheapest to make.
    """

    time_s: float
    frame: bytes
    command: Command | None
    reply: bytes
    executed: bool


class Emulator:
    """A robot on the other end of a serial line.

    Args:
        world: A :class:`World`, a shipped world's name or a path to a world file.
        params: The robot's settings.
        faults: What to inject on the wire, as a :class:`FaultSpec` or its text form.
        seed: Seeds faults, sensor noise, the start's jitter and what the world varies, so a run can
            be repeated exactly.
        clock: The clock it runs on; real time by default.
        baud: The baud rate the robot is set to. Bytes sent at another rate turn into
            noise both ways, as they do on a real serial line.
        boot_s: For this long after start the robot ignores everything it is sent, like a
            board that resets when its port is opened.
    """

    def __init__(
        self,
        world: World | str | Path = "box",
        *,
        params: RobotParams | None = None,
        faults: FaultSpec | str = "",
        seed: int = 0,
        clock: Clock | None = None,
        baud: int = DEFAULT_EMULATOR_BAUD,
        boot_s: float = 0.0,
    ) -> None:
        # the world as this seed has it: what its file varies from seed to seed, moved by the seed's draw
        self.world = (world if isinstance(world, World) else load_world(world)).for_seed(seed)
        self.clock: Clock = clock or RealClock()
        self.robot = Robot(self.world, params or RobotParams(), seed)
        self.firmware = Firmware(self.robot)
        self.faults = faults if isinstance(faults, FaultSpec) else FaultSpec.parse(faults)
        self.baud = baud
        self.boot_s = boot_s
        self.seed = seed
        self.log: deque[Exchange] = deque(maxlen=LOG_LIMIT)
        self._rng = random.Random(seed)
        self._origin_s = self.clock.now()
        self._inbox: deque[tuple[float, bytes]] = deque()
        self._outbox: deque[tuple[float, bytes]] = deque()
        self._in_free_s = 0.0  # when the incoming line is free for the next byte
        self._out_free_s = 0.0
        self._lock = threading.RLock()

    # ------------------------------------------------------------------ time

    def now_s(self) -> float:
        """Simulated seconds since the emulator started."""
        return self.clock.now() - self._origin_s

    def byte_time_s(self) -> float:
        """What one byte costs on the wire when pacing is on (10 bits), else 0."""
        return 10.0 / self.baud if self.faults.pace else 0.0

    def next_event_s(self) -> float | None:
        """Clock time of the next byte to arrive or leave, or None when nothing is under way."""
        with self._lock:
            due = [queue[0][0] for queue in (self._inbox, self._outbox) if queue]
            return min(due) + self._origin_s if due else None

    def advance(self) -> None:
        """Catches up with the clock: delivers due input to the firmware, steps the physics."""
        with self._lock:
            self._advance()

    def _advance(self) -> float:
        """:meth:`advance`, with the lock held; returns the time it caught up with."""
        now = self.now_s()
        while self._inbox and self._inbox[0][0] <= now:
            due, data = self._inbox.popleft()
            self.robot.advance_to(due)
            for frame in self.firmware.frames(data):
                self._answer(frame, due)
        self.robot.advance_to(now)
        return now

    # ------------------------------------------------------------------ wire

    def receive(self, data: bytes, baud: int | None = None) -> None:
        """Takes bytes sent to the robot now.

        Args:
            data: The bytes, as written by the other end.
            baud: The rate the other end sends at; None means the robot's own rate.
        """
        with self._lock:
            self.advance()
            now = self.now_s()
            if now < self.boot_s:
                return  # still booting: the bytes are lost
            if baud is not None and baud != self.baud:
                # A UART at the wrong rate sees noise, and what it sends back is noise too.
                data = bytes(0x80 | (b * 37 + 11) & 0x7F for b in data)
                self._send(bytes(0x80 | self._rng.randrange(128) for _ in range(max(1, len(data) // 2))), now)
            else:
                data = self._damage(data)
            if not data:
                return
            byte_s = self.byte_time_s()
            if byte_s:
                data = data[: max(0, WIRE_BUFFER_BYTES - len(self._inbox))]  # past the UART's buffer: overrun, lost
                start = max(now, self._in_free_s)
                for i, byte in enumerate(data):
                    self._inbox.append((start + (i + 1) * byte_s, bytes([byte])))
                self._in_free_s = start + len(data) * byte_s
            else:
                self._inbox.append((now, data))
            self.advance()

    def hang_up(self) -> None:
        """The peer went away: bytes still on the wire either way are lost, not kept for the next one.

        Commands already received are carried out; a frame cut off halfway is dropped.
        """
        with self._lock:
            self.advance()
            self._inbox.clear()
            self._outbox.clear()
            self._in_free_s = self._out_free_s = 0.0
            self.firmware.frames(b"\n")  # ends a partial frame (the robot answers nobody)

    def ready_count(self) -> int:
        """How many reply bytes have arrived and wait to be read."""
        with self._lock:
            self.advance()
            now = self.now_s()
            return sum(len(chunk) for due, chunk in self._outbox if due <= now)

    def read_ready(self, limit: int | None = None) -> bytes:
        """Takes up to ``limit`` reply bytes that have arrived (all of them when None)."""
        with self._lock:
            self.advance()
            now = self.now_s()
            out = bytearray()
            while self._outbox and self._outbox[0][0] <= now and (limit is None or len(out) < limit):
                due, chunk = self._outbox.popleft()
                room = len(chunk) if limit is None else limit - len(out)
                out += chunk[:room]
                if room < len(chunk):
                    self._outbox.appendleft((due, chunk[room:]))
            return bytes(out)

    def answer_now(self, frame: bytes, baud: int | None = None) -> bytes | None:
        """Answers one whole frame at once, when going over the wire would change nothing.

        That is when no fault is injected and pacing is off, the frame is sent at the robot's
        own rate, the robot has booted, and no byte is under way either way nor any partial
        frame waiting. The frame is then received and carried out, and its reply taken,
        exactly as :meth:`receive` and :meth:`read_ready` would: same clock, same log, same
        reply, with no bytes queued in between.

        Args:
            frame: One command frame, ending with its newline.
            baud: The rate the other end sends at; None means the robot's own rate.

        Returns:
            The reply bytes, or None when the wire could make a difference: send the frame
            with :meth:`receive` then.
        """
        with self._lock:
            now = self._advance()  # delivers what is due first, as receive does
            if (
                self.faults.active
                or (baud is not None and baud != self.baud)
                or self._inbox or self._outbox or not self.firmware.idle
                or len(frame) != FRAME_LENGTH or frame.find(NEWLINE) != FRAME_LENGTH - 1
            ):  # fmt: skip
                return None
            if now < self.boot_s:
                return None
            return self._carry_out(bytes(frame), now)

    def discard_ready(self) -> int:
        """Drops every reply byte that has arrived; returns how many."""
        with self._lock:
            return len(self.read_ready())

    def _carry_out(self, frame: bytes, due: float) -> bytes:
        """Has the firmware carry out ``frame`` received at ``due``, logs it; returns the reply."""
        command, reply = self.firmware.execute(frame)
        self.log.append(Exchange(due, frame, command, reply, command is not None and reply != NO))
        return reply

    def _answer(self, frame: bytes, due: float) -> None:
        faults = self.faults
        if faults.no and self._rng.random() < faults.no:
            reply = NO
            self.log.append(Exchange(due, frame, None, NO, False))
        else:
            reply = self._carry_out(frame, due)
        when = due
        if faults.delay and self._rng.random() < faults.delay:
            when += faults.delay_s
        self._send(self._damage(reply), when)
        if faults.garbage and self._rng.random() < faults.garbage:
            noise = bytes(self._rng.randrange(256) for _ in range(self._rng.randint(1, 4)))
            self._send(noise, when + self._rng.uniform(0.0, 0.05))

    def _send(self, data: bytes, when: float) -> None:
        if not data:
            return
        byte_s = self.byte_time_s()
        if not byte_s:
            self._outbox.append((when, data))
        else:
            data = data[: max(0, WIRE_BUFFER_BYTES - len(self._outbox))]  # a reader that never reads: lost
            start = max(when, self._out_free_s)
            for i, byte in enumerate(data):
                self._outbox.append((start + (i + 1) * byte_s, bytes([byte])))
            self._out_free_s = start + len(data) * byte_s
        if len(self._outbox) > 1 and self._outbox[-1][0] < self._outbox[-2][0]:
            self._outbox = deque(sorted(self._outbox, key=lambda item: item[0]))

    def _damage(self, data: bytes) -> bytes:
        faults = self.faults
        if not (faults.drop or faults.corrupt):
            return data
        out = bytearray()
        for byte in data:
            if faults.drop and self._rng.random() < faults.drop:
                continue
            if faults.corrupt and self._rng.random() < faults.corrupt:
                byte ^= self._rng.randrange(1, 256)
            out.append(byte)
        return bytes(out)

    # ------------------------------------------------------------------ conveniences

    def pose(self) -> Pose:
        """Where the robot truly is now (the emulator's own state, caught up with the clock)."""
        with self._lock:
            self._advance()
            return self.robot.pose

    def commands(self) -> list[Command]:
        """The commands received and carried out, in order."""
        with self._lock:
            return [e.command for e in self.log if e.executed and e.command is not None]

    def set_auto_mode(self, auto: bool) -> None:
        """Switches between auto mode and manual mode (the handheld remote took over)."""
        with self._lock:
            self.advance()
            self.robot.auto_mode = auto
            if not auto:
                self.robot.halt()


#: Options an emu:// URL and ``autonomy emulator`` accept, with what each means.
OPTIONS = {
    "world": "arena: a shipped world's name or a world file's path (default box)",
    "seed": "seed for faults and sensor noise (default 0)",
    "faults": "fault spec, e.g. drop=0.01,pace (default none)",
    "time": "real or virtual (default real)",
    "baud": "the baud rate the emulated robot is set to (default 57600)",
    "battery": "battery level at start, 0..255 (default 230)",
    "noise": "front sensor noise, standard deviation in mm (default 0)",
    "profile": "a robot profile (YAML): the robot's own settings, as autonomy calibrate fits them (default none)",
    "mode": "auto or manual (default auto)",
    "boot": "seconds the robot ignores input after start, like a board that resets on open (default 0)",
}


def emulator_from_options(options: dict[str, str], clock: Clock | None = None) -> Emulator:
    """Builds an emulator from string options (an emu:// query or the CLI).

    Raises:
        ValueError: an unknown option or a value that cannot be used; the message says which.
        WorldError: the world, or the robot profile, cannot be found or read (:class:`ProfileInvalid`).
    """
    unknown = set(options) - set(OPTIONS)
    if unknown:
        raise ValueError(f"unknown emulator option '{sorted(unknown)[0]}': use {', '.join(OPTIONS)}")

    def number(key: str, kind: type, default: float, low: float = -math.inf, high: float = math.inf) -> Any:
        try:
            value = kind(options.get(key, default))
        except ValueError:
            raise ValueError(f"emulator option {key} must be a number, got '{options[key]}'") from None
        if not (math.isfinite(value) and low <= value <= high):
            raise ValueError(f"emulator option {key} must be from {low:g} to {high:g}, got '{options[key]}'")
        return value

    params = RobotParams()
    if options.get("profile"):  # the robot's own settings; battery and noise, when given, say otherwise
        params = load_profile(options["profile"]).params
    if "battery" in options:
        params = replace(params, battery_start=number("battery", float, 230, 0, 255))
    if "noise" in options:
        params = replace(params, sensor_noise_mm=number("noise", float, 0, 0, 100))
    time_mode = options.get("time", "real")
    if time_mode not in ("real", "virtual"):
        raise ValueError(f"emulator option time must be real or virtual, got '{time_mode}'")
    if clock is None and time_mode == "virtual":
        clock = VirtualClock()
    emulator = Emulator(
        options.get("world", "box"),
        params=params,
        faults=options.get("faults", ""),
        seed=number("seed", int, 0),
        clock=clock,
        baud=number("baud", int, DEFAULT_EMULATOR_BAUD),
        boot_s=number("boot", float, 0.0, 0, 60),
    )
    mode = options.get("mode", "auto")
    if mode not in ("auto", "manual"):
        raise ValueError(f"emulator option mode must be auto or manual, got '{mode}'")
    emulator.robot.auto_mode = mode == "auto"
    return emulator

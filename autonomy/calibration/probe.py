"""The probe: a short, safe routine that drives a robot and records what it does, for a fit.

The robot stands facing a wall, its front a measured distance from it (a metre, by default),
with nothing else in that metre. The probe:

1. checks that the robot is upright, in auto mode, not in a collision, and that its front
   sensor sees nothing within its reach;
2. turns in place, 90 degrees left, 180 right and 90 left, back to where it faced;
3. drives forward and back again at each speed setting, 150 to 300 mm, by the odometer;
4. drives at speed 2 straight at the wall until the sensor (or, if the sensor does not see it,
   the odometer) puts it 100 mm away, stands still there for a moment, and drives back.

It reads the status packet every 10 ms throughout. It stops the robot at once, and says why, on
a collision, a tilt of more than 30 degrees, a fall, something ahead that is not the wall, a
robot that does not move when told to, or if it has taken 2 minutes. It needs at most the
measured distance and the robot's own length of floor: 1.2 m from a metre.
"""

from __future__ import annotations

from collections.abc import Callable

from autonomy.calibration.recording import Recording, Sample, Sent, Unwrapper
from autonomy.client import Client
from autonomy.errors import AutonomyError, CommandRefused
from autonomy.protocol import Status, heading_delta_deg

#: What the front sensor reads when it sees nothing (PROTOCOL.md: 255, nothing closer).
NOTHING_MM = 255
#: How often the status is read, seconds.
POLL_S = 0.01
#: A tilt past this, degrees, is a robot falling: the probe stops it.
TILT_LIMIT_DEG = 30.0
#: The approach ends this far from the wall, mm.
STOP_GAP_MM = 100.0
#: Something the sensor sees this much nearer than the wall should be is not the wall, mm.
NOT_THE_WALL_MM = 150.0
#: How long the robot stands still between tests, and at the wall, seconds.
SETTLE_S = 0.4
STILL_AT_WALL_S = 0.6
#: The longest the probe may take, seconds.
MOST_S = 120.0
#: A robot told to move that has moved less than this, mm, after this long, s, is blocked.
BLOCKED_MM, BLOCKED_S = 5.0, 1.0
#: The turns made, degrees (left positive): they come back to where the robot faced.
TURNS_DEG = (90, -180, 90)
#: How far each speed setting drives forward (and back), mm.
DRIVE_MM = {1: 150.0, 2: 200.0, 3: 250.0, 4: 300.0}
#: The distances to the wall a probe takes, mm: enough for its drives, no more than a metre and a bit.
WALL_MM = (600.0, 1100.0)
#: How far a drive rolls on after a stop, as a share of the default model's braking distance (a margin).
BRAKING_MARGIN = 1.0


class ProbeStopped(AutonomyError):
    """The probe stopped the robot before it was done; the message says why and what to do."""


class ProbeRefused(AutonomyError):
    """The robot is not ready for a probe (before it moved at all); the message says why."""


class Probe:
    """Drives the routine on ``client`` and records it.

    Args:
        client: The robot, open.
        wall_mm: The measured distance from the robot's front to the wall it faces.
        say: Where a line about each step goes.
    """

    def __init__(self, client: Client, wall_mm: float = 1000.0, say: Callable[[str], None] = lambda _: None) -> None:
        if not WALL_MM[0] <= wall_mm <= WALL_MM[1]:
            raise ProbeRefused(
                f"the wall must be {WALL_MM[0]:.0f} to {WALL_MM[1]:.0f} mm from the robot's front, got {wall_mm:g}"
            )
        self.client = client
        self.clock = client.clock
        self.wall_mm = wall_mm
        self.say = say
        self.recording = Recording(f"probe of {client.name}")
        self._unwrap = Unwrapper()
        self._start_s = 0.0
        self._start_heading = 0
        self._facing_wall = False
        self._last: Status | None = None

    # ------------------------------------------------------------------ reading

    def sample(self) -> Status:
        """Reads the status, records it, and stops the robot if it is in trouble.

        Raises:
            ProbeStopped: a collision, a tilt or fall, or the probe's time is up.
        """
        before = self.clock.now()
        status = self.client.status()
        when = (before + self.clock.now()) / 2.0
        odometer = self._unwrap(status.odometer_mm)
        gap = self.wall_mm - odometer if self._facing_wall else None
        self.recording.samples.append(
            Sample(when, status.heading_deg, odometer, status.front_distance_mm, status.moving, gap)
        )
        self._last = status
        if status.collided:
            self._halt(
                f"the robot hit something {odometer:.0f} mm from where it started: the probe needs the floor "
                "clear between the robot and the wall"
            )
        if abs(status.tilt_deg) > TILT_LIMIT_DEG or status.mode == 3:
            self._halt(f"the robot tilted {status.tilt_deg} degrees: stand it up on a flat floor and start again")
        if when - self._start_s > MOST_S:
            self._halt(f"the probe took more than {MOST_S:.0f} s: is the robot's link too slow?")
        return status

    def _halt(self, why: str) -> None:
        self.client.safe_stop()
        raise ProbeStopped(why)

    def _send(self, kind: str, value: int = 0) -> None:
        when = self.clock.now()
        try:
            if kind == "move":
                self.client.move(abs(value), backward=value < 0)
            elif kind == "turn":
                self.client.turn(value)
            else:
                self.client.stop()
        except CommandRefused:
            told = {"move": f"to drive at speed {abs(value)}", "turn": f"to turn {value} degrees"}.get(kind, "to stop")
            self._halt(f"the robot refused {told} (it answered NO): is its battery low, or its remote in charge?")
        self.recording.sent.append(Sent(when, kind, value))

    def _wait(self, seconds: float) -> Status:
        """Reads the status every :data:`POLL_S` for ``seconds``; the last one read."""
        end = self.clock.now() + seconds
        status = self.sample()
        while self.clock.now() < end:
            self.clock.sleep(POLL_S)
            status = self.sample()
        return status

    def _until_still(self, most_s: float, what: str) -> Status:
        """Reads the status until the robot has not moved for :data:`SETTLE_S`."""
        start = self.clock.now()
        still_since = None
        while True:
            status = self.sample()
            now = self.clock.now()
            if status.moving:
                still_since = None
            elif still_since is None:
                still_since = now
            elif now - still_since >= SETTLE_S:
                return status
            if now - start > most_s:
                self._halt(f"the robot did not come to rest after {what} within {most_s:.0f} s")
            self.clock.sleep(POLL_S)

    # ------------------------------------------------------------------ the routine

    def run(self) -> Recording:
        """The whole routine; the robot stands still at the end, where it began, facing the wall.

        Raises:
            ProbeRefused: the robot is not ready (nothing moved).
            ProbeStopped: the probe stopped the robot part way; the message says why.
        """
        self._start_s = self.clock.now()
        self._check()
        self._turns()
        self._facing_wall = True
        for setting in (1, 2, 3, 4):
            self._there_and_back(setting)
        self._approach()
        return self.recording

    def _check(self) -> None:
        status = self.client.status()
        if status.collided:
            raise ProbeRefused("the robot's collision flag is set: move it clear of everything and start again")
        if abs(status.tilt_deg) > TILT_LIMIT_DEG or status.mode == 3:
            raise ProbeRefused(f"the robot is not upright (tilt {status.tilt_deg} degrees): stand it up first")
        if not status.auto_mode:
            raise ProbeRefused("the robot is in manual mode (its remote has it): switch it to auto mode")
        if status.moving:
            raise ProbeRefused("the robot is moving: let it stand still first")
        # nothing within the sensor's reach: it reads "nothing closer", twice of three times (a reading spoilt on a
        # noisy link is not something ahead; something there is read each time)
        readings = sorted([status.front_distance_mm, *(self.client.status().front_distance_mm for _ in range(2))])
        seen = readings[1]
        if seen < NOTHING_MM:
            raise ProbeRefused(
                f"the front sensor sees something {seen} mm ahead: the probe needs the {self.wall_mm:.0f} mm "
                "between the robot and the wall clear"
            )
        self.recording.sensor_max_mm = NOTHING_MM
        self.say(
            f"the robot is ready: upright, in auto mode, nothing within {status.front_distance_mm} mm ahead; "
            f"the wall is {self.wall_mm:.0f} mm away, as told"
        )
        self.sample()
        self._start_heading = status.heading_deg

    def _turns(self) -> None:
        self.say("turning in place: 90 degrees left, 180 right, 90 left")
        for angle in TURNS_DEG:
            start = self.sample().heading_deg
            self._send("turn", angle)
            self._wait(0.2)
            status = self._until_still(abs(angle) / 5.0 + 5.0, f"a turn of {angle} degrees")
            if abs(heading_delta_deg(start, status.heading_deg)) < abs(angle) / 4:
                self._halt(
                    f"the robot did not turn (told {angle} degrees): is it blocked, or its wheels off the floor?"
                )
        status = self.sample()
        error = heading_delta_deg(status.heading_deg, self._start_heading)
        if abs(error) >= 2:  # back to facing the wall, so that the approach drives straight at it
            self._send("turn", error)
            self._wait(0.2)
            self._until_still(10.0, "turning back to the wall")

    def _drive(self, setting: int, distance_mm: float, backward: bool, until: Callable[[Status, float], bool]) -> None:
        """Drives at ``setting`` until ``distance_mm`` is covered (by the odometer) or ``until`` says so, then stops."""
        status = self.sample()
        start = self._unwrap.total_mm
        sign = -1.0 if backward else 1.0
        braking = BRAKING_MARGIN * (setting * 107.0) ** 2 / (2 * 1500.0)
        self._send("move", -setting if backward else setting)
        sent = self.clock.now()
        while True:
            self.clock.sleep(POLL_S)
            status = self.sample()
            moved = sign * (self._unwrap.total_mm - start)
            if moved >= distance_mm - braking or until(status, moved):
                break
            if self.clock.now() - sent > BLOCKED_S and moved < BLOCKED_MM:
                self._halt(
                    f"the robot did not move at speed {setting} ({moved:.0f} mm in {BLOCKED_S:g} s): is it blocked, "
                    "its wheels off the floor, or its battery low?"
                )
            if self.clock.now() - sent > 4.0 * distance_mm / 50.0 + 5.0:
                self._halt(f"the robot drove on for too long at speed {setting}: is its odometer working?")
        self._send("stop")
        self._until_still(5.0, f"a stop from speed {setting}")

    def _there_and_back(self, setting: int) -> None:
        distance = DRIVE_MM[setting]
        self.say(f"speed {setting}: {distance:.0f} mm forward and back")

        def nothing_ahead(status: Status, _moved: float) -> bool:
            if status.front_distance_mm < self.recording.sensor_max_mm:
                self._halt(
                    f"something came {status.front_distance_mm} mm ahead of the robot: the probe needs "
                    f"the {self.wall_mm:.0f} mm to the wall clear"
                )
            return False

        self._drive(setting, distance, False, nothing_ahead)
        self._drive(setting, distance, True, lambda _s, _m: False)

    def _approach(self) -> None:
        self.say(f"speed 2 towards the wall, to {STOP_GAP_MM:.0f} mm from it, and back")
        start = self._unwrap.total_mm

        def near(status: Status, _moved: float) -> bool:
            gap = self.wall_mm - self._unwrap.total_mm
            reading = status.front_distance_mm
            if reading < self.recording.sensor_max_mm and reading < gap - NOT_THE_WALL_MM:
                self._halt(
                    f"the sensor sees something {reading} mm ahead, where the wall should be {gap:.0f} mm away: "
                    f"is the wall {self.wall_mm:.0f} mm from the robot's front, and the floor clear?"
                )
            return reading <= STOP_GAP_MM or gap <= STOP_GAP_MM

        self._drive(2, self.wall_mm - start, False, near)
        self._wait(STILL_AT_WALL_S)
        back = self._unwrap.total_mm - start
        self._drive(3, back, True, lambda _s, _m: False)

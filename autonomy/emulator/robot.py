"""The emulated robot's physics: wheels, turning, servos, sensor, tilt, battery, collisions.

No bytes and no clock here: :meth:`Robot.advance_to` is handed simulated time and steps the
model in fixed steps, so a run depends only on when commands arrived, not on how often
somebody looked (to within rounding: a steady drive's steps are taken several at once, and
positions agree to within a millionth of a millimetre however the time is split). Every
constant is a field of :class:`RobotParams`, documented in docs/emulator.md.
"""

from __future__ import annotations

import math
import random
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from autonomy.emulator.script import SensorScript
from autonomy.emulator.world import EPSILON_MM, ROBOT_RADIUS_MM, SENSOR_CONE_DEG, Pose, World

MODE_IDLE = 0
MODE_MOVING = 1
MODE_TURNING = 2
MODE_FALLEN = 3
GRAVITY_MM_S2 = 9810.0
#: How far inside the clearance a cruise's steps go unchecked: far more than the rounding of their sums.
CRUISE_MARGIN_MM = 0.001
#: Two places closer than this (each way) are one place to the robot's trail, mm: far less than a step
#: at the slowest speed, far more than the rounding of a position (which differs in the last digits
#: between a drive taken a step at a time and one taken at once).
SAME_PLACE_MM = 1e-6
#: How far past the time stepped to a step may end and still be taken, a share of the step. The robot's
#: time is a sum of steps, and that sum drifts from the clock's time by its rounding: 5 ms steps are
#: 2e-12 s short of the clock after 13 s, and would leave the robot a whole step behind it from there on
#: (its status 5 ms old, its commands acted on 5 ms early). A thousandth of a step is far more than an
#: hour of that drift, and far less than anything a clock tells apart.
STEP_SLACK = 1e-3


@dataclass(frozen=True)
class RobotParams:
    """The emulator's settings. None of these are protocol facts; all are documented defaults."""

    #: Wheel diameter; one revolution moves the robot ``pi * wheel_diameter_mm``.
    wheel_diameter_mm: float = 68.0
    #: Wheel velocity of speed settings 1..4, in the ``V`` units (20 = one revolution per second); a
    #: calibrated robot's are fractions.
    speed_setting_v: tuple[float, float, float, float] = (10, 20, 30, 40)
    #: How fast the robot speeds up and slows down.
    acceleration_mm_s2: float = 1500.0
    #: Turn-in-place rate.
    turn_rate_deg_s: float = 90.0
    #: How long after a motion command (move, turn, stop) the motors act on it.
    command_delay_s: float = 0.0
    #: Radius of the robot's footprint (a circle) used for collisions.
    body_radius_mm: float = ROBOT_RADIUS_MM
    #: Servo slew rate.
    servo_speed_deg_s: float = 120.0
    #: Largest distance the front sensor reports; anything further reads this.
    sensor_max_mm: int = 255
    #: The front sensor's field of view, degrees across (0: a single ray along the heading).
    sensor_cone_deg: float = SENSOR_CONE_DEG
    #: Standard deviation of the sensor's noise (0: exact, rounded to whole mm).
    sensor_noise_mm: float = 0.0
    #: The sensor reads ``sensor_scale`` times the true distance plus ``sensor_offset_mm`` (then its noise).
    sensor_scale: float = 1.0
    sensor_offset_mm: float = 0.0
    #: Battery level at power-on, 0..255.
    battery_start: float = 230.0
    #: Battery drain while idle and the extra drain while driving or turning, in levels per second.
    battery_idle_drain_per_s: float = 0.02
    battery_motion_drain_per_s: float = 0.1
    #: Below this battery level ``GR`` answers ``NO``.
    battery_unhealthy_below: float = 40.0
    #: Below this battery level motion commands are refused.
    battery_cutoff_below: float = 10.0
    #: How long the collision flag stays set after an impact.
    collision_hold_s: float = 0.5
    #: Sudden forward pitch (degrees) per mm/s of speed lost in an impact.
    impact_tilt_deg_per_mm_s: float = 0.04
    #: How quickly the tilt follows its target (first-order time constant).
    tilt_time_constant_s: float = 0.15
    #: Physics step.
    step_s: float = 0.005
    #: What ``GF`` answers.
    firmware_version: str = "E10"

    @property
    def wheel_circumference_mm(self) -> float:
        """Distance one wheel revolution moves the robot."""
        return math.pi * self.wheel_diameter_mm

    def speed_mm_s(self, setting: int) -> float:
        """Ground speed of speed setting 1..4."""
        return self.speed_setting_v[setting - 1] / 20.0 * self.wheel_circumference_mm


@dataclass
class Impact:
    """One collision: when, where, and how fast the robot was going."""

    time_s: float
    pose: Pose
    speed_mm_s: float


@dataclass
class Robot:
    """The robot's state and its physics.

    Args:
        world: The arena it drives in.
        params: Its settings.
        seed: Seeds the sensor noise.
    """

    world: World
    params: RobotParams = field(default_factory=RobotParams)
    seed: int = 0

    def __post_init__(self) -> None:
        start = self.world.start_pose(self.seed)
        self.x_mm, self.y_mm, self.heading_deg = start.x_mm, start.y_mm, start.heading_deg
        self.time_s = 0.0
        self.speed_mm_s = 0.0  # signed, forward positive
        self.target_speed_mm_s = 0.0
        self.turn_remaining_deg = 0.0  # signed, left positive
        self.odometer_mm = 0.0
        self.tilt_deg = 0.0
        self.battery = self.params.battery_start
        self.servo_deg = [0.0, 0.0, 0.0]
        self.servo_target_deg = [0.0, 0.0, 0.0]
        self.auto_mode = True
        self.fallen = False
        self.collided_until_s = -math.inf
        #: What the sensors report whatever the world holds (None: what it holds), from ``script_from_s`` on.
        self.script: SensorScript | None = None
        self.script_from_s = 0.0
        self.impacts: list[Impact] = []
        self.beeps: list[tuple[float, tuple[int, int, int], int]] = []
        #: Each servo command carried out: (time_s, servo id, the angle it was sent to, degrees).
        self.servo_moves: list[tuple[float, int, float]] = []
        #: Where the robot was at each beep, in the order of :attr:`beeps`.
        self.beep_poses: list[Pose] = []
        #: Whether it was driving or turning at each beep (braking to a stop is not), as :attr:`beeps`.
        self.beep_moving: list[bool] = []
        #: Each time it stood still until a command set it going again: (from_s, to_s, where).
        self.stills: list[tuple[float, float, Pose]] = []
        #: The robot's own record of where it went: (time_s, pose) at the start and whenever its motion
        #: changed (a command, an impact, the end of a drive). Between two of them it drove straight
        #: along its heading, or turned where it stood, so the segments between them are its path,
        #: whatever read it how often. One straight drive is kept as its two ends, and a stay in one
        #: place as two points (when it came and when it left, its turns there between them).
        self.trail: list[tuple[float, Pose]] = [(0.0, start)]
        #: The last time the wheels turned or the robot turned in place, simulated seconds.
        self.moved_s = 0.0
        self._accel_mm_s2 = 0.0
        #: Motion commands received and not yet acted on (``command_delay_s``): (due_s, action, its arguments).
        self._pending: deque[tuple[float, Callable[..., None], tuple[Any, ...]]] = deque()
        self._rng = random.Random(self.seed)
        # Where the clearance was last measured, and how far the body could move from there
        # before touching anything: steps that stay inside that bound need no new measurement.
        self._free_at: tuple[float, float, float] = (self.x_mm, self.y_mm, -math.inf)
        # The last sensor reading's pose and its gap: a robot that has not moved sees the same.
        self._seen: tuple[float, float, float, float, float] = (math.nan, math.nan, math.nan, math.nan, 0.0)

    def place(self, pose: Pose) -> None:
        """Puts the robot, standing, at ``pose`` instead of its world's start (before a run: its trail starts there)."""
        self.x_mm, self.y_mm, self.heading_deg = pose.x_mm, pose.y_mm, pose.heading_deg
        self.trail = [(self.time_s, self.pose)]
        self._free_at = (self.x_mm, self.y_mm, -math.inf)
        self._seen = (math.nan, math.nan, math.nan, math.nan, 0.0)

    # ------------------------------------------------------------------ readings

    @property
    def pose(self) -> Pose:
        """Where the robot is now."""
        return Pose(self.x_mm, self.y_mm, self.heading_deg)

    @property
    def mode(self) -> int:
        """0 idle, 1 moving at a fixed velocity, 2 turning, 3 fallen."""
        if self.fallen:
            return MODE_FALLEN
        if self.turn_remaining_deg:
            return MODE_TURNING
        if self.target_speed_mm_s:
            return MODE_MOVING
        return MODE_IDLE

    @property
    def moving(self) -> bool:
        """True while the wheels turn or the robot turns in place."""
        return bool(self.speed_mm_s or self.turn_remaining_deg)

    @property
    def collided(self) -> bool:
        """The collision flag: set on impact (or a scripted bump) and held ``collision_hold_s``."""
        if self.time_s < self.collided_until_s:
            return True
        script = self.script
        return script is not None and script.bumped_at(self.script_time_s, self.params.collision_hold_s, self.pose)

    @property
    def reported_tilt_deg(self) -> float:
        """The tilt the robot reports: its own, or the script's."""
        script = self.script
        scripted = script.tilt_at(self.script_time_s, self.pose) if script is not None else None
        return self.tilt_deg if scripted is None else float(scripted)

    @property
    def healthy(self) -> bool:
        """What ``GR`` reports: not fallen and the battery above its health level."""
        return not self.fallen and self.battery >= self.params.battery_unhealthy_below

    @property
    def can_move(self) -> bool:
        """Whether motion commands (F T M D) are accepted."""
        return self.auto_mode and not self.fallen and self.battery >= self.params.battery_cutoff_below

    def true_front_gap_mm(self, reach_mm: float = math.inf) -> float:
        """Distance from the robot's front edge to the nearest obstacle in the sensor's cone.

        The sensor sits on the front edge and sees a cone ``sensor_cone_deg`` across about the
        heading (:meth:`World.cone_distance`), so a wall met at a shallow angle is seen too.

        Args:
            reach_mm: Distances this long or longer come back as infinity (faster to find).
        """
        x, y, heading, reach, gap = self._seen
        if (x, y, heading, reach) == (self.x_mm, self.y_mm, self.heading_deg, reach_mm):
            return gap
        radius = self.params.body_radius_mm
        rad = math.radians(self.heading_deg)
        sx, sy = self.x_mm + radius * math.cos(rad), self.y_mm + radius * math.sin(rad)
        gap = self.world.cone_distance(sx, sy, self.heading_deg, self.params.sensor_cone_deg, reach_mm=reach_mm)
        self._seen = (self.x_mm, self.y_mm, self.heading_deg, reach_mm, gap)
        return gap

    def front_distance_mm(self) -> int:
        """The front sensor's reading, 0..``sensor_max_mm`` (the script's, when it says one)."""
        if self.script is not None:
            scripted = self.script.front_at(self.script_time_s, self.pose)
            if scripted is not None:
                return scripted
        p = self.params
        # beyond its range plus ten standard deviations of noise, nothing can read below the range
        scale = p.sensor_scale
        reach = (p.sensor_max_mm - p.sensor_offset_mm + 10 * p.sensor_noise_mm) / scale + 1
        gap = self.true_front_gap_mm(reach) * scale + p.sensor_offset_mm
        if p.sensor_noise_mm:
            gap += self._rng.gauss(0.0, p.sensor_noise_mm)
        if gap >= p.sensor_max_mm:
            return p.sensor_max_mm
        reading = round(gap)
        return reading if reading > 0 else 0

    def velocity_v(self) -> int:
        """Average wheel velocity in ``V`` units (20 = one revolution per second), -99..99."""
        v = round(self.speed_mm_s / self.params.wheel_circumference_mm * 20.0)
        return max(-99, min(99, v))

    # ------------------------------------------------------------------ commands

    def move(self, setting: int, backward: bool = False) -> None:
        """Drives at speed setting 1..4; replaces a turn in progress (``command_delay_s`` from now)."""
        self._command(self._move, setting, backward)

    def turn(self, angle_deg: float) -> None:
        """Turns in place by ``angle_deg`` (left positive), replacing a move, ``command_delay_s`` from now."""
        self._command(self._turn, angle_deg)

    def stop(self) -> None:
        """Cancels every movement (``command_delay_s`` from now); the wheels slow down at the acceleration limit."""
        self._command(self._stop)

    def halt(self) -> None:
        """Cancels every movement at once, and the commands not yet acted on (the remote took over, a fall)."""
        self._pending.clear()
        self._stop()

    def _command(self, action: Callable[..., None], *args: Any) -> None:
        """Acts on a motion command now, or ``command_delay_s`` from now, after those received before it."""
        delay_s = self.params.command_delay_s
        if delay_s > 0.0:
            self._pending.append((self.time_s + delay_s, action, args))
        else:
            action(*args)

    def _move(self, setting: int, backward: bool = False) -> None:
        self._leave_rest()
        self._mark()
        self.turn_remaining_deg = 0.0
        speed = self.params.speed_mm_s(setting)
        self.target_speed_mm_s = -speed if backward else speed

    def _turn(self, angle_deg: float) -> None:
        self._leave_rest()
        self._mark()
        self.target_speed_mm_s = 0.0
        self.speed_mm_s = 0.0
        self.turn_remaining_deg = float(angle_deg)

    def _stop(self) -> None:
        self._mark()
        self.target_speed_mm_s = 0.0
        self.turn_remaining_deg = 0.0

    @property
    def script_time_s(self) -> float:
        """The time as the sensor script counts it: seconds since it was set."""
        return self.time_s - self.script_from_s

    def servo_to(self, servo_id: int, angle_deg: float) -> None:
        """Sends servo ``servo_id`` towards an absolute angle (kept in :attr:`servo_moves`)."""
        self.servo_target_deg[servo_id] = max(-99.0, min(99.0, float(angle_deg)))
        self.servo_moves.append((self.time_s, servo_id, self.servo_target_deg[servo_id]))

    def servo_by(self, servo_id: int, delta_deg: float) -> None:
        """Sends servo ``servo_id`` ``delta_deg`` from where it is now."""
        self.servo_to(servo_id, self.servo_deg[servo_id] + delta_deg)

    def beep(self, tones: tuple[int, int, int], volume: int) -> None:
        """Records a beep, and where the robot was."""
        self.beeps.append((self.time_s, tones, volume))
        self.beep_poses.append(self.pose)
        self.beep_moving.append(bool(self.target_speed_mm_s or self.turn_remaining_deg))

    def _leave_rest(self) -> None:
        """Notes the time the robot stood still until now, if it did: a command may set it going."""
        if not (self.speed_mm_s or self.target_speed_mm_s or self.turn_remaining_deg):
            still = (self.moved_s, self.time_s, self.pose)
            if self.stills and self.stills[-1][0] == self.moved_s:  # a turn of 0 degrees set nothing going
                self.stills[-1] = still
            else:
                self.stills.append(still)

    def _mark(self) -> None:
        """Adds where the robot is now to :attr:`trail`, as its motion is about to change.

        A point on the straight line the last two run along, in the same direction, replaces the
        last (the drive goes on). Where the robot stands, the trail keeps two points: when it got
        there and when it last was told anything there (a turn in place between them, or a pause),
        so that the times along the path stay right.
        """
        trail = self.trail
        x, y, heading = self.x_mm, self.y_mm, self.heading_deg
        point = (self.time_s, Pose(x, y, heading))
        _, last = trail[-1]
        if abs(last.x_mm - x) <= SAME_PLACE_MM and abs(last.y_mm - y) <= SAME_PLACE_MM:
            _, before = trail[-2] if len(trail) > 1 else (0.0, None)
            if before is not None and abs(before.x_mm - x) <= SAME_PLACE_MM and abs(before.y_mm - y) <= SAME_PLACE_MM:
                trail[-1] = point  # arrived before: this is the latest moment there
            elif len(trail) > 1 or last.heading_deg != heading:
                trail.append(point)
            return
        if len(trail) >= 2:
            _, before = trail[-2]
            same_line = before.heading_deg == last.heading_deg == heading
            onward = (last.x_mm - before.x_mm) * (x - last.x_mm) + (last.y_mm - before.y_mm) * (y - last.y_mm) > 0.0
            if same_line and onward:
                trail[-1] = point
                return
        trail.append(point)

    def knock_over(self) -> None:
        """The robot falls: everything stops, motion is refused until :meth:`stand_up`."""
        self.halt()  # marks the trail
        self.speed_mm_s = 0.0
        self.fallen = True
        self.tilt_deg = 90.0

    def stand_up(self) -> None:
        """Puts a fallen robot back on its wheels."""
        self.fallen = False
        self.tilt_deg = 0.0

    # ------------------------------------------------------------------ physics

    def advance_to(self, time_s: float) -> None:
        """Steps the model in fixed steps up to ``time_s`` (never backward), acting on delayed commands when due."""
        pending = self._pending
        while pending and pending[0][0] <= time_s:
            due_s, action, args = pending.popleft()
            self._advance_steps(due_s)
            action(*args)
        self._advance_steps(time_s)

    def _advance_steps(self, time_s: float) -> None:
        step = self.params.step_s
        while self.time_s + step <= time_s + step * STEP_SLACK:
            if not (self._cruise(step, time_s) if self.speed_mm_s else self._stand(step, time_s)):
                self._step(step)

    def _cruise(self, dt: float, until_s: float) -> int:
        """Takes the steps of a straight drive at a steady speed, as :meth:`_step` takes them, faster.

        While the robot drives straight at its target speed, upright, with its servos at rest and
        with room ahead (the clearance measured last still covers the step), a step only moves it
        along its heading, lets the tilt settle and drains the battery. The steps well inside the
        clearance are counted one by one (the time is :meth:`_step`'s own, number for number) and
        taken at once: n steps' distance, tilt and charge in one go, which is :meth:`_step`'s
        result to within rounding (a millionth of a millimetre), not number for number. Near the
        edge of the clearance each step is checked and taken as :meth:`_step` takes it. It stops
        before the first step that is anything else, which :meth:`_step` takes.

        Returns:
            How many steps it took.
        """
        speed = self.speed_mm_s
        if (
            not speed
            or speed != self.target_speed_mm_s
            or self.turn_remaining_deg  # pragma: no mutate - a turn zeroes the speed today; kept should that change
            or self.fallen
            or self.servo_deg != self.servo_target_deg
        ):
            return 0
        p = self.params
        distance_mm = speed * dt
        rad = math.radians(self.heading_deg)
        dx, dy = math.cos(rad), math.sin(rad)
        free_x, free_y, free_mm = self._free_at
        settle = dt / p.tilt_time_constant_s
        if not settle < 1.0:  # min(1.0, settle): in the loops of the physics, a call costs more than the step
            settle = 1.0
        drain = p.battery_idle_drain_per_s + p.battery_motion_drain_per_s
        time_s, x, y, odometer, tilt, battery = (
            self.time_s, self.x_mm, self.y_mm, self.odometer_mm, self.tilt_deg, self.battery
        )  # fmt: skip
        # Worked out once, the same numbers each step: the step along each axis, the charge, the end.
        step_x, step_y, used, end_s = dx * distance_mm, dy * distance_mm, drain * dt, until_s + dt * STEP_SLACK
        # A step cannot take the robot further from where the clearance was measured than the
        # distance driven: the first steps that stay well inside it need not be checked one by one.
        # (A NaN anywhere makes this NaN, and every step is checked.)
        unchecked = (free_mm - math.hypot(x - free_x, y - free_y) - CRUISE_MARGIN_MM) / abs(distance_mm) - 1.0
        steps = 0
        while steps < unchecked and time_s + dt <= end_s:  # counted one by one, so that the time is _step's own
            time_s += dt
            steps += 1
        if steps:  # equal steps, taken at once
            x += steps * step_x
            y += steps * step_y
            odometer += steps * distance_mm
            if tilt != 0.0:
                tilt *= (1.0 - settle) ** steps
            battery -= steps * used
            if not battery > 0.0:  # max(0.0, battery) without the call, NaN included
                battery = 0.0
        while time_s + dt <= end_s:  # near the edge of the clearance: each step checked
            if not free_mm - math.hypot(x + step_x - free_x, y + step_y - free_y) > 0.0:
                break  # the clearance must be measured again: a step of its own
            time_s += dt
            x += step_x
            y += step_y
            odometer += distance_mm
            if tilt != 0.0:
                tilt = tilt + (0.0 - tilt) * settle
            battery -= used
            if not battery > 0.0:  # max(0.0, battery) without the call, NaN included
                battery = 0.0
            steps += 1
        if steps:
            self.time_s, self.x_mm, self.y_mm, self.odometer_mm, self.tilt_deg, self.battery = (
                time_s, x, y, odometer, tilt, battery
            )  # fmt: skip
            self._accel_mm_s2 = 0.0
            self.moved_s = time_s
        return steps

    def _stand(self, dt: float, until_s: float) -> int:
        """Takes the steps of a robot whose wheels stand still, turning in place or not, as :meth:`_step` takes them.

        While neither wheel speed nor its target is anything but zero, upright, with its servos at
        rest, a step only turns it (if it is turning), lets the tilt settle and drains the battery:
        worked out here with :meth:`_step`'s arithmetic in its order, so the state is the same
        number for number. It stops before the first step that is anything else.

        Returns:
            How many steps it took.
        """
        if self.speed_mm_s or self.target_speed_mm_s or self.fallen or self.servo_deg != self.servo_target_deg:
            return 0
        p = self.params
        most = p.turn_rate_deg_s * dt
        settle = dt / p.tilt_time_constant_s
        if not settle < 1.0:  # min(1.0, settle)
            settle = 1.0
        turning_used = (p.battery_idle_drain_per_s + p.battery_motion_drain_per_s) * dt
        standing_used = (p.battery_idle_drain_per_s + 0.0) * dt
        time_s, heading, turning, tilt, battery = (
            self.time_s, self.heading_deg, self.turn_remaining_deg, self.tilt_deg, self.battery
        )  # fmt: skip
        end_s = until_s + dt * STEP_SLACK
        steps = 0
        moved_s = self.moved_s
        while time_s + dt <= end_s:
            time_s += dt
            if turning:
                moved_s = time_s
                left = abs(turning)
                turn = math.copysign(most if most < left else left, turning)  # min(left, most)
                heading += turn
                turning -= turn
                if abs(turning) < 1e-9:
                    turning = 0.0
            if tilt != 0.0:
                tilt = tilt + (0.0 - tilt) * settle
            battery -= turning_used if turning else standing_used
            if not battery > 0.0:  # max(0.0, battery), NaN included
                battery = 0.0
            steps += 1
        if steps:
            self.time_s, self.heading_deg, self.turn_remaining_deg, self.tilt_deg, self.battery = (
                time_s, heading, turning, tilt, battery
            )  # fmt: skip
            self._accel_mm_s2 = 0.0
            self.moved_s = moved_s
        return steps

    def _step(self, dt: float) -> None:
        # Runs ten times per tick of a 20 Hz mission: attributes are read once, and the tilt is worked out here.
        p = self.params
        self.time_s += dt
        speed = previous_speed = self.speed_mm_s
        previous_heading = self.heading_deg
        turning = self.turn_remaining_deg
        if turning:
            most, left = p.turn_rate_deg_s * dt, abs(turning)
            turn = math.copysign(most if most < left else left, turning)  # min(left, most)
            self.heading_deg += turn
            turning -= turn
            if abs(turning) < 1e-9:
                turning = 0.0
            self.turn_remaining_deg = turning
        delta_v = self.target_speed_mm_s - speed
        if delta_v:
            max_dv = p.acceleration_mm_s2 * dt
            change = delta_v if delta_v < max_dv else max_dv  # max(-max_dv, min(max_dv, delta_v)), NaN included
            speed += change if change > -max_dv else -max_dv
            self.speed_mm_s = speed
        if self.heading_deg != previous_heading:
            self.moved_s = self.time_s
        if previous_speed > 0.0 >= speed or previous_speed < 0.0 <= speed:
            self._mark()  # stopped, or about to drive back: the end of a drive, where the trail must have it
        if speed:
            impacts = len(self.impacts)
            x_mm, y_mm = self.x_mm, self.y_mm
            self._drive(speed * dt)
            if abs(self.x_mm - x_mm) > SAME_PLACE_MM or abs(self.y_mm - y_mm) > SAME_PLACE_MM:  # not pushing on
                self.moved_s = self.time_s
            speed = self.speed_mm_s
            # An impact is not braking: the body pitches forward (the kick), it does not lean back.
            accel = 0.0 if len(self.impacts) > impacts else (speed - previous_speed) / dt
        else:
            accel = (speed - previous_speed) / dt
        self._accel_mm_s2 = accel
        if not self.fallen:
            # A balancing robot leans into its acceleration: atan(a / g).
            target = math.degrees(math.atan2(accel, GRAVITY_MM_S2)) if accel else 0.0
            tilt = self.tilt_deg
            if target != tilt:
                settle = dt / p.tilt_time_constant_s
                self.tilt_deg = tilt + (target - tilt) * (settle if settle < 1.0 else 1.0)  # min(1.0, settle)
        if self.servo_deg != self.servo_target_deg:
            for i in range(3):
                gap = self.servo_target_deg[i] - self.servo_deg[i]
                self.servo_deg[i] += max(-p.servo_speed_deg_s * dt, min(p.servo_speed_deg_s * dt, gap))
        drain = p.battery_idle_drain_per_s + (p.battery_motion_drain_per_s if speed or turning else 0.0)
        battery = self.battery - drain * dt
        self.battery = battery if battery > 0.0 else 0.0  # max(0.0, battery), NaN included, without the call

    def _drive(self, distance_mm: float) -> None:
        """Moves along the heading, stopping at the first contact."""
        rad = math.radians(self.heading_deg)
        dx, dy = math.cos(rad), math.sin(rad)
        radius = self.params.body_radius_mm
        x, y = self.x_mm + dx * distance_mm, self.y_mm + dy * distance_mm
        free_x, free_y, free_mm = self._free_at
        # Nothing can come nearer than the distance moved since the clearance was measured.
        fits = free_mm - math.hypot(x - free_x, y - free_y) > 0.0
        if not fits:
            clearance = self.world.clearance(x, y)
            fits = clearance >= radius - EPSILON_MM
            if fits:
                self._free_at = (x, y, clearance - radius)
        if fits:
            self.x_mm, self.y_mm = x, y
            self.odometer_mm += distance_mm
            return
        # Find how far it can go before touching (bisection on the fraction of the step).
        low, high = 0.0, 1.0
        for _ in range(30):
            mid = (low + high) / 2
            if self.world.circle_fits(self.x_mm + dx * distance_mm * mid, self.y_mm + dy * distance_mm * mid, radius):
                low = mid
            else:
                high = mid
        self.x_mm += dx * distance_mm * low
        self.y_mm += dy * distance_mm * low
        self.odometer_mm += distance_mm * low
        self._impact()

    def _impact(self) -> None:
        p = self.params
        speed = self.speed_mm_s
        self._mark()
        self.impacts.append(Impact(self.time_s, self.pose, abs(speed)))
        self.collided_until_s = self.time_s + p.collision_hold_s
        self.tilt_deg += speed * p.impact_tilt_deg_per_mm_s  # the body pitches on, the wheels stop
        self.speed_mm_s = 0.0
        self.target_speed_mm_s = 0.0

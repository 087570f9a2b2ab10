"""Scripted sensors: what the robot's sensors report at given times, whatever its world holds.

A mission's unit test needs a wall at 80 mm at 2.5 s, or a bump at 3 s, without building a world
where the robot would meet them then. A :class:`SensorScript` set on the emulator's robot makes
its front sensor, its collision flag and its tilt report what the script says from each time on
(the robot still drives in its world, and the judge still reads the world's own account: a
scripted bump is what the bumper says, not an impact). It can also make the robot refuse a kind of
command from a time on (answer ``NO``, as a robot in manual mode refuses motion): a beep, a move, a
turn or a servo; never a stop, so that a run's end still stops the robot. And what the sensors
report can depend on where the robot is instead (:class:`Area`): a wall seen only in one corner of
an empty floor, a bump wherever the robot crosses a line.
"""

from __future__ import annotations

from bisect import bisect_right
from dataclasses import dataclass

from autonomy.emulator.world import EPSILON_MM, Pose, Shape

#: The commands a script can make the robot refuse (``NO``), as a scenario names them; a stop is never refused.
REFUSABLE = ("beep", "move", "turn", "servo")


@dataclass(frozen=True)
class Area:
    """What the sensors report while the robot's centre is in ``shape`` (and, if set, it faces within ``heading_deg``).

    Attributes:
        shape: Where on the floor, in the world's coordinates.
        heading_deg: ``(from, to)``: only while the heading is in that arc, counter-clockwise from ``from``
            to ``to`` (a full turn or more from one to the other: any way); None: whichever way it faces.
        front_mm: What the front sensor reads there (None: what it would otherwise).
        bump: Whether the collision flag is up there.
        tilt_deg: The tilt the status packet reports there (None: what it would otherwise).
    """

    shape: Shape
    heading_deg: tuple[float, float] | None = None
    front_mm: int | None = None
    bump: bool = False
    tilt_deg: int | None = None

    def holds(self, pose: Pose) -> bool:
        """Whether the robot at ``pose`` is in the area (its edge included), facing as it says."""
        if self.shape.gap(pose.x_mm, pose.y_mm) > EPSILON_MM:
            return False
        if self.heading_deg is None or self.heading_deg[1] - self.heading_deg[0] >= 360.0:  # a full turn: any way
            return True
        start, end = (a % 360.0 for a in self.heading_deg)
        heading = pose.heading_deg % 360.0
        return start <= heading <= end if start <= end else heading >= start or heading <= end


@dataclass(frozen=True)
class SensorScript:
    """What the sensors report, by time from the start of the run (seconds).

    Attributes:
        front_mm: ``(from_s, mm)`` steps, in time order: from ``from_s`` on, the front sensor reads ``mm``
            (before the first, what the world holds).
        bumps_s: Times at which the collision flag is raised, held as an impact holds it.
        tilt_deg: ``(from_s, degrees)`` steps, as ``front_mm``, for the tilt the status packet reports.
        refuses: ``(command, from_s)`` pairs: from ``from_s`` on, the robot answers ``NO`` to that command
            (one of :data:`REFUSABLE`) and does not carry it out.
        areas: What the sensors report by where the robot is: the first area it is in that says a sensor
            decides that sensor, before the times do.
    """

    front_mm: tuple[tuple[float, int], ...] = ()
    bumps_s: tuple[float, ...] = ()
    tilt_deg: tuple[tuple[float, int], ...] = ()
    refuses: tuple[tuple[str, float], ...] = ()
    areas: tuple[Area, ...] = ()

    @staticmethod
    def _step(steps: tuple[tuple[float, int], ...], time_s: float) -> int | None:
        index = bisect_right(steps, time_s, key=lambda step: step[0]) - 1
        return steps[index][1] if index >= 0 else None

    def front_at(self, time_s: float, pose: Pose | None = None) -> int | None:
        """The front sensor's reading at ``time_s`` with the robot at ``pose``, or None: the world's."""
        if pose is not None:
            for area in self.areas:
                if area.front_mm is not None and area.holds(pose):
                    return area.front_mm
        return self._step(self.front_mm, time_s) if self.front_mm else None

    def tilt_at(self, time_s: float, pose: Pose | None = None) -> int | None:
        """The tilt reported at ``time_s`` with the robot at ``pose``, or None: the robot's own."""
        if pose is not None:
            for area in self.areas:
                if area.tilt_deg is not None and area.holds(pose):
                    return area.tilt_deg
        return self._step(self.tilt_deg, time_s) if self.tilt_deg else None

    def bumped_at(self, time_s: float, hold_s: float, pose: Pose | None = None) -> bool:
        """Whether the collision flag is up at ``time_s``: a scripted bump holds it, or ``pose`` is in a bump area."""
        if pose is not None and any(area.bump and area.holds(pose) for area in self.areas):
            return True
        return any(bump_s <= time_s < bump_s + hold_s for bump_s in self.bumps_s)

    def refused(self, command: str, time_s: float) -> bool:
        """Whether the robot refuses ``command`` (one of :data:`REFUSABLE`) at ``time_s``."""
        return any(name == command and from_s <= time_s for name, from_s in self.refuses)

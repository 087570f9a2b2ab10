"""Scripted sensors: what the robot's sensors report at given times, whatever its world holds.

A mission's unit test needs a wall at 80 mm at 2.5 s, or a bump at 3 s, without building a world
where the robot would meet them then. A :class:`SensorScript` set on the emulator's robot makes
its front sensor, its collision flag and its tilt report what the script says from each time on
(the robot still drives in its world, and the judge still reads the world's own account: a
scripted bump is what the bumper says, not an impact). It can also make the robot refuse a kind of
command from a time on (answer ``NO``, as a robot in manual mode refuses motion): a beep, a move, a
turn or a servo; never a stop, so that a run's end still stops the robot.
"""

from __future__ import annotations

from bisect import bisect_right
from dataclasses import dataclass

#: The commands a script can make the robot refuse (``NO``), as a scenario names them; a stop is never refused.
REFUSABLE = ("beep", "move", "turn", "servo")


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
    """

    front_mm: tuple[tuple[float, int], ...] = ()
    bumps_s: tuple[float, ...] = ()
    tilt_deg: tuple[tuple[float, int], ...] = ()
    refuses: tuple[tuple[str, float], ...] = ()

    @staticmethod
    def _step(steps: tuple[tuple[float, int], ...], time_s: float) -> int | None:
        index = bisect_right(steps, time_s, key=lambda step: step[0]) - 1
        return steps[index][1] if index >= 0 else None

    def front_at(self, time_s: float) -> int | None:
        """The front sensor's reading at ``time_s``, or None: the world's."""
        return self._step(self.front_mm, time_s) if self.front_mm else None

    def tilt_at(self, time_s: float) -> int | None:
        """The tilt reported at ``time_s``, or None: the robot's own."""
        return self._step(self.tilt_deg, time_s) if self.tilt_deg else None

    def bumped_at(self, time_s: float, hold_s: float) -> bool:
        """Whether a scripted bump holds the collision flag up at ``time_s``."""
        return any(bump_s <= time_s < bump_s + hold_s for bump_s in self.bumps_s)

    def refused(self, command: str, time_s: float) -> bool:
        """Whether the robot refuses ``command`` (one of :data:`REFUSABLE`) at ``time_s``."""
        return any(name == command and from_s <= time_s for name, from_s in self.refuses)

"""Scripted sensors: what the robot's sensors report at given times, whatever its world holds.

A mission's unit test needs a wall at 80 mm at 2.5 s, or a bump at 3 s, without building a world
where the robot would meet them then. A :class:`SensorScript` set on the emulator's robot makes
its front sensor, its collision flag and its tilt report what the script says from each time on
(the robot still drives in its world, and the judge still reads the world's own account: a
scripted bump is what the bumper says, not an impact).
"""

from __future__ import annotations

from bisect import bisect_right
from dataclasses import dataclass


@dataclass(frozen=True)
class SensorScript:
    """What the sensors report, by time from the start of the run (seconds).

    Attributes:
        front_mm: ``(from_s, mm)`` steps, in time order: from ``from_s`` on, the front sensor reads ``mm``
            (before the first, what the world holds).
        bumps_s: Times at which the collision flag is raised, held as an impact holds it.
        tilt_deg: ``(from_s, degrees)`` steps, as ``front_mm``, for the tilt the status packet reports.
    """

    front_mm: tuple[tuple[float, int], ...] = ()
    bumps_s: tuple[float, ...] = ()
    tilt_deg: tuple[tuple[float, int], ...] = ()

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

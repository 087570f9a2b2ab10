"""Decorators the mission compiler needs beyond py_trees' own.

py_trees' ``Timeout`` reads ``time.monotonic``; :class:`ClockTimeout` reads the run's
clock instead, so a time-out works the same in real and in virtual time.
"""

from __future__ import annotations

from typing import Any

import py_trees
from py_trees.common import Status

from autonomy.behaviours.base import RobotContext
from autonomy.clock import Clock


class ClockTimeout(py_trees.decorators.Decorator):
    """FAILURE if the child is still RUNNING ``seconds`` after it started; the child is halted.

    Args:
        name: The node's display name.
        child: The decorated behaviour.
        seconds: How long the child may run.
    """

    def __init__(self, name: str, child: py_trees.behaviour.Behaviour, seconds: float) -> None:
        super().__init__(name=name, child=child)
        self.seconds = seconds
        self._clock: Clock | None = None
        self._deadline_s = 0.0

    def setup(self, **kwargs: Any) -> None:
        """Takes the run's clock from ``robot=RobotContext``."""
        robot = kwargs.get("robot")
        if not isinstance(robot, RobotContext):
            raise TypeError(f"{self.name}: setup() needs robot=RobotContext(...)")
        self._clock = robot.clock

    def _time_now(self) -> float:
        if self._clock is None:
            raise RuntimeError(f"node '{self.name}' was not set up: call setup(robot=RobotContext(...)) first")
        return self._clock.now()

    def initialise(self) -> None:
        """Starts the countdown."""
        self._deadline_s = self._time_now() + self.seconds

    def update(self) -> Status:
        """The child's status, or FAILURE once the time is up (halting the child)."""
        if self.decorated.status == Status.RUNNING and self._time_now() >= self._deadline_s:
            self.feedback_message = f"timed out after {self.seconds:g} s"
            self.decorated.stop(Status.INVALID)
            return Status.FAILURE
        return self.decorated.status

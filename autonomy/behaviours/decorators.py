"""Decorators the mission compiler needs beyond py_trees' own.

py_trees' ``Timeout`` reads ``time.monotonic``; :class:`ClockTimeout` reads the run's
clock instead, so a time-out works the same in real and in virtual time. :class:`Repeat` and
:class:`Retry` are py_trees' own, saying where they are in words rather than py_trees' text.
"""

from __future__ import annotations

from typing import Any

import py_trees
from py_trees.common import Status

from autonomy.behaviours.base import RobotContext
from autonomy.clock import Clock
from autonomy.words import plural


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


class Repeat(py_trees.decorators.Repeat):
    """py_trees' ``Repeat``, saying where it is in our words: ``3 of 4 done``, ``forever, 5 times so far``.

    Args:
        name: The node's display name.
        child: The decorated behaviour.
        num_success: Successes to repeat for; -1: forever.
    """

    def update(self) -> Status:
        """As py_trees' ``Repeat``; the feedback counts the child's successes."""
        status = super().update()
        done, times = self.success, self.num_success
        if status == Status.FAILURE:
            self.feedback_message = f"the child failed after {plural(done, 'success', 'successes')}"
        elif times < 0:
            self.feedback_message = f"forever, {plural(done, 'time')} so far"
        else:
            self.feedback_message = f"{done} of {times} done"
        return status


class Retry(py_trees.decorators.Retry):
    """py_trees' ``Retry``, saying where it is in our words: ``attempt 2 of 3``, ``failed 3 times``.

    Args:
        name: The node's display name.
        child: The decorated behaviour.
        num_failures: Attempts in all.
    """

    def update(self) -> Status:
        """As py_trees' ``Retry``; the feedback counts the attempts."""
        status = super().update()
        failures, attempts = self.failures, self.num_failures
        if status == Status.SUCCESS:
            self.feedback_message = f"succeeded on attempt {failures + 1} of {attempts}"
        elif status == Status.FAILURE:
            self.feedback_message = f"failed {plural(attempts, 'time')}"
        else:
            self.feedback_message = f"attempt {failures + 1} of {attempts}"
        return status

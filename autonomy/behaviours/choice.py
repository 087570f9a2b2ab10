"""A composite that runs one of its children, picked at random, the same way again under the same seed.

:class:`RandomChoice` picks anew each time it starts (not while its pick is still running), from a
generator of its own: seeded with its ``seed`` when the mission gives one, else with the run's seed
(the emulator's, 0 on a robot) and its place among the run's random choices. So a run, its trace and
its replay, and a scenario's run on a seed, pick the same children in the same order every time.
"""

from __future__ import annotations

import random
from collections.abc import Iterator
from typing import Any

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from autonomy.behaviours.base import RobotContext


class RandomChoice(py_trees.composites.Composite):
    """Runs one child, picked at random each time it starts, and returns what that child returns.

    Args:
        name: The node's display name.
        children: The children to pick from, each as likely.
        seed: The seed of its picks (None: the run's, with its place among the run's random choices).
    """

    def __init__(self, name: str, children: list[Behaviour], seed: int | None = None) -> None:
        super().__init__(name=name, children=children)
        self.seed = seed
        self._rng = random.Random(f"random {seed or 0}")
        self.picks = 0

    def setup(self, **kwargs: Any) -> None:
        """Seeds its picks from ``robot=RobotContext``: the run's seed, unless the node gives its own."""
        robot = kwargs.get("robot")
        if not isinstance(robot, RobotContext):
            raise TypeError(f"{self.name}: setup() needs robot=RobotContext(...)")
        self._rng = robot.random_for(self.name) if self.seed is None else random.Random(f"random {self.seed}")
        self.picks = 0

    def tick(self) -> Iterator[Behaviour]:
        """Picks a child when it starts, then ticks that child alone until it ends."""
        if self.status != Status.RUNNING:
            if self.current_child is not None and self.current_child.status != Status.INVALID:
                self.current_child.stop(Status.INVALID)
            self.current_child = self.children[self._rng.randrange(len(self.children))] if self.children else None
            self.picks += 1
            self.initialise()
        if self.current_child is None:
            self.stop(Status.FAILURE)
            yield self
            return
        child = self.current_child
        yield from child.tick()
        self.feedback_message = f"picked '{child.name}' (pick {self.picks})"
        if child.status == Status.RUNNING:
            self.status = Status.RUNNING
        else:
            self.stop(child.status)
        yield self

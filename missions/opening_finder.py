"""An example plugin: behaviours written in Python for mission files.

A mission loads it with ``plugins: [opening_finder]`` (the module is found next to the
mission file). Each class below becomes a node type: ``node_type`` is its name, ``params``
what the validator checks, ``doc`` what ``autonomy behaviours`` shows.
"""

from __future__ import annotations

from typing import Any

from py_trees.common import Status

from autonomy.behaviours import Param, RobotAction, RobotCondition
from autonomy.protocol import heading_delta_deg


class TurnUntilClear(RobotAction):
    """Turn left in steps until the front sensor sees at least ``mm`` of free space."""

    node_type = "turn_until_clear"
    doc = "Turn left step_deg at a time until nothing is closer than mm; fails after max_deg."
    params = (
        Param("mm", "int", "free space wanted ahead", unit="mm", required=True, minimum=1, maximum=255, example=200),
        Param("step_deg", "int", "size of each turn", unit="deg", default=30, minimum=5, maximum=90),
        Param("max_deg", "int", "give up after turning this far", unit="deg", default=360, minimum=5, maximum=999),
    )

    def __init__(self, name: str, **args: Any) -> None:
        super().__init__(name, **args)
        self.turned_deg = 0
        self.turning = False

    def initialise(self) -> None:
        """Starts with no turn under way."""
        self.turned_deg = 0
        self.turning = False

    def update(self) -> Status:
        """One decision per tick: wait for a step to finish, look, turn again or stop."""
        status = self.robot_status
        if self.turning and status.moving:
            return Status.RUNNING  # the step is still under way
        self.turning = False
        self.release_motion()
        if status.front_distance_mm >= self.args["mm"]:
            self.feedback_message = f"clear: {status.front_distance_mm} mm after {self.turned_deg} deg"
            return Status.SUCCESS
        if self.turned_deg >= self.args["max_deg"]:
            self.feedback_message = f"no opening of {self.args['mm']} mm found"
            return Status.FAILURE
        if not self.send(lambda: self.client.turn(self.args["step_deg"])):
            return Status.FAILURE
        self.started_motion()
        self.turning = True
        self.turned_deg += self.args["step_deg"]
        self.feedback_message = f"looking: {status.front_distance_mm} mm at +{self.turned_deg} deg"
        return Status.RUNNING


class HeadingNear(RobotCondition):
    """The robot faces ``heading_deg`` give or take ``tolerance_deg``."""

    node_type = "heading_near"
    doc = "The heading is within tolerance_deg of heading_deg."
    params = (
        Param("heading_deg", "int", "the heading wanted", unit="deg", required=True, minimum=0, maximum=359),
        Param("tolerance_deg", "int", "how close counts", unit="deg", default=10, minimum=0, maximum=180),
    )

    def check(self) -> bool:
        """Shortest angle between the heading and the target, within the tolerance."""
        gap = heading_delta_deg(self.args["heading_deg"], self.robot_status.heading_deg)
        return abs(gap) <= self.args["tolerance_deg"]

    def describe(self) -> str:
        """The reading."""
        return f"heading {self.robot_status.heading_deg} deg"

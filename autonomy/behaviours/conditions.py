"""Built-in conditions: they read the values polled before the tick and send nothing."""

from __future__ import annotations

from autonomy.behaviours.base import SENSOR_REACH, Param, RobotCondition


class ObstacleWithin(RobotCondition):
    """The front sensor reads less than ``mm``."""

    node_type = "obstacle_within"
    doc = "Something is in front, closer than mm (front sensor)."
    params = (
        Param(
            "mm",
            "int",
            "distance",
            unit="mm",
            required=True,
            minimum=1,
            maximum=255,
            example=150,
            range_why=SENSOR_REACH,
        ),
    )

    def check(self) -> bool:
        """Front distance below mm."""
        return self.robot_status.front_distance_mm < self.args["mm"]

    def describe(self) -> str:
        """The reading."""
        return f"front {self.robot_status.front_distance_mm} mm"


class Collided(RobotCondition):
    """The collision flag is set."""

    node_type = "collided"
    doc = "The robot bumped into something (collision flag, held at least 0.5 s)."

    def check(self) -> bool:
        """The flag."""
        return self.robot_status.collided


class Moving(RobotCondition):
    """The robot moves, on purpose or pushed."""

    node_type = "moving"
    doc = "The robot is moving (on purpose or pushed)."

    def check(self) -> bool:
        """The flag."""
        return self.robot_status.moving


class AutoMode(RobotCondition):
    """The robot is in auto mode (not taken over by its remote)."""

    node_type = "auto_mode"
    doc = "The robot is in auto mode; in manual mode it refuses motion commands."

    def check(self) -> bool:
        """The flag."""
        return self.robot_status.auto_mode


class TiltWithin(RobotCondition):
    """The tilt is no more than ``degrees`` either way."""

    node_type = "tilt_within"
    doc = "The robot leans no more than degrees either way."
    params = (Param("degrees", "int", "largest lean", unit="deg", required=True, minimum=0, maximum=127, example=20),)

    def check(self) -> bool:
        """Tilt within degrees either way."""
        return abs(self.robot_status.tilt_deg) <= self.args["degrees"]

    def describe(self) -> str:
        """The reading."""
        return f"tilt {self.robot_status.tilt_deg} deg"


class BatteryAbove(RobotCondition):
    """The battery level is above ``level`` (polled about once a second)."""

    node_type = "battery_above"
    doc = "The battery level (0..255, polled about once a second) is above level."
    params = (Param("level", "int", "battery level", required=True, minimum=0, maximum=255, example=60),)

    def check(self) -> bool:
        """Battery above level."""
        return self.battery > self.args["level"]

    def describe(self) -> str:
        """The reading."""
        return f"battery {self.battery}"


class Healthy(RobotCondition):
    """The platform reports itself healthy (``GR``, polled about once a second)."""

    node_type = "healthy"
    doc = "The robot reports itself healthy (GR, polled about once a second)."

    def check(self) -> bool:
        """The last GR reply."""
        return self.healthy


BUILTIN_CONDITIONS = (ObstacleWithin, Collided, Moving, AutoMode, TiltWithin, BatteryAbove, Healthy)

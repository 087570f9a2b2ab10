"""py_trees behaviours that drive the robot: actions call the client, conditions read the blackboard.

Write your own by subclassing :class:`RobotAction` or :class:`RobotCondition`, declaring
``node_type``, ``doc`` and ``params``; see docs/missions.md, "Behaviours in Python".
"""

from autonomy.behaviours.actions import BUILTIN_ACTIONS
from autonomy.behaviours.base import (
    BATTERY_KEY,
    HEALTHY_KEY,
    STATUS_KEY,
    Param,
    RobotAction,
    RobotBehaviour,
    RobotCondition,
    RobotContext,
)
from autonomy.behaviours.conditions import BUILTIN_CONDITIONS
from autonomy.behaviours.decorators import ClockTimeout
from autonomy.behaviours.tree import NodeSource, describe_tree, kind_of, preorder

__all__ = [
    "BATTERY_KEY",
    "BUILTIN_ACTIONS",
    "BUILTIN_CONDITIONS",
    "HEALTHY_KEY",
    "NodeSource",
    "STATUS_KEY",
    "ClockTimeout",
    "Param",
    "RobotAction",
    "RobotBehaviour",
    "RobotCondition",
    "RobotContext",
    "describe_tree",
    "kind_of",
    "preorder",
]

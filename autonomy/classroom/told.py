"""How a verdict tells what happened: what the robot hit, how far and which way, and which node was running.

Plain words from a run's facts, for :mod:`~autonomy.classroom.judge`'s one-line verdicts.
"""

from __future__ import annotations

import math

from autonomy.classroom.facts import Contact, RunFacts, arrival_s
from autonomy.emulator.world import World
from autonomy.record import Pose


def hit(world: World, pose: Pose) -> str:
    """What the robot touches at ``pose``: an obstacle's name (``obstacle 2`` for one without), or ``a wall``."""
    names = world.obstacle_names or ("",) * len(world.obstacles)
    wall = min(pose.x_mm, pose.y_mm, world.width_mm - pose.x_mm, world.height_mm - pose.y_mm)
    nearest = min(
        (
            (obstacle.gap(pose.x_mm, pose.y_mm), name or f"obstacle {index + 1}")
            for index, (obstacle, name) in enumerate(zip(world.obstacles, names, strict=True))
        ),
        default=(math.inf, ""),
    )
    return nearest[1] if nearest[0] < wall else "a wall"


def while_running(facts: RunFacts, time_s: float, collided: bool = False) -> str:
    """``, while 'to the end' (move, line 7) was running``: which node lost a mark, from the run's records.

    After the mission's end, its last node; with ``collided`` (a collision then), ``: the mission ended
    before the robot could stop`` too. Empty where the run kept no account of its nodes.
    """
    label = facts.running_at(time_s)
    if not label:
        return ""
    if collided and time_s > facts.time_s + 1e-6:
        return f", while {label} was running: the mission ended before the robot could stop"
    return f", while {label} was running"


def named_node(facts: RunFacts, line: str) -> int | None:
    """The node that a verdict's line says was running (in :func:`while_running`'s words), by id; None: none."""
    said = [(line.find(f"while {label} was running"), node) for node, label in enumerate(facts.node_labels)]
    return min(((at, node) for at, node in said if at >= 0), default=(0, None))[1]


def got_there(facts: RunFacts) -> str:
    """``; it got there while ... was running``: the node that took the robot where it came to rest."""
    during = while_running(facts, arrival_s(facts.path))
    return f"; it got there{during[1:]}" if during else ""


def contact_text(contact: Contact) -> str:
    """``4.1 s, at 427 mm/s``: when a collision began and how hard it hit."""
    return f"{contact.time_s:.1f} s at {contact.speed_mm_s:.0f} mm/s"


def stopped_by(facts: RunFacts, world: World) -> str:
    """``, but only because it hit a wall at 320 mm/s (stopped by it, not by itself)``, or empty."""
    contact = facts.rest_hit
    if contact is None:
        return ""
    what = hit(world, contact.pose)
    return f", but only because it hit {what} at {contact.speed_mm_s:.0f} mm/s (stopped by it, not by itself)"


def listed(names: list[str]) -> str:
    """``a, b and c``."""
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


def either(names: list[str]) -> str:
    """``a, b or c``."""
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " or " + names[-1]


#: The eight points of the compass, counter-clockwise from east (+x), as the world's headings go.
_COMPASS = ("east", "north-east", "north", "north-west", "west", "south-west", "south", "south-east")


def mm(distance_mm: float) -> str:
    """A distance as a student reads it: ``35 mm``, or ``less than 1 mm`` (never ``0 mm`` for a miss)."""
    return "less than 1 mm" if distance_mm < 0.5 else f"{distance_mm:.0f} mm"


def bearing(from_x_mm: float, from_y_mm: float, to_x_mm: float, to_y_mm: float) -> str:
    """Which way ``to`` lies from ``from``, as one of the eight points of the compass (north is +y)."""
    angle_deg = math.degrees(math.atan2(to_y_mm - from_y_mm, to_x_mm - from_x_mm)) % 360.0
    return _COMPASS[round(angle_deg / 45.0) % 8]

"""A run's facts, from the emulator's own account: the robot's true path, impacts, beeps, turns and rest.

They are gathered as the run goes (:class:`Gatherer` keeps its header and end record), then read
from the emulated robot once the mission has ended and the robot, told to stop, has come to rest
(:func:`facts_of`): what :mod:`~autonomy.classroom.judge` decides each criterion from.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import pairwise

from autonomy.emulator.robot import Robot
from autonomy.record import Pose, Record, RunEnd, RunHeader

SUCCEEDED = "succeeded"


FAILED = "failed"


#: How long the emulator runs on after a mission's end for the robot to come to rest, simulated seconds.
SETTLE_MOST_S = 30.0


#: An impact is a new collision once the robot has been this far from where the last one was, mm;
#: pushing on against the same wall is one collision, backing off and bumping again is two.
NEW_COLLISION_MM = 30.0


@dataclass(frozen=True)
class Turn:
    """A turn in place: when, where, by how much (left positive), and how far it is from where the robot turned before.

    ``away_mm`` is a straight line from the place of the turn before (or of the start): a drive out and
    back again, however long, is no side of a square.
    """

    time_s: float
    x_mm: float
    y_mm: float
    degrees: float
    away_mm: float = 0.0


@dataclass
class RunFacts:
    """What the judge needs of one run, from the emulator's own account and the run's end record.

    Times are the mission's: seconds from the start of its run.

    Attributes:
        nodes: How many nodes the tree has.
        outcome: The end record's outcome (``succeeded``, ``failed``...).
        reason: The end record's reason.
        time_s: When the mission ended.
        path: The true path: the pose at the start, wherever the motion changed, and where the robot
            came to rest; it drove straight or turned in place between two of them.
        beeps: Where the robot was at each beep the robot sounded (time, pose).
        impacts: Each impact the emulator recorded (time, pose).
        collisions: The impacts that were new collisions (see ``NEW_COLLISION_MM``).
        rest_s: When the robot last moved, having come to rest for good; None if it never did.
        time_limit_s: The exercise's time limit.
    """

    nodes: int
    outcome: str
    reason: str
    time_s: float
    path: list[tuple[float, Pose]]
    beeps: list[tuple[float, Pose]]
    impacts: list[tuple[float, Pose]]
    collisions: list[tuple[float, Pose]]
    rest_s: float | None
    time_limit_s: float = math.inf

    @property
    def distance_mm(self) -> float:
        """How far the robot truly drove, forward and back."""
        return sum(math.hypot(b.x_mm - a.x_mm, b.y_mm - a.y_mm) for (_, a), (_, b) in pairwise(self.path))

    @property
    def turns(self) -> list[Turn]:
        """Every turn in place, where the path changed heading."""
        if not self.path:
            return []
        out: list[Turn] = []
        last = self.path[0][1]  # where it last turned, or started
        for (_, before), (time_s, pose) in pairwise(self.path):
            delta = pose.heading_deg - before.heading_deg
            if abs(delta) >= 0.5:
                away_mm = math.hypot(pose.x_mm - last.x_mm, pose.y_mm - last.y_mm)
                out.append(Turn(time_s, pose.x_mm, pose.y_mm, delta, away_mm))
                last = pose
        return out


class Gatherer:
    """A listener that keeps a run's header and end record (the judge reads the rest from the emulator)."""

    def __init__(self) -> None:
        self.header: RunHeader | None = None
        self.end: RunEnd | None = None

    def __call__(self, record: Record) -> None:
        """Takes one record."""
        if isinstance(record, RunHeader) and self.header is None:
            self.header = record
        elif isinstance(record, RunEnd) and self.end is None:
            self.end = record


def settle(robot: Robot, most_s: float = SETTLE_MOST_S) -> None:
    """Runs the robot's physics on until it stands still (at most ``most_s``): where it comes to rest."""
    until_s = robot.time_s + most_s
    while robot.moving and robot.time_s < until_s:
        robot.advance_to(min(until_s, robot.time_s + 0.1))


def facts_of(gathered: Gatherer, robot: Robot, time_limit_s: float = math.inf) -> RunFacts:
    """A run's facts, once it has ended: its end record, and the robot's own account, let come to rest.

    Args:
        gathered: The run's header and end record.
        robot: The emulated robot the run drove, as the run left it.
        time_limit_s: The exercise's time limit (the robot must have come to rest within it).

    Raises:
        ValueError: the run has no header or end record.
    """
    header, end = gathered.header, gathered.end
    if header is None or end is None:
        raise ValueError("a run to judge needs its header and its end record")
    offset_s = robot.time_s - end.time_s  # the robot's clock started before the mission's run
    settle(robot)
    rest_s = None if robot.moving else robot.moved_s - offset_s
    robot.stop()  # marks where it came to rest (or was still going) on the trail; it stands already
    path = [(t - offset_s, pose) for t, pose in robot.trail]
    impacts = [(i.time_s - offset_s, i.pose) for i in robot.impacts]
    beeps = [(t - offset_s, pose) for (t, _, _), pose in zip(robot.beeps, robot.beep_poses, strict=True)]
    return RunFacts(
        nodes=len(header.nodes),
        outcome=end.outcome,
        reason=end.reason,
        time_s=end.time_s,
        path=path,
        beeps=beeps,
        impacts=impacts,
        collisions=_collisions(impacts, path),
        rest_s=rest_s,
        time_limit_s=time_limit_s,
    )


def _collisions(impacts: list[tuple[float, Pose]], path: list[tuple[float, Pose]]) -> list[tuple[float, Pose]]:
    """The impacts that begin a collision: the first, and each one after the robot got far from the last collision.

    Far is ``NEW_COLLISION_MM`` from where the collision before began, at some moment since its
    last impact, however many impacts that collision had.
    """
    out: list[tuple[float, Pose]] = []
    last_s = 0.0
    for time_s, pose in impacts:
        if out:
            _, first = out[-1]
            points = [p for t, p in path if last_s <= t <= time_s] + [pose]
            if all(math.hypot(p.x_mm - first.x_mm, p.y_mm - first.y_mm) < NEW_COLLISION_MM for p in points):
                last_s = time_s  # still the same push
                continue
        out.append((time_s, pose))
        last_s = time_s
    return out


def path_points(facts: RunFacts, most: int = 400) -> list[tuple[float, float]]:
    """The true path as at most ``most`` points (x_mm, y_mm), rounded to 1 mm, the last always kept."""
    poses = [p for _, p in facts.path]
    step = max(1, math.ceil(len(poses) / most))
    kept = poses[::step]
    if poses and kept[-1] is not poses[-1]:
        kept.append(poses[-1])
    return [(round(p.x_mm), round(p.y_mm)) for p in kept]

"""A run's facts, from the emulator's own account: the robot's true path, contacts, beeps, stops, turns and rest.

They are gathered as the run goes (:class:`Gatherer` keeps its header and end record), then read
from the emulated robot once the mission has ended and the robot, told to stop, has come to rest
(:func:`facts_of`): what :mod:`~autonomy.classroom.judge` decides each criterion from.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from dataclasses import dataclass, field
from itertools import pairwise

from autonomy.emulator.robot import SAME_PLACE_MM, Impact, Robot
from autonomy.emulator.world import World
from autonomy.mission.registry import BUILTINS
from autonomy.record import NodeInfo, Pose, Record, RunEnd, RunHeader, TickRecord
from autonomy.runner import clipped

SUCCEEDED = "succeeded"


FAILED = "failed"


#: How long the emulator runs on after a mission's end for the robot to come to rest, simulated seconds.
SETTLE_MOST_S = 30.0


#: A contact is over once the robot's body has been this far clear of every wall and obstacle, mm:
#: pushing on against a wall, or turning and driving on along it, is one collision; backing off
#: this much (a little) and bumping again is two, however near the first the second is.
CONTACT_CLEAR_MM = 5.0
#: How long a robot whose mission was still running when its time ran out must have stood still by then, to
#: have come to rest for good (seconds).
STILL_AT_LIMIT_S = 1.0

#: An impact no faster than this is a touch, mm/s (half the slowest drive): a robot that came to
#: rest at a faster one was stopped by what it hit, not by itself.
TOUCH_MM_S = 50.0

#: The most of a node's name a verdict line says (a name may be 1,000 characters long), characters.
NODE_NAME_CHARS = 60

#: How finely the path is looked along for a contact's end, mm.
_CLEAR_STEP_MM = 1.0


@dataclass(frozen=True)
class Contact:
    """One collision: the robot touched a wall or an obstacle, and stayed in touch until it drew clear.

    Attributes:
        time_s: Its first impact.
        pose: Where the robot was at its first impact.
        speed_mm_s: How fast the robot hit, at the hardest of its impacts.
        impacts: How many impacts it had (pushing on against a wall is one contact of many impacts).
        end_s: Its last impact.
    """

    time_s: float
    pose: Pose
    speed_mm_s: float = 0.0
    impacts: int = 1
    end_s: float = 0.0


@dataclass(frozen=True)
class Beep:
    """A beep the robot sounded: when, where, how loud, and whether it was driving or turning then.

    ``moving`` is False for a beep made standing: still, or braking to a stop (no drive nor turn
    under way); a beep at volume 0 is silent, and no beep to any criterion.
    """

    time_s: float
    pose: Pose
    volume: int = 3
    moving: bool = False

    @property
    def audible(self) -> bool:
        """Whether it made a sound: volume 1 or more."""
        return self.volume > 0


@dataclass(frozen=True)
class Still:
    """A time the robot stood still (neither wheels nor heading moving): from, to, and where.

    The last one, where it came to rest for good, ends at infinity. ``stopped_by_impact``: it began
    where an impact faster than a touch stopped the robot (not a stop of its own).
    """

    start_s: float
    end_s: float
    pose: Pose
    stopped_by_impact: bool = False

    @property
    def duration_s(self) -> float:
        """How long it stood there."""
        return self.end_s - self.start_s


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
        beeps: Each beep the robot sounded, silent ones (volume 0) included.
        impacts: Each impact the emulator recorded (time, pose).
        collisions: The contacts: each collision, from its first impact until the robot drew clear
            (see ``CONTACT_CLEAR_MM``), with how fast it hit.
        rest_s: When the robot last moved, having come to rest for good; None if it never did.
        time_limit_s: The exercise's time limit.
        stills: Each time the robot stood still, during the mission and after, the last one where
            it came to rest for good.
        rest_hit: The contact that brought the robot to rest for good, when an impact faster than a
            touch (``TOUCH_MM_S``) did: it was stopped by a wall or an obstacle, not by itself.
        node_types: The tree's nodes as ``type`` and, for each parameter it was given, ``type.param``
            (``move``, ``move.until_obstacle_mm``): what a static criterion looks for.
        running: Which node was running when: (the tick's time, the node's id) each time the tree's
            tip changed (:attr:`Runner.tips`).
        node_labels: Each node as a student finds it in their file, by id: ``'to the end' (move,
            line 7)``, or ``move until < 60 mm (line 5)`` for a node without a name of its own.
        node_kinds: Each node's type, by id (``move``).
        rest_touching: Whether the robot, where it came to rest last, touches a wall or an obstacle (is less
            than ``CONTACT_CLEAR_MM`` clear of it).
        last_tick_s: When the mission's last tick was.
        left_going: Whether the run ended with the robot still told to drive or turn (its wheels' target not
            zero): the stop at the end did not reach it.
        servo_moves: Each servo command the robot carried out: (time_s, servo id, the angle it was sent to).
    """

    nodes: int
    outcome: str
    reason: str
    time_s: float
    path: list[tuple[float, Pose]]
    beeps: list[Beep]
    impacts: list[tuple[float, Pose]]
    collisions: list[Contact]
    rest_s: float | None
    time_limit_s: float = math.inf
    stills: list[Still] = field(default_factory=list)
    rest_hit: Contact | None = None
    node_types: frozenset[str] = frozenset()
    running: list[tuple[float, int]] = field(default_factory=list)
    node_labels: list[str] = field(default_factory=list)
    node_kinds: list[str] = field(default_factory=list)
    rest_touching: bool = False
    last_tick_s: float = math.inf
    left_going: bool = False
    servo_moves: list[tuple[float, int, float]] = field(default_factory=list)

    def running_at(self, time_s: float) -> str:
        """The label of the node that was running at ``time_s`` (the mission's last, after its end), or empty."""
        if not self.running or not self.node_labels:
            return ""
        # the tip a tick left ran from that tick on: what happened at a tick's own time came before it
        index = bisect_left(self.running, time_s, key=lambda tip: tip[0]) - 1
        if time_s > self.time_s and index == len(self.running) - 1 and index > 0:
            if self.running[index][0] >= self.last_tick_s - 1e-9:  # the last tick's node, there for no time
                index -= 1
        node = self.running[max(0, index)][1]
        return self.node_labels[node] if node < len(self.node_labels) else ""

    @property
    def sounded(self) -> list[Beep]:
        """The beeps that made a sound (volume 1 or more)."""
        return [beep for beep in self.beeps if beep.audible]

    @property
    def moving_at_time_limit(self) -> bool:
        """Whether the robot was still moving when its time ran out (see :func:`moving_at_time_limit`)."""
        return moving_at_time_limit(self.outcome, self.rest_s, self.time_s)

    @property
    def rest_by_itself(self) -> bool:
        """Whether the robot came to rest for good by itself, not stopped by what it hit (see ``rest_hit``)."""
        return self.rest_hit is None

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
        self.last_tick_s = math.inf

    def __call__(self, record: Record) -> None:
        """Takes one record."""
        if type(record) is TickRecord:
            self.last_tick_s = record.time_s
        elif isinstance(record, RunHeader) and self.header is None:
            self.header = record
        elif isinstance(record, RunEnd) and self.end is None:
            self.end = record


def settle(robot: Robot, most_s: float = SETTLE_MOST_S) -> None:
    """Runs the robot's physics on until it stands still (at most ``most_s``): where it comes to rest."""
    until_s = robot.time_s + most_s
    while robot.moving and robot.time_s < until_s:
        robot.advance_to(min(until_s, robot.time_s + 0.1))


def _given(node_type: str, key: str, value: object) -> bool:
    """Whether a node's parameter was given: set, to other than its default."""
    if value is None:
        return False
    kind = BUILTINS.get(node_type)
    if kind is None:  # a plugin's node: what it was given is what it has
        return True
    default = next((p.default for p in kind.params if p.name == key), None)
    return value != default


def node_label(node: NodeInfo) -> str:
    """A node as a student finds it in their file: ``'to the end' (move, line 7)``; ``move 300 mm (line 5)``."""
    line = f"line {node.line}" if node.line else ""
    name = clipped(node.name, NODE_NAME_CHARS)
    if node.name.split(" ")[0] == node.type:  # the name it was given by default, which says its type
        return f"{name} ({line})" if line else name
    return f"'{name}' ({node.type}, {line})" if line else f"'{name}' ({node.type})"


def facts_of(
    gathered: Gatherer, robot: Robot, time_limit_s: float = math.inf, running: list[tuple[float, int]] | None = None
) -> RunFacts:
    """A run's facts, once it has ended: its end record, and the robot's own account, let come to rest.

    Args:
        gathered: The run's header and end record.
        robot: The emulated robot the run drove, as the run left it.
        time_limit_s: The exercise's time limit (the robot must have come to rest within it).
        running: Which node was running when (:attr:`Runner.tips`).

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
    beeps = [
        Beep(t - offset_s, pose, volume, moving)
        for (t, _, volume), pose, moving in zip(robot.beeps, robot.beep_poses, robot.beep_moving, strict=True)
    ]
    collisions = contacts_of(robot.impacts, robot.trail, robot.world, robot.params.body_radius_mm, offset_s)
    near_s = 2 * robot.params.step_s  # an impact within a step or two of a stop is what stopped the robot

    def hard_impact_at(time_s: float) -> float | None:
        """The time of an impact faster than a touch that stopped the robot at ``time_s``, if one did."""
        times = [i.time_s - offset_s for i in robot.impacts if i.speed_mm_s > TOUCH_MM_S]
        return next((t for t in reversed(times) if abs(t - time_s) <= near_s), None)

    stills = [
        Still(a - offset_s, b - offset_s, pose, hard_impact_at(a - offset_s) is not None) for a, b, pose in robot.stills
    ]
    rest_hit = None
    if rest_s is not None:  # came to its last place at an impact harder than a touch: stopped by what it hit
        hard_s = hard_impact_at(arrival_s(path))
        if hard_s is not None:
            rest_hit = next((c for c in collisions if c.time_s - near_s <= hard_s <= c.end_s + near_s), None)
        if not moving_at_time_limit(end.outcome, rest_s, end.time_s):  # such a robot did not stop by itself
            stills.append(Still(rest_s, math.inf, robot.pose, rest_hit is not None))
    return RunFacts(
        nodes=len(header.nodes),
        outcome=end.outcome,
        reason=end.reason,
        time_s=end.time_s,
        path=path,
        beeps=beeps,
        impacts=impacts,
        collisions=collisions,
        rest_s=rest_s,
        time_limit_s=time_limit_s,
        stills=stills,
        rest_hit=rest_hit,
        running=list(running or []),
        servo_moves=[(t - offset_s, servo, angle) for t, servo, angle in robot.servo_moves],
        last_tick_s=gathered.last_tick_s,
        node_labels=[node_label(node) for node in header.nodes],
        node_kinds=[node.type for node in header.nodes],
        rest_touching=robot.world.clearance(robot.pose.x_mm, robot.pose.y_mm)
        <= robot.params.body_radius_mm + CONTACT_CLEAR_MM,
        node_types=frozenset(
            [n.type for n in header.nodes]
            + [f"{n.type}.{k}" for n in header.nodes for k, v in n.params.items() if _given(n.type, k, v)]
        ),
    )


def moving_at_time_limit(outcome: str, rest_s: float | None, time_s: float) -> bool:
    """Whether the robot was still moving when its time ran out: stopped by the time limit, not by its mission.

    A mission still running then must have left the robot standing :data:`STILL_AT_LIMIT_S` at least: one
    caught standing between two of its moves (a wiggle, a beat of its dance) had not come to rest for good.
    """
    return outcome not in (SUCCEEDED, FAILED) and rest_s is not None and rest_s > time_s - STILL_AT_LIMIT_S


def arrival_s(path: list[tuple[float, Pose]]) -> float:
    """When the robot came to the place where the path ends (turning there afterwards changes nothing)."""
    end = path[-1][1]
    arrived = path[-1][0]
    for time_s, pose in reversed(path):
        if abs(pose.x_mm - end.x_mm) > SAME_PLACE_MM or abs(pose.y_mm - end.y_mm) > SAME_PLACE_MM:
            break
        arrived = time_s
    return arrived


def contacts_of(
    impacts: list[Impact], trail: list[tuple[float, Pose]], world: World, radius_mm: float, offset_s: float = 0.0
) -> list[Contact]:
    """The collisions: each impact begins one unless the robot stayed in touch since the impact before.

    In touch means the body never drew ``CONTACT_CLEAR_MM`` clear of every wall and obstacle along
    the path between the two impacts: pushing on, or turning and driving on along a wall, is one
    contact; backing off a little and bumping again, in the same spot or not, is another.

    Args:
        impacts: The emulator's impacts, in order.
        trail: The robot's path (the emulator's trail), in the emulator's time.
        world: The world the robot drove in.
        radius_mm: The robot's body radius.
        offset_s: Taken off every time (the emulator's clock against the mission's).
    """
    out: list[Contact] = []
    for impact in impacts:
        if out and not _drew_clear(out[-1].end_s + offset_s, impact, trail, world, radius_mm):
            last = out[-1]
            out[-1] = Contact(
                last.time_s,
                last.pose,
                max(last.speed_mm_s, impact.speed_mm_s),
                last.impacts + 1,
                impact.time_s - offset_s,
            )
            continue
        t = impact.time_s - offset_s
        out.append(Contact(t, impact.pose, impact.speed_mm_s, 1, t))
    return out


def _drew_clear(
    since_s: float, impact: Impact, trail: list[tuple[float, Pose]], world: World, radius_mm: float
) -> bool:
    """Whether the body was ``CONTACT_CLEAR_MM`` clear of everything at a moment from ``since_s`` to ``impact``."""
    points = [p for t, p in trail if since_s <= t <= impact.time_s] + [impact.pose]
    clear = radius_mm + CONTACT_CLEAR_MM
    for a, b in pairwise(points):
        length = math.hypot(b.x_mm - a.x_mm, b.y_mm - a.y_mm)
        steps = max(1, math.ceil(length / _CLEAR_STEP_MM))
        for k in range(steps + 1):
            f = k / steps
            if world.clearance(a.x_mm + (b.x_mm - a.x_mm) * f, a.y_mm + (b.y_mm - a.y_mm) * f) > clear:
                return True
    return False


def path_points(facts: RunFacts, most: int = 400) -> list[tuple[float, float]]:
    """The true path as at most ``most`` points (x_mm, y_mm), rounded to 1 mm, the last always kept."""
    poses = [p for _, p in facts.path]
    step = max(1, math.ceil(len(poses) / most))
    kept = poses[::step]
    if poses and kept[-1] is not poses[-1]:
        kept.append(poses[-1])
    return [(round(p.x_mm), round(p.y_mm)) for p in kept]

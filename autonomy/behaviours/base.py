"""What every leaf behaviour builds on, built-in or written in a plugin.

A leaf is a py_trees behaviour, with its lifecycle as the contract: ``__init__`` only
configures (no I/O), ``setup(robot=...)`` receives the :class:`RobotContext`,
``initialise()`` starts work, ``update()`` returns at once, ``terminate()`` cleans up.

A leaf class declares what a mission file may pass it, and the validator, the catalogue
(``autonomy behaviours``), the JSON Schema and docs/missions.md all read that declaration::

    class SpinUntilClear(RobotAction):
        node_type = "spin_until_clear"
        doc = "Turn left in steps until nothing is closer than mm."
        params = (Param("mm", "int", "clearance to wait for", unit="mm", required=True, minimum=1, maximum=255),)

        def update(self) -> Status:
            if self.robot_status.front_distance_mm >= self.args["mm"]:
                return Status.SUCCESS
            self.send(lambda: self.client.turn(15))
            return Status.RUNNING

Actions reach the robot through ``self.client``; conditions only read ``self.robot_status``,
the status packet the runner polled before this tick (the same snapshot for every node).
"""

from __future__ import annotations

import random
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, ClassVar, TypeVar

import py_trees
from py_trees.common import Access, Status

from autonomy.client import Client
from autonomy.clock import Clock
from autonomy.errors import CommandRefused
from autonomy.protocol import Status as Packet

#: Blackboard keys the runner writes before every tick.
STATUS_KEY = "/robot/status"
BATTERY_KEY = "/robot/battery"
HEALTHY_KEY = "/robot/healthy"
ROBOT_KEYS = (STATUS_KEY, BATTERY_KEY, HEALTHY_KEY)

#: The longest duration a node takes (an hour) and the longest drive (100 m).
MAX_SECONDS = 3600
#: Why a distance the front sensor is to read is at most 255 mm (a Param's ``range_why``).
SENSOR_REACH = "the front sensor reads at most 255 mm"
MAX_DISTANCE_MM = 100_000
#: Largest size of any number in a mission, for parameters that declare no maximum of their own.
MAX_NUMBER = 1_000_000_000

#: Parameter kinds a node type may declare.
KINDS = ("int", "number", "bool", "string", "choice", "tones", "node", "nodes")


@dataclass(frozen=True)
class Param:
    """One parameter a node type takes, as a mission file writes it.

    Attributes:
        name: The key in the mission file.
        kind: One of :data:`KINDS`: ``int``, ``number`` (int or float), ``bool``,
            ``string``, ``choice`` (one of ``choices``), ``tones`` (three tones 1-9),
            ``node`` (one child node), ``nodes`` (a list of child nodes).
        doc: One line for the catalogue and the docs.
        unit: The unit, when it has one (``mm``, ``deg``, ``s``).
        required: Whether the node needs it.
        default: The value when it is left out.
        minimum: Smallest value allowed (numbers).
        maximum: Largest value allowed (numbers).
        positive: The value must be above zero (for durations).
        choices: The values a ``choice`` takes.
        example: A value to show in hints and docs.
        range_why: Why the range is what it is, said with a value out of it (``the front sensor
            reads at most 255 mm``).
    """

    name: str
    kind: str
    doc: str
    unit: str = ""
    required: bool = False
    default: Any = None
    minimum: float | None = None
    maximum: float | None = None
    positive: bool = False
    choices: tuple[str, ...] = ()
    example: Any = None
    range_why: str = ""

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"parameter {self.name}: kind must be one of {KINDS}, got {self.kind!r}")

    def sample(self) -> str:
        """A value to show in hints and docs: ``example``, else one made from the kind and range."""
        if self.example is not None:
            return str(self.example)
        if self.kind in ("int", "number"):
            return _num(self.minimum if self.minimum is not None else 1)
        if self.kind == "choice" and self.choices:
            return self.choices[0]
        return "true" if self.kind == "bool" else "..."

    def describe_range(self) -> str:
        """The allowed values in words, e.g. ``1..4`` or ``forward | backward``."""
        if self.kind == "choice":
            return " | ".join(self.choices)
        if self.kind == "tones":
            return "[t1, t2, t3], each 1..9"
        if self.minimum is not None and self.maximum is not None:
            return f"{_num(self.minimum, ',')}..{_num(self.maximum, ',')}"
        if self.positive:
            return f"above 0, at most {_num(self.maximum, ',')}" if self.maximum is not None else "> 0"
        if self.minimum is not None:
            return f">= {_num(self.minimum)}"
        return ""


def _num(value: float, thousands: str = "") -> str:
    return f"{int(value):{thousands}}" if float(value).is_integer() else str(value)


@dataclass
class RobotContext:
    """What a run gives its behaviours: the robot link, the clock, and a place to log.

    Attributes:
        client: The open client.
        clock: The run's clock (real or virtual).
        log: Called with a message for the person watching (the ``log`` node, events).
        turn_rate_deg_s: Expected turn-in-place rate, for turn time-outs.
        motion_owner: The action whose motion command the robot is carrying out, if any.
        polled: The values polled before this tick (status packet, battery, health), as the
            runner also puts them on the blackboard: read here, they cost a leaf no blackboard
            look-up (None when no runner polls, and the blackboard is read instead).
        rebased: True when this tick's packet replaced a believed state that was wrong (see
            :class:`~autonomy.client.StatusGuard`): the step from the last tick's packet is
            not a motion, and the wrong-way checks leave it out.
        seed: The run's seed (the emulator's; 0 on a robot): what random choices are drawn from.
        watched: Whether anybody reads the nodes' feedback while they run (the live views,
            a trace). A run that records no node states (a grader's) sets it False, and a
            node may then leave out the feedback it would say tick after tick while RUNNING (a
            countdown, the distance so far): it is formatted for nobody. A node that ends
            still says why.
    """

    client: Client
    clock: Clock
    log: Callable[[str], None] = field(default=lambda message: None)
    turn_rate_deg_s: float = 90.0
    motion_owner: object | None = None
    polled: tuple[Packet, int, bool] | None = None
    rebased: bool = False
    watched: bool = True
    seed: int = 0
    _randoms: int = 0

    def random_for(self, name: str) -> random.Random:
        """A generator of random picks for the run's next random node: its seed, the run's and the node's place.

        Nodes are set up in the tree's order, once a run, so each random node of a run draws from the same
        generator on every run with the same seed, whatever the others draw.
        """
        self._randoms += 1
        return random.Random(f"random {self.seed} {self._randoms} {name}")


_Update = TypeVar("_Update", bound=Callable[..., Status])


def returns_status(update: _Update) -> _Update:
    """Marks an ``update`` that returns a :class:`Status` on every path (the node types' own).

    Every other ``update`` a subclass defines is wrapped to check what it returns; one marked
    so is not, which spares every tick of the node a call.
    """
    update._checked = True  # type: ignore[attr-defined]
    return update


class NoStatus(TypeError):
    """An ``update`` returned something other than a :class:`Status` (a plugin's ``return`` forgotten).

    Attributes:
        where: ``FILE:LINE`` of that ``update``, which a crash report names rather than the check's.
    """

    def __init__(self, message: str, where: str) -> None:
        super().__init__(message)
        self.where = where


class RobotBehaviour(py_trees.behaviour.Behaviour):
    """Base of every leaf: declares its node type and parameters, reaches the robot.

    Args:
        name: The node's display name.
        **args: The validated parameters, as declared in :attr:`params` (defaults filled).
    """

    #: The node type's name in mission files (empty: not a node type of its own).
    node_type: ClassVar[str] = ""
    #: One line for the catalogue and the docs.
    doc: ClassVar[str] = ""
    #: The parameters the node type takes.
    params: ClassVar[tuple[Param, ...]] = ()
    #: Groups of parameters of which exactly one must be given, e.g. (("left", "right"),).
    exactly_one_of: ClassVar[tuple[tuple[str, ...], ...]] = ()
    #: "action" or "condition".
    category: ClassVar[str] = "action"
    #: The statuses the node can return (what a mission's tests can cover: ``autonomy test``).
    statuses: ClassVar[tuple[str, ...]] = ("SUCCESS", "FAILURE", "RUNNING")

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Checks what every ``update`` of a subclass returns (py_trees would only log it and go on)."""
        super().__init_subclass__(**kwargs)
        update = cls.__dict__.get("update")
        if update is not None and not getattr(update, "_checked", False):
            code = getattr(update, "__code__", None)
            where = f"{code.co_filename}:{code.co_firstlineno}" if code is not None else ""

            def checked(self: RobotBehaviour) -> Status:
                status = update(self)
                if not isinstance(status, Status):
                    raise NoStatus(
                        f"update() returned {status!r}; it must return Status.RUNNING, SUCCESS or FAILURE", where
                    )
                return status

            checked._checked = True  # type: ignore[attr-defined]
            checked.__doc__, checked.__name__, checked.__qualname__ = update.__doc__, "update", update.__qualname__
            cls.update = checked  # type: ignore[method-assign]

    def __init__(self, name: str, **args: Any) -> None:
        super().__init__(name)
        self.args = args
        self.robot: RobotContext | None = None
        self.blackboard = self.attach_blackboard_client(name=name)
        for key in ROBOT_KEYS:
            self.blackboard.register_key(key=key, access=Access.READ)

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        """py_trees' own leaf tick, step for step, without its debug-log lines.

        As :meth:`py_trees.behaviour.Behaviour.tick`: :meth:`initialise` unless RUNNING, then
        :meth:`update`; a result other than RUNNING stops the node; a result that is not a
        status is logged and taken as INVALID. py_trees formats its debug lines (and lists
        every status) whether or not they are logged, which cost a tenth of a run.

        Yields:
            The node itself, once ticked.
        """
        if self.status is not Status.RUNNING:
            self.initialise()
        new_status = self.update()
        if type(new_status) is not Status:
            self.logger.error(f"A behaviour returned an invalid status, setting to INVALID [{new_status}][{self.name}]")
            new_status = Status.INVALID
        if new_status is not Status.RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self

    def stop(self, new_status: Status) -> None:
        """py_trees' own :meth:`py_trees.behaviour.Behaviour.stop`, without its debug-log line."""
        self.terminate(new_status)
        self.status = new_status
        self.iterator = self.tick()

    def setup(self, **kwargs: Any) -> None:
        """Takes the run's :class:`RobotContext` (keyword ``robot``)."""
        robot = kwargs.get("robot")
        if not isinstance(robot, RobotContext):
            raise TypeError(f"{self.name}: setup() needs robot=RobotContext(...)")
        self.robot = robot

    @property
    def context(self) -> RobotContext:
        """The run's context, as :meth:`setup` received it.

        Raises:
            RuntimeError: the node was ticked without being set up.
        """
        if self.robot is None:
            raise RuntimeError(f"node '{self.name}' was not set up: call setup(robot=RobotContext(...)) first")
        return self.robot

    @property
    def client(self) -> Client:
        """The robot link."""
        return self.context.client

    @property
    def clock(self) -> Clock:
        """The run's clock."""
        return self.context.clock

    def _polled(self, index: int) -> Any:
        """One of the values polled before this tick: from the run's context, else the blackboard."""
        polled = self.robot.polled if self.robot is not None else None
        return polled[index] if polled is not None else self.blackboard.get(ROBOT_KEYS[index])

    @property
    def robot_status(self) -> Packet:
        """The status packet polled before this tick."""
        robot = self.robot  # read several times a tick: the context's value at once, when it has one
        return robot.polled[0] if robot is not None and robot.polled is not None else self._polled(0)

    @property
    def battery(self) -> int:
        """The battery level, polled about once a second."""
        return self._polled(1)

    @property
    def healthy(self) -> bool:
        """The ``GR`` reply, polled about once a second."""
        return self._polled(2)

    def send(self, request: Callable[[], object]) -> bool:
        """Runs one client request; a ``NO`` becomes False and the feedback message.

        Link errors (time-outs, a lost link) are not caught: they end the run.
        """
        try:
            request()
        except CommandRefused as err:
            self.feedback_message = f"{err}; {err.hint}"
            return False
        return True


class RobotAction(RobotBehaviour):
    """An action: it may send commands. One that starts a motion stops it when halted.

    Subclasses call :meth:`started_motion` after a motion command was accepted and
    :meth:`stop_motion` when they end it themselves. If the node is halted (preempted,
    timed out, the mission ends) while the robot is still carrying out *its* motion, ``X``
    is sent. If another node has started a motion since, nothing is sent: the robot
    already replaced this node's motion with the newer one, and a stop would cancel it
    (a selector halts the preempted child after ticking the one that preempts it).
    """

    category: ClassVar[str] = "action"

    def started_motion(self) -> None:
        """Marks that the robot is carrying out this node's motion."""
        self.context.motion_owner = self

    def owns_motion(self) -> bool:
        """True while the robot carries out this node's motion."""
        return self.robot is not None and self.robot.motion_owner is self

    def release_motion(self) -> None:
        """Marks that this node's motion has ended (without sending anything)."""
        if self.owns_motion():
            self.context.motion_owner = None

    def stop_motion(self) -> bool:
        """Sends ``X`` now (in this tick); returns whether the robot accepted it."""
        self.release_motion()
        return self.send(self.client.stop)

    def terminate(self, new_status: Status) -> None:
        """Stops the robot when halted while it still carries out this node's motion."""
        if self.owns_motion():
            self.release_motion()
            try:
                self.client.stop()
            except Exception as err:  # noqa: BLE001 - terminate must not raise; the runner stops again
                self.feedback_message = f"could not stop: {err}"


class RobotCondition(RobotBehaviour):
    """A condition: SUCCESS when :meth:`check` holds on the polled status, else FAILURE."""

    category: ClassVar[str] = "condition"
    statuses: ClassVar[tuple[str, ...]] = ("SUCCESS", "FAILURE")

    def check(self) -> bool:
        """Returns whether the condition holds; reads only the polled values."""
        raise NotImplementedError

    def describe(self) -> str:
        """The values the condition looked at, for the feedback message."""
        return ""

    @returns_status
    def update(self) -> Status:
        """SUCCESS or FAILURE, at once."""
        holds = self.check()
        self.feedback_message = self.describe()
        return Status.SUCCESS if holds else Status.FAILURE

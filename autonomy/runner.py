"""Ticks a mission's tree against the robot, produces its tick records, guarantees the final stop.

Before every tick the runner polls the status packet once (``Gb000``) and puts it on the
py_trees blackboard, so every node of the tick sees the same snapshot; battery and health
are polled about once a second. Whatever way the run ends (success, failure, Ctrl-C,
SIGTERM, an exception, a lost link) the running nodes are halted and ``X`` is sent until
it is acknowledged or the link is gone.

The runner is the producer of the run's records (:mod:`autonomy.record`): a header when
the run starts, a :class:`~autonomy.record.TickRecord` after every tick, a
:class:`~autonomy.record.RunEnd` at the end. Its listeners (the trace writer, the views)
never reach back into it.
"""

from __future__ import annotations

import contextlib
import gc
import math
import os
import signal
import traceback
from collections import Counter
from collections.abc import Iterable, Iterator
from dataclasses import asdict, dataclass, field
from types import TracebackType
from typing import cast

import py_trees
from py_trees.blackboard import Blackboard
from py_trees.common import Access, Status

import autonomy
from autonomy.behaviours import BATTERY_KEY, HEALTHY_KEY, STATUS_KEY, RobotContext, engine
from autonomy.behaviours.base import NoStatus
from autonomy.behaviours.engine import tick_tree
from autonomy.behaviours.tree import describe_tree, preorder
from autonomy.client import Client
from autonomy.clock import wall_date
from autonomy.errors import AutonomyError, LinkError
from autonomy.mission import MissionSpec, build_tree
from autonomy.protocol import Reply, heading_delta_deg, odometer_delta_mm
from autonomy.protocol import Status as Packet
from autonomy.record import (
    Event,
    Exchange,
    Listener,
    NodeState,
    Pose,
    Record,
    RunEnd,
    RunHeader,
    TickRecord,
)
from autonomy.words import plural

#: How often battery and health are polled.
SLOW_POLL_S = 1.0

SUCCEEDED = "succeeded"
FAILED = "failed"
TIME_LIMIT = "stopped at the time limit"
INTERRUPTED = "interrupted"
LINK_LOST = "lost the link"
CRASHED = "stopped by an error"

_COMMAND_NAMES = {"F": "move", "T": "turn", "S": "beep", "M": "servo move", "D": "servo step", "X": "stop"}
#: Where dead reckoning starts when the start pose is not known (a real robot).
_ORIGIN = Pose(0.0, 0.0, 0.0)
_LIBRARY_DIRS = tuple(os.path.dirname(m.__file__ or "") + os.sep for m in (autonomy, py_trees))


def _short_path(filename: str) -> str:
    """A file's path relative to the working directory when it is under it, else as it is."""
    here = os.getcwd() + os.sep
    return filename[len(here) :] if filename.startswith(here) else filename


@dataclass
class RunSummary:
    """How a run went.

    ``commands`` counts the commands the mission meant to send (one per request, whatever
    the reply); ``retries`` counts the extra attempts the link made apart.
    """

    mission: str
    outcome: str
    ticks: int = 0
    time_s: float = 0.0
    tick_hz: float = 20.0
    distance_mm: int = 0
    turned_deg: float = 0.0
    collisions: int = 0
    commands: Counter = field(default_factory=Counter)
    stopped: bool = False
    reason: str = ""
    requests: int = 0
    retries: int = 0
    refused: int = 0
    framing_errors: int = 0
    implausible: int = 0

    def to_json(self) -> dict:
        """The counts as plain JSON."""
        out = asdict(self)
        out["commands"] = dict(sorted(self.commands.items()))
        return out

    @property
    def paragraph(self) -> str:
        """The run in a few sentences, for the person who started it."""
        head = f"Mission '{self.mission}' {self.outcome} after {self.time_s:.1f} s "
        head += f"({plural(self.ticks, 'tick')} at {self.tick_hz:g} Hz)"
        head += f": {self.reason}." if self.reason else "."
        motion = {c: n for c, n in self.commands.items() if c in _COMMAND_NAMES and c != "X"}
        sent = [plural(n, _COMMAND_NAMES[c]) for c, n in sorted(motion.items())]
        collisions = {0: "no collisions", 1: "1 collision"}.get(self.collisions, f"{self.collisions} collisions")
        body = (
            f" The robot drove {self.distance_mm / 1000:.2f} m and turned {self.turned_deg:.0f} degrees, "
            f"with {collisions}; it was sent {', '.join(sent) if sent else 'no motion commands'}."
        )
        end = " It was stopped at the end." if self.stopped else " The stop could NOT be confirmed: check the robot."
        link = (
            f" Link: {plural(self.requests, 'request')}, {plural(self.retries, 'retry', 'retries')}, "
            f"{self.refused} refused, {plural(self.framing_errors, 'framing error')}"
            + (f", {plural(self.implausible, 'implausible status packet')} ignored." if self.implausible else ".")
        )
        return head + body + end + link


class BehaviourCrashed(AutonomyError):
    """A behaviour raised an exception; :attr:`event` names the node, its file and line.

    Attributes:
        event: The ``exception`` event, as the trace records it.
    """

    def __init__(self, event: Event) -> None:
        super().__init__(event.message)
        self.event = event


@contextlib.contextmanager
def settled_heap() -> Iterator[None]:
    """For a process's one run (the command line's): what exists before it is left out of collections.

    Python's garbage collector looks again and again at every object there is as a listener
    keeps the run's records (the browser view keeps them all); the modules, the tree and a
    view's server stay to the end, so what is garbage is collected first and the rest frozen
    out of later collections (``gc.freeze``) until the block ends. The browser view then costs
    a tick about a quarter of what it did. Not for a process that runs one mission after another
    (grading runs several a worker): what a run left as garbage would be frozen with the rest.
    """
    gc.collect()
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


#: Most characters kept of a behaviour's text (feedback, a log message, an exception's): the views
#: show a line of it, and one text of megabytes a tick would make a trace no reader takes.
MAX_TEXT_CHARS = 1000
#: Most characters kept of an exception's whole traceback (its end: the innermost frames).
MAX_TRACEBACK_CHARS = 20_000


def plain_text(value: object) -> str:
    """``value`` as plain text: a behaviour's own text type (a str subclass, a number...) made a str."""
    text = value if isinstance(value, str) else str(value)
    return text if type(text) is str else str.__str__(text)  # a copy of exactly str, whatever __str__ says


def feedback_text(value: object) -> str:
    """A node's feedback as plain text (``""`` for none); never raises.

    A behaviour's own feedback object whose text cannot be had (its ``__str__`` raises) is
    named instead: a run is not ended by what would only be shown, whether or not anybody
    looks at its nodes (a grader does not).
    """
    try:
        return plain_text(value) if value else ""
    except Exception as err:  # noqa: BLE001 - any failure of a behaviour's own type to be text
        return f"(a {type(value).__name__} that cannot be shown as text: {type(err).__name__})"


def clipped(text: str, most: int = MAX_TEXT_CHARS) -> str:
    """``text``, or its first ``most`` characters ending with ``…``."""
    return text if len(text) <= most else text[: most - 1] + "…"


def traceback_text(err: BaseException) -> str:
    """``err``'s traceback as Python prints it, short enough for a trace's line.

    Past :data:`MAX_TRACEBACK_CHARS`: its innermost frames and its message clipped, so that an
    exception's own text of megabytes leaves its frames in.
    """
    whole = "".join(traceback.format_exception(err))
    if len(whole) <= MAX_TRACEBACK_CHARS:
        return whole
    frames = "".join(traceback.format_tb(err.__traceback__))
    frames = frames[-(MAX_TRACEBACK_CHARS - MAX_TEXT_CHARS - 100) :]
    return f"Traceback (its innermost frames):\n…{frames}{clipped(f'{type(err).__name__}: {err}')}\n"


#: The most exchanges a runner keeps to hand out again (errors' texts may all differ).
MOST_EXCHANGES_KEPT = 1024


def _reply_text(outcome: Reply | AutonomyError) -> str:
    if isinstance(outcome, AutonomyError):
        return f"error: {outcome}"
    if isinstance(outcome, Packet):
        return "status"
    return outcome.encode().decode("ascii").strip()  # OK, NO or a value: ASCII by the decoder's checks


class Runner:
    """Runs one tree on one robot, handing its records to listeners.

    Args:
        root: The tree's root (built, not yet set up).
        client: An open client.
        mission: The mission's name, for the summary.
        mission_file: The mission file, for the header.
        mission_sha256: The SHA-256 of the mission file's text, for the header.
        tick_hz: Ticks per second.
        max_seconds: Stop the run after this long (None: no limit).
        listeners: Receive every record (header, ticks, end), in order.
        node_states: Whether tick records say which nodes' status or feedback changed. A grader,
            which judges poses, the wire and events, leaves them out: finding them looks at every
            node, every tick (some 7% of a tick). Without them, nodes leave out the feedback
            they would say while RUNNING (:attr:`RobotContext.watched`).
        tips: Whether to keep :attr:`tips`, which node was running when: the grader's account of
            which node lost a mark (a few attribute reads a tick).
    """

    def __init__(
        self,
        root: py_trees.behaviour.Behaviour,
        client: Client,
        *,
        mission: str = "mission",
        mission_file: str = "",
        mission_sha256: str = "",
        tick_hz: float = 20.0,
        max_seconds: float | None = None,
        listeners: Iterable[Listener] = (),
        node_states: bool = True,
        tips: bool = False,
    ) -> None:
        self.root = root
        #: With ``tips``: each time the tree's tip (the deepest node it ticked last, a running one while
        #: the mission runs) changed, (the tick's time since the run started, s; the node's id), in order.
        self.tips: list[tuple[float, int]] | None = [] if tips else None
        self.client = client
        self.clock = client.clock
        self.tick_hz = tick_hz
        self.max_seconds = max_seconds
        self.listeners: list[Listener] = list(listeners)
        self.node_states = node_states
        self.mission_file = mission_file
        self.mission_sha256 = mission_sha256
        self.summary = RunSummary(mission, FAILED, tick_hz=tick_hz)
        self.header: RunHeader | None = None
        self.end: RunEnd | None = None
        self._events: list[Event] = []
        self._wire: list[Exchange] = []
        self._exchanges: dict[tuple[bytes, str, int], Exchange] = {}
        self._blackboard = py_trees.blackboard.Client()
        for key in (STATUS_KEY, BATTERY_KEY, HEALTHY_KEY):
            self._blackboard.register_key(key=key, access=Access.WRITE)
        self._nodes = list(preorder(root))
        self._ids = {id(node): index for index, node in enumerate(self._nodes)}
        self._statuses: list[Status] = [Status.INVALID] * len(self._nodes)
        self._feedbacks: list[str] = [""] * len(self._nodes)
        self._emulator = getattr(client.port, "emulator", None)
        self._last: Packet | None = None
        self._last_time_s: float  # set with _last
        self._pose = _ORIGIN
        self._start_s = self.clock.now()  # again once set up: a run whose setup fails lasted no time
        # Set up first thing: the client's counts when the run starts; polled each tick: battery and health.
        self._framing_before: int
        self._implausible_before: int
        self._rebased: int
        self._last_slow_s = -float("inf")
        self._battery: int
        self._healthy: bool
        self._stop_reason = ""
        self.context = RobotContext(client, self.clock, log=self._log, watched=node_states)

    # ------------------------------------------------------------------ events

    def _emit(self, record: Record) -> None:
        for listener in self.listeners:
            listener(record)

    def _log(self, message: str, kind: str = "log") -> None:
        self._events.append(Event(kind, clipped(plain_text(message))))

    def _on_exchange(self, frame: bytes, outcome: Reply | AutonomyError, attempt: int) -> None:
        reply = _reply_text(outcome)
        exchange = self._exchanges.get((frame, reply, attempt))
        if exchange is None:  # exchanges are values: a run repeats the same few, the status poll every tick
            exchange = Exchange(frame[:-1].decode("ascii"), reply, attempt)  # a frame we encoded: ASCII
            if len(self._exchanges) < MOST_EXCHANGES_KEPT:
                self._exchanges[frame, reply, attempt] = exchange
        self._wire.append(exchange)
        sent = exchange.sent
        if attempt:
            self.summary.retries += 1
            return
        self.summary.requests += 1
        if sent[:1] != "G":
            self.summary.commands[sent[:1]] += 1
        if reply == "NO":
            self.summary.refused += 1

    def _observe(self, status: Packet, time_s: float) -> float:
        """Counts distance, turns and collisions; moves the dead-reckoned pose. Returns the speed."""
        last = self._last
        speed_mm_s = 0.0
        rebased, self._rebased = self._rebased, self.client.stats.rebased
        first = last is None
        self.context.rebased = rebased != self._rebased
        if last is not None and self.context.rebased:  # the robot's odometer or heading started anew
            self._log(
                "two status packets in a row disagreed with the one believed before: counting from them", "warning"
            )
            last = None
        if last is None:
            self._pose = Pose(self._pose.x_mm, self._pose.y_mm, float(status.heading_deg))
            if status.collided and first:
                self.summary.collisions += 1
        else:
            moved_mm = odometer_delta_mm(last.odometer_mm, status.odometer_mm)
            turned_deg = heading_delta_deg(last.heading_deg, status.heading_deg)
            self.summary.distance_mm += abs(moved_mm)
            self.summary.turned_deg += abs(turned_deg)
            mid_rad = math.radians(last.heading_deg + turned_deg / 2)
            self._pose = Pose(
                self._pose.x_mm + moved_mm * math.cos(mid_rad),
                self._pose.y_mm + moved_mm * math.sin(mid_rad),
                float(status.heading_deg),
            )
            if time_s > self._last_time_s:
                speed_mm_s = moved_mm / (time_s - self._last_time_s)
            if status.collided and not last.collided:
                self.summary.collisions += 1
                self._log(
                    f"collision (front sensor {status.front_distance_mm} mm, heading {status.heading_deg} deg)",
                    "collision",
                )
        self._last, self._last_time_s = status, time_s
        return speed_mm_s

    # ------------------------------------------------------------------ running

    def run(self) -> RunSummary:
        """Runs until the tree succeeds or fails, the time limit, Ctrl-C or an error.

        Never raises for the ways a run ends; the summary's ``outcome`` and ``reason``
        say what happened. The robot is stopped in every case.
        """
        summary = self.summary
        try:
            self.setup()
            summary.outcome = self._loop()
        except KeyboardInterrupt:
            summary.outcome = INTERRUPTED
            summary.reason = "Ctrl-C or SIGTERM"
        except LinkError as err:
            summary.outcome = LINK_LOST
            summary.reason = str(err)
        except BehaviourCrashed as err:
            summary.outcome = CRASHED
            summary.reason = err.event.message
            self._events.append(err.event)
        except (Exception, SystemExit) as err:  # noqa: BLE001 - a bug anywhere must still end in a stopped robot
            summary.outcome = CRASHED
            summary.reason = clipped(f"{type(err).__name__}: {err}")
            self._events.append(Event("exception", summary.reason, traceback=traceback_text(err)))
        finally:
            summary.time_s = self.clock.now() - self._start_s
            self._halt()
            summary.stopped = self._final_stop()
            if self._on_exchange in self.client.listeners:
                self.client.listeners.remove(self._on_exchange)
            summary.framing_errors = self.client.stats.framing_errors - self._framing_before
            summary.implausible = self.client.stats.implausible - self._implausible_before
            self._finish()
        return summary

    @classmethod
    def for_mission(
        cls,
        spec: MissionSpec,
        client: Client,
        *,
        max_seconds: float | None = None,
        listeners: Iterable[Listener] = (),
        node_states: bool = True,
        tips: bool = False,
    ) -> Runner:
        """A runner for a validated mission: its tree built, its name, file, hash and tick rate passed on."""
        return cls(
            build_tree(spec),
            client,
            mission=spec.name,
            mission_file=spec.source,
            mission_sha256=spec.sha256,
            tick_hz=spec.tick_hz,
            max_seconds=max_seconds,
            listeners=listeners,
            node_states=node_states,
            tips=tips,
        )

    def setup(self) -> None:
        """Hands every node the run's context, starts the clock, sends the header; :meth:`run` calls it."""
        self.client.listeners.append(self._on_exchange)
        self._framing_before = self.client.stats.framing_errors
        self._implausible_before = self.client.stats.implausible
        self._rebased = self.client.stats.rebased
        self.context.seed = int(getattr(self._emulator, "seed", 0) or 0)  # what random choices are drawn from
        for node in self.root.iterate():
            node.setup(robot=self.context)
        self._start_s = self.clock.now()
        emulator = self._emulator
        world = emulator.world.as_dict() if emulator is not None else None
        if world is not None:
            start = world["start"]
            self._pose = Pose(float(start["x_mm"]), float(start["y_mm"]), float(start["heading_deg"]))
        self.header = RunHeader(
            mission=self.summary.mission,
            nodes=describe_tree(self.root),
            tick_hz=self.tick_hz,
            mission_file=self.mission_file,
            mission_sha256=self.mission_sha256,
            world=world,
            seed=emulator.seed if emulator is not None else None,
            faults=str(emulator.faults) if emulator is not None else "",
            port=self.client.name,
            baud=int(getattr(self.client.port, "baudrate", 0) or 0),
            clock="virtual" if self.clock.is_virtual else "real",
            autonomy_version=autonomy.__version__,
            date=wall_date(),
        )
        self._emit(self.header)

    def tick(self) -> Status:
        """One tick: poll the status (battery and health about once a second), tick the tree.

        Returns:
            The root's status after the tick.

        Raises:
            BehaviourCrashed: a behaviour raised (the event names the node).
            LinkError: the link failed.
            RuntimeError: :meth:`setup` has not run (:meth:`run` calls both).
        """
        if self.header is None:
            raise RuntimeError("Runner.tick() before Runner.setup(): call setup() first (run() does both)")
        now = self.clock.now()
        status = self.client.status()
        polled_s = self.clock.now()
        if now - self._last_slow_s >= SLOW_POLL_S:
            self._battery, self._healthy = self.client.battery(), self.client.healthy()
            self._last_slow_s = now
            self._blackboard.set(BATTERY_KEY, self._battery)  # these two change only when polled
            self._blackboard.set(HEALTHY_KEY, self._healthy)
        if Blackboard.activity_stream is None:  # what set() comes down to when nobody records activity
            Blackboard.storage[STATUS_KEY] = status
        else:
            self._blackboard.set(STATUS_KEY, status)
        self.context.polled = (status, self._battery, self._healthy)
        time_s = now - self._start_s
        # The packet is as of when it came, which retries over a lossy link make later than the tick's start.
        speed_mm_s = self._observe(status, polled_s - self._start_s)
        try:
            tick_tree(self.root)
        except LinkError:
            raise
        except (Exception, SystemExit) as err:  # a plugin's sys.exit() ends the run as an error, not the program
            raise BehaviourCrashed(self._crash_event(err)) from err
        except KeyboardInterrupt as err:
            if type(err) is KeyboardInterrupt and signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
                raise BehaviourCrashed(self._crash_event(err)) from err  # raised by a behaviour, not by Ctrl-C
            raise
        self.summary.ticks += 1
        tips = self.tips
        if tips is not None:
            tip = self.root.tip()
            index = self._ids.get(id(tip), 0) if tip is not None else 0
            if not tips or tips[-1][1] != index:
                tips.append((time_s, index))
        # the wire and events are taken last: should anything before fail, the end record has them
        truth, nodes = self._truth(), self._changes() if self.node_states else {}
        record = TickRecord(  # in its fields' order: keywords cost a tick's record twice as much to make
            self.summary.ticks,  # tick
            time_s,
            status,
            self._battery,
            self._healthy,
            speed_mm_s,
            self._pose,  # dead_reckoning
            truth,
            nodes,
            self._take_wire(),
            self._take_events(),
        )
        self._emit(record)
        return self.root.status

    def _truth(self) -> Pose | None:
        if self._emulator is None:
            return None
        return Pose._make(self._emulator.pose())  # the emulator's own pose, the same three fields

    def request_stop(self, reason: str) -> None:
        """Ends the run after the current tick, as interrupted, for ``reason`` (thread-safe)."""
        self._stop_reason = reason or "stop requested"

    def _take_wire(self) -> list[Exchange]:
        wire, self._wire = self._wire, []
        return wire

    def _take_events(self) -> list[Event]:
        events, self._events = self._events, []
        return events

    def _changes(self) -> dict[int, NodeState]:
        """The nodes whose status or feedback differ from the last tick's.

        Every node is looked at: a halted node turns INVALID without being ticked.
        """
        changes: dict[int, NodeState] = {}
        statuses, feedbacks = self._statuses, self._feedbacks
        for index, node in enumerate(self._nodes):
            status, feedback = node.status, node.feedback_message
            if status is not statuses[index] or feedback != feedbacks[index]:
                statuses[index], feedbacks[index] = status, feedback
                # the common case, a plain str, without the calls (a node that counts down says something every tick)
                text = feedback if type(feedback) is str else feedback_text(feedback)
                changes[index] = NodeState(status._value_, text if len(text) <= MAX_TEXT_CHARS else clipped(text))
        return changes

    def _loop(self) -> str:
        period_s = 1.0 / self.tick_hz
        next_tick_s = self._start_s
        while True:
            status = self.tick()
            if status == Status.SUCCESS:
                return SUCCEEDED
            if status == Status.FAILURE:
                self.summary.reason = self._why_failed()
                return FAILED
            if self._stop_reason:
                self.summary.reason = self._stop_reason
                return INTERRUPTED
            now_s = self.clock.now()
            if self.max_seconds is not None and now_s - self._start_s >= self.max_seconds:
                self.summary.reason = f"the mission was still running after {self.max_seconds:g} s"
                return TIME_LIMIT
            next_tick_s += period_s
            wake_s = next_tick_s
            if self.max_seconds is not None and (end_s := self._start_s + self.max_seconds) < wake_s:
                wake_s = end_s
            delay_s = wake_s - now_s  # nothing ran since now_s was read
            if delay_s > 0:
                self.clock.sleep(delay_s)
            else:
                next_tick_s = self.clock.now()  # behind: do not try to catch up in a burst

    def _finish(self) -> None:
        if self.header is None:  # setup itself failed: still say how the run began
            self.header = RunHeader(self.summary.mission, describe_tree(self.root), self.tick_hz)
            self._emit(self.header)
        summary = self.summary
        self.end = RunEnd(
            outcome=summary.outcome,
            reason=summary.reason,
            stopped=summary.stopped,
            time_s=summary.time_s,
            summary=summary.to_json(),
            paragraph=summary.paragraph,
            wire=self._take_wire(),
            events=self._take_events(),
            truth=self._truth(),
        )
        self._emit(self.end)

    def _crash_event(self, err: BaseException) -> Event:
        """Names the node whose code raised (the innermost on the stack), its file and line, and the last frames.

        The root's own tick is always on the stack, so some node is always named.
        """
        node = self.root  # pragma: no mutate - the root's tick is on the stack, so this is always replaced
        tb: TracebackType | None = err.__traceback__
        while tb is not None:  # a node's own methods have it as self, the tick engine's steps as node
            frame = tb.tb_frame
            candidate = frame.f_locals.get("self")
            if candidate is None and frame.f_code.co_filename == engine.__file__:
                candidate = frame.f_locals.get("node")  # only the engine's: elsewhere a "node" may be any node
            if candidate is not None and id(candidate) in self._ids:
                node = candidate
            tb = tb.tb_next
        frames = traceback.extract_tb(err.__traceback__)
        # A crash in the package's own code has no frames of its own: all are shown then. (Under mutation
        # testing the mutation tool's frames are on every stack, so the fallback cannot be told apart.)
        own = [f for f in frames if not f.filename.startswith(_LIBRARY_DIRS)] or list(frames)  # pragma: no mutate
        lines = tuple(f"{_short_path(f.filename)}:{f.lineno} in {f.name}: {(f.line or '').strip()}" for f in own[-3:])
        if isinstance(err, NoStatus) and err.where:  # the update that returned no status, not the check that saw it
            lines = (f"{_short_path(err.where)} in update",)
        error = clipped(f"{type(err).__name__}: {err}")
        full = traceback_text(err)
        node_id = self._ids[id(node)]
        nodes = cast(RunHeader, self.header).nodes  # tick() refuses to run before setup() made it
        info = nodes[node_id]
        where = info.where
        message = f"node '{node.name}' ({info.type}{', ' + where if where else ''}) raised {error}"
        if lines:
            message += f" at {lines[-1].split(': ', 1)[0]}"
        return Event("exception", message, node_id, where, lines, full)

    def _why_failed(self) -> str:
        failed = [
            node
            for node in self._nodes
            if node.status == Status.FAILURE and not any(c.status == Status.FAILURE for c in node.children)
        ]
        if not failed:
            return ""
        node = failed[-1]  # the last tried: a sequence stops at it, a selector tried it after all the others
        return f"'{node.name}' failed" + (f" ({clipped(node.feedback_message)})" if node.feedback_message else "")

    def _halt(self) -> None:
        """Halts running nodes, so that motion actions send their stop."""
        if self.root.status == Status.RUNNING:
            try:
                self.root.stop(Status.INVALID)
            except (Exception, SystemExit) as err:  # noqa: BLE001 - the final stop below still runs
                self._log(f"halting the tree raised {type(err).__name__}: {err}", "warning")

    def _final_stop(self) -> bool:
        stopped = self.client.safe_stop()
        self._log("the robot acknowledged the stop" if stopped else "the robot did not acknowledge the stop", "stop")
        return stopped

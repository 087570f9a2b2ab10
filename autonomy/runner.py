"""Ticks a mission's tree against the robot and guarantees the final stop.

Before every tick the runner polls the status packet once (``Gb000``) and puts it on the
py_trees blackboard, so every node of the tick sees the same snapshot; battery and health
are polled about once a second. Whatever way the run ends (success, failure, Ctrl-C,
SIGTERM, an exception, a lost link) the running nodes are halted and ``X`` is sent until
it is acknowledged or the link is gone.
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TextIO

import py_trees
from py_trees.common import Access, Status

from autonomy.behaviours import BATTERY_KEY, HEALTHY_KEY, STATUS_KEY, RobotContext
from autonomy.behaviours.tree import preorder
from autonomy.client import Client
from autonomy.errors import AutonomyError, LinkError
from autonomy.protocol import Reply, heading_delta_deg, odometer_delta_mm
from autonomy.protocol import Status as Packet

#: How often battery and health are polled.
SLOW_POLL_S = 1.0

SUCCEEDED = "succeeded"
FAILED = "failed"
TIME_LIMIT = "stopped at the time limit"
INTERRUPTED = "interrupted"
LINK_LOST = "lost the link"
CRASHED = "stopped by an error"


@dataclass
class TickReport:
    """What one tick saw and did, for a live view."""

    tick: int
    time_s: float
    status: Packet
    battery: int
    active: list[str]
    messages: list[str]


@dataclass
class RunSummary:
    """How a run went."""

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
    framing_errors: int = 0

    @property
    def paragraph(self) -> str:
        """The run in a few sentences, for the person who started it."""
        head = f"Mission '{self.mission}' {self.outcome} after {self.time_s:.1f} s "
        head += f"({self.ticks} ticks at {self.tick_hz:g} Hz)"
        head += f": {self.reason}." if self.reason else "."
        names = {"F": "move", "T": "turn", "S": "beep", "M": "servo move", "D": "servo step"}
        sent = [f"{n} {names[c]}{'s' if n != 1 else ''}" for c, n in sorted(self.commands.items()) if c in names]
        collisions = {0: "no collisions", 1: "1 collision"}.get(self.collisions, f"{self.collisions} collisions")
        body = (
            f" The robot drove {self.distance_mm / 1000:.2f} m and turned {self.turned_deg:.0f} degrees, "
            f"with {collisions}; it was sent {', '.join(sent) if sent else 'no motion commands'}."
        )
        end = " It was stopped at the end." if self.stopped else " The stop could NOT be confirmed: check the robot."
        link = f" Link: {self.requests} requests, {self.retries} retries, {self.framing_errors} framing errors."
        return head + body + end + link


def _reply_text(outcome: Reply | AutonomyError) -> str:
    if isinstance(outcome, AutonomyError):
        return f"error: {outcome}"
    if isinstance(outcome, Packet):
        return "status"
    encode = getattr(outcome, "encode", None)
    return encode().decode("ascii", "replace").strip() if encode else str(outcome)


class Runner:
    """Runs one tree on one robot.

    Args:
        root: The tree's root (built, not yet set up).
        client: An open client.
        mission: The mission's name, for the summary.
        tick_hz: Ticks per second.
        max_seconds: Stop the run after this long (None: no limit).
        trace: Where to write one JSON line per tick, or None.
        on_tick: Called after every tick with a :class:`TickReport`.
        on_message: Called with each ``log`` message and event as it happens.
    """

    def __init__(
        self,
        root: py_trees.behaviour.Behaviour,
        client: Client,
        *,
        mission: str = "mission",
        tick_hz: float = 20.0,
        max_seconds: float | None = None,
        trace: TextIO | None = None,
        on_tick: Callable[[TickReport], None] | None = None,
        on_message: Callable[[str], None] | None = None,
    ) -> None:
        self.root = root
        self.client = client
        self.clock = client.clock
        self.tick_hz = tick_hz
        self.max_seconds = max_seconds
        self.trace = trace
        self.on_tick = on_tick
        self.on_message = on_message
        self.summary = RunSummary(mission, FAILED, tick_hz=tick_hz)
        self._messages: list[str] = []
        self._exchanges: list[dict[str, str]] = []
        self._blackboard = py_trees.blackboard.Client(name=f"runner:{mission}")
        for key in (STATUS_KEY, BATTERY_KEY, HEALTHY_KEY):
            self._blackboard.register_key(key=key, access=Access.WRITE)
        self._ids = {id(node): index for index, node in enumerate(preorder(root))}
        self._last: Packet | None = None
        self._start_s = 0.0
        self._last_slow_s = -float("inf")
        self._battery, self._healthy = 0, True
        self.context = RobotContext(client, self.clock, log=self._log)

    # ------------------------------------------------------------------ events

    def _log(self, message: str) -> None:
        self._messages.append(message)
        if self.on_message is not None:
            self.on_message(message)

    def _record(self, frame: bytes, outcome: Reply | AutonomyError) -> None:
        command = frame[:1].decode("ascii", "replace")
        if not isinstance(outcome, AutonomyError) and command != "G":
            self.summary.commands[command] += 1
        if self.trace is not None:
            self._exchanges.append({"sent": frame[:-1].decode("ascii", "replace"), "reply": _reply_text(outcome)})

    def _observe(self, status: Packet) -> None:
        last = self._last
        if last is not None:
            self.summary.distance_mm += abs(odometer_delta_mm(last.odometer_mm, status.odometer_mm))
            self.summary.turned_deg += abs(heading_delta_deg(last.heading_deg, status.heading_deg))
            if status.collided and not last.collided:
                self.summary.collisions += 1
                self._log(f"collision (front sensor {status.front_distance_mm} mm, heading {status.heading_deg} deg)")
        elif status.collided:
            self.summary.collisions += 1
        self._last = status

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
        except Exception as err:  # noqa: BLE001 - a behaviour's bug must still end in a stopped robot
            summary.outcome = CRASHED
            summary.reason = f"{type(err).__name__}: {err}"
        finally:
            summary.time_s = self.clock.now() - self._start_s
            self._halt()
            summary.stopped = self._final_stop()
            if self._record in self.client.listeners:
                self.client.listeners.remove(self._record)
            stats = self.client.stats
            summary.requests, summary.retries, summary.framing_errors = (
                stats.requests,
                stats.retries,
                stats.framing_errors,
            )
        return summary

    def setup(self) -> None:
        """Hands every node the run's context and starts the clock; :meth:`run` calls it."""
        self.client.listeners.append(self._record)
        for node in self.root.iterate():
            node.setup(robot=self.context)
        self._start_s = self.clock.now()
        if self.trace is not None:
            self._write_header()

    def tick(self) -> Status:
        """One tick: poll the status (battery and health about once a second), tick the tree.

        Returns:
            The root's status after the tick.
        """
        now = self.clock.now()
        status = self.client.status()
        if now - self._last_slow_s >= SLOW_POLL_S:
            self._battery, self._healthy = self.client.battery(), self.client.healthy()
            self._last_slow_s = now
        self._blackboard.set(STATUS_KEY, status)
        self._blackboard.set(BATTERY_KEY, self._battery)
        self._blackboard.set(HEALTHY_KEY, self._healthy)
        self._observe(status)
        self.root.tick_once()
        self.summary.ticks += 1
        self._after_tick(now - self._start_s, status, self._battery)
        return self.root.status

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
            if self.max_seconds is not None and self.clock.now() - self._start_s >= self.max_seconds:
                self.summary.reason = f"the mission was still running after {self.max_seconds:g} s"
                return TIME_LIMIT
            next_tick_s += period_s
            delay_s = next_tick_s - self.clock.now()
            if delay_s > 0:
                self.clock.sleep(delay_s)
            else:
                next_tick_s = self.clock.now()  # behind: do not try to catch up in a burst

    def _after_tick(self, time_s: float, status: Packet, battery: int) -> None:
        if self.on_tick is not None:
            active = [node.name for node in self._active_path()]
            self.on_tick(TickReport(self.summary.ticks, time_s, status, battery, active, self._messages))
        if self.trace is not None:
            line: dict[str, Any] = {
                "tick": self.summary.ticks,
                "time_s": round(time_s, 4),
                "status": status.as_dict(),
                "nodes": {
                    str(self._ids[id(node)]): node.status.value
                    for node in preorder(self.root)
                    if node.status != Status.INVALID
                },
                "commands": self._exchanges,
            }
            if self._messages:
                line["log"] = self._messages
            self.trace.write(json.dumps(line) + "\n")
            self._exchanges = []
        self._messages = []

    def _write_header(self) -> None:
        assert self.trace is not None
        parents = {id(child): self._ids[id(node)] for node in preorder(self.root) for child in node.children}
        nodes = [
            {"id": self._ids[id(node)], "name": node.name, "kind": type(node).__name__, "parent": parents.get(id(node))}
            for node in preorder(self.root)
        ]
        self.trace.write(json.dumps({"mission": self.summary.mission, "tick_hz": self.tick_hz, "nodes": nodes}) + "\n")

    def _active_path(self) -> list[py_trees.behaviour.Behaviour]:
        path, node = [], self.root
        while node is not None and node.status == Status.RUNNING:
            path.append(node)
            running = [child for child in node.children if child.status == Status.RUNNING]
            node = running[0] if running else None
        return path

    def _why_failed(self) -> str:
        failed = [
            node
            for node in preorder(self.root)
            if node.status == Status.FAILURE and not any(c.status == Status.FAILURE for c in node.children)
        ]
        if not failed:
            return ""
        node = failed[0]
        return f"'{node.name}' failed" + (f" ({node.feedback_message})" if node.feedback_message else "")

    def _halt(self) -> None:
        """Halts running nodes, so that motion actions send their stop."""
        if self.root.status == Status.RUNNING:
            try:
                self.root.stop(Status.INVALID)
            except Exception as err:  # noqa: BLE001 - the final stop below still runs
                self._log(f"halting the tree raised {type(err).__name__}: {err}")

    def _final_stop(self) -> bool:
        stopped = self.client.safe_stop()
        if not stopped:
            self._log("the robot did not acknowledge the stop")
        return stopped

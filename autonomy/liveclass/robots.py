"""The class's robots: students' missions run on real robots, from one queue (``class serve --robot NAME=PORT``).

A student whose mission ran without problems on the exercise's public seeds asks for a run on a
robot (``POST /api/robot``) and waits in the class's queue: first asked, first served, one place
each. The teacher sets a robot at its start and presses Start on the desk; an exercise that says
``robot_start: when_asked`` lets the next run start as soon as a robot is free. A run is the
mission on the robot, in real time, for at most the exercise's time limit. It is shown live by a
view server of the robot's own (framed in the student's page and shown on the projector), and its
trace and replay are kept with the student's works, "on robot NAME". It earns no marks unless the
exercise gives runs on robots ``robot_points``: then the teacher, having watched it, marks it at the
desk (:meth:`RobotDesk.mark`), and a student's best-marked run counts beside their hand-in.

Each robot has a thread of its own. The thread holds the robot's link, opened once with its
guardian, so a board that resets when its port opens is not reset between runs. It asks the robot
for its status every :data:`ROBOT_POLL_S` while it waits, and runs the missions started on it,
one at a time. A robot that does not answer, or whose link drops during a run, is "lost". Its run
ends as "robot lost", which is not the student's doing: the student is put back at the head of
the queue. The queue goes on without that robot until it answers again.

The robot is stopped at the end of every run: the runner stops it on every way out, the teacher's
Stop included. Should the class's server be killed outright, the link's guardian stops it.
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import os
import re
import signal
import threading
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from autonomy.classroom.exercise import Exercise
from autonomy.classroom.job import check_text, run_seed
from autonomy.client import Client
from autonomy.clock import Clock, RealClock, wait_event
from autonomy.emulator.profile import load_profile
from autonomy.errors import AutonomyError
from autonomy.liveclass.store import ClassStore, StoreError
from autonomy.liveclass.work import GRADING_NICENESS, MISSION_LABEL, NO_PLUGINS
from autonomy.record import Record, to_line
from autonomy.runner import LINK_LOST, Runner
from autonomy.views.lines import printable
from autonomy.views.page import standalone_html
from autonomy.views.web import ViewServer

#: How often a robot waiting for a run is asked for its status, and a lost one tried again, seconds.
ROBOT_POLL_S = 2.0
#: How long a robot's link, opened, waits for its first answer, seconds.
READY_TIMEOUT_S = 2.0
#: A run whose robot's link dropped: not the student's doing.
ROBOT_LOST = "robot lost"
#: Who starts a run: the teacher (the default), or the queue itself as soon as a robot is free.
START_BY_TEACHER = "teacher"
START_WHEN_ASKED = "when_asked"
#: A robot's name on the command line and on the pages.
ROBOT_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,31}")
#: Where a class's runs on robots are kept, in its folder.
RUNS_FOLDER = "robot-runs"
#: How many of the class's last runs on robots the teacher's desk lists (to mark them, replay them).
DESK_RUNS = 30


def _short(name: str) -> str:
    """A name as a refusal says it back: printable, and at most 40 characters."""
    return printable(name[:40]) + ("..." if len(name) > 40 else "")


#: Longest an emulated run beside a robot's may take to be made, wall seconds (its work is one seed's grading).
EMULATED_WAIT_S = 120.0


def run_files(folder: Path, number: int) -> tuple[Path, Path, Path]:
    """A run on a robot's trace (JSON lines), its replay, and the emulated run beside it (pages of their own)."""
    runs = folder / RUNS_FOLDER
    return runs / f"{number}.jsonl", runs / f"{number}.html", runs / f"{number}-emulated.html"


def emulated_page(exercise: Exercise, text: str, profile: str) -> str:
    """``text`` run on the emulator of a robot's ``profile``, as the exercise's first public seed runs: its replay.

    In virtual time, in the exercise's world: what the student's mission does on the emulator fitted to the
    robot it just ran on, to be shown beside that run.

    Raises:
        ValueError: the mission has problems (it had none when its run was asked for).
    """
    spec, problems = check_text(exercise, text, MISSION_LABEL, NO_PLUGINS)
    if spec is None:
        raise ValueError(str(problems[0]) if problems else "the mission has problems")
    records: list[Record] = []
    seed = next(seed for seed in exercise.seeds if not seed.hidden)
    run_seed(dataclasses.replace(exercise, robot_ref=profile), spec, seed, watchers=[records.append])
    return standalone_html(records, at_end=True)


def _behind() -> None:
    """The emulated runs' process: behind the class's server, as gradings are; a Ctrl-C is the server's."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    os.nice(GRADING_NICENESS)


def parse_robots(given: list[str]) -> dict[str, str]:
    """``--robot NAME=PORT`` options, as names and ports in the order given.

    Raises:
        ValueError: one is not ``NAME=PORT``, or a name is given twice; the message says which.
    """
    robots: dict[str, str] = {}
    for option in given:
        name, equals, port = option.partition("=")
        if not equals or not port.strip():
            raise ValueError(f"--robot {option!r}: give a name and the robot's port, e.g. --robot a=/dev/ttyUSB0")
        if not ROBOT_NAME.fullmatch(name):
            raise ValueError(
                f"--robot {option!r}: a robot's name is 1 to 32 letters, digits, '-' or '_', starting with one of the"
                " first two"
            )
        if name in robots:
            raise ValueError(f"--robot {name}: two robots are named '{name}'; give each a name of its own")
        robots[name] = port.strip()
    return robots


def parse_profiles(given: list[str], robots: dict[str, str]) -> dict[str, str]:
    """``--robot-profile NAME=PROFILE`` options, as robots' names and their profiles' paths (each one read).

    Raises:
        ValueError: one is not ``NAME=PROFILE``, or names no robot, or is given twice; the message says which.
        WorldError: a profile is not there, or has problems (:class:`ProfileInvalid`: each at its place).
    """
    profiles: dict[str, str] = {}
    for option in given:
        name, equals, path = option.partition("=")
        if not equals or not path.strip():
            raise ValueError(
                f"--robot-profile {option!r}: give a robot's name and its profile, e.g. --robot-profile a=robot-a.yaml"
            )
        if name not in robots:
            named = ", ".join(robots) or "none: give them with --robot NAME=PORT"
            raise ValueError(f"--robot-profile {name}: no robot is named '{_short(name)}' (the robots: {named})")
        if name in profiles:
            raise ValueError(f"--robot-profile {name}: robot {name} is given two profiles")
        load_profile(path.strip())
        profiles[name] = str(Path(path.strip()).resolve())
    return profiles


@dataclasses.dataclass
class Ticket:
    """A student's place in the queue, then their run on a robot."""

    student: str
    name: str
    text: str
    asked_s: float
    #: ``waiting``, ``running``, then ``done``.
    state: str = "waiting"
    robot: str = ""
    outcome: str = ""
    summary: str = ""
    #: The run as kept (its number; None: not kept).
    run: int | None = None
    #: What the student is told besides (put back at the head of the queue, say).
    note: str = ""


@dataclasses.dataclass(eq=False)
class Robot:
    """One of the class's robots, as its thread keeps it."""

    name: str
    port: str
    #: Its calibration profile's file (empty: none): each run is shown beside the same mission on its emulator.
    profile: str = ""
    #: ``connecting``, ``free``, ``running``, or ``lost``.
    state: str = "connecting"
    why: str = ""
    ticket: Ticket | None = None
    started_s: float = 0.0
    #: The run the teacher's Start gave it, for its thread to take (None: none).
    pending: Ticket | None = None
    #: Why its run is to stop (the teacher's Stop), should the Stop come before the run's runner is made.
    stop_reason: str = ""
    wake: threading.Event = dataclasses.field(default_factory=threading.Event)
    runner: Runner | None = None
    client: Client | None = None
    view: ViewServer | None = None
    thread: threading.Thread | None = None
    #: How it was lost during a run, said until it answers again.
    lost_during: str = ""


class RobotDesk:
    """The class's robots and their queue; thread-safe (the server's loop asks, each robot's thread works).

    Args:
        robots: Each robot's name and port (see :func:`parse_robots`).
        exercise: The class's exercise (its time limit is each run's; its ``robot_start`` who starts runs).
        store: Where the runs are kept.
        folder: The class's folder (the runs' traces and replays are kept there).
        changed: Called, from any thread, whenever what the desk or a student's page shows changes.
        host: The interface the robots' live views are served on (the class's).
        framed_by: The origins of the class's pages, which frame the live views.
        baud: The robots' links' rate.
        open_link: Opens a robot's link (:meth:`Client.open`'s arguments).
        clock: Real time (how long a student has waited, a run has gone).
        profiles: The calibration profiles of robots that have one, by name (each a file's path): their runs are
            shown beside the same mission on the emulator of that profile, made in a process of its own.
    """

    def __init__(
        self,
        robots: dict[str, str],
        exercise: Exercise,
        store: ClassStore,
        folder: Path,
        changed: Callable[[], None],
        host: str = "127.0.0.1",
        framed_by: str = "",
        baud: int | None = None,
        open_link: Callable[..., Client] = Client.open,
        clock: Clock | None = None,
        profiles: dict[str, str] | None = None,
    ) -> None:
        profiles = profiles or {}
        self.robots = [Robot(name, port, profiles.get(name, "")) for name, port in robots.items()]
        #: Where the emulated runs are made (a process of their own, started at the first); None: not yet.
        self._emulator: ProcessPoolExecutor | None = None
        self.exercise = exercise
        self.store = store
        self.folder = Path(folder)
        self.start_by = exercise.robot_start
        self._changed = changed
        self._host, self._framed_by = host, framed_by
        self._baud = baud
        self._open = open_link
        self._clock = clock or RealClock()
        self._lock = threading.Lock()
        self._queue: list[Ticket] = []
        #: Each student's last ticket (waiting, running or done), what their page shows.
        self._tickets: dict[str, Ticket] = {}
        self._closing = False
        #: The class's last runs on robots, newest first, as the desk lists them (read once, then kept up).
        self._finished: list[dict[str, Any]] = store.last_robot_runs(DESK_RUNS)

    # ------------------------------------------------------------------ starting and stopping

    def start(self) -> None:
        """Serves each robot's live view and starts its thread.

        Raises:
            OSError: a view's port cannot be bound (what was started is stopped).
        """
        try:
            for robot in self.robots:
                robot.view = ViewServer(self._host, 0, framed_by=self._framed_by)
                robot.view.start()
        except OSError:
            self.stop()
            raise
        for robot in self.robots:
            robot.thread = threading.Thread(
                target=self._serve, args=(robot,), name=f"autonomy-robot-{robot.name}", daemon=True
            )
            robot.thread.start()

    def stop(self) -> None:
        """Ends each run under way (its robot stopped), lets go of each robot's link, stops the views."""
        with self._lock:
            self._closing = True
            for robot in self.robots:
                if robot.runner is not None:
                    robot.runner.request_stop("the class's server stopped")
                robot.wake.set()
        for robot in self.robots:
            if robot.thread is not None:
                robot.thread.join(timeout=30)
            if robot.view is not None:
                robot.view.stop()
        with self._lock:
            emulator, self._emulator = self._emulator, None
        if emulator is not None:
            emulator.shutdown(wait=False, cancel_futures=True)

    def view_ports(self) -> list[int]:
        """The ports of the robots' live views (the class's pages frame them)."""
        return [robot.view.port for robot in self.robots if robot.view is not None]

    # ------------------------------------------------------------------ the students'

    def ask(self, student: str, name: str, text: str) -> str | None:
        """Puts a student in the queue for a run of ``text`` (checked by the caller); None, or why not."""
        with self._lock:
            if self._closing:
                return "the class is closing"
            ticket = self._tickets.get(student)
            if ticket is not None and ticket.state != "done":
                return "you are in the queue already" if ticket.state == "waiting" else "your run is under way"
            ticket = Ticket(student, name, text, self._clock.now())
            self._tickets[student] = ticket
            self._queue.append(ticket)
            robots = list(self.robots)
        for robot in robots:  # a robot that starts runs by itself takes it at once
            robot.wake.set()
        self._changed()
        return None

    def cancel(self, student: str) -> bool:
        """Takes a student's waiting ticket out of the queue; whether they had one."""
        with self._lock:
            ticket = self._tickets.get(student)
            if ticket is None or ticket.state != "waiting":
                return False
            self._queue.remove(ticket)
            del self._tickets[student]
        self._changed()
        return True

    def of(self, student: str) -> dict[str, Any]:
        """What a student's page shows: the robots, and their ticket (their place, their run) or None."""
        with self._lock:
            ticket = self._tickets.get(student)
            shown = None
            if ticket is not None:
                shown = {
                    "state": ticket.state,
                    "place": self._queue.index(ticket) + 1 if ticket.state == "waiting" else None,
                    "robot": ticket.robot,
                    "outcome": ticket.outcome,
                    "summary": ticket.summary,
                    "run": ticket.run,
                    "note": ticket.note,
                    "view_port": self._view_port(ticket.robot) if ticket.state == "running" else None,
                    "points": next((r["points"] for r in self._finished if r["number"] == ticket.run), None),
                }
            return {
                "robots": len(self.robots),
                "free": sum(robot.state == "free" for robot in self.robots),
                "start_by": self.start_by,
                "robot_points": self.exercise.robot_points,
                "ticket": shown,
            }

    # ------------------------------------------------------------------ the teacher's

    def desk(self) -> dict[str, Any]:
        """What the teacher's desk shows: each robot's state and run, the queue, who starts runs."""
        now_s = self._clock.now()
        with self._lock:
            return {
                "start_by": self.start_by,
                "robot_points": self.exercise.robot_points,
                "runs": [
                    {**run, "student": printable(run["student"]), "name": printable(run["name"])}
                    for run in self._finished
                ],
                "robots": [
                    {
                        "name": robot.name,
                        "port": printable(robot.port),
                        "state": robot.state,
                        "why": robot.why,
                        "student": printable(robot.ticket.name) if robot.ticket is not None else None,
                        "running_s": round(now_s - robot.started_s, 1) if robot.ticket is not None else None,
                        "view_port": robot.view.port if robot.view is not None else None,
                    }
                    for robot in self.robots
                ],
                "queue": [
                    {"student": printable(t.student), "name": printable(t.name), "waiting_s": round(now_s - t.asked_s)}
                    for t in self._queue
                ],
            }

    def start_on(self, name: str) -> str | None:
        """The teacher's Start: the queue's next run, now on robot ``name`` (and no other); None, or why not.

        The run is the robot's from this moment: a second Start finds it running. Should the robot be lost
        before its thread takes the run, the run goes back to the head of the queue, not run, and waits for
        the next Start.
        """
        with self._lock:
            robot = self._robot(name)
            if robot is None:
                return f"no robot is named '{_short(name)}'"
            if robot.state != "free":
                return f"robot {name} is {robot.state}: " + (
                    "wait for its run to end" if robot.state == "running" else "it must answer first"
                )
            if not self._queue:
                return "nobody is waiting for a robot"
            self._take(robot, self._queue.pop(0))
            robot.pending = robot.ticket
        self._changed()
        robot.wake.set()
        return None

    def _take(self, robot: Robot, ticket: Ticket) -> None:
        """``ticket``, out of the queue, is now ``robot``'s run (with the lock held)."""
        ticket.state, ticket.robot, ticket.note = "running", robot.name, ""
        robot.ticket, robot.started_s, robot.state = ticket, self._clock.now(), "running"

    def _give_back(self, robot: Robot, ticket: Ticket) -> None:
        """A run its robot could not start (it was lost first): first in the queue again, never run (lock held)."""
        ticket.state, ticket.robot = "waiting", ""
        ticket.note = f"robot {robot.name} did not answer as your run was to start: you are first in the queue again"
        self._queue.insert(0, ticket)
        robot.ticket = robot.pending = None
        robot.stop_reason = ""

    def stop_on(self, name: str) -> str | None:
        """The teacher's Stop: the run on robot ``name`` ends after its tick, the robot stopped; None, or why not."""
        with self._lock:
            robot = self._robot(name)
            if robot is None:
                return f"no robot is named '{_short(name)}'"
            if robot.ticket is None:
                return f"robot {_short(name)} has no run under way"
            robot.stop_reason = "stopped by the teacher"  # a run just started, its runner not made yet, too
            if robot.runner is not None:
                robot.runner.request_stop(robot.stop_reason)
        return None

    def mark(self, number: int, points: object) -> str | None:
        """The teacher's mark of the kept run ``number``; None, or why not.

        ``points`` is from 0 to the exercise's ``robot_points``, or None: the mark taken back. A run that
        lost its robot has no mark: it was not the student's doing, and they had it again.
        """
        most = self.exercise.robot_points
        if not most:
            return "this exercise gives runs on robots no marks: give it robot_points: N (docs/exercises.md)"
        if points is not None and (
            isinstance(points, bool) or not isinstance(points, (int, float)) or not 0 <= points <= most
        ):
            return f"a run's mark is a number from 0 to {most:g} (the exercise's robot_points), or null to take it back"
        mark = None if points is None else round(float(points), 2) + 0.0  # hundredths, as the pages show (no -0)
        run = self.store.robot_run(number)
        if run is None:
            return f"no run on a robot is numbered {number}"
        if run["outcome"] == ROBOT_LOST:
            return f"run {number} lost its robot: it was not the student's doing, and it has no mark"
        self.store.mark_robot_run(number, mark)
        with self._lock:
            for kept in self._finished:
                if kept["number"] == number:
                    kept["points"] = mark
        self._changed()
        return None

    def _robot(self, name: str) -> Robot | None:
        return next((robot for robot in self.robots if robot.name == name), None)

    def _view_port(self, name: str) -> int | None:
        robot = self._robot(name)
        return robot.view.port if robot is not None and robot.view is not None else None

    # ------------------------------------------------------------------ each robot's thread

    def _set(self, robot: Robot, state: str, why: str = "") -> None:
        with self._lock:
            changed = (robot.state, robot.why) != (state, why)
            robot.state, robot.why = state, why
        if changed:
            self._changed()

    def _emulated(self, text: str, profile: str) -> tuple[str, str]:
        """The emulated run of ``text`` on ``profile``'s emulator (:func:`emulated_page`), and why not ("", why)."""
        with self._lock:
            if self._closing:
                return "", "the class is closing"
            if self._emulator is None:
                context = multiprocessing.get_context("forkserver")
                self._emulator = ProcessPoolExecutor(1, mp_context=context, initializer=_behind)
            emulator = self._emulator
        try:
            return emulator.submit(emulated_page, self.exercise, text, profile).result(timeout=EMULATED_WAIT_S), ""
        except Exception as err:  # noqa: BLE001 - said beside the run, which is kept whatever happens here
            return "", f"{type(err).__name__}: {err}" if str(err) else type(err).__name__

    def _serve(self, robot: Robot) -> None:
        """A robot's thread: its link kept open and asked after, the runs started on it run, until the class stops."""
        try:
            while not self._closing:
                if robot.client is None and not self._connect(robot):
                    wait_event(robot.wake, ROBOT_POLL_S)
                    robot.wake.clear()
                    continue
                ticket = self._next_for(robot)
                if ticket is not None:
                    try:  # still there? A robot gone is not a run lost: it never started
                        robot.client.status()
                    except AutonomyError as err:
                        with self._lock:
                            robot.pending = ticket
                        self._lose(robot, f"it stopped answering ({err})")
                        continue
                    self._run(robot, ticket)
                    continue
                if wait_event(robot.wake, ROBOT_POLL_S):
                    robot.wake.clear()
                    continue
                try:  # still there?
                    robot.client.status()
                except AutonomyError as err:
                    self._lose(robot, f"it stopped answering ({err})")
        finally:
            if robot.client is not None:
                robot.client.close()  # stopped first
                robot.client = None

    def _connect(self, robot: Robot) -> bool:
        """Opens a robot's link, with its guardian; whether it answers."""
        options: dict[str, Any] = {"guardian": True, "ready_timeout_s": READY_TIMEOUT_S}
        if self._baud is not None:
            options["baud"] = self._baud
        try:
            robot.client = self._open(robot.port, **options)
        except (AutonomyError, OSError, ValueError) as err:
            self._set(robot, "lost", f"{robot.lost_during}; " * bool(robot.lost_during) + f"it does not answer: {err}")
            return False
        robot.lost_during = ""
        self._set(robot, "free")
        return True

    def _lose(self, robot: Robot, why: str) -> None:
        client, robot.client = robot.client, None
        if client is not None:
            client.close()
        with self._lock:
            if robot.pending is not None:  # a Start pressed as the robot went: its run waits for the next Start
                self._give_back(robot, robot.pending)
            robot.state = "lost"  # (not "free" for a moment, whatever it was)
        self._set(robot, "lost", why)

    def _next_for(self, robot: Robot) -> Ticket | None:
        """The run ``robot`` starts now: the one the teacher's Start gave it, or (``when_asked``) the queue's next."""
        with self._lock:
            if robot.pending is not None:
                ticket, robot.pending = robot.pending, None
                return ticket
            if self._closing or not self._queue or self.start_by != START_WHEN_ASKED or robot.state != "free":
                return None
            self._take(robot, self._queue.pop(0))
            ticket = robot.ticket
        self._changed()
        return ticket

    def _run(self, robot: Robot, ticket: Ticket) -> None:
        """Runs a ticket's mission on its robot, in real time; keeps the run; the robot is stopped at its end."""
        assert robot.client is not None and robot.view is not None  # noqa: S101 - connected before a ticket is taken
        records: list[Record] = []
        spec, problems = check_text(self.exercise, ticket.text, MISSION_LABEL, NO_PLUGINS)
        if spec is None:  # checked when asked: the exercise cannot have changed since
            self._end(robot, ticket, "not run", str(problems[0]) if problems else "the mission has problems", records)
            return
        try:
            runner = Runner.for_mission(
                spec, robot.client, max_seconds=self.exercise.time_limit_s, listeners=[robot.view.hub, records.append]
            )
        except Exception as err:  # noqa: BLE001 - a node that cannot be made: said to the student
            self._end(robot, ticket, "not run", f"the mission's tree could not be made: {err}", records)
            return
        with self._lock:
            robot.runner = runner
            stop = "the class's server stopped" if self._closing else robot.stop_reason
        if stop:  # the class stopped, or the teacher pressed Stop, as the run started
            runner.request_stop(stop)
        try:
            summary = runner.run()  # the robot stopped on every way out
        finally:
            with self._lock:
                robot.runner = None
        lost = summary.outcome == LINK_LOST
        if lost:
            robot.lost_during = f"its link dropped during {ticket.name}'s run ({summary.reason})"
        self._end(robot, ticket, ROBOT_LOST if lost else summary.outcome, summary.paragraph, records)
        if lost:
            self._lose(robot, robot.lost_during)

    def _end(self, robot: Robot, ticket: Ticket, outcome: str, summary: str, records: list[Record]) -> None:
        """A run's end: kept (its trace and replay beside it), said to its student; a run lost, asked again."""
        number = None
        try:
            number = self.store.add_robot_run(ticket.student, robot.name, ticket.text, outcome, summary)
            row = self.store.robot_run(number)
            if row is not None:  # on the desk from now, as it lists it (a mark given from now on is shown there)
                kept = {key: row[key] for key in ("number", "student", "robot", "at", "outcome", "points")}
                kept["name"] = ticket.name
                with self._lock:
                    self._finished = [kept, *self._finished][:DESK_RUNS]
            trace, replay, emulated = run_files(self.folder, number)
            trace.parent.mkdir(mode=0o700, exist_ok=True)
            if records:
                trace.write_text("".join(to_line(record) + "\n" for record in records), encoding="utf-8")
                replay.write_text(standalone_html(records, at_end=True), encoding="utf-8")
                if robot.profile:
                    beside, why = self._emulated(ticket.text, robot.profile)
                    if beside:
                        emulated.write_text(beside, encoding="utf-8")
                    else:
                        summary += f" (the emulated run beside it could not be made: {why})"
        except (StoreError, OSError) as err:
            summary += f" (the class's server could not keep this run: {err})"
        with self._lock:
            ticket.state, ticket.outcome, ticket.summary, ticket.run = "done", outcome, summary, number
            robot.ticket, robot.stop_reason = None, ""
            if robot.state == "running":  # a robot lost is lost from now (never free for a moment)
                robot.state, robot.why = ("lost", robot.lost_during) if outcome == ROBOT_LOST else ("free", "")
            if outcome == ROBOT_LOST and not self._closing:  # not the student's doing: first in the queue again
                again = Ticket(ticket.student, ticket.name, ticket.text, ticket.asked_s)
                again.note = f"robot {robot.name} was lost during your run: you are first in the queue again"
                self._queue.insert(0, again)
                self._tickets[ticket.student] = again
        self._changed()


__all__ = [
    "ROBOT_LOST",
    "START_BY_TEACHER",
    "START_WHEN_ASKED",
    "RobotDesk",
    "Ticket",
    "parse_robots",
    "run_files",
]

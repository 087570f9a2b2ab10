"""The class's server: the JSON API the students' and the teacher's pages use (and a script may).

Every route is under ``/api/``. A student's requests carry ``Authorization: Bearer CODE`` (the
sign-in code ``codes.csv`` gives them); the teacher's, the teacher's token. Bodies are JSON of at
most 1 MB. docs/class.md describes each route.

``POST /api/check``   ``{"mission": TEXT}`` -> the problems at their lines, or the tree drawn
``POST /api/blocks``  ``{"mission": TEXT}`` -> the mission as blocks (Blockly's JSON), or its problems
``POST /api/text``    ``{"workspace": BLOCKS}`` -> the blocks as the mission's text, or their problems, at their blocks
``GET  /api/palette`` the blocks a page defines, and its toolbox: the exercise's allowed nodes
``POST /api/run``     the mission, tried on the public seeds -> the marks of each (runs a minute are limited)
``POST /api/handin``  the mission, graded on every seed and kept -> what the student may see
``GET  /api/me``      the exercise (text, world picture, criteria), the student, their hand-ins and their last mission
``GET  /api/class``   (the teacher) every student's sign-in, runs, hand-ins, marks, last problem
                      (``?after=V``: once it is newer than version V)
``POST /api/deadline`` (the teacher) ``{"deadline_s": EPOCH_S, "now" or null}``: when hand-ins close
``GET  /api/export/grades.csv``, ``autograder.zip``, ``feedback.zip`` (the teacher) the teacher's desk's exports

The pages: ``/`` (a student's: sign in, write, run, hand in), ``/teacher`` (the class table, any
student's run replayed, the projector view), and each graded work's feedback page at
``/pages/NUMBER-KEY.html``, whose key only its student and the teacher are given.

The server checks who it talks to and bounds what each costs, as every server of ours
(:class:`~autonomy.views.web.BoundedServer`); a student's Python never runs; grading is done in
the grader's limited worker processes, two at a time.
"""

from __future__ import annotations

import asyncio
import collections
import errno
import functools
import hashlib
import hmac
import html
import io
import json
import math
import multiprocessing
import os
import re
import secrets
import signal
import urllib.parse
import zipfile
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import replace
from pathlib import Path
from typing import Any

from aiohttp import web

from autonomy.classroom.cluster import ClusterUnfit
from autonomy.classroom.exercise import Exercise
from autonomy.classroom.gradebook import RosterEntry, RosterMatch
from autonomy.classroom.limits import cpu_used_up_why
from autonomy.classroom.overview import class_overview
from autonomy.classroom.report import to_csv
from autonomy.classroom.results import Report, file_names
from autonomy.clock import Clock, pause, thread_cpu_time_s, wall_time_s
from autonomy.errors import AutonomyError
from autonomy.liveclass import lms
from autonomy.liveclass.lti import (
    JWKS_RETRY_S,
    STATE_S,
    Launch,
    LaunchRefused,
    LtiTool,
    UnknownKey,
    frame_origins,
    state_cookie,
    tool_urls,
)
from autonomy.liveclass.robots import RobotDesk, run_files
from autonomy.liveclass.store import ClassStore, StoreError, Student, Work, code_digest, token_digest
from autonomy.liveclass.work import (
    GRADING_NICENESS,
    MAX_MISSION_CHARS,
    LocalGrader,
    as_blocks,
    as_text,
    check,
    exercise_shown,
    page_file,
    palette,
    work_file,
)
from autonomy.source import finite_number
from autonomy.views.editor import origins, vendor_response
from autonomy.views.lines import printable
from autonomy.views.page import static_text
from autonomy.views.web import BoundedServer, address_group, nonced_page, query_line, query_selected

#: Runs one student may start in a minute; past that they are told when they can run again.
RUNS_PER_MINUTE = 10
#: Hand-ins one student may make in a minute, and in an hour (every hand-in is kept for good: see :func:`disk_bound`).
HANDINS_PER_MINUTE = 4
HANDINS_PER_HOUR = 20
#: A wrong guess is forgotten after this long without another from the same address.
GUESS_MEMORY_S = 600.0
#: Checks at once (drawing a tree of 500 nodes takes a tenth of a second): off the server's loop.
CHECKS_AT_ONCE = 2
#: CPU time a student's checks (and their blocks turned to text and back) may take in :data:`CHECK_WINDOW_S`,
#: seconds: a check of a class's tree costs tens of milliseconds, its largest a third of a second.
CHECK_CPU_SHARE_S = 2.0
#: How far back a student's checks' CPU time is counted, seconds.
CHECK_WINDOW_S = 10.0
#: A check that took more CPU time than this, seconds, sends its student's next checks in :data:`CHECK_WINDOW_S` to
#: the lane for costly checks, a thread of its own: a class's checks take a few milliseconds each.
COSTLY_CHECK_S = 0.1
#: After a wrong code, an address may try another code only this long later, doubling at each wrong one up to
#: the most; a code tried sooner is refused at once, unchecked (codes that signed in from there are still taken).
GUESS_WAIT_S = 0.25
MOST_GUESS_WAIT_S = 8.0
#: Addresses whose wrong guesses are remembered; past this the oldest are forgotten. An IPv6 address is
#: counted with its /64 network (one machine may hold all of it).
GUESSERS_KEPT = 10_000
#: Large answers on their way at once to one address (pages, checks): one client of many connections takes no more
#: than its share of the server's 256, and a class behind one router still gets two each.
MAX_ANSWERS_PER_ADDRESS = 64
#: Codes remembered as signed in from one address (a class behind one router: a few dozen).
CODES_KEPT_PER_ADDRESS = 256
#: A grading that took more CPU time than this (seconds) holds its student's next one back as long (in wall time).
LONG_GRADING_S = 5.0
#: CPU time the grading of a student not known to be slow may take, seconds: a class's run takes a tenth of a
#: second, a hand-in of 16 seeds half of one. One that needs more is graded again with the whole budget, in
#: the lane for anyone, and its student is known to be slow for :data:`SLOW_MEMORY_S`.
QUICK_GRADING_CPU_S = 2.0
#: CPU time a student's gradings may take in :data:`GRADING_WINDOW_S` before they are known to be slow, seconds:
#: ten quick runs a minute take one or two; ten that take a second and a half each are slow.
GRADING_CPU_SHARE_S = 6.0
#: How far back a student's gradings' CPU time is counted, seconds.
GRADING_WINDOW_S = 60.0
#: Feedback pages kept per student: their latest runs' (their hand-ins' are counted apart), and the largest kept.
RUN_PAGES_KEPT = 5
HANDIN_PAGES_KEPT = 20
MAX_PAGE_BYTES = 8 * 1024 * 1024
#: Bytes of the pages kept per student, their runs' and their hand-ins': the newest first, within the counts above.
RUN_PAGE_BYTES_KEPT = 8 * 1024 * 1024
HANDIN_PAGE_BYTES_KEPT = 16 * 1024 * 1024
#: Runs of a student whose seeds' results (their maps) are kept: their last; the older keep their marks.
RUN_RESULTS_KEPT = 5
#: Largest result kept with a work, as JSON: past it, its seeds' maps (paths, contacts, beeps, turns) are left out.
MAX_RESULT_BYTES = 64 * 1024
#: Longest problem kept with a work (the first of them: the class table shows it).
MAX_PROBLEM_CHARS = 500
#: What a work's row holds besides its text and its result (the date, the mark, the problem, the indexes), at most.
WORK_ROW_BYTES = 4 * MAX_PROBLEM_CHARS + 512
#: What the database's write-ahead log may hold before it is folded back (SQLite's default: 1,000 pages of 4 KB).
WAL_BYTES = 4 * 1024 * 1024
#: A student whose grading took longer than :data:`LONG_GRADING_S` within this long is graded in the lane for anyone.
SLOW_MEMORY_S = 600.0
#: Texts of a student's runs kept in the class's database, their last (every hand-in's is kept).
RUN_TEXTS_KEPT = 20
#: A mission's text is at most this many bytes (UTF-8: at most four a character).
MAX_TEXT_BYTES = 4 * MAX_MISSION_CHARS
#: Problems kept with a work that had problems (a student sees them all when they check).
PROBLEMS_KEPT = 20
#: What a student is told who sends a request while their last is under way.
UNDER_WAY = "your last request is still under way: send the next when it has its answer"
#: What a student is told when the class's server cannot keep their work (its disk full, say): nothing was kept.
NOT_KEPT = "the class's server cannot keep work just now, so nothing was kept: tell your teacher, then send it again"
#: What a work left grading says once the server starts again (it stopped, or could not keep the grading's end).
UNFINISHED = "the grading did not finish (the server stopped, or could not keep it): send it again"
#: The errors of a disk that cannot take more (full, over a quota, a file too large, read-only, failing).
DISK_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS, errno.EIO})
#: Largest request body.
MAX_REQUEST_BYTES = 1024 * 1024
#: A request's body must have come whole this long after its headers (a mission of 100 kB takes a second
#: on a slow link); one that has not is answered 408 and let go.
BODY_DEADLINE_S = 15.0
#: Bytes of bodies being read at once, all students together: each body counts its declared length, or the
#: largest when it declares none. Past this a request is answered 503 and asked again a second later.
BODIES_READ_BYTES = 64 * MAX_REQUEST_BYTES
#: The setting that holds the teacher's token's digest, and the one that holds the hand-ins' deadline.
TEACHER_TOKEN = "teacher_token_sha256"
DEADLINE = "deadline_s"
#: The setting that holds which exercise the class is of (its name and its text's SHA-256).
EXERCISE = "exercise"
#: Longest a teacher's ``GET /api/class?after=V`` waits for the class to change.
CLASS_WAIT_S = 20.0
#: Teachers' pages waiting on the class at once (a teacher has one or two: the desk and the projector).
CLASS_WAITERS = 16
#: The class at a glance is made again at most this often while the class changes (a class of 300 changes
#: ten times a second; each making reads every student's latest work): a change is shown within as long.
OVERVIEW_EVERY_S = 1.5
#: The pages' files, and their types.
PAGE_FILES = {
    "student.html": "text/html",
    "teacher.html": "text/html",
    "common.js": "text/javascript",
    "class.js": "text/javascript",
    "teacher.js": "text/javascript",
    "class.css": "text/css",
    "blocks.js": "text/javascript",
    "text.js": "text/javascript",
    "contrast.js": "text/javascript",
    "contrast.css": "text/css",
    "overview.js": "text/javascript",
    "overview.css": "text/css",
}
#: The pages' files that are the views' (shared with ``autonomy edit``), by name.
SHARED_FILES = {
    name: "autonomy.views"
    for name in ("blocks.js", "text.js", "contrast.js", "contrast.css", "overview.js", "overview.css")
}
#: The pages' policy: their own scripts and styles, pictures as data or the server's, frames of this server (feedback
#: pages). Blockly writes one style attribute (the direction of a bubble's text): style attributes are allowed.
#: CodeMirror puts its themes in a <style> element of its own, with the response's nonce (``nonced_page``): no other
#: <style> element, and no script but the server's, is taken.
PAGE_POLICY = (
    "default-src 'none'; script-src 'self'; style-src 'self'; style-src-attr 'unsafe-inline'; img-src 'self' data:; "
    "connect-src 'self'; "
    "frame-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'"
)
#: A feedback page's policy, on top of its own: a sandbox of its own origin, framed by the class's pages alone.
FEEDBACK_POLICY = "sandbox allow-scripts; frame-ancestors 'self'"
#: An LTI login's or launch's form, at most (an id_token is a few kilobytes); how long a session it opens lasts (a
#: school day); the longest id an LMS may give a student.
LTI_MOST_BYTES = 64 * 1024
#: The LMS's forms read at once, at most, in bytes (a sign-in's form comes in a moment: 64 at once is a crowd).
LTI_BODIES_READ_BYTES = 64 * LTI_MOST_BYTES
LTI_SESSION_S = 12 * 3600.0
MAX_LTI_ID = 200
#: The page a teacher adding the class to their course confirms on (its texts escaped; no script).
DEEP_LINK_PAGE = """<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>autonomy: add the class to your course</title>
<link rel="icon" href="data:,">
<link rel="stylesheet" href="/static/class.css">
</head>
<body>
<header class="bar"><span class="brand">autonomy</span><span id="title">add the class to your course</span></header>
<main class="card narrow">
  <h1>{title}</h1>
  <p>{text}</p>
  <p>A student's hand-in is marked out of {points}; the mark goes to the course's gradebook.</p>
  <form id="add" method="post" action="{back}">
    <input type="hidden" name="JWT" value="{added}">
    <button type="submit">Add "{title}" to the course</button>
  </form>
  <form id="none" method="post" action="{back}">
    <input type="hidden" name="JWT" value="{none}">
    <button type="submit">Add nothing</button>
  </form>
</main>
</body>
</html>
"""
_PAGE_NAME = re.compile(r"(\d{1,12})-([0-9a-f]{32})\.html")
_ROBOT_PAGE_NAME = re.compile(r"(\d{1,12})-([0-9a-f]{32})(-emulated)?\.html")


def _as_seen(page: str | None, written_as: str | None) -> str | None:
    """A work's page's address, opening on its blocks when the work was made from blocks."""
    return f"{page}#as-blocks" if page and written_as == "blocks" else page


def _lately(costs: collections.deque[tuple[float, float]], now_s: float, window_s: float) -> collections.deque:
    """``costs`` (each ``(when_s, cpu_s)``, oldest first), those older than ``window_s`` let go: the same deque."""
    while costs and now_s - costs[0][0] >= window_s:
        costs.popleft()
    return costs


def _costly_lane() -> ProcessPoolExecutor:
    """The lane for costly checks: a process of its own, started from a clean one (see :func:`_behind`)."""
    return ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("forkserver"), initializer=_behind)


def _behind() -> None:
    """The costly checks' process: behind the server as gradings are; a Ctrl-C is for the server, which ends it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    os.nice(GRADING_NICENESS)


def _costed(work: Callable[..., Any], *args: Any) -> tuple[Any, float]:
    """``work(*args)`` in the calling thread, and the CPU time it took there, seconds."""
    started_s = thread_cpu_time_s()
    done = work(*args)
    return done, thread_cpu_time_s() - started_s


def _failed(future: asyncio.Future[Any]) -> bool:
    """Whether a making ended without its result (to be made again, not answered 500 until the class changes)."""
    return future.done() and (future.cancelled() or future.exception() is not None)


class _Makings:
    """What a teacher's pages ask for, made of the class as it is: one making at a time, for every page asking."""

    def __init__(self) -> None:
        self._last: tuple[int, asyncio.Future[Any]] | None = None
        self._started_s = -math.inf

    async def of(
        self, clock: Clock, version: Callable[[], int], make: Callable[[int], asyncio.Future[Any]], every_s: float = 0.0
    ) -> tuple[int, Any]:
        """The making of the class's version now (``version()``), and what it made; ``make`` starts one.

        A making of an earlier version under way is waited for first, then the class's is made: an answer
        is never of a class older than asked. At most one making starts every ``every_s`` on ``clock``
        (the changes meanwhile are shown together, a little later).
        """
        while True:
            now, last = version(), self._last
            if last is not None and last[0] == now and not _failed(last[1]):
                break
            if last is not None and not last[1].done():
                await asyncio.wait([asyncio.shield(last[1])])
                continue
            wait_s = self._started_s + every_s - clock.now()
            if wait_s > 0:
                await pause(clock, wait_s)
                continue
            last = self._last = (now, make(now))
            self._started_s = clock.now()
            break
        return last[0], await asyncio.shield(last[1])


def _bounded(result: dict[str, Any]) -> dict[str, Any]:
    """A work's result as kept: within :data:`MAX_RESULT_BYTES`, its seeds' maps left out if need be, then its seeds."""
    if len(json.dumps(result)) <= MAX_RESULT_BYTES:
        return result
    maps = ("path", "collisions", "beeps", "turns")
    seeds = [{key: ([] if key in maps else value) for key, value in seed.items()} for seed in result.get("seeds", [])]
    smaller = {**result, "seeds": seeds, "problems": result.get("problems", [])[:PROBLEMS_KEPT]}
    if len(json.dumps(smaller)) <= MAX_RESULT_BYTES:
        return smaller
    return {key: value for key, value in smaller.items() if key in ("total", "max_points", "marks", "written_as")}


def disk_bound(students: int, hours: float) -> tuple[int, int, int]:
    """The most a class keeps on disk, in bytes, however its students send their works.

    Returns a student's at any time, what a student adds an hour, and a lesson's of ``students`` for
    ``hours``. At any time: a student's pages (their last runs' and hand-ins', within
    :data:`RUN_PAGE_BYTES_KEPT` and :data:`HANDIN_PAGE_BYTES_KEPT`; pages past them are removed as they
    go, and two more may be on their way), and their last runs' texts and results. Every hour: their
    hand-ins (each text twice, in its file and in the database, and its result) and their runs' rows,
    each as often as the rate limits let them.
    """
    pages = RUN_PAGE_BYTES_KEPT + HANDIN_PAGE_BYTES_KEPT + 2 * MAX_PAGE_BYTES
    at_once = pages + RUN_TEXTS_KEPT * MAX_TEXT_BYTES + RUN_RESULTS_KEPT * MAX_RESULT_BYTES
    hand_in = 2 * MAX_TEXT_BYTES + MAX_RESULT_BYTES + WORK_ROW_BYTES
    hourly = HANDINS_PER_HOUR * hand_in + 60 * RUNS_PER_MINUTE * WORK_ROW_BYTES  # an old run: its row alone
    return at_once, hourly, math.ceil(students * (at_once + hourly * hours)) + WAL_BYTES


def disk_said(students: int, hours: float = 2.0) -> str:
    """What ``class serve`` says at its start of the class's disk: :func:`disk_bound`'s figures, in one line."""
    at_once, hourly, lesson = disk_bound(students, hours)
    return (
        f"disk: at most {lesson / 2**30:.1f} GB for a {hours:g}-hour lesson of {students} students "
        f"({at_once / 2**20:.0f} MB a student at once: the pages of their last {RUN_PAGES_KEPT} runs and "
        f"{HANDIN_PAGES_KEPT} hand-ins, their last runs' texts; {hourly / 2**20:.0f} MB more a student an hour, "
        "handing in as often as allowed); older pages are removed as they go (the exports keep each last hand-in's)"
    )


def _report_of(result: dict[str, Any]) -> Report:
    """The report a work's result keeps (how the work was written apart)."""
    return Report.from_json({key: value for key, value in result.items() if key != "written_as"})


def page_text(name: str) -> str:
    """One of the pages' files (:data:`PAGE_FILES`), as text."""
    return static_text(name, SHARED_FILES.get(name, "autonomy.liveclass"))


#: Every answer of the API: a student's work is never kept by a browser's cache.
NO_STORE = {"Cache-Control": "no-store"}


def _points(value: float | None) -> str:
    """Points as a comment to the LMS says them: hundredths at most, a dash for none."""
    return "-" if value is None else f"{round(value, 2):g}"


def _json(data: Any, status: int = 200, headers: dict[str, str] | None = None) -> web.Response:
    return web.Response(
        text=json.dumps(data), status=status, content_type="application/json", headers={**NO_STORE, **(headers or {})}
    )


def _refusal(status: int, why: str, **more: Any) -> web.Response:
    return _json({"error": why, **more}, status)


def _come_back(status: int, why: str, wait_s: float) -> web.Response:
    """A refusal that says when to ask again (``retry_after_s``, and ``Retry-After``), in whole seconds."""
    wait_s = max(1, math.ceil(wait_s))
    return _json({"error": why, "retry_after_s": wait_s}, status, {"Retry-After": str(wait_s)})


def _bearer(request: web.Request) -> str:
    """What a request's ``Authorization: Bearer ...`` carries, as sent."""
    return request.headers.get("Authorization", "").removeprefix("Bearer ")


def seen_by_student(exercise: Exercise, report: Report) -> dict[str, Any]:
    """What a student is shown of a grading: the marks by criterion, and each seed's outcome and marks.

    Hidden seeds are named ``hidden seed K``, never by their numbers.
    """
    return {
        "total": report.total,
        "max_points": report.max_points,
        "criteria": [
            {"label": criterion.shown, "points": criterion.points, "earned": mark}
            for criterion, mark in zip(exercise.criteria, report.marks, strict=False)
        ],
        "seeds": [
            {
                "seed": seed.seed,
                "outcome": seed.outcome,
                "earned": round(
                    sum(c.points * share for c, share in zip(exercise.criteria, seed.shares, strict=False)), 2
                ),
            }
            for seed in report.seeds
        ],
        "problems": list(report.problems),
        "notes": list(report.notes),
    }


class ClassServer(BoundedServer):
    """Serves a class's API in a thread of its own; bodies of at most :data:`MAX_REQUEST_BYTES`.

    Args:
        exercise: The exercise, with its hidden seeds drawn (see :meth:`Exercise.with_secret`).
        store: The class's storage.
        folder: The class's folder (works and feedback pages are kept there).
        host: The interface.
        port: The TCP port (0: any free one).
        key: What feedback pages' addresses are signed with (the class's secret keeps them the same
            from one start to the next; default: new ones).
        grader: Grades a work instead of this machine's workers (``grade_text``'s arguments; see
            :class:`autonomy.liveclass.work.DaskGrader`).
        autograder: The exercise packed for Gradescope (``autonomy gradescope``), for its export;
            None: not offered.
        robots: The class's robots, by name, each with its port: students' runs on them, from a queue
            (:mod:`autonomy.liveclass.robots`); none by default.
        robot_baud: The robots' links' rate (default: the client's).
        robot_profiles: The calibration profiles of robots that have one, by name: each of their runs is shown
            beside the same mission on that profile's emulator.
    """

    def start(self) -> None:
        """Serves the class; then its robots' live views, and a thread for each robot.

        Raises:
            OSError: a port cannot be bound (nothing is left serving).
        """
        super().start()
        if self.lti is not None and self.lti.platform.token_url:
            self.lms_link = lms.LmsLink(
                self.store, lms.LmsServices(self.lti), f"autonomy:{self.exercise.name}", self.exercise.title,
                self.exercise.max_points + self.exercise.robot_points, self._clock, self._robots_changed,
            )  # fmt: skip
            self.lms_link.start()
            self.lms_link.nudge(roster=bool(self.store.setting(lms.MEMBERSHIPS_URL)))  # scores waiting since
        if not self._robots_given:
            return
        desk = RobotDesk(
            self._robots_given,
            self.exercise,
            self.store,
            self.folder,
            self._robots_changed,
            self.host,
            " ".join(origins(self.host, self.port)),
            self._robot_baud,
            profiles=self._robot_profiles,
        )
        try:
            desk.start()
        except OSError:
            super().stop()
            raise
        self.robots = desk

    def stop(self) -> None:
        """Ends the robots' runs (each robot stopped) and lets go of their links, then stops serving."""
        if self.robots is not None:
            self.robots.stop()
        if self.lms_link is not None:
            self.lms_link.stop()
        super().stop()

    def _robots_changed(self) -> None:
        """A robot or the queue changed (from a robot's thread): the teachers' and students' pages are told."""
        try:
            self._loop.call_soon_threadsafe(self._change)
        except RuntimeError:  # the loop is closed: the class has stopped
            pass

    def __init__(
        self,
        exercise: Exercise,
        store: ClassStore,
        folder: Path,
        host: str = "127.0.0.1",
        port: int = 8770,
        key: bytes | None = None,
        grader: Callable[..., tuple[Report, Path]] | None = None,
        autograder: Callable[[], bytes] | None = None,
        robots: dict[str, str] | None = None,
        robot_baud: int | None = None,
        robot_profiles: dict[str, str] | None = None,
        lti: LtiTool | None = None,
        public_url: str = "",
    ):
        super().__init__(host, port, "class")
        #: The class's LMS's sign-in (LTI 1.3), if it has one; the address the LMS knows the class by.
        self.lti = lti
        self.public_url = (public_url or (lti.platform.public_url if lti is not None else "")).rstrip("/")
        if lti is not None:  # the LMS's page posts the launch (and may post the login); served as the public name
            self.cross_origin_paths = frozenset({"/lti/launch", "/lti/login"})
            public = urllib.parse.urlsplit(self.public_url)
            self.served_as = (public.hostname,) if public.hostname else ()
        #: The LMS's services' addresses its teachers' launches gave (their origins may frame the pages).
        self._lms_urls: tuple[str, ...] = tuple(
            url for url in (store.setting(lms.MEMBERSHIPS_URL), store.setting(lms.LINEITEMS_URL)) if url
        )
        #: The LMS's roster and gradebook, read and written in a thread of their own (an LMS with a token URL).
        self.lms_link: lms.LmsLink | None = None
        #: The LMS's keys are fetched here, off the loop (a launch waits on it; nothing else does).
        self._lti_keys = ThreadPoolExecutor(1, thread_name_prefix="autonomy-lti-keys")
        #: The class's robots (``--robot NAME=PORT``) and their queue, once the server listens; None: none.
        self._robots_given, self._robot_baud = dict(robots or {}), robot_baud
        self._robot_profiles = dict(robot_profiles or {})
        self.robots: RobotDesk | None = None
        self._key = key if key is not None else secrets.token_bytes(32)
        self._exercise_shown = exercise_shown(exercise)  # the same for every student: made once
        self._palette = json.dumps(palette(exercise)).encode()  # the blocks of the page's Blocks, made once
        #: This machine's workers, kept warm between works, unless another grader is given.
        self._local = LocalGrader(exercise, lanes=2) if grader is None else None
        self._grader = grader or self._local
        self._autograder = autograder
        #: Bumped at each change of the class table; teachers' pages wait on it.
        self._version = 0
        self._changed: asyncio.Event | None = None
        self._class_waiters = 0
        #: The class at a glance's makings, and the class table's (their JSON); the table's rows as shown, by
        #: student (read off the loop, in the views' thread alone; None: to be read whole); the students whose
        #: rows changed since (None: all).
        self._overview, self._table = _Makings(), _Makings()
        self._table_rows: dict[str, dict[str, Any]] | None = None
        self._stale: set[str] | None = None
        self.max_request_bytes = MAX_REQUEST_BYTES
        self.max_answers_per_address = MAX_ANSWERS_PER_ADDRESS
        self.exercise = exercise
        self.store = store
        self.folder = Path(folder)
        self._runs: dict[tuple[str, str], collections.deque[float]] = {}
        #: Per address: wrong guesses, when the last was, and until when it may try no other code.
        self._guesses: collections.OrderedDict[str, tuple[int, float, float]] = collections.OrderedDict()
        #: Per address: the digests of the codes that signed in from there (taken whatever its guesses).
        self._known: collections.OrderedDict[str, set[str]] = collections.OrderedDict()
        #: Per student: when their last long grading ended, and how long it took (their next waits as long).
        self._long: dict[str, tuple[float, float]] = {}
        #: Per student: the CPU time of each of their gradings lately, when it ended (see :data:`GRADING_CPU_SHARE_S`).
        self._spent: dict[str, collections.deque[tuple[float, float]]] = {}
        #: Two gradings at once (the machine's two cores), in two lanes: anyone's, and one for students whose
        #: gradings are quick; and how many wait in each.
        # (on a cluster, each lane as many as half its workers' threads: the cluster's lanes in place of this machine's)
        slots = getattr(grader, "slots", 2)
        self._lanes = [
            ThreadPoolExecutor(size, thread_name_prefix=f"autonomy-grading-{name}")
            for name, size in (("any", max(1, slots // 2)), ("quick", max(1, slots - slots // 2)))
        ]
        self._waiting = [0, 0]
        self._checkers = ThreadPoolExecutor(CHECKS_AT_ONCE, thread_name_prefix="autonomy-check")
        #: Costly checks, in a process of their own: what they cost is not the GIL the server's loop needs.
        self._costly_checkers = _costly_lane()
        #: The rest off the loop (histories, the class at a glance, exports, the disk's bounds): never the checks'.
        self._chores = ThreadPoolExecutor(1, thread_name_prefix="autonomy-chores")
        #: The teacher's views (the class table, the class at a glance), off the loop and never before a run's chores.
        self._views = ThreadPoolExecutor(1, thread_name_prefix="autonomy-views")
        #: Per student: the CPU time of each of their checks lately, when it ended (see :data:`CHECK_CPU_SHARE_S`).
        self._checked: dict[str, collections.deque[tuple[float, float]]] = {}
        #: Students with a request under way (a check, a run or a hand-in): one at a time each.
        self._busy: set[str] = set()
        #: Students whose history (``/api/me``) is being read: one reading at a time each.
        self._reading_history: set[str] = set()
        self._signed_in: set[str] = set()
        #: Bytes of the bodies being read now (see :data:`BODIES_READ_BYTES`).
        self._reading_bytes = 0
        #: Bytes of the LMS's forms being read now, apart: anyone may post one (see :data:`LTI_BODIES_READ_BYTES`).
        self._reading_lti_bytes = 0
        self.body_deadline_s = BODY_DEADLINE_S
        self.bodies_read_bytes = BODIES_READ_BYTES
        # a work is kept once graded, in one write; one kept as grading (by a server before that) is never finished
        store.fail_unfinished(UNFINISHED)

    def _routes(self, app: web.Application) -> None:
        app.middlewares.append(self._keeping)
        app.router.add_get("/", functools.partial(self._file, "student.html"))
        app.router.add_get("/teacher", functools.partial(self._file, "teacher.html"))
        app.router.add_get("/static/{name}", self._static)
        app.router.add_get("/pages/{name}", self._page)
        app.router.add_get("/vendor/{library}/{name:.+}", self._vendor)
        app.router.add_post("/api/check", self._check)
        app.router.add_post("/api/blocks", self._blocks)
        app.router.add_post("/api/text", self._text)
        app.router.add_post("/api/run", self._run)
        app.router.add_post("/api/handin", self._handin)
        app.router.add_get("/api/me", self._me)
        app.router.add_get("/api/palette", self._palette_of)
        app.router.add_get("/api/class", self._class)
        app.router.add_get("/api/overview", self._overview_of)
        app.router.add_post("/api/deadline", self._deadline)
        app.router.add_get("/api/export/{name}", self._export)
        app.router.add_get("/api/robot", self._robot_state)
        app.router.add_post("/api/robot", self._robot_ask)
        app.router.add_post("/api/robot/cancel", self._robot_cancel)
        app.router.add_get("/api/robots", self._robots_desk)
        app.router.add_post("/api/robots/{action}", self._robots_act)
        app.router.add_get("/robot-runs/{name}", self._robot_page)
        app.router.add_get("/lti/jwks", self._lti_jwks)
        app.router.add_route("*", "/lti/login", self._lti_login)
        app.router.add_post("/lti/launch", self._lti_launch)
        app.router.add_get("/api/lms", self._lms_desk)
        app.router.add_post("/api/lms/roster", self._lms_roster)
        app.router.add_post("/api/lms/again", self._lms_again)

    @web.middleware
    async def _keeping(self, request: web.Request, handler: Callable[..., Any]) -> web.StreamResponse:
        """A request the class cannot be kept for (its database or its disk refusing): one line, and the answer.

        The teacher's terminal says it once (then how often again); the student gets ``{"error"}``, 503.
        """
        try:
            return await handler(request)
        except (StoreError, OSError) as err:
            if isinstance(err, OSError) and err.errno not in DISK_ERRNOS:
                raise
            said = str(err) if isinstance(err, StoreError) else f"{err.filename or self.folder}: {err.strerror}"
            self._refused("cannot keep", f"the class cannot be kept: {said}; works are refused until it can")
            return _come_back(503, NOT_KEPT, 30)

    def _serving(self, loop: asyncio.AbstractEventLoop) -> None:
        self._changed = asyncio.Event()
        if self._local is not None:  # its workers start now, not at the first works
            loop.run_in_executor(self._chores, self._local.start)

    def _change(self, student: str | None = None) -> None:
        """The class table changed (a student's row; None: any): the teachers' pages waiting on it are answered.

        On the server's loop.
        """
        if student is None:
            self._stale = None
        elif self._stale is not None:
            self._stale.add(student)
        self._version += 1
        if self._changed is not None:
            self._changed.set()
            self._changed = asyncio.Event()

    def _closing(self) -> None:
        for lane in self._lanes:
            lane.shutdown(wait=False, cancel_futures=True)
        self._checkers.shutdown(wait=False, cancel_futures=True)
        self._costly_checkers.shutdown(wait=False, cancel_futures=True)
        self._chores.shutdown(wait=False, cancel_futures=True)
        self._views.shutdown(wait=False, cancel_futures=True)
        self._lti_keys.shutdown(wait=False, cancel_futures=True)
        if self._local is not None:
            self._local.close()

    # ------------------------------------------------------------------ who asks

    async def _student(self, request: web.Request) -> Student | web.Response:
        """The student a request's code names, or the refusal.

        An address that sent a wrong code may try another only a while later (0.25 s, doubling at each
        wrong one, up to 8 s); a code tried sooner is refused at once, unchecked, so that guessing in
        parallel gains nothing and holds no connection. Codes that signed in from that address are
        always taken: a class behind one router is not held back by one student's typo.
        """
        code = "".join(_bearer(request).split())
        if not code:
            return _refusal(401, "sign in with the code on your sheet")
        if self._teacher(request):  # not a guess: the teacher trying a student's page costs their address nothing
            return _refusal(403, "the teacher's token signs in as no student: this asks for a student's code")
        address = address_group(request.remote or "")
        digest = code_digest(code)
        now_s = self._clock.now()
        wrong, last_s, until_s = self._guesses.get(address, (0, 0.0, 0.0))
        known = self._known.get(address, set())
        if now_s < until_s and digest not in known:
            self._refused("codes", "a code sent too soon after a wrong one was refused")
            why = f"a wrong code was typed here a moment ago: try again in {math.ceil(until_s - now_s)} s"
            return _come_back(429, why, until_s - now_s)
        student = self.store.student_by_code(code)
        if student is not None:
            self._known.setdefault(address, set())
            self._known.move_to_end(address)
            if len(known) < CODES_KEPT_PER_ADDRESS:
                self._known[address].add(digest)
            while len(self._known) > GUESSERS_KEPT:
                self._known.popitem(last=False)
            if student.id not in self._signed_in:
                self._signed_in.add(student.id)
                self.store.sign_in(student.id)
                self._change(student.id)
            return student
        wrong = 1 if now_s - last_s > GUESS_MEMORY_S else wrong + 1  # a right code in between forgets nothing
        wait_s = min(MOST_GUESS_WAIT_S, GUESS_WAIT_S * 2 ** (wrong - 1))
        self._guesses.pop(address, None)
        self._guesses[address] = (wrong, now_s, now_s + wait_s)
        while len(self._guesses) > GUESSERS_KEPT:
            self._guesses.popitem(last=False)
        self._refused("codes", "a request with a wrong sign-in code was refused")
        return _come_back(401, "no student has this sign-in code: type the one on your sheet", wait_s)

    def _teacher(self, request: web.Request) -> bool:
        token = _bearer(request).strip()
        if not token:
            return False
        if hmac.compare_digest(token_digest(token), self.store.setting(TEACHER_TOKEN)):
            return True
        return self.lti is not None and self.store.teacher_session(token)  # an instructor's launch from the LMS

    async def _body(
        self, request: web.Request, most: int = MAX_REQUEST_BYTES, lms_form: bool = False
    ) -> bytes | web.Response:
        """A request's body, read against :attr:`body_deadline_s` within :attr:`bodies_read_bytes`; or the refusal.

        Read only once the student is known and has no other request under way: one student's
        requests whose bodies never end cost one connection, for the deadline.

        Args:
            request: The request.
            most: The most bytes its body may be.
            lms_form: An LMS's login or launch form, posted by anyone's browser: read within a budget of its own
                (:data:`LTI_BODIES_READ_BYTES`), so that forms that never end hold back no student's work.
        """
        declared = request.content_length
        if declared is not None and declared > most:
            return _refusal(413, f"the request is larger than {most:,} bytes")
        counted = most if declared is None else declared
        if lms_form:
            if self._reading_lti_bytes + counted > LTI_BODIES_READ_BYTES:
                self._refused("lti bodies", "too many LMS forms were being read at once; one was asked again later")
                return _come_back(503, "the class is reading many sign-ins at once: start yours again in a moment", 1)
        elif self._reading_bytes + counted > self.bodies_read_bytes:
            self._refused("bodies", "too many requests' bodies were being read at once; one was asked again later")
            return _come_back(503, "the server is reading many requests at once: send yours again in a moment", 1)
        if lms_form:
            self._reading_lti_bytes += counted
        else:
            self._reading_bytes += counted
        try:
            body = await asyncio.wait_for(request.read(), self.body_deadline_s)
            return body if len(body) <= most else _refusal(413, f"the request is larger than {most:,} bytes")
        except asyncio.TimeoutError:
            self._refused("slow bodies", "a request's body did not come whole in time; it was let go")
            return _refusal(408, f"the request's body did not come whole within {self.body_deadline_s:g} s")
        except web.HTTPRequestEntityTooLarge:
            return _refusal(413, f"the request is larger than {MAX_REQUEST_BYTES:,} bytes")
        except (web.RequestPayloadError, ConnectionError):  # a broken gzip, or the client went
            return _refusal(400, "the request's body could not be read (is its Content-Encoding right?)")
        finally:
            if lms_form:
                self._reading_lti_bytes -= counted
            else:
                self._reading_bytes -= counted

    async def _mission(self, request: web.Request) -> str | web.Response:
        """The mission's text a request's body carries (``{"mission": TEXT}``), or the refusal."""
        body = await self._body(request)
        if isinstance(body, web.Response):
            return body
        try:
            sent = json.loads(body.decode("utf-8"))
        except (ValueError, RecursionError):  # not JSON (nor UTF-8), or nested deeper than a reader goes
            return _refusal(400, 'the body is JSON: {"mission": "the mission file\'s text"}')
        mission = sent.get("mission") if isinstance(sent, dict) else None
        if not isinstance(mission, str):
            return _refusal(400, 'the body is JSON: {"mission": "the mission file\'s text"}')
        try:
            mission.encode("utf-8")
        except UnicodeEncodeError:
            return _refusal(400, "the mission holds a character that is not text (half of a surrogate pair)")
        return mission

    # ------------------------------------------------------------------ routes

    async def _one_at_a_time(self, request: web.Request) -> Student | web.Response:
        """Who asks, now marked as having a request under way (release with :meth:`_done`); or the refusal.

        Nothing of the request's body has been read yet: a student with a request under way is
        refused before theirs is.
        """
        student = await self._student(request)
        if isinstance(student, web.Response):
            return student
        if student.id in self._busy:
            return _refusal(429, UNDER_WAY)
        self._busy.add(student.id)
        return student

    def _done(self, student: Student) -> None:
        self._busy.discard(student.id)

    async def _student_work(
        self, request: web.Request, read: Callable[[web.Request], Any], work: Callable[[Exercise, Any], Any]
    ) -> Any:
        """One request of a student's at a time: what it sends (``read``), worked on off the loop; or the refusal.

        A student whose checks took more than :data:`CHECK_CPU_SHARE_S` of CPU time in the last
        :data:`CHECK_WINDOW_S` is asked to come back once enough of it is past, and one whose check took more than
        :data:`COSTLY_CHECK_S` in it is checked in the lane for costly checks: the checks' threads are the
        class's, and a text made to be costly to check takes its student's share of a lane of its own (a process).
        """
        student = await self._one_at_a_time(request)
        if isinstance(student, web.Response):
            return student
        try:
            now_s = self._clock.now()
            spent = _lately(self._checked.setdefault(student.id, collections.deque()), now_s, CHECK_WINDOW_S)
            if spent and sum(cpu_s for _, cpu_s in spent) > CHECK_CPU_SHARE_S:
                wait_s = CHECK_WINDOW_S - (now_s - spent[0][0])
                why = "your last checks took much of the machine the class shares: check again in"
                return _come_back(429, f"{why} {max(1, math.ceil(wait_s))} s", wait_s)
            sent = await read(request)
            if isinstance(sent, web.Response):
                return sent
            costly = any(cpu_s > COSTLY_CHECK_S for _, cpu_s in spent)  # in their own lane, apart from the class's
            try:
                done, cpu_s = await asyncio.get_running_loop().run_in_executor(
                    self._costly_checkers if costly else self._checkers, _costed, work, self.exercise, sent
                )
            except BrokenProcessPool:  # the costly checks' process ended (its memory?): a new one for the next
                self._costly_checkers = _costly_lane()
                spent.append((self._clock.now(), CHECK_CPU_SHARE_S))
                return _come_back(503, "your check could not be finished: check again in a moment", 1)
            spent.append((self._clock.now(), cpu_s))
            return done
        finally:
            self._done(student)

    async def _check(self, request: web.Request) -> web.StreamResponse:
        # off the server's loop: a tree of 3,000 nodes takes a third of a second to draw
        checked = await self._student_work(request, self._mission, check)
        if isinstance(checked, web.Response):
            return checked
        checked["hand_ins_open"] = self._hand_ins_open()
        body = json.dumps(checked).encode()
        return await self._send_in_pieces(request, body, "application/json", NO_STORE)  # trees are big

    async def _blocks(self, request: web.Request) -> web.StreamResponse:
        """The mission's text as blocks (``{"mission": TEXT}``), or its problems: a text with problems stays text.

        ``?line=N``: the line the text's cursor is on; the answer's ``selected`` is the block of its node.
        """
        line = query_line(request)
        shown = await self._student_work(request, self._mission, functools.partial(as_blocks, line=line))
        if isinstance(shown, web.Response):
            return shown
        return await self._send_in_pieces(request, json.dumps(shown).encode(), "application/json", NO_STORE)

    async def _text(self, request: web.Request) -> web.Response:
        """The blocks as the mission's text (``{"workspace": ...}``), or their problems, each at its block.

        ``?selected=ID``: the block selected; the answer's ``line`` is where its node begins in the text.
        """
        selected = query_selected(request)
        shown = await self._student_work(request, self._body, functools.partial(as_text, selected=selected))
        return shown if isinstance(shown, web.Response) else _json(shown)

    async def _palette_of(self, request: web.Request) -> web.StreamResponse:
        """The blocks a page defines and its toolbox (the exercise's allowed nodes), to a student or the teacher."""
        if not self._teacher(request):
            student = await self._student(request)
            if isinstance(student, web.Response):
                return student
        headers = {"Cache-Control": "private, max-age=3600"}
        return await self._send_in_pieces(request, self._palette, "application/json", headers)

    async def _vendor(self, request: web.Request) -> web.Response:
        return vendor_response(request.match_info["library"], request.match_info["name"])

    async def _run(self, request: web.Request) -> web.Response:
        return await self._graded(request, hand_in=False)

    async def _handin(self, request: web.Request) -> web.Response:
        return await self._graded(request, hand_in=True)

    async def _graded(self, request: web.Request, hand_in: bool) -> web.Response:
        student = await self._one_at_a_time(request)
        if isinstance(student, web.Response):
            return student
        try:
            if hand_in and not self._hand_ins_open():
                return _json({"error": "hand-ins are closed: the deadline has passed", "hand_ins_open": False}, 403)
            kind = "handin" if hand_in else "run"
            most = HANDINS_PER_MINUTE if hand_in else RUNS_PER_MINUTE
            now_s = self._clock.now()
            done = self._runs.setdefault((student.id, kind), collections.deque())
            while done and now_s - done[0] >= 60.0:
                done.popleft()
            verb = "hand in" if hand_in else "run"
            if len(done) >= most:
                wait_s = 60.0 - (now_s - done[0])
                why = f"{most} {'hand-ins' if hand_in else 'runs'} a minute at most: you can {verb} again in"
                return _come_back(429, f"{why} {max(1, math.ceil(wait_s))} s", wait_s)
            hour = self._runs.setdefault((student.id, "handin-hour"), collections.deque()) if hand_in else None
            while hour and now_s - hour[0] >= 3600.0:
                hour.popleft()
            if hour is not None and len(hour) >= HANDINS_PER_HOUR:
                wait_s = 3600.0 - (now_s - hour[0])
                why = f"{HANDINS_PER_HOUR} hand-ins an hour at most: you can hand in again in"
                return _come_back(429, f"{why} {max(1, math.ceil(wait_s / 60))} min", wait_s)
            ended_s, took_s = self._long.get(student.id, (0.0, 0.0))
            if now_s < ended_s + took_s:  # their last grading was long: the others' go first
                wait_s = ended_s + took_s - now_s
                why = "your last grading took long, and the class shares the machine: you can"
                return _come_back(429, f"{why} {verb} again in {max(1, math.ceil(wait_s))} s", wait_s)
            mission = await self._mission(request)
            if isinstance(mission, web.Response):
                return mission
            done.append(self._clock.now())
            if hour is not None:
                hour.append(self._clock.now())
            return await self._grade(student, mission, kind, request.query.get("as") == "blocks")
        finally:
            self._done(student)

    async def _grade(self, student: Student, mission: str, kind: str, from_blocks: bool = False) -> web.Response:
        loop = asyncio.get_running_loop()
        forget = {"runs_kept": RUN_TEXTS_KEPT, "results_kept": RUN_RESULTS_KEPT} if kind == "run" else {}
        checked = await loop.run_in_executor(self._checkers, check, self.exercise, mission)
        if not checked["ok"]:
            first = checked["problems"][0]
            problem = f"line {first['line']}, column {first['column']}: {first['message']}"[:MAX_PROBLEM_CHARS]
            kept = {"problems": checked["problems"][:PROBLEMS_KEPT]}
            # a refused run's text is one of the runs' texts kept: the last ones alone
            self.store.add_work(student.id, kind, mission[:MAX_MISSION_CHARS], kept, problem=problem, **forget)
            self._change(student.id)
            return _json({"ok": False, "problems": checked["problems"]}, 422)
        number = self.store.new_number()  # kept once graded, in one write: until then its files alone have it
        count = self.store.count(student.id, kind) + 1  # theirs: hand-in 3 is their third (one at a time each)
        try:
            label = f"{'hand-in' if kind == 'handin' else 'run'} {count}"
            grading = functools.partial(self._grader, label=label)  # what their page is headed by: no id
            report, page = await self._in_lane(student.id, grading, mission, number, kind == "handin")
        except Exception as err:  # noqa: BLE001 - said in one line, kept as the work's problem, answered 500
            if isinstance(err, OSError) and err.errno in DISK_ERRNOS:
                await loop.run_in_executor(self._chores, self._let_go, student.id, number, kind)
                raise  # the disk: said as the store's faults are (nothing of the work is kept)
            # a cluster that cannot grade says why (its workers gone); anything else, its kind alone
            why = f"the grading failed: {err if isinstance(err, ClusterUnfit) else type(err).__name__}"
            self._refused(f"grading {type(err).__name__}", f"{why} (work {number})")
            self._keep(student.id, kind, mission, {"error": why}, None, None, why, number)
            if kind == "run":  # its text is one of the runs' texts kept, as a graded run's is: in the database
                await loop.run_in_executor(self._chores, self._let_go, student.id, number, kind, False)
            return _refusal(500, why)
        shown = seen_by_student(self.exercise, report)
        problem = report.problems[0] if report.problems else ""
        kept_result = {**report.to_json(), **({"written_as": "blocks"} if from_blocks else {})}
        self._keep(student.id, kind, mission, kept_result, report.total, report.max_points, problem, number)
        kept = await loop.run_in_executor(self._chores, self._bound_disk, student.id, number, kind, count, page)
        if kind == "handin" and self.lms_link is not None:  # its mark to the LMS's gradebook (queued: kept first)
            await loop.run_in_executor(self._chores, self._lms_mark, student.id)
        return _json(
            {
                "ok": True,
                "number": number,
                "kind": kind,
                "count": count,
                "page": _as_seen(self._page_url(number), "blocks" if from_blocks else None) if kept else None,
                "page_problem": "" if kept else f"its replay is over {MAX_PAGE_BYTES // 2**20} MB: too large to keep",
                **shown,
            }
        )  # kept before it is said

    def _keep(
        self, student: str, kind: str, mission: str, result: dict[str, Any], total: float | None,
        most: float | None, why: str, number: int,
    ) -> None:  # fmt: skip
        """Keeps a graded work, in one write (the texts of the student's runs but their last ones forgotten in it).

        Where it cannot be kept, nothing of it is: its files go too, and it raises (see :meth:`_keeping`).
        """
        forget = {"runs_kept": RUN_TEXTS_KEPT, "results_kept": RUN_RESULTS_KEPT} if kind == "run" else {}
        try:
            self.store.add_work(
                student, kind, mission, _bounded(result), total, most, why[:MAX_PROBLEM_CHARS], number=number, **forget
            )
        except StoreError:
            self._let_go(student, number, kind)
            raise
        self._change(student)

    def _let_go(self, student: str, number: int, kind: str, page_too: bool = True) -> None:
        """A work's files go: its text's (the database keeps it, or nothing does), and its page unless told."""
        try:
            work_file(self.folder, student, number, hand_in=kind == "handin").unlink(missing_ok=True)
            if page_too:
                page_file(self.folder, student, number).unlink(missing_ok=True)
        except OSError:
            pass

    async def _in_lane(
        self, student: str, grading: Callable[..., tuple[Report, Path]], mission: str, number: int, hand_in: bool
    ) -> tuple[Report, Path]:
        """Grades in a lane: a student known to be slow in the lane for anyone, the others in the less busy.

        A student is slow for :data:`SLOW_MEMORY_S` after a grading of theirs took long, or needed more than
        :data:`QUICK_GRADING_CPU_S`, and while their gradings took more than :data:`GRADING_CPU_SHARE_S` in
        the last :data:`GRADING_WINDOW_S`. Any other's grading may take :data:`QUICK_GRADING_CPU_S` alone:
        one that needs more is graded again with the whole budget, in the lane for anyone. So students whose
        missions spin, first time or not, hold a lane for two seconds at most and then share one: the rest of
        the class is graded in the other. CPU time is counted in the grading's own process (never wall time,
        which a busy machine stretches for everyone); a grading that took long holds its student's next back
        as long.
        """
        slow = self._slow(student)
        lane = 0 if slow or self._waiting[0] < self._waiting[1] else 1
        report, page = await self._graded_in(lane, grading, mission, student, number, hand_in, slow)
        overran = report.cpu_s >= QUICK_GRADING_CPU_S or cpu_used_up_why(QUICK_GRADING_CPU_S) in report.problems
        # not graded within the quick budget: more CPU time needed, or, on a machine busy with more than the
        # class, more wall time (a mission with problems of its own never comes here: its check refused it)
        if not slow and (overran or report.problems):
            if overran:
                self._long[student] = (self._clock.now(), report.cpu_s)
            report, page = await self._graded_in(0, grading, mission, student, number, hand_in, True)
        self._spent.setdefault(student, collections.deque()).append((self._clock.now(), report.cpu_s))
        if report.cpu_s > LONG_GRADING_S:
            self._long[student] = (self._clock.now(), report.cpu_s)
        return report, page

    def _slow(self, student: str) -> bool:
        """Whether a student's gradings are graded in the lane for anyone (see :meth:`_in_lane`)."""
        now_s = self._clock.now()
        if student in self._long and now_s - self._long[student][0] < SLOW_MEMORY_S:
            return True
        spent = _lately(self._spent.get(student, collections.deque()), now_s, GRADING_WINDOW_S)
        return sum(cpu_s for _, cpu_s in spent) > GRADING_CPU_SHARE_S

    async def _graded_in(
        self, lane: int, grading: Callable[..., tuple[Report, Path]], mission: str, student: str, number: int,
        hand_in: bool, whole: bool,
    ) -> tuple[Report, Path]:  # fmt: skip
        """One grading in ``lane``, with the whole CPU budget or the quick one."""
        budget = {} if whole else {"cpu_s": QUICK_GRADING_CPU_S}
        self._waiting[lane] += 1
        try:
            return await asyncio.get_running_loop().run_in_executor(
                self._lanes[lane],
                functools.partial(grading, **budget),
                self.exercise, student, mission, self.folder, number, hand_in,
            )  # fmt: skip
        finally:
            self._waiting[lane] -= 1

    def _bound_disk(self, student: str, number: int, kind: str, count: int, page: Path) -> bool:
        """Bounds what a student keeps on disk; whether this work's page is kept.

        No page over :data:`MAX_PAGE_BYTES`; the pages of their last :data:`RUN_PAGES_KEPT` runs and
        :data:`HANDIN_PAGES_KEPT` hand-ins, within :data:`RUN_PAGE_BYTES_KEPT` and
        :data:`HANDIN_PAGE_BYTES_KEPT` (the newest first); the texts of their last :data:`RUN_TEXTS_KEPT` runs,
        in the database alone (a hand-in's text is kept for good, in both).
        """
        try:
            if page.stat().st_size > MAX_PAGE_BYTES:
                page.unlink()
            if kind == "handin":
                most, most_bytes = HANDIN_PAGES_KEPT, HANDIN_PAGE_BYTES_KEPT
            else:
                most, most_bytes = RUN_PAGES_KEPT, RUN_PAGE_BYTES_KEPT
            kept_bytes = 0
            # the newest first; one past the count too (the older ones went when they were past it)
            for k, older in enumerate(self.store.latest(student, kind, most + 1)):
                path = page_file(self.folder, student, older)
                size = path.stat().st_size if path.is_file() else 0
                kept_bytes += size
                if k >= most or (k > 0 and kept_bytes > most_bytes):
                    path.unlink(missing_ok=True)
            if kind == "run":  # the database keeps its text (the last runs' alone)
                self._let_go(student, number, kind, page_too=False)
            return page.is_file()
        except OSError:
            return False

    # ------------------------------------------------------------------ pages

    def _page_policy(self, *framing_urls: str) -> str:
        """The pages' policy: :data:`PAGE_POLICY`, with the robots' live views framed, and the LMS framing the pages.

        An LMS launches the tool in a frame of its own: its origins (its issuer's, those lti-config was given with
        ``--frame-origin``, and those of the services its teacher's launches named) may frame the pages.
        """
        policy = PAGE_POLICY
        if self.lti is not None:
            framing = " ".join(frame_origins(self.lti.platform, *self._lms_urls, *framing_urls))
            if framing:
                policy = policy.replace("frame-ancestors 'none'", f"frame-ancestors {framing}")
        if self.robots is None:
            return policy
        views = " ".join(origin for port in self.robots.view_ports() for origin in origins(self.host, port))
        return policy.replace("frame-src 'self'", f"frame-src 'self' {views}")

    # ------------------------------------------------------------------ LTI 1.3: the class inside an LMS

    async def _lti_jwks(self, request: web.Request) -> web.Response:
        """The tool's public key (``GET /lti/jwks``), which the LMS checks the tool's signatures with."""
        if self.lti is None:
            raise web.HTTPNotFound()
        return _json(self.lti.key.jwks())

    async def _lti_form(self, request: web.Request) -> dict[str, str] | web.Response:
        """A login's or launch's fields: the query's, and a form's body read against the deadline; or the refusal."""
        given = {key: value for key, value in request.query.items()}
        if request.method == "POST":
            body = await self._body(request, LTI_MOST_BYTES, lms_form=True)
            if isinstance(body, web.Response):
                return body
            try:
                given |= dict(urllib.parse.parse_qsl(body.decode("ascii"), max_num_fields=32))
            except (UnicodeDecodeError, ValueError):
                return _refusal(400, "an LTI form is application/x-www-form-urlencoded ASCII")
        return given

    async def _lti_login(self, request: web.Request) -> web.StreamResponse:
        """The LMS's login initiation (``/lti/login``): the browser sent back to the LMS with a state and a nonce."""
        if self.lti is None:
            raise web.HTTPNotFound()
        given = await self._lti_form(request)
        if isinstance(given, web.Response):
            return given
        redirect_uri = tool_urls(self._public_url(request))["redirect_uri"]
        try:
            address, state = self.lti.login(given, redirect_uri)
        except LaunchRefused as err:
            return _refusal(401, f"LTI login refused: {err}")
        answer = web.Response(status=302, headers={"Location": address, **NO_STORE})
        answer.set_cookie(
            state_cookie(state), state, max_age=int(STATE_S), path="/", httponly=True, secure=True, samesite="None"
        )  # fmt: skip - the launch is a post from the LMS's site; a cookie each, so that two tabs' logins both hold
        return answer

    async def _lti_launch(self, request: web.Request) -> web.StreamResponse:
        """The LMS's launch (``POST /lti/launch``): its id_token checked whole, then the person signed in.

        A learner is signed in to the student's page, an instructor to the teacher's desk.
        """
        if self.lti is None:
            raise web.HTTPNotFound()
        given = await self._lti_form(request)
        if isinstance(given, web.Response):
            return given
        lti, loop = self.lti, asyncio.get_running_loop()
        try:  # the state first: a launch this tool gave no login costs no fetch of the LMS's keys
            state = given.get("state", "")
            nonce = lti.claim(state, request.cookies.get(state_cookie(state), "") if state else "")
            course = json.loads(self.store.setting(lms.COURSE, "{}")).get("id", "")
            jwks = await loop.run_in_executor(self._lti_keys, lti.keys) if lti.needs_fetch() else lti.keys()
            try:
                launch = lti.check(given.get("id_token", ""), nonce, jwks, course)
            except UnknownKey:  # a key the LMS added since its keys were fetched: fetched again, once a while
                if not lti.needs_fetch(again=True) or wall_time_s() - lti.fetched_at_s() < JWKS_RETRY_S:
                    raise
                jwks = await loop.run_in_executor(self._lti_keys, functools.partial(lti.keys, again=True))
                launch = lti.check(given.get("id_token", ""), nonce, jwks, course)
            ties = not (lti.platform.course_id or course)
            if launch.deep_link is not None:  # the teacher adds the class to the course: the page they confirm on
                await loop.run_in_executor(self._chores, self._lti_teacher, launch, ties, False)
                answer = self._deep_link_page(launch, self._public_url(request))
            elif launch.instructor:
                code = await loop.run_in_executor(self._chores, self._lti_teacher, launch, ties)
                answer = web.Response(status=303, headers={"Location": f"/teacher#{code}", **NO_STORE})
            else:
                code = await loop.run_in_executor(self._chores, self._lti_student, launch)
                answer = web.Response(status=303, headers={"Location": f"/#code={code}", **NO_STORE})
        except LaunchRefused as err:
            return _refusal(401, f"LTI launch refused: {err}")
        answer.del_cookie(state_cookie(state), path="/", secure=True, samesite="None")
        return answer

    def _lti_keep(self, launch: Launch) -> None:
        """Keeps what a teacher's launch says of the course's services (where its roster and its line items are).

        A learner's launch changes none (another graded link of the course would send the marks to its column).
        The link's own line item is the first one given, kept until it is gone (its column deleted).
        """
        kept = self.store.setting(lms.LINK_LINEITEM_URL)
        for key, value in ((lms.MEMBERSHIPS_URL, launch.memberships_url), (lms.LINEITEMS_URL, launch.lineitems_url),
                           (lms.LINK_LINEITEM_URL, "" if kept else launch.lineitem_url)):  # fmt: skip
            if value and self.store.setting(key) != value:
                self.store.set_setting(key, value)
                self._lms_urls = (*self._lms_urls, value)[-8:]
                if self.lms_link is not None:  # marks that waited for where the gradebook is
                    self.lms_link.nudge()

    def _lti_teacher(self, launch: Launch, ties: bool, session: bool = True) -> str:
        """An instructor's session (the class tied to their course, if it was to none); the roster read anew."""
        if ties:
            self.store.set_setting(lms.COURSE, json.dumps({"id": launch.course_id, "title": launch.course_title}))
            said = f"{launch.course_title} ({launch.course_id})" if launch.course_title else launch.course_id
            self._refused("lms course", f"LMS: the class is course {printable(said)[:120]}'s from now on")
        self._lti_keep(launch)
        lms.take_roster(self.store, [lms.Member(launch.subject, launch.name, "", True, True)])
        if self.lms_link is not None:
            self.lms_link.nudge(roster=True)
        return self.store.new_session("", LTI_SESSION_S) if session else ""

    def _deep_link_page(self, launch: Launch, base_url: str) -> web.Response:
        """The page a teacher adding the class to their course confirms on: the exercise, and two buttons.

        Each button posts the signed answer to the LMS (its form's action, the one address the page's policy lets
        a form go to): the exercise as a link with its line item, or nothing (they changed their mind).
        """
        if self.lti is None or launch.deep_link is None:
            raise ValueError("not a deep-linking request")
        back = launch.deep_link[0]
        exercise = self.exercise
        item = {
            "type": "ltiResourceLink",
            "title": exercise.title,
            "text": exercise.description,
            "url": tool_urls(base_url)["tool_url"],
            "lineItem": {
                "scoreMaximum": exercise.max_points + exercise.robot_points,
                "label": exercise.title,
                "resourceId": f"autonomy:{exercise.name}",
                "tag": lms.TAG,
            },  # fmt: skip
        }
        added = self.lti.deep_link_answer(launch, item)
        none = self.lti.deep_link_answer(launch, None)
        page = DEEP_LINK_PAGE.format(
            title=html.escape(exercise.title),
            text=html.escape(exercise.description),
            points=html.escape(f"{exercise.max_points + exercise.robot_points:g}"),
            back=html.escape(back, quote=True),
            added=html.escape(added, quote=True),
            none=html.escape(none, quote=True),
        )
        parts = urllib.parse.urlsplit(back)  # the LMS's page it goes back to frames it, and takes its forms
        policy = self._page_policy(back).replace("form-action 'none'", f"form-action {parts.scheme}://{parts.netloc}")
        headers = {"Content-Security-Policy": policy, **NO_STORE}
        return web.Response(text=page, content_type="text/html", headers=headers)

    def _lti_student(self, launch: Launch) -> str:
        """A learner's session: on the roster from now on (the LMS vouches for them), then a code of the session's.

        Raises:
            LaunchRefused: their id is another LMS person's.
        """
        student = lms.admit(self.store, launch.subject, lms.student_id(launch.subject, launch.roster_id), launch.name)
        self._loop.call_soon_threadsafe(self._change, student)
        self._lms_mark(student)  # a mark of theirs from before the LMS knew them
        return self.store.new_session(student, LTI_SESSION_S)

    def _lms_mark(self, student: str) -> None:
        """Queues a student's mark for the LMS (their last hand-in's, and their best run's on a robot); off the loop."""
        if self.lms_link is None:
            return
        (row,) = self.store.summary([student]) or [None]
        if row is None or (row["max_points"] is None and row["robot_points"] is None):
            return
        given = (row["total"] or 0.0) + (row["robot_points"] or 0.0)
        maximum = self.exercise.max_points + self.exercise.robot_points
        said = [f"Hand-in: {_points(row['total'])} / {_points(self.exercise.max_points)}."]
        if self.exercise.robot_points:
            said.append(f"On a robot: {_points(row['robot_points'])} / {_points(self.exercise.robot_points)}.")
        page = self._page_url(row["last_handin"]) if row["last_handin"] else None
        if page and self.public_url:
            said.append(f"Feedback: {self.public_url}{page}")
        if lms.queue_score(self.store, student, round(given, 4), maximum, " ".join(said)):
            self.lms_link.nudge()

    async def _lms_desk(self, request: web.Request) -> web.Response:
        """What the desk shows of the LMS (``GET /api/lms``): its course, roster and scores; the teacher's alone."""
        if not self._teacher(request):
            return _refusal(401, "the teacher's token is needed")
        if self.lti is None:
            return _json({"lms": None})
        said = await asyncio.get_running_loop().run_in_executor(self._chores, self._lms_said)
        return _json(said)

    def _lms_said(self) -> dict[str, Any]:
        link = self.lms_link
        return {
            "lms": self.lti.platform.issuer if self.lti is not None else None,
            "course": (
                {"id": self.lti.platform.course_id, "title": ""}
                if self.lti is not None and self.lti.platform.course_id
                else json.loads(self.store.setting(lms.COURSE, "{}")) or None
            ),
            "instructors": lms.instructors(self.store),
            "roster": json.loads(self.store.setting(lms.ROSTER_READ, "{}")) or None,
            "services": link is not None,
            "problem": link.problem if link is not None else "",
            "scores": lms.scores_said(self.store),
        }

    async def _lms_again(self, request: web.Request) -> web.Response:
        """Sends the marks the LMS refused again (``POST /api/lms/again``), the teacher having mended why."""
        if not self._teacher(request):
            return _refusal(401, "the teacher's token is needed")
        if self.lms_link is None:
            return _refusal(409, "the class sends no marks to an LMS (docs/lms.md)")
        again = await asyncio.get_running_loop().run_in_executor(self._chores, self.lms_link.send_again)
        self._change()
        return _json({"again": again})

    async def _lms_roster(self, request: web.Request) -> web.Response:
        """Reads the LMS's roster anew (``POST /api/lms/roster``); the teacher's alone. Answered at once (202)."""
        if not self._teacher(request):
            return _refusal(401, "the teacher's token is needed")
        if self.lms_link is None:
            return _refusal(409, "the class has no LMS with a roster: give lti-config its --token-url (docs/lms.md)")
        self.lms_link.nudge(roster=True, now=True)
        return _json({"ok": True}, 202)

    def _public_url(self, request: web.Request) -> str:
        """The address the LMS knows the tool by: ``--public-url`` or lti-config's, else the request's own."""
        return self.public_url or f"{request.scheme}://{request.host}"

    async def _file(self, name: str, request: web.Request) -> web.Response:
        if name.endswith(".html"):
            return nonced_page(page_text(name), self._page_policy())
        return web.Response(
            text=page_text(name), content_type=PAGE_FILES[name], headers={"Content-Security-Policy": PAGE_POLICY}
        )

    async def _static(self, request: web.Request) -> web.Response:
        name = request.match_info["name"]
        if name not in PAGE_FILES or name.endswith(".html"):
            raise web.HTTPNotFound()
        return await self._file(name, request)

    def _page_key(self, number: int) -> str:
        return hmac.new(self._key, f"page {number}".encode(), hashlib.sha256).hexdigest()[:32]

    def _page_url(self, number: int | None) -> str | None:
        """Where a graded work's feedback page is: an address only its student and the teacher are given."""
        return None if number is None else f"/pages/{number}-{self._page_key(number)}.html"

    async def _page(self, request: web.Request) -> web.Response:
        """A work's feedback page, to the one who has its address: in a sandbox, framed by the class's pages alone."""
        named = _PAGE_NAME.fullmatch(request.match_info["name"])
        if not named or not hmac.compare_digest(named[2], self._page_key(int(named[1]))):
            raise web.HTTPNotFound()
        work = self.store.work(int(named[1]))
        path = page_file(self.folder, work.student, work.id) if work is not None else None
        if path is None or not path.is_file():
            raise web.HTTPNotFound()
        headers = {"Content-Security-Policy": FEEDBACK_POLICY, **NO_STORE}
        return await self._send_in_pieces(request, path, "text/html; charset=utf-8", headers, page=True)

    # ------------------------------------------------------------------ the student's

    def _hand_ins_of(self, student: str) -> list[dict[str, Any]]:
        """A student's hand-ins as their page lists them, without their texts, each with its page if it has one."""
        works = self.store.work_list(student, "handin")
        for work in works:
            graded = work["total"] is not None and page_file(self.folder, student, work["number"]).is_file()
            work["page"] = _as_seen(self._page_url(work["number"]), work.pop("written_as")) if graded else None
        return works

    async def _me(self, request: web.Request) -> web.Response:
        """The exercise, and (to a student) who they are, their works, and their last mission's text."""
        if self._teacher(request):
            return _json({"exercise": self._exercise_shown, "deadline_s": self._deadline_s()})
        student = await self._student(request)
        if isinstance(student, web.Response):
            return student
        if student.id in self._reading_history:  # one at a time (beside a check of theirs): none queue up
            return _refusal(429, UNDER_WAY)
        self._reading_history.add(student.id)
        try:
            # their hand-ins alone (runs are not listed: an hour of them is hundreds), and their last text, off the loop
            works, mission, robot_runs = await asyncio.get_running_loop().run_in_executor(
                self._chores, self._history, student.id
            )
        finally:
            self._reading_history.discard(student.id)
        me = {
            "exercise": self._exercise_shown,
            "deadline_s": self._deadline_s(),
            "hand_ins_open": self._hand_ins_open(),
            "student": {"id": printable(student.id), "name": printable(student.name)},
            "mission": mission,
            "works": works,
            "robots": len(self.robots.robots) if self.robots is not None else 0,
            "robot_runs": robot_runs,
        }
        return await self._send_in_pieces(request, json.dumps(me).encode(), "application/json", NO_STORE)

    def _history(self, student: str) -> tuple[list[dict[str, Any]], str, list[dict[str, Any]]]:
        """A student's hand-ins (see :meth:`_hand_ins_of`), their last mission's text, their runs on robots."""
        return self._hand_ins_of(student), self.store.last_source(student), self._robot_runs_of(student)

    # ------------------------------------------------------------------ the class's robots

    def _robot_runs_of(self, student: str) -> list[dict[str, Any]]:
        """A student's runs on the class's robots, each with its replay's address (None: none was kept)."""
        runs = self.store.robot_runs(student)
        for run in runs:
            run["label"] = f"on robot {run['robot']}"
            run["page"] = self._robot_page_url(run["number"])
            run["emulated_page"] = self._robot_page_url(run["number"], emulated=True)
        return runs

    def _robot_page_url(self, number: int, emulated: bool = False) -> str | None:
        """Where a run on a robot is replayed (or the emulated run beside it): its student's and the teacher's alone."""
        if not run_files(self.folder, number)[2 if emulated else 1].is_file():
            return None
        key = hmac.new(self._key, f"robot run {number}".encode(), hashlib.sha256).hexdigest()[:32]
        return f"/robot-runs/{number}-{key}{'-emulated' if emulated else ''}.html"

    async def _robot_page(self, request: web.Request) -> web.StreamResponse:
        """A run on a robot replayed, or the emulated run beside it (pages of their own), to whoever has its address."""
        named = _ROBOT_PAGE_NAME.fullmatch(request.match_info["name"])
        emulated = bool(named and named[3])
        if not named or self._robot_page_url(int(named[1]), emulated) != f"/robot-runs/{named[0]}":
            raise web.HTTPNotFound()
        headers = {"Content-Security-Policy": FEEDBACK_POLICY, **NO_STORE}
        path = run_files(self.folder, int(named[1]))[2 if emulated else 1]
        return await self._send_in_pieces(request, path, "text/html; charset=utf-8", headers, page=True)

    def _robot_said(self, student: Student) -> dict[str, Any]:
        """What a student's page shows of the robots: their ticket, and their last run's replay once it is kept."""
        assert self.robots is not None  # noqa: S101 - asked only of a class with robots
        said = self.robots.of(student.id)
        ticket = said["ticket"]
        if ticket is not None and ticket["run"] is not None:
            ticket["page"] = self._robot_page_url(ticket["run"])
            ticket["emulated_page"] = self._robot_page_url(ticket["run"], emulated=True)
        return said

    async def _robot_state(self, request: web.Request) -> web.Response:
        """A student's place in the robots' queue, or their run on a robot (``GET /api/robot``)."""
        student = await self._student(request)
        if isinstance(student, web.Response):
            return student
        if self.robots is None:
            return _refusal(404, "this class has no robots")
        return _json(self._robot_said(student))

    async def _robot_ask(self, request: web.Request) -> web.Response:
        """A student asks for a run on a robot of ``{"mission": TEXT}``: their last run's text, without problems."""
        student = await self._one_at_a_time(request)
        if isinstance(student, web.Response):
            return student
        try:
            if self.robots is None:
                return _refusal(404, "this class has no robots")
            mission = await self._mission(request)
            if isinstance(mission, web.Response):
                return mission
            why = await asyncio.get_running_loop().run_in_executor(self._chores, self._robot_refusal, student, mission)
            if why:
                return _refusal(409, why)
            why = self.robots.ask(student.id, student.name, mission)
            if why:
                return _refusal(409, why)
            return _json(self._robot_said(student))
        finally:
            self._done(student)

    def _robot_refusal(self, student: Student, mission: str) -> str:
        """Why a student may not run ``mission`` on a robot (empty: they may): it must have run without problems."""
        last = self.store.latest(student.id, "run", 1)
        work = self.store.work(last[0]) if last else None
        if work is None or work.source != mission:
            return "run this mission first: a robot runs a mission that ran without problems on the public seeds"
        if work.problem or work.total is None or "error" in work.result:
            return "your last run had problems: a robot runs a mission that ran without problems on the public seeds"
        return ""

    async def _robot_cancel(self, request: web.Request) -> web.Response:
        """A student leaves the robots' queue."""
        student = await self._student(request)
        if isinstance(student, web.Response):
            return student
        if self.robots is None:
            return _refusal(404, "this class has no robots")
        if not self.robots.cancel(student.id):
            return _refusal(409, "you are not waiting for a robot")
        return _json(self._robot_said(student))

    def _desk(self, robots: RobotDesk) -> dict[str, Any]:
        """What the teacher's desk shows of the robots (:meth:`RobotDesk.desk`), each kept run with its replay."""
        desk = robots.desk()
        for run in desk["runs"]:
            run["page"] = self._robot_page_url(run["number"])
        return desk

    def _teachers_robots(self, request: web.Request) -> RobotDesk | web.Response:
        """The class's robots, to the teacher; or the refusal (not the teacher, or a class without robots)."""
        if not self._teacher(request):
            return _refusal(401, "the robots are the teacher's: use the teacher's token")
        if self.robots is None:
            return _refusal(404, "this class has no robots: class serve --robot NAME=PORT")
        return self.robots

    async def _robots_desk(self, request: web.Request) -> web.Response:
        """The teacher's: each robot's state and run, and the queue."""
        robots = self._teachers_robots(request)
        return robots if isinstance(robots, web.Response) else _json(self._desk(robots))

    async def _robots_act(self, request: web.Request) -> web.Response:
        """The teacher's Start, Stop and marks of the robots' runs.

        ``POST /api/robots/start`` or ``/stop`` with ``{"robot": NAME}``; ``/mark`` with ``{"run": NUMBER,
        "points": POINTS or null}``.
        """
        robots = self._teachers_robots(request)
        if isinstance(robots, web.Response):
            return robots
        action = request.match_info["action"]
        if action not in ("start", "stop", "mark"):
            raise web.HTTPNotFound()
        body = await self._object(request)
        if isinstance(body, web.Response):
            return body
        if action == "mark":
            number = body.get("run")
            if (
                isinstance(number, bool)
                or not isinstance(number, int)
                or not 0 < number < 2**63
                or "points" not in body
            ):
                return _refusal(400, 'the body is JSON: {"run": the run\'s number, "points": its mark, or null}')
            try:
                why = await asyncio.get_running_loop().run_in_executor(
                    self._chores, robots.mark, number, body["points"]
                )
            except StoreError as err:
                return _refusal(500, str(err))
            if why:
                return _refusal(409, why)
            run = await asyncio.get_running_loop().run_in_executor(self._chores, self.store.robot_run, number)
            if run is not None and self.lms_link is not None:
                await asyncio.get_running_loop().run_in_executor(self._chores, self._lms_mark, run["student"])
            return _json(self._desk(robots))
        name = body.get("robot")
        if not isinstance(name, str):
            return _refusal(400, 'the body is JSON: {"robot": "the robot\'s name"}')
        why = robots.start_on(name) if action == "start" else robots.stop_on(name)
        if why:
            return _refusal(409, why)
        return _json(self._desk(robots))

    # ------------------------------------------------------------------ the teacher's

    def _deadline_s(self) -> float | None:
        deadline = self.store.setting(DEADLINE)
        return float(deadline) if deadline else None

    def _hand_ins_open(self) -> bool:
        """Whether hand-ins are open now, by this machine's clock (a page's clock may be off)."""
        deadline = self._deadline_s()
        return deadline is None or wall_time_s() < deadline

    async def _class(self, request: web.Request) -> web.Response:
        """The class table; with ``?after=V``, once it is newer than version V (or after :data:`CLASS_WAIT_S`)."""
        if not self._teacher(request):
            return _refusal(401, "the class table is the teacher's: use the teacher's token")
        after = request.query.get("after", "")
        if after.isascii() and after.isdigit() and int(after) >= self._version and self._changed is not None:
            if self._class_waiters >= CLASS_WAITERS:
                return _refusal(429, f"at most {CLASS_WAITERS} pages wait on the class at once")
            self._class_waiters += 1
            try:
                await asyncio.wait_for(self._changed.wait(), CLASS_WAIT_S)
            except TimeoutError:
                pass
            finally:
                self._class_waiters -= 1

        def make(version: int) -> asyncio.Future[bytes]:
            stale, self._stale = self._stale, set()  # the making reads these again (every row, if None)
            return asyncio.get_running_loop().run_in_executor(self._views, self._table_now, stale)

        version, rows = await self._table.of(self._clock, lambda: self._version, make)
        head = {
            "version": version,
            "exercise": self.exercise.name,
            "title": self.exercise.title,
            "max_points": self.exercise.max_points,
            "deadline_s": self._deadline_s(),
            "now_s": wall_time_s(),
            "robot_points": self.exercise.robot_points,
            "robots": self._desk(self.robots) if self.robots is not None else None,
        }
        body = json.dumps(head).encode()[:-1] + b', "students": ' + rows + b"}"
        return web.Response(body=body, content_type="application/json", headers=NO_STORE)

    def _table_now(self, stale: set[str] | None) -> bytes:
        """The class table's rows as JSON, read again for the ``stale`` students alone (None: all), off the loop.

        A long lesson's thousands of works are read once; after that, each change reads the works of the
        student it is of. Should a making fail, the next reads every row.
        """
        try:
            if self._table_rows is None or stale is None:
                self._table_rows = {row["id"]: self._shown_row(row) for row in self.store.summary()}
            elif stale:
                for row in self.store.summary(stale):
                    student = row["id"]
                    self._table_rows[student] = self._shown_row(row)
            return json.dumps(list(self._table_rows.values())).encode()
        except BaseException:
            self._table_rows = None
            raise

    def _shown_row(self, row: dict[str, Any]) -> dict[str, Any]:
        """A student's row of the class table as the teacher's page shows it."""
        row["id"], row["name"] = printable(row["id"]), printable(row["name"])
        # a work made from blocks: its page opens with them (#as-blocks), as its student last saw it
        row["latest_page"] = _as_seen(self._page_url(row.pop("last_graded")), row.pop("last_graded_as"))
        row["handin_page"] = _as_seen(self._page_url(row.pop("last_handin")), row.pop("last_handin_as"))
        return row

    async def _overview_of(self, request: web.Request) -> web.Response:
        """The class at a glance (:func:`class_overview`) of each student's latest graded work.

        Made once for each version of the class, one making at a time, off the loop, at most one every
        :data:`OVERVIEW_EVERY_S`: a teacher's pages asking as often as they like cost at most one making under
        way, and none while the class has not changed. Each answer is of the class as it was when asked, or later.
        """
        if not self._teacher(request):
            return _refusal(401, "the class at a glance is the teacher's: use the teacher's token")
        loop = asyncio.get_running_loop()
        _, body = await self._overview.of(
            self._clock,
            lambda: self._version,
            lambda version: loop.run_in_executor(self._views, self._overview_now, version),
            OVERVIEW_EVERY_S,
        )
        return web.Response(body=body, content_type="application/json", headers=NO_STORE)

    def _overview_now(self, version: int) -> bytes:
        """The class at a glance now, as JSON, with ``version``: the class's when it was asked for (read since)."""
        reports: list[Report] = []
        links: list[str | None] = []
        for row in self.store.summary():
            work = self.store.work(row["last_graded"]) if row["last_graded"] else None
            name = printable(row["name"])
            if work is None or "seeds" not in work.result:
                reports.append(Report(name, "", 0.0, self.exercise.max_points, [], ["no graded run yet"]))
                links.append(None)
                continue
            reports.append(replace(_report_of(work.result), student=name))
            links.append(_as_seen(self._page_url(work.id), row["last_graded_as"]))
        data = class_overview(self.exercise, reports, links, "each student's latest graded run or hand-in")
        return json.dumps({"version": version, **data}, separators=(",", ":")).encode()

    async def _object(self, request: web.Request) -> dict[str, Any] | web.Response:
        """A request's body as a JSON object (``{}`` when it is not one), or the refusal of its reading."""
        read = await self._body(request)
        if isinstance(read, web.Response):
            return read
        try:
            body = json.loads(read.decode("utf-8"))
        except (ValueError, RecursionError):
            body = None
        return body if isinstance(body, dict) else {}

    async def _deadline(self, request: web.Request) -> web.Response:
        """Sets (``{"deadline_s": EPOCH_S}``) or lifts (``null``) the hand-ins' deadline."""
        if not self._teacher(request):
            return _refusal(401, "the deadline is the teacher's: use the teacher's token")
        body = await self._object(request)
        if isinstance(body, web.Response):
            return body
        deadline = body.get("deadline_s", "missing")
        if deadline == "now":  # the server's clock: the teacher's page may be on a machine whose clock is off
            deadline = wall_time_s()
        if deadline is not None and not finite_number(deadline):
            return _refusal(400, 'the body is JSON: {"deadline_s": seconds since the epoch, "now", or null for none}')
        self.store.set_setting(DEADLINE, "" if deadline is None else repr(float(deadline)))
        self._change()
        return _json({"deadline_s": self._deadline_s()})

    async def _export(self, request: web.Request) -> web.Response:
        """The teacher's desk's exports: the gradebook, the autograder for Gradescope, every feedback page."""
        if not self._teacher(request):
            return _refusal(401, "the exports are the teacher's: use the teacher's token")
        name = request.match_info["name"]
        loop = asyncio.get_running_loop()
        if name == "grades.csv":
            body, kind = self._gradebook().encode("utf-8"), "text/csv"
        elif name == "feedback.zip":
            body, kind = await loop.run_in_executor(self._chores, self._feedback_zip), "application/zip"
        elif name == "autograder.zip" and self._autograder is not None:
            try:
                body, kind = await loop.run_in_executor(self._chores, self._autograder), "application/zip"
            except AutonomyError as err:
                return _refusal(500, str(err))
        else:
            raise web.HTTPNotFound()
        disposition = f'attachment; filename="{self.exercise.name}-{name}"'
        return web.Response(body=body, content_type=kind, headers={"Content-Disposition": disposition})

    def _handed_in(self) -> list[tuple[Student, Work | None]]:
        """Each student on the roster, with their last graded hand-in (None: none)."""
        last = {row["id"]: row["last_handin"] for row in self.store.summary()}
        return [
            (student, self.store.work(last[student.id]) if last.get(student.id) else None)
            for student in self.store.students()
        ]

    def _gradebook(self) -> str:
        """The gradebook, as ``autonomy grade --roster --csv`` writes it: ids first, each student's last hand-in."""
        listed: list[tuple[RosterEntry, Report | None]] = []
        for line, (student, work) in enumerate(self._handed_in(), start=2):
            report = _report_of(work.result) if work is not None and "seeds" in work.result else None
            listed.append((RosterEntry(student.id, student.name, "", line), report))
        on_robot = self.store.robot_marks() if self.exercise.robot_points else None
        return to_csv(self.exercise, [r for _, r in listed if r is not None], RosterMatch(listed, []), on_robot)

    def _feedback_zip(self) -> bytes:
        """Each student's last hand-in's feedback page, as ``ID.html``."""
        out = io.BytesIO()
        handed_in = self._handed_in()
        names = file_names(student.id for student, _ in handed_in)  # no two alike
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as archive:
            for student, work in handed_in:
                page = page_file(self.folder, student.id, work.id) if work is not None else None
                if page is not None and page.is_file():
                    archive.writestr(f"{names[student.id]}.html", page.read_bytes())
        return out.getvalue()

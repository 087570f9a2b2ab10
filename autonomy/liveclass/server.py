"""The class's server: the JSON API the students' and the teacher's pages use (and a script may).

Every route is under ``/api/``. A student's requests carry ``Authorization: Bearer CODE`` (the
sign-in code ``codes.csv`` gives them); the teacher's, the teacher's token. Bodies are JSON of at
most 1 MB. docs/class.md describes each route.

``POST /api/check``   ``{"mission": TEXT}`` -> the problems at their lines, or the tree drawn
``POST /api/run``     the mission, tried on the public seeds -> the marks of each (runs a minute are limited)
``POST /api/handin``  the mission, graded on every seed and kept -> what the student may see
``GET  /api/class``   (the teacher) every student's sign-in, runs, hand-ins, marks, last problem

The server checks who it talks to and bounds what each costs, as every server of ours
(:class:`~autonomy.views.web.BoundedServer`); a student's Python never runs; grading is done in
the grader's limited worker processes, two at a time.
"""

from __future__ import annotations

import asyncio
import collections
import hmac
import json
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from aiohttp import web

from autonomy.classroom.exercise import Exercise
from autonomy.classroom.grade import Report
from autonomy.clock import wall_time_s
from autonomy.liveclass.store import ClassStore, Student, code_digest
from autonomy.liveclass.work import MAX_MISSION_CHARS, check, grade_text
from autonomy.views.web import BoundedServer

#: Runs one student may start in a minute; past that they are told when they can run again.
RUNS_PER_MINUTE = 10
#: Hand-ins one student may make in a minute.
HANDINS_PER_MINUTE = 4
#: A wrong guess is forgotten after this long without another from the same address.
GUESS_MEMORY_S = 600.0
#: Checks at once (drawing a tree of 3,000 nodes takes a third of a second): off the server's loop.
CHECKS_AT_ONCE = 2
#: After a wrong code, the next answer to that address waits this long, doubling each time up to the most.
GUESS_WAIT_S = 0.25
MOST_GUESS_WAIT_S = 8.0
#: Addresses whose wrong guesses are remembered; past this the oldest are forgotten.
GUESSERS_KEPT = 10_000
#: Gradings at once (the machine's two cores).
GRADINGS_AT_ONCE = 2
#: What a student is told who sends a request while their last is under way.
UNDER_WAY = "your last request is still under way: send the next when it has its answer"
#: Largest request body.
MAX_REQUEST_BYTES = 1024 * 1024
#: The setting that holds the teacher's token's digest, and the one that holds the hand-ins' deadline.
TEACHER_TOKEN = "teacher_token_sha256"
DEADLINE = "deadline_s"


def _json(data: Any, status: int = 200, headers: dict[str, str] | None = None) -> web.Response:
    return web.Response(text=json.dumps(data), status=status, content_type="application/json", headers=headers)


def _refusal(status: int, why: str, **more: Any) -> web.Response:
    return _json({"error": why, **more}, status)


def seen_by_student(exercise: Exercise, report: Report) -> dict[str, Any]:
    """What a student is shown of a grading: the marks by criterion, and each seed's outcome.

    Hidden seeds are named ``hidden seed K``, never by their numbers.
    """
    return {
        "total": report.total,
        "max_points": report.max_points,
        "criteria": [
            {"label": criterion.label, "points": criterion.points, "earned": mark}
            for criterion, mark in zip(exercise.criteria, report.marks, strict=False)
        ],
        "seeds": [{"seed": seed.seed, "outcome": seed.outcome} for seed in report.seeds],
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
    """

    def __init__(self, exercise: Exercise, store: ClassStore, folder: Path, host: str = "127.0.0.1", port: int = 8770):
        super().__init__(host, port, "class")
        self.max_request_bytes = MAX_REQUEST_BYTES
        self.exercise = exercise
        self.store = store
        self.folder = Path(folder)
        self._runs: dict[tuple[str, str], collections.deque[float]] = {}
        #: Per address: wrong guesses, when the last was, and a lock that makes its guesses wait in turn.
        self._guesses: collections.OrderedDict[str, tuple[int, float, asyncio.Lock]] = collections.OrderedDict()
        self._graders = ThreadPoolExecutor(GRADINGS_AT_ONCE, thread_name_prefix="autonomy-grading")
        self._checkers = ThreadPoolExecutor(CHECKS_AT_ONCE, thread_name_prefix="autonomy-check")
        #: Students with a request under way (a check, a run or a hand-in): one at a time each.
        self._busy: set[str] = set()
        self._signed_in: set[str] = set()

    def _routes(self, app: web.Application) -> None:
        app.router.add_post("/api/check", self._check)
        app.router.add_post("/api/run", self._run)
        app.router.add_post("/api/handin", self._handin)
        app.router.add_get("/api/class", self._class)

    def _closing(self) -> None:
        self._graders.shutdown(wait=False, cancel_futures=True)
        self._checkers.shutdown(wait=False, cancel_futures=True)

    # ------------------------------------------------------------------ who asks

    async def _student(self, request: web.Request) -> Student | web.Response:
        """The student a request's code names, or the refusal (which waits longer after each wrong guess)."""
        address = request.remote or ""
        code = request.headers.get("Authorization", "").removeprefix("Bearer ").strip()
        student = self.store.student_by_code(code) if code else None
        if student is not None:
            if student.id not in self._signed_in:
                self._signed_in.add(student.id)
                self.store.sign_in(student.id)
            return student
        now_s = self._clock.now()
        wrong, last_s, lock = self._guesses.pop(address, (0, now_s, asyncio.Lock()))
        wrong = 1 if now_s - last_s > GUESS_MEMORY_S else wrong + 1  # a right code in between forgets nothing
        self._guesses[address] = (wrong, now_s, lock)
        while len(self._guesses) > GUESSERS_KEPT:
            self._guesses.popitem(last=False)
        async with lock:  # an address's wrong guesses wait in turn, not side by side
            await asyncio.sleep(min(MOST_GUESS_WAIT_S, GUESS_WAIT_S * 2 ** (wrong - 1)))
        self._refused("codes", "a request with a wrong sign-in code was refused")
        return _refusal(401, "no student has this sign-in code: type the one on your sheet")

    def _teacher(self, request: web.Request) -> bool:
        token = request.headers.get("Authorization", "").removeprefix("Bearer ").strip()
        return bool(token) and hmac.compare_digest(code_digest(token), self.store.setting(TEACHER_TOKEN))

    async def _mission(self, request: web.Request) -> str | web.Response:
        try:
            body = await request.json()
        except web.HTTPRequestEntityTooLarge:
            return _refusal(413, f"the request is larger than {MAX_REQUEST_BYTES:,} bytes")
        except (ValueError, RecursionError):  # not JSON, or nested deeper than a reader goes
            return _refusal(400, 'the body is JSON: {"mission": "the mission file\'s text"}')
        mission = body.get("mission") if isinstance(body, dict) else None
        if not isinstance(mission, str):
            return _refusal(400, 'the body is JSON: {"mission": "the mission file\'s text"}')
        try:
            mission.encode("utf-8")
        except UnicodeEncodeError:
            return _refusal(400, "the mission holds a character that is not text (half of a surrogate pair)")
        return mission

    # ------------------------------------------------------------------ routes

    async def _asked(self, request: web.Request) -> tuple[Student, str] | web.Response:
        """Who asks, and the mission they send; or the refusal."""
        student = await self._student(request)
        if isinstance(student, web.Response):
            return student
        mission = await self._mission(request)
        if isinstance(mission, web.Response):
            return mission
        return student, mission

    async def _check(self, request: web.Request) -> web.Response:
        asked = await self._asked(request)
        if isinstance(asked, web.Response):
            return asked
        student, mission = asked
        if student.id in self._busy:
            return _refusal(429, UNDER_WAY)
        self._busy.add(student.id)
        try:  # off the server's loop: a tree of 3,000 nodes takes a third of a second to draw
            return _json(
                await asyncio.get_running_loop().run_in_executor(self._checkers, check, self.exercise, mission)
            )
        finally:
            self._busy.discard(student.id)

    async def _run(self, request: web.Request) -> web.Response:
        return await self._graded(request, hand_in=False)

    async def _handin(self, request: web.Request) -> web.Response:
        return await self._graded(request, hand_in=True)

    async def _graded(self, request: web.Request, hand_in: bool) -> web.Response:
        asked = await self._asked(request)
        if isinstance(asked, web.Response):
            return asked
        student, mission = asked
        if hand_in:
            deadline = self.store.setting(DEADLINE)
            if deadline and wall_time_s() >= float(deadline):
                return _refusal(403, "hand-ins are closed: the deadline has passed")
        if student.id in self._busy:
            return _refusal(429, UNDER_WAY)
        kind = "handin" if hand_in else "run"
        most = HANDINS_PER_MINUTE if hand_in else RUNS_PER_MINUTE
        now_s = self._clock.now()
        done = self._runs.setdefault((student.id, kind), collections.deque())
        while done and now_s - done[0] >= 60.0:
            done.popleft()
        if len(done) >= most:
            wait_s = max(1, round(60.0 - (now_s - done[0]) + 0.5))
            what = "hand-ins" if hand_in else "runs"
            why = f"{most} {what} a minute at most: you can {'hand in' if hand_in else 'run'} again in {wait_s} s"
            return _json({"error": why, "retry_after_s": wait_s}, 429, {"Retry-After": str(wait_s)})
        done.append(now_s)
        self._busy.add(student.id)
        try:
            return await self._grade(student, mission, kind)
        finally:
            self._busy.discard(student.id)

    async def _grade(self, student: Student, mission: str, kind: str) -> web.Response:
        loop = asyncio.get_running_loop()
        checked = await loop.run_in_executor(self._checkers, check, self.exercise, mission)
        if not checked["ok"]:
            first = checked["problems"][0]
            problem = f"line {first['line']}, column {first['column']}: {first['message']}"
            self.store.add_work(
                student.id, kind, mission[:MAX_MISSION_CHARS], {"problems": checked["problems"]}, problem=problem
            )
            return _json({"ok": False, "problems": checked["problems"]}, 422)
        number = self.store.add_work(student.id, kind, mission, {"grading": True})
        try:
            report, _page = await loop.run_in_executor(
                self._graders, grade_text, self.exercise, student.id, mission, self.folder, number, kind == "handin"
            )
        except Exception as err:  # noqa: BLE001 - said in one line, kept as the work's problem, answered 500
            why = f"the grading failed: {type(err).__name__}"
            self._refused(f"grading {type(err).__name__}", f"{why} (work {number})")
            self.store.finish_work(number, {"error": why}, None, None, why)
            return _refusal(500, why)
        shown = seen_by_student(self.exercise, report)
        problem = report.problems[0] if report.problems else ""
        self.store.finish_work(number, report.to_json(), report.total, report.max_points, problem)
        return _json({"ok": True, "number": number, "kind": kind, **shown})  # kept before it is said

    async def _class(self, request: web.Request) -> web.Response:
        if not self._teacher(request):
            return _refusal(401, "the class table is the teacher's: use the teacher's token")
        deadline = self.store.setting(DEADLINE)
        return _json(
            {
                "exercise": self.exercise.name,
                "title": self.exercise.title,
                "deadline_s": float(deadline) if deadline else None,
                "students": self.store.summary(),
            }
        )

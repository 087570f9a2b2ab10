"""A class's storage: students and their sign-in codes, every run and hand-in, the class's settings.

SQLite from the standard library, in write-ahead-log mode, in one file of the class's folder
(``class.sqlite``). Every write is committed before the server answers, with ``synchronous=FULL``:
a hand-in the server acknowledged is on disk, whatever happens to the server next (``kill -9``,
the machine losing power).

A sign-in code is kept only as its SHA-256: the teacher hands the codes out from ``codes.csv``.
"""

from __future__ import annotations

import hashlib
import json
import secrets
import sqlite3
import threading
from collections.abc import Callable, Collection
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

from autonomy.clock import wall_date, wall_time_s
from autonomy.errors import AutonomyError

T = TypeVar("T")

#: The file in the class's folder.
DATABASE = "class.sqlite"
#: Sign-in codes are made of these (no 0/o, 1/l/i: read off a sheet and typed).
CODE_ALPHABET = "23456789abcdefghjkmnpqrstuvwxyz"
CODE_LENGTH = 8

#: How a work was written (``blocks``, or NULL for text), kept in its result.
_WRITTEN_AS = "json_extract(result, '$.written_as')"
#: A work whose grading has not ended (yet, or ever: see :meth:`ClassStore.fail_unfinished`).
_GRADING = "json_extract(result, '$.grading') IS NOT NULL"
#: A work that was handed in or run and answered: neither grading still nor failed by the server (its ``error``).
_ANSWERED = "json_extract(w.result, '$.grading') IS NULL AND json_extract(w.result, '$.error') IS NULL"

_SCHEMA = """
CREATE TABLE IF NOT EXISTS students (
    id TEXT PRIMARY KEY,
    name TEXT NOT NULL,
    code_sha256 TEXT NOT NULL UNIQUE,
    signed_in TEXT NOT NULL DEFAULT '',
    on_roster INTEGER NOT NULL DEFAULT 1
);
CREATE TABLE IF NOT EXISTS works (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    student TEXT NOT NULL REFERENCES students(id),
    kind TEXT NOT NULL CHECK (kind IN ('run', 'handin')),
    at TEXT NOT NULL,
    source TEXT NOT NULL,
    total REAL,
    max_points REAL,
    problem TEXT NOT NULL DEFAULT '',
    result TEXT NOT NULL DEFAULT '{}'
);
CREATE INDEX IF NOT EXISTS works_by_student ON works (student, kind, id);
CREATE TABLE IF NOT EXISTS settings (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS robot_runs (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    student TEXT NOT NULL REFERENCES students(id),
    robot TEXT NOT NULL,
    at TEXT NOT NULL,
    source TEXT NOT NULL,
    outcome TEXT NOT NULL,
    summary TEXT NOT NULL DEFAULT '',
    points REAL
);
CREATE INDEX IF NOT EXISTS robot_runs_by_student ON robot_runs (student, id);
CREATE TABLE IF NOT EXISTS sessions (
    digest TEXT PRIMARY KEY,
    student TEXT NOT NULL,
    until_s REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS lms_people (
    sub TEXT PRIMARY KEY,
    student TEXT UNIQUE REFERENCES students(id),
    name TEXT NOT NULL,
    instructor INTEGER NOT NULL DEFAULT 0,
    active INTEGER NOT NULL DEFAULT 1
);
CREATE TABLE IF NOT EXISTS lms_scores (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    student TEXT NOT NULL REFERENCES students(id),
    sub TEXT NOT NULL,
    given REAL NOT NULL,
    maximum REAL NOT NULL,
    comment TEXT NOT NULL,
    at TEXT NOT NULL,
    sent TEXT NOT NULL DEFAULT '',
    refused TEXT NOT NULL DEFAULT ''
);
CREATE INDEX IF NOT EXISTS lms_scores_waiting ON lms_scores (sent, refused, id);
"""


_LAST_ID = "SELECT MAX(id) FROM works"


def _forgetting(student: str, kept: int) -> tuple[str, tuple[Any, ...]]:
    """The statement that forgets the texts of a student's runs but their last ``kept``."""
    older = "SELECT id FROM works WHERE student = ? AND kind = 'run' ORDER BY id DESC LIMIT -1 OFFSET ?"
    return f"UPDATE works SET source = '' WHERE source != '' AND id IN ({older})", (student, kept)  # noqa: S608


class StoreError(AutonomyError):
    """The class's storage cannot be opened or written; the message says why."""


@dataclass(frozen=True)
class Student:
    """One student of the class."""

    id: str
    name: str
    signed_in: str


#: A student's columns, as :class:`Student` holds them, and a work's, as :class:`Work` does.
_STUDENT = "id, name, signed_in"
_WORK = "id, student, kind, at, source, total, max_points, problem, result"


@dataclass(frozen=True)
class Work:
    """A run or a hand-in, as kept."""

    id: int
    student: str
    kind: str
    at: str
    source: str
    total: float | None
    max_points: float | None
    problem: str
    result: dict[str, Any]


def _work(row: tuple[Any, ...]) -> Work:
    """A work as read (:data:`_WORK`'s columns), its result parsed."""
    return Work(*row[:8], json.loads(row[8]))


def new_code() -> str:
    """A random sign-in code of :data:`CODE_LENGTH` characters (about 40 bits)."""
    return "".join(secrets.choice(CODE_ALPHABET) for _ in range(CODE_LENGTH))


def code_digest(code: str) -> str:
    """How a code is kept: its SHA-256, of the code in lower case without spaces or dashes (as copied off a sheet)."""
    return token_digest("".join(code.split()).replace("-", "").lower())


def token_digest(token: str) -> str:
    """How the teacher's token is kept: its SHA-256, letter for letter (it is pasted, never typed)."""
    return hashlib.sha256(token.encode("utf-8", "replace")).hexdigest()


class ClassStore:
    """The class's database, safe to use from several threads (one connection, one lock).

    Args:
        folder: The class's folder; made if missing.

    Raises:
        StoreError: the folder or the database cannot be made or opened.
    """

    def __init__(self, folder: Path) -> None:
        self.folder = Path(folder)
        try:
            self.folder.mkdir(mode=0o700, parents=True, exist_ok=True)
            database = self.folder / DATABASE
            database.touch(mode=0o600)  # the students' work, and their codes' digests: the teacher's alone
            self._db = sqlite3.connect(database, check_same_thread=False, isolation_level=None)
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=FULL")
            self._db.execute("PRAGMA foreign_keys=ON")
            self._db.executescript(_SCHEMA)
            columns = {row[1] for row in self._db.execute("PRAGMA table_info(students)")}
            if "on_roster" not in columns:  # a class kept before students could leave the roster
                self._db.execute("ALTER TABLE students ADD COLUMN on_roster INTEGER NOT NULL DEFAULT 1")
            columns = {row[1] for row in self._db.execute("PRAGMA table_info(robot_runs)")}
            if "points" not in columns:  # a class kept before the teacher could mark a run on a robot
                self._db.execute("ALTER TABLE robot_runs ADD COLUMN points REAL")
        except (OSError, sqlite3.Error) as err:
            raise StoreError(f"{self.folder}: cannot keep the class there: {err}") from err
        self._lock = threading.Lock()
        #: The last work's number given out (see :meth:`new_number`): none is given twice, kept or not.
        self._last_number = 0

    def close(self) -> None:
        """Closes the database."""
        with self._lock:
            self._db.close()

    def _write(self, statements: list[tuple[str, tuple[Any, ...]]]) -> int:
        """Runs ``statements`` in one transaction, committed before it returns; the last row id inserted."""

        def run(db: sqlite3.Connection) -> int:
            last = 0
            for sql, values in statements:
                last = db.execute(sql, values).lastrowid or last
            return last

        return self.transact(run)

    def transact(self, work: Callable[[sqlite3.Connection], T]) -> T:
        """Runs ``work`` on the database in one transaction (its reads and writes, none other's between them)."""
        with self._lock:
            try:
                self._db.execute("BEGIN IMMEDIATE")
                done = work(self._db)
                self._db.execute("COMMIT")
            except BaseException as err:  # whatever it was, the next write starts on a clean transaction
                if self._db.in_transaction:
                    self._db.execute("ROLLBACK")
                if isinstance(err, sqlite3.Error):
                    raise StoreError(f"{self.folder / DATABASE}: cannot write: {err}") from err
                raise
            return done

    def _read(self, sql: str, values: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
        with self._lock:
            return self._db.execute(sql, values).fetchall()

    def read(self, sql: str, values: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
        """The rows of one query of the class's own (the LMS's tables are read so)."""
        return self._read(sql, values)

    def write(self, statements: list[tuple[str, tuple[Any, ...]]]) -> int:
        """Runs statements of the class's own in one transaction (see :meth:`_write`)."""
        return self._write(statements)

    # ------------------------------------------------------------------ students

    def enrol(self, roster: list[tuple[str, str]]) -> dict[str, str]:
        """Makes the class the roster's: new students get a code, names are the roster's, the rest are let go.

        A student no longer on the roster can no longer sign in, and leaves the class table; their
        work is kept, and they are back, with the code they had, when the roster names them again.
        A student the class's LMS has in the course stays (the LMS's roster is the class's too).

        Args:
            roster: (id, name) pairs.

        Returns:
            The new students' codes by id (a student already in the class keeps the code they have).
        """
        known = {row[0] for row in self._read("SELECT id FROM students")}
        codes = {sid: new_code() for sid, _ in roster if sid not in known}
        listed = [sid for sid, _ in roster]
        self._write(
            [
                ("INSERT INTO students (id, name, code_sha256) VALUES (?, ?, ?)", (sid, name, code_digest(codes[sid])))
                for sid, name in roster
                if sid in codes
            ]
            + [("UPDATE students SET name = ?, on_roster = 1 WHERE id = ?", (name, sid)) for sid, name in roster]
            + [
                (
                    f"UPDATE students SET on_roster = 0 WHERE id NOT IN ({', '.join('?' * len(listed))}) AND id NOT "  # noqa: S608
                    "IN (SELECT student FROM lms_people WHERE active = 1 AND student IS NOT NULL)",
                    tuple(listed),
                )
            ]
        )
        return codes

    def new_codes(self, students: list[str]) -> dict[str, str]:
        """Gives these students new codes (their old ones sign in no more); the codes by id.

        Raises:
            StoreError: a student is not in the class.
        """
        known = {row[0] for row in self._read("SELECT id FROM students")}
        unknown = [sid for sid in students if sid not in known]
        if unknown:
            raise StoreError(f"not in the class: {', '.join(unknown[:5])}")
        codes = {sid: new_code() for sid in students}
        self._write(
            [
                ("UPDATE students SET code_sha256 = ? WHERE id = ?", (code_digest(code), sid))
                for sid, code in codes.items()
            ]
        )
        return codes

    def student_by_code(self, code: str) -> Student | None:
        """The student on the roster whose code this is (a code on their sheet, or a session's), or None."""
        digest = code_digest(code)
        rows = self._read(
            f"SELECT {_STUDENT} FROM students WHERE code_sha256 = ? AND on_roster = 1",  # noqa: S608
            (digest,),
        )
        if not rows:
            rows = self._read(
                f"SELECT {_STUDENT} FROM students WHERE on_roster = 1 AND id = "  # noqa: S608 - our own text
                "(SELECT student FROM sessions WHERE digest = ? AND until_s > ? AND student != '')",
                (digest, wall_time_s()),
            )
        return Student(*rows[0]) if rows else None

    def new_session(self, student: str, lasting_s: float) -> str:
        """A new session's code, ``student``'s (empty: the teacher's), for ``lasting_s`` (:meth:`student_by_code`)."""
        code = secrets.token_urlsafe(24)
        now_s = wall_time_s()
        self._write(
            [
                ("DELETE FROM sessions WHERE until_s <= ?", (now_s,)),
                ("INSERT INTO sessions (digest, student, until_s) VALUES (?, ?, ?)",
                 (code_digest(code), student, now_s + lasting_s)),
            ]
        )  # fmt: skip
        return code

    def teacher_session(self, code: str) -> bool:
        """Whether ``code`` is a teacher's session (an instructor's launch from the LMS) not yet lapsed."""
        rows = self._read(
            "SELECT 1 FROM sessions WHERE digest = ? AND student = '' AND until_s > ?",
            (code_digest(code), wall_time_s()),
        )
        return bool(rows)

    def sign_in(self, student: str) -> None:
        """Notes that ``student`` signed in (now)."""
        self._write([("UPDATE students SET signed_in = ? WHERE id = ?", (wall_date(), student))])

    def students(self) -> list[Student]:
        """Every student on the roster, in its order."""
        return [
            Student(*row)
            for row in self._read(f"SELECT {_STUDENT} FROM students WHERE on_roster = 1 ORDER BY rowid")  # noqa: S608
        ]

    # ------------------------------------------------------------------ works

    def add_work(
        self,
        student: str,
        kind: str,
        source: str,
        result: dict[str, Any],
        total: float | None = None,
        max_points: float | None = None,
        problem: str = "",
        number: int | None = None,
        runs_kept: int | None = None,
        results_kept: int | None = None,
    ) -> int:
        """Keeps a run or a hand-in, in one write committed to disk before it returns; its number.

        Args:
            student: Whose it is.
            kind: ``run`` or ``handin``.
            source: Its mission's text.
            result: What its grading gave, as JSON.
            total: Its mark (None: not graded).
            max_points: The mark it was out of.
            problem: Its first problem ("" if none).
            number: Its number, given by :meth:`new_number` before its grading (its files are named by it);
                default: the next one.
            runs_kept: Forget, in the same write, the texts of the student's runs but their last ``runs_kept``
                (see :meth:`forget_old_runs`).
            results_kept: Forget, in the same write, the results of the student's runs but their last
                ``results_kept`` (each keeps its mark and its first problem, in its row; and why the server
                failed it, if it did).
        """
        number = self.new_number() if number is None else number  # never one given out for a work under way
        row = (student, kind, wall_date(), source, total, max_points, problem, json.dumps(result))
        statements: list[tuple[str, tuple[Any, ...]]] = [
            (
                "INSERT INTO works (id, student, kind, at, source, total, max_points, problem, result) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (number, *row),
            )
        ]
        if runs_kept is not None:
            statements.append(_forgetting(student, runs_kept))
        if results_kept is not None:  # an old run keeps its mark and its first problem, in its row
            older = "SELECT id FROM works WHERE student = ? AND kind = 'run' ORDER BY id DESC LIMIT -1 OFFSET ?"
            statements.append(
                (
                    f"UPDATE works SET result = '{{}}' WHERE id IN ({older}) AND result != '{{}}' "  # noqa: S608
                    "AND json_type(result, '$.error') IS NULL AND json_type(result, '$.grading') IS NULL",
                    (student, results_kept),
                )
            )
        kept = self._write(statements)
        with self._lock:
            self._last_number = max(self._last_number, kept)
        return kept

    def new_number(self) -> int:
        """The number of a work to come, to name its files while it is graded; :meth:`add_work` keeps it with it.

        No other work gets it, whether or not it is ever kept (a grading that failed to be kept leaves a gap).
        """
        with self._lock:
            if not self._last_number:
                sequence = self._db.execute("SELECT seq FROM sqlite_sequence WHERE name = 'works'").fetchone()
                self._last_number = max(sequence[0] if sequence else 0, self._db.execute(_LAST_ID).fetchone()[0] or 0)
            self._last_number += 1
            return self._last_number

    def finish_work(
        self, number: int, result: dict[str, Any], total: float | None, max_points: float | None, problem: str = ""
    ) -> None:
        """Keeps a work's result (its grading's), committed to disk before it returns."""
        self._write(
            [
                (
                    "UPDATE works SET result = ?, total = ?, max_points = ?, problem = ? WHERE id = ?",
                    (json.dumps(result), total, max_points, problem, number),
                )
            ]
        )

    def fail_unfinished(self, why: str) -> int:
        """Ends each work still grading (its server stopped before its end was kept) with ``why``; how many."""
        unfinished = self._read(f"SELECT COUNT(*) FROM works WHERE {_GRADING}")[0][0]  # noqa: S608 - our own
        if unfinished:
            error = json.dumps({"error": why})
            self._write([(f"UPDATE works SET result = ?, problem = ? WHERE {_GRADING}", (error, why))])  # noqa: S608
        return unfinished

    def works(self, student: str, kind: str | None = None) -> list[Work]:
        """A student's runs and hand-ins (or those of ``kind``), oldest first."""
        where, values = ("student = ?", (student,)) if kind is None else ("student = ? AND kind = ?", (student, kind))
        rows = self._read(f"SELECT {_WORK} FROM works WHERE {where} ORDER BY id", values)  # noqa: S608
        return [_work(row) for row in rows]

    def work_list(self, student: str, kind: str | None = None) -> list[dict[str, Any]]:
        """A student's runs and hand-ins (or those of one ``kind``), oldest first, without their texts or results.

        Each has ``number``, ``kind``, ``count`` (the how-manieth of its kind, theirs), ``at``, ``total``,
        ``max_points``, ``problem``, ``written_as`` (``blocks`` for one made from blocks, else None).
        """
        rows = self._read(
            "SELECT id, kind, ROW_NUMBER() OVER (PARTITION BY kind ORDER BY id), at, total, max_points, problem, "
            f"{_WRITTEN_AS} FROM works WHERE student = ? AND kind IN (?, ?) ORDER BY id",  # noqa: S608 - our own
            (student, *((kind, kind) if kind else ("run", "handin"))),
        )
        keys = ("number", "kind", "count", "at", "total", "max_points", "problem", "written_as")
        return [dict(zip(keys, row, strict=True)) for row in rows]

    def latest(self, student: str, kind: str, count: int) -> list[int]:
        """The numbers of a student's last ``count`` works of ``kind``, the newest first."""
        rows = self._read(
            "SELECT id FROM works WHERE student = ? AND kind = ? ORDER BY id DESC LIMIT ?", (student, kind, count)
        )
        return [row[0] for row in rows]

    def last_source(self, student: str) -> str:
        """The text of a student's last run or hand-in ("" if none)."""
        rows = self._read("SELECT source FROM works WHERE student = ? ORDER BY id DESC LIMIT 1", (student,))
        return rows[0][0] if rows else ""

    def count(self, student: str, kind: str) -> int:
        """How many runs (or hand-ins) a student has made."""
        return self._read("SELECT COUNT(*) FROM works WHERE student = ? AND kind = ?", (student, kind))[0][0]

    def forget_old_runs(self, student: str, kept: int) -> None:
        """Forgets the texts of a student's runs but their last ``kept`` (their marks stay).

        A hand-in's text is never forgotten: every version handed in is kept.
        """
        self._write([_forgetting(student, kept)])

    def work(self, number: int) -> Work | None:
        """The run or hand-in numbered ``number``, or None."""
        rows = self._read(f"SELECT {_WORK} FROM works WHERE id = ?", (number,))  # noqa: S608
        return _work(rows[0]) if rows else None

    def summary(self, students: Collection[str] | None = None) -> list[dict[str, Any]]:
        """The class table: per student on the roster, sign-in, runs, hand-ins, marks, last problem.

        The marks are their last graded hand-in's, as the gradebook counts them: a hand-in refused for a
        problem after it (its text not a mission) leaves them as they were, and the last problem says why.

        The last problem is their last run's or hand-in's: empty once one has none. Runs and hand-ins are those
        answered: one still grading, or that the server failed (its disk full, say), is not counted.

        Args:
            students: Those whose rows are read (their works alone are: a few of a long lesson's thousands);
                default: everyone's.
        """
        if students is not None:
            chosen = sorted(students)
            return [row for k in range(0, len(chosen), 500) for row in self._summary(chosen[k : k + 500])]
        return self._summary(None)

    def _summary(self, students: list[str] | None) -> list[dict[str, Any]]:
        chosen = "" if students is None else f" AND s.id IN ({', '.join('?' * len(students))})"
        last_graded_handin = (
            "FROM works w WHERE w.student = s.id AND w.kind = 'handin' AND w.total IS NOT NULL "
            "ORDER BY w.id DESC LIMIT 1"
        )
        rows = self._read(
            "SELECT s.id, s.name, s.signed_in, "
            f"(SELECT COUNT(*) FROM works w WHERE w.student = s.id AND w.kind = 'run' AND {_ANSWERED}), "
            f"(SELECT COUNT(*) FROM works w WHERE w.student = s.id AND w.kind = 'handin' AND {_ANSWERED}), "
            f"(SELECT w.total {last_graded_handin}), (SELECT w.max_points {last_graded_handin}), "  # noqa: S608
            "(SELECT w.problem FROM works w WHERE w.student = s.id ORDER BY w.id DESC LIMIT 1), "
            "(SELECT MAX(w.id) FROM works w WHERE w.student = s.id), "
            "(SELECT MAX(w.id) FROM works w WHERE w.student = s.id AND w.total IS NOT NULL), "
            "(SELECT MAX(w.id) FROM works w WHERE w.student = s.id AND w.kind = 'handin' AND w.total IS NOT NULL), "
            f"(SELECT {_WRITTEN_AS} FROM works w WHERE w.student = s.id AND w.total IS NOT NULL "
            "ORDER BY w.id DESC LIMIT 1), "
            f"(SELECT {_WRITTEN_AS} {last_graded_handin}), "
            "(SELECT MAX(r.points) FROM robot_runs r WHERE r.student = s.id) "
            f"FROM students s WHERE s.on_roster = 1{chosen} ORDER BY s.rowid",  # noqa: S608 - our own text
            tuple(students or ()),
        )
        keys = (
            "id", "name", "signed_in", "runs", "handins", "total", "max_points", "last_problem", "last_work",
            "last_graded", "last_handin", "last_graded_as", "last_handin_as", "robot_points",
        )  # fmt: skip
        return [dict(zip(keys, row, strict=True)) for row in rows]

    # ------------------------------------------------------------------ runs on the class's robots

    def add_robot_run(self, student: str, robot: str, source: str, outcome: str, summary: str) -> int:
        """Keeps a run on one of the class's robots (unmarked), committed to disk before it returns; its number.

        Its trace and its replay are files named by the number (see :func:`autonomy.liveclass.robots.run_files`).
        """
        row = (student, robot, wall_date(), source, outcome, summary)
        return self._write(
            [("INSERT INTO robot_runs (student, robot, at, source, outcome, summary) VALUES (?, ?, ?, ?, ?, ?)", row)]
        )

    def robot_runs(self, student: str) -> list[dict[str, Any]]:
        """A student's runs on the class's robots, oldest first: ``number``, ``robot``, ``at``, ``outcome``, ``points``.

        ``points`` is the teacher's mark of the run (None: not marked).
        """
        rows = self._read(
            "SELECT id, robot, at, outcome, summary, points FROM robot_runs WHERE student = ? ORDER BY id", (student,)
        )
        return [dict(zip(("number", "robot", "at", "outcome", "summary", "points"), row, strict=True)) for row in rows]

    def robot_run(self, number: int) -> dict[str, Any] | None:
        """The run on a robot numbered ``number`` (``student``, ``source`` and ``points`` too), or None."""
        rows = self._read(
            "SELECT id, student, robot, at, source, outcome, summary, points FROM robot_runs WHERE id = ?", (number,)
        )
        keys = ("number", "student", "robot", "at", "source", "outcome", "summary", "points")
        return dict(zip(keys, rows[0], strict=True)) if rows else None

    def last_robot_runs(self, count: int) -> list[dict[str, Any]]:
        """The class's last ``count`` runs on its robots, newest first: each with its student's name, and marks."""
        rows = self._read(
            "SELECT r.id, r.student, s.name, r.robot, r.at, r.outcome, r.points FROM robot_runs r "
            "JOIN students s ON s.id = r.student ORDER BY r.id DESC LIMIT ?",
            (count,),
        )
        keys = ("number", "student", "name", "robot", "at", "outcome", "points")
        return [dict(zip(keys, row, strict=True)) for row in rows]

    def mark_robot_run(self, number: int, points: float | None) -> None:
        """Sets the teacher's mark of a run on a robot (None: takes it back), committed before it returns."""
        self._write([("UPDATE robot_runs SET points = ? WHERE id = ?", (points, number))])

    def robot_marks(self) -> dict[str, float]:
        """Each student's best-marked run on a robot, by student (those with none marked are left out)."""
        rows = self._read("SELECT student, MAX(points) FROM robot_runs WHERE points IS NOT NULL GROUP BY student")
        return {student: float(points) for student, points in rows}

    # ------------------------------------------------------------------ settings

    def setting(self, key: str, default: str = "") -> str:
        """A setting of the class (the deadline, the teacher's token's digest...)."""
        rows = self._read("SELECT value FROM settings WHERE key = ?", (key,))
        return rows[0][0] if rows else default

    def set_setting(self, key: str, value: str) -> None:
        """Sets a setting, committed before it returns."""
        self._write([("INSERT INTO settings (key, value) VALUES (?, ?) ON CONFLICT(key) DO UPDATE SET value = ?",
                      (key, value, value))])  # fmt: skip

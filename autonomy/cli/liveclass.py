"""``autonomy class serve``: a live class, served from the teacher's machine."""

from __future__ import annotations

import argparse
import csv
import secrets
import signal
import sys
from pathlib import Path
from typing import Any

from autonomy.cli.common import (
    EXIT_OK,
    EXIT_USAGE,
    _addresses,
    _fail,
    _interrupt,
    _Parser,
    _port_busy,
    _tcp_port,
    _warn_if_public,
)
from autonomy.cli.grade import _exercise


def cmd_class_serve(args: argparse.Namespace) -> int:
    """Serves the class's API until Ctrl-C; writes the students' codes to DIR/codes.csv."""
    from autonomy.classroom.exercise import SecretError, read_secret
    from autonomy.classroom.gradebook import GradebookError, read_roster
    from autonomy.liveclass.server import DEADLINE, TEACHER_TOKEN, ClassServer
    from autonomy.liveclass.store import ClassStore, StoreError, code_digest

    found = _exercise(args.exercise)
    if isinstance(found, int):
        return found
    exercise, _ = found
    try:
        roster = read_roster(args.roster)
    except GradebookError as err:
        return _fail(err.problems[0], EXIT_USAGE)
    folder = Path(args.dir)
    try:
        store = ClassStore(folder)
    except StoreError as err:
        return _fail(str(err), EXIT_USAGE)
    secret_file = folder / "secret"
    try:
        if not secret_file.exists():
            secret_file.write_bytes(secrets.token_bytes(32))
            secret_file.chmod(0o600)
        secret = read_secret(str(secret_file))
    except (OSError, SecretError) as err:
        return _fail(f"{secret_file}: cannot keep the class's secret there: {err}", EXIT_USAGE)
    exercise = exercise.with_secret(secret)
    if args.deadline is not None:
        store.set_setting(DEADLINE, str(args.deadline))
    codes = store.enrol([(entry.id, entry.name) for entry in roster])
    token = secrets.token_urlsafe(18)
    store.set_setting(TEACHER_TOKEN, code_digest(token))
    if codes:
        _write_codes(folder / "codes.csv", roster, codes)
    server = ClassServer(exercise, store, folder, args.host, args.port)
    try:
        server.start()
    except OSError as err:
        store.close()
        return _fail(f"cannot serve the class on {args.host}:{args.port}: {_port_busy(err, '--port')}", EXIT_USAGE)
    _warn_if_public(args.host, "the class is")
    shown = " or ".join(_addresses(args.host))
    students = len(store.students())
    deadline = store.setting(DEADLINE)
    closes = f"; hand-ins close at {_when(float(deadline))}" if deadline else ""
    codes_file = folder / "codes.csv"
    print(f"class: {exercise.name}, {students} students; their codes are in {codes_file}{closes}", file=sys.stderr)
    print(
        f"teacher: token {token} (new at each start): GET /api/class with 'Authorization: Bearer {token}'",
        file=sys.stderr,
        flush=True,
    )
    print(f"http://{shown}:{server.port}/", flush=True)
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        server.wait()
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
        store.close()
    return EXIT_OK


def _deadline(text: str) -> float:
    """``--deadline``: a date and time (``2026-11-27T15:00``, this machine's time unless it says its offset)."""
    from datetime import datetime

    try:
        return datetime.fromisoformat(text).timestamp()
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a date and time such as 2026-11-27T15:00, got {text[:40]!r}"
        ) from None


def _when(epoch_s: float) -> str:
    from datetime import datetime

    return datetime.fromtimestamp(epoch_s).astimezone().isoformat(timespec="minutes")


def _write_codes(path: Path, roster: list[Any], codes: dict[str, str]) -> None:
    """Adds the new students' codes to ``codes.csv`` (``id,name,code``), for the teacher to hand out."""
    new = not path.exists()
    with path.open("a", encoding="utf-8", newline="") as stream:
        writer = csv.writer(stream)
        if new:
            writer.writerow(["id", "name", "code"])
        for entry in roster:
            if entry.id in codes:
                writer.writerow([entry.id, entry.name, codes[entry.id]])
    path.chmod(0o600)


def add_parsers(sub: Any) -> None:
    """Adds ``autonomy class``."""
    group = sub.add_parser("class", help="a live class: students write, run and hand in from their browsers")
    commands = group.add_subparsers(dest="class_command", metavar="COMMAND", required=True, parser_class=_Parser)
    serve = commands.add_parser("serve", help="serve the class from this machine until Ctrl-C")
    serve.add_argument("exercise", metavar="EXERCISE", help="an exercise file, or a name (./exercises/, or shipped)")
    serve.add_argument("--roster", required=True, metavar="ROSTER.csv", help="the students: id,name per line")
    serve.add_argument("--dir", required=True, metavar="CLASSDIR", help="where the class is kept (made if missing)")
    serve.add_argument("--host", default="127.0.0.1", help="the interface (default 127.0.0.1, this machine only)")
    serve.add_argument("--port", type=_tcp_port, default=8770, help="the port (default 8770; 0: any free one)")
    serve.add_argument(
        "--deadline",
        type=_deadline,
        metavar="TIME",
        help="when hand-ins close, e.g. 2026-11-27T15:00 (kept with the class; the students' codes stay in codes.csv)",
    )
    serve.set_defaults(func=cmd_class_serve)

"""``autonomy class serve``: a live class, served from the teacher's machine."""

from __future__ import annotations

import argparse
import contextlib
import csv
import json
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
    _shown,
    _tcp_port,
    _warn_if_public,
    _world_failed,
)
from autonomy.cli.grade import _exercise
from autonomy.client import DEFAULT_BAUD, SUPPORTED_BAUD_RATES


def cmd_class_serve(args: argparse.Namespace) -> int:
    """Serves the class until Ctrl-C; writes the students' codes to DIR/codes.csv."""
    from autonomy.classroom.gradebook import GradebookError, read_roster
    from autonomy.emulator import WorldError
    from autonomy.liveclass.robots import parse_profiles, parse_robots
    from autonomy.liveclass.store import ClassStore, StoreError

    try:
        args.robots = parse_robots(args.robot)
        args.profiles = parse_profiles(args.robot_profile, args.robots)
    except ValueError as err:
        return _fail(str(err), EXIT_USAGE)
    except WorldError as err:  # a profile with problems: each at its place
        return _world_failed(err)
    found = _exercise(args.exercise)
    if isinstance(found, int):
        return found
    exercise, exercise_path = found
    try:
        roster = read_roster(args.roster)
    except GradebookError as err:
        return _fail(err.problems[0], EXIT_USAGE)
    folder = Path(args.dir)
    try:
        store = ClassStore(folder)
    except StoreError as err:
        return _fail(str(err), EXIT_USAGE)
    with contextlib.ExitStack() as closing:  # whichever way this ends, the class and the cluster are let go
        closing.callback(store.close)
        return _serve(args, exercise, Path(exercise_path), roster, store, closing)


def _serve(
    args: argparse.Namespace,
    exercise: Any,
    exercise_path: Path,
    roster: list[Any],
    store: Any,
    closing: contextlib.ExitStack,
) -> int:
    """Serves the class kept in ``store`` until Ctrl-C; what it opens is closed by ``closing``."""
    import hashlib

    from autonomy.classroom.gradescope import build_autograder
    from autonomy.classroom.secret import SecretError, read_secret
    from autonomy.liveclass.server import DEADLINE, EXERCISE, TEACHER_TOKEN, ClassServer, disk_said
    from autonomy.liveclass.store import token_digest

    folder = Path(args.dir)
    secret_file = folder / "secret"
    try:
        if not secret_file.exists():
            # as text, as a teacher would write one: read_secret takes the file bar the spaces and line ends
            # around it, which random bytes could end with (the grading would then use fewer than were kept)
            secret_file.write_text(secrets.token_hex(32) + "\n", encoding="ascii")
            secret_file.chmod(0o600)
        secret = read_secret(str(secret_file))
    except (OSError, SecretError) as err:
        return _fail(f"{secret_file}: cannot keep the class's secret there: {err}", EXIT_USAGE)
    kept = store.setting(EXERCISE)
    this = f"{exercise.name} {hashlib.sha256(exercise.source.encode()).hexdigest()}"
    if kept and kept != this:
        return _fail(
            f"{folder} holds a class of another exercise ('{kept.split()[0]}', or another version of it): "
            "give this one a --dir of its own",
            EXIT_USAGE,
        )
    store.set_setting(EXERCISE, this)
    grader = None
    if args.dask:
        from autonomy.classroom.cluster import ClusterUnfit
        from autonomy.liveclass.work import DaskGrader

        try:
            grader = DaskGrader(args.dask)
        except ImportError:
            return _fail("--dask needs dask.distributed: pip install 'autonomy[cluster]'", EXIT_USAGE)
        except OSError as err:
            return _fail(f"--dask {args.dask}: no Dask scheduler answers there ({err})", EXIT_USAGE)
        except ClusterUnfit as err:  # no worker, or a worker with no or another autonomy
            return _fail(str(err), EXIT_USAGE)
        closing.callback(grader.close)
    plain, exercise = exercise, exercise.with_secret(secret)
    if args.deadline is not None:
        store.set_setting(DEADLINE, str(args.deadline))
    codes = store.enrol([(entry.id, entry.name) for entry in roster])
    token = secrets.token_urlsafe(18)
    store.set_setting(TEACHER_TOKEN, token_digest(token))
    if codes:
        _write_codes(folder / "codes.csv", roster, codes)
    lti = _lti_of(folder)
    if isinstance(lti, int):
        return lti
    server = ClassServer(
        exercise,
        store,
        folder,
        args.host,
        args.port,
        key=hashlib.sha256(b"feedback pages " + secret).digest(),
        grader=grader,
        autograder=lambda: build_autograder(plain, exercise_path, secret),
        robots=args.robots,
        robot_baud=args.robot_baud,
        robot_profiles=args.profiles,
        lti=lti,
        public_url=args.public_url or "",
    )
    try:
        server.start()
    except OSError as err:
        return _fail(f"cannot serve the class on {args.host}:{args.port}: {_port_busy(err, '--port')}", EXIT_USAGE)
    closing.callback(server.stop)
    _warn_if_public(args.host, "the class is", "sign in with a code, and read the exercise")
    shown = " or ".join(_addresses(args.host))
    students = len(store.students())
    deadline = store.setting(DEADLINE)
    closes = f"; hand-ins close at {_when(float(deadline))}" if deadline else ""
    codes_file = folder / "codes.csv"
    print(f"class: {exercise.name}, {students} students; their codes are in {codes_file}{closes}", file=sys.stderr)
    where = "on a Dask cluster at " + args.dask if args.dask else "here"
    print(
        f"teacher: http://{shown}:{server.port}/teacher#{token} (the token is new at each start; graded {where})",
        file=sys.stderr,
        flush=True,
    )
    first = (_addresses(args.host) or ["127.0.0.1"])[0]
    links = _write_links(folder / "codes.csv", f"http://{f'[{first}]' if ':' in first else first}:{server.port}/")
    if links is not None:
        print(f"each student's sign-in link (no code to type) is in {links}", file=sys.stderr)
    print(disk_said(students), file=sys.stderr)
    if lti is not None:
        said = f"LMS: {lti.platform.issuer} launches the class (LTI 1.3, client id {lti.platform.client_id}); "
        course = lti.platform.course_id or json.loads(store.setting("lms.course", "{}")).get("id", "")
        said += f"course {course}; " if course else "its teacher opens its link in the course first; "
        said += (
            "roster and marks by its token URL; " if lti.platform.token_url else "no roster or marks (no token URL); "
        )
        said += f"answering at {lti.platform.public_url or args.public_url}; " if (
            lti.platform.public_url or args.public_url) else ""  # fmt: skip
        said += f"codes sign in too; the tool's addresses: autonomy class lti-config --dir {folder}"
        print(_shown(said), file=sys.stderr)
    if args.robots:
        starts = (
            "the teacher starts each run at the desk"
            if exercise.robot_start == "teacher"
            else ("a run starts as soon as a robot is free (the exercise's robot_start: when_asked)")
        )
        named = ", ".join(f"{name} ({port})" for name, port in args.robots.items())
        said = f"robots: {named} at {args.robot_baud} baud; {starts}; each run at most {exercise.time_limit_s:g} s"
        said += (
            f", marked by the teacher out of {exercise.robot_points:g}" if exercise.robot_points else ", for no marks"
        )
        print(_shown(said), file=sys.stderr)
    signal.signal(signal.SIGTERM, _interrupt)
    try:  # from the moment its address is said, a Ctrl-C ends the class as it should (it was a race)
        print(f"http://{shown}:{server.port}/", flush=True)
        server.wait()
    except KeyboardInterrupt:
        pass
    return EXIT_OK


def _lti_of(folder: Path) -> Any:
    """The class's LMS sign-in (LTI 1.3), as ``class lti-config`` set it; None: none; an exit status: it cannot be."""
    from autonomy.liveclass.lti import LtiError, LtiTool, ToolKey, read_platform

    try:
        platform = read_platform(folder)
        if platform is None:
            return None
        try:
            import jwt  # noqa: F401 - the extra's, needed from the first launch
        except ImportError:
            return _fail("the class's LMS (LTI 1.3) needs PyJWT: pip install 'autonomy[lms]'", EXIT_USAGE)
        return LtiTool(platform, ToolKey(folder))
    except LtiError as err:
        return _fail(str(err), EXIT_USAGE)


def _address_wrong(url: str) -> str:
    """Why ``url`` is not an address the LMS can reach the class or be reached at; empty: it is one."""
    import ipaddress
    import urllib.parse

    try:
        parts = urllib.parse.urlsplit(url)
        port = parts.port
    except ValueError:
        return "its port is not a number from 1 to 65535"
    if parts.scheme not in ("http", "https") or not parts.hostname:
        return "an address starting https://"
    if any(c.isspace() or not c.isprintable() for c in url) or parts.query or parts.fragment or port == 0:
        return "an address with no space, query (?) or fragment (#)"
    if parts.scheme == "http":
        host = parts.hostname
        try:
            here = host == "localhost" or ipaddress.ip_address(host).is_loopback
        except ValueError:
            here = False
        if not here:
            return "https:// (http:// only on this machine: the LMS and the sign-in's cookie need HTTPS)"
    return ""


def cmd_class_lti_config(args: argparse.Namespace) -> int:
    """Prints what an LMS's admin pastes in to add the class as an LTI 1.3 tool; keeps the LMS's details if given."""
    import dataclasses
    import urllib.parse

    from autonomy.liveclass.lti import (
        LtiError,
        Platform,
        ToolKey,
        canvas_config,
        frame_origins,
        read_platform,
        tool_urls,
        write_platform,
    )

    folder = Path(args.dir)
    for name, url in (("--public-url", args.public_url), ("--issuer", args.issuer), ("--auth-url", args.auth_url),
                      ("--token-url", args.token_url), ("--jwks-url", args.jwks_url)):  # fmt: skip
        why = _address_wrong(url) if url else ""
        if why and not (name == "--issuer" and urllib.parse.urlsplit(url).scheme in ("http", "https")):
            return _fail(f"{name} {url!r}: {why}", EXIT_USAGE)
    for origin in args.frame_origin or []:
        parts = urllib.parse.urlsplit(origin)
        if _address_wrong(origin) or f"{parts.scheme}://{parts.netloc}" != origin:
            return _fail(f"--frame-origin {origin!r}: an origin, such as https://school.instructure.com", EXIT_USAGE)
    named = {"--issuer": args.issuer, "--client-id": args.client_id, "--auth-url": args.auth_url,
             "--jwks-url": args.jwks_url, "--deployment-id": args.deployment_id}  # fmt: skip
    missing = [name for name, value in named.items() if not value]
    if len(missing) not in (0, len(named)):
        return _fail(
            f"the LMS's {', '.join(missing)} missing: an LMS is given with --issuer, --client-id, --auth-url, "
            "--jwks-url and --deployment-id (each from its admin's page of this tool); --token-url too, for its "
            "roster and gradebook",
            EXIT_USAGE,
        )
    try:
        key = ToolKey(folder)
    except ImportError:
        return _fail("the class's LMS (LTI 1.3) needs PyJWT: pip install 'autonomy[lms]'", EXIT_USAGE)
    except LtiError as err:
        return _fail(str(err), EXIT_USAGE)
    try:
        if not missing:  # the LMS given anew: its file made again (a broken one too), what else it kept kept
            kept = None
            with contextlib.suppress(LtiError):
                kept = read_platform(folder)
            platform = Platform(args.issuer, args.client_id, args.auth_url, args.token_url or "", args.jwks_url,
                                tuple(args.deployment_id), public_url=kept.public_url if kept else "",
                                course_id=kept.course_id if kept else "",
                                frame_origins=kept.frame_origins if kept else ())  # fmt: skip
            print(f"kept the LMS's settings in {write_platform(folder, platform)}", file=sys.stderr)
        platform = read_platform(folder)
        if platform is None and (args.course_id is not None or args.frame_origin):
            why = "--course-id and --frame-origin are kept with the class's LMS: give the LMS first (--issuer ...)"
            return _fail(why, EXIT_USAGE)
        if platform is not None and (args.public_url or args.course_id is not None or args.frame_origin):
            platform = dataclasses.replace(
                platform,
                public_url=args.public_url or platform.public_url,
                course_id=platform.course_id if args.course_id is None else args.course_id,
                frame_origins=tuple(dict.fromkeys((*platform.frame_origins, *(args.frame_origin or [])))),
            )
            write_platform(folder, platform)
    except LtiError as err:
        return _fail(str(err), EXIT_USAGE)
    if args.course_id is not None:  # the course a teacher's launch tied the class to is let go: this one rules
        from autonomy.liveclass.lms import COURSE
        from autonomy.liveclass.store import DATABASE, ClassStore, StoreError

        if (folder / DATABASE).is_file():
            try:
                store = ClassStore(folder)
                store.set_setting(COURSE, "{}")
                store.close()
            except StoreError as err:
                return _fail(str(err), EXIT_USAGE)
    base = args.public_url or (platform.public_url if platform else "") or f"http://{args.host}:{args.port}"
    urls = tool_urls(base)
    print("The tool (paste these into the LMS):")
    for label, name in (("Tool URL", "tool_url"), ("Login URL (OIDC initiation)", "login_url"),
                        ("Redirect URI", "redirect_uri"), ("Public keyset URL (JWKS)", "jwks_url")):  # fmt: skip
        print(f"  {label + ':':30} {urls[name]}")
    print(f"  {'Key id:':30} {key.kid} (the key is {key.path}, readable by you alone)")
    if platform is None:
        print("The LMS: not given yet (autonomy class lti-config --dir ... --issuer ... --client-id ... --auth-url ...")
        print("  --token-url ... --jwks-url ... --deployment-id ...)")
    else:
        print(f"The LMS: {platform.issuer}, client id {platform.client_id}, deployments "
              f"{', '.join(platform.deployment_ids)}")  # fmt: skip
        course = f"course {platform.course_id}" if platform.course_id else "the course its teacher first opens it from"
        print(f"  the class is {course}; roster and marks {'by ' + platform.token_url if platform.token_url else 'not'}"
              f"{'' if platform.token_url else ' read or sent (no --token-url)'}")  # fmt: skip
        print(f"  the class answers at {platform.public_url or 'the address each request names (no --public-url)'}"
              f"; its pages may be framed by {', '.join(frame_origins(platform))}")  # fmt: skip
    print("Canvas (Developer Keys, LTI key, Method: Paste JSON):")
    print(json.dumps(canvas_config(base, args.title), indent=2))
    return EXIT_OK


def cmd_class_codes(args: argparse.Namespace) -> int:
    """Gives students new sign-in codes (a code lost, or ``codes.csv``); their old codes sign in no more."""
    from autonomy.liveclass.store import DATABASE, ClassStore, StoreError

    folder = Path(args.dir)
    if not (folder / DATABASE).is_file():
        return _fail(f"{folder}: no class is kept there (autonomy class serve --dir makes one)", EXIT_USAGE)
    try:
        store = ClassStore(folder)
    except StoreError as err:
        return _fail(str(err), EXIT_USAGE)
    try:
        students = {student.id: student for student in store.students()}
        chosen = list(students) if args.all else list(dict.fromkeys(args.students))
        if not chosen:
            return _fail("name the students (their ids), or --all", EXIT_USAGE)
        missing = [sid for sid in chosen if sid not in students]  # a code for one not there would go nowhere
        if missing:
            return _fail(f"not in the class: {', '.join(missing[:5])} (ids as in codes.csv)", EXIT_USAGE)
        try:
            codes = store.new_codes(chosen)
        except StoreError as err:
            return _fail(str(err), EXIT_USAGE)
        roster = [students[sid] for sid in chosen]
        _write_codes(folder / "codes.csv", roster, codes, replace=True)
    finally:
        store.close()
    print(f"{len(codes)} new codes in {folder / 'codes.csv'}; the old ones sign in no more", file=sys.stderr)
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


def _write_codes(path: Path, roster: list[Any], codes: dict[str, str], replace: bool = False) -> None:
    """Adds the new students' codes to ``codes.csv`` (``id,name,code``), for the teacher to hand out.

    With ``replace``, the lines of these students are taken out first (their codes are new). Ids and
    names are written as a spreadsheet shows them and runs none (``=HYPERLINK(...)`` gets a ``'``).
    """
    from autonomy.classroom.report import cell_text

    rows: list[list[str]] = []
    if path.exists():
        with path.open(encoding="utf-8", newline="") as stream:
            rows = [row for row in csv.reader(stream) if row]
        if replace:
            rows = [row for row in rows if row[0] not in {cell_text(sid) for sid in codes}]
    rows = rows or [["id", "name", "code"]]
    rows += [[cell_text(entry.id), cell_text(entry.name), codes[entry.id]] for entry in roster if entry.id in codes]
    fresh = path.with_name(path.name + ".new")
    with fresh.open("w", encoding="utf-8", newline="") as stream:
        fresh.chmod(0o600)
        csv.writer(stream).writerows(rows)
    fresh.replace(path)


def _write_links(codes: Path, address: str) -> Path | None:
    """Writes ``links.csv`` beside ``codes.csv``: each student's sign-in link, ``ADDRESS#code=CODE`` (None: no codes).

    A link signs its student in with no code to type (WCAG 3.3.8): the teacher sends it, or makes a QR
    code of it. It is as secret as the code, and the file is the teacher's alone.
    """
    if not codes.exists():
        return None
    with codes.open(encoding="utf-8", newline="") as stream:
        rows = [row for row in csv.reader(stream) if len(row) >= 3][1:]
    path = codes.with_name("links.csv")
    fresh = path.with_name(path.name + ".new")
    with fresh.open("w", encoding="utf-8", newline="") as stream:
        fresh.chmod(0o600)
        csv.writer(stream).writerows([["id", "name", "link"], *([i, n, f"{address}#code={c}"] for i, n, c, *_ in rows)])
    fresh.replace(path)
    return path


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
    serve.add_argument(
        "--dask",
        metavar="ADDRESS",
        help="grade runs and hand-ins on the Dask cluster with its scheduler at ADDRESS (needs autonomy[cluster])",
    )
    serve.add_argument(
        "--robot",
        action="append",
        default=[],
        metavar="NAME=PORT",
        help="a robot of the class's, e.g. a=/dev/ttyUSB0 (repeat for each): students ask for runs on it, from a queue",
    )
    serve.add_argument(
        "--robot-profile",
        action="append",
        default=[],
        metavar="NAME=PROFILE",
        help="a robot's calibration profile (autonomy calibrate): its runs are shown beside the same mission on it",
    )
    serve.add_argument(
        "--robot-baud",
        type=int,
        choices=SUPPORTED_BAUD_RATES,
        default=DEFAULT_BAUD,
        help=f"the robots' links' rate (default {DEFAULT_BAUD})",
    )
    serve.add_argument(
        "--public-url",
        metavar="URL",
        help="the address the school's LMS knows the class by, e.g. https://class.school.example (LTI 1.3)",
    )
    serve.set_defaults(func=cmd_class_serve)
    lti = commands.add_parser("lti-config", help="what the school's LMS needs to launch the class (LTI 1.3)")
    lti.add_argument("--dir", required=True, metavar="CLASSDIR", help="the class's folder (its key is kept there)")
    lti.add_argument("--host", default="127.0.0.1", help="the class's host, as class serve --host")
    lti.add_argument("--port", type=_tcp_port, default=8770, help="the class's port, as class serve --port")
    lti.add_argument("--public-url", metavar="URL", help="the address the LMS knows the class by (else host and port)")
    lti.add_argument("--title", default="autonomy class", help="the tool's name in the LMS")
    lti.add_argument("--issuer", metavar="URL", help="the LMS's issuer (platform id)")
    lti.add_argument("--client-id", metavar="ID", help="the client id the LMS gave this tool")
    lti.add_argument("--auth-url", metavar="URL", help="the LMS's OIDC authorisation address")
    lti.add_argument("--token-url", metavar="URL", help="the LMS's access token address")
    lti.add_argument("--jwks-url", metavar="URL", help="the LMS's public keyset address")
    lti.add_argument(
        "--frame-origin", action="append", metavar="ORIGIN", help="an origin whose pages may frame the class's "
        "(the LMS's pages, where they are not its issuer's: a Canvas cloud school's own host); again for more"
    )  # fmt: skip
    lti.add_argument(
        "--course-id", metavar="ID", help="the LMS's id of the class's course (default: the first its teacher opens it "
        "from; '' unties it)"
    )  # fmt: skip
    lti.add_argument(
        "--deployment-id", action="append", metavar="ID", help="a deployment id the LMS gave (repeat for each)"
    )
    lti.set_defaults(func=cmd_class_lti_config)
    codes = commands.add_parser("codes", help="give students new sign-in codes (the old ones sign in no more)")
    codes.add_argument("students", nargs="*", metavar="ID", help="the students' ids, as in codes.csv")
    codes.add_argument("--all", action="store_true", help="every student of the class")
    codes.add_argument("--dir", required=True, metavar="CLASSDIR", help="the class's folder")
    codes.set_defaults(func=cmd_class_codes)

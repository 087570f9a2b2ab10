"""``autonomy run``, ``replay`` and ``plot``: a mission run, a recorded run played back or drawn."""

from __future__ import annotations

import argparse
import os
import signal
import sys
from typing import Any
from urllib.parse import quote

from autonomy.cli.common import (
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_LINK,
    EXIT_OK,
    EXIT_USAGE,
    _addresses,
    _bounded,
    _fail,
    _interrupt,
    _InterruptOnce,
    _load,
    _port_busy,
    _positive,
    _serve_until_interrupted,
    _shown,
    _silence_stdout,
    _start_view,
    _tcp_port,
    _view_arguments,
    _warn_if_public,
    _world_failed,
)
from autonomy.client import DEFAULT_BAUD, SUPPORTED_BAUD_RATES, Client
from autonomy.emulator import WorldError
from autonomy.errors import AutonomyError
from autonomy.words import plural


class _Output:
    """Writes lines to standard output; once the reader has gone (``| head -1``), asks the run to end."""

    def __init__(self) -> None:
        self.closed = False
        self.on_close: list = []

    def __call__(self, line: str) -> None:
        if self.closed:
            return
        try:
            print(line, flush=True)
        except BrokenPipeError:
            self.closed = True
            _silence_stdout()
            for callback in self.on_close:
                callback("its output was closed")

    def paragraph(self, text: str) -> None:
        """Writes a paragraph; on a terminal, folded between words to its width (a pipe gets one line).

        A behaviour's exception quoted in it (``RuntimeError("\\x1b[31m...")``) reaches the terminal as ``�``.
        """
        text = _shown(text)
        if _is_terminal(sys.stdout):
            import shutil
            import textwrap

            width = max(1, shutil.get_terminal_size().columns - 1)
            # a word longer than the line (a long mission name) stays whole: the terminal wraps it
            text = textwrap.fill(text, width=width, break_long_words=False, break_on_hyphens=False)
        self(text)


def _is_terminal(stream: Any) -> bool:
    try:
        return bool(stream.isatty())
    except ValueError:  # closed
        return False


def _choose_port(args: argparse.Namespace, spec: Any) -> tuple[str, str, str]:
    """Decides where the mission runs and in which world.

    Returns:
        (port URL, what to say about the world, an error message or empty).
    """
    from autonomy.urlhandler.protocol_emu import parse_emu_url

    if args.port is not None and not args.port.strip():
        return "", "", "--port is empty: give a serial device, socket://HOST:PORT, or leave it out for the emulator"
    if args.world is not None and not args.world.strip():
        return "", "", "--world is empty: give a world's name or file, or leave it out"
    port = args.port or "emu://"
    if not port.lower().startswith("emu://"):
        if args.fast:
            return port, "", "--fast runs in virtual time, which needs the built-in emulator (leave out --port)"
        if getattr(args, "profile", None):
            return (
                port,
                "",
                f"--profile is the built-in emulator's robot; {port} is a robot of its own (leave out --port)",
            )
        if args.world:
            return (
                port,
                "",
                (
                    f"--world applies to the built-in emulator; {port} has its own world "
                    "(give it to `autonomy emulator --world`, or leave out --port)"
                ),
            )
        note = f"on {port}"
        if spec.world:
            note += f"; the mission's world '{spec.world}' is not applied there (that robot or emulator has its own)"
        return port, note, ""
    try:
        options = parse_emu_url(port)
    except Exception as err:  # noqa: BLE001 - pyserial's SerialException: a bad URL is a usage error
        return port, "", str(err)
    in_port = options.get("world")
    if in_port and args.world and in_port != args.world:
        return port, "", f"--world {args.world} and world={in_port} in --port disagree: give one of them"
    if in_port:
        world, origin = in_port, "from --port"
        if spec.world and spec.world != in_port:
            origin += f", not the mission's '{spec.world}'"
    elif args.world:
        world, origin = args.world, "from --world" + (f", not the mission's '{spec.world}'" if spec.world else "")
    elif spec.world:
        world, origin = spec.world, "the mission's"
    else:
        world, origin = "box", "the default; the mission names none"
    if not in_port:
        port += ("&" if "?" in port else "?") + f"world={quote(world, safe='/')}"
    profile = getattr(args, "profile", None)
    if profile and options.get("profile") and options["profile"] != profile:
        return port, "", f"--profile {profile} and profile={options['profile']} in --port disagree: give one of them"
    if profile and not options.get("profile"):
        port += f"&profile={quote(profile, safe='/')}"
    profile = profile or options.get("profile")
    if args.fast and "time=" not in port:
        port += "&time=virtual"
    time_text = "virtual time" if "time=virtual" in port else "real time"
    robot = f" as robot profile '{profile}'" if profile else ""
    return port, f"in world '{world}' ({origin}) on the built-in emulator{robot}, in {time_text}", ""


def _print_crash(end: Any, debug: bool) -> None:
    for event in end.events if end is not None else []:
        if event.kind != "exception":
            continue
        if debug and event.traceback:  # line by line, each made printable
            for line in event.traceback.rstrip().splitlines():
                print(_shown(line), file=sys.stderr)
        else:
            for frame in event.frames:
                print(f"  {_shown(frame)}", file=sys.stderr)
            print("  (--debug prints the whole traceback)", file=sys.stderr)


def _when_stopped(client: Any) -> tuple[float, Any, int] | None:
    """On the in-process emulator, the robot as the run left it: its clock, its pose, how many impacts so far."""
    emulator = getattr(client.port, "emulator", None)
    if emulator is None:
        return None
    robot = emulator.robot
    return robot.time_s, robot.pose, len(robot.impacts)


def _came_to_rest(client: Any, stopped: tuple[float, Any, int] | None) -> str:
    """On the in-process emulator: where the robot came to rest after the final stop, and what it hit on the way.

    ``stopped`` is the robot as the run left it (:func:`_when_stopped`).

    The run ends when the mission does; a robot that was going fast rolls on after its stop (and
    may hit what is ahead), which is what grading judges. Elsewhere (a real robot, an emulator
    over a link) nothing is known of it: empty.
    """
    from autonomy.classroom.facts import SETTLE_MOST_S, settle
    from autonomy.classroom.told import hit

    if stopped is None:
        return ""
    robot = client.port.emulator.robot
    stopped_s, where, impacts = stopped
    settle(robot)  # (already, when the run was judged: the same)
    if robot.moving:
        return f"After the stop it was still moving {SETTLE_MOST_S:g} s later."
    rest = robot.pose
    rolled_mm = ((rest.x_mm - where.x_mm) ** 2 + (rest.y_mm - where.y_mm) ** 2) ** 0.5
    hits = sorted({hit(robot.world, impact.pose) for impact in robot.impacts[impacts:]})
    at = f"({rest.x_mm:.0f}, {rest.y_mm:.0f}) mm"
    if rolled_mm < 1.0 and not hits:
        return f"After the stop it came to rest where it stopped, at {at}."
    struck = f", hitting {' and '.join(hits)} on the way" if hits else ""
    later_s = max(0.0, robot.moved_s - stopped_s)
    return f"After the stop it rolled on {rolled_mm:.0f} mm and came to rest {later_s:.1f} s later at {at}{struck}."


def _exercise_seed(args: argparse.Namespace) -> tuple[Any, Any] | int:
    """The exercise and seed of ``--exercise EX --seed N``, the port and time limit set as its grading has them.

    Returns:
        (exercise, seed); or, if they cannot be run, the exit code (why said).
    """
    from autonomy.classroom.job import seed_url
    from autonomy.cli.grade import _exercise

    if args.port is not None or args.world is not None:
        return _fail("--exercise runs in the exercise's world on the built-in emulator: leave out --port and --world",
                     EXIT_USAGE)  # fmt: skip
    found = _exercise(args.exercise)
    if isinstance(found, int):
        return found
    exercise, _ = found
    public = [seed for seed in exercise.seeds if not seed.hidden]
    chosen = next((seed for seed in public if args.seed is None or seed.seed == args.seed), None)
    if chosen is None:
        listed = ", ".join(str(seed.seed) for seed in public)
        return _fail(
            f"the exercise '{exercise.name}' has no public seed {args.seed}: its seeds are {listed}", EXIT_USAGE
        )
    args.port = seed_url(exercise, chosen, virtual=False)  # --fast makes it virtual, as for any run
    args.max_seconds = args.max_seconds or exercise.time_limit_s
    return exercise, chosen


def _graded_lines(exercise: Any, seed: Any, gathered: Any, client: Any, tips: list[tuple[float, int]]) -> list[str]:
    """What the grader says of this run of one seed: its points, and each criterion's line."""
    from autonomy.classroom.facts import facts_of
    from autonomy.classroom.job import verdicts_of

    emulator = getattr(client.port, "emulator", None)
    if emulator is None or gathered.end is None:
        return []
    verdicts = verdicts_of(exercise, seed, facts_of(gathered, emulator.robot, exercise.time_limit_s, tips))
    shares = zip(exercise.criteria, verdicts, strict=True)
    earned = sum(criterion.points * verdict.share for criterion, verdict in shares)
    lines = [f"As the grader marks it, {seed.label}: {earned:.4g} of {exercise.max_points:g} points"]
    lines += [f"  {'yes' if v.held else 'no '} {criterion.shown}: {v.line}" for criterion, v in
              zip(exercise.criteria, verdicts, strict=True)]  # fmt: skip
    lines.append("(on this seed alone: grading runs every seed, and hidden ones when the teacher hands it in)")
    return lines


def cmd_run(args: argparse.Namespace) -> int:
    """Runs a mission on the robot or the built-in emulator."""
    from autonomy.runner import FAILED, INTERRUPTED, LINK_LOST, SUCCEEDED, Runner, settled_heap
    from autonomy.trace import TraceWriter
    from autonomy.views.lines import LinePrinter

    spec = _load(args.mission, check_world=not args.exercise)  # an exercise runs in its own world, as graded
    if spec is None:
        return EXIT_USAGE
    graded = None
    if args.exercise:  # run as the grader runs it: the exercise's world, one of its seeds, its time limit
        graded = _exercise_seed(args)
        if isinstance(graded, int):
            return graded
    if args.world:
        from autonomy.emulator import load_world

        try:
            load_world(args.world)
        except WorldError as err:
            return _world_failed(err)
    if args.profile is not None:
        if args.exercise:
            return _fail("--exercise runs on the exercise's own robot, as graded: leave out --profile", EXIT_USAGE)
        from autonomy.emulator import load_profile

        try:
            load_profile(args.profile)
        except WorldError as err:
            return _world_failed(err)
    port, where, error = _choose_port(args, spec)
    if error:
        return _fail(error, EXIT_USAGE)
    if graded is not None:  # said as the exercise has it (the port is its own, which says the world's file)
        exercise, seed = graded
        time_text = "virtual time" if "time=virtual" in port else "real time"
        where = (
            f"as exercise '{exercise.name}' grades it: its world '{exercise.world.name}', {seed.label}, in {time_text}"
        )
    written = [os.path.realpath(p) for p in (args.trace, args.btlog) if p]
    if len(set(written)) < len(written) or os.path.realpath(args.mission) in written:
        return _fail("--trace and --btlog need files of their own (not each other, not the mission)", EXIT_USAGE)
    if args.groot and args.groot_port == 65535:
        return _fail("--groot-port takes 0..65534: the next port is Groot2's too", EXIT_USAGE)
    interrupts = _InterruptOnce()
    interrupts.install()
    output = _Output()
    if args.live and not _is_terminal(sys.stdout):
        print("autonomy: --live needs a terminal; printing lines instead", file=sys.stderr)
        args.live = False
    if not args.quiet and not args.live:
        output(f"Running '{spec.name}' {where}.")
    trace = None
    if args.trace:
        try:
            trace = open(args.trace, "w", encoding="utf-8")  # noqa: SIM115 - closed in finally
        except OSError as err:
            return _fail(f"cannot write the trace to {args.trace}: {err.strerror}", EXIT_USAGE)
    listeners: list[Any] = []
    gathered = None
    if graded is not None:
        from autonomy.classroom.facts import Gatherer

        gathered = Gatherer()
        listeners.append(gathered)
    writer = TraceWriter(trace) if trace is not None else None
    if writer is not None:
        listeners.append(writer)
    server = live = groot = btlog = btlog_writer = None
    try:
        if args.btlog or args.groot:
            from autonomy.mission.btcpp import instance

            tree = instance(spec)
        if args.btlog:
            from autonomy.btlog import BtlogWriter

            try:
                btlog = open(args.btlog, "wb")  # noqa: SIM115 - closed in finally
            except OSError as err:
                return _fail(f"cannot write the log to {args.btlog}: {err.strerror}", EXIT_USAGE)
            btlog_writer = BtlogWriter(btlog, tree)
            listeners.append(btlog_writer)
        if args.groot:
            groot, error = _start_groot(args, tree)
            if groot is None:
                return _fail(error, EXIT_USAGE)
            listeners.append(groot)
        if args.view:
            server, error = _start_view(args)
            if server is None:
                return _fail(error, EXIT_USAGE)
            listeners.append(server.hub)
        if args.live:
            from autonomy.views.terminal import LiveView

            live = LiveView(title="live")
            listeners.append(live)
        else:
            listeners.append(LinePrinter(output, quiet=args.quiet))
        try:
            client = Client.open(port, baud=args.baud, guardian=True)
        except KeyboardInterrupt:
            return _fail("interrupted while connecting", EXIT_INTERRUPTED)
        except AutonomyError as err:
            return _fail(str(err), EXIT_LINK)
        try:
            runner = Runner.for_mission(
                spec, client, max_seconds=args.max_seconds, listeners=listeners, tips=graded is not None
            )
            output.on_close.append(runner.request_stop)
            with settled_heap():  # this process's one run
                if live is not None:
                    with live:
                        summary = runner.run()
                else:
                    summary = runner.run()
        finally:
            interrupts.raised = True  # from here on Ctrl-C waits: the stop and the summary come first
            client.close()
        stopped = _when_stopped(client)
        marks = []  # judged first, from the run as it ended (the judge lets the robot come to rest itself)
        if graded is not None and gathered is not None and summary.outcome != INTERRUPTED:
            marks = _graded_lines(*graded, gathered, client, runner.tips or [])
        rest = _came_to_rest(client, stopped)  # past the run's records: what a replay of them cannot say
        run_part, link_part = summary.paragraph.split(" Link: ", 1)  # said before the link's counts
        output.paragraph(f"{run_part}{' ' + rest if rest else ''} Link: {link_part}")
        for line in marks:
            output(_shown(line))
        _print_crash(runner.end, args.debug)
        if server is not None and not output.closed and summary.outcome != INTERRUPTED:
            _serve_until_interrupted(server, "the run is over", interrupts)
    finally:
        if trace is not None:
            if writer is not None:
                writer.flush()  # the lines held back, when the run ended without its closing record
            try:
                trace.close()
            except OSError as err:
                if writer is not None and not writer.failure:
                    writer.failure = err.strerror or str(err)
            if writer is not None and writer.failure:
                print(f"autonomy: the trace {args.trace} is incomplete: {writer.failure}", file=sys.stderr)
        if btlog is not None:
            try:
                btlog.close()
            except OSError as err:
                if btlog_writer is not None and not btlog_writer.failure:
                    btlog_writer.failure = err.strerror or str(err)
            if btlog_writer is not None and btlog_writer.failure:
                print(f"autonomy: the log {args.btlog} is incomplete: {btlog_writer.failure}", file=sys.stderr)
        if groot is not None:
            groot.stop()
        if server is not None:
            server.stop()
    code = {SUCCEEDED: EXIT_OK, FAILED: EXIT_FAILED, LINK_LOST: EXIT_LINK, INTERRUPTED: EXIT_INTERRUPTED}.get(
        summary.outcome, EXIT_FAILED
    )
    if not args.quiet:  # what was written, and where, after the summary
        if writer is not None and not writer.failure:
            output(_shown(f"trace: {args.trace}, {plural(summary.ticks, 'tick')}"))
        if btlog_writer is not None and not btlog_writer.failure:
            changes = plural(btlog_writer.changes_written, "status change")
            output(_shown(f"btlog: {args.btlog}, {changes} of {plural(len(btlog_writer.uids), 'node')}"))
    lost = (writer is not None and writer.failure) or (btlog_writer is not None and btlog_writer.failure)
    return EXIT_FAILED if code == EXIT_OK and lost else code


def _start_groot(args: argparse.Namespace, tree: Any) -> tuple[Any, str]:
    """Starts the Groot2 publisher; returns it, or None and why not."""
    from autonomy.groot import GrootPublisher

    host = args.groot_host
    try:
        groot = GrootPublisher(tree, host, args.groot_port).start()
    except OSError as err:
        why = _port_busy(err, "--groot-port")
        return None, f"cannot publish to Groot2 on {host}:{args.groot_port}: {why}"
    _warn_if_public(host, "Groot2 is")
    shown = " or ".join(_addresses(host))
    print(f"groot2: attach to {shown} port {groot.port}", file=sys.stderr, flush=True)
    return groot, ""


def _read_recording(path: str) -> tuple[Any, str]:
    """A trace or a ``.btlog``, read; or None and why not."""
    from pathlib import Path

    from autonomy.btlog import MAGIC, BtlogError, read_btlog
    from autonomy.source import exists, is_file
    from autonomy.trace import TraceError, read_trace

    if exists(Path(path)) and not is_file(Path(path)):
        return None, f"{path}: not a recording (a folder, a device or a pipe)"
    try:
        with open(path, "rb") as stream:
            is_btlog = stream.read(len(MAGIC)) == MAGIC
    except OSError:
        is_btlog = False  # read_trace says why
    try:
        return (read_btlog(path) if is_btlog else read_trace(path)), ""
    except (TraceError, BtlogError) as err:
        return None, str(err)


def cmd_replay(args: argparse.Namespace) -> int:
    """Plays a trace back: in the terminal view, or in the browser with --view."""
    from autonomy.clock import RealClock
    from autonomy.trace import replay
    from autonomy.views.lines import LinePrinter

    trace, error = _read_recording(args.trace)
    if trace is None:
        return _fail(error, EXIT_USAGE)
    if trace.cut_off_line:
        print(f"note: {args.trace} was cut off at line {trace.cut_off_line}; playing what came before", file=sys.stderr)
    elif trace.end is None:  # killed between two lines: whole, but without its closing record
        print(f"note: {args.trace} has no closing record (the run was cut off); playing it all", file=sys.stderr)
    if not trace.ticks:
        print(f"note: {args.trace} holds no ticks: there is nothing to play", file=sys.stderr)
    signal.signal(signal.SIGTERM, _interrupt)
    if args.view:
        server, error = _start_view(args, "replay")
        if server is None:
            return _fail(error, EXIT_USAGE)
        try:
            for record in trace.records():
                server.hub(record)
            _serve_until_interrupted(server, f"replaying {args.trace}")
        finally:
            server.stop()
        return EXIT_OK
    output = _Output()
    try:
        if sys.stdout.isatty() and not args.lines:
            from autonomy.views.terminal import LiveView

            with LiveView(title=f"replay x{args.speed:g}") as live:
                replay(trace, live, RealClock(), args.speed)
                RealClock().sleep(args.hold)
        else:
            replay(trace, LinePrinter(output), RealClock(), args.speed)
        if trace.end is not None:
            output.paragraph(trace.end.paragraph)
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
    return EXIT_OK


def cmd_plot(args: argparse.Namespace) -> int:
    """Draws a recorded run: PNG or SVG with matplotlib, or a self-contained HTML page."""
    out = args.output
    suffix = out.rsplit(".", 1)[-1].lower() if "." in out else ""
    if suffix not in ("png", "svg", "html"):
        return _fail(f"-o must end in .png, .svg or .html, got '{out}'", EXIT_USAGE)
    trace, error = _read_recording(args.trace)
    if trace is None:
        return _fail(error, EXIT_USAGE)
    if not trace.header.telemetry and suffix != "html":
        return _fail(
            f"{args.trace} holds node statuses only, no telemetry or path to plot: "
            "record the run with --trace, or write -o FILE.html to see its tree",
            EXIT_USAGE,
        )
    try:
        if suffix == "html":
            from autonomy.views.page import standalone_html

            with open(out, "w", encoding="utf-8") as stream:
                stream.write(standalone_html(trace, at_end=True))  # where the run ended, as it is handed in
        else:
            from autonomy.views.plot import plot_run

            plot_run(trace, out)
    except OSError as err:
        return _fail(f"cannot write {out}: {err.strerror or err}", EXIT_USAGE)
    print(_shown(f"{out}: {len(trace.ticks)} ticks of '{trace.header.mission}'"))
    return EXIT_OK


def add_parsers(sub: Any) -> None:
    """Adds this module's commands to the command line's subparsers."""
    run = sub.add_parser("run", help="run a mission on the robot or the built-in emulator")
    run.add_argument("mission", metavar="MISSION", help="a mission file (.yaml, or BehaviorTree.CPP 4 .xml)")
    run.add_argument("--port", metavar="URL", help="the robot (default: the built-in emulator, in the mission's world)")
    run.add_argument("--baud", type=int, choices=SUPPORTED_BAUD_RATES, default=DEFAULT_BAUD)
    run.add_argument("--world", metavar="NAME|PATH", help="the emulator's arena (overrides the mission's world)")
    run.add_argument("--fast", action="store_true", help="virtual time: as fast as the machine allows (emulator only)")
    run.add_argument(
        "--profile",
        metavar="FILE",
        help="the emulated robot's own settings: a robot profile, as `autonomy calibrate` writes it",
    )
    run.add_argument("--max-seconds", type=_positive, metavar="S", help="stop the mission after this long")
    run.add_argument(
        "--exercise",
        metavar="EX",
        help="run as exercise EX grades it (its world, one of its seeds, its time limit), and say its marks",
    )
    run.add_argument(
        "--seed",
        type=_bounded(int, 0, 2**31 - 1, "a seed"),
        metavar="N",
        help="with --exercise: its seed N (default: the first)",
    )
    run.add_argument("--trace", metavar="FILE", help="record the run: a header, one JSON line per tick, an end")
    run.add_argument("--btlog", metavar="FILE", help="record the run for Groot2: BehaviorTree.CPP's FileLogger2 format")
    run.add_argument("--groot", action="store_true", help="let Groot2 attach and watch the run (see --groot-port)")
    run.add_argument(
        "--groot-port",
        type=_tcp_port,
        default=1667,
        metavar="PORT",
        help="Groot2's port (default 1667; the next one is taken too; 0: any free)",
    )
    run.add_argument(
        "--groot-host", default="127.0.0.1", metavar="HOST", help="the interface for Groot2 (default 127.0.0.1)"
    )
    shown = run.add_mutually_exclusive_group()
    shown.add_argument("--quiet", action="store_true", help="only the summary")
    shown.add_argument("--live", action="store_true", help="a full-screen view of the tree and the robot")
    _view_arguments(run)
    run.add_argument("--debug", action="store_true", help="print the whole traceback when a behaviour raises")
    run.set_defaults(func=cmd_run)
    replay = sub.add_parser("replay", help="play a recorded run back, in the terminal or the browser")
    replay.add_argument(
        "trace", metavar="TRACE", help="a trace written by run --trace, or a .btlog (ours or BehaviorTree.CPP's)"
    )
    _view_arguments(replay)
    replay.add_argument(
        "--speed",
        type=_bounded(float, 0.01, 1_000_000, "a playback speed"),
        default=1.0,
        metavar="X",
        help="playback speed, 0.01 to 1,000,000 (default 1)",
    )
    replay.add_argument("--lines", action="store_true", help="line output even on a terminal")
    replay.add_argument("--hold", type=float, default=2.0, metavar="S", help=argparse.SUPPRESS)
    replay.set_defaults(func=cmd_replay)
    plot = sub.add_parser("plot", help="draw a recorded run: map, telemetry, timeline")
    plot.add_argument("trace", metavar="TRACE", help="a trace written by run --trace (a .btlog: -o FILE.html only)")
    plot.add_argument("-o", "--output", required=True, metavar="FILE", help="FILE.png, FILE.svg or FILE.html")
    plot.set_defaults(func=cmd_plot)

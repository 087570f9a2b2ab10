"""The ``autonomy`` command: parses arguments, calls the library, turns errors into exit codes.

This is the only module that prints or exits. Exit codes: 0 success, 1 mission failed,
2 invalid mission or usage, 3 robot link error, 130 interrupted (Ctrl-C or SIGTERM).
"""

from __future__ import annotations

import argparse
import dataclasses
import errno
import json
import math
import os
import signal
import sys
from collections.abc import Sequence
from typing import Any
from urllib.parse import quote

from autonomy import __version__
from autonomy.client import DEFAULT_BAUD, SUPPORTED_BAUD_RATES, Client
from autonomy.emulator import FaultSpec, FaultSpecError, WorldError, WorldInvalid, emulator_from_options
from autonomy.errors import AutonomyError, Interrupted, LinkError
from autonomy.source import visible

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_LINK = 3
EXIT_INTERRUPTED = 130


class _Parser(argparse.ArgumentParser):
    """argparse with errors as one line and exit code 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_USAGE, f"{self.prog}: error: {_shown(message)} (see {self.prog} --help)\n")


def _fail(message: str, code: int) -> int:
    print(f"autonomy: error: {_shown(message)}", file=sys.stderr)
    return code


def _shown(text: object) -> str:
    """One line as it may reach a terminal: a file named with control characters changes nothing on the screen."""
    from autonomy.views.lines import printable

    return printable(str(text))


#: Most problems printed for one file: past that, the first ones are what to fix.
MAX_PROBLEMS_SHOWN = 100


def _problems(problems: Sequence[object]) -> int:
    """Prints a file's problems, one ``FILE:LINE:COL: ...`` a line (at most 100, then a count); exit 2."""
    for problem in problems[:MAX_PROBLEMS_SHOWN]:
        print(_shown(problem), file=sys.stderr)
    if len(problems) > MAX_PROBLEMS_SHOWN:
        print(f"... and {len(problems) - MAX_PROBLEMS_SHOWN:,} more problems, not shown", file=sys.stderr)
    return EXIT_USAGE


def _world_failed(err: WorldError) -> int:
    """Prints a world's problems, or why it cannot be found; exit 2."""
    return _problems(err.problems) if isinstance(err, WorldInvalid) else _fail(str(err), EXIT_USAGE)


# --------------------------------------------------------------------------- emulator


def _host_port(text: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    if not sep:
        host, port = "127.0.0.1", text
    usage = f"expected HOST:PORT, [IPV6]:PORT or PORT, got {visible(text)!r}"
    if host.startswith("[") and host.endswith("]"):  # an IPv6 address: [::1]:7777
        host = host[1:-1]
    if not host.isprintable() or "[" in host or "]" in host or " " in host:
        raise argparse.ArgumentTypeError(usage)
    return host or "127.0.0.1", _tcp_port(port, usage)


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got '{text}'") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"must be a number above 0, got {text}")
    return value


def _bounded(kind: type, low: float, high: float, what: str) -> Any:
    """An argparse type: a number of ``kind`` from ``low`` to ``high`` (finite), else a one-line error."""

    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got '{text}'") from None
        if not low <= value <= high:  # NaN fails this too
            raise argparse.ArgumentTypeError(f"must be from {low:,} to {high:,}, got {text}")
        return value

    return parse


def _faults(text: str) -> str:
    try:
        FaultSpec.parse(text)
    except FaultSpecError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
    return text


def cmd_emulator(args: argparse.Namespace) -> int:
    """Serves an emulated robot over TCP or a pseudo-terminal until Ctrl-C or SIGTERM."""
    from autonomy.emulator.servers import PtyServer, TcpServer

    options = {"world": args.world, "seed": str(args.seed), "faults": args.faults, "baud": str(args.baud)}
    for key in ("battery", "noise", "mode", "boot"):
        if getattr(args, key) is not None:
            options[key] = str(getattr(args, key))
    try:
        emulator = emulator_from_options(options)
        server = PtyServer(emulator) if args.pty else TcpServer(emulator, *args.tcp)
    except WorldError as err:
        return _world_failed(err)
    except ValueError as err:
        return _fail(str(err), EXIT_USAGE)
    except OSError as err:
        return _fail(f"cannot serve on {args.tcp[0]}:{args.tcp[1]}: {err.strerror or err}", EXIT_LINK)
    print(server.url, flush=True)
    if getattr(server, "public", False):
        print(
            f"autonomy: warning: serving on every network address ({args.tcp[0]}): anyone who can reach this "
            "machine can drive the robot; use 127.0.0.1 unless you mean it",
            file=sys.stderr,
            flush=True,
        )
    print(
        f"emulated robot in world '{emulator.world.name}', {args.baud} baud, faults: {emulator.faults}; Ctrl-C to stop",
        file=sys.stderr,
        flush=True,
    )
    signal.signal(signal.SIGTERM, lambda *_: server.stop_soon())
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        server.stop_soon()
        server.serve_forever()  # returns at once, closing the port
    return EXIT_OK


# --------------------------------------------------------------------------- probe


def _status_lines(status: dict[str, Any]) -> list[str]:
    return [
        f"    {key:<18}{('yes' if value else 'no') if isinstance(value, bool) else value}"
        for key, value in status.items()
        if key != "raw"
    ]


def cmd_probe(args: argparse.Namespace) -> int:
    """Connects to a robot and prints what it reports about itself."""
    try:
        with Client.open(args.port, baud=args.baud, ready_timeout_s=args.wait) as client:
            report: dict[str, Any] = {
                "port": args.port,
                "baud": args.baud,
                "firmware": client.firmware_version,
                "battery": client.battery(),
                "healthy": client.healthy(),
                "velocity": client.velocity(),
                "tilt_deg": client.tilt_deg(),
                "status": client.status().as_dict(),
            }
    except LinkError as err:
        return _fail(str(err), EXIT_LINK)
    except AutonomyError as err:
        return _fail(f"{args.port}: {err}", EXIT_LINK)
    if args.json:
        print(json.dumps(report))
        return EXIT_OK
    print(f"robot at {args.port} ({args.baud} baud)")
    print(f"  firmware        {report['firmware']}")
    print(f"  battery         {report['battery']} / 255")
    print(f"  health          {'OK' if report['healthy'] else 'NOT OK'}")
    print(f"  velocity        {report['velocity']:+d} ({report['velocity'] / 20:.2f} wheel turns/s)")
    print(f"  tilt            {report['tilt_deg']:+d} deg")
    print(f"  status packet   {report['status']['raw']}")
    print("\n".join(_status_lines(report["status"])))
    return EXIT_OK


# --------------------------------------------------------------------------- missions


def _load(path: str) -> Any:
    """Validates a mission file; prints its problems and returns None when it has any."""
    from autonomy.mission import MissionInvalid, load_mission

    try:
        return load_mission(path)
    except MissionInvalid as err:
        _problems(err.problems)
        return None


def _interrupt(*_: object) -> None:
    raise Interrupted


class _InterruptOnce:
    """Ctrl-C and SIGTERM end a run once; pressed again while the robot is being stopped, they wait.

    A second Ctrl-C must not cut the final stop short: that is when a moving robot is told to stop.
    """

    def __init__(self) -> None:
        self.raised = False
        self.held = False  # pressed while it waited: the command ends once the robot is stopped

    def install(self) -> None:
        signal.signal(signal.SIGINT, self)
        signal.signal(signal.SIGTERM, self)

    def __call__(self, *_: object) -> None:
        if not self.raised:
            self.raised = True
            raise Interrupted
        self.held = True
        print("autonomy: stopping the robot first; one moment", file=sys.stderr, flush=True)


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


def _silence_stdout() -> None:
    """Points standard output at /dev/null, so that the interpreter's last flush cannot fail."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


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
    if args.fast and "time=" not in port:
        port += "&time=virtual"
    time_text = "virtual time" if "time=virtual" in port else "real time"
    return port, f"in world '{world}' ({origin}) on the built-in emulator, in {time_text}", ""


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


def cmd_run(args: argparse.Namespace) -> int:
    """Runs a mission on the robot or the built-in emulator."""
    from autonomy.runner import FAILED, INTERRUPTED, LINK_LOST, SUCCEEDED, Runner, settled_heap
    from autonomy.trace import TraceWriter
    from autonomy.views.lines import LinePrinter

    spec = _load(args.mission)
    if spec is None:
        return EXIT_USAGE
    if args.world:
        from autonomy.emulator import load_world

        try:
            load_world(args.world)
        except WorldError as err:
            return _world_failed(err)
    port, where, error = _choose_port(args, spec)
    if error:
        return _fail(error, EXIT_USAGE)
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
            client = Client.open(port, baud=args.baud)
        except KeyboardInterrupt:
            return _fail("interrupted while connecting", EXIT_INTERRUPTED)
        except AutonomyError as err:
            return _fail(str(err), EXIT_LINK)
        try:
            runner = Runner.for_mission(spec, client, max_seconds=args.max_seconds, listeners=listeners)
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
        output.paragraph(summary.paragraph)
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
    lost = (writer is not None and writer.failure) or (btlog_writer is not None and btlog_writer.failure)
    return EXIT_FAILED if code == EXIT_OK and lost else code


def _warn_if_public(host: str, what: str) -> None:
    """Warns when ``what`` is served on an interface other machines can reach."""
    if host not in ("127.0.0.1", "localhost", "::1"):
        print(f"warning: {what} served on {host}: anyone who can reach this machine can watch the run", file=sys.stderr)


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


def _port_busy(err: OSError, option: str) -> str:
    """Why a server could not start, and for a port in use, what to do."""
    if err.errno == errno.EADDRINUSE:
        return f"the port is in use (another run's view, or another program): {option} 0 takes any free port"
    return str(err.strerror or err)


def _addresses(host: str) -> list[str]:
    """Where others reach a server on ``host``: for every interface (0.0.0.0), this machine's own addresses."""
    if host not in ("0.0.0.0", "::", ""):
        return [host]
    import socket

    found: list[str] = []
    try:
        found += socket.gethostbyname_ex(socket.gethostname())[2]
    except OSError:
        pass
    try:  # the address of the way out: a datagram socket connected to an address for documentation sends nothing
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.connect(("192.0.2.1", 9))
            found.append(probe.getsockname()[0])
    except OSError:
        pass
    outside = sorted({a for a in found if not a.startswith("127.")})
    return [*outside, "127.0.0.1"] if outside else ["this machine's address"]


def _start_view(args: argparse.Namespace, mode: str = "live") -> tuple[Any, str]:
    """Starts the browser view's server; returns it, or None and why not."""
    from autonomy.views.web import ViewServer

    host = args.view_host
    try:
        server = ViewServer(host, args.view_port, mode=mode)
        server.start()
    except OSError as err:
        return None, f"cannot serve the view on {host}:{args.view_port}: {_port_busy(err, '--view-port')}"
    _warn_if_public(host, "the view is")
    print(f"view: {_view_url(server)}", file=sys.stderr, flush=True)
    return server, ""


def _view_url(server: Any) -> str:
    """The page's address as a person opens it: one served on every interface (0.0.0.0) at this machine's addresses."""
    if server.host not in ("0.0.0.0", "::", ""):
        return str(server.url)
    urls = [f"http://{address}:{server.port}/" for address in _addresses(server.host) if address[0].isdigit()]
    return " or ".join(urls) or str(server.url)


def _serve_until_interrupted(server: Any, why: str, interrupts: _InterruptOnce | None = None) -> None:
    try:
        if interrupts is not None:
            interrupts.raised = False  # the robot is stopped: Ctrl-C now just ends the view
            if interrupts.held:  # pressed while the robot was stopped or the summary written: it ends the view
                return
        print(f"{why}; the view stays at {_view_url(server)} until Ctrl-C", file=sys.stderr, flush=True)
        server.wait()
    except KeyboardInterrupt:
        pass


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


def cmd_world_list(args: argparse.Namespace) -> int:
    """Lists the built-in worlds: each one's name, size, obstacles and zones, and its description."""
    from autonomy.emulator import load_world
    from autonomy.emulator.world import SHIPPED
    from autonomy.words import plural

    for name in SHIPPED:
        world = load_world(name)
        zones = f", zones {', '.join(zone.name for zone in world.zones)}" if world.zones else ""
        print(
            f"{name:10} {world.width_mm / 1000:g} x {world.height_mm / 1000:g} m, "
            f"{plural(len(world.obstacles), 'obstacle')}{zones}"
        )
        if world.description:
            print(f"{'':11}{_shown(world.description.strip().splitlines()[0])}")
    print("Use one in a mission (world: NAME), see it with autonomy world show NAME -o NAME.svg, or write your own:")
    print("docs/worlds.md says how.")
    return EXIT_OK


def cmd_world_show(args: argparse.Namespace) -> int:
    """Draws a world (a built-in name or a file) with its start pose, as SVG."""
    from autonomy.emulator import load_world
    from autonomy.emulator.world import Jitter
    from autonomy.views.mapsvg import world_svg

    try:
        world = load_world(args.world)
    except WorldError as err:
        return _world_failed(err)
    if args.seed is not None:  # as a run with that seed has it: what the world varies, and where it starts
        world = dataclasses.replace(world.for_seed(args.seed), start=world.start_pose(args.seed), jitter=Jitter())
    out = args.output
    suffix = out.rsplit(".", 1)[-1].lower() if out not in (None, "-") and "." in out else "svg"
    if suffix not in ("svg", "png"):
        return _fail(f"-o must end in .svg or .png, got '{out}'", EXIT_USAGE)
    if out in (None, "-"):
        sys.stdout.write(world_svg(world.as_dict()))
        return EXIT_OK
    try:
        if suffix == "png":
            from autonomy.views.plot import plot_world

            plot_world(world.as_dict(), out)
        else:
            with open(out, "w", encoding="utf-8") as stream:
                stream.write(world_svg(world.as_dict()))
    except OSError as err:
        return _fail(f"cannot write {args.output}: {err.strerror or err}", EXIT_USAGE)
    print(_shown(f"{args.output}: world '{world.name}', {world.width_mm:g} x {world.height_mm:g} mm"))
    return EXIT_OK


def cmd_check(args: argparse.Namespace) -> int:
    """Validates mission files; every problem of every file, then ok or not."""
    from autonomy.behaviours.tree import preorder
    from autonomy.mission import build_tree
    from autonomy.mission.lint import lint
    from autonomy.words import plural

    bad = 0
    for path in args.missions:
        spec = _load(path)
        if spec is None:
            bad += 1
            continue
        count = sum(1 for _ in preorder(build_tree(spec)))
        warnings = lint(spec)
        noted = f", {plural(len(warnings), 'warning')}" if warnings else ""
        print(_shown(f"{path}: ok (mission '{spec.name}', {plural(count, 'node')}{noted})"))
        for warning in warnings:
            print(_shown(warning))
    return EXIT_USAGE if bad else EXIT_OK


def _exercise_path(text: str) -> tuple[str, str]:
    """An exercise given by path, or by name: from ./exercises/ (a teacher's own), else those shipped with autonomy.

    Returns:
        Its path, or empty and why there is none of that name.
    """
    from importlib import resources
    from pathlib import Path

    from autonomy.source import suggest

    if Path(text).is_file() or "/" in text or text.endswith((".yaml", ".yml")):
        return text, ""
    shipped = Path(str(resources.files("autonomy").joinpath("exercises")))
    for folder in (Path("exercises"), shipped):
        if (folder / f"{text}.yaml").is_file():
            return str(folder / f"{text}.yaml"), ""
    names = sorted({found.stem for folder in (Path("exercises"), shipped) for found in folder.glob("*.yaml")})
    shown = text if len(text) <= 40 else text[:40] + "..."  # made printable where it is printed (_fail)
    return "", (
        f"no exercise named '{shown}'{suggest(text, names)}: use one of {', '.join(names)} "
        "(./exercises/ and those shipped with autonomy), or give the exercise file's path"
    )


def _exercise(text: str) -> tuple[Any, str] | int:
    """The exercise a command names (a file, or a name) and its path; or, if none, the exit code."""
    from autonomy.classroom import ExerciseInvalid, load_exercise

    path, missing = _exercise_path(text)
    if missing:
        return _fail(missing, EXIT_USAGE)
    try:
        return load_exercise(path), path
    except ExerciseInvalid as err:
        return _problems(err.problems)


def cmd_grade(args: argparse.Namespace) -> int:
    """Grades mission files against an exercise: marks, feedback, a gradebook."""
    from pathlib import Path

    from autonomy.classroom import find_submissions, grade_class
    from autonomy.classroom.exercise import SecretError, read_secret
    from autonomy.classroom.grade import WALL_PER_CPU, default_cpu_s
    from autonomy.classroom.gradebook import (
        GradebookError,
        apply_adjustments,
        compare,
        match_roster,
        read_adjustments,
        read_earlier,
        read_roster,
        unknown_students,
    )
    from autonomy.classroom.report import feedback, to_csv, to_gradescope, to_html, to_json
    from autonomy.emulator.world import SHIPPED

    found = _exercise(args.exercise)
    if isinstance(found, int):
        return found
    exercise, path = found
    hidden_note = ""
    if args.secret_file:
        try:
            secret = read_secret(args.secret_file)
        except SecretError as err:
            return _fail(str(err), EXIT_USAGE)
        if not exercise.hidden_seeds:
            hidden_note = "This exercise has no hidden seeds: the secret changes nothing."
        exercise = exercise.with_secret(secret)
    elif exercise.hidden_seeds:
        hidden_note = (
            f"This exercise also has {exercise.hidden_seeds} hidden seeds, which the teacher's marks use "
            f"(autonomy grade --secret-file): these marks are from its {len(exercise.seeds)} public seeds only."
        )
    submissions = find_submissions(args.submissions)
    alone = len(submissions) == 1
    if args.gradescope and not alone:
        return _fail("--gradescope writes one submission's results: give one submission", EXIT_USAGE)
    if args.dask and (args.traces or args.feedback):
        return _fail("--traces and --feedback need the runs here: grade without --dask for them", EXIT_USAGE)
    # the teacher's own files, before any grading: every problem of every one of them at once, FILE:LINE
    problems: list[str] = []
    roster, adjustments = None, []
    try:
        roster = read_roster(args.roster) if args.roster else None
    except GradebookError as err:
        problems += err.problems
    try:
        adjustments = read_adjustments(args.adjust) if args.adjust else []
    except GradebookError as err:
        problems += err.problems
    known = {student for student, _ in submissions}
    problems += unknown_students(adjustments, known, args.adjust or "")
    earlier = None
    try:
        earlier = read_earlier(args.compare, exercise) if args.compare else None
    except GradebookError as err:
        problems += err.problems
    if problems:
        return _problems(problems)
    corrections: dict[str, list[tuple[float, str]]] = {}
    for adjustment in adjustments:
        corrections.setdefault(adjustment.student, []).append((adjustment.points, adjustment.reason))
    kinds = (("csv", args.csv), ("json", args.json), ("html", args.html), ("gradescope", args.gradescope))
    targets = [(target, kind) for kind, target in kinds if target]
    # every file read (the exercise, its world, each submission's mission, a folder's files) is kept from harm
    inputs = {Path(p).resolve() for p in (path, *args.submissions)} | {p.resolve() for _, p in submissions}
    inputs |= {Path(p).resolve() for p in (args.roster, args.adjust, args.compare) if p}
    inputs |= {Path(exercise.world_ref).resolve()} if exercise.world_ref not in SHIPPED else set()  # a file
    for _, given in submissions:
        try:
            inputs |= {p.resolve() for p in given.iterdir()} if given.is_dir() else set()
        except OSError:  # a folder that cannot be listed: its student's report says so
            pass
    chosen: set[Path] = set()
    student_pages: set[Path] = set()
    if args.feedback:  # each student's page is an output too
        from autonomy.classroom.grade import file_names, page_path

        student_pages = {page_path(Path(args.feedback), name).resolve() for name in file_names(known).values()}
    for target, _ in targets:  # before hours of grading, not after
        where = Path(target)
        if where.resolve() in inputs:
            return _fail(f"{target} is one of the files to grade: write the marks elsewhere", EXIT_USAGE)
        if where.resolve() in chosen:
            return _fail(f"{target} is given for two outputs: give each its own file", EXIT_USAGE)
        if where.resolve() in student_pages:
            return _fail(f"{target} is where a student's feedback page goes: write it elsewhere", EXIT_USAGE)
        chosen.add(where.resolve())
        if where.is_dir() or not where.parent.is_dir() or not os.access(where.parent, os.W_OK):
            return _fail(f"cannot write {target}: no such folder, or not writable", EXIT_USAGE)
    if not args.quiet:
        public = [s for s in exercise.seeds if not s.hidden]
        seeds = ", ".join(str(s.seed) for s in public)
        hidden = len(exercise.seeds) - len(public)
        print(
            f"Grading {len(submissions)} submission{'s' if not alone else ''} for '{exercise.title}' "
            f"in world '{exercise.world.name}', seeds {seeds}"
            + (f" and {hidden} hidden" if hidden else "")
            + f", {exercise.time_limit_s:g} s a run.",
            flush=True,
        )
        if hidden_note:
            print(hidden_note, flush=True)
    for ending in (signal.SIGTERM, signal.SIGHUP):  # a closed terminal ends the workers as Ctrl-C does
        signal.signal(ending, _interrupt)
    progress = None
    if not alone and not args.quiet and sys.stderr.isatty():
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        progress = Progress(
            TextColumn("grading"),
            BarColumn(),
            MofNCompleteColumn(),
            TimeElapsedColumn(),
            console=Console(file=sys.stderr),
            transient=True,
        )
        task = progress.add_task("grading", total=len(submissions))
        progress.start()
    try:
        traces = Path(args.traces) if args.traces else None
        feedback_folder = Path(args.feedback) if args.feedback else None
        for folder in (traces, feedback_folder):
            if folder is not None:
                folder.mkdir(parents=True, exist_ok=True)
        limits = {
            "cpu_s": (cpu_s := args.cpu_seconds or default_cpu_s(exercise)),
            "wall_s": args.wall_seconds or WALL_PER_CPU * cpu_s,
            "memory_mb": args.memory_mb,
            "allow_plugins": args.allow_plugins,
            "on_report": (lambda _: progress.advance(task)) if progress is not None else None,
        }
        if args.dask:
            from autonomy.classroom.grade import grade_on_dask

            reports = grade_on_dask(exercise, submissions, args.dask, **limits)
        else:
            reports = grade_class(
                exercise,
                submissions,
                traces=traces,
                feedback=feedback_folder,
                corrections=corrections,
                workers=args.workers,
                **limits,
            )
    except KeyboardInterrupt:
        return _fail("grading interrupted", EXIT_INTERRUPTED)
    except ImportError:
        return _fail("--dask needs dask.distributed: pip install 'autonomy[cluster]'", EXIT_USAGE)
    except OSError as err:  # no scheduler there
        return _fail(f"--dask {args.dask}: no Dask scheduler answers there ({err})", EXIT_USAGE)
    finally:
        if progress is not None:
            progress.stop()
    apply_adjustments(reports, adjustments, args.adjust or "")
    matched = match_roster(roster, reports, Path(args.roster).parent) if roster is not None else None
    if alone and not args.quiet:
        for line in feedback(exercise, reports[0]):
            print(line)
    elif not args.quiet:
        _print_marks(exercise, reports)
        for report in reports:
            for points, reason in report.adjustments:
                print(_shown(f"correction: {report.student} {points:+g} ({reason})"))
    if matched is not None and not args.quiet:
        for entry, report in matched.listed:
            if report is None:
                print(_shown(f"no submission: {entry.id} {entry.name} (roster line {entry.line})"))
        for report in matched.unlisted:
            print(_shown(f"not on the roster: {report.student} ({report.file or 'no file'})"))
    if earlier is not None and not args.quiet:
        print(_shown(f"Since {args.compare}:"))
        for line in compare(exercise, reports, earlier):
            print(_shown(f"  {line}"))
    # a student checking their own mission learns from the exit code too that nothing of it ran
    code = EXIT_USAGE if alone and reports[0].problems else EXIT_OK
    pages: dict[str, str] = {}
    if args.feedback:  # written by the workers, as they graded
        from autonomy.classroom.grade import file_names, page_path

        names = file_names([r.student for r in reports])
        pages = {r.student: str(page_path(Path(args.feedback), names[r.student])) for r in reports}
        pages = {student: page for student, page in pages.items() if Path(page).is_file()}
        if not args.quiet:
            print(_shown(f"wrote {len(pages)} feedback pages in {args.feedback}"))

    def made(kind: str, target: str) -> str:
        if kind == "csv":
            return to_csv(exercise, reports, matched)
        if kind == "json":
            return to_json(exercise, reports, matched)
        if kind == "gradescope":
            return to_gradescope(exercise, reports[0])
        where = Path(target).resolve().parent  # each student linked to their page, from where the class page is
        return to_html(exercise, reports, {name: os.path.relpath(page, where) for name, page in pages.items()})

    for target, kind in targets:  # one that fails does not keep the others from being written
        try:
            # a problem quoting a path that is not UTF-8 (a folder from another system) has '?' for its bytes
            Path(target).write_text(made(kind, target), encoding="utf-8", errors="replace")
        except OSError as err:
            code = _fail(f"cannot write {target}: {err.strerror or err}", EXIT_USAGE)
            continue
        if not args.quiet:
            print(f"wrote {target}")
    return code


def cmd_gradescope(args: argparse.Namespace) -> int:
    """Packs an exercise, with this package, as the autograder zip Gradescope takes."""
    from pathlib import Path

    from autonomy.classroom.exercise import SecretError, read_secret
    from autonomy.classroom.gradescope import AutograderError, build_autograder

    found = _exercise(args.exercise)
    if isinstance(found, int):
        return found
    exercise, path = found
    try:
        secret = read_secret(args.secret_file) if args.secret_file else None
    except SecretError as err:
        return _fail(str(err), EXIT_USAGE)
    try:
        data = build_autograder(exercise, Path(path), secret)
    except AutograderError as err:
        return _fail(str(err), EXIT_USAGE)
    try:
        Path(args.output).write_bytes(data)
    except OSError as err:
        return _fail(f"cannot write {args.output}: {err.strerror or err}", EXIT_USAGE)
    hidden = f", {exercise.hidden_seeds} hidden seeds from the secret" if secret and exercise.hidden_seeds else ""
    print(_shown(f"wrote {args.output}: the autograder for '{exercise.title}' ({len(data):,} bytes{hidden})"))
    return EXIT_OK


def _print_marks(exercise: Any, reports: list[Any]) -> None:
    """The class's marks as a table in the terminal; why a student was not graded, below it.

    Criteria are named in the table's head when that fits the terminal, else numbered there
    and named under the table.
    """
    from rich.cells import cell_len
    from rich.console import Console
    from rich.table import Table

    console = Console(highlight=False)
    labels = [f"{_shown(c.label)} ({c.points:g})" for c in exercise.criteria]
    names = [_shown(report.student) for report in reports]
    cells = [len(f"{m:g}") for report in reports for m in report.marks]
    student = max([len("student"), *map(cell_len, names)])  # on screen: a Chinese character takes two cells
    total = max([len("total"), *(len(f"{report.total:g}") for report in reports)])

    def width(heads: list[str]) -> int:  # the table's width with these heads over the criteria
        return student + total + sum(max(cell_len(head), *cells, 1) for head in heads) + 3 * (len(heads) + 2) + 1

    numbers = [f"#{index}" for index in range(1, len(labels) + 1)]
    title = f"{_shown(exercise.title)}: marks out of {exercise.max_points:g}"
    heads = labels if width(labels) <= console.width else numbers
    console.print(title, soft_wrap=True)
    if width(numbers) > console.width:  # too narrow even for a table: a line a student
        for name, report in zip(names, reports, strict=True):
            marks = ", ".join(f"{number} {m:g}" for number, m in zip(numbers, report.marks, strict=True))
            console.print(f"{name}: {report.total:g} ({marks})", soft_wrap=True)
    else:
        table = Table()
        table.add_column("student", no_wrap=True)
        table.add_column("total", justify="right", no_wrap=True)
        for head in heads:
            table.add_column(head, justify="right", no_wrap=True)
        for name, report in zip(names, reports, strict=True):
            table.add_row(name, f"{report.total:g}", *[f"{m:g}" for m in report.marks])
        console.print(table)
    if heads is not labels:
        for number, label in zip(numbers, labels, strict=True):
            console.print(f"  {number} {label}", soft_wrap=True)
    troubled = [(name, report) for name, report in zip(names, reports, strict=True) if report.problems]
    if troubled:
        console.print("Not graded (the mark is 0):", soft_wrap=True)
        for name, report in troubled:
            more = f" (+{len(report.problems) - 1} more)" if len(report.problems) > 1 else ""
            console.print(f"  {name}: {_shown(report.problems[0])}{more}", soft_wrap=True)


def cmd_show(args: argparse.Namespace) -> int:
    """Prints a mission's tree as text, DOT or SVG; each node says what it is."""
    from autonomy.behaviours.tree import describe_tree
    from autonomy.mission import build_tree
    from autonomy.mission.render import dot_tree
    from autonomy.record import RunHeader
    from autonomy.views.treesvg import svg_tree
    from autonomy.views.treetext import tree_text

    spec = _load(args.mission)
    if spec is None:
        return EXIT_USAGE
    nodes = describe_tree(build_tree(spec))
    render = {
        "unicode": lambda: tree_text(RunHeader(spec.name, nodes, spec.tick_hz)),
        "dot": lambda: dot_tree(nodes, spec.name),
        "svg": lambda: svg_tree(nodes, spec.name),
    }
    out = args.output if args.output not in (None, "-") else None
    suffix = out.rsplit(".", 1)[-1].lower() if out and "." in out else ""
    form = args.format or {"svg": "svg", "dot": "dot"}.get(suffix, "unicode")
    return _write_out(render[form](), out)


def _write_out(text: str, output: str | None) -> int:
    if not output or output == "-":
        sys.stdout.write(text)
        return EXIT_OK
    try:
        with open(output, "w", encoding="utf-8") as stream:
            stream.write(text)
    except OSError as err:
        return _fail(f"cannot write {output}: {err.strerror or err}", EXIT_USAGE)
    print(f"wrote {output}", file=sys.stderr)
    return EXIT_OK


def cmd_export(args: argparse.Namespace) -> int:
    """Writes a mission as BehaviorTree.CPP 4 XML, or the node palette for Groot2."""
    from autonomy.mission import BUILTINS
    from autonomy.mission.btcpp import ExportError, export_xml, palette_xml

    spec = None
    if args.mission:
        spec = _load(args.mission)
        if spec is None:
            return EXIT_USAGE
    if args.palette:
        return _write_out(palette_xml(spec.registry if spec is not None else BUILTINS), args.output)
    if spec is None:
        return _fail("export needs a MISSION, or --palette", EXIT_USAGE)
    try:
        return _write_out(export_xml(spec), args.output)
    except ExportError as err:
        return _fail(f"{args.mission}: {err}", EXIT_USAGE)


def cmd_import(args: argparse.Namespace) -> int:
    """Writes a BehaviorTree.CPP 4 file that uses autonomy's nodes as a YAML mission."""
    from autonomy.mission.btcpp import to_yaml

    spec = _load(args.tree)
    if spec is None:
        return EXIT_USAGE
    return _write_out(to_yaml(spec), args.output)


def cmd_behaviours(args: argparse.Namespace) -> int:
    """Lists every node type with its parameters (with a mission: its plugins' too)."""
    from autonomy.mission import BUILTINS
    from autonomy.mission.catalogue import catalogue_markdown, catalogue_text

    registry = BUILTINS
    if args.mission:
        spec = _load(args.mission)
        if spec is None:
            return EXIT_USAGE
        registry = spec.registry
    sys.stdout.write(catalogue_markdown(registry) if args.markdown else catalogue_text(registry))
    return EXIT_OK


def cmd_schema(args: argparse.Namespace) -> int:
    """Prints the JSON Schema of mission files (with a mission: its plugins' node types too)."""
    from autonomy.mission import BUILTINS
    from autonomy.mission.catalogue import json_schema

    registry = BUILTINS
    if args.mission:
        spec = _load(args.mission)
        if spec is None:
            return EXIT_USAGE
        registry = spec.registry
    print(json.dumps(json_schema(registry), indent=2))
    return EXIT_OK


# --------------------------------------------------------------------------- parser


def _view_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--view", action="store_true", help="serve a live page of the run (see --view-port)")
    parser.add_argument(
        "--view-port", type=_tcp_port, default=8765, metavar="PORT", help="the page's port (default 8765; 0: any free)"
    )
    parser.add_argument(
        "--view-host",
        default="127.0.0.1",
        metavar="HOST",
        help="the interface to serve on (default 127.0.0.1, this machine only)",
    )


def _tcp_port(text: str, not_a_number: str = "") -> int:
    if not (text.isascii() and text.isdigit()):
        raise argparse.ArgumentTypeError(not_a_number or f"expected a port number, got {visible(text)!r}")
    number = int(text)
    if not 0 <= number <= 65535:
        raise argparse.ArgumentTypeError(f"port must be 0..65535, got {number}")
    return number


def build_parser() -> argparse.ArgumentParser:
    """Returns the argument parser for every subcommand."""
    parser = _Parser(prog="autonomy", description="Missions as behaviour trees on a small self-balancing robot.")
    parser.add_argument("--version", action="version", version=f"autonomy {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    emu = sub.add_parser("emulator", help="serve an emulated robot over TCP or a pseudo-terminal")
    where = emu.add_mutually_exclusive_group()
    where.add_argument(
        "--tcp",
        type=_host_port,
        default=("127.0.0.1", 7777),
        metavar="HOST:PORT",
        help="listen on TCP (default 127.0.0.1:7777; port 0 picks a free one)",
    )
    where.add_argument("--pty", action="store_true", help="serve on a pseudo-terminal and print its path")
    emu.add_argument("--world", default="box", metavar="NAME|PATH", help="arena (default box)")
    emu.add_argument("--seed", type=int, default=0, help="seed for faults and sensor noise (default 0)")
    emu.add_argument("--faults", type=_faults, default="", metavar="SPEC", help="e.g. drop=0.01,corrupt=0.01,pace")
    emu.add_argument(
        "--baud",
        type=int,
        choices=SUPPORTED_BAUD_RATES,
        default=DEFAULT_BAUD,
        help="the baud rate the emulated robot is set to (pacing, mismatch)",
    )
    emu.add_argument("--battery", type=float, metavar="LEVEL", help="battery level at start, 0..255 (default 230)")
    emu.add_argument("--noise", type=float, metavar="MM", help="front sensor noise, standard deviation (default 0)")
    emu.add_argument("--mode", choices=("auto", "manual"), help="auto or manual mode at start (default auto)")
    emu.add_argument("--boot", type=float, metavar="S", help="seconds the robot ignores input after start (default 0)")
    emu.set_defaults(func=cmd_emulator)

    probe = sub.add_parser("probe", help="check that a robot answers and print what it reports")
    probe.add_argument(
        "--port", required=True, metavar="URL", help="/dev/ttyUSB0, COM3, socket://HOST:PORT or emu://[?options]"
    )
    probe.add_argument("--baud", type=int, choices=SUPPORTED_BAUD_RATES, default=DEFAULT_BAUD)
    probe.add_argument("--json", action="store_true", help="print one JSON object")
    probe.add_argument(
        "--wait", type=float, default=3.0, metavar="S", help="how long to wait for the robot to answer (default 3 s)"
    )
    probe.set_defaults(func=cmd_probe)

    run = sub.add_parser("run", help="run a mission on the robot or the built-in emulator")
    run.add_argument("mission", metavar="MISSION", help="a mission file (.yaml, or BehaviorTree.CPP 4 .xml)")
    run.add_argument("--port", metavar="URL", help="the robot (default: the built-in emulator, in the mission's world)")
    run.add_argument("--baud", type=int, choices=SUPPORTED_BAUD_RATES, default=DEFAULT_BAUD)
    run.add_argument("--world", metavar="NAME|PATH", help="the emulator's arena (overrides the mission's world)")
    run.add_argument("--fast", action="store_true", help="virtual time: as fast as the machine allows (emulator only)")
    run.add_argument("--max-seconds", type=_positive, metavar="S", help="stop the mission after this long")
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

    world = sub.add_parser("world", help="look at worlds")
    world_sub = world.add_subparsers(dest="world_command", required=True, parser_class=_Parser)
    world_show = world_sub.add_parser("show", help="draw a world with its start pose (SVG, or PNG)")
    world_show.add_argument("world", metavar="WORLD", help="a built-in world's name or a world file")
    world_show.add_argument(
        "-o", "--output", metavar="FILE", help="FILE.svg or FILE.png (default: SVG on standard output)"
    )
    world_show.add_argument(
        "--seed",
        type=_bounded(int, 0, 2**31 - 1, "a seed"),
        metavar="N",
        help="draw it as a run with seed N has it: what it varies moved, its start jittered",
    )
    world_show.set_defaults(func=cmd_world_show)
    world_list = world_sub.add_parser("list", help="the built-in worlds: name, size and what each is for")
    world_list.set_defaults(func=cmd_world_list)

    check = sub.add_parser("check", help="validate mission files, reporting every problem")
    check.add_argument("missions", nargs="+", metavar="MISSION")
    check.set_defaults(func=cmd_check)

    grade = sub.add_parser("grade", help="run mission files against an exercise and mark them")
    grade.add_argument("exercise", metavar="EXERCISE", help="an exercise file, or a name (./exercises/, or shipped)")
    grade.add_argument(
        "submissions", nargs="+", metavar="SUBMISSION", help="mission files, or folders of one student's files"
    )
    grade.add_argument(
        "--workers",
        type=_bounded(int, 1, 256, "a number of processes"),
        metavar="N",
        help="processes at once (default: the machine's cores)",
    )
    grade.add_argument("--allow-plugins", action="store_true", help="run the Python plugins submissions load")
    grade.add_argument(
        "--cpu-seconds",
        type=_bounded(float, 1, 86400, "a number of seconds"),
        metavar="S",
        help="CPU time a submission may take, all its seeds (default: 60, more for long exercises)",
    )
    grade.add_argument(
        "--wall-seconds",
        type=_bounded(float, 1, 864000, "a number of seconds"),
        metavar="S",
        help="wall time a submission may take, for one that waits rather than works (default: 10 times --cpu-seconds)",
    )
    grade.add_argument(
        "--memory-mb",
        type=_bounded(int, 256, 1 << 20, "a number of MiB"),
        default=1024,
        metavar="MB",
        help="memory a submission may take (default 1024)",
    )
    grade.add_argument(
        "--secret-file",
        metavar="FILE",
        help="the teacher's secret, which draws the exercise's hidden seeds: they are graded too",
    )
    grade.add_argument(
        "--roster",
        metavar="FILE.csv",
        help="the class list (columns id,name,submission): ids first in the gradebook, missing students listed",
    )
    grade.add_argument(
        "--adjust",
        metavar="FILE.csv",
        help="the teacher's corrections (columns student,points,reason): added to the marks, shown with the reason",
    )
    grade.add_argument("--compare", metavar="OLD.json", help="say what changed since an earlier grading's --json")
    grade.add_argument("--csv", metavar="FILE", help="write a gradebook: student, total, one column per criterion")
    grade.add_argument("--json", metavar="FILE", help="write every mark, verdict and path as JSON")
    grade.add_argument("--html", metavar="FILE", help="write one page: the class table, each student's runs on maps")
    grade.add_argument(
        "--gradescope", metavar="FILE", help="write one submission's results as Gradescope's autograder results.json"
    )
    grade.add_argument(
        "--feedback",
        metavar="DIR",
        help="write one page per student into DIR, to hand to them: their file, marks, and each run to replay",
    )
    grade.add_argument("--traces", metavar="DIR", help="keep each run's trace in DIR/STUDENT/, for autonomy replay")
    grade.add_argument(
        "--dask",
        metavar="ADDRESS",
        help="grade on the Dask cluster with its scheduler at ADDRESS (tcp://host:8786; needs autonomy[cluster])",
    )
    grade.add_argument("--quiet", action="store_true", help="print nothing but errors (write the files)")
    grade.set_defaults(func=cmd_grade)

    scope = sub.add_parser("gradescope", help="pack an exercise as the autograder zip Gradescope takes")
    scope.add_argument("exercise", metavar="EXERCISE", help="an exercise file, or a name (./exercises/, or shipped)")
    scope.add_argument("-o", "--output", metavar="FILE.zip", default="autograder.zip", help="default autograder.zip")
    scope.add_argument("--secret-file", metavar="FILE", help="the teacher's secret, for the exercise's hidden seeds")
    scope.set_defaults(func=cmd_gradescope)

    show = sub.add_parser("show", help="print a mission's tree (text, Graphviz DOT or an SVG picture)")
    show.add_argument("mission", metavar="MISSION")
    show.add_argument(
        "--format",
        choices=("unicode", "dot", "svg"),
        default=None,
        help="unicode (the default): the tree as text; dot: Graphviz's language (dot -Tpng); svg: a picture. "
        "-o FILE.svg or FILE.dot writes that format without it",
    )
    show.add_argument("-o", "--output", metavar="FILE", help="where to write it (default: standard output)")
    show.set_defaults(func=cmd_show)

    export = sub.add_parser("export", help="write a mission as BehaviorTree.CPP 4 XML, or the palette for Groot2")
    export.add_argument("mission", nargs="?", metavar="MISSION", help="the mission (with --palette: add its plugins)")
    export.add_argument("--palette", action="store_true", help="the model of every node type, for Groot2's editor")
    export.add_argument("-o", "--output", metavar="FILE", help="where to write it (default: standard output)")
    export.set_defaults(func=cmd_export)

    imports = sub.add_parser("import", help="write a BehaviorTree.CPP 4 file of autonomy's nodes as a YAML mission")
    imports.add_argument("tree", metavar="TREE.xml")
    imports.add_argument("-o", "--output", metavar="FILE", help="where to write it (default: standard output)")
    imports.set_defaults(func=cmd_import)

    behaviours = sub.add_parser("behaviours", help="list every node type and its parameters")
    behaviours.add_argument("mission", nargs="?", metavar="MISSION", help="also list this mission's plugin behaviours")
    behaviours.add_argument("--markdown", action="store_true", help="as the reference of docs/missions.md")
    behaviours.set_defaults(func=cmd_behaviours)

    schema = sub.add_parser("schema", help="print the JSON Schema of mission files, for editors")
    schema.add_argument(
        "mission", nargs="?", metavar="MISSION", help="also its plugins' node types (an editor then knows them)"
    )
    schema.set_defaults(func=cmd_schema)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the command line; returns the exit code."""
    args = build_parser().parse_args(argv)
    return int(args.func(args))


def run() -> None:
    """Console-script entry point."""
    for name in ("stdout", "stderr"):
        if getattr(sys, name) is None:  # started with it closed (>&-): what it says is lost, the command still runs
            setattr(sys, name, open(os.devnull, "w", encoding="utf-8"))  # noqa: SIM115 - for the whole process
    try:
        code = main()
        sys.stdout.flush()
    except BrokenPipeError:  # the reader went away (| head): nothing more to say
        _silence_stdout()
        code = EXIT_OK
    except KeyboardInterrupt:  # before or after a run, when there is no robot to stop
        code = EXIT_INTERRUPTED
    # The command is done: a Ctrl-C pressed again now (as the interpreter shuts down, when Python
    # has put back the default handler) would end the process by the signal, not with its code.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    sys.exit(code)


__all__ = ["build_parser", "main", "run"]

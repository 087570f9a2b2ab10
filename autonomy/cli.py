"""The ``autonomy`` command: parses arguments, calls the library, turns errors into exit codes.

This is the only module that prints or exits. Exit codes: 0 success, 1 mission failed,
2 invalid mission or usage, 3 robot link error, 130 interrupted (Ctrl-C or SIGTERM).
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
from collections.abc import Sequence
from typing import Any

from autonomy.client import DEFAULT_BAUD, SUPPORTED_BAUD_RATES, Client
from autonomy.clock import VirtualClock
from autonomy.emulator import FaultSpec, FaultSpecError, WorldError, emulator_from_options
from autonomy.errors import AutonomyError, LinkError

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_LINK = 3
EXIT_INTERRUPTED = 130


class _Parser(argparse.ArgumentParser):
    """argparse with errors as one line and exit code 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _fail(message: str, code: int) -> int:
    print(f"autonomy: error: {message}", file=sys.stderr)
    return code


# --------------------------------------------------------------------------- emulator


def _host_port(text: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    if not sep:
        host, port = "127.0.0.1", text
    try:
        number = int(port)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected HOST:PORT or PORT, got '{text}'") from None
    if not 0 <= number <= 65535:
        raise argparse.ArgumentTypeError(f"port must be 0..65535, got {number}")
    return host or "127.0.0.1", number


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got '{text}'") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be above 0, got {text}")
    return value


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
    try:
        emulator = emulator_from_options(options)
        server = PtyServer(emulator) if args.pty else TcpServer(emulator, *args.tcp)
    except (WorldError, ValueError) as err:
        return _fail(str(err), EXIT_USAGE)
    except OSError as err:
        return _fail(f"cannot serve on {args.tcp[0]}:{args.tcp[1]}: {err.strerror or err}", EXIT_LINK)
    print(server.url, flush=True)
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
        for problem in err.problems:
            print(problem, file=sys.stderr)
        return None


def _interrupt(*_: object) -> None:
    raise KeyboardInterrupt


def cmd_run(args: argparse.Namespace) -> int:
    """Runs a mission on the robot or the built-in emulator."""
    from autonomy.mission import build_tree
    from autonomy.runner import FAILED, INTERRUPTED, LINK_LOST, SUCCEEDED, Runner, TickReport

    spec = _load(args.mission)
    if spec is None:
        return EXIT_USAGE
    port = args.port or "emu://"
    emulated = port.lower().startswith("emu://")
    if args.fast and not emulated:
        return _fail("--fast runs in virtual time, which needs the built-in emulator (leave out --port)", EXIT_USAGE)
    if args.world and not emulated:
        print(f"note: --world applies to the built-in emulator; {port} has its own", file=sys.stderr)
    if emulated and "world=" not in port:
        port += ("&" if "?" in port else "?") + f"world={args.world or spec.world or 'box'}"
    trace = None
    if args.trace:
        try:
            trace = open(args.trace, "w", encoding="utf-8")  # noqa: SIM115 - closed in finally
        except OSError as err:
            return _fail(f"cannot write the trace to {args.trace}: {err.strerror}", EXIT_USAGE)
    signal.signal(signal.SIGTERM, _interrupt)
    shown = {"path": "", "at_s": -10.0}

    def on_tick(report: TickReport) -> None:
        path = " > ".join(report.active) or "(idle)"
        if path == shown["path"] and report.time_s - shown["at_s"] < 2.0:
            return
        shown.update(path=path, at_s=report.time_s)
        s = report.status
        print(
            f"{report.time_s:7.2f} s  {path:<48} front {s.front_distance_mm:3d} mm  heading {s.heading_deg:3d}  "
            f"odometer {s.odometer_mm:5d} mm  tilt {s.tilt_deg:+3d}  battery {report.battery:3d}"
            + ("  COLLIDED" if s.collided else ""),
            flush=True,
        )

    try:
        try:
            client = Client.open(port, baud=args.baud, clock=VirtualClock() if args.fast else None)
        except KeyboardInterrupt:
            return _fail("interrupted while connecting", EXIT_INTERRUPTED)
        except AutonomyError as err:
            return _fail(str(err), EXIT_LINK)
        try:
            runner = Runner(
                build_tree(spec),
                client,
                mission=spec.name,
                tick_hz=spec.tick_hz,
                max_seconds=args.max_seconds,
                trace=trace,
                on_tick=None if args.quiet else on_tick,
                on_message=lambda message: print(f"          log: {message}", flush=True),
            )
            summary = runner.run()
        finally:
            client.close()
    finally:
        if trace is not None:
            trace.close()
    print(summary.paragraph)
    return {SUCCEEDED: EXIT_OK, FAILED: EXIT_FAILED, LINK_LOST: EXIT_LINK, INTERRUPTED: EXIT_INTERRUPTED}.get(
        summary.outcome, EXIT_FAILED
    )


def cmd_check(args: argparse.Namespace) -> int:
    """Validates mission files; every problem of every file, then ok or not."""
    from autonomy.behaviours.tree import preorder
    from autonomy.mission import build_tree

    bad = 0
    for path in args.missions:
        spec = _load(path)
        if spec is None:
            bad += 1
            continue
        count = sum(1 for _ in preorder(build_tree(spec)))
        print(f"{path}: ok (mission '{spec.name}', {count} nodes)")
    return EXIT_USAGE if bad else EXIT_OK


def cmd_show(args: argparse.Namespace) -> int:
    """Prints a mission's tree as text, DOT or SVG."""
    from autonomy.mission import build_tree
    from autonomy.mission.render import dot_tree, svg_tree, unicode_tree

    spec = _load(args.mission)
    if spec is None:
        return EXIT_USAGE
    root = build_tree(spec)
    render = {
        "unicode": lambda: unicode_tree(root),
        "dot": lambda: dot_tree(root, spec.name),
        "svg": lambda: svg_tree(root, spec.name),
    }
    sys.stdout.write(render[args.format]())
    return EXIT_OK


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
    """Prints the JSON Schema of mission files."""
    from autonomy.mission import BUILTINS
    from autonomy.mission.catalogue import json_schema

    print(json.dumps(json_schema(BUILTINS), indent=2))
    return EXIT_OK


# --------------------------------------------------------------------------- parser


def build_parser() -> argparse.ArgumentParser:
    """Returns the argument parser for every subcommand."""
    parser = _Parser(prog="autonomy", description="Missions as behaviour trees on a small self-balancing robot.")
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
    run.add_argument("mission", metavar="MISSION", help="a mission file (.yaml)")
    run.add_argument("--port", metavar="URL", help="the robot (default: the built-in emulator, in the mission's world)")
    run.add_argument("--baud", type=int, choices=SUPPORTED_BAUD_RATES, default=DEFAULT_BAUD)
    run.add_argument("--world", metavar="NAME|PATH", help="the emulator's arena (overrides the mission's world)")
    run.add_argument("--fast", action="store_true", help="virtual time: as fast as the machine allows (emulator only)")
    run.add_argument("--max-seconds", type=_positive, metavar="S", help="stop the mission after this long")
    run.add_argument("--trace", metavar="FILE", help="write one JSON line per tick")
    run.add_argument("--quiet", action="store_true", help="only the summary")
    run.set_defaults(func=cmd_run)

    check = sub.add_parser("check", help="validate mission files, reporting every problem")
    check.add_argument("missions", nargs="+", metavar="MISSION")
    check.set_defaults(func=cmd_check)

    show = sub.add_parser("show", help="print a mission's tree")
    show.add_argument("mission", metavar="MISSION")
    show.add_argument("--format", choices=("unicode", "dot", "svg"), default="unicode")
    show.set_defaults(func=cmd_show)

    behaviours = sub.add_parser("behaviours", help="list every node type and its parameters")
    behaviours.add_argument("mission", nargs="?", metavar="MISSION", help="also list this mission's plugin behaviours")
    behaviours.add_argument("--markdown", action="store_true", help="as the reference of docs/missions.md")
    behaviours.set_defaults(func=cmd_behaviours)

    schema = sub.add_parser("schema", help="print the JSON Schema of mission files, for editors")
    schema.set_defaults(func=cmd_schema)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the command line; returns the exit code."""
    args = build_parser().parse_args(argv)
    return int(args.func(args))


def run() -> None:
    """Console-script entry point."""
    sys.exit(main())


__all__ = ["build_parser", "main", "run"]

"""The ``autonomy`` command: parses arguments, calls the library, turns errors into exit codes.

This is the only module that prints or exits. Exit codes: 0 success, 2 bad usage or input,
3 robot link error, 130 interrupted.
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
from autonomy.protocol import Status

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


def _status_lines(status: Status) -> list[str]:
    names = {True: "yes", False: "no"}
    return [
        f"    {key:<18}{names.get(value, value) if isinstance(value, bool) else value}"
        for key, value in status.as_dict().items()
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
            status = client.status()
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
    print("\n".join(_status_lines(status)))
    return EXIT_OK


# --------------------------------------------------------------------------- demo


def cmd_demo(args: argparse.Namespace) -> int:
    """Drives a short square on the emulator (or a robot), printing telemetry."""
    from autonomy.demo import square_drive

    clock = VirtualClock() if args.fast else None
    last = [""]

    def report(step: str, status: Status) -> None:
        line = (
            f"{step:<34} heading {status.heading_deg:3d} deg  front {status.front_distance_mm:3d} mm  "
            f"odometer {status.odometer_mm:5d} mm  tilt {status.tilt_deg:+3d} deg"
        )
        if step != last[0] or args.verbose:
            print(line, flush=True)
            last[0] = step

    try:
        with Client.open(args.port, baud=args.baud, clock=clock) as client:
            status = square_drive(client, report)
            print(
                f"done: heading {status.heading_deg} deg, odometer {status.odometer_mm} mm, "
                f"{client.stats.requests} requests, {client.stats.retries} retries"
            )
    except KeyboardInterrupt:
        return _fail("interrupted; the robot was told to stop", EXIT_INTERRUPTED)
    except AutonomyError as err:
        return _fail(str(err), EXIT_LINK)
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

    demo = sub.add_parser("demo", help="drive a short square, printing telemetry")
    demo.add_argument("--port", default="emu://", metavar="URL", help="default: the built-in emulator")
    demo.add_argument("--baud", type=int, choices=SUPPORTED_BAUD_RATES, default=DEFAULT_BAUD)
    demo.add_argument("--fast", action="store_true", help="virtual time: as fast as the machine allows")
    demo.add_argument("--verbose", action="store_true", help="a line for every status poll")
    demo.set_defaults(func=cmd_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the command line; returns the exit code."""
    args = build_parser().parse_args(argv)
    return int(args.func(args))


def run() -> None:
    """Console-script entry point."""
    sys.exit(main())


__all__ = ["build_parser", "main", "run"]

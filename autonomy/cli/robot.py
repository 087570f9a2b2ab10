"""``autonomy emulator`` and ``autonomy probe``: an emulated robot for other programs, and is the robot there."""

from __future__ import annotations

import argparse
import json
import signal
import sys
from typing import Any

from autonomy.cli.common import EXIT_LINK, EXIT_OK, EXIT_USAGE, _fail, _faults, _host_port, _world_failed
from autonomy.client import DEFAULT_BAUD, SUPPORTED_BAUD_RATES, Client
from autonomy.emulator import WorldError, emulator_from_options
from autonomy.errors import AutonomyError, LinkError


def cmd_emulator(args: argparse.Namespace) -> int:
    """Serves an emulated robot over TCP or a pseudo-terminal until Ctrl-C or SIGTERM."""
    from autonomy.emulator.servers import PtyServer, TcpServer

    if args.pty and args.rfc2217:
        return _fail("--rfc2217 is for --tcp: a pseudo-terminal carries the client's baud rate itself", EXIT_USAGE)
    options = {"world": args.world, "seed": str(args.seed), "faults": args.faults, "baud": str(args.baud)}
    for key in ("battery", "noise", "mode", "boot", "profile"):
        if getattr(args, key) is not None:
            options[key] = str(getattr(args, key))
    try:
        emulator = emulator_from_options(options)
        server = PtyServer(emulator) if args.pty else TcpServer(emulator, *args.tcp, rfc2217=args.rfc2217)
    except WorldError as err:
        return _world_failed(err)
    except ValueError as err:
        return _fail(str(err), EXIT_USAGE)
    except OSError as err:
        return _fail(f"cannot serve on {args.tcp[0]}:{args.tcp[1]}: {err.strerror or err}", EXIT_LINK)
    signal.signal(signal.SIGTERM, lambda *_: server.stop_soon())
    try:  # from the moment its address is said, a Ctrl-C stops it as it should
        print(server.url, flush=True)
        if getattr(server, "public", False):
            where = "every network address" if args.tcp[0] in ("0.0.0.0", "::", "") else "a network address"
            print(
                f"autonomy: warning: serving on {where} ({args.tcp[0]}): anyone who can reach this "
                "machine can drive the robot; use 127.0.0.1 unless you mean it",
                file=sys.stderr,
                flush=True,
            )
        robot = f" as robot profile '{args.profile}'" if args.profile else ""
        said = f"emulated robot in world '{emulator.world.name}'{robot}, {args.baud} baud, faults: {emulator.faults}"
        print(f"{said}; Ctrl-C to stop", file=sys.stderr, flush=True)
        server.serve_forever()
    except KeyboardInterrupt:
        server.stop_soon()
        server.serve_forever()  # returns at once, closing the port
    return EXIT_OK


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


def add_parsers(sub: Any) -> None:
    """Adds this module's commands to the command line's subparsers."""
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
    emu.add_argument(
        "--rfc2217",
        action="store_true",
        help="on TCP, speak RFC 2217 (rfc2217://HOST:PORT): the client says its baud rate, as on a real line",
    )
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
    emu.add_argument(
        "--profile", metavar="FILE", help="the robot's own settings: a robot profile, as `autonomy calibrate` writes it"
    )
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

"""The ``autonomy`` command: parses arguments, calls the library, turns errors into exit codes.

This package is the only place that prints or exits. Exit codes: 0 success, 1 mission failed,
2 invalid mission or usage, 3 robot link error, 130 interrupted (Ctrl-C or SIGTERM).

One module per command or family, each adding its own subparsers; what they share is in
:mod:`autonomy.cli.common`.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
from collections.abc import Sequence

from autonomy import __version__
from autonomy.cli import calibrate, exercises, grade, liveclass, missions, robot, runs, scenarios, world
from autonomy.cli.common import EXIT_INTERRUPTED, EXIT_OK, _Parser, _silence_stdout


def build_parser() -> argparse.ArgumentParser:
    """Returns the argument parser for every subcommand."""
    parser = _Parser(prog="autonomy", description="Missions as behaviour trees on a small self-balancing robot.")
    parser.add_argument("--version", action="version", version=f"autonomy {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    robot.add_parsers(sub)
    runs.add_parsers(sub)
    world.add_parsers(sub)
    missions.add_check(sub)
    grade.add_parsers(sub)
    exercises.add_parsers(sub)
    liveclass.add_parsers(sub)
    missions.add_parsers(sub)
    scenarios.add_parsers(sub)
    calibrate.add_parsers(sub)
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

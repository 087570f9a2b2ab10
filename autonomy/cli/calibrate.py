"""``autonomy calibrate``: the emulator's settings fitted to a robot, by a probe on the robot or from its traces."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from autonomy.cli.common import (
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_LINK,
    EXIT_OK,
    EXIT_USAGE,
    _fail,
    _InterruptOnce,
    _shown,
    _world_failed,
)
from autonomy.cli.runs import _is_terminal
from autonomy.client import DEFAULT_BAUD, SUPPORTED_BAUD_RATES
from autonomy.emulator import WorldError
from autonomy.errors import AutonomyError, Interrupted, LinkError

#: How far a robot may drift from its profile and still match it: a share of each setting, or
#: an amount (the delay, s; the sensor's offset, mm).
CHECK_SHARE = {
    "acceleration_mm_s2": 0.10,
    "sensor_scale": 0.03,
    "sensor_noise_mm": None,  # noise is not a fault of the robot's: not checked
}
CHECK_SHARE_DEFAULT = 0.03
CHECK_AMOUNT = {"command_delay_s": 0.03, "sensor_offset_mm": 10.0}
#: A fitted sensor offset past this, mm, is said with what else it may be: the wall not where --wall-mm says.
OFFSET_TOLD_MM = 30.0

FLOOR = (
    "The probe drives the robot for about half a minute (2 minutes at most). Put it on a flat floor facing a "
    "wall, its front {wall:g} mm from the wall (measure it), with nothing else in between or beside that path. "
    "It turns in place, drives forward and back at each speed, and drives up to the wall. "
    "Ctrl-C stops it at any moment."
)


def _probe(args: argparse.Namespace) -> Any:
    """Drives the probe on ``args.port``; the recording, or an exit code (why said)."""
    from autonomy.calibration import Probe, ProbeRefused, ProbeStopped
    from autonomy.client import Client

    print(_shown(FLOOR.format(wall=args.wall_mm)), file=sys.stderr)
    if not args.yes:
        if not _is_terminal(sys.stdin):
            return _fail("the probe drives the robot: run it in a terminal to confirm, or give --yes", EXIT_USAGE)
        try:
            input("Press Enter when the robot is ready (Ctrl-C: not now) ")
        except (EOFError, KeyboardInterrupt):
            print(file=sys.stderr)
            return EXIT_INTERRUPTED
    interrupts = _InterruptOnce()
    interrupts.install()
    client = None
    try:
        client = Client.open(args.port, baud=args.baud, guardian=not args.port.startswith("emu://"))
        return Probe(client, args.wall_mm, lambda line: print(_shown(line), file=sys.stderr)).run()
    except Interrupted:
        return _fail("interrupted: the robot was stopped where it was", EXIT_INTERRUPTED)
    except (ProbeRefused, ProbeStopped) as err:
        stopped = "the robot was stopped" if isinstance(err, ProbeStopped) else "nothing moved"
        return _fail(f"{err} ({stopped})", EXIT_FAILED)
    except LinkError as err:
        return _fail(str(err), EXIT_LINK)
    except AutonomyError as err:
        return _fail(f"{args.port}: {err}", EXIT_LINK)
    finally:
        if client is not None:
            client.close()  # stops the robot, whatever ended the probe


def _traces(paths: list[str]) -> Any:
    from autonomy.calibration import Recording, from_trace
    from autonomy.trace import TraceError

    runs: list[Recording] = []
    for path in paths:
        try:
            runs.append(from_trace(path))
        except TraceError as err:
            return _fail(str(err), EXIT_USAGE)
    return runs


def _check_line(profile_path: str, profile: Any, found: Any) -> tuple[bool, str]:
    """Whether the robot still matches its profile, and one line that says so (or what changed)."""
    from autonomy.calibration.fit import start_values

    expected = start_values(profile.params) | {
        "sensor_scale": profile.params.sensor_scale,
        "sensor_offset_mm": profile.params.sensor_offset_mm,
    }
    off: list[str] = []
    for value in found.values:
        if not value.fitted or value.name not in expected:
            continue
        share = CHECK_SHARE.get(value.name, CHECK_SHARE_DEFAULT)
        was = expected[value.name]
        if value.name in CHECK_AMOUNT:
            if abs(value.value - was) > CHECK_AMOUNT[value.name]:
                off.append(f"{value.name} is {value.value:.3g} {value.unit} (profile {was:.3g})".replace("  ", " "))
        elif share is not None and abs(value.value - was) > share * abs(was):
            change = 100 * (value.value - was) / was
            off.append(f"{value.name} is {change:+.1f}% ({value.value:.4g} {value.unit}, profile {was:.4g})")
    if off:
        return False, (
            f"{profile_path}: the robot no longer matches its profile: {'; '.join(off)}: calibrate it again "
            "(a worn wheel or a low battery does this)"
        )
    return True, (
        f"{profile_path}: the robot matches its profile (each setting within its tolerance; the fit's residual "
        f"{found.rms_mm:.1f} mm and {found.rms_deg:.1f} degrees RMS)"
    )


def _output_refused(output: Path, traces: list[Path]) -> str:
    """Why ``-o`` cannot be written, said before the probe drives (a profile fitted is never lost); empty if it can."""
    import os

    if output.is_dir():
        return f"-o {output} is a folder: give the profile's file name (robot-NAME.yaml)"
    for trace in traces:
        if output.exists() and trace.exists() and os.path.samefile(output, trace):
            return f"-o {output} is one of the traces fitted: give the profile a file of its own (robot-NAME.yaml)"
    folder = output.parent
    if not folder.is_dir():
        return f"-o {output}: the folder {folder} is not there: make it first, or write the profile elsewhere"
    if not os.access(folder, os.W_OK | os.X_OK) or (output.exists() and not os.access(output, os.W_OK)):
        return f"-o {output}: this user cannot write there: write the profile elsewhere"
    return ""


def cmd_calibrate(args: argparse.Namespace) -> int:
    """Probes a robot (or reads traces), fits the emulator's settings, and writes or checks a profile."""
    if args.check and args.port is None:
        return _fail("--check probes the robot: give --port PORT", EXIT_USAGE)
    if args.port is None and not args.traces:
        return _fail("give --port PORT to probe a robot, or the trace files of its earlier runs to fit", EXIT_USAGE)
    if args.port is not None and args.traces:
        return _fail("give --port PORT or trace files, not both", EXIT_USAGE)
    if args.check and args.output:
        return _fail("--check says whether the robot matches its profile; it writes nothing (leave out -o)", EXIT_USAGE)
    try:
        from autonomy.calibration import FitError, fit
    except ImportError as err:
        return _fail(f"autonomy calibrate needs scipy ({err.name}): pip install 'autonomy[calibrate]'", EXIT_USAGE)
    from autonomy.emulator import load_profile, profile_text

    profile = None
    if args.check:
        try:
            profile = load_profile(args.check)
        except WorldError as err:
            return _world_failed(err)
    if args.output:
        refused = _output_refused(Path(args.output), [Path(trace) for trace in args.traces])
        if refused:
            return _fail(refused, EXIT_USAGE)
    recording = _probe(args) if args.port is not None else _traces(args.traces)
    if isinstance(recording, int):
        return recording
    try:
        found = fit(recording, profile.params if profile is not None else None)
    except FitError as err:
        return _fail(str(err), EXIT_USAGE)
    if profile is not None:
        matches, line = _check_line(args.check, profile, found)
        print(_shown(line))
        return EXIT_OK if matches else EXIT_FAILED
    print(
        f"Fitted from {found.samples:,} samples (residual {found.rms_mm:.2f} mm and {found.rms_deg:.2f} degrees RMS):"
    )
    for value in found.values:
        print(_shown(f"  {value.line}"))
    offset = next((v for v in found.values if v.name == "sensor_offset_mm" and v.fitted), None)
    if offset is not None and args.port is not None and abs(offset.value) > OFFSET_TOLD_MM:
        print(
            _shown(
                f"note: the sensor reads {abs(offset.value):.0f} mm {'more' if offset.value > 0 else 'less'} than the "
                f"distance to the wall: if the wall was not {args.wall_mm:g} mm from the robot's front, measure it and "
                "probe again with --wall-mm"
            ),
            file=sys.stderr,
        )
    name = args.name or (Path(args.output).stem if args.output else "robot")
    text = profile_text(found.params, name, found.notes())
    if not args.output:
        print("\nThe profile (write it to a file with -o robot-NAME.yaml):\n")
        print(text, end="")
        return EXIT_OK
    replaced = Path(args.output).exists()
    try:
        Path(args.output).write_text(text, encoding="utf-8")
    except OSError as err:
        return _fail(f"cannot write {args.output}: {err.strerror or err}", EXIT_USAGE)
    wrote = "Wrote (over the profile that was there)" if replaced else "Wrote"
    print(_shown(f"{wrote} {args.output}: use it with --profile {args.output}, or an exercise's robot: {args.output}"))
    return EXIT_OK


def _wall_mm(text: str) -> float:
    from autonomy.calibration.probe import WALL_MM

    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected millimetres, got '{text}'") from None
    if not WALL_MM[0] <= value <= WALL_MM[1]:
        raise argparse.ArgumentTypeError(f"must be from {WALL_MM[0]:.0f} to {WALL_MM[1]:.0f} mm, got {text}")
    return value


def add_parsers(sub: Any) -> None:
    """Adds ``autonomy calibrate``."""
    cal = sub.add_parser(
        "calibrate",
        help="fit the emulator's settings to a robot: a short probe on it, or its traces; writes a robot profile",
    )
    cal.add_argument("traces", nargs="*", metavar="TRACE", help="traces of the robot's earlier runs (run --trace)")
    cal.add_argument("--port", metavar="URL", help="the robot to probe (it drives: see docs/robots.md)")
    cal.add_argument("--baud", type=int, choices=SUPPORTED_BAUD_RATES, default=DEFAULT_BAUD)
    cal.add_argument(
        "--wall-mm",
        type=_wall_mm,
        default=1000.0,
        metavar="MM",
        help="how far the robot's front is from the wall it faces (default 1000)",
    )
    cal.add_argument("--yes", action="store_true", help="the robot is ready: start without asking")
    cal.add_argument("-o", "--output", metavar="FILE", help="write the profile there (robot-NAME.yaml)")
    cal.add_argument("--name", help="what the profile calls the robot (default: the file's name)")
    cal.add_argument(
        "--check", metavar="PROFILE", help="say whether the robot still matches PROFILE (exit 0) or not (exit 1)"
    )
    cal.set_defaults(func=cmd_calibrate)

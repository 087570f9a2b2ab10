"""``autonomy world list`` and ``autonomy world show``."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from typing import Any

from autonomy.cli.common import EXIT_OK, EXIT_USAGE, _bounded, _fail, _Parser, _shown, _world_failed
from autonomy.emulator import WorldError


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


def add_parsers(sub: Any) -> None:
    """Adds this module's commands to the command line's subparsers."""
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

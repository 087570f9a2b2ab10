"""``autonomy exercise list`` and ``autonomy exercise show``: the exercises at hand, and one to hand out."""

from __future__ import annotations

import argparse
import textwrap
from typing import Any

from autonomy.cli.common import EXIT_OK, _Parser, _shown
from autonomy.words import plural


def cmd_exercise_list(args: argparse.Namespace) -> int:
    """Lists the exercises a name finds: each one's name, title, world, time, points and hidden seeds."""
    from autonomy.classroom import ExerciseInvalid, load_exercise
    from autonomy.cli.grade import exercise_folders

    own, shipped = exercise_folders()
    seen: set[str] = set()
    for where, folder in [("here", own)] + ([("shipped", shipped)] if own.resolve() != shipped.resolve() else []):
        for path in sorted(folder.glob("*.yaml")) if folder.is_dir() else []:
            if path.stem in seen:  # a teacher's own of that name is the one a name finds
                continue
            seen.add(path.stem)
            try:
                exercise = load_exercise(path)
            except ExerciseInvalid as err:
                print(_shown(f"{path.stem:10} {where}: not a valid exercise ({len(err.problems)} problems: autonomy "
                             f"check {path})"))  # fmt: skip
                continue
            hidden = f", {exercise.hidden_seeds} hidden seeds" if exercise.hidden_seeds else ""
            print(_shown(
                f"{path.stem:10} {exercise.title}: world {exercise.world.name}, {exercise.time_limit_s:g} s a run, "
                f"{exercise.max_points:g} points, {plural(len(exercise.seeds), 'seed')}{hidden} ({where})"
            ))  # fmt: skip
    print("Hand one out with autonomy exercise show NAME; grade with autonomy grade NAME FILES...")
    return EXIT_OK


def cmd_exercise_show(args: argparse.Namespace) -> int:
    """Prints an exercise as a student is given it: what to do, where, in how long, what is marked, with what nodes."""
    from autonomy.cli.grade import _exercise

    found = _exercise(args.exercise)
    if isinstance(found, int):
        return found
    exercise, _ = found
    for line in exercise_text(exercise):
        print(_shown(line) if line else "")
    return EXIT_OK


def exercise_text(exercise: Any) -> list[str]:
    """The exercise's text for a student: its title, what to do, the world and time, the marks, the nodes to use."""
    lines = [exercise.title, "=" * len(exercise.title), ""]
    for paragraph in exercise.description.strip().split("\n\n"):  # folded for a page, its paragraphs kept
        lines += [*textwrap.wrap(" ".join(paragraph.split()), width=88), ""]
    lines.append(f"World: {exercise.world.name}. Each run may take {exercise.time_limit_s:g} s.")
    public = sum(1 for seed in exercise.seeds if not seed.hidden)
    hidden = f", and on {exercise.hidden_seeds} hidden ones when handed in" if exercise.hidden_seeds else ""
    each = " (each a little different)" if public > 1 else ""
    lines.append(f"Your mission is run on {plural(public, 'seed')}{each}{hidden}.")
    lines += ["", f"Marks ({exercise.max_points:g} points):"]
    lines += [f"  - {criterion.shown}: {criterion.points:g}" for criterion in exercise.criteria if criterion.points]
    if exercise.robot_points:
        most = exercise.robot_points
        lines.append(f"  - a run on one of the class's robots, marked by your teacher: up to {most:g} more")
    if exercise.allowed_nodes is not None:
        lines += ["", f"Nodes you may use: {', '.join(exercise.allowed_nodes)}."]
    return lines


def add_parsers(sub: Any) -> None:
    """Adds this module's commands to the command line's subparsers."""
    exercise = sub.add_parser("exercise", help="the exercises at hand, and one as a teacher hands it out")
    exercise_sub = exercise.add_subparsers(dest="exercise_command", required=True, parser_class=_Parser)
    listed = exercise_sub.add_parser("list", help="the exercises a name finds (./exercises/, then the shipped ones)")
    listed.set_defaults(func=cmd_exercise_list)
    shown = exercise_sub.add_parser("show", help="an exercise's text, as a student is given it")
    shown.add_argument("exercise", metavar="EXERCISE", help="an exercise's name or file")
    shown.set_defaults(func=cmd_exercise_show)

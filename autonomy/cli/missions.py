"""Mission files: ``check``, ``show``, ``blocks``, ``edit``, ``export``, ``import``, ``behaviours``, ``schema``."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from autonomy.cli.common import EXIT_OK, EXIT_USAGE, _fail, _load, _problems, _shown, _tcp_port, _world_failed
from autonomy.emulator import WorldError
from autonomy.words import plural


def _kind_of(path: str) -> str:
    """What a file to check is: an exercise, a world, a scenario file or (else) a mission.

    An exercise has ``criteria:`` at its top, a world ``arena_mm:``, a scenario file is a ``NAME.test.yaml``;
    anything else is read as a mission, whose reader says what is wrong with it.
    """
    import re

    from autonomy.scenarios.files import SUFFIX
    from autonomy.source import UnreadableFile, read_text

    if path.endswith(SUFFIX):
        return "scenarios"
    try:
        text = read_text(Path(path))
    except UnreadableFile:
        return "mission"  # the mission's reader says why
    if re.search(r"^mission\s*:", text, re.M):
        return "mission"
    if re.search(r"^criteria\s*:", text, re.M):
        return "exercise"
    return "world" if re.search(r"^arena_mm\s*:", text, re.M) else "mission"


def _check_world(path: str) -> bool:
    """Validates a world file: every problem at its place, or what it holds."""
    from autonomy.emulator import load_world
    from autonomy.words import plural

    try:
        world = load_world(path)
    except WorldError as err:
        _world_failed(err)
        return False
    zones = f", zones {', '.join(zone.name for zone in world.zones)}" if world.zones else ""
    size = f"{world.width_mm / 1000:g} x {world.height_mm / 1000:g} m"
    print(_shown(f"{path}: ok (world '{world.name}', {size}, {plural(len(world.obstacles), 'obstacle')}{zones})"))
    return True


def _tests_of(path: str) -> str | None:
    """``, N scenarios in its tests:`` for a mission's own tests; None when they have problems (each one said)."""
    from autonomy.scenarios import ScenariosInvalid, load_scenarios
    from autonomy.words import plural

    try:
        tests = load_scenarios(path)
    except ScenariosInvalid as err:
        _problems(err.problems)
        return None
    return f", {plural(len(tests.scenarios), 'scenario')} in its tests: autonomy test runs them"


def _check_scenarios(path: str) -> bool:
    """Validates a scenario file and the mission it tests: every problem at its place, or what it holds."""
    from autonomy.scenarios import ScenariosInvalid, load_scenarios
    from autonomy.words import plural

    try:
        tests = load_scenarios(path)
    except ScenariosInvalid as err:
        _problems(err.problems)
        return False
    print(
        _shown(f"{path}: ok ({plural(len(tests.scenarios), 'scenario')} of {tests.mission}; autonomy test runs them)")
    )
    return True


def _check_exercise(path: str, secret_file: str | None) -> bool:
    """Validates an exercise (its world, zones, criteria) and grades its ``solution:`` on every seed.

    Returns:
        Whether all is well: every problem is said, and each seed where the solution falls short.
    """
    from autonomy.classroom import ExerciseInvalid, grade_one, load_exercise
    from autonomy.classroom.secret import SecretError, read_secret

    try:
        exercise = load_exercise(path)
    except ExerciseInvalid as err:
        _problems(err.problems)
        return False
    hidden = f" and {exercise.hidden_seeds} hidden" if exercise.hidden_seeds else ""
    print(_shown(
        f"{path}: ok (exercise '{exercise.name}', world {exercise.world.name}, "
        f"{plural(len(exercise.criteria), 'criterion', 'criteria')}, {exercise.max_points:g} points, "
        f"{plural(len(exercise.seeds), 'seed')}{hidden})"
    ))  # fmt: skip
    if not exercise.solution:
        return True
    if not Path(exercise.solution).is_file():
        print(_shown(f"{path}: solution: the solution file {exercise.solution} is not there"), file=sys.stderr)
        return False
    if secret_file:
        try:
            exercise = exercise.with_secret(read_secret(secret_file))
        except SecretError as err:
            print(_shown(f"autonomy: error: {err}"), file=sys.stderr)
            return False
    report = grade_one(exercise, "solution", Path(exercise.solution))
    short = [seed for seed in report.seeds if any(share < 1 for share in seed.shares)] if not report.problems else []
    if report.problems:
        print(_shown(f"  its solution {exercise.solution} cannot be graded:"))
        for problem in report.problems:
            print(_shown(f"    {problem}"))
        return False
    for seed in short:
        lost = [
            f"{c.label}: {line}" for c, (held, line) in zip(exercise.criteria, seed.verdicts, strict=True) if not held
        ]
        print(_shown(f"  its solution falls short on {seed.seed}: " + "; ".join(lost)))
    seeds = f"{len(report.seeds)} seeds" + ("" if exercise.hidden_seeds == 0 or secret_file else
                                             " (the hidden ones need the teacher's secret: --secret-file)")  # fmt: skip
    if not short:
        print(_shown(f"  its solution earns {report.total:g} of {exercise.max_points:g} on every one of {seeds}"))
    return not short


def cmd_check(args: argparse.Namespace) -> int:
    """Validates mission files; every problem of every file, then ok or not."""
    from autonomy.behaviours.tree import preorder
    from autonomy.mission import build_tree
    from autonomy.mission.lint import lint
    from autonomy.words import plural

    bad = 0
    for path in args.missions:
        kind = _kind_of(path)
        if kind != "mission":
            secret = getattr(args, "secret_file", None)
            bad += not (
                _check_exercise(path, secret)
                if kind == "exercise"
                else _check_world(path)
                if kind == "world"
                else _check_scenarios(path)
            )
            continue
        spec = _load(path)
        if spec is None:
            bad += 1
            continue
        tests = ""
        if spec.tests_text:  # its own tests: checked as a scenario file is, before the mission is said ok
            tests = _tests_of(path)
            if tests is None:
                bad += 1
                continue
        count = sum(1 for _ in preorder(build_tree(spec)))
        warnings = lint(spec)
        noted = f", {plural(len(warnings), 'warning')}" if warnings else ""
        print(_shown(f"{path}: ok (mission '{spec.name}', {plural(count, 'node')}{noted}{tests})"))
        for warning in warnings:
            print(_shown(warning))
    return EXIT_USAGE if bad else EXIT_OK


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
    suffix = out.rsplit(".", 1)[-1].lower() if out and "." in out.rsplit("/", 1)[-1] else ""
    if suffix not in ("", "svg", "dot", "gv", "txt"):  # a picture's name holding text would not open as one
        return _fail(f"-o {out}: a tree is written as .svg (a picture), .dot (Graphviz) or .txt, not .{suffix}",
                     EXIT_USAGE)  # fmt: skip
    form = args.format or {"svg": "svg", "dot": "dot", "gv": "dot"}.get(suffix, "unicode")
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


def cmd_blocks(args: argparse.Namespace) -> int:
    """A mission as Blockly's JSON of a workspace, or a workspace back as the mission's canonical text."""
    from pathlib import Path

    from autonomy.mission import BUILTINS, MissionInvalid
    from autonomy.mission.blocks import block_definitions, from_workspace, load_words, to_workspace, toolbox
    from autonomy.mission.blocks import workspace_json as as_json
    from autonomy.source import UnreadableFile, read_text

    try:
        words = load_words(args.words) if args.words else None
    except MissionInvalid as err:
        return _problems(err.problems)
    if args.palette:
        registry = BUILTINS if args.input is None else _registry(args.input)
        if registry is None:
            return EXIT_USAGE
        palette = {"blocks": block_definitions(registry, words), "toolbox": toolbox(registry)}
        return _write_out(json.dumps(palette, indent=1, ensure_ascii=False) + "\n", args.output)
    if args.input is None:
        return _fail("autonomy blocks: give a mission (to blocks) or a workspace .json (to a mission)", EXIT_USAGE)
    if not args.input.lower().endswith(".json"):
        spec = _load(args.input)
        if spec is None:
            return EXIT_USAGE
        return _write_out(as_json(to_workspace(spec, read_text(args.input))), args.output)
    try:
        text = read_text(args.input)
    except UnreadableFile as err:
        return _problems([f"{args.input}:{err.line}:{err.column}: cannot read the file: {err.reason}"])
    try:
        mission, _ = from_workspace(text, args.input, base_dir=Path(args.input).parent)
    except MissionInvalid as err:
        return _problems(err.problems)
    return _write_out(mission, args.output)


def cmd_edit(args: argparse.Namespace) -> int:
    """Serves a page with the mission as blocks and as text side by side, that checks and saves the file."""
    import signal
    from pathlib import Path

    from autonomy.cli.common import _interrupt, _port_busy, _warn_if_public
    from autonomy.mission import MissionInvalid
    from autonomy.mission.blocks import load_words
    from autonomy.views.editor import EditorServer

    path = Path(args.mission)
    if path.is_dir() or (path.exists() and not path.is_file()):
        return _fail(f"{args.mission} is not a file: name the mission file to edit", EXIT_USAGE)
    if not path.parent.is_dir():
        return _fail(f"no folder {path.parent} to keep {path.name} in", EXIT_USAGE)
    try:
        words = load_words(args.words) if args.words else None
    except MissionInvalid as err:
        return _problems(err.problems)
    server = EditorServer(path, args.host, args.port, words)
    try:
        server.start()
    except OSError as err:
        return _fail(f"cannot serve the editor on {args.host}:{args.port}: {_port_busy(err, '--port')}", EXIT_USAGE)
    # the page needs its key, but its runs' live view (read-only) has none
    _warn_if_public(args.host, "the editor's runs are", "watch them")
    made = "" if path.exists() else " (a new file: it is made when you save)"
    print(f"editing {path}{made}; the page is at (its key is new at each start):", file=sys.stderr)
    signal.signal(signal.SIGTERM, _interrupt)
    try:  # from the moment its address is said, a Ctrl-C ends the editor as it should
        print(server.page_url, flush=True)
        server.wait()
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
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


def _registry(mission: str | None) -> Any:
    """The node types a mission may use (its plugins' too), or the built-ins; None when the mission has problems."""
    from autonomy.mission import BUILTINS

    if not mission:
        return BUILTINS
    spec = _load(mission)
    return spec.registry if spec is not None else None


def cmd_behaviours(args: argparse.Namespace) -> int:
    """Lists every node type with its parameters (with a mission: its plugins' too)."""
    from autonomy.mission.catalogue import catalogue_markdown, catalogue_text

    registry = _registry(args.mission)
    if registry is None:
        return EXIT_USAGE
    sys.stdout.write(catalogue_markdown(registry) if args.markdown else catalogue_text(registry))
    return EXIT_OK


def cmd_schema(args: argparse.Namespace) -> int:
    """Prints the JSON Schema of mission files (with a mission: its plugins' node types too)."""
    from autonomy.mission.catalogue import json_schema

    registry = _registry(args.mission)
    if registry is None:
        return EXIT_USAGE
    print(json.dumps(json_schema(registry), indent=2))
    return EXIT_OK


def add_check(sub: Any) -> None:
    """Adds ``check`` to the command line's subparsers."""
    check = sub.add_parser(
        "check",
        help="validate mission files (or exercises: their world, zones and criteria, and their solution: graded)",
    )
    check.add_argument("missions", nargs="+", metavar="MISSION")
    check.add_argument(
        "--secret-file", metavar="FILE", help="an exercise's solution is graded on its hidden seeds too, drawn from it"
    )
    check.set_defaults(func=cmd_check)


def add_parsers(sub: Any) -> None:
    """Adds this module's other commands to the command line's subparsers."""
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
    blocks = sub.add_parser(
        "blocks",
        help="a mission as blocks (Blockly's JSON of a workspace), or a workspace.json back as the mission",
        description="MISSION.yaml gives the workspace's JSON; WORKSPACE.json gives the mission's canonical text. "
        "Both ways lose nothing: the same tree, the comments kept (docs/blocks.md).",
    )
    blocks.add_argument("input", nargs="?", metavar="MISSION|WORKSPACE.json")
    blocks.add_argument("-o", "--output", metavar="FILE", help="where to write it (default: standard output)")
    blocks.add_argument(
        "--palette", action="store_true", help="the blocks' definitions and toolbox (with a mission: its plugins')"
    )
    blocks.add_argument("--words", metavar="WORDS.yaml", help="what the blocks say (default: the English words)")
    blocks.set_defaults(func=cmd_blocks)
    edit = sub.add_parser(
        "edit", help="a page with a mission as blocks and as text side by side: check it, and save it to the file"
    )
    edit.add_argument("mission", metavar="MISSION.yaml")
    edit.add_argument("--host", default="127.0.0.1", help="the interface (default 127.0.0.1, this machine only)")
    edit.add_argument("--port", type=_tcp_port, default=8766, help="the page's port (default 8766; 0: any free one)")
    edit.add_argument("--words", metavar="WORDS.yaml", help="what the blocks say (default: the English words)")
    edit.set_defaults(func=cmd_edit)
    behaviours = sub.add_parser("behaviours", help="list every node type and its parameters")
    behaviours.add_argument("mission", nargs="?", metavar="MISSION", help="also list this mission's plugin behaviours")
    behaviours.add_argument("--markdown", action="store_true", help="as the reference of docs/missions.md")
    behaviours.set_defaults(func=cmd_behaviours)
    schema = sub.add_parser("schema", help="print the JSON Schema of mission files, for editors")
    schema.add_argument(
        "mission", nargs="?", metavar="MISSION", help="also its plugins' node types (an editor then knows them)"
    )
    schema.set_defaults(func=cmd_schema)

"""Mission file -> validated :class:`MissionSpec`, reporting every problem at once.

Nothing is built until the whole file is valid. Each problem is a :class:`Problem` that
prints as ``FILE:LINE:COL: PATH: message``, where PATH is the YAML path
(``tree.repeat.do.sequence[1].turn``).
"""

from __future__ import annotations

import hashlib
import importlib.util
import math
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from autonomy.behaviours import Param
from autonomy.behaviours.base import MAX_NUMBER
from autonomy.emulator.world import SHIPPED, WorldError, WorldInvalid, load_world, world_file
from autonomy.errors import AutonomyError, Interrupted
from autonomy.mission.registry import BUILTINS, NodeType, Registry, leaf_classes_in, leaf_type
from autonomy.mission.xml_read import AttributeText, parse_xml
from autonomy.source import (
    MAX_FILE_BYTES,
    Located,
    Problem,
    UnreadableFile,
    control_character,
    exists,
    exponent_hint,
    is_file,
    parse,
    read_text,
    refused,
)
from autonomy.source import suggest as _suggest

TOP_LEVEL = ("mission", "description", "tick_hz", "world", "subtrees", "tree", "plugins", "tests")
DEFAULT_TICK_HZ = 20.0
MIN_TICK_HZ = 1.0
MAX_TICK_HZ = 200.0
#: Deepest a tree may be, counted in nodes from the root down, subtrees expanded.
MAX_TREE_DEPTH = 50
#: Most nodes a tree may have, subtrees expanded (each use of a subtree is a copy).
MAX_TREE_NODES = 3_000
#: Longest text (a name, a message, a description) a mission may hold.
MAX_TEXT_CHARS = 1_000
#: Longest name of a subtree (it is a key of the file, and what its calls name).
MAX_NAME_CHARS = 200


class MissionInvalid(AutonomyError):
    """A mission file with problems; :attr:`problems` lists all of them, in file order."""

    def __init__(self, problems: list[Problem]) -> None:
        self.problems = sorted(problems, key=lambda p: (p.file, p.line, p.column))
        super().__init__("\n".join(str(p) for p in self.problems))


@dataclass
class NodeSpec:
    """A validated node: its type, arguments (defaults filled in), child nodes, and the arguments the file gave."""

    type: NodeType
    args: dict[str, Any]
    children: list[NodeSpec]
    name: str | None
    path: str
    line: int
    column: int
    given: tuple[str, ...] = ()

    @property
    def display_name(self) -> str:
        """The ``name:`` given in the file, or one made from the type and arguments."""
        return self.name or self.type.label(self.args)


@dataclass
class MissionSpec:
    """A validated mission file, ready to build.

    ``tests_text`` is its ``tests:`` block as written (its scenarios, docs/testing.md), which a run
    ignores and a rewrite of the file (the blocks' canonical text) keeps.
    """

    name: str
    description: str
    tick_hz: float
    world: str | None
    tree: NodeSpec
    subtrees: dict[str, NodeSpec]
    registry: Registry
    source: str
    plugins: list[str] = field(default_factory=list)
    sha256: str = ""
    tests_text: str = ""


def _type_name(value: Any) -> str:
    if value is None:
        return "nothing"
    if isinstance(value, bool):
        return f"{str(value).lower()} (true/false)"
    if isinstance(value, str):
        shown = value if len(value) <= 40 else f"{value[:40]}... ({len(value):,} characters)"
        return f"'{shown}' (text)"
    if isinstance(value, (list, dict)):
        return "a list" if isinstance(value, list) else "a mapping"
    return repr(value)


class _Validator:
    def __init__(self, source: str, registry: Registry, check_world: bool, refuse_plugins: str | None = None) -> None:
        self.source = source
        self.registry = registry
        self.check_world = check_world
        self.refuse_plugins = refuse_plugins
        self.plugins_refused = False  # a plugins list was refused: a node it would have given is not "unknown"
        self.problems: list[Problem] = []
        self.references: list[tuple[str, str, Located, str]] = []  # (owner, subtree name, where, path)

    def problem(self, where: Located | tuple[int, int], path: str, message: str) -> None:
        if isinstance(where, Located) and refused(where):  # the reader said why already
            return
        line, column = (where.line, where.column) if isinstance(where, Located) else where
        self.problems.append(Problem(self.source, line, column, path, message))

    def unknown(self, type_name: str) -> str:
        """Why ``type_name`` names no node: a likely typo, and the plugins that may define it when not run."""
        hint = _suggest(type_name, self.registry.names())
        if self.plugins_refused:
            return f"'{type_name}' is no built-in node{hint}: if a plugin of yours defines it, plugins are not run here"
        return f"unknown node '{type_name}'{hint}"

    # ------------------------------------------------------------------ top level

    def mission(self, root: Located, base_dir: Path) -> MissionSpec | None:
        if not isinstance(root.value, dict):
            self.problem(root, "", "a mission file is a mapping with at least 'mission:' and 'tree:'")
            return None
        doc: dict[str, Located] = root.value
        if "mission" not in doc and ("criteria" in doc or "arena_mm" in doc):
            what, use = (
                ("an exercise", "autonomy grade THIS_FILE MISSION")
                if "criteria" in doc
                else ("a world", "a mission's world: line, or autonomy world show THIS_FILE")
            )
            self.problem(root, "", f"this is {what} file, not a mission: use it with {use}")
            return None
        for key in doc:
            if key not in TOP_LEVEL:
                self.problem(root.keys[key], key, f"unknown key '{key}'{_suggest(key, list(TOP_LEVEL))}")
        name = self.text(doc, "mission", required_at=root)
        description = self.text(doc, "description") or ""
        world = self.text(doc, "world")
        if world is not None and self.check_world:
            world = self.world(world, doc["world"], base_dir)
        tick_hz = DEFAULT_TICK_HZ
        if "tick_hz" in doc:
            value = doc["tick_hz"].value
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                self.problem(doc["tick_hz"], "tick_hz", f"tick_hz must be a number, got {_type_name(value)}")
            elif not MIN_TICK_HZ <= value <= MAX_TICK_HZ:  # NaN fails this too
                self.problem(
                    doc["tick_hz"], "tick_hz", f"tick_hz must be from {MIN_TICK_HZ:g} to {MAX_TICK_HZ:g}, got {value}"
                )
            else:
                tick_hz = float(value)
        plugins = self.plugins(doc.get("plugins"), base_dir)
        subtrees: dict[str, NodeSpec] = {}
        known: list[str] = []
        if "subtrees" in doc:
            block = doc["subtrees"]
            if not isinstance(block.value, dict):
                self.problem(block, "subtrees", "subtrees is a mapping of names to trees")
            else:
                for sub_name, sub in block.value.items():
                    where = block.keys[sub_name]
                    if not sub_name.strip():  # the reader has made sure keys are text
                        self.problem(where, "subtrees", "a subtree needs a name that is not blank")
                        continue
                    if self.plain_text(sub_name, where, "subtrees") is None:
                        continue
                    if len(sub_name) > MAX_NAME_CHARS or "\n" in sub_name or "\r" in sub_name:
                        why = f"a subtree's name is one line of at most {MAX_NAME_CHARS} characters"
                        self.problem(where, "subtrees", why)
                        continue
                    known.append(sub_name)
                    spec = self.node(sub, f"subtrees.{sub_name}", owner=sub_name)
                    if spec is not None:
                        subtrees[sub_name] = spec
        tree = None
        if "tree" not in doc:
            self.problem(root, "", "missing 'tree:', the root node of the mission")
        else:
            tree = self.node(doc["tree"], "tree", owner="")
        self.check_references(known)
        if self.problems or tree is None or name is None:
            return None
        self.check_size(tree, subtrees)
        if self.problems:
            return None
        return MissionSpec(name, description, tick_hz, world, tree, subtrees, self.registry, self.source, plugins)

    def text(self, doc: dict[str, Located], key: str, required_at: Located | None = None) -> str | None:
        """The text under ``key``; a problem at ``required_at`` (the document) when it must be there and is not."""
        if key not in doc:
            if required_at is not None:
                self.problem(required_at, "", f"missing '{key}:'")
            return None
        value = doc[key].value
        if not isinstance(value, str) or not value.strip():
            self.problem(doc[key], key, f"{key} must be text, got {_type_name(value)}")
            return None
        return self.plain_text(value, doc[key], key)

    def plain_text(self, value: str, where: Located | tuple[int, int], path: str) -> str | None:
        """``value``, or None and a problem when it holds a control character (it would reach terminals).

        Text is at most :data:`MAX_TEXT_CHARS` long: it is shown in one line of a terminal.
        """
        bad = control_character(value)
        if bad:
            self.problem(where, path, f"contains the control character {bad}; write plain text")
            return None
        if len(value) > MAX_TEXT_CHARS:
            self.problem(where, path, f"is {len(value):,} characters long; at most {MAX_TEXT_CHARS:,}")
            return None
        return value

    def world(self, name: str, where: Located, base_dir: Path) -> str | None:
        """The world to run in: a shipped name, or a world file's path (found beside the mission).

        A world file's own problems are reported at their place in it.
        """
        path = world_file(name, base_dir)
        if path is None:
            return name
        if not is_file(path):
            if exists(path):
                self.problem(where, "world", f"'{name}' is not a world file (a folder, a device or a pipe)")
            elif Path(name).suffix or "/" in name:  # a file's name: that file is missing
                self.problem(where, "world", f"the world file '{name}' is not there (beside the mission: {path})")
            else:
                hint = _suggest(name, list(SHIPPED))
                self.problem(
                    where,
                    "world",
                    f"no world named '{name}'{hint}: use one of {', '.join(SHIPPED)}, or a world file beside the "
                    f"mission ({name}.yaml)",
                )
            return None
        try:
            load_world(path)
        except WorldInvalid as err:
            count = len(err.problems)
            self.problem(where, "world", f"the world file {path} is not valid ({count} listed with its name)")
            self.problems += err.problems
            return None
        except WorldError as err:
            self.problem(where, "world", str(err))
            return None
        return str(path)

    def plugins(self, block: Located | None, base_dir: Path) -> list[str]:
        if block is None:
            return []
        if self.refuse_plugins is not None:  # refused as written, whatever it names: nothing is imported
            self.problem(block, "plugins", self.refuse_plugins)
            self.plugins_refused = True
            return []
        if not isinstance(block.value, list):
            self.problem(block, "plugins", "plugins is a list of Python module names, e.g. [my_behaviours]")
            return []
        names = []
        for index, item in enumerate(block.value):
            path = f"plugins[{index}]"
            if not isinstance(item.value, str):
                self.problem(item, path, f"a plugin is a module name, got {_type_name(item.value)}")
                continue
            try:
                module = import_plugin(item.value, base_dir)
            except Interrupted:  # Ctrl-C or SIGTERM meanwhile, as the command line raises it: the command's
                raise
            except BaseException as err:  # noqa: BLE001 - sys.exit() or Ctrl-C raised by a plugin is its file's fault
                why = str(err) if isinstance(err, PluginNotFound) else f"{type(err).__name__}: {err}".rstrip(": ")
                self.problem(item, path, f"cannot import plugin '{item.value}': {why}")
                continue
            classes = leaf_classes_in(module)
            if not classes:
                self.problem(
                    item,
                    path,
                    f"plugin '{item.value}' declares no behaviours "
                    "(RobotAction/RobotCondition subclasses with a node_type)",
                )
            for cls in classes:
                try:
                    self.registry.add(leaf_type(cls, origin=f"plugin {item.value}"))
                except ValueError as err:
                    self.problem(item, path, f"plugin '{item.value}': {err}")
            names.append(item.value)
        return names

    # ------------------------------------------------------------------ nodes

    def node(self, where: Located, path: str, owner: str) -> NodeSpec | None:
        value = where.value
        if isinstance(value, str):
            return self.bare(where, path)
        if not isinstance(value, dict):
            self.problem(
                where,
                path,
                f"expected a node (a mapping like 'move: {{...}}' or a name like 'stop'), got {_type_name(value)}",
            )
            return None
        if len(value) != 1:
            keys = list(value)
            hint = ""
            if keys and self.registry.get(keys[0]) is not None:
                hint = f"; are the parameters of '{keys[0]}' indented under it?"
            self.problem(where, path, f"a node has exactly one key, its type; found {', '.join(keys) or 'none'}{hint}")
            return None
        type_name, body = next(iter(value.items()))
        key_where = where.keys[type_name]
        node_type = self.registry.get(type_name)
        node_path = f"{path}.{type_name}"
        if node_type is None:
            self.problem(key_where, node_path, self.unknown(type_name))
            return None
        if node_type.category == "reference":
            return self.reference(node_type, body, node_path, key_where, owner)
        short_form = bool(node_type.children_param) and isinstance(body.value, list)
        if short_form:
            args_where: dict[str, Located] = {node_type.children_param: body}
            arg_keys: dict[str, tuple[int, int]] = {node_type.children_param: (body.line, body.column)}
        elif isinstance(body.value, dict):
            args_where, arg_keys = body.value, body.keys
        elif body.value is None and not node_type.needs_parameters:
            args_where, arg_keys = {}, {}
        else:
            self.problem(body, node_path, self.shape_hint(node_type, body))
            return None
        return self.arguments(node_type, args_where, arg_keys, node_path, key_where, owner, short_form)

    def shape_hint(self, node_type: NodeType, body: Located) -> str:
        if node_type.category == "composite":
            return f"{node_type.name} takes a list of children, or {{children: [...], ...}}"
        if node_type.category == "decorator":
            own = [f"{p.name}: ..." for p in node_type.params if p.name != "do"]
            return f"{node_type.name} takes a mapping, e.g. {node_type.name}: {{{', '.join([*own, 'do: NODE'])}}}"
        if body.value is None:
            return f"'{node_type.name}' needs parameters: {self.required_text(node_type)}"
        example = example_arguments(node_type)
        return f"{node_type.name} takes its parameters as a mapping, e.g. {node_type.name}: {{{example}}}"

    def required_text(self, node_type: NodeType) -> str:
        parts = [p.name for p in node_type.params if p.required]
        parts += [" or ".join(group) for group in node_type.exactly_one_of]
        return ", ".join(parts)

    def bare(self, where: Located, path: str) -> NodeSpec | None:
        type_name = where.value
        node_type = self.registry.get(type_name)
        node_path = f"{path}.{type_name}"
        if node_type is None:
            self.problem(where, path, self.unknown(type_name))
            return None
        if node_type.needs_parameters:
            self.problem(
                where,
                node_path,
                f"'{type_name}' needs parameters ({self.required_text(node_type) or 'children'}); "
                f"write it as {type_name}: {{{example_arguments(node_type)}}}",
            )
            return None
        return self.arguments(node_type, {}, {}, node_path, (where.line, where.column), owner="")

    def reference(
        self, node_type: NodeType, body: Located, path: str, key_where: tuple[int, int], owner: str
    ) -> NodeSpec | None:
        if not isinstance(body.value, str):
            self.problem(
                body, path, f"subtree takes the name of a subtree, e.g. subtree: corner; got {_type_name(body.value)}"
            )
            return None
        self.references.append((owner, body.value, body, path))
        return NodeSpec(node_type, {"subtree": body.value}, [], None, path, *key_where)

    def arguments(
        self,
        node_type: NodeType,
        given: dict[str, Located],
        key_at: dict[str, tuple[int, int]],
        path: str,
        key_where: tuple[int, int],
        owner: str,
        short_form: bool = False,
    ) -> NodeSpec:
        """The node's spec, its problems reported; a spec with problems is never used (the mission is refused)."""
        args: dict[str, Any] = {}
        name = None
        known = [p.name for p in node_type.params] + ["name"]
        for key, located in given.items():
            param = node_type.param(key)
            if key == "name":
                if not isinstance(located.value, str) or not located.value.strip():
                    self.problem(located, f"{path}.name", f"name must be text, got {_type_name(located.value)}")
                else:
                    name = self.plain_text(located.value, located, f"{path}.name")
            elif param is None:
                self.problem(
                    key_at[key],
                    f"{path}.{key}",
                    f"unknown parameter '{key}' for {node_type.name}{_suggest(key, known)}; "
                    f"it takes {', '.join(known)}",
                )
            elif param.kind not in ("node", "nodes"):
                args[key] = self.value(param, located, f"{path}.{key}", node_type)
        children: list[NodeSpec] = []
        for param in node_type.params:  # children in declared order: a while's condition before its do
            if param.kind not in ("node", "nodes") or param.name not in given:
                continue
            located = given[param.name]
            child_path = path if short_form else f"{path}.{param.name}"
            if param.kind == "nodes":
                children += self.children(node_type, located, child_path, owner)
            elif self.single(located, child_path, param.name):
                child = self.node(located, child_path, owner)
                children += [child] if child is not None else []
        for param in node_type.params:
            if param.required and param.name not in given:
                self.problem(key_where, path, f"{node_type.name} needs '{param.name}' ({param.doc})")
            elif param.kind not in ("node", "nodes"):
                args.setdefault(param.name, param.default)
        for group in node_type.exactly_one_of:
            present = [g for g in group if g in given]
            if len(present) != 1:
                said = "only one of" if present else "one of"
                self.problem(key_where, path, f"{node_type.name} takes {said} {', '.join(group)}")
        written = tuple(key for key in given if key in args)
        return NodeSpec(node_type, args, children, name, path, *key_where, given=written)

    def single(self, located: Located, path: str, key: str) -> bool:
        if isinstance(located.value, list):
            self.problem(
                located, path, f"{key} takes one node; to do several things, wrap them: {key}: {{sequence: [...]}}"
            )
            return False
        return True

    def children(self, node_type: NodeType, located: Located, path: str, owner: str) -> list[NodeSpec]:
        """The children that are nodes; the problems of the others are reported."""
        if not isinstance(located.value, list):
            self.problem(located, path, f"{node_type.name} takes a list of children, got {_type_name(located.value)}")
            return []
        if not located.value:
            self.problem(located, path, f"{node_type.name} needs at least one child")
        kids = [self.node(item, f"{path}[{i}]", owner) for i, item in enumerate(located.value)]
        return [kid for kid in kids if kid is not None]

    def value(self, param: Param, located: Located, path: str, node_type: NodeType) -> Any:
        value = located.plain
        if isinstance(value, AttributeText):
            value = _from_attribute(param.kind, value)
        kind = param.kind
        what = f"{node_type.name} {param.name}"
        if kind == "bool":
            if not isinstance(value, bool):
                self.problem(located, path, f"{what} must be true or false, got {_type_name(value)}")
                return _INVALID
            return value
        if kind == "string":
            if not isinstance(value, str):
                self.problem(located, path, f"{what} must be text, got {_type_name(value)}")
                return _INVALID
            self.plain_text(value, located, path)
            return value
        if kind == "choice":
            if value not in param.choices:
                self.problem(
                    located,
                    path,
                    f"{what} must be {' or '.join(param.choices)}, "
                    f"got {_type_name(value)}{_suggest(str(value), list(param.choices))}",
                )
                return _INVALID
            return value
        if kind == "tones":
            if not (
                isinstance(value, list)
                and len(value) == 3
                and all(isinstance(t, int) and not isinstance(t, bool) and 1 <= t <= 9 for t in value)
            ):
                self.problem(located, path, f"{what} must be three tones 1..9, as in [5, 7, 9]; got {located.plain!r}")
                return _INVALID
            return list(value)
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or (kind == "int" and not isinstance(value, int))
        ):
            expected = "a whole number" if kind == "int" else "a number"
            self.problem(located, path, f"{what} must be {expected}, got {_type_name(value)}{exponent_hint(value)}")
            return _INVALID
        low, high = param.minimum, param.maximum
        if not math.isfinite(value) or abs(value) > MAX_NUMBER:
            if high is not None:  # the parameter's own range says more than the limit on every number
                unit = f" {param.unit}" if param.unit else ""
                self.problem(located, path, f"{what} must be {param.describe_range()}{unit}, got {value} ({param.doc})")
            else:
                self.problem(located, path, f"{what} must be a finite number of at most {MAX_NUMBER:,}, got {value}")
            return _INVALID
        if (low is not None and value < low) or (high is not None and value > high) or (param.positive and value <= 0):
            unit = f" {param.unit}" if param.unit else ""
            why = f": {param.range_why}" if param.range_why else ""
            self.problem(
                located, path, f"{what} must be {param.describe_range()}{unit}, got {value}{why} ({param.doc})"
            )
            return _INVALID
        return value

    def check_references(self, known: list[str]) -> None:
        graph: dict[str, set[str]] = {}
        for owner, target, where, path in self.references:
            if target not in known:
                listed = f"; the subtrees are {', '.join(known)}" if known else "; this mission defines no subtrees"
                self.problem(where, path, f"unknown subtree '{target}'{_suggest(target, known)}{listed}")
            else:
                graph.setdefault(owner, set()).add(target)
        suspects = _reaching_a_cycle(graph)
        reported: set[str] = set()
        for _owner, target, where, path in self.references:
            if target in suspects and target not in reported and _reaches(graph, target, target):
                reported.add(target)
                self.problem(where, path, f"subtree '{target}' includes itself (directly or through other subtrees)")

    def check_size(self, tree: NodeSpec, subtrees: dict[str, NodeSpec]) -> None:
        """Refuses a tree too deep or too large once its subtrees are expanded (each use is a copy).

        Sizes are worked out once per subtree, without recursion, so a chain of thousands of
        subtrees is measured, and refused, in no time.
        """
        measured: dict[int, tuple[int, int]] = {}  # id(spec) -> (depth, nodes)
        todo: list[tuple[NodeSpec, bool]] = [(tree, False)]
        while todo:
            spec, ready = todo.pop()
            if id(spec) in measured:
                continue
            if spec.type.category == "reference":  # a subtree the reader refused is missing: nothing to measure
                below = [subtrees[spec.args["subtree"]]] if spec.args["subtree"] in subtrees else []
            else:
                below = spec.children
            if not ready:
                todo.append((spec, True))
                todo.extend((child, False) for child in below)  # one measured already is skipped when popped
                continue
            sizes = [measured[id(child)] for child in below]
            if spec.type.category == "reference":
                measured[id(spec)] = sizes[0] if sizes else (0, 0)
            else:
                depth = 1 + max((d for d, _ in sizes), default=0)
                nodes = 1 + sum(n for _, n in sizes)
                measured[id(spec)] = (depth, min(nodes, MAX_TREE_NODES + 1))
        depth, nodes = measured[id(tree)]
        if depth > MAX_TREE_DEPTH:
            crossing, level = tree, 1  # follow the deepest branch to the first node past the limit
            while True:
                while crossing.type.category == "reference" and crossing.args["subtree"] in subtrees:
                    crossing = subtrees[crossing.args["subtree"]]
                if level > MAX_TREE_DEPTH:
                    break
                crossing = max(crossing.children, key=lambda child: measured[id(child)][0])
                level += 1
            self.problem(
                (crossing.line, crossing.column),
                crossing.path,
                f"the tree is {depth} nodes deep with its subtrees expanded, and this node is level "
                f"{MAX_TREE_DEPTH + 1} from the root; at most {MAX_TREE_DEPTH} levels are allowed",
            )
        if nodes > MAX_TREE_NODES:
            self.problem(
                (tree.line, tree.column),
                "tree",
                f"the tree has more than {MAX_TREE_NODES:,} nodes with its subtrees expanded "
                "(each use of a subtree is a copy)",
            )


def _reaching_a_cycle(graph: dict[str, set[str]]) -> set[str]:
    """The names from which a cycle can be reached: what is left once sinks are peeled off, in linear time."""
    users: dict[str, set[str]] = {}
    for owner, targets in graph.items():
        for target in targets:
            users.setdefault(target, set()).add(owner)
    names = set(graph) | set(users)
    left = {name: len(graph.get(name, ())) for name in names}
    sinks = [name for name, count in left.items() if count == 0]
    while sinks:
        name = sinks.pop()
        del left[name]
        for owner in users.get(name, ()):
            left[owner] -= 1
            if left[owner] == 0:
                sinks.append(owner)
    return set(left)


def _reaches(graph: dict[str, set[str]], start: str, goal: str) -> bool:
    seen: set[str] = set()
    todo = list(graph[start])  # a name that may reach a cycle refers to some subtree
    while todo:
        name = todo.pop()
        if name == goal:
            return True
        if name not in seen:
            seen.add(name)
            todo.extend(graph.get(name, ()))
    return False


_DECIMAL = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?|[-+]?(inf|nan)", re.IGNORECASE)


def _from_attribute(kind: str, text: str) -> Any:
    """An XML attribute's text as a value of ``kind``; the text itself when it is not one."""
    word = text.strip()
    if kind == "bool":
        return {"true": True, "false": False, "1": True, "0": False}.get(word.lower(), text)
    if kind == "tones":
        parts = [p.strip() for p in word.split(";")]
        return [int(p) for p in parts] if all(re.fullmatch(r"\d{1,3}", p) for p in parts) else text
    if kind == "int":
        return int(word) if re.fullmatch(r"[-+]?\d{1,40}", word) else text
    if kind == "number":
        if re.fullmatch(r"[-+]?\d{1,40}", word):
            return int(word)
        if (
            re.fullmatch(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?|[-+]?(inf|nan)", word, re.IGNORECASE)
            and len(word) <= 40
        ):
            return float(word)
    return str(text)


def example_arguments(node_type: NodeType) -> str:
    """A short, valid-looking argument list for hints, e.g. ``left: 90``."""
    wanted = [p for p in node_type.params if p.required]
    wanted += [node_type.param(group[0]) for group in node_type.exactly_one_of]  # type: ignore[misc]
    return ", ".join(f"{param.name}: {param.sample()}" for param in wanted)


class _Invalid:
    pass


_INVALID = _Invalid()


class PluginNotFound(ImportError):
    """No ``NAME.py`` (or package ``NAME/``) beside the mission."""


def import_plugin(module_name: str, base_dir: Path) -> Any:
    """Imports the plugin ``module_name`` from the mission's folder, and from nowhere else.

    The plugin is ``base_dir/NAME.py`` (or the package ``base_dir/NAME/``); an installed module
    of that name is never imported in its place. Each file is loaded under a module name of its
    own, made from its path, so two missions whose folders both hold a ``beh.py`` each get their
    own. While it loads, its folder is on ``sys.path``, so it may import files beside it.

    Raises:
        PluginNotFound: there is no such file beside the mission.
        BaseException: whatever the plugin's code raised while it was imported.
    """
    if not module_name.isidentifier():
        raise PluginNotFound(f"'{module_name}' is not a module name: name a file beside the mission, without '.py'")
    folder = base_dir.resolve()
    file, package = folder / f"{module_name}.py", folder / module_name / "__init__.py"
    if not file.is_file():
        if not package.is_file():
            raise PluginNotFound(
                f"no plugin '{module_name}': plugins are Python files beside the mission, "
                f"and there is no {module_name}.py in {folder}"
            )
        file = package
    unique = f"autonomy_plugin_{hashlib.sha256(str(file).encode()).hexdigest()[:12]}_{module_name}"
    if unique in sys.modules:
        return sys.modules[unique]
    spec = importlib.util.spec_from_file_location(unique, file)  # a package's __init__.py makes a package
    if spec is None or spec.loader is None:  # pragma: no mutate - never for a .py file; for the type checker
        raise PluginNotFound(f"cannot load {file} as Python")  # pragma: no mutate
    module = importlib.util.module_from_spec(spec)
    sys.modules[unique] = module
    path = str(folder)
    added = path not in sys.path
    if added:
        sys.path.insert(0, path)
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[unique]
        raise
    finally:
        if added:
            sys.path.remove(path)
    return module


def validate_text(
    text: str,
    source: str = "<mission>",
    base_dir: Path | None = None,
    registry: Registry | None = None,
    check_world: bool = True,
    refuse_plugins: str | None = None,
) -> MissionSpec:
    """Validates a mission given as text.

    Args:
        text: The mission file's text.
        source: Its name, for problems.
        base_dir: Where its plugins and world file are looked for (default: the working folder).
        registry: The node types known besides its plugins' (default: the built-in ones).
        check_world: Whether to load the world it names; grading does not (it runs in the
            exercise's world, and must not read files a submission points at).
        refuse_plugins: When given, a list of Python plugins (YAML's ``plugins:``, XML's
            ``_plugins``) is a problem with this message, and none of it is imported.

    Raises:
        MissionInvalid: with every problem found.
    """
    if len(text) > MAX_FILE_BYTES or len(text.encode("utf-8", "surrogatepass")) > MAX_FILE_BYTES:
        # refused before anything reads it: a text of megabytes would take seconds to parse
        size = len(text.encode("utf-8", "surrogatepass"))
        why = f"the text is {size:,} bytes long; a mission file is at most {MAX_FILE_BYTES:,}"
        raise MissionInvalid([Problem(source, 1, 1, "", why)])
    xml = source.lower().endswith(".xml") or text.lstrip("\ufeff \t\r\n").startswith("<")
    root, errors = parse_xml(text) if xml else parse(text)
    problems = [Problem(source, e.line, e.column, "", e.message) for e in errors]
    validator = _Validator(source, (registry or BUILTINS).copy(), check_world, refuse_plugins)
    spec = validator.mission(root, base_dir or Path.cwd()) if root is not None else None
    problems += validator.problems
    if problems or spec is None:
        # The reader and the validator each say why they give nothing: the fallback is never seen.
        raise MissionInvalid(problems or [Problem(source, 1, 1, "", "not a mission")])  # pragma: no mutate
    spec.sha256 = hashlib.sha256(text.encode("utf-8")).hexdigest()
    if not xml and isinstance(root.value, dict) and "tests" in root.value:  # a run ignores them; a rewrite keeps them
        spec.tests_text = top_level_block(text, root, "tests")
    return spec


def top_level_block(text: str, root: Located, key: str) -> str:
    """The lines of ``text`` that hold the top-level ``key`` and its value, as written (up to the next key).

    The comment lines right above the key are its, too.
    """
    lines = text.splitlines()
    first = root.keys[key][0]
    after = [line for line, _ in root.keys.values() if line > first]
    while first > 1 and lines[first - 2].startswith("#"):
        first -= 1
    block = lines[first - 1 : (min(after) - 1) if after else len(lines)]
    while block and not block[-1].strip():
        block.pop()
    return "\n".join(block) + "\n"


def validate_file(path: str | Path, check_world: bool = True) -> MissionSpec:
    """Reads and validates a mission file.

    Raises:
        MissionInvalid: the file cannot be read, or has problems (all of them listed).
    """
    path = Path(path)
    try:
        text = read_text(path)
    except UnreadableFile as err:
        raise MissionInvalid(
            [Problem(str(path), err.line, err.column, "", f"cannot read the file: {err.reason}")]
        ) from None
    return validate_text(text, str(path), path.parent, check_world=check_world)

"""A mission as blocks: Blockly's JSON of a workspace, and back to the mission's text, losing nothing.

The blocks are made from the node registry, never written one by one: every node type is a block
with a field for each parameter (a number with its range, a choice as a dropdown, a flag as a
checkbox), a composite takes statements, a decorator wraps its child, and a subtree is a named
definition with blocks that call it. A parameter that may be left out and has no default (``move``'s
``distance_mm``, ``repeat``'s ``times``) gives its node a second block, with the phrase and without;
of a group of which exactly one is given (``turn``'s ``left`` and ``right``), each is a block of its
own. What a block says comes from one catalogue of words (``words/en.yaml``), which a teacher may
translate.

Both ways go through one canonical text (:func:`canonical_text`): the mission written with its
nodes by name, the keys in the registry's order, a leaf's parameters on one line. From a mission's
text to blocks and back gives that text, and the same tree. What the canonical text changes:

- an alias becomes its node's name (``fallback`` is written ``selector``);
- a parameter is written when the file gave it, or when its value is not the default;
- ``tick_hz`` is written when it is not 20; a whole number written ``1.0`` is written ``1``;
- a comment stands on its own line before the node it stood before or beside (one beside a node's
  parameter, before that node; one beside a key whose node is below it, before that node); comments
  before or beside the top-level keys other than ``subtrees`` and ``tree``, or after the last node,
  go to the top of the file; an XML mission's comments are not kept;
- keys, indentation and quoting are as the canonical writer puts them.
"""

from __future__ import annotations

import bisect
import contextlib
import itertools
import json
import re
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from autonomy.behaviours import Param
from autonomy.mission.registry import NodeType, Registry
from autonomy.mission.validate import DEFAULT_TICK_HZ, MissionInvalid, MissionSpec, NodeSpec, validate_text
from autonomy.source import Problem, finite_number

#: The mission's block, and a definition of named steps (a subtree): no node type's name has a ``@``.
MISSION_BLOCK = "@mission"
DEFINE_BLOCK = "@define"
#: Joins a node's name and the optional parameters its block has: ``move+distance_mm``.
VARIANT_JOIN = "+"
#: The colour of each category's blocks: dark enough for their white words (at least 6:1, WCAG AA asks 4.5:1).
COLOURS = {
    "composite": "#2f6b34",
    "decorator": "#6b3fa0",
    "action": "#2b5f91",
    "condition": "#7a5a00",
    "reference": "#8c3a5e",
}
MISSION_COLOUR = "#7a4424"
#: What the nested chains of a large mission need of Python's recursion limit to be read and written as JSON.
_DEEP_JSON_LIMIT = 20_000
_deep_json_lock = threading.Lock()
#: What YAML takes for the end of a line: a comment's text is cut at each (a comment is never more than a comment).
LINE_BREAKS = re.compile("\r\n|[\r\n\x85\u2028\u2029]")


# --------------------------------------------------------------------------- the words


@dataclass(frozen=True)
class Words:
    """What the blocks say (see ``words/en.yaml``)."""

    mission: str
    define: str
    nodes: dict[str, str]
    params: dict[str, str]
    choices: dict[str, str]
    units: dict[str, str]


def load_words(path: str | Path | None = None) -> Words:
    """The catalogue of words at ``path`` (default: the English one shipped).

    Raises:
        MissionInvalid: the file cannot be read, or is not a catalogue (FILE:LINE:COL).
    """
    if path is None:
        text, label = resources.files("autonomy.mission").joinpath("words/en.yaml").read_text("utf-8"), "en.yaml"
    else:
        label = str(path)
        try:
            text = Path(path).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as err:
            raise MissionInvalid([Problem(label, 1, 1, "", f"cannot read the words: {err}")]) from None
    return _words(text, label)


@lru_cache(maxsize=8)
def _words(text: str, label: str) -> Words:
    from autonomy.source import parse

    root, errors = parse(text)
    if errors or root is None or not isinstance(root.value, dict):
        first = errors[0] if errors else None
        where = (first.line, first.column) if first else (1, 1)
        raise MissionInvalid([Problem(label, *where, "", first.message if first else "the words are a mapping")])
    doc = root.value
    problems = []

    def table(key: str) -> dict[str, str]:
        found = doc.get(key)
        if found is None:
            return {}
        if not isinstance(found.value, dict) or not all(isinstance(v.value, str) for v in found.value.values()):
            problems.append(Problem(label, found.line, found.column, key, f"{key} maps names to words (text)"))
            return {}
        return {k: v.value for k, v in found.value.items()}

    def sentence(key: str, default: str) -> str:
        found = doc.get(key)
        if found is not None and not isinstance(found.value, str):
            problems.append(Problem(label, found.line, found.column, key, f"{key} is a sentence (text)"))
        return found.value if found is not None and isinstance(found.value, str) else default

    words = Words(
        sentence("mission", "mission %name in the world %world (%tick_hz ticks a second)"),
        sentence("define", "the steps called %name are"),
        table("nodes"),
        table("params"),
        table("choices"),
        table("units"),
    )
    if problems:
        raise MissionInvalid(problems)
    return words


# --------------------------------------------------------------------------- the blocks


def free_params(node_type: NodeType) -> tuple[Param, ...]:
    """The parameters a node may leave out that have no default: each makes a block with it and one without."""
    return tuple(
        p for p in node_type.params if p.kind not in ("node", "nodes") and not p.required and p.default is None
    )


def variants(node_type: NodeType) -> list[tuple[str, ...]]:
    """Each set of free parameters a block of this node has (one of each ``exactly_one_of`` group)."""
    free = [p.name for p in free_params(node_type)]
    grouped = {name for group in node_type.exactly_one_of for name in group}
    loose = [name for name in free if name not in grouped]
    groups = [tuple(name for name in group if name in free) for group in node_type.exactly_one_of]
    found = []
    for picked in itertools.product(*[g for g in groups if g]):
        for size in range(len(loose) + 1):
            for chosen in itertools.combinations(loose, size):
                names = set(picked) | set(chosen)
                found.append(tuple(name for name in free if name in names))
    return sorted(found, key=lambda v: (len(v), [free.index(n) for n in v]))


def block_type(node_type: NodeType, chosen: tuple[str, ...]) -> str:
    """The block's type name: the node's name, and its free parameters (``move+distance_mm``)."""
    return VARIANT_JOIN.join((node_type.name, *chosen))


def _unit(param: Param, words: Words) -> str:
    return words.units.get(param.unit, param.unit)


def _message(sentence: str, names: list[str]) -> tuple[str, list[str]]:
    """A Blockly message from words with ``%name`` places: ``%N`` for each name it says, and the names in order."""
    said: list[str] = []

    def place(found: re.Match[str]) -> str:
        name = found[1]
        if name in names and name not in said:
            said.append(name)
            return f"%{len(said)}"
        return found[0].replace("%", "%%")

    text = re.sub(r"%([A-Za-z_][A-Za-z0-9_]*)", place, sentence.replace("%%", "\0"))
    return text.replace("\0", "%%"), said


def _field(param: Param, words: Words) -> list[dict[str, Any]]:
    """The Blockly fields a parameter is shown with."""
    if param.kind == "tones":
        default = list(param.default or (5, 7, 9))
        return [
            {
                "type": "field_number",
                "name": f"{param.name}.{i}",
                "value": default[i],
                "min": 1,
                "max": 9,
                "precision": 1,
            }
            for i in range(3)
        ]
    if param.kind == "bool":
        return [{"type": "field_checkbox", "name": param.name, "checked": bool(param.default)}]
    if param.kind == "choice":
        options = [[words.choices.get(choice, choice), choice] for choice in param.choices]
        return [{"type": "field_dropdown", "name": param.name, "options": options}]
    if param.kind in ("int", "number"):
        shown: dict[str, Any] = {"type": "field_number", "name": param.name}
        value = param.default if param.default is not None else param.example
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            value = param.minimum if param.minimum is not None and param.minimum > 0 else 1
        shown["value"] = value
        if param.minimum is not None:
            shown["min"] = param.minimum
        elif param.positive:
            shown["min"] = 0
        if param.maximum is not None:
            shown["max"] = param.maximum
        if param.kind == "int":
            shown["precision"] = 1
        return [shown]
    return [{"type": "field_input", "name": param.name, "text": "" if param.default is None else str(param.default)}]


def _sentence(node_type: NodeType, chosen: tuple[str, ...], words: Words) -> tuple[str, list[str]]:
    """What a block of this node (with ``chosen`` free parameters) says, and the fields' parameters in order."""
    fields = [
        p
        for p in node_type.params
        if p.kind not in ("node", "nodes") and (p.required or p.default is not None or p.name in chosen)
    ]
    form = block_type(node_type, chosen)
    if form in words.nodes:  # words of this form of the node: "repeat %times times", not "repeat forever"
        message, said = _message(words.nodes[form], [p.name for p in fields])
    else:
        said_words = words.nodes.get(node_type.name, node_type.name.replace("_", " "))
        message, said = _message(said_words, [p.name for p in fields if p.name not in chosen])
    parts = [message]
    for param in fields:
        if param.name in said:
            continue
        phrase = words.params.get(f"{node_type.name}.{param.name}")
        if phrase is None:
            unit = _unit(param, words)
            phrase = f"{param.name.replace('_', ' ')} %{param.name}" + (f" {unit}" if unit else "")
        more, extra = _message(phrase, [param.name])
        if not extra:  # the words forgot the value: it is said after them
            more, extra = f"{more} %1", [param.name]
        offset = len(said)
        parts.append(re.sub(r"%(\d+)", lambda m, offset=offset: f"%{int(m[1]) + offset}", more))
        said += extra
    return " ".join(part for part in parts if part), said


def _renumber(message: str, names: list[str], params: dict[str, Param]) -> str:
    """A message whose ``%N`` count parameters, counting Blockly's fields instead (a tones parameter is three)."""
    starts, at = [], 1
    for name in names:
        starts.append(at)
        at += 3 if params[name].kind == "tones" else 1

    def place(found: re.Match[str]) -> str:
        index = int(found[1]) - 1
        start = starts[index]
        return f"%{start}" if params[names[index]].kind != "tones" else f"%{start} %{start + 1} %{start + 2}"

    return re.sub(r"(?<!%)%(\d+)", place, message)


def block_definitions(registry: Registry, words: Words | None = None) -> list[dict[str, Any]]:
    """Blockly's JSON definitions of every block: the mission's, a definition of steps, and each node's forms.

    Each block's tooltip is the node's line of doc, as ``autonomy behaviours`` and docs/missions.md say it.
    """
    words = words or load_words()
    mission_message, mission_fields = _message(words.mission, ["name", "world", "tick_hz"])
    mission_params = {
        "name": Param("name", "string", "the mission's name"),
        "world": Param("world", "string", "the world"),
        "tick_hz": Param("tick_hz", "number", "ticks a second", default=DEFAULT_TICK_HZ, minimum=1, maximum=200),
    }
    for name in mission_params:
        if name not in mission_fields:
            mission_message += f" {name.replace('_', ' ')} %{len(mission_fields) + 1}"
            mission_fields.append(name)
    defined_message, _ = _message(words.define, ["name"])
    if "%1" not in defined_message:
        defined_message += " %1"
    blocks: list[dict[str, Any]] = [
        {
            "type": MISSION_BLOCK,
            "message0": mission_message,
            "args0": [_field(mission_params[n], words)[0] for n in mission_fields],
            "message1": "%1",
            "args1": [{"type": "input_statement", "name": "tree"}],
            "colour": MISSION_COLOUR,
            "tooltip": "The mission: its name, its world, how often its tree is ticked, and its tree.",
        },
        {
            "type": DEFINE_BLOCK,
            "message0": defined_message,
            "args0": [{"type": "field_input", "name": "name", "text": "steps"}],
            "message1": "%1",
            "args1": [{"type": "input_statement", "name": "body"}],
            "colour": COLOURS["reference"],
            "tooltip": "Named steps (a subtree): a block 'do the steps called ...' does them.",
        },
    ]
    for node_type in registry:
        params = {p.name: p for p in node_type.params}
        for chosen in variants(node_type):
            message, names = _sentence(node_type, chosen, words)
            definition: dict[str, Any] = {
                "type": block_type(node_type, chosen),
                "message0": _renumber(message, names, params),
                "args0": [f for name in names for f in _field(params[name], words)],
                "previousStatement": None,
                "nextStatement": None,
                "colour": COLOURS.get(node_type.category, "#555555"),
                "tooltip": node_type.doc,
            }
            inputs = [p for p in node_type.params if p.kind in ("node", "nodes")]
            for index, param in enumerate(inputs, start=1):
                phrase = words.params.get(f"{node_type.name}.{param.name}", "" if param.kind == "nodes" else param.name)
                definition[f"message{index}"] = f"{phrase.replace('%', '%%')} %1".strip()
                definition[f"args{index}"] = [{"type": "input_statement", "name": param.name}]
            blocks.append(definition)
    return blocks


def toolbox(registry: Registry, allowed: tuple[str, ...] | None = None) -> dict[str, Any]:
    """Blockly's toolbox: a category per kind of node, each node's forms in it (``allowed``: only those nodes)."""
    categories = []
    names = {"composite": "Order", "decorator": "Change", "action": "Do", "condition": "Check", "reference": "Steps"}
    for category, title in names.items():
        steps = category == "reference" and (allowed is None or "subtree" in allowed)
        contents = [{"kind": "block", "type": MISSION_BLOCK}] if category == "reference" else []
        contents += [{"kind": "block", "type": DEFINE_BLOCK}] if steps else []
        for node_type in registry:
            if node_type.category != category or (allowed is not None and node_type.name not in allowed):
                continue
            contents += [{"kind": "block", "type": block_type(node_type, chosen)} for chosen in variants(node_type)]
        if contents:
            categories.append({"kind": "category", "name": title, "colour": COLOURS[category], "contents": contents})
    return {"kind": "categoryToolbox", "contents": categories}


# --------------------------------------------------------------------------- the outline both ways share


@dataclass
class Outline:
    """A node as the canonical text writes it.

    Attributes:
        type: The node type.
        params: The parameters written, in the registry's order (children apart).
        name: Its ``name:``, if any.
        children: Its children: a composite's in order; a decorator's, one per node parameter.
        comments: The comment lines before it.
        where: Where it came from, for problems: (line, column) in its source.
    """

    type: NodeType
    params: dict[str, Any]
    name: str | None = None
    children: list[Outline] = field(default_factory=list)
    comments: list[str] = field(default_factory=list)
    where: tuple[int, int] = (1, 1)


@dataclass
class MissionOutline:
    """A mission as the canonical text writes it."""

    name: str
    description: str = ""
    tick_hz: float = DEFAULT_TICK_HZ
    world: str | None = None
    plugins: list[str] = field(default_factory=list)
    subtrees: dict[str, Outline] = field(default_factory=dict)
    tree: Outline | None = None
    comments: list[str] = field(default_factory=list)
    tests: str = ""


def _whole(value: Any) -> bool:
    """Whether ``value`` is a whole number (not a flag): 3, or 3.0 as a page may send it."""
    return (isinstance(value, int) and not isinstance(value, bool)) or (isinstance(value, float) and value.is_integer())


def _written(value: Any, param: Param) -> Any:
    if param.kind == "tones":
        return [int(v) for v in value]
    if param.kind == "number" and isinstance(value, float) and value.is_integer() and abs(value) < 2**53:
        return int(value)
    return value


def _outline(spec: NodeSpec, comments: dict[int, list[str]]) -> Outline:
    params = {}
    for param in spec.type.params:
        if param.kind in ("node", "nodes"):
            continue
        value = spec.args.get(param.name)
        if value is None:
            continue
        if param.name in spec.given or value != param.default:
            params[param.name] = _written(value, param)
    return Outline(
        spec.type,
        params,
        spec.name,
        [_outline(child, comments) for child in spec.children],
        comments.get(id(spec), []),
        (spec.line, spec.column),
    )


def outline_of(spec: MissionSpec, text: str = "") -> MissionOutline:
    """The mission's outline, the comments of its ``text`` attached to the nodes they stand before or beside."""
    nodes = list(_walk(spec))
    if spec.tests_text and spec.tests_text in text:  # its comments are the tests', kept with them: blank lines here
        at = text.index(spec.tests_text)
        text = text[:at] + "\n" * spec.tests_text.count("\n") + text[at + len(spec.tests_text) :]
    attached, top = _attach(text, nodes)
    return MissionOutline(
        spec.name,
        spec.description,
        spec.tick_hz,
        spec.world,
        list(spec.plugins),
        {name: _outline(root, attached) for name, root in spec.subtrees.items()},
        _outline(spec.tree, attached),
        top,
        spec.tests_text,
    )


def _walk(spec: MissionSpec) -> Iterator[NodeSpec]:
    stack = [spec.tree, *reversed(spec.subtrees.values())]
    while stack:
        node = stack.pop()
        yield node
        stack.extend(reversed(node.children))


_TOP_KEY = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)\s*:")


def _tokens(text: str, loader: Any) -> list[Any]:
    return list(yaml.scan(text, Loader=loader))


def comments_in(text: str) -> list[tuple[int, int, str, bool]]:
    """Every comment in a YAML text: (line, column, its words, whether it stands alone on its line); 1-based.

    Empty when the text cannot be scanned (a text with problems stays text), and for an XML mission
    (its comments are XML's, and are not kept).
    """
    if text.lstrip("\ufeff \t\r\n").startswith("<"):
        return []
    try:
        tokens = _tokens(text, getattr(yaml, "CSafeLoader", yaml.SafeLoader))
    except yaml.YAMLError:  # libyaml's scanner takes fewer files than PyYAML's: that one, as the file was read
        try:
            tokens = _tokens(text, yaml.SafeLoader)
        except yaml.YAMLError:
            return []
    covered: dict[int, list[tuple[int, int]]] = {}
    for token in tokens:
        start, end = token.start_mark, token.end_mark
        for line in range(start.line, end.line + 1):
            begin = start.column if line == start.line else 0
            stop = end.column if line == end.line else 10**9
            covered.setdefault(line, []).append((begin, stop))
    found = []
    for number, line in enumerate(text.splitlines()):
        at = line.find("#")
        while at >= 0:
            inside = any(begin <= at < stop for begin, stop in covered.get(number, ()))
            if not inside and (at == 0 or line[at - 1] in " \t\ufeff"):
                words = line[at + 1 :]
                alone = not line[:at].strip(" \t\ufeff")
                found.append((number + 1, at + 1, words[1:] if words.startswith(" ") else words, alone))
                break
            at = line.find("#", at + 1)
    return found


def _attach(text: str, nodes: list[NodeSpec]) -> tuple[dict[int, list[str]], list[str]]:
    """Each node's comments (by the node's ``id``), and the mission's own (the top of the file).

    A comment on its own line goes with the node after it; one beside a node, with that node; one
    beside a key whose value is below it (``tree:``, ``do:``, ``-``), with the node below; one
    beside a parameter, with the node the parameter is of. Those of the top-level keys but
    ``tree`` and ``subtrees``, or after the last node, are the mission's.
    """
    found = comments_in(text)
    if not found:
        return {}, []
    lines = text.splitlines()
    order = sorted(nodes, key=lambda n: (n.line, n.column))
    start_lines = [n.line for n in order]
    following = [""] * len(lines)  # each line's next line that is neither blank nor a comment
    after = ""
    for index in range(len(lines) - 1, -1, -1):
        following[index] = after
        stripped = lines[index].strip(" \t\ufeff")
        if stripped and not stripped.startswith("#"):
            after = lines[index]
    attached: dict[int, list[str]] = {}
    top: list[str] = []

    def node_after(line: int) -> NodeSpec | None:
        index = bisect.bisect_right(start_lines, line)
        return order[index] if index < len(order) else None

    for line, column, words, alone in found:
        target: NodeSpec | None = None
        if alone:
            key = _TOP_KEY.match(following[line - 1])
            if not (key and key_is_top(key[1]) and key[1] not in ("tree", "subtrees")):
                target = node_after(line)
        else:
            index = bisect.bisect_left(start_lines, line)
            code = lines[line - 1][: column - 1].rstrip(" \t")
            key = _TOP_KEY.match(code.lstrip("\ufeff"))
            if index < len(order) and start_lines[index] == line:
                target = order[index]  # beside a node (the outermost that starts there)
            elif key and key_is_top(key[1]) and key[1] not in ("tree", "subtrees"):
                target = None  # beside mission:, world:...: the mission's
            elif code.endswith((":", "-")):
                target = node_after(line)  # beside a key whose node is below
            elif index > 0:
                target = order[index - 1]  # beside a parameter: its node's
        if target is None:
            top.append(words)
        else:
            attached.setdefault(id(target), []).append(words)
    return attached, top


def _tests_block(text: str) -> bool:
    """Whether ``text`` is a ``tests:`` block alone: comments, its key, then lines under it (indented or blank)."""
    lines = text.split("\n")
    while lines and lines[0].startswith("#"):
        lines.pop(0)
    return (
        bool(lines) and lines[0].startswith("tests:") and all(not line.strip() or line[0] in " #" for line in lines[1:])
    )


def key_is_top(key: str) -> bool:
    """Whether ``key`` is one of a mission file's top-level keys."""
    return key in ("mission", "description", "tick_hz", "world", "subtrees", "tree", "plugins", "tests")


# --------------------------------------------------------------------------- the canonical text


#: PyYAML's own writer, never libyaml's: the canonical text is the same on every machine, with libyaml or not.
_BaseDumper: Any = yaml.SafeDumper


class _Dumper(_BaseDumper):
    pass


class _TextDumper(_BaseDumper):
    """Writes a long text folded over lines (``description: >``), as a person would."""


def _folded(dumper: Any, value: str) -> yaml.ScalarNode:
    style = ">" if len(value) > 80 and value == value.strip(" ") and "\n\n" not in value else None
    if style and any(line[:1] in (" ", "\t") for line in value.split("\n")):
        style = None  # an indented line is kept as it is only quoted
    return dumper.represent_scalar("tag:yaml.org,2002:str", value, style=style)


_TextDumper.add_representer(str, _folded)


def _scalar(value: Any) -> str:
    """A value as YAML writes it in a flow (``[5, 7, 9]``, ``'a: b'``), on one line."""
    return _flow(json.dumps(value, ensure_ascii=False))


@lru_cache(maxsize=4096)
def _flow(value_json: str) -> str:
    """:func:`_scalar` of a value given as JSON (the same values recur: each is written once)."""
    value = json.loads(value_json)
    text = yaml.dump(value, Dumper=_Dumper, default_flow_style=True, width=10**9, allow_unicode=True, sort_keys=False)
    return text.removesuffix("\n...\n").removesuffix("\n")


class _Writer:
    """Writes an outline's canonical text a line at a time, noting the line each node starts on."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.starts: list[tuple[int, Outline]] = []

    def comments(self, comments: list[str], indent: int) -> None:
        lines = [line for comment in comments for line in LINE_BREAKS.split(comment)]
        self.lines += [f"{' ' * indent}#{' ' + c if c else ''}" for c in lines]

    def node(self, node: Outline, indent: int, lead: str = "") -> None:
        """The node as a block at ``indent``: ``lead`` (``key: `` or ``- ``) before its first line."""
        pad = " " * indent
        self.starts.append((len(self.lines) + 1, node))
        head: dict[str, Any] = {} if node.name is None else {"name": node.name}
        head.update(node.params)
        node_type, key = node.type, _scalar(node.type.name)
        child_params = [p for p in node_type.params if p.kind in ("node", "nodes")]
        if node_type.category == "reference":
            self.lines.append(f"{pad}{lead}{key}: {_scalar(node.params['subtree'])}")
            return
        if not child_params:
            bare = not head and not node_type.needs_parameters
            self.lines.append(f"{pad}{lead}{key}" if bare else f"{pad}{lead}{key}: {_scalar(head)}")
            return
        inner = " " * (indent + len(lead) + 2)
        self.lines.append(f"{pad}{lead}{key}:")
        self.lines += [f"{inner}{_scalar(k)}: {_scalar(v)}" for k, v in head.items()]
        if node_type.category == "composite":
            if head:
                self.lines.append(f"{inner}{child_params[0].name}:")
            for child in node.children:
                self.item(child, len(inner) + (2 if head else 0))
            return
        for param, child in zip(child_params, node.children, strict=False):
            self.value(param.name, child, len(inner))

    def item(self, node: Outline, indent: int) -> None:
        """The node as an item of a list at ``indent``."""
        self.comments(node.comments, indent)
        self.node(node, indent, "- ")

    def value(self, key: str, node: Outline, indent: int) -> None:
        """``key:`` and the node as its value, at ``indent``: on the key's line when it is a bare name."""
        bare = not node.comments and not node.children and not node.params and node.name is None
        if bare and not node.type.needs_parameters and node.type.category != "reference":
            self.starts.append((len(self.lines) + 1, node))
            self.lines.append(f"{' ' * indent}{key}: {_scalar(node.type.name)}")
            return
        self.lines.append(f"{' ' * indent}{key}:")
        self.comments(node.comments, indent + 2)
        self.node(node, indent + 2)


def _write(outline: MissionOutline) -> _Writer:
    writer = _Writer()
    writer.comments(outline.comments, 0)
    lines = writer.lines
    lines.append(f"mission: {_scalar(outline.name)}")
    if outline.description:
        lines += _description(outline.description)
    if float(outline.tick_hz) != DEFAULT_TICK_HZ:
        hz = int(outline.tick_hz) if float(outline.tick_hz).is_integer() else outline.tick_hz
        lines.append(f"tick_hz: {_scalar(hz)}")
    if outline.world:
        lines.append(f"world: {_scalar(outline.world)}")
    if outline.plugins:
        lines.append(f"plugins: {_scalar(list(outline.plugins))}")
    if outline.subtrees:
        lines.append("subtrees:")
        for name, root in outline.subtrees.items():
            writer.value(_scalar(name), root, 2)
    if outline.tree is not None:
        writer.value("tree", outline.tree, 0)
    if outline.tests:  # the mission's scenarios, as they were written
        lines += outline.tests.rstrip("\n").split("\n")
    return writer


def _description(text: str) -> list[str]:
    """The ``description:`` lines: folded over lines when that reads back the same, else quoted."""
    for dumper in (_TextDumper, _Dumper):
        written = yaml.dump({"description": text}, Dumper=dumper, width=100, allow_unicode=True, sort_keys=False)
        try:
            if yaml.load(written, Loader=yaml.SafeLoader) == {"description": text}:  # noqa: S506 - the safe loader
                return written.splitlines()
        except yaml.YAMLError:
            continue
    return [f"description: {_scalar(text)}"]


def outline_text(outline: MissionOutline) -> str:
    """The canonical text of a mission's outline."""
    return "\n".join(_write(outline).lines) + "\n"


def canonical_text(spec: MissionSpec, text: str = "") -> str:
    """The canonical text (see the module's doc) of the mission ``spec``, read from ``text``: what blocks give back."""
    return outline_text(outline_of(spec, text))


# --------------------------------------------------------------------------- to blocks


@contextlib.contextmanager
def _deep_json() -> Iterator[None]:
    """Room for JSON nested as deep as a long chain of blocks (each ``next`` is two levels)."""
    with _deep_json_lock:
        before = sys.getrecursionlimit()
        sys.setrecursionlimit(max(before, _DEEP_JSON_LIMIT))
        try:
            yield
        finally:
            sys.setrecursionlimit(before)


def _field_values(node: Outline, chosen: tuple[str, ...]) -> dict[str, Any]:
    values: dict[str, Any] = {}
    for param in node.type.params:
        if param.kind in ("node", "nodes"):
            continue
        if not (param.required or param.default is not None or param.name in chosen):
            continue
        value = node.params.get(param.name, param.default)
        if param.kind == "tones":
            for i, tone in enumerate(value):
                values[f"{param.name}.{i}"] = tone
        elif param.kind == "bool":
            values[param.name] = "TRUE" if value else "FALSE"
        else:
            values[param.name] = value
    return values


def _state(node: Outline, ids: Iterator[str], placed: dict[str, tuple[int, int]]) -> dict[str, Any]:
    chosen = tuple(p.name for p in free_params(node.type) if p.name in node.params)
    state: dict[str, Any] = {"type": block_type(node.type, chosen), "id": next(ids)}
    placed[state["id"]] = node.where
    if node.type.category == "reference":
        state["type"] = node.type.name
    values = _field_values(node, chosen)
    if values:
        state["fields"] = values
    data: dict[str, Any] = {}
    if node.name is not None:
        data["name"] = node.name
    given = [p.name for p in node.type.params if p.default is not None and p.name in node.params]
    if given:
        data["given"] = given
    if data:
        state["data"] = json.dumps(data, ensure_ascii=False)
    if node.comments:
        state["icons"] = {"comment": {"text": "\n".join(node.comments), "pinned": False, "height": 80, "width": 240}}
    inputs = {}
    child_params = [p for p in node.type.params if p.kind in ("node", "nodes")]
    if node.type.category == "composite":
        chain = _chain(node.children, ids, placed)
        if chain is not None:
            inputs[child_params[0].name] = {"block": chain}
    else:
        for param, child in zip(child_params, node.children, strict=False):
            inputs[param.name] = {"block": _state(child, ids, placed)}
    if inputs:
        state["inputs"] = inputs
    return state


def _chain(nodes: list[Outline], ids: Iterator[str], placed: dict[str, tuple[int, int]]) -> dict[str, Any] | None:
    """Blocks one after another: each holds the next (``"next": {"block": ...}``)."""
    states = [_state(node, ids, placed) for node in nodes]
    for before, after in zip(states, states[1:], strict=False):
        before["next"] = {"block": after}
    return states[0] if states else None


def outline_workspace(outline: MissionOutline, placed: dict[str, tuple[int, int]] | None = None) -> dict[str, Any]:
    """Blockly's JSON of a workspace holding the mission's blocks (the ids numbered in order: the same each time).

    Args:
        outline: The mission.
        placed: Filled, when given, with where each block's node was written: its id -> (line, column).
    """
    placed = {} if placed is None else placed
    ids = (f"b{n}" for n in itertools.count(1))
    mission: dict[str, Any] = {
        "type": MISSION_BLOCK,
        "id": next(ids),
        "x": 20,
        "y": 20,
        "fields": {
            "name": outline.name,
            "world": outline.world or "",
            "tick_hz": outline.tick_hz,
        },
    }
    kept = {"description": outline.description, "plugins": outline.plugins, "tests": outline.tests}  # kept with it
    if outline.description or outline.plugins or outline.tests:
        mission["data"] = json.dumps({k: v for k, v in kept.items() if v}, ensure_ascii=False)
    if outline.comments:
        text = "\n".join(outline.comments)
        mission["icons"] = {"comment": {"text": text, "pinned": False, "height": 80, "width": 240}}
    if outline.tree is not None:
        mission["inputs"] = {"tree": {"block": _state(outline.tree, ids, placed)}}
    blocks = [mission]
    for index, (name, root) in enumerate(outline.subtrees.items()):
        defined = {"type": DEFINE_BLOCK, "id": next(ids), "x": 20, "y": 220 + 200 * index, "fields": {"name": name}}
        defined["inputs"] = {"body": {"block": _state(root, ids, placed)}}
        blocks.append(defined)
    return {"blocks": {"languageVersion": 0, "blocks": blocks}}


def to_workspace(spec: MissionSpec, text: str = "", placed: dict[str, tuple[int, int]] | None = None) -> dict[str, Any]:
    """Blockly's JSON of a workspace that holds the mission ``spec``, and the comments of ``text``, its file's text.

    ``placed``, when given, is filled with where each block's node is in ``text``: its id -> (line, column).
    """
    return outline_workspace(outline_of(spec, text), placed)


def block_at_line(placed: dict[str, tuple[int, int]], line: int) -> str | None:
    """The block of the node a line of the text is part of: the last node begun on or before it (None: none is)."""
    begun = [(where, block) for block, where in placed.items() if where[0] <= line]
    return max(begun)[1] if begun else None


def read_json(text: str | bytes) -> Any:
    """JSON as deep as a workspace's chains of blocks nest (past that: RecursionError; not JSON: ValueError)."""
    with _deep_json():
        return json.loads(text)


def workspace_json(workspace: dict[str, Any]) -> str:
    """The workspace as JSON text on one line, however long its chains of blocks.

    Chains nest deep: indented, the text would grow with the square of their length.
    """
    with _deep_json():
        return json.dumps(workspace, ensure_ascii=False, separators=(",", ":")) + "\n"


# --------------------------------------------------------------------------- back from blocks


class _Reader:
    """Reads a workspace's blocks into an outline, each problem at the line and column of its block."""

    def __init__(self, text: str, source: str, registry: Registry) -> None:
        self.text, self.source, self.registry = text, source, registry
        self.problems: list[Problem] = []
        self.types: dict[str, tuple[NodeType, tuple[str, ...]]] = {}
        for node_type in registry:
            for chosen in variants(node_type):
                self.types[block_type(node_type, chosen)] = (node_type, chosen)
            if node_type.category == "reference":
                self.types[node_type.name] = (node_type, ())
        self.block_at: dict[int, tuple[int, int]] = {}
        self.block_ids: dict[int, str] = {}  # each node's block's id
        self.mission_at = (1, 1)
        self._ids: dict[str, int] | None = None

    def where(self, state: Any) -> tuple[int, int]:
        """Where a block stands in the workspace's text: its ``"id"`` (the first that names it)."""
        block_id = state.get("id") if isinstance(state, dict) else None
        if self._ids is None:  # every id's place, found once
            self._ids = {}
            for found in re.finditer(r'"id"\s*:\s*("(?:[^"\\]|\\.)*")', self.text):
                try:
                    self._ids.setdefault(json.loads(found[1]), found.start())
                except ValueError:
                    continue
        at = self._ids.get(block_id) if isinstance(block_id, str) else None
        if at is None:
            return 1, 1
        line = self.text.count("\n", 0, at) + 1
        return line, at - (self.text.rfind("\n", 0, at) + 1) + 1

    def part(self, state: dict[str, Any], key: str, path: str) -> dict[str, Any]:
        """A block's ``fields`` or ``inputs`` (empty when it has none, or they are not what Blockly saves)."""
        found = state.get(key) or {}
        if not isinstance(found, dict):
            self.problem(state, f"{path}.{key}", f"the block's {key} are not what Blockly saves")
            return {}
        return found

    def held(self, state: dict[str, Any], name: str, path: str) -> Any:
        """The first block in the block's input ``name`` (None: none)."""
        held = self.part(state, "inputs", path).get(name)
        return held.get("block") if isinstance(held, dict) else None

    def problem(self, state: Any, path: str, message: str) -> None:
        self.problems.append(Problem(self.source, *self.where(state), path, message))

    def text_field(self, state: dict[str, Any], name: str, path: str) -> str:
        value = self.part(state, "fields", path).get(name, "")
        if not isinstance(value, str):
            self.problem(state, f"{path}.fields.{name}", f"{name} is text, got {value!r}"[:200])
            return ""
        return value

    def data(self, state: dict[str, Any], path: str) -> dict[str, Any]:
        raw = state.get("data")
        if raw is None:
            return {}
        try:
            data = json.loads(raw) if isinstance(raw, str) else None
        except ValueError:
            data = None
        if not isinstance(data, dict):
            self.problem(state, f"{path}.data", "the block's data is not what autonomy keeps there")
            return {}
        return data

    def comments(self, state: dict[str, Any]) -> list[str]:
        icons = state.get("icons")
        comment = icons.get("comment") if isinstance(icons, dict) else None
        text = comment.get("text") if isinstance(comment, dict) else None
        return LINE_BREAKS.split(text) if isinstance(text, str) else []

    def chain(self, first: Any, path: str) -> list[Outline]:
        nodes, state, index = [], first, 0
        while state is not None:
            node = self.node(state, f"{path}[{index}]")
            if node is not None:
                nodes.append(node)
            following = state.get("next") if isinstance(state, dict) else None
            state = following.get("block") if isinstance(following, dict) else None
            index += 1
        return nodes

    def node(self, state: Any, path: str) -> Outline | None:
        if not isinstance(state, dict) or not isinstance(state.get("type"), str):
            self.problem(state, path, "a block is a mapping with a type")
            return None
        if state.get("enabled") is False or state.get("disabledReasons"):
            self.problem(state, path, "a block is turned off: turn it on, or delete it")
        found = self.types.get(state["type"])
        if found is None:
            self.problem(state, path, f"no node makes a block '{state['type']}'"[:200])
            return None
        node_type, chosen = found
        path = f"{path}.{node_type.name}"
        fields = self.part(state, "fields", path)
        params: dict[str, Any] = {}
        data = self.data(state, path)
        given = data.get("given", [])
        if not isinstance(given, list):
            self.problem(state, f"{path}.data", "the block's data is not what autonomy keeps there")
            given = []
        for param in node_type.params:
            if param.kind in ("node", "nodes"):
                continue
            if not (param.required or param.default is not None or param.name in chosen):
                continue
            if param.kind == "tones":
                value: Any = [fields.get(f"{param.name}.{i}") for i in range(3)]
            elif param.kind == "bool":
                raw = fields.get(param.name)
                value = raw if isinstance(raw, bool) else raw == "TRUE" if raw in ("TRUE", "FALSE") else raw
            else:
                value = fields.get(param.name)
            if value is None or (isinstance(value, list) and None in value):
                self.problem(state, f"{path}.{param.name}", f"the block has no {param.name}")
                continue
            if param.kind == "tones" and not all(_whole(tone) and 1 <= tone <= 9 for tone in value):
                self.problem(state, f"{path}.{param.name}", f"{param.name} are three whole numbers from 1 to 9")
                continue
            if param.required or param.name in chosen or param.name in given or value != param.default:
                params[param.name] = _written(value, param)
        name = data.get("name")
        if name is not None and not isinstance(name, str):
            self.problem(state, f"{path}.data", "the block's name is text")
            name = None
        children: list[Outline] = []
        for param in node_type.params:
            if param.kind not in ("node", "nodes"):
                continue
            kids = self.chain(self.held(state, param.name, path), f"{path}.{param.name}")
            if param.kind == "nodes":
                if not kids:
                    self.problem(state, f"{path}.{param.name}", f"{node_type.name} needs at least one block inside it")
                children += kids
            elif not kids:
                self.problem(state, f"{path}.{param.name}", f"{node_type.name} needs a block in '{param.name}'")
            elif len(kids) == 1:
                children.append(kids[0])
            else:  # several blocks where one goes: they are done in order
                children.append(Outline(self.registry.get("sequence") or node_type, {}, None, kids))
        if node_type.category == "reference":
            params = {"subtree": self.text_field(state, "subtree", path)}
        node = Outline(node_type, params, name or None, children, self.comments(state))
        self.block_at[id(node)] = self.where(state)
        if isinstance(state.get("id"), str):
            self.block_ids[id(node)] = state["id"]
        return node

    def mission(self, workspace: Any) -> MissionOutline | None:
        blocks = workspace.get("blocks") if isinstance(workspace, dict) else None
        top = blocks.get("blocks") if isinstance(blocks, dict) else None
        if not isinstance(top, list):
            self.problems.append(Problem(self.source, 1, 1, "blocks", "not a workspace of blocks (Blockly's JSON)"))
            return None
        missions = [state for state in top if isinstance(state, dict) and state.get("type") == MISSION_BLOCK]
        if len(missions) != 1:
            said = "there is no 'mission' block" if not missions else f"there are {len(missions)} 'mission' blocks"
            where = self.where(missions[1]) if len(missions) > 1 else (1, 1)
            why = f"{said}: the blocks need exactly one, holding the mission's first block"
            self.problems.append(Problem(self.source, *where, "blocks", why))
            return None
        state = missions[0]
        self.mission_at = self.where(state)
        hz = self.part(state, "fields", "mission").get("tick_hz", DEFAULT_TICK_HZ)
        if not finite_number(hz):
            self.problem(state, "mission.tick_hz", f"tick_hz is a number, got {hz!r}"[:200])
            hz = DEFAULT_TICK_HZ
        data = self.data(state, "mission")
        plugins, description = data.get("plugins", []), data.get("description", "")
        if not isinstance(plugins, list) or not all(isinstance(p, str) for p in plugins):
            self.problem(state, "mission.data", "the mission's plugins are a list of module names")
            plugins = []
        if not isinstance(description, str):
            self.problem(state, "mission.data", "the mission's description is text")
            description = ""
        tests = data.get("tests", "")
        if not isinstance(tests, str) or tests and not _tests_block(tests):
            self.problem(state, "mission.data", "the mission's tests are the text of its tests: block, as written")
            tests = ""
        outline = MissionOutline(
            self.text_field(state, "name", "mission"),
            description,
            hz,
            self.text_field(state, "world", "mission") or None,
            plugins,
            comments=self.comments(state),
            tests=tests,
        )
        roots = self.chain(self.held(state, "tree", "mission"), "mission.tree")
        if not roots:
            self.problem(state, "mission.tree", "the mission has no blocks: put its first block inside it")
        elif len(roots) == 1:
            outline.tree = roots[0]
        else:
            outline.tree = Outline(self.registry.get("sequence") or roots[0].type, {}, None, roots)
        for index, other in enumerate(top):
            if other is state:
                continue
            path = f"blocks[{index}]"
            if not isinstance(other, dict) or other.get("type") != DEFINE_BLOCK:
                kind = other.get("type") if isinstance(other, dict) else None
                named = str(kind).split(VARIANT_JOIN)[0] if isinstance(kind, str) else "block"
                said = f"a '{named}' block lies outside the mission: put it in the mission, or delete it"
                self.problem(other, path, said[:200])
                continue
            name = self.text_field(other, "name", path)
            body = self.chain(self.held(other, "body", path), f"{path}.{name}")
            if body:
                body[0].comments[:0] = self.comments(other)  # a comment on the steps' block: before their first
            if name in outline.subtrees:
                self.problem(other, path, f"two sets of steps are called '{name}': rename one")
            elif not body:
                self.problem(other, path, f"the steps called '{name}' are empty: put blocks in them")
            else:
                root = (
                    body[0]
                    if len(body) == 1
                    else Outline(self.registry.get("sequence") or body[0].type, {}, None, body)
                )
                outline.subtrees[name] = root
        return outline


def from_workspace(
    text: str,
    source: str = "workspace.json",
    registry: Registry | None = None,
    base_dir: Path | None = None,
    refuse_plugins: str | None = None,
    lines: dict[str, int] | None = None,
) -> tuple[str, MissionSpec]:
    """The mission a workspace's JSON holds: its canonical text, checked as every mission is.

    Args:
        text: The workspace, as Blockly's JSON.
        source: Its name, for problems.
        registry: The node types known besides its plugins' (default: the built-in ones).
        base_dir: Where its plugins are looked for (default: the working folder).
        refuse_plugins: When given, the mission's plugins are a problem with this message, never imported.
        lines: Filled, when given, with the line of the canonical text each block's node begins on (by its id).

    Raises:
        MissionInvalid: the workspace is not one, or the mission it holds has problems; each at the
            line and column of its block in ``text``.
    """
    from autonomy.mission.registry import BUILTINS

    registry = registry or BUILTINS
    try:
        with _deep_json():
            workspace = json.loads(text)
    except RecursionError:
        raise MissionInvalid([Problem(source, 1, 1, "", "not a workspace: nested deeper than blocks go")]) from None
    except ValueError as err:
        line, column = (err.lineno, err.colno) if isinstance(err, json.JSONDecodeError) else (1, 1)
        raise MissionInvalid([Problem(source, line, column, "", f"not JSON: {err}"[:300])]) from None
    reading = registry
    plugins = _plugins_named(workspace)
    if plugins and refuse_plugins is None:  # their nodes' blocks are read with them (the check says what fails)
        stub = f"mission: plugins\nplugins: {_scalar(plugins)}\ntree: stop\n"
        with contextlib.suppress(MissionInvalid):
            reading = validate_text(stub, source, base_dir, registry=registry, check_world=False).registry
    reader = _Reader(text, source, reading)
    try:
        outline = reader.mission(workspace)
    except RecursionError:
        raise MissionInvalid([Problem(source, 1, 1, "", "the blocks are nested deeper than a mission goes")]) from None
    if reader.problems or outline is None:
        raise MissionInvalid(reader.problems or [Problem(source, 1, 1, "", "not a workspace of blocks")])
    writer = _write(outline)
    mission = "\n".join(writer.lines) + "\n"
    if lines is not None:
        for line, node in writer.starts:
            if id(node) in reader.block_ids:
                lines.setdefault(reader.block_ids[id(node)], line)
    try:
        spec = validate_text(
            mission, source, base_dir, registry=registry, check_world=False, refuse_plugins=refuse_plugins
        )
    except MissionInvalid as err:  # said at the block whose node it is
        lines = _lines_of(outline)
        problems = []
        for problem in err.problems:
            node = lines.get(problem.line)
            where = reader.block_at.get(id(node), reader.mission_at) if node is not None else reader.mission_at
            problems.append(Problem(source, *where, problem.path, problem.message))
        raise MissionInvalid(problems) from None
    return mission, spec


def problems_at_blocks(sent: str, problems: list[Problem]) -> list[dict[str, Any]]:
    """A workspace's problems as a page shows them, each with the id of its block (``block``).

    The block is the one whose ``"id"`` the problem stands at in ``sent``, the workspace's JSON
    (None: the whole workspace's, or the text's).
    """
    lines = sent.splitlines()
    shown = []
    for problem in problems:
        at = lines[problem.line - 1][problem.column - 1 :] if problem.line <= len(lines) else ""
        named = re.match(r'"id":("(?:[^"\\]|\\.)*")', at)
        block = json.loads(named[1]) if named else None
        shown.append({"line": problem.line, "column": problem.column, "path": problem.path, "message": problem.message,
                      "block": block})  # fmt: skip
    return shown


def _plugins_named(workspace: Any) -> list[str]:
    """The plugins the mission block of a workspace names (in its data)."""
    try:
        mission = next(b for b in workspace["blocks"]["blocks"] if b.get("type") == MISSION_BLOCK)
        named = json.loads(mission.get("data") or "{}").get("plugins", [])
    except (KeyError, TypeError, AttributeError, StopIteration, ValueError):
        return []
    return [name for name in named if isinstance(name, str)] if isinstance(named, list) else []


def _lines_of(outline: MissionOutline) -> dict[int, Outline]:
    """The node each line of the outline's canonical text belongs to: the last one started at or before it."""
    starts = _write(outline).starts
    found: dict[int, Outline] = {}
    for (line, node), following in zip(starts, [*starts[1:], (10**9, None)], strict=True):
        for number in range(line, min(following[0], line + 10_000)):
            found[number] = node
    return found

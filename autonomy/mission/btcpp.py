"""Missions as BehaviorTree.CPP 4 XML, for Groot2: export, the node palette, import to YAML.

Three kinds of XML come out of a validated mission:

* :func:`export_xml`: the mission to open and edit in Groot2 (or run with BehaviorTree.CPP):
  one ``<BehaviorTree>`` for the tree and one for each subtree, and a ``<TreeNodesModel>`` of
  every node type it uses, with ports, types, defaults and docs. ``autonomy check/show/run``
  read it back (:mod:`autonomy.mission.xml_read`).
* :func:`palette_xml`: the model of every node type, built-in and a mission's plugins, to load
  into Groot2's editor.
* :func:`instance`: the tree as BehaviorTree.CPP describes a running tree to its loggers and to
  Groot2 (every node's ``_uid``, one ``<BehaviorTree>`` per use of a subtree), with the record
  node each uid shows.

:func:`to_yaml` writes a validated mission (read from either format) as a YAML mission file.
The table of which BehaviorTree.CPP node is which of ours is in :mod:`autonomy.mission.xml_read`.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any
from xml.sax.saxutils import quoteattr

import yaml

from autonomy.behaviours import Param
from autonomy.mission.registry import NodeType, Registry
from autonomy.mission.validate import MissionSpec, NodeSpec
from autonomy.mission.xml_read import BLACKBOARD, EXPLICIT, KNOWN_TAGS, OWN_CONTROLS, WHILE_MARK

INDENT = "    "
#: Our structure types and the BehaviorTree.CPP node each is. Our ``while`` is exactly a
#: ``ReactiveSequence`` of its condition and its child, written as one with :data:`WHILE_MARK`
#: (an attribute BehaviorTree.CPP passes over), so that a stock BehaviorTree.CPP loads it and
#: ``autonomy import`` gives ``while`` back.
_COMPOSITE_TAGS = {("sequence", True): "Sequence", ("sequence", False): "ReactiveSequence"}
_COMPOSITE_TAGS |= {("selector", True): "Fallback", ("selector", False): "ReactiveFallback"}
_DECORATOR_TAGS = {
    "repeat": "Repeat",
    "retry": "RetryUntilSuccessful",
    "timeout": "Timeout",
    "invert": "Inverter",
    "force_success": "ForceSuccess",
    "force_failure": "ForceFailure",
    "once": "RunOnce",
}
_PORT_TYPES = {
    "int": "int",
    "number": "double",
    "bool": "bool",
    "string": "std::string",
    "choice": "std::string",
    "tones": "std::vector<int>",
}


class ExportError(ValueError):
    """A mission that BehaviorTree.CPP cannot express as it stands (the message says why)."""


def attribute_text(value: Any) -> str:
    """A parameter's value as BehaviorTree.CPP writes it in an attribute (lists with ``;``)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return ";".join(attribute_text(v) for v in value)
    if isinstance(value, float):
        return str(int(value)) if value.is_integer() and abs(value) < 1e15 else repr(value)
    return str(value)


@dataclass
class BtNode:
    """One node as BehaviorTree.CPP sees it.

    Attributes:
        tag: The element's tag: a BehaviorTree.CPP node, one of ours, or ``SubTree``.
        name: The ``name:`` the mission gave it (None: BehaviorTree.CPP names it by its tag).
        ports: Its ports, as attribute text.
        children: Its children; for a ``SubTree``, none (see ``subtree``).
        subtree: For a ``SubTree``, the subtree's ID.
        spec: The mission's node it is.
    """

    tag: str
    name: str | None
    ports: dict[str, str]
    children: list[BtNode] = field(default_factory=list)
    subtree: str = ""
    spec: NodeSpec | None = None


def _ports(node_type: NodeType, args: dict[str, Any]) -> dict[str, str]:
    """The arguments that differ from the defaults, in declared order."""
    out = {}
    for param in node_type.params:
        if param.kind in ("node", "nodes"):
            continue
        value = args.get(param.name)
        if value is not None and value != param.default:
            out[param.name] = attribute_text(value)
    return out


def bt_node(spec: NodeSpec, exact: bool = True) -> BtNode:
    """The mission's node (and everything below it, subtrees as references) as BehaviorTree.CPP's.

    Args:
        spec: The node.
        exact: Refuse what BehaviorTree.CPP would run differently (a timeout in fractions of a
            millisecond); else round it, for a description of the tree that is not run.

    Raises:
        ExportError: ``exact``, and a timeout that is not a whole number of milliseconds, or a
            text BehaviorTree.CPP would take for a blackboard entry (``{name}``).
    """
    node_type, args = spec.type, spec.args
    kids = [bt_node(child, exact) for child in spec.children]
    if node_type.category == "reference":
        return BtNode("SubTree", None, {}, subtree=args["subtree"], spec=spec)
    name = node_type.name
    if name in ("sequence", "selector"):
        return BtNode(_COMPOSITE_TAGS[name, bool(args["memory"])], spec.name, {}, kids, spec=spec)
    if name == "parallel":
        counts = {"failure_count": "1", "success_count": "-1" if args["policy"] == "all" else "1"}
        return BtNode("Parallel", spec.name, counts, kids, spec=spec)
    if name == "while":
        return BtNode("ReactiveSequence", spec.name, dict([WHILE_MARK]), kids, spec=spec)
    if name in _DECORATOR_TAGS:
        ports: dict[str, str] = {}
        if name == "repeat":
            ports["num_cycles"] = str(args["times"] or -1)
        elif name == "retry":
            ports["num_attempts"] = str(args["attempts"])
        elif name == "timeout":
            msec = args["seconds"] * 1000
            if exact and abs(msec - round(msec)) > 1e-6:
                raise ExportError(
                    f"{spec.path}: timeout {args['seconds']} s is not a whole number of milliseconds, "
                    "which BehaviorTree.CPP's Timeout (msec) needs"
                )
            ports["msec"] = str(max(1, round(msec)))
        elif name == "once":
            ports["then_skip"] = "false"
        return BtNode(_DECORATOR_TAGS[name], spec.name, ports, kids, spec=spec)
    ports = _ports(node_type, args)
    for key, value in ports.items():
        if exact and BLACKBOARD.match(value):
            raise ExportError(
                f"{spec.path}.{key}: '{value}' would be read by BehaviorTree.CPP as a blackboard entry, "
                "not as text: write it without the braces"
            )
    if name in KNOWN_TAGS or name in EXPLICIT:  # a plugin's leaf named like BehaviorTree.CPP's own nodes
        tag = "Action" if node_type.category == "action" else "Condition"
        return BtNode(tag, spec.name, {"ID": name, **ports}, kids, spec=spec)
    return BtNode(name, spec.name, ports, kids, spec=spec)


def _attributes(pairs: list[tuple[str, str]]) -> str:
    return "".join(f" {key}={quoteattr(value)}" for key, value in pairs)


def _element(node: BtNode, depth: int) -> Iterator[str]:
    pad = INDENT * depth
    if node.tag == "SubTree":
        yield f"{pad}<SubTree ID={quoteattr(node.subtree)}/>"
        return
    ports = dict(node.ports)
    pairs = [("ID", ports.pop("ID"))] if "ID" in ports else []
    pairs += ([("name", node.name)] if node.name else []) + list(ports.items())
    if not node.children:
        yield f"{pad}<{node.tag}{_attributes(pairs)}/>"
        return
    yield f"{pad}<{node.tag}{_attributes(pairs)}>"
    for child in node.children:
        yield from _element(child, depth + 1)
    yield f"{pad}</{node.tag}>"


def _types_used(mission: MissionSpec) -> list[NodeType]:
    seen: dict[str, NodeType] = {}
    todo = [mission.tree, *mission.subtrees.values()]
    while todo:
        spec = todo.pop()
        seen.setdefault(spec.type.name, spec.type)
        todo.extend(spec.children)
    return [t for t in mission.registry if t.name in seen]


def _port_line(param: Param) -> str:
    doc = param.doc + (f" ({param.unit})" if param.unit else "")
    if param.choices:
        doc += f"; one of {', '.join(param.choices)}"
    if param.required:
        doc += "; required"
    pairs = [("name", param.name), ("type", _PORT_TYPES[param.kind])]
    if param.default is not None:
        pairs.append(("default", attribute_text(param.default)))
    text = doc.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    return f"<input_port{_attributes(pairs)}>{text}</input_port>"


def model_lines(types: list[NodeType]) -> list[str]:
    """``<TreeNodesModel>`` for ``types``: our leaves, their ports and docs (BehaviorTree.CPP knows its own)."""
    lines = ["<TreeNodesModel>"]
    for node_type in types:  # and our composites it has none like, as control nodes of their own (``random``)
        if node_type.category not in ("action", "condition") and node_type.name not in OWN_CONTROLS:
            continue  # BehaviorTree.CPP's own nodes are known to every editor
        tag = {"action": "Action", "condition": "Condition"}.get(node_type.category, "Control")
        lines.append(f"{INDENT}<{tag} ID={quoteattr(node_type.name)}>")
        for param in node_type.params:
            if param.kind not in ("node", "nodes"):  # the children are the element's, not ports
                lines.append(INDENT * 2 + _port_line(param))
        lines.append(f"{INDENT * 2}<MetadataFields><Metadata description={quoteattr(node_type.doc)}/></MetadataFields>")
        lines.append(f"{INDENT}</{tag}>")
    lines.append("</TreeNodesModel>")
    return lines


def export_xml(mission: MissionSpec) -> str:
    """The mission as a BehaviorTree.CPP 4 file, with the model of the node types it uses.

    Raises:
        ExportError: the mission holds something BehaviorTree.CPP cannot express.
    """
    settings = [("ID", mission.name)]
    if mission.description:
        settings.append(("_description", mission.description.strip()))
    settings.append(("_tick_hz", attribute_text(mission.tick_hz)))
    if mission.world:
        settings.append(("_world", mission.world))
    if mission.plugins:
        settings.append(("_plugins", ";".join(mission.plugins)))
    lines = ['<?xml version="1.0" encoding="UTF-8"?>']
    lines.append(f'<root BTCPP_format="4" main_tree_to_execute={quoteattr(mission.name)}>')
    lines.append(f"{INDENT}<BehaviorTree{_attributes(settings)}>")
    lines += _element(bt_node(mission.tree), 2)
    lines.append(f"{INDENT}</BehaviorTree>")
    for name, spec in mission.subtrees.items():
        lines.append(f"{INDENT}<BehaviorTree ID={quoteattr(name)}>")
        lines += _element(bt_node(spec), 2)
        lines.append(f"{INDENT}</BehaviorTree>")
    lines += [INDENT + line for line in model_lines(_types_used(mission))]
    lines.append("</root>")
    return "\n".join(lines) + "\n"


def palette_xml(registry: Registry) -> str:
    """The model of every node type in ``registry``, for Groot2's editor."""
    lines = ['<?xml version="1.0" encoding="UTF-8"?>', '<root BTCPP_format="4">']
    lines += [INDENT + line for line in model_lines(list(registry))]
    lines.append("</root>")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- the running tree


@dataclass
class Instance:
    """The mission's tree as BehaviorTree.CPP numbers a running tree.

    Attributes:
        xml: The tree as BehaviorTree.CPP's loggers and Groot2 get it: every node with its
            ``_uid``, one ``<BehaviorTree _fullpath=...>`` for each use of a subtree.
        record_ids: For uid 1, 2, ...: the id of the record node whose status it shows (a
            ``SubTree`` node shows its subtree's root).
        tags: For uid 1, 2, ...: the node's tag.
        blackboards: The names of the tree's blackboards, as Groot2 asks for them: the main
            tree's ID and each use of a subtree's ``_fullpath``.
    """

    xml: str
    record_ids: list[int]
    tags: list[str]
    blackboards: list[str] = field(default_factory=list)


def instance(mission: MissionSpec) -> Instance:
    """Numbers the mission's nodes as BehaviorTree.CPP would.

    Depth first, from 1, a subtree's nodes right after its ``SubTree`` node. A timeout is shown
    to the nearest millisecond: this describes the tree autonomy runs, for loggers and Groot2.
    """
    record_ids: list[int] = []
    tags: list[str] = []
    blocks: list[list[str]] = []
    blackboards = [mission.name]
    next_record = [0]

    def tree_block(root: BtNode, tree_id: str, fullpath: str) -> None:
        block: list[str] = []
        blocks.append(block)  # the block keeps its place: trees come in the order they are met
        block.append(f"{INDENT}<BehaviorTree ID={quoteattr(tree_id)} _fullpath={quoteattr(fullpath)}>")
        element(root, 2, fullpath, block)
        block.append(f"{INDENT}</BehaviorTree>")

    def element(node: BtNode, depth: int, fullpath: str, block: list[str]) -> None:
        pad = INDENT * depth
        uid = len(record_ids) + 1
        tags.append(node.tag)
        if node.tag == "SubTree":
            record_ids.append(-1)  # filled in once the subtree's root is numbered
            inner = f"{node.subtree}::{uid}"
            path = f"{fullpath}/{inner}" if fullpath else inner
            blackboards.append(path)
            block.append(f'{pad}<SubTree ID={quoteattr(node.subtree)} _fullpath={quoteattr(path)} _uid="{uid}"/>')
            target = mission.subtrees[node.subtree]
            tree_block(bt_node(target, exact=False), node.subtree, path)
            record_ids[uid - 1] = record_ids[uid]
            return
        record_ids.append(next_record[0])
        next_record[0] += 1
        ports = dict(node.ports)
        explicit = [("ID", ports.pop("ID"))] if "ID" in ports else []
        pairs = [*explicit, ("name", node.name or explicit[0][1] if explicit else node.name or node.tag)]
        pairs += [("_uid", str(uid)), *sorted(ports.items())]
        if not node.children:
            block.append(f"{pad}<{node.tag}{_attributes(pairs)}/>")
            return
        block.append(f"{pad}<{node.tag}{_attributes(pairs)}>")
        for child in node.children:
            element(child, depth + 1, fullpath, block)
        block.append(f"{pad}</{node.tag}>")

    tree_block(bt_node(mission.tree, exact=False), mission.name, "")
    lines = ['<root BTCPP_format="4">']
    for block in blocks:
        lines += block
    lines += [INDENT + line for line in model_lines(_types_used(mission))]
    lines.append("</root>")
    return Instance("\n".join(lines) + "\n", record_ids, tags, blackboards)


# --------------------------------------------------------------------------- to YAML


def _yaml_node(spec: NodeSpec) -> Any:
    node_type, args = spec.type, spec.args
    if node_type.category == "reference":
        return {"subtree": args["subtree"]}
    body: dict[str, Any] = {}
    if spec.name is not None:
        body["name"] = spec.name
    for param in node_type.params:
        if param.kind in ("node", "nodes"):
            continue
        value = args.get(param.name)
        if value is not None and value != param.default:
            body[param.name] = list(value) if isinstance(value, (list, tuple)) else value
    kids = [_yaml_node(child) for child in spec.children]
    child_params = [p for p in node_type.params if p.kind in ("node", "nodes")]
    if node_type.category == "composite":
        if not body:
            return {node_type.name: kids}
        body["children"] = kids
    else:
        for param, kid in zip(child_params, kids, strict=False):
            body[param.name] = kid
    if not body and not node_type.needs_parameters:
        return node_type.name
    return {node_type.name: body}


class _Dumper(yaml.SafeDumper):
    pass


def _text(dumper: yaml.SafeDumper, value: str) -> yaml.ScalarNode:
    style = ">" if len(value) > 80 else None
    return dumper.represent_scalar("tag:yaml.org,2002:str", value, style=style)


_Dumper.add_representer(str, _text)
_Dumper.add_multi_representer(str, _text)  # attribute text read from XML


def to_yaml(mission: MissionSpec) -> str:
    """The mission as a YAML mission file."""
    doc: dict[str, Any] = {"mission": mission.name}
    if mission.description:
        doc["description"] = mission.description.strip()
    doc["tick_hz"] = int(mission.tick_hz) if float(mission.tick_hz).is_integer() else mission.tick_hz
    if mission.world:
        doc["world"] = mission.world
    if mission.plugins:
        doc["plugins"] = list(mission.plugins)
    if mission.subtrees:
        doc["subtrees"] = {name: _yaml_node(spec) for name, spec in mission.subtrees.items()}
    doc["tree"] = _yaml_node(mission.tree)
    return yaml.dump(doc, Dumper=_Dumper, sort_keys=False, default_flow_style=None, width=100, allow_unicode=True)

"""Views of the node-type registry: the CLI catalogue, the docs' reference, the JSON Schema.

All three are made from :mod:`autonomy.mission.registry`, so they cannot disagree with
the validator.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from autonomy.behaviours import Param
from autonomy.mission.registry import CATEGORIES, NodeType, Registry
from autonomy.mission.validate import DEFAULT_TICK_HZ, MAX_TICK_HZ, example_arguments

HEADINGS = {
    "composite": "Composites",
    "decorator": "Decorators",
    "action": "Actions",
    "condition": "Conditions",
    "reference": "Subtrees",
}


def _by_category(registry: Registry) -> list[tuple[str, list[NodeType]]]:
    return [(c, [t for t in registry if t.category == c]) for c in CATEGORIES if any(t.category == c for t in registry)]


def _yaml(value: Any) -> str:
    """A default as a mission file writes it."""
    return json.dumps(value) if isinstance(value, (bool, list)) else str(value)


def _param_facts(param: Param) -> str:
    facts = [param.kind]
    if param.unit:
        facts.append(param.unit)
    if param.describe_range():
        facts.append(param.describe_range())
    if param.required:
        facts.append("required")
    elif param.default is not None:
        facts.append(f"default {_yaml(param.default)}")
    return ", ".join(facts)


def _names(node_type: NodeType) -> str:
    return node_type.name + "".join(f" (alias {a})" for a in node_type.aliases)


def catalogue_text(registry: Registry) -> str:
    """Every node type with its parameters, for ``autonomy behaviours``."""
    lines = []
    for category, types in _by_category(registry):
        lines.append(f"{HEADINGS[category]}:")
        for node_type in types:
            origin = f"  [{node_type.origin}]" if node_type.origin != "built-in" else ""
            lines.append(f"  {_names(node_type):<28}{node_type.doc}{origin}")
            for param in node_type.params:
                lines.append(f"      {param.name:<24}{param.doc} ({_param_facts(param)})")
            for group in node_type.exactly_one_of:
                lines.append(f"      exactly one of {', '.join(group)}")
        lines.append("")
    return "\n".join(lines).rstrip() + "\n"


def catalogue_markdown(registry: Registry) -> str:
    """The node reference of docs/missions.md."""
    out = []
    for category, types in _by_category(registry):
        out.append(f"### {HEADINGS[category]}\n")
        for node_type in types:
            out.append(f"#### `{node_type.name}`" + "".join(f" (alias `{a}`)" for a in node_type.aliases) + "\n")
            out.append(node_type.doc + "\n")
            if node_type.params:
                out.append("| parameter | kind | unit | values | default | meaning |")
                out.append("|---|---|---|---|---|---|")
                for p in node_type.params:
                    default = "required" if p.required else ("" if p.default is None else f"`{_yaml(p.default)}`")
                    values = p.describe_range().replace("|", "\\|")  # a bare | would split the cell
                    out.append(f"| `{p.name}` | {p.kind} | {p.unit} | {values} | {default} | {p.doc} |")
                out.append("")
            for group in node_type.exactly_one_of:
                out.append(f"Give exactly one of {', '.join(f'`{g}`' for g in group)}.\n")
            out.append(f"Example: `{_example(node_type)}`\n")
    return "\n".join(out).rstrip() + "\n"


def node_help(registry: Registry, names: tuple[str, ...] | None = None) -> list[dict[str, str]]:
    """Each node type (or those of ``names``) in a line, for a page: name, category, what it does, an example."""
    return [
        {"name": t.name, "category": t.category, "doc": t.doc, "example": _example(t)}
        for _, types in _by_category(registry)
        for t in types
        if names is None or t.name in names or any(alias in names for alias in t.aliases)
    ]


def _example(node_type: NodeType) -> str:
    if node_type.category == "reference":
        return "subtree: corner"
    if node_type.category == "composite":
        return f"{node_type.name}: [stop, beep]"
    arguments = example_arguments(node_type)
    return f"{node_type.name}: {{{arguments}}}" if arguments else node_type.name


REFERENCE_START = "<!-- reference:start -->\n"
REFERENCE_END = "<!-- reference:end -->"


def with_reference(document: str, registry: Registry) -> str:
    """``document`` (docs/missions.md) with its node reference made anew from ``registry``."""
    start = document.index(REFERENCE_START) + len(REFERENCE_START)
    end = document.index(REFERENCE_END)
    return document[:start] + "\n" + catalogue_markdown(registry) + "\n" + document[end:]


def update_reference(path: str | Path, registry: Registry | None = None) -> None:
    """Rewrites the node reference in the docs file at ``path`` (``make docs``)."""
    from autonomy.mission.registry import BUILTINS

    path = Path(path)
    path.write_text(with_reference(path.read_text(encoding="utf-8"), registry or BUILTINS), encoding="utf-8")


# --------------------------------------------------------------------------- JSON Schema


def _param_schema(param: Param) -> dict[str, Any]:
    schema: dict[str, Any]
    if param.kind == "int":
        schema = {"type": "integer"}
    elif param.kind == "number":
        schema = {"type": "number"}
    elif param.kind == "bool":
        schema = {"type": "boolean"}
    elif param.kind == "string":
        schema = {"type": "string"}
    elif param.kind == "choice":
        schema = {"enum": list(param.choices)}
    elif param.kind == "tones":
        schema = {
            "type": "array",
            "items": {"type": "integer", "minimum": 1, "maximum": 9},
            "minItems": 3,
            "maxItems": 3,
        }
    elif param.kind == "node":
        schema = {"$ref": "#/$defs/node"}
    else:
        schema = {"type": "array", "items": {"$ref": "#/$defs/node"}, "minItems": 1}
    if param.minimum is not None:
        schema["minimum"] = param.minimum
    if param.maximum is not None:
        schema["maximum"] = param.maximum
    if param.positive:
        schema["exclusiveMinimum"] = 0
    if param.default is not None:
        schema["default"] = param.default
    unit = f" ({param.unit})" if param.unit else ""
    schema["description"] = param.doc + unit
    return schema


def _node_schema(node_type: NodeType) -> dict[str, Any]:
    if node_type.category == "reference":
        body: dict[str, Any] = {"type": "string", "description": "the name of a subtree"}
    else:
        properties = {"name": {"type": "string", "description": "display name"}}
        properties.update({p.name: _param_schema(p) for p in node_type.params})
        body = {
            "type": "object" if node_type.needs_parameters else ["object", "null"],
            "properties": properties,
            "additionalProperties": False,
        }
        required = [p.name for p in node_type.params if p.required]
        if required:
            body["required"] = required
        if node_type.exactly_one_of:
            body["allOf"] = [{"oneOf": [{"required": [name]} for name in group]} for group in node_type.exactly_one_of]
        if node_type.children_param:
            children = _param_schema(node_type.param(node_type.children_param))  # type: ignore[arg-type]
            body = {"oneOf": [children, body]}
    return {
        "type": "object",
        "description": node_type.doc,
        "properties": {name: body for name in (node_type.name, *node_type.aliases)},
        "minProperties": 1,
        "maxProperties": 1,
        "additionalProperties": False,
    }


def json_schema(registry: Registry, allowed: tuple[str, ...] | None = None) -> dict[str, Any]:
    """A JSON Schema (2020-12) of the mission format, for editors (``allowed``: of those nodes alone)."""
    types = [t for t in registry if allowed is None or t.name in allowed]
    bare = sorted(name for t in types if not t.needs_parameters for name in (t.name, *t.aliases))
    defs: dict[str, Any] = {"bare": {"enum": bare, "description": "a node without parameters, written by name"}}
    for node_type in types:
        defs[node_type.name] = _node_schema(node_type)
    defs["node"] = {"anyOf": [{"$ref": f"#/$defs/{name}"} for name in defs]}
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "autonomy mission",
        "description": "A mission file: a behaviour tree for the robot, written in YAML.",
        "type": "object",
        "required": ["mission", "tree"],
        "additionalProperties": False,
        "properties": {
            "mission": {"type": "string", "description": "the mission's name"},
            "description": {"type": "string", "description": "what it does, in a sentence"},
            "tick_hz": {
                "type": "number",
                "exclusiveMinimum": 0,
                "maximum": MAX_TICK_HZ,
                "default": DEFAULT_TICK_HZ,
                "description": "ticks per second",
            },
            "world": {"type": "string", "description": "the emulator's arena (ignored on a real robot)"},
            "plugins": {"type": "array", "items": {"type": "string"}, "description": "Python modules with behaviours"},
            "subtrees": {"type": "object", "additionalProperties": {"$ref": "#/$defs/node"}},
            "tree": {"$ref": "#/$defs/node"},
        },
        "$defs": defs,
    }

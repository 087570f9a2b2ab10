"""Small helpers over py_trees trees, and the description of a tree that records carry."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import py_trees

from autonomy.behaviours.base import RobotAction, RobotBehaviour, RobotCondition
from autonomy.record import NodeInfo

Behaviour = py_trees.behaviour.Behaviour


@dataclass(frozen=True)
class NodeSource:
    """Where a built node came from: its node type, parameters, and place in the mission file.

    The mission compiler sets it as ``node.mission_source`` on every node it builds.
    """

    type: str
    category: str
    params: dict[str, Any] = field(default_factory=dict)
    file: str = ""
    line: int = 0
    column: int = 0


def preorder(root: Behaviour) -> Iterator[Behaviour]:
    """Every node, parents before their children, children in order (py_trees' iterate() is post-order)."""
    stack = [root]
    while stack:
        node = stack.pop()
        yield node
        stack.extend(reversed(node.children))


def kind_of(node: Behaviour) -> str:
    """composite, decorator, action or condition."""
    source = getattr(node, "mission_source", None)
    if source is not None:
        return source.category
    if isinstance(node, py_trees.composites.Composite):
        return "composite"
    if isinstance(node, RobotCondition):
        return "condition"
    if isinstance(node, RobotAction):
        return "action"
    return "decorator" if node.children else "action"


def _type_of(node: Behaviour) -> str:
    if isinstance(node, RobotBehaviour) and node.node_type:
        return node.node_type
    return type(node).__name__.lower()


def describe_tree(root: Behaviour) -> list[NodeInfo]:
    """Every node as a :class:`~autonomy.record.NodeInfo`, in preorder (ids 0, 1, ...)."""
    ids = {id(node): index for index, node in enumerate(preorder(root))}
    out = []
    for node in preorder(root):
        source: NodeSource | None = getattr(node, "mission_source", None)
        parent = ids.get(id(node.parent)) if node.parent is not None and node is not root else None
        if source is not None:
            out.append(
                NodeInfo(
                    ids[id(node)],
                    node.name,
                    source.type,
                    source.category,
                    dict(source.params),
                    parent,
                    source.file,
                    source.line,
                )
            )
        else:
            params = dict(getattr(node, "args", {}) or {})
            out.append(NodeInfo(ids[id(node)], node.name, _type_of(node), kind_of(node), params, parent))
    return out

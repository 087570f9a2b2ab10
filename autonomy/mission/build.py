"""Validated mission -> py_trees behaviour tree.

Every node is built fresh, so a subtree used twice becomes two independent copies. A
subtree's root is shown under the subtree's name unless the file named it. Every node
carries a :class:`~autonomy.behaviours.tree.NodeSource` as ``mission_source``: its node
type, parameters and ``file:line``, for traces, views and error messages.
"""

from __future__ import annotations

import py_trees

from autonomy.behaviours.tree import NodeSource
from autonomy.mission.validate import MissionInvalid, MissionSpec, NodeSpec, Problem


def build_node(spec: NodeSpec, mission: MissionSpec) -> py_trees.behaviour.Behaviour:
    """Builds one node and everything below it."""
    if spec.type.category == "reference":
        target = mission.subtrees[spec.args["subtree"]]
        root = build_node(target, mission)
        if target.name is None:
            root.name = spec.args["subtree"]
        return root
    children = [build_node(child, mission) for child in spec.children]
    try:
        node = spec.type.build(spec.display_name, spec.args, children)
    except BaseException as err:  # noqa: BLE001 - a plugin's class that cannot be built is the file's problem
        why = f"{type(err).__name__}: {err}".rstrip(": ")
        problem = f"cannot build node '{spec.display_name}' ({spec.type.origin}): {why}"
        raise MissionInvalid([Problem(mission.source, spec.line, spec.column, spec.path, problem)]) from None
    node.mission_source = NodeSource(
        spec.type.name, spec.type.category, dict(spec.args), mission.source, spec.line, spec.column
    )
    return node


def build_tree(mission: MissionSpec) -> py_trees.behaviour.Behaviour:
    """Builds the mission's tree (the root node; nothing is set up or connected).

    Raises:
        MissionInvalid: a node's class could not be built (a plugin's fault).
    """
    return build_node(mission.tree, mission)

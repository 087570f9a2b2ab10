"""Validated mission -> py_trees behaviour tree.

Every node is built fresh, so a subtree used twice becomes two independent copies. A
subtree's root is shown under the subtree's name unless the file named it. Every node
carries a :class:`~autonomy.behaviours.tree.NodeSource` as ``mission_source``: its node
type, parameters and ``file:line``, for traces, views and error messages.
"""

from __future__ import annotations

import py_trees

from autonomy.behaviours.tree import NodeSource
from autonomy.errors import Interrupted
from autonomy.mission.validate import MissionInvalid, MissionSpec, NodeSpec, Problem


def build_node(spec: NodeSpec, mission: MissionSpec) -> py_trees.behaviour.Behaviour:
    """Builds one node and everything below it.

    A chain of subtree references is followed in a loop, not by recursion: only the tree's
    own levels (at most ``MAX_TREE_DEPTH``) recurse. The outermost reference names the node,
    unless the subtree it names has a name of its own.
    """
    names: list[str | None] = []
    while spec.type.category == "reference":
        target = mission.subtrees[spec.args["subtree"]]
        names.append(spec.args["subtree"] if target.name is None else None)
        spec = target
    if names:
        root = build_node(spec, mission)
        for name in reversed(names):
            if name is not None:
                root.name = name
        return root
    children = [build_node(child, mission) for child in spec.children]
    try:
        node = spec.type.build(spec.display_name, spec.args, children)
    except Interrupted:  # Ctrl-C or SIGTERM meanwhile, as the command line raises it: the command's, not the plugin's
        raise
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

"""Mission files: YAML -> validated document -> py_trees tree, and their node-type registry.

from autonomy.mission import load_mission, build_tree
spec = load_mission("missions/square.yaml")   # raises MissionInvalid with every problem
root = build_tree(spec)
"""

from pathlib import Path

from autonomy.mission.build import build_tree
from autonomy.mission.registry import BUILTINS, NodeType, Registry
from autonomy.mission.validate import MissionInvalid, MissionSpec, NodeSpec, Problem, validate_file, validate_text


def load_mission(path: str | Path, check_world: bool = True) -> MissionSpec:
    """Validates a mission file; one with plugins is built once too.

    A plugin's class that cannot be built (an abstract method left out, an ``__init__`` that
    raises) is then a problem of the file, at the node that uses it, before anything runs.

    Raises:
        MissionInvalid: with every problem found.
    """
    spec = validate_file(path, check_world)
    if spec.plugins:
        build_tree(spec)
    return spec


__all__ = [
    "BUILTINS",
    "MissionInvalid",
    "MissionSpec",
    "NodeSpec",
    "NodeType",
    "Problem",
    "Registry",
    "build_tree",
    "load_mission",
    "validate_file",
    "validate_text",
]

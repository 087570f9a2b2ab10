"""Mission files: YAML -> validated document -> py_trees tree, and their node-type registry.

from autonomy.mission import load_mission, build_tree
spec = load_mission("missions/square.yaml")   # raises MissionInvalid with every problem
root = build_tree(spec)
"""

from autonomy.mission.build import build_tree
from autonomy.mission.registry import BUILTINS, NodeType, Registry
from autonomy.mission.validate import MissionInvalid, MissionSpec, NodeSpec, Problem, validate_file, validate_text

load_mission = validate_file

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

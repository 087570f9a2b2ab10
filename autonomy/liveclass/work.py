"""What the class's server does with a student's mission text: check it, and say where its problems are.

Nothing here runs a student's Python: plugins are refused, as in grading.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from autonomy.behaviours.tree import describe_tree
from autonomy.classroom.exercise import Exercise
from autonomy.classroom.grade import check_text
from autonomy.mission import build_tree
from autonomy.views.treesvg import svg_tree

#: How a student's mission is named in its problems.
MISSION_LABEL = "mission.yaml"
#: Longest mission text taken (a mission file may be 500,000 bytes; a class's are a few hundred).
MAX_MISSION_CHARS = 100_000


def check(exercise: Exercise, text: str) -> dict[str, Any]:
    """The ``api/check`` answer: each problem at its line and column, or the tree drawn.

    Returns:
        ``{"ok": bool, "problems": [{"line", "column", "path", "message"}...], "tree_svg": str}``; the
        tree is drawn only for a mission without problems.
    """
    if len(text) > MAX_MISSION_CHARS:
        message = f"the mission is {len(text):,} characters long; at most {MAX_MISSION_CHARS:,} are taken"
        return {"ok": False, "problems": [{"line": 1, "column": 1, "path": "", "message": message}], "tree_svg": ""}
    spec, problems = check_text(exercise, text, MISSION_LABEL, Path("/nonexistent-plugins"))
    if spec is None:
        shown = [{"line": p.line, "column": p.column, "path": p.path, "message": p.message} for p in problems]
        return {"ok": False, "problems": shown, "tree_svg": ""}
    return {"ok": True, "problems": [], "tree_svg": svg_tree(describe_tree(build_tree(spec)), spec.name)}

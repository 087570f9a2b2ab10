"""What the class's server does with a student's mission text: check it, and say where its problems are.

Nothing here runs a student's Python: plugins are refused, as in grading.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from autonomy.behaviours.tree import describe_tree
from autonomy.classroom.exercise import Exercise
from autonomy.classroom.grade import Report, check_text, file_names, grade_class, page_path
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


def public_only(exercise: Exercise) -> Exercise:
    """The exercise with its public seeds alone: what a student's "Run" is tried on."""
    return dataclasses.replace(exercise, seeds=[seed for seed in exercise.seeds if not seed.hidden])


def grade_text(
    exercise: Exercise, student: str, text: str, folder: Path, number: int, hand_in: bool
) -> tuple[Report, Path]:
    """Grades a student's mission text as ``autonomy grade`` does, in a limited worker process.

    The text is kept as ``FOLDER/works/NAME/NUMBER-run.yaml`` (or ``-handin``), and its feedback page,
    with each seed's replay, written to ``FOLDER/pages/NAME-NUMBER.html``.

    Args:
        exercise: The exercise, with its hidden seeds when it has them (see :meth:`Exercise.with_secret`).
        student: The student's id.
        text: The mission's text.
        folder: The class's folder.
        number: The work's number in the class's store, which names its files.
        hand_in: Graded on every seed; otherwise ("Run") on the public seeds alone.

    Returns:
        The report, and the feedback page's path.
    """
    name = file_names([student])[student]
    kept = folder / "works" / name / f"{number}-{'handin' if hand_in else 'run'}.yaml"
    kept.parent.mkdir(parents=True, exist_ok=True)
    kept.write_text(text, encoding="utf-8")
    pages = folder / "pages"
    pages.mkdir(parents=True, exist_ok=True)
    graded = exercise if hand_in else public_only(exercise)
    (report,) = grade_class(graded, [(f"{name}-{number}", kept)], workers=1, feedback=pages, start_method="forkserver")
    return report, page_path(pages, file_names([f"{name}-{number}"])[f"{name}-{number}"])

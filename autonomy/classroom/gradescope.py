"""The autograder zip Gradescope takes: this package, an exercise, and the two scripts Gradescope runs.

Gradescope builds a container from the zip once (``setup.sh``), then for each submission puts the
student's files in ``/autograder/submission`` and runs ``run_autograder``, which must leave
``/autograder/results/results.json``. Here ``run_autograder`` is one ``autonomy grade`` of the
submission with ``--gradescope``; the root ``/autograder`` can be moved with ``AUTOGRADER_ROOT``
(for trying the zip out on a machine of one's own).

The zip holds the package's source and a ``pyproject.toml`` naming the same dependencies as the
installed package, so ``setup.sh`` installs what grades here, whichever way it was installed.
"""

from __future__ import annotations

import io
import json
import zipfile
from importlib import metadata, resources
from pathlib import Path
from typing import Any

from autonomy import __version__
from autonomy.classroom.exercise import Exercise
from autonomy.classroom.report import feedback, for_the_student
from autonomy.classroom.results import Report
from autonomy.emulator.world import SHIPPED
from autonomy.errors import AutonomyError
from autonomy.views.lines import printable

SETUP = """#!/usr/bin/env bash
# Gradescope runs this once, to build the autograder's image: Python and this package.
set -euo pipefail
if ! command -v python3 >/dev/null || ! python3 -m venv --help >/dev/null 2>&1; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3 python3-venv python3-pip
fi
python3 -m venv /autograder/venv
/autograder/venv/bin/python -m pip install --quiet --upgrade pip
/autograder/venv/bin/python -m pip install --quiet /autograder/source/package
"""

RUN = """#!/usr/bin/env bash
# Gradescope runs this for each submission: the student's files are in $ROOT/submission, and the
# marks must be left in $ROOT/results/results.json. AUTOGRADER_ROOT moves the root, to try it out.
set -uo pipefail
ROOT="${{AUTOGRADER_ROOT:-/autograder}}"
AUTONOMY="${{AUTONOMY:-$ROOT/venv/bin/autonomy}}"
mkdir -p "$ROOT/results"
rm -f "$ROOT/results/results.json"  # nothing of an earlier run stands for this one
cd "$ROOT/source/exercise"
"$AUTONOMY" grade {exercise} "$ROOT/submission" --gradescope "$ROOT/results/results.json" --quiet{secret}
status=$?
if [ ! -s "$ROOT/results/results.json" ]; then  # the grader itself failed: say so, not a silent zero
    printf '{{"score": 0, "output": "The autograder failed (exit %s): tell your teacher.", "tests": []}}\\n' \\
        "$status" > "$ROOT/results/results.json"
fi
exit 0
"""


class AutograderError(AutonomyError):
    """An exercise that cannot be packed for Gradescope (say why)."""


def _pyproject() -> str:
    """A ``pyproject.toml`` for the package as installed here: its version and its dependencies."""
    try:
        requires = [r for r in metadata.requires("autonomy") or [] if "extra ==" not in r]
    except metadata.PackageNotFoundError:
        requires = []
    listed = "".join(f'    "{r}",\n' for r in requires)
    return (
        '[build-system]\nrequires = ["setuptools>=68"]\nbuild-backend = "setuptools.build_meta"\n\n'
        f'[project]\nname = "autonomy"\nversion = "{__version__}"\nrequires-python = ">=3.10"\n'
        f"dependencies = [\n{listed}]\n\n"
        '[project.scripts]\nautonomy = "autonomy.cli:run"\n\n'
        '[tool.setuptools.packages.find]\ninclude = ["autonomy*"]\n\n'
        '[tool.setuptools.package-data]\n"autonomy.emulator" = ["worlds/*.yaml"]\n"autonomy.views" = ["static/*"]\n'
    )


def _package_files() -> list[tuple[str, bytes]]:
    """Every file of the ``autonomy`` package (no caches), as (path in the zip, bytes)."""
    root = resources.files("autonomy")
    out = []

    def walk(folder: object, prefix: str) -> None:
        for item in sorted(folder.iterdir(), key=lambda entry: entry.name):  # type: ignore[attr-defined]
            if item.name == "__pycache__" or item.name.endswith((".pyc", ".pyo")):
                continue
            if item.is_dir():
                walk(item, f"{prefix}{item.name}/")
            else:
                out.append((f"package/autonomy/{prefix}{item.name}", item.read_bytes()))

    walk(root, "")
    return out


def build_autograder(exercise: Exercise, exercise_path: Path, secret: bytes | None = None) -> bytes:
    """The autograder zip for ``exercise`` (read from ``exercise_path``), its hidden seeds drawn from ``secret``.

    Raises:
        AutograderError: the exercise's world, or its robot profile, is a file that does not lie beside it (or below).
    """
    files: list[tuple[str, bytes]] = [
        ("setup.sh", SETUP.encode()),
        (
            "run_autograder",
            RUN.format(exercise=exercise_path.name, secret=" --secret-file ../secret.txt" if secret else "").encode(),
        ),
        ("package/pyproject.toml", _pyproject().encode()),
        *_package_files(),
        (f"exercise/{exercise_path.name}", exercise_path.read_bytes()),
    ]
    if exercise.world_ref not in SHIPPED:
        world = Path(exercise.world_ref).resolve()
        try:
            inside = world.relative_to(exercise_path.resolve().parent)
        except ValueError:
            raise AutograderError(
                f"the exercise's world {exercise.world_ref} is not beside it: put the world file in the exercise's "
                "folder (or below it), so that the autograder has it"
            ) from None
        files.append((f"exercise/{inside.as_posix()}", world.read_bytes()))
    if exercise.robot_ref:
        robot = Path(exercise.robot_ref).resolve()
        try:
            inside = robot.relative_to(exercise_path.resolve().parent)
        except ValueError:
            raise AutograderError(
                f"the exercise's robot profile {exercise.robot_ref} is not beside it: put it in the exercise's "
                "folder (or below it), so that the autograder has it"
            ) from None
        files.append((f"exercise/{inside.as_posix()}", robot.read_bytes()))
    if secret:
        files.append(("secret.txt", secret + b"\n"))
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, data in files:
            info = zipfile.ZipInfo(name, date_time=(2026, 1, 1, 0, 0, 0))  # the same bytes for the same inputs
            info.external_attr = (0o755 if name in ("setup.sh", "run_autograder") else 0o644) << 16
            info.compress_type = zipfile.ZIP_DEFLATED
            archive.writestr(info, data)
    return out.getvalue()


def to_gradescope(exercise: Exercise, report: Report) -> str:
    """One submission's marks as Gradescope's autograder results (``results.json``).

    Each criterion is a test (``name``, ``score``, ``max_score``, ``output``: each seed's line,
    ``visibility``); a teacher's correction is a test of its own; the student's whole feedback is
    the ``output``; the top-level ``score`` is the mark, corrections included.
    """
    report = for_the_student(report)  # Gradescope shows it to the student
    tests: list[dict[str, Any]] = []
    for index, criterion in enumerate(exercise.criteria):
        if report.problems:
            output = "Not graded: " + " | ".join(printable(p) for p in report.problems)
        else:
            output = "\n".join(
                f"{seed.seed}: {'yes' if seed.verdicts[index][0] else 'no'} {printable(seed.verdicts[index][1])}"
                for seed in report.seeds
            )
        tests.append(
            {
                "name": printable(criterion.shown),
                "score": report.marks[index],
                "max_score": criterion.points,
                "output": output,
                "visibility": "visible",
            }
        )
    for points, reason in report.adjustments:
        tests.append(
            {
                "name": "Correction by the teacher",
                "score": points,
                "max_score": 0,
                "output": printable(reason),
                "visibility": "visible",
            }
        )
    document = {
        "score": report.total,
        "output": "\n".join(feedback(exercise, report)),
        "visibility": "visible",
        "stdout_visibility": "hidden",
        "tests": tests,
    }
    return json.dumps(document, indent=1, ensure_ascii=False) + "\n"

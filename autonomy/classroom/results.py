"""What grading gives: each seed's run, each student's report, and where their files go.

Plain data that every output reads (the CSV, JSON and HTML reports, the gradebook, the feedback
pages, the live class): this module imports nothing else of the classroom's, so the outputs never
import the graders, nor the graders the outputs' data.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any


@dataclass
class SeedResult:
    """One submission's run on one seed.

    Attributes:
        seed: The seed's label (``seed 3``).
        outcome: How the run ended.
        time_s: How long it ran, simulated seconds.
        verdicts: For each criterion, in the exercise's order: (held, the one-line account).
        shares: For each criterion, the share of its points this run earns (0..1).
        path: The true path, at most 400 points (x_mm, y_mm), where the robot came to rest last.
        collisions: Each collision: (time_s, x_mm, y_mm, speed_mm_s: how hard it hit).
        beeps: Each beep that sounded: (time_s, x_mm, y_mm).
        turns: Each turn in place: (time_s, x_mm, y_mm, degrees, left positive).
        rest_s: When the robot came to rest for good (None: it never did).
        world_seed: The seed the world was drawn with (what it varies, and the start).
        trace: Where the run's trace was kept (``--traces``), else empty.
        lost_while: For each criterion not held in full, the type of the node that was running when it was
            lost (``move``), as its line names it; empty where it held or no node is named.
    """

    seed: str
    outcome: str
    time_s: float
    verdicts: list[tuple[bool, str]]
    shares: list[float] = field(default_factory=list)
    path: list[tuple[float, float]] = field(default_factory=list)
    collisions: list[tuple[float, ...]] = field(default_factory=list)
    beeps: list[tuple[float, float, float]] = field(default_factory=list)
    turns: list[tuple[float, float, float, float]] = field(default_factory=list)
    rest_s: float | None = None
    world_seed: int = 0
    trace: str = ""
    lost_while: list[str] = field(default_factory=list)


@dataclass
class Report:
    """One student's marks.

    Attributes:
        student: The file's or folder's name.
        file: The mission file graded (empty when none was found).
        total: The marks scored.
        max_points: The most that could be scored.
        marks: Each criterion's mark: its points times its mean share over the seeds.
        problems: Why it was not graded (``FILE:LINE:COL`` lines, or a reason), else empty.
        seeds: Each seed's run.
        notes: What the student should know that cost no marks (a ``world:`` of their own, not used).
        adjustments: The teacher's corrections, (points, reason), already in ``total``.
        shape: The tree's shape, numbers and names left out (what similar submissions are told by;
            not written out in reports).
        cpu_s: The CPU time its grading took, seconds (what the class's server tells a long grading by;
            not written out in reports, nor compared: it differs a little from one grading to the next).
    """

    student: str
    file: str
    total: float
    max_points: float
    marks: list[float]
    problems: list[str] = field(default_factory=list)
    seeds: list[SeedResult] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    adjustments: list[tuple[float, str]] = field(default_factory=list)
    shape: list[str] = field(default_factory=list)
    cpu_s: float = field(default=0.0, compare=False)

    def to_json(self) -> dict[str, Any]:
        """The report as plain JSON (tuples as lists), its tree's shape left out."""
        out = asdict(self)
        del out["shape"], out["cpu_s"]
        return out

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Report:
        """The report :meth:`to_json` wrote (its tree's shape, left out there, is empty)."""
        seeds = [
            SeedResult(
                **{
                    **seed,
                    "verdicts": [tuple(v) for v in seed["verdicts"]],
                    "path": [tuple(p) for p in seed["path"]],
                    "collisions": [tuple(c) for c in seed["collisions"]],
                    "beeps": [tuple(b) for b in seed["beeps"]],
                    "turns": [tuple(t) for t in seed["turns"]],
                }
            )
            for seed in data["seeds"]
        ]
        return cls(**{**data, "seeds": seeds, "adjustments": [tuple(a) for a in data["adjustments"]]})


def file_names(students: Iterable[str]) -> dict[str, str]:
    """Each student's name as a file's, no two alike even where case is not told apart.

    Letters, digits and ``-_.`` are kept, the rest become ``_``; a name that would then be
    another's (``frank o'neil`` and ``frank_o_neil``) gets ``-2``, ``-3``... in the students' order.
    """
    out: dict[str, str] = {}
    taken: set[str] = set()
    for student in sorted(set(students)):
        base = "".join(c if c.isalnum() or c in "-_." else "_" for c in student).strip(".") or "student"
        name, count = base, 1
        while name.lower() in taken:
            count += 1
            name = f"{base}-{count}"
        taken.add(name.lower())
        out[student] = name
    return out


def page_path(folder: Path, name: str) -> Path:
    """Where ``--feedback`` writes one student's page: ``FOLDER/NAME.html`` (``NAME`` from :func:`file_names`)."""
    return folder / f"{name}.html"

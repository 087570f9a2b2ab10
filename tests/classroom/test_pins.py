"""Behaviours a change could alter with every other test still passing, each pinned where it is promised."""

from __future__ import annotations

import pytest

from autonomy.classroom.exercise import Criterion, load_exercise
from autonomy.classroom.facts import SUCCEEDED, RunFacts
from autonomy.classroom.judge import judge
from autonomy.record import Pose
from tests.views.conftest import ROOT

GARAGE = load_exercise(ROOT / "exercises" / "garage.yaml")  # its garage: x from 2,240 to 2,400 mm, y from 420 to 780
END_IN_GARAGE = Criterion("end_in_zone", "garage", 5.0, {}, "end_in_zone garage")


def ended_at(x_mm: float, y_mm: float) -> RunFacts:
    """A run that ended on its own, at rest at (x_mm, y_mm)."""
    path = [(0.0, Pose(500.0, 600.0, 0.0)), (5.0, Pose(x_mm, y_mm, 0.0))]
    return RunFacts(1, SUCCEEDED, "", 5.0, path, [], [], [], 5.0, 30.0)


@pytest.mark.parametrize(
    "x_mm, held, said",
    [
        (2320.0, True, "ended inside it"),
        (2400.0, True, "ended inside it"),  # on its edge
        (2401.0, False, "1 mm outside it"),
        (2460.0, False, "60 mm outside it"),  # 6 cm out is out
        (2180.0, False, "60 mm outside it"),
    ],
)
def test_end_in_zone_holds_inside_the_zone_and_its_edge_and_nowhere_else(x_mm, held, said):
    verdict = judge(END_IN_GARAGE, ended_at(x_mm, 600.0), GARAGE.world)
    assert verdict.held is held and said in verdict.line, verdict.line

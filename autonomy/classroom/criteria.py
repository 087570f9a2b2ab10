"""The kinds of criteria an exercise may mark, each with its parameters (docs/exercises.md)."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class CriterionKind:
    """One kind of criterion: its key, what its value is, its options and their defaults.

    Attributes:
        key: The key that names it in a criteria item (``end_in_zone``).
        value: ``zone`` (a zone of the world), ``zones`` (a list of them), ``count`` (a whole
            number >= 0), ``seconds``, ``mm``, ``degrees`` or ``true`` (the value must be true).
        summary: What it asks, for the docs.
        options: Further keys it takes, with their defaults: a number, or a zone's name (a text).
    """

    key: str
    value: str
    summary: str
    options: dict[str, float | str] = field(default_factory=dict)


CRITERIA = {
    kind.key: kind
    for kind in (
        CriterionKind("reach_zone", "zone", "the robot's centre is in the zone at some moment"),
        CriterionKind(
            "visit_in_order",
            "zones",
            "the robot's centre is in each zone in turn, in the order given; each zone is its share",
        ),
        CriterionKind(
            "rest_in_zone",
            "zone",
            "the robot comes to rest for good inside the zone within the time limit (after the zone 'after', if "
            "set); within near_mm of it, without a collision, earns a part, less the further out",
            {"after": "", "near_mm": 0.0},
        ),
        CriterionKind("end_in_zone", "zone", "the mission ends on its own and the robot comes to rest inside the zone"),
        CriterionKind("avoid_zone", "zone", "the robot's centre never enters the zone"),
        CriterionKind(
            "max_collisions",
            "count",
            "at most this many collisions (with the obstacle with: names only; with the robot's centre in zone at:)",
            {"with": "", "at": ""},
        ),
        CriterionKind(
            "min_collisions",
            "count",
            "at least this many collisions (with the obstacle with: names only; with the robot's centre in zone at:)",
            {"with": "", "at": ""},
        ),
        CriterionKind("finish_within_s", "seconds", "the mission succeeds within this many seconds"),
        CriterionKind("max_distance_mm", "mm", "the robot drives at most this far, forward and back"),
        CriterionKind(
            "beeps_in",
            "zones",
            "a beep at each zone (each its share), and no more than extra_beeps more, anywhere (else nothing)",
            {"within_mm": 0.0, "extra_beeps": 0.0},
        ),
        CriterionKind(
            "beep_near", "zone", "a beep while the robot's centre is within within_mm of the zone", {"within_mm": 0.0}
        ),
        CriterionKind(
            "end_heading_deg", "degrees", "the robot ends facing this heading, give or take", {"tolerance_deg": 10.0}
        ),
        CriterionKind(
            "turns",
            "degrees",
            "the robot turns in place by this much (left positive, as a heading changes), at least count times "
            "(only at least after_drive_mm from where it turned before, in a straight line, if set)",
            {"count": 1.0, "tolerance_deg": 10.0, "after_drive_mm": 0.0},
        ),
        CriterionKind("max_nodes", "count", "the mission's tree has at most this many nodes"),
        CriterionKind("succeed", "true", "the mission succeeds (does not fail, crash or run out of time)"),
    )
}

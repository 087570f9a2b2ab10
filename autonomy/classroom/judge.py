"""Judging one run against an exercise's criteria, from its tick records alone.

Every criterion is decided from what the records say (the emulator's truth pose, the
collision events, the commands on the wire, the end record), so a trace file can be judged
again later, with the same verdicts: it holds the run's numbers in full. (A trace of record
version 1 held times to 0.1 ms and poses to 0.1 mm: a pose within 0.05 mm of a zone's edge
could be judged the other way.)
Each verdict says in one line what happened, with numbers: ``garage: ended 35 mm outside
(needed inside)``, ``collisions: 3, allowed 0``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from autonomy.classroom.exercise import Criterion
from autonomy.emulator.world import World
from autonomy.protocol import heading_delta_deg
from autonomy.record import Pose, Record, RunEnd, RunHeader, TickRecord
from autonomy.runner import plural

SUCCEEDED = "succeeded"
FAILED = "failed"


@dataclass(frozen=True)
class Verdict:
    """Whether a criterion held on one run, and what happened, in one line."""

    held: bool
    line: str


@dataclass
class RunFacts:
    """What the judge needs of one run, gathered from its records.

    Attributes:
        nodes: How many nodes the tree has.
        outcome: The end record's outcome (``succeeded``, ``failed``...).
        reason: The end record's reason.
        time_s: How long the run took.
        path: The true pose at every tick, then at the end (time, pose).
        beeps: The true pose whenever a beep was accepted (time, pose).
        collisions: The times of the collisions.
        distance_mm: How far the robot drove, by its odometer.
    """

    nodes: int
    outcome: str
    reason: str
    time_s: float
    path: list[tuple[float, Pose]]
    beeps: list[tuple[float, Pose]]
    collisions: list[float]
    distance_mm: float


class Gatherer:
    """A listener that gathers a run's facts as its records come (a live run's, or a trace's).

    Nothing of a record is kept but what the judge needs, so grading a long run does not hold
    all its records. :meth:`facts` gives what was gathered once the run has ended.
    """

    def __init__(self) -> None:
        self._header: RunHeader | None = None
        self._end: RunEnd | None = None
        self._no_truth = False
        self._path: list[tuple[float, Pose]] = []
        self._beeps: list[tuple[float, Pose]] = []
        self._collisions: list[float] = []

    def __call__(self, record: Record) -> None:
        """Takes one record."""
        if not isinstance(record, TickRecord):
            if isinstance(record, RunHeader) and self._header is None:
                self._header = record
            elif isinstance(record, RunEnd) and self._end is None:
                self._end = record
            return
        truth, time_s = record.truth, record.time_s
        if truth is None:
            self._no_truth = True
            return
        self._path.append((time_s, truth))
        for exchange in record.wire:
            if exchange.reply == "OK" and exchange.sent.startswith("S"):
                self._beeps.append((time_s, truth))
                break
        if record.events:
            self._collisions += [time_s for e in record.events if e.kind == "collision"]

    def facts(self) -> RunFacts:
        """The run's facts.

        Raises:
            ValueError: the records held no header or end, or no truth pose (the run was not on
                the built-in emulator, so nothing can be judged).
        """
        header, end = self._header, self._end
        if header is None or end is None:
            raise ValueError("a run to judge needs its header and its end record")
        if self._no_truth or (end.truth is None and not self._path):
            raise ValueError("the run has no truth pose: only runs on the built-in emulator can be judged")
        path = self._path + ([(end.time_s, end.truth)] if end.truth is not None else [])
        return RunFacts(
            nodes=len(header.nodes),
            outcome=end.outcome,
            reason=end.reason,
            time_s=end.time_s,
            path=path,
            beeps=list(self._beeps),
            collisions=list(self._collisions),
            distance_mm=float(end.summary.get("distance_mm", 0)),
        )


def gather(records: Iterable[Record]) -> RunFacts:
    """Collects a run's facts from its records (a live run's, or a trace's): see :class:`Gatherer`.

    Raises:
        ValueError: the records hold no header or end, or no truth pose (the run was not on
            the built-in emulator, so nothing can be judged).
    """
    gatherer = Gatherer()
    for record in records:
        gatherer(record)
    return gatherer.facts()


def judge(criterion: Criterion, facts: RunFacts, world: World) -> Verdict:
    """Whether ``criterion`` held on the run ``facts`` describe, in ``world``."""
    kind, value = criterion.kind, criterion.value
    end_time, end_pose = facts.path[-1]
    if kind in ("reach_zone", "end_in_zone", "avoid_zone", "beep_near"):
        zone = world.zone(value)
        if zone is None:
            return Verdict(False, f"{value}: the world has no such zone")
        if kind == "reach_zone":
            inside = next((t for t, p in facts.path if zone.contains(p.x_mm, p.y_mm)), None)
            if inside is not None:
                return Verdict(True, f"{value}: reached at {inside:.1f} s")
            closest, _, pose = min((zone.distance_mm(p.x_mm, p.y_mm), t, p) for t, p in facts.path)
            toward = bearing(pose.x_mm, pose.y_mm, *zone.shape.nearest(pose.x_mm, pose.y_mm))
            return Verdict(
                False,
                f"{value}: never reached, {_mm(closest)} {toward} of where the robot came closest "
                f"({pose.x_mm:.0f}, {pose.y_mm:.0f} mm)",
            )
        if kind == "avoid_zone":
            inside = next((t for t, p in facts.path if zone.contains(p.x_mm, p.y_mm)), None)
            if inside is None:
                return Verdict(True, f"{value}: never entered")
            return Verdict(False, f"{value}: entered at {inside:.1f} s (needed never)")
        if kind == "beep_near":
            radius = criterion.options["within_mm"]
            if not facts.beeps:
                return Verdict(False, f"beep near {value}: no beep at all")
            gaps = [(zone.distance_mm(p.x_mm, p.y_mm), t) for t, p in facts.beeps]
            near = next(((g, t) for g, t in gaps if g <= radius), None)
            if near is not None:
                where = "inside it" if near[0] <= 1e-6 else f"{_mm(near[0])} from it"
                return Verdict(True, f"beep near {value}: beeped {where} at {near[1]:.1f} s")
            nearest = min(g for g, _ in gaps)
            return Verdict(
                False, f"beep near {value}: nearest beep {nearest:.0f} mm from it (needed within {radius:g} mm)"
            )
        # end_in_zone
        gap = zone.distance_mm(end_pose.x_mm, end_pose.y_mm)
        if facts.outcome not in (SUCCEEDED, FAILED):
            where = "inside" if gap <= 0 else f"{gap:.0f} mm outside"
            return Verdict(False, f"{value}: the mission did not end on its own ({facts.outcome}), {where}")
        if gap <= 1e-6:
            return Verdict(True, f"{value}: ended inside")
        return Verdict(False, f"{value}: ended {gap:.0f} mm outside (needed inside)")
    if kind == "max_collisions":
        count = len(facts.collisions)
        first = f", the first at {facts.collisions[0]:.1f} s" if facts.collisions else ""
        return Verdict(count <= value, f"collisions: {count}, allowed {value}{first}")
    if kind == "finish_within_s":
        if facts.outcome != SUCCEEDED:
            why = f": {facts.reason}" if facts.reason else ""
            return Verdict(False, f"did not succeed ({facts.outcome} after {facts.time_s:.1f} s{why})")
        return Verdict(facts.time_s <= value, f"succeeded in {facts.time_s:.1f} s, allowed {value:g} s")
    if kind == "max_distance_mm":
        return Verdict(facts.distance_mm <= value, f"drove {facts.distance_mm:,.0f} mm, allowed {value:,.0f} mm")
    if kind == "end_heading_deg":
        tolerance = criterion.options["tolerance_deg"]
        heading = end_pose.heading_deg % 360.0
        error = abs(heading_delta_deg(value, heading))
        shown = round(heading) % 360  # 359.7 is shown as 0, as a compass would
        return Verdict(
            error <= tolerance, f"ended facing {shown} deg, needed {value:g} ± {tolerance:g} (off by {error:.0f})"
        )
    if kind == "max_nodes":
        return Verdict(facts.nodes <= value, f"uses {plural(facts.nodes, 'node')}, allowed {value}")
    if kind == "succeed":
        why = f": {facts.reason}" if facts.reason else ""
        return Verdict(facts.outcome == SUCCEEDED, f"the mission {facts.outcome} after {facts.time_s:.1f} s{why}")
    return Verdict(False, f"unknown criterion {kind}")


#: The eight points of the compass, counter-clockwise from east (+x), as the world's headings go.
_COMPASS = ("east", "north-east", "north", "north-west", "west", "south-west", "south", "south-east")


def _mm(distance_mm: float) -> str:
    """A distance as a student reads it: ``35 mm``, or ``less than 1 mm`` (never ``0 mm`` for a miss)."""
    return "less than 1 mm" if distance_mm < 0.5 else f"{distance_mm:.0f} mm"


def bearing(from_x_mm: float, from_y_mm: float, to_x_mm: float, to_y_mm: float) -> str:
    """Which way ``to`` lies from ``from``, as one of the eight points of the compass (north is +y)."""
    angle_deg = math.degrees(math.atan2(to_y_mm - from_y_mm, to_x_mm - from_x_mm)) % 360.0
    return _COMPASS[round(angle_deg / 45.0) % 8]


def path_points(facts: RunFacts, most: int = 400) -> list[tuple[float, float]]:
    """The true path as at most ``most`` points (x_mm, y_mm), rounded to 1 mm, the last always kept."""
    poses = [p for _, p in facts.path]
    step = max(1, math.ceil(len(poses) / most))
    kept = poses[::step]
    if poses and kept[-1] is not poses[-1]:
        kept.append(poses[-1])
    return [(round(p.x_mm), round(p.y_mm)) for p in kept]

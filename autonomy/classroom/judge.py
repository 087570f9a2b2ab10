"""Judging one run against an exercise's criteria, from what really happened.

Every criterion is decided from the emulator's own account of the run, never from what the
mission happened to read: the robot's true path (where it was whenever its motion changed,
so the straight drives and turns in place between are known exactly, however often the
mission looked), each impact the emulator recorded, and where the robot was at each beep.
The run is judged where the robot came to rest: once the mission has ended and the robot has
been told to stop, the emulator runs on until it stands still, so a robot that ends at full
speed rolls on, and whatever it then hits counts. The mission's tick rate, and how it saw two
impacts close together, change nothing of this.

Each verdict says in one line what happened, with numbers: ``garage: came to rest 35 mm
outside it (needed inside)``, ``collisions: 3, allowed 0``. A criterion over several zones
(``visit_in_order``, ``beeps_in``) holds in part: each zone is its share.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import pairwise

from autonomy.classroom.criteria import Criterion
from autonomy.classroom.facts import FAILED, SETTLE_MOST_S, STILL_AT_LIMIT_S, SUCCEEDED, Beep, RunFacts
from autonomy.classroom.told import bearing, contact_text, either, got_there, hit, listed, mm, stopped_by, while_running
from autonomy.emulator.world import ROBOT_RADIUS_MM, World, Zone
from autonomy.protocol import heading_delta_deg
from autonomy.record import Pose
from autonomy.words import plural


@dataclass(frozen=True)
class Verdict:
    """How far a criterion held on one run, and what happened, in one line.

    Attributes:
        held: Whether it held in full.
        line: What happened.
        share: The share of its points it earns on this run, 0..1 (1 when it held).
    """

    held: bool
    line: str
    share: float = -1.0

    def __post_init__(self) -> None:
        if self.share < 0.0:
            object.__setattr__(self, "share", 1.0 if self.held else 0.0)


# ---------------------------------------------------------------------------- the path and zones


def _first_inside(zone: Zone, path: list[tuple[float, Pose]], after: float = 0.0) -> float | None:
    """Where along the path (segment index plus fraction) the robot is first in ``zone``, at ``after`` or later."""
    if not path:
        return None
    if len(path) == 1:
        pose = path[0][1]
        return 0.0 if zone.contains(pose.x_mm, pose.y_mm) else None
    first = int(after)
    for index in range(min(first, len(path) - 2), len(path) - 1):
        a, b = path[index][1], path[index + 1][1]
        start = after - index if index == first else 0.0
        ax, ay = a.x_mm + (b.x_mm - a.x_mm) * start, a.y_mm + (b.y_mm - a.y_mm) * start
        entered = zone.shape.entry(ax, ay, b.x_mm, b.y_mm)
        if entered is not None:
            return index + start + (1.0 - start) * entered
    return None


def _time_at(path: list[tuple[float, Pose]], where: float) -> float:
    """The time at a place along the path (segment index plus fraction), between its ends' times."""
    index = min(int(where), len(path) - 1)
    if index >= len(path) - 1:
        return path[-1][0]
    fraction = where - index
    return path[index][0] + (path[index + 1][0] - path[index][0]) * fraction


def _closest(zone: Zone, path: list[tuple[float, Pose]]) -> tuple[float, float, float]:
    """(gap, x, y): where the path came closest to ``zone``, and how far from it."""
    if len(path) == 1:
        pose = path[0][1]
        return zone.distance_mm(pose.x_mm, pose.y_mm), pose.x_mm, pose.y_mm
    return min(zone.shape.segment_nearest(a.x_mm, a.y_mm, b.x_mm, b.y_mm) for (_, a), (_, b) in pairwise(path))


def _missed(zone: Zone, path: list[tuple[float, Pose]], name: str) -> str:
    """``corner_2 is 370 mm north-east of where the robot came closest (1130, 880 mm)``."""
    gap, x, y = _closest(zone, path)
    toward = bearing(x, y, *zone.shape.nearest(x, y))
    return f"{name} is {mm(gap)} {toward} of where the robot came closest ({x:.0f}, {y:.0f} mm)"


def _beep_zones(beeps: list[Beep], zones: list[Zone], within_mm: float) -> list[list[int]]:
    """For each beep, the indexes of the zones it was at (within ``within_mm`` of)."""
    return [
        [i for i, zone in enumerate(zones) if zone.distance_mm(b.pose.x_mm, b.pose.y_mm) <= within_mm + 1e-6]
        for b in beeps
    ]


def _counted_beeps(criterion: Criterion, facts: RunFacts) -> tuple[list[Beep], str]:
    """The beeps a beep criterion counts (those that sounded; made standing, with ``standing``), and why others not.

    Returns:
        The beeps, and what the line adds of those left out (``; 2 silent beeps (volume 0) not counted``).
    """
    standing = bool(criterion.options.get("standing"))
    silent = len(facts.beeps) - len(facts.sounded)
    counted = [b for b in facts.sounded if not (standing and b.moving)]
    moving = len(facts.sounded) - len(counted)
    told = []
    if silent:
        told.append(f"{plural(silent, 'silent beep')} (volume 0)")
    if moving:
        told.append(f"{plural(moving, 'beep')} made while driving or turning")
    return counted, (f"; {' and '.join(told)} not counted at a zone" if told else "")


# ---------------------------------------------------------------------------- the criteria


def judge(criterion: Criterion, facts: RunFacts, world: World) -> Verdict:
    """How far ``criterion`` held on the run ``facts`` describe, in ``world``."""
    kind, value = criterion.kind, criterion.value
    if kind in ("visit_in_order", "beeps_in"):
        zones = [world.zone(name) for name in value]
        if any(zone is None for zone in zones):
            return Verdict(False, f"{', '.join(value)}: the world lacks one of these zones")
        return (_visits if kind == "visit_in_order" else _beeps_in)(criterion, facts, [z for z in zones if z])
    if kind in ("reach_zone", "end_in_zone", "rest_in_zone", "avoid_zone", "beep_near", "stop_in_zone"):
        zone = world.zone(value)
        if zone is None:
            return Verdict(False, f"{value}: the world has no such zone")
        return _zone_verdict(criterion, facts, zone, world)
    end_pose = facts.path[-1][1]
    if kind in ("max_collisions", "min_collisions"):
        return _collision_verdict(criterion, facts, world)
    if kind == "finish_within_s":
        if facts.outcome != SUCCEEDED:
            why = f": {facts.reason}" if facts.reason else ""
            during = while_running(facts, facts.time_s)
            return Verdict(False, f"did not succeed ({facts.outcome} after {facts.time_s:.1f} s{why}){during}")
        if facts.time_s > value:
            return Verdict(
                False, f"succeeded in {facts.time_s:.1f} s, allowed {value:g} s{while_running(facts, value)}"
            )
        return Verdict(True, f"succeeded in {facts.time_s:.1f} s, allowed {value:g} s")
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
    if kind == "turns":
        at = str(criterion.options.get("at") or "")
        zone = world.zone(at) if at else None
        if at and zone is None:
            return Verdict(False, f"{at}: the world has no such zone")
        return _turns(criterion, facts, zone)
    if kind == "rest_distance_ahead_mm":
        return _distance_ahead(criterion, facts, world)
    if kind == "uses_nodes":
        used = [name for name in value if name in facts.node_types]
        if used:
            return Verdict(True, f"uses {listed(used)}")
        return Verdict(False, f"uses none of {either(list(value))} (needed one)")
    if kind == "max_nodes":
        return Verdict(facts.nodes <= value, f"uses {plural(facts.nodes, 'node')}, allowed {value}")
    if kind == "succeed":
        why = f": {facts.reason}" if facts.reason else ""
        during = "" if facts.outcome == SUCCEEDED else while_running(facts, facts.time_s)
        return Verdict(
            facts.outcome == SUCCEEDED, f"the mission {facts.outcome} after {facts.time_s:.1f} s{why}{during}"
        )
    return Verdict(False, f"unknown criterion {kind}")


def _collision_verdict(criterion: Criterion, facts: RunFacts, world: World) -> Verdict:
    """How many collisions: with the obstacle ``with`` names only, and only with the robot's centre in zone ``at``."""
    kind, value = criterion.kind, criterion.value
    wanted, at = str(criterion.options.get("with") or ""), str(criterion.options.get("at") or "")
    over = float(criterion.options.get("over_mm_s") or 0.0)
    zone = world.zone(at) if at else None
    placed = [
        c
        for c in facts.collisions
        if (not wanted or hit(world, c.pose) == wanted) and (zone is None or zone.contains(c.pose.x_mm, c.pose.y_mm))
    ]
    collisions = [c for c in placed if c.speed_mm_s > over]
    what = "collisions" + (f" with {wanted}" if wanted else "") + (f" at {at}" if at else "")
    what += f" faster than {over:g} mm/s" if over else ""
    first = f", the first at {contact_text(collisions[0])}" if collisions else ""
    hardest = max(collisions, key=lambda c: c.speed_mm_s) if len(collisions) > 1 else None
    if hardest is not None and hardest.speed_mm_s > collisions[0].speed_mm_s:
        first += f", the hardest at {contact_text(hardest)}"
    others = len(facts.collisions) - len(placed)
    if others:
        places = sorted({hit(world, c.pose) for c in facts.collisions if c not in placed})
        where = " elsewhere" if at else ""
        first += f" (and {plural(others, 'collision')}{where} with {listed(places)})"
    softer = len(placed) - len(collisions)
    if softer:
        first += f" ({plural(softer, 'touch', 'touches')} at {over:g} mm/s or slower not counted)"
    count = len(collisions)
    if kind == "max_collisions":
        if count > value:  # the collision that was one too many, and the node that was running then
            too_many = collisions[int(value)]
            first += f"; the one too many at {too_many.time_s:.1f} s" if value else ""
            first += while_running(facts, too_many.time_s, collided=True)
        return Verdict(count <= value, f"{what}: {count}, allowed {value}{first}")
    return Verdict(count >= value, f"{what}: {count}, needed at least {value}{first}")


#: Why a near miss earned nothing: the robot rests against what it hit (a bump on the way, backed off from, is no bar).
_NOT_AGAINST = "; a near miss earns a part only for a robot at rest clear of walls and obstacles, stopped by itself)"


def _against(facts: RunFacts) -> bool:
    """Whether the robot rests against a wall or an obstacle, or was stopped by what it hit: no careful near miss."""
    return facts.rest_touching or facts.rest_hit is not None


def _moving_at_limit(facts: RunFacts) -> str:
    """Why a robot caught by the time limit had not come to rest for good."""
    if facts.rest_s is not None and facts.rest_s < facts.time_s - 1e-6:
        stood_s = facts.time_s - facts.rest_s
        return (
            f"the mission was still running when its time ran out ({facts.time_s:g} s), the robot standing only "
            f"{stood_s:.2f} s between two moves (at rest for good needs {STILL_AT_LIMIT_S:g} s at least)"
        )
    return f"the robot was still moving when its time ran out ({facts.time_s:g} s)"


def _near_mm(criterion: Criterion) -> float:
    return float(criterion.options.get("near_mm") or 0.0)


def _near_share(criterion: Criterion, gap_mm: float) -> float:
    """The part of a zone's points a miss by ``gap_mm`` earns: 1 at its edge, none at ``near_mm`` (0: none at all)."""
    near_mm = _near_mm(criterion)
    return max(0.0, 1.0 - gap_mm / near_mm) if near_mm > 0 else 0.0


def _zone_verdict(criterion: Criterion, facts: RunFacts, zone: Zone, world: World) -> Verdict:
    kind, name, path = criterion.kind, zone.name, facts.path
    end_time, end_pose = path[-1]
    if kind == "reach_zone":
        inside = _first_inside(zone, path)
        if inside is not None:
            return Verdict(True, f"{name}: reached at {_time_at(path, inside):.1f} s")
        line = f"{name}: never reached; {_missed(zone, path, name)}"
        share = _near_share(criterion, _closest(zone, path)[0])
        if share > 0:
            line += f": {share:.0%} of its points, for coming within {_near_mm(criterion):g} mm of it"
        return Verdict(False, line, share)
    if kind == "avoid_zone":
        inside = _first_inside(zone, path)
        if inside is None:
            return Verdict(True, f"{name}: never entered")
        entered_s = _time_at(path, inside)
        return Verdict(False, f"{name}: entered at {entered_s:.1f} s (needed never){while_running(facts, entered_s)}")
    if kind == "beep_near":
        radius = float(criterion.options["within_mm"])
        beeps, left_out = _counted_beeps(criterion, facts)
        if not beeps:
            return Verdict(
                False, f"beep at {name}: no beep counted{left_out}" if left_out else f"beep at {name}: no beep at all"
            )
        gaps = [(zone.distance_mm(b.pose.x_mm, b.pose.y_mm), b.time_s) for b in beeps]
        near = next(((g, t) for g, t in gaps if g <= radius + 1e-6), None)
        if near is not None:
            where = "inside it" if near[0] <= 1e-6 else f"{mm(near[0])} from it"
            return Verdict(True, f"beep at {name}: beeped {where} at {near[1]:.1f} s")
        nearest = min(g for g, _ in gaps)
        needed = "inside it" if radius <= 0 else f"within {radius:g} mm"
        return Verdict(False, f"beep at {name}: nearest beep {mm(nearest)} from it (needed {needed}){left_out}")
    if kind == "stop_in_zone":
        return _stop_in(criterion, facts, zone)
    gap = zone.distance_mm(end_pose.x_mm, end_pose.y_mm)
    where = "inside it" if gap <= 1e-6 else f"{mm(gap)} outside it"
    if kind == "end_in_zone":
        if facts.outcome not in (SUCCEEDED, FAILED):
            return Verdict(False, f"{name}: the mission did not end on its own ({facts.outcome}); it stopped {where}")
        if gap <= 1e-6:
            stopped = stopped_by(facts, world)
            return Verdict(not stopped, f"{name}: ended inside it{stopped}" + (got_there(facts) if stopped else ""))
        line = f"{name}: ended {where} (needed inside)"
        share = _near_share(criterion, gap)
        if share > 0 and _against(facts):
            line, share = line[:-1] + _NOT_AGAINST, 0.0
        if share > 0:
            line += f": {share:.0%} of its points, for ending within {_near_mm(criterion):g} mm of it, clear of all"
        return Verdict(False, line + got_there(facts), share)
    # rest_in_zone
    if facts.rest_s is None:
        return Verdict(False, f"{name}: the robot never came to rest (it was still moving {SETTLE_MOST_S:g} s after)")
    if facts.moving_at_time_limit:
        return Verdict(False, f"{name}: {_moving_at_limit(facts)}")
    if facts.rest_s > facts.time_limit_s + 1e-9:
        return Verdict(
            False, f"{name}: came to rest only at {facts.rest_s:.2f} s, after the {facts.time_limit_s:g} s allowed"
        )
    after = str(criterion.options.get("after") or "")
    if gap > 1e-6:
        toward = bearing(end_pose.x_mm, end_pose.y_mm, *zone.shape.nearest(end_pose.x_mm, end_pose.y_mm))
        line = f"{name}: came to rest {mm(gap)} outside it (it lies {toward}; needed inside)"
        share = _near_share(criterion, gap)
        if share > 0 and after:
            earlier = world.zone(after)
            share = share if earlier is not None and _first_inside(earlier, path) is not None else 0.0
        if share > 0 and _against(facts):
            line, share = line[:-1] + _NOT_AGAINST, 0.0
        if share > 0:
            line += f": {share:.0%} of its points, for resting within {_near_mm(criterion):g} mm of it, clear of all"
        return Verdict(False, line + got_there(facts), share)
    if after:
        earlier = world.zone(after)
        if earlier is None or _first_inside(earlier, path) is None:
            return Verdict(False, f"{name}: came to rest inside it, but never after {after} (needed after it)")
    stopped = stopped_by(facts, world)
    if stopped:
        return Verdict(False, f"{name}: came to rest inside it at {facts.rest_s:.1f} s{stopped}{got_there(facts)}")
    return Verdict(True, f"{name}: came to rest inside it at {facts.rest_s:.1f} s")


def _entries(zone: Zone, path: list[tuple[float, Pose]]) -> list[float]:
    """Every place along the path (segment index plus fraction) where the robot comes into ``zone``."""
    first = path[0][1]
    found = [0.0] if zone.contains(first.x_mm, first.y_mm) else []
    for index, ((_, a), (_, b)) in enumerate(pairwise(path)):
        if zone.contains(a.x_mm, a.y_mm):
            continue  # inside already (a straight segment leaves a convex zone once, and comes back in no more)
        entered = zone.shape.entry(a.x_mm, a.y_mm, b.x_mm, b.y_mm)
        if entered is not None:
            found.append(index + entered)
    return found


def _visits(criterion: Criterion, facts: RunFacts, zones: list[Zone]) -> Verdict:
    """The most zones visited in the order given (each missed or out-of-order zone costs its share).

    The zones' visits, in the order they happened, are matched against the order asked for: the
    longest run of visits in that order counts (visiting corner 3 first does not spoil corners 1 and 2).
    """
    path = facts.path
    visits = sorted((at, index) for index, zone in enumerate(zones) for at in _entries(zone, path))
    # longest run of visits whose zones come in the order given: best[k] ends with visits[k]
    best: list[tuple[int, int]] = []  # (length, the visit before it, or -1)
    for k, (_, zone) in enumerate(visits):
        before = [(best[j][0], j) for j in range(k) if visits[j][1] < zone]
        length, previous = max(before) if before else (0, -1)
        best.append((length + 1, previous))
    counted: dict[int, float] = {}
    if best:
        k = max(range(len(best)), key=lambda j: (best[j][0], -j))
        while k >= 0:
            at, zone = visits[k]
            counted[zone] = at
            k = best[k][1]
    parts = []
    for index, zone in enumerate(zones):
        if index in counted:
            parts.append(f"{zone.name} at {_time_at(path, counted[index]):.1f} s")
        elif any(z == index for _, z in visits):
            at = next(a for a, z in visits if z == index)
            parts.append(f"{zone.name} only out of order, at {_time_at(path, at):.1f} s")
        else:
            parts.append(f"{zone.name} never: {_missed(zone, path, zone.name)}")
    hit = len(counted)
    return Verdict(hit == len(zones), f"in order, {hit} of {len(zones)}: " + "; ".join(parts), hit / len(zones))


def _beeps_in(criterion: Criterion, facts: RunFacts, zones: list[Zone]) -> Verdict:
    """A beep at each zone, and at most ``extra_beeps`` more: a beep counts for the zone it is at, the first there.

    Any other beep is an extra one: elsewhere, or again at a zone that had its beep.
    """
    within = float(criterion.options["within_mm"])
    allowed = int(criterion.options["extra_beeps"])
    beeps, left_out = _counted_beeps(criterion, facts)
    at = _beep_zones(beeps, zones, within)
    beeped: list[int] = []
    extra = len(facts.sounded) - len(beeps)  # a beep made while driving is no beep at a zone, but a beep all the same
    for found in at:
        new = [i for i in found if i not in beeped]
        if new:
            beeped.append(new[0])  # zones do not overlap in a sensible exercise; if they do, the first
        else:
            extra += 1
    beeped.sort()
    names = [zones[i].name for i in beeped]
    missing = [zone for i, zone in enumerate(zones) if i not in beeped]
    parts = [f"beeped at {listed(names)}" if names else "no beep at any of them"]
    for zone in missing:
        if beeps:
            gap, pose = min(((zone.distance_mm(b.pose.x_mm, b.pose.y_mm), b.pose) for b in beeps), key=lambda g: g[0])
            toward = bearing(pose.x_mm, pose.y_mm, *zone.shape.nearest(pose.x_mm, pose.y_mm))
            parts.append(f"none at {zone.name} (it is {mm(gap)} {toward} of the nearest beep)")
        else:
            parts.append(f"none at {zone.name}")
    over = extra > allowed
    parts.append(f"{plural(extra, 'extra beep')}, allowed {allowed}" + (": no points for beeps" if over else ""))
    share = 0.0 if over else len(beeped) / len(zones)
    return Verdict(share >= 1.0, "; ".join(parts) + left_out, share)


def _turn_text(degrees: float) -> str:
    """``left 90``, ``right 45``: a turn as a heading's change, within a half-turn either way."""
    wrapped = (degrees + 180.0) % 360.0 - 180.0
    if round(abs(wrapped)) == 180:  # a half-turn: the way it was turned (wrapping alone says right for 180 left)
        wrapped = math.copysign(180.0, degrees)
    return f"{'left' if wrapped >= 0 else 'right'} {abs(wrapped):.0f}"


def _turns(criterion: Criterion, facts: RunFacts, zone: Zone | None = None) -> Verdict:
    """Turns in place by the criterion's degrees, give or take its tolerance, as a change of heading.

    With ``after_drive_mm``, a turn counts only that far (in a straight line) from where the robot
    turned before, or started: at the end of a side, not after a drive out and back again.

    A turn is the change of heading at one place (turns there one after another add up), taken
    within a half-turn either way: 450 degrees left is a quarter-turn left, as the path sees it.
    """
    wanted, tolerance = float(criterion.value), float(criterion.options["tolerance_deg"])
    count, after_mm = int(criterion.options["count"]), float(criterion.options.get("after_drive_mm") or 0.0)
    turns = [t for t in facts.turns if zone is None or zone.contains(t.x_mm, t.y_mm)]
    matching = [t for t in turns if abs(heading_delta_deg(wanted, t.degrees)) <= tolerance and t.away_mm >= after_mm]
    asked = f"{_turn_text(wanted)} ± {tolerance:g} degrees" + (f" after a drive of {after_mm:g} mm" if after_mm else "")
    asked += f" at {zone.name}" if zone is not None else ""
    found = f"turned {asked} {plural(len(matching), 'time')}, needed {count}"
    others = [t for t in turns if t not in matching]
    if others:
        found += f" (its other turns: {', '.join(_turn_text(t.degrees) for t in others[:6])}" + (
            ", ...)" if len(others) > 6 else ")"
        )
    share = min(1.0, len(matching) / count) if count else 1.0
    return Verdict(share >= 1.0, found, share)


def _stop_in(criterion: Criterion, facts: RunFacts, zone: Zone) -> Verdict:
    """The robot stood still with its centre in the zone for at least ``for_s``, at some time of its run."""
    need_s = float(criterion.options["for_s"])
    stops = [s for s in facts.stills if not s.stopped_by_impact]  # where a wall stopped it is no stop of its own
    inside = [s for s in stops if zone.contains(s.pose.x_mm, s.pose.y_mm)]
    long_enough = [s for s in inside if s.duration_s >= need_s - 1e-9]
    if long_enough:
        first = long_enough[0]
        how = "for good" if first.end_s == math.inf else f"for {first.duration_s:.1f} s"
        return Verdict(True, f"{zone.name}: stopped in it at {max(0.0, first.start_s):.1f} s, {how}")
    if inside:
        longest = max(s.duration_s for s in inside)
        return Verdict(False, f"{zone.name}: stood in it {longest:.1f} s at most (needed {need_s:g} s)")
    if stops:
        gap, still = min(((zone.distance_mm(s.pose.x_mm, s.pose.y_mm), s) for s in stops), key=lambda g: g[0])
        toward = bearing(still.pose.x_mm, still.pose.y_mm, *zone.shape.nearest(still.pose.x_mm, still.pose.y_mm))
        return Verdict(
            False, f"{zone.name}: never stopped in it; the nearest stop was {mm(gap)} from it (it lies {toward})"
        )
    return Verdict(False, f"{zone.name}: the robot never stopped")


def _distance_ahead(criterion: Criterion, facts: RunFacts, world: World) -> Verdict:
    """At rest for good within the time limit, with what lies straight ahead between the range's two distances."""
    low, high = criterion.value
    if facts.rest_s is None:
        return Verdict(False, "the robot never came to rest")
    if facts.moving_at_time_limit:
        return Verdict(False, _moving_at_limit(facts))
    if facts.rest_s > facts.time_limit_s + 1e-9:
        return Verdict(False, f"came to rest only at {facts.rest_s:.2f} s, after the {facts.time_limit_s:g} s allowed")
    pose = facts.path[-1][1]
    rad = math.radians(pose.heading_deg)
    front_x, front_y = pose.x_mm + ROBOT_RADIUS_MM * math.cos(rad), pose.y_mm + ROBOT_RADIUS_MM * math.sin(rad)
    ahead = world.cone_distance(front_x, front_y, pose.heading_deg, 0.0)
    shown = "nothing" if not math.isfinite(ahead) else f"{ahead:.0f} mm"
    needed = f"needed {low:g} to {high:g} mm"
    held = low - 1e-6 <= ahead <= high + 1e-6
    stopped = stopped_by(facts, world)
    line = f"came to rest with {shown} ahead of its front ({needed}){stopped}"
    if not held or stopped:
        line += got_there(facts)
    return Verdict(held and not stopped, line)

"""The emulator's world: a walled arena, box and circle obstacles, named zones, a start pose.

Coordinates are millimetres with the origin at the arena's lower-left corner, x to the
right, y up. Headings are degrees from the +x axis, growing counter-clockwise (left).
Worlds are small YAML files (docs/worlds.md); the ones shipped with the package are found by
name. A world file is checked like a mission: every problem at once, as ``FILE:LINE:COL``.
"""

from __future__ import annotations

import functools
import math
import random
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, ClassVar, NamedTuple

import yaml

from autonomy.errors import AutonomyError
from autonomy.source import (
    Located,
    Problem,
    Reader,
    UnreadableFile,
    control_character,
    exists,
    is_file,
    parse,
    read_text,
    suggest,
)

EPSILON_MM = 1e-6
#: The footprint the start pose is checked with (the emulated robot's ``body_radius_mm``).
ROBOT_RADIUS_MM = 60.0
#: The front sensor's field of view, degrees across: it reads the nearest thing in this cone.
SENSOR_CONE_DEG = 25.0
#: How many rays sample that cone (one along the heading, the rest spread evenly).
SENSOR_RAYS = 7
#: The cells the sensor's search for nearby obstacles is sorted into: mm a side, and most a side.
NEAR_CELL_MM = 100.0
NEAR_CELLS = 64
#: How many reaches' cells a world keeps, the last asked for (a run asks with one).
MOST_REACHES = 8
#: How far past a cone's edge a shape must lie for the cone's rays to be known to miss it, mm: far
#: more than any rounding of a ray's distance, and less than anything a sensor reads.
BEYOND_MM = 0.01
#: Largest arena side accepted, mm (100 m).
MAX_ARENA_MM = 100_000.0
#: Most obstacles and zones a world may have (every check looks at every pair).
MAX_OBSTACLES, MAX_ZONES = 300, 50
#: Largest start jitter accepted: mm either way, and degrees either way.
MAX_JITTER_MM, MAX_JITTER_DEG = 1000.0, 180.0


class WorldError(AutonomyError):
    """A world that cannot be found or read."""


class WorldInvalid(WorldError):
    """A world file with problems; :attr:`problems` lists every one, in file order."""

    def __init__(self, problems: list[Problem]) -> None:
        self.problems = sorted(problems, key=lambda p: (p.line, p.column))
        super().__init__("\n".join(str(p) for p in self.problems))


class Pose(NamedTuple):
    """Where the robot is: centre in mm and heading in degrees (unbounded, left positive).

    A named tuple: one is made every tick (the run's truth), and a tuple is made and read
    several times as fast as a frozen dataclass.
    """

    x_mm: float
    y_mm: float
    heading_deg: float


@dataclass(frozen=True)
class Box:
    """An axis-aligned rectangle between two corners (an obstacle or a zone)."""

    x_min_mm: float
    y_min_mm: float
    x_max_mm: float
    y_max_mm: float

    def ray_distance(self, ox: float, oy: float, dx: float, dy: float) -> float:
        """Distance along the unit ray (dx, dy) from (ox, oy) to this box, inf on a miss."""
        # The slab test, written out for each axis (the sensor calls it for every ray): the ray is
        # inside the box where it is between both pairs of sides at once.
        if abs(dx) < 1e-12:
            if ox < self.x_min_mm or ox > self.x_max_mm:
                return math.inf
            t_near, t_far = 0.0, math.inf
        else:
            t1, t2 = (self.x_min_mm - ox) / dx, (self.x_max_mm - ox) / dx
            if t1 > t2:
                t1, t2 = t2, t1
            # max(0.0, t1) and min(inf, t2), NaN included, without the calls
            t_near, t_far = t1 if t1 > 0.0 else 0.0, t2 if t2 < math.inf else math.inf
            if t_near > t_far:
                return math.inf
        if abs(dy) < 1e-12:
            if oy < self.y_min_mm or oy > self.y_max_mm:
                return math.inf
            return t_near
        t1, t2 = (self.y_min_mm - oy) / dy, (self.y_max_mm - oy) / dy
        if t1 > t2:
            t1, t2 = t2, t1
        if t1 > t_near:  # max(t_near, t1)
            t_near = t1
        if t2 < t_far:  # min(t_far, t2)
            t_far = t2
        return math.inf if t_near > t_far else t_near

    def beyond(self, x: float, y: float, nx: float, ny: float) -> bool:
        """Whether the whole box lies further than ``BEYOND_MM`` past the line through (x, y) across (nx, ny)."""
        nearest_x = self.x_min_mm if nx > 0.0 else self.x_max_mm  # the corner least far along (nx, ny)
        nearest_y = self.y_min_mm if ny > 0.0 else self.y_max_mm
        return (nearest_x - x) * nx + (nearest_y - y) * ny > BEYOND_MM

    def gap(self, x: float, y: float) -> float:
        """Distance from the point (x, y) to the box (0 inside)."""
        # min(max(x, x_min), x_max), and the same for y, NaN included, without the calls
        x_min, y_min, x_max, y_max = self.x_min_mm, self.y_min_mm, self.x_max_mm, self.y_max_mm
        cx = x_min if x_min > x else x
        cx = x_max if x_max < cx else cx
        cy = y_min if y_min > y else y
        cy = y_max if y_max < cy else cy
        return math.hypot(x - cx, y - cy)

    def nearest(self, x: float, y: float) -> tuple[float, float]:
        """The point of the box nearest to (x, y): (x, y) itself inside it."""
        return min(max(x, self.x_min_mm), self.x_max_mm), min(max(y, self.y_min_mm), self.y_max_mm)

    def entry(self, ax: float, ay: float, bx: float, by: float) -> float | None:
        """How far along the segment from (ax, ay) to (bx, by) it first is in the box (0..1), None if never."""
        return _entry(self, ax, ay, bx, by)

    def segment_nearest(self, ax: float, ay: float, bx: float, by: float) -> tuple[float, float, float]:
        """(gap, x, y): the point of the segment from (ax, ay) to (bx, by) nearest the box, and its gap (0 inside)."""
        entered = self.entry(ax, ay, bx, by)
        if entered is not None:
            return 0.0, ax + (bx - ax) * entered, ay + (by - ay) * entered
        # outside all along: nearest at an end, or across from one of the box's corners
        candidates = [(ax, ay), (bx, by)]
        candidates += [
            _on_segment(ax, ay, bx, by, cx, cy)
            for cx in (self.x_min_mm, self.x_max_mm)
            for cy in (self.y_min_mm, self.y_max_mm)
        ]
        return min((self.gap(x, y), x, y) for x, y in candidates)

    def rect_gap(self, x_min: float, y_min: float, x_max: float, y_max: float) -> float:
        """Distance from the rectangle [x_min, x_max] x [y_min, y_max] to the box (0 where they meet).

        No point of the rectangle is nearer the box (see :meth:`gap`).
        """
        dx = max(self.x_min_mm - x_max, x_min - self.x_max_mm, 0.0)
        dy = max(self.y_min_mm - y_max, y_min - self.y_max_mm, 0.0)
        return math.hypot(dx, dy)

    def bounds(self) -> tuple[float, float, float, float]:
        """(x_min, y_min, x_max, y_max) in mm."""
        return self.x_min_mm, self.y_min_mm, self.x_max_mm, self.y_max_mm

    def as_dict(self) -> dict[str, Any]:
        """The shape as a world file writes it."""
        return {"box": {"from_mm": [self.x_min_mm, self.y_min_mm], "to_mm": [self.x_max_mm, self.y_max_mm]}}


@dataclass(frozen=True)
class Circle:
    """A disc (a post, a can, or a round zone)."""

    x_mm: float
    y_mm: float
    radius_mm: float

    def ray_distance(self, ox: float, oy: float, dx: float, dy: float) -> float:
        """Distance along the unit ray (dx, dy) from (ox, oy) to this circle, inf on a miss."""
        fx, fy = ox - self.x_mm, oy - self.y_mm
        b = fx * dx + fy * dy
        c = fx * fx + fy * fy - self.radius_mm**2
        if c <= 0:
            return 0.0
        disc = b * b - c
        if disc < 0:
            return math.inf
        t = -b - math.sqrt(disc)
        return t if t >= 0 else math.inf

    def beyond(self, x: float, y: float, nx: float, ny: float) -> bool:
        """Whether the whole disc lies further than ``BEYOND_MM`` past the line through (x, y) across (nx, ny)."""
        return (self.x_mm - x) * nx + (self.y_mm - y) * ny - self.radius_mm > BEYOND_MM

    def gap(self, x: float, y: float) -> float:
        """Distance from the point (x, y) to the circle's edge (0 inside)."""
        gap = math.hypot(x - self.x_mm, y - self.y_mm) - self.radius_mm
        return gap if gap > 0.0 else 0.0  # max(0.0, gap), NaN included

    def nearest(self, x: float, y: float) -> tuple[float, float]:
        """The point of the circle nearest to (x, y): on its edge toward (x, y), or (x, y) itself inside it."""
        away = math.hypot(x - self.x_mm, y - self.y_mm)
        if away <= self.radius_mm:
            return x, y
        return self.x_mm + (x - self.x_mm) * self.radius_mm / away, self.y_mm + (y - self.y_mm) * self.radius_mm / away

    def entry(self, ax: float, ay: float, bx: float, by: float) -> float | None:
        """How far along the segment from (ax, ay) to (bx, by) it first is in the disc (0..1), None if never."""
        return _entry(self, ax, ay, bx, by)

    def segment_nearest(self, ax: float, ay: float, bx: float, by: float) -> tuple[float, float, float]:
        """(gap, x, y): the point of the segment from (ax, ay) to (bx, by) nearest the disc, and its gap (0 inside)."""
        entered = self.entry(ax, ay, bx, by)
        if entered is not None:
            return 0.0, ax + (bx - ax) * entered, ay + (by - ay) * entered
        x, y = _on_segment(ax, ay, bx, by, self.x_mm, self.y_mm)
        return self.gap(x, y), x, y

    def rect_gap(self, x_min: float, y_min: float, x_max: float, y_max: float) -> float:
        """Distance from the rectangle [x_min, x_max] x [y_min, y_max] to the circle's edge (0 or less where they meet).

        No point of the rectangle is nearer the circle (see :meth:`gap`).
        """
        dx = max(x_min - self.x_mm, self.x_mm - x_max, 0.0)
        dy = max(y_min - self.y_mm, self.y_mm - y_max, 0.0)
        return math.hypot(dx, dy) - self.radius_mm

    def bounds(self) -> tuple[float, float, float, float]:
        """(x_min, y_min, x_max, y_max) of the circle, in mm."""
        r = self.radius_mm
        return self.x_mm - r, self.y_mm - r, self.x_mm + r, self.y_mm + r

    def as_dict(self) -> dict[str, Any]:
        """The shape as a world file writes it."""
        return {"circle": {"center_mm": [self.x_mm, self.y_mm], "radius_mm": self.radius_mm}}


Obstacle = Box | Circle
Shape = Box | Circle


def _entry(shape: Box | Circle, ax: float, ay: float, bx: float, by: float) -> float | None:
    """How far along a segment (0..1) it first is in ``shape`` (its edge counts, as :meth:`Zone.contains` has it).

    The shape's own ray test along the segment, with a start inside or on the edge as 0.
    """
    if shape.gap(ax, ay) <= EPSILON_MM:
        return 0.0
    length = math.hypot(bx - ax, by - ay)
    if length == 0.0:
        return None
    along = shape.ray_distance(ax, ay, (bx - ax) / length, (by - ay) / length)
    return along / length if along <= length else None


def _on_segment(ax: float, ay: float, bx: float, by: float, px: float, py: float) -> tuple[float, float]:
    """The point of the segment from (ax, ay) to (bx, by) nearest to (px, py)."""
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    if length2 == 0.0:
        return ax, ay
    t = max(0.0, min(1.0, ((px - ax) * dx + (py - ay) * dy) / length2))
    return ax + dx * t, ay + dy * t


#: An obstacle's bounds (x_min, y_min, x_max, y_max, in mm), and the obstacle.
_Bounded = tuple[float, float, float, float, Obstacle]
#: A reach's cells: their side in mm, and for each cell (by row, then column) the obstacles `World._near` looks at.
_Cells = tuple[float, list[list[tuple[_Bounded, ...]]]]


def _cell_span(low_mm: float, high_mm: float, cell_mm: float, count: int) -> tuple[int, int]:
    """The first and last of ``count`` cells ``cell_mm`` wide from 0 that meet [low_mm, high_mm].

    One more each way than the division says, so that no rounding of it can leave a cell out;
    all of them for bounds that are not finite.
    """
    low, high = low_mm / cell_mm, high_mm / cell_mm
    first = max(0, math.floor(low) - 1) if math.isfinite(low) else 0
    last = min(count - 1, math.floor(high) + 1) if math.isfinite(high) else count - 1
    return first, last


def _inside(inner: Shape, outer: Shape) -> bool:
    """Whether ``inner`` lies wholly within ``outer``."""
    if isinstance(outer, Box):
        x0, y0, x1, y1 = inner.bounds()
        return outer.x_min_mm <= x0 and outer.y_min_mm <= y0 and x1 <= outer.x_max_mm and y1 <= outer.y_max_mm
    if isinstance(inner, Circle):
        centres = math.hypot(inner.x_mm - outer.x_mm, inner.y_mm - outer.y_mm)
        return centres + inner.radius_mm <= outer.radius_mm
    corners = [(x, y) for x in (inner.x_min_mm, inner.x_max_mm) for y in (inner.y_min_mm, inner.y_max_mm)]
    return all(math.hypot(x - outer.x_mm, y - outer.y_mm) <= outer.radius_mm for x, y in corners)


@dataclass(frozen=True)
class Zone:
    """A named area of the floor that exercises refer to (``garage``, ``start``, ``danger``).

    Zones are drawn on the map but are not obstacles: the robot drives through them.
    """

    name: str
    shape: Shape

    def contains(self, x_mm: float, y_mm: float) -> bool:
        """Whether the point is in the zone (its edge included)."""
        return self.shape.gap(x_mm, y_mm) <= EPSILON_MM

    def distance_mm(self, x_mm: float, y_mm: float) -> float:
        """How far the point is outside the zone (0 inside)."""
        return self.shape.gap(x_mm, y_mm)

    def as_dict(self) -> dict[str, Any]:
        """The zone's shape as a world file writes it."""
        return self.shape.as_dict()


@dataclass(frozen=True)
class Vary:
    """Named obstacles and zones that move together, by up to ``x_mm`` and ``y_mm`` either way, drawn per seed."""

    names: tuple[str, ...]
    x_mm: float = 0.0
    y_mm: float = 0.0


def _moved(shape: Shape, dx: float, dy: float, width_mm: float, height_mm: float) -> Shape | None:
    """``shape`` moved by (dx, dy), or None when nothing of it is left in the arena.

    A box's side that lies against a wall stays there (the box grows or shrinks: a wall across the
    arena, in two parts, keeps meeting the walls as its opening moves), and a box is cut at a wall
    it is moved past.
    """
    if isinstance(shape, Circle):
        return Circle(shape.x_mm + dx, shape.y_mm + dy, shape.radius_mm)

    def side(edge: float, delta: float, wall: float) -> float:
        return edge if edge in (0.0, wall) else min(wall, max(0.0, edge + delta))

    x0, x1 = side(shape.x_min_mm, dx, width_mm), side(shape.x_max_mm, dx, width_mm)
    y0, y1 = side(shape.y_min_mm, dy, height_mm), side(shape.y_max_mm, dy, height_mm)
    return Box(x0, y0, x1, y1) if x0 < x1 and y0 < y1 else None


@dataclass(frozen=True)
class Jitter:
    """How far each run's start may stray from the world's start, either way (drawn from the seed)."""

    x_mm: float = 0.0
    y_mm: float = 0.0
    heading_deg: float = 0.0

    def __bool__(self) -> bool:
        return bool(self.x_mm or self.y_mm or self.heading_deg)


@functools.lru_cache(maxsize=64)
def _cone_directions(
    heading_deg: float, cone_deg: float, rays: int
) -> tuple[tuple[tuple[float, float], ...], tuple[float, float, float, float], tuple[tuple[float, float], ...]]:
    """Unit vectors of ``rays`` rays spread evenly over a cone about ``heading_deg`` (as ``ray_distance`` makes them).

    With them, for the walls, the largest component of any ray towards +x, -x, +y and -y (0.0 when
    no ray heads that way): a wall is nearest along the ray that heads most straight at it, since
    a distance over a larger component is never longer. A robot driving straight asks for the
    same cone tick after tick.
    """
    step = cone_deg / (rays - 1)
    first = heading_deg - cone_deg / 2
    units: list[tuple[float, float]] = []
    # max() of the components above 1e-12 and min() of those below -1e-12 (0.0 for none), NaN left out,
    # in the loop that makes them: a turning robot asks for a new cone every tick
    east = west = north = south = 0.0
    for k in range(rays):
        angle = math.radians(first + k * step)
        dx, dy = math.cos(angle), math.sin(angle)
        units.append((dx, dy))
        if dx > 1e-12:
            if dx > east:
                east = dx
        elif dx < -1e-12 and dx < west:
            west = dx
        if dy > 1e-12:
            if dy > north:
                north = dy
        elif dy < -1e-12 and dy < south:
            south = dy
    directions = tuple(units)
    return directions, (east, west, north, south), _edges(directions) if cone_deg < 180.0 else ()


def _edges(directions: tuple[tuple[float, float], ...]) -> tuple[tuple[float, float], ...]:
    """Across each edge ray of a cone, pointing out of it: nothing wholly past either edge is on any ray.

    That holds while every ray lies between the edge rays; a heading so large that its rays'
    angles round apart (some 1e14 degrees) can spread a cone under a half-turn over more, and
    then the cone has no edges to go by (empty).
    """
    (first_x, first_y), (last_x, last_y) = directions[0], directions[-1]
    for dx, dy in directions:  # a loop, not all() of a generator: a turning robot asks for a new cone every tick
        if not (-last_y * dx + last_x * dy <= 1e-9 and first_y * dx - first_x * dy <= 1e-9):
            return ()
    return (-last_y, last_x), (first_y, -first_x)


@dataclass(frozen=True)
class World:
    """An arena of ``width_mm`` x ``height_mm`` with walls all round, obstacles, zones and a start."""

    name: str
    width_mm: float
    height_mm: float
    start: Pose
    obstacles: tuple[Obstacle, ...] = field(default_factory=tuple)
    zones: tuple[Zone, ...] = field(default_factory=tuple)
    jitter: Jitter = field(default_factory=Jitter)
    description: str = ""
    #: A name for each obstacle ("" for none), in the order of ``obstacles``: what ``vary`` moves.
    obstacle_names: tuple[str, ...] = ()
    #: What moves from seed to seed (see :meth:`for_seed`).
    vary: tuple[Vary, ...] = ()
    # What the sensor's search keeps (see _near and _index_cells): each obstacle's bounds, and by reach
    # the cells. Set at once with the fields, not on first use: an attribute set later would cost
    # every read of the world's fields (Python would give up the instance's compact form). Each
    # world has its own; ``ClassVar`` keeps them out of the dataclass's fields.
    _obstacle_bounds: ClassVar[tuple[_Bounded, ...]]
    _near_cells: ClassVar[dict[float, _Cells]]

    def __post_init__(self) -> None:
        bounds = tuple((*obstacle.bounds(), obstacle) for obstacle in self.obstacles)
        object.__setattr__(self, "_obstacle_bounds", bounds)  # a frozen dataclass sets its own fields this way
        object.__setattr__(self, "_near_cells", {})

    def ray_distance(
        self, x: float, y: float, heading_deg: float, obstacles: tuple[Obstacle, ...] | None = None
    ) -> float:
        """Distance from (x, y) along ``heading_deg`` to the first wall or obstacle (of ``obstacles``, if given)."""
        dx, dy = math.cos(math.radians(heading_deg)), math.sin(math.radians(heading_deg))
        if not (0 <= x <= self.width_mm and 0 <= y <= self.height_mm):
            return 0.0
        best = math.inf
        if dx > 1e-12:
            best = (self.width_mm - x) / dx
        elif dx < -1e-12:
            best = -x / dx
        if dy > 1e-12:
            best = min(best, (self.height_mm - y) / dy)
        elif dy < -1e-12:
            best = min(best, -y / dy)
        for obstacle in self.obstacles if obstacles is None else obstacles:
            best = min(best, obstacle.ray_distance(x, y, dx, dy))
        return best

    def cone_distance(
        self,
        x: float,
        y: float,
        heading_deg: float,
        cone_deg: float = SENSOR_CONE_DEG,
        rays: int = SENSOR_RAYS,
        reach_mm: float = math.inf,
    ) -> float:
        """Distance from (x, y) to the nearest wall or obstacle within a cone about ``heading_deg``.

        The cone is ``cone_deg`` across, sampled by ``rays`` rays spread evenly over it, as a
        distance sensor reports the nearest echo in its field of view.

        Args:
            x: Where the sensor is, mm.
            y: Where the sensor is, mm.
            heading_deg: The cone's axis.
            cone_deg: How wide the cone is, degrees across.
            rays: How many rays sample it.
            reach_mm: Nothing this far or further matters (a sensor's range): such a distance
                comes back as infinity, and obstacles that far from (x, y) are not looked at.
        """
        near = None
        if math.isfinite(reach_mm):
            near = self._near(x, y, reach_mm)
            if not near and min(x, y, self.width_mm - x, self.height_mm - y) >= reach_mm:
                return math.inf  # nothing within reach in any direction
        if rays <= 1 or cone_deg <= 0:
            found = self.ray_distance(x, y, heading_deg, near)
            return found if found < reach_mm else math.inf
        # raises for an infinite heading
        directions, (east, west, north, south), edges = _cone_directions(heading_deg, cone_deg, rays)
        if not (0 <= x <= self.width_mm and 0 <= y <= self.height_mm):
            return 0.0 if reach_mm > 0 else math.inf  # as every ray says from outside the arena
        obstacles = self.obstacles if near is None else near
        left = right = below = above = True  # the walls that may be within reach
        if near is not None:
            # A wall further than the reach along its normal is further along every ray: it cannot count.
            left, right = x < reach_mm, self.width_mm - x < reach_mm
            below, above = y < reach_mm, self.height_mm - y < reach_mm
        # Each distance is worked out as ray_distance works it out, so the nearest is the same number:
        # a wall's along the ray heading most straight at it (the least of (width - x) / dx over the
        # rays is over the largest dx), an obstacle's along every ray. `if d < found: found = d` is
        # min(found, d), NaN included, without the call.
        found = math.inf
        if right and east and (d := (self.width_mm - x) / east) < found:
            found = d
        if left and west and (d := -x / west) < found:
            found = d
        if above and north and (d := (self.height_mm - y) / north) < found:
            found = d
        if below and south and (d := -y / south) < found:
            found = d
        for obstacle in obstacles:
            if edges and (obstacle.beyond(x, y, *edges[0]) or obstacle.beyond(x, y, *edges[1])):
                continue  # wholly outside the cone, past one of its edges (beside or behind the robot)
            for dx, dy in directions:
                if (d := obstacle.ray_distance(x, y, dx, dy)) < found:
                    found = d
        return found if found < reach_mm else math.inf

    def _near(self, x: float, y: float, reach_mm: float) -> tuple[Obstacle, ...] | None:
        """The obstacles closer than ``reach_mm`` to (x, y); None (all of them) when the reach is infinite."""
        if not math.isfinite(reach_mm):
            return None
        if math.isnan(x) or math.isnan(y):  # no bounds say anything of a NaN: each shape's own gap decides
            return tuple(obstacle for obstacle in self.obstacles if obstacle.gap(x, y) < reach_mm)
        margin_mm = reach_mm + 1.0  # outside its bounds grown by more than the reach, a shape is out of reach
        candidates = self._obstacle_bounds
        if 0.0 <= x < self.width_mm and 0.0 <= y < self.height_mm:
            index = self._near_cells.get(reach_mm) or self._index_cells(reach_mm)
            if index is not None:
                cell_mm, cells = index
                candidates = cells[int(y // cell_mm)][int(x // cell_mm)]
                if not candidates:  # nothing near anywhere in this cell (the sensor, most of the time)
                    return ()
        near = []  # in a loop, not a generator: a cell keeps one or two shapes, and most polls look at them
        for x_min, y_min, x_max, y_max, obstacle in candidates:
            if (
                x_min - margin_mm < x < x_max + margin_mm
                and y_min - margin_mm < y < y_max + margin_mm
                and obstacle.gap(x, y) < reach_mm
            ):
                near.append(obstacle)
        return tuple(near)

    def _index_cells(self, reach_mm: float) -> _Cells | None:
        """Sorts the obstacles into cells for ``reach_mm``: a cell keeps each one its points may be near.

        A point passes :meth:`_near`'s bounds test only for a shape whose bounds, grown by the
        margin, contain it; a cell keeps every shape whose grown bounds meet the cell (edges
        included), so that the test looks at no fewer shapes than before, only at fewer far ones,
        and of those only the shapes that come within the margin of the cell grown by a
        millimetre (``rect_gap``): no point of the cell is nearer any other shape than the margin,
        which :meth:`_near` would find out one shape at a time. Most polls then find their cell
        empty. Cells are ``NEAR_CELL_MM`` a side, larger in a large arena (some ``NEAR_CELLS`` a
        side). A run asks with one reach; the cells of the last ``MOST_REACHES`` reaches are kept
        (a shipped world is one object for every run of a process, whose runs may each ask with
        a reach of their own), the oldest making room. None (look at every shape) for an arena
        that is not finite.
        """
        if not math.isfinite(self.width_mm + self.height_mm):
            return None
        for oldest in list(self._near_cells)[: 1 - MOST_REACHES]:  # keeps the last MOST_REACHES - 1
            self._near_cells.pop(oldest, None)  # a copy of the keys, and pop: another thread may be at it too
        margin_mm = reach_mm + 1.0
        cell_mm = max(NEAR_CELL_MM, self.width_mm / NEAR_CELLS, self.height_mm / NEAR_CELLS)
        columns, rows = int(self.width_mm // cell_mm) + 1, int(self.height_mm // cell_mm) + 1  # x // cell_mm < columns
        lists: list[list[list[_Bounded]]] = [[[] for _ in range(columns)] for _ in range(rows)]
        for item in self._obstacle_bounds:
            x_min, y_min, x_max, y_max, _ = item
            first_column, last_column = _cell_span(x_min - margin_mm, x_max + margin_mm, cell_mm, columns)
            first_row, last_row = _cell_span(y_min - margin_mm, y_max + margin_mm, cell_mm, rows)
            for row in range(first_row, last_row + 1):
                low_mm, high_mm = row * cell_mm - 1.0, (row + 1) * cell_mm + 1.0
                for column in range(first_column, last_column + 1):
                    left_mm, right_mm = column * cell_mm - 1.0, (column + 1) * cell_mm + 1.0
                    if not item[4].rect_gap(left_mm, low_mm, right_mm, high_mm) >= margin_mm:  # NaN: kept
                        lists[row][column].append(item)
        cells = [[tuple(cell) for cell in row] for row in lists]
        self._near_cells[reach_mm] = cell_mm, cells
        return cell_mm, cells

    def clearance(self, x: float, y: float) -> float:
        """Distance from (x, y) to the nearest wall or obstacle (0 or less: touching one)."""
        nearest = min(x, y, self.width_mm - x, self.height_mm - y)
        for obstacle in self.obstacles:
            nearest = min(nearest, obstacle.gap(x, y))
        return nearest

    def circle_fits(self, x: float, y: float, radius_mm: float) -> bool:
        """True when a circle of ``radius_mm`` at (x, y) touches nothing (contact allowed)."""
        return self.clearance(x, y) >= radius_mm - EPSILON_MM

    def zone(self, name: str) -> Zone | None:
        """The zone called ``name``, or None."""
        return next((zone for zone in self.zones if zone.name == name), None)

    def for_seed(self, seed: int) -> World:
        """The world as a run with ``seed`` has it: each group of :attr:`vary` moved by the seed's draw.

        The same seed always draws the same world.

        A box moved past a wall is cut there (a wall across the arena with an opening that moves is
        two boxes that reach the walls). The world given back varies no more.
        """
        if not self.vary:
            return self
        rng = random.Random(f"vary {seed}")
        return self.moved([(rng.uniform(-v.x_mm, v.x_mm), rng.uniform(-v.y_mm, v.y_mm)) for v in self.vary])

    def moved(self, offsets: list[tuple[float, float]]) -> World:
        """The world with each group of :attr:`vary` moved by its (dx, dy); it varies no more."""
        by_name = {name: offset for group, offset in zip(self.vary, offsets, strict=True) for name in group.names}
        obstacles, names = [], []
        for obstacle, name in zip(self.obstacles, self.obstacle_names or ("",) * len(self.obstacles), strict=True):
            dx, dy = by_name.get(name, (0.0, 0.0)) if name else (0.0, 0.0)
            shape = _moved(obstacle, dx, dy, self.width_mm, self.height_mm)
            if shape is not None:
                obstacles.append(shape)
                names.append(name)
        zones = []
        for zone in self.zones:
            dx, dy = by_name.get(zone.name, (0.0, 0.0))
            shape = _moved(zone.shape, dx, dy, self.width_mm, self.height_mm)
            if shape is not None:
                zones.append(Zone(zone.name, shape))
        return World(
            self.name,
            self.width_mm,
            self.height_mm,
            self.start,
            tuple(obstacles),
            tuple(zones),
            self.jitter,
            self.description,
            tuple(names),
        )

    def start_pose(self, seed: int) -> Pose:
        """The start for a run with ``seed``: the world's start moved by its jitter, the same for the same seed."""
        if not self.jitter:
            return self.start
        rng = random.Random(f"start {seed}")
        j = self.jitter
        return Pose(
            self.start.x_mm + rng.uniform(-j.x_mm, j.x_mm),
            self.start.y_mm + rng.uniform(-j.y_mm, j.y_mm),
            self.start.heading_deg + rng.uniform(-j.heading_deg, j.heading_deg),
        )

    def as_dict(self) -> dict[str, Any]:
        """The world as a world file writes it (:func:`world_from_dict` reads it back)."""
        start: dict[str, Any] = {
            "x_mm": self.start.x_mm,
            "y_mm": self.start.y_mm,
            "heading_deg": self.start.heading_deg,
        }
        if self.jitter:
            start["jitter"] = {
                "x_mm": self.jitter.x_mm,
                "y_mm": self.jitter.y_mm,
                "heading_deg": self.jitter.heading_deg,
            }
        names = self.obstacle_names or ("",) * len(self.obstacles)
        out: dict[str, Any] = {
            "name": self.name,
            "arena_mm": [self.width_mm, self.height_mm],
            "start": start,
            "obstacles": [
                {**item.as_dict(), "name": name} if name else item.as_dict()
                for item, name in zip(self.obstacles, names, strict=True)
            ],
        }
        if self.zones:
            out["zones"] = {zone.name: zone.as_dict() for zone in self.zones}
        if self.vary:
            out["vary"] = [{"move": list(v.names), "x_mm": v.x_mm, "y_mm": v.y_mm} for v in self.vary]
        if self.description:
            out["description"] = self.description
        return out


def _extremes(world: World, vary: list[tuple[Vary, Located]]) -> list[tuple[list[tuple[float, float]], Located]]:
    """The layouts a world's checks look at besides its own, and where to report a problem of theirs.

    Each group moved to each of its extremes alone, then every group to its least and to its most at once.
    """
    zero = [(0.0, 0.0)] * len(vary)
    out = []
    for index, (group, where) in enumerate(vary):
        for sx, sy in ((-1, -1), (-1, 1), (1, -1), (1, 1)):
            offsets = list(zero)
            offsets[index] = (sx * group.x_mm, sy * group.y_mm)
            out.append((offsets, where))
    if len(vary) > 1:
        for sign in (-1, 1):
            out.append(([(sign * g.x_mm, sign * g.y_mm) for g, _ in vary], vary[0][1]))
    return out


# --------------------------------------------------------------------------- reading

SHIPPED = ("box", "empty", "corridor", "obstacles", "square", "garage", "slalom", "bump", "opening", "calibration")
TOP_LEVEL = ("name", "description", "arena_mm", "start", "obstacles", "zones", "vary")
VARY_KEYS = ("move", "x_mm", "y_mm")
START_KEYS = ("x_mm", "y_mm", "heading_deg", "jitter")
JITTER_KEYS = ("x_mm", "y_mm", "heading_deg")
SHAPE_KEYS = {"box": ("from_mm", "to_mm"), "circle": ("center_mm", "radius_mm")}


class _Reader(Reader):
    """Reads a world document, collecting every problem with its place."""

    def keys(self, located: Located, path: str, allowed: tuple[str, ...]) -> dict[str, Located] | None:
        if not isinstance(located.value, dict):
            self.problem(located, path, f"expected a mapping with {', '.join(allowed)}")
            return None
        for key in located.value:
            if key not in allowed:
                hint = suggest(key, list(allowed)) or f" (allowed: {', '.join(allowed)})"
                shown_key = key if len(key) <= 40 else key[:40] + "..."
                self.problem(
                    located.keys[key], f"{path}.{shown_key}" if path else shown_key, f"unknown key '{shown_key}'{hint}"
                )
        return located.value

    def pair(self, located: Located, path: str, low: float, high: float) -> tuple[float, float] | None:
        if not (isinstance(located.value, list) and len(located.value) == 2):
            self.problem(located, path, f"expected a pair of numbers [x, y], got {located.plain!r}")
            return None
        x = self.number(located.value[0], f"{path}[0]", low, high)
        y = self.number(located.value[1], f"{path}[1]", low, high)
        return (x, y) if x is not None and y is not None else None

    def shape(self, located: Located, path: str) -> Shape | None:
        kinds = tuple(SHAPE_KEYS)
        if not (isinstance(located.value, dict) and len(located.value) == 1):
            self.problem(
                located,
                path,
                "expected one of {box: {from_mm: [x, y], to_mm: [x, y]}} or "
                "{circle: {center_mm: [x, y], radius_mm: r}}",
            )
            return None
        kind, spec = next(iter(located.value.items()))
        if kind not in kinds:
            self.problem(
                located.keys[kind],
                f"{path}.{kind}",
                f"unknown shape '{kind}'{suggest(kind, list(kinds))} (use box or circle)",
            )
            return None
        fields = self.keys(spec, f"{path}.{kind}", SHAPE_KEYS[kind])
        if fields is None:
            return None
        missing = [key for key in SHAPE_KEYS[kind] if key not in fields]
        for key in missing:
            self.problem(spec, f"{path}.{kind}", f"'{key}' is missing")
        if missing:
            return None
        if kind == "box":
            a = self.pair(fields["from_mm"], f"{path}.box.from_mm", -MAX_ARENA_MM, MAX_ARENA_MM)
            b = self.pair(fields["to_mm"], f"{path}.box.to_mm", -MAX_ARENA_MM, MAX_ARENA_MM)
            if a is None or b is None:
                return None
            if a[0] == b[0] or a[1] == b[1]:
                self.problem(spec, f"{path}.box", f"a box needs some width and height, got {list(a)} to {list(b)}")
                return None
            return Box(min(a[0], b[0]), min(a[1], b[1]), max(a[0], b[0]), max(a[1], b[1]))
        centre = self.pair(fields["center_mm"], f"{path}.circle.center_mm", -MAX_ARENA_MM, MAX_ARENA_MM)
        radius = self.number(fields["radius_mm"], f"{path}.circle.radius_mm", 1.0, MAX_ARENA_MM)
        return Circle(centre[0], centre[1], radius) if centre is not None and radius is not None else None

    # ------------------------------------------------------------------ the document

    def world(self, root: Located, default_name: str) -> World | None:
        doc = self.keys(root, "", TOP_LEVEL)
        if doc is None:
            return None
        name = self.text(doc["name"], "name") if "name" in doc else default_name
        description = (self.text(doc["description"], "description") if "description" in doc else "") or ""
        arena = None
        if "arena_mm" not in doc:
            self.problem(root, "", "'arena_mm' is missing: the arena's [width, height] in mm")
        else:
            arena = self.pair(doc["arena_mm"], "arena_mm", 1.0, MAX_ARENA_MM)
        obstacles: list[tuple[Obstacle, Located, str, str]] = []
        if "obstacles" in doc and doc["obstacles"].value is not None:
            items = doc["obstacles"]
            if not isinstance(items.value, list):
                self.problem(items, "obstacles", "expected a list of {box: ...} or {circle: ...}")
            elif len(items.value) > MAX_OBSTACLES:
                self.problem(items, "obstacles", f"at most {MAX_OBSTACLES} obstacles, got {len(items.value)}")
            else:
                for index, item in enumerate(items.value):
                    called = ""
                    if isinstance(item.value, dict) and "name" in item.value:
                        called = self.text(item.value["name"], f"obstacles[{index}].name") or ""
                        rest = {k: v for k, v in item.value.items() if k != "name"}
                        item = Located(rest, item.line, item.column, {k: item.keys[k] for k in rest})
                        if called and called in [n for _, _, _, n in obstacles]:
                            self.problem(item, f"obstacles[{index}].name", f"another obstacle is named '{called}'")
                    shape = self.shape(item, f"obstacles[{index}]")
                    if shape is not None:
                        obstacles.append((shape, item, f"obstacles[{index}]", called))
        zones: list[tuple[Zone, Located, str]] = []
        if "zones" in doc and doc["zones"].value is not None:
            block = doc["zones"]
            if not isinstance(block.value, dict):
                self.problem(block, "zones", "expected a mapping of zone names to {box: ...} or {circle: ...}")
            else:
                for zone_name, item in list(block.value.items())[:MAX_ZONES]:
                    if not zone_name.strip() or control_character(zone_name):
                        self.problem(block.keys[zone_name], "zones", f"a zone needs a plain name, got {zone_name!r}")
                        continue
                    shape = self.shape(item, f"zones.{zone_name}")
                    if shape is not None:
                        zones.append((Zone(zone_name, shape), item, f"zones.{zone_name}"))
        start, jitter, start_at = self.start(doc.get("start"), arena, root)
        named = {n for _, _, _, n in obstacles if n} | {z.name for z, _, _ in zones}
        vary = self.vary(doc["vary"], named) if "vary" in doc and doc["vary"].value is not None else []
        if name is None or arena is None or start is None or jitter is None:
            return None
        world = World(
            name,
            arena[0],
            arena[1],
            start,
            tuple(o for o, _, _, _ in obstacles),
            tuple(z for z, _, _ in zones),
            jitter,
            description,
            tuple(n for _, _, _, n in obstacles) if any(n for _, _, _, n in obstacles) else (),
            tuple(v for v, _ in vary),
        )
        self.check_layout(world, [(o, w, p) for o, w, p, _ in obstacles], zones, start_at)
        if not self.problems and vary:
            self.check_vary(world, vary, [(o, p, n) for o, _, p, n in obstacles], zones)
        if not self.problems:
            for offsets, where in _extremes(world, vary):
                moved = world.moved(offsets)
                found = _Reader(self.label)
                names = world.obstacle_names or ("",) * len(world.obstacles)
                paths = {n: p for _, _, p, n in obstacles if n}
                found.check_layout(
                    moved,
                    [(o, where, paths.get(n, "obstacles")) for o, n in zip(moved.obstacles, names, strict=False)],
                    [(z, where, f"zones.{z.name}") for z in moved.zones],
                    where,
                )
                for problem in found.problems[:1]:
                    shown = ", ".join(f"({dx + 0.0:+g}, {dy + 0.0:+g} mm)" for dx, dy in offsets)  # no -0
                    self.problem(
                        where, "vary", f"moved as far as it may go [{shown}], {problem.path}: {problem.message}"
                    )
                if found.problems:
                    break
        return world

    def check_vary(
        self,
        world: World,
        vary: list[tuple[Vary, Located]],
        obstacles: list[tuple[Obstacle, str, str]],
        zones: list[tuple[Zone, Located, str]],
    ) -> None:
        """Checks every place what varies may take, not only the ends of its ranges.

        The start (with its jitter) must leave the robot clear of every obstacle wherever the
        obstacle and the start may be; a zone must stay inside the arena wherever it goes, and
        never lie wholly inside a box obstacle.
        """
        ranges: dict[str, tuple[float, float, Located]] = {}
        for group, where in vary:
            for name in group.names:
                ranges[name] = (group.x_mm, group.y_mm, where)
        group_of = {name: id(where) for name, (_, _, where) in ranges.items()}
        start, jitter = world.start, world.jitter
        for obstacle, path, name in obstacles:
            if name not in ranges:
                continue
            vx, vy, where = ranges[name]
            reach_x, reach_y = jitter.x_mm + vx, jitter.y_mm + vy
            gap = obstacle.rect_gap(
                start.x_mm - reach_x, start.y_mm - reach_y, start.x_mm + reach_x, start.y_mm + reach_y
            )
            if not gap >= ROBOT_RADIUS_MM - EPSILON_MM:
                self.problem(
                    where,
                    "vary",
                    f"{path} ('{name}') may come to touch the robot at the start (radius {ROBOT_RADIUS_MM:g} mm): "
                    "keep what moves further from it, or move it less",
                )
                return
        for zone, located, path in zones:
            vx, vy, where = ranges.get(zone.name, (0.0, 0.0, located))
            x0, y0, x1, y1 = zone.shape.bounds()
            if zone.name in ranges and (
                x0 - vx < 0 or y0 - vy < 0 or x1 + vx > world.width_mm or y1 + vy > world.height_mm
            ):
                self.problem(where, "vary", f"{path} may be moved outside the arena: move it less, or make room")
                continue
            for obstacle, obstacle_path, name in obstacles:
                if not isinstance(obstacle, Box) or (zone.name not in ranges and name not in ranges):
                    continue
                if name in ranges and zone.name in ranges and group_of[name] == group_of[zone.name]:
                    continue  # they move together: as they stand is checked already
                ox, oy, _ = ranges.get(name, (0.0, 0.0, where))
                rx, ry = vx + ox, vy + oy  # how far one may move from the other, either way
                fits_x = max(obstacle.x_min_mm - x0, -rx) <= min(obstacle.x_max_mm - x1, rx)
                fits_y = max(obstacle.y_min_mm - y0, -ry) <= min(obstacle.y_max_mm - y1, ry)
                if fits_x and fits_y:
                    self.problem(
                        where,
                        "vary",
                        f"{path} may come to lie wholly inside {obstacle_path}: the robot could not enter it",
                    )

    def vary(self, located: Located, named: set[str]) -> list[tuple[Vary, Located]]:
        if not isinstance(located.value, list):
            self.problem(located, "vary", "expected a list of {move: [names], x_mm: mm, y_mm: mm}")
            return []
        out: list[tuple[Vary, Located]] = []
        seen: set[str] = set()
        for index, item in enumerate(located.value):
            path = f"vary[{index}]"
            fields = self.keys(item, path, VARY_KEYS)
            if fields is None:
                continue
            if "move" not in fields or not isinstance(fields["move"].value, list) or not fields["move"].value:
                self.problem(item, f"{path}.move", "expected move: a list of the names of obstacles and zones")
                continue
            names = []
            for k, entry in enumerate(fields["move"].value):
                word = self.text(entry, f"{path}.move[{k}]")
                if word is None:
                    continue
                if word not in named:
                    hint = suggest(word, sorted(named))
                    self.problem(entry, f"{path}.move[{k}]", f"no obstacle or zone is named '{word}'{hint}")
                elif word in seen:
                    self.problem(entry, f"{path}.move[{k}]", f"'{word}' is moved by another group already")
                else:
                    seen.add(word)
                    names.append(word)
            amounts = [
                self.number(fields[key], f"{path}.{key}", 0.0, MAX_JITTER_MM) if key in fields else 0.0
                for key in ("x_mm", "y_mm")
            ]
            if len(names) == len(fields["move"].value) and None not in amounts:
                out.append((Vary(tuple(names), float(amounts[0]), float(amounts[1])), item))
        return out

    def start(
        self, located: Located | None, arena: tuple[float, float] | None, root: Located
    ) -> tuple[Pose | None, Jitter | None, Located]:
        if located is None:
            if arena is None:
                return None, None, root
            return Pose(arena[0] / 2, arena[1] / 2, 0.0), Jitter(), root
        fields = self.keys(located, "start", START_KEYS)
        if fields is None:
            return None, None, located
        x = self.number(fields["x_mm"], "start.x_mm", -MAX_ARENA_MM, MAX_ARENA_MM) if "x_mm" in fields else None
        y = self.number(fields["y_mm"], "start.y_mm", -MAX_ARENA_MM, MAX_ARENA_MM) if "y_mm" in fields else None
        heading = 0.0
        if "heading_deg" in fields:
            heading = self.number(fields["heading_deg"], "start.heading_deg", -360.0, 360.0)
        if arena is not None:
            x = arena[0] / 2 if "x_mm" not in fields else x
            y = arena[1] / 2 if "y_mm" not in fields else y
        jitter: Jitter | None = Jitter()
        if "jitter" in fields:
            jitter = self.jitter(fields["jitter"])
        if x is None or y is None or heading is None:
            return None, jitter, located
        return Pose(x, y, heading), jitter, located

    def jitter(self, located: Located) -> Jitter | None:
        fields = self.keys(located, "start.jitter", JITTER_KEYS)
        if fields is None:
            return None
        values = {}
        for key in JITTER_KEYS:
            if key in fields:
                high = MAX_JITTER_DEG if key == "heading_deg" else MAX_JITTER_MM
                values[key] = self.number(fields[key], f"start.jitter.{key}", 0.0, high)
        if any(v is None for v in values.values()):
            return None
        return Jitter(**values)

    def check_layout(
        self,
        world: World,
        obstacles: list[tuple[Obstacle, Located, str]],
        zones: list[tuple[Zone, Located, str]],
        start_at: Located,
    ) -> None:
        arena = Box(0.0, 0.0, world.width_mm, world.height_mm)
        size = f"the {world.width_mm:g} x {world.height_mm:g} mm arena"
        for index, (shape, where, path) in enumerate(obstacles):
            x0, y0, x1, y1 = shape.bounds()
            if x1 <= 0 or y1 <= 0 or x0 >= world.width_mm or y0 >= world.height_mm:
                self.problem(where, path, f"lies wholly outside {size}")
            elif not _inside(shape, arena):
                self.problem(where, path, f"reaches outside {size} (the walls are at 0 and the arena's size)")
            for other, other_where, other_path in obstacles[:index]:
                if _inside(shape, other):
                    self.problem(where, path, f"lies wholly inside {other_path} (line {other_where.line}): remove one")
        for zone, where, path in zones:
            x0, y0, x1, y1 = zone.shape.bounds()
            if not _inside(zone.shape, arena):
                self.problem(where, path, f"reaches outside {size}")
            for obstacle, _, obstacle_path in obstacles:
                if _inside(zone.shape, obstacle):
                    self.problem(where, path, f"lies wholly inside {obstacle_path}: the robot could never enter it")
        start, jitter = world.start, world.jitter
        points = [(start.x_mm, start.y_mm)]
        if jitter:
            points += [
                (start.x_mm + sx * jitter.x_mm, start.y_mm + sy * jitter.y_mm) for sx in (-1, 1) for sy in (-1, 1)
            ]
        for k, (x, y) in enumerate(points):
            if world.circle_fits(x, y, ROBOT_RADIUS_MM):
                continue
            what = "the start" if k == 0 else f"the start moved by its jitter to ({x:g}, {y:g})"
            if not (0 <= x <= world.width_mm and 0 <= y <= world.height_mm):
                why = f"is outside {size}"
            elif any(obstacle.gap(x, y) <= EPSILON_MM for obstacle in world.obstacles):
                why = "is inside an obstacle"
            else:
                why = f"leaves the robot (radius {ROBOT_RADIUS_MM:g} mm) touching a wall or an obstacle"
            self.problem(start_at, "start", f"{what} {why}")
            break
        else:  # the corners are clear: so must be every start between them
            if jitter:
                x0, y0 = start.x_mm - jitter.x_mm, start.y_mm - jitter.y_mm
                x1, y1 = start.x_mm + jitter.x_mm, start.y_mm + jitter.y_mm
                for shape, _, path in obstacles:
                    if not shape.rect_gap(x0, y0, x1, y1) >= ROBOT_RADIUS_MM - EPSILON_MM:
                        self.problem(
                            start_at,
                            "start",
                            f"the start moved by its jitter may leave the robot (radius {ROBOT_RADIUS_MM:g} mm) "
                            f"touching {path}: keep it further away, or jitter the start less",
                        )
                        break


def _read_text(text: str, label: str, default_name: str) -> World:
    located, errors = parse(text)
    if located is None or errors:
        raise WorldInvalid([Problem(label, e.line, e.column, "", e.message) for e in errors])
    reader = _Reader(label)
    world = reader.world(located, default_name)
    if reader.problems or world is None:
        raise WorldInvalid(reader.problems or [Problem(label, 1, 1, "", "not a world")])
    return world


def parse_world_text(text: str, label: str = "<world>") -> World:
    """Reads a world file's text.

    Args:
        text: The YAML text.
        label: The file name that problems are reported against.

    Raises:
        WorldInvalid: every problem in the text, each with its line and column.
    """
    return _read_text(text, label, Path(label).stem)


def world_from_dict(document: dict[str, Any]) -> World:
    """The inverse of :meth:`World.as_dict` (a trace's header carries a world as a dict).

    Raises:
        WorldInvalid: the dict is not a valid world.
    """
    return _read_text(yaml.safe_dump(document, sort_keys=False), "<world>", str(document.get("name", "world")))


@functools.cache
def _shipped_world(name: str) -> World:
    """A shipped world, read once: a world is a value, and grading asks for the same one for every seed."""
    source = resources.files("autonomy.emulator").joinpath("worlds", f"{name}.yaml").read_text(encoding="utf-8")
    return _read_text(source, f"{name}.yaml", name)


def world_file(name: str, base_dir: Path) -> Path | None:
    """Where the world a file names as ``name`` is, the file being in ``base_dir``; None for a shipped world.

    A shipped world's name is that world. A bare name (``hall``) is the world file ``hall.yaml``
    beside the file, when there is one (a folder called ``hall`` is not taken for it). Anything
    else is a path: beside the file, else as given (absolute, or from the working folder); where
    there is none, the path beside the file, for the message that says so.
    """
    if name in SHIPPED:
        return None
    path = Path(name)
    if not path.suffix and is_file(base_dir / path.with_suffix(".yaml")):
        return base_dir / path.with_suffix(".yaml")
    if exists(base_dir / path):  # an absolute path stays itself
        return base_dir / path
    return path if exists(path) else base_dir / path


def read_shape(located: Located, path: str, label: str) -> tuple[Shape | None, list[Problem]]:
    """A shape as a world file writes one (``{box: {from_mm, to_mm}}`` or ``{circle: ...}``), and its problems."""
    reader = _Reader(label)
    return reader.shape(located, path), reader.problems


def load_world(name_or_path: str | Path) -> World:
    """Loads a shipped world by name (:data:`SHIPPED`) or a world file.

    Raises:
        WorldError: no such world, or the file is not a valid world (:class:`WorldInvalid`,
            with every problem).
    """
    text = str(name_or_path)
    if text in SHIPPED:
        return _shipped_world(text)
    path = Path(text)
    if not exists(path):
        hint = suggest(text, list(SHIPPED))
        if not hint and is_file(path.with_suffix(".yaml")):
            hint = f" (did you mean '{path.with_suffix('.yaml')}'?)"
        raise WorldError(
            f"no world named '{text}'{hint}: use one of {', '.join(SHIPPED)} or the path of a world file (.yaml)"
        )
    try:
        source = read_text(path)
    except UnreadableFile as err:
        raise WorldInvalid(
            [Problem(text, err.line, err.column, "", f"cannot read the world file: {err.reason}")]
        ) from None
    return _read_text(source, text, path.stem)

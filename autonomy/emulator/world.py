"""The emulator's world: a rectangular arena with walls, box and circle obstacles, a start pose.

Coordinates are millimetres with the origin at the arena's lower-left corner, x to the
right, y up. Headings are degrees from the +x axis, growing counter-clockwise (left).
Worlds are small YAML files; the ones shipped with the package are found by name.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from autonomy.errors import AutonomyError

EPSILON_MM = 1e-6


class WorldError(AutonomyError):
    """A world file that cannot be found or read."""


@dataclass(frozen=True)
class Pose:
    """Where the robot is: centre in mm and heading in degrees (unbounded, left positive)."""

    x_mm: float
    y_mm: float
    heading_deg: float


@dataclass(frozen=True)
class Box:
    """An axis-aligned rectangular obstacle between two corners."""

    x_min_mm: float
    y_min_mm: float
    x_max_mm: float
    y_max_mm: float

    def ray_distance(self, ox: float, oy: float, dx: float, dy: float) -> float:
        """Distance along the unit ray (dx, dy) from (ox, oy) to this box, inf on a miss."""
        t_near, t_far = 0.0, math.inf
        for origin, direction, low, high in (
            (ox, dx, self.x_min_mm, self.x_max_mm),
            (oy, dy, self.y_min_mm, self.y_max_mm),
        ):
            if abs(direction) < 1e-12:
                if origin < low or origin > high:
                    return math.inf
                continue
            t1, t2 = (low - origin) / direction, (high - origin) / direction
            if t1 > t2:
                t1, t2 = t2, t1
            t_near, t_far = max(t_near, t1), min(t_far, t2)
            if t_near > t_far:
                return math.inf
        return t_near

    def gap(self, x: float, y: float) -> float:
        """Distance from the point (x, y) to the box (0 inside)."""
        cx = min(max(x, self.x_min_mm), self.x_max_mm)
        cy = min(max(y, self.y_min_mm), self.y_max_mm)
        return math.hypot(x - cx, y - cy)


@dataclass(frozen=True)
class Circle:
    """A round obstacle (a post, a can)."""

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

    def gap(self, x: float, y: float) -> float:
        """Distance from the point (x, y) to the circle's edge (0 inside)."""
        return max(0.0, math.hypot(x - self.x_mm, y - self.y_mm) - self.radius_mm)


Obstacle = Box | Circle


@dataclass(frozen=True)
class World:
    """An arena of ``width_mm`` x ``height_mm`` with walls all round, obstacles and a start pose."""

    name: str
    width_mm: float
    height_mm: float
    start: Pose
    obstacles: tuple[Obstacle, ...] = field(default_factory=tuple)

    def ray_distance(self, x: float, y: float, heading_deg: float) -> float:
        """Distance from (x, y) along ``heading_deg`` to the first wall or obstacle."""
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
        for obstacle in self.obstacles:
            best = min(best, obstacle.ray_distance(x, y, dx, dy))
        return best

    def clearance(self, x: float, y: float) -> float:
        """Distance from (x, y) to the nearest wall or obstacle (0 or less: touching one)."""
        nearest = min(x, y, self.width_mm - x, self.height_mm - y)
        for obstacle in self.obstacles:
            nearest = min(nearest, obstacle.gap(x, y))
        return nearest

    def as_dict(self) -> dict[str, Any]:
        """The world as a world file writes it (``parse_world`` reads it back)."""
        obstacles: list[dict[str, Any]] = []
        for item in self.obstacles:
            if isinstance(item, Box):
                box = {"from_mm": [item.x_min_mm, item.y_min_mm], "to_mm": [item.x_max_mm, item.y_max_mm]}
                obstacles.append({"box": box})
            else:
                obstacles.append({"circle": {"center_mm": [item.x_mm, item.y_mm], "radius_mm": item.radius_mm}})
        return {
            "name": self.name,
            "arena_mm": [self.width_mm, self.height_mm],
            "start": {"x_mm": self.start.x_mm, "y_mm": self.start.y_mm, "heading_deg": self.start.heading_deg},
            "obstacles": obstacles,
        }

    def circle_fits(self, x: float, y: float, radius_mm: float) -> bool:
        """True when a circle of ``radius_mm`` at (x, y) touches nothing (contact allowed)."""
        return self.clearance(x, y) >= radius_mm - EPSILON_MM


# --------------------------------------------------------------------------- loading

SHIPPED = ("box", "empty", "corridor", "obstacles")


def _pair(value: Any, what: str) -> tuple[float, float]:
    if not (isinstance(value, list) and len(value) == 2 and all(isinstance(v, (int, float)) for v in value)):
        raise WorldError(f"{what} must be a pair of numbers [x, y], got {value!r}")
    return float(value[0]), float(value[1])


def _number(mapping: dict[str, Any], key: str, where: str, default: float | None = None) -> float:
    value = mapping.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise WorldError(f"{where}: '{key}' must be a number, got {value!r}")
    return float(value)


def parse_world(document: Any, name: str) -> World:
    """Builds a :class:`World` from a parsed YAML document.

    Raises:
        WorldError: a missing or malformed field; the message names it.
    """
    if not isinstance(document, dict):
        raise WorldError(f"world {name}: expected a mapping at the top")
    width, height = _pair(document.get("arena_mm"), f"world {name}: arena_mm")
    if width <= 0 or height <= 0:
        raise WorldError(f"world {name}: arena_mm must be positive, got {[width, height]}")
    start = document.get("start", {})
    if not isinstance(start, dict):
        raise WorldError(f"world {name}: start must be a mapping")
    pose = Pose(
        _number(start, "x_mm", f"world {name}: start", width / 2),
        _number(start, "y_mm", f"world {name}: start", height / 2),
        _number(start, "heading_deg", f"world {name}: start", 0.0),
    )
    obstacles: list[Obstacle] = []
    for index, item in enumerate(document.get("obstacles") or []):
        where = f"world {name}: obstacles[{index}]"
        if not (isinstance(item, dict) and len(item) == 1):
            raise WorldError(f"{where}: expected one of {{box: ...}} or {{circle: ...}}")
        kind, spec = next(iter(item.items()))
        if not isinstance(spec, dict):
            raise WorldError(f"{where}: {kind} needs a mapping of parameters")
        if kind == "box":
            (x1, y1), (x2, y2) = (
                _pair(spec.get("from_mm"), f"{where}.from_mm"),
                _pair(spec.get("to_mm"), f"{where}.to_mm"),
            )
            obstacles.append(Box(min(x1, x2), min(y1, y2), max(x1, x2), max(y1, y2)))
        elif kind == "circle":
            cx, cy = _pair(spec.get("center_mm"), f"{where}.center_mm")
            obstacles.append(Circle(cx, cy, _number(spec, "radius_mm", where)))
        else:
            raise WorldError(f"{where}: unknown obstacle '{kind}' (use box or circle)")
    return World(str(document.get("name", name)), width, height, pose, tuple(obstacles))


def load_world(name_or_path: str | Path) -> World:
    """Loads a shipped world by name (``box``, ``empty``, ``corridor``, ``obstacles``) or a file.

    Raises:
        WorldError: no such world, or the file is not a valid world.
    """
    text = str(name_or_path)
    if text in SHIPPED:
        source = resources.files("autonomy.emulator").joinpath("worlds", f"{text}.yaml").read_text()
        label = text
    else:
        path = Path(text)
        if not path.is_file():
            raise WorldError(f"no world named '{text}': use one of {', '.join(SHIPPED)} or a path to a .yaml file")
        source, label = path.read_text(encoding="utf-8"), str(path)
    try:
        document = yaml.safe_load(source)
    except yaml.YAMLError as err:
        raise WorldError(f"world {label}: not valid YAML: {err}") from err
    return parse_world(document, label)

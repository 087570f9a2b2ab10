"""A world as SVG: the arena's walls, its obstacles, the start pose and a scale.

World coordinates are millimetres with y up; the picture flips them once, in the group
``#world``, so paths drawn into ``#paths`` (the browser view does) use world coordinates too.
"""

from __future__ import annotations

import math
from typing import Any
from xml.sax.saxutils import escape

from autonomy.views.lines import printable

MARGIN_PX = 24.0
#: Longest side of the arena in pixels.
SIZE_PX = 560.0


def world_svg(world: dict[str, Any], title: str = "") -> str:
    """The world (as a world file writes it, see ``World.as_dict``) as a standalone SVG."""
    width_mm, height_mm = (float(v) for v in world["arena_mm"])
    scale = SIZE_PX / max(width_mm, height_mm)
    width_px, height_px = width_mm * scale + 2 * MARGIN_PX, height_mm * scale + 2 * MARGIN_PX + 18
    name = printable(str(world.get("name", "world")))
    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width_px:.0f}" height="{height_px:.0f}" '
        f'viewBox="0 0 {width_px:.0f} {height_px:.0f}" font-family="DejaVu Sans, sans-serif" font-size="11" '
        'class="map">',
        f"<title>{escape(printable(title) or f'world {name}')}</title>",
        f'<text x="{MARGIN_PX}" y="16">{escape(f"world {name}: {width_mm:g} x {height_mm:g} mm")}</text>',
        f'<g id="world" transform="translate({MARGIN_PX},{MARGIN_PX + 18 + height_mm * scale:.2f}) '
        f'scale({scale:.6f},{-scale:.6f})" data-scale="{scale:.6f}">',
        f'<rect x="0" y="0" width="{width_mm:g}" height="{height_mm:g}" fill="#fcfcfa" class="floor"/>',
    ]
    grid_mm = 500.0 if max(width_mm, height_mm) > 1000 else 100.0
    # the lines inside the arena only, under its walls: none drawn over a wall
    parts += [_grid_line(x, 0, x, height_mm, scale) for x in _inside(grid_mm, width_mm)]
    parts += [_grid_line(0, y, width_mm, y, scale) for y in _inside(grid_mm, height_mm)]
    parts.append(
        f'<rect x="0" y="0" width="{width_mm:g}" height="{height_mm:g}" fill="none" stroke="#222" '
        f'stroke-width="{3 / scale:.2f}" class="arena"/>'
    )
    for item in world.get("obstacles", []):
        if "box" in item:
            (x1, y1), (x2, y2) = item["box"]["from_mm"], item["box"]["to_mm"]
            parts.append(
                f'<rect x="{min(x1, x2):g}" y="{min(y1, y2):g}" width="{abs(x2 - x1):g}" height="{abs(y2 - y1):g}" '
                'fill="#868e96" class="obstacle"/>'
            )
        elif "circle" in item:
            (cx, cy), r = item["circle"]["center_mm"], item["circle"]["radius_mm"]
            parts.append(f'<circle cx="{cx:g}" cy="{cy:g}" r="{r:g}" fill="#868e96" class="obstacle"/>')
    for zone_name, item in (world.get("zones") or {}).items():
        parts.append(_zone(str(zone_name), item, scale))
    start = world.get("start", {})
    sx, sy, heading = float(start.get("x_mm", 0)), float(start.get("y_mm", 0)), float(start.get("heading_deg", 0))
    tip = (sx + 140 * math.cos(math.radians(heading)), sy + 140 * math.sin(math.radians(heading)))
    parts += [
        f'<circle cx="{sx:g}" cy="{sy:g}" r="60" fill="none" stroke="#1971c2" stroke-width="{2 / scale:.2f}" '
        'class="start"/>',
        f'<line x1="{sx:g}" y1="{sy:g}" x2="{tip[0]:.1f}" y2="{tip[1]:.1f}" stroke="#1971c2" '
        f'stroke-width="{3 / scale:.2f}" class="start-heading"/>',
        '<g id="paths"></g>',
        "</g>",
        f'<text x="{MARGIN_PX}" y="{height_px - 6:.0f}" fill="#555">'
        f"grid {grid_mm:g} mm; blue circle and line: start pose, heading {heading:g} deg</text>",
        "</svg>",
    ]
    return "\n".join(parts) + "\n"


def _zone(name: str, item: dict[str, Any], scale: float) -> str:
    """A zone: a dashed outline, lightly filled, with its name (upright: the group is flipped)."""
    style = (
        f'fill="rgba(250,176,5,.12)" stroke="#e67700" stroke-width="{2 / scale:.2f}" stroke-dasharray="{8 / scale:.1f}"'
    )
    if "box" in item:
        (x1, y1), (x2, y2) = item["box"]["from_mm"], item["box"]["to_mm"]
        x, y, top = min(x1, x2), min(y1, y2), max(y1, y2)
        shape = f'<rect x="{x:g}" y="{y:g}" width="{abs(x2 - x1):g}" height="{abs(y2 - y1):g}" {style}/>'
        label_x, label_y = x + 4 / scale, top - 13 / scale
    else:
        (cx, cy), r = item["circle"]["center_mm"], item["circle"]["radius_mm"]
        shape = f'<circle cx="{cx:g}" cy="{cy:g}" r="{r:g}" {style}/>'
        label_x, label_y = cx - r, cy + r + 4 / scale
    label = (
        f'<text x="{label_x:.1f}" y="{-label_y:.1f}" transform="scale(1,-1)" font-size="{11 / scale:.1f}" '
        f'fill="#d9480f">{escape(printable(name))}</text>'
    )
    return f'<g class="zone" data-zone="{escape(printable(name), {chr(34): "&quot;"})}">{shape}{label}</g>'


def _inside(step_mm: float, length_mm: float) -> list[float]:
    """Every multiple of ``step_mm`` strictly between 0 and ``length_mm``."""
    return [k * step_mm for k in range(1, math.ceil(length_mm / step_mm)) if k * step_mm < length_mm]


def _grid_line(x1: float, y1: float, x2: float, y2: float, scale: float) -> str:
    return f'<line x1="{x1:g}" y1="{y1:g}" x2="{x2:g}" y2="{y2:g}" stroke="#e9ecef" stroke-width="{1 / scale:.2f}"/>'

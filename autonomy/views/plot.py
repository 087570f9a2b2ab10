"""One picture of a recorded run, with matplotlib: the map and path, telemetry, and a timeline.

The map shows the world (when the run was on the emulator), the path by dead reckoning and,
when known, the true path, with collisions marked. The telemetry is plotted against time.
The timeline has one row per node: a bar while it was RUNNING, coloured by how it ended
(green succeeded, red failed, grey halted), and a tick mark where it finished at once.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure
from matplotlib.patches import Circle, Rectangle

from autonomy.record import FAILURE, INVALID, RUNNING, SUCCESS, TreeState
from autonomy.trace import Trace
from autonomy.views.lines import fit

OUTCOME_COLOURS = {SUCCESS: "#2f9e44", FAILURE: "#e03131", INVALID: "#adb5bd", RUNNING: "#f59f00"}
#: Each plot: its label, its value in a tick, and the value at which it wraps round to 0 (or None).
TELEMETRY = (
    ("front distance (mm)", lambda t: t.status.front_distance_mm, None),
    ("heading (deg)", lambda t: t.status.heading_deg, 360),
    ("tilt (deg)", lambda t: t.status.tilt_deg, None),
    ("speed (mm/s), mean of 0.25 s", lambda t: t.speed_mm_s, None),
    ("battery (/255)", lambda t: t.battery, None),
)
MAX_TIMELINE_ROWS = 60
#: The speed is plotted as its mean over this long: the odometer counts whole millimetres, so at
#: 20 Hz a steady 210 mm/s reads 200 and 220 in turn, a zig-zag band rather than a line.
SPEED_WINDOW_S = 0.25


def timeline(trace: Trace) -> list[tuple[int, list[tuple[float, float, str]], list[tuple[float, str]]]]:
    """For each node: its RUNNING spans (start s, end s, how it ended) and its instant results (s, status)."""
    header = trace.header
    state = TreeState(header)
    spans: dict[int, list[tuple[float, float, str]]] = {n.id: [] for n in header.nodes}
    marks: dict[int, list[tuple[float, str]]] = {n.id: [] for n in header.nodes}
    started: dict[int, float] = {}
    end_s = trace.end.time_s if trace.end is not None else (trace.ticks[-1].time_s if trace.ticks else 0.0)
    for tick in trace.ticks:
        for node_id, new in tick.nodes.items():
            old = state.nodes[node_id].status
            if new.status == RUNNING and old != RUNNING:
                started[node_id] = tick.time_s
            elif old == RUNNING and new.status != RUNNING:
                spans[node_id].append((started.pop(node_id), tick.time_s, new.status))
            elif new.status in (SUCCESS, FAILURE) and old != RUNNING:
                marks[node_id].append((tick.time_s, new.status))
        state.apply(tick)
    for node_id, start_s in started.items():
        spans[node_id].append((start_s, end_s, RUNNING if trace.end is None else INVALID))
    return [(n.id, spans[n.id], marks[n.id]) for n in header.nodes]


def broken_at_wraps(times: list[float], values: list[float], wrap: float | None) -> tuple[list[float], list[float]]:
    """The series with a gap wherever it wraps round (a heading from 359 to 0 degrees).

    Between two samples more than half of ``wrap`` apart, a NaN is put in, where matplotlib
    lifts the pen: the line stops at one edge and starts again at the other, instead of
    crossing the whole plot as if the robot had spun round.
    """
    if wrap is None or not values:
        return times, values
    xs, ys = [times[0]], [values[0]]
    for index in range(1, len(values)):
        if abs(values[index] - values[index - 1]) > wrap / 2:
            xs.append((times[index - 1] + times[index]) / 2)
            ys.append(math.nan)
        xs.append(times[index])
        ys.append(values[index])
    return xs, ys


#: Longest text a picture shows of a name (a mission's, a node's, a zone's): matplotlib lays out every
#: character, and a name of megabytes took minutes and gigabytes.
MAX_LABEL_CHARS = 80


def mean_over(times: list[float], values: list[float], window_s: float) -> list[float]:
    """Each value as the mean of those from ``window_s`` before it up to it (times in order)."""
    out: list[float] = []
    first, total = 0, 0.0
    for index, (time_s, value) in enumerate(zip(times, values, strict=True)):
        total += value
        while first < index and times[first] <= time_s - window_s:  # at 1e17 s, time_s - window_s is time_s
            total -= values[first]
            first += 1
        out.append(total / (index - first + 1))
    return out


def plot_run(trace: Trace, path: str | Path) -> None:
    """Draws the run into ``path`` (.png or .svg)."""
    header, ticks = trace.header, trace.ticks
    rows = min(len(header.nodes), MAX_TIMELINE_ROWS)
    figure = Figure(figsize=(14, 8 + rows * 0.22), layout="constrained")
    top, bottom = figure.subfigures(2, 1, height_ratios=[8, 1 + rows * 0.22])
    left, right = top.subfigures(1, 2, width_ratios=[1, 1.15])
    outcome = trace.end.outcome if trace.end is not None else "cut off (no end record)"
    title = (
        f"{fit(header.mission, MAX_LABEL_CHARS)}: {outcome}, {len(ticks)} ticks, {fit(header.date, MAX_LABEL_CHARS)}"
    )
    figure.suptitle(title, fontsize=13)
    _map(left.add_subplot(), trace)
    axes = right.subplots(len(TELEMETRY), 1, sharex=True)
    times = [t.time_s for t in ticks]
    for ax, (label, get, wrap) in zip(axes, TELEMETRY, strict=True):
        values = [get(t) for t in ticks]
        if label.startswith("speed"):
            values = mean_over(times, values, SPEED_WINDOW_S)
        series = broken_at_wraps(times, values, wrap)
        ax.plot(*series, color="#1c7ed6", linewidth=1.2, gid=f"series-{label.split(' (')[0].replace(' ', '-')}")
        ax.set_ylabel(label, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    _timeline(bottom.add_subplot(), trace, rows)
    figure.savefig(str(path))


def plot_world(world: dict[str, Any], path: str | Path) -> None:
    """Draws a world (as ``World.as_dict`` gives it) and its start pose into ``path`` (.png)."""
    width, height = world["arena_mm"]
    longest = max(width, height)
    figure = Figure(figsize=(3.5 + 7 * width / longest, 1.5 + 7 * height / longest), layout="constrained")
    ax = figure.add_subplot()
    _world(ax, world)
    start = world.get("start") or {}
    x_mm, y_mm, heading = float(start.get("x_mm", 0)), float(start.get("y_mm", 0)), float(start.get("heading_deg", 0))
    reach_mm = 0.06 * max(width, height)
    ax.scatter([x_mm], [y_mm], marker="o", color="#1971c2", zorder=5, label=f"start, heading {heading:g} deg")
    ax.annotate(
        "",
        (x_mm + reach_mm * math.cos(math.radians(heading)), y_mm + reach_mm * math.sin(math.radians(heading))),
        (x_mm, y_mm),
        arrowprops={"arrowstyle": "->", "color": "#1971c2", "linewidth": 2},
    )
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    figure.savefig(str(path))


def _world(ax: Any, world: dict[str, Any]) -> None:
    """The arena's walls, its obstacles and its zones, named, and the axes fitted to it."""
    width, height = world["arena_mm"]
    ax.add_patch(Rectangle((0, 0), width, height, fill=False, linewidth=2, edgecolor="#222"))
    for item in world.get("obstacles", []):
        if "box" in item:
            (x1, y1), (x2, y2) = item["box"]["from_mm"], item["box"]["to_mm"]
            ax.add_patch(Rectangle((min(x1, x2), min(y1, y2)), abs(x2 - x1), abs(y2 - y1), color="#868e96"))
        elif "circle" in item:
            ax.add_patch(Circle(item["circle"]["center_mm"], item["circle"]["radius_mm"], color="#868e96"))
    zone_style = {"facecolor": (0.98, 0.69, 0.02, 0.12), "edgecolor": "#e67700", "linestyle": "--"}
    # a zone's name inside it, from its top left corner: not on its edge
    label_style = {"xytext": (3, -3), "textcoords": "offset points", "va": "top", "color": "#d9480f", "fontsize": 8}
    for name, item in (world.get("zones") or {}).items():
        if "box" in item:
            (x1, y1), (x2, y2) = item["box"]["from_mm"], item["box"]["to_mm"]
            ax.add_patch(Rectangle((min(x1, x2), min(y1, y2)), abs(x2 - x1), abs(y2 - y1), **zone_style))
            ax.annotate(fit(str(name), MAX_LABEL_CHARS), (min(x1, x2), max(y1, y2)), **label_style)
        elif "circle" in item:
            (cx, cy), r = item["circle"]["center_mm"], item["circle"]["radius_mm"]
            ax.add_patch(Circle((cx, cy), r, **zone_style))
            ax.annotate(fit(str(name), MAX_LABEL_CHARS), (cx - r * 0.7, cy + r * 0.7), **label_style)
    ax.set_xlim(-50, width + 50)
    ax.set_ylim(-50, height + 50)
    ax.set_title(f"world {fit(str(world.get('name', '?')), MAX_LABEL_CHARS)}", fontsize=10)


def _map(ax: Any, trace: Trace) -> None:
    world, ticks = trace.header.world, trace.ticks
    if world:
        _world(ax, world)
    else:
        ax.set_title("world unknown: dead reckoning from the start", fontsize=10)
    ax.plot(
        [t.dead_reckoning.x_mm for t in ticks],
        [t.dead_reckoning.y_mm for t in ticks],
        color="#1c7ed6",
        linewidth=2,
        label="dead reckoning",
    )
    truth = [t.truth for t in ticks if t.truth is not None]
    if truth:
        ax.plot(
            [p.x_mm for p in truth],
            [p.y_mm for p in truth],
            color="#2b8a3e",
            linestyle="--",
            linewidth=1.5,
            label="truth (emulator)",
        )
    hits = [t.truth or t.dead_reckoning for t in ticks if any(e.kind == "collision" for e in t.events)]
    if hits:
        ax.scatter(
            [p.x_mm for p in hits],
            [p.y_mm for p in hits],
            marker="x",
            s=80,
            color="#e03131",
            zorder=5,
            label=f"collision ({len(hits)})",
        )
    if ticks:
        ax.scatter(
            [ticks[0].dead_reckoning.x_mm],
            [ticks[0].dead_reckoning.y_mm],
            marker="o",
            color="#1971c2",
            zorder=5,
            label="start",
        )
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncols=4, frameon=False)  # off the map


def _timeline(ax: Any, trace: Trace, rows: int) -> None:
    header = trace.header
    depth = {}
    for node in header.nodes:
        depth[node.id] = 0 if node.parent is None else depth[node.parent] + 1
    # One collection per row and colour, and one for all marks of a colour: a node that changes on every
    # tick costs points in them, never an artist of its own (matplotlib's cost is per artist).
    marked: dict[str, tuple[list[float], list[float]]] = {}
    for row, (_node_id, spans, marks) in enumerate(timeline(trace)[:rows]):
        bars: dict[str, list[tuple[float, float]]] = {}
        for start_s, end_s, how in spans:
            bars.setdefault(how, []).append((start_s, max(end_s - start_s, 0.02)))
        for how, pieces in bars.items():
            ax.broken_barh(pieces, (row - 0.35, 0.7), color=OUTCOME_COLOURS[how])
        for when_s, how in marks:
            whens, rows_of = marked.setdefault(how, ([], []))
            whens.append(when_s)
            rows_of.append(row)
    for how, (whens, rows_of) in marked.items():
        ax.vlines(
            whens, [r - 0.35 for r in rows_of], [r + 0.35 for r in rows_of], colors=OUTCOME_COLOURS[how], linewidth=1
        )
    ax.set_yticks(range(rows))
    ax.set_yticklabels(
        [("  " * depth[n.id]) + fit(n.name, MAX_LABEL_CHARS) for n in header.nodes[:rows]],
        fontsize=7,
        family="monospace",
    )
    ax.invert_yaxis()
    ax.set_xlabel("time (s)")
    ax.set_title(
        "timeline: bars while RUNNING; green succeeded, red failed, grey halted; marks: instant results", fontsize=9
    )
    ax.grid(axis="x", alpha=0.3)

"""The tree as text: what each node is, the symbols and their legend, and folding to fit a screen.

Used by ``autonomy show`` (no statuses) and the terminal live view (with statuses).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

from autonomy.record import FAILURE, INVALID, RUNNING, SUCCESS, NodeInfo, NodeState, RunHeader

#: One symbol per shape of node.
SHAPE_SYMBOLS = {
    "sequence": "→",
    "selector": "?",
    "parallel": "⇉",
    "while": "↻",
    "decorator": "◈",
    "action": "•",
    "condition": "◇",
}
#: One symbol per status.
STATUS_SYMBOLS = {RUNNING: "●", SUCCESS: "✔", FAILURE: "✘", INVALID: "○"}
#: Colour names per status (rich's and the page's).
STATUS_COLOURS = {RUNNING: "yellow", SUCCESS: "green", FAILURE: "red", INVALID: "grey50"}

LEGEND_SHAPES = "→ sequence  ? selector  ⇉ parallel  ↻ while  ◈ decorator  • action  ◇ condition"
LEGEND_STATUS = "● running  ✔ succeeded  ✘ failed  ○ not run yet (or halted)"


def shape_of(info: NodeInfo) -> str:
    """The key of :data:`SHAPE_SYMBOLS` for a node."""
    if info.type in ("sequence", "selector", "parallel", "while"):
        return info.type
    return info.category if info.category in SHAPE_SYMBOLS else "action"


def _value(value: Any) -> str:
    return value if isinstance(value, str) else json.dumps(value)


def type_text(info: NodeInfo) -> str:
    """What a node is, in words: its type, memory or policy, parameters."""
    params = {k: v for k, v in info.params.items() if v is not None and k != "subtree"}
    if info.type in ("sequence", "selector"):
        return f"{info.type}, {'memory' if params.get('memory') else 'no memory'}"
    if info.type == "parallel":
        return f"parallel, succeeds on {params.get('policy', 'all')}"
    if info.type == "repeat":
        return f"repeat {params['times']} times" if params.get("times") else "repeat forever"
    if info.type == "while":
        return "while (condition, then do, every tick)"
    return " ".join([info.type, *(f"{k}={_value(v)}" for k, v in params.items())])


@dataclass(frozen=True)
class Line:
    """One line of a tree drawn as text.

    Attributes:
        node: The node's id.
        depth: How deep it is (0: the root).
        folded: How many nodes under it are hidden (0: none).
    """

    node: int
    depth: int
    folded: int = 0


def tree_lines(header: RunHeader, states: dict[int, NodeState] | None = None, max_lines: int = 0) -> list[Line]:
    """The tree as lines, folded to at most ``max_lines`` (0: no limit).

    Folding goes in steps until the tree fits: first the subtrees that are not running
    (finished or not started) become one line each; then only running nodes and their
    children stay; then the lines past the limit are cut (the last line says how many).
    """
    children = header.children()
    sizes: dict[int, int] = {}

    def size(node_id: int) -> int:
        if node_id not in sizes:
            sizes[node_id] = 1 + sum(size(c) for c in children.get(node_id, []))
        return sizes[node_id]

    def running(node_id: int) -> bool:
        return states is not None and states.get(node_id, NodeState(INVALID)).status == RUNNING

    def walk(keep: callable, fold: callable) -> list[Line]:  # type: ignore[valid-type]
        out: list[Line] = []
        stack = [(c, 0) for c in reversed(children.get(None, []))]
        while stack:
            node_id, depth = stack.pop()
            kids = children.get(node_id, [])
            if fold(node_id) and kids:
                out.append(Line(node_id, depth, size(node_id) - 1))
                continue
            out.append(Line(node_id, depth))
            stack.extend((c, depth + 1) for c in reversed(kids) if keep(c))
        return out

    lines = walk(lambda c: True, lambda n: False)
    if not max_lines or len(lines) <= max_lines:
        return lines
    lines = walk(lambda c: True, lambda n: not running(n) and n != 0)
    if len(lines) <= max_lines:
        return lines
    parents = {n.id: n.parent for n in header.nodes}
    lines = walk(lambda c: running(c) or running(parents[c]), lambda n: not running(n) and n != 0)
    if len(lines) > max_lines:
        lines = _around_running(lines, [i for i, line in enumerate(lines) if running(line.node)], max_lines)
    return lines


def _around_running(lines: list[Line], running: list[int], max_lines: int) -> list[Line]:
    """At most ``max_lines`` of ``lines``: the running ones that fit, deepest first, and as many as fit around the last.

    Each run of lines left out becomes one line saying how many (``Line(-1, depth, count)``), or,
    when it is one line, that line itself; so the node that runs now is on screen even in a
    sequence of hundreds, or at the bottom of a deep chain.
    """
    focus = running[-1] if running else 0
    kept = set(running) | {focus}

    def shown(indexes: set[int]) -> int:  # lines drawn: those kept, and one for each run left out
        order = sorted(indexes)
        gaps = (order[0] > 0) + (order[-1] < len(lines) - 1) + sum(b - a > 1 for a, b in pairwise(order))
        return len(order) + gaps

    while shown(kept) > max_lines and len(kept) > 1:  # the running chain does not fit: its top goes first
        kept.discard(min(kept - {focus}))
    before, after = focus - 1, focus + 1
    while before >= 0 or after < len(lines):  # widen around the focus, a line before for each after
        for index in (after, before):
            if 0 <= index < len(lines) and index not in kept and shown(kept | {index}) <= max_lines:
                kept.add(index)
        if shown(kept | {after}) > max_lines and shown(kept | {before}) > max_lines:
            break
        before, after = before - 1, after + 1
    out: list[Line] = []
    previous = -1
    for index in [*sorted(kept), len(lines)]:
        hidden = index - previous - 1
        if hidden == 1:  # one line left out takes the room of the line saying so: it is shown
            out.append(lines[previous + 1])
        elif hidden > 1:
            out.append(Line(-1, lines[previous + 1].depth, hidden))
        if index < len(lines):
            out.append(lines[index])
        previous = index
    if len(out) > max_lines:  # a limit below three: the running line, and what fits before it
        at = out.index(lines[focus])
        out = out[max(0, at - max_lines + 1) :][:max_lines]
    return out


def tree_text(header: RunHeader) -> str:
    """The whole tree as indented text with what each node is, and a legend (``autonomy show``)."""
    out = []
    for line in tree_lines(header):
        info = header.nodes[line.node]
        symbol = SHAPE_SYMBOLS[shape_of(info)]
        label = type_text(info)
        text = f"{'    ' * line.depth}{symbol} "
        text += label if label.startswith(info.name) else f"{info.name}  [{label}]"
        out.append(text)
    out += ["", f"legend: {LEGEND_SHAPES}"]
    return "\n".join(out) + "\n"

"""The tree as SVG, laid out here (no Graphviz): children below their parent, left to right.

Each node is a ``<g class="node" id="node-N" data-node="N">``: the browser view colours it by
status. Every box says what the node is (type, memory or policy, parameters), and a legend
below the tree explains the shapes, symbols and colours.
"""

from __future__ import annotations

from dataclasses import dataclass
from xml.sax.saxutils import escape

from autonomy.record import NodeInfo
from autonomy.views.lines import fit, printable
from autonomy.views.treetext import LEGEND_SHAPES, SHAPE_SYMBOLS, shape_of, type_text

#: Fill colours by node category.
FILLS = {
    "composite": "#dbe9f6",
    "decorator": "#eeeeee",
    "action": "#d8f0d2",
    "condition": "#fff3b0",
}
#: Status colours in the browser view (also in its legend).
STATUS_FILLS = {"RUNNING": "#ffd43b", "SUCCESS": "#8ce99a", "FAILURE": "#ff8787", "INVALID": "#f1f3f5"}

CHAR_PX = 7.0
SMALL_CHAR_PX = 5.8
ROW_PX = 78
GAP_PX = 14
BOX_PX = 38
MAX_LABEL_CHARS = 48
#: A box's type and parameters are wrapped to lines of at most this many characters, at most two.
DETAIL_CHARS = 40
DETAIL_LINES = 2
LINE_PX = 12
#: A composite with more children than this lays them out in rows, joined by a rail on their left.
ROW_CHILDREN = 6
RAIL_PX = 16


@dataclass
class _Box:
    node: NodeInfo
    x: float
    y: float
    width: float
    title: str
    detail: list[str]

    @property
    def height(self) -> float:
        """Taller by a line for each line of detail past the first."""
        return BOX_PX + LINE_PX * max(0, len(self.detail) - 1)


def _cut(text: str) -> str:
    return fit(text, MAX_LABEL_CHARS)


def _wrapped(text: str) -> list[str]:
    """``text`` in lines of at most :data:`DETAIL_CHARS` (broken at spaces), at most :data:`DETAIL_LINES`."""
    lines: list[str] = []
    for word in printable(text).split(" "):
        if lines and len(lines[-1]) + 1 + len(word) <= DETAIL_CHARS:
            lines[-1] += " " + word
        else:
            lines.append(word)
    if len(lines) > DETAIL_LINES:
        lines = [*lines[: DETAIL_LINES - 1], " ".join(lines[DETAIL_LINES - 1 :])]
    return [fit(line, DETAIL_CHARS) for line in lines if line]


def svg_tree(nodes: list[NodeInfo], title: str = "mission", legend: bool = True) -> str:
    """The tree as a standalone SVG picture."""
    children: dict[int | None, list[NodeInfo]] = {}
    for node in nodes:
        children.setdefault(node.parent, []).append(node)
    boxes: list[_Box] = []
    cursor = [float(GAP_PX)]

    deepest = [0]  # the deepest row used so far by the subtree being placed
    wrapped: dict[int, list[list[int]]] = {}  # a node whose children go in rows: their ids, row by row

    def place(node: NodeInfo, depth: int) -> _Box:
        detail = type_text(node)
        if detail.startswith(node.name):
            head, lines = _cut(f"{SHAPE_SYMBOLS[shape_of(node)]} {detail}"), []
        else:
            head, lines = _cut(f"{SHAPE_SYMBOLS[shape_of(node)]} {node.name}"), _wrapped(detail)
        width = max(70.0, CHAR_PX * len(head) + 20, *(SMALL_CHAR_PX * len(line) + 20 for line in lines))
        y = GAP_PX + depth * ROW_PX
        left, first = cursor[0], len(boxes)
        deepest[0] = max(deepest[0], depth)
        own = children.get(node.id, [])
        rows = [own[i : i + ROW_CHILDREN] for i in range(0, len(own), ROW_CHILDREN)]
        kids: list[_Box] = []
        row_depth = depth + 1
        if len(rows) > 1:  # a long sequence in rows, read as text is, joined by a rail on their left
            wrapped[node.id] = [[child.id for child in row] for row in rows]
            widest = left
            for number, row in enumerate(rows):
                cursor[0] = left + RAIL_PX
                placed = [place(child, row_depth) for child in row]
                kids = placed if number == 0 else kids  # the parent stands over the first row
                widest = max(widest, cursor[0])
                row_depth = deepest[0] + 1
            cursor[0] = widest
        else:
            kids = [place(child, depth + 1) for child in own]
        if not kids:
            box = _Box(node, left, y, width, head, lines)
        else:
            box = _Box(node, (kids[0].x + kids[-1].x + kids[-1].width) / 2 - width / 2, y, width, head, lines)
            if box.x < left:  # a parent wider than its children: move the whole subtree right
                for placed in boxes[first:]:
                    placed.x += left - box.x
                box.x = left
        cursor[0] = max(cursor[0], box.x + width + GAP_PX)
        boxes.append(box)
        return box

    for root in children.get(None, []):
        place(root, 0)
    if not boxes:
        return '<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10"></svg>\n'
    shift = GAP_PX - min(b.x for b in boxes)
    for box in boxes:
        box.x += shift
    width = max(b.x + b.width for b in boxes) + GAP_PX
    height = max(b.y + b.height for b in boxes) + GAP_PX
    legend_parts, legend_height = _legend(height) if legend else ([], 0)
    width = max(width, 560.0) if legend else width
    where = {b.node.id: b for b in boxes}
    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" height="{height + legend_height:.0f}" '
        f'viewBox="0 0 {width:.0f} {height + legend_height:.0f}" font-family="DejaVu Sans, sans-serif" '
        'font-size="12" class="tree">',
        f"<title>{escape(printable(title))}</title>",
    ]
    for box in boxes:
        if box.node.id in wrapped:
            parts += _rail(box, [[where[i] for i in row] for row in wrapped[box.node.id]])
            continue
        for child in children.get(box.node.id, []):
            c = where[child.id]
            parts.append(
                f'<line x1="{box.x + box.width / 2:.1f}" y1="{box.y + box.height:.1f}" '
                f'x2="{c.x + c.width / 2:.1f}" y2="{c.y:.1f}" stroke="#666"/>'
            )
    for box in boxes:
        node = box.node
        fill = FILLS.get(node.category, "#eeeeee")
        radius = BOX_PX / 2 if node.category == "condition" else (12 if node.category == "decorator" else 4)
        tip = printable(f"{node.name}: {type_text(node)}" + (f" ({node.where})" if node.where else ""))
        parts.append(f'<g class="node" id="node-{node.id}" data-node="{node.id}" data-status="INVALID">')
        parts.append(f"<title>{escape(tip)}</title>")
        parts.append(
            f'<rect x="{box.x:.1f}" y="{box.y:.1f}" width="{box.width:.1f}" height="{box.height:g}" rx="{radius}" '
            f'fill="{fill}" stroke="#333"/>'
        )
        middle = box.x + box.width / 2
        if box.detail:
            parts.append(f'<text x="{middle:.1f}" y="{box.y + 15:.1f}" text-anchor="middle">{escape(box.title)}</text>')
            for number, line in enumerate(box.detail):
                parts.append(
                    f'<text x="{middle:.1f}" y="{box.y + 30 + number * LINE_PX:.1f}" text-anchor="middle" '
                    f'font-size="10" fill="#444" class="detail">{escape(line)}</text>'
                )
        else:
            parts.append(f'<text x="{middle:.1f}" y="{box.y + 23:.1f}" text-anchor="middle">{escape(box.title)}</text>')
        parts.append("</g>")
    parts += legend_parts
    parts.append("</svg>")
    return "\n".join(parts) + "\n"


def _rail(parent: _Box, rows: list[list[_Box]]) -> list[str]:
    """A parent joined to children in rows: down from it, along the left of the rows, and over each row."""
    x = min(row[0].x for row in rows) - RAIL_PX / 2
    top = parent.y + parent.height
    middle = parent.x + parent.width / 2
    buses = [row[0].y - 12 for row in rows]
    lines = [(middle, top, middle, buses[0]), (x, buses[0], middle, buses[0]), (x, buses[0], x, buses[-1])]
    for bus, row in zip(buses, rows, strict=True):
        centres = [child.x + child.width / 2 for child in row]
        lines.append((x, bus, max(centres), bus))
        lines += [(centre, bus, centre, child.y) for centre, child in zip(centres, row, strict=True)]
    return [
        f'<line x1="{x1:.1f}" y1="{y1:.1f}" x2="{x2:.1f}" y2="{y2:.1f}" stroke="#666" class="rail"/>'
        for x1, y1, x2, y2 in lines
    ]


def _legend(top: float) -> tuple[list[str], float]:
    parts = [f'<g class="legend" transform="translate({GAP_PX},{top:.0f})" font-size="11">']
    parts.append(f'<text x="0" y="12">{escape("symbols: " + LEGEND_SHAPES)}</text>')
    x = 0.0
    for name, fill in FILLS.items():
        parts.append(f'<rect x="{x:.0f}" y="20" width="14" height="12" fill="{fill}" stroke="#333"/>')
        parts.append(f'<text x="{x + 18:.0f}" y="30">{name}</text>')
        x += 18 + len(name) * 7 + 16
    parts.append(f'<text x="{x:.0f}" y="30" fill="#444">boxes: name, then type and parameters</text>')
    parts.append("</g>")
    return parts, 40.0

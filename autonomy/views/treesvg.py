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


@dataclass
class _Box:
    node: NodeInfo
    x: float
    y: float
    width: float
    title: str
    detail: str


def _cut(text: str) -> str:
    return fit(text, MAX_LABEL_CHARS)


def svg_tree(nodes: list[NodeInfo], title: str = "mission", legend: bool = True) -> str:
    """The tree as a standalone SVG picture."""
    children: dict[int | None, list[NodeInfo]] = {}
    for node in nodes:
        children.setdefault(node.parent, []).append(node)
    boxes: list[_Box] = []
    cursor = [float(GAP_PX)]

    def place(node: NodeInfo, depth: int) -> _Box:
        detail = type_text(node)
        if detail.startswith(node.name):
            head, detail = _cut(f"{SHAPE_SYMBOLS[shape_of(node)]} {detail}"), ""
        else:
            head, detail = _cut(f"{SHAPE_SYMBOLS[shape_of(node)]} {node.name}"), _cut(detail)
        width = max(70.0, CHAR_PX * len(head) + 20, SMALL_CHAR_PX * len(detail) + 20)
        y = GAP_PX + depth * ROW_PX
        left, first = cursor[0], len(boxes)
        kids = [place(child, depth + 1) for child in children.get(node.id, [])]
        if not kids:
            box = _Box(node, left, y, width, head, detail)
        else:
            box = _Box(node, (kids[0].x + kids[-1].x + kids[-1].width) / 2 - width / 2, y, width, head, detail)
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
    height = max(b.y for b in boxes) + BOX_PX + GAP_PX
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
        for child in children.get(box.node.id, []):
            c = where[child.id]
            parts.append(
                f'<line x1="{box.x + box.width / 2:.1f}" y1="{box.y + BOX_PX:.1f}" '
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
            f'<rect x="{box.x:.1f}" y="{box.y:.1f}" width="{box.width:.1f}" height="{BOX_PX}" rx="{radius}" '
            f'fill="{fill}" stroke="#333"/>'
        )
        middle = box.x + box.width / 2
        if box.detail:
            parts.append(f'<text x="{middle:.1f}" y="{box.y + 15:.1f}" text-anchor="middle">{escape(box.title)}</text>')
            parts.append(
                f'<text x="{middle:.1f}" y="{box.y + 30:.1f}" text-anchor="middle" font-size="10" fill="#444" '
                f'class="detail">{escape(box.detail)}</text>'
            )
        else:
            parts.append(f'<text x="{middle:.1f}" y="{box.y + 23:.1f}" text-anchor="middle">{escape(box.title)}</text>')
        parts.append("</g>")
    parts += legend_parts
    parts.append("</svg>")
    return "\n".join(parts) + "\n"


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

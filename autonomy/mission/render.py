"""Pictures of a built tree: unicode text, Graphviz DOT, and SVG (laid out here, no Graphviz needed)."""

from __future__ import annotations

from dataclasses import dataclass
from xml.sax.saxutils import escape

import py_trees

from autonomy.behaviours import RobotAction, RobotCondition
from autonomy.behaviours.tree import preorder

Behaviour = py_trees.behaviour.Behaviour

#: Colours and shapes by kind of node.
STYLES = {
    "sequence": ("#dbe9f6", "box"),
    "selector": ("#f6e3c7", "box"),
    "parallel": ("#e4dbf6", "box"),
    "decorator": ("#eeeeee", "hexagon"),
    "action": ("#d8f0d2", "box"),
    "condition": ("#fff3b0", "ellipse"),
}


def kind_of(node: Behaviour) -> str:
    """sequence, selector, parallel, decorator, action or condition."""
    if isinstance(node, py_trees.composites.Sequence):
        return "sequence"
    if isinstance(node, py_trees.composites.Selector):
        return "selector"
    if isinstance(node, py_trees.composites.Parallel):
        return "parallel"
    if isinstance(node, RobotCondition):
        return "condition"
    if isinstance(node, RobotAction):
        return "action"
    return "decorator" if node.children else "action"


def unicode_tree(root: Behaviour) -> str:
    """The tree as indented text with py_trees' symbols."""
    return py_trees.display.unicode_tree(root).rstrip() + "\n"


def dot_tree(root: Behaviour, title: str = "mission") -> str:
    """The tree in Graphviz DOT."""
    lines = [f'digraph "{_dot(title)}" {{', "  graph [ordering=out];", '  node [fontname="sans-serif", style=filled];']
    ids = {id(node): f"n{index}" for index, node in enumerate(preorder(root))}
    for node in preorder(root):
        fill, shape = STYLES[kind_of(node)]
        lines.append(f'  {ids[id(node)]} [label="{_dot(node.name)}", shape={shape}, fillcolor="{fill}"];')
    for node in preorder(root):
        for child in node.children:
            lines.append(f"  {ids[id(node)]} -> {ids[id(child)]};")
    lines.append("}")
    return "\n".join(lines) + "\n"


def _dot(text: str) -> str:
    return text.replace("\\", "\\\\").replace('"', '\\"')


@dataclass
class _Box:
    node: Behaviour
    x: float
    y: float
    width: float


CHAR_PX = 7.2
ROW_PX = 70
GAP_PX = 16
BOX_PX = 30


def svg_tree(root: Behaviour, title: str = "mission") -> str:
    """The tree as a standalone SVG picture: children below their parent, left to right."""
    boxes: list[_Box] = []
    cursor = [GAP_PX]

    def place(node: Behaviour, depth: int) -> _Box:
        width = max(60.0, CHAR_PX * len(node.name) + 20)
        y = GAP_PX + depth * ROW_PX
        left, first = cursor[0], len(boxes)
        if not node.children:
            box = _Box(node, left, y, width)
        else:
            kids = [place(child, depth + 1) for child in node.children]
            box = _Box(node, (kids[0].x + kids[-1].x + kids[-1].width) / 2 - width / 2, y, width)
            if box.x < left:  # a parent wider than its children: move the whole subtree right
                for placed in boxes[first:]:
                    placed.x += left - box.x
                box.x = left
        cursor[0] = max(cursor[0], box.x + width + GAP_PX)
        boxes.append(box)
        return box

    place(root, 0)
    shift = GAP_PX - min(b.x for b in boxes)
    for box in boxes:
        box.x += shift
    width = max(b.x + b.width for b in boxes) + GAP_PX
    height = max(b.y for b in boxes) + BOX_PX + GAP_PX
    where = {id(b.node): b for b in boxes}
    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" height="{height:.0f}" '
        f'viewBox="0 0 {width:.0f} {height:.0f}" font-family="sans-serif" font-size="12">',
        f"<title>{escape(title)}</title>",
    ]
    for box in boxes:
        for child in box.node.children:
            c = where[id(child)]
            parts.append(
                f'<line x1="{box.x + box.width / 2:.1f}" y1="{box.y + BOX_PX:.1f}" '
                f'x2="{c.x + c.width / 2:.1f}" y2="{c.y:.1f}" stroke="#666"/>'
            )
    for box in boxes:
        fill, shape = STYLES[kind_of(box.node)]
        radius = BOX_PX / 2 if shape == "ellipse" else (4 if shape == "box" else 10)
        parts.append(
            f'<rect x="{box.x:.1f}" y="{box.y:.1f}" width="{box.width:.1f}" height="{BOX_PX}" rx="{radius}" '
            f'fill="{fill}" stroke="#333"/>'
        )
        parts.append(
            f'<text x="{box.x + box.width / 2:.1f}" y="{box.y + BOX_PX / 2 + 4:.1f}" '
            f'text-anchor="middle">{escape(box.node.name)}</text>'
        )
    parts.append("</svg>")
    return "\n".join(parts) + "\n"

"""The tree in Graphviz DOT, for people who have Graphviz (``autonomy show --format dot``).

Text and SVG pictures, which need nothing installed, are in :mod:`autonomy.views`.
"""

from __future__ import annotations

from autonomy.record import NodeInfo
from autonomy.views.treesvg import FILLS
from autonomy.views.treetext import SHAPE_SYMBOLS, shape_of, type_text

#: Graphviz shapes by node category.
SHAPES = {"composite": "box", "decorator": "hexagon", "action": "box", "condition": "ellipse"}


def dot_tree(nodes: list[NodeInfo], title: str = "mission") -> str:
    """The tree in Graphviz DOT: each node's name, then its type and parameters."""
    lines = [f'digraph "{_dot(title)}" {{', "  graph [ordering=out];", '  node [fontname="sans-serif", style=filled];']
    for node in nodes:
        label = _dot(f"{SHAPE_SYMBOLS[shape_of(node)]} {node.name}")
        detail = type_text(node)
        if detail != node.name:
            label += f"\\n{_dot(detail)}"
        shape, fill = SHAPES.get(node.category, "box"), FILLS.get(node.category, "#eeeeee")
        lines.append(f'  n{node.id} [label="{label}", shape={shape}, fillcolor="{fill}"];')
    for node in nodes:
        if node.parent is not None:
            lines.append(f"  n{node.parent} -> n{node.id};")
    lines.append("}")
    return "\n".join(lines) + "\n"


def _dot(text: str) -> str:
    return text.replace("\\", "\\\\").replace('"', '\\"')

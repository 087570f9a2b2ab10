"""Small helpers over py_trees trees."""

from __future__ import annotations

from collections.abc import Iterator

import py_trees


def preorder(root: py_trees.behaviour.Behaviour) -> Iterator[py_trees.behaviour.Behaviour]:
    """Every node, parents before their children, children in order (py_trees' iterate() is post-order)."""
    stack = [root]
    while stack:
        node = stack.pop()
        yield node
        stack.extend(reversed(node.children))

"""Mutants of a mission: small changes a mission's tests should notice, for ``autonomy test --mutate``.

Each mutant changes one thing of the tree (its subtrees too): a sequence made a selector and back, a
condition inverted, a child left out, a number it was given moved by a fifth either way (within the
parameter's range), ``memory`` flipped. A mutant that some scenario fails on is caught; one that
every scenario passes is said as "your tests pass even when ...": a branch no scenario tells from
another, or a threshold no scenario comes near.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace

from autonomy.mission import MissionInvalid, MissionSpec, NodeSpec, build_tree

#: How far a number the file gave is moved, each way.
SHIFT = 0.2
#: The composites swapped for one another.
SWAPPED = {"sequence": "selector", "selector": "sequence"}


@dataclass(frozen=True)
class Mutant:
    """One small change of a mission.

    Attributes:
        change: What was changed, in words: ``'avoid' (sequence, line 12) is a selector``.
        spec: The mission with the change.
    """

    change: str
    spec: MissionSpec


def _where(node: NodeSpec) -> str:
    return f"'{node.display_name}' ({node.type.name}, line {node.line})"


def _changes(node: NodeSpec, spec: MissionSpec) -> Iterator[tuple[str, NodeSpec]]:
    """Each one-thing change of ``node`` itself: (what it is, the changed node)."""
    registry = spec.registry
    kind = node.type.name
    if kind in SWAPPED and SWAPPED[kind] in registry.names():
        other = registry.get(SWAPPED[kind])
        yield f"{_where(node)} is a {other.name}", replace(node, type=other)
    if node.type.category == "condition" and "invert" in registry.names():
        invert = registry.get("invert")
        inverted = NodeSpec(invert, {}, [node], None, node.path, node.line, node.column)
        yield f"{_where(node)} is inverted", inverted
    if node.type.category == "composite" and len(node.children) > 1:
        for k, child in enumerate(node.children):
            kept = node.children[:k] + node.children[k + 1 :]
            yield f"{_where(child)} is left out of {_where(node)}", replace(node, children=kept)
    for name in node.given:
        param, value = node.type.param(name), node.args.get(name)
        if param is None:
            continue
        if param.kind == "bool" and isinstance(value, bool):
            flipped = {**node.args, name: not value}
            yield f"{_where(node)} has {name} {str(not value).lower()}", replace(node, args=flipped)
        elif param.kind in ("int", "number") and isinstance(value, int | float) and not isinstance(value, bool):
            for factor in (1.0 - SHIFT, 1.0 + SHIFT):
                moved = value * factor
                moved = round(moved) if param.kind == "int" or isinstance(value, int) else round(moved, 3)
                low = param.minimum if param.minimum is not None else -float("inf")
                high = param.maximum if param.maximum is not None else float("inf")
                if moved == value or not low <= moved <= high or (param.positive and moved <= 0):
                    continue
                changed = {**node.args, name: moved}
                yield f"{_where(node)} has {name} {moved:g} instead of {value:g}", replace(node, args=changed)


def _mutated(node: NodeSpec, spec: MissionSpec) -> Iterator[tuple[str, NodeSpec]]:
    """Each one-thing change anywhere in ``node``'s subtree: (what it is, the subtree with it)."""
    yield from _changes(node, spec)
    for k, child in enumerate(node.children):
        for change, changed in _mutated(child, spec):
            yield change, replace(node, children=[*node.children[:k], changed, *node.children[k + 1 :]])


def mutants(spec: MissionSpec) -> list[Mutant]:
    """Every mutant of the mission that builds, the tree's first, then each subtree's."""
    found: list[Mutant] = []

    def keep(change: str, made: Callable[[], MissionSpec]) -> None:
        mutated = made()
        try:
            build_tree(mutated)
        except (MissionInvalid, ValueError, TypeError, KeyError):  # a change its nodes cannot take: no mutant
            return
        found.append(Mutant(change, mutated))

    for change, tree in _mutated(spec.tree, spec):
        keep(change, lambda tree=tree: replace(spec, tree=tree))
    for name, subtree in spec.subtrees.items():
        for change, changed in _mutated(subtree, spec):
            keep(f"{change} (in subtree '{name}')", lambda changed=changed, name=name: replace(
                spec, subtrees={**spec.subtrees, name: changed}))  # fmt: skip
    return found

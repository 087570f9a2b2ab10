"""Warnings: valid missions that behave in ways their authors rarely mean.

``autonomy check`` prints these after a file's problems, as ``FILE:LINE:COL: PATH: warning:
...``; they do not make the check fail. A teacher can lint a class's files before grading.

- A condition followed only by actions that finish at once (beep, log, servo, stop), under a
  ``repeat``: it succeeds in one tick and is started again on the next, so it fires on every
  tick while the condition holds; the collision flag alone is held for 0.5 s, ten ticks.
  Not when something that takes time follows it before the repeat comes round again.
- A ``repeat`` forever that nothing ends: no ``times``, no ``parallel``, ``timeout`` or
  ``while`` above it, and no condition below it that could fail and so end it.
- A ``move`` with no ending (no ``distance_mm``, ``seconds`` or ``until_obstacle_mm``) that
  nothing above it can stop: no ``parallel``, ``timeout`` or ``while``, and no ``selector``
  (without memory) with a branch before it, which takes over when it can.
"""

from __future__ import annotations

from collections.abc import Iterator

from autonomy.mission.validate import MissionSpec, NodeSpec
from autonomy.source import Problem

#: Actions that finish in the tick they start.
INSTANT_ACTIONS = ("beep", "log", "servo", "stop")
#: Nodes above which something can end what runs below them.
ENDERS = ("parallel", "timeout", "while")


def _walk(
    spec: MissionSpec, node: NodeSpec, above: tuple[NodeSpec, ...]
) -> Iterator[tuple[NodeSpec, tuple[NodeSpec, ...]]]:
    """Every node with the nodes above it, in preorder, subtrees expanded where they are used.

    A loop, not recursion: a chain of thousands of subtree references is walked too.
    """
    todo = [(node, above)]
    while todo:
        node, above = todo.pop()
        yield node, above
        children = node.children
        if node.type.name == "subtree":
            target = spec.subtrees.get(node.args.get("subtree", ""))
            if target is None or any(a.type.name == "subtree" and a.args == node.args for a in above):
                continue
            children = [target]
        todo.extend((child, (*above, node)) for child in reversed(children))


def _is_condition(node: NodeSpec) -> bool:
    """A condition, or a decorator that only turns one round (``invert: {do: collided}``)."""
    while node.type.name in ("invert", "force_success", "force_failure") and node.children:
        node = node.children[0]
    return node.type.category == "condition"


def _ticked_again(above: tuple[NodeSpec, ...]) -> bool:
    """Whether what succeeds here is started again: a ``repeat`` above it runs it anew after each success."""
    return any(a.type.name == "repeat" for a in above)


def _branches(node: NodeSpec, above: tuple[NodeSpec, ...]) -> Iterator[tuple[NodeSpec, int]]:
    """Each node above ``node``, nearest first, with the index among its children of the branch that leads down."""
    below = node
    for parent in reversed(above):
        index = next((i for i, child in enumerate(parent.children) if child is below), -1)  # -1: a subtree's
        yield parent, index
        below = parent


def _takes_time(spec: MissionSpec, node: NodeSpec) -> bool:
    """Whether ``node`` holds an action that takes time: anything but a beep, log, servo or stop."""
    return any(n.type.category == "action" and n.type.name not in INSTANT_ACTIONS for n, _ in _walk(spec, node, ()))


def _followed_by_time(spec: MissionSpec, node: NodeSpec, above: tuple[NodeSpec, ...]) -> bool:
    """Whether something that takes time (a wait, a move...) runs after ``node`` before its repeat starts it anew."""
    for parent, index in _branches(node, above):
        if parent.type.name == "repeat":
            return False
        after = parent.children[index + 1 :] if parent.type.name == "sequence" and index >= 0 else []
        if any(_takes_time(spec, c) for c in after):
            return True
    return False


#: Nodes a child's failure goes up through: a failing condition under them fails them too.
PASS_FAILURE_UP = ("sequence", "invert", "force_failure", "subtree")


def _can_fail(spec: MissionSpec, node: NodeSpec) -> bool:
    """Whether a condition below ``node`` can fail it, and so end a ``repeat`` (drive until a wall is near).

    Not one whose failure something on the way up takes in: a selector, a ``force_success``...
    """
    return any(
        n.type.category == "condition" and all(a.type.name in PASS_FAILURE_UP for a in above[1:])
        for n, above in _walk(spec, node, ())
    )


def _preempted(node: NodeSpec, above: tuple[NodeSpec, ...]) -> bool:
    """Whether something above ``node`` can end it: a parallel, timeout or while; a selector with a branch before it."""
    return any(
        parent.type.name in ENDERS or (parent.type.name == "selector" and index > 0 and not parent.args.get("memory"))
        for parent, index in _branches(node, above)
    )


def lint(spec: MissionSpec) -> list[Problem]:
    """The warnings for a valid mission, each at the node it is about, in file order."""
    found: dict[tuple[int, int, str], Problem] = {}

    def warn(node: NodeSpec, message: str) -> None:
        key = (node.line, node.column, message)
        found.setdefault(key, Problem(spec.source, node.line, node.column, node.path, f"warning: {message}"))

    for node, above in _walk(spec, spec.tree, ()):
        name = node.type.name
        if name == "sequence" and node.children and _ticked_again(above):
            first, rest = node.children[0], node.children[1:]
            if (
                _is_condition(first)
                and rest
                and all(c.type.name in INSTANT_ACTIONS for c in rest)
                and not _followed_by_time(spec, node, above)
            ):
                did = " and ".join(sorted({c.type.name for c in rest}))
                held = " (the collision flag stays set 0.5 s: about 10 ticks)" if first.type.name == "collided" else ""
                warn(
                    node,
                    f"'{first.display_name}' then only {did}, under a repeat: it runs again on every tick "
                    f"while '{first.display_name}' holds{held}; add an action that takes time (a move, a turn, "
                    "a wait) after it",
                )
        if name == "repeat" and node.children and node.children[0].type.name in INSTANT_ACTIONS:
            warn(
                node,
                f"repeats '{node.children[0].display_name}', which is done in one tick: it runs on every tick "
                f"({spec.tick_hz:g} times a second); put a wait after it in a sequence",
            )
        if (
            name == "repeat"
            and not node.args.get("times")
            and not any(a.type.name in ENDERS for a in above)
            and not _can_fail(spec, node)
        ):
            warn(
                node,
                "repeats forever and nothing ends it: the mission only ends if its child fails; give times:, "
                "or put it under a timeout, or in a parallel with a wait",
            )
        elif name == "move" and not any(node.args.get(k) for k in ("distance_mm", "seconds", "until_obstacle_mm")):
            if not _preempted(node, above):
                warn(
                    node,
                    "drives on until something stops it, and nothing here does: give distance_mm, seconds or "
                    "until_obstacle_mm, or put it after a condition in a selector, or in a parallel",
                )
    return sorted(found.values(), key=lambda p: (p.line, p.column))

"""Ticking a tree by calls instead of generators: py_trees' steps, in py_trees' order.

py_trees ticks a tree through generators: each node yields itself up through every one of
its ancestors, and every composite formats its debug-log lines on every tick and stop,
whether or not they are logged. On a 20-node tree that is most of what a tick costs.

:func:`tick_tree` ticks the same tree by calling each node's steps directly. A node whose
class ticks (or stops) as one of py_trees' ``Sequence``, ``Selector``, ``Parallel``,
``Decorator`` or ``OneShot``, or as our leaves do, that is whose class does not override
``tick`` (or ``stop``), has that method's steps run here in the same order, without the
debug lines: ``initialise``, ``update`` and ``terminate`` are called as py_trees calls
them, and statuses, ``current_child`` and feedback messages come out the same
(``tests/behaviours/test_engine.py`` ticks random trees both ways and compares every call).
One thing is left out: py_trees' ``stop`` makes the node a new ``iterator`` (a generator of its
``tick``) that py_trees itself never reads; making it was a twentieth of a tick, six times a tick.
Any other node is ticked or stopped through its own method. The class decides: a ``tick`` or
``stop`` set on one node object (a test's spy, say) is not looked for, since looking would
cost every node a look into its ``__dict__`` on every call, which makes Python give up the
compact attributes of every node (a tenth of a tick); patch the class instead. A ``tick``
generator is run to its end: unlike py_trees,
which drops a child's generator where its parent stops looking, code after its last ``yield``
always runs. Each level of a tree takes two Python frames here (one in py_trees), so a tree
more than about 490 levels deep (a long chain of subtrees, say) meets Python's recursion
limit, where py_trees' own ticking met it at about 990: the run then ends as a crash, with
the robot stopped.
"""

from __future__ import annotations

from collections.abc import Callable
from itertools import islice

from py_trees.behaviour import Behaviour
from py_trees.common import ParallelPolicy, Status
from py_trees.composites import Composite, Parallel, Selector, Sequence
from py_trees.decorators import Decorator, OneShot

from autonomy.behaviours.base import RobotBehaviour

RUNNING, SUCCESS, FAILURE, INVALID = Status.RUNNING, Status.SUCCESS, Status.FAILURE, Status.INVALID


def tick_tree(root: Behaviour) -> Status:
    """Ticks ``root`` once, as ``root.tick_once()`` does; returns its status."""
    tick(root)
    return root.status


def tick(node: Behaviour) -> None:
    """Ticks one node (and its subtree)."""
    # By the class's tick method as it is now: a class whose tick was replaced is noticed at once.
    # The steps below do this in place where they tick a child or stop a node as a tick goes
    # (a call less for each: a fiftieth of a tick).
    _KNOWN.get(node.__class__.tick, _by_generator)(node)


def stop(node: Behaviour, new_status: Status) -> None:
    """Stops one node (and halts its subtree) as its ``stop`` method does."""
    _KNOWN.get(node.__class__.stop, _by_method)(node, new_status)


# ---------------------------------------------------------------------------------- ticks


def _by_generator(node: Behaviour) -> None:
    for _ in node.tick():
        pass


def _leaf(node: Behaviour) -> None:
    """:meth:`py_trees.behaviour.Behaviour.tick` (as :meth:`RobotBehaviour.tick` runs it)."""
    if node.status is not RUNNING:
        node.initialise()
    _settle(node)


def _settle(node: Behaviour) -> None:
    """The end of every tick: ``update``'s result, checked, stops the node unless RUNNING."""
    new_status = node.update()
    if type(new_status) is not Status:
        node.logger.error(f"A behaviour returned an invalid status, setting to INVALID [{new_status}][{node.name}]")
        new_status = INVALID
    if new_status is not RUNNING:
        _KNOWN.get(node.__class__.stop, _by_method)(node, new_status)
    node.status = new_status


def _decorator(node: Decorator) -> None:  # type: ignore[misc]
    """:meth:`py_trees.decorators.Decorator.tick`."""
    if node.status is not RUNNING:
        node.initialise()
    _KNOWN.get(node.decorated.__class__.tick, _by_generator)(node.decorated)
    _settle(node)


def _one_shot(node: OneShot) -> None:  # type: ignore[misc]
    """:meth:`py_trees.decorators.OneShot.tick`: once done, the child is not ticked again."""
    if node.final_status:
        _leaf(node)
    else:
        _decorator(node)


def _sequence(node: Sequence) -> None:  # type: ignore[misc]
    """:meth:`py_trees.composites.Sequence.tick`."""
    children = node.children
    index = 0
    if node.status is not RUNNING:
        node.current_child = children[0] if children else None
        for child in children:
            if child.status is not INVALID:
                _KNOWN.get(child.__class__.stop, _by_method)(child, INVALID)
        node.initialise()
    elif node.memory and node.current_child is not None:
        index = children.index(node.current_child)
    else:
        node.current_child = children[0] if children else None
    if not children:
        node.current_child = None
        stop(node, SUCCESS)
        return
    for child in islice(children, index, None):  # the list itself, as py_trees: a child added now is ticked
        _KNOWN.get(child.__class__.tick, _by_generator)(child)
        if child.status is not SUCCESS:
            if not node.memory:
                for later in islice(children, index + 1, None):
                    if later.status is not INVALID:
                        stop(later, INVALID)
            if child.status is not RUNNING:
                _KNOWN.get(node.__class__.stop, _by_method)(node, child.status)
            else:
                node.status = child.status
            return
        if index + 1 < len(children):
            node.current_child = children[index + 1]
            index += 1
    stop(node, SUCCESS)


def _selector(node: Selector) -> None:  # type: ignore[misc]
    """:meth:`py_trees.composites.Selector.tick`."""
    children = node.children
    if node.status is not RUNNING:
        node.current_child = children[0] if children else None
        node.initialise()
    if not children:
        node.current_child = None
        stop(node, FAILURE)
        return
    if node.memory:
        if node.current_child is None:  # py_trees asserts it: a selector has a current child once ticked
            raise AssertionError(f"selector '{node.name}' has no current child")
        index = children.index(node.current_child)
        for child in islice(children, None, index):
            if child.status is not INVALID:
                stop(child, INVALID)
    else:
        index = 0
    previous = node.current_child
    for child in islice(children, index, None):
        _KNOWN.get(child.__class__.tick, _by_generator)(child)
        if child.status is RUNNING or child.status is SUCCESS:
            node.current_child = child
            if previous is None or previous != child:
                # it interrupted: everything of lower priority is invalidated
                passed = False
                for other in children:
                    if passed and other.status is not INVALID:
                        stop(other, INVALID)
                    passed = passed or other == child
            if child.status is SUCCESS:
                stop(node, child.status)
            else:
                node.status = child.status
            return
    stop(node, FAILURE)
    node.current_child = children[-1]


def _parallel(node: Parallel) -> None:  # type: ignore[misc]
    """:meth:`py_trees.composites.Parallel.tick`."""
    node.validate_policy_configuration()
    children = node.children
    if node.status is not RUNNING:
        for child in children:
            if child.status is not INVALID:
                stop(child, INVALID)
        node.current_child = None
        node.initialise()
    if not children:
        node.current_child = None
        stop(node, SUCCESS)
        return
    policy = node.policy
    for child in children:
        if policy.synchronise and child.status is SUCCESS:
            continue
        _KNOWN.get(child.__class__.tick, _by_generator)(child)
    new_status = RUNNING
    node.current_child = children[-1]
    failed = next((child for child in children if child.status is FAILURE), None)
    if failed is not None:
        node.current_child = failed
        new_status = FAILURE
    elif isinstance(policy, ParallelPolicy.SuccessOnAll):
        if all(child.status is SUCCESS for child in children):
            new_status = SUCCESS
            node.current_child = children[-1]
    elif isinstance(policy, ParallelPolicy.SuccessOnOne):
        for child in reversed(children):
            if child.status is SUCCESS:
                new_status = SUCCESS
                node.current_child = child
                break
    elif isinstance(policy, ParallelPolicy.SuccessOnSelected):
        if all(child.status is SUCCESS for child in policy.children):
            new_status = SUCCESS
            node.current_child = policy.children[-1]
    else:
        raise RuntimeError(f"this parallel has been configured with an unrecognised policy [{type(policy)}]")
    if new_status is not RUNNING:
        stop(node, new_status)
    node.status = new_status


# ---------------------------------------------------------------------------------- stops


def _stop_leaf(node: Behaviour, new_status: Status) -> None:
    """:meth:`py_trees.behaviour.Behaviour.stop` (as :meth:`RobotBehaviour.stop` runs it)."""
    node.terminate(new_status)
    node.status = new_status


def _stop_composite(node: Composite, new_status: Status) -> None:  # type: ignore[misc]
    """:meth:`py_trees.composites.Composite.stop`, which ``Sequence`` and ``Selector`` call."""
    if new_status is INVALID:
        node.current_child = None
        for child in node.children:
            if child.status is not INVALID:
                stop(child, new_status)
    node.terminate(new_status)
    node.status = new_status


def _stop_parallel(node: Parallel, new_status: Status) -> None:  # type: ignore[misc]
    """:meth:`py_trees.composites.Parallel.stop`: running children are halted first."""
    for child in node.children:
        if child.status is RUNNING:
            stop(child, INVALID)
    _stop_composite(node, new_status)


def _stop_decorator(node: Decorator, new_status: Status) -> None:  # type: ignore[misc]
    """:meth:`py_trees.decorators.Decorator.stop`."""
    node.terminate(new_status)
    if new_status is INVALID:
        stop(node.decorated, new_status)
    if node.decorated.status is RUNNING:
        stop(node.decorated, INVALID)
    node.status = new_status


def _by_method(node: Behaviour, new_status: Status) -> None:
    node.stop(new_status)


#: py_trees' tick and stop methods, and the steps here that do what each does. Any other tick is
#: run as the generator it is (py_trees' own leaves keep their debug lines), any other stop called.
_KNOWN: dict[Callable[..., object], Callable[..., None]] = {
    RobotBehaviour.tick: _leaf,
    Decorator.tick: _decorator,
    OneShot.tick: _one_shot,
    Sequence.tick: _sequence,
    Selector.tick: _selector,
    Parallel.tick: _parallel,
    RobotBehaviour.stop: _stop_leaf,
    Composite.stop: _stop_composite,
    Sequence.stop: _stop_composite,
    Selector.stop: _stop_composite,
    Parallel.stop: _stop_parallel,
    Decorator.stop: _stop_decorator,
}


__all__ = ["stop", "tick", "tick_tree"]

"""The tick engine ticks and halts any tree exactly as py_trees' own generators do.

Random trees of every composite and decorator a mission can hold, over scripted leaves
(ours and py_trees' own), are built twice. One copy is ticked with ``tick_once`` and halted
with ``stop``, the other with the engine; every call py_trees makes on a node (initialise,
update, terminate, in order) and every node's status, feedback and current child must agree
after every tick.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from unittest import mock

import py_trees
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from py_trees.common import OneShotPolicy, ParallelPolicy, Status

from autonomy.behaviours import ClockTimeout, RobotBehaviour, RobotContext, engine
from autonomy.clock import VirtualClock
from tests.harness import mission_files

MISSIONS = Path(__file__).resolve().parents[2] / "missions"
STATUSES = [Status.RUNNING, Status.SUCCESS, Status.FAILURE]


def logged(base: type) -> type:
    """``base`` with initialise and terminate noted in the tree's shared log."""

    class Logged(base):  # type: ignore[misc,valid-type]
        log: list[str]

        def initialise(self) -> None:
            self.log.append(f"{self.name} initialise from {self.status.name}")
            super().initialise()

        def terminate(self, new_status: Status) -> None:
            self.log.append(f"{self.name} terminate {self.status.name}->{new_status.name}")
            super().terminate(new_status)

    return Logged


def scripted(base: type) -> type:
    class Scripted(logged(base)):  # type: ignore[misc]
        script: list[Status]

        def update(self) -> Status:
            status = self.script[self.updates % len(self.script)]
            self.updates += 1
            self.log.append(f"{self.name} update -> {status.name}")
            self.feedback_message = f"update {self.updates}"
            return status

    return Scripted


OurLeaf, TheirLeaf = scripted(RobotBehaviour), scripted(py_trees.behaviour.Behaviour)
COMPOSITES = {
    "sequence": logged(py_trees.composites.Sequence),
    "selector": logged(py_trees.composites.Selector),
    "parallel": logged(py_trees.composites.Parallel),
}
DECORATORS = {
    "repeat": logged(py_trees.decorators.Repeat),
    "retry": logged(py_trees.decorators.Retry),
    "inverter": logged(py_trees.decorators.Inverter),
    "failure_is_success": logged(py_trees.decorators.FailureIsSuccess),
    "success_is_failure": logged(py_trees.decorators.SuccessIsFailure),
    "one_shot": logged(py_trees.decorators.OneShot),
    "timeout": logged(ClockTimeout),
}

leaves = st.tuples(st.just("leaf"), st.booleans(), st.lists(st.sampled_from(STATUSES), min_size=1, max_size=5))
trees = st.recursive(
    leaves,
    lambda children: st.one_of(
        st.tuples(st.sampled_from(sorted(COMPOSITES)), st.integers(0, 3), st.lists(children, max_size=4)),
        st.tuples(st.sampled_from(sorted(DECORATORS)), st.integers(0, 3), children),
    ),
    max_leaves=12,
)


def build(spec: Any, log: list[str], clock: VirtualClock, names: itertools.count) -> py_trees.behaviour.Behaviour:
    """One tree from ``spec``; the same spec builds the same tree (names included)."""
    kind, option, rest = spec
    name = f"{kind}{next(names)}"
    if kind == "leaf":
        node = (OurLeaf if option else TheirLeaf)(name)
        node.script, node.updates = rest, 0
    elif kind in COMPOSITES:
        children = [build(child, log, clock, names) for child in rest]
        if kind == "parallel":
            policy = [
                ParallelPolicy.SuccessOnOne(),
                ParallelPolicy.SuccessOnAll(synchronise=False),
                ParallelPolicy.SuccessOnAll(synchronise=True),
                ParallelPolicy.SuccessOnSelected(children[:1], synchronise=True),
            ][option if children else option % 3]
            node = COMPOSITES[kind](name, policy=policy, children=children)
        else:
            node = COMPOSITES[kind](name, memory=bool(option % 2), children=children)
    else:
        child = build(rest, log, clock, names)
        arguments = {
            "repeat": {"num_success": option + 1 if option < 3 else -1},
            "retry": {"num_failures": option + 1},
            "one_shot": {"policy": [OneShotPolicy.ON_COMPLETION, OneShotPolicy.ON_SUCCESSFUL_COMPLETION][option % 2]},
            "timeout": {"seconds": 0.1 * option},
        }.get(kind, {})
        node = DECORATORS[kind](name=name, child=child, **arguments)
    node.log = log
    return node


def state(root: py_trees.behaviour.Behaviour) -> list[tuple[object, ...]]:
    """Each node's status, feedback and current child.

    Not its ``iterator``: py_trees makes a new one at every stop and never reads it; the engine leaves it be.
    """
    seen = []
    for node in root.iterate():
        child = getattr(node, "current_child", None)
        current = child if child is None else child.name  # anything but a node or None fails here
        seen.append((node.name, node.status, node.feedback_message, current))
    return seen


def twins(spec: Any) -> tuple[tuple[Any, list[str], VirtualClock], ...]:
    made = []
    for _ in range(2):
        log: list[str] = []
        clock = VirtualClock()
        root = build(spec, log, clock, itertools.count())
        context = RobotContext(client=None, clock=clock)  # type: ignore[arg-type]
        for node in root.iterate():
            if isinstance(node, (ClockTimeout, RobotBehaviour)):
                node.setup(robot=context)
        made.append((root, log, clock))
    return tuple(made)


#: What a node is stopped with: INVALID when halted, or how it ended. Nothing stops a node with RUNNING (not
#: py_trees, not the runner), and py_trees' own tick trips over a memory selector stopped so.
HALTS = [Status.INVALID, Status.SUCCESS, Status.FAILURE]


@settings(max_examples=1000, deadline=None)
@given(trees, st.integers(1, 12), st.integers(0, 11), st.integers(0, 30), st.sampled_from(HALTS))
def test_the_engine_ticks_and_stops_any_tree_as_py_trees_does(spec, ticks, halt_at, which, halt_status):
    (theirs, their_log, their_clock), (ours, our_log, our_clock) = twins(spec)
    for number in range(ticks):
        theirs.tick_once()
        assert engine.tick_tree(ours) is ours.status
        assert our_log == their_log
        assert state(ours) == state(theirs)
        if number == halt_at:  # a node stopped in the middle (the root halted at a run's end, mostly)
            their_nodes, our_nodes = list(theirs.iterate()), list(ours.iterate())
            index = which % len(their_nodes) if which % 3 else 0
            their_nodes[index].stop(halt_status)
            engine.stop(our_nodes[index], halt_status)
            assert our_log == their_log
            assert state(ours) == state(theirs)
        their_clock.sleep(0.05)
        our_clock.sleep(0.05)


def test_every_node_of_a_shipped_mission_is_ticked_and_stopped_by_the_engine_itself():
    from autonomy.mission import build_tree, load_mission

    for path in mission_files(MISSIONS.glob("*.yaml")):
        for node in build_tree(load_mission(path)).iterate():
            assert type(node).tick in engine._KNOWN, (path.name, node.name)  # not run as a generator
            assert type(node).stop in engine._KNOWN, (path.name, node.name)  # nor stopped through its method


def test_a_node_that_ticks_and_stops_its_own_way_is_run_through_its_own_methods():
    class Custom(py_trees.behaviour.Behaviour):
        ticks = 0

        def update(self) -> Status:
            return Status.FAILURE  # never called: its tick decides

        def tick(self):
            Custom.ticks += 1
            self.status = Status.SUCCESS
            yield self

        def stop(self, new_status: Status = Status.INVALID) -> None:
            Custom.stops.append(new_status)
            super().stop(new_status)

    Custom.stops = []
    root = py_trees.composites.Sequence("s", memory=True, children=[Custom("custom")])
    assert engine.tick_tree(root) is Status.SUCCESS
    assert Custom.ticks == 1
    engine.tick_tree(root)  # a sequence starting again resets its children through their own stop
    assert Custom.stops == [Status.INVALID] and Custom.ticks == 2


@pytest.mark.parametrize("kind", ["sequence", "selector", "parallel"])
def test_a_composite_without_children_ends_as_py_trees_says(kind):
    (theirs, _, _), (ours, _, _) = twins((kind, 0, []))
    theirs.tick_once()
    engine.tick_tree(ours)
    assert state(ours) == state(theirs) and ours.status is not Status.RUNNING


class Grows(py_trees.behaviour.Behaviour):
    """A leaf that gives its parent one more child during its first tick (py_trees allows it)."""

    def __init__(self, name: str, added: Status, result: Status) -> None:
        super().__init__(name)
        self.added, self.result = added, result

    def update(self) -> Status:
        if not any(child.name == "added" for child in self.parent.children):
            self.parent.add_child(py_trees.behaviours.StatusQueue("added", [self.added], self.added))
        return self.result


@pytest.mark.parametrize(
    ("make", "result", "added"),
    [
        (lambda: py_trees.composites.Sequence("root", memory=False), Status.SUCCESS, Status.FAILURE),
        (lambda: py_trees.composites.Selector("root", memory=False), Status.FAILURE, Status.RUNNING),
    ],
)
def test_a_child_added_during_a_tick_is_ticked_in_that_tick_as_py_trees_does(make, result, added):
    seen = []
    for ticking in (lambda root: root.tick_once(), engine.tick_tree):
        root = make()
        root.add_child(Grows("grows", added, result))
        ticking(root)
        seen.append((root.status, [(child.name, child.status) for child in root.children]))
    assert seen[0] == seen[1] and seen[0][1][-1] == ("added", added)


def test_a_spy_on_a_class_s_tick_or_stop_sees_the_calls_py_trees_makes():
    class Leaf(RobotBehaviour):
        def update(self) -> Status:
            return Status.SUCCESS

    class Inner(py_trees.composites.Sequence):
        pass

    sequence_tick = py_trees.composites.Sequence.tick
    counts = []
    for ticking in (lambda root: root.tick_once(), engine.tick_tree):
        inner = Inner("inner", memory=False, children=[py_trees.behaviours.Success("x")])
        root = py_trees.composites.Sequence("root", memory=False, children=[Leaf("leaf"), inner])
        ticked = []

        def spy(self: Inner, ticked: list[str] = ticked) -> Iterator[py_trees.behaviour.Behaviour]:
            # counted when it runs: py_trees also calls tick() at a stop, for a generator it never runs
            ticked.append(self.name)
            yield from sequence_tick(self)

        with mock.patch.object(Leaf, "stop", autospec=True, side_effect=RobotBehaviour.stop) as stops:
            with mock.patch.object(Inner, "tick", spy):
                ticking(root)
                ticking(root)
        counts.append((stops.call_count, len(ticked)))
    assert counts[0] == counts[1] and counts[0][0] > 0 and counts[0][1] > 0


def test_a_class_whose_tick_is_replaced_after_it_was_seen_ticks_the_new_way():
    def fails(self):
        self.status = Status.FAILURE
        yield self

    class Leaf(RobotBehaviour):
        def update(self) -> Status:
            return Status.SUCCESS

    root = py_trees.composites.Sequence("root", memory=False, children=[Leaf("leaf")])
    assert engine.tick_tree(root) is Status.SUCCESS
    with mock.patch.object(Leaf, "tick", fails):
        assert engine.tick_tree(root) is Status.FAILURE
    assert engine.tick_tree(root) is Status.SUCCESS

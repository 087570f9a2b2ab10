"""Validated missions build the py_trees objects the format promises."""

import py_trees
from py_trees.common import OneShotPolicy, ParallelPolicy

from autonomy.behaviours import ClockTimeout
from autonomy.behaviours.actions import Move, Turn
from autonomy.behaviours.conditions import Collided
from tests.harness import tree_of


def test_composites_and_their_memory_defaults():
    root = tree_of(
        "  sequence:\n    - sequence: [stop]\n    - sequence: {memory: false, children: [stop]}\n"
        "    - selector: [stop]\n    - fallback: {memory: true, children: [stop]}\n"
        "    - parallel: [stop]\n    - parallel: {policy: one, children: [stop]}\n"
    )
    seq, seq_nomem, sel, fallback, par_all, par_one = root.children
    assert isinstance(root, py_trees.composites.Sequence) and root.memory is True
    assert seq.memory is True and seq_nomem.memory is False
    assert isinstance(sel, py_trees.composites.Selector) and sel.memory is False
    assert isinstance(fallback, py_trees.composites.Selector) and fallback.memory is True
    assert isinstance(par_all.policy, ParallelPolicy.SuccessOnAll) and par_all.policy.synchronise
    assert isinstance(par_one.policy, ParallelPolicy.SuccessOnOne)


def test_decorators():
    root = tree_of(
        "  sequence:\n    - repeat: {times: 3, do: stop}\n    - repeat: {do: stop}\n"
        "    - retry: {attempts: 2, do: stop}\n    - timeout: {seconds: 1.5, do: stop}\n"
        "    - invert: {do: collided}\n    - force_success: {do: stop}\n    - force_failure: {do: stop}\n"
        "    - once: {do: stop}\n    - while: {do: {move: {speed: 1}}, condition: collided}\n"
    )
    repeat, forever, retry, timeout, invert, force_s, force_f, once, while_ = root.children
    assert isinstance(repeat, py_trees.decorators.Repeat) and repeat.num_success == 3
    assert forever.num_success == -1
    assert isinstance(retry, py_trees.decorators.Retry) and retry.num_failures == 2
    assert isinstance(timeout, ClockTimeout) and timeout.seconds == 1.5
    assert not isinstance(timeout, py_trees.decorators.Timeout)  # py_trees' Timeout reads time.monotonic
    assert isinstance(invert, py_trees.decorators.Inverter)
    assert isinstance(force_s, py_trees.decorators.FailureIsSuccess)
    assert isinstance(force_f, py_trees.decorators.SuccessIsFailure)
    assert isinstance(once, py_trees.decorators.OneShot) and once.policy == OneShotPolicy.ON_COMPLETION
    # while: a sequence without memory, the condition first whatever order the file gave
    assert isinstance(while_, py_trees.composites.Sequence) and while_.memory is False
    assert [type(c) for c in while_.children] == [Collided, Move]


def test_subtrees_are_fresh_copies_named_after_the_subtree():
    root = tree_of(
        "  sequence: [{subtree: corner}, {subtree: corner}]\n",
        "subtrees:\n  corner:\n    sequence: [{turn: {left: 90}}, beep]\n",
    )
    first, second = root.children
    assert first is not second and first.children[0] is not second.children[0]
    assert first.name == second.name == "corner"
    assert isinstance(first.children[0], Turn)


def test_display_names():
    root = tree_of(
        "  sequence:\n    - move: {speed: 2, distance_mm: 300}\n"
        "    - move: {speed: 1, direction: backward, seconds: 2}\n"
        "    - move: {speed: 3, until_obstacle_mm: 100, name: to the wall}\n    - turn: {right: 45}\n"
        "    - servo: {id: 1, by: -3}\n    - obstacle_within: {mm: 120}\n    - battery_above: {level: 60}\n"
    )
    assert [c.name for c in root.children] == [
        "move 300 mm",
        "move backward 2 s",
        "to the wall",
        "turn right 45 deg",
        "servo 1 by -3 deg",
        "obstacle within 120 mm",
        "battery above 60",
    ]

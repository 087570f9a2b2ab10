"""Our leaves tick exactly as py_trees' own leaves do (they skip only py_trees' debug logging)."""

from __future__ import annotations

import py_trees
from py_trees.common import Status

from autonomy.behaviours.base import RobotBehaviour

SCRIPT = [Status.RUNNING, Status.RUNNING, Status.SUCCESS, Status.RUNNING, Status.FAILURE, Status.SUCCESS]


def scripted(base: type) -> type:
    """A leaf on ``base`` that returns SCRIPT in turn and notes every call py_trees makes on it."""

    class Scripted(base):  # type: ignore[misc,valid-type]
        def __init__(self) -> None:
            super().__init__("scripted")
            self.calls: list[str] = []
            self.left = list(SCRIPT)

        def initialise(self) -> None:
            self.calls.append(f"initialise from {self.status.name}")

        def update(self) -> Status:
            self.calls.append("update")
            return self.left.pop(0)

        def terminate(self, new_status: Status) -> None:
            self.calls.append(f"terminate {self.status.name}->{new_status.name}")

    return Scripted


def history(node: py_trees.behaviour.Behaviour) -> list[object]:
    """Ticks ``node`` through SCRIPT, halting it once while RUNNING; returns the calls and statuses seen."""
    seen: list[object] = []
    for step in range(len(SCRIPT)):
        iterator = node.iterator
        ticked = list(node.tick())
        seen.append((ticked == [node], node.status, node.iterator is not iterator))  # a stop makes a new one
        if step == 3:  # halted by a parent while RUNNING
            node.stop(Status.INVALID)
            seen.append(node.status)
    return [*node.calls, *seen]


def test_our_leaf_calls_initialise_update_and_terminate_as_py_trees_does():
    ours, theirs = scripted(RobotBehaviour)(), scripted(py_trees.behaviour.Behaviour)()
    assert history(ours) == history(theirs)
    assert ours.calls[:4] == ["initialise from INVALID", "update", "update", "update"]


def test_a_result_that_is_not_a_status_is_invalid_and_logged(capsys):
    node = scripted(RobotBehaviour)()
    node.update = lambda: "done"  # set on the instance: not checked when the class was made
    node.tick_once()
    assert node.status is Status.INVALID
    assert "invalid status, setting to INVALID [done][scripted]" in capsys.readouterr().out

"""Conditions read the polled snapshot and never talk to the robot themselves."""

import pytest
from py_trees.common import Status

from autonomy.behaviours.conditions import AutoMode, BatteryAbove, Collided, Healthy, Moving, ObstacleWithin, TiltWithin
from tests.harness import Rig


@pytest.mark.parametrize(
    ("condition", "query", "holds"),
    [
        (ObstacleWithin("o", mm=200), "world=box", False),  # 880 mm of free floor
        (Collided("c"), "", False),
        (Moving("m"), "", False),
        (AutoMode("a"), "", True),
        (AutoMode("a"), "mode=manual", False),
        (TiltWithin("t", degrees=0), "", True),
        (BatteryAbove("b", level=100), "battery=101", True),
        (BatteryAbove("b", level=100), "battery=100", False),
        (Healthy("h"), "", True),
        (Healthy("h"), "battery=30", False),
    ],
)
def test_conditions_on_a_fresh_robot(condition, query, holds):
    rig = Rig(condition, query)
    assert rig.tick() == (Status.SUCCESS if holds else Status.FAILURE)


def test_conditions_send_nothing_of_their_own():
    rig = Rig(ObstacleWithin("o", mm=100))
    before = len(rig.emulator.log)
    rig.runner.tick()
    polls = [e.frame for e in list(rig.emulator.log)[before:]]
    # the runner's polls, nothing more (a link's first status is read twice, to be trusted)
    assert polls == [b"Gb000\n", b"Gb000\n", b"GB000\n", b"GR000\n"]


def test_obstacle_within_sees_the_wall_ahead():
    rig = Rig(ObstacleWithin("o", mm=150), "world=box")
    rig.client.port.emulator.robot.x_mm = 1800  # 140 mm from the east wall
    assert rig.tick() == Status.SUCCESS
    assert rig.root.feedback_message == "front 140 mm"


def test_moving_and_collided_follow_the_robot():
    rig = Rig(Moving("m"), "world=box")
    rig.client.move(2)
    rig.client.clock.sleep(0.2)
    assert rig.tick() == Status.SUCCESS
    collided = Rig(Collided("c"), "world=box")
    collided.client.move(4)
    while not collided.emulator.robot.impacts:
        collided.client.clock.sleep(0.05)
        collided.emulator.advance()
    assert collided.tick() == Status.SUCCESS

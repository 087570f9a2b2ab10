"""Actions fed status packets written by hand, tick by tick: the exact edges of when they end.

The emulator cannot put a reading exactly on a limit at an exact time; here each packet and
each instant is chosen, so a limit met exactly, a collision on the first tick or a corrected
reading in the middle of a drift each get a test of their own.
"""

from __future__ import annotations

import pytest
from py_trees.common import Status

from autonomy.behaviours.actions import Move, Turn, Wait
from autonomy.behaviours.base import RobotContext
from autonomy.clock import VirtualClock
from autonomy.protocol import Status as Packet


class Link:
    """Stands in for the client: notes each command an action sends, and accepts it."""

    def __init__(self) -> None:
        self.sent: list[str] = []

    def move(self, speed: int, backward: bool = False) -> None:
        self.sent.append(f"F{'-' if backward else '+'}{speed}")

    def stop(self) -> None:
        self.sent.append("X")

    def turn(self, angle_deg: int) -> None:
        self.sent.append(f"T{angle_deg:+d}")


def packet(
    odometer_mm: int = 1000, heading_deg: int = 0, front_mm: int = 255, moving: bool = True, collided: bool = False
) -> Packet:
    return Packet(1, True, collided, moving, 0, heading_deg, front_mm, odometer_mm)


class Script:
    """One action, ticked at chosen instants with chosen packets."""

    def __init__(self, action) -> None:
        self.action, self.link, self.clock = action, Link(), VirtualClock()
        self.context = RobotContext(client=self.link, clock=self.clock)  # type: ignore[arg-type]
        action.setup(robot=self.context)

    def tick(self, at_s: float, status: Packet, rebased: bool = False) -> Status:
        """The first tick starts the action (it sends its command) with that tick's packet, as in a run."""
        self.clock.advance_to(at_s)
        self.context.polled, self.context.rebased = (status, 100, True), rebased
        self.action.tick_once()
        return self.action.status


def move(**args) -> Move:
    full = {"speed": 2, "direction": "forward", "distance_mm": None, "seconds": None, "until_obstacle_mm": None}
    return Move("move", **{**full, **args})


# ---------------------------------------------------------------- move


def test_a_move_ends_on_the_tick_it_has_covered_exactly_its_distance():
    script = Script(move(distance_mm=100))
    assert script.tick(0.0, packet(1000)) == Status.RUNNING
    assert script.tick(0.05, packet(1099)) == Status.RUNNING
    assert script.tick(0.10, packet(1100)) == Status.SUCCESS
    assert script.link.sent == ["F+2", "X"] and script.action.feedback_message == "drove 100 mm"


def test_a_move_for_seconds_ends_on_the_tick_at_exactly_its_time():
    script = Script(move(seconds=1.0))
    assert script.tick(0.0, packet(1000)) == Status.RUNNING
    assert script.tick(0.5, packet(1040)) == Status.RUNNING
    assert script.tick(1.0, packet(1080)) == Status.SUCCESS
    assert script.action.feedback_message == "drove for 1.0 s"


def test_a_move_until_an_obstacle_goes_on_at_the_distance_and_ends_below_it():
    script = Script(move(until_obstacle_mm=100))
    assert script.tick(0.0, packet(1000, front_mm=101)) == Status.RUNNING
    assert script.tick(0.05, packet(1010, front_mm=100)) == Status.RUNNING
    assert script.action.feedback_message == "10 mm, front 100 mm"
    assert script.tick(0.10, packet(1020, front_mm=99)) == Status.SUCCESS
    assert script.action.feedback_message == "obstacle at 99 mm"


def test_a_move_not_moving_after_exactly_its_stall_time_fails_and_says_why():
    script = Script(move(distance_mm=500))
    assert script.tick(0.0, packet(1000, moving=False)) == Status.RUNNING
    assert script.tick(Move.STALL_S - 0.05, packet(1000, moving=False)) == Status.RUNNING
    assert script.tick(Move.STALL_S, packet(1000, moving=False)) == Status.FAILURE
    assert script.action.feedback_message == "blocked after 0 mm: the robot is not moving (an obstacle, or its remote?)"


def test_a_move_pushing_on_what_it_touched_before_it_started_is_blocked_not_collided():
    script = Script(move(distance_mm=500))
    assert script.tick(0.0, packet(1000, moving=False, collided=True)) == Status.RUNNING
    assert script.tick(Move.STALL_S, packet(1000, moving=False, collided=True)) == Status.FAILURE
    assert script.action.feedback_message == "blocked after 0 mm: the robot is pushing against an obstacle"


def test_a_corrected_reading_in_a_backward_drift_neither_adds_to_it_nor_takes_from_it():
    """Windows of -30, 0 (a correction), -28, -26, -16 mm: slowing down, but 100 mm backward in all."""
    script = Script(move(distance_mm=5000))
    odometer = 1000
    assert script.tick(0.0, packet(odometer)) == Status.RUNNING
    for step, (mm, rebased) in enumerate([(-30, False), (500, True), (-28, False), (-26, False)]):
        odometer += mm
        assert script.tick(0.05 * (step + 1), packet(odometer), rebased) == Status.RUNNING, step
    assert script.tick(0.25, packet(odometer - 16)) == Status.FAILURE
    assert script.action.feedback_message == "moving the wrong way: 100 mm backward (asked forward)"


def test_the_label_of_a_move_until_an_obstacle():
    assert Move.label({"speed": 2, "until_obstacle_mm": 120}) == "move until < 120 mm"
    assert Move.label({"speed": 2, "direction": "backward", "seconds": 2}) == "move backward 2 s"


# ---------------------------------------------------------------- turn


def test_a_turn_keeps_its_parameters_as_given():
    assert Turn("turn", left=90).args == {"left": 90} and Turn("turn", right=30).angle_deg == -30


def test_a_turn_collided_says_how_far_it_had_to_go():
    script = Script(Turn("turn", left=90))
    assert script.tick(0.0, packet(heading_deg=0)) == Status.RUNNING
    assert script.tick(0.05, packet(heading_deg=30, collided=True)) == Status.FAILURE
    assert script.action.feedback_message == "collided with 60 deg to go" and script.link.sent == ["T+90", "X"]


def test_a_right_turn_says_what_is_left_of_it_as_asked_not_as_a_signed_heading():
    """turn right 70: the heading counts left positive, the messages count the way the turn was asked."""
    script = Script(Turn("turn", right=70))
    assert script.tick(0.0, packet(heading_deg=0)) == Status.RUNNING
    assert script.tick(0.05, packet(heading_deg=340)) == Status.RUNNING
    assert script.action.feedback_message == "50 deg to go"
    assert script.tick(0.10, packet(heading_deg=330, collided=True)) == Status.FAILURE
    assert script.action.feedback_message == "collided with 40 deg to go" and script.link.sent == ["T-70", "X"]


def test_a_turn_past_its_target_says_how_far_past_and_ends_saying_how_far_it_went_and_which_way():
    script = Script(Turn("turn", left=10))
    assert script.tick(0.0, packet(heading_deg=0)) == Status.RUNNING
    assert script.tick(0.05, packet(heading_deg=16)) == Status.RUNNING  # still moving, 6 deg past
    assert script.action.feedback_message == "6 deg past"
    assert script.tick(0.10, packet(heading_deg=12, moving=False)) == Status.SUCCESS
    assert script.action.feedback_message == "turned 12 deg left"


@pytest.mark.parametrize(("side", "angle_deg"), [("right", 0), ("right", 2), ("left", 0)])
def test_a_turn_that_went_nowhere_says_the_way_it_was_asked(side, angle_deg):
    """0 degrees has no sign of its own: the message names the side the mission asked for."""
    script = Script(Turn("turn", **{side: angle_deg}))
    assert script.tick(0.0, packet(heading_deg=0, moving=False)) == Status.SUCCESS  # within 3 degrees, at rest
    assert script.action.feedback_message == f"turned 0 deg {side}"


def test_a_turn_times_out_only_after_its_deadline():
    """90 degrees at 90 deg/s: 1 s expected, so the deadline is 2 x 1 s + 2 s = 4 s after the start."""
    script = Script(Turn("turn", left=90))
    assert script.tick(0.0, packet(heading_deg=0)) == Status.RUNNING
    for at_s in (1.0, 2.0, 3.0, 4.0):
        assert script.tick(at_s, packet(heading_deg=45)) == Status.RUNNING, at_s
    assert script.action.feedback_message == "45 deg to go"
    assert script.tick(4.05, packet(heading_deg=45)) == Status.FAILURE
    assert script.action.feedback_message == "timed out with 45 deg to go"


def test_a_one_degree_turn_going_the_wrong_way_says_it_was_asked_left():
    script = Script(Turn("turn", left=1))
    assert script.tick(0.0, packet(heading_deg=0)) == Status.RUNNING
    assert script.tick(0.10, packet(heading_deg=0)) == Status.RUNNING  # past the robot's delay (RESPONSE_S)
    assert script.tick(0.20, packet(heading_deg=355)) == Status.RUNNING
    assert script.tick(0.25, packet(heading_deg=350)) == Status.FAILURE
    assert script.action.feedback_message == "turning the wrong way: 10 deg right (asked left)"


def test_a_robot_still_turning_as_a_turn_starts_goes_on_as_it_was_for_a_moment():
    """Its delay (the link, its motors): 0.15 s of the old turn at full rate is not the new turn's wrong way."""
    script = Script(Turn("turn", left=90))
    assert script.tick(0.0, packet(heading_deg=0)) == Status.RUNNING  # still turning right from before
    for step in (1, 2):  # 0.05, 0.10 s: 5 degrees right a tick, not slowing, within the delay
        assert script.tick(0.05 * step, packet(heading_deg=360 - 5 * step)) == Status.RUNNING
    assert script.tick(0.15, packet(heading_deg=345)) == Status.RUNNING  # one window past the delay: not yet
    assert script.tick(0.20, packet(heading_deg=340)) == Status.FAILURE  # two: it is the wrong way
    assert script.action.feedback_message == "turning the wrong way: 20 deg right (asked left)"


def test_a_turn_of_nothing_has_no_wrong_way():
    """A zero turn waits for the robot to settle; a drift either way is not the wrong way."""
    script = Script(Turn("turn", left=0))
    for tick in range(6):
        assert script.tick(0.05 * tick, packet(heading_deg=100 - 2 * tick)) == Status.RUNNING
    assert script.tick(0.30, packet(heading_deg=98, moving=False)) == Status.SUCCESS


def test_a_corrected_heading_is_not_a_turn_the_wrong_way():
    """A jump of 60 degrees back is a correction: the turn goes on (it is counted in what is left to turn)."""
    script = Script(Turn("turn", left=90))
    assert script.tick(0.0, packet(heading_deg=0)) == Status.RUNNING
    assert script.tick(0.05, packet(heading_deg=300), rebased=True) == Status.RUNNING
    assert script.tick(0.10, packet(heading_deg=300), rebased=True) == Status.RUNNING


def test_a_corrected_heading_in_a_drift_the_wrong_way_is_left_out_of_its_total():
    """Windows of -8, 0 (a correction), -6, -4, -2 degrees: slowing down, but 20 degrees right in all."""
    script = Script(Turn("turn", left=90))
    heading = 100
    assert script.tick(0.0, packet(heading_deg=heading)) == Status.RUNNING
    for step, (deg, rebased) in enumerate([(-8, False), (40, True), (-6, False), (-4, False)]):
        heading += deg
        assert script.tick(0.05 * (step + 1), packet(heading_deg=heading), rebased) == Status.RUNNING, step
    assert script.tick(0.25, packet(heading_deg=heading - 2)) == Status.FAILURE
    assert script.action.feedback_message == "turning the wrong way: 20 deg right (asked left)"


# ---------------------------------------------------------------- wait


def test_a_wait_within_a_nanosecond_of_its_end_is_over():
    script = Script(Wait("wait", seconds=1e-9))
    assert script.tick(0.0, packet()) == Status.SUCCESS

"""Actions ticked one at a time against the emulator: what they send, when they end."""

import pytest
from py_trees.common import Status

from autonomy.behaviours.actions import Beep, Log, Move, Servo, Stop, Turn, Wait
from autonomy.protocol import Beep as BeepCommand
from autonomy.protocol import Move as MoveCommand
from autonomy.protocol import ServoBy, ServoTo
from autonomy.protocol import Stop as StopCommand
from autonomy.protocol import Turn as TurnCommand
from tests.harness import Recorder, Rig, tree_of


def move(**args) -> Move:
    full = {"speed": 2, "direction": "forward", "distance_mm": None, "seconds": None, "until_obstacle_mm": None}
    full.update(args)
    return Move("move", **full)


def test_move_a_distance_sends_f_then_x_and_ends_near_it():
    rig = Rig(move(distance_mm=300), "world=empty")
    assert rig.tick() == Status.RUNNING
    assert rig.sent() == [MoveCommand(2)]
    assert rig.tick_until_done() == Status.SUCCESS
    assert rig.sent() == [MoveCommand(2), StopCommand()]
    travelled = rig.robot.x_mm - 10000
    assert 300 <= travelled <= 300 + 11 + 16  # one tick of driving, then the slow-down after X


def test_move_backward_counts_the_odometer_down():
    rig = Rig(move(distance_mm=200, direction="backward"), "world=empty")
    assert rig.tick_until_done() == Status.SUCCESS
    assert rig.sent()[0] == MoveCommand(2, backward=True)
    assert 9770 <= rig.robot.x_mm <= 9800


def test_move_for_seconds():
    rig = Rig(move(seconds=1.0), "world=empty")
    rig.tick_until_done()
    assert rig.client.clock.now() == pytest.approx(1.0, abs=0.11)


def test_move_until_obstacle_stops_short_without_touching():
    rig = Rig(move(speed=3, until_obstacle_mm=100), "world=box")
    assert rig.tick_until_done() == Status.SUCCESS
    gap = rig.robot.true_front_gap_mm()
    assert 20 < gap < 100 and not rig.robot.impacts


def test_move_fails_on_a_collision_and_stops():
    rig = Rig(move(speed=2), "world=box")
    assert rig.tick_until_done() == Status.FAILURE
    assert "collided" in rig.root.feedback_message
    assert rig.sent() == [MoveCommand(2), StopCommand()]
    assert len(rig.robot.impacts) == 1


def test_move_starting_against_a_wall_fails_as_blocked():
    first = Rig(move(speed=2), "world=box")
    first.tick_until_done()  # now touching the east wall, collision flag held
    again = Rig(move(speed=1), client=first.client)  # the same robot, a new move
    started_s = again.client.clock.now()
    assert again.tick_until_done() == Status.FAILURE
    assert again.root.feedback_message.startswith("blocked after 0 mm")
    assert again.client.clock.now() - started_s < 1.0


def test_move_refused_in_manual_mode_fails_with_a_hint():
    rig = Rig(move(speed=1), "mode=manual")
    assert rig.tick() == Status.FAILURE
    assert "manual mode" in rig.root.feedback_message
    assert rig.sent() == []


def test_halting_a_move_sends_stop():
    rig = Rig(move(speed=2), "world=empty")
    rig.tick(5)
    rig.root.stop(Status.INVALID)
    assert rig.sent() == [MoveCommand(2), StopCommand()]


@pytest.mark.parametrize(("args", "expected_deg"), [({"left": 90}, 90), ({"right": 90}, 270), ({"left": 400}, 40)])
def test_turn_ends_within_3_degrees(args, expected_deg):
    rig = Rig(Turn("turn", **args))
    assert rig.tick_until_done() == Status.SUCCESS
    heading = rig.robot.heading_deg % 360
    assert abs((heading - expected_deg + 180) % 360 - 180) <= 3
    assert rig.sent() == [TurnCommand(args.get("left", -args.get("right", 0)))]


def test_turn_times_out_when_the_robot_turns_slower_than_expected():
    rig = Rig(Turn("turn", left=360))
    rig.runner.context.turn_rate_deg_s = 1000.0  # expects 0.36 s; the robot takes 4 s
    assert rig.tick_until_done() == Status.FAILURE
    assert "timed out" in rig.root.feedback_message
    assert rig.sent()[-1] == StopCommand()


def test_stop_beep_servo_and_log_succeed_at_once():
    recorder = Recorder()
    root = tree_of(
        "  sequence:\n    - stop\n    - beep: {tones: [1, 6, 2], volume: 5}\n"
        "    - servo: {id: 1, angle: -45}\n    - servo: {id: 2, by: 7}\n    - log: {message: hello}\n"
    )
    rig = Rig(root)
    rig.runner.listeners.append(recorder)
    assert rig.tick() == Status.SUCCESS
    assert rig.sent() == [StopCommand(), BeepCommand((1, 6, 2), 5), ServoTo(1, -45), ServoBy(2, 7)]
    assert recorder.events("log") == ["hello"]


def test_wait_runs_for_its_seconds_in_virtual_time():
    rig = Rig(Wait("wait", seconds=2.0), tick_hz=10)
    ticks = 0
    while rig.tick() == Status.RUNNING:
        ticks += 1
    assert ticks == 20 and rig.sent() == []


def test_leaf_classes_are_plain_behaviours_without_io_before_setup():
    for node in (move(distance_mm=1), Turn("t", left=1), Stop("s"), Beep("b", tones=[1, 1, 1], volume=1)):
        assert node.robot is None  # __init__ configures only
    assert Servo("s", id=0, angle=1, by=None).args["angle"] == 1
    assert Log.node_type == "log"


def test_a_turn_built_in_code_needs_one_side():
    import pytest as _pytest

    from autonomy.behaviours.actions import Turn as TurnNode

    for args in ({}, {"left": 90, "right": 90}):
        with _pytest.raises(ValueError, match="turn takes one of left= or right=, in degrees"):
            TurnNode("t", **args)
    assert TurnNode("t", right=45).angle_deg == -45 and TurnNode("t", left=0).angle_deg == 0


def test_the_wrong_way_is_two_backward_windows_not_slowing_or_the_total():
    from autonomy.behaviours.actions import WrongWay

    def feed(steps, step_limit=1.0, total_limit=20.0):
        watch = WrongWay(step_limit, total_limit)
        watch.reset(10.0)
        out = []
        for tick, step in enumerate(steps, start=1):
            out.append(watch.update(step, 10.0 + 0.05 * tick))  # one window a tick, at 20 Hz
        return out

    assert feed([-2, -2]) == [0.0, 4.0]  # two windows backward, not slowing: counts, with the travel so far
    assert feed([-2, -2, -2]) == [0.0, 4.0, 6.0]
    assert feed([-1, -1, -1]) == [0.0, 0.0, 0.0]  # exactly the step limit a window: not more than it
    assert feed([-2, 0.5, -2]) == [0.0, 0.0, 0.0]  # going forward between: starts again
    assert feed([-6, -2, -2]) == [0.0, 0.0, 0.0]  # slowing down by more than the limit: rolling back
    assert feed([5, -2, -2]) == [0.0, 0.0, 4.0]  # forward travel does not pay for backward travel
    assert feed([-19.5, 19.5, -0.5], total_limit=20.0) == [0.0, 0.0, 0.0]
    assert feed([-12, 11, -8.5], total_limit=20.0) == [0.0, 0.0, 0.0]
    assert feed([-10, -10], step_limit=15.0, total_limit=20.0) == [0.0, 20.0]  # the total, exactly, counts
    assert feed([-10, -9.5], step_limit=15.0, total_limit=20.0) == [0.0, 0.0]


def test_progress_within_one_window_is_summed_before_it_is_judged():
    from autonomy.behaviours.actions import WrongWay

    watch = WrongWay(1.0, 50.0)
    watch.reset(0.0)
    # At 200 Hz: twenty ticks of -0.5 are two windows of -5 each (a window closes once 50 ms have passed).
    seen = [watch.update(-0.5, 0.005 * tick) for tick in range(1, 21)]
    assert seen[:19] == [0.0] * 19 and seen[19] == 10.0

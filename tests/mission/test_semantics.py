"""What trees do when ticked: preemption, halting, time-outs on the run's clock, counts."""

from py_trees.common import Status

from autonomy.protocol import Move as MoveCommand
from autonomy.protocol import Stop as StopCommand
from autonomy.protocol import Turn as TurnCommand
from tests.harness import Rig, tree_of


def test_selector_preempts_a_lower_branch_and_stops_its_motion():
    root = tree_of(
        "  selector:\n    - sequence: [{obstacle_within: {mm: 200}}, {turn: {left: 90}}]\n    - move: {speed: 2}\n"
    )
    rig = Rig(root, "world=box")
    while not rig.sent() or rig.sent()[-1] != TurnCommand(90):
        assert rig.tick() == Status.RUNNING
    # the move was preempted: its halt must not cancel the turn that replaced it
    assert rig.sent() == [MoveCommand(2), TurnCommand(90)]
    assert rig.tick_until_done() == Status.SUCCESS
    assert 87 <= rig.robot.heading_deg <= 93


def test_while_halts_its_child_when_the_condition_fails():
    root = tree_of(
        "  while:\n    condition: {invert: {do: {obstacle_within: {mm: 150}}}}\n    do: {move: {speed: 2}}\n"
    )
    rig = Rig(root, "world=box")
    assert rig.tick_until_done() == Status.FAILURE
    assert rig.sent() == [MoveCommand(2), StopCommand()]
    assert rig.robot.true_front_gap_mm() < 150 and not rig.robot.impacts


def test_timeout_runs_on_the_virtual_clock_and_halts_the_child():
    rig = Rig(tree_of("  timeout: {seconds: 1.5, do: {move: {speed: 1}}}\n"), "world=empty")
    assert rig.tick_until_done() == Status.FAILURE
    assert 1.5 <= rig.client.clock.now() <= 1.6
    assert rig.sent() == [MoveCommand(1), StopCommand()]
    assert rig.root.feedback_message == "timed out after 1.5 s"


def test_parallel_one_ends_when_the_first_child_does_and_halts_the_rest():
    rig = Rig(
        tree_of("  parallel:\n    policy: one\n    children: [{wait: {seconds: 1}}, {move: {speed: 1}}]\n"),
        "world=empty",
    )
    assert rig.tick_until_done() == Status.SUCCESS
    assert rig.sent() == [MoveCommand(1), StopCommand()]


def test_parallel_all_waits_for_every_child():
    rig = Rig(tree_of("  parallel: [{wait: {seconds: 1}}, {wait: {seconds: 2}}]\n"))
    assert rig.tick_until_done() == Status.SUCCESS
    assert 2.0 <= rig.client.clock.now() <= 2.1


def test_repeat_retry_and_once_count():
    rig = Rig(tree_of("  repeat: {times: 3, do: beep}\n"))
    rig.tick_until_done()
    assert len(rig.robot.beeps) == 3
    rig = Rig(tree_of("  retry: {attempts: 3, do: {sequence: [beep, collided]}}\n"))
    assert rig.tick_until_done() == Status.FAILURE
    assert len(rig.robot.beeps) == 3
    rig = Rig(tree_of("  repeat: {times: 3, do: {once: {do: beep}}}\n"))
    rig.tick_until_done()
    assert len(rig.robot.beeps) == 1


def test_force_and_invert():
    assert Rig(tree_of("  force_success: {do: collided}\n")).tick() == Status.SUCCESS
    assert Rig(tree_of("  force_failure: {do: stop}\n")).tick() == Status.FAILURE
    assert Rig(tree_of("  invert: {do: collided}\n")).tick() == Status.SUCCESS


def test_status_is_polled_once_before_every_tick_and_battery_about_once_a_second():
    rig = Rig(tree_of("  wait: {seconds: 5}\n"))
    rig.tick_until_done()
    frames = [e.frame[:2] for e in rig.emulator.log]
    ticks = rig.runner.summary.ticks
    assert frames.count(b"Gb") == ticks + 1  # the link's first packet is read twice, to be trusted
    assert frames.count(b"GB") == frames.count(b"GR")
    assert 5 <= frames.count(b"GB") <= 6  # about once a second over 5 s

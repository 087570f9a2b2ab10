"""What users would see go wrong and nothing else catches: a robot that refuses X, a turn that stops
short, a clock not starting at 0, a tick longer than its period, subtrees that loop past the start."""

from __future__ import annotations

import re
import threading

import pytest
from py_trees.common import Status

from autonomy.behaviours.actions import Move, Stop, Turn
from autonomy.client import Client, open_port
from autonomy.clock import VirtualClock
from autonomy.mission import MissionInvalid, load_mission, validate_text
from autonomy.runner import TIME_LIMIT, Runner
from tests.harness import Rig
from tests.mission.test_runner import Explodes, tree_of


class Meddling:
    """An emulator port whose robot turns short (``T+090`` becomes ``T+080``) or refuses ``X``."""

    def __init__(
        self, query: str = "world=empty", short_turn: bool = False, refuse_stop: bool = False, refuse: bytes = b""
    ) -> None:
        self.inner = open_port(f"emu://?time=virtual&{query}")
        self.short_turn, self.refuse_stop = short_turn, refuse_stop
        self.refuse = refuse or (b"X" if refuse_stop else b"")
        self.refused = 0
        self._pending = b""

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def write(self, data: bytes) -> int:
        if self.refuse and data.startswith(self.refuse):
            self.refused += 1
            self._pending = b"NO\n"
            return len(data)
        if self.short_turn and data.startswith(b"T"):
            data = data[:2] + b"%03d\n" % max(0, int(data[2:5]) - 10)
        return self.inner.write(data)

    def read(self, size: int = 1) -> bytes:
        if self._pending:
            out, self._pending = self._pending[:size], self._pending[size:]
            return out
        return self.inner.read(size)

    def reset_input_buffer(self) -> None:
        self._pending = b""
        self.inner.reset_input_buffer()


def rig_on(port: Meddling, node) -> Rig:
    return Rig(node, client=Client(port, clock=port.inner.clock, name="meddling"))


def test_a_turn_that_stops_10_degrees_short_fails():
    rig = rig_on(Meddling(short_turn=True), Turn("t", left=90))
    assert rig.tick_until_done() == Status.FAILURE
    assert rig.root.feedback_message == "timed out with 10 deg to go"


@pytest.mark.parametrize("short_by", [3, 4])
def test_a_turn_is_done_within_3_degrees_and_not_beyond(short_by):
    port = Meddling()
    rig = rig_on(port, Turn("t", left=90))
    rig.tick()  # T sent
    rig.robot.turn_remaining_deg -= short_by  # the robot will stop short_by degrees early
    status = rig.tick_until_done()
    assert status == (Status.SUCCESS if short_by <= 3 else Status.FAILURE)


def test_a_stop_node_fails_when_the_robot_refuses_x():
    port = Meddling(refuse_stop=True)
    rig = rig_on(port, Stop("stop"))
    assert rig.tick() == Status.FAILURE and port.refused == 4  # asked again, refused every time
    assert "refused X0000" in rig.root.feedback_message


def test_a_move_whose_stop_is_refused_does_not_succeed():
    port = Meddling(refuse_stop=True)
    rig = rig_on(port, Move("m", speed=2, direction="forward", distance_mm=100))
    assert rig.tick_until_done() == Status.FAILURE
    assert "refused X0000" in rig.root.feedback_message


def test_a_run_whose_final_stop_is_refused_says_so():
    port = Meddling(refuse_stop=True)
    client = Client(port, clock=port.inner.clock, name="meddling")
    summary = Runner(tree_of("  move: {speed: 1}\n"), client, max_seconds=0.5).run()
    assert summary.outcome == TIME_LIMIT and not summary.stopped
    assert "The stop could NOT be confirmed" in summary.paragraph


@pytest.mark.parametrize("start_s", [0.0, 1_000_000.0, 1.7e9])
def test_the_time_limit_counts_from_the_start_of_the_run_whatever_the_clock_reads(start_s):
    client = Client.open("emu://?time=virtual&world=empty", clock=VirtualClock(start_s))
    summary = Runner(tree_of("  wait: {seconds: 60}\n"), client, max_seconds=3).run()
    assert summary.outcome == TIME_LIMIT and summary.time_s == pytest.approx(3.0, abs=0.06)
    assert 59 <= summary.ticks <= 62


class Slow(Explodes):
    """A node whose every tick takes 0.2 s, four times its period."""

    def update(self):
        self.clock.sleep(0.2)
        return Status.RUNNING


def test_ticks_longer_than_their_period_come_one_after_the_other_without_a_burst():
    client = Client.open("emu://?time=virtual&world=empty")
    runner = Runner(Slow("slow", RuntimeError("unused"), after_ticks=10**9), client, max_seconds=1.0)
    summary = runner.run()
    assert summary.outcome == TIME_LIMIT and 5 <= summary.ticks <= 6


@pytest.mark.parametrize("tones", ["[10, 1, 1]", "[0, 5, 5]", "[5, 5]", "[5, 5, 5, 5]", "[5, 5, 5.5]", "[5, 5, true]"])
def test_tones_are_three_whole_numbers_from_1_to_9(tones):
    with pytest.raises(MissionInvalid, match="three tones 1..9"):
        validate_text(f"mission: t\ntree:\n  beep: {{tones: {tones}}}\n")


def test_a_loop_among_subtrees_past_the_start_is_found_at_once():
    text = (
        "mission: t\nsubtrees:\n  a: {subtree: b}\n  b: {sequence: [{subtree: c}]}\n  c: {subtree: b}\n"
        "tree: {subtree: a}\n"
    )
    outcome: list = []

    def check() -> None:
        try:
            validate_text(text, "m.yaml")
        except MissionInvalid as err:
            outcome.append(err)

    worker = threading.Thread(target=check, daemon=True)
    worker.start()
    worker.join(timeout=10)
    assert not worker.is_alive(), "checking a loop of subtrees hangs"
    said = [p.message for p in outcome[0].problems]
    assert sorted(said) == [
        "subtree 'b' includes itself (directly or through other subtrees)",
        "subtree 'c' includes itself (directly or through other subtrees)",
    ]  # 'a' only leads into the loop: it is not in it


@pytest.mark.parametrize("value", ["fast", "'20'", "[20]", "true", "null"])
def test_tick_hz_must_be_a_number(value):
    with pytest.raises(MissionInvalid, match="tick_hz must be a number"):
        validate_text(f"mission: t\ntick_hz: {value}\ntree: stop\n")


def test_a_stop_asked_for_without_a_reason_still_gives_one():
    client = Client.open("emu://?time=virtual&world=empty")
    runner = Runner(tree_of("  wait: {seconds: 10}\n"), client)
    runner.request_stop("")
    assert runner.run().reason == "stop requested"
    other = Runner(tree_of("  wait: {seconds: 10}\n"), client)
    other.request_stop("its output was closed")
    assert other.run().reason == "its output was closed"


def test_the_failure_reason_names_the_leaf_that_failed_and_what_it_said():
    summary, _ = run_tree(
        "  sequence: [beep, {selector: [collided, {move: {speed: 1, distance_mm: 100}}]}]\n", "mode=manual"
    )
    assert summary.reason.startswith("'move 100 mm' failed (the robot refused F+100 (answered NO)")
    bare, _ = run_tree("  sequence: [beep, collided]\n")
    assert bare.reason == "'collided' failed"  # nothing said, nothing added


def run_tree(tree: str, query: str = ""):
    client = Client.open(f"emu://?time=virtual&world=empty{'&' + query if query else ''}")
    summary = Runner(tree_of(tree), client, max_seconds=5).run()
    return summary, client


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ("mission: t\ntree:\n  move: 5\n", "move takes its parameters as a mapping, e.g. move: {speed: 2}"),
        ("mission: t\ntree:\n  move:\n", "'move' needs parameters: speed"),
        ("mission: t\ntree: move\n", "'move' needs parameters (speed); write it as move: {speed: 2}"),
        ("mission: t\ntree:\n  sequence: [turn]\n", "tree.sequence[0].turn: 'turn' needs parameters (left or right)"),
    ],
)
def test_a_node_without_its_parameters_is_shown_how_to_write_them(text, said):
    with pytest.raises(MissionInvalid, match=re.escape(said)):
        validate_text(text, "m.yaml")


@pytest.mark.parametrize(
    ("length", "shown"), [(40, "'" + "x" * 40 + "' (text)"), (41, "'" + "x" * 40 + "... (41 characters)' (text)")]
)
def test_long_text_is_quoted_short_in_problems(length, shown):
    with pytest.raises(MissionInvalid) as caught:
        validate_text(f"mission: t\ntree:\n  move: {{speed: {'x' * length}}}\n", "m.yaml")
    assert str(caught.value.problems[0]).endswith(f"got {shown}")


def test_validating_a_file_can_leave_its_world_alone(tmp_path):
    mission = tmp_path / "m.yaml"
    mission.write_text("mission: t\nworld: nowhere\ntree: stop\n")
    assert load_mission(mission, check_world=False).world == "nowhere"
    with pytest.raises(MissionInvalid, match="no world named 'nowhere'"):
        load_mission(mission)


@pytest.mark.parametrize(("args", "label"), [({"left": 90}, "turn left 90 deg"), ({"right": 45}, "turn right 45 deg")])
def test_a_turn_is_named_by_its_side_and_angle(args, label):
    assert Turn.label(args) == label


def test_a_turn_says_how_far_it_has_to_go_each_tick():
    rig = Rig(Turn("t", left=90), "world=empty")
    rig.tick(3)
    assert re.fullmatch(r"\d+ deg to go", rig.root.feedback_message)
    assert 70 <= int(rig.root.feedback_message.split()[0]) < 90


def test_actions_fail_when_the_robot_refuses_them():
    from autonomy.behaviours.actions import Beep, Servo

    servo = Rig(Servo("s", id=0, angle=10, by=None), "mode=manual")  # manual mode: M is refused
    assert servo.tick() == Status.FAILURE and "refused M0+10" in servo.root.feedback_message
    beeping = rig_on(Meddling(refuse=b"S"), Beep("b", tones=[1, 2, 3], volume=2))
    assert beeping.tick() == Status.FAILURE and "refused S1232" in beeping.root.feedback_message
    heard = rig_on(Meddling(), Beep("b", tones=[1, 2, 3], volume=2))
    assert heard.tick() == Status.SUCCESS and heard.robot.beeps[-1][1:] == ((1, 2, 3), 2)


def test_a_crash_outside_the_working_folder_keeps_its_whole_path():
    from autonomy.runner import _short_path

    assert _short_path("/somewhere/else/beh.py") == "/somewhere/else/beh.py"
    import os

    assert _short_path(os.path.join(os.getcwd(), "missions", "beh.py")) == os.path.join("missions", "beh.py")


@pytest.mark.parametrize(
    ("node", "rewrite", "said"),
    [
        (Turn("t", left=60), (b"T+", b"T-"), r"turning the wrong way: \d+ deg right \(asked left\)"),
        (Turn("t", right=60), (b"T-", b"T+"), r"turning the wrong way: \d+ deg left \(asked right\)"),
    ],
)
def test_a_turn_the_wrong_way_says_which_way_it_went_and_which_was_asked(node, rewrite, said):
    from tests.client.test_client_faults import LosingPort

    port = LosingPort("emu://?time=virtual&world=empty", b"?", rewrite)
    rig = Rig(node, client=Client(port, clock=port.inner.clock, name="flipped"))
    assert rig.tick_until_done() == Status.FAILURE
    assert re.fullmatch(said, node.feedback_message), node.feedback_message


def test_a_turn_says_how_far_it_turned_and_which_way_and_a_turn_of_nothing_is_done_at_once():
    rig = Rig(Turn("t", left=90), "world=empty")
    assert rig.tick_until_done() == Status.SUCCESS and re.fullmatch(
        r"turned (8[7-9]|9[0-3]) deg left", rig.root.feedback_message
    )
    right = Rig(Turn("t", right=70), "world=empty")  # as the mission says it: not "turned -70 deg"
    assert right.tick_until_done() == Status.SUCCESS and re.fullmatch(
        r"turned (6[7-9]|7[0-3]) deg right", right.root.feedback_message
    )
    nothing = Rig(Turn("t", left=0), "world=empty")
    assert nothing.tick_until_done() == Status.SUCCESS


@pytest.mark.parametrize(
    ("args", "label"), [({"id": 0, "angle": 45}, "servo 0 to 45 deg"), ({"id": 1, "by": -5}, "servo 1 by -5 deg")]
)
def test_a_servo_node_is_named_by_what_it_does(args, label):
    from autonomy.behaviours.actions import Servo

    assert Servo.label(args) == label

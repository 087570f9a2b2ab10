"""What users would see go wrong and nothing else catches: a robot that refuses X, a turn that stops
short, a clock not starting at 0, a tick longer than its period, subtrees that loop past the start."""

from __future__ import annotations

import threading

import pytest
from py_trees.common import Status

from autonomy.behaviours.actions import Move, Stop, Turn
from autonomy.client import Client, open_port
from autonomy.clock import VirtualClock
from autonomy.mission import MissionInvalid, validate_text
from autonomy.runner import TIME_LIMIT, Runner
from tests.harness import Rig
from tests.mission.test_runner import Explodes, tree_of


class Meddling:
    """An emulator port whose robot turns short (``T+090`` becomes ``T+080``) or refuses ``X``."""

    def __init__(self, query: str = "world=empty", short_turn: bool = False, refuse_stop: bool = False) -> None:
        self.inner = open_port(f"emu://?time=virtual&{query}")
        self.short_turn, self.refuse_stop = short_turn, refuse_stop
        self.refused = 0
        self._pending = b""

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def write(self, data: bytes) -> int:
        if self.refuse_stop and data.startswith(b"X"):
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

"""Warnings for valid missions that behave in surprising ways (autonomy check)."""

from pathlib import Path

import pytest

from autonomy.mission import validate_text
from autonomy.mission.lint import lint
from tests.harness import mission_files

ROOT = Path(__file__).resolve().parents[2]


def warnings(text: str) -> list[str]:
    return [f"{p.line}:{p.column}: {p.path}: {p.message}" for p in lint(validate_text(text, "m.yaml"))]


def test_a_condition_then_a_beep_under_a_repeat_fires_every_tick_while_it_holds():
    found = warnings(
        "mission: m\ntree:\n  parallel:\n    policy: one\n    children:\n      - wait: {seconds: 60}\n"
        "      - repeat:\n          do:\n            selector:\n"
        "              - sequence: [collided, {beep: {}}]\n              - move: {speed: 2}\n"
    )
    assert len(found) == 1
    assert found[0].startswith(
        "10:17: tree.parallel.children[1].repeat.do.selector[0].sequence: warning: 'collided' then only beep"
    )
    assert "on every tick while 'collided' holds" in found[0]


def test_the_same_sequence_that_takes_time_or_runs_once_is_not_warned_about():
    assert (
        warnings(
            "mission: m\ntree:\n  repeat:\n    times: 3\n    do:\n"
            "      sequence: [collided, {beep: {}}, {wait: {seconds: 1}}]\n"
        )
        == []
    )
    assert (
        warnings("mission: m\ntree:\n  selector:\n    - sequence: [collided, {beep: {}}]\n    - log: {message: hi}\n")
        == []
    )


def test_a_repeat_forever_that_nothing_ends():
    found = warnings("mission: m\ntree:\n  repeat:\n    do:\n      move: {speed: 1, seconds: 1}\n")
    assert found == [
        "3:3: tree.repeat: warning: repeats forever and nothing ends it: the mission only ends if its child fails; "
        "give times:, or put it under a timeout, or in a parallel with a wait"
    ]
    assert (
        warnings("mission: m\ntree:\n  timeout:\n    seconds: 5\n    do:\n      repeat: {do: {wait: {seconds: 1}}}\n")
        == []
    )


def test_a_move_with_no_ending_that_nothing_stops():
    found = warnings("mission: m\ntree:\n  sequence:\n    - beep: {}\n    - move: {speed: 2}\n")
    assert len(found) == 1 and found[0].startswith("5:7: tree.sequence[1].move: warning: drives on until something")
    assert warnings("mission: m\ntree:\n  selector: [collided, {move: {speed: 2}}]\n") == []
    assert warnings("mission: m\ntree:\n  move: {speed: 2, until_obstacle_mm: 100}\n") == []


def test_warnings_follow_subtrees_to_where_they_are_used():
    found = warnings(
        "mission: m\nsubtrees:\n  bump:\n    sequence: [collided, {beep: {}}]\n"
        "tree:\n  repeat:\n    times: 5\n    do: {subtree: bump}\n"
    )
    assert [w.split(": warning")[0] for w in found] == ["4:5: subtrees.bump.sequence"]


@pytest.mark.parametrize(
    "path",
    mission_files((ROOT / "missions").glob("*.yaml")) + sorted((ROOT / "exercises" / "solutions").glob("*.yaml")),
)
def test_shipped_missions_and_reference_solutions_give_no_warning(path):
    from autonomy.mission import load_mission

    assert lint(load_mission(path)) == []


def test_an_instant_action_repeated_and_a_decorated_condition_are_warned_about_too():
    found = warnings(
        "mission: m\ntree:\n  parallel:\n    policy: one\n    children:\n      - wait: {seconds: 5}\n"
        "      - repeat: {do: {beep: {}}}\n"
        "      - repeat:\n          do:\n            sequence: [{invert: {do: collided}}, {beep: {}}]\n"
    )
    assert [w.split(": warning: ")[0] for w in found] == [
        "7:9: tree.parallel.children[1].repeat",
        "10:13: tree.parallel.children[2].repeat.do.sequence",
    ]
    assert "it runs on every tick (20 times a second)" in found[0]
    assert "then only beep, under a repeat" in found[1]


def test_a_sequence_followed_by_a_wait_before_its_repeat_comes_round_is_not_warned_about():
    text = (
        "mission: m\ntree:\n  repeat:\n    times: 5\n    do:\n      sequence:\n"
        "        - sequence: [{obstacle_within: {mm: 200}}, {beep: {}}]\n        - {wait: {seconds: 2}}\n"
    )
    assert warnings(text) == []
    assert len(warnings(text.replace("{wait: {seconds: 2}}", "{beep: {}}"))) == 1  # only instants after it: warned


def test_a_repeat_forever_ended_by_a_condition_failing_is_not_warned_about():
    until = (
        "mission: m\ntree:\n  repeat:\n    do:\n      sequence:\n"
        "        - invert: {do: {obstacle_within: {mm: 200}}}\n        - move: {speed: 2, distance_mm: 50}\n"
    )
    assert warnings(until) == []


def test_a_move_first_in_a_selector_has_nothing_to_stop_it():
    found = warnings("mission: m\ntree:\n  selector: [{move: {speed: 2}}, {beep: {}}]\n")
    assert len(found) == 1 and found[0].startswith("3:15: tree.selector[0].move: warning: drives on until something")
    remembering = "mission: m\ntree:\n  selector:\n    memory: true\n    children: [collided, {move: {speed: 2}}]\n"
    assert len(warnings(remembering)) == 1  # a selector with memory does not look at 'collided' again


def test_a_condition_whose_failure_is_taken_in_on_the_way_up_does_not_end_a_repeat():
    for body in (
        "selector: [{obstacle_within: {mm: 200}}, {move: {speed: 2, distance_mm: 50}}]",
        "sequence: [{force_success: {do: {obstacle_within: {mm: 200}}}}, {move: {speed: 2, distance_mm: 50}}]",
    ):
        found = warnings(f"mission: m\ntree:\n  repeat:\n    do:\n      {body}\n")
        assert [w.split(": warning: ")[1][:30] for w in found] == ["repeats forever and nothing en"], body


def test_only_beeps_after_a_condition_then_beep_take_no_time():
    text = (
        "mission: m\ntree:\n  repeat:\n    times: 5\n    do:\n      sequence:\n"
        "        - sequence: [collided, {beep: {}}]\n        - sequence: [{beep: {}}, {log: {message: hi}}]\n"
    )
    assert len(warnings(text)) == 1

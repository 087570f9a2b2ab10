"""Every mission in missions/ runs on the emulator in virtual time; what physically happened is checked."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from autonomy.client import Client
from autonomy.emulator import Emulator
from autonomy.mission import build_tree, load_mission
from autonomy.protocol import Beep, Get, Move, ServoBy, ServoTo, Stop, Turn
from autonomy.runner import SUCCEEDED, Runner, RunSummary
from tests.harness import Recorder, mission_files

MISSIONS = Path(__file__).resolve().parents[2] / "missions"


def run(name: str, query: str = "", before=None) -> tuple[RunSummary, Emulator, list[str]]:
    spec = load_mission(MISSIONS / f"{name}.yaml")
    client = Client.open(f"emu://?time=virtual&world={spec.world or 'box'}{'&' + query if query else ''}")
    if before is not None:
        before(client.port.emulator)
    recorder = Recorder()
    summary = Runner(build_tree(spec), client, mission=spec.name, tick_hz=spec.tick_hz, listeners=[recorder]).run()
    emulator = client.port.emulator
    emulator.advance()
    return summary, emulator, recorder.events("log")


def motions(emulator: Emulator) -> list:
    return [c for c in emulator.commands() if not isinstance(c, Get)]


def test_every_mission_file_is_valid():
    names = [p.stem for p in mission_files(MISSIONS.glob("*.yaml"))]
    assert {"square", "wander", "move_until_wall", "beep_on_collision", "servo_scan", "patrol", "explore"} <= set(names)
    for name in names:
        load_mission(MISSIONS / f"{name}.yaml")


def test_square_comes_back_where_it_started():
    summary, emulator, _ = run("square")
    robot = emulator.robot
    assert summary.outcome == SUCCEEDED and summary.stopped
    assert math.hypot(robot.x_mm - 1000, robot.y_mm - 1000) < 40  # a closed square
    assert abs((robot.heading_deg + 180) % 360 - 180) <= 6  # four turns of 90 +-3
    assert not robot.impacts and len(robot.beeps) == 4
    assert 1200 <= robot.odometer_mm <= 1300  # four 300 mm sides
    assert motions(emulator).count(Turn(90)) == 4 and motions(emulator)[-1] == Stop()


def test_move_until_wall_stops_short_of_the_wall():
    summary, emulator, _ = run("move_until_wall")
    robot = emulator.robot
    assert summary.outcome == SUCCEEDED
    assert not robot.impacts
    assert 20 < robot.true_front_gap_mm() < 100
    assert motions(emulator) == [Move(3), Stop(), Beep((9, 9, 9), 2), Stop()]


def test_beep_on_collision_beeps_after_each_bump_and_backs_off():
    summary, emulator, _ = run("beep_on_collision")
    robot = emulator.robot
    assert summary.outcome == SUCCEEDED and summary.collisions == 3
    assert len(robot.impacts) == 3 and len(robot.beeps) == 3
    for impact, beep in zip(robot.impacts, robot.beeps, strict=True):
        assert 0 <= beep[0] - impact.time_s < 0.2  # the beep follows its bump within a few ticks
    assert robot.world.clearance(robot.x_mm, robot.y_mm) > robot.params.body_radius_mm + 50  # backed off
    assert motions(emulator).count(Move(1, backward=True)) == 3


def test_wander_covers_ground_and_recovers_from_every_bump():
    summary, emulator, _ = run("wander")
    robot = emulator.robot
    assert summary.outcome == SUCCEEDED and 59.9 <= summary.time_s <= 60.2
    assert summary.distance_mm > 5000
    assert len(robot.impacts) <= 5
    assert robot.world.circle_fits(robot.x_mm, robot.y_mm, robot.params.body_radius_mm)
    beeps_after_bumps = [b for b in robot.beeps if b[1] == (2, 2, 2)]
    assert len(beeps_after_bumps) == len(robot.impacts)  # every bump was noticed and recovered from
    assert motions(emulator)[-1] == Stop() and robot.mode == 0  # told to stop (it may still be rolling)


def test_servo_scan_sweeps_and_returns_to_the_centre():
    summary, emulator, _ = run("servo_scan")
    sent = motions(emulator)
    assert summary.outcome == SUCCEEDED
    assert [c for c in sent if isinstance(c, ServoTo)] == [ServoTo(0, a) for a in (-60, -30, 0, 30, 60)]
    assert [c for c in sent if isinstance(c, ServoBy)] == [ServoBy(0, -9)] * 6
    assert emulator.robot.servo_deg[0] == pytest.approx(6)  # 60 - 6 * 9
    assert emulator.robot.odometer_mm == 0


def test_patrol_goes_back_and_forth_until_the_battery_guard_ends_it():
    summary, emulator, messages = run("patrol", "battery=60")
    robot = emulator.robot
    assert summary.outcome == SUCCEEDED
    assert int(robot.battery) <= 50 and not robot.impacts  # GB reports whole levels
    assert motions(emulator).count(Turn(180)) >= 2  # at least one round trip
    assert summary.distance_mm > 6000
    assert robot.beeps[-1][1:] == ((3, 2, 1), 5)
    assert messages[-1] == "patrol ended: battery low or robot unhealthy"
    assert robot.mode == 0


def test_patrol_guard_also_watches_health():
    def knock_over(emulator: Emulator) -> None:
        emulator.robot.knock_over()  # GR answers NO from the start

    summary, emulator, messages = run("patrol", before=knock_over)
    assert summary.outcome == SUCCEEDED
    assert not any(isinstance(c, (Move, Turn)) for c in motions(emulator))  # never set off
    assert messages == ["patrol ended: battery low or robot unhealthy"]

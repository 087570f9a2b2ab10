"""Robot profiles: read and written back, every problem at its place, and taken wherever an emulator is made."""

from __future__ import annotations

import dataclasses
import zipfile

import pytest

from autonomy.classroom import load_exercise
from autonomy.classroom.job import seed_url
from autonomy.client import Client
from autonomy.emulator import ProfileInvalid, RobotParams, parse_profile_text, profile_text
from tests.cli.test_cli import ROOT, assert_one_line_error, autonomy

BAD = "name: bad\nturn_rate_deg_s: .nan\nspeed_setting_v: [1, 2, 3]\nturn_rat: 3\ncommand_delay_s: 0.5\n"


def test_a_profile_written_is_read_back_as_the_same_settings():
    params = dataclasses.replace(
        RobotParams(),
        speed_setting_v=(9.1, 18.6, 28.9, 37.2),
        acceleration_mm_s2=1180.25,
        command_delay_s=0.045,
        sensor_scale=0.97,
        sensor_offset_mm=8.0,
    )
    text = profile_text(params, "robot-3", {"acceleration_mm_s2": "± 4 mm/s²"})
    assert "acceleration_mm_s2: 1180.25  # ± 4 mm/s²" in text
    assert "turn_rate_deg_s" not in text  # the defaults are left out
    profile = parse_profile_text(text, "robot-3.yaml")
    assert profile.name == "robot-3" and profile.params == params


def test_every_problem_of_a_profile_is_said_at_its_place():
    with pytest.raises(ProfileInvalid) as caught:
        parse_profile_text(BAD, "bad.yaml")
    said = [str(problem) for problem in caught.value.problems]
    assert said == [
        "bad.yaml:2:18: turn_rate_deg_s: must be from 1 to 3,600, got nan",
        "bad.yaml:3:18: speed_setting_v: expected the four speeds' [V1, V2, V3, V4], got [1, 2, 3]",
        "bad.yaml:4:1: turn_rat: unknown key 'turn_rat' (did you mean 'turn_rate_deg_s'?)",
        "bad.yaml:5:18: command_delay_s: must be from 0 to 0.3, got 0.5",
    ]
    with pytest.raises(ProfileInvalid, match="battery_cutoff_below: must not be above battery_unhealthy_below"):
        parse_profile_text("battery_cutoff_below: 90\nbattery_unhealthy_below: 80\n", "b.yaml")
    with pytest.raises(ProfileInvalid, match=r"^b.yaml:1:1: expected a mapping"):
        parse_profile_text("- 1\n", "b.yaml")


def test_a_bad_profile_is_every_problem_and_exit_2_for_run_and_the_emulator(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(BAD)
    for args in (
        ("run", "missions/square.yaml", "--fast", "--profile", str(bad)),
        ("emulator", "--tcp", "127.0.0.1:0", "--profile", str(bad)),
    ):
        result = autonomy(*args)
        assert result.returncode == 2, result.stderr
        assert "Traceback" not in result.stderr
        assert result.stderr.splitlines() == [
            f"{bad}:2:18: turn_rate_deg_s: must be from 1 to 3,600, got nan",
            f"{bad}:3:18: speed_setting_v: expected the four speeds' [V1, V2, V3, V4], got [1, 2, 3]",
            f"{bad}:4:1: turn_rat: unknown key 'turn_rat' (did you mean 'turn_rate_deg_s'?)",
            f"{bad}:5:18: command_delay_s: must be from 0 to 0.3, got 0.5",
        ]
    missing = autonomy("run", "missions/square.yaml", "--profile", str(tmp_path / "none.yaml"))
    assert_one_line_error(missing, 2, "none.yaml", "no such file")
    assert_one_line_error(
        autonomy("run", "missions/square.yaml", "--fast", "--port", f"emu://?profile={bad}"),
        3,
        f"cannot open emu://?profile={bad}",
        f"{bad}:2:18: turn_rate_deg_s",
    )


def test_an_emulator_made_with_a_profile_is_that_robot(tmp_path):
    robot = tmp_path / "slow.yaml"
    robot.write_text("speed_setting_v: [5, 10, 15, 20]\nturn_rate_deg_s: 45\n")
    client = Client.open(f"emu://?time=virtual&world=empty&profile={robot}")
    assert client.port.emulator.robot.params == RobotParams(speed_setting_v=(5, 10, 15, 20), turn_rate_deg_s=45)
    client.close()
    ran = autonomy("run", "missions/square.yaml", "--fast", "--profile", str(robot))
    assert ran.returncode == 0, ran.stderr
    assert f"on the built-in emulator as robot profile '{robot}', in virtual time" in ran.stdout
    clash = autonomy(
        "run", "missions/square.yaml", "--fast", "--profile", str(robot), "--port", "emu://?profile=other.yaml"
    )
    assert_one_line_error(clash, 2, "disagree")


def test_an_exercise_s_robot_is_every_seed_s_robot_checked_graded_and_zipped(tmp_path):
    text = (ROOT / "exercises" / "square.yaml").read_text()
    solution = ROOT / "exercises" / "solutions" / "square.yaml"
    text = text.replace("solution: solutions/square.yaml", f"solution: {solution}\nrobot: late.yaml")
    exercise_file = tmp_path / "square.yaml"
    exercise_file.write_text(text)
    line = next(i for i, row in enumerate(text.splitlines(), 1) if row.startswith("robot:"))
    missing = autonomy("check", str(exercise_file))
    assert missing.returncode == 2
    assert f"{exercise_file}:{line}:8: robot: the robot profile 'late.yaml' is not there" in missing.stderr
    (tmp_path / "late.yaml").write_text("command_delay_s: 9\n")
    bad = autonomy("check", str(exercise_file))
    assert bad.returncode == 2
    assert f"{tmp_path / 'late.yaml'}:1:18: command_delay_s: must be from 0 to 0.3, got 9" in bad.stderr
    assert f"{exercise_file}:{line}:8: robot: the robot profile" in bad.stderr
    # a late robot with soft wheels: the teacher's solution, full marks on the default robot, falls short on it
    (tmp_path / "late.yaml").write_text("command_delay_s: 0.3\nacceleration_mm_s2: 300\n")
    exercise = load_exercise(exercise_file)
    assert f"profile={tmp_path / 'late.yaml'}".replace("/", "%2F") in seed_url(exercise, exercise.seeds[0])
    checked = autonomy("check", str(exercise_file))
    assert checked.returncode == 2, checked.stdout + checked.stderr
    assert "its solution falls short on seed 3: beeps_in" in checked.stdout
    default = autonomy("check", "exercises/square.yaml")
    assert "its solution earns 10 of 10 on every one of 3 seeds" in default.stdout
    zipped = autonomy("gradescope", str(exercise_file), "-o", str(tmp_path / "autograder.zip"))
    assert zipped.returncode == 0, zipped.stderr
    with zipfile.ZipFile(tmp_path / "autograder.zip") as archive:
        assert archive.read("exercise/late.yaml") == (tmp_path / "late.yaml").read_bytes()
    elsewhere = tmp_path / "away"
    elsewhere.mkdir()
    (elsewhere / "square.yaml").write_text(text.replace("robot: late.yaml", f"robot: {tmp_path / 'late.yaml'}"))
    outside = autonomy("gradescope", str(elsewhere / "square.yaml"), "-o", str(tmp_path / "away.zip"))
    assert_one_line_error(outside, 2, "robot profile", "is not beside it")

"""autonomy calibrate: a probe on robots the fit is not told of (emulators with their own settings, over TCP and a
pseudo-terminal, in real time), the settings it recovers, held-out missions, and a probe stopping the robot."""

from __future__ import annotations

import dataclasses
import importlib
import math
import random
import re
import subprocess
import sys
from pathlib import Path

import pytest

from autonomy.calibration import Probe, ProbeRefused, ProbeStopped, fit, from_trace
from autonomy.calibration.fit import pieces, start_values
from autonomy.calibration.recording import Recording, Sample, Sent
from autonomy.client import Client
from autonomy.emulator import RobotParams, load_profile, profile_text
from autonomy.mission import load_mission
from autonomy.protocol import Stop
from autonomy.runner import Runner
from tests.cli.test_cli import ROOT, assert_one_line_error, autonomy

HERE = Path(__file__).resolve().parent
ROBOTS = HERE / "robots"
#: What the fit must recover within 3% (the issue's figure), in the fit's terms.
WITHIN_3_PERCENT = (
    "speed_1_mm_s",
    "speed_2_mm_s",
    "speed_3_mm_s",
    "speed_4_mm_s",
    "acceleration_mm_s2",
    "turn_rate_deg_s",
)
HELD_OUT = [
    ROOT / "missions" / "square.yaml",
    ROOT / "missions" / "move_until_wall.yaml",
    HERE / "heldout" / "zigzag.yaml",
    HERE / "heldout" / "backward.yaml",
    HERE / "heldout" / "approach.yaml",
]


def misses(found: RobotParams, truth: RobotParams) -> dict[str, float]:
    """Each motion setting's miss, as a share of the true value."""
    got, want = start_values(found), start_values(truth)
    return {name: abs(got[name] - want[name]) / want[name] for name in WITHIN_3_PERCENT}


def assert_recovered(found: RobotParams, truth: RobotParams) -> None:
    off = {name: f"{100 * share:.2f}%" for name, share in misses(found, truth).items() if share > 0.03}
    assert not off, off
    assert abs(found.command_delay_s - truth.command_delay_s) < 0.015
    assert abs(found.sensor_scale - truth.sensor_scale) < 0.03 * truth.sensor_scale
    assert abs(found.sensor_offset_mm - truth.sensor_offset_mm) < 3.0
    assert abs(found.sensor_noise_mm - truth.sensor_noise_mm) < 0.5


def linked_robot(how: list[str], robot: Path) -> tuple[subprocess.Popen, str]:
    """``autonomy emulator`` with a profile the fit is not told of, on a link: the process and its URL."""
    process = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "emulator", *how, "--world", "calibration", "--profile", str(robot)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    return process, process.stdout.readline().strip()


def test_a_probe_over_a_link_recovers_each_speed_the_acceleration_and_the_turn_rate_within_3_percent(tmp_path):
    """Three robots, two over TCP and one over a pseudo-terminal, each probed in real time, side by side.

    robot-c acts on a command at once: the emulator acts on it within the step it arrives in, before it
    arrived (a fit that started each piece at the command's own sample had its acceleration 4-6% high).
    """
    robots = {
        "tcp robot-a": (["--tcp", "127.0.0.1:0"], "robot-a"),
        "pty robot-b": (["--pty"], "robot-b"),
        "tcp robot-c": (["--tcp", "127.0.0.1:0"], "robot-c"),
    }
    started, probes = [], {}
    try:
        for label, (how, robot) in robots.items():
            process, url = linked_robot(how, ROBOTS / f"{robot}.yaml")
            started.append(process)
            assert url.startswith("socket://" if "tcp" in label else "/dev/"), url
            command = [sys.executable, "-m", "autonomy", "calibrate", "--port", url, "--yes"]
            probe = subprocess.Popen(
                [*command, "-o", str(tmp_path / f"{robot}-fit.yaml")],
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                cwd=ROOT,
            )
            started.append(probe)
            probes[label] = (robot, probe)
        for label, (robot, probe) in probes.items():
            stdout, stderr = probe.communicate(timeout=150)
            assert probe.returncode == 0, (label, stderr)
            assert "Traceback" not in stderr
            found = load_profile(tmp_path / f"{robot}-fit.yaml")
            assert found.name == f"{robot}-fit"
            assert_recovered(found.params, load_profile(ROBOTS / f"{robot}.yaml").params)
            # each setting is said with its uncertainty, and the fit's residual in mm and degrees
            assert re.search(r"residual [\d.]+ mm and [\d.]+ degrees RMS", stdout), stdout
            for name in (*WITHIN_3_PERCENT, "command_delay_s", "sensor_scale", "sensor_offset_mm", "sensor_noise_mm"):
                assert re.search(rf"^  {name} +[\d.-]+ .* ± [\d.e-]+", stdout, re.M), (label, name, stdout)
    finally:
        for process in started:
            if process.poll() is None:
                process.terminate()
            process.communicate(timeout=30)


def probed(robot: Path, world: str = "calibration", more: str = "") -> tuple[Client, Probe]:
    client = Client.open(f"emu://?time=virtual&world={world}&profile={robot}&seed=3{more}")
    return client, Probe(client, 1000.0)


def final_pose(mission: Path, profile: Path | None):
    spec = load_mission(mission)
    client = Client.open(f"emu://?time=virtual&world={spec.world}" + (f"&profile={profile}" if profile else ""))
    try:
        Runner.for_mission(spec, client, max_seconds=60).run()
        emulator = client.port.emulator
        emulator.clock.sleep(2.0)  # at rest, after the stop
        return emulator.pose() if hasattr(emulator, "pose") else emulator.robot.pose
    finally:
        client.close()


def apart(a, b) -> tuple[float, float]:
    return math.hypot(a.x_mm - b.x_mm, a.y_mm - b.y_mm), abs((a.heading_deg - b.heading_deg + 180.0) % 360.0 - 180.0)


@pytest.mark.parametrize("robot", ["robot-a", "robot-b"])
def test_held_out_missions_on_the_calibrated_emulator_end_within_20_mm_and_3_degrees_of_the_robot(robot, tmp_path):
    truth = ROBOTS / f"{robot}.yaml"
    client, probe = probed(truth)
    with client:
        recording = probe.run()
    found = fit(recording)
    profile = tmp_path / "fitted.yaml"
    profile.write_text(profile_text(found.params, "fitted", found.notes()))
    calibrated, uncalibrated = {}, {}
    for mission in HELD_OUT:
        real = final_pose(mission, truth)
        calibrated[mission.stem] = apart(final_pose(mission, profile), real)
        uncalibrated[mission.stem] = apart(final_pose(mission, None), real)
    far = {name: miss for name, miss in calibrated.items() if miss[0] > 20.0 or miss[1] > 3.0}
    assert not far, (far, calibrated)
    # the robot is one the defaults do not fit: uncalibrated, the same missions end far off
    assert max(miss[0] for miss in uncalibrated.values()) > 40.0, uncalibrated
    assert max(miss[1] for miss in uncalibrated.values()) > 10.0, uncalibrated


def test_a_probe_leaves_the_robot_where_it_began_facing_the_wall():
    client, probe = probed(ROBOTS / "robot-a.yaml")
    with client:
        start = client.port.emulator.pose()
        probe.run()
        client.clock.sleep(1.0)
        end = client.port.emulator.pose()
        assert not client.port.emulator.robot.moving
    distance, turned = apart(start, end)
    assert distance < 30.0 and turned < 2.0, (start, end)
    assert probe.recording.samples[-1].time_s - probe.recording.samples[0].time_s < 120.0


def test_a_probe_of_a_robot_that_hits_something_stops_it_at_once_and_says_so(tmp_path):
    # a post beside the path, out of the sensor's cone, in the body's way
    world = tmp_path / "post.yaml"
    world.write_text(
        "name: post\narena_mm: [1460, 1200]\nstart: {x_mm: 400, y_mm: 600, heading_deg: 0}\n"
        "obstacles:\n  - circle: {center_mm: [620, 652], radius_mm: 8}\n"
    )
    client, probe = probed(ROBOTS / "robot-a.yaml", world=str(world))
    with client:
        with pytest.raises(ProbeStopped, match="the robot hit something"):
            probe.run()
        emulator = client.port.emulator
        assert isinstance(emulator.commands()[-1], Stop)
        client.clock.sleep(1.0)
        emulator.advance()
        assert not emulator.robot.moving and emulator.robot.impacts


def test_a_probe_of_a_robot_that_does_not_move_stops_it_and_says_what_to_look_at(tmp_path):
    stuck = tmp_path / "stuck.yaml"  # wheels that spin on the spot: a fraction of a millimetre a second
    stuck.write_text("speed_setting_v: [0.1, 0.1, 0.1, 0.1]\n")
    client, probe = probed(stuck)
    with client:
        with pytest.raises(ProbeStopped, match="did not move at speed 1 .*blocked"):
            probe.run()
        assert isinstance(client.port.emulator.commands()[-1], Stop)


def test_a_probe_refuses_a_robot_with_something_in_front_of_it(tmp_path):
    world = tmp_path / "near.yaml"
    world.write_text("name: near\narena_mm: [660, 1200]\nstart: {x_mm: 400, y_mm: 600, heading_deg: 0}\n")
    client, probe = probed(ROBOTS / "robot-a.yaml", world=str(world))
    with client:
        with pytest.raises(ProbeRefused, match="sees something 2.. mm ahead"):
            probe.run()
        assert not [c for c in client.port.emulator.commands() if c.letter in "FT"]  # nothing moved


def test_a_probe_of_a_robot_that_refuses_to_move_stops_and_says_why():
    client, probe = probed(ROBOTS / "robot-a.yaml", more="&battery=5")
    with client:
        with pytest.raises(ProbeStopped, match=r"refused to turn 90 degrees \(it answered NO\): is its battery low"):
            probe.run()


def test_a_probe_that_meets_something_nearer_than_the_wall_stops(tmp_path):
    world = tmp_path / "short.yaml"  # the wall is 500 mm away, not the metre it was said to be
    world.write_text("name: short\narena_mm: [960, 1200]\nstart: {x_mm: 400, y_mm: 600, heading_deg: 0}\n")
    client, probe = probed(ROBOTS / "robot-a.yaml", world=str(world))
    with client:
        with pytest.raises(ProbeStopped, match="something came 2.. mm ahead|sees something .* where the wall should"):
            probe.run()
        client.clock.sleep(1.0)
        client.port.emulator.advance()
        assert not client.port.emulator.robot.impacts


# ---------------------------------------------------------------------- the command


def test_calibrate_says_in_one_line_what_it_needs():
    assert_one_line_error(autonomy("calibrate"), 2, "give --port PORT to probe a robot, or the trace files")
    assert_one_line_error(autonomy("calibrate", "--check", "x.yaml"), 2, "--check probes the robot: give --port")
    assert_one_line_error(autonomy("calibrate", "--wall-mm", "300", "--port", "emu://"), 2, "must be from 600 to 1100")


def test_calibrate_asks_before_it_drives_and_will_not_drive_unasked():
    result = subprocess.run(
        [sys.executable, "-m", "autonomy", "calibrate", "--port", "emu://?time=virtual&world=calibration"],
        capture_output=True,
        text=True,
        stdin=subprocess.DEVNULL,
        cwd=ROOT,
        timeout=60,
    )
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "facing a wall, its front 1000 mm from the wall" in result.stderr
    assert result.stderr.strip().splitlines()[-1] == (
        "autonomy: error: the probe drives the robot: run it in a terminal to confirm, or give --yes"
    )


def test_check_says_in_one_line_whether_the_robot_still_matches_its_profile(tmp_path):
    robot = ROBOTS / "robot-a.yaml"
    port = f"emu://?time=virtual&world=calibration&profile={robot}"
    mine = tmp_path / "robot-a-fitted.yaml"
    made = autonomy("calibrate", "--port", port, "--yes", "-o", str(mine))
    assert made.returncode == 0, made.stderr
    same = autonomy("calibrate", "--check", str(mine), "--port", port, "--yes")
    assert same.returncode == 0, same.stdout + same.stderr
    assert same.stdout.strip() == same.stdout.strip().splitlines()[0]
    assert "the robot matches its profile" in same.stdout
    worn = tmp_path / "worn.yaml"  # a worn wheel: speed 4 is 8% slower than it was
    params = load_profile(robot).params
    speeds = (*params.speed_setting_v[:3], params.speed_setting_v[3] * 0.92)
    worn.write_text(profile_text(dataclasses.replace(params, speed_setting_v=speeds), "worn"))
    changed = autonomy("calibrate", "--check", str(mine), "--port", port.replace(str(robot), str(worn)), "--yes")
    assert changed.returncode == 1, changed.stdout + changed.stderr
    line = changed.stdout.strip()
    assert "\n" not in line and "no longer matches its profile: speed_4_mm_s is -8" in line, line
    assert "calibrate it again" in line


def test_calibrate_from_traces_fits_what_the_runs_drove_and_leaves_the_rest_saying_why(tmp_path):
    robot = ROBOTS / "robot-a.yaml"
    traces = []
    for name in ("square", "patrol"):
        trace = tmp_path / f"{name}.jsonl"
        ran = autonomy(
            "run", f"missions/{name}.yaml", "--fast", "--quiet", "--profile", str(robot), "--trace", str(trace),
            "--max-seconds", "30",
        )  # fmt: skip
        assert ran.returncode in (0, 1), ran.stderr
        traces.append(str(trace))
    out = tmp_path / "from-traces.yaml"
    result = autonomy("calibrate", *traces, "-o", str(out))
    assert result.returncode == 0, result.stderr
    found, truth = start_values(load_profile(out).params), start_values(load_profile(robot).params)
    for name in ("speed_2_mm_s", "speed_3_mm_s", "turn_rate_deg_s"):  # square drives at 2, patrol at 3
        assert abs(found[name] - truth[name]) < 0.03 * truth[name], (name, found[name], truth[name])
    assert re.search(r"speed_1_mm_s .* left at 106.8: the runs never drive at speed 1", result.stdout)
    assert re.search(r"speed_4_mm_s .* left at 427.3: the runs never drive at speed 4", result.stdout)
    assert "sensor_scale" in result.stdout and "no reading at a known distance from a wall" in result.stdout
    assert "1: 106.8 mm/s (left)" in out.read_text() and "not fitted" in out.read_text()  # the profile says it too


def test_a_bad_trace_is_one_line():
    assert_one_line_error(autonomy("calibrate", "README.md"), 2, "README.md")


def test_from_trace_reads_a_run_s_commands_and_samples(tmp_path):
    trace = tmp_path / "square.jsonl"
    ran = autonomy("run", "missions/square.yaml", "--fast", "--quiet", "--trace", str(trace))
    assert ran.returncode == 0, ran.stderr
    recording = from_trace(trace)
    assert [s.kind for s in recording.sent].count("turn") == 4
    assert [s.value for s in recording.sent if s.kind == "move"] == [2, 2, 2, 2]
    assert recording.samples[-1].odometer_mm == pytest.approx(1200, abs=40)


def synthetic(truth: dict[str, float], late_s: list[float], sent: list[Sent], end_s: float) -> Recording:
    """What the fit's own model says a robot reports every 10 ms, each command acting ``late_s`` off its time."""
    from autonomy.calibration.fit import predict

    acted = [dataclasses.replace(c, time_s=c.time_s + late) for c, late in zip(sent, late_s, strict=True)]
    times = [0.01 * i for i in range(int(end_s / 0.01))]
    blank = [Sample(t, 0, 0.0, 255, False) for t in times]
    odometer, heading = predict(truth | {"speed_lead_s": RobotParams().step_s / 2.0}, acted, blank)  # the emulator's
    samples, last = [], (None, None)
    for t, s, h in zip(times, odometer, heading, strict=True):
        now = (round(s), round(h) % 360)
        samples.append(Sample(t, now[1], float(now[0]), 255, now != last))
        last = now
    return Recording("synthetic", sent, samples)


def test_a_recording_is_cut_where_the_robot_stood_still_before_a_move_or_turn():
    truth = start_values(RobotParams())
    sent = [Sent(0.5, "move", 2), Sent(1.5, "stop"), Sent(1.6, "move", 1), Sent(2.4, "stop"), Sent(3.5, "turn", 90)]
    recording = synthetic(truth, [0.0] * len(sent), sent, 5.0)
    cut = pieces(recording)
    # at rest from the start, and after the second stop; the move at 1.6 comes while it still rolls
    assert [piece.sent for piece in cut] == [[], sent[:4], sent[4:]]
    # each from a sample of its stand-still a tenth of a second before its command: the command may act early
    assert [piece.samples[0].time_s for piece in cut] == pytest.approx([0.0, 0.4, 3.4])
    assert sum(len(piece.samples) for piece in cut) == len(recording.samples)


def test_the_acceleration_is_read_from_each_start_and_stop_whenever_each_command_acted():
    truth = start_values(RobotParams(acceleration_mm_s2=1900.0, command_delay_s=0.07))
    sent, t = [], 0.2
    for speed in (1, 2, 3, 4, -2, -4) * 2:  # twelve starts and stops: the odometer's whole millimetres leave <1%
        sent += [Sent(t, "move", speed), Sent(t + 1.0, "stop")]
        t += 2.0
    rng = random.Random(4)
    late_s = [rng.uniform(0.0, 0.006) for _ in sent]  # a link's few milliseconds, each time different
    found = start_values(fit(synthetic(truth, late_s, sent, t)).params)
    assert found["acceleration_mm_s2"] == pytest.approx(truth["acceleration_mm_s2"], rel=0.01)
    for k in range(1, 5):
        assert found[f"speed_{k}_mm_s"] == pytest.approx(truth[f"speed_{k}_mm_s"], rel=0.005)
    assert found["command_delay_s"] == pytest.approx(0.073, abs=0.003)


def a_trace(folder: Path, name: str = "square") -> Path:
    trace = folder / f"{name}.jsonl"
    ran = autonomy("run", f"missions/{name}.yaml", "--fast", "--quiet", "--trace", str(trace), "--max-seconds", "20")
    assert ran.returncode in (0, 1), ran.stderr
    return trace


def test_a_trace_whose_times_run_backward_or_past_a_day_is_one_line_with_its_tick(tmp_path):
    import json

    lines = a_trace(tmp_path).read_text().splitlines()
    for when, said in (("1e300", "past 24 hours"), ("-5", "before the tick before it")):
        bent = []
        ticks = 0
        for line in lines:
            record = json.loads(line)
            if record.get("type") == "tick":
                ticks += 1
                if ticks == 10:
                    record["time_s"] = float(when)
            bent.append(json.dumps(record))
        wrong = tmp_path / "wrong.jsonl"
        wrong.write_text("\n".join(bent) + "\n")
        assert_one_line_error(autonomy("calibrate", str(wrong)), 2, "wrong.jsonl: tick 10:", said)


def test_a_fit_past_its_samples_is_refused_in_one_line_before_it_takes_the_machine(tmp_path, monkeypatch):
    fit_module = importlib.import_module("autonomy.calibration.fit")
    monkeypatch.setattr(fit_module, "MAX_SAMPLES", 100)
    with pytest.raises(fit_module.FitError, match="a fit takes at most 100"):
        fit(from_trace(a_trace(tmp_path)))


def test_a_profile_that_cannot_be_written_is_said_before_the_robot_drives(tmp_path):
    trace = a_trace(tmp_path)
    before = trace.read_bytes()
    assert_one_line_error(autonomy("calibrate", str(trace), "-o", str(trace)), 2, "is one of the traces fitted")
    assert trace.read_bytes() == before  # the trace is not written over
    missing = tmp_path / "nowhere" / "robot.yaml"
    result = autonomy("calibrate", "--port", "socket://127.0.0.1:9", "--yes", "-o", str(missing))
    assert_one_line_error(result, 2, f"the folder {missing.parent} is not there")  # before the port is opened
    kept = tmp_path / "robot-3.yaml"
    assert autonomy("calibrate", str(trace), "-o", str(kept)).returncode == 0
    again = autonomy("calibrate", str(trace), "-o", str(kept))
    assert again.returncode == 0 and "over the profile that was there" in again.stdout


@pytest.mark.parametrize(
    ("wall_mm", "said"),
    [
        ("1100", "the sensor reads 100 mm less than the distance to the wall: if the wall was not 1100 mm"),
        ("600", "left at 1: the sensor never read the wall, though the robot drove to"),
    ],
)
def test_a_wall_not_where_the_probe_was_told_is_said_not_fitted_as_the_sensor_s_fault(wall_mm, said):
    result = autonomy("calibrate", "--port", "emu://?time=virtual&world=calibration", "--yes", "--wall-mm", wall_mm)
    assert result.returncode == 0, result.stderr
    assert said in result.stdout + result.stderr


def test_one_reading_spoilt_on_the_link_is_not_something_ahead():
    """(Something there, read each time, is refused: see the test of a robot with something in front of it.)"""
    client = Client.open("emu://?time=virtual&world=calibration&seed=3")
    try:
        real = client.status
        readings = iter([False, True, False])  # the second status read is spoilt: it "sees" 44 mm

        def spoilt():
            status = real()
            return dataclasses.replace(status, front_distance_mm=44) if next(readings, False) else status

        client.status = spoilt
        said = []
        Probe(client, 1000.0, said.append)._check()  # ready: it does not raise
        assert said[0].startswith("the robot is ready")
    finally:
        client.close()


def test_a_setting_near_zero_is_printed_as_a_number_a_teacher_reads_never_in_powers_of_ten():
    from autonomy.calibration.fit import Fitted

    assert Fitted("command_delay_s", 1.48e-05, 3.29e-04, "s").line.split() == [
        "command_delay_s", "0.0000148", "s", "±", "0.000329"
    ]  # fmt: skip
    assert Fitted("command_delay_s", 3e-11, 1e-7, "s").line.split()[1::3] == ["0", "0"]  # none, to the fit's rounding

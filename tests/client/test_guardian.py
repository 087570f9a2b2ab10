"""The guardian: a robot driven over a link of the operating system's is stopped when the engine is killed."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from autonomy.client import Client
from autonomy.emulator import Emulator
from autonomy.emulator.firmware import Firmware
from autonomy.emulator.servers import PtyServer, TcpServer
from autonomy.guardian import Guardian, link_descriptor
from autonomy.protocol import Move, Stop, parse_command

ROOT = Path(__file__).resolve().parents[2]

DRIVE_ON = """\
mission: drive on
world: empty
tree:
  move: {speed: 1, until_obstacle_mm: 100}
"""


@pytest.mark.parametrize("link", ["tcp", "pty"])
def test_kill_9_of_a_run_leaves_the_robot_stopped_within_half_a_second(tmp_path, link):
    """The robot is served from this process, so its own log says when the stop came, on this process's clock."""
    mission = tmp_path / "drive.yaml"
    mission.write_text(DRIVE_ON)
    emulator = Emulator("empty")  # in real time: its clock is time.monotonic, as this test's
    server = TcpServer(emulator, port=0) if link == "tcp" else PtyServer(emulator)
    with server:
        run = subprocess.Popen(
            [sys.executable, "-m", "autonomy", "run", str(mission), "--port", server.url],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        assert run.stdout.readline().startswith("Running 'drive on'")
        assert "move" in run.stdout.readline()  # the move has started: the robot drives
        time.sleep(0.3)
        run.send_signal(signal.SIGKILL)  # what the out-of-memory killer does: nothing of the engine runs again
        killed_s = time.monotonic()
        run.wait(timeout=10)
        stops: list[float] = []
        while not stops and time.monotonic() < killed_s + 10:  # the guardian's stop, once it comes
            with emulator._lock:  # noqa: SLF001 - read while its server's thread writes
                origin_s = emulator._origin_s  # noqa: SLF001 - the emulator's time 0 on the clock
                stops = [origin_s + e.time_s for e in emulator.log if isinstance(e.command, Stop)]
            time.sleep(0.01)
        said = run.stderr.read()
        emulator.advance()
        moved_mm = emulator.robot.odometer_mm
        time.sleep(0.3)
        emulator.advance()
        assert stops, said
        assert stops[0] - killed_s < 0.5, f"the stop came {stops[0] - killed_s:.3f} s after the kill"
        assert emulator.robot.mode == 0
        assert emulator.robot.odometer_mm - moved_mm < 10  # a robot driving on covers 30 mm in 0.3 s
    assert "the engine's process is gone; the robot was stopped" in said, said


@pytest.fixture(params=["tcp", "pty"])
def served(request):
    """Yields (url, emulator) of an emulator served in this process on each link."""
    emulator = Emulator("empty")
    server = TcpServer(emulator, port=0) if request.param == "tcp" else PtyServer(emulator)
    with server:
        yield server.url, emulator


def test_a_guardian_released_by_its_engine_sends_nothing_and_leaves_the_line_free(served):
    url, emulator = served
    robot = Client.open(url, guardian=True)
    guardian = robot._guardian
    assert guardian is not None and guardian.process.poll() is None  # it waits, costing nothing
    robot.move(1)
    robot.close()  # stops the robot itself, then lets the guardian go before it closes the port
    assert guardian.process.returncode == 0
    sent = [type(command) for command in emulator.commands()]
    assert sent.count(Stop) == 1  # the engine's own stop, and nothing after it
    with Client.open(url) as again:  # the line is free at once
        assert again.firmware()


def test_a_guardian_whose_engine_is_gone_stops_the_robot(served):
    url, emulator = served
    robot = Client.open(url, guardian=True)
    robot.move(1)
    guardian = robot._guardian
    os.close(guardian._write_fd)  # the kernel does this when the engine's process ends, however it ends
    guardian.released = True
    assert guardian.process.wait(timeout=5) == 0  # the stop was answered OK
    commands = emulator.commands()
    assert isinstance(commands[-1], Stop) and Move(1) in commands
    assert emulator.robot.mode == 0
    robot.close()


def test_a_half_sent_frame_does_not_swallow_the_guardian_s_stop():
    """The engine may die in the middle of a frame: the guardian's newline ends that frame first."""
    engine, robot_end = socket.socketpair()
    guardian = Guardian(engine.fileno(), Stop().encode(), "socketpair")
    engine.sendall(b"F+1")  # half a frame, then the engine is gone
    os.close(guardian._write_fd)
    guardian.released = True
    firmware = Firmware(Emulator("box").robot)
    robot_end.settimeout(5)
    frames = firmware.frames(b"F+1")
    while not frames or not any(frame.startswith(b"X") for frame in frames):
        frames += firmware.frames(robot_end.recv(64))
    robot_end.sendall(b"NO\nOK\n")  # the half frame is refused, the stop is done
    assert guardian.process.wait(timeout=5) == 0
    assert [type(parse_command(frame)) for frame in frames if frame.startswith(b"X")] == [Stop]
    engine.close()
    robot_end.close()


def test_a_robot_that_never_answers_gets_three_stops_and_the_guardian_says_so():
    engine, robot_end = socket.socketpair()
    read_fd, write_fd = os.pipe()
    guardian = subprocess.Popen(  # the guardian's side as the engine starts it, its message read here
        [sys.executable, "-I", "-S", str(ROOT / "autonomy" / "guardian.py"), str(engine.fileno()), str(read_fd)]
        + [Stop().encode().hex(), "the test's link"],
        pass_fds=(engine.fileno(), read_fd),
        stderr=subprocess.PIPE,
        text=True,
    )
    os.close(read_fd)
    os.close(write_fd)
    _, said = guardian.communicate(timeout=10)
    robot_end.settimeout(1)
    assert robot_end.recv(100) == b"\nX0000\n" * 3
    assert guardian.returncode == 1
    assert said == "autonomy: the engine's process is gone; the stop was sent but NOT confirmed (the test's link)\n"
    engine.close()
    robot_end.close()


def test_only_links_of_the_operating_system_s_get_a_guardian():
    with Client.open("emu://?world=box&time=virtual", guardian=True) as robot:  # it ends with this process
        assert link_descriptor(robot.port) is None and robot._guardian is None

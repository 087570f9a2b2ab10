"""The TCP emulator under a flood of connections: the client it serves keeps its line, and it serves again after."""

from __future__ import annotations

import resource
import socket
import subprocess
import sys
from pathlib import Path

from autonomy.client import Client

ROOT = Path(__file__).resolve().parents[2]


def test_1500_connections_at_once_leave_the_served_client_its_line_and_the_emulator_serving_after():
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(max(soft, 4096), hard), hard))  # this test's own sockets
    served = subprocess.Popen(  # the emulator in a process of its own, as `autonomy emulator --tcp` runs
        [sys.executable, "-m", "autonomy", "emulator", "--tcp", "127.0.0.1:0"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    flood: list[socket.socket] = []
    try:
        url = served.stdout.readline().strip()
        host, port = url.removeprefix("socket://").rsplit(":", 1)
        with Client.open(url) as robot:  # the one client, driving
            robot.move(2)
            for _ in range(1500):
                flood.append(socket.create_connection((host, int(port)), timeout=30))  # a full backlog waits
            for conn in flood[:50]:
                conn.sendall(b"Gb000\n")
            assert robot.status().odometer_mm > 0  # its line held through the flood: it answers, it drove
            robot.stop()
            assert flood[-1].recv(200).startswith(b"BUSY")  # told the line is busy, and let go
        for conn in flood:
            conn.close()
        flood.clear()
        with Client.open(url) as again:  # and after it, the next client is served
            assert again.firmware()
        assert served.poll() is None  # it never stopped
    finally:
        for conn in flood:
            conn.close()
        served.terminate()
        _, errors = served.communicate(timeout=10)
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
    assert "Traceback" not in errors, errors


def test_a_connection_numbered_past_select_s_limit_is_turned_away_and_the_server_goes_on():
    import os

    from autonomy.emulator import Emulator
    from autonomy.emulator.servers import SELECT_FD_LIMIT, TcpServer

    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(max(soft, 4096), hard), hard))
    fillers: list[int] = []
    try:
        with TcpServer(Emulator("box"), port=0) as server:
            host, port = server.address
            while not fillers or fillers[-1] < SELECT_FD_LIMIT:  # this process holds a thousand files
                fillers.append(os.open(os.devnull, os.O_RDONLY))
            with socket.create_connection((host, port), timeout=10) as late:
                assert (
                    late.recv(200)
                    == b"BUSY: another client is connected to this emulator; one at a time, as on a serial line\n"
                )
            for fd in fillers:
                os.close(fd)
            fillers.clear()
            with Client.open(server.url) as robot:  # it went on serving
                assert robot.firmware() == "E10"
    finally:
        for fd in fillers:
            os.close(fd)
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))

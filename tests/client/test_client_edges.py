"""Opening links and waiting for the robot: a real silent pseudo-terminal, a port that is not
there, an emulator's own clock, and a robot that goes quiet after it has talked."""

from __future__ import annotations

import os
from types import SimpleNamespace

import pytest

from autonomy import client as client_module
from autonomy.client import DEFAULT_TIMEOUT_S, Client, open_port
from autonomy.clock import VirtualClock
from autonomy.errors import LinkError, ReplyTimeout


def test_a_silent_pseudo_terminal_is_reported_within_the_ready_time_out():
    """pyserial on a real pty whose other end never answers: the port's read time-out ends each try."""
    controller, device = os.openpty()
    try:
        with pytest.raises(ReplyTimeout, match=r"within 0\.3 s; nothing came back: is the robot on"):
            Client.open(os.ttyname(device), ready_timeout_s=0.3, timeout_s=0.05)
    finally:
        os.close(controller)
        os.close(device)


def test_ports_are_opened_with_the_read_time_out_that_bounds_every_wait():
    assert open_port("loop://").timeout == DEFAULT_TIMEOUT_S


def test_an_emulator_port_keeps_its_own_clock_unless_given_one():
    assert isinstance(Client.open("emu://?time=virtual").clock, VirtualClock)
    mine = VirtualClock(100.0)
    assert Client.open("emu://?time=virtual", clock=mine).clock is mine


@pytest.mark.parametrize(
    ("devices", "listed"), [([], "none found"), (["/dev/ttyUSB1", "/dev/ttyACM0"], "/dev/ttyACM0, /dev/ttyUSB1")]
)
def test_a_port_that_is_not_there_lists_the_serial_ports_there_are(monkeypatch, tmp_path, devices, listed):
    ports = [SimpleNamespace(device=name) for name in devices]
    monkeypatch.setattr(client_module.list_ports, "comports", lambda: ports)
    with pytest.raises(LinkError) as caught:
        Client.open(str(tmp_path / "ttyNOPE"))
    assert str(caught.value).endswith(f"no such port (serial ports on this machine: {listed})")


class Quiet:
    """The emulator's port with the robot gone quiet: writes are taken, nothing comes back."""

    def __init__(self, port) -> None:
        self.inner = port

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def write(self, data: bytes) -> int:
        return len(data)

    def read(self, size: int = 1) -> bytes:
        return b""

    @property
    def in_waiting(self) -> int:
        return 0


def test_waiting_again_for_a_robot_that_went_quiet_says_nothing_came_back_this_time():
    client = Client.open("emu://?time=virtual")
    client.status()
    assert client.stats.bytes_received > 0  # what came back before is not counted again
    client.port = Quiet(client.port)
    with pytest.raises(ReplyTimeout, match=r"within 1 s; nothing came back"):
        client.wait_ready(1.0)

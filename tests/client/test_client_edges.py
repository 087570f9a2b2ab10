"""Opening links and waiting for the robot: a real silent pseudo-terminal, a port that is not
there, an emulator's own clock, and a robot that goes quiet after it has talked."""

from __future__ import annotations

import os
from types import SimpleNamespace

import pytest

from autonomy import client as client_module
from autonomy.client import DEFAULT_RETRIES, DEFAULT_TIMEOUT_S, GARBLED_LIMIT, Client, open_port
from autonomy.clock import RealClock, VirtualClock
from autonomy.errors import CommandRefused, LinkError, ReplyTimeout
from tests.client.fakes import ScriptedPort, frames_of
from tests.client.test_client_faults import TimedPort, packet


def test_a_silent_pseudo_terminal_is_reported_within_the_ready_time_out():
    """pyserial on a real pty whose other end never answers: the port's read time-out ends each try."""
    controller, device = os.openpty()
    clock = RealClock()
    started_s = clock.now()
    try:
        with pytest.raises(ReplyTimeout, match=r"within 0\.3 s; nothing came back: is the robot on"):
            Client.open(os.ttyname(device), ready_timeout_s=0.3, timeout_s=0.05)
        assert clock.now() - started_s < 5.0  # the time-out, give or take a loaded machine; never a hang
    finally:
        os.close(controller)
        os.close(device)


@pytest.mark.parametrize(
    ("faults", "came_back"),
    [
        ("drop=1", "nothing came back"),
        ("drop=0.3", "bytes came back but none formed a reply"),
        ("no=1", "lines of text but none the reply asked for (the last: 'NO')"),
    ],
)
def test_an_emulated_link_that_loses_every_reply_is_blamed_on_its_injected_faults(faults, came_back):
    """Not on the baud rate, the power or the protocol, which a real robot's silence would ask about."""
    message = no_answer(f"faults={faults}")
    assert f"{came_back}: the emulator injects link faults ({faults}), and they kept the replies" in message
    assert "baud?" not in message and "is the robot on" not in message and "protocol?" not in message


@pytest.mark.parametrize(
    ("options", "guess"),
    [
        ("baud=115200&faults=drop=0.001", "is the robot set to 115200 baud?"),
        ("boot=60&faults=drop=0.01", "is the robot on"),
    ],
)
def test_a_wrong_baud_rate_or_a_robot_still_starting_is_said_even_on_a_faulty_emulated_link(options, guess):
    """The faults are named only when they are the reason: a wrong rate or a booting robot is said as for a real one."""
    message = no_answer(options)
    assert guess in message and "injects" not in message


def no_answer(options: str) -> str:
    """What opening an emulated link with ``options`` says when no reply gets through."""
    with pytest.raises(ReplyTimeout) as caught:
        Client.open(f"emu://?{options}&time=virtual", ready_timeout_s=0.5, timeout_s=0.05)
    return str(caught.value)


@pytest.mark.parametrize(
    ("faults", "named"),
    [
        ("", ""),
        ("pace", ""),
        ("drop=0.3", "drop=0.3"),
        ("no=0.5,pace", "no=0.5,pace"),
        ("delay=0.1", "delay=0.1,delay_s=0.3"),
    ],
)
def test_an_emulator_port_names_only_the_faults_that_can_keep_a_reply_from_getting_through(faults, named):
    port = open_port(f"emu://?faults={faults}&time=virtual")
    try:
        hint = port.silence_hint()
        assert hint == (
            f"the emulator injects link faults ({named}), and they kept the replies from getting through"
            if named
            else ""
        )
    finally:
        port.close()


def test_ports_are_opened_with_the_read_time_out_that_bounds_every_wait():
    assert open_port("loop://").timeout == DEFAULT_TIMEOUT_S


def test_an_emulator_port_keeps_its_own_clock_unless_given_one():
    own = Client.open("emu://?time=virtual")
    assert isinstance(own.clock, VirtualClock) and own.clock is own.port.clock is own.port.emulator.clock
    mine = VirtualClock(100.0)
    given = Client.open("emu://?time=virtual", clock=mine)
    assert given.clock is mine and given.port.clock is mine and given.port.emulator.clock is mine


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


# ---------------------------------------------------------------- one request, byte by byte


class Counting(ScriptedPort):
    """Notes how many bytes each read asks for."""

    def __init__(self, replies) -> None:
        super().__init__(replies)
        self.asked: list[int] = []

    def read(self, size: int = 1) -> bytes:
        self.asked.append(size)
        return super().read(size)


def test_a_no_to_a_value_request_is_asked_again_as_garbled_before_it_uses_up_the_retries():
    port = ScriptedPort([b"NO\n"] * 40)
    client = Client(port, name="r")
    with pytest.raises(ReplyTimeout, match=r"the robot answered NO to GD000, a request that is always valid"):
        client.front_distance_mm()
    assert frames_of(port) == [b"GD000"] * (GARBLED_LIMIT + 1 + DEFAULT_RETRIES)
    assert client.stats.refusals == GARBLED_LIMIT + 1 + DEFAULT_RETRIES


def test_a_value_after_a_no_to_its_request_is_taken():
    port = ScriptedPort([b"NO\n", b"NO\n", b"D042\n"])
    assert Client(port, name="r").front_distance_mm() == 42 and len(port.writes) == 3


def test_a_refused_command_carries_its_frame():
    with pytest.raises(CommandRefused) as caught:
        Client(ScriptedPort([b"NO\n"] * 4), name="r").move(3)
    assert caught.value.frame == b"F+300\n"


def test_an_implausible_packet_reaches_the_listeners_with_its_bytes_and_attempt():
    bad = packet(odometer_mm=455 - 256)
    port = TimedPort([packet(), packet(), bad, packet(460, 92, 1)])
    client = Client(port, name="r")
    seen = []
    client.listeners.append(lambda frame, outcome, attempt: seen.append((attempt, outcome)))
    client.status()
    client.status()
    [(attempt, refused)] = [(a, o) for a, o in seen if "implausible" in str(o)]
    assert attempt == 0 and refused.data == bad


def test_replies_are_read_a_frame_at_a_time_not_byte_by_byte():
    port = Counting([packet(), packet(), b"D042\n"])
    client = Client(port, name="r")
    client.status()  # the first packet is asked for twice
    assert port.asked == [3, 6, 3, 6]  # a NO is the shortest reply; then the rest of the packet
    assert client.front_distance_mm() == 42 and port.asked[4:] == [3, 2]


def test_a_reply_cut_short_says_how_many_bytes_came():
    port = ScriptedPort([packet()[:4]])
    client = Client(port, name="r", retries=0)
    with pytest.raises(ReplyTimeout) as caught:
        client.status()
    assert caught.value.received == 4 and client.stats.bytes_received == 4
    assert port.clock.now() == 0.25  # the last byte came at the time-out: no read after it
    port.replies.append(b"OK\n")
    client.stop()
    assert client.stats.bytes_sent == 12  # two frames of six bytes


def test_a_silent_robot_costs_one_time_out_per_attempt_and_no_more():
    port = ScriptedPort([None])
    client = Client(port, name="r", retries=0, timeout_s=0.25)
    with pytest.raises(ReplyTimeout):
        client.status()
    assert port.clock.now() == 0.25


def test_a_client_names_its_link_by_the_port_or_calls_it_the_robot():
    port = ScriptedPort()
    assert Client(port).name == "robot" and Client(port).firmware_version == ""
    port.port = "/dev/ttyUSB7"
    assert Client(port).name == "/dev/ttyUSB7" and Client(port, name="arm").name == "arm"

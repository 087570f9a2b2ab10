"""The same client over every way in: emu:// (virtual time), a real TCP socket, a real pty."""

import socket

import pytest

from autonomy.client import Client
from autonomy.clock import VirtualClock
from autonomy.emulator import Emulator
from autonomy.emulator.servers import PtyServer, TcpServer
from autonomy.errors import LinkLost, PortError, ReplyTimeout
from autonomy.protocol import Beep, Get, Move, Stop


@pytest.fixture(params=["emu", "tcp", "pty"])
def link(request):
    """Yields (client, emulator) over each transport."""
    if request.param == "emu":
        client = Client.open("emu://?world=corridor&time=virtual")
        yield client, client.port.emulator
        client.close()
        return
    emulator = Emulator("corridor")
    server = TcpServer(emulator, port=0) if request.param == "tcp" else PtyServer(emulator)
    with server:
        client = Client.open(server.url)
        yield client, emulator
        client.close()


def test_every_parameter_answers(link):
    client, _ = link
    assert client.firmware() == "E10"
    assert client.battery() == 230
    assert client.healthy() is True
    assert client.velocity() == 0
    assert client.tilt_deg() == 0
    assert client.front_distance_mm() == 255
    status = client.status()
    assert (status.mode, status.auto_mode, status.heading_deg, status.odometer_mm) == (0, True, 0, 0)


def test_driving_moves_the_odometer_and_the_emulator_sees_each_command(link):
    client, emulator = link
    client.beep((1, 6, 2), 5)
    client.move(2)
    client.clock.sleep(0.3)
    moving = client.status()
    client.stop()
    assert moving.moving and moving.mode == 1 and moving.odometer_mm > 20
    assert [c for c in emulator.commands() if not isinstance(c, Get)] == [Beep((1, 6, 2), 5), Move(2), Stop()]
    assert emulator.robot.beeps[0][1:] == ((1, 6, 2), 5)


def test_tcp_server_serves_one_peer_at_a_time_and_tells_the_other_why():
    with TcpServer(Emulator("box"), port=0) as server:
        first = Client.open(server.url)
        with pytest.raises(LinkLost, match="BUSY: another client is connected"):
            Client.open(server.url, ready_timeout_s=0.5)
        assert first.firmware() == "E10"
        first.close()
        second = Client.open(server.url)  # the line is free again
        assert second.firmware() == "E10"
        second.close()


def test_a_client_that_reconnects_at_once_is_always_served():
    with TcpServer(Emulator("box"), port=0) as server:
        host, port = server.address
        for _ in range(100):
            with socket.create_connection((host, port)) as sock:
                sock.sendall(b"GF000\n")
                assert sock.recv(16) == b"FE10\n"  # served, not turned away


def test_a_reconnecting_client_never_gets_the_replies_meant_for_the_one_before():
    with TcpServer(Emulator("box", faults="pace"), port=0) as server:
        for _ in range(30):
            with socket.create_connection(server.address) as sock:
                sock.sendall(b"GB000\n")  # closed before the paced reply is out
            with socket.create_connection(server.address) as sock:
                sock.settimeout(2.0)
                sock.sendall(b"GF000\n")
                reply = b""
                while not reply.endswith(b"\n"):
                    reply += sock.recv(16)
                assert reply == b"FE10\n"


def test_a_silent_peer_is_dropped_after_the_idle_time_out():
    with TcpServer(Emulator("box"), port=0, idle_peer_s=0.2) as server:
        silent = socket.create_connection(server.address)
        silent.settimeout(3.0)
        assert silent.recv(16) == b""  # closed by the server
        client = Client.open(server.url)  # and the line is free
        assert client.firmware() == "E10"
        client.close()
        silent.close()


def test_tcp_server_speaks_ipv6_on_loopback():
    try:
        server = TcpServer(Emulator("box"), host="::1", port=0)
    except OSError:
        pytest.skip("this machine has no IPv6 loopback")
    with server:
        assert server.url.startswith("socket://[::1]:") and not server.public
        client = Client.open(server.url)
        assert client.firmware() == "E10"
        client.close()


@pytest.mark.parametrize("kind", ["tcp", "pty"])
def test_server_going_away_is_a_lost_link(kind):
    emulator = Emulator("box")
    server = (TcpServer(emulator, port=0) if kind == "tcp" else PtyServer(emulator)).start()
    client = Client.open(server.url)
    server.stop()
    with pytest.raises(LinkLost):
        for _ in range(5):  # a write may still be buffered; a read cannot succeed
            client.status()
    assert client.close() is False


def test_lost_delayed_and_refused_replies_are_survived_by_retries():
    client = Client.open("emu://?time=virtual&seed=3&faults=drop=0.003,garbage=0.05,delay=0.02,no=0.02")
    headings = {client.status().heading_deg for _ in range(400)}
    assert headings == {0}  # every packet that got through is the true one
    stats = client.stats
    assert stats.attempts > stats.requests > 400  # 400 statuses, firmware polls on open, retries on top
    assert stats.retries > 0 and stats.framing_errors > 0 and stats.timeouts > 0 and stats.refusals > 0
    client.close()


def test_corrupted_bytes_are_caught_where_the_frame_shows_them():
    # The protocol has no checksum: a corrupted byte inside a packet whose first and last bytes
    # are intact cannot be seen. Corrupted framing bytes are caught, counted and asked again.
    client = Client.open("emu://?time=virtual&seed=5&faults=corrupt=0.01")
    statuses = [client.status() for _ in range(400)]
    assert client.stats.framing_errors > 0 and client.stats.retries > 0
    assert sum(s.heading_deg == 0 and s.front_distance_mm == 255 for s in statuses) > 350
    client.close()


def test_same_seed_same_faults():
    def run() -> tuple:
        client = Client.open("emu://?time=virtual&seed=11&faults=drop=0.005,corrupt=0.005")
        for _ in range(100):
            client.status()
        return (client.stats.retries, client.stats.framing_errors, client.clock.now())

    assert run() == run()


@pytest.mark.parametrize(("baud", "expected_s"), [(57600, 15 * 10 / 57600), (115200, 15 * 10 / 115200)])
def test_pacing_makes_a_status_poll_cost_its_wire_time(baud, expected_s):
    client = Client.open(f"emu://?time=virtual&faults=pace&baud={baud}", baud=baud)
    client.status()  # the link's first packet is read twice; from then on, one poll each
    start = client.clock.now()
    client.status()
    assert client.clock.now() - start == pytest.approx(expected_s, rel=1e-9)


def test_wrong_baud_rate_gives_noise_and_a_clear_error():
    with pytest.raises(ReplyTimeout, match="none formed a reply: is the robot set to 57600 baud"):
        Client.open("emu://?time=virtual", baud=115200)


def test_open_errors_are_one_line_port_errors():
    with pytest.raises(PortError, match="no such port"):
        Client.open("/dev/does-not-exist")
    with pytest.raises(PortError, match="baud rate 9600 is not supported"):
        Client.open("emu://", baud=9600)
    with pytest.raises(PortError, match="unknown emulator option 'wrold'"):
        Client.open("emu://?wrold=box")
    with pytest.raises(PortError, match="no world named 'mars'"):
        Client.open("emu://?world=mars")


def test_client_can_run_on_a_clock_of_its_own():
    clock = VirtualClock(100.0)
    client = Client.open("emu://?boot=1.5", clock=clock)
    assert client.clock is clock and client.port.emulator.clock is clock
    assert clock.now() >= 101.5  # it polled through the boot time, on this clock
    client.close()


def test_why_a_port_did_not_open_says_what_to_do():
    with pytest.raises(PortError, match=r"no such port \(serial ports on this machine: "):
        Client.open("/dev/ttyNOSUCH")
    listener = socket.create_server(("127.0.0.1", 0))
    free_port = listener.getsockname()[1]
    listener.close()  # nothing listens there now
    with pytest.raises(PortError, match=r"connection refused \(is the emulator running there\?\)"):
        Client.open(f"socket://127.0.0.1:{free_port}")


@pytest.mark.parametrize(
    "url",
    [
        "socket://127.0.0.1:0",
        "socket://127.0.0.1:65536",
        "socket://127.0.0.1:abc",
        "socket://127.0.0.1:\uff17\uff17",  # digits, but not ASCII ones
        "socket://:7777",
        "SOCKET://127.0.0.1:0",  # the scheme in capitals is checked the same
    ],
)
def test_a_socket_url_without_a_host_and_a_port_from_1_to_65535_is_refused_before_connecting(url):
    with pytest.raises(PortError, match=r"expected socket://HOST:PORT, with a PORT from 1 to 65535"):
        Client.open(url)


@pytest.mark.parametrize("port", [1, 65535])
def test_ports_1_and_65535_are_tried(port):
    with pytest.raises(PortError, match="connection refused"):  # nothing listens there: tried, and refused
        Client.open(f"socket://127.0.0.1:{port}")


@pytest.mark.parametrize("suffix", ["", "/", "?logging=warning"])
def test_a_socket_url_may_end_in_a_path_or_pyserial_options(suffix):
    with TcpServer(Emulator("box"), port=0) as server:
        url = server.url + suffix
        client = Client.open(url)
        assert client.name == url and client.status().heading_deg == 0
        client.close()


def test_an_unknown_scheme_or_an_empty_error_still_says_something():
    from autonomy.client import _open_reason, _reason

    with pytest.raises(PortError, match=r"cannot open nosuch://x: invalid URL"):
        Client.open("nosuch://x")
    assert _reason(TimeoutError()) == "TimeoutError"
    assert _open_reason(ValueError("first line\nsecond")) == "first line"


def test_closing_twice_reports_the_stop_both_times():
    client = Client.open("emu://?time=virtual")
    assert client.closed is False
    assert client.close() is True and client.close() is True and client.closed is True


def test_a_client_over_tcp_keeps_the_clock_and_name_it_was_opened_with():
    clock = VirtualClock(5.0)
    with TcpServer(Emulator("box"), port=0) as server:
        client = Client.open(server.url, clock=clock)
        assert client.clock is clock and client.name == server.url
        client.close()

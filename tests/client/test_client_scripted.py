"""The client against a scripted port: retries, refusals, framing, stale input, stop on close."""

import threading

import pytest
import serial

from autonomy.client import GARBLED_LIMIT, Client
from autonomy.errors import CommandRefused, LinkError, LinkLost, ReplyTimeout
from autonomy.protocol import Status
from tests.client.fakes import ScriptedPort, frames_of

STATUS = Status(1, True, False, True, -4, 270, 10, 65535).encode()  # front distance 10 mm is byte 0x0A


def client_for(port: ScriptedPort, **kwargs) -> Client:
    return Client(port, name="scripted", **kwargs)


def test_status_packet_with_newline_bytes_is_read_by_length():
    port = ScriptedPort([STATUS, STATUS])
    status = client_for(port).status()
    assert status.front_distance_mm == 10 and status.heading_deg == 270 and status.tilt_deg == -4
    assert frames_of(port) == [b"Gb000", b"Gb000"]  # a link's first packet is trusted once a second agrees


def test_repeatable_command_is_asked_again_after_silence():
    port = ScriptedPort([None, None, b"B187\n"])
    client = client_for(port)
    assert client.battery() == 187
    assert frames_of(port) == [b"GB000"] * 3
    assert client.stats.timeouts == 2 and client.stats.retries == 2


def test_repeatable_command_gives_up_after_its_retries():
    port = ScriptedPort([None] * 10)
    client = client_for(port, retries=2)
    with pytest.raises(ReplyTimeout, match="no reply to F1?"):
        client.move(1)
    assert frames_of(port) == [b"F+100"] * 3


@pytest.mark.parametrize(("call", "frame"), [(lambda c: c.turn(90), b"T+090"), (lambda c: c.servo_by(1, -3), b"D1-30")])
def test_relative_moves_are_never_repeated(call, frame):
    port = ScriptedPort([None, b"OK\n"])
    client = client_for(port)
    with pytest.raises(ReplyTimeout):
        call(client)
    frames = frames_of(port)
    assert frames[0] == frame and frames.count(frame) == 1  # exactly one: a repeat could move twice
    assert set(frames[1:]) == {b"Gb000"}  # the lost reply is settled by reading the status


def test_relative_move_keeps_reading_past_junk_for_its_reply():
    port = ScriptedPort([b"\xff\x13OK\n"])
    client = client_for(port)
    client.turn(-45)
    assert frames_of(port) == [b"T-045"]
    assert client.stats.framing_errors == 1


def test_framing_error_is_counted_and_the_request_asked_again():
    corrupted = b"c" + STATUS[1:]
    port = ScriptedPort([corrupted, STATUS, STATUS])
    client = client_for(port)
    assert client.status().heading_deg == 270
    assert frames_of(port) == [b"Gb000"] * 3
    assert client.stats.framing_errors >= 1


def test_stale_input_is_discarded_before_a_request():
    port = ScriptedPort([b"D077\n"])
    port.buffer += b"D001\nOK\n"  # a late reply to something earlier
    assert client_for(port).front_distance_mm() == 77


def test_no_is_a_refusal_after_retries():
    port = ScriptedPort([b"NO\n"] * 4)
    client = client_for(port)
    with pytest.raises(CommandRefused, match="refused F\\+300"):
        client.move(3)
    assert client.stats.refusals == 4


def test_no_to_a_turn_is_not_retried():
    port = ScriptedPort([b"NO\n", b"OK\n"])
    with pytest.raises(CommandRefused):
        client_for(port).turn(10)
    assert frames_of(port) == [b"T+010"]


def test_health_no_is_an_answer_not_a_refusal():
    port = ScriptedPort([b"NO\n", b"NO\n"])
    assert client_for(port).healthy() is False
    assert frames_of(port) == [b"GR000"] * 2  # not retried as a refusal; asked once more to be believed


def test_close_sends_stop_until_acknowledged():
    port = ScriptedPort([b"NO\n", None, b"OK\n"])
    client = client_for(port)
    assert client.close() is True
    assert frames_of(port) == [b"X0000"] * 3
    assert port.closed


def test_close_gives_up_after_bounded_tries():
    port = ScriptedPort([None] * 20)
    client = client_for(port, stop_tries=4)
    assert client.close() is False
    assert frames_of(port) == [b"X0000"] * 4 and port.closed


def test_context_manager_stops_the_robot_on_an_exception():
    port = ScriptedPort(responder=lambda frame: b"OK\n")
    with pytest.raises(RuntimeError), client_for(port) as client:
        client.move(2)
        raise RuntimeError("student code failed")
    assert frames_of(port) == [b"F+200", b"X0000"]


def test_requests_after_close_fail_clearly():
    port = ScriptedPort(responder=lambda frame: b"OK\n")
    client = client_for(port)
    client.close()
    with pytest.raises(LinkError, match="closed"):
        client.stop()


def test_pyserial_errors_are_wrapped_as_link_lost():
    port = ScriptedPort([b"OK\n"])
    port.fail_with = serial.SerialException("device reports readiness to read but returned no data")
    client = client_for(port)
    with pytest.raises(LinkLost, match="lost the link to scripted") as info:
        client.status()
    assert isinstance(info.value.__cause__, serial.SerialException)
    assert client.close() is False  # the stop cannot get through; close still finishes


def test_wait_ready_polls_firmware_until_the_board_answers():
    port = ScriptedPort([None] * 7 + [b"F1.3\n"])
    client = client_for(port)
    assert client.wait_ready(3.0) == "1.3"
    assert frames_of(port) == [b"GF000"] * 8
    assert port.clock.now() == pytest.approx(7 * 0.25)


def test_wait_ready_tells_silence_from_noise():
    silent = client_for(ScriptedPort([None] * 100))
    with pytest.raises(ReplyTimeout, match="nothing came back"):
        silent.wait_ready(1.0)
    noisy = client_for(ScriptedPort(responder=lambda frame: b"\xf3\x9e\xa1"))
    with pytest.raises(ReplyTimeout, match="none formed a reply: is the robot set to 115200 baud"):
        noisy.wait_ready(1.0)


def test_listeners_see_every_exchange():
    port = ScriptedPort([None, b"OK\n"])
    seen = []
    client = client_for(port)
    client.listeners.append(lambda frame, outcome, attempt: seen.append((frame, type(outcome).__name__, attempt)))
    client.stop()
    assert seen == [(b"X0000\n", "ReplyTimeout", 0), (b"X0000\n", "Ack", 1)]


def test_one_request_in_flight_across_threads():
    lock_violations = []

    def responder(frame: bytes) -> bytes:
        if port.busy:
            lock_violations.append(frame)
        port.busy = True
        return b"F%03d\n" % len(port.writes)  # a 3-character "firmware version" that counts

    port = ScriptedPort(responder=responder)
    original_read = port.read

    def read(size: int = 1) -> bytes:
        data = original_read(size)
        if not port.buffer:
            port.busy = False
        return data

    port.read = read
    client = client_for(port)
    results: list[int] = []

    def worker() -> None:
        for _ in range(200):
            results.append(int(client.firmware()))

    threads = [threading.Thread(target=worker) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not lock_violations
    assert sorted(results) == list(range(1, 801))  # every request got its own reply


def test_a_turn_answered_with_noise_then_no_is_refused_not_accepted():
    port = ScriptedPort([b"\x13\xfeNO\n"])
    client = client_for(port)
    with pytest.raises(CommandRefused, match="refused T\\+090"):
        client.turn(90)
    assert frames_of(port) == [b"T+090"]


class TricklingPort(ScriptedPort):
    """A line that brings one byte of noise every 10 ms, for ever."""

    reads = 0

    def read(self, size: int = 1) -> bytes:
        self.reads += 1
        if self.reads > 1000:
            raise AssertionError("the client reads for ever: its time-out does not end the attempt")
        self.clock.sleep(0.01)
        return b"\xff"


def test_a_turn_amid_endless_noise_times_out_when_its_time_is_up():
    port = TricklingPort()
    client = client_for(port)
    with pytest.raises(ReplyTimeout, match="no reply to T\\+090 from scripted within 0.25 s"):
        client.turn(90)
    assert frames_of(port)[0] == b"T+090" and frames_of(port).count(b"T+090") == 1


def test_client_open_keeps_its_time_out_and_retries():
    client = Client.open("emu://?time=virtual", timeout_s=0.1, retries=1)
    assert client.timeout_s == 0.1 and client.retries == 1 and client.port.timeout == 0.1
    client.port.emulator.faults = type(client.port.emulator.faults)(drop=1.0)  # nothing gets through now
    start = client.clock.now()
    with pytest.raises(ReplyTimeout):
        client.battery()
    assert client.stats.attempts - 1 == 2  # the first request and its one retry (after wait_ready's GF)
    assert client.clock.now() - start == pytest.approx(0.2, abs=0.05)


def test_a_beep_by_default_is_three_rising_tones_at_volume_3():
    port = ScriptedPort([b"OK\n"])
    client_for(port).beep()
    assert frames_of(port) == [b"S5793"]


def test_waiting_for_a_robot_asks_once_a_try_and_never_retries_within_a_try():
    client = client_for(ScriptedPort([None] * 100))
    with pytest.raises(ReplyTimeout):
        client.wait_ready(1.0)
    assert client.stats.retries == 0 and client.stats.attempts == 4  # one GF000 each 0.25 s time-out


def test_a_robot_that_answers_at_once_but_wrongly_is_asked_again_after_a_pause():
    port = ScriptedPort(responder=lambda frame: b"OK\n")
    client = client_for(port)
    with pytest.raises(ReplyTimeout) as caught:
        client.wait_ready(1.0)
    tries = len(port.writes) / (GARBLED_LIMIT + 1)  # a garbled reply is asked again at once, GARBLED_LIMIT times
    assert 18 <= tries <= 22  # then one try each 50 ms, not thousands
    message = str(caught.value)
    assert "lines of text but none the reply asked for (the last: 'OK')" in message
    assert f"{caught.value.received} bytes came back" in message and caught.value.received == 3 * len(port.writes)
    assert client._waiting_ready is False


@pytest.mark.parametrize("noise", [b"\x7f\x7f\n", b"\x01ab\n", b"ab\x1f\n", b"\x80\n"])
def test_bytes_that_are_not_text_point_at_the_baud_rate(noise):
    client = client_for(ScriptedPort(responder=lambda frame: noise))
    with pytest.raises(ReplyTimeout, match="none formed a reply: is the robot set to 115200 baud"):
        client.wait_ready(0.5)


@pytest.mark.parametrize(
    ("said", "last"),
    [
        (b"BOOT OK V1\n", "BOOT OK V1"),  # spaces are text
        (b"one\ntwo\n", "two"),  # the last line
        (b"a long banner of text\n", "banner of text"),  # the last 16 bytes heard
    ],
)
def test_a_robot_that_speaks_text_is_quoted_at_its_last_line(said, last):
    client = client_for(ScriptedPort(responder=lambda frame: said))
    with pytest.raises(ReplyTimeout) as caught:
        client.wait_ready(0.5)
    assert f"lines of text but none the reply asked for (the last: {last!r})" in str(caught.value)

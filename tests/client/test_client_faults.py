"""A faulty link: replies of the wrong kind, corrupted status packets, lost replies to T and D."""

import pytest
from py_trees.common import Status as TreeStatus

from autonomy.behaviours.actions import Move, Turn
from autonomy.client import GARBLED_LIMIT, SETTLE_POLLS, SETTLE_WAIT_S, Client
from autonomy.errors import CommandUnconfirmed, ReplyTimeout
from autonomy.protocol import Ack, Status
from autonomy.protocol import Turn as TurnFrame
from tests.client.fakes import ScriptedPort, frames_of
from tests.harness import Rig


def packet(odometer_mm: int = 455, heading_deg: int = 90, tilt_deg: int = 0, **flags) -> bytes:
    return Status(
        flags.get("mode", 0),
        True,
        flags.get("collided", False),
        flags.get("moving", False),
        tilt_deg,
        heading_deg,
        200,
        odometer_mm,
    ).encode()


class TimedPort(ScriptedPort):
    """A scripted port on which every request takes 50 ms, as one tick apart would."""

    def write(self, data: bytes) -> int:
        self.clock.sleep(0.05)
        return super().write(data)


def client_for(port: ScriptedPort) -> Client:
    return Client(port, name="scripted")


# --------------------------------------------------------------------------- wrong kind of reply


@pytest.mark.parametrize("letter", list("DBFVA"))
def test_an_acknowledgement_to_a_value_request_is_a_framing_error_and_asked_again(letter):
    value = b"F123\n" if letter == "F" else letter.encode() + b"+12\n" if letter in "VA" else letter.encode() + b"012\n"
    port = ScriptedPort([b"OK\n", value])
    client = client_for(port)
    assert client._parameter(letter) in (12, "123")
    assert frames_of(port) == [f"G{letter}000".encode()] * 2
    assert client.stats.framing_errors == 1


def test_a_robot_that_only_acknowledges_value_requests_times_out_cleanly():
    port = ScriptedPort([b"OK\n"] * 30)
    client = client_for(port)
    with pytest.raises(ReplyTimeout, match="no valid reply to GF000"):
        client.firmware()
    assert client.stats.framing_errors == 8 + 4  # garbled replies asked again, then the retries


# --------------------------------------------------------------------------- corrupted packets


def test_an_odometer_jump_is_polled_again_and_never_returned():
    port = TimedPort([packet(455), packet(455), packet(17874), packet(477)])
    client = client_for(port)
    assert client.status().odometer_mm == 455
    assert client.status().odometer_mm == 477
    assert client.stats.implausible == 1 and client.stats.requests == 3


@pytest.mark.parametrize(
    ("bad", "why"),
    [
        (packet(heading_deg=90 + 128), "heading 90 -> 218"),
        (packet(heading_deg=(90 + 256) % 360), "heading 90 -> 346"),
        (packet(tilt_deg=-123), "tilt 0 -> -123"),
        (packet(odometer_mm=455 - 256), "odometer 455 -> 199"),
    ],
)
def test_a_corrupted_heading_tilt_or_odometer_is_refused_with_the_reason(bad, why):
    seen = []
    port = TimedPort([packet(), packet(), bad, packet(460, 92, 1)])
    client = client_for(port)
    client.listeners.append(lambda frame, outcome, attempt: seen.append((attempt, str(outcome))))
    client.status()
    assert client.status() == Status(0, True, False, False, 1, 92, 200, 460)
    refused = [text for _, text in seen if "implausible" in text]
    assert len(refused) == 1 and f"implausible status: {why}" in refused[0]


def test_motion_at_full_speed_is_plausible():
    # 427 mm/s and 90 deg/s, the emulator's fastest, polled at 20 Hz
    port = TimedPort([packet(0, 0), packet(0, 0), packet(22, 5), packet(44, 9), packet(65500, 355)])
    client = client_for(port)
    readings = [client.status() for _ in range(3)]
    assert [r.odometer_mm for r in readings] == [0, 22, 44] and client.stats.implausible == 0


def test_a_corrupted_first_packet_is_replaced_before_anything_sees_it():
    port = TimedPort([packet(17874), packet(455), packet(456)])
    client = client_for(port)
    assert client.status().odometer_mm == 456
    assert client.stats.implausible == 1


def test_a_new_collision_must_show_in_the_next_packet_too():
    flipped = packet(collided=True)
    port = TimedPort([packet(), packet(), flipped, packet(), packet(collided=True), packet(collided=True)])
    client = client_for(port)
    client.status()
    assert client.status().collided is False  # one packet with the flag, the next without it: corrupt
    assert client.stats.implausible == 1
    assert client.status().collided is True  # two in a row: a real collision
    assert client.stats.implausible == 1


def test_a_jump_two_packets_agree_on_is_believed_as_a_new_start():
    port = TimedPort([packet(455), packet(455), packet(30000), packet(30001)])
    client = client_for(port)
    client.status()
    assert client.status().odometer_mm == 30001  # the robot restarted or was moved: both say so
    assert client.stats.implausible == 1 and client.stats.rebased == 1


def test_a_believed_packet_that_was_corrupt_is_replaced_once_two_agree():
    # heading 333 corrupted to 325 passes (a robot can turn 8 degrees in 50 ms); the real 333 comes back
    port = TimedPort([packet(heading_deg=333), packet(heading_deg=333), packet(heading_deg=325)])
    port.replies.extend([packet(heading_deg=333)] * 3)
    client = client_for(port)
    client.status()
    assert client.status().heading_deg == 325
    assert client.status().heading_deg == 333 and client.stats.rebased == 0


def test_packets_that_never_agree_end_in_a_clear_link_error():
    noise = [packet(odometer_mm=(7919 * n) % 65536, heading_deg=(97 * n) % 360) for n in range(1, 30)]
    port = TimedPort([packet(455), packet(455), *noise])
    client = client_for(port)
    client.status()
    with pytest.raises(ReplyTimeout, match="packets in a row were garbled or did not agree with each other"):
        client.status()
    assert client.stats.implausible == GARBLED_LIMIT + 1


def test_a_run_does_not_count_a_jump_its_robot_made_as_distance():
    rig = Rig(Move("m", speed=1, direction="forward", seconds=0.5), "world=empty")
    rig.tick()
    rig.robot.odometer_mm += 20000  # as if the robot restarted its odometer mid-run
    rig.tick_until_done()
    assert rig.client.stats.rebased == 1 and rig.runner.summary.distance_mm < 200


def test_corrupted_bytes_never_reach_a_run_summary():
    """1% corrupted bytes once gave 28 m driven in a few seconds: now every packet is checked."""
    rig = Rig(Move("m", speed=4, direction="forward", seconds=2.0), "world=empty&seed=3&faults=corrupt=0.01")
    rig.tick_until_done()
    summary = rig.runner.summary
    truth_mm = rig.robot.odometer_mm
    assert rig.client.stats.implausible > 0
    assert summary.distance_mm == pytest.approx(truth_mm, abs=60)  # 2 s at 427 mm/s: about 850 mm


# --------------------------------------------------------------------------- lost replies to T and D


def test_a_lost_reply_to_a_turn_is_settled_by_the_status():
    def respond(frame: bytes) -> bytes | None:
        if frame.startswith(b"T"):
            return None  # the reply is lost
        return packet(heading_deg=95, moving=True) if respond.turning else packet()

    respond.turning = False
    port = TimedPort(responder=respond)
    client = client_for(port)
    client.status()
    respond.turning = True
    client.turn(60)
    assert frames_of(port).count(b"T+060") == 1 and client.stats.settled == 1


def test_a_lost_reply_to_a_turn_the_robot_did_not_take_fails_the_command_not_the_link():
    port = TimedPort(responder=lambda frame: None if frame.startswith(b"T") else packet())
    client = client_for(port)
    client.status()
    with pytest.raises(CommandUnconfirmed, match="the robot is not turning") as caught:
        client.turn(60)
    assert frames_of(port).count(b"T+060") == 1
    assert caught.value.frame == b"T+060\n"  # the command that was not confirmed travels with the error


def test_a_lost_reply_to_a_servo_step_fails_the_command_not_the_link():
    port = TimedPort(responder=lambda frame: None if frame.startswith(b"D") else packet())
    client = client_for(port)
    with pytest.raises(CommandUnconfirmed, match="may or may not have moved"):
        client.servo_by(0, 5)
    assert frames_of(port).count(b"D0+50") == 1


class LosingPort:
    """An emulator port that loses the reply to the first frame starting with ``letter``."""

    def __init__(self, url: str, letter: bytes, rewrite: tuple[bytes, bytes] | None = None) -> None:
        from autonomy.client import open_port

        self.inner = open_port(url)
        self.letter, self.rewrite, self.lose = letter, rewrite, False
        self.lost = 0

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def write(self, data: bytes) -> int:
        if self.rewrite and data.startswith(self.rewrite[0]):
            data = self.rewrite[1] + data[len(self.rewrite[0]) :]
        elif data.startswith(self.letter) and not self.lost:
            self.lose = True
        return self.inner.write(data)

    def read(self, size: int = 1) -> bytes:
        data = self.inner.read(size)
        if self.lose and data:
            self.lose, self.lost = False, 1
            self.inner.reset_input_buffer()
            return b""
        return data


def test_a_turn_whose_reply_is_lost_still_completes_in_a_run():
    port = LosingPort("emu://?time=virtual&world=empty", b"T")
    rig = Rig(Turn("t", left=90), client=Client(port, clock=port.inner.clock, name="losing"))
    assert rig.tick_until_done() == TreeStatus.SUCCESS
    assert port.lost and rig.client.stats.settled == 1
    assert [c.angle_deg for c in rig.sent() if hasattr(c, "angle_deg")] == [90]


@pytest.mark.parametrize(
    ("node", "rewrite", "why"),
    [
        (Turn("t", left=60), (b"T+", b"T-"), "turning the wrong way"),
        (Turn("t", right=60), (b"T-", b"T+"), "turning the wrong way"),
        (Move("m", speed=2, direction="forward", seconds=3.0), (b"F+", b"F-"), "moving the wrong way"),
        (Move("m", speed=1, direction="backward", distance_mm=500), (b"F-", b"F+"), "moving the wrong way"),
    ],
)
def test_a_motion_the_wrong_way_is_stopped_within_3_ticks(node, rewrite, why):
    port = LosingPort("emu://?time=virtual&world=empty", b"?", rewrite)
    rig = Rig(node, client=Client(port, clock=port.inner.clock, name="sign-flipped"))
    ticks = 0
    while rig.tick() == TreeStatus.RUNNING:
        ticks += 1
    assert rig.root.status == TreeStatus.FAILURE and why in node.feedback_message
    assert ticks <= 3
    assert rig.sent()[-1].letter == "X"
    rig.client.clock.sleep(0.5)  # it slows down at its acceleration
    assert not rig.robot.moving


@pytest.mark.parametrize("tick_hz", [20.0, 50.0, 100.0, 200.0])
def test_a_move_that_starts_while_the_robot_still_rolls_back_is_not_the_wrong_way(tick_hz):
    rig = Rig(Move("m", speed=2, direction="forward", distance_mm=300), "world=empty", tick_hz=tick_hz)
    robot = rig.robot
    robot.speed_mm_s = robot.target_speed_mm_s = -robot.params.speed_mm_s(4)  # backing at full speed
    assert rig.tick_until_done() == TreeStatus.SUCCESS, rig.root.feedback_message
    assert rig.root.feedback_message.startswith("drove")


def settle_rig(before: bytes, after: bytes) -> tuple[Client, TimedPort]:
    """A client whose T reply is lost, with the robot reading ``before`` until the T and ``after`` since."""
    state = {"turned": False}

    def respond(frame: bytes) -> bytes | None:
        if frame.startswith(b"T"):
            state["turned"] = True
            return None
        return after if state["turned"] else before

    port = TimedPort(responder=respond)
    client = client_for(port)
    client.status()
    return client, port


@pytest.mark.parametrize(
    ("before", "after", "settled"),
    [
        (packet(heading_deg=90), packet(heading_deg=93), True),  # turned, already stopped
        (packet(heading_deg=90), packet(heading_deg=90, moving=True, mode=2), True),  # just started
        (packet(heading_deg=90, moving=True, mode=1), packet(heading_deg=90, moving=True, mode=1), False),  # driving on
        (packet(heading_deg=90), packet(heading_deg=90), False),  # nothing happened
    ],
)
def test_a_lost_turn_reply_is_settled_only_by_a_turn_the_status_shows(before, after, settled):
    client, port = settle_rig(before, after)
    start_s = client.clock.now()
    if settled:
        assert client.request(TurnFrame(30)) == Ack(True)
        assert client.stats.settled == 1
    else:
        with pytest.raises(CommandUnconfirmed, match="the robot is not turning"):
            client.request(TurnFrame(30))
        frames = frames_of(port)
        after = frames[frames.index(b"T+030") + 1 :]
        assert after == [b"Gb000"] * SETTLE_POLLS and client.stats.settled == 0
        waited_s = client.clock.now() - start_s
        # Each frame takes 50 ms on this port; the time-out; a wait between polls, none after the last.
        frame_s = 0.05 * (1 + SETTLE_POLLS)
        assert waited_s == pytest.approx(frame_s + client.timeout_s + (SETTLE_POLLS - 1) * SETTLE_WAIT_S)
    assert frames_of(port).count(b"T+030") == 1


def test_each_settled_turn_is_counted():
    turns = []

    def respond(frame: bytes) -> bytes | None:
        if frame.startswith(b"T"):
            turns.append(frame)
            return None
        return packet(heading_deg=90 + 5 * len(turns))

    client = client_for(TimedPort(responder=respond))
    client.status()
    client.turn(30)
    client.turn(30)
    assert client.stats.settled == 2 and len(turns) == 2


@pytest.mark.parametrize(
    ("heard", "said"),
    [
        (b"BUSY: another client\n", "BUSY: another client"),
        (b"\x00\xff\nHELLO 12345678\n", "HELLO 12345678"),  # the last line only
        (b"1234567\n", ""),  # too short to be a notice
        (b"12345678\n", "12345678"),  # long enough
        (b"abc\x07defgh\n", ""),  # not printable
        (b"caf\xe9 au lait!\n", ""),  # not ASCII
        (b"", ""),
    ],
)
def test_what_a_port_said_is_shown_only_when_it_is_a_line_of_text(heard, said):
    client = client_for(ScriptedPort())
    client._heard = bytearray(heard)
    assert client.heard_text() == said


def test_health_is_not_taken_as_bad_from_one_garbled_request():
    port = ScriptedPort([b"NO\n", b"OK\n"])  # the first GR000 arrived garbled, so the robot said NO
    client = client_for(port)
    assert client.healthy() is True and frames_of(port) == [b"GR000", b"GR000"]
    unhealthy = ScriptedPort([b"NO\n", b"NO\n"])
    assert client_for(unhealthy).healthy() is False and len(unhealthy.writes) == 2

"""Request/reply over a pyserial port: the one way the package talks to a robot.

The port comes from a URL through :func:`serial.serial_for_url`: a device path
(``/dev/ttyUSB0``, ``COM3``), ``socket://host:port`` (an emulator in another process) or
``emu://`` (an emulator in this process, see :mod:`autonomy.emulator`). The client code is
the same for all of them.

One request is in flight at a time (a lock makes the client safe to share between
threads). Before each request stale input is discarded. Commands that are harmless to
repeat (``G X F M S``) are asked again after a time-out, a framing error or a ``NO``;
relative moves (``T D``) never are, since a repeat after a lost ``OK`` would move twice:
a lost reply to one of them is settled by reading the status instead.

The protocol has no checksum, so every status packet is judged by a
:class:`~autonomy.guard.StatusGuard` before it is returned: one the robot cannot have sent is
counted and polled again, and never returned.
"""

from __future__ import annotations

import errno
import threading
from collections.abc import Callable
from dataclasses import dataclass
from types import TracebackType
from typing import Any, TypeVar

import serial
from serial.tools import list_ports

from autonomy.clock import Clock, RealClock
from autonomy.errors import (
    AutonomyError,
    CommandRefused,
    CommandUnconfirmed,
    FramingError,
    ImplausibleStatus,
    LinkError,
    LinkLost,
    PortError,
    ReplyTimeout,
)
from autonomy.guard import StatusGuard, Verdict
from autonomy.guardian import Guardian, link_descriptor
from autonomy.protocol import (
    PARAMETERS,
    STATUS_LENGTH,
    Ack,
    Beep,
    Command,
    Get,
    Health,
    Move,
    Parameter,
    Reply,
    ReplyDecoder,
    ServoBy,
    ServoTo,
    Status,
    Stop,
    Turn,
    decode_status,
)

try:
    from termios import error as _TermiosError  # pyserial lets this through when a pty goes away
except ImportError:  # pragma: no cover - not on Windows

    class _TermiosError(Exception):  # type: ignore[no-redef]
        """Never raised where termios does not exist."""


#: What a pyserial port raises when the device or connection fails under it.
PORT_ERRORS = (serial.SerialException, OSError, _TermiosError)

# pyserial imports ``autonomy.urlhandler.protocol_emu`` only when an emu:// URL is opened,
# so the client does not depend on the emulator.
if "autonomy.urlhandler" not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append("autonomy.urlhandler")

DEFAULT_BAUD = 57600
SUPPORTED_BAUD_RATES = (57600, 115200)
DEFAULT_TIMEOUT_S = 0.25
DEFAULT_RETRIES = 3
DEFAULT_READY_TIMEOUT_S = 3.0
DEFAULT_STOP_TRIES = 5
#: Pause between two tries of a robot that is not ready yet.
READY_RETRY_S = 0.05

#: Garbled replies (framing errors, implausible status packets) a repeatable request asks
#: again for before they use up its retries: at 1% corrupted bytes, 9% of status packets are
#: garbled, and a run of 20 Hz polls would otherwise lose the link about once an hour.
GARBLED_LIMIT = 8
#: How much of what the port said last is kept, to quote a server's notice or a board's banner.
HEARD_BYTES = 120
#: After a lost reply to ``T``: how many status polls look for the turn, and the wait between them.
SETTLE_POLLS = 3
SETTLE_WAIT_S = 0.05

#: Called after every attempt with the frame sent, the reply (or error) it got, and the
#: attempt number (0 for a request's first attempt, 1.. for its retries).
ExchangeListener = Callable[[bytes, "Reply | AutonomyError", int], None]


@dataclass
class LinkStats:
    """Counters of what happened on the link since it was opened."""

    requests: int = 0
    attempts: int = 0
    retries: int = 0
    timeouts: int = 0
    framing_errors: int = 0
    refusals: int = 0
    implausible: int = 0
    rebased: int = 0
    settled: int = 0
    bytes_sent: int = 0
    bytes_received: int = 0


def open_port(url: str, baud: int = DEFAULT_BAUD, clock: Clock | None = None) -> serial.SerialBase:
    """Opens the pyserial port behind ``url``.

    Args:
        url: A device path, ``socket://host:port`` or ``emu://[?options]``.
        baud: 57600 or 115200.
        clock: For ``emu://`` ports, the clock the emulator runs on.

    Raises:
        PortError: the URL is not understood or the port cannot be opened.
    """
    if baud not in SUPPORTED_BAUD_RATES:
        raise PortError(f"baud rate {baud} is not supported; the robot speaks 57600 or 115200")
    if url.lower().startswith("socket://"):
        host, _, port = url[len("socket://") :].split("?")[0].split("/")[0].rpartition(":")
        if not host or not (port.isascii() and port.isdigit()) or not 1 <= int(port) <= 65535:
            raise PortError(f"cannot open {url}: expected socket://HOST:PORT, with a PORT from 1 to 65535")
    try:
        port = serial.serial_for_url(url, baudrate=baud, timeout=DEFAULT_TIMEOUT_S, do_not_open=True)
        if clock is not None and hasattr(port, "clock"):
            port.clock = clock
        port.open()
    except (serial.SerialException, OSError, ValueError) as err:
        raise PortError(f"cannot open {url}: {_open_reason(err)}") from err
    return port


def _reason(err: BaseException) -> str:
    text = str(err).strip() or type(err).__name__
    return text.splitlines()[0]


def _open_reason(err: BaseException) -> str:
    """Says why a port did not open, in terms of what to do about it."""
    code = getattr(err, "errno", None)
    if code == errno.ENOENT:
        ports = ", ".join(sorted(info.device for info in list_ports.comports())) or "none found"
        return f"no such port (serial ports on this machine: {ports})"
    if code in (errno.EACCES, errno.EPERM):
        return "permission denied (on Linux, join the 'dialout' group and log in again)"
    if code == errno.EBUSY:
        return "the port is in use by another program"
    if code == errno.ECONNREFUSED or f"[Errno {errno.ECONNREFUSED}]" in str(err):  # pyserial drops errno here
        return "connection refused (is the emulator running there?)"
    return _reason(err)


class Client:
    """Talks to one robot over an open pyserial port.

    Args:
        port: An open pyserial port (anything with ``read``, ``write``,
            ``reset_input_buffer`` and ``close``).
        clock: The clock for time-outs and waits; by default the port's own clock
            (emulator ports carry one) or real time.
        timeout_s: How long one attempt waits for its reply.
        retries: How many more attempts a repeatable command gets.
        stop_tries: How many ``X`` frames :meth:`safe_stop` sends at most.
        name: How the link is named in error messages (the URL).
    """

    def __init__(
        self,
        port: Any,
        *,
        clock: Clock | None = None,
        timeout_s: float = DEFAULT_TIMEOUT_S,
        retries: int = DEFAULT_RETRIES,
        stop_tries: int = DEFAULT_STOP_TRIES,
        name: str = "",
    ) -> None:
        self.port = port
        self.clock: Clock = clock or getattr(port, "clock", None) or RealClock()
        self.timeout_s = timeout_s
        self.retries = retries
        self.stop_tries = stop_tries
        self.name = name or str(getattr(port, "port", "") or "robot")
        self.stats = LinkStats()
        self.listeners: list[ExchangeListener] = []
        self.firmware_version = ""
        self._lock = threading.RLock()
        self._closed = False
        self.guard = StatusGuard()
        self._heard = bytearray()
        self._guardian: Guardian | None = None
        self._waiting_ready = False  # while True, stale input is read into _heard, not discarded
        # An in-process emulator's port can answer a frame at once (a port class's own method, never a mock's).
        self._answer_now: Callable[[bytes], bytes | None] | None = (
            port.answer_now if callable(getattr(type(port), "answer_now", None)) else None
        )
        port.timeout = timeout_s

    # ------------------------------------------------------------------ lifecycle

    @classmethod
    def open(
        cls,
        url: str,
        *,
        baud: int = DEFAULT_BAUD,
        clock: Clock | None = None,
        timeout_s: float = DEFAULT_TIMEOUT_S,
        retries: int = DEFAULT_RETRIES,
        ready_timeout_s: float = DEFAULT_READY_TIMEOUT_S,
        guardian: bool = False,
    ) -> Client:
        """Opens ``url`` and waits until the robot answers.

        Boards that reset when the port opens stay silent for up to ~2 s, so this polls
        ``GF000`` until a valid reply comes or ``ready_timeout_s`` has passed.

        Args:
            url: A device path, ``socket://host:port``, ``rfc2217://host:port`` or ``emu://[?options]``.
            baud: 57600 or 115200.
            clock: For ``emu://`` ports, the clock the emulator runs on.
            timeout_s: How long one attempt waits for its reply.
            retries: How many more attempts a repeatable command gets.
            ready_timeout_s: How long to wait for the robot's first answer.
            guardian: Start a :class:`~autonomy.guardian.Guardian` that stops the robot if this process
                is killed outright (links of the operating system's only; an ``emu://`` robot ends with
                the process).

        Raises:
            PortError: the port cannot be opened.
            ReplyTimeout: the robot did not answer in time.
        """
        port = open_port(url, baud, clock)
        client = cls(port, clock=clock, timeout_s=timeout_s, retries=retries)  # named by the port: its URL
        try:
            link_fd = link_descriptor(port) if guardian else None
            if link_fd is not None:
                try:
                    client._guardian = Guardian(link_fd, Stop().encode(), url)
                except OSError as err:
                    raise PortError(f"cannot start the process that stops the robot if this one dies: {err}") from err
            client.wait_ready(ready_timeout_s)
        except BaseException:
            client._close_port()
            raise
        return client

    def wait_ready(self, ready_timeout_s: float = DEFAULT_READY_TIMEOUT_S) -> str:
        """Polls ``GF000`` until the robot answers; returns its firmware version.

        Raises:
            ReplyTimeout: no valid answer within ``ready_timeout_s``; the message tells
                a silent port (robot off, wrong port) from one that sends bytes that
                never form a reply (wrong baud rate).
            LinkLost: the port failed while waiting (with what it said, when it said something).
        """
        self._waiting_ready = True
        try:
            return self._wait_ready(ready_timeout_s)
        finally:
            self._waiting_ready = False

    def _wait_ready(self, ready_timeout_s: float) -> str:
        deadline = self.clock.now() + ready_timeout_s
        received_before = self.stats.bytes_received
        while True:
            tried_s = self.clock.now()
            try:
                reply = self.request(_GET["F"], retries=0)
            except LinkLost as err:
                said = self.heard_text()
                if said:
                    raise LinkLost(f"{err} (it said: {said})") from err
                raise
            except (ReplyTimeout, FramingError, CommandRefused):
                if self.clock.now() < deadline:
                    if self.clock.now() - tried_s < READY_RETRY_S:  # answered at once, wrongly: not asked in a spin
                        self.clock.sleep(READY_RETRY_S)
                    continue
                received = self.stats.bytes_received - received_before
                baud = getattr(self.port, "baudrate", DEFAULT_BAUD)
                heard = bytes(self._heard[-16:])
                # what an emulated link knows of its own silence (a port class's own method, never a mock's)
                known = self.port.silence_hint() if callable(getattr(type(self.port), "silence_hint", None)) else ""
                if received and heard.endswith(b"\n") and all(32 <= byte < 127 or byte == 10 for byte in heard):
                    last = heard.decode("ascii").strip().splitlines()[-1]  # printable ASCII, checked above
                    came = (
                        f"{received} bytes came back, lines of text but none the reply asked for (the last: {last!r})"
                    )
                    guess = "does this robot speak this protocol?"
                elif received:
                    other = " or ".join(str(b) for b in SUPPORTED_BAUD_RATES if b != baud)
                    came = f"{received} bytes came back but none formed a reply"
                    guess = f"is the robot set to {other} baud?"
                else:
                    came = "nothing came back"
                    guess = "is the robot on, and is this its port?"
                hint = f"{came}: {known or guess}"
                raise ReplyTimeout(
                    f"no answer from {self.name} at {baud} baud within {ready_timeout_s:g} s; {hint}",
                    received,
                ) from None
            self.firmware_version = str(_expect(reply, Parameter).value)
            return self.firmware_version

    def safe_stop(self) -> bool:
        """Sends ``X`` until it is acknowledged or ``stop_tries`` ran out. Never raises.

        Returns:
            True when the robot acknowledged the stop.
        """
        for _ in range(self.stop_tries):
            try:
                self.request(Stop(), retries=0)
                return True
            except LinkLost:
                return False
            except AutonomyError:
                continue
        return False

    def close(self) -> bool:
        """Stops the robot (see :meth:`safe_stop`) and closes the port.

        Returns:
            True when the stop was acknowledged.
        """
        with self._lock:
            if self._closed:
                return True
            stopped = self.safe_stop()
            self._close_port()
            return stopped

    def _close_port(self) -> None:
        self._closed = True
        if self._guardian is not None:
            self._guardian.release()  # before the port closes: the guardian holds the same link
        try:
            self.port.close()
        except PORT_ERRORS:
            pass

    @property
    def closed(self) -> bool:
        """True once :meth:`close` ran."""
        return self._closed

    def __enter__(self) -> Client:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # ------------------------------------------------------------------ requests

    def request(self, command: Command, *, retries: int | None = None) -> Reply:
        """Sends ``command`` and returns its reply.

        Args:
            command: The command to send.
            retries: Overrides the client's retry count for this request (repeatable
                commands only; ``T`` and ``D`` are never repeated).

        Returns:
            The decoded reply. A ``NO`` to anything but ``GR`` raises instead.

        Raises:
            CommandRefused: the robot answered ``NO`` (to every attempt).
            ReplyTimeout: no valid reply (to every attempt).
            LinkLost: the port failed.
            LinkError: the client is closed.
        """
        with self._lock:
            if self._closed:
                raise LinkError(f"the link to {self.name} is closed")
            frame = command.encode()
            tries = 1 + ((self.retries if retries is None else retries) if command.retryable else 0)
            self.stats.requests += 1
            failure: AutonomyError  # set by every attempt that does not return (there is at least one)
            attempt = garbled = 0
            while tries > 0:
                if attempt:
                    self.stats.retries += 1
                attempt += 1
                try:
                    reply = self._exchange(command, frame)
                except (ReplyTimeout, FramingError) as err:
                    failure = err
                    self._notify(frame, err, attempt - 1)
                    if isinstance(err, FramingError) and command.retryable and garbled < GARBLED_LIMIT:
                        garbled += 1
                    else:
                        tries -= 1
                    continue
                if isinstance(reply, Status):
                    verdict, why = self.guard.judge(reply, self.clock.now())
                    self.stats.rebased = self.guard.rebased
                    if verdict is Verdict.ACCEPT:
                        self.stats.implausible += bool(why)
                        self._notify(frame, reply, attempt - 1)
                        return reply
                    if verdict is Verdict.READ_AGAIN:  # believed once the next packet agrees: a request of its own
                        self._notify(frame, reply, attempt - 1)
                        self.stats.requests += 1
                        attempt = 0
                        continue
                    self.stats.implausible += 1
                    garbled += 1
                    self._notify(frame, ImplausibleStatus(f"implausible status: {why}", reply.raw), attempt - 1)
                    if garbled > GARBLED_LIMIT:
                        raise ReplyTimeout(
                            f"no plausible status from {self.name}: {garbled} packets in a row were garbled or did not "
                            f"agree with each other ({why})"
                        )
                    continue
                self._notify(frame, reply, attempt - 1)
                if isinstance(reply, Ack) and not reply.ok:
                    self.stats.refusals += 1
                    if isinstance(command, Get):  # always valid: a NO means the request arrived garbled
                        failure = FramingError(
                            f"the robot answered NO to {_text(frame)}, a request that is always valid"
                        )
                        if garbled < GARBLED_LIMIT:
                            garbled += 1
                        else:
                            tries -= 1
                        continue
                    failure = CommandRefused(f"the robot refused {_text(frame)} (answered NO)", frame)
                    tries -= 1
                    continue
                return reply
            if isinstance(failure, ReplyTimeout) and not command.retryable:
                return self._settle(command, frame, failure)
            if isinstance(failure, FramingError):
                raise ReplyTimeout(f"no valid reply to {_text(frame)} from {self.name}: {failure}") from failure
            raise failure

    def _settle(self, command: Command, frame: bytes, failure: ReplyTimeout) -> Reply:
        """Settles a lost reply to ``T`` or ``D`` by reading the status, never by sending it again.

        Returns:
            An ``OK`` when the status shows the turn under way.

        Raises:
            CommandUnconfirmed: the link answers, but the command was not seen carried out
                (a servo step cannot be seen in the status at all).
            LinkError: the status cannot be read either: the link is really gone.
        """
        before = self.guard.trusted
        try:
            if isinstance(command, Turn):
                for poll in range(SETTLE_POLLS):
                    status = self.status()
                    turned = before is not None and status.heading_deg != before.heading_deg
                    if turned or (status.moving and (before is None or not before.moving)):
                        self.stats.settled += 1
                        return Ack(True)
                    if poll + 1 < SETTLE_POLLS:
                        self.clock.sleep(SETTLE_WAIT_S)
                seen = "the robot is not turning"
            else:
                self.status()
                seen = "a servo step does not show in the status, so it may or may not have moved"
        except LinkLost:
            raise
        except LinkError as err:
            raise ReplyTimeout(f"{failure}, and the status cannot be read either ({err})") from err
        raise CommandUnconfirmed(f"{failure}; the link answers, but {seen}", frame) from failure

    def _drain_heard(self) -> None:
        """Reads what came unasked (a server's notice, a board's boot banner) into :meth:`heard_text`."""
        try:
            for _ in range(256):  # byte by byte: a notice still arriving is read whole
                if not getattr(self.port, "in_waiting", 0):
                    return
                data = self.port.read(1)
                if not data:
                    return
                self._heard += data
        except PORT_ERRORS:
            return  # the request that follows fails, and says so
        finally:
            del self._heard[:-HEARD_BYTES]

    def heard_text(self) -> str:
        """The last bytes received, when they read as a line of text (a server saying why it closed)."""
        text = bytes(self._heard).decode("ascii", "replace").strip()
        line = text.splitlines()[-1] if text else ""
        return line if len(line) >= 8 and line.isprintable() and "\ufffd" not in line else ""

    def _notify(self, frame: bytes, outcome: Reply | AutonomyError, attempt: int) -> None:
        for listener in self.listeners:
            listener(frame, outcome, attempt)

    def _exchange(self, command: Command, frame: bytes) -> Reply:
        """One attempt: discard stale input, send, read until a reply or the time-out.

        An in-process emulator answers a frame at once when the wire would change nothing
        (``answer_now``); the reply is then read from what it returned, the same way.
        """
        self.stats.attempts += 1
        data = None if self._answer_now is None or self._waiting_ready else self._io(self._answer_now, frame)
        if data is None:
            if self._waiting_ready:
                self._drain_heard()
            else:
                self._io(self.port.reset_input_buffer)
            self._io(self.port.write, frame)
        self.stats.bytes_sent += len(frame)
        if command is _STATUS_GET and data and len(data) == STATUS_LENGTH:
            # A whole status packet answered at once (every poll in grading): decode_status checks its frame
            self._received(data)
            try:
                return decode_status(data)
            except FramingError:
                self.stats.framing_errors += 1
                raise
        decoder = ReplyDecoder.for_command(command)
        deadline = self.clock.now() + self.timeout_s
        received = 0
        while True:
            if data:
                received += len(data)
                self._received(data)
                decoder.feed(data)
            try:
                reply = decoder.next_reply()
            except FramingError:
                self.stats.framing_errors += 1
                if command.retryable:
                    raise
                data = None
                continue  # T and D cannot be asked again: keep looking for their reply
            if reply is not None:
                return reply
            data = self._io(self.port.read, decoder.bytes_needed()) if self.clock.now() < deadline else b""
            if not data:
                self.stats.timeouts += 1
                raise ReplyTimeout(
                    f"no reply to {_text(frame)} from {self.name} within {self.timeout_s:g} s",
                    received,
                )

    def _received(self, data: bytes) -> None:
        """Counts bytes of a reply, and keeps the last of them for :meth:`heard_text`."""
        self.stats.bytes_received += len(data)
        self._heard += data
        del self._heard[:-HEARD_BYTES]

    def _io(self, operation: Callable[..., Any], *args: Any) -> Any:
        try:
            return operation(*args)
        except PORT_ERRORS as err:
            raise LinkLost(f"lost the link to {self.name}: {_reason(err)}") from err

    # ------------------------------------------------------------------ commands

    def beep(self, tones: tuple[int, int, int] = (5, 7, 9), volume: int = 3) -> None:
        """Beeps three tones (1 lowest .. 9 highest) at ``volume`` 0..5."""
        self.request(Beep(tones, volume))

    def stop(self) -> None:
        """Cancels every movement (``X``)."""
        self.request(Stop())

    def move(self, speed: int, *, backward: bool = False) -> None:
        """Starts moving at speed setting 1..4 until told otherwise (``F``)."""
        self.request(Move(speed, backward))

    def servo_to(self, servo_id: int, angle_deg: int) -> None:
        """Moves servo 0..2 to an absolute angle, -99..+99 degrees (``M``)."""
        self.request(ServoTo(servo_id, angle_deg))

    def servo_by(self, servo_id: int, delta_deg: int) -> None:
        """Moves servo 0..2 by -9..+9 degrees from where it is (``D``; never repeated)."""
        self.request(ServoBy(servo_id, delta_deg))

    def turn(self, angle_deg: int) -> None:
        """Turns in place: positive left, negative right, |angle| <= 999 (``T``; never repeated)."""
        self.request(Turn(angle_deg))

    def status(self) -> Status:
        """Returns the binary status packet (``Gb000``)."""
        return _expect(self.request(_STATUS_GET), Status)

    def _parameter(self, letter: str) -> int | str:
        return _expect(self.request(_GET[letter]), Parameter).value

    def front_distance_mm(self) -> int:
        """Returns the front distance sensor, 0..255 mm (``GD``)."""
        return int(self._parameter("D"))

    def battery(self) -> int:
        """Returns the battery level, 0..255 (``GB``)."""
        return int(self._parameter("B"))

    def firmware(self) -> str:
        """Returns the firmware version, three characters (``GF``)."""
        return str(self._parameter("F"))

    def velocity(self) -> int:
        """Returns the average wheel velocity, -99..+99; 20 = one wheel turn per second (``GV``)."""
        return int(self._parameter("V"))

    def tilt_deg(self) -> int:
        """Returns the tilt angle, -99..+99 degrees (``GA``)."""
        return int(self._parameter("A"))

    def healthy(self) -> bool:
        """Returns True when the platform reports itself healthy (``GR``); an unhealthy answer is asked twice."""
        # A robot answers NO to a request that reached it garbled, too: a NO is believed once it is said twice.
        return _expect(self.request(_GET["R"]), Health).ok or _expect(self.request(_GET["R"]), Health).ok


#: The requests for each parameter, made once (commands are immutable).
_GET = {letter: Get(letter) for letter in PARAMETERS}
_STATUS_GET = _GET["b"]


def _text(frame: bytes) -> str:
    """A frame as it reads, without its newline: ``T+090``."""
    return frame[:-1].decode("ascii")  # a frame we encoded: ASCII


_R = TypeVar("_R", Ack, Parameter, Health, Status)


def _expect(reply: Reply, kind: type[_R]) -> _R:
    """Returns ``reply`` when it is of ``kind``; a reply of another kind is a framing error."""
    if not isinstance(reply, kind):  # pragma: no mutate - each decoder gives its own kind or NO, which raised
        raise FramingError(f"expected a {kind.__name__.lower()} reply, got {reply!r}")  # pragma: no mutate
    return reply

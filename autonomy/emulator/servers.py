"""Serving the emulator to other processes: over TCP (``socket://``) or a pseudo-terminal.

Both run one loop that waits for bytes (or for the next reply byte to fall due), hands
them to the :class:`~autonomy.emulator.core.Emulator` and writes its replies back, in real
time. A serial line has one peer: the TCP server talks to one connection at a time. One that
arrives meanwhile is answered, at its first request, with a line of text saying so, and
closed (:data:`TURN_AWAY_S` at the latest); a peer that has closed its side is
let go first, so a client that reconnects at once is always served; a peer that sends nothing
for :data:`IDLE_PEER_S` is dropped, so a forgotten connection cannot hold the robot.
"""

from __future__ import annotations

import ipaddress
import os
import selectors
import socket
import termios
import threading
import tty
from collections.abc import Callable

from serial.rfc2217 import PortManager

from autonomy.emulator.core import Emulator

#: Longest the loop sleeps with nothing due, so the physics keeps up and stop() is seen.
IDLE_POLL_S = 0.02
#: A TCP peer that sends nothing for this long is dropped.
IDLE_PEER_S = 60.0
#: What a TCP client that comes while another is served reads before the server closes it.
#: How long such a client is kept waiting for its first request before it is closed anyway.
TURN_AWAY_S = 2.0
#: Most clients held waiting to be told the line is busy; past that, each is told at once and let go,
#: so that a flood of connections never holds more than a few file descriptors (select() takes < 1024).
MOST_TURNED_AWAY = 16
#: select() watches descriptors below this; a connection numbered past it (a process holding a thousand
#: files already) is turned away at once rather than end the loop with a ValueError.
SELECT_FD_LIMIT = 1024
BUSY_LINE = b"BUSY: another client is connected to this emulator; one at a time, as on a serial line\n"


class _Server:
    """The loop both servers share; subclasses say how bytes come and go."""

    def __init__(self, emulator: Emulator) -> None:
        self.emulator = emulator
        # select() keeps microsecond time-outs (epoll rounds up to whole ms, too coarse for byte pacing).
        self._selector = selectors.SelectSelector()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        """What a client passes to ``serial_for_url`` to reach this server."""
        raise NotImplementedError

    def _send(self, data: bytes) -> None:
        raise NotImplementedError

    def _timeout_s(self) -> float:
        due = self.emulator.next_event_s()
        if due is None:
            return IDLE_POLL_S
        return max(0.0, min(IDLE_POLL_S, due - self.emulator.clock.now()))

    def serve_forever(self) -> None:
        """Runs the loop until :meth:`stop` is called."""
        while not self._stop.is_set():
            for key, _ in self._selector.select(self._timeout_s()):
                handler: Callable[[], None] = key.data
                handler()
            out = self.emulator.read_ready()
            if out:
                self._send(out)
            self._check_idle()
        self._close()

    def _check_idle(self) -> None:
        """Drops a peer that has been silent too long (TCP only)."""

    def start(self) -> _Server:
        """Runs the loop in a background thread; returns self."""
        self._thread = threading.Thread(target=self.serve_forever, name=type(self).__name__, daemon=True)
        self._thread.start()
        return self

    def stop_soon(self) -> None:
        """Asks the loop to end at its next turn (safe from a signal handler)."""
        self._stop.set()

    def stop(self) -> None:
        """Ends the loop, waits for its thread, and releases the socket or terminal."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None

    def _close(self) -> None:
        self._selector.close()

    def __enter__(self) -> _Server:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


class _Line:
    """The serial line's settings as an RFC 2217 client sets them (pyserial's ``PortManager`` reads and sets them)."""

    def __init__(self, baudrate: int) -> None:
        self.baudrate = baudrate
        self.bytesize, self.parity, self.stopbits = 8, "N", 1
        self.xonxoff = self.rtscts = self.break_condition = False
        self.dtr = self.rts = True
        self.cts = self.dsr = self.cd = True
        self.ri = False

    def reset_input_buffer(self) -> None:
        """Nothing is buffered on this side of the line."""

    def reset_output_buffer(self) -> None:
        """Nothing is buffered on this side of the line."""


class _Sender:
    """What ``PortManager`` writes its Telnet answers through: the peer's socket."""

    def __init__(self, conn: socket.socket) -> None:
        self.conn = conn

    def write(self, data: bytes) -> None:
        try:
            self.conn.sendall(data)
        except OSError:
            pass  # the peer is gone: the next read says so


class TcpServer(_Server):
    """Serves the emulator on a TCP port, for ``socket://HOST:PORT`` (or ``rfc2217://HOST:PORT``).

    ``socket://`` carries bytes only, so its client is taken to be at the robot's rate. With
    ``rfc2217``, the port speaks RFC 2217 (Telnet's serial-port option, as pyserial's
    ``rfc2217://`` does): the client says its rate, and one at another rate than the robot's
    gets noise both ways, as over a real line.

    Args:
        emulator: The emulator to serve.
        host: Address to bind; loopback unless told otherwise.
        port: TCP port; 0 picks a free one (see :attr:`address`).
        rfc2217: Speak RFC 2217, for ``rfc2217://``.
    """

    def __init__(
        self,
        emulator: Emulator,
        host: str = "127.0.0.1",
        port: int = 7777,
        idle_peer_s: float = IDLE_PEER_S,
        rfc2217: bool = False,
    ) -> None:
        super().__init__(emulator)
        self.rfc2217 = rfc2217
        self._line: _Line | None = None
        self._manager: PortManager | None = None
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self._listener = socket.create_server((host, port), family=family, reuse_port=False)
        self._listener.setblocking(False)
        self._selector.register(self._listener, selectors.EVENT_READ, self._accept)
        self._conn: socket.socket | None = None
        self.idle_peer_s = idle_peer_s
        self._heard_s = 0.0
        self._turned_away: dict[socket.socket, float] = {}

    @property
    def address(self) -> tuple[str, int]:
        """The bound (host, port)."""
        host, port = self._listener.getsockname()[:2]
        return host, port

    @property
    def url(self) -> str:
        """``socket://HOST:PORT`` (``rfc2217://HOST:PORT`` when it speaks RFC 2217)."""
        host, port = self.address
        scheme = "rfc2217" if self.rfc2217 else "socket"
        return f"{scheme}://[{host}]:{port}" if ":" in host else f"{scheme}://{host}:{port}"

    @property
    def public(self) -> bool:
        """True when other machines can reach it: bound to every address (0.0.0.0 or ::) or to a network's."""
        try:
            return not ipaddress.ip_address(self.address[0].split("%")[0]).is_loopback
        except ValueError:
            return True

    def _accept(self) -> None:
        try:
            conn, _ = self._listener.accept()
        except OSError:
            return
        if conn.fileno() >= SELECT_FD_LIMIT:
            self._turn_away(conn, registered=False)
            return
        while self._conn is not None and self._receive():
            pass  # read what the current peer sent: a peer that has closed is let go now
        if self._conn is not None:  # one peer at a time, like a serial line: say so at its first request
            conn.setblocking(False)
            if len(self._turned_away) >= MOST_TURNED_AWAY:  # a flood: told at once and let go, never held
                self._turn_away(conn, registered=False)
                return
            self._turned_away[conn] = self.emulator.clock.now()
            self._selector.register(conn, selectors.EVENT_READ, lambda: self._turn_away(conn))
            return
        conn.setblocking(False)
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._conn = conn
        self._heard_s = self.emulator.clock.now()
        if self.rfc2217:  # the line's settings start as the robot's; the client's own come over Telnet
            self._line = _Line(self.emulator.baud)
            self._manager = PortManager(self._line, _Sender(conn))
        self._selector.register(conn, selectors.EVENT_READ, self._receive)

    def _receive(self) -> bool:
        """Reads what the peer sent; returns True when more may be waiting."""
        if self._conn is None:
            return False
        try:
            data = self._conn.recv(4096)
        except (BlockingIOError, InterruptedError):
            return False
        except OSError:
            data = b""
        if not data:
            self._drop_connection()
            return False
        self._heard_s = self.emulator.clock.now()
        if self._manager is not None and self._line is not None:  # Telnet's commands taken out, the rate heard
            data = b"".join(self._manager.filter(data))
            if data:
                self.emulator.receive(data, baud=self._line.baudrate)
            return True
        self.emulator.receive(data)
        return True

    def _turn_away(self, conn: socket.socket, registered: bool = True) -> None:
        try:
            conn.sendall(BUSY_LINE)
        except OSError:
            pass
        if registered:
            self._selector.unregister(conn)
            del self._turned_away[conn]
        conn.close()

    def _check_idle(self) -> None:
        now_s = self.emulator.clock.now()
        if self._conn is not None and now_s - self._heard_s > self.idle_peer_s:
            self._drop_connection()
        for conn, since_s in list(self._turned_away.items()):
            if now_s - since_s > TURN_AWAY_S:  # it asked nothing: told all the same, and let go
                self._turn_away(conn)

    def _drop_connection(self) -> None:
        if self._conn is not None:
            self._selector.unregister(self._conn)
            self._conn.close()
            self._conn = None
            self._line = self._manager = None
            self.emulator.hang_up()

    def _send(self, data: bytes) -> None:
        if self._conn is None:
            return  # nobody listens: the bytes are lost, as on an unplugged cable
        if self._manager is not None:
            data = b"".join(self._manager.escape(data))
        try:
            self._conn.sendall(data)
        except OSError:
            self._drop_connection()

    def _close(self) -> None:
        self._drop_connection()
        for conn in list(self._turned_away):
            self._selector.unregister(conn)
            conn.close()
        self._turned_away.clear()
        self._selector.unregister(self._listener)
        self._listener.close()
        super()._close()


#: A terminal's speed constants by baud rate, and back (the rates a client may set).
_SPEEDS = {
    rate: getattr(termios, f"B{rate}")
    for rate in (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400)
    if hasattr(termios, f"B{rate}")
}
_BAUDS = {speed: rate for rate, speed in _SPEEDS.items()}


class PtyServer(_Server):
    """Serves the emulator on a pseudo-terminal; open :attr:`device` like a serial port.

    The terminal is raw (no echo, no newline translation), so every byte of a status
    packet arrives as sent. The server keeps its own handle on the device open, so a
    client may close and reopen it.
    """

    def __init__(self, emulator: Emulator) -> None:
        super().__init__(emulator)
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        tty.setraw(self._master)
        # The terminal starts at the robot's rate: a client that sets another (as pyserial does,
        # with --baud) talks at it, and gets noise both ways, as over a real line and emu://.
        attributes = termios.tcgetattr(self._slave)
        speed = _SPEEDS.get(emulator.baud)
        if speed is not None:
            attributes[4] = attributes[5] = speed
            termios.tcsetattr(self._slave, termios.TCSANOW, attributes)
        os.set_blocking(self._master, False)
        self.device = os.ttyname(self._slave)
        self._selector.register(self._master, selectors.EVENT_READ, self._receive)

    def _client_baud(self) -> int | None:
        """The rate the client set the terminal to (None: one the robot has no name for, or unknown)."""
        try:
            speed = termios.tcgetattr(self._slave)[5]
        except termios.error:
            return None
        return _BAUDS.get(speed)

    @property
    def url(self) -> str:
        """The device path, e.g. ``/dev/pts/5``."""
        return self.device

    def _receive(self) -> None:
        try:
            data = os.read(self._master, 4096)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            return
        if data:
            self.emulator.receive(data, baud=self._client_baud())

    def _send(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            try:
                written = os.write(self._master, view)
            except OSError:
                return  # buffer full or reader gone: the bytes are lost, as in a UART overrun
            view = view[written:]

    def _close(self) -> None:
        self._selector.unregister(self._master)
        os.close(self._master)
        os.close(self._slave)
        super()._close()

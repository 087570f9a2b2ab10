"""Serving the emulator to other processes: over TCP (``socket://``) or a pseudo-terminal.

Both run one loop that waits for bytes (or for the next reply byte to fall due), hands
them to the :class:`~autonomy.emulator.core.Emulator` and writes its replies back, in real
time. A serial line has one peer: the TCP server talks to one connection at a time and
closes any other that arrives meanwhile.
"""

from __future__ import annotations

import os
import selectors
import socket
import threading
import tty
from collections.abc import Callable

from autonomy.emulator.core import Emulator

#: Longest the loop sleeps with nothing due, so the physics keeps up and stop() is seen.
IDLE_POLL_S = 0.02


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
        self._close()

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


class TcpServer(_Server):
    """Serves the emulator on a TCP port, for ``socket://HOST:PORT``.

    Args:
        emulator: The emulator to serve.
        host: Address to bind; loopback unless told otherwise.
        port: TCP port; 0 picks a free one (see :attr:`address`).
    """

    def __init__(self, emulator: Emulator, host: str = "127.0.0.1", port: int = 7777) -> None:
        super().__init__(emulator)
        self._listener = socket.create_server((host, port), reuse_port=False)
        self._listener.setblocking(False)
        self._selector.register(self._listener, selectors.EVENT_READ, self._accept)
        self._conn: socket.socket | None = None

    @property
    def address(self) -> tuple[str, int]:
        """The bound (host, port)."""
        host, port = self._listener.getsockname()[:2]
        return host, port

    @property
    def url(self) -> str:
        """``socket://HOST:PORT``."""
        host, port = self.address
        return f"socket://{host}:{port}"

    def _accept(self) -> None:
        conn, _ = self._listener.accept()
        if self._conn is not None:
            conn.close()  # one peer at a time, like a serial line
            return
        conn.setblocking(False)
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._conn = conn
        self._selector.register(conn, selectors.EVENT_READ, self._receive)

    def _receive(self) -> None:
        if self._conn is None:
            return
        try:
            data = self._conn.recv(4096)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            data = b""
        if not data:
            self._drop_connection()
            return
        self.emulator.receive(data)

    def _drop_connection(self) -> None:
        if self._conn is not None:
            self._selector.unregister(self._conn)
            self._conn.close()
            self._conn = None

    def _send(self, data: bytes) -> None:
        if self._conn is None:
            return  # nobody listens: the bytes are lost, as on an unplugged cable
        try:
            self._conn.sendall(data)
        except OSError:
            self._drop_connection()

    def _close(self) -> None:
        self._drop_connection()
        self._selector.unregister(self._listener)
        self._listener.close()
        super()._close()


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
        os.set_blocking(self._master, False)
        self.device = os.ttyname(self._slave)
        self._selector.register(self._master, selectors.EVENT_READ, self._receive)

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
            self.emulator.receive(data)

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

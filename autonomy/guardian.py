"""A process that stops the robot when the engine's process is gone.

The protocol has no watchdog: a robot told to move keeps moving until it is told to stop. The
engine stops it on every way out it can see (success, failure, Ctrl-C, an exception, a lost
link), but a process killed outright (``kill -9``, the out-of-memory killer, a segfault) sees
nothing. So a run that drives a robot over a link of the operating system's (a serial port, a
pseudo-terminal, TCP) starts a :class:`Guardian`: a small process of its own that holds the
same link and a pipe from the engine. It waits on the pipe, costing nothing. When the engine
closes the link it says so on the pipe and the guardian leaves quietly; when the engine's
process is gone, by any means, the kernel closes the pipe, and the guardian sends ``\\n``
(which ends any frame the engine left half sent) then ``X0000\\n``, until the robot answers
``OK`` or three tries have gone.

It cannot help when the link itself is gone (a pulled cable, a host that lost power): only a
watchdog on the robot could.

The guardian's side runs as this file, by path, in an interpreter started with ``-I -S``: it
needs nothing but the standard library and :mod:`autonomy.clock`, and starts in a few
milliseconds.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

#: How many times it sends them, and how long it waits for ``OK`` after each.
STOP_TRIES = 3
STOP_ANSWER_S = 0.3
#: What the engine writes on the pipe when it lets go of the link itself.
RELEASE = b"R"
#: How long the engine waits for a released guardian to leave.
RELEASE_WAIT_S = 2.0


def link_descriptor(port: Any) -> int | None:
    """The operating system's descriptor behind an open pyserial port, or None (an in-process emulator).

    A serial port or pseudo-terminal is its ``fileno()``; ``socket://`` and ``rfc2217://`` are the socket's.
    """
    sock = getattr(port, "_socket", None)
    if sock is not None and callable(getattr(sock, "fileno", None)):
        return sock.fileno()
    fileno = getattr(type(port), "fileno", None)
    if callable(fileno) and getattr(port, "fd", None) is not None:
        try:
            return int(port.fileno())
        except (OSError, ValueError, TypeError):
            return None
    return None


class Guardian:
    """The engine's side: starts the guardian process on ``link_fd``, and lets it go.

    Args:
        link_fd: The link's descriptor (see :func:`link_descriptor`).
        stop_frame: The stop command's frame (``X0000\\n``); a newline goes before it.
        name: How the link is named in the guardian's one line (its URL).

    Raises:
        OSError: the process could not be started.
    """

    def __init__(self, link_fd: int, stop_frame: bytes, name: str = "") -> None:
        read_fd, self._write_fd = os.pipe()  # neither end is inherited by anything else the engine starts
        try:
            self.process = subprocess.Popen(
                [sys.executable, "-I", "-S", str(Path(__file__).resolve())]
                + [str(link_fd), str(read_fd), stop_frame.hex(), name],
                pass_fds=(link_fd, read_fd),
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                start_new_session=True,  # a Ctrl-C or a hang-up of the terminal is the engine's to handle
            )
        except BaseException:
            os.close(self._write_fd)
            raise
        finally:
            os.close(read_fd)
        self.released = False

    def release(self) -> None:
        """Tells the guardian the engine closes the link itself, and waits for it to leave. Never raises."""
        if self.released:
            return
        self.released = True
        try:
            os.write(self._write_fd, RELEASE)
        except OSError:
            pass
        finally:
            os.close(self._write_fd)
        try:
            self.process.wait(timeout=RELEASE_WAIT_S)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()


def _stop(link_fd: int, stop_bytes: bytes, wait_readable: Any) -> bool:
    """Sends ``stop_bytes`` until ``OK`` comes back; True when it did."""
    while wait_readable(link_fd, 0.0):  # what the engine left unread is not an answer to the stop
        try:
            if not os.read(link_fd, 4096):
                return False
        except BlockingIOError:
            break
        except OSError:
            return False
    for _ in range(STOP_TRIES):
        try:
            os.write(link_fd, stop_bytes)
        except BlockingIOError:
            continue
        except OSError:
            return False
        heard = b""
        while wait_readable(link_fd, STOP_ANSWER_S):
            try:
                chunk = os.read(link_fd, 64)
            except BlockingIOError:
                continue
            except OSError:
                return False
            if not chunk:
                return False
            heard += chunk
            if b"OK\n" in heard:
                return True
    return False


def _watch(link_fd: int, pipe_fd: int, stop_bytes: bytes, name: str) -> int:
    """The guardian process: waits for the engine, and stops the robot if the engine went without a word."""
    for sig in (signal.SIGINT, signal.SIGHUP, signal.SIGTERM, signal.SIGQUIT):
        signal.signal(sig, signal.SIG_IGN)  # only the engine's end lets it go
    import importlib.util

    spec = importlib.util.spec_from_file_location("autonomy_clock", Path(__file__).with_name("clock.py"))
    clock = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
    spec.loader.exec_module(clock)  # type: ignore[union-attr]
    try:
        word = os.read(pipe_fd, 1)
    except OSError:
        word = b""
    if word == RELEASE:
        return 0
    stopped = _stop(link_fd, stop_bytes, clock.wait_readable)
    said = "the robot was stopped" if stopped else "the stop was sent but NOT confirmed"
    try:
        sys.stderr.write(f"autonomy: the engine's process is gone; {said} ({name or 'the link'})\n")
        sys.stderr.flush()
    except (OSError, ValueError):
        pass
    return 0 if stopped else 1


if __name__ == "__main__":
    sys.exit(_watch(int(sys.argv[1]), int(sys.argv[2]), b"\n" + bytes.fromhex(sys.argv[3]), sys.argv[4]))

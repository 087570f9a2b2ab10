"""The one place that reads or waits on time.

Everything else asks a :class:`Clock`, so the same code runs in real time (a robot on a
cable, a demo someone watches) or in virtual time (tests, ``--fast`` runs), where waiting
costs nothing and runs are exactly repeatable.
"""

from __future__ import annotations

import datetime
import select
import signal
import threading
import time
from typing import Protocol


class Clock(Protocol):
    """What the rest of the package needs to know about time."""

    def now(self) -> float:
        """Returns seconds since an arbitrary, fixed origin; never goes backward."""
        ...

    def sleep(self, seconds: float) -> None:
        """Waits ``seconds`` (returns at once when ``seconds <= 0``)."""
        ...

    @property
    def is_virtual(self) -> bool:
        """True when waiting costs no real time."""
        ...


class RealClock:
    """Wall-clock time: ``time.monotonic`` and ``time.sleep``."""

    is_virtual = False

    #: Returns the monotonic clock in seconds: ``time.monotonic`` itself, with no call of ours
    #: in between (a trace writer reads it every tick).
    now = staticmethod(time.monotonic)

    def sleep(self, seconds: float) -> None:
        """Sleeps for real."""
        if seconds > 0:
            time.sleep(seconds)


def cpu_alarm(cpu_s: float | None, again_s: float = 0.0) -> None:
    """Has SIGPROF sent to this process once it has used ``cpu_s`` more of CPU time, then every ``again_s``.

    CPU time (user and system), unlike wall time, does not grow while the process waits for a
    core, so a limit on it ends the same work on a busy machine as on a quiet one. ``None``
    disarms it. Unix only (``signal.setitimer``), as are the grader's workers that use it.
    """
    signal.setitimer(signal.ITIMER_PROF, cpu_s or 0.0, again_s if cpu_s else 0.0)


class VirtualClock:
    """Simulated time that only moves when somebody waits on it.

    ``sleep`` advances the clock at once, so a ten-minute mission takes as long as its
    computation. Thread-safe: several threads may sleep, each moves time forward.

    Args:
        start_s: The clock's first reading.
    """

    is_virtual = True

    def __init__(self, start_s: float = 0.0) -> None:
        self._now_s = start_s
        self._lock = threading.Lock()

    def now(self) -> float:
        """Returns the simulated time in seconds."""
        return self._now_s

    def sleep(self, seconds: float) -> None:
        """Advances simulated time by ``seconds`` without waiting."""
        if seconds > 0:
            with self._lock:
                self._now_s += seconds

    def advance_to(self, when_s: float) -> None:
        """Moves simulated time forward to ``when_s`` (never backward)."""
        with self._lock:
            if when_s > self._now_s:
                self._now_s = when_s


async def pause(clock: Clock, seconds: float) -> None:
    """Waits ``seconds`` on ``clock`` without holding an event loop: for real, or advancing simulated time."""
    import asyncio

    if clock.is_virtual:
        clock.sleep(seconds)
        await asyncio.sleep(0)
    elif seconds > 0:
        await asyncio.sleep(seconds)


def wait_readable(fd: int, timeout_s: float) -> bool:
    """Waits, in real time, at most ``timeout_s`` for ``fd`` to have bytes (or an end) to read.

    Returns:
        True when ``fd`` can be read without waiting.
    """
    poller = select.poll()  # poll(), not select(): any descriptor number
    poller.register(fd, select.POLLIN)
    return bool(poller.poll(max(0.0, timeout_s) * 1000.0))


def wait_event(event: threading.Event, timeout_s: float) -> bool:
    """Waits, in real time, at most ``timeout_s`` for ``event`` to be set (by another thread).

    Returns:
        Whether it is set.
    """
    return event.wait(max(0.0, timeout_s))


def make_clock(virtual: bool) -> Clock:
    """Returns a new virtual clock when ``virtual`` is true, else a real one."""
    return VirtualClock() if virtual else RealClock()


def cpu_time_s() -> float:
    """This process's CPU time so far (user and system), seconds: what a grading's cost is counted in.

    Unlike wall time it does not grow while the process waits for a core, so it is the same for
    the same work on a busy machine as on a quiet one.
    """
    return time.process_time()


def thread_cpu_time_s() -> float:
    """The calling thread's CPU time so far, seconds: what one piece of work done in a thread costs."""
    return time.thread_time()


def wall_time_s() -> float:
    """Seconds since the epoch, by the wall clock (deadlines a person sets)."""
    return time.time()


def wall_date() -> str:
    """Today's date and time of day, ISO 8601 with the local offset (for trace headers)."""
    return datetime.datetime.now().astimezone().isoformat(timespec="seconds")

"""The ``emu://`` URL scheme: a pyserial port with an emulated robot on the other end.

``serial.serial_for_url("emu://?world=corridor&seed=3&time=virtual")`` returns a port that
behaves like a serial line to a robot: ``write`` sends bytes to the emulator, ``read``
waits (on the emulator's clock) for its replies. Query options are listed in
:data:`autonomy.emulator.core.OPTIONS`. The emulator is reachable as ``port.emulator``,
and its clock as ``port.clock``; set ``port.clock`` before ``open()`` to run on a clock
of your own.
"""

from __future__ import annotations

from typing import Any
from urllib.parse import parse_qsl, urlsplit

import serial
from serial.serialutil import PortNotOpenError, SerialBase, SerialException

from autonomy.clock import Clock
from autonomy.emulator.core import Emulator, emulator_from_options
from autonomy.errors import AutonomyError


def parse_emu_url(url: str) -> dict[str, str]:
    """Returns the options of an ``emu://`` URL.

    Raises:
        SerialException: not an emu:// URL, or an option given twice.
    """
    parts = urlsplit(url)
    if parts.scheme.lower() != "emu":
        raise SerialException(f"expected an emu:// URL, got {url!r}")
    if parts.netloc or parts.path.strip("/"):
        raise SerialException(f"an emu:// URL takes only ?options, as in emu://?world=box; got {url!r}")
    options: dict[str, str] = {}
    # %XX that are not UTF-8 (a path's bytes) come back as the same surrogates os.fsdecode makes of them
    for key, value in parse_qsl(parts.query, keep_blank_values=True, errors="surrogateescape"):
        if key in options:
            raise SerialException(f"emu:// option '{key}' given twice")
        options[key] = value
    return options


class Serial(SerialBase):
    """A serial port whose far end is an in-process :class:`Emulator`."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self.clock: Clock | None = None
        self.emulator: Emulator | None = None
        super().__init__(*args, **kwargs)

    def open(self) -> None:
        """Builds the emulator from the URL's options (or uses one set beforehand)."""
        if self.is_open:
            raise SerialException("port already open")
        if self._port is None:
            raise SerialException("port must be configured before it can be used")
        if self.emulator is None:
            try:
                self.emulator = emulator_from_options(parse_emu_url(self._port), self.clock)
            except (ValueError, AutonomyError) as err:
                raise SerialException(str(err)) from err
        self.clock = self.emulator.clock
        self.is_open = True

    def close(self) -> None:
        """Closes the port; the emulator stays as it is, for inspection."""
        self.is_open = False

    def _reconfigure_port(self, *args: Any, **kwargs: Any) -> None:
        """Nothing to configure: the baud rate is read at each write."""

    def from_url(self, url: str) -> dict[str, str]:
        """Checks the URL; the options are applied when the port opens."""
        return parse_emu_url(url)

    @property
    def in_waiting(self) -> int:
        """Reply bytes that have arrived and are not yet read."""
        self._check_open()
        return self._emu.ready_count()

    def read(self, size: int = 1) -> bytes:
        """Reads up to ``size`` bytes, waiting on the emulator's clock up to ``timeout``."""
        self._check_open()
        emu, clock = self._emu, self._emu.clock
        deadline = None if self._timeout is None else clock.now() + self._timeout
        data = bytearray(emu.read_ready(size))
        while len(data) < size:
            now = clock.now()
            wake = emu.next_event_s()
            if deadline is not None:
                if now >= deadline:
                    break
                wake = deadline if wake is None else min(wake, deadline)
            elif wake is None:
                break  # nothing is under way: waiting forever would never end
            clock.sleep(wake - now)
            data += emu.read_ready(size - len(data))
        return bytes(data)

    def write(self, data: bytes) -> int:
        """Sends ``data`` to the emulator at the port's baud rate."""
        self._check_open()
        data = bytes(data)
        self._emu.receive(data, self._baudrate)
        return len(data)

    def answer_now(self, frame: bytes) -> bytes | None:
        """Sends one whole frame and returns its reply at once, when the wire would change nothing.

        Only the in-process emulator can do this (see :meth:`Emulator.answer_now`); None means
        the frame was not sent: write it and read the reply as usual.
        """
        self._check_open()
        return self._emu.answer_now(frame, self._baudrate)

    def silence_hint(self) -> str:
        """Why no reply got through, when the emulator knows a reason a real robot's guesses would miss; else "".

        That is the faults it injects that lose, delay, damage or refuse traffic (``drop=0.3``),
        while the port sends at the emulator's own baud rate and the robot has booted: a wrong
        rate or a robot still starting are what a client's own guesses already say. A client
        says it when the robot does not answer.
        """
        emulator = self.emulator
        if emulator is None or self._baudrate != emulator.baud or emulator.now_s() < emulator.boot_s:
            return ""
        if not emulator.faults.disturbing:
            return ""
        return f"the emulator injects link faults ({emulator.faults}), and they kept the replies from getting through"

    def reset_input_buffer(self) -> None:
        """Discards reply bytes that have arrived."""
        self._check_open()
        self._emu.discard_ready()

    def reset_output_buffer(self) -> None:
        """Nothing is buffered on the way out."""
        self._check_open()

    def _check_open(self) -> None:
        if not self.is_open:
            raise PortNotOpenError()

    @property
    def _emu(self) -> Emulator:
        if self.emulator is None:
            raise PortNotOpenError()
        return self.emulator


__all__ = ["Serial", "parse_emu_url", "serial"]

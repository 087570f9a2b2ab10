"""A scripted stand-in for a pyserial port, on a virtual clock."""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

import serial

from autonomy.clock import VirtualClock

Responder = Callable[[bytes], bytes]


class ScriptedPort:
    """Answers each written frame with the next scripted reply (or a responder's answer).

    A reply of ``None`` means silence: the read waits the whole time-out on the virtual
    clock and returns what it has. ``pending`` preloads stale bytes.
    """

    def __init__(self, replies: list[bytes | None] | None = None, responder: Responder | None = None) -> None:
        self.clock = VirtualClock()
        self.timeout = 0.25
        self.writes: list[bytes] = []
        self.replies = deque(replies or [])
        self.responder = responder
        self.buffer = bytearray()
        self.fail_with: Exception | None = None
        self.closed = False
        self.busy = False  # set while a write awaits its read, to catch interleaved requests

    def write(self, data: bytes) -> int:
        self._maybe_fail()
        self.writes.append(bytes(data))
        if self.responder is not None:
            reply = self.responder(bytes(data))
        else:
            reply = self.replies.popleft() if self.replies else None
        if reply:
            self.buffer += reply
        return len(data)

    def read(self, size: int = 1) -> bytes:
        self._maybe_fail()
        if len(self.buffer) < size:
            self.clock.sleep(self.timeout)
        out = bytes(self.buffer[:size])
        del self.buffer[:size]
        return out

    def reset_input_buffer(self) -> None:
        self._maybe_fail()
        self.buffer.clear()

    def close(self) -> None:
        self.closed = True

    def _maybe_fail(self) -> None:
        if self.fail_with is not None:
            raise self.fail_with


def frames_of(port: ScriptedPort) -> list[bytes]:
    return [w[:-1] for w in port.writes]


__all__ = ["ScriptedPort", "frames_of", "serial"]

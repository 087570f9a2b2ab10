"""A short scripted drive: a square with a beep at each corner, reporting as it goes."""

from __future__ import annotations

from collections.abc import Callable

from autonomy.client import Client
from autonomy.protocol import Status

#: How often the drive looks at the robot while waiting.
POLL_S = 0.1


def square_drive(
    client: Client,
    report: Callable[[str, Status], None],
    *,
    side_s: float = 1.5,
    speed: int = 2,
) -> Status:
    """Drives a square: ``side_s`` forward at ``speed``, then left 90 degrees, four times.

    Args:
        client: An open client.
        report: Called with a short description of the current step and the latest status.
        side_s: How long each side takes.
        speed: Speed setting 1..4.

    Returns:
        The last status read.
    """
    clock = client.clock
    status = client.status()
    for corner in range(1, 5):
        client.move(speed)
        end = clock.now() + side_s
        while clock.now() < end:
            clock.sleep(POLL_S)
            status = client.status()
            report(f"side {corner}: forward", status)
            if status.collided:
                client.stop()
                report(f"side {corner}: bumped into something, stopping", status)
                return status
        client.stop()
        client.turn(90)
        client.beep((5, 7, 9), 2)
        while True:
            clock.sleep(POLL_S)
            status = client.status()
            report(f"corner {corner}: turning left", status)
            if not status.moving:
                break
    return status

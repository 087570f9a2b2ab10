"""autonomy: missions as behaviour trees on a small self-balancing robot, over its serial line.

The public API of the robot link::

    from autonomy import Client
    with Client.open("emu://?world=box&time=virtual") as robot:
        robot.move(2)
        print(robot.status().front_distance_mm)
"""

from autonomy.client import Client, LinkStats, open_port
from autonomy.clock import Clock, RealClock, VirtualClock
from autonomy.errors import (
    AutonomyError,
    CommandRefused,
    FramingError,
    InvalidCommand,
    LinkError,
    LinkLost,
    PortError,
    ProtocolError,
    ReplyTimeout,
)
from autonomy.protocol import Beep, Get, Move, ServoBy, ServoTo, Status, Stop, Turn

__version__ = "0.1.0"

__all__ = [
    "AutonomyError",
    "Beep",
    "Client",
    "Clock",
    "CommandRefused",
    "FramingError",
    "Get",
    "InvalidCommand",
    "LinkError",
    "LinkLost",
    "LinkStats",
    "Move",
    "PortError",
    "ProtocolError",
    "RealClock",
    "ReplyTimeout",
    "ServoBy",
    "ServoTo",
    "Status",
    "Stop",
    "Turn",
    "VirtualClock",
    "open_port",
]

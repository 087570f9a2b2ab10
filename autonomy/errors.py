"""The project's exceptions: one root, a typed child for each way things go wrong.

Every error the library raises on purpose derives from :class:`AutonomyError`, so a
caller that wants to handle "anything autonomy complained about" catches that one
class. Errors from the libraries below (pyserial, sockets) are wrapped where they
enter, with the original kept as ``__cause__``::

    AutonomyError
     ├── ProtocolError            bytes or values that break the protocol
     │    ├── FramingError        a reply that is not a valid frame
     │    │    └── ImplausibleStatus  a status packet the robot cannot have sent (corrupted)
     │    └── InvalidCommand      a command argument out of its range (also a ValueError)
     ├── CommandRefused           the robot answered ``NO``
     │    └── CommandUnconfirmed  a move or servo step whose reply was lost, not carried out
     └── LinkError                the link to the robot itself
          ├── PortError           the port could not be opened (no such device, bad URL)
          ├── ReplyTimeout        no valid reply in time
          └── LinkLost            the port went away while in use
"""

from __future__ import annotations


class AutonomyError(Exception):
    """Root of every error raised by the autonomy package."""


class Interrupted(KeyboardInterrupt):
    """Ctrl-C or SIGTERM, as the command line's signal handler raises it.

    A plain ``KeyboardInterrupt`` raised while such a handler is installed cannot be a Ctrl-C:
    the runner takes it as an error of the behaviour that raised it.
    """


class ProtocolError(AutonomyError):
    """Bytes or values that do not follow the robot's serial protocol."""


class FramingError(ProtocolError):
    """A reply that is not a valid frame for the request it answers.

    Attributes:
        data: The bytes that were rejected.
    """

    def __init__(self, message: str, data: bytes = b"") -> None:
        super().__init__(message)
        self.data = data


class ImplausibleStatus(FramingError):
    """A well-formed status packet the robot cannot have sent: a corrupted byte.

    The protocol has no checksum; a packet whose odometer, heading or tilt differs from
    the last trusted one by more than the robot can have moved since is taken as corrupt.
    """


class InvalidCommand(ProtocolError, ValueError):
    """A command built with an argument outside the protocol's range."""


class CommandRefused(AutonomyError):
    """The robot answered ``NO``: it did not accept the command.

    Attributes:
        frame: The 6-byte command frame that was refused.
    """

    #: What to check, for the person reading the message.
    hint = "is the robot in manual mode, fallen or out of battery?"

    def __init__(self, message: str, frame: bytes = b"") -> None:
        super().__init__(message)
        self.frame = frame


class CommandUnconfirmed(CommandRefused):
    """A command that is never repeated (``T``, ``D``) lost its reply and was not seen carried out.

    The link still answers (the status was read after the reply was missed), so the run
    goes on and the node that sent it fails.
    """

    hint = "the reply was lost on the link"


class LinkError(AutonomyError):
    """The link to the robot failed: it could not be opened, answered nothing, or went away."""


class PortError(LinkError):
    """The port could not be opened: no such device, permission denied, or a bad URL."""


class ReplyTimeout(LinkError):
    """No valid reply arrived within the request's time-out.

    Attributes:
        received: How many bytes arrived, none of them a valid reply. Bytes with no valid
            frame among them usually mean a wrong baud rate; none at all, a robot that is
            off or a wrong port.
    """

    def __init__(self, message: str, received: int = 0) -> None:
        super().__init__(message)
        self.received = received


class LinkLost(LinkError):
    """The port stopped working while in use (cable pulled, emulator closed)."""

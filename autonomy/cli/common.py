"""What every command shares: exit codes, printing, argument types, loading a mission, the view's server."""

from __future__ import annotations

import argparse
import errno
import math
import os
import signal
import sys
from collections.abc import Sequence
from typing import Any

from autonomy.emulator import FaultSpec, FaultSpecError, WorldError, WorldInvalid
from autonomy.errors import Interrupted
from autonomy.source import visible

EXIT_OK = 0


EXIT_FAILED = 1


EXIT_USAGE = 2


EXIT_LINK = 3


EXIT_INTERRUPTED = 130


class _Parser(argparse.ArgumentParser):
    """argparse with errors as one line and exit code 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_USAGE, f"{self.prog}: error: {_shown(message)} (see {self.prog} --help)\n")


def _fail(message: str, code: int) -> int:
    print(f"autonomy: error: {_shown(message)}", file=sys.stderr)
    return code


def _shown(text: object) -> str:
    """One line as it may reach a terminal: a file named with control characters changes nothing on the screen."""
    from autonomy.views.lines import printable

    return printable(str(text))


#: Most problems printed for one file: past that, the first ones are what to fix.
MAX_PROBLEMS_SHOWN = 100


def _problems(problems: Sequence[object]) -> int:
    """Prints a file's problems, one ``FILE:LINE:COL: ...`` a line (at most 100, then a count); exit 2."""
    for problem in problems[:MAX_PROBLEMS_SHOWN]:
        print(_shown(problem), file=sys.stderr)
    if len(problems) > MAX_PROBLEMS_SHOWN:
        print(f"... and {len(problems) - MAX_PROBLEMS_SHOWN:,} more problems, not shown", file=sys.stderr)
    return EXIT_USAGE


def _world_failed(err: WorldError) -> int:
    """Prints a world's problems, or why it cannot be found; exit 2."""
    return _problems(err.problems) if isinstance(err, WorldInvalid) else _fail(str(err), EXIT_USAGE)


def _host_port(text: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    if not sep:
        host, port = "127.0.0.1", text
    usage = f"expected HOST:PORT, [IPV6]:PORT or PORT, got {visible(text)!r}"
    if host.startswith("[") and host.endswith("]"):  # an IPv6 address: [::1]:7777
        host = host[1:-1]
    if not host.isprintable() or "[" in host or "]" in host or " " in host:
        raise argparse.ArgumentTypeError(usage)
    return host or "127.0.0.1", _tcp_port(port, usage)


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got '{text}'") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"must be a number above 0, got {text}")
    return value


def _bounded(kind: type, low: float, high: float, what: str) -> Any:
    """An argparse type: a number of ``kind`` from ``low`` to ``high`` (finite), else a one-line error."""

    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got '{text}'") from None
        if not low <= value <= high:  # NaN fails this too
            raise argparse.ArgumentTypeError(f"must be from {low:,} to {high:,}, got {text}")
        return value

    return parse


def _faults(text: str) -> str:
    try:
        FaultSpec.parse(text)
    except FaultSpecError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
    return text


def _load(path: str, check_world: bool = True) -> Any:
    """Validates a mission file; prints its problems and returns None when it has any.

    Without ``check_world``, the world its ``world:`` names is not looked for: the run is in another's
    (an exercise's, as grading runs it).
    """
    from autonomy.mission import MissionInvalid, load_mission

    try:
        return load_mission(path, check_world)
    except MissionInvalid as err:
        _problems(err.problems)
        return None


def _interrupt(*_: object) -> None:
    raise Interrupted


class _InterruptOnce:
    """Ctrl-C and SIGTERM end a run once; pressed again while the robot is being stopped, they wait.

    A second Ctrl-C must not cut the final stop short: that is when a moving robot is told to stop.
    """

    def __init__(self) -> None:
        self.raised = False
        self.held = False  # pressed while it waited: the command ends once the robot is stopped

    def install(self) -> None:
        signal.signal(signal.SIGINT, self)
        signal.signal(signal.SIGTERM, self)

    def __call__(self, *_: object) -> None:
        if not self.raised:
            self.raised = True
            raise Interrupted
        self.held = True
        print("autonomy: stopping the robot first; one moment", file=sys.stderr, flush=True)


def _silence_stdout() -> None:
    """Points standard output at /dev/null, so that the interpreter's last flush cannot fail."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def _warn_if_public(host: str, what: str, can: str = "watch the run") -> None:
    """Warns when ``what`` is served on an interface other machines can reach, where anyone ``can`` do so."""
    import ipaddress

    try:
        loopback = host.lower() == "localhost" or ipaddress.ip_address(host).is_loopback
    except ValueError:
        loopback = False
    if not loopback:
        print(f"warning: {what} served on {host}: anyone who can reach this machine can {can}", file=sys.stderr)


def _port_busy(err: OSError, option: str) -> str:
    """Why a server could not start, and for a port in use, what to do."""
    if err.errno == errno.EADDRINUSE:
        return f"the port is in use (another run's view, or another program): {option} 0 takes any free port"
    return str(err.strerror or err)


def _addresses(host: str) -> list[str]:
    """Where others reach a server on ``host``: for every interface (0.0.0.0), this machine's own addresses."""
    if host not in ("0.0.0.0", "::", ""):
        return [host]
    import socket

    found: list[str] = []
    try:
        found += socket.gethostbyname_ex(socket.gethostname())[2]
    except OSError:
        pass
    try:  # the address of the way out: a datagram socket connected to an address for documentation sends nothing
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.connect(("192.0.2.1", 9))
            found.append(probe.getsockname()[0])
    except OSError:
        pass
    outside = sorted({a for a in found if not a.startswith("127.")})
    return [*outside, "127.0.0.1"] if outside else ["this machine's address"]


def _start_view(args: argparse.Namespace, mode: str = "live") -> tuple[Any, str]:
    """Starts the browser view's server; returns it, or None and why not."""
    from autonomy.views.web import ViewServer

    host = args.view_host
    try:
        server = ViewServer(host, args.view_port, mode=mode)
        server.start()
    except OSError as err:
        return None, f"cannot serve the view on {host}:{args.view_port}: {_port_busy(err, '--view-port')}"
    _warn_if_public(host, "the view is")
    print(f"view: {_view_url(server)}", file=sys.stderr, flush=True)
    return server, ""


def _view_url(server: Any) -> str:
    """The page's address as a person opens it: one served on every interface (0.0.0.0) at this machine's addresses."""
    if server.host not in ("0.0.0.0", "::", ""):
        return str(server.url)
    urls = [f"http://{address}:{server.port}/" for address in _addresses(server.host) if address[0].isdigit()]
    return " or ".join(urls) or str(server.url)


def _serve_until_interrupted(server: Any, why: str, interrupts: _InterruptOnce | None = None) -> None:
    try:
        if interrupts is not None:
            interrupts.raised = False  # the robot is stopped: Ctrl-C now just ends the view
            if interrupts.held:  # pressed while the robot was stopped or the summary written: it ends the view
                return
        print(f"{why}; the view stays at {_view_url(server)} until Ctrl-C", file=sys.stderr, flush=True)
        server.wait()
    except KeyboardInterrupt:
        pass


def _view_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--view", action="store_true", help="serve a live page of the run (see --view-port)")
    parser.add_argument(
        "--view-port", type=_tcp_port, default=8765, metavar="PORT", help="the page's port (default 8765; 0: any free)"
    )
    parser.add_argument(
        "--view-host",
        default="127.0.0.1",
        metavar="HOST",
        help="the interface to serve on (default 127.0.0.1, this machine only)",
    )


def _tcp_port(text: str, not_a_number: str = "") -> int:
    if not (text.isascii() and text.isdigit()):
        raise argparse.ArgumentTypeError(not_a_number or f"expected a port number, got {visible(text)!r}")
    number = int(text)
    if not 0 <= number <= 65535:
        raise argparse.ArgumentTypeError(f"port must be 0..65535, got {number}")
    return number

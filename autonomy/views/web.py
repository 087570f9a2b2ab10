"""The browser view: a page that shows a run as it goes, or plays a recorded one back.

Served with aiohttp (one well-kept package that has both the HTTP server and WebSockets, and
runs in a thread of its own beside the runner). Every script, style and font comes from this
package: the page loads nothing from the internet.

The page gets everything from two addresses: ``api/run`` (the header, the tree and map
pictures, and every record so far) and the WebSocket ``api/stream?from=N`` (messages
``NAME\nJSON``: ``ticks``, a list of the tick records since the last message, or ``preview``
for a burst of them in a run in virtual time, then ``end``; a page that had previews asks
``api/run`` again at the end). A page on a finished run waits on the WebSocket ``api/next``
for the next run. :mod:`autonomy.views.page` has the page, and freezes it on a whole run, in one file.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import ipaddress
import logging
import os
import resource
import secrets
import threading
import uuid
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any, cast

import msgspec
from aiohttp import web

from autonomy.clock import Clock, RealClock
from autonomy.record import NodeState, Record, RunEnd, RunHeader, TickRecord, to_line
from autonomy.views.page import STATIC_FILES, run_payload, static_text

#: Sends one message (``NAME\nJSON``) on a page's WebSocket.
Put = Callable[[str], Awaitable[None]]


#: What the server would log of a request it could not handle: nothing (it answers 400, and goes on).
_QUIET_LOGGER = logging.getLogger("autonomy.views.web.requests")
_QUIET_LOGGER.addHandler(logging.NullHandler())
_QUIET_LOGGER.propagate = False
#: Where a refusal is said: one line (on the terminal, when nothing else is set up), never a traceback.
REFUSALS = logging.getLogger("autonomy.view")
#: A refusal of a kind said already is said again, with how many there were, at most this often.
REFUSAL_REPEAT_S = 10.0

#: Connections served at once; past this a new one is answered 503 and closed. Fewer when the process
#: may open fewer files: :data:`RESERVED_FILES` are kept for everything else it opens, and a burst of
#: connections taken in at once (at most :data:`LISTEN_BACKLOG`) may pass the limit before it is seen.
MAX_CONNECTIONS = 4096
RESERVED_FILES = 256
LISTEN_BACKLOG = 128
#: Connections served at once to one address (an IPv6 machine: its /64), as a share of :data:`MAX_CONNECTIONS`:
#: one client that opens connections by the thousand holds its share, never every slot. A class behind one
#: router still has 16 each for 30 students.
CONNECTIONS_PER_ADDRESS_SHARE = 8
#: How long a request refused before its body was read may go on sending it (read and thrown away) before
#: its connection is closed: a refusal is read by a client whose body is short, and costs nothing held longer.
LINGER_S = 2.0
#: ``api/run`` answers on their way at once; past this a page is answered 503 and asks again a second
#: later. Each holds a piece and the socket's buffer, about 200 KB at most: 50 MB in all.
MAX_ANSWERS_SENDING = 256
#: Pages (a feedback page, a file) on their way at once, apart from the answers of the API: readers of pages
#: who read slowly, or never, hold these alone, never what a check's or a run's answer needs.
MAX_PAGES_SENDING = 96
#: Of those, to one address (an IPv6 address counted with its /64).
MAX_PAGES_PER_ADDRESS = 16
#: The slowest an answer may be read, over the whole of it, bytes a second (past :data:`ANSWER_STALL_S`): a page
#: of 8 MB has about four minutes, however it is read, a piece just before each stall or not.
MIN_ANSWER_BYTES_PER_S = 32_768
#: An answer is sent in pieces of this size, the next once the page has read the last.
ANSWER_PIECE_BYTES = 65_536
#: A page that reads none of its answer for this long is let go.
ANSWER_STALL_S = 10.0
#: A request's headers: at most this many, each at most this long (the page's are a dozen, short).
MAX_HEADERS = 32
MAX_HEADER_BYTES = 4096
#: A connection that sends no request for this long is closed (a page's fetches come together).
IDLE_CONNECTION_S = 10.0
#: Largest WebSocket message taken from a page (it sends none: its socket's end closes it).
MAX_PAGE_MESSAGE_BYTES = 1024
#: Most events a preview carries (the last ones); the page gets every one with the whole run at its end.
PREVIEW_EVENTS = 200
#: A live run's ``api/run`` answer is made again at most this often: a page takes what came since from its stream.
PAYLOAD_AGE_S = 1.0
_RETRY = {"Retry-After": "1"}
_BUSY_ANSWER = (
    b"HTTP/1.1 503 Service Unavailable\r\nContent-Type: text/plain\r\nContent-Length: 30\r\n"
    b"Retry-After: 1\r\nConnection: close\r\n\r\ntoo many connections at once\r\n"
)


class _Refusing(asyncio.Protocol):
    """A connection past the limit: told so, and closed once its request is read, or after a second.

    Closed with the request unread, the kernel would reset it, and the page would never see the 503.
    """

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        transport.write(_BUSY_ANSWER)  # type: ignore[attr-defined]
        asyncio.get_running_loop().call_later(1.0, transport.close)
        self._transport = transport

    def data_received(self, data: bytes) -> None:
        self._transport.close()


def page_file(
    name: str, files: dict[str, str], package: str = "autonomy.views", headers: dict[str, str] | None = None
) -> web.Response:
    """One of a page's own files (``files``: their names and types), from ``package``'s ``static/``; else not found."""
    if name not in files:
        raise web.HTTPNotFound()
    return web.Response(text=static_text(name, package), content_type=files[name], headers=headers)


#: Where a page's HTML has the nonce of its response's styles (``<meta name="style-nonce" content="...">``).
STYLE_NONCE_MARK = "{{style-nonce}}"


def nonced_page(text: str, policy: str) -> web.Response:
    """A page whose own scripts add ``<style>`` elements (CodeMirror's themes): a new nonce at each response.

    The nonce is put in the policy's ``style-src`` and in the page (at :data:`STYLE_NONCE_MARK`), where the
    page's scripts read it; a style put in the page by anything else (received markup) has none and is refused.
    """
    nonce = secrets.token_urlsafe(18)
    policy = policy.replace("style-src 'self'", f"style-src 'self' 'nonce-{nonce}'", 1)
    headers = {"Content-Security-Policy": policy, "Cache-Control": "no-store"}
    return web.Response(text=text.replace(STYLE_NONCE_MARK, nonce), content_type="text/html", headers=headers)


def query_line(request: web.Request) -> int | None:
    """The ``line`` of a request's query (a text's cursor's: 1 and on), or None."""
    given = request.query.get("line", "")
    return int(given) if given.isascii() and given.isdigit() and len(given) <= 7 else None


def query_selected(request: web.Request) -> str | None:
    """The ``selected`` of a request's query (a block's id, at most 64 characters), or None."""
    return request.query.get("selected", "")[:64] or None


def address_group(address: str) -> str:
    """Who a connection is counted as: an IPv4 address, or an IPv6 address's /64 network (one machine may hold all)."""
    try:
        ip = ipaddress.ip_address(address)
    except ValueError:
        return address
    if isinstance(ip, ipaddress.IPv6Address):
        return str(ip.ipv4_mapped) if ip.ipv4_mapped else str(ipaddress.ip_network(f"{ip}/64", strict=False))
    return str(ip)


class _Counted(asyncio.Protocol):
    """A connection counted against its address's share: served by the server's handler, or refused past the share.

    Args:
        server: The server that counts.
        serve: Makes the protocol that serves the connection (aiohttp's request handler).
    """

    def __init__(self, server: BoundedServer, serve: Callable[[], asyncio.BaseProtocol]) -> None:
        self._server, self._serve = server, serve
        self._inner: asyncio.Protocol = _Refusing()
        self._address: str | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        peer = transport.get_extra_info("peername")
        address = address_group(str(peer[0])) if isinstance(peer, tuple) and peer else ""
        counts, share = self._server.connections_from, self._server.max_connections_per_address
        if share < self._server.max_connections and counts[address] >= share:  # few in all: the limit in all alone
            self._server._refused(
                "connections from one",
                f"{self._server.max_connections_per_address} connections at once from one address; another was refused",
            )
        else:
            counts[address] += 1
            self._address = address
            self._inner = cast(asyncio.Protocol, self._serve())
        self._inner.connection_made(transport)

    def data_received(self, data: bytes) -> None:
        self._inner.data_received(data)

    def eof_received(self) -> bool | None:
        return self._inner.eof_received()

    def pause_writing(self) -> None:
        self._inner.pause_writing()

    def resume_writing(self) -> None:
        self._inner.resume_writing()

    def connection_lost(self, exc: Exception | None) -> None:
        if self._address is not None:
            counts = self._server.connections_from
            counts[self._address] -= 1
            if counts[self._address] <= 0:
                del counts[self._address]
            self._address = None
        self._inner.connection_lost(exc)


def connection_limit() -> int:
    """How many connections the view serves at once: :data:`MAX_CONNECTIONS`, or fewer if files are fewer.

    The process's soft limit of open files is raised first, as far as its hard limit lets it, to what
    :data:`MAX_CONNECTIONS` needs (a shell's usual soft limit of 1,024 would leave 640).
    """
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    needed = MAX_CONNECTIONS + RESERVED_FILES + LISTEN_BACKLOG
    if soft != resource.RLIM_INFINITY and soft < needed:
        wanted = needed if hard == resource.RLIM_INFINITY else min(needed, hard)
        try:
            resource.setrlimit(resource.RLIMIT_NOFILE, (wanted, hard))
        except (ValueError, OSError):  # not allowed here: the limit stands, and is said
            pass
        soft, _ = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft == resource.RLIM_INFINITY:
        return MAX_CONNECTIONS
    return max(16, min(MAX_CONNECTIONS, soft - RESERVED_FILES - LISTEN_BACKLOG))


class RecordHub:
    """A listener that keeps a run's records for the page and wakes its event streams.

    Called from the runner's thread, it only keeps the record and, now and then, wakes the
    server's thread: turning records into JSON is the server thread's work, done when a page
    asks, so that watching costs the run as little as can be.

    Args:
        mode: ``live`` or ``replay`` (the page shows replay controls).
    """

    #: Ticks less than this far apart come in a burst (a run in virtual time).
    BURST_S = 0.005
    #: How often the streams are woken during a burst.
    BURST_WAKE_S = 1.0
    #: Most records a burst is sent as; a page gets every record when the run ends.
    PREVIEW_RECORDS = 10

    def __init__(self, mode: str = "live") -> None:
        self.mode = mode
        self.header: RunHeader | None = None
        self.ticks: list[TickRecord] = []
        self.end: RunEnd | None = None
        self.generation = 0
        #: Which hub this is: a page that watched a finished run knows the next one by its ``run``.
        self.name = uuid.uuid4().hex[:12]
        self.closed = False
        self._lock = threading.Lock()
        self._loop: asyncio.AbstractEventLoop | None = None
        #: The streams of the run (``api/stream``), woken by its records.
        self._waiters: set[asyncio.Event] = set()
        #: The pages waiting for the next run (``api/next``), woken only when one starts or the server stops.
        self._run_waiters: set[asyncio.Event] = set()
        #: The ``api/run`` answer, encoded once for every page that asks until the run changes.
        self._payload: tuple[tuple[str, int, bool], bytes] = (("", -1, False), b"")
        self._payload_s = 0.0
        self._clock = RealClock()
        self._wake_pending = False
        self._woken_s = -1.0
        self._last_record_s = -1.0
        self._new_header = False

    def __call__(self, record: Record) -> None:
        """Takes one record."""
        with self._lock:
            if isinstance(record, RunHeader):
                self.header, self.ticks, self.end = record, [], None
                self.generation += 1
                self._new_header = True
            elif isinstance(record, TickRecord):
                self.ticks.append(record)
            elif isinstance(record, RunEnd):
                self.end = record
        self.wake()

    def wake(self) -> None:
        """Wakes every waiting event stream (from any thread).

        A tick that comes on its own (a run in real time) is sent at once. Ticks that come in a
        burst, less than :data:`BURST_S` apart, are sent together every :data:`BURST_WAKE_S`:
        each wake of the server's thread takes the interpreter from the run.
        """
        now_s = self._clock.now()
        since_tick_s, self._last_record_s = now_s - self._last_record_s, now_s
        loop = self._loop
        if loop is None or loop.is_closed():
            return
        if self._new_header and self._run_waiters:
            loop.call_soon_threadsafe(self._wake_run_waiters)
        if not self._waiters or self._wake_pending:
            return
        wait_s = self.BURST_WAKE_S if since_tick_s < self.BURST_S else 0.0
        if now_s - self._woken_s < wait_s and self.end is None and not self._new_header:
            return
        self._wake_pending, self._woken_s, self._new_header = True, now_s, False
        loop.call_soon_threadsafe(self._wake_all)

    def _wake_all(self) -> None:
        self._wake_pending = False
        for event in self._waiters:
            event.set()

    def _wake_run_waiters(self) -> None:
        for event in self._run_waiters:
            event.set()

    @property
    def run(self) -> str:
        """The run's name for the page: this hub's, and which of its runs (empty before any)."""
        return f"{self.name}-{self.generation}" if self.header is not None else ""

    def encoded_payload(self) -> bytes:
        """The whole run so far, as the page's ``api/run`` answer, in UTF-8.

        Made once for every page that asks while the run stays as it is.
        """
        with self._lock:
            header, ticks, end, run = self.header, self.ticks, self.end, self.run
            count = len(ticks)
        key = (run, count, end is not None)
        (made_run, made_count, made_end), answer = self._payload
        now_s = self._clock.now()
        fresh = (made_run, made_end) == (run, end is not None) and now_s - self._payload_s < PAYLOAD_AGE_S
        if (made_run, made_count, made_end) == key or (fresh and end is None):
            return answer  # a live run's from a moment ago: the page's stream starts where it ends
        answer = run_payload(header, ticks[:count], end, self.mode, run).encode("utf-8")
        self._payload, self._payload_s = (key, answer), now_s
        return answer

    def event(self, ticks: list[TickRecord]) -> str:
        """The message for ``ticks``: all of them, or for a burst a preview.

        A preview is at most :data:`PREVIEW_RECORDS` records: each the last tick of its share of
        the burst, carrying every node change and the last :data:`PREVIEW_EVENTS` events of that
        share, so the tree is right and the path, plots and log are drawn from fewer points until
        the run ends (or the replay's whole run is fetched).
        """
        if len(ticks) <= self.PREVIEW_RECORDS:
            return "ticks\n[" + ",".join(to_line(t) for t in ticks) + "]"
        size = -(-len(ticks) // self.PREVIEW_RECORDS)
        shares = [ticks[i : i + size] for i in range(0, len(ticks), size)]
        merged = []
        for share in shares:
            nodes: dict[int, NodeState] = {}
            for tick in share:
                nodes.update(tick.nodes)
            events = [event for tick in share for event in tick.events][-PREVIEW_EVENTS:]
            merged.append(msgspec.structs.replace(share[-1], nodes=nodes, wire=[], events=events))
        return "preview\n[" + ",".join(t.to_line() for t in merged) + "]"


#: What the page may load and run: its own files and its own WebSocket, nothing inline, nothing framed.
CONTENT_SECURITY_POLICY = (
    "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; connect-src 'self'; "
    "base-uri 'none'; form-action 'none'; frame-ancestors 'none'"
)


def _own_host(host_header: str, served_as: str = "") -> bool:
    """Whether a request's ``Host`` names this machine by address, as ``localhost``, or as a name of ``served_as``.

    A page of another site that got its name resolved to this machine (DNS rebinding) asks with
    that name: it is refused. A name is never needed here: the page's address is printed as one,
    unless the server was told to serve on a name (``--view-host robot-lab.local``): that one is taken.
    """
    host, port = host_header, ""
    if host.startswith("["):  # [::1] or [::1]:8765
        close = host.find("]")
        host, port = host[1:close], host[close + 1 :] if close > 0 else ""
        if close < 0 or (port and not port.startswith(":")):
            return False
        port = port[1:]
    elif host.count(":") == 1:
        host, port = host.split(":")
    if port and not (port.isascii() and port.isdigit()):
        return False
    if host.lower() == "localhost" or host.lower() in served_as.lower().split():
        return True
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


@web.middleware
async def _checked_origin(request: web.Request, handler: Callable[[web.Request], Awaitable[web.StreamResponse]]):
    """Serves only requests to this machine by address, and WebSockets opened by the page itself."""
    host = request.headers.get("Host", "")
    if not _own_host(host, request.app[SERVED_AS]):
        return web.Response(status=403, text="this page is served by address (127.0.0.1, or this machine's)\n")
    origins = request.headers.getall("Origin", [])
    origin = origins[0] if len(origins) == 1 else None if not origins else "several"
    crossing = request.path in request.app[CROSS_ORIGIN_PATHS] and origin != "several"
    if origin is not None and origin not in (f"http://{host}", f"https://{host}") and not crossing:
        return web.Response(status=403, text="a page of another origin may not read this run\n")
    response = await handler(request)
    if not response.prepared:  # a WebSocket's answer has gone already
        response.headers.setdefault("Content-Security-Policy", CONTENT_SECURITY_POLICY)
        response.headers.setdefault("X-Content-Type-Options", "nosniff")
    return response


#: The name the server was told to serve on, taken in ``Host`` besides addresses and ``localhost``.
SERVED_AS = web.AppKey("served_as", str)
#: The paths another site's page may post to (an LMS's launch of the class: its own checks are its state and token).
CROSS_ORIGIN_PATHS = web.AppKey("cross_origin_paths", frozenset)


class BoundedServer:
    """An aiohttp server in a thread of its own, bounding what one client can cost.

    It answers only requests to this machine by address (or the name it serves on), WebSockets of
    its own pages, with a strict content security policy; it takes at most
    :attr:`max_connections` connections at once, requests of a few headers, and lets a silent
    connection go; each kind of refusal is said in one line. A subclass adds its routes
    (:meth:`_routes`).

    Args:
        host: The interface (127.0.0.1 unless asked otherwise).
        port: The TCP port (0: any free one).
        name: How its refusals are introduced (``view``).
    """

    #: Largest request body taken.
    max_request_bytes = 1024 * 1024

    def __init__(self, host: str = "127.0.0.1", port: int = 8765, name: str = "view") -> None:
        self.host, self.port = host, port
        self.name = name
        #: Other names it is served as (a proxy's public name), and the paths another site's page may post to.
        self.served_as: tuple[str, ...] = ()
        self.cross_origin_paths: frozenset[str] = frozenset()
        self._loop = asyncio.new_event_loop()
        self._thread: threading.Thread | None = None
        self._runner: web.AppRunner | None = None
        self._listener: asyncio.AbstractServer | None = None
        self._stopped = threading.Event()
        self._clock = RealClock()
        #: Per kind of refusal: when it was last said, and how many since.
        self._refusals: dict[str, tuple[float, int]] = {}
        self.max_connections = connection_limit()
        if self.max_connections < MAX_CONNECTIONS:  # the files the process may open are too few: said, not silent
            files = resource.getrlimit(resource.RLIMIT_NOFILE)[1]
            self._refused("files", f"at most {self.max_connections:,} connections at once, not {MAX_CONNECTIONS:,}: "
                          f"the process may open {files:,} files (raise `ulimit -Hn` to serve more)")  # fmt: skip
        self.max_connections_per_address = max(16, self.max_connections // CONNECTIONS_PER_ADDRESS_SHARE)
        #: Connections served now, by address (:func:`address_group`).
        self.connections_from: collections.Counter[str] = collections.Counter()
        self._answers_sending = 0
        self.max_answers_sending = MAX_ANSWERS_SENDING
        self._sending_to: collections.Counter[str] = collections.Counter()
        self.max_answers_per_address = MAX_ANSWERS_SENDING  # a server of many clients takes fewer (the class's)
        self._pages_sending = 0
        self.max_pages_sending = MAX_PAGES_SENDING
        self._pages_to: collections.Counter[str] = collections.Counter()
        self.max_pages_per_address = MAX_PAGES_PER_ADDRESS

    @property
    def url(self) -> str:
        """Where the page is."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/"

    def _routes(self, app: web.Application) -> None:
        """Adds the server's routes to ``app``."""
        raise NotImplementedError

    def _make_app(self) -> web.Application:
        """The application: the checks of every request, and the routes."""
        app = web.Application(middlewares=[_checked_origin], client_max_size=self.max_request_bytes)
        names = [self.host if self.host not in ("", "0.0.0.0", "::") else "", *self.served_as]
        app[SERVED_AS] = " ".join(name for name in names if name)
        app[CROSS_ORIGIN_PATHS] = self.cross_origin_paths
        self._routes(app)
        return app

    def start(self) -> None:
        """Binds the port and starts serving.

        Raises:
            OSError: the port cannot be bound.
        """
        # A malformed request (a header of 200 KB, a path of 15 KB) is the client's problem: answered
        # 400 and let go, never a traceback in the terminal the robot is watched from.
        self._runner = web.AppRunner(
            self._make_app(),
            handle_signals=False,
            access_log=None,
            shutdown_timeout=0.5,
            logger=_QUIET_LOGGER,
            keepalive_timeout=IDLE_CONNECTION_S,
            lingering_time=LINGER_S,
            max_headers=MAX_HEADERS,
            max_field_size=MAX_HEADER_BYTES,
            max_line_size=MAX_HEADER_BYTES,
        )
        ready = threading.Event()
        failure: list[OSError] = []
        self._thread = threading.Thread(
            target=self._serve, args=(self._runner, ready, failure), name=f"autonomy-{self.name}", daemon=True
        )
        self._thread.start()
        ready.wait()
        if failure:
            self._thread.join()
            self._thread = None
            raise failure[0]

    def _serve(self, runner: web.AppRunner, ready: threading.Event, failure: list[OSError]) -> None:
        loop = self._loop
        asyncio.set_event_loop(loop)
        loop.set_exception_handler(self._loop_fault)
        try:
            loop.run_until_complete(runner.setup())
            handler = runner.server
            if handler is None:  # setup() made it
                raise OSError(f"the {self.name}'s server was not set up")

            def connection() -> asyncio.BaseProtocol:
                if len(handler.connections) >= self.max_connections:
                    self._refused("connections", f"{self.max_connections} connections at once; another was refused")
                    return _Refusing()
                return _Counted(self, handler)

            self._listener = loop.run_until_complete(
                loop.create_server(connection, self.host, self.port, reuse_address=True, backlog=LISTEN_BACKLOG)
            )
        except OSError as err:
            failure.append(err)
            loop.run_until_complete(runner.cleanup())
            loop.close()
            ready.set()
            return
        sockets = self._listener.sockets
        if sockets:
            self.port = sockets[0].getsockname()[1]
        self._serving(loop)
        ready.set()
        loop.run_forever()
        self._stopped.set()

    def _serving(self, loop: asyncio.AbstractEventLoop) -> None:
        """Called on the server's thread once it listens, before it serves."""

    def _closing(self) -> None:
        """Called as :meth:`stop` begins, on the caller's thread."""

    async def _before_cleanup(self) -> None:
        """Called on the server's thread as it stops, before its connections are closed."""

    def stop(self) -> None:
        """Closes every connection and stops serving."""
        self._closing()
        if self._thread is None or self._loop.is_closed():
            return
        future = asyncio.run_coroutine_threadsafe(self._shutdown(), self._loop)
        try:
            future.result(timeout=5)
        except Exception:  # noqa: BLE001, S110 - shutting down: nothing left to tell anyone
            pass
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(timeout=5)
        if not self._loop.is_running():
            self._loop.close()

    async def _shutdown(self) -> None:
        if self._listener is not None:
            self._listener.close()
        await self._before_cleanup()
        if self._runner is not None:
            await self._runner.cleanup()

    async def _send_in_pieces(
        self,
        request: web.Request,
        body: bytes | Path,
        content_type: str,
        headers: dict[str, str] | None = None,
        page: bool = False,
    ) -> web.StreamResponse:
        """Sends a large answer (bytes, or a file's) a piece at a time, as the client reads it.

        A client that does not read holds a piece of the answer (and the kernel's buffer), never a
        copy of it. At most :attr:`max_answers_sending` answers are on their way at once, and
        :attr:`max_answers_per_address` to one address (past that: 503, asked again a second later); a
        ``page`` counts apart, within :attr:`max_pages_sending` and :attr:`max_pages_per_address`. One not
        read for :data:`ANSWER_STALL_S`, or read slower than :data:`MIN_ANSWER_BYTES_PER_S`, is given up.
        """
        address = address_group(request.remote or "")
        kind = "pages" if page else "answers"
        to, most_to = (self._pages_to, self.max_pages_per_address) if page else (
            self._sending_to, self.max_answers_per_address)  # fmt: skip
        if to[address] >= most_to:
            self._refused(f"{kind} to one", f"too many {kind} are on their way to one address at once")
            return web.Response(status=503, text=f"too many {kind} are on their way to you at once\n", headers=_RETRY)
        sending = self._pages_sending if page else self._answers_sending
        if sending >= (self.max_pages_sending if page else self.max_answers_sending):
            self._refused(kind, f"too many {kind} are on their way at once")
            return web.Response(status=503, text=f"too many {kind} are on their way at once\n", headers=_RETRY)
        self._count_sending(page, address, 1)
        try:
            with body.open("rb") if isinstance(body, Path) else contextlib.nullcontext() as stream:
                length = os.fstat(stream.fileno()).st_size if stream is not None else len(body)
                view = memoryview(body) if stream is None else None
                response = web.StreamResponse(headers={"Content-Type": content_type, **(headers or {})})
                response.content_length = length
                response.headers.setdefault("Content-Security-Policy", CONTENT_SECURITY_POLICY)
                response.headers["X-Content-Type-Options"] = "nosniff"
                await response.prepare(request)
                until_s = self._clock.now() + ANSWER_STALL_S + length / MIN_ANSWER_BYTES_PER_S
                for start in range(0, length, ANSWER_PIECE_BYTES):
                    piece = (
                        view[start : start + ANSWER_PIECE_BYTES]
                        if view is not None
                        else stream.read(ANSWER_PIECE_BYTES)
                    )
                    left_s = min(ANSWER_STALL_S, until_s - self._clock.now())
                    try:
                        if left_s <= 0:
                            raise asyncio.TimeoutError
                        await asyncio.wait_for(response.write(piece), left_s)
                    except asyncio.TimeoutError:
                        self._refused("stalled", "a client stopped reading its answer, or read it too slowly; let go")
                        if request.transport is not None:
                            request.transport.abort()
                        return response
                await response.write_eof()
                return response
        except ConnectionError:  # the client went
            return web.Response()
        finally:
            self._count_sending(page, address, -1)

    def _count_sending(self, page: bool, address: str, change: int) -> None:
        """Counts an answer (or a page) to ``address`` as on its way (``change`` 1), or as gone (-1)."""
        if page:
            self._pages_sending += change
        else:
            self._answers_sending += change
        to = self._pages_to if page else self._sending_to
        to[address] += change
        if not to[address]:
            del to[address]

    def _refused(self, kind: str, text: str) -> None:
        """Says a refusal in one line: the first of its kind at once, then how many, at most every few seconds."""
        now_s = self._clock.now()
        said_s, since = self._refusals.get(kind, (-REFUSAL_REPEAT_S, 0))
        if now_s - said_s < REFUSAL_REPEAT_S:
            self._refusals[kind] = (said_s, since + 1)
            return
        self._refusals[kind] = (now_s, 0)
        REFUSALS.warning("%s: %s%s", self.name, text, f" ({since} more since it was last said)" if since else "")

    def _loop_fault(self, loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
        """What the event loop could not handle (no file descriptor left to accept with, say): one line."""
        error = context.get("exception")
        message = context.get("message", "a fault")
        why = (error.strerror or str(error)) if isinstance(error, OSError) else type(error).__name__ if error else ""
        self._refused(f"loop {message}", f"{message}: {why}" if why else message)

    def wait(self, clock: Clock | None = None) -> None:
        """Blocks until the server stops (or Ctrl-C), looking twice a second."""
        clock = clock or RealClock()
        while not self._stopped.is_set():
            clock.sleep(0.5)


class ViewServer(BoundedServer):
    """Serves the page of a run in a thread of its own.

    Args:
        host: The interface (127.0.0.1 unless asked otherwise).
        port: The TCP port (0: any free one).
        mode: ``live`` or ``replay``.
        framed_by: The origins (``http://127.0.0.1:8766 http://localhost:8766``) whose pages may show the page in a
            frame; none when empty.
    """

    def __init__(self, host: str = "127.0.0.1", port: int = 8765, mode: str = "live", framed_by: str = "") -> None:
        super().__init__(host, port, "view")
        self.hub = RecordHub(mode)
        self.framed_by = framed_by

    def _routes(self, app: web.Application) -> None:
        app.router.add_get("/", self._index)
        app.router.add_get("/static/{name}", self._static)
        app.router.add_get("/api/run", self._run)
        app.router.add_get("/api/stream", self._stream)
        app.router.add_get("/api/next", self._next)

    def _serving(self, loop: asyncio.AbstractEventLoop) -> None:
        self.hub._loop = loop  # noqa: SLF001 - the hub wakes streams on this loop

    def _closing(self) -> None:
        self.hub.closed = True

    async def _before_cleanup(self) -> None:
        self.hub._wake_all()  # noqa: SLF001
        self.hub._wake_run_waiters()  # noqa: SLF001

    # ------------------------------------------------------------------ handlers

    async def _index(self, request: web.Request) -> web.Response:
        headers = {}
        if self.framed_by:
            policy = CONTENT_SECURITY_POLICY.replace("frame-ancestors 'none'", f"frame-ancestors {self.framed_by}")
            headers["Content-Security-Policy"] = policy
        return web.Response(text=static_text("index.html"), content_type="text/html", headers=headers)

    async def _static(self, request: web.Request) -> web.Response:
        return page_file(request.match_info["name"], STATIC_FILES)

    async def _run(self, request: web.Request) -> web.StreamResponse:
        """The whole run so far: one encoded answer for every page, sent a piece at a time as each page reads it."""
        return await self._send_in_pieces(request, self.hub.encoded_payload(), "application/json; charset=utf-8")

    async def _stream(self, request: web.Request) -> web.StreamResponse:
        """The run as it goes, for a page: messages ``ticks``, ``preview``, ``end``, or ``header`` (start again)."""
        hub = self.hub
        try:
            sent = max(0, int(request.query.get("from", "0")))
        except ValueError:
            raise web.HTTPBadRequest(text="from must be a tick count") from None
        generation = hub.generation

        async def send(put: Put, event: asyncio.Event) -> None:
            nonlocal sent
            if "run" in request.query and request.query["run"] != hub.run:
                # the page watched another run: one this server had before, or the last server on
                # this port, stopped in the middle of its run (its browser came back here)
                await put("header\n{}")
                return
            while True:
                event.clear()
                if hub.generation != generation:
                    await put("header\n{}")
                    return
                ticks, end = hub.ticks[sent:], hub.end
                if ticks:  # every tick since the last wake, in one message: the page parses once
                    await put(hub.event(ticks))
                    sent += len(ticks)
                if end is not None and sent >= len(hub.ticks):
                    await put(f"end\n{to_line(end)}")
                    return
                if hub.closed:  # stopping: what there was has been sent (a run ended by Ctrl-C too)
                    return
                await event.wait()

        return await self._events(request, send, hub._waiters)  # noqa: SLF001

    async def _next(self, request: web.Request) -> web.StreamResponse:
        """For a page on a finished live run: the message ``run`` once a run other than the page's has started.

        Here, or on the next server on this port (while there is none, the page comes back less
        and less often).
        """
        hub = self.hub
        seen = request.query.get("run", "")

        async def send(put: Put, event: asyncio.Event) -> None:
            while not hub.closed:
                event.clear()
                if hub.run not in ("", seen):
                    await put("run\n{}")
                    return
                await event.wait()

        return await self._events(request, send, hub._run_waiters)  # noqa: SLF001

    async def _events(
        self,
        request: web.Request,
        send: Callable[[Put, asyncio.Event], Awaitable[None]],
        waiters: set[asyncio.Event],
    ) -> web.StreamResponse:
        """A WebSocket on which ``send`` puts its messages (``NAME\\nJSON``), woken by the hub, until it returns.

        A WebSocket, not server-sent events: a browser keeps six HTTP connections to one server,
        and a page held one for as long as it was open, so the seventh page of a run never loaded.
        It ends when ``send`` returns, or when the page goes. ``waiters`` is the hub's set that wakes it.
        """
        # closing waits at most a second for the page's answer; the page sends nothing, so nothing big is taken
        socket = web.WebSocketResponse(timeout=1.0, max_msg_size=MAX_PAGE_MESSAGE_BYTES)
        try:
            await socket.prepare(request)
        except ConnectionError:  # the page went while its socket was being opened (a tab shown and hidden at once)
            return web.Response()  # to nobody: aiohttp lets go of a response to a connection already gone
        event = asyncio.Event()
        waiters.add(event)

        async def put(message: str) -> None:  # a page that reads none of a message for a while is let go
            try:
                await asyncio.wait_for(socket.send_str(message), ANSWER_STALL_S)
            except asyncio.TimeoutError:
                self._refused("stalled", "a page stopped reading the run; it was let go")
                raise ConnectionResetError("the page stopped reading") from None

        sending = asyncio.ensure_future(send(put, event))
        listening = asyncio.ensure_future(socket.receive())  # returns once the page closes its end
        try:
            await asyncio.wait({sending, listening}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            waiters.discard(event)
            for task in (sending, listening):
                task.cancel()
            results = await asyncio.gather(sending, listening, return_exceptions=True)
            if not socket.closed:
                await socket.close()
        failed = results[0]
        if isinstance(failed, Exception) and not isinstance(failed, (ConnectionError, asyncio.CancelledError)):
            raise failed  # not the page going away: a fault of the server's own
        return socket

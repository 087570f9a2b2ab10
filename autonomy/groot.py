"""A live publisher Groot2 attaches to, as BehaviorTree.CPP's ``Groot2Publisher`` is.

Groot2 connects a ZeroMQ REQ socket to port 1667 (by default) and asks; we answer on a ROUTER
socket (as a REP socket would, and knowing who asks), from a thread of our own, so the run never
waits on Groot2 and costs nothing while nobody asks. Each request's first frame is a 6-byte
header: the protocol (2), the request type (one letter) and a 4-byte id. A reply is two frames:
the header echoed with the 16-byte id of the tree added, then the answer:

=====  =========================================================================
``T``  the tree's XML, every node with its ``_uid`` (:func:`~autonomy.mission.btcpp.instance`)
``S``  3 bytes per node, uid (2 bytes, little-endian) then status; a node back to IDLE
       reports 10 + the status it had
``B``  the blackboards named in the second frame (``;``-separated), as MessagePack: a map
       of each name to nil (autonomy has no blackboard)
``D``  the breakpoints set: none (``[]``)
``A``, ``X``  remove or disable every breakpoint: the header alone
``r``  start or stop recording transitions (Groot2 PRO; a second frame says which): the header alone
``t``  the transitions recorded: none (an empty frame)
=====  =========================================================================

Anything else gets ``[b"error", reason]``. The publisher also binds the next port (1668) for
Groot2's subscriber, as the reference does, and publishes nothing on it.
"""

from __future__ import annotations

import struct
import threading
import uuid

import zmq

from autonomy.btlog import CODES
from autonomy.clock import RealClock
from autonomy.mission.btcpp import Instance
from autonomy.record import INVALID, Record, TickRecord

PROTOCOL = 2
DEFAULT_PORT = 1667


#: Largest request taken in (Groot2's are a few bytes; a bigger one is refused by ZeroMQ).
MAX_REQUEST_BYTES = 65_536
#: Replies held for one client that does not read them; past this its replies are dropped. Groot2
#: asks one thing at a time, so it never has more than one waiting.
REPLIES_HELD = 2
#: Requests taken in from one client before its connection is read no further until they are answered.
REQUESTS_HELD = 4
#: Requests a second taken in, at most, from everyone together, counted over bursts of :data:`RECEIVE_BURST`:
#: what a crowd of clients can cost the run's process (ZeroMQ reads from each client in turn).
RECEIVES_PER_S = 10_000
RECEIVE_BURST = 50
#: Requests a second one client is answered (Groot2 asks 10 while it watches); past that its requests
#: are dropped unanswered.
PEER_REQUESTS_PER_S = 20
#: The kernel's buffer for what one client sent and is not read yet: a client that floods is slowed
#: by TCP itself, and what it left behind is little.
RECEIVE_BUFFER_BYTES = 2048


def _msgpack_nils(names: list[str]) -> bytes:
    """``{name: nil, ...}`` as MessagePack, each name once, in sorted order; nil when there are none."""
    unique = sorted(set(names))
    if not unique:
        return b"\xc0"
    count = len(unique)
    out = bytearray(bytes([0x80 | count]) if count < 16 else b"\xde" + struct.pack(">H", count))
    for name in unique:
        raw = name.encode("utf-8")
        if len(raw) < 32:
            out += bytes([0xA0 | len(raw)])
        elif len(raw) < 256:
            out += b"\xd9" + bytes([len(raw)])
        else:
            out += b"\xda" + struct.pack(">H", len(raw))
        out += raw + b"\xc0"
    return bytes(out)


class GrootPublisher:
    """A record listener that keeps every node's status, and answers Groot2 from a thread.

    Args:
        tree: The mission's tree as BehaviorTree.CPP numbers it.
        host: The interface to listen on.
        port: The request port (the next one is bound too); 0 picks a free pair.

    Raises:
        OSError: the ports cannot be bound.
    """

    def __init__(self, tree: Instance, host: str = "127.0.0.1", port: int = DEFAULT_PORT) -> None:
        self.tree = tree
        self.tree_id = uuid.uuid4().bytes
        self.xml = tree.xml.encode("utf-8")
        #: Per record node: the status byte Groot2 is told.
        self.codes: dict[int, int] = {record_id: 0 for record_id in tree.record_ids}
        self._context = zmq.Context()
        self._reply = self._context.socket(zmq.ROUTER)
        self._publish = self._context.socket(zmq.PUB)
        self._reply.setsockopt(zmq.LINGER, 0)
        self._reply.setsockopt(zmq.MAXMSGSIZE, MAX_REQUEST_BYTES)
        # A client that asks and never reads costs a few replies, each sharing the one buffer of its
        # answer (sent without a copy), never a queue that grows with every request.
        self._reply.setsockopt(zmq.SNDHWM, REPLIES_HELD)
        self._reply.setsockopt(zmq.RCVHWM, REQUESTS_HELD)
        self._reply.setsockopt(zmq.RCVBUF, RECEIVE_BUFFER_BYTES)
        self._publish.setsockopt(zmq.LINGER, 0)
        address = f"[{host}]" if ":" in host else host
        if ":" in host:
            self._reply.setsockopt(zmq.IPV6, 1)
            self._publish.setsockopt(zmq.IPV6, 1)
        try:
            port = self._bind(address, port)
        except zmq.ZMQError as err:
            self._context.destroy(linger=0)
            raise OSError(err.errno, f"ports {port} and {port + 1}: {err.strerror}") from None
        self.host, self.port = host, port
        #: Blackboard names Groot2 may ask for: the main tree's and each use of a subtree's.
        self.blackboards = set(tree.blackboards)
        self._stopped = False
        self._thread = threading.Thread(target=self._serve, name="groot2", daemon=True)
        #: Requests answered, and requests dropped (a client past its share), for the curious.
        self.requests = 0
        self.dropped = 0
        #: Changed by every tick that changed a status: the ``S`` answer is made once per change.
        self._version = 0
        self._status_answer: tuple[int, bytes] = (-1, b"")

    def _bind(self, address: str, port: int) -> int:
        if port:
            self._reply.bind(f"tcp://{address}:{port}")
            self._publish.bind(f"tcp://{address}:{port + 1}")
            return port
        for _ in range(20):  # a free port whose next one is free too
            port = self._reply.bind_to_random_port(f"tcp://{address}", min_port=20000, max_port=60000)
            try:
                self._publish.bind(f"tcp://{address}:{port + 1}")
                return port
            except zmq.ZMQError:
                self._reply.unbind(self._reply.last_endpoint)
        raise zmq.ZMQError(zmq.EADDRINUSE)

    def start(self) -> GrootPublisher:
        """Starts answering."""
        self._thread.start()
        return self

    def __call__(self, record: Record) -> None:
        """Takes in a tick's changes (a few dictionary writes; the answers are made on request)."""
        if isinstance(record, TickRecord):
            codes = self.codes
            for node_id, state in record.nodes.items():
                if state.status == INVALID:
                    previous = codes.get(node_id, 0)
                    codes[node_id] = previous + 10 if 0 < previous < 10 else previous
                else:
                    codes[node_id] = CODES.get(state.status, 0)
            if record.nodes:
                self._version += 1

    def status_bytes(self) -> bytes:
        """The ``S`` answer: uid and status of every node, in uid order (made again only after a change)."""
        version = self._version  # read first: a tick that comes while the answer is made makes it again next time
        made, answer = self._status_answer
        if made == version:
            return answer
        codes = self.codes
        answer = b"".join(
            struct.pack("<HB", uid, codes.get(record_id, 0))
            for uid, record_id in enumerate(self.tree.record_ids, start=1)
        )
        self._status_answer = (version, answer)
        return answer

    def answer(self, frames: list[bytes]) -> list[bytes]:
        """The reply to one request."""
        header = frames[0] if frames else b""
        if len(header) != 6:
            return [b"error", b"wrong request header"]
        kind = header[1:2]
        head = bytes([PROTOCOL]) + header[1:6] + self.tree_id
        if kind == b"T":
            return [head, self.xml]
        if kind == b"S":
            return [head, self.status_bytes()]
        if kind == b"B":
            if len(frames) != 2:
                return [b"error", b"must be 2 parts message"]
            names = frames[1].decode("utf-8", "replace").split(";")
            return [head, _msgpack_nils([n for n in names if n in self.blackboards])]
        if kind == b"D":
            return [head, b"[]"]
        if kind == b"r":  # recording on or off (the second frame): nothing is kept either way
            return [head] if len(frames) == 2 else [b"error", b"must be 2 parts message"]
        if kind in (b"A", b"X"):  # no breakpoints to remove or disable
            return [head]
        if kind == b"t":  # the transitions recorded: none
            return [head, b""]
        return [b"error", b"Request not recognized"]

    def _serve(self) -> None:
        """Answers until :meth:`stop` ends the context, which wakes the waiting receive.

        It takes in at most :data:`RECEIVES_PER_S` requests a second, whoever sends them, and answers
        each client at most :data:`PEER_REQUESTS_PER_S` a second: a crowd of clients costs the run a
        bounded share of its process, and ZeroMQ takes requests from each client in turn, so Groot2
        among them is still answered.
        """
        clock = RealClock()
        budget_start_s, received = clock.now(), 0
        second_s, asked = clock.now(), {}  # per client, its requests in this second
        try:
            while True:
                frames = self._reply.recv_multipart()
                received += 1
                if received >= RECEIVE_BURST:
                    clock.sleep(RECEIVE_BURST / RECEIVES_PER_S - (clock.now() - budget_start_s))
                    budget_start_s, received = clock.now(), 0
                if len(frames) < 3 or frames[1] != b"":  # not a REQ socket's request (a REP socket drops it too)
                    continue
                now_s = clock.now()
                if now_s - second_s >= 1.0:
                    second_s, asked = now_s, {}
                count = asked[frames[0]] = asked.get(frames[0], 0) + 1
                if count > PEER_REQUESTS_PER_S:
                    self.dropped += 1
                    continue  # dropped: a flood costs a receive a request, never an answer
                try:
                    reply = self.answer(frames[2:])
                except Exception as err:  # noqa: BLE001 - a request we cannot answer must not end the publisher
                    reply = [b"error", f"cannot answer: {type(err).__name__}".encode()]
                # A ROUTER drops an answer, unsaid, to a client whose replies look held past REPLIES_HELD, and
                # it learns what the client took only when it reads its commands: requests coming back to
                # back on a busy machine left it counting replies long read, and an honest answer went.
                self._reply.getsockopt(zmq.EVENTS)  # reads them
                self._reply.send_multipart(frames[:2] + reply, copy=False)  # large answers: views of one buffer
                self.requests += 1
        except zmq.ZMQError:  # ETERM: stop() ended the context
            pass
        finally:
            self._reply.close(linger=0)

    def stop(self) -> None:
        """Stops answering and closes the sockets."""
        if self._stopped:
            return
        self._stopped = True
        self._publish.close(linger=0)
        started = self._thread.ident is not None
        if not started or not self._thread.is_alive():
            self._reply.close(linger=0)
        self._context.term()  # returns once the serving thread has closed its socket
        if started:
            self._thread.join()

"""The browser view's server on its own: what a page is sent, for a run in real and in virtual time."""

from __future__ import annotations

import asyncio
import json
import threading
import urllib.request
from concurrent.futures import ThreadPoolExecutor

import aiohttp

from autonomy.client import Client
from autonomy.mission import build_tree, load_mission
from autonomy.record import RunHeader, TreeState, record_from_json
from autonomy.runner import Runner
from autonomy.views.web import ViewServer
from tests.views.conftest import ROOT


def messages_of(url: str) -> list[tuple[str, str]]:
    """Every message of a page's WebSocket at ``url``, as (name, JSON), until the server closes it."""

    async def read() -> list[tuple[str, str]]:
        out = []
        async with aiohttp.ClientSession() as session, session.ws_connect(url) as socket:
            async for message in socket:
                name, _, data = message.data.partition("\n")
                out.append((name, data))
        return out

    return asyncio.run(read())


def test_a_run_in_virtual_time_is_previewed_then_served_whole():
    server = ViewServer("127.0.0.1", 0)
    server.start()
    received: list[tuple[str, str]] = []

    def read() -> None:
        received.extend(messages_of(server.url.replace("http", "ws") + "api/stream?from=0"))

    reader = threading.Thread(target=read)

    def start_reading(record) -> None:  # a page that is there when the run starts
        if isinstance(record, RunHeader):
            reader.start()
            while not server.hub._waiters:  # noqa: SLF001 - wait until it listens
                threading.Event().wait(0.01)

    spec = load_mission(ROOT / "missions" / "wander.yaml")
    client = Client.open("emu://?time=virtual&world=obstacles")
    try:
        summary = Runner(build_tree(spec), client, mission=spec.name, listeners=[server.hub, start_reading]).run()
        reader.join(timeout=30)
        events = received
        assert events[-1][0] == "end" and json.loads(events[-1][1])["outcome"] == "succeeded"
        previews = [json.loads(data) for kind, data in events if kind == "preview"]
        assert previews and all(len(batch) <= server.hub.PREVIEW_RECORDS for batch in previews)
        sent = [tick for kind, data in events if kind in ("ticks", "preview") for tick in json.loads(data)]
        assert len(sent) < summary.ticks  # a preview, not every tick
        whole = json.loads(urllib.request.urlopen(server.url + "api/run", timeout=10).read())
        assert len(whole["ticks"]) == summary.ticks and whole["end"]["outcome"] == "succeeded"
        header = record_from_json(whole["header"])
        previewed, exact = TreeState(header), TreeState(header)
        for tick in sent:
            previewed.apply(record_from_json(tick))
        for tick in whole["ticks"]:
            exact.apply(record_from_json(tick))
        assert previewed.nodes == exact.nodes  # the preview's tree ends where the run's does
        collisions = sum(e["kind"] == "collision" for t in sent for e in t.get("events", []))
        assert collisions == summary.collisions  # no event is lost from the log
    finally:
        client.close()
        server.stop()


def test_a_page_that_goes_while_its_websocket_opens_leaves_no_error(caplog):
    """A tab shown and hidden at once closes a socket still opening: normal, and silent."""
    import logging
    import socket
    import struct

    server = ViewServer("127.0.0.1", 0)
    server.start()
    request = (
        f"GET /api/next?run=x HTTP/1.1\r\nHost: 127.0.0.1:{server.port}\r\nUpgrade: websocket\r\n"
        "Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
    ).encode()
    try:
        with caplog.at_level(logging.ERROR):
            for _ in range(30):
                with socket.create_connection(("127.0.0.1", server.port)) as raw:
                    raw.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))  # a reset
                    raw.sendall(request)
            page = urllib.request.urlopen(server.url + "api/run", timeout=10).read()
        assert json.loads(page)["mode"] == "live"  # the server still serves
        assert [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR] == []
    finally:
        server.stop()


MALFORMED = """
import socket
from autonomy.views.web import ViewServer

server = ViewServer("127.0.0.1", 0)
server.start()
port = int(server.url.rstrip("/").rsplit(":", 1)[1])
for request in (
    b"GET /api/run HTTP/1.1\\r\\nHost: x\\r\\nX-Big: " + b"a" * 200_000 + b"\\r\\n\\r\\n",  # a header of 200 KB
    b"GET /static/" + b"../" * 5000 + b" HTTP/1.1\\r\\nHost: x\\r\\n\\r\\n",  # a path of 15 KB
):
    with socket.create_connection(("127.0.0.1", port), timeout=5) as client:
        client.sendall(request)
        print(client.recv(64).split(b"\\r\\n")[0].decode())
server.stop()
"""


def test_a_malformed_request_is_answered_400_and_leaves_no_traceback_in_the_terminal():
    import os
    import subprocess
    import sys

    result = subprocess.run(  # a process of its own: its stderr is the terminal's, as in a run
        [sys.executable, "-c", MALFORMED],
        capture_output=True, text=True, timeout=60, env={**os.environ, "PYTHONPATH": str(ROOT)},
    )  # fmt: skip
    assert result.stdout.splitlines() == ["HTTP/1.0 400 Bad Request"] * 2, result.stderr
    assert result.stderr == ""


def test_the_view_answers_only_by_address_and_only_its_own_page_s_websocket():
    server = ViewServer("127.0.0.1", 0)
    server.start()
    try:
        port = server.port

        def get(host: str) -> tuple[int, dict]:
            request = urllib.request.Request(f"http://127.0.0.1:{port}/", headers={"Host": host})
            try:
                with urllib.request.urlopen(request, timeout=5) as answer:
                    return answer.status, dict(answer.headers)
            except urllib.error.HTTPError as refused:
                return refused.code, dict(refused.headers)

        status, headers = get(f"127.0.0.1:{port}")
        assert status == 200 and "script-src 'self'" in headers["Content-Security-Policy"]
        assert "frame-ancestors 'none'" in headers["Content-Security-Policy"]
        assert get(f"localhost:{port}")[0] == 200 and get(f"[::1]:{port}")[0] == 200
        assert get(f"rebind.example:{port}")[0] == 403  # a name resolved to this machine by another site
        assert get("")[0] in (400, 403)

        async def socket_from(origin: str) -> str:
            async with aiohttp.ClientSession() as session:
                try:
                    url = f"ws://127.0.0.1:{port}/api/next?run="
                    async with session.ws_connect(url, headers={"Origin": origin}):
                        return "opened"
                except aiohttp.WSServerHandshakeError as refused:
                    return f"refused {refused.status}"

        def in_a_thread(origin: str) -> str:  # a browser test before may have left a loop running in this one
            with ThreadPoolExecutor(1) as pool:
                return pool.submit(asyncio.run, socket_from(origin)).result(timeout=30)

        assert in_a_thread("http://evil.example") == "refused 403"
        assert in_a_thread(f"http://127.0.0.1:{port}") == "opened"
    finally:
        server.stop()


def test_a_view_told_to_serve_on_a_name_takes_that_name_and_no_other():
    from autonomy.views.web import _own_host

    assert _own_host("Robot-Lab.local:8765", "robot-lab.local")  # --view-host robot-lab.local
    assert not _own_host("rebind.example:8765", "robot-lab.local")
    assert not _own_host("robot-lab.local:8765", "")  # served by address: no name at all
    assert _own_host("192.0.2.7:8765", "robot-lab.local") and _own_host("[::1]:8765") and _own_host("[::1]")
    for crafted in ("[::1]evil.com:8765", "localhost:abc", "[::1", "", ":8765", "127.0.0.1:80:80", "localhost."):
        assert not _own_host(crafted), crafted


def test_pages_that_never_read_a_replay_of_8_mb_hold_pieces_of_one_answer_never_copies(tmp_path):
    """60 clients ask ``api/run`` of a replayed 9 MB trace, 20 times each, and read nothing."""
    import subprocess
    import sys
    from collections import Counter

    from tests.crowd import memory_mb, non_readers

    mission = tmp_path / "wander.yaml"
    mission.write_text((ROOT / "missions" / "wander.yaml").read_text().replace("seconds: 60", "seconds: 900"))
    trace = tmp_path / "long.jsonl"
    made = subprocess.run(
        [sys.executable, "-m", "autonomy", "run", str(mission), "--fast", "--quiet", "--trace", str(trace)],
        cwd=ROOT, capture_output=True, timeout=120,
    )  # fmt: skip
    assert made.returncode == 0 and trace.stat().st_size > 8_000_000
    replay = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "replay", str(trace), "--view", "--view-port", "0"],
        cwd=ROOT, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
    )  # fmt: skip
    crowd = []
    try:
        port = int(replay.stderr.readline().rsplit(":", 1)[1].strip(" /\n"))
        first = b'"end":null}'
        while first.endswith(b'"end":null}'):  # until the whole trace is read in, and its answer made
            first = urllib.request.urlopen(f"http://127.0.0.1:{port}/api/run", timeout=30).read()
        start_mb = memory_mb(replay.pid)["VmRSS"]
        crowd = non_readers(port, 60)
        threading.Event().wait(3.0)  # the server writes what it can, then waits on them
        held_mb = memory_mb(replay.pid)["VmHWM"] - start_mb
        again = urllib.request.urlopen(f"http://127.0.0.1:{port}/api/run", timeout=30).read()  # a page still gets it
        answers = Counter(conn.recv(64).split(b"\r\n")[0] for conn in crowd)
    finally:
        for conn in crowd:
            conn.close()
        replay.terminate()
        _, said = replay.communicate(timeout=20)
    assert again == first and len(first) > 4_000_000
    assert held_mb < 60, f"{held_mb} MB held for 60 clients that read nothing (a copy each would be 2 x 60 x 4 MB)"
    assert answers == {b"HTTP/1.1 200 OK": 60}
    assert "Traceback" not in said


def test_answers_past_the_limit_are_refused_503_and_said_once(caplog, tmp_path):
    import logging

    from autonomy.mission import validate_text
    from tests.crowd import non_readers

    server = ViewServer("127.0.0.1", 0, mode="replay")
    server.max_answers_sending = 5
    text = (ROOT / "missions" / "wander.yaml").read_text().replace("seconds: 60", "seconds: 300")
    spec = validate_text(text, "wander.yaml", ROOT / "missions")
    client = Client.open("emu://?time=virtual&world=obstacles")
    Runner(build_tree(spec), client, mission=spec.name, listeners=[server.hub]).run()  # an answer of 3 MB
    client.close()
    server.start()
    crowd = []
    try:
        with caplog.at_level(logging.WARNING, logger="autonomy.view"):
            crowd = non_readers(server.port, 12, requests=1)
            threading.Event().wait(0.5)
            answers = sorted(conn.recv(64).split(b"\r\n")[0] for conn in crowd)
        assert answers == [b"HTTP/1.1 200 OK"] * 5 + [b"HTTP/1.1 503 Service Unavailable"] * 7
        said = [record.getMessage() for record in caplog.records if record.name == "autonomy.view"]
        assert said == ["view: too many answers are on their way at once"]
    finally:
        for conn in crowd:
            conn.close()
        server.stop()


def test_connections_past_the_limit_are_told_so_in_one_line_each_kind_and_closed(caplog):
    import logging
    import socket

    server = ViewServer("127.0.0.1", 0)
    server.max_connections = 20
    server.start()
    held = []
    try:
        with caplog.at_level(logging.WARNING, logger="autonomy.view"):
            for _ in range(20):
                held.append(socket.create_connection(("127.0.0.1", server.port), timeout=10))
            threading.Event().wait(0.3)
            refused = []
            for _ in range(30):
                with socket.create_connection(("127.0.0.1", server.port), timeout=10) as extra:
                    refused.append(extra.recv(200))
        assert all(answer.startswith(b"HTTP/1.1 503 Service Unavailable") for answer in refused)
        assert all(answer.endswith(b"too many connections at once\r\n") for answer in refused)
        said = [record.getMessage() for record in caplog.records if record.name == "autonomy.view"]
        assert said == ["view: 20 connections at once; another was refused"]  # once, not 30 times
        for conn in held:
            conn.close()
        held.clear()
        threading.Event().wait(0.3)
        page = urllib.request.urlopen(server.url + "api/run", timeout=10).read()  # served again once they went
        assert json.loads(page)["mode"] == "live"
    finally:
        for conn in held:
            conn.close()
        server.stop()


def test_a_loop_fault_such_as_no_file_left_to_accept_with_is_one_line_not_a_traceback_each_time(caplog):
    import errno
    import logging

    server = ViewServer("127.0.0.1", 0)
    fault = {"message": "socket.accept() out of system resource", "exception": OSError(errno.EMFILE, "Too many")}
    with caplog.at_level(logging.WARNING, logger="autonomy.view"):
        for _ in range(1000):
            server._loop_fault(server._loop, fault)  # noqa: SLF001 - what asyncio calls on each failed accept
    said = [record.getMessage() for record in caplog.records if record.name == "autonomy.view"]
    assert said == ["view: socket.accept() out of system resource: Too many"]
    assert all(record.exc_info is None for record in caplog.records)


def test_pages_waiting_for_the_next_run_are_woken_by_a_new_run_only_never_by_ticks():
    from autonomy.record import TickRecord

    server = ViewServer("127.0.0.1", 0)
    server.start()
    hub = server.hub
    spec = load_mission(ROOT / "missions" / "square.yaml")
    client = Client.open("emu://?time=virtual&world=square")
    ticks: list[TickRecord] = []
    header: list[RunHeader] = []
    try:
        Runner(build_tree(spec), client, mission=spec.name, listeners=[lambda r: (
            header.append(r) if isinstance(r, RunHeader) else ticks.append(r) if isinstance(r, TickRecord) else None
        )]).run()  # fmt: skip
        hub(header[0])
        watched = hub.run
        received: list[tuple[str, str]] = []
        reader = threading.Thread(target=lambda: received.extend(messages_of(
            server.url.replace("http", "ws") + f"api/next?run={watched}"
        )))  # fmt: skip
        reader.start()
        while not hub._run_waiters:  # noqa: SLF001 - until it waits
            threading.Event().wait(0.01)
        (waiting,) = hub._run_waiters  # noqa: SLF001
        for tick in ticks:
            hub(tick)
            threading.Event().wait(0.0005)  # ticks apart, each one woken at once
        threading.Event().wait(0.2)
        assert not waiting.is_set() and received == []  # no tick woke it
        hub(header[0])  # a new run
        reader.join(timeout=10)
        assert received == [("run", "{}")]
    finally:
        client.close()
        server.stop()


LOW_FILES = """
import resource, sys, runpy
resource.setrlimit(resource.RLIMIT_NOFILE, (300, 300))  # the hard limit too: the view cannot raise it
sys.argv = ["autonomy", *sys.argv[1:]]
runpy.run_module("autonomy", run_name="__main__")
"""


MORE_FILES = """
import resource
resource.setrlimit(resource.RLIMIT_NOFILE, (1024, 8192))  # a shell's usual soft limit, under a higher hard one
from autonomy.views.web import connection_limit
print(connection_limit(), *resource.getrlimit(resource.RLIMIT_NOFILE))
"""


def test_a_view_raises_its_soft_limit_of_files_to_serve_every_connection_it_would():
    """With a shell's soft limit of 1,024 files the cap of 4,096 connections silently fell to 640."""
    import subprocess
    import sys

    from autonomy.views.web import LISTEN_BACKLOG, MAX_CONNECTIONS, RESERVED_FILES

    said = subprocess.run([sys.executable, "-c", MORE_FILES], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert said.stdout.split() == [str(MAX_CONNECTIONS), str(MAX_CONNECTIONS + RESERVED_FILES + LISTEN_BACKLOG), "8192"]


def test_a_view_allowed_few_files_refuses_a_flood_past_them_in_one_line_and_serves_on(tmp_path):
    """When file descriptors ran out the view wrote hundreds of thousands of traceback lines."""
    import socket
    import subprocess
    import sys

    from autonomy.views.web import LISTEN_BACKLOG

    trace = tmp_path / "square.jsonl"
    made = subprocess.run(
        [sys.executable, "-m", "autonomy", "run", "missions/square.yaml", "--fast", "--quiet", "--trace", str(trace)],
        cwd=ROOT, capture_output=True, timeout=60,
    )  # fmt: skip
    assert made.returncode == 0
    replay = subprocess.Popen(
        [sys.executable, "-c", LOW_FILES, "replay", str(trace), "--view", "--view-port", "0"],
        cwd=ROOT, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
    )  # fmt: skip
    flood: list[socket.socket] = []
    try:
        first = replay.stderr.readline()  # the view says first that it serves fewer connections than it would
        port = int(replay.stderr.readline().rsplit(":", 1)[1].strip(" /\n"))
        for _ in range(600):  # twice what the process may hold
            flood.append(socket.create_connection(("127.0.0.1", port), timeout=10))
        threading.Event().wait(1.0)
        refused = 0
        for conn in flood:
            conn.settimeout(0.05)
            try:
                refused += conn.recv(64).startswith(b"HTTP/1.1 503")
            except TimeoutError:
                pass  # held, served
        for conn in flood:
            conn.close()
        flood.clear()
        threading.Event().wait(0.5)
        page = urllib.request.urlopen(f"http://127.0.0.1:{port}/api/run", timeout=10).read()  # and it serves on
    finally:
        for conn in flood:
            conn.close()
        replay.terminate()
        _, said = replay.communicate(timeout=20)
    assert json.loads(page)["mode"] == "replay"
    assert refused >= 600 - 16 - LISTEN_BACKLOG  # 16 held (and a burst taken in at once), the rest told 503
    assert first.startswith("view: at most 16 connections at once, not 4,096: the process may open 300 files")
    lines = [line for line in said.splitlines() if line.startswith("view:")]
    # each kind of refusal in one line: past its limit, and, on a busy machine where the refused ones are not
    # closed as fast as they come, the files run out for a moment too
    assert lines[0] == "view: 16 connections at once; another was refused", said
    assert lines[1:] in ([], ["view: socket.accept() out of system resource: Too many open files"]), said
    assert "Traceback" not in said


def test_a_page_s_socket_takes_no_big_message_two_origins_are_refused_and_a_silent_connection_is_let_go(monkeypatch):
    """A WebSocket frame of 4 MB half sent held 4 MB a connection; a silent connection was kept an hour."""
    import socket
    import time

    import autonomy.views.web as web_module

    monkeypatch.setattr(web_module, "IDLE_CONNECTION_S", 1.0)
    server = ViewServer("127.0.0.1", 0)
    server.start()
    try:
        port = server.port

        async def big_message() -> tuple[str, int | None]:
            async with aiohttp.ClientSession() as session:
                async with session.ws_connect(f"ws://127.0.0.1:{port}/api/next?run=x") as ws:
                    await ws.send_str("x" * 100_000)
                    message = await ws.receive(timeout=10)
                    return str(message.type), ws.close_code

        with ThreadPoolExecutor(1) as pool:
            _, code = pool.submit(asyncio.run, big_message()).result(timeout=30)
        assert code == 1009  # "message too big": closed, nothing held

        raw = (  # its own Origin, then a second one
            f"GET /api/run HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nOrigin: http://127.0.0.1:{port}\r\n"
            "Origin: http://evil.example\r\n\r\n"
        ).encode()
        with socket.create_connection(("127.0.0.1", port), timeout=10) as two:
            two.sendall(raw)
            assert two.recv(64).startswith(b"HTTP/1.1 403")

        with socket.create_connection(("127.0.0.1", port), timeout=10) as silent:
            started = time.monotonic()
            assert silent.recv(64) == b""  # closed by the server, not kept
            assert time.monotonic() - started < 5
    finally:
        server.stop()


def test_a_client_past_the_limit_that_asks_reads_the_503_rather_than_a_reset():
    import socket

    server = ViewServer("127.0.0.1", 0)
    server.max_connections = 2
    server.start()
    held = []
    try:
        held = [socket.create_connection(("127.0.0.1", server.port), timeout=10) for _ in range(2)]
        threading.Event().wait(0.3)
        for _ in range(5):
            with socket.create_connection(("127.0.0.1", server.port), timeout=10) as late:
                late.sendall(f"GET /api/run HTTP/1.1\r\nHost: 127.0.0.1:{server.port}\r\n\r\n".encode())
                threading.Event().wait(0.1)  # the request is there before the server answers and closes
                assert late.recv(200).startswith(b"HTTP/1.1 503 Service Unavailable")
    finally:
        for conn in held:
            conn.close()
        server.stop()


def test_a_preview_of_a_run_of_many_events_carries_the_last_ones_only():
    from autonomy.protocol import Status as Packet
    from autonomy.record import Event, Pose, TickRecord
    from autonomy.views.web import PREVIEW_EVENTS, RecordHub

    packet = Packet(0, True, False, False, 0, 0, 255, 0)
    ticks = [
        TickRecord(i, i * 0.05, packet, 200, True, 0.0, Pose(0, 0, 0), events=[Event("log", f"{i}:" + "x" * 990)])
        for i in range(1, 5001)
    ]
    kind, _, body = RecordHub("replay").event(ticks).partition("\n")
    previews = json.loads(body)
    assert kind == "preview" and len(previews) <= RecordHub.PREVIEW_RECORDS
    assert all(len(record["events"]) <= PREVIEW_EVENTS for record in previews)
    assert previews[-1]["events"][-1]["message"].startswith("5000:")  # the latest are kept
    assert len(body) < 3_000_000  # the whole run's events are 5 MB


def test_one_address_s_waiting_websockets_take_its_share_and_a_page_from_another_is_served():
    """The attack: one address opens WebSockets and leaves them waiting; its share fills, never the view."""
    server = ViewServer("127.0.0.1", 0)
    server.max_connections_per_address = 20
    server.start()
    port = server.port

    async def attack_then_honest() -> tuple[list[str], str, list[tuple[str, str]]]:
        url, origin = f"ws://127.0.0.1:{port}/api/next?run=", f"http://127.0.0.1:{port}"
        attacker = aiohttp.ClientSession(connector=aiohttp.TCPConnector(limit=0, local_addr=("127.0.0.1", 0)))
        honest = aiohttp.ClientSession(connector=aiohttp.TCPConnector(local_addr=("127.0.0.2", 0)))
        held, refused = [], []
        try:
            for _ in range(20):
                held.append(await attacker.ws_connect(url, headers={"Origin": origin}))
            for _ in range(10):  # past its share: each refused at once
                try:
                    await attacker.ws_connect(url, headers={"Origin": origin})
                    refused.append("opened")
                except (aiohttp.WSServerHandshakeError, aiohttp.ClientError) as err:
                    refused.append(type(err).__name__)
            async with honest.get(f"http://127.0.0.1:{port}/", headers={"Host": f"127.0.0.1:{port}"}) as page:
                seen = f"{page.status} {len(await page.read()) > 0}"
            async with honest.ws_connect(url, headers={"Origin": origin}) as socket:  # and its page's socket
                waiting = [("opened", str(not socket.closed))]
            return refused, seen, waiting
        finally:
            for socket in held:
                await socket.close()
            await attacker.close()
            await honest.close()

    try:
        with ThreadPoolExecutor(1) as pool:
            refused, page, socket = pool.submit(asyncio.run, attack_then_honest()).result(timeout=60)
        assert "opened" not in refused and len(refused) == 10
        assert page == "200 True" and socket == [("opened", "True")]
    finally:
        server.stop()


def test_an_ipv6_client_s_connections_are_counted_with_its_64_and_refused_past_its_share():
    import socket

    from autonomy.views.web import address_group

    server = ViewServer("::1", 0)
    server.max_connections_per_address = 8
    server.start()
    held = []
    try:
        for _ in range(8):
            held.append(socket.create_connection(("::1", server.port), timeout=10))
        threading.Event().wait(0.3)
        assert server.connections_from[address_group("::1")] == 8
        assert address_group("::1") == address_group("::2") == "::/64"  # any address of that /64 is the same one
        with socket.create_connection(("::1", server.port), timeout=10) as extra:
            assert extra.recv(200).startswith(b"HTTP/1.1 503 Service Unavailable")
    finally:
        for conn in held:
            conn.close()
        server.stop()

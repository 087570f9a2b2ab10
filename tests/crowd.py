"""Clients that hold on and never read: the crowd the servers are tested and measured against (loopback only)."""

from __future__ import annotations

import asyncio
import re
import signal
import socket
import subprocess
import sys
import threading
from pathlib import Path

import aiohttp
import zmq

ROOT = Path(__file__).resolve().parents[1]


def big_mission(path: Path, conditions: int = 1600, drive_s: float = 8.0, wait_s: float = 0.0) -> Path:
    """A mission of ``conditions + 5`` nodes (6 with a wait): its conditions pass in its first tick, it waits
    ``wait_s``, then it drives ``drive_s``."""
    lines = ["mission: big", "world: empty", "tree:", "  sequence:", "    - sequence:"]
    lines += ["        - battery_above: {level: 0}"] * conditions
    if wait_s:
        lines.append(f"    - wait: {{seconds: {wait_s:g}}}")
    lines.append(f"    - move: {{speed: 1, seconds: {drive_s:g}}}")
    path.write_text("\n".join(lines) + "\n")
    return path


def memory_mb(pid: int) -> dict[str, int]:
    """A process's resident memory now and at its peak, and its address space, in MB (empty once it is gone)."""
    try:
        text = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return {}
    found = {key: re.search(key + r":\s+(\d+)", text) for key in ("VmRSS", "VmHWM", "VmSize")}
    return {key: int(value.group(1)) // 1024 for key, value in found.items() if value}  # a zombie has none


class PeakMemory:
    """Watches a process's peak resident memory (VmHWM), in MB, every 50 ms until :meth:`close`."""

    def __init__(self, pid: int) -> None:
        self.pid, self.peak_mb = pid, 0
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._watch)
        self._thread.start()

    def _watch(self) -> None:
        while not self._done.wait(0.05):
            self.peak_mb = max(self.peak_mb, memory_mb(self.pid).get("VmHWM", 0))

    def close(self) -> None:
        self._done.set()
        self._thread.join()


class Run:
    """``autonomy run ARGS`` in a process of its own, with the ports it prints of its view and Groot2 publisher."""

    def __init__(self, *args: str) -> None:
        self.process = subprocess.Popen(
            [sys.executable, "-m", "autonomy", "run", *args],
            cwd=ROOT,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.view_port = self.groot_port = 0
        self.said: list[str] = []
        while not (("--view" not in args or self.view_port) and ("--groot" not in args or self.groot_port)):
            line = self.process.stderr.readline()
            if not line:
                raise RuntimeError("the run ended before it served: " + "".join(self.said))
            self.said.append(line)
            if found := re.search(r"view: http://127\.0\.0\.1:(\d+)/", line):
                self.view_port = int(found.group(1))
            if found := re.search(r"groot2: attach to .* port (\d+)", line):
                self.groot_port = int(found.group(1))
        self.start = memory_mb(self.process.pid)

    def finish(self, timeout_s: float) -> tuple[bool, int, str]:
        """Waits for the run to end by itself, then ends the view it goes on serving (Ctrl-C).

        Returns:
            Whether the run ended by itself in time, the exit code and everything it said.
        """
        ended = False
        reader = threading.Thread(target=self._read_until_over, daemon=True)
        reader.start()
        reader.join(timeout_s)
        ended = any("the run is over" in line for line in self.said)
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
        try:
            code = self.process.wait(timeout=20)
        finally:
            if self.process.poll() is None:
                self.process.kill()
        reader.join(5)
        return ended, code, "".join(self.said) + self.process.stderr.read()

    def _read_until_over(self) -> None:
        for line in self.process.stderr:
            self.said.append(line)
            if "the run is over" in line:
                return


class GrootCrowd:
    """ZeroMQ DEALER clients that ask for the tree and the statuses, over and over, and never read a reply."""

    def __init__(self, port: int, clients: int) -> None:
        self.context = zmq.Context()
        self.sockets = []
        for _ in range(clients):
            dealer = self.context.socket(zmq.DEALER)
            dealer.setsockopt(zmq.LINGER, 0)
            dealer.setsockopt(zmq.SNDHWM, 0)  # no limit on this side: every request it can, goes
            dealer.connect(f"tcp://127.0.0.1:{port}")
            self.sockets.append(dealer)
        self.sent = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._ask, daemon=True)
        self._thread.start()

    def _ask(self) -> None:
        while not self._stop.is_set():
            for dealer in self.sockets:
                for kind in (b"T", b"S"):
                    try:
                        dealer.send_multipart([b"", b"\x02" + kind + b"\x00\x00\x00\x01"], zmq.NOBLOCK)
                        self.sent += 1
                    except zmq.Again:
                        pass
            self._stop.wait(0.05)

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self.context.destroy(linger=0)


def non_readers(
    port: int, clients: int, requests: int = 20, path: str = "/api/run", source: str = ""
) -> list[socket.socket]:
    """Connections that each ask ``path`` ``requests`` times at once and never read an answer (from ``source``)."""
    ask = f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode() * requests
    crowd = []
    for _ in range(clients):
        conn = socket.socket()
        conn.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # a small window: the answers back up in the server
        if source:
            conn.bind((source, 0))
        conn.connect(("127.0.0.1", port))
        conn.sendall(ask)
        crowd.append(conn)
    return crowd


class IdleWebSockets:
    """WebSockets open on ``api/next`` that wait and say nothing, in a thread of their own.

    They come from ``addresses`` loopback addresses in turn (127.0.0.10 and on): a server takes only
    its share of connections from one address.
    """

    def __init__(self, port: int, count: int, run: str = "watched", addresses: int = 1) -> None:
        self._addresses = addresses
        self.opened = 0
        self._loop = asyncio.new_event_loop()
        self._ready = threading.Event()
        self._done: asyncio.Event | None = None
        self._thread = threading.Thread(target=self._loop.run_until_complete, args=(self._hold(port, count, run),))
        self._thread.daemon = True
        self._thread.start()
        if not self._ready.wait(120):
            raise RuntimeError(f"only {self.opened} of {count} WebSockets opened")

    async def _hold(self, port: int, count: int, run: str) -> None:
        self._done = asyncio.Event()
        many = [(f"127.0.0.{10 + n}", 0) for n in range(self._addresses)]
        local = [("127.0.0.1", 0)] if self._addresses == 1 else many
        sessions = [aiohttp.ClientSession(connector=aiohttp.TCPConnector(limit=0, local_addr=a)) for a in local]
        try:
            sockets = []
            url = f"http://127.0.0.1:{port}/api/next?run={run}"
            for start in range(0, count, 200):
                batch = range(start, min(start + 200, count))
                opened = await asyncio.gather(
                    *(sessions[n % len(sessions)].ws_connect(url, autoping=False) for n in batch)
                )
                sockets += opened
                self.opened = len(sockets)
            self._ready.set()
            await self._done.wait()
            for ws in sockets:
                await ws.close()
        finally:
            for session in sessions:
                await session.close()

    def close(self) -> None:
        if self._done is not None:
            self._loop.call_soon_threadsafe(self._done.set)
        self._thread.join(timeout=30)


def tick_gaps_ms(trace: Path, from_s: float = 0.0) -> list[float]:
    """The gaps between a trace's ticks from ``from_s`` into the run on, in milliseconds."""
    import json

    times = [json.loads(line)["time_s"] for line in trace.read_text().splitlines() if line.startswith('{"type":"tick"')]
    times = [time_s for time_s in times if time_s >= from_s]
    return [(later - earlier) * 1000 for earlier, later in zip(times, times[1:], strict=False)]

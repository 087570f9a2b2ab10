"""A live class under load: 300 students checking as they type, running and handing in, for 5 minutes.

Starts ``autonomy class serve garage`` (a process of its own, on loopback) with a roster of N,
then plays N students from this process, each from an address of their own (127.0.x.y) and on
their own schedule: a check every 2 s (of the text as it is typed: a typo now and then), a run
every 30 s, a hand-in every 3 minutes. Every request is timed from before it is sent to its
whole answer. The teacher's page follows the class all along, as it does (``GET
/api/class?after=V``, answered at each change): the longest wait between two of its answers is
how late a change may be shown.

Reports, per kind of request: how many, the median, 95th percentile and slowest answer; how
many were refused (and why), and how many got no answer at all (lost); the server's resident
memory at the end (its own, and with its grading workers); and the class folder's size.
Targets: p95 under 100 ms for a check, 2 s for a run and 3 s for a hand-in; none refused, none
lost; the server under 500 MB; the class folder under 1 GB; the teacher's page answered at
least every 2 s.

With ``--dask N``, the class is graded on a Dask LocalCluster of N worker processes on loopback
(one thread each, started in a process of its own) in place of the server's own workers.

Also reports the server's own CPU time (its process alone, not its workers'), a request.

Usage: python benchmarks/liveclass.py [--seconds S] [--students N] [--dask N]
"""

from __future__ import annotations

import argparse
import asyncio
import collections
import csv
import os
import random
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import aiohttp

ROOT = Path(__file__).resolve().parents[1]
SOLUTION = (ROOT / "exercises" / "solutions" / "garage.yaml").read_text()
TYPED = [SOLUTION[:cut] for cut in range(40, len(SOLUTION), 40)] + [SOLUTION.replace("move", "mvoe", 1), SOLUTION]


#: Each student's pace: seconds between two checks, two runs, two hand-ins.
CHECK_EVERY_S, RUN_EVERY_S, HANDIN_EVERY_S = 2.0, 30.0, 180.0


async def student(url: str, code: str, address: str, seconds: float, seen: dict, rng: random.Random) -> None:
    """One student, from ``address``: checks as they type, runs and hands in, each on their own schedule."""
    timeout = aiohttp.ClientTimeout(total=120)
    connector = aiohttp.TCPConnector(limit=0, local_addr=(address, 0))
    async with aiohttp.ClientSession(timeout=timeout, connector=connector) as session:
        await _student(session, url, code, seconds, seen, rng)


async def _student(session, url: str, code: str, seconds: float, seen: dict, rng: random.Random) -> None:
    headers = {"Authorization": f"Bearer {code}"}
    start = time.monotonic()
    await asyncio.sleep(rng.uniform(0, CHECK_EVERY_S))  # the class does not start typing in the same millisecond
    next_run, next_handin = start + rng.uniform(0, RUN_EVERY_S), start + rng.uniform(0, HANDIN_EVERY_S)
    typed = 0
    while time.monotonic() - start < seconds:
        now = time.monotonic()
        if now >= next_handin:
            kind, text, next_handin = "handin", SOLUTION, next_handin + HANDIN_EVERY_S
        elif now >= next_run:
            kind, text, next_run = "run", SOLUTION, next_run + RUN_EVERY_S
        else:
            kind, text = "check", TYPED[typed % len(TYPED)]
            typed += 1
        sent = time.monotonic()
        try:
            async with session.post(f"{url}api/{kind}", json={"mission": text}, headers=headers) as answer:
                await answer.read()
                status = answer.status
        except (aiohttp.ClientError, asyncio.TimeoutError) as err:
            seen[kind]["lost"].append(type(err).__name__)
            continue
        took = time.monotonic() - sent
        if status in (200, 422):
            seen[kind]["times"].append(took)
        else:
            seen[kind]["refused"].append(status)
        if kind == "check":
            await asyncio.sleep(max(0.0, CHECK_EVERY_S - took))


async def glance(session, url: str, headers: dict, seen: dict, again: asyncio.Event) -> None:
    """The teacher's class at a glance, as their page asks for it: once at a time, again if the class changed since."""
    while True:
        again.clear()
        sent = time.monotonic()
        try:
            async with session.get(url + "api/overview", headers=headers) as answer:
                await answer.read()
                (seen["glances"] if answer.status == 200 else seen["refused"]).append(time.monotonic() - sent)
        except (aiohttp.ClientError, asyncio.TimeoutError) as err:
            seen["lost"].append(type(err).__name__)
        if not again.is_set():
            return


async def teacher(session, url: str, token: str, seconds: float, seen: dict) -> None:
    """The teacher's page: the class table, asked again at each change, and the class at a glance after it.

    Keeps its answers' times, the versions seen, and the class at a glance's answers' times.
    """
    headers = {"Authorization": f"Bearer {token}"}
    start, version = time.monotonic(), None
    seen["glances"], again, glancing = [], asyncio.Event(), None
    while time.monotonic() - start < seconds:
        path = "api/class" if version is None else f"api/class?after={version}"
        sent = time.monotonic()
        try:
            async with session.get(url + path, headers=headers) as answer:
                table = await answer.json()
        except (aiohttp.ClientError, asyncio.TimeoutError) as err:
            seen["lost"].append(type(err).__name__)
            await asyncio.sleep(1)
            continue
        seen["times"].append(time.monotonic() - sent)
        seen.setdefault("answered", []).append(time.monotonic() - start)
        if answer.status != 200:
            seen["refused"].append(answer.status)
            continue
        version = table["version"]
        seen["versions"] = version
        again.set()
        if glancing is None or glancing.done():
            glancing = asyncio.ensure_future(glance(session, url, headers, seen, again))
    if glancing is not None:
        await glancing


def address(k: int) -> str:
    """The ``k``-th student's loopback address: 127.0.1.1, 127.0.1.2, ... (the teacher's machine is 127.0.0.1)."""
    return f"127.0.{1 + k // 250}.{1 + k % 250}"


async def play(url: str, codes: list[str], token: str, seconds: float) -> dict:
    seen = {kind: {"times": [], "refused": [], "lost": []} for kind in ("check", "run", "handin", "class")}
    timeout = aiohttp.ClientTimeout(total=120)
    async with aiohttp.ClientSession(timeout=timeout, connector=aiohttp.TCPConnector(limit=0)) as session:
        await asyncio.gather(
            teacher(session, url, token, seconds, seen["class"]),
            *(student(url, code, address(i), seconds, seen, random.Random(i)) for i, code in enumerate(codes)),
        )
    return seen


def memory_mb(pid: int) -> tuple[int, int]:
    """A process's resident memory, and its own with every process under it (its grading workers), in MB."""

    def rss_kb(p: int) -> int:
        try:
            return int(re.search(r"VmRSS:\s+(\d+)", Path(f"/proc/{p}/status").read_text()).group(1))
        except (OSError, AttributeError):
            return 0

    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parents[int(entry.name)] = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                pass
    family, grown = {pid}, True
    while grown:
        more = {p for p, parent in parents.items() if parent in family} - family
        family |= more
        grown = bool(more)
    return rss_kb(pid) // 1024, sum(rss_kb(p) for p in family) // 1024


def folder_mb(folder: Path) -> float:
    return sum(f.stat().st_size for f in folder.rglob("*") if f.is_file()) / 2**20


#: A LocalCluster of N workers on loopback, in a process of its own: prints its address, lives until stdin closes.
CLUSTER = """
import sys
import dask, distributed
with dask.config.set({"distributed.worker.daemon": False}):
    with distributed.LocalCluster(n_workers=int(sys.argv[1]), threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster:
        print(cluster.scheduler_address, flush=True)
        sys.stdin.read()
"""


def cpu_s(pid: int) -> float:
    """A process's own CPU time so far (user and system, not its children's)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=300.0)
    parser.add_argument("--students", type=int, default=300)
    parser.add_argument("--dask", type=int, default=0, help="grade on a LocalCluster of this many workers")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        roster = Path(folder) / "roster.csv"
        roster.write_text(
            "id,name,submission\n" + "".join(f"{1000 + i},Student {i},s{i}\n" for i in range(args.students))
        )
        cluster, on = None, []
        if args.dask:
            cluster = subprocess.Popen(
                [sys.executable, "-c", CLUSTER, str(args.dask)],
                cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
            )  # fmt: skip
            on = ["--dask", cluster.stdout.readline().strip()]
        server = subprocess.Popen(
            [sys.executable, "-m", "autonomy", "class", "serve", "garage", "--roster", str(roster)]
            + ["--dir", str(Path(folder) / "class"), "--port", "0", *on],
            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip
        try:
            said = server.stderr.readline() + server.stderr.readline()
            token = re.search(r"/teacher#(\S+)", said).group(1)
            url = server.stdout.readline().strip()
            with (Path(folder) / "class" / "codes.csv").open() as stream:
                codes = [row["code"] for row in csv.DictReader(stream)]
            before_s = cpu_s(server.pid)
            seen = asyncio.run(play(url, codes, token, args.seconds))
            server_cpu_s = cpu_s(server.pid) - before_s
            rss_mb, all_mb = memory_mb(server.pid)
            kept_mb = folder_mb(Path(folder) / "class")
        finally:
            server.terminate()
            server.wait(timeout=30)
            if cluster is not None:
                cluster.communicate("", timeout=60)
    where = f"on a LocalCluster of {args.dask} workers" if args.dask else "by the server's own workers"
    print(f"{args.students} students, {args.seconds:g} s, each from an address of their own; graded {where}")
    requests = sum(len(got["times"]) + len(got["refused"]) for got in seen.values())
    print(f"the server's own CPU: {server_cpu_s / requests * 1000:.2f} ms a request ({requests} requests)")
    print(
        f"the server's memory at the end: {rss_mb} MB, {all_mb} MB with its workers; the class folder: {kept_mb:.0f} MB"
    )
    print(f"{'':<8}{'answered':>9}{'median':>9}{'p95':>9}{'slowest':>9}{'refused':>9}{'lost':>6}")
    for kind, got in seen.items():
        if kind == "class":
            continue
        times = sorted(got["times"])
        p95 = times[int(len(times) * 0.95)] if times else float("nan")
        print(
            f"{kind:<8}{len(times):>9}{statistics.median(times) * 1000 if times else 0:>7.0f}ms{p95 * 1000:>7.0f}ms"
            f"{(times[-1] if times else 0) * 1000:>7.0f}ms{len(got['refused']):>9}{len(got['lost']):>6}"
        )
        if got["refused"]:
            print(f"         refused: {dict(collections.Counter(got['refused']))}")
    answered = [0.0] + [t for t in seen["class"].get("answered", []) if t <= args.seconds]  # while the class works
    gap_s = max((b - a for a, b in zip(answered, answered[1:], strict=False)), default=float("inf"))
    print(
        f"the teacher's page: {len(seen['class']['times'])} answers for {seen['class'].get('versions', 0)} changes "
        f"of the class table, {len(seen['class']['refused'])} refused, {len(seen['class']['lost'])} lost; "
        f"the longest wait between two: {gap_s:.2f} s"
    )
    glances = sorted(seen["class"]["glances"])
    if glances:
        print(
            f"the class at a glance: {len(glances)} answers, median {statistics.median(glances) * 1000:.0f} ms, "
            f"slowest {glances[-1] * 1000:.0f} ms"
        )
    p95 = {
        kind: sorted(seen[kind]["times"])[int(len(seen[kind]["times"]) * 0.95)] for kind in ("check", "run", "handin")
    }
    lost = sum(len(got["lost"]) for got in seen.values())
    refused = sum(len(got["refused"]) for got in seen.values())
    met = p95["check"] < 0.1 and p95["run"] < 2.0 and p95["handin"] < 3.0 and not lost and not refused
    met = met and all_mb < 500 and kept_mb < 1024 and gap_s <= 2.0
    print(
        "target: check p95 < 100 ms, run p95 < 2 s, hand-in p95 < 3 s, none refused or lost, "
        f"memory < 500 MB, folder < 1 GB, the teacher's page within 2 s: {'meets' if met else 'MISSES'} target"
    )


if __name__ == "__main__":
    main()

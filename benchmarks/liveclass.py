"""A live class under load: 30 students checking as they type, running and handing in, for 5 minutes.

Starts ``autonomy class serve garage`` (a process of its own, on loopback) with a roster of 30,
then plays 30 students from this process, each on its own schedule: a check every 0.5 s (of
the text as it is typed: a typo now and then), a run every 10 s, a hand-in every 60 s. Every
request is timed from before it is sent to its whole answer. The teacher's page follows the
class all along, as it does (``GET /api/class?after=V``, answered at each change).

Reports, per kind of request: how many, the median, 95th percentile and slowest answer; how
many were refused (and why), and how many got no answer at all (lost); and the server's
resident memory at the end. Targets: p95 under 100 ms for a check and under 1 s for a run;
no request lost.

Usage: python benchmarks/liveclass.py [--seconds S] [--students N]
"""

from __future__ import annotations

import argparse
import asyncio
import collections
import csv
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


async def student(session, url: str, code: str, seconds: float, seen: dict, rng: random.Random) -> None:
    headers = {"Authorization": f"Bearer {code}"}
    start = time.monotonic()
    next_run, next_handin = start + rng.uniform(0, 10), start + rng.uniform(0, 60)
    typed = 0
    while time.monotonic() - start < seconds:
        now = time.monotonic()
        if now >= next_handin:
            kind, text, next_handin = "handin", SOLUTION, next_handin + 60
        elif now >= next_run:
            kind, text, next_run = "run", SOLUTION, next_run + 10
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
            await asyncio.sleep(max(0.0, 0.5 - took))


async def teacher(session, url: str, token: str, seconds: float, seen: dict) -> None:
    """The teacher's page: the class table, asked again at each change; its answers' times and the versions seen."""
    headers = {"Authorization": f"Bearer {token}"}
    start, version = time.monotonic(), None
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
        if answer.status != 200:
            seen["refused"].append(answer.status)
            continue
        version = table["version"]
        seen["versions"] = version


async def play(url: str, codes: list[str], token: str, seconds: float) -> dict:
    seen = {kind: {"times": [], "refused": [], "lost": []} for kind in ("check", "run", "handin", "class")}
    timeout = aiohttp.ClientTimeout(total=120)
    async with aiohttp.ClientSession(timeout=timeout, connector=aiohttp.TCPConnector(limit=0)) as session:
        await asyncio.gather(
            teacher(session, url, token, seconds, seen["class"]),
            *(student(session, url, code, seconds, seen, random.Random(i)) for i, code in enumerate(codes)),
        )
    return seen


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=300.0)
    parser.add_argument("--students", type=int, default=30)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        roster = Path(folder) / "roster.csv"
        roster.write_text(
            "id,name,submission\n" + "".join(f"{1000 + i},Student {i},s{i}\n" for i in range(args.students))
        )
        server = subprocess.Popen(
            [sys.executable, "-m", "autonomy", "class", "serve", "garage", "--roster", str(roster)]
            + ["--dir", str(Path(folder) / "class"), "--port", "0"],
            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip
        try:
            said = server.stderr.readline() + server.stderr.readline()
            token = re.search(r"/teacher#(\S+)", said).group(1)
            url = server.stdout.readline().strip()
            with (Path(folder) / "class" / "codes.csv").open() as stream:
                codes = [row["code"] for row in csv.DictReader(stream)]
            seen = asyncio.run(play(url, codes, token, args.seconds))
            status = Path(f"/proc/{server.pid}/status").read_text()
            rss_mb = int(re.search(r"VmRSS:\s+(\d+)", status).group(1)) // 1024
        finally:
            server.terminate()
            server.wait(timeout=30)
    print(f"{args.students} students, {args.seconds:g} s; the server's memory at the end: {rss_mb} MB")
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
    print(
        f"the teacher's page: {len(seen['class']['times'])} answers for {seen['class'].get('versions', 0)} changes "
        f"of the class table, {len(seen['class']['refused'])} refused, {len(seen['class']['lost'])} lost"
    )
    check_p95 = sorted(seen["check"]["times"])[int(len(seen["check"]["times"]) * 0.95)]
    run_p95 = sorted(seen["run"]["times"])[int(len(seen["run"]["times"]) * 0.95)]
    lost = sum(len(got["lost"]) for got in seen.values())
    verdict = "meets" if check_p95 < 0.1 and run_p95 < 1.0 and not lost else "MISSES"
    print(f"target: check p95 < 100 ms, run p95 < 1 s, nothing lost: {verdict} target")


if __name__ == "__main__":
    main()

"""The class's LMS services against an LMS run in this process on loopback (tests/liveclass/lms_platform.py).

Serves garage to no one (a ClassServer in this process, its LMS given), then:
  - roster: the teacher's launch, then the course's 300 students read from the LMS (4 pages of 100, an access
    token asked for first) and put on the class table: the time from the launch's answer to the table showing them;
  - scores: 300 marks queued, then sent by the class's own link (its thread), to the LMS answering at once and
    to one whose every answer takes ``--latency-ms`` to begin (an LMS far away): the time until the LMS has all;
  - down: the LMS down for ``--down-s`` seconds with 300 marks waiting, then back: how long after it is back
    the LMS has every mark, and whether each arrived exactly once.

Targets (issue 45): 300 scores sent in < 60 s; every queued score exactly once after a minute down.

Usage: python benchmarks/lms.py [--down-s 60] [--latency-ms 100]
"""

from __future__ import annotations

import argparse
import collections
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from autonomy.liveclass import lms  # noqa: E402
from tests.liveclass.lms_platform import FakeLms  # noqa: E402
from tests.liveclass.test_lms import open_class, teacher_opens  # noqa: E402

STUDENTS = 300


def until(what, timeout_s: float = 600.0) -> float:
    """Waits until ``what()`` holds; the seconds it took."""
    start = time.perf_counter()
    while not what():
        if time.perf_counter() - start > timeout_s:
            raise SystemExit(f"not within {timeout_s} s")
        time.sleep(0.005)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--down-s", type=float, default=60.0)
    parser.add_argument("--latency-ms", type=float, default=100.0)
    args = parser.parse_args()
    platform = FakeLms()
    platform.enrol(STUDENTS)
    with tempfile.TemporaryDirectory() as folder:
        server, store = open_class(Path(folder), platform)
        try:
            start = time.perf_counter()
            teacher_opens(server, platform)
            took = until(lambda: len(store.students()) == STUDENTS) + (time.perf_counter() - start)
            print(f"roster: {STUDENTS} students read and on the class table {took:.2f} s after the teacher's launch")
            for round_, latency_s in enumerate((0.0, args.latency_ms / 1000)):
                platform.delay_s = latency_s
                before = len(platform.sent())
                for k in range(STUDENTS):
                    lms.queue_score(store, f"{k:05d}", (k + round_) % 11, 10.0, f"round {round_}")
                server.lms_link.nudge()
                took = until(lambda before=before: len(platform.sent()) == before + STUDENTS)
                print(f"scores: {STUDENTS} sent in {took:.2f} s, each answer {latency_s * 1000:.0f} ms late")
            platform.delay_s = 0.0
            platform.down()
            before = len(platform.sent())
            for k in range(STUDENTS):
                lms.queue_score(store, f"{k:05d}", 10, 10.0, "after the LMS was down")
            server.lms_link.nudge()
            time.sleep(args.down_s)
            waiting = len(lms.waiting(store))
            platform.up()
            took = until(lambda: len(platform.sent()) == before + STUDENTS)
            time.sleep(2.0)  # anything sent twice would come now
            again = collections.Counter(s["userId"] for s in platform.sent()[before:])
            once = len(again) == STUDENTS and set(again.values()) == {1}
            print(f"down: {waiting} waiting after {args.down_s:g} s down; every one at the LMS {took:.2f} s after it "
                  f"was back; each exactly once: {once} ({sum(again.values())} sent)")  # fmt: skip
        finally:
            server.stop()
            store.close()
            platform.close()


if __name__ == "__main__":
    main()

"""Hostile input and a faulty link, measured.

Measures:
  - the validator on mutated missions (tests/fuzz/mutants.py; 100,000 by default): how many
    raised anything but the project's own MissionInvalid (target 0), and the slowest one;
  - hostile files checked by `autonomy check` in a fresh process (a 5 MB file, 30,000 keys,
    40,000 children, 1,000 levels of brackets, descriptions as large as a file may be, a chain
    of 2,000 subtrees, a subtree bomb):
    wall time of each (target: every rejection under 1 s);
  - the fault matrix: the toy robot of tests/client/toyrobot.py (an independent reading of
    the protocol) running the matrix mission, and the emulator running missions/square.yaml,
    over 20 seeds of each fault: runs completed, failed cleanly (a summary, the robot
    stopped or the stop said unconfirmed) and hung.

Usage: python benchmarks/hostile.py [MUTANTS]
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from autonomy.client import Client  # noqa: E402
from autonomy.mission import MissionInvalid, load_mission, validate_text  # noqa: E402
from autonomy.runner import SUCCEEDED, Runner  # noqa: E402
from autonomy.source import MAX_FILE_BYTES  # noqa: E402
from tests.client.test_fault_matrix import FAULTS, run_on_line  # noqa: E402
from tests.fuzz.mutants import mutant  # noqa: E402

SEEDS = range(20)


def validator(count: int) -> None:
    untyped: Counter = Counter()
    first: dict[str, int] = {}
    slowest = (0.0, -1)
    times = []
    for number in range(count):
        source, text = mutant(number)
        start = time.perf_counter()
        try:
            validate_text(text, source, ROOT / "missions")
        except MissionInvalid:
            pass
        except Exception as err:  # noqa: BLE001 - counted: the figure is how many there are
            untyped[type(err).__name__] += 1
            first.setdefault(type(err).__name__, number)
        took = time.perf_counter() - start
        times.append(took)
        slowest = max(slowest, (took, number))
    print(f"validator: {count:,} mutants, {sum(untyped.values())} untyped exceptions {dict(untyped) or ''}")
    for name, number in first.items():
        print(f"  first {name}: mutant {number}")
    print(
        f"  per mutant: median {statistics.median(times) * 1000:.2f} ms, "
        f"slowest {slowest[0] * 1000:.1f} ms (mutant {slowest[1]})"
    )


def hostile_files() -> None:
    files = {
        "5 MB of comments": "mission: t\ntree: stop\n" + "# x\n" * 1_300_000,
        "30,000 keys": "mission: t\ntree: stop\n" + "".join(f"k{i}: {i}\n" for i in range(30_000)),
        "40,000 children": "mission: t\ntree:\n  sequence:\n" + "    - stop\n" * 40_000,
        "1,000 levels of brackets": "mission: t\ntree: " + "[" * 1000 + "]" * 1000 + "\n",
        # the YAML parser's slowest reads of a file at the size limit: words of one letter, one quoted text
        "a description of words": "mission: t\ndescription: " + "a " * (MAX_FILE_BYTES // 2 - 30) + "\ntree: stop\n",
        "a quoted description": 'mission: t\ndescription: "' + "x" * (MAX_FILE_BYTES - 60) + '"\ntree: stop\n',
        "2,000 chained subtrees": "mission: t\nsubtrees:\n"
        + "".join(f"  s{i}: {{subtree: s{i + 1}}}\n" for i in range(2000))
        + "  s2000: stop\ntree: {subtree: s0}\n",
        "a subtree bomb (2^30 nodes)": "mission: t\nsubtrees:\n"
        + "".join(f"  s{i}: {{sequence: [{{subtree: s{i + 1}}}, {{subtree: s{i + 1}}}]}}\n" for i in range(30))
        + "  s30: stop\ntree: {subtree: s0}\n",
    }
    with tempfile.TemporaryDirectory() as tmp:
        for name, text in files.items():
            path = Path(tmp) / "m.yaml"
            path.write_text(text)
            start = time.perf_counter()
            result = subprocess.run(
                [sys.executable, "-m", "autonomy", "check", str(path)], capture_output=True, text=True, cwd=ROOT
            )
            took = time.perf_counter() - start
            said = (result.stderr or result.stdout).strip().splitlines()[0][:90]
            print(f"  {name:28} {len(text) / 1e6:5.2f} MB  exit {result.returncode}  {took:.2f} s  {said}")


def classify(summary) -> str:
    if summary.outcome == SUCCEEDED:
        return "completed"
    return "failed cleanly" if summary.paragraph else "failed"


def guarded(run) -> str:
    result: list = []
    worker = threading.Thread(target=lambda: result.append(run()), daemon=True)
    worker.start()
    worker.join(timeout=120)
    return "hung" if worker.is_alive() else classify(result[0])


def emulator_run(fault: str, rate: float, seed: int):
    spec = load_mission(ROOT / "missions" / "square.yaml")
    faults = f"{fault}={rate}" if fault != "none" else "none"
    client = Client.open(f"emu://?world=box&time=virtual&seed={seed}&faults={faults}")
    summary = Runner.for_mission(spec, client, max_seconds=60).run()
    client.close()
    return summary


def fault_matrix() -> None:
    print(f"fault matrix, {len(SEEDS)} seeds each: completed / failed cleanly / hung")
    for label, run in (
        ("toy robot, matrix mission", lambda f, r, s: run_on_line(f, r, s)[0]),
        ("emulator, square", emulator_run),
    ):
        print(f"  {label}")
        for fault, rate in FAULTS:
            counts = Counter(guarded(lambda s=seed, f=fault, r=rate, go=run: go(f, r, s)) for seed in SEEDS)
            print(
                f"    {fault:8} {rate:<5g} {counts['completed']:3} / {counts['failed cleanly']:3} / "
                f"{counts['hung']:3}" + (f"  (other: {counts['failed']})" if counts["failed"] else "")
            )


def main() -> None:
    count = int(sys.argv[1]) if len(sys.argv) > 1 else 100_000
    print("hostile files, `autonomy check` in a fresh process:")
    hostile_files()
    fault_matrix()
    validator(count)


if __name__ == "__main__":
    main()

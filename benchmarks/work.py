"""Work done a tick, counted in machine instructions: figures this machine's noise cannot move.

Wall-clock figures on a shared 2-core machine vary by 15% or more between identical runs, more
than the targets they are meant to check. Valgrind (``cachegrind``, no cache simulation) counts
the instructions a process executes instead, the same every time. Each set-up runs in a fresh
process under it, and the count of a process that only imports is taken off.

Measures, for the wander mission (1 minute, 1,201 ticks, in-process emulator, virtual time):
  - instructions a tick alone (what grading runs; 3 seeds' worth is a student's run);
  - what the trace writer adds (target: at most 10%).

Usage: python benchmarks/work.py   (needs valgrind: apt-get install valgrind)
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SETUP = """
import os, sys, tempfile
from autonomy.client import Client
from autonomy.mission import build_tree, load_mission
from autonomy.runner import Runner
from autonomy.trace import TraceWriter
spec = load_mission({mission!r})
"""
RUN = """
listeners = []
if {traced}:
    stream = open(os.path.join(tempfile.mkdtemp(), "run.jsonl"), "w", encoding="utf-8")
    listeners.append(TraceWriter(stream))
client = Client.open("emu://?time=virtual&world=obstacles")
summary = Runner(build_tree(spec), client, mission=spec.name, listeners=listeners).run()
print("ticks", summary.ticks, file=sys.stderr)
"""


def instructions(code: str) -> tuple[int, int]:
    """Runs ``code`` in a fresh Python under cachegrind; returns (instructions, ticks it reported)."""
    result = subprocess.run(
        [
            "valgrind",
            "--tool=cachegrind",
            "--cache-sim=no",
            "--cachegrind-out-file=/dev/null",
            sys.executable,
            "-c",
            code,
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    )
    count = re.search(r"I\s+refs:\s+([\d,]+)", result.stderr)
    ticks = re.search(r"^ticks (\d+)$", result.stderr, re.MULTILINE)
    assert count, result.stderr
    return int(count.group(1).replace(",", "")), int(ticks.group(1)) if ticks else 0


def main() -> None:
    if shutil.which("valgrind") is None:
        print("benchmarks/work.py: skipped, it needs valgrind (apt-get install valgrind)")
        return
    setup = SETUP.format(mission=str(ROOT / "missions" / "wander.yaml"))
    base, _ = instructions(setup)
    plain, ticks = instructions(setup + RUN.format(traced=False))
    traced, _ = instructions(setup + RUN.format(traced=True))
    per_tick = (plain - base) / ticks
    added = (traced - plain) / ticks
    print(f"wander, 1 minute ({ticks:,} ticks), alone: {per_tick / 1e3:,.0f} thousand instructions a tick")
    print(f"with the trace writer: +{added / 1e3:,.1f} thousand a tick, +{added / per_tick * 100:.1f}% (target <= 10%)")


if __name__ == "__main__":
    main()

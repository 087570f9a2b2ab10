"""Work done a tick, counted in machine instructions: figures this machine's noise cannot move.

Wall-clock figures on a shared 2-core machine vary by 15% or more between identical runs, more
than the targets they are meant to check. Valgrind (``cachegrind``, no cache simulation) counts
the instructions a process executes instead, the same every time. Each set-up runs in a fresh
process under it, and the count of the same set-up ended before the run is taken off; both
end at once, without the interpreter's clean-up (paid once at exit, not by the ticks).

Measures, for the wander mission (1 minute, 1,201 ticks, in-process emulator, virtual time),
run as `autonomy run` runs it (what existed before the run left out of garbage collections):
  - instructions a tick alone (what grading runs, without that: the same count within 0.1%
    for a run whose records nobody keeps; 3 seeds' worth is a student's run);
  - what the trace writer adds (target: at most 10%);
  - what the browser view adds to the run: its server running, every record handed to it
    (target: at most 5%). Its page's work (a headless Chromium, another process) is not in
    this count: ``benchmarks/views.py`` measures the run with a real page on the clock.

The trace writer flushes its file every 0.1 s of real time. Under valgrind a run takes some twenty
times as long, so it would flush some twenty times as often a tick as it does outside; the trace's
count therefore stretches that 0.1 s by the slowdown measured on the run alone (its time under
valgrind over its time outside), so that it flushes as often a tick as a real run.

The count is not quite the same for the same work laid out differently in memory: the length of
the code itself moves a set-up's figure by up to 1% (about 4,000 instructions a tick). Each set-up
is therefore counted three times, behind comments of three lengths, and the median taken.

The terminal view is left to ``benchmarks/views.py``: it draws by the clock (at most 1/160 of
a run going flat out), and under valgrind every tick takes fifty times as long, so it would
take the run for one in real time and draw ten times a second.

Usage: python benchmarks/work.py   (needs valgrind: apt-get install valgrind)
"""

from __future__ import annotations

import os
import re
import shutil
import statistics
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
LISTENERS = {
    "alone": "listeners = []",
    "trace": """
stream = open(os.path.join(tempfile.mkdtemp(), "run.jsonl"), "w", encoding="utf-8")
listeners = [TraceWriter(stream)]
""",
    "browser": """
from autonomy.views.web import ViewServer
server = ViewServer("127.0.0.1", 0)
server.start()
listeners = [server.hub]
""",
}
#: As `autonomy run` runs a mission: in a settled heap (see ``autonomy.runner.settled_heap``),
#: whose own clean-up at the start is taken off with the rest of the set-up.
SETTLED = "\nfrom autonomy.runner import settled_heap\nwith settled_heap():\n    pass\n"
RUN = """
import time
from autonomy.runner import settled_heap
client = Client.open("emu://?time=virtual&world=obstacles")
with settled_heap():
    started = time.perf_counter()
    summary = Runner(build_tree(spec), client, mission=spec.name, listeners=listeners).run()
    print("ticks", summary.ticks, "seconds", time.perf_counter() - started, file=sys.stderr)
"""
#: The trace's flushes as often a tick under valgrind as outside it (see above).
STRETCH = "\nfrom autonomy.trace import FlushTimer\nFlushTimer.FLUSH_S *= {slowdown!r}\n"
EXIT = "\nos._exit(0)\n"
#: Comments put before the code, so that each set-up is counted laid out three ways (see above).
LAYOUTS = ("", "#" + "-" * 13 + "\n", "#" + "-" * 57 + "\n")
#: The most each may add to a tick, in percent.
TARGETS = {"trace": 10.0, "browser": 5.0}


def run_seconds(stderr: str) -> float:
    """The run's own seconds, as the code printed them."""
    found = re.search(r"^ticks \d+ seconds ([\d.e-]+)$", stderr, re.MULTILINE)
    assert found, stderr
    return float(found.group(1))


def native_seconds(code: str) -> float:
    """Runs ``code`` in a fresh Python outside valgrind; returns the run's own seconds (best of 3)."""
    times = []
    for _ in range(3):
        result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
        times.append(run_seconds(result.stderr))
    return min(times)


def instructions(code: str) -> tuple[int, int, float]:
    """Runs ``code`` in a fresh Python under cachegrind.

    Returns:
        Its instructions, the ticks it reported (0: none), and the run's own seconds (0.0: none).
    """
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
        env={**os.environ, "PYTHONHASHSEED": "0"},  # the same dictionaries and sets every time
        capture_output=True,
        text=True,
        check=True,
    )
    count = re.search(r"I\s+refs:\s+([\d,]+)", result.stderr)
    ticks = re.search(r"^ticks (\d+) ", result.stderr, re.MULTILINE)
    assert count, result.stderr
    seconds = run_seconds(result.stderr) if ticks else 0.0
    return int(count.group(1).replace(",", "")), int(ticks.group(1)) if ticks else 0, seconds


def main() -> None:
    if shutil.which("valgrind") is None:
        print("benchmarks/work.py: skipped, it needs valgrind (apt-get install valgrind)")
        return
    setup = SETUP.format(mission=str(ROOT / "missions" / "wander.yaml"))
    per_tick: dict[str, float] = {}
    slowdown = 1.0
    for name, listeners in LISTENERS.items():
        if name == "trace":
            listeners += STRETCH.format(slowdown=slowdown)
        # Both end at once, without the interpreter's clean-up (a last collection over every object
        # kept): that is paid once at exit, not by the ticks.
        counts = []
        for layout in LAYOUTS:
            before, _, _ = instructions(layout + setup + listeners + SETTLED + EXIT)
            total, ticks, seconds = instructions(layout + setup + listeners + RUN + EXIT)
            counts.append((total - before) / ticks)
        per_tick[name] = statistics.median(counts)
        if name == "alone":
            slowdown = seconds / native_seconds(setup + listeners + RUN + EXIT)
    alone = per_tick["alone"]
    print(
        f"wander, 1 minute ({ticks:,} ticks), alone: {alone / 1e3:,.0f} thousand instructions a tick "
        f"(valgrind ran it {slowdown:.0f} times slower)"
    )
    for name, target in TARGETS.items():
        added = per_tick[name] - alone
        print(
            f"with the {name} {'writer' if name == 'trace' else 'view'}: +{added / 1e3:,.1f} thousand a tick, "
            f"+{added / alone * 100:.1f}% (target <= {target:g}%)"
        )


if __name__ == "__main__":
    main()

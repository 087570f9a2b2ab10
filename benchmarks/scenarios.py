"""How fast a mission's scenarios run: 50 scenarios of 60 s, as ``autonomy test`` runs them.

Writes a scenario file of 50 scenarios for the wander mission (its own world, ``obstacles``,
each scenario a seed of its own, 60 s each: 3,000 simulated seconds in all, each run checked for
no more than 3 collisions and its nodes' statuses followed), then times ``autonomy test`` on it as
a whole process (its start included), median of three. Target: under 10 s on two cores.

Usage: python benchmarks/scenarios.py [--scenarios N]
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def scenario_text(count: int) -> str:
    """``count`` scenarios of 60 s for the wander mission, a seed each."""
    items = "".join(
        f"  - name: wanders for a minute on seed {seed}\n"
        f"    world: obstacles\n"
        f"    seeds: [{seed}]\n"
        f"    time_limit_s: 61\n"
        f"    expect:\n"
        f"      criteria:\n"
        f"        - max_collisions: 3\n"
        f"    nodes:\n"
        f"      - node: avoid\n"
        f"        runs: true\n"
        for seed in range(1, count + 1)
    )
    return "scenarios:\n" + items


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--scenarios", type=int, default=50, help="how many scenarios (default 50)")
    options = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        shutil.copy(ROOT / "missions" / "wander.yaml", folder / "wander.yaml")
        (folder / "wander.test.yaml").write_text(scenario_text(options.scenarios))
        took, last = [], None
        for _ in range(3):
            started = time.perf_counter()
            last = subprocess.run(
                [sys.executable, "-m", "autonomy", "test", str(folder)], capture_output=True, text=True, check=False
            )
            took.append(time.perf_counter() - started)
        assert last is not None
        summary = [line for line in last.stdout.splitlines() if " scenarios: " in line]
        print(summary[0] if summary else last.stdout + last.stderr)
        print(
            f"{options.scenarios} scenarios of 60 s, autonomy test as a whole process: "
            f"median {statistics.median(took):.2f} s "
            f"(runs {', '.join(f'{t:.2f}' for t in took)} s; target < 10 s)"
        )


if __name__ == "__main__":
    main()

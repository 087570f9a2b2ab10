"""How much a plan that never looks earns in the exercises that say it must look.

For `garage`, `opening` and `bump`, a fixed plan (a fixed distance east; north a fixed distance,
then east; round the box a fixed way) is tried at every distance on a grid. Measures, out of 10:
  - the best distance on the exercise's public seeds (what a student tuning by `autonomy grade`
    finds), and what that distance earns with the hidden seeds of three teachers' secrets
    (target: at most 4, 40% of the marks, both);
  - the best distance on 150 other seeds (what any fixed plan could hope for; target: at most 4);
  - the reference solution on the public seeds and 40 hidden seeds of each of three secrets
    (target: 10).

Usage: python benchmarks/fixed_plans.py [--seeds N]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path

from autonomy.classroom import grade_one, load_exercise
from autonomy.classroom.exercise import Exercise, Seed

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from tests.classroom.fixed_plans import FIXED_PLANS as PLANS  # noqa: E402 - the tests' own plans

SECRETS = (b"first secret of a teacher", b"second secret of another", b"third secret, a long one")


def best(exercise: Exercise, plans: dict[int, Path]) -> tuple[float, int]:
    """The best total of the plans on the exercise's seeds, and its distance."""
    return max((grade_one(exercise, path.stem, path).total, distance) for distance, path in plans.items())


def main() -> None:
    """Prints the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=150, help="other seeds to try every plan on (default 150)")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    for name, (text, distances) in PLANS.items():
        exercise = load_exercise(ROOT / "exercises" / f"{name}.yaml")
        plans = {}
        for distance in distances:
            plans[distance] = folder / f"{name}_{distance}.yaml"
            plans[distance].write_text(text.format(d=distance))
        public, distance = best(exercise, plans)
        hidden = [grade_one(exercise.with_secret(s), "tuned", plans[distance]).total for s in SECRETS]
        others = dataclasses.replace(exercise, seeds=[Seed(s) for s in range(10_000, 10_000 + args.seeds)])
        anywhere, where = best(others, plans)
        reference = ROOT / "exercises" / "solutions" / f"{name}.yaml"
        many = dataclasses.replace(exercise, hidden_seeds=40)
        solution = [grade_one(many.with_secret(s), name, reference).total for s in SECRETS]
        verdict = "meets target" if max(public, *hidden, anywhere) <= 4 and min(solution) == 10 else "MISSES target"
        print(
            f"{name}: a fixed plan tuned to the {len(exercise.seeds)} public seeds ({distance} mm): {public:g} / 10 "
            f"there, {', '.join(f'{h:g}' for h in hidden)} with the hidden seeds of three secrets; the best fixed "
            f"plan on {args.seeds} other seeds ({where} mm): {anywhere:g}; the reference solution with 40 hidden "
            f"seeds: {', '.join(f'{s:g}' for s in solution)} (target: fixed at most 4, reference 10): {verdict}"
        )


if __name__ == "__main__":
    main()

"""Plans that never look, for the exercises that say a mission must: each a mission with a distance to tune.

Tried at every distance of its grid by the tests (a fixed plan tuned to the public seeds earns at
most 40%) and by ``benchmarks/fixed_plans.py`` (what the best of them earns on many seeds).
"""

FIXED_PLANS = {
    # a fixed distance east
    "garage": ("mission: fixed\ntree:\n  move: {{speed: 2, distance_mm: {d}}}\n", range(1300, 2800, 50)),
    # north a fixed distance, then east through where the opening might be
    "opening": (
        "mission: fixed\ntree:\n  sequence:\n    - turn: {{left: 90}}\n    - move: {{speed: 2, distance_mm: {d}}}\n"
        "    - turn: {{right: 90}}\n    - move: {{speed: 2, distance_mm: 1900}}\n",
        range(100, 1700, 50),
    ),
    # round the north side of where the box might be, a fixed distance, and back into line: never a bump
    "bump": (
        "mission: fixed\ntree:\n  sequence:\n    - turn: {{left: 90}}\n    - move: {{speed: 2, distance_mm: 400}}\n"
        "    - turn: {{right: 90}}\n    - move: {{speed: 2, distance_mm: {d}}}\n    - turn: {{right: 90}}\n"
        "    - move: {{speed: 2, distance_mm: 400}}\n",
        range(1100, 2600, 50),
    ),
}

"""A file reads the same whichever parser PyYAML has: with libyaml or without, in PyYAML 6.0 to 6.0.4.

The reader reads every file with PyYAML's parser written in Python (``autonomy.source``). These
tests run the hostile inputs through the mission reader twice: here, where PyYAML comes with
libyaml, and in a fresh interpreter where libyaml cannot be imported, as in an install of PyYAML
without it. The problems must be the same, to the character. ``make test-pyyaml`` runs them
against each PyYAML release from 6.0 that has a wheel for the Python running them.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
import yaml

from autonomy.mission import MissionInvalid, validate_text
from tests.fuzz.mutants import ROOT, mutant

#: Hostile files whose reading the parsers' differences reach: deep nesting, tabs, escapes,
#: numbers, tags, aliases, and the mistakes a student makes.
HOSTILE = {
    "1,000 levels of brackets": "mission: t\ntree: " + "[" * 1000 + "]" * 1000 + "\n",
    "5,000 levels of brackets": "world: garage\ndescription: " + "[" * 5000 + "]" * 5000 + "\n",
    "200,000 open brackets": "x: " + "[" * 200_000,
    "1,000 levels of braces": "mission: t\ntree: " + "{a: " * 1000 + "b" + "}" * 1000 + "\n",
    "300 levels of blocks": "mission: t\ntree:\n" + "".join("  " * (i + 1) + "sequence:\n" for i in range(300)),
    "a tab in the indentation": "mission: t\ntree:\n  sequence:\n\t- stop\n",
    "a tab inside a value": "mission: t\ndescription: so it stops in front of the po\tst.\ntree: stop\n",
    "a tab after a colon": "mission:\tt\ntree: stop\n",
    "a tab at the end of a line": "mission: t\t\ntree: stop\n",
    "a tab before a comment": "mission: t\t# the name\ntree: stop\n",
    "a tab in a flow list": "mission: t\ntree:\n  beep: {tones: [1,\t2]}\n",
    "a tab in a key": "mission: t\ntr\tee: stop\n",
    "a tab in quotes": 'mission: "t\tx"\ntree: stop\n',
    "a tab on a line of nothing else": "mission: t\n\t\ntree: stop\n",
    "a tab after a byte-order mark": "\ufeff\tmission: t\ntree: stop\n",
    "a tab after a line that ends in CR": "mission: t\rtree:\r  \t- stop\r",
    "question marks after a number": "mission: t\ntree:\n  move: {speed: 2, distance_mm: 50????}\n",
    "a lone surrogate": "mission: t\ud800\ntree: stop\n",
    "an escaped lone surrogate": 'mission: "t\\ud800x"\ntree: stop\n',
    "an escaped lone surrogate in a key": 'mission: t\n"\\udfff": 1\ntree: stop\n',
    "an escaped backslash before u": 'mission: "t\\\\ud800"\ntree: stop\n',
    "an escaped lone surrogate after a byte-order mark": '\ufeffmission: "t\\ud800x"\ntree: stop\n',
    "an escaped lone surrogate after a line that ends in CR": 'mission: t\rdescription: "\\ud800"\rtree: stop\r',
    "a surrogate pair escaped as in JSON": 'mission: "\\ud83d\\ude00"\ntree: stop\n',
    "a refused value in a list as a key": "mission: t\n? [!!binary a]\n: 1\ntree: stop\n",
    "a NUL": "mission: t\x00\ntree: stop\n",
    "an escape": "mission: t\x1b[31m\ntree: stop\n",
    "an unknown escape": 'mission: "a\\qb"\ntree: stop\n',
    "5,000 digits": "mission: t\ntree:\n  wait: {seconds: " + "9" * 5000 + "}\n",
    "NaN": "mission: t\ntree:\n  wait: {seconds: .nan}\n",
    "a tag that runs code": 'mission: t\ntree: !!python/object/apply:os.system ["echo hi"]\n',
    "a binary tag": "mission: t\ntree:\n  wait: {seconds: !!binary 'a'}\n",
    "an alias bomb": "mission: t\na: &a [" + ", ".join(["x"] * 100) + "]\nb: &b [" + ", ".join(["*a"] * 100) + "]\n",
    "an alias without anchor": "mission: *x\ntree: stop\n",
    "a second document": "mission: t\n---\ntree: stop\n",
    "out of line": "mission: t\ntree:\n  sequence:\n    - stop\n   - beep\n",
    "a colon in a value": "mission: t: u\ntree: stop\n",
    "an open quote": "mission: 't\ntree: stop\n",
    "an open list": "mission: t\ntree: {sequence: [stop, beep\n",
    "a directive": "%YAML 1.1\n%TAG ! tag:x,2002:\n--- !x\nmission: t\n",
    "a block scalar indicator": "mission: |x\n  t\ntree: stop\n",
}
#: Mutants of the shipped missions: one in ten reads differently in libyaml than in PyYAML's Python parser.
MUTANTS = 400


def cases() -> dict[str, str]:
    """Every hostile case by name: the ones above and the first mutants."""
    return {**HOSTILE, **{f"mutant {number}": mutant(number)[1] for number in range(MUTANTS)}}


def read(text: str) -> list[str]:
    """What the mission reader says of ``text``: its problems, or the mission's name when it has none."""
    try:
        return [validate_text(text, "m.yaml", ROOT / "missions").name]
    except MissionInvalid as err:
        return [str(problem) for problem in err.problems]


#: Runs in a fresh interpreter, where PyYAML cannot import libyaml.
WITHOUT_LIBYAML = """
import json, sys
sys.modules["yaml._yaml"] = None  # as PyYAML installed without libyaml: 'import yaml._yaml' fails
import yaml
from tests.mission.test_parsers import cases, read
print(json.dumps({"with_libyaml": yaml.__with_libyaml__, "read": {name: read(text) for name, text in cases().items()}}))
"""


def test_a_file_reads_the_same_with_libyaml_and_without():
    if not yaml.__with_libyaml__:
        pytest.skip(f"this PyYAML {yaml.__version__} has no libyaml: it has one parser")
    run = subprocess.run(
        [sys.executable, "-c", WITHOUT_LIBYAML], cwd=ROOT, capture_output=True, text=True, timeout=120, check=True
    )
    without = json.loads(run.stdout)
    assert without["with_libyaml"] is False
    here = {name: read(text) for name, text in cases().items()}
    assert here.keys() == without["read"].keys()
    differ = {name: (here[name], without["read"][name]) for name in here if here[name] != without["read"][name]}
    assert not differ


@pytest.mark.parametrize(
    ("name", "said"),
    [
        ("1,000 levels of brackets", "m.yaml:2:106: nested more than 100 levels deep"),
        ("1,000 levels of braces", "m.yaml:2:403: nested more than 100 levels deep"),
        (
            "a tab in the indentation",
            "m.yaml:4:1: a tab: indent with spaces (YAML does not allow tabs for indentation)",
        ),
        (
            "a tab inside a value",
            "m.yaml:2:44: a tab outside quotes: use spaces (YAML takes a tab only inside quotes or a | or > block)",
        ),
        ("a tab after a colon", "m.yaml:1:9: a tab outside quotes"),
        ("a tab at the end of a line", "m.yaml:1:11: a tab at the end of the line: remove it"),
        ("a tab on a line of nothing else", "m.yaml:2:1: a tab on a line of nothing else: remove it"),
        ("a tab after a byte-order mark", "m.yaml:1:1: a tab: indent with spaces"),
        ("a tab after a line that ends in CR", "m.yaml:3:3: a tab: indent with spaces"),
        ("a tab before a comment", "m.yaml:1:11: a tab outside quotes"),
        ("a tab in a flow list", "m.yaml:3:20: a tab outside quotes"),
        ("a tab in a key", "m.yaml:2:3: a tab outside quotes"),
        ("question marks after a number", "m.yaml:3:35: a '{' mapping is not closed with '}'"),
        ("an escaped lone surrogate", "m.yaml:1:12: an escape for a code that is not a character"),
        ("an escaped lone surrogate in a key", "m.yaml:2:2: an escape for a code that is not a character"),
        ("an escaped lone surrogate after a byte-order mark", "m.yaml:1:12: an escape for a code"),
        ("an escaped lone surrogate after a line that ends in CR", "m.yaml:2:15: an escape for a code"),
        ("a surrogate pair escaped as in JSON", "m.yaml:1:11: an escape for a code that is not a character"),
        ("a refused value in a list as a key", "m.yaml:2:4: the tag tag:yaml.org,2002:binary is not allowed"),
    ],
)
def test_where_the_parsers_part_the_python_parser_decides(name, said):
    """libyaml takes some of these files and refuses others elsewhere; the reader says what PyYAML's parser says."""
    [found] = read(HOSTILE[name])
    assert found.startswith(said)


def test_a_tab_inside_quotes_and_an_escaped_backslash_are_text():
    assert read(HOSTILE["a tab in quotes"]) == ["t\tx"]
    assert read(HOSTILE["an escaped backslash before u"]) == ["t\\ud800"]

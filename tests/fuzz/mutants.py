"""Mutants of the shipped mission files: the kinds of damage a classroom (or an adversary) does.

Deterministic for a seed, so a failing mutant can be made again from its number.
"""

from __future__ import annotations

import random
import re
from pathlib import Path

from tests.harness import mission_files

ROOT = Path(__file__).resolve().parents[2]
SOURCES = mission_files([*ROOT.glob("missions/*.yaml"), *ROOT.glob("exercises/*/*.yaml")])

#: Characters and snippets that break files in interesting ways.
PALETTE = [
    "\x00",
    "\x07",
    "\x1b",
    "\x7f",
    "\x85",
    "\x9b",
    "\u2028",
    "\ufeff",
    "\ud800",
    "\t",
    "\r",
    "\n",
    " ",
    "[",
    "]",
    "{",
    "}",
    ":",
    ": ",
    "-",
    "- ",
    ",",
    "#",
    "&a",
    "*a",
    "!!",
    "!!python/object/apply:os.system ",
    "'",
    '"',
    "\\",
    "%",
    "@",
    "`",
    "|",
    ">",
    "?",
    "<<: ",
    "~",
    "é",
    "名",
    "\U0001f916",
]
NUMBERS = [
    ".nan",
    ".inf",
    "-.inf",
    "1e400",
    "1.0e-300",
    "-0",
    "0",
    "9" * 5000,
    "0x" + "f" * 500,
    "0b" + "1" * 300,
    "1" * 60 + ".5",
    "1:" * 50 + "1",
    "True",
    "null",
    "''",
    "3.14159",
    "-1",
    "999999999999",
    "07777",
]
WORDS = [
    "sequence",
    "selector",
    "parallel",
    "repeat",
    "retry",
    "timeout",
    "invert",
    "subtree",
    "subtrees",
    "move",
    "turn",
    "beep",
    "servo",
    "wait",
    "log",
    "stop",
    "collided",
    "mission",
    "tree",
    "tick_hz",
    "plugins",
    "world",
    "do",
    "children",
    "name",
    "seconds",
    "speed",
    "left",
    "right",
    "times",
    "memory",
    "this",
    "boxx",
]
_NUMBER = re.compile(r"(?<![\w.])-?\d+(\.\d+)?(?![\w.])")
_WORD = re.compile(r"[a-z_]{2,}")


def _insert(text: str, rng: random.Random) -> str:
    at = rng.randrange(len(text) + 1)
    return text[:at] + rng.choice(PALETTE) * rng.choice([1, 1, 1, 2, 50]) + text[at:]


def _delete(text: str, rng: random.Random) -> str:
    at = rng.randrange(len(text) + 1)
    return text[:at] + text[at + rng.randint(1, 12) :]


def _lines(text: str, rng: random.Random) -> str:
    lines = text.split("\n")
    i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
    kind = rng.randrange(4)
    if kind == 0:
        lines.insert(j, lines[i])
    elif kind == 1:
        del lines[i]
    elif kind == 2:
        lines[i], lines[j] = lines[j], lines[i]
    else:
        lines[i] = rng.choice(["", " ", "  ", "\t", "    "]) + lines[i].lstrip(" ") * rng.choice([0, 1])
    return "\n".join(lines)


def _number(text: str, rng: random.Random) -> str:
    found = list(_NUMBER.finditer(text))
    if not found:
        return _insert(text, rng)
    match = rng.choice(found)
    return text[: match.start()] + rng.choice(NUMBERS) + text[match.end() :]


def _word(text: str, rng: random.Random) -> str:
    found = list(_WORD.finditer(text))
    if not found:
        return _insert(text, rng)
    match = rng.choice(found)
    replacement = rng.choice(WORDS) if rng.random() < 0.8 else match.group()[::-1]
    return text[: match.start()] + replacement + text[match.end() :]


def _nest(text: str, rng: random.Random) -> str:
    at = rng.randrange(len(text) + 1)
    depth = rng.choice([2, 50, 120, 1000])
    return text[:at] + "[" * depth + "x" + "]" * depth + text[at:]


def _truncate(text: str, rng: random.Random) -> str:
    return text[: rng.randrange(len(text) + 1)]


MUTATIONS = [_insert, _insert, _delete, _lines, _lines, _number, _number, _word, _word, _nest, _truncate]


def mutant(number: int) -> tuple[str, str]:
    """Mutant ``number``: (the file it came from, its text)."""
    rng = random.Random(f"mutant {number}")
    source = rng.choice(SOURCES)
    text = source.read_text(encoding="utf-8")
    for _ in range(rng.choice([1, 1, 2, 3])):
        text = rng.choice(MUTATIONS)(text, rng)
    return source.name, text

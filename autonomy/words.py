"""Counts in plain words, for every layer's messages (this module imports nothing of ours)."""

from __future__ import annotations


def plural(count: int, word: str, words: str = "") -> str:
    """``1 tick``, ``2 ticks`` (``words`` for a plural not made with -s: ``retries``)."""
    return f"{count} {word if count == 1 else words or word + 's'}"

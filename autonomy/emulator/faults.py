"""Fault injection for the emulator's wire: seeded, and off unless asked for.

A spec is a comma-separated list, e.g. ``drop=0.01,corrupt=0.01,no=0.02,pace``:

=========== ==================================================================
``drop=P``    each byte, either direction, is lost with probability P
``corrupt=P`` each byte, either direction, has random bits flipped with probability P
``delay=P``   a reply is held back ``delay_s`` seconds with probability P
``delay_s=S`` how long a delayed reply waits (default 0.3 s)
``garbage=P`` after a frame, 1-4 unsolicited random bytes arrive with probability P
``no=P``      a valid command is answered ``NO`` (and not carried out) with probability P
``pace``      every byte costs its wire time, 10 bits at the link's baud rate
=========== ==================================================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import ClassVar

PROBABILITIES = ("drop", "corrupt", "delay", "garbage", "no")


class FaultSpecError(ValueError):
    """A fault spec that cannot be parsed."""


@dataclass(frozen=True)
class FaultSpec:
    """Which faults to inject and how often (probabilities 0..1)."""

    drop: float = 0.0
    corrupt: float = 0.0
    delay: float = 0.0
    delay_s: float = 0.3
    garbage: float = 0.0
    no: float = 0.0
    pace: bool = False
    #: True when anything is injected or paced: the wire can change what a frame meets. Worked out
    #: once (asked before every frame an in-process emulator answers) and set with the fields: an
    #: attribute set later would cost every read of the spec (Python would give up its compact
    #: form). Each spec has its own; ``ClassVar`` keeps it out of the dataclass's fields.
    active: ClassVar[bool]

    def __post_init__(self) -> None:
        object.__setattr__(self, "active", self.disturbing or self.pace)  # a frozen dataclass sets its own fields so

    @property
    def disturbing(self) -> bool:
        """Whether any fault can lose, delay, damage or refuse traffic (pacing alone only times it)."""
        return any(getattr(self, name) for name in PROBABILITIES)

    @classmethod
    def parse(cls, text: str) -> FaultSpec:
        """Parses a spec such as ``"drop=0.01,pace"`` (empty or ``none``: no faults).

        Raises:
            FaultSpecError: an unknown fault or a value out of range; the message says which.
        """
        values: dict[str, float | bool] = {}
        known = [f.name for f in fields(cls)]
        for item in filter(None, (part.strip() for part in text.split(","))):
            if item == "none":
                continue
            name, _, raw = item.partition("=")
            name = name.strip()
            if name not in known:
                raise FaultSpecError(f"unknown fault '{name}' in '{text}': use {', '.join(known)}")
            if name == "pace":
                values[name] = raw.strip().lower() not in ("0", "false", "no", "off")
                continue
            try:
                value = float(raw)
            except ValueError:
                raise FaultSpecError(f"fault '{name}' needs a number, as in {name}=0.05; got '{item}'") from None
            if not math.isfinite(value):
                raise FaultSpecError(f"fault '{name}' needs a finite number, got '{raw.strip()}'")
            if name in PROBABILITIES and not 0.0 <= value <= 1.0:
                raise FaultSpecError(f"fault '{name}' is a probability 0..1, got {value}")
            if value < 0:
                raise FaultSpecError(f"fault '{name}' cannot be negative, got {value}")
            values[name] = value
        return cls(**values)  # type: ignore[arg-type]

    def __str__(self) -> str:
        parts = [f"{name}={getattr(self, name):g}" for name in PROBABILITIES if getattr(self, name)]
        if self.delay:
            parts.append(f"delay_s={self.delay_s:g}")
        if self.pace:
            parts.append("pace")
        return ",".join(parts) or "none"

"""Run trees tick by tick against an in-process emulator in virtual time."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import py_trees
from py_trees.common import Status

from autonomy.client import Client
from autonomy.emulator import Emulator
from autonomy.mission import build_tree, validate_text
from autonomy.protocol import Command, Get
from autonomy.record import RunEnd, RunHeader, TickRecord
from autonomy.runner import Runner


class Rig:
    """A robot on emu:// in virtual time, and a runner for one tree on it."""

    def __init__(
        self, root: py_trees.behaviour.Behaviour, query: str = "", tick_hz: float = 20.0, client: Client | None = None
    ) -> None:
        self.client = client or Client.open(f"emu://?time=virtual{'&' + query if query else ''}")
        self.emulator: Emulator = self.client.port.emulator
        self.root = root
        self.runner = Runner(root, self.client, tick_hz=tick_hz)
        self.runner.setup()
        self.period_s = 1.0 / tick_hz

    def tick(self, count: int = 1) -> Status:
        status = self.root.status
        for _ in range(count):
            status = self.runner.tick()
            self.client.clock.sleep(self.period_s)
        return status

    def tick_until_done(self, limit: int = 10_000) -> Status:
        for _ in range(limit):
            status = self.tick()
            if status in (Status.SUCCESS, Status.FAILURE):
                return status
        raise AssertionError(f"still {self.root.status} after {limit} ticks")

    def sent(self) -> list[Command]:
        """Commands the robot received and carried out, polls left out."""
        return [c for c in self.emulator.commands() if not isinstance(c, Get)]

    @property
    def robot(self):
        self.emulator.advance()
        return self.emulator.robot


class Recorder:
    """A listener that keeps every record, with shortcuts to what tests look at."""

    def __init__(self) -> None:
        self.records: list = []

    def __call__(self, record) -> None:
        self.records.append(record)

    @property
    def header(self) -> RunHeader:
        return self.records[0]

    @property
    def ticks(self) -> list[TickRecord]:
        return [r for r in self.records if isinstance(r, TickRecord)]

    @property
    def end(self) -> RunEnd:
        return self.records[-1]

    def events(self, kind: str = "log") -> list[str]:
        return [e.message for r in self.records if not isinstance(r, RunHeader) for e in r.events if e.kind == kind]


def tree_of(yaml_tree: str, subtrees: str = "") -> py_trees.behaviour.Behaviour:
    """Builds a tree from the YAML of a mission's tree: block (indented two spaces)."""
    text = f"mission: test\n{subtrees}tree:\n{yaml_tree}"
    return build_tree(validate_text(text, "test.yaml"))


def mission_files(paths: Iterable[Path]) -> list[Path]:
    """The mission files of ``paths``, sorted: their scenario files (``NAME.test.yaml``, docs/testing.md) left out."""
    return sorted(path for path in paths if not path.name.endswith(".test.yaml"))

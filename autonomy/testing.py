"""A mission run on the built-in emulator, from a test: what a plugin's own tests need.

:func:`run_mission` runs a mission file (its plugins loaded from beside it, as ``autonomy run``
loads them) in virtual time, so a minute of driving takes a fraction of a second, and gives
back the run's records, with a few questions asked of them::

    from autonomy.testing import run_mission

    def test_it_stops_before_the_wall():
        run = run_mission("approach.yaml", world="box")
        assert run.outcome == "succeeded" and run.collisions == 0
        assert "RUNNING" in run.statuses("approach")

:func:`check_scenario` runs a scenario written as a scenario file writes one (docs/testing.md), and
checks what it expects, so that pytest code and ``NAME.test.yaml`` files assert the same things in
the same words::

    from autonomy.testing import check_scenario

    def test_it_stops_before_the_wall_and_beeps_once():
        outcome = check_scenario(
            "approach.yaml", world="box", seeds=[1, 2],
            expect={"outcome": "succeeded", "beeps": 1, "criteria": [{"max_collisions": 0}]},
            nodes=[{"node": "beep", "reaches": "SUCCESS", "before_s": 10}],
        )
        assert outcome.passed, outcome.report

docs/plugins.md has a whole plugin with its tests.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any
from urllib.parse import urlencode

import yaml

from autonomy.client import Client
from autonomy.mission import load_mission
from autonomy.record import Pose, Record, RunEnd, RunHeader, TickRecord
from autonomy.runner import Runner, RunSummary

if TYPE_CHECKING:
    from autonomy.scenarios import ScenarioOutcome


@dataclass
class MissionRun:
    """A finished run: its summary and its records.

    Attributes:
        summary: What ``autonomy run`` prints at the end (outcome, time, distance, commands...).
        header: The run's first record: its tree (``header.nodes``), world and settings.
        ticks: Every tick's record, in order (``docs/trace.md`` says what each holds).
        end: The last record.
    """

    summary: RunSummary
    header: RunHeader
    ticks: list[TickRecord]
    end: RunEnd

    @property
    def outcome(self) -> str:
        """``succeeded``, ``failed``, ``stopped at the time limit``, ``stopped by an error``..."""
        return self.summary.outcome

    @property
    def collisions(self) -> int:
        """How many times the robot reported a collision."""
        return self.summary.collisions

    @property
    def path(self) -> list[Pose]:
        """Where the emulator says the robot was at each tick (x_mm, y_mm, heading_deg)."""
        return [tick.truth for tick in self.ticks if tick.truth is not None]

    def node_ids(self, name: str) -> list[int]:
        """The ids of the nodes named ``name`` (their ``name:``, or the label they are shown with), else of that type.

        Raises:
            KeyError: no node has that name or type (the message lists the names there are).
        """
        ids = [node.id for node in self.header.nodes if node.name == name]
        ids = ids or [node.id for node in self.header.nodes if node.type == name]
        if not ids:
            raise KeyError(f"no node named {name!r}: the nodes are {', '.join(n.name for n in self.header.nodes)}")
        return ids

    def statuses(self, name: str) -> list[str]:
        """Each status the node(s) named ``name`` (or of that type) took, in order, as they changed (``RUNNING``...)."""
        ids = set(self.node_ids(name))
        return [state.status for tick in self.ticks for node, state in tick.nodes.items() if node in ids]

    def feedback(self, name: str) -> list[str]:
        """Each feedback message the node(s) named ``name`` (or of that type) gave, in order, as it changed."""
        ids = set(self.node_ids(name))
        return [state.feedback for tick in self.ticks for node, state in tick.nodes.items() if node in ids]


def run_mission(
    mission: str | Path, *, world: str | None = None, seed: int = 0, max_seconds: float = 60.0
) -> MissionRun:
    """Runs a mission file on the built-in emulator, in virtual time.

    Args:
        mission: The mission file (YAML, or BehaviorTree.CPP XML); its plugins are loaded from
            its folder.
        world: The world to run in (default: the mission's ``world:``, else ``box``).
        seed: The emulator's seed: where in its start jitter the robot starts, and what the world varies.
        max_seconds: Stop the run after this long (simulated seconds).

    Raises:
        autonomy.mission.MissionInvalid: the mission has problems (each one, ``FILE:LINE:COL``).
    """
    spec = load_mission(mission)
    options = {"world": world or spec.world or "box", "seed": str(seed), "time": "virtual"}
    records: list[Record] = []
    client = Client.open("emu://?" + urlencode(options))
    try:
        summary = Runner.for_mission(spec, client, max_seconds=max_seconds, listeners=[records.append]).run()
    finally:
        client.close()
    header = next(record for record in records if isinstance(record, RunHeader))
    ticks = [record for record in records if isinstance(record, TickRecord)]
    end = next(record for record in reversed(records) if isinstance(record, RunEnd))
    return MissionRun(summary, header, ticks, end)


def check_scenario(mission: str | Path, **scenario: Any) -> ScenarioOutcome:
    """Runs one scenario on ``mission``, on each of its seeds, and checks what it expects, as ``autonomy test`` does.

    The scenario's keys are a scenario file's (docs/testing.md): ``world`` (required), ``seeds``,
    ``start``, ``time_limit_s``, ``battery``, ``sensors``, ``expect`` and ``nodes``; ``name`` is
    the test's if left out. Its world file, if it names one, is looked for beside the mission.

    Returns:
        The scenario's outcome: ``passed``, and ``report``, a line for each thing that did not hold.

    Raises:
        autonomy.scenarios.ScenariosInvalid: the scenario, or the mission, has problems (each one, with
            where it is in the scenario: ``scenarios[0].expect.beeps``).
    """
    from autonomy.scenarios import ScenariosInvalid, run_scenario
    from autonomy.scenarios.files import mission_of_test, scenarios_from_text
    from autonomy.source import Problem

    mission = Path(mission).resolve()
    try:
        text = yaml.safe_dump({"mission": str(mission), "scenarios": [{"name": "check_scenario", **scenario}]})
    except yaml.YAMLError as err:  # a value no scenario file could hold (an object, a numpy number)
        why = f"a scenario's values are numbers, text, true/false, lists and mappings: {str(err).splitlines()[0]}"
        raise ScenariosInvalid([Problem("check_scenario", 1, 1, "", why[:300])]) from None
    tests = scenarios_from_text(text, mission_of_test(mission), "the scenario given to check_scenario")
    return run_scenario(tests, tests.scenarios[0])

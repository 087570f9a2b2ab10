"""pytest collects scenario files: each ``NAME.test.yaml`` a file of tests, each of its scenarios a test.

Registered by the package (the ``pytest11`` entry point), so that an author's own pytest run, given
the folder, runs their missions' scenarios beside their Python tests: ``pytest tests/ missions/``.
A scenario fails with the lines ``autonomy test`` says; a file with problems fails to be collected,
with each problem at its ``FILE:LINE:COL``.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from autonomy.scenarios.files import SUFFIX, holds_tests


def pytest_collect_file(file_path: Path, parent: pytest.Collector) -> pytest.Collector | None:
    """A scenario file's collector, for a ``NAME.test.yaml`` or a mission with a ``tests:`` list."""
    if file_path.name.endswith(SUFFIX) or holds_tests(file_path):
        return ScenarioFileCollector.from_parent(parent, path=file_path)
    return None


class ScenarioProblems(Exception):
    """A scenario file that cannot be read: its problems, one a line."""


class ScenarioFailed(Exception):
    """A scenario that did not hold: what did not, one a line."""


class ScenarioFileCollector(pytest.File):
    """A scenario file: a test for each scenario."""

    def collect(self) -> Iterator[pytest.Item]:
        """Reads the file and its mission; a test for each scenario."""
        from autonomy.scenarios import ScenariosInvalid, load_scenarios

        try:
            tests = load_scenarios(self.path)
        except ScenariosInvalid as err:
            raise ScenarioProblems("\n".join(str(p) for p in err.problems)) from None
        for scenario in tests.scenarios:
            yield ScenarioItem.from_parent(self, name=scenario.name, tests=tests, scenario=scenario)

    def repr_failure(self, excinfo: pytest.ExceptionInfo[BaseException]) -> str:  # type: ignore[override]
        """A file's problems as they are, not as a traceback."""
        if isinstance(excinfo.value, ScenarioProblems):
            return str(excinfo.value)
        return super().repr_failure(excinfo)  # type: ignore[return-value]


class ScenarioItem(pytest.Item):
    """One scenario, run on each of its seeds."""

    def __init__(self, *, tests: Any, scenario: Any, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.tests = tests
        self.scenario = scenario

    def runtest(self) -> None:
        """Runs the scenario; raises with what did not hold."""
        from autonomy.scenarios import run_scenario

        outcome = run_scenario(self.tests, self.scenario)
        if not outcome.passed:
            raise ScenarioFailed(outcome.report)

    def repr_failure(self, excinfo: pytest.ExceptionInfo[BaseException]) -> str:  # type: ignore[override]
        """What did not hold, a line each, not a traceback."""
        if isinstance(excinfo.value, ScenarioFailed):
            return f"scenario '{self.scenario.name}' did not hold:\n{excinfo.value}"
        return super().repr_failure(excinfo)  # type: ignore[return-value]

    def reportinfo(self) -> tuple[Path, int, str]:
        """Where the scenario is: its file and line."""
        return self.path, self.scenario.line - 1, f"scenario: {self.scenario.name}"

"""Mission tests for behaviour authors: scenario files beside a mission, run and checked (docs/testing.md)."""

from autonomy.scenarios.files import ScenarioFile, ScenariosInvalid, find_scenario_files, load_scenarios
from autonomy.scenarios.running import Coverage, ScenarioOutcome, run_scenario

__all__ = [
    "Coverage",
    "ScenarioFile",
    "ScenarioOutcome",
    "ScenariosInvalid",
    "find_scenario_files",
    "load_scenarios",
    "run_scenario",
]

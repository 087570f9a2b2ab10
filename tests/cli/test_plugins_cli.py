"""Plugins from the command line: each mission's own, never an installed module, never obeyed."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.test_cli import autonomy

BEHAVIOUR = (
    "from py_trees.common import Status\n"
    "from autonomy.behaviours import RobotCondition\n\n"
    "class Check(RobotCondition):\n"
    "    node_type = '{name}'\n"
    "    doc = 'always holds'\n"
    "    def check(self):\n"
    "        {body}\n"
    "        return True\n"
)


def mission_with_plugin(folder: Path, node: str, body: str = "pass", module: str = "beh") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{module}.py").write_text(BEHAVIOUR.format(name=node, body=body))
    mission = folder / "m.yaml"
    mission.write_text(f"mission: m\nplugins: [{module}]\ntree: {node}\n")
    return mission


def test_each_mission_is_checked_against_its_own_plugin(tmp_path):
    first = mission_with_plugin(tmp_path / "A", "alpha_cond")
    second = mission_with_plugin(tmp_path / "B", "beta_cond")
    result = autonomy("check", str(first), str(second))
    assert result.returncode == 0, result.stdout + result.stderr
    assert result.stdout.count("ok") == 2


@pytest.mark.parametrize(
    ("code", "shown"),
    [
        ("import sys\nsys.exit(0)\n", "SystemExit: 0"),
        ("import sys\nsys.exit()\n", "SystemExit"),
        ("raise KeyboardInterrupt\n", "KeyboardInterrupt"),
        ("1/0\n", "ZeroDivisionError: division by zero"),
    ],
)
def test_a_plugin_that_exits_or_raises_on_import_is_a_mission_problem(tmp_path, code, shown):
    (tmp_path / "bad.py").write_text(code)
    mission = tmp_path / "m.yaml"
    mission.write_text("mission: m\nplugins: [bad]\ntree: stop\n")
    for command in ("check", "run"):
        result = autonomy(command, str(mission), "--fast") if command == "run" else autonomy(command, str(mission))
        assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
        assert f"m.yaml:2:11: plugins[0]: cannot import plugin 'bad': {shown}" in result.stderr


def test_an_installed_module_is_never_imported_as_a_plugin(tmp_path):
    mission = tmp_path / "m.yaml"
    mission.write_text("mission: m\nplugins: [this]\ntree: stop\n")
    result = autonomy("check", str(mission))
    assert result.returncode == 2 and "Zen of Python" not in result.stdout + result.stderr
    assert "no plugin 'this': plugins are Python files beside the mission" in result.stderr


def test_a_plugin_name_that_is_a_path_is_refused(tmp_path):
    mission = tmp_path / "m.yaml"
    mission.write_text("mission: m\nplugins: ['../evil']\ntree: stop\n")
    result = autonomy("check", str(mission))
    assert result.returncode == 2 and "is not a module name" in result.stderr


def test_sys_exit_in_a_plugins_setup_ends_the_run_with_a_summary_and_the_robot_stopped(tmp_path):
    folder = tmp_path / "S"
    folder.mkdir()
    (folder / "beh.py").write_text(
        "import sys\n"
        "from py_trees.common import Status\n"
        "from autonomy.behaviours import RobotAction\n\n"
        "class Quit(RobotAction):\n"
        "    node_type = 'quit'\n"
        "    doc = 'exits'\n"
        "    def setup(self, **kwargs):\n"
        "        super().setup(**kwargs)\n"
        "        sys.exit(0)\n"
        "    def update(self):\n"
        "        return Status.SUCCESS\n"
    )
    mission = folder / "m.yaml"
    mission.write_text("mission: m\nplugins: [beh]\ntree: {sequence: [{move: {speed: 1}}, quit]}\n")
    result = autonomy("run", str(mission), "--fast", "--max-seconds", "5")
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert "stopped by an error" in result.stdout and "SystemExit" in result.stdout
    assert "It was stopped at the end." in result.stdout


def test_a_plugin_class_that_cannot_be_built_is_a_problem_of_the_file(tmp_path):
    (tmp_path / "beh.py").write_text(
        "from autonomy.behaviours import RobotAction\n\n"
        "class Half(RobotAction):\n"
        "    node_type = 'half'\n"
        "    doc = 'no update'\n"
    )
    mission = tmp_path / "m.yaml"
    mission.write_text("mission: m\nplugins: [beh]\ntree:\n  sequence: [stop, half]\n")
    for command in ("check", "run"):
        result = autonomy(command, str(mission))
        assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
        assert "m.yaml:4:" in result.stderr and "cannot build node 'half' (plugin beh)" in result.stderr
        assert "abstract method update" in result.stderr


@pytest.mark.parametrize(
    ("body", "said", "at"),
    [
        ("raise KeyboardInterrupt", "raised KeyboardInterrupt", "beh.py:7 in update"),
        ("return None", "update() returned None; it must return Status.RUNNING, SUCCESS or", "beh.py:6 in update"),
        ("return 42", "update() returned 42", "beh.py:6 in update"),  # the plugin's update, not the check's line
    ],
)
def test_a_behaviour_that_raises_ctrl_c_or_returns_no_status_ends_the_run_as_its_error(tmp_path, body, said, at):
    (tmp_path / "beh.py").write_text(
        "from py_trees.common import Status\n"
        "from autonomy.behaviours import RobotAction\n\n"
        "class Odd(RobotAction):\n"
        "    node_type = 'odd'\n"
        "    def update(self):\n"
        f"        {body}\n"
    )
    mission = tmp_path / "m.yaml"
    mission.write_text("mission: m\nplugins: [beh]\ntree: {parallel: [{move: {speed: 1}}, odd]}\n")
    result = autonomy("run", str(mission), "--fast", "--max-seconds", "5")
    assert result.returncode == 1 and "Traceback" not in result.stderr, result.stdout + result.stderr
    assert "stopped by an error" in result.stdout and "node 'odd'" in result.stdout and said in result.stdout
    assert "It was stopped at the end." in result.stdout and "[ERROR]" not in result.stdout
    assert f"{said}" in result.stdout and f" at {tmp_path / at}" in result.stdout and "base.py" not in result.stdout

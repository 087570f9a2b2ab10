"""What got in a newcomer's way in their first hour, each as the command that showed it."""

from __future__ import annotations

import pytest

from tests.cli.test_cli import assert_one_line_error, autonomy


def test_a_mission_given_where_the_exercise_goes_says_which_comes_first():
    swapped = autonomy("grade", "missions/square.yaml", "exercises/solutions/square.yaml")
    mission_first = "missions/square.yaml:1:1: this is a mission file, not an exercise"
    assert_one_line_error(swapped, 2, mission_first, "autonomy grade EXERCISE THIS_FILE")
    world = autonomy("grade", "autonomy/emulator/worlds/garage.yaml", "exercises/solutions/garage.yaml")
    assert_one_line_error(world, 2, "garage.yaml:5:1: this is a world file, not an exercise: an exercise names its")


def test_world_show_writes_a_png_for_png_and_refuses_what_it_cannot_write(tmp_path):
    png = tmp_path / "w.png"
    result = autonomy("world", "show", "opening", "-o", str(png))
    assert result.returncode == 0, result.stderr
    assert png.read_bytes().startswith(b"\x89PNG\r\n\x1a\n")  # a picture, not SVG text under a .png name
    svg = tmp_path / "w.svg"
    assert autonomy("world", "show", "opening", "-o", str(svg)).returncode == 0
    assert svg.read_text().startswith("<svg")
    assert_one_line_error(autonomy("world", "show", "opening", "-o", str(tmp_path / "w.jpg")), 2, ".svg or .png")
    assert not (tmp_path / "w.jpg").exists()


def test_the_speed_is_plotted_as_its_mean_over_a_quarter_second_not_the_odometer_s_zig_zag(tmp_path):
    from autonomy.trace import read_trace
    from autonomy.views.plot import SPEED_WINDOW_S, mean_over

    trace = tmp_path / "run.jsonl"
    assert autonomy("run", "missions/square.yaml", "--fast", "--quiet", "--trace", str(trace)).returncode == 0
    ticks = read_trace(trace).ticks
    times, speeds = [t.time_s for t in ticks], [t.speed_mm_s for t in ticks]
    cruise = range(10, 30)  # the first side, at full speed
    assert max(speeds[i] for i in cruise) - min(speeds[i] for i in cruise) >= 19  # whole millimetres a tick
    mean = mean_over(times, speeds, SPEED_WINDOW_S)
    assert max(mean[i] for i in cruise) - min(mean[i] for i in cruise) < 8
    assert mean_over([0.0, 0.1, 0.2, 0.3], [1.0, 2.0, 3.0, 4.0], 0.25) == [1.0, 1.5, 2.0, 3.0]
    svg = tmp_path / "run.svg"
    assert autonomy("plot", str(trace), "-o", str(svg)).returncode == 0
    assert "speed (mm/s), mean of 0.25 s" in svg.read_text()


def test_a_distance_past_the_sensor_s_reach_says_so(tmp_path):
    mission = tmp_path / "far.yaml"
    mission.write_text("mission: far\ntree:\n  sequence:\n    - move: {speed: 2, until_obstacle_mm: 300}\n")
    result = autonomy("check", str(mission))
    assert result.returncode == 2
    assert "until_obstacle_mm must be 1..255 mm, got 300: the front sensor reads at most 255 mm" in result.stderr


def test_show_writes_a_picture_with_o_and_says_what_each_format_is(tmp_path):
    svg, dot = tmp_path / "square.svg", tmp_path / "square.dot"
    assert autonomy("show", "missions/square.yaml", "-o", str(svg)).returncode == 0
    assert svg.read_text().startswith("<svg") and "move 300 mm" in svg.read_text()
    assert autonomy("show", "missions/square.yaml", "--format", "dot", "-o", str(dot)).returncode == 0
    assert dot.read_text().startswith("digraph")
    text = autonomy("show", "missions/square.yaml")
    assert text.returncode == 0 and "repeat x4" in text.stdout
    shown = autonomy("show", "--help").stdout
    assert "Graphviz" in shown and "-o FILE" in shown


def test_repeat_and_retry_say_where_they_are_in_words_not_py_trees_text(tmp_path):
    from autonomy.trace import read_trace

    mission = tmp_path / "counted.yaml"
    mission.write_text(
        "mission: counted\nworld: box\ntree:\n  sequence:\n"
        "    - repeat:\n        times: 3\n        do: {wait: {seconds: 0.2}}\n"
        "    - retry:\n        attempts: 2\n        do: {wait: {seconds: 0.1}}\n"
        "    - timeout:\n        seconds: 1\n        do:\n          repeat:\n            do: {wait: {seconds: 0.2}}\n"
    )
    trace = tmp_path / "run.jsonl"
    result = autonomy("run", str(mission), "--fast", "--quiet", "--trace", str(trace))
    assert result.returncode == 1, result.stderr  # the timeout fails the forever repeat, as it should
    said = {
        (node, state.feedback)
        for tick in read_trace(trace).ticks
        for node, state in tick.nodes.items()
        if node in (1, 3, 6)
    }
    assert {(1, "0 of 3 done"), (1, "2 of 3 done"), (1, "3 of 3 done")} <= said
    assert (3, "attempt 1 of 2") in said and (3, "succeeded on attempt 1 of 2") in said
    assert (6, "forever, 0 times so far") in said and (6, "forever, 4 times so far") in said
    assert not [text for _, text in said if "[status:" in text]


def test_the_line_output_puts_the_acting_leaf_first_and_gives_a_beep_a_line():
    wander = autonomy("run", "missions/wander.yaml", "--fast").stdout.splitlines()
    assert all("move until" in line.split("bat 230  ")[1][:20] for line in wander[1:3]), wander[:3]
    square = autonomy("run", "missions/square.yaml", "--fast").stdout.splitlines()
    assert sum(line.endswith("beep: done") for line in square) == 4, square


def test_world_list_names_every_built_in_world_and_a_world_file_beside_the_mission_is_suggested(tmp_path):
    from autonomy.emulator.world import SHIPPED

    listed = autonomy("world", "list")
    assert listed.returncode == 0
    names = [line.split()[0] for line in listed.stdout.splitlines() if line[:1].isalpha() and " m, " in line]
    assert names == list(SHIPPED)
    assert "garage     3 x 1.2 m, 1 obstacle, zones garage" in listed.stdout
    (tmp_path / "lab.yaml").write_text("name: lab\narena_mm: [2000, 2000]\n")
    mission = tmp_path / "m.yaml"
    mission.write_text("mission: m\nworld: lab\ntree:\n  move: {speed: 1, seconds: 1}\n")
    assert autonomy("check", str(mission)).returncode == 0  # lab.yaml, beside the mission
    mission.write_text("mission: m\nworld: lab.yaml\ntree:\n  move: {speed: 1, seconds: 1}\n")
    assert autonomy("check", str(mission)).returncode == 0
    mission.write_text("mission: m\nworld: labs\ntree:\n  move: {speed: 1, seconds: 1}\n")
    checked = autonomy("check", str(mission))
    assert checked.returncode == 2 and "no world named 'labs'" in checked.stderr and "(labs.yaml)" in checked.stderr


def test_an_exported_while_is_behaviortree_cpp_s_own_reactive_sequence_and_imports_as_while(tmp_path):
    from autonomy.mission import load_mission
    from tests.btcpp import reference

    xml, back = tmp_path / "patrol.xml", tmp_path / "patrol.yaml"
    assert autonomy("export", "missions/patrol.yaml", "-o", str(xml)).returncode == 0
    text = xml.read_text()
    assert "<While" not in text and '<ReactiveSequence name="patrol while fit" _autonomy="while">' in text
    spec = load_mission("missions/patrol.yaml")
    stock = reference.factory(spec)  # BehaviorTree.CPP itself, our leaves registered as stand-ins
    stock.register_behavior_tree_from_text(reference.for_reference(text, reference.leaf_names(spec)))
    assert stock.create_tree("patrol") is not None  # no node of ours to write in C++ first
    assert autonomy("import", str(xml), "-o", str(back)).returncode == 0
    assert "  - while:\n      name: patrol while fit" in back.read_text()


def test_a_busy_view_port_says_to_take_any_and_every_interface_prints_addresses_one_can_open(tmp_path):
    import signal
    import socket
    import subprocess
    import sys

    from tests.cli.test_cli import ROOT

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = str(taken.getsockname()[1])
        busy = autonomy("run", "missions/square.yaml", "--fast", "--quiet", "--view", "--view-port", port)
        assert_one_line_error(busy, 2, f"127.0.0.1:{port}", "the port is in use", "--view-port 0 takes any free port")
    served = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "run", "missions/square.yaml", "--fast", "--quiet", "--view"]
        + ["--view-host", "0.0.0.0", "--view-port", "0"],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        lines = [served.stderr.readline() for _ in range(2)]
    finally:
        served.send_signal(signal.SIGINT)
        served.communicate(timeout=30)
    view = next(line for line in lines if line.startswith("view: "))
    assert "0.0.0.0" not in view and "http://127.0.0.1:" in view, lines


def test_the_world_s_grid_stays_inside_its_walls_and_under_them(tmp_path):
    import xml.etree.ElementTree as ET

    svg = tmp_path / "box.svg"
    assert autonomy("world", "show", "box", "-o", str(svg)).returncode == 0
    ns = "{http://www.w3.org/2000/svg}"
    world = next(g for g in ET.parse(svg).iter(f"{ns}g") if g.get("id") == "world")
    shapes = list(world)
    lines = [e for e in shapes if e.tag == f"{ns}line" and e.get("stroke") == "#e9ecef"]
    assert len(lines) == 6  # 500, 1000 and 1500 mm each way; none on the walls at 0 and 2000
    assert {float(e.get("x1")) for e in lines if e.get("x1") == e.get("x2")} == {500.0, 1000.0, 1500.0}
    walls = next(i for i, e in enumerate(shapes) if e.get("class") == "arena")
    assert all(shapes.index(line) < walls for line in lines)  # the walls are drawn over the grid


def test_a_btlog_replays_with_the_names_and_kinds_a_trace_of_the_run_has(tmp_path):
    from autonomy.btlog import read_btlog
    from autonomy.trace import read_trace

    log, trace = tmp_path / "run.btlog", tmp_path / "run.jsonl"
    ran = autonomy("run", "missions/patrol.yaml", "--fast", "--quiet", "--btlog", str(log), "--trace", str(trace))
    assert ran.returncode == 0, ran.stderr
    logged = [(n.name, n.type, n.category) for n in read_btlog(log).header.nodes]
    traced = [(n.name, n.type, n.category) for n in read_trace(trace).header.nodes]
    assert logged == traced  # "selector", "patrol while fit" a decorator, "battery above 50" a condition...
    shown = autonomy("replay", str(log), "--lines", "--speed", "1000")
    assert "move until < 150 mm" in shown.stdout and "speed=3" not in shown.stdout


@pytest.mark.parametrize("how", [["--pty"], ["--tcp", "127.0.0.1:0", "--rfc2217"]], ids=["pty", "rfc2217"])
def test_a_client_at_the_wrong_rate_on_the_pty_or_rfc2217_emulator_gets_noise_as_over_a_real_line(how):
    import subprocess
    import sys

    from tests.cli.test_cli import ROOT

    served = subprocess.Popen(
        [sys.executable, "-m", "autonomy", "emulator", *how], cwd=ROOT, stdout=subprocess.PIPE, text=True
    )
    try:
        device = served.stdout.readline().strip()
        wrong = autonomy("probe", "--port", device, "--baud", "115200", "--wait", "2")
        assert_one_line_error(wrong, 3, "no answer", "at 115200 baud", "is the robot set to 57600 baud?")
        right = autonomy("probe", "--port", device, "--baud", "57600")
        assert right.returncode == 0 and "firmware" in right.stdout, right.stderr
    finally:
        served.terminate()
        served.wait(timeout=10)


def test_a_tree_picture_wraps_a_node_s_parameters_rather_than_cut_them(tmp_path):
    import xml.etree.ElementTree as ET

    svg = tmp_path / "wander.svg"
    assert autonomy("show", "missions/wander.yaml", "-o", str(svg)).returncode == 0
    ns = "{http://www.w3.org/2000/svg}"
    nodes = [g for g in ET.parse(svg).iter(f"{ns}g") if g.get("class") == "node"]
    details = [" ".join(t.text for t in g.iter(f"{ns}text") if t.get("class") == "detail") for g in nodes]
    assert "move speed=2 until_obstacle_mm=150 direction=forward" in details  # was cut at "direction=fo…"
    assert not [text for text in details if "…" in text]
    tall = [g for g in nodes if float(next(g.iter(f"{ns}rect")).get("height")) > 38]
    assert tall  # a box with two lines of parameters is a line taller


def test_a_long_sequence_is_drawn_in_rows_joined_by_a_rail_not_as_a_strip(tmp_path):
    import xml.etree.ElementTree as ET

    svg = tmp_path / "scan.svg"
    assert autonomy("show", "missions/servo_scan.yaml", "-o", str(svg)).returncode == 0
    ns = "{http://www.w3.org/2000/svg}"
    root = ET.parse(svg).getroot()
    assert float(root.get("width")) < 1300  # it was a strip 2,023 px wide and 340 high
    nodes = [g for g in root.iter(f"{ns}g") if g.get("class") == "node"]
    assert len(nodes) == 16  # every node is there
    tops = sorted({float(next(g.iter(f"{ns}rect")).get("y")) for g in nodes})
    assert len(tops) >= 4  # the root, two rows of its 12 children, the rest below
    assert [e for e in root.iter(f"{ns}line") if e.get("class") == "rail"]

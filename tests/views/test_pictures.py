"""autonomy plot and autonomy world show: files a person opens, checked for what they draw."""

from __future__ import annotations

import itertools
import math
import subprocess
import sys
import xml.etree.ElementTree as ET

from autonomy.trace import read_trace
from autonomy.views.plot import broken_at_wraps, timeline
from tests.views.conftest import ROOT

SVG = "{http://www.w3.org/2000/svg}"


def autonomy(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "autonomy", *args], cwd=ROOT, capture_output=True, text=True)


def test_plot_writes_png_and_svg_with_map_telemetry_and_timeline(tmp_path):
    trace = tmp_path / "run.jsonl"
    assert (
        autonomy("run", "missions/beep_on_collision.yaml", "--fast", "--quiet", "--trace", str(trace)).returncode == 0
    )
    png, svg = tmp_path / "run.png", tmp_path / "run.svg"
    assert autonomy("plot", str(trace), "-o", str(png)).returncode == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
    result = autonomy("plot", str(trace), "-o", str(svg))
    assert result.returncode == 0 and result.stdout.startswith(f"{svg}: ")
    text = svg.read_text()
    for words in (
        "dead reckoning",
        "truth (emulator)",
        "collision (3)",
        "front distance (mm)",
        "battery (/255)",
        "timeline: bars while RUNNING",
        "world box",
    ):
        assert words in text, words


def test_the_timeline_says_when_each_node_ran_and_how_it_ended(tmp_path):
    trace = tmp_path / "run.jsonl"
    assert autonomy("run", "missions/square.yaml", "--fast", "--quiet", "--trace", str(trace)).returncode == 0
    recorded = read_trace(trace)
    rows = dict((node_id, spans) for node_id, spans, _ in timeline(recorded))
    moves = rows[2]  # move 300 mm: four times, each succeeded, each about 1.5 s long
    assert [how for _, _, how in moves] == ["SUCCESS"] * 4
    assert all(1.3 <= end - start <= 1.7 for start, end, _ in moves)
    assert rows[0][0][2] == "SUCCESS" and rows[0][0][1] == recorded.ticks[-1].time_s


def test_plot_refuses_an_unknown_suffix_in_one_line(tmp_path):
    result = autonomy("plot", "missing.jsonl", "-o", str(tmp_path / "x.pdf"))
    assert (
        result.returncode == 2
        and result.stderr == f"autonomy: error: -o must end in .png, .svg or .html, got '{tmp_path / 'x.pdf'}'\n"
    )


def test_world_show_draws_the_arena_obstacles_and_start(tmp_path):
    out = tmp_path / "obstacles.svg"
    result = autonomy("world", "show", "obstacles", "-o", str(out))
    assert result.returncode == 0 and result.stdout == f"{out}: world 'obstacles', 3000 x 3000 mm\n"
    svg = ET.parse(out).getroot()
    classes = [el.get("class") for el in svg.iter()]
    assert classes.count("obstacle") == 5 and "arena" in classes and "start" in classes
    start = next(el for el in svg.iter(f"{SVG}circle") if el.get("class") == "start")
    assert (start.get("cx"), start.get("cy")) == ("500", "500")
    heading = next(el for el in svg.iter(f"{SVG}line") if el.get("class") == "start-heading")
    assert float(heading.get("x2")) > 500 and float(heading.get("y2")) > 500  # 45 degrees: up and right
    world_file = tmp_path / "lab.yaml"
    world_file.write_text("name: lab\narena_mm: [1000, 500]\nstart: {x_mm: 100, y_mm: 250}\n")
    assert "world lab: 1000 x 500 mm" in autonomy("world", "show", str(world_file)).stdout
    missing = autonomy("world", "show", "nowhere")
    assert missing.returncode == 2 and missing.stderr.startswith("autonomy: error: no world named 'nowhere'")


def test_the_heading_plot_lifts_its_pen_where_the_heading_wraps_round(tmp_path):
    trace, svg = tmp_path / "run.jsonl", tmp_path / "run.svg"
    assert autonomy("run", "missions/square.yaml", "--fast", "--quiet", "--trace", str(trace)).returncode == 0
    headings = [t.status.heading_deg for t in read_trace(trace).ticks]
    assert any(a - b > 180 for a, b in itertools.pairwise(headings))  # the last turn goes from 355 to 0
    assert autonomy("plot", str(trace), "-o", str(svg)).returncode == 0
    groups = {g.get("id"): g for g in ET.parse(svg).iter(f"{SVG}g") if (g.get("id") or "").startswith("series-")}
    strokes = {name: next(g.iter(f"{SVG}path")).get("d").count("M") for name, g in groups.items()}
    assert strokes == {
        "series-front-distance": 1,
        "series-heading": 2,
        "series-tilt": 1,
        "series-speed": 1,
        "series-battery": 1,
    }


def test_a_series_is_broken_only_where_it_jumps_more_than_half_its_wrap():
    times = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
    xs, ys = broken_at_wraps(times, [350, 359, 2, 10, 190, 181], 360)
    assert xs == [0.0, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0]
    assert ys[:2] == [350, 359] and math.isnan(ys[2]) and ys[3:] == [2, 10, 190, 181]  # 10 -> 190 is a turn
    assert broken_at_wraps(times, [0, 300, 0, 300, 0, 300], None) == (times, [0, 300, 0, 300, 0, 300])
    assert broken_at_wraps([], [], 360) == ([], [])


def test_a_trace_naming_things_with_control_characters_plots_them_printable_without_warnings(tmp_path):
    import json

    trace = tmp_path / "run.jsonl"
    assert autonomy("run", "missions/square.yaml", "--fast", "--quiet", "--trace", str(trace)).returncode == 0
    lines = trace.read_text().splitlines()
    header = json.loads(lines[0])
    header["mission"], header["nodes"][1]["name"] = "evil\x1b[2J\x07 name", "node\x1b]0;pwn\x07"
    trace.write_text("\n".join([json.dumps(header), *lines[1:]]) + "\n")
    svg = tmp_path / "run.svg"
    result = autonomy("plot", str(trace), "-o", str(svg))
    assert result.returncode == 0 and result.stderr == ""  # no missing-glyph warnings from the picture
    text = svg.read_text()
    assert "\x1b" not in text and "evil�[2J� name" in text and "node�]0;pwn�" in text

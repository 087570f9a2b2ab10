"""The classroom from the command line: worlds checked, exercises graded, mistakes explained."""

from __future__ import annotations

import csv
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.cli.test_cli import ROOT, assert_one_line_error, autonomy


def test_check_validates_the_world_a_mission_names(tmp_path):
    world = tmp_path / "lab.yaml"
    world.write_text("arena_mm: [3000, 3000]\nstart: {x_mm: 5000, heading: 90}\n")
    mission = tmp_path / "m.yaml"
    mission.write_text("mission: m\nworld: lab.yaml\ntree:\n  beep: {}\n")
    typo = tmp_path / "t.yaml"
    typo.write_text("mission: t\nworld: boxx\ntree:\n  beep: {}\n")
    result = autonomy("check", str(mission), str(typo))
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert result.stderr.splitlines() == [
        f"{world}:2:8: start: the start is outside the 3000 x 3000 mm arena",
        f"{world}:2:21: start.heading: unknown key 'heading' (did you mean 'heading_deg'?)",
        f"{mission}:2:8: world: the world file {world} is not valid (2 listed with its name)",
        f"{typo}:2:8: world: no world named 'boxx' (did you mean 'box'?): use one of box, empty, corridor, "
        "obstacles, square, garage, slalom, bump, opening, calibration, or a world file beside the mission (boxx.yaml)",
    ]


def test_run_with_a_bad_world_is_a_usage_error_with_every_problem(tmp_path):
    world = tmp_path / "lab.yaml"
    world.write_text(
        "arena_mm: [3000, 3000]\nstart: {x_mm: 500, y_mm: 500}\nobstacles:\n"
        "  - box: {from_mm: [400, 400], to_mm: [600, 600]}\n"
    )
    result = autonomy("run", "missions/square.yaml", "--fast", "--world", str(world))
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert result.stderr.strip() == f"{world}:2:8: start: the start is inside an obstacle"
    shown = autonomy("world", "show", str(world))
    assert shown.returncode == 2 and shown.stderr.strip() == result.stderr.strip()


def test_a_world_with_zones_is_drawn_with_them():
    result = autonomy("world", "show", "opening")
    assert result.returncode == 0
    assert result.stdout.count('class="zone"') == 2 and 'data-zone="goal"' in result.stdout
    assert 'data-zone="past_wall"' in result.stdout  # through the opening


def test_a_world_is_drawn_as_a_seed_draws_it():
    import re

    def walls(seed):
        shown = autonomy("world", "show", "garage", *(["--seed", str(seed)] if seed is not None else []))
        assert shown.returncode == 0, shown.stderr
        return re.findall(r'<rect x="([0-9.]+)"[^>]*class="obstacle"', shown.stdout)

    assert walls(None) == ["2500"]  # as the file has it
    assert walls(8) == walls(8) != walls(52)  # the end wall where each seed puts it
    assert 2000 <= float(walls(8)[0]) <= 3000


def test_a_student_grades_their_own_mission_and_reads_what_to_fix(tmp_path):
    mission = tmp_path / "alice.yaml"
    mission.write_text("mission: alice\nworld: box\ntree:\n  move: {speed: 2, distance_mm: 2400}\n")
    result = autonomy("grade", "exercises/garage.yaml", str(mission))
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[:4] == [
        "Grading 1 submission for '2. Park in the garage' in world 'garage', seeds 8, 52, 56, 80, 30 s a run.",
        "This exercise also has 12 hidden seeds, which the teacher's marks use (autonomy grade --secret-file): "
        "these marks are from its 4 public seeds only.",
        "alice: 2.5 / 10 in '2. Park in the garage'",
        "  Note: the mission names the world 'box', which grading does not use: every run is in the exercise's "
        "world 'garage'",
    ]
    # a fixed 2.4 m is right where the hall is that long (seed 52), into the end wall where it is shorter
    assert lines[4:6] == [
        "  MISS Parked in the garage: 1.25 / 5 points",  # the criterion's title, the student's words
        "         seed 8: no  garage: came to rest 40 mm outside it (it lies west; needed inside; a near miss earns "
        "a part only for a robot at rest clear of walls and obstacles, stopped by itself); it got there while "
        "move 2400 mm (line 4) was running",
    ]
    assert "         seed 52: yes garage: came to rest inside it at 11.5 s" in lines
    assert (
        "         seed 8: no  collisions: 1, allowed 0, the first at 9.0 s at 214 mm/s, while move 2400 mm (line 4) "
        "was running" in lines
    )  # speed 2: the node that was running when the mark was lost, as the student wrote it


def test_the_teacher_s_secret_adds_the_hidden_seeds(tmp_path):
    secret = tmp_path / "secret.txt"
    secret.write_text("0123456789abcdef0123456789abcdef\n")
    result = autonomy("grade", "exercises/garage.yaml", "exercises/solutions/garage.yaml", "--secret-file", str(secret))
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert (
        lines[0].endswith("seeds 8, 52, 56, 80 and 12 hidden, 30 s a run.")
        and "hidden seeds, which" not in result.stdout
    )
    assert lines[1] == "garage: 10 / 10 in '2. Park in the garage'"
    hidden = [line for line in lines if line.startswith("         hidden seed ")]
    assert len(hidden) == 12 * 4 and all(": yes " in line for line in hidden)  # four criteria, twelve seeds
    assert "         hidden seed 12: yes garage: came to rest inside it" in "\n".join(lines)
    short = tmp_path / "short.txt"
    short.write_text("guessable\n")
    refused = autonomy("grade", "exercises/garage.yaml", "exercises/solutions/garage.yaml", "--secret-file", str(short))
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    assert refused.stderr.strip().endswith(
        f"the secret file {short} holds 9 bytes: give it at least 16 that nobody can guess, "
        "e.g. python3 -c 'import secrets; print(secrets.token_hex(16))' > secret.txt"
    )
    gone = autonomy("grade", "exercises/garage.yaml", "exercises/solutions/garage.yaml", "--secret-file", "nowhere")
    assert gone.returncode == 2 and gone.stderr.strip().endswith("cannot read the secret file nowhere: no such file")
    for odd in ("/dev/zero", str(tmp_path)):  # a device that never ends, a folder: refused before reading
        refused = autonomy("grade", "exercises/garage.yaml", "exercises/solutions/garage.yaml", "--secret-file", odd)
        assert refused.returncode == 2 and refused.stderr.strip().endswith(
            f"the secret file {odd} is not a file: give a small text file"
        )
    big = tmp_path / "big.txt"
    big.write_bytes(b"x" * 5000)
    refused = autonomy("grade", "exercises/garage.yaml", "exercises/solutions/garage.yaml", "--secret-file", str(big))
    assert refused.returncode == 2 and "is over 4096 bytes" in refused.stderr
    plain = autonomy("grade", "exercises/slalom.yaml", "exercises/solutions/slalom.yaml", "--secret-file", str(secret))
    assert plain.stdout.splitlines()[1] == "This exercise has no hidden seeds: the secret changes nothing."


def test_a_teacher_grades_a_class_into_a_gradebook_json_and_a_page(tmp_path):
    bob = tmp_path / "bob"
    bob.mkdir()
    (bob / "mission.yaml").write_text("mission: bob\ntree:\n  mvoe: {speed: 2}\n")
    files = [str(ROOT / "exercises" / "solutions" / "garage.yaml"), str(bob), str(tmp_path / "nobody.yaml")]
    out = {kind: tmp_path / f"marks.{kind}" for kind in ("csv", "json", "html")}
    result = autonomy("grade", "garage", *files, "--workers", "2", *(f"--{k}={v}" for k, v in out.items()), timeout=120)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    assert "marks out of 10" in result.stdout and f"wrote {out['csv']}" in result.stdout
    rows = list(csv.DictReader(out["csv"].open()))
    assert [(r["student"], r["total"]) for r in rows] == [("bob", "0"), ("garage", "10"), ("nobody", "0")]
    assert rows[0]["problems"] == f"{bob / 'mission.yaml'}:3:3: tree.mvoe: unknown node 'mvoe' (did you mean 'move'?)"
    assert rows[2]["problems"] == f"{tmp_path / 'nobody.yaml'}: no such file or folder"
    document = json.loads(out["json"].read_text())
    assert document["max_points"] == 10 and len(document["students"][1]["seeds"]) == 4
    page = out["html"].read_text()
    assert page.count('class="seed"') == 4  # and nothing to fetch from anywhere:
    # (SVG's namespace is a name, in markup and in the script that draws the class at a glance: never fetched)
    assert "http" not in page.replace('"http://www.w3.org/2000/svg"', "").replace('http-equiv="', "")
    again = autonomy("grade", "garage", *files, "--quiet", f"--csv={tmp_path / 'again.csv'}", timeout=120)
    assert again.returncode == 0 and again.stdout == ""
    assert (tmp_path / "again.csv").read_bytes() == out["csv"].read_bytes()


def test_a_bad_exercise_is_every_problem_at_its_place_and_exit_2(tmp_path):
    exercise = tmp_path / "ex.yaml"
    exercise.write_text("world: garage\ntime_limit_s: -1\nseeds: [1]\ncriteria:\n  - end_in_zone: garge\n")
    result = autonomy("grade", str(exercise), "missions/square.yaml")
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert result.stderr.splitlines() == [
        f"{exercise}:2:15: time_limit_s: must be from 0.1 to 3,600, got -1",
        f"{exercise}:5:18: criteria[0].end_in_zone: world 'garage' has no zone 'garge' (did you mean 'garage'?) "
        "(its zones: garage)",
    ]


def _children(pid: int) -> set[int]:
    """Every process below ``pid``."""
    import os

    parents: dict[int, int] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as stat:
                    parents[int(entry)] = int(stat.read().rsplit(")", 1)[1].split()[1])
            except OSError:
                continue
    found, frontier = set(), {pid}
    while frontier:
        frontier = {child for child, parent in parents.items() if parent in frontier} - found
        found |= frontier
    return found


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def test_sigterm_while_grading_ends_every_worker_and_what_plugins_started(tmp_path):
    import signal
    import subprocess
    import sys
    import time

    for name in ("ann", "ben"):
        folder = tmp_path / name
        folder.mkdir()
        (folder / "spin.py").write_text(
            "import os\nif os.fork() == 0:\n    while True:\n        pass\nwhile True:\n    pass\n"
        )
        (folder / "mission.yaml").write_text("mission: spin\nplugins: [spin]\ntree:\n  wait: {seconds: 1}\n")
    grader = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "autonomy",
            "grade",
            "garage",
            str(tmp_path / "ann"),
            str(tmp_path / "ben"),
            "--allow-plugins",
            "--workers",
            "2",
        ],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 20
    while len(_children(grader.pid)) < 4 and time.monotonic() < deadline:  # two workers, each with a fork
        time.sleep(0.1)
    below = _children(grader.pid)
    assert len(below) >= 4
    grader.send_signal(signal.SIGTERM)
    out, err = grader.communicate(timeout=20)
    assert grader.returncode == 130 and "Traceback" not in err, err
    assert err.strip() == "autonomy: error: grading interrupted"
    time.sleep(0.5)
    assert [pid for pid in below if _alive(pid)] == []


def test_grading_options_out_of_range_are_one_line_errors():
    for option, value in (
        ("--workers", "0"),
        ("--wall-seconds", "nan"),
        ("--wall-seconds", "inf"),
        ("--cpu-seconds", "nan"),
        ("--cpu-seconds", "0.5"),
        ("--memory-mb", "5"),
    ):
        result = autonomy("grade", "garage", "missions/square.yaml", option, value)
        assert result.returncode == 2 and "Traceback" not in result.stderr
        assert len(result.stderr.strip().splitlines()) == 1 and f"argument {option}: must be from" in result.stderr


def test_an_exercise_name_that_is_not_there_is_one_line_with_the_names_that_are(tmp_path):
    result = autonomy("grade", "bmp", "missions/square.yaml")
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert result.stderr.strip() == (
        "autonomy: error: no exercise named 'bmp' (did you mean 'bump'?): use one of bump, garage, opening, slalom, "
        "square (./exercises/ and those shipped with autonomy), or give the exercise file's path"
    )


def test_a_shipped_exercise_is_found_by_name_from_anywhere_and_a_teacher_s_own_comes_first(tmp_path):
    def grade_here(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, "-m", "autonomy", "grade", *args], capture_output=True, text=True, timeout=60, cwd=tmp_path
        )

    solution = str(ROOT / "exercises" / "solutions" / "garage.yaml")
    shipped = grade_here("garage", solution)  # no exercises folder here
    assert shipped.returncode == 0, shipped.stderr
    assert "for '2. Park in the garage'" in shipped.stdout and "10 / 10" in shipped.stdout
    (tmp_path / "exercises").mkdir()
    own = (ROOT / "exercises" / "garage.yaml").read_text().replace("2. Park in the garage", "Our own garage")
    (tmp_path / "exercises" / "garage.yaml").write_text(own)
    assert "for 'Our own garage'" in grade_here("garage", solution).stdout


def grade_in(folder, *args: str) -> subprocess.CompletedProcess:
    """`autonomy grade` run in ``folder`` (which has an exercises/ of its own)."""
    return subprocess.run(
        [sys.executable, "-m", "autonomy", "grade", *args],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=folder,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )


def test_marks_are_never_written_over_a_file_that_is_graded_nor_twice_to_one_file(tmp_path):
    (tmp_path / "exercises").mkdir()
    exercise = tmp_path / "exercises" / "garage.yaml"
    exercise.write_text((ROOT / "exercises" / "garage.yaml").read_text())
    (tmp_path / "class" / "alice").mkdir(parents=True)
    mission = tmp_path / "class" / "alice" / "mission.yaml"
    mission.write_text((ROOT / "exercises" / "solutions" / "garage.yaml").read_text())
    before = {exercise: exercise.read_bytes(), mission: mission.read_bytes()}
    for target in ("exercises/garage.yaml", "class/alice/mission.yaml"):  # the exercise by its name; inside a folder
        result = grade_in(tmp_path, "garage", "class/alice", "--csv", target)
        assert result.returncode == 2 and "Traceback" not in result.stderr
        assert result.stderr == f"autonomy: error: {target} is one of the files to grade: write the marks elsewhere\n"
    assert {path: path.read_bytes() for path in before} == before
    world = tmp_path / "lab.yaml"  # an exercise beside its world file, both given from their own folder
    world.write_text((ROOT / "autonomy" / "emulator" / "worlds" / "garage.yaml").read_text())
    (tmp_path / "ex.yaml").write_text(exercise.read_text().replace("world: garage", "world: lab.yaml"))
    result = grade_in(tmp_path, "ex.yaml", "class/alice", "--csv", "lab.yaml")
    assert result.returncode == 2 and "lab.yaml is one of the files to grade" in result.stderr
    assert world.read_text() == (ROOT / "autonomy" / "emulator" / "worlds" / "garage.yaml").read_text()
    twice = grade_in(tmp_path, "garage", "class/alice", "--csv", "marks", "--html", "marks")
    assert twice.returncode == 2 and twice.stderr == (
        "autonomy: error: marks is given for two outputs: give each its own file\n"
    )
    assert not (tmp_path / "marks").exists()


def test_a_file_name_that_is_not_utf8_is_graded_and_every_output_written(tmp_path):
    (tmp_path / "exercises").mkdir()
    (tmp_path / "exercises" / "garage.yaml").write_text((ROOT / "exercises" / "garage.yaml").read_text())
    name = os.fsdecode(b"lat\xe9in.yaml")  # unpacked from another system's zip
    (tmp_path / name).write_text((ROOT / "exercises" / "solutions" / "garage.yaml").read_text())
    result = grade_in(tmp_path, "garage", name, "--csv", "m.csv", "--json", "m.json", "--html", "m.html")
    assert result.returncode == 0 and "Traceback" not in result.stderr, result.stderr
    shown = "lat\\xe9in"  # the byte that is not UTF-8 written out: lat\xe9in and lat\xe8in stay two students
    assert result.stdout.splitlines()[2] == f"{shown}: 10 / 10 in '2. Park in the garage'"
    assert next(csv.DictReader((tmp_path / "m.csv").open()))["student"] == shown
    student = json.loads((tmp_path / "m.json").read_text())["students"][0]
    assert (student["student"], student["file"], student["total"]) == (shown, f"{shown}.yaml", 10)
    assert shown in (tmp_path / "m.html").read_text()


def test_check_prints_no_control_character_of_a_file_name(tmp_path):
    """A teacher checks a class's files: a name chosen to set the window title or clear the screen does neither."""
    good = tmp_path / "x\x1b]0;pwned\x07\x1b[2J.yaml"
    good.write_text("mission: m\ntree:\n  beep: {}\n")
    bad = tmp_path / "y\x1b[2J.yaml"
    bad.write_text("mission: m\ntree:\n  mvoe: {}\n")
    result = autonomy("check", str(good), str(bad))
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "\x1b" not in result.stdout + result.stderr and "\x07" not in result.stdout
    assert result.stdout == f"{tmp_path}/x�]0;pwned��[2J.yaml: ok (mission 'm', 1 node)\n"
    assert result.stderr == f"{tmp_path}/y�[2J.yaml:3:3: tree.mvoe: unknown node 'mvoe' (did you mean 'move'?)\n"


def test_a_student_grading_a_mission_that_cannot_run_gets_exit_2(tmp_path):
    mission = tmp_path / "mine.yaml"
    mission.write_text("mission: mine\ntree:\n  mvoe: {speed: 2}\n")
    result = autonomy("grade", "garage", str(mission))
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert f"{mission}:3:3: tree.mvoe: unknown node 'mvoe' (did you mean 'move'?)" in result.stdout


def graded_at_width(columns: str, *files: str) -> str:
    """What `autonomy grade garage FILES` prints in a terminal ``columns`` wide."""
    result = subprocess.run(
        [sys.executable, "-m", "autonomy", "grade", "garage", *files, "--workers", "2"],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
        env={**os.environ, "COLUMNS": columns},
    )
    assert result.returncode == 0, result.stderr
    return result.stdout


@pytest.mark.parametrize(
    ("columns", "expected"),
    [
        (
            "200",
            [
                "┃ student           ┃ total ┃ rest_in_zone garage (5) ┃ max_collisions 0 (3) ┃ "
                "finish_within_s 30 (2) ┃ reach_zone garage (0) ┃",
                "│ garage            │    10 │                       5 │                    3 │                      2 "
                "│                     0 │",
                "│ garage_until_bump │     0 │                       0 │                    0 │                      0 "
                "│                     0 │",
            ],
        ),
        (
            "60",
            [
                "┃ student           ┃ total ┃ #1 ┃ #2 ┃ #3 ┃ #4 ┃",
                "│ garage            │    10 │  5 │  3 │  2 │  0 │",
                "  #1 rest_in_zone garage (5)",
                "  #3 finish_within_s 30 (2)",
            ],
        ),
        (
            "20",
            [
                "garage: 10 (#1 5, #2 3, #3 2, #4 0)",
                "garage_until_bump: 0 (#1 0, #2 0, #3 0, #4 0)",
                "  #2 max_collisions 0 (3)",
            ],
        ),
    ],
)
def test_the_marks_table_fits_the_terminal_naming_criteria_under_it_when_it_must(columns, expected):
    solutions = [ROOT / "exercises" / "solutions" / "garage.yaml", ROOT / "exercises/wrong/garage_until_bump.yaml"]
    lines = graded_at_width(columns, *map(str, solutions)).splitlines()
    assert [line for line in expected if line not in lines] == []


def test_the_marks_table_counts_wide_characters_as_the_terminal_does(tmp_path):
    from rich.cells import cell_len

    (tmp_path / "张伟张伟张伟张伟张伟张伟.yaml").write_text((ROOT / "exercises/solutions/garage.yaml").read_text())
    (tmp_path / "bo.yaml").write_text((ROOT / "exercises/wrong/garage_until_bump.yaml").read_text())
    files = sorted(str(p) for p in tmp_path.glob("*.yaml"))
    for columns in ("200", "60"):
        shown = graded_at_width(columns, *files)
        table = [line for line in shown.splitlines() if line[:1] in "┏┃┡│└"]
        assert table and all(cell_len(line) <= int(columns) for line in table)
        assert "…" not in shown  # no head nor mark cut
        assert "│ 张伟张伟张伟张伟张伟张伟 │    10 │" in shown


def _desk(tmp_path):
    """A class folder: alice (the reference), bob (a fixed distance), zed (into the wall), and the exercise."""
    (tmp_path / "exercises").mkdir()
    (tmp_path / "exercises" / "garage.yaml").write_text((ROOT / "exercises" / "garage.yaml").read_text())
    (tmp_path / "class").mkdir()
    for student, source in (
        ("alice", "solutions/garage.yaml"),
        ("bob", "wrong/garage_fixed_distance.yaml"),
        ("zed", "wrong/garage_until_bump.yaml"),
    ):
        (tmp_path / "class" / f"{student}.yaml").write_text((ROOT / "exercises" / source).read_text())
    return ["class/alice.yaml", "class/bob.yaml", "class/zed.yaml"]


def test_a_roster_puts_ids_first_lists_who_handed_in_nothing_and_who_is_not_on_it(tmp_path):
    files = _desk(tmp_path)
    (tmp_path / "roster.csv").write_text(
        'id,name,submission\n1001,Alice Smith,alice\n1002,"Jones, Bob",class/bob.yaml\n1003,Carol King,carol\n'
    )
    result = grade_in(tmp_path, "garage", *files, "--roster", "roster.csv", "--csv", "marks.csv", "--json", "m.json")
    assert result.returncode == 0, result.stderr
    assert "no submission: 1003 Carol King (roster line 4)" in result.stdout
    assert "not on the roster: zed (class/zed.yaml)" in result.stdout
    rows = list(csv.reader((tmp_path / "marks.csv").read_text().splitlines()))
    # Moodle's grade import: an id column to map to "ID number", the total to map to the assignment
    assert rows[0] == [
        "id", "name", "student", "total", "out_of", "rest_in_zone garage", "max_collisions 0", "finish_within_s 30",
        "reach_zone garage", "adjustment", "adjustment_reasons", "problems",
    ]  # fmt: skip
    assert [row[:4] for row in rows[1:]] == [
        ["1001", "Alice Smith", "alice", "10"],
        ["1002", "Jones, Bob", "bob", "2.5"],
        ["1003", "Carol King", "", "0"],
        ["", "", "zed", "0"],
    ]
    assert rows[3][-1] == "no submission" and rows[4][-1] == "not on the roster"
    document = json.loads((tmp_path / "m.json").read_text())
    assert document["roster"][2] == {"id": "1003", "name": "Carol King", "student": None}
    assert document["not_on_the_roster"] == ["zed"]
    (tmp_path / "twice.csv").write_text("id,name,submission\n7,A,alice\n7,B,bob\n")
    refused = grade_in(tmp_path, "garage", *files, "--roster", "twice.csv")
    assert refused.returncode == 2 and refused.stderr.strip() == "twice.csv:3: id '7' is on line 2 already"
    (tmp_path / "headless.csv").write_text("1001,Alice,alice\n")
    refused = grade_in(tmp_path, "garage", *files, "--roster", "headless.csv")
    said = "headless.csv:1: the roster's first line must name the columns id,name (and perhaps submission);"
    assert refused.returncode == 2 and said in refused.stderr


def test_a_roster_of_ids_and_names_alone_takes_each_id_for_its_submission(tmp_path):
    files = _desk(tmp_path)
    (tmp_path / "roster.csv").write_text("id,name\nalice,Alice Smith\ncarol,Carol King\n")
    result = grade_in(tmp_path, "garage", *files, "--roster", "roster.csv", "--csv", "marks.csv")
    assert result.returncode == 0, result.stderr
    assert "no submission: carol Carol King (roster line 3)" in result.stdout
    rows = list(csv.reader((tmp_path / "marks.csv").read_text().splitlines()))
    assert [row[:4] for row in rows[1:3]] == [["alice", "Alice Smith", "alice", "10"], ["carol", "Carol King", "", "0"]]
    (tmp_path / "twice.csv").write_text("id,name\n7,A\n7,B\n")
    refused = grade_in(tmp_path, "garage", *files, "--roster", "twice.csv")
    assert refused.returncode == 2 and refused.stderr.strip() == "twice.csv:3: id '7' is on line 2 already"


def test_a_teacher_s_correction_is_added_to_the_mark_and_shown_with_its_reason_everywhere(tmp_path):
    files = _desk(tmp_path)
    (tmp_path / "adjust.csv").write_text("student,points,reason\nbob,1.5,the hall's wall stood 2 cm off\n")
    result = grade_in(
        tmp_path, "garage", *files, "--adjust", "adjust.csv", "--csv", "m.csv", "--json", "m.json", "--html", "m.html"
    )
    assert result.returncode == 0, result.stderr
    assert "correction: bob +1.5 (the hall's wall stood 2 cm off)" in result.stdout
    bob = [row for row in csv.reader((tmp_path / "m.csv").read_text().splitlines()) if row[0] == "bob"][0]
    assert bob[1] == "4" and bob[-3:] == ["1.5", "the hall's wall stood 2 cm off", ""]  # 2.5 graded, 1.5 by hand
    document = json.loads((tmp_path / "m.json").read_text())
    assert [s["adjustments"] for s in document["students"]] == [[], [[1.5, "the hall's wall stood 2 cm off"]], []]
    assert "Correction by the teacher: +1.5 (the hall&#x27;s wall stood 2 cm off)" in (tmp_path / "m.html").read_text()
    alone = grade_in(tmp_path, "garage", "class/bob.yaml", "--adjust", "adjust.csv")
    assert "  Correction by the teacher: +1.5 (the hall's wall stood 2 cm off)" in alone.stdout.splitlines()
    (tmp_path / "wrong.csv").write_text("student,points,reason\nbobby,1,typo\nbob,lots,\n")
    refused = grade_in(tmp_path, "garage", *files, "--adjust", "wrong.csv")
    assert refused.returncode == 2 and refused.stderr.splitlines() == [
        "wrong.csv:3: points must be a number from -1000 to 1000, got 'lots'",
        "wrong.csv:3: a correction needs its reason, which the student will read",
    ]
    (tmp_path / "who.csv").write_text("student,points,reason\nbobby,1,typo\n")
    refused = grade_in(tmp_path, "garage", *files, "--adjust", "who.csv")
    assert (
        refused.returncode == 2
        and refused.stderr.strip() == "who.csv:2: no student 'bobby' among the submissions given"
    )


def test_a_grading_is_compared_with_an_earlier_one(tmp_path):
    files = _desk(tmp_path)
    first = grade_in(tmp_path, "garage", *files, "--json", "before.json")
    assert first.returncode == 0, first.stderr
    (tmp_path / "class" / "bob.yaml").write_text((ROOT / "exercises" / "solutions" / "garage.yaml").read_text())
    (tmp_path / "class" / "dan.yaml").write_text(
        (ROOT / "exercises" / "wrong" / "garage_park_then_beep.yaml").read_text()
    )
    again = grade_in(
        tmp_path, "garage", "class/bob.yaml", "class/dan.yaml", "class/zed.yaml", "--compare", "before.json"
    )
    assert again.returncode == 0, again.stderr
    lines = again.stdout.splitlines()
    since = lines[lines.index("Since before.json:") + 1 :]
    assert since == [
        "  changed: bob, 2.5 -> 10 (rest_in_zone garage 1.25 -> 5; max_collisions 0 0.75 -> 3; "
        "finish_within_s 30 0.5 -> 2)",
        "  new: dan, 8",
        "  missing: alice, was 10",
        "  the same: 1 of 3",
    ]
    refused = grade_in(tmp_path, "garage", *files, "--compare", "class/bob.yaml")
    assert refused.returncode == 2 and refused.stderr.startswith(
        "class/bob.yaml:1: not the JSON of an earlier grading (autonomy grade --json)"
    )


#: What Gradescope takes as an autograder's results.json (its published format: a score and tests).
GRADESCOPE_RESULTS = {
    "type": "object",
    "required": ["tests"],
    "properties": {
        "score": {"type": "number"},
        "execution_time": {"type": "number"},
        "output": {"type": "string"},
        "visibility": {"enum": ["hidden", "after_due_date", "after_published", "visible"]},
        "stdout_visibility": {"enum": ["hidden", "after_due_date", "after_published", "visible"]},
        "tests": {
            "type": "array",
            "items": {
                "type": "object",
                "required": ["name"],
                "properties": {
                    "score": {"type": "number"},
                    "max_score": {"type": "number"},
                    "name": {"type": "string"},
                    "number": {"type": "string"},
                    "output": {"type": "string"},
                    "tags": {"type": "array", "items": {"type": "string"}},
                    "visibility": {"enum": ["hidden", "after_due_date", "after_published", "visible"]},
                },
                "additionalProperties": False,
            },
        },
    },
    "additionalProperties": False,
}


@pytest.mark.parametrize(
    ("source", "score", "first_output"),
    [
        ("solutions/garage.yaml", 10, "seed 8: yes garage: came to rest inside it at"),
        ("wrong/garage_fixed_distance.yaml", 2.5, "seed 8: no garage: came to rest 40 mm outside it"),
        (None, 0, "Not graded: "),
    ],
)
def test_the_gradescope_autograder_zip_grades_a_submission_into_results_gradescope_takes(
    tmp_path, source, score, first_output
):
    import zipfile

    import jsonschema

    built = autonomy("gradescope", "exercises/garage.yaml", "-o", str(tmp_path / "autograder.zip"))
    assert built.returncode == 0, built.stderr
    assert built.stdout.startswith(f"wrote {tmp_path / 'autograder.zip'}: the autograder for '2. Park in the garage'")
    root = tmp_path / "autograder"  # Gradescope's /autograder, here
    with zipfile.ZipFile(tmp_path / "autograder.zip") as archive:
        archive.extractall(root / "source")
        names = archive.namelist()
    assert {"setup.sh", "run_autograder", "package/pyproject.toml", "exercise/garage.yaml"} <= set(names)
    assert "package/autonomy/emulator/worlds/garage.yaml" in names
    (root / "submission").mkdir()
    mission = root / "submission" / "my_mission.yaml"
    if source is None:
        mission.write_text("mission: oops\ntree:\n  mvoe: {speed: 2}\n")
    else:
        mission.write_text((ROOT / "exercises" / source).read_text())
    run = subprocess.run(
        ["bash", str(root / "source" / "run_autograder")],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "AUTOGRADER_ROOT": str(root), "AUTONOMY": str(Path(sys.executable).parent / "autonomy")},
    )
    assert run.returncode == 0, run.stderr  # Gradescope reads the results, not the exit code
    results = json.loads((root / "results" / "results.json").read_text())
    jsonschema.validate(results, GRADESCOPE_RESULTS)
    assert results["score"] == score and sum(t["max_score"] for t in results["tests"]) == 10
    assert [t["name"] for t in results["tests"]] == [
        "Parked in the garage", "No crash", "Done within 30 s", "Drove up to the garage"
    ]  # fmt: skip
    assert results["tests"][0]["output"].startswith(first_output)
    assert results["output"].startswith(f"submission: {score:g} / 10 in '2. Park in the garage'")


def test_the_autograder_zip_s_package_builds_and_carries_the_secret_for_hidden_seeds(tmp_path):
    import zipfile

    secret = tmp_path / "secret.txt"
    secret.write_text("a secret of the teacher's, long enough\n")
    built = autonomy(
        "gradescope", "exercises/garage.yaml", "-o", str(tmp_path / "ag.zip"), "--secret-file", str(secret)
    )
    assert built.returncode == 0 and built.stdout.strip().endswith("bytes, 12 hidden seeds from the secret)")
    with zipfile.ZipFile(tmp_path / "ag.zip") as archive:
        archive.extractall(tmp_path / "source")
        assert archive.read("secret.txt") == b"a secret of the teacher's, long enough\n"
        assert "--secret-file ../secret.txt" in archive.read("run_autograder").decode()
    wheel = subprocess.run(  # what setup.sh installs: the package as it grades here, worlds and pages included
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(tmp_path / "w"),
         str(tmp_path / "source" / "package")],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert wheel.returncode == 0, wheel.stderr
    (built_wheel,) = (tmp_path / "w").glob("autonomy-*.whl")
    with zipfile.ZipFile(built_wheel) as archive:
        names = archive.namelist()
    assert "autonomy/emulator/worlds/garage.yaml" in names and "autonomy/views/static/index.html" in names
    assert "autonomy/classroom/gradescope.py" in names


def test_the_teacher_s_files_are_read_as_spreadsheets_save_them_and_every_problem_is_told_at_once(tmp_path):
    files = _desk(tmp_path)
    (tmp_path / "bom.csv").write_bytes(b'\xef\xbb\xbfid,name,submission\r\n1001,"Smith, Alice",alice\r\n')
    saved = grade_in(tmp_path, "garage", *files, "--roster", "bom.csv", "--csv", "m.csv")  # Excel's "CSV UTF-8"
    assert saved.returncode == 0, saved.stderr
    assert (tmp_path / "m.csv").read_text().splitlines()[1].startswith('1001,"Smith, Alice",alice,10,')
    (tmp_path / "open.csv").write_text('id,name,submission\n1,"Smith, Alice,alice\n2,Bob,bob\n')
    (tmp_path / "twice.csv").write_text("id,name,submission\n1,A,alice\n2,B,alice\n")
    (tmp_path / "adjust.csv").write_text("student,points,reason\nnobody,1,typo\nalice,nan,x\n")
    (tmp_path / "square.json").write_text('{"exercise": "square", "criteria": [], "students": []}')
    for roster, expected in (
        ("open.csv", 'open.csv:2: a quote (") is opened and not closed on this line'),
        ("twice.csv", "twice.csv:3: submission 'alice' is on line 2 already"),
    ):
        refused = grade_in(
            tmp_path, "garage", *files, "--roster", roster, "--adjust", "adjust.csv", "--compare", "square.json"
        )
        assert refused.returncode == 2 and refused.stderr.splitlines() == [  # every file's problems, all at once
            expected,
            "adjust.csv:3: points must be a number from -1000 to 1000, got 'nan'",
            "square.json:1: it grades exercise 'square', not 'garage'",
        ], refused.stderr


def test_feedback_pages_show_the_corrections_and_never_share_a_file_or_become_another_output(tmp_path):
    (tmp_path / "exercises").mkdir()
    (tmp_path / "exercises" / "garage.yaml").write_text((ROOT / "exercises" / "garage.yaml").read_text())
    (tmp_path / "c").mkdir()
    for student in ("frank o'neil", "frank_o_neil", "class"):
        (tmp_path / "c" / f"{student}.yaml").write_text((ROOT / "exercises" / "solutions" / "garage.yaml").read_text())
    (tmp_path / "adjust.csv").write_text('student,points,reason\nfrank_o_neil,-2.5,"late, by two days"\n')
    files = ["c/frank o'neil.yaml", "c/frank_o_neil.yaml", "c/class.yaml"]
    result = grade_in(tmp_path, "garage", *files, "--adjust", "adjust.csv", "--feedback", "p", "--html", "class.html")
    assert result.returncode == 0, result.stderr
    assert "wrote 3 feedback pages in p" in result.stdout
    assert sorted(p.name for p in (tmp_path / "p").iterdir()) == [
        "class.html",
        "frank_o_neil-2.html",
        "frank_o_neil.html",
    ]
    late = (tmp_path / "p" / "frank_o_neil-2.html").read_text()  # the second of the two, in sorted order
    assert "frank_o_neil: 7.5 / 10" in late and "Correction by the teacher: -2.5 (late, by two days)" in late
    assert "frank o&#x27;neil: 10 / 10" in (tmp_path / "p" / "frank_o_neil.html").read_text()
    refused = grade_in(tmp_path, "garage", *files, "--feedback", "p", "--html", "p/class.html")
    assert refused.returncode == 2 and "p/class.html is where a student's feedback page goes: write it elsewhere" in (
        refused.stderr
    )


def test_a_submission_folder_may_hold_its_mission_as_xml_in_any_case_or_one_folder_down(tmp_path):
    (tmp_path / "exercises").mkdir()
    (tmp_path / "exercises" / "garage.yaml").write_text((ROOT / "exercises" / "garage.yaml").read_text())
    xml = autonomy("export", str(ROOT / "exercises" / "solutions" / "garage.yaml"), "-o", str(tmp_path / "m.xml"))
    assert xml.returncode == 0, xml.stderr
    for folder, name, text in (
        ("xml", "mission.xml", (tmp_path / "m.xml").read_text()),
        ("upper", "PARK.YAML", (ROOT / "exercises" / "solutions" / "garage.yaml").read_text()),
        ("zipped/hw2", "alice.yaml", (ROOT / "exercises" / "solutions" / "garage.yaml").read_text()),
    ):
        (tmp_path / folder).mkdir(parents=True)
        (tmp_path / folder / name).write_text(text)
    (tmp_path / "odd").mkdir()
    (tmp_path / "odd" / "notes.txt").write_text("no mission here")
    result = grade_in(tmp_path, "garage", "xml", "upper", "zipped", "odd", "--csv", "m.csv")
    assert result.returncode == 0, result.stderr
    rows = {row["student"]: row for row in csv.DictReader((tmp_path / "m.csv").open())}
    assert [rows[s]["total"] for s in ("xml", "upper", "zipped")] == ["10", "10", "10"]
    assert rows["odd"]["problems"] == "odd: no mission file (.yaml, .yml or .xml) in the folder (it holds notes.txt)"


def test_a_student_s_page_and_gradescope_results_name_no_folder_of_the_teacher_s_machine(tmp_path):
    # a teacher's own exercise, its world a file in a folder of theirs, the students' files given by full paths
    folder = tmp_path / "teacher-secret-folder"
    (folder / "worlds").mkdir(parents=True)
    (folder / "worlds" / "hall.yaml").write_bytes(
        (ROOT / "autonomy" / "emulator" / "worlds" / "garage.yaml").read_bytes()
    )
    exercise = (ROOT / "exercises" / "garage.yaml").read_text().replace("world: garage", "world: worlds/hall.yaml")
    (folder / "mine.yaml").write_text(exercise)
    (folder / "alice.yaml").write_bytes((ROOT / "exercises" / "solutions" / "garage.yaml").read_bytes())
    (folder / "bob.yaml").write_text("mission: bob\ntree:\n  mvoe: {speed: 2}\n")
    pages = folder / "pages"
    graded = autonomy("grade", str(folder / "mine.yaml"), str(folder / "alice.yaml"), str(folder / "bob.yaml"),
                      "--feedback", str(pages), "--quiet")  # fmt: skip
    assert graded.returncode == 0, graded.stderr
    results = folder / "results.json"
    scoped = autonomy("grade", str(folder / "mine.yaml"), str(folder / "bob.yaml"), "--gradescope", str(results))
    assert scoped.returncode == 2 and "bob.yaml:3:3" in results.read_text()  # its problem, at its place
    given = [*sorted(pages.glob("*.html")), results]
    assert len(given) == 3
    for shown in given:
        text = shown.read_text()
        assert str(tmp_path) not in text and "teacher-secret-folder" not in text and "worlds/hall" not in text, shown
        assert "worlds%2Fhall" not in text and ("alice.yaml" in text or "bob.yaml" in text), shown
    assert "hall.yaml" in (pages / "alice.html").read_text()  # the world, by its file's name


def test_exercise_list_and_show_give_a_teacher_the_exercises_and_one_to_hand_out(tmp_path):
    listed = autonomy("exercise", "list")
    assert listed.returncode == 0, listed.stderr
    names = [line.split()[0] for line in listed.stdout.splitlines()[:-1]]
    assert names == ["bump", "garage", "opening", "slalom", "square"]
    assert "garage     2. Park in the garage: world garage, 30 s a run, 10 points, 4 seeds, 12 hidden seeds" in (
        listed.stdout
    )
    shown = autonomy("exercise", "show", "garage")
    assert shown.returncode == 0, shown.stderr
    lines = shown.stdout.splitlines()
    assert lines[:2] == ["2. Park in the garage", "====================="]
    told = lines[: next(n for n, line in enumerate(lines) if line.startswith("World: garage."))]
    assert len(told) > 5 and all(len(line) <= 88 for line in told)  # the text, folded for a page
    assert "Your mission is run on 4 seeds (each a little different), and on 12 hidden ones when handed in." in lines
    assert "Marks (10 points):" in lines and "  - No crash: 3" in lines
    assert not any(re.search(r"\bseed \d", line) for line in lines)  # no seed's number, hidden or public
    missing = autonomy("exercise", "show", "garag")
    assert_one_line_error(missing, 2, "no exercise named 'garag' (did you mean 'garage'?)")


def test_expect_lists_each_student_outside_the_band_a_teacher_wrote_first_and_why(tmp_path):
    hand = ROOT / "tests" / "classroom" / "second_class"
    files = [str(hand / f"gar_{name}.yaml") for name in ("255", "fast", "while", "creep")]
    (tmp_path / "fair.csv").write_text(  # bands written before grading: the second class's, a point either way
        "student,lo,hi\ngar_255,2,4\ngar_fast,0,1\ngar_while,7,9\ngar_creep,0,1\n"
    )
    fair = autonomy("grade", "garage", *files, "--expect", str(tmp_path / "fair.csv"), "--quiet")
    assert fair.returncode == 0 and fair.stdout == "4 of 4 students within the band expected\n", fair.stdout
    (tmp_path / "wrong.csv").write_text("student,lo,hi\ngar_255,2,4\ngar_fast,8,10\ngar_while,0,1\nzed,0,10\n")
    told = autonomy("grade", "garage", *files, "--expect", str(tmp_path / "wrong.csv"), "--quiet")
    assert told.returncode == 1, told.stderr
    lines = told.stdout.splitlines()
    assert lines[0].startswith("gar_fast: 0, expected 8 to 10: lost rest_in_zone garage (0 of 5)")
    assert re.match(r"gar_while: \d+(\.\d+)?, expected 0 to 1: earned rest_in_zone garage \(", lines[1]), lines[1]
    assert lines[2:] == ["zed: expected 0 to 10, but has no submission", "1 of 4 students within the band expected"]
    (tmp_path / "bad.csv").write_text("student,lo,hi\na,5,2\na,1,x\n")
    refused = autonomy("grade", "garage", *files, "--expect", str(tmp_path / "bad.csv"))
    assert refused.returncode == 2 and refused.stderr.splitlines() == [
        f"{tmp_path / 'bad.csv'}:2: lo and hi must be numbers, 0 <= lo <= hi, got '5', '2'",
        f"{tmp_path / 'bad.csv'}:3: 'a' is on line 2 already",
        f"{tmp_path / 'bad.csv'}:3: lo and hi must be numbers, 0 <= lo <= hi, got '1', 'x'",
    ]


def test_check_validates_an_exercise_and_grades_its_solution_on_every_seed(tmp_path):
    shipped = autonomy("check", "exercises/garage.yaml", "exercises/square.yaml")
    assert shipped.returncode == 0, shipped.stdout + shipped.stderr
    assert (
        "exercises/garage.yaml: ok (exercise 'garage', world garage, 4 criteria, 10 points, 4 seeds and 12 hidden)"
        in (shipped.stdout)
    )
    assert "  its solution earns 10 of 10 on every one of 3 seeds" in shipped.stdout  # the square, no hidden seeds
    (tmp_path / "secret.txt").write_text("a teacher's secret, long enough\n")
    hidden = autonomy("check", "exercises/garage.yaml", "--secret-file", str(tmp_path / "secret.txt"))
    assert "  its solution earns 10 of 10 on every one of 16 seeds" in hidden.stdout, hidden.stdout
    # a teacher's own exercise whose solution is no solution on every seed: each seed it falls short on, and why
    text = (
        (ROOT / "exercises" / "garage.yaml")
        .read_text()
        .replace("world: garage", f"world: {ROOT}/autonomy/emulator/worlds/garage.yaml")
    )
    (tmp_path / "fixed.yaml").write_bytes((ROOT / "exercises" / "wrong" / "garage_fixed_distance.yaml").read_bytes())
    (tmp_path / "mine.yaml").write_text(text.replace("solution: solutions/garage.yaml", "solution: fixed.yaml"))
    short = autonomy("check", str(tmp_path / "mine.yaml"))
    assert short.returncode == 2, short.stdout
    assert re.search(
        r"^  its solution falls short on seed 8: rest_in_zone garage: garage: came to rest", short.stdout, re.M
    )
    (tmp_path / "gone.yaml").write_text(text.replace("solution: solutions/garage.yaml", "solution: nowhere.yaml"))
    gone = autonomy("check", str(tmp_path / "gone.yaml"))
    assert gone.returncode == 2 and "mine.yaml" not in gone.stderr
    assert (
        gone.stderr
        == f"{tmp_path / 'gone.yaml'}: solution: the solution file {tmp_path / 'nowhere.yaml'} is not there\n"
    )
    assert (
        autonomy("grade", str(tmp_path / "gone.yaml"), str(tmp_path / "fixed.yaml")).returncode == 0
    )  # graded all the same

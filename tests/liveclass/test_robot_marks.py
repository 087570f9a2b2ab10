"""A run on a robot counts for no marks unless the teacher says so: the exercise gives such runs ``robot_points``,
and the teacher, having watched a run, marks it at the desk. A student's best-marked run counts beside their
hand-in, in the gradebook's own column; a run that lost its robot is never marked; a student never marks."""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import sqlite3

import pytest

from autonomy.classroom.exercise import ExerciseInvalid, load_exercise
from autonomy.classroom.gradebook import RosterEntry, RosterMatch
from autonomy.classroom.report import to_csv
from autonomy.classroom.results import Report
from autonomy.cli.exercises import exercise_text
from autonomy.liveclass.robots import ROBOT_LOST
from autonomy.liveclass.store import ClassStore
from tests.cli.test_cli import ROOT
from tests.liveclass.test_robots import SHORT, TEACHER, class_with, desk, ticket, until
from tests.liveclass.test_server import SOLUTION, call, fetch

MARKED = dataclasses.replace(SHORT, robot_points=5.0)


def gradebook(server) -> dict[str, dict[str, str]]:
    status, _, body = fetch(server, "/api/export/grades.csv", TEACHER)
    assert status == 200
    return {row["id"]: row for row in csv.DictReader(io.StringIO(body.decode()))}


def test_the_teacher_marks_a_watched_run_and_the_best_marked_counts_beside_the_hand_in(tmp_path):
    store = ClassStore(tmp_path)
    store.enrol([("s1", "Ada"), ("s2", "Bob")])
    earlier = store.add_robot_run("s2", "a", SOLUTION, "succeeded", "")  # kept before the server started
    lost = store.add_robot_run("s2", "a", SOLUTION, ROBOT_LOST, "")
    store.close()
    server, _ = class_with(tmp_path, {"a": "emu://?world=garage"}, MARKED)
    codes = server.store.new_codes(["s1", "s2"])  # enrolled before: their codes made anew
    try:
        until(lambda: desk(server)["robots"][0]["state"] == "free")
        # a real run, on the in-process robot: listed on the desk as soon as it is kept, not marked
        assert call(server, "/api/run", {"mission": SOLUTION}, codes["s1"])[0] == 200
        assert call(server, "/api/robot", {"mission": SOLUTION}, codes["s1"])[0] == 200
        assert call(server, "/api/robots/start", {"robot": "a"}, TEACHER)[0] == 200
        done = until(lambda: (t := ticket(server, codes["s1"]))["state"] == "done" and t, timeout_s=30)
        shown = desk(server)
        assert shown["robot_points"] == 5
        assert [(r["number"], r["name"], r["points"]) for r in shown["runs"]] == [
            (done["run"], "Ada", None),
            (lost, "Bob", None),
            (earlier, "Bob", None),
        ]
        assert shown["runs"][0]["page"].startswith(f"/robot-runs/{done['run']}-")
        # the teacher's alone, within the exercise's points, never a run that lost its robot
        assert call(server, "/api/robots/mark", {"run": done["run"], "points": 5}, codes["s1"])[0] == 401
        for points in (6, -1, "4", True, float("nan")):
            status, refused = call(server, "/api/robots/mark", {"run": done["run"], "points": points}, TEACHER)
            assert status == 409 and "from 0 to 5" in refused["error"], points
        status, refused = call(server, "/api/robots/mark", {"run": lost, "points": 3}, TEACHER)
        assert status == 409 and "not the student's doing" in refused["error"]
        assert call(server, "/api/robots/mark", {"run": 999, "points": 3}, TEACHER)[0] == 409
        assert call(server, "/api/robots/mark", {"run": done["run"]}, TEACHER)[0] == 400
        for number in (2**63, -(2**63) - 1, 1.0, True, "1"):  # no run, and no number the store could take
            assert call(server, "/api/robots/mark", {"run": number, "points": 1}, TEACHER)[0] == 400, number
        # a mark is kept in hundredths, as the pages and the gradebook show it: never 1e-320, nor -0
        for points in (1e-320, -0.0):
            status, marked = call(server, "/api/robots/mark", {"run": done["run"], "points": points}, TEACHER)
            assert status == 200 and json.dumps(marked["runs"][0]["points"]) == "0.0"
        assert gradebook(server)["s1"]["on_robot"] == "0"
        # marked: on the desk, the student's page, the class table and the gradebook
        status, marked = call(server, "/api/robots/mark", {"run": done["run"], "points": 3.5}, TEACHER)
        assert status == 200 and marked["runs"][0]["points"] == 3.5
        assert ticket(server, codes["s1"])["points"] == 3.5
        status, me = call(server, "/api/me", code=codes["s1"], method="GET")
        assert me["exercise"]["robot_points"] == 5 and [r["points"] for r in me["robot_runs"]] == [3.5]
        status, handed = call(server, "/api/handin", {"mission": SOLUTION}, codes["s1"])
        assert status == 200 and handed["max_points"] == 10
        book = gradebook(server)
        assert float(book["s1"]["total"]) == pytest.approx(handed["total"] + 3.5)
        assert (book["s1"]["out_of"], book["s1"]["on_robot"]) == ("15", "3.5")
        assert (book["s2"]["total"], book["s2"]["on_robot"], book["s2"]["problems"]) == ("0", "0", "no submission")
        # a student's best-marked run counts, handed in or not; a mark taken back counts no more
        assert call(server, "/api/robots/mark", {"run": earlier, "points": 4}, TEACHER)[0] == 200
        assert (gradebook(server)["s2"]["total"], gradebook(server)["s2"]["on_robot"]) == ("4", "4")
        status, table = call(server, "/api/class", code=TEACHER, method="GET")
        rows = {row["id"]: row for row in table["students"]}
        assert table["robot_points"] == 5 and (rows["s1"]["robot_points"], rows["s2"]["robot_points"]) == (3.5, 4)
        assert call(server, "/api/robots/mark", {"run": earlier, "points": None}, TEACHER)[0] == 200
        assert gradebook(server)["s2"]["on_robot"] == "0"
    finally:
        server.stop()
        server.store.close()
    # kept on disk: a class served again has its marks
    again = ClassStore(tmp_path)
    assert again.robot_marks() == {"s1": 3.5}
    again.close()


def test_without_robot_points_a_run_on_a_robot_counts_for_no_marks(tmp_path):
    store = ClassStore(tmp_path)
    store.enrol([("s1", "Ada")])
    run = store.add_robot_run("s1", "a", SOLUTION, "succeeded", "")
    store.close()
    server, codes = class_with(tmp_path, {"a": "emu://?world=garage"}, SHORT)
    try:
        status, refused = call(server, "/api/robots/mark", {"run": run, "points": 1}, TEACHER)
        assert status == 409 and "robot_points: N" in refused["error"]
        assert desk(server)["robot_points"] == 0
        assert "on_robot" not in next(iter(gradebook(server).values()))
    finally:
        server.stop()
        server.store.close()


def test_a_class_kept_before_runs_had_marks_is_read_and_marked(tmp_path):
    old = sqlite3.connect(tmp_path / "class.sqlite")
    old.executescript(
        "CREATE TABLE robot_runs (id INTEGER PRIMARY KEY AUTOINCREMENT, student TEXT NOT NULL, robot TEXT NOT NULL,"
        " at TEXT NOT NULL, source TEXT NOT NULL, outcome TEXT NOT NULL, summary TEXT NOT NULL DEFAULT '');"
        "INSERT INTO robot_runs (student, robot, at, source, outcome) VALUES ('s1', 'a', 'then', '', 'succeeded');"
    )
    old.close()
    store = ClassStore(tmp_path)
    try:
        assert store.robot_runs("s1")[0]["points"] is None
        store.mark_robot_run(1, 2.0)
        assert store.robot_marks() == {"s1": 2.0}
    finally:
        store.close()


def test_the_gradebook_s_robot_column_counts_in_the_total_of_a_student_who_handed_in_nothing():
    roster = [RosterEntry("s1", "Ada", "", 2), RosterEntry("s2", "Bob", "", 3)]
    report = Report("s1", "s1.yaml", 7.0, MARKED.max_points, [7.0] + [0.0] * (len(MARKED.criteria) - 1))
    text = to_csv(MARKED, [report], RosterMatch([(roster[0], report), (roster[1], None)], []), {"s2": 2.5})
    rows = list(csv.DictReader(io.StringIO(text)))
    most = f"{MARKED.max_points + 5:g}"
    assert [(r["id"], r["total"], r["out_of"], r["on_robot"], r["problems"]) for r in rows] == [
        ("s1", "7", most, "0", ""),
        ("s2", "2.5", most, "2.5", "no submission"),
    ]
    assert "on_robot" not in to_csv(MARKED, [report])  # autonomy grade: no runs on robots, no column


def test_an_exercise_s_robot_points_are_a_number_said_at_its_line(tmp_path):
    text = (ROOT / "exercises" / "garage.yaml").read_text()
    good = tmp_path / "good.yaml"
    good.write_text(text + "robot_points: 4\n")
    assert load_exercise(good).robot_points == 4 and load_exercise(ROOT / "exercises" / "garage.yaml").robot_points == 0
    handed_out = exercise_text(load_exercise(good))  # autonomy exercise show: what a student is given
    assert "  - a run on one of the class's robots, marked by your teacher: up to 4 more" in handed_out
    assert not any("robots" in line for line in exercise_text(load_exercise(ROOT / "exercises" / "garage.yaml")))
    bad = tmp_path / "bad.yaml"
    bad.write_text(text + "robot_points: lots\n")
    with pytest.raises(ExerciseInvalid) as refused:
        load_exercise(bad)
    (problem,) = refused.value.problems
    assert (problem.line, problem.column) == (len(text.splitlines()) + 1, 15) and "number" in problem.message

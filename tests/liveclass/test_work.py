"""Checking a student's mission text for the class's page: problems where they stand, or the tree."""

from __future__ import annotations

from autonomy.classroom.exercise import load_exercise
from autonomy.liveclass.work import MAX_MISSION_CHARS, check
from tests.views.conftest import ROOT

GARAGE = load_exercise(ROOT / "exercises" / "garage.yaml")
SQUARE = load_exercise(ROOT / "exercises" / "square.yaml")  # it allows a few nodes only


def test_a_mission_with_a_typo_is_told_at_its_line_and_column():
    answer = check(GARAGE, "mission: park\ntree:\n  sequence:\n    - mvoe: {speed: 2, seconds: 1}\n")
    assert answer["ok"] is False and answer["tree_svg"] == ""
    (problem,) = answer["problems"]
    assert (problem["line"], problem["column"]) == (4, 7)
    assert "mvoe" in problem["message"] and "move" in problem["message"]  # the node it may have meant


def test_a_node_the_exercise_does_not_allow_is_told_where_it_stands():
    answer = check(SQUARE, "mission: park\ntree:\n  sequence:\n    - wait: {seconds: 1}\n")
    assert answer["ok"] is False
    assert [(p["line"], p["message"].split(" (")[0]) for p in answer["problems"]] == [
        (4, "'wait' is not allowed in this exercise")
    ]


def test_a_good_mission_gets_its_tree_drawn_and_a_plugin_is_refused_unrun(tmp_path):
    answer = check(
        GARAGE, "mission: park\ntree:\n  sequence:\n    - move: {speed: 2, until_obstacle_mm: 60}\n    - beep\n"
    )
    assert answer["ok"] is True and answer["problems"] == []
    assert answer["tree_svg"].startswith("<svg") and answer["tree_svg"].count('class="node') == 3
    planted = tmp_path / "evil.py"
    planted.write_text("raise SystemExit('ran')\n")
    refused = check(GARAGE, f"mission: park\nplugins: [{planted}]\ntree: {{move: {{speed: 2, seconds: 1}}}}\n")
    assert refused["ok"] is False and "plugin" in refused["problems"][0]["message"]


def test_a_mission_longer_than_taken_is_refused_in_one_problem():
    answer = check(GARAGE, "#" * (MAX_MISSION_CHARS + 1))
    assert answer["ok"] is False and len(answer["problems"]) == 1 and "at most" in answer["problems"][0]["message"]


def test_a_run_is_graded_on_the_public_seeds_and_a_hand_in_on_every_one_in_a_worker_forked_from_a_clean_process(
    tmp_path,
):
    import threading

    from autonomy.classroom.pool import grade_class
    from autonomy.liveclass.work import grade_text

    secret_exercise = GARAGE.with_secret(b"the teacher's secret")
    text = (ROOT / "exercises" / "solutions" / "garage.yaml").read_text()
    busy = threading.Event()
    beside = threading.Thread(target=busy.wait)  # a server has threads of its own: the workers do not fork from it
    beside.start()
    try:
        run, run_page = grade_text(secret_exercise, "ada", text, tmp_path, 1, hand_in=False)
        handin, handin_page = grade_text(secret_exercise, "ada", text, tmp_path, 2, hand_in=True)
    finally:
        busy.set()
        beside.join()
    public = [seed for seed in secret_exercise.seeds if not seed.hidden]
    assert [s.seed for s in run.seeds] == [s.label for s in public]
    assert len(handin.seeds) == len(secret_exercise.seeds) > len(public)
    assert handin.total == run.total == GARAGE.max_points  # the reference solution, on every seed
    assert (tmp_path / "works" / "ada" / "1-run.yaml").read_text() == text
    assert (tmp_path / "works" / "ada" / "2-handin.yaml").read_text() == text
    assert run_page.is_file() and handin_page.is_file() and run_page != handin_page
    kept = tmp_path / "works" / "ada" / "2-handin.yaml"
    (forked,) = grade_class(secret_exercise, [("ada-2", kept)], workers=1)  # as `autonomy grade` marks it
    assert forked.marks == handin.marks


def test_what_a_student_is_shown_of_the_exercise_keeps_its_lines_and_shows_no_control_character():
    import dataclasses

    from autonomy.liveclass.work import exercise_shown

    exercise = load_exercise(ROOT / "exercises" / "garage.yaml")
    text = "Park.\nThen stop.\u202e\x07"
    shown = exercise_shown(dataclasses.replace(exercise, description=text))
    assert shown["description"] == "Park.\nThen stop.\ufffd\ufffd"


def _graded_in_a_daemon(answers, exercise, text: str) -> None:
    from autonomy.liveclass.work import grade_on_worker

    report, page = grade_on_worker(exercise, "s1", text, 1, False, "run 1")
    answers.put((report.to_json(), page))


def test_a_dask_worker_that_is_a_daemon_grades_through_a_process_of_its_own(tmp_path):
    import multiprocessing

    from autonomy.liveclass.work import grade_text

    garage = GARAGE
    text = (ROOT / "exercises" / "solutions" / "garage.yaml").read_text()
    context = multiprocessing.get_context("spawn")
    answers = context.Queue()
    daemon = context.Process(target=_graded_in_a_daemon, args=(answers, garage, text), daemon=True)
    daemon.start()  # a daemon may not start a multiprocessing child: as a Dask worker is by default
    there, page = answers.get(timeout=120)
    daemon.join(30)
    report, path = grade_text(garage, "s1", text, tmp_path, 1, False, "run 1")
    assert there == report.to_json() and there["total"] == 10 and page == path.read_bytes()

"""The page's data without a server: a replay's rows, what cannot be replayed, and a page that holds several runs."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import msgspec
import pytest

from autonomy.classroom.exercise import load_exercise
from autonomy.classroom.job import grade_one
from autonomy.classroom.report import write_feedback_page
from autonomy.client import Client
from autonomy.mission import build_tree, load_mission
from autonomy.record import Event, Pose, RunHeader, TickRecord
from autonomy.runner import Runner
from autonomy.views.page import ROW_FIELDS, VIEWER_ID, ReplayMaker, replay_payload
from tests.views.conftest import ROOT

STATUS_FIELDS = {"front_distance_mm", "heading_deg", "tilt_deg"}
OMITTED: dict = {"nodes": {}, "events": [], "truth": None}  # a tick's line leaves these out when empty


def recorded(mission: str = "missions/square.yaml") -> list:
    records: list = []
    spec = load_mission(ROOT / mission)
    client = Client.open("emu://?time=virtual&world=square")
    try:
        Runner(build_tree(spec), client, mission=spec.name, listeners=[records.append]).run()
    finally:
        client.close()
    return records


def test_a_replay_row_holds_what_the_page_draws_of_its_tick():
    records = recorded()
    ticks = [r for r in records if isinstance(r, TickRecord)]
    payload = json.loads(replay_payload(records, at_end=True))
    assert payload["mode"] == "replay" and payload["open_at_end"] is True and "ticks" not in payload
    assert payload["row_fields"] == list(ROW_FIELDS) and len(payload["rows"]) == len(ticks) > 100
    assert payload["end"]["outcome"] == records[-1].outcome == "succeeded"
    assert payload["header"]["mission"] == records[0].mission and "<svg" in payload["tree_svg"]
    for row, tick in zip(payload["rows"], ticks, strict=True):
        whole = json.loads(tick.to_line())
        for name, value in zip(payload["row_fields"], row, strict=True):
            expected = whole["status"][name] if name in STATUS_FIELDS else whole.get(name, OMITTED.get(name))
            assert value == expected, (tick.tick, name)
    assert sum(bool(row[ROW_FIELDS.index("nodes")]) for row in payload["rows"]) > 10  # the tree's changes are in
    # a third of the records' size: the page draws no wire, nor the status's flags and bytes
    assert len(",".join(json.dumps(r) for r in payload["rows"])) < 0.5 * sum(len(t.to_line()) for t in ticks)


def test_a_number_json_cannot_hold_stops_the_replay_and_a_lone_surrogate_is_escaped():
    records = recorded()
    header, ticks = records[0], [r for r in records if isinstance(r, TickRecord)]
    odd = msgspec.structs.replace(ticks[3], events=[Event("log", "half \ud800 a pair")])
    maker = ReplayMaker()
    for record in [header, ticks[0], odd, ticks[4]]:
        maker(record)
    rows = json.loads(maker.payload())["rows"]
    assert [row[0] for row in rows] == [ticks[0].tick, ticks[3].tick, ticks[4].tick]
    assert rows[1][ROW_FIELDS.index("events")][0]["message"] == "half \ud800 a pair"
    for field, value in (("time_s", math.nan), ("dead_reckoning", Pose(1.0, math.inf, 0.0))):
        broken = ReplayMaker()
        for record in [header, ticks[0], msgspec.structs.replace(ticks[1], **{field: value}), ticks[2]]:
            broken(record)  # a listener of a run: it never raises
        with pytest.raises(ValueError, match=f"tick {ticks[1].tick} holds a number that is not finite"):
            broken.payload()
    off_emulator = ReplayMaker()  # a run with no truth: null is what it holds, not a fault
    for record in [header, msgspec.structs.replace(ticks[0], truth=None)]:
        off_emulator(record)
    assert json.loads(off_emulator.payload())["rows"][0][ROW_FIELDS.index("truth")] is None
    again = ReplayMaker()  # a new header starts again
    for record in [header, ticks[0], RunHeader(**{**vars(header), "mission": "second"}), ticks[1]]:
        again(record)
    assert len(json.loads(again.payload())["rows"]) == 1


def test_a_feedback_page_holds_the_viewer_once_each_run_once_and_tells_a_run_it_cannot_replay(tmp_path):
    exercise = load_exercise(ROOT / "exercises" / "garage.yaml")
    runs: list[ReplayMaker] = []
    report = grade_one(exercise, "alice", ROOT / "exercises" / "solutions" / "garage.yaml", runs=runs)
    assert len(runs) == len(exercise.seeds) == 4
    text = write_feedback_page(exercise, report, tmp_path, runs, "alice").read_text(encoding="utf-8")
    assert text.isascii()  # one byte a character, however long
    assert text.count(f'id="{VIEWER_ID}"') == 1 and text.count("<iframe") == 4
    for number in range(1, 5):
        data = text.split(f'<script id="run-{number}" type="application/json">')[1].split("</script>")[0]
        assert "<" not in data and json.loads(data)["rows"]
    tick = next(r for r in recorded() if isinstance(r, TickRecord))
    runs[2](msgspec.structs.replace(tick, time_s=math.nan))  # a number JSON cannot hold, in the third seed's run
    text = write_feedback_page(exercise, report, tmp_path, runs, "alice").read_text(encoding="utf-8")
    assert text.count("<iframe") == 3 and text.count('data-run="run-') == 3
    assert f"This run cannot be replayed: tick {tick.tick} holds a number that is not finite." in text


def test_making_a_student_s_pages_needs_none_of_the_server_s_packages():
    # a grader's workers make the pages: a package imported there is imported by every worker
    code = (
        "import sys, autonomy.classroom.pool, autonomy.classroom.report, autonomy.views.page\n"
        "print(sorted(m for m in ('aiohttp', 'zmq') if m in sys.modules))"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert result.stdout.strip() == "[]"


def test_a_student_s_page_names_no_hidden_seed_and_is_the_same_bytes_graded_twice(tmp_path):
    exercise = load_exercise(ROOT / "exercises" / "garage.yaml").with_secret(b"a teacher's secret, long enough")
    hidden = [seed.seed for seed in exercise.seeds if seed.hidden]
    assert len(hidden) == 12
    pages = []
    for folder in (tmp_path / "one", tmp_path / "two"):
        folder.mkdir()
        runs: list[ReplayMaker] = []
        report = grade_one(exercise, "alice", ROOT / "exercises" / "solutions" / "garage.yaml", runs=runs)
        pages.append(write_feedback_page(exercise, report, folder, runs, "alice").read_bytes())
    assert pages[0] == pages[1]  # no date, nothing of the machine or the hour
    text = pages[0].decode()
    assert text.count("<iframe") == 16 and "hidden seed 12" in text
    for number in hidden:  # with a hidden seed's number, its run could be made again before the marks
        assert str(number) not in text, number
    headers = [
        json.loads(text.split(f'<script id="run-{n}" type="application/json">')[1].split("</script>")[0])["header"]
        for n in range(1, 17)
    ]
    assert [h["seed"] for h in headers[:4]] == [s.seed for s in exercise.seeds[:4]]  # the public ones say theirs
    assert all(h["seed"] is None and h["port"].startswith("the exercise's emulator, hidden seed") for h in headers[4:])


def test_a_page_with_nothing_to_replay_holds_no_viewer(tmp_path):
    exercise = load_exercise(ROOT / "exercises" / "garage.yaml")
    broken = tmp_path / "broken.yaml"
    broken.write_text("mission: oops\ntree:\n  mvoe: {speed: 2}\n")
    runs: list[ReplayMaker] = []
    report = grade_one(exercise, "bob", broken, runs=runs)
    text = write_feedback_page(exercise, report, tmp_path, runs, "bob").read_text()
    assert "unknown node &#x27;mvoe&#x27;" in text and VIEWER_ID not in text and len(text) < 8_000

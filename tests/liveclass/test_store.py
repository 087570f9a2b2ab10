"""The class's storage: codes, works kept, and nothing acknowledged lost to kill -9."""

from __future__ import annotations

import signal
import subprocess
import sys

import pytest

from autonomy.liveclass.store import CODE_ALPHABET, CODE_LENGTH, ClassStore, StoreError
from tests.views.conftest import ROOT


def test_a_roster_enrolled_twice_keeps_each_student_s_code_and_codes_are_kept_only_as_digests(tmp_path):
    store = ClassStore(tmp_path)
    first = store.enrol([("s1", "Ada"), ("s2", "Bob")])
    again = store.enrol([("s1", "Ada"), ("s2", "Bob"), ("s3", "Cy")])
    assert set(first) == {"s1", "s2"} and set(again) == {"s3"}  # the new student alone gets a new code
    for code in (*first.values(), *again.values()):
        assert len(code) == CODE_LENGTH and set(code) <= set(CODE_ALPHABET)
    assert store.student_by_code(first["s1"]).name == "Ada"
    assert store.student_by_code(f"  {first['s2'].upper()} ").id == "s2"  # typed with spaces and capitals
    assert store.student_by_code("not-a-code") is None and store.student_by_code("") is None
    kept = (tmp_path / "class.sqlite").read_bytes() + (tmp_path / "class.sqlite-wal").read_bytes()
    assert not any(code.encode() in kept for code in (*first.values(), *again.values()))
    assert [s.id for s in store.students()] == ["s1", "s2", "s3"]


def test_works_are_kept_in_order_and_the_class_table_says_the_last_of_each(tmp_path):
    store = ClassStore(tmp_path)
    store.enrol([("s1", "Ada"), ("s2", "Bob")])
    store.add_work("s1", "run", "tree: a", {}, problem="mission.yaml:3:5: unknown node 'mvoe'")
    store.add_work("s1", "handin", "tree: b", {"marks": [1, 2]}, 3.0, 10.0)
    store.add_work("s1", "handin", "tree: c", {"marks": [4, 4]}, 8.0, 10.0)
    assert [w.source for w in store.works("s1")] == ["tree: a", "tree: b", "tree: c"]
    assert [w.result for w in store.works("s1", "handin")] == [{"marks": [1, 2]}, {"marks": [4, 4]}]
    ada, bob = store.summary()
    assert (ada["runs"], ada["handins"], ada["total"], ada["max_points"]) == (1, 2, 8.0, 10.0)
    assert ada["last_problem"] == ""  # fixed since: her last hand-in has none
    assert (bob["runs"], bob["handins"], bob["total"]) == (0, 0, None)
    store.add_work("s2", "run", "tree: d", {}, problem="mission.yaml:2:1: 'tree' is missing")
    assert store.summary()[1]["last_problem"] == "mission.yaml:2:1: 'tree' is missing"


def test_a_work_is_kept_in_one_write_under_the_number_it_was_graded_as_and_no_number_is_given_twice(tmp_path):
    store = ClassStore(tmp_path)
    store.enrol([("s1", "Ada"), ("s2", "Bob")])
    grading = store.new_number()  # Ada's run, being graded: its files have the number, the database nothing yet
    assert store.works("s1") == [] and store.summary()[0]["runs"] == 0
    refused = store.add_work("s2", "run", "tree: a", {}, problem="refused")  # Bob's, kept meanwhile
    writes = []
    store._db.set_trace_callback(lambda sql: writes.append(sql) if sql == "COMMIT" else None)
    for k in range(3):
        store.add_work(
            "s1", "run", f"tree: {k}", {"marks": [k]}, k, 10.0, number=grading if k == 0 else None, runs_kept=2
        )
    store._db.set_trace_callback(None)
    assert len(writes) == 3  # one a work: its row, and the texts of her runs but the last two forgotten, at once
    numbers = [w.id for w in store.works("s1")]
    assert numbers[0] == grading and refused not in numbers and len(set(numbers + [refused])) == 4
    assert [w.source for w in store.works("s1")] == ["", "tree: 1", "tree: 2"]
    assert [w.result for w in store.works("s1")] == [{"marks": [0]}, {"marks": [1]}, {"marks": [2]}]
    given = store.new_number()
    store.close()
    again = ClassStore(tmp_path)  # a new start gives none of the numbers kept
    assert again.new_number() > max(numbers) and given > max(numbers)


WRITER = """
import sys
from pathlib import Path
from autonomy.liveclass.store import ClassStore
store = ClassStore(Path(sys.argv[1]))
store.enrol([("s1", "Ada")])
while True:
    number = store.add_work("s1", "handin", "tree: x" * 100, {"marks": [1]}, 1.0, 10.0)
    print(number, flush=True)  # acknowledged: only now is the hand-in said to be kept
"""


def test_every_hand_in_acknowledged_before_a_kill_9_is_there_after_it(tmp_path):
    command = [sys.executable, "-c", WRITER, str(tmp_path)]
    writer = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, text=True)
    acknowledged = [int(writer.stdout.readline()) for _ in range(200)]
    writer.send_signal(signal.SIGKILL)  # in the middle of a write, most likely
    writer.wait()
    acknowledged += [int(line) for line in writer.stdout.read().split()]
    kept = {work.id for work in ClassStore(tmp_path).works("s1")}
    assert set(acknowledged) <= kept and len(acknowledged) >= 200


def test_the_roster_changes_the_class_a_student_let_go_cannot_sign_in_and_is_back_with_their_work(tmp_path):
    store = ClassStore(tmp_path)
    codes = store.enrol([("s1", "Ada"), ("s2", "Bob")])
    store.add_work("s2", "handin", "mission: m\n", {}, 7.0, 10.0)
    assert store.enrol([("s1", "Ada King")]) == {}  # Bob leaves, Ada is renamed
    assert store.student_by_code(codes["s2"]) is None
    assert [(s.id, s.name) for s in store.students()] == [("s1", "Ada King")]
    assert [row["id"] for row in store.summary()] == ["s1"]
    assert store.enrol([("s1", "Ada King"), ("s2", "Bob")]) == {}  # back, with the code and the work he had
    assert store.student_by_code(codes["s2"]).id == "s2"
    assert store.summary()[1]["total"] == 7.0


def test_new_codes_replace_the_old_ones_and_a_student_not_in_the_class_is_said(tmp_path):
    store = ClassStore(tmp_path)
    old = store.enrol([("s1", "Ada"), ("s2", "Bob")])
    new = store.new_codes(["s1"])
    assert set(new) == {"s1"} and new["s1"] != old["s1"]
    assert store.student_by_code(old["s1"]) is None and store.student_by_code(new["s1"]).id == "s1"
    assert store.student_by_code(old["s2"]).id == "s2"
    with pytest.raises(StoreError, match="not in the class: s9"):
        store.new_codes(["s1", "s9"])
    assert store.student_by_code(new["s1"]).id == "s1"  # nothing changed


def test_a_class_kept_before_students_could_leave_the_roster_is_opened(tmp_path):
    import sqlite3

    old = sqlite3.connect(tmp_path / "class.sqlite")
    old.executescript(
        "CREATE TABLE students (id TEXT PRIMARY KEY, name TEXT NOT NULL, code_sha256 TEXT NOT NULL UNIQUE, "
        "signed_in TEXT NOT NULL DEFAULT '');"
        "INSERT INTO students VALUES ('s1', 'Ada', 'x', '');"
    )
    old.commit()
    old.close()
    assert [s.id for s in ClassStore(tmp_path).students()] == ["s1"]

"""The lock: `make test` runs in an environment that is exactly requirements.lock, which meets pyproject.toml."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

from tests.lockfile import LOCK, ROOT, differences, every_pin, installed, locked

try:
    import tomllib
except ImportError:  # Python 3.10
    import tomli as tomllib


def test_the_environment_is_the_lock():
    if Path(sys.prefix).resolve() != (ROOT / ".venv").resolve():
        pytest.skip(f"the lock describes {ROOT / '.venv'}, not {sys.prefix} (make test-latest, make mutation)")
    assert differences(locked(), installed()) == []


def test_the_lock_pins_what_pyproject_asks_for_in_its_ranges():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    asked = [
        *project["project"]["dependencies"],
        *project["project"]["optional-dependencies"]["test"],
        *project["build-system"]["requires"],  # installed from the lock too: .venv builds the project itself
    ]
    here, forks = locked(), every_pin()
    for text in asked:
        requirement = Requirement(text)
        name = canonicalize_name(requirement.name)
        if not requirement.marker or requirement.marker.evaluate():
            assert name in here, f"{text} is not in {LOCK.name} for this Python: run make lock"
        versions = [(version, number) for pinned, version, _, number in forks if pinned == name]
        assert versions, f"{text} is not in {LOCK.name}: run make lock"
        for version, number in versions:  # for every Python and platform, not only this one
            assert requirement.specifier.contains(version, prereleases=True), f"{LOCK.name}:{number}: {name}=={version}"


def test_every_pin_has_its_hashes():
    text = LOCK.read_text(encoding="utf-8")
    pins = re.findall(r"^(\S+==\S+)(.*(?:\n[ \t]+.*)*)", text, flags=re.MULTILINE)
    assert len(pins) >= len(locked())
    unhashed = [pin for pin, rest in pins if "--hash=sha256:" not in rest]
    assert not unhashed


def test_the_lock_reader_refuses_what_it_cannot_compare(tmp_path):
    lock = tmp_path / "requirements.lock"
    lock.write_text("a==1 ; python_version >= '3'\nb==2 ; python_version < '3'\n    --hash=sha256:00\n# c==3\n")
    assert locked(lock) == {"a": "1"}
    lock.write_text("a>=1\n")
    with pytest.raises(ValueError, match="requirements.lock:1: not a pin of one version"):
        locked(lock)
    lock.write_text("a==1\nA==2\n")
    with pytest.raises(ValueError, match="pinned twice"):
        locked(lock)
    assert differences({"a": "1", "b": "2"}, {"a": "1", "b": "3", "c": "4"}) == ["b: 2 -> 3", "c: not locked -> 4"]

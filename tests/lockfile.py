"""The lock file (requirements.lock) and the environment it makes: what each pins, what differs.

``make test-latest`` runs it as ``python -m tests.lockfile``, to say which of the newest releases
it installed are not the locked ones: what ``make lock`` would change.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from packaging.markers import Marker
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parents[1]
LOCK = ROOT / "requirements.lock"

#: A pin of the lock: ``name==version``, and its environment marker after ``;``, if any.
_PIN = re.compile(r"^([A-Za-z0-9][A-Za-z0-9._-]*)==([^\s;\\]+)\s*(?:;\s*([^\\]+?))?\s*\\?$")


def every_pin(path: Path = LOCK) -> list[tuple[str, str, Marker | None, int]]:
    """Every pin of the lock, whatever Python or platform it is for: normalised name, version, marker, line.

    Raises:
        ValueError: a requirement line that is not ``name==version``.
    """
    pins = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if not line.strip() or line.startswith((" ", "#")):
            continue  # hashes, "# via" notes and the header
        match = _PIN.match(line)
        if not match:
            raise ValueError(f"{path.name}:{number}: not a pin of one version: {line!r}")
        name, version, marker = match.groups()
        pins.append((canonicalize_name(name), version, Marker(marker) if marker else None, number))
    return pins


def locked(path: Path = LOCK) -> dict[str, str]:
    """The versions the lock pins for this interpreter and platform, by normalised name.

    Raises:
        ValueError: a requirement line that is not ``name==version``, or a name pinned twice here.
    """
    pins: dict[str, str] = {}
    for name, version, marker, number in every_pin(path):
        if marker and not marker.evaluate():
            continue
        if name in pins:
            raise ValueError(f"{path.name}:{number}: {name} is pinned twice for this interpreter")
        pins[name] = version
    return pins


def installed(python: str = sys.executable) -> dict[str, str]:
    """What ``pip freeze --all`` lists in the environment of ``python``, by normalised name (editables left out)."""
    frozen = subprocess.run(
        [python, "-m", "pip", "freeze", "--all", "--exclude-editable", "--disable-pip-version-check"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    pins = {}
    for line in frozen.splitlines():
        name, found, version = line.partition("==")
        if found:
            pins[canonicalize_name(name)] = version
        elif line.strip() and not line.startswith("#"):
            pins[line.strip()] = "?"  # installed from a link or a folder: no version to compare
    return pins


def differences(lock: dict[str, str], have: dict[str, str]) -> list[str]:
    """Each package whose version differs, or that only one side has, as ``name: locked -> installed``."""
    return [
        f"{name}: {lock.get(name, 'not locked')} -> {have.get(name, 'not installed')}"
        for name in sorted(lock.keys() | have.keys())
        if lock.get(name) != have.get(name)
    ]


if __name__ == "__main__":
    changed = differences(locked(), installed())
    print(f"Against {LOCK.name}, this environment has {len(changed)} other versions" + (":" if changed else "."))
    for line in changed:
        print(f"  {line}")

"""What is handed in: a mission file, or a folder of one student's files, and the student it is from."""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path


def find_submissions(paths: Iterable[str | Path]) -> list[tuple[str, Path]]:
    """(student, path) for each submission: a mission file, or a folder of one student's files.

    A folder's student is the folder's name and its mission is its one ``.yaml`` file (or
    ``mission.yaml`` when it has several). Students of the same name (``a/alice.yaml``,
    ``b/alice.yaml``; ``alice/hw2/mission.yaml``, ``bob/hw2/mission.yaml``) are told apart by
    as many of their folders as it takes. The bytes of a name that are not UTF-8 are written
    out (``lat\\xe9in``). Files are sorted by student, so reports are too.
    """
    given = [Path(raw) for raw in paths]
    choices = [_names(path) for path in given]
    level = [0] * len(given)
    while True:
        seen: dict[str, list[int]] = {}
        for index, names in enumerate(choices):
            seen.setdefault(names[level[index]], []).append(index)
        further = [i for group in seen.values() if len(group) > 1 for i in group if level[i] + 1 < len(choices[i])]
        if not further:  # all told apart, or nothing left to tell them apart by (the same file given twice)
            break
        for index in further:
            level[index] += 1
    found = [(names[level[index]], path) for index, (names, path) in enumerate(zip(choices, given, strict=True))]
    return sorted(found, key=lambda item: (item[0], str(item[1])))


def _names(path: Path) -> list[str]:
    """A submission's student, then with more and more of its folders, then the path as given.

    The student is a file's name without its suffix, or a folder's name (``.`` is the folder it names).
    """
    name = path.stem if path.is_file() or path.suffix in (".yaml", ".yml") else path.name
    whole = Path(os.path.abspath(path))
    folders = [readable(part) for part in whole.parent.parts[1:]]
    name = readable(name or whole.name or str(path))
    # past the top folder, the path as given (alice.yml beside a folder alice/) tells them apart
    return [name, *("/".join([*folders[-depth:], name]) for depth in range(1, len(folders) + 1)), readable(str(path))]


def readable(text: str) -> str:
    r"""``text`` as valid Unicode: the bytes of a file name that are not UTF-8 written out (``lat\xe9in``).

    Written out, not replaced: two names that differ only there stay two names.
    """
    return text.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


#: What a mission file is called: YAML, or BehaviorTree.CPP's XML (any case: ``PARK.YAML``).
MISSION_SUFFIXES = (".yaml", ".yml", ".xml")


def mission_file(path: Path) -> tuple[Path | None, str]:
    """A submission's mission file, or None and why there is none (in one line).

    A file is its own mission; a folder's is its one mission file, or ``mission.yaml`` among several
    (one folder down when the folder holds nothing but one folder: a zipped folder unpacked).
    """
    if not path.exists() and not path.is_symlink():
        return None, f"{path}: no such file or folder"
    if path.is_file() or path.is_symlink():
        return path, ""
    if not path.is_dir():
        return None, f"{path}: not a mission file nor a folder"

    def missions(folder: Path) -> list[Path]:
        return sorted(
            p
            for p in folder.iterdir()
            if p.suffix.lower() in MISSION_SUFFIXES and not p.name.startswith(".") and p.is_file()
        )

    candidates = missions(path)
    if not candidates:  # a zipped folder unpacked: the files one folder down
        inner = [p for p in path.iterdir() if p.is_dir() and not p.name.startswith((".", "__"))]
        if len(inner) == 1:
            candidates = missions(inner[0])
    if len(candidates) == 1:
        return candidates[0], ""
    named = [p for p in candidates if p.stem == "mission"]
    if named:
        return named[0], ""
    if not candidates:
        found = sorted(p.name for p in path.iterdir() if not p.name.startswith("."))[:5]
        there = f" (it holds {', '.join(found)})" if found else " (it is empty)"
        return None, f"{path}: no mission file (.yaml, .yml or .xml) in the folder{there}"
    listed = ", ".join(p.name for p in candidates)
    return None, f"{path}: several mission files ({listed}); name the one to grade mission.yaml"

"""YAML with positions: every value keeps the line and column it came from.

Mission, world and exercise files are read with it, so that every problem they hold is
reported as ``FILE:LINE:COL: PATH: message`` (:class:`Problem`). Parsing uses PyYAML's
safe loader (``yaml.safe_load`` semantics: plain data, no tags that build objects), but
keeps the node tree so that an error can name ``FILE:LINE:COL``.
Duplicate keys, which ``safe_load`` silently resolves to the last one, are errors here.
"""

from __future__ import annotations

import difflib
import math
import unicodedata
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

#: Most YAML nodes one file may expand to (aliases can multiply a small file).
MAX_NODES = 100_000
SEQ_TAG = "tag:yaml.org,2002:seq"
MAP_TAG = "tag:yaml.org,2002:map"


@dataclass
class Located:
    """A value from the file and where it stands (1-based line and column).

    ``value`` is a dict of str to :class:`Located` for a mapping, a list of
    :class:`Located` for a sequence, and a plain Python value for a scalar. For
    mappings, ``keys`` holds where each key stands.
    """

    value: Any
    line: int
    column: int
    keys: dict[str, tuple[int, int]] = field(default_factory=dict)

    @property
    def plain(self) -> Any:
        """The value with positions stripped, all the way down."""
        if isinstance(self.value, dict):
            return {k: v.plain for k, v in self.value.items()}
        if isinstance(self.value, list):
            return [v.plain for v in self.value]
        return self.value


@dataclass(frozen=True)
class Problem:
    """One thing wrong with a file, where it stands: prints as ``FILE:LINE:COL: PATH: message``.

    PATH is the YAML path of the value (``tree.repeat.do.sequence[1].turn``), empty for the
    file as a whole.
    """

    file: str
    line: int
    column: int
    path: str
    message: str

    def __str__(self) -> str:
        where = f"{self.path}: " if self.path else ""
        return f"{self.file}:{self.line}:{self.column}: {where}{self.message}"


def suggest(word: str, options: list[str]) -> str:
    """`` (did you mean 'x'?)`` for the option closest to ``word``, or empty when none is close."""
    close = difflib.get_close_matches(word, options, n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def control_character(text: str) -> str:
    """The first control or formatting character in ``text`` (escaped, as ``'\\x1b'``), or empty.

    Tabs and newlines are whitespace, not control: a description may span lines.
    """
    for char in text:
        if unicodedata.category(char) in ("Cc", "Cf") and char not in "\t\n":
            return repr(char)
    return ""


#: Largest mission, world or exercise file read, bytes.
MAX_FILE_BYTES = 1_000_000
#: Deepest nesting of lists and mappings a file may have.
MAX_DEPTH = 100


class UnreadableFile(Exception):
    """A file that cannot be read as text: :attr:`reason` says why, in a few words."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def read_text(path: str | Path, max_bytes: int = MAX_FILE_BYTES) -> str:
    """Reads a UTF-8 text file of at most ``max_bytes``, reading no more than that.

    Devices, pipes and folders are refused before anything is read: a link to ``/dev/zero``
    must not fill the memory, nor a pipe hang the reader.

    Raises:
        UnreadableFile: not a regular file, too large, not UTF-8, or not readable.
    """
    path = Path(path)
    try:
        if not path.exists():
            raise UnreadableFile("no such file")
        if not path.is_file():
            raise UnreadableFile("not a regular file (a folder, a device or a pipe)")
        with path.open("rb") as stream:
            data = stream.read(max_bytes + 1)
    except OSError as err:
        raise UnreadableFile(err.strerror or str(err)) from None
    if len(data) > max_bytes:
        raise UnreadableFile(f"larger than {max_bytes:,} bytes")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data[: err.start].count(b"\n") + 1
        raise UnreadableFile(f"not UTF-8 text (line {line}: {err.reason}); save it as UTF-8") from None


def shown(number: float) -> str:
    """A bound as people write it: ``3,600``, ``0.1``."""
    return f"{int(number):,}" if float(number).is_integer() else f"{number:g}"


class Reader:
    """Reads a document parsed with positions, collecting every problem with its place.

    The readers of world and exercise files build on it, so that both say the same things the
    same way.

    Args:
        label: The file's name, as problems name it.
    """

    def __init__(self, label: str) -> None:
        self.label = label
        self.problems: list[Problem] = []

    def problem(self, where: Located | tuple[int, int], path: str, message: str) -> None:
        """Notes one problem at a value (or a line and column)."""
        line, column = (where.line, where.column) if isinstance(where, Located) else where
        self.problems.append(Problem(self.label, line, column, path, message))

    def text(self, located: Located, path: str) -> str | None:
        """The value as text that is not empty and holds no control character, or None and a problem."""
        if not isinstance(located.value, str) or not located.value.strip():
            self.problem(located, path, f"expected text, got {located.plain!r}")
            return None
        bad = control_character(located.value)
        if bad:
            self.problem(located, path, f"contains the control character {bad}; write plain text")
            return None
        return located.value

    def number(self, located: Located, path: str, low: float, high: float, whole: bool = False) -> Any:
        """The value as a finite number from ``low`` to ``high`` (a whole one if asked), or None and a problem."""
        value = located.value
        if isinstance(value, bool) or not isinstance(value, (int, float)) or (whole and not isinstance(value, int)):
            kind = "a whole number" if whole else "a number"
            self.problem(located, path, f"expected {kind}, got {located.plain!r}")
            return None
        if not math.isfinite(value) or not low <= value <= high:
            self.problem(located, path, f"must be from {shown(low)} to {shown(high)}, got {value!r}")
            return None
        return value


@dataclass(frozen=True)
class SourceError:
    """One problem at a place in the file."""

    line: int
    column: int
    message: str


def _where(node: yaml.Node) -> tuple[int, int]:
    return node.start_mark.line + 1, node.start_mark.column + 1


def parse(text: str) -> tuple[Located | None, list[SourceError]]:
    """Parses one YAML document.

    Returns:
        The document (None when it could not be read at all) and the problems found.
    """
    loader = yaml.SafeLoader(text)
    errors: list[SourceError] = []
    count = 0
    try:
        root = loader.get_single_node()
        if root is None:
            return None, [SourceError(1, 1, "the file is empty")]

        def convert(node: yaml.Node, stack: tuple[int, ...]) -> Located:
            nonlocal count
            count += 1
            line, column = _where(node)
            if count > MAX_NODES:
                raise _TooLarge(line, column)
            if len(stack) >= MAX_DEPTH:
                raise _TooDeep(line, column)
            if id(node) in stack:
                errors.append(SourceError(line, column, "an alias refers to itself"))
                return Located(None, line, column)
            stack = (*stack, id(node))
            if isinstance(node, (yaml.SequenceNode, yaml.MappingNode)) and node.tag not in (SEQ_TAG, MAP_TAG):
                errors.append(SourceError(line, column, f"the tag {node.tag} is not allowed: plain YAML only"))
                return Located(None, line, column)
            if isinstance(node, yaml.SequenceNode):
                return Located([convert(item, stack) for item in node.value], line, column)
            if isinstance(node, yaml.MappingNode):
                loader.flatten_mapping(node)  # apply '<<' merge keys as safe_load does
                located = Located({}, line, column)
                for key_node, value_node in node.value:
                    key = loader.construct_object(key_node, deep=True)
                    key_line, key_column = _where(key_node)
                    if not isinstance(key, str):
                        errors.append(SourceError(key_line, key_column, f"keys must be names, got {key!r}"))
                        continue
                    if key in located.value:
                        first = located.keys[key]
                        errors.append(
                            SourceError(key_line, key_column, f"'{key}' is given twice (first on line {first[0]})")
                        )
                        continue
                    located.keys[key] = (key_line, key_column)
                    located.value[key] = convert(value_node, stack)
                return located
            return Located(loader.construct_object(node, deep=True), line, column)

        return convert(root, ()), errors
    except _TooLarge as err:
        return None, [SourceError(err.line, err.column, f"the file expands to more than {MAX_NODES} values")]
    except _TooDeep as err:
        return None, [SourceError(err.line, err.column, f"nested more than {MAX_DEPTH} levels deep")]
    except RecursionError:  # the YAML reader itself gives up on deeper nesting still
        return None, [SourceError(1, 1, f"nested more than {MAX_DEPTH} levels deep")]
    except yaml.MarkedYAMLError as err:
        mark = err.problem_mark or err.context_mark
        line, column = (mark.line + 1, mark.column + 1) if mark else (1, 1)
        problem = err.problem or err.context or "not valid YAML"
        return None, [SourceError(line, column, f"not valid YAML: {problem}")]
    except yaml.YAMLError as err:
        return None, [SourceError(1, 1, f"not valid YAML: {err}")]
    finally:
        loader.dispose()


class _TooLarge(Exception):
    def __init__(self, line: int, column: int) -> None:
        self.line, self.column = line, column


class _TooDeep(Exception):
    def __init__(self, line: int, column: int) -> None:
        self.line, self.column = line, column

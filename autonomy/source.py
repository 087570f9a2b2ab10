"""YAML with positions: every value keeps the line and column it came from.

Mission, world and exercise files are read with it, so that every problem they hold is
reported as ``FILE:LINE:COL: PATH: message`` (:class:`Problem`). Parsing uses PyYAML's
safe loader (``yaml.safe_load`` semantics: plain data, no tags that build objects), but
keeps the node tree so that an error can name ``FILE:LINE:COL``.
Duplicate keys, which ``safe_load`` silently resolves to the last one, are errors here.

Every file is read by PyYAML's parser written in Python, never by libyaml's (``CSafeLoader``),
so that a file reads the same on every machine: the two parsers take different files (libyaml
takes a tab outside quotes, which the Python parser refuses), and libyaml's releases differ
among themselves (the one PyYAML 6.0.4 bundles refuses flow nesting past 1,000 levels while
scanning ahead, before this reader's own limit is reached). The Python parser is the same code
in PyYAML 6.0 to 6.0.4, and in every install, with libyaml or without.
"""

from __future__ import annotations

import difflib
import math
import re
import unicodedata
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

#: Most values (scalars, lists, mappings; aliases count what they repeat) one file may hold:
#: far more than any mission, world or exercise needs, and refused in well under a second.
MAX_NODES = 10_000
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
    file as a whole. Whatever of the file the path or message quotes is shown with its
    invisible characters escaped (a tab as ``\\t``), so that a problem is always one plain line.
    """

    file: str
    line: int
    column: int
    path: str
    message: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", _cut(visible(self.path)))
        object.__setattr__(self, "message", _cut(visible(self.message)))

    def __str__(self) -> str:
        where = f"{self.path}: " if self.path else ""
        return f"{self.file}:{self.line}:{self.column}: {where}{self.message}"


_HIDDEN = ("Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp")
#: Longest message or path a problem shows (a 900 KB key is quoted, not printed whole).
MAX_PROBLEM_CHARS = 400


def _cut(text: str) -> str:
    return text if len(text) <= MAX_PROBLEM_CHARS else f"{text[:MAX_PROBLEM_CHARS]}... ({len(text):,} characters)"


def visible(text: str) -> str:
    """``text`` with control, format and separator characters escaped as Python writes them."""
    if text.isprintable():
        return text
    return "".join(repr(c)[1:-1] if unicodedata.category(c) in _HIDDEN else c for c in text)


#: A number YAML 1.1 reads as text: an exponent without a point or a sign (1e9, 5e-3).
_EXPONENT_AS_TEXT = re.compile(r"^[-+]?\d+(\.\d*)?[eE][-+]?\d+$")


def exponent_hint(value: Any) -> str:
    """Why a value written as a number came as text, when YAML read it so (``1e9``); else empty."""
    if isinstance(value, str) and _EXPONENT_AS_TEXT.match(value):
        return f" (YAML reads {value} as text: write it out, or with a point and a sign, as 1.0e+3)"
    return ""


def suggest(word: str, options: list[str]) -> str:
    """`` (did you mean 'x'?)`` for the option closest to ``word``, or empty when none is close."""
    close = difflib.get_close_matches(word, options, n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def control_character(text: str) -> str:
    """The first control or formatting character, or lone surrogate, in ``text`` (escaped), or empty.

    Tabs and newlines are whitespace, not control: a description may span lines.
    """
    for char in text:
        if unicodedata.category(char) in ("Cc", "Cf", "Cs", "Zl", "Zp") and char not in "\t\n":
            return repr(char)
    return ""


#: Largest mission, world or exercise file read, bytes: some 500 times the largest one shipped,
#: and read (or refused) by PyYAML's parser in Python in well under a second.
MAX_FILE_BYTES = 500_000
#: Deepest nesting of lists and mappings a file may have.
MAX_DEPTH = 100


def finite_number(value: Any) -> bool:
    """Whether ``value`` is a number a float holds: not a flag, not NaN or infinity, not a 400-digit whole number."""
    if type(value) not in (int, float):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def is_file(path: Path) -> bool:
    """Whether ``path`` is a file; False, not an error, for a name no file can have (too long, a NUL)."""
    try:
        return path.is_file()
    except (OSError, ValueError):
        return False


def exists(path: Path) -> bool:
    """Whether anything is at ``path``; False, not an error, for a name no file can have."""
    try:
        return path.exists()
    except (OSError, ValueError):
        return False


class UnreadableFile(Exception):
    """A file that cannot be read as text: :attr:`reason` says why, in a few words.

    Attributes:
        reason: Why, in a few words.
        line: Where the trouble is, when it is at a place (a byte that is not UTF-8).
        column: The column there, counted in characters.
    """

    def __init__(self, reason: str, line: int = 1, column: int = 1) -> None:
        super().__init__(reason)
        self.reason, self.line, self.column = reason, line, column


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
        line_start = data.rfind(b"\n", 0, err.start) + 1
        column = len(data[line_start : err.start].decode("utf-8", "replace")) + 1
        raise UnreadableFile(_not_utf8(data, err.start), line, column) from None


#: Bytes no text file holds: C0 control codes other than tab, line feed and carriage return.
_BINARY = re.compile(b"[\x00-\x08\x0b\x0c\x0e-\x1f]")
#: What a byte from 0x80 up stands for in a text saved as Windows-1252 (or Latin-1) besides letters.
_TEXT_SIGNS = frozenset("\xa0¡¢£¥§©«®°±²³µ¶·¹º»¼½¾¿×÷€‚„…†‡•–—‘’“”‹›™")


def _not_utf8(data: bytes, index: int) -> str:
    """Why ``data`` is not UTF-8 text, where ``data[index]`` is the first byte that is not: a guess at what it is."""
    here = f"the byte 0x{data[index]:02x} here"
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        return f"{here} starts a UTF-16 byte-order mark: the file is saved as UTF-16; save it as UTF-8"
    if _BINARY.search(data):
        return f"{here} is not text, nor are others in the file: it looks like a picture, an archive or a program"
    try:
        upper = [char for char in data.decode("cp1252") if char >= "\x80"]
    except UnicodeDecodeError:  # five bytes stand for nothing in Windows-1252
        upper = ["\x81"]
    if all(char.isalpha() or char in _TEXT_SIGNS for char in upper):
        return f"{here} is not UTF-8 text (a file saved as Latin-1 or Windows-1252?): save it as UTF-8"
    return f"{here} is not UTF-8 text: save the file as UTF-8"


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
        """Notes one problem at a value (or a line and column); none at a value the reader refused."""
        if isinstance(where, Located) and refused(where):
            return
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
            self.problem(located, path, f"expected {kind}, got {located.plain!r}{exponent_hint(value)}")
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


#: Characters YAML does not allow in a file, and the ones it takes as line breaks besides
#: ``\n`` and ``\r`` (NEL, LINE and PARAGRAPH SEPARATOR), which would put every later problem
#: on the wrong line.
_NOT_TEXT = re.compile(
    "[^\t\n\r\x20-\x7e\xa0-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]|[\u2028\u2029]"
    # invisible format characters (Unicode category Cf): zero-width and bidirectional controls
    # can make a file read differently from what it says
    "|[\xad\u0600-\u0605\u061c\u06dd\u070f\u0890\u0891\u08e2\u180e\u200b-\u200f\u202a-\u202e\u2060-\u2064\u2066-\u206f"
    "\ufeff\ufff9-\ufffb\U000110bd\U000110cd\U00013430-\U0001343f\U0001bca0-\U0001bca3\U0001d173-\U0001d17a\U000e0001\U000e0020-\U000e007f]"
)
_NAMES = {"\x00": "NUL", "\x07": "BEL", "\x08": "BACKSPACE", "\x1b": "ESC", "\x7f": "DEL", "\x85": "NEL"}
#: Most characters a number may be written with (a longer one is not a number a robot uses).
MAX_NUMBER_CHARS = 40
_INT_TAG = "tag:yaml.org,2002:int"
_FLOAT_TAG = "tag:yaml.org,2002:float"
_MERGE_TAG = "tag:yaml.org,2002:merge"
_STR_TAG = "tag:yaml.org,2002:str"
#: Tags a value may carry explicitly (``!!str 5``): the plain kinds a mission is made of.
_SAFE_TAGS = {f"tag:yaml.org,2002:{name}" for name in ("null", "bool", "int", "float", "str")}


def _line_start(text: str, index: int) -> int:
    """Where the line of ``text[index]`` starts: after ``\\n``, ``\\r\\n`` or a lone ``\\r``, as YAML has it."""
    return max(text.rfind("\n", 0, index), text.rfind("\r", 0, index)) + 1


def _position(text: str, index: int) -> tuple[int, int]:
    """The 1-based line and column of ``text[index]``, as the YAML parser counts them.

    A line ends at ``\\n``, ``\\r\\n`` or a lone ``\\r``, and a byte-order mark at the start takes no
    column, so that a place found here is the one the parser's own problems name.
    """
    breaks = text.count("\n", 0, index) + text.count("\r", 0, index) - text.count("\r\n", 0, index)
    line_start = _line_start(text, index)
    bom = line_start == 0 and text.startswith("\ufeff")
    return breaks + 1, max(index - line_start + 1 - bom, 1)


def text_problems(text: str) -> list[SourceError]:
    """Characters that have no place in a text file, each where it stands (at most 20)."""
    problems = []
    for match in _NOT_TEXT.finditer(text, 1 if text.startswith("\ufeff") else 0):
        char = match.group()
        line, column = _position(text, match.start())
        code = f"U+{ord(char):04X}"
        if "\ud800" <= char <= "\udfff":
            what = f"a lone surrogate ({code}), which is not text"
        elif unicodedata.category(char) in ("Zl", "Zp", "Cf"):
            what = f"an invisible {unicodedata.name(char, 'format character').lower()} ({code})"
        else:
            what = f"the control character {_NAMES.get(char, code)}" + (f" ({code})" if char in _NAMES else "")
        problems.append(SourceError(line, column, f"{what}: remove it; the file must be plain text"))
        if len(problems) == 20:
            break
    return problems


#: What PyYAML's parser says, and what it means to a student.
#: Each entry: the words to find, where ("problem" or "context"), and the plain message.
_PLAIN_WORDS = (
    (
        ("expected <block end>",),
        "problem",
        "this line does not line up with the ones above it: the items of one list or mapping start in the same column",
    ),
    (
        ("mapping values are not allowed",),
        "problem",
        "a ': ' where a plain value was expected: put the value in quotes, or start the mapping on its own line",
    ),
    (
        ("could not find expected ':'",),
        "problem",
        "a key without ':' after it, or a line indented by mistake, ends here",
    ),
    (("',' or ']'",), "problem", "a '[' list is not closed with ']', or its items are not separated by ','"),
    (("',' or '}'",), "problem", "a '{' mapping is not closed with '}', or its entries are not separated by ','"),
    (("quoted scalar",), "context", "a quoted text is not closed: add the closing quote"),
    (
        ("unknown escape character",),
        "problem",
        "an unknown escape in a double-quoted text: write \\\\ for a backslash, or use single quotes",
    ),
)


def _plain_words(err: yaml.MarkedYAMLError, text: str) -> SourceError:
    """A YAML parser's complaint, said in words a student can act on, at its line and column."""
    mark = err.problem_mark or err.context_mark
    line, column = (mark.line + 1, mark.column + 1) if mark else (1, 1)
    said = {"problem": err.problem or "", "context": err.context or ""}
    index = mark.index if mark is not None else -1
    here = text[index] if 0 <= index < len(text) else ""
    if "cannot start any token" in said["problem"] and here == "\t":
        return SourceError(line, column, _tab(text, index))
    if "cannot start any token" in said["problem"]:
        return SourceError(line, column, f"{here!r} cannot start a value here: put the value in quotes")
    if "could not determine a constructor for the tag" in said["problem"]:
        tag = said["problem"].rsplit(" ", 1)[-1]
        return SourceError(line, column, f"the tag {tag} is not allowed: plain YAML only")
    for needles, where, message in _PLAIN_WORDS:
        if any(needle in said[where] for needle in needles):
            if needles == ("quoted scalar",) and "end of stream" not in said["problem"]:
                continue
            return SourceError(line, column, message)
    return SourceError(line, column, f"not valid YAML: {said['problem'] or said['context'] or err}")


def _tab(text: str, index: int) -> str:
    """What to do about the tab at ``text[index]``, which the YAML parser refused, by where it stands on its line."""
    start = _line_start(text, index)
    end = min((at for at in (text.find("\n", index), text.find("\r", index)) if at >= 0), default=len(text))
    before, after = text[start:index].strip(" \t\ufeff"), text[index:end].strip(" \t")
    if not before and not after:
        return "a tab on a line of nothing else: remove it (YAML does not allow tabs for indentation)"
    if not after:
        return "a tab at the end of the line: remove it (YAML takes a tab only inside quotes or a | or > block)"
    if not before:
        return "a tab: indent with spaces (YAML does not allow tabs for indentation)"
    return "a tab outside quotes: use spaces (YAML takes a tab only inside quotes or a | or > block)"


#: An escape in a double-quoted text: ``\\uXXXX`` and ``\\UXXXXXXXX`` give their code, any other one character.
_ESCAPE = re.compile(r"\\(?:u([0-9a-fA-F]{4})|U([0-9a-fA-F]{8})|.)", re.DOTALL)


def _surrogate_escape(text: str, start: int, end: int) -> int:
    """Where in ``text[start:end]`` (a double-quoted text) an escape names a lone surrogate, or -1."""
    for match in _ESCAPE.finditer(text, start, end):
        code = match.group(1) or match.group(2)
        if code and 0xD800 <= int(code, 16) <= 0xDFFF:
            return match.start()
    return -1


class _Refused(Exception):
    """Ends the parse: the file is too large or too deep to read on."""

    def __init__(self, line: int, column: int, message: str) -> None:
        self.error = SourceError(line, column, message)


@dataclass
class _Open:
    """A list or mapping being read: where it stands, and (for a mapping) the key waiting for its value."""

    located: Located
    start_count: int
    anchor: str | None
    refused: bool = False
    key: tuple[str, int, int] | None = None
    key_refused: bool = False
    merges: list[tuple[Located, int, int]] = field(default_factory=list)


class _Composer:
    """Builds :class:`Located` values from the YAML parser's events, in a loop.

    Reading events (not PyYAML's node tree) keeps the work proportional to what is read:
    a file past :data:`MAX_NODES` values or :data:`MAX_DEPTH` levels is refused where it
    crosses the limit, before the rest is read, and nothing recurses, however deep the file.
    """

    def __init__(self, loader: yaml.SafeLoader, text: str) -> None:
        self.loader = loader
        self.text = text
        self.errors: list[SourceError] = []
        self.count = 0
        self.anchors: dict[str, tuple[Located | None, int]] = {}  # None: still open

    def document(self) -> Located | None:
        loader = self.loader
        loader.get_event()  # stream start
        if loader.check_event(yaml.StreamEndEvent):
            return None
        loader.get_event()  # document start
        root = self.node()
        loader.get_event()  # document end
        if not loader.check_event(yaml.StreamEndEvent):
            mark = loader.peek_event().start_mark
            raise _Refused(
                mark.line + 1, mark.column + 1, "a second document: a file holds one, so remove the '---' line"
            )
        return root

    def node(self) -> Located:
        stack: list[_Open] = []
        while True:
            event = self.loader.get_event()
            mark = event.start_mark
            line, column = mark.line + 1, mark.column + 1
            if isinstance(event, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
                done = stack.pop()
                self._close(done)
                value = Located(REFUSED, done.located.line, done.located.column) if done.refused else done.located
            elif isinstance(event, yaml.AliasEvent):
                value = self._alias(event.anchor, line, column)
            else:
                self.count += 1
                if self.count > MAX_NODES:
                    raise _Refused(line, column, f"the file holds more than {MAX_NODES:,} values")
                tag = getattr(event, "tag", None)
                if isinstance(event, yaml.ScalarEvent):
                    value = self._scalar(event, line, column)
                    self._anchor(event.anchor, value, self.count - 1)
                else:
                    if len(stack) >= MAX_DEPTH:
                        raise _Refused(line, column, f"nested more than {MAX_DEPTH} levels deep")
                    bad_tag = tag not in (None, "!", SEQ_TAG, MAP_TAG)
                    if bad_tag:
                        self.errors.append(SourceError(line, column, f"the tag {tag} is not allowed: plain YAML only"))
                    mapping = isinstance(event, yaml.MappingStartEvent)
                    located = Located({} if mapping else [], line, column)
                    if event.anchor is not None:
                        self.anchors[event.anchor] = (None, 0)
                    stack.append(_Open(located, self.count - 1, event.anchor, refused=bad_tag))
                    continue
            if not stack:
                return value
            self._add(stack[-1], value, event)

    def _close(self, done: _Open) -> None:
        located = done.located
        for merged, line, column in done.merges:  # '<<' entries: keys given in the mapping win
            for key, item in merged.value.items():
                if key not in located.value:
                    located.value[key] = item
                    located.keys[key] = (line, column)
        if done.anchor is not None:
            self.anchors[done.anchor] = (located, self.count - done.start_count)

    def _alias(self, anchor: str, line: int, column: int) -> Located:
        if anchor not in self.anchors:
            self.errors.append(SourceError(line, column, f"the alias *{anchor} has no anchor &{anchor} before it"))
            return Located(REFUSED, line, column)
        target, size = self.anchors[anchor]
        if target is None:
            self.errors.append(SourceError(line, column, f"the alias *{anchor} refers to itself"))
            return Located(REFUSED, line, column)
        self.count += size
        if self.count > MAX_NODES:
            raise _Refused(line, column, f"the file expands to more than {MAX_NODES:,} values (through aliases)")
        return target

    def _anchor(self, anchor: str | None, value: Located, start_count: int) -> None:
        if anchor is not None:
            self.anchors[anchor] = (value, self.count - start_count)

    def _scalar(self, event: yaml.ScalarEvent, line: int, column: int) -> Located:
        loader = self.loader
        if event.tag not in (None, "!"):
            tag = event.tag
            if tag not in _SAFE_TAGS:
                self.errors.append(SourceError(line, column, f"the tag {tag} is not allowed: plain YAML only"))
                return Located(REFUSED, line, column)
        else:
            tag = loader.resolve(yaml.ScalarNode, event.value, event.implicit)
        if tag in (_INT_TAG, _FLOAT_TAG) and len(event.value) > MAX_NUMBER_CHARS:
            digits = sum(char.isalnum() for char in event.value)
            self.errors.append(
                SourceError(
                    line, column, f"a number written with {digits:,} digits: no value here needs more than a few"
                )
            )
            return Located(REFUSED, line, column)
        if event.style == '"' and _SURROGATES.search(event.value):
            at = _surrogate_escape(self.text, event.start_mark.index, event.end_mark.index)
            where = _position(self.text, at) if at >= 0 else (line, column)
            self.errors.append(
                SourceError(
                    *where,
                    "an escape for a code that is not a character (\\ud800 to \\udfff are not): write the "
                    "character itself, or \\U and its 8 hex digits (\\U0001F600, not \\ud83d\\ude00)",
                )
            )
            return Located(REFUSED, line, column)
        if tag == _STR_TAG:
            return Located(event.value, line, column)  # most values: no constructor needed
        if tag == _MERGE_TAG:
            return Located(_MERGE, line, column)
        node = yaml.ScalarNode(tag, event.value, event.start_mark, event.end_mark, event.style)
        try:
            value = loader.construct_object(node, deep=True)
        except Exception:  # noqa: BLE001 - PyYAML's constructors fail in many ways on a value a tag forces
            kind = tag.rsplit(":", 1)[-1]
            self.errors.append(SourceError(line, column, f"{event.value[:20]!r} is not a {kind}: write a plain value"))
            return Located(REFUSED, line, column)
        return Located(value, line, column)

    def _add(self, into: _Open, value: Located, event: yaml.Event) -> None:
        container = into.located
        if isinstance(container.value, list):
            container.value.append(value)
            return
        if into.key is None and not into.key_refused:
            if value.value is _MERGE:
                into.key = ("<<", value.line, value.column)
            elif refused(value):  # its problem is said where it stands
                into.key_refused = True
            elif not isinstance(value.value, str):
                self.errors.append(SourceError(value.line, value.column, f"keys must be names, got {value.plain!r}"))
                into.key_refused = True
            else:
                into.key = (value.value, value.line, value.column)
            return
        if into.key_refused:
            into.key_refused = False
            return
        waiting = into.key
        into.key = None
        if waiting is None:
            return
        key, line, column = waiting
        if value.value is _MERGE:  # '<<' where a value belongs
            self.errors.append(SourceError(value.line, value.column, "'<<' merges a mapping in, as a key only"))
            value = Located(REFUSED, value.line, value.column)
        if key == "<<":
            merged = value.value if isinstance(value.value, list) else [value]
            for item in merged:
                if isinstance(item.value, dict):
                    into.merges.append((item, line, column))
                else:
                    self.errors.append(SourceError(item.line, item.column, "'<<' merges mappings only"))
            return
        if key in container.value:
            first = container.keys[key]
            self.errors.append(SourceError(line, column, f"'{key}' is given twice (first on line {first[0]})"))
            return
        container.keys[key] = (line, column)
        container.value[key] = value


_MERGE = object()
_SURROGATES = re.compile("[\ud800-\udfff]")


class _RefusedValue:
    """The value of something the reader refused (its problem is reported where it stands)."""

    def __repr__(self) -> str:
        return "<refused>"


#: What a refused value reads as: readers leave it alone, its problem is already reported.
REFUSED = _RefusedValue()


def refused(located: Located) -> bool:
    """Whether ``located`` was refused by the reader, or is a list holding such a value.

    Its problem is reported where it stands; a check of the value around it says nothing more.
    """
    value = located.value
    return value is REFUSED or (isinstance(value, list) and any(item.value is REFUSED for item in value))


_Loader = yaml.SafeLoader  # the Python parser, never libyaml's: see the module's docstring


def parse(text: str) -> tuple[Located | None, list[SourceError]]:
    """Parses one YAML document, with the positions of its values.

    Control characters, nesting deeper than :data:`MAX_DEPTH`, more than :data:`MAX_NODES`
    values, tags that build objects and numbers written with absurdly many digits are
    refused where they stand; the YAML parser's own complaints come in plain words.

    Returns:
        The document (None when it could not be read at all) and the problems found.
    """
    bad = text_problems(text)
    if bad:
        return None, bad
    loader = _Loader(text)
    composer = _Composer(loader, text)
    try:
        root = composer.document()
        if root is None:
            return None, [SourceError(1, 1, "the file is empty")]
        return root, composer.errors
    except _Refused as err:
        return None, [*composer.errors, err.error]
    except yaml.MarkedYAMLError as err:
        return None, [*composer.errors, _plain_words(err, text)]
    except yaml.YAMLError as err:
        return None, [*composer.errors, SourceError(1, 1, f"not valid YAML: {err}")]
    finally:
        loader.dispose()

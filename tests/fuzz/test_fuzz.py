"""Fuzzing: the validator and the reply decoder meet only their own errors, whatever they are fed.

`make test` runs 3,000 mutants and 300 generated cases a test, the same ones every time;
`make fuzz` sets AUTONOMY_FUZZ_CASES=100000, for that many of each (a tenth as many generated
YAML documents, which cost hypothesis ten times more to make), new ones every run.
"""

from __future__ import annotations

import os
import unicodedata

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from autonomy.errors import FramingError
from autonomy.mission import MissionInvalid, MissionSpec, validate_text
from autonomy.protocol import ReplyDecoder, ReplyKind
from tests.fuzz.mutants import ROOT, WORDS, mutant
from tests.harness import mission_files

LONG = os.environ.get("AUTONOMY_FUZZ_CASES")
MUTANTS = int(LONG or 3000)
EXAMPLES = int(LONG or 300)
FUZZ = settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=list(HealthCheck), derandomize=not LONG)
#: Generating nested documents costs hypothesis about 10 ms each: a tenth as many of those.
FUZZ_DOCUMENTS = settings(FUZZ, max_examples=max(EXAMPLES // 10, 300))
MISSIONS = ROOT / "missions"


def outcome(text: str, source: str = "m.yaml") -> MissionSpec | MissionInvalid:
    """The validator's answer: a mission, or its own error with every problem at a place."""
    try:
        return validate_text(text, source, MISSIONS)
    except MissionInvalid as err:
        assert err.problems, "an error with no problem in it"
        for problem in err.problems:
            assert problem.line >= 1 and problem.column >= 1 and problem.message, problem
            hidden = [
                c for c in problem.message if unicodedata.category(c) in ("Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp")
            ]
            assert not hidden, f"a message that would garble a terminal: {problem.message!r}"
        return err


def test_mutants_of_the_shipped_missions_meet_only_positioned_problems():
    for number in range(MUTANTS):
        source, text = mutant(number)
        try:
            outcome(text, source)
        except Exception as err:  # noqa: BLE001 - the point: name the mutant that broke through
            raise AssertionError(f"mutant {number} of {source} raised {type(err).__name__}: {err}") from err


names = st.sampled_from(WORDS) | st.text(min_size=1, max_size=8)
scalars = (
    st.none()
    | st.booleans()
    | st.integers(-(10**12), 10**12)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=20)
    | names
)
documents = st.recursive(
    scalars,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(names, inner, max_size=4),
    max_leaves=40,
)


@FUZZ_DOCUMENTS
@given(st.dictionaries(names, documents, max_size=6))
def test_any_yaml_document_meets_only_positioned_problems(document):
    outcome(yaml.dump(document, Dumper=getattr(yaml, "CSafeDumper", yaml.SafeDumper), allow_unicode=True))


@FUZZ
@given(st.text(max_size=300))
def test_any_text_meets_only_positioned_problems(text):
    outcome(text)


@FUZZ
@given(
    st.binary(max_size=64),
    st.sampled_from(
        [(ReplyKind.ACK, ""), (ReplyKind.HEALTH, ""), (ReplyKind.STATUS, "")]
        + [(ReplyKind.PARAMETER, p) for p in "DBFVA"]
    ),
    st.integers(1, 9),
)
def test_any_bytes_meet_only_framing_errors_in_the_reply_decoder(data, kind, chunk):
    decoder = ReplyDecoder(*kind)
    for start in range(0, len(data), chunk):
        decoder.feed(data[start : start + chunk])
        for _ in range(len(data) + 2):
            try:
                if decoder.next_reply() is None:
                    break
            except FramingError:
                continue
    assert decoder.buffered <= len(data)


def _exported() -> list[tuple[str, str]]:
    from autonomy.mission import load_mission
    from autonomy.mission.btcpp import export_xml

    return [(str(p.with_suffix(".xml")), export_xml(load_mission(p))) for p in mission_files(MISSIONS.glob("*.yaml"))]


XML_PIECES = [
    "<",
    ">",
    "/>",
    "</",
    '"',
    "'",
    "=",
    "&amp;",
    "&x;",
    "<!DOCTYPE a>",
    "<![CDATA[x]]>",
    "<?pi x?>",
    "<!-- c -->",
    "\x00",
    "\u200b",
    "\ufeff",
    "é",
    " ",
    "\n",
    "_uid",
    "ID",
    "SubTree",
    "While",
    "-1",
    "1e999",
]


def test_mutants_of_the_exported_missions_as_xml_meet_only_positioned_problems():
    import random

    sources = _exported()
    for number in range(MUTANTS):
        rng = random.Random(number)
        source, text = rng.choice(sources)
        for _ in range(rng.randint(1, 4)):
            at = rng.randrange(len(text) + 1)
            cut = rng.choice([0, 0, 1, rng.randint(1, 40)])
            text = text[:at] + rng.choice(XML_PIECES + [text[rng.randrange(len(text)) :][:30]]) + text[at + cut :]
        try:
            outcome(text, source)
        except Exception as err:  # noqa: BLE001 - the point: name the mutant that broke through
            raise AssertionError(f"XML mutant {number} of {source} raised {type(err).__name__}: {err}") from err


@FUZZ
@given(st.binary(max_size=400), st.integers(0, 2))
def test_any_btlog_bytes_meet_only_btlog_errors(tail, how):
    import struct
    import tempfile
    from pathlib import Path

    from autonomy.btlog import MAGIC, BtlogError, read_btlog

    xml = b'<root><BehaviorTree _fullpath=""><Sequence _uid="1"><stop _uid="2"/></Sequence></BehaviorTree></root>'
    head = [MAGIC + b"\x01" + struct.pack("<I", len(xml)) + xml + struct.pack("<Q", 1), MAGIC + b"\x01", b""][how]
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "x.btlog"
        path.write_bytes(head + tail)
        try:
            trace = read_btlog(path)
        except BtlogError as err:
            assert str(err).startswith(str(path)), err
        else:
            assert all(set(tick.nodes) <= {0, 1} for tick in trace.ticks)

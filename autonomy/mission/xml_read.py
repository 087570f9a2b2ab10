"""BehaviorTree.CPP 4 XML -> the same located document a YAML mission file gives.

A mission drawn in Groot2 (or written for BehaviorTree.CPP) is read into the mapping the YAML
reader would have made of the equivalent mission file, every value at its line and column, and
then checked by the very same validator: the same ``FILE:LINE:COL`` problems, the same
did-you-means. What this module decides is only how BehaviorTree.CPP's words map to ours:

========================================  ==================================================
BehaviorTree.CPP 4                         autonomy
========================================  ==================================================
``Sequence`` / ``ReactiveSequence``        ``sequence`` with ``memory: true`` / ``false``
``Fallback`` / ``ReactiveFallback``        ``selector`` with ``memory: true`` / ``false``
``Parallel success_count= failure_count=`` ``parallel``: -1 (all) or 1 (one), failing on 1
``Repeat num_cycles``                      ``repeat times`` (-1: forever)
``RetryUntilSuccessful num_attempts``      ``retry attempts``
``Timeout msec``                           ``timeout seconds``
``Inverter``, ``ForceSuccess``,            ``invert``, ``force_success``, ``force_failure``,
``ForceFailure``, ``RunOnce``              ``once``
``ReactiveSequence _autonomy="while"``     ``while``: the condition, then the child (``While``,
                                           as earlier exports wrote it, too)
``SubTree ID=``                            ``subtree:``
``<move speed="2"/>``, ``<Action ID=..>``  the leaf, its attributes its parameters
========================================  ==================================================

The main ``<BehaviorTree>`` (``main_tree_to_execute``, or the only one) is the mission's tree
and its ``ID`` the mission's name; the others are its subtrees. The mission's other settings
ride on the main tree as attributes BehaviorTree.CPP ignores: ``_description``, ``_tick_hz``,
``_world`` and ``_plugins``. Attribute values stay text (:class:`AttributeText`) until the
validator reads them as the parameter's kind.

Untrusted files are safe to read: a DOCTYPE (and with it every entity) is refused, and the
limits of YAML files hold here too (500 KB, :data:`~autonomy.source.MAX_NODES` elements,
:data:`~autonomy.source.MAX_DEPTH` levels).
"""

from __future__ import annotations

import bisect
import re
from dataclasses import dataclass, field, replace
from xml.parsers import expat

from autonomy.source import MAX_DEPTH, MAX_NODES, REFUSED, Located, SourceError, suggest, text_problems

#: BehaviorTree.CPP's structure nodes that autonomy has, and the node type each becomes.
COMPOSITES = {
    "Sequence": ("sequence", {"memory": True}),
    "ReactiveSequence": ("sequence", {"memory": False}),
    "Fallback": ("selector", {"memory": True}),
    "ReactiveFallback": ("selector", {"memory": False}),
    "Parallel": ("parallel", {}),
    "While": ("while", {}),
}
#: Our own composites BehaviorTree.CPP has no node for, written under their own names (``<random>``).
OWN_CONTROLS = ("random",)
DECORATORS = {
    "Repeat": "repeat",
    "RetryUntilSuccessful": "retry",
    "Timeout": "timeout",
    "Inverter": "invert",
    "ForceSuccess": "force_success",
    "ForceFailure": "force_failure",
    "RunOnce": "once",
}
#: BehaviorTree.CPP's own nodes autonomy has nothing like, and what to use instead.
UNSUPPORTED = {
    "SequenceWithMemory": "use Sequence (autonomy's sequence starts over after a failure)",
    "AsyncSequence": "use Sequence",
    "AsyncFallback": "use Fallback",
    "ParallelAll": "use Parallel",
    "IfThenElse": "use a Fallback of a ReactiveSequence and the else branch",
    "WhileDoElse": "use While",
    "KeepRunningUntilFailure": "use Repeat with num_cycles -1",
    "Delay": "use autonomy's wait before the child",
    "Sleep": "use autonomy's wait",
    "Precondition": "use While, or a ReactiveSequence with the condition first",
    "Script": "autonomy has no blackboard scripts",
    "ScriptCondition": "autonomy has no blackboard scripts",
    "SetBlackboard": "autonomy has no blackboard",
    "UnsetBlackboard": "autonomy has no blackboard",
    "AlwaysSuccess": "use force_success over a node, or wait 0",
    "AlwaysFailure": "use force_failure over a node",
    "Switch2": "use a Fallback",
    "Switch3": "use a Fallback",
    "Switch4": "use a Fallback",
    "Switch5": "use a Fallback",
    "Switch6": "use a Fallback",
    "LoopInt": "autonomy has no blackboard queues",
    "LoopDouble": "autonomy has no blackboard queues",
    "LoopString": "autonomy has no blackboard queues",
    "LoopBool": "autonomy has no blackboard queues",
    "SkipUnlessUpdated": "autonomy has no blackboard",
    "WaitValueUpdate": "autonomy has no blackboard",
    "WasEntryUpdated": "autonomy has no blackboard",
    "ManualSelector": "use a Fallback",
}
#: Every BehaviorTree.CPP node name this reader knows, for did-you-mean.
KNOWN_TAGS = [*COMPOSITES, *DECORATORS, *UNSUPPORTED, "SubTree"]
BLACKBOARD = re.compile(r"^\s*\{.+\}\s*$", re.DOTALL)
#: Elements that name their node type in ``ID=`` rather than in their tag.
EXPLICIT = ("Action", "Condition", "Control", "Decorator")
#: Attributes BehaviorTree.CPP writes for itself, which say nothing about the mission.
BOOKKEEPING = ("_uid", "_fullpath", "_autoremap")
#: The attribute that marks a ``ReactiveSequence`` as our ``while`` (its condition, then its child).
WHILE_MARK = ("_autonomy", "while")
#: The mission's settings, as attributes of the main ``<BehaviorTree>``.
SETTINGS = {"_description": "description", "_tick_hz": "tick_hz", "_world": "world", "_plugins": "plugins"}


class AttributeText(str):
    """An attribute's value: text, to be read as the kind of the parameter it gives."""


@dataclass
class Element:
    """One XML element, where it starts, its attributes where they stand, and its children."""

    tag: str
    line: int
    column: int
    attributes: dict[str, str]
    places: dict[str, tuple[int, int]]
    children: list[Element] = field(default_factory=list)

    def at(self, name: str) -> tuple[int, int]:
        """Where attribute ``name`` stands (the element's start when it is not there)."""
        return self.places.get(name, (self.line, self.column))

    def text(self, name: str) -> Located:
        """Attribute ``name`` as a located :class:`AttributeText`."""
        return Located(AttributeText(self.attributes[name]), *self.at(name))


class XmlUnreadable(Exception):
    """XML that cannot be read; ``error`` says where and why."""

    def __init__(self, error: SourceError) -> None:
        super().__init__(error.message)
        self.error = error


_ATTRIBUTE = re.compile(r"""([^\s=/>]+)\s*=\s*("[^"]*"|'[^']*')""")
_START_TAG = re.compile(rb"""<[^\s/>]+(?:\s+[^\s=/>]+\s*=\s*(?:"[^"]*"|'[^']*'))*\s*/?>""")
_PLAIN_EXPAT = {
    "not well-formed (invalid token)": "not well-formed XML here (a stray '<' or '&', or a character XML forbids)",
    "mismatched tag": "this closing tag does not match the element it closes",
    "no element found": "the XML ends before its elements are closed",
    "unclosed token": "an element or attribute is not closed here",
    "junk after document element": "text after the end of the root element: a file holds one <root>",
    "duplicate attribute": "an attribute given twice",
    "syntax error": 'not XML: a BehaviorTree.CPP file starts with <root BTCPP_format="4">',
}


def read_elements(text: str) -> Element:
    """Parses XML into elements, with the line and column of each element and attribute.

    Raises:
        XmlUnreadable: not well-formed, a DOCTYPE, or past the limits.
    """
    data = text.encode("utf-8")
    line_starts = [0] + [m.end() for m in re.finditer(b"\n", data)]
    parser = expat.ParserCreate(encoding="utf-8")  # the text is UTF-8 whatever its declaration says
    parser.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)
    stack: list[Element] = []
    done: list[Element] = []
    count = [0]

    bom = 3 if data.startswith(b"\xef\xbb\xbf") else 0
    ascii_text = data.isascii()
    columns: dict[int, list[int]] = {}  # per non-ASCII line: the character column of each byte

    def position(offset: int) -> tuple[int, int]:
        line = bisect.bisect_right(line_starts, offset) - 1
        start = line_starts[line] + (bom if line == 0 else 0)
        if ascii_text:
            return line + 1, offset - start + 1
        if line not in columns:
            end = line_starts[line + 1] if line + 1 < len(line_starts) else len(data)
            chars, count = [], 0
            for byte in data[start:end]:
                chars.append(count)
                count += (byte & 0xC0) != 0x80  # a byte that starts a character
            chars.append(count)
            columns[line] = chars
        chars = columns[line]
        return line + 1, chars[min(max(offset - start, 0), len(chars) - 1)] + 1

    def refuse(message: str) -> None:
        raise XmlUnreadable(SourceError(*position(parser.CurrentByteIndex), message))

    def start(tag: str, attributes: dict[str, str]) -> None:
        count[0] += 1
        if count[0] > MAX_NODES:
            refuse(f"the file holds more than {MAX_NODES:,} elements")
        if len(stack) >= MAX_DEPTH:
            refuse(f"elements nested more than {MAX_DEPTH} levels deep")
        offset = parser.CurrentByteIndex
        tag_text = _START_TAG.match(data, offset)
        places = {}
        if tag_text is not None:
            decoded = tag_text.group().decode("utf-8", "replace")
            for match in _ATTRIBUTE.finditer(decoded):
                places[match.group(1)] = position(offset + len(decoded[: match.start(1)].encode("utf-8")))
        element = Element(tag, *position(offset), dict(attributes), places)
        (stack[-1].children if stack else done).append(element)
        stack.append(element)

    def end(tag: str) -> None:
        stack.pop()

    def doctype(*_: object) -> None:
        start = data.rfind(b"<!DOCTYPE", 0, parser.CurrentByteIndex + 1)
        if start >= 0:
            raise XmlUnreadable(
                SourceError(
                    *position(start),
                    "a DOCTYPE: BehaviorTree.CPP files have none, and entities are not read; remove it",
                )
            )
        refuse("a DOCTYPE: BehaviorTree.CPP files have none, and entities are not read; remove it")

    def characters(content: str) -> None:
        if content.strip() and stack and stack[-1].tag not in ("input_port", "output_port", "inout_port", "Metadata"):
            refuse(f"text inside <{stack[-1].tag}>: nodes are elements, their parameters attributes")

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.StartDoctypeDeclHandler = doctype
    parser.EntityDeclHandler = doctype
    parser.CharacterDataHandler = characters
    try:
        parser.Parse(data, True)
    except expat.ExpatError as err:
        words = expat.errors.messages[err.code] if err.code in expat.errors.messages else str(err)
        line, column = err.lineno, err.offset + 1
        raise XmlUnreadable(
            SourceError(line, column, _PLAIN_EXPAT.get(words, f"not well-formed XML: {words}"))
        ) from None
    return done[0]


def _node(element: Element, problems: list[SourceError], main_id: str = "") -> Located:
    """One node element as the YAML reader would have read the node.

    A node that cannot be read is reported, and stands as a plain sequence of its children (or,
    without children, as a refused value), so that the rest of the file, the nodes under it
    included, is still read and checked: every problem comes at once.
    """
    tag, where = element.tag, (element.line, element.column)
    kids = [_node(child, problems, main_id) for child in element.children]
    if tag == "ReactiveSequence" and element.attributes.get(WHILE_MARK[0]) == WHILE_MARK[1]:
        tag = "While"  # our while, as BehaviorTree.CPP runs it: the mark is ours, not a port
        element = replace(element, attributes={k: v for k, v in element.attributes.items() if k != WHILE_MARK[0]})

    def refuse() -> Located:
        if not kids:
            return Located(REFUSED, *where)
        children = Located({"children": Located(kids, *where)}, *where, keys={"children": where})
        return Located({"sequence": children}, *where, keys={"sequence": where})

    leaf_only = tag in ("Action", "Condition")  # <Action ID="Timeout"/> is a leaf called Timeout
    if tag in EXPLICIT or tag == "SubTree":
        if not element.attributes.get("ID", "").strip():
            problems.append(SourceError(*where, f'<{tag}> needs ID="...", the node type'))
            return refuse()
        if tag != "SubTree":
            tag = element.attributes["ID"]
    before = len(problems)
    for name, value in element.attributes.items():
        if name.startswith("_") and name not in BOOKKEEPING:
            said = "pre- and post-conditions, scripts" if not name.startswith("__") else "blackboards"
            problems.append(
                SourceError(*element.at(name), f"BehaviorTree.CPP's {name} ({said}) is not something autonomy runs")
            )
        elif BLACKBOARD.match(value) and name != "ID":
            problems.append(
                SourceError(
                    *element.at(name),
                    f'{name}="{value.strip()}" reads a blackboard entry; autonomy has no blackboard: write the value',
                )
            )
    if len(problems) > before:
        return refuse()
    if tag == "SubTree":
        for name in element.attributes:
            if name not in ("ID", "name", *BOOKKEEPING):
                said = f"SubTree port '{name}': autonomy has no blackboard to remap"
                problems.append(SourceError(*element.at(name), said))
                return refuse()
        if element.attributes["ID"] == main_id:
            said = f"SubTree '{main_id}' is the main tree: it would hold itself"
            problems.append(SourceError(*element.at("ID"), said))
            return refuse()
        return Located({"subtree": element.text("ID")}, *where, keys={"subtree": where})
    if tag in UNSUPPORTED and not leaf_only:
        problems.append(SourceError(*where, f"BehaviorTree.CPP's {tag} has no autonomy equivalent: {UNSUPPORTED[tag]}"))
        return refuse()
    params: dict[str, Located] = {}
    keys: dict[str, tuple[int, int]] = {}

    def put(key: str, value: Located) -> None:
        params[key] = value
        keys[key] = (value.line, value.column)

    ours = tag
    # An empty attribute is a port left empty (Groot2 writes one for every port it shows): not given.
    ports = {k: v for k, v in element.attributes.items() if k not in BOOKKEEPING and k != "ID" and v.strip()}
    name = ports.pop("name", None)
    if name is not None and name not in (tag, element.tag):  # BehaviorTree.CPP names an unnamed node by its ID
        put("name", element.text("name"))
    if tag in COMPOSITES and not leaf_only:
        ours, fixed = COMPOSITES[tag]
        for key, value in fixed.items():
            put(key, Located(value, *where))
        if tag == "Parallel":
            counts = _parallel(element, ports, problems)
            if counts is None:
                return refuse()
            put("policy", Located(counts, *where))
        elif tag == "While":
            if len(kids) != 2:
                said = f"While takes two children, the condition and the node; got {len(kids)}"
                problems.append(SourceError(*where, said))
                return refuse()
            put("condition", kids[0])
            put("do", kids[1])
            kids = []
        elif ports:
            key = next(iter(ports))
            problems.append(SourceError(*element.at(key), f"unknown port '{key}' for {tag}: it takes none"))
            return refuse()
        if not kids and tag != "While":
            problems.append(SourceError(*where, f"<{tag}> needs at least one child"))
            return refuse()
        if kids:
            put("children", Located(kids, *where))
    elif tag in DECORATORS and not leaf_only:
        ours = DECORATORS[tag]
        if not _decorator_ports(element, ports, put, problems):
            return refuse()
        if len(kids) != 1:
            problems.append(SourceError(*where, f"{tag} takes exactly one child, got {len(kids)}"))
            return refuse()
        put("do", kids[0])
    elif tag in OWN_CONTROLS and not leaf_only:  # ours, as our export writes it: its ports, its children
        if not kids:
            problems.append(SourceError(*where, f"<{tag}> needs at least one child"))
            return refuse()
        for key in ports:
            put(key, element.text(key))
        put("children", Located(kids, *where))
    else:
        if kids:
            hint = suggest(tag, KNOWN_TAGS)
            what = f"not a control or decorator node autonomy knows{hint}" if hint else "a leaf here"
            problems.append(SourceError(*where, f"<{tag}> has children, but it is {what}"))
            return refuse()
        if tag[:1].isupper() and tag not in KNOWN_TAGS and not leaf_only:
            hint = suggest(tag, KNOWN_TAGS)
            if hint:
                problems.append(SourceError(*where, f"unknown node '{tag}'{hint}"))
                return refuse()
        for key in ports:
            put(key, element.text(key))
    return Located({ours: Located(params, *where, keys=keys)}, *where, keys={ours: where})


def _whole(element: Element, key: str, problems: list[SourceError]) -> int | None:
    text = element.attributes[key].strip()
    if not re.fullmatch(r"[-+]?\d{1,12}", text):
        problems.append(SourceError(*element.at(key), f"{element.tag} {key} must be a whole number, got '{text}'"))
        return None
    return int(text)


def _parallel(element: Element, ports: dict[str, str], problems: list[SourceError]) -> str | None:
    for key in ports:
        if key not in ("success_count", "failure_count"):
            problems.append(
                SourceError(
                    *element.at(key), f"unknown port '{key}' for Parallel: it takes success_count, failure_count"
                )
            )
            return None
    success = _whole(element, "success_count", problems) if "success_count" in ports else -1
    failure = _whole(element, "failure_count", problems) if "failure_count" in ports else 1
    if success is None or failure is None:
        return None
    if failure != 1 or success not in (-1, 1):
        where = element.at("success_count" if success not in (-1, 1) else "failure_count")
        problems.append(
            SourceError(
                *where,
                f"autonomy's parallel succeeds when all (success_count -1) or one (1) child has, and fails on "
                f"the first failure (failure_count 1); got success_count {success}, failure_count {failure}",
            )
        )
        return None
    return "all" if success == -1 else "one"


_DECORATOR_PORTS = {
    "Repeat": ("num_cycles", "times"),
    "RetryUntilSuccessful": ("num_attempts", "attempts"),
    "Timeout": ("msec", "seconds"),
    "RunOnce": ("then_skip", ""),
}


def _decorator_ports(element: Element, ports: dict[str, str], put, problems: list[SourceError]) -> bool:
    port, ours = _DECORATOR_PORTS.get(element.tag, ("", ""))
    for key in ports:
        if key != port:
            known = f"it takes {port}" if port else "it takes no ports"
            problems.append(SourceError(*element.at(key), f"unknown port '{key}' for {element.tag}: {known}"))
            return False
    if element.tag == "RunOnce" and ports.get("then_skip", "").strip().lower() not in ("false", "0"):
        problems.append(
            SourceError(
                *element.at("then_skip"),
                "RunOnce needs then_skip=\"false\": autonomy's once gives the child's result again afterwards, "
                "where BehaviorTree.CPP's default (true) skips the node",
            )
        )
        return False
    if not port or port not in ports:
        if element.tag in ("RetryUntilSuccessful", "Timeout", "Repeat"):  # as BehaviorTree.CPP: no default
            forever = " (-1: forever)" if element.tag == "Repeat" else ""
            problems.append(SourceError(element.line, element.column, f"{element.tag} needs {port}{forever}"))
            return False
        return True
    if element.tag == "RunOnce":
        return True  # its then_skip was checked above
    value = _whole(element, port, problems)
    if value is None:
        return False
    where = element.at(port)
    if element.tag == "Repeat" and value == -1:
        return True  # forever
    if element.tag == "RetryUntilSuccessful" and value == -1:
        said = "num_attempts -1 (forever) is not autonomy's: its retry takes 1 to 1000 attempts"
        problems.append(SourceError(*where, f"RetryUntilSuccessful {said}"))
        return False
    if element.tag == "Timeout" and value <= 0:
        problems.append(SourceError(*where, f"Timeout msec must be above 0, got {value}"))
        return False
    if element.tag == "Timeout":
        put(ours, Located(value // 1000 if value % 1000 == 0 else value / 1000, *where))
    else:
        put(ours, Located(value, *where))
    return True


def _setting(key: str, value: Located) -> Located:
    if key == "tick_hz":
        try:
            return Located(float(value.value), value.line, value.column)
        except ValueError:
            return value
    if key == "plugins":
        names = [n.strip() for n in re.split(r"[;,]", value.value) if n.strip()]
        return Located([Located(n, value.line, value.column) for n in names], value.line, value.column)
    return Located(str(value.value), value.line, value.column)


def parse_xml(text: str) -> tuple[Located | None, list[SourceError]]:
    """Reads a BehaviorTree.CPP 4 file into a mission document.

    Returns:
        The document (None when it could not be read at all) and the problems found.
    """
    bad = text_problems(text)
    if bad:
        return None, bad
    if not text.strip():
        return None, [SourceError(1, 1, "the file is empty")]
    try:
        root = read_elements(text)
    except XmlUnreadable as stop:
        return None, [stop.error]
    where = (root.line, root.column)
    if root.tag != "root":
        return None, [SourceError(*where, f'expected <root BTCPP_format="4">, found <{root.tag}>')]
    problems: list[SourceError] = []
    version = root.attributes.get("BTCPP_format")
    if version is not None and version.strip() != "4":
        problems.append(SourceError(*root.at("BTCPP_format"), f"BTCPP_format {version!r}: autonomy reads format 4"))
    trees = [child for child in root.children if child.tag == "BehaviorTree"]
    for child in root.children:
        if child.tag not in ("BehaviorTree", "TreeNodesModel", "include"):
            problems.append(SourceError(child.line, child.column, f"unexpected <{child.tag}> in <root>"))
        elif child.tag == "include":
            problems.append(SourceError(child.line, child.column, "<include> is not read: put every tree in this file"))
    if not trees:
        return None, [*problems, SourceError(*where, 'no <BehaviorTree ID="..."> in this file')]
    seen: dict[str, Element] = {}
    for tree in trees:
        if "ID" not in tree.attributes:
            problems.append(SourceError(tree.line, tree.column, '<BehaviorTree> needs ID="...", its name'))
        elif tree.attributes["ID"] in seen:
            problems.append(SourceError(*tree.at("ID"), f"a second tree with ID '{tree.attributes['ID']}'"))
        else:
            seen[tree.attributes["ID"]] = tree
    main_id = root.attributes.get("main_tree_to_execute")
    if main_id is None:
        if len(trees) > 1:  # reported; the first is checked as the mission, for the problems in it
            problems.append(
                SourceError(*where, 'several trees: say which is the mission with main_tree_to_execute="ID" on <root>')
            )
        main_id = trees[0].attributes.get("ID", "")
    elif main_id not in seen:
        problems.append(SourceError(*root.at("main_tree_to_execute"), f'no <BehaviorTree ID="{main_id}"> in this file'))
        return None, problems
    main = seen.get(main_id)
    if main is None:
        return None, problems
    doc: dict[str, Located] = {}
    keys: dict[str, tuple[int, int]] = {}
    doc["mission"] = main.text("ID")
    keys["mission"] = main.at("ID")
    for attribute, key in SETTINGS.items():
        if main.attributes.get(attribute, "").strip():  # an empty setting is one not given
            doc[key] = _setting(key, main.text(attribute))
            keys[key] = main.at(attribute)
    subtrees: dict[str, Located] = {}
    sub_keys: dict[str, tuple[int, int]] = {}
    for tree_id, tree in seen.items():
        if len(tree.children) != 1:
            problems.append(
                SourceError(
                    tree.line, tree.column, f"tree '{tree_id}' needs exactly one root node, got {len(tree.children)}"
                )
            )
            if tree is main:
                doc["tree"] = Located(REFUSED, tree.line, tree.column)
            continue
        node = _node(tree.children[0], problems, main_id)
        if tree is main:
            doc["tree"] = node
            keys["tree"] = (node.line, node.column)
        else:
            subtrees[tree_id] = node
            sub_keys[tree_id] = tree.at("ID")
    if subtrees:
        doc["subtrees"] = Located(subtrees, main.line, main.column, keys=sub_keys)
        keys["subtrees"] = (main.line, main.column)
    # With problems, the document still goes to the validator, refused parts left out, so that
    # every problem of the file is reported at once.
    return Located(doc, *where, keys=keys), problems

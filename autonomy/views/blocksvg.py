"""A mission's blocks as a picture (SVG): the same sentences, fields, colours and nesting as its blocks.

Drawn from Blockly's JSON of the workspace (:func:`autonomy.mission.blocks.to_workspace`) and the
blocks' definitions (:func:`autonomy.mission.blocks.block_definitions`), with no browser: a feedback
page shows a student who built their mission from blocks what they built, as they saw it. Every
text is escaped; the picture holds no script and fetches nothing.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Any
from xml.sax.saxutils import escape, quoteattr

#: A row of words and fields, in pixels.
ROW_PX = 26
#: How far a block's inner blocks are drawn in, and the strip under them.
INDENT_PX = 18
BOTTOM_PX = 10
#: An estimate of a character's width in the picture's font (12 px DejaVu Sans), in pixels: narrow, wide, others.
NARROW = frozenset("ijlft.,:;'|!()[] ")
WIDE = frozenset("mwMW%@")
CHAR_PX = 7.2
PAD_PX = 8
#: The most blocks drawn: past that, the picture says how many more there are.
MAX_BLOCKS = 2_000


@dataclass
class _Drawn:
    """A block laid out: its SVG (at 0, 0), its width and height."""

    parts: list[str] = field(default_factory=list)
    width: float = 0.0
    height: float = 0.0


def _field_text(arg: dict[str, Any], fields: dict[str, Any]) -> str:
    value = fields.get(arg["name"])
    kind = arg["type"]
    if kind == "field_checkbox":
        checked = arg.get("checked") if value is None else value
        return "✓" if checked in (True, "TRUE") else "✗"
    if kind == "field_dropdown":
        chosen = value if value is not None else arg["options"][0][1]
        return next((label for label, option in arg["options"] if option == chosen), str(chosen)) + " ▾"
    if value is None:
        value = arg.get("value", arg.get("text", ""))
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    return str(value)


def _width(text: str) -> float:
    return sum(4.0 if c in NARROW else 10.5 if c in WIDE else 8.4 if c.isupper() else CHAR_PX for c in text)


class _Painter:
    def __init__(self, definitions: list[dict[str, Any]]) -> None:
        self.definitions = {d["type"]: d for d in definitions}
        self.drawn = 0

    def chain(self, state: dict[str, Any] | None) -> _Drawn:
        """Blocks one under another (each block's ``next``)."""
        out = _Drawn()
        while isinstance(state, dict):
            if self.drawn >= MAX_BLOCKS:
                out.parts.append(_text(PAD_PX, out.height + 17, "...", "#111"))
                out.height += ROW_PX
                break
            block = self.block(state)
            out.parts.append(f'<g transform="translate(0,{out.height:g})">{"".join(block.parts)}</g>')
            out.width = max(out.width, block.width)
            out.height += block.height + 2
            state = (state.get("next") or {}).get("block")
        return out

    def block(self, state: dict[str, Any]) -> _Drawn:
        """One block and the blocks inside it."""
        self.drawn += 1
        definition = self.definitions.get(state.get("type", ""), {})
        colour = definition.get("colour", "#555555")
        fields, inputs = state.get("fields") or {}, state.get("inputs") or {}
        rows: list[tuple[str, Any]] = []  # ("row", [(text, is_field)]) or ("inner", _Drawn)
        index = 0
        while f"message{index}" in definition:
            message, args = definition[f"message{index}"], definition.get(f"args{index}", [])
            pieces: list[tuple[str, bool]] = []
            inner = None
            for token in _tokens(message):
                if isinstance(token, int) and 0 < token <= len(args):
                    arg = args[token - 1]
                    if arg["type"] == "input_statement":
                        inner = self.chain((inputs.get(arg["name"]) or {}).get("block"))
                    else:
                        pieces.append((_field_text(arg, fields), True))
                elif isinstance(token, str) and token.strip():
                    pieces.append((token.strip(), False))
            if pieces:
                rows.append(("row", pieces))
            if inner is not None:
                rows.append(("inner", inner))
            index += 1
        if not rows:
            rows.append(("row", [(state.get("type", "?"), False)]))
        out = _Drawn()
        body: list[str] = []
        for kind, content in rows:
            if kind == "row":
                x = PAD_PX
                for text, is_field in content:
                    if is_field:
                        width = _width(text) + 10
                        body.append(
                            f'<rect x="{x:g}" y="{out.height + 4:g}" width="{width:g}" height="{ROW_PX - 8}" rx="4" '
                            'fill="#ffffff" fill-opacity="0.9"/>'
                        )
                        body.append(_text(x + 5, out.height + 17, text, "#111111"))
                        x += width + 5
                    else:
                        body.append(_text(x, out.height + 17, text, "#ffffff"))
                        x += _width(text) + 5
                out.width = max(out.width, x + PAD_PX - 5)
                out.height += ROW_PX
            else:
                inner: _Drawn = content
                height = max(inner.height, ROW_PX)
                body.append(
                    f'<rect x="{INDENT_PX}" y="{out.height:g}" width="{max(inner.width, 40):g}" height="{height:g}" '
                    'fill="#ffffff"/>'
                )
                body.append(f'<g transform="translate({INDENT_PX},{out.height:g})">{"".join(inner.parts)}</g>')
                out.width = max(out.width, INDENT_PX + inner.width)
                out.height += height
                if rows[-1][1] is content:
                    out.height += BOTTOM_PX
        out.parts = [f'<rect width="{out.width:g}" height="{out.height:g}" rx="4" fill={quoteattr(colour)}/>', *body]
        return out


def _tokens(message: str) -> list[str | int]:
    """A Blockly message split into its words and its ``%N`` places (``%%`` is a percent sign)."""
    out: list[str | int] = []
    text, i = "", 0
    while i < len(message):
        if message[i] == "%" and message[i + 1 : i + 2] == "%":
            text += "%"
            i += 2
        elif message[i] == "%" and message[i + 1 : i + 2].isdigit():
            j = i + 1
            while j < len(message) and message[j].isdigit():
                j += 1
            out += [text, int(message[i + 1 : j])]
            text, i = "", j
        else:
            text += message[i]
            i += 1
    return [*out, text]


def _text(x: float, y: float, text: str, colour: str) -> str:
    return f'<text x="{x:g}" y="{y:g}" fill="{colour}">{escape(text)}</text>'


def blocks_svg(workspace: dict[str, Any], definitions: list[dict[str, Any]], label: str) -> str:
    """The workspace's blocks drawn as one SVG picture (ASCII: others as references): its top blocks one under another.

    Args:
        workspace: Blockly's JSON of the workspace.
        definitions: The blocks' definitions.
        label: What the picture is, for those who cannot see it.
    """
    painter = _Painter(definitions)
    tops = ((workspace.get("blocks") or {}).get("blocks")) or []
    parts, width, height = [], 0.0, 0.0
    for top in tops:
        drawn = painter.chain(top)
        parts.append(f'<g transform="translate(0,{height:g})">{"".join(drawn.parts)}</g>')
        width, height = max(width, drawn.width), height + drawn.height + 16
    width, height = max(width, 1.0) + 2, max(height, 1.0)
    svg = (
        f'<svg xmlns="http://www.w3.org/2000/svg" role="img" aria-label={quoteattr(label)} '
        f'width="{width:g}" height="{height:g}" viewBox="0 0 {width:g} {height:g}" '
        'font-family="DejaVu Sans, Arial, sans-serif" font-size="12">'
        f"<title>{escape(label)}</title>{''.join(parts)}</svg>"
    )
    return svg.encode("ascii", "xmlcharrefreplace").decode("ascii")  # a page of it stays one byte a character


@functools.cache
def _builtin_definitions() -> list[dict[str, Any]]:
    """The built-in nodes' blocks, made once a process (a page is drawn with every run graded)."""
    from autonomy.mission import BUILTINS
    from autonomy.mission.blocks import block_definitions

    return block_definitions(BUILTINS)


def mission_blocks_svg(text: str, label: str) -> str | None:
    """A mission file's text drawn as its blocks (None: not a mission the blocks hold).

    Its plugins are never imported: a mission that names any is not drawn.
    """
    from autonomy.mission import MissionInvalid, validate_text
    from autonomy.mission.blocks import to_workspace

    try:
        spec = validate_text(text, "mission", check_world=False, refuse_plugins="plugins are not drawn")
        return blocks_svg(to_workspace(spec, text), _builtin_definitions(), label)
    except (MissionInvalid, RecursionError, ValueError):
        return None

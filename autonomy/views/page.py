"""The browser view's page and what it shows of a run, without a server.

The page (``static/``) gets a run as one JSON object: the header, the tree and map pictures,
every tick record and the end record. The view server (:mod:`autonomy.views.web`) answers it
at ``api/run``; :func:`standalone_html` writes it into the page itself, one file that plays a
recorded run with nothing to fetch; and a page that holds several runs (a student's feedback
page) frames the page once for each (:func:`runs_host_head`).
Nothing here needs the server's packages, so a grader's workers can make pages without them.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Iterable
from importlib import resources
from typing import Any

import msgspec

from autonomy.record import Event, NodeState, Pose, Record, RunEnd, RunHeader, TickRecord, ticks_json, to_line
from autonomy.trace import Trace
from autonomy.views.mapsvg import world_svg
from autonomy.views.treesvg import svg_tree

#: The page's files besides ``index.html``, and their types.
STATIC_FILES = {"app.js": "text/javascript", "app.css": "text/css"}
#: What a framed viewer asks the page it is in for (the page answers with the frame's run, as JSON text).
RUN_REQUEST = "autonomy-run?"


@functools.cache
def static_text(name: str, package: str = "autonomy.views") -> str:
    """One of a package's page files (``static/``: the view's ``index.html``, ``app.js``, ``app.css``), as text."""
    return resources.files(package).joinpath("static", name).read_text(encoding="utf-8")


#: The last tree drawn: (mission, nodes, picture). A student's runs on every seed have the same tree.
_last_tree: tuple[str, list[Any], str] = ("", [], "")


def _tree_svg(header: RunHeader) -> str:
    global _last_tree  # one picture kept, swapped whole: a thread reading it sees the one or the other
    mission, nodes, svg = _last_tree
    if mission != header.mission or nodes != header.nodes or not svg:
        svg = svg_tree(header.nodes, header.mission, legend=False)
        _last_tree = (header.mission, header.nodes, svg)
    return svg


def _head(header: RunHeader | None, mode: str, run: str) -> dict[str, Any]:
    if header is None:
        return {"mode": mode, "run": run, "header": None, "tree_svg": "", "map_svg": None}
    return {
        "mode": mode,
        "run": run,
        "header": header.to_json(),
        "tree_svg": _tree_svg(header),
        "map_svg": world_svg(header.world) if header.world else None,
    }


def run_payload(
    header: RunHeader | None,
    ticks: list[TickRecord],
    end: RunEnd | None,
    mode: str,
    run: str = "",
    open_at_end: bool = False,
) -> str:
    """A run as the page takes it (the ``api/run`` answer), in JSON.

    Args:
        header: The run's header (None: no run yet).
        ticks: Its tick records so far.
        end: Its end record, if it ended.
        mode: ``live`` or ``replay`` (the page shows replay controls).
        run: The run's name, by which a live page knows the next run from this one.
        open_at_end: A replay opens on the run's last tick (where it ended), not its first.
    """
    head = _head(header, mode, run)
    return "".join(_parts(head, "ticks", ticks_json(ticks)[1:-1], end, open_at_end))


def _parts(head: dict[str, Any], key: str, items: str, end: RunEnd | None, open_at_end: bool) -> list[str]:
    """The payload's JSON in pieces: ``head``'s fields, then ``key``'s items (a JSON array's inside), the end."""
    if open_at_end:
        head["open_at_end"] = True
    end_text = to_line(end) if end else "null"
    return [json.dumps(head)[:-1], f',"{key}":[', items, '],"end":', end_text, "}"]


class _Row(msgspec.Struct, array_like=True, gc=False):
    """What the page draws of one tick, in JSON an array: its items in :data:`ROW_FIELDS`' order."""

    tick: int
    time_s: float
    front_distance_mm: int
    heading_deg: int
    tilt_deg: int
    battery: int
    speed_mm_s: float
    dead_reckoning: Pose
    truth: Pose | None
    nodes: dict[int, NodeState]
    events: list[Event]


#: The items of a replay's row, in order; the payload names them (``row_fields``), and the page makes
#: each row a tick record again (static/app.js). Those of the status packet are its own fields.
ROW_FIELDS = _Row.__struct_fields__
_encode_row = msgspec.json.Encoder().encode


class ReplayMaker:
    """A listener that makes a recorded run's payload (:func:`replay_payload`) as its records come.

    A replay's page draws a few of each tick's fields (not the wire, nor the status's flags):
    each tick is kept as a row of those, in JSON an array (:data:`ROW_FIELDS`), a third of the
    tick's record, and the record let go at once. A grader that keeps every run of a class
    for its pages holds text, which the garbage collector does not go over, and writes pages a
    third the size. A new header starts again (the last run is kept).
    """

    def __init__(self) -> None:
        self.header: RunHeader | None = None
        self.end: RunEnd | None = None
        self._rows: list[bytes] = []
        #: Why the run cannot be replayed ("": it can).
        self.why = ""

    def __call__(self, record: Record) -> None:
        """Takes one record."""
        if type(record) is TickRecord:
            if self.why:
                return
            status = record.status
            values = _Row(
                record.tick,
                record.time_s,
                status.front_distance_mm,
                status.heading_deg,
                status.tilt_deg,
                record.battery,
                record.speed_mm_s,
                record.dead_reckoning,
                record.truth,
                record.nodes,
                record.events,
            )
            try:  # the encoder writes NaN and infinity as null, as it writes the truth of a run off the emulator
                row = _encode_row(values)
                finite = b"null" not in row or record.finite()
            except UnicodeEncodeError:  # a behaviour's text holding a lone surrogate: escaped, as json does
                row = json.dumps(msgspec.to_builtins(values, str_keys=True)).encode("ascii")
                finite = record.finite()
            if not finite:
                self.why = f"tick {record.tick} holds a number that is not finite"
            self._rows.append(row)
        elif isinstance(record, RunHeader):
            self.header, self.end, self._rows, self.why = record, None, [], ""
        elif isinstance(record, RunEnd):
            self.end = record

    def payload(self, at_end: bool = False) -> str:
        """The run so far as the page takes it, in JSON: its ticks as rows (``rows``, :data:`ROW_FIELDS`).

        Args:
            at_end: Open on the run's last tick (where it ended), not its first.

        Raises:
            ValueError: a record holds a number that is not finite (NaN or infinity).
        """
        return "".join(self.payload_parts(at_end))

    def payload_parts(
        self, at_end: bool = False, header: RunHeader | None = None, marks: dict[str, list[Any]] | None = None
    ) -> list[str]:
        """:meth:`payload` in pieces, to be written one after another without being joined first.

        Args:
            at_end: Open on the run's last tick (where it ended), not its first.
            header: The header to show instead of the run's (one made for whoever reads the page).
            marks: What a grader judged of the run, drawn on the map as the replay reaches each:
                ``beeps`` ([time_s, x_mm, y_mm]) and ``turns`` ([time_s, x_mm, y_mm, degrees]).

        Raises:
            ValueError: a record holds a number that is not finite (NaN or infinity).
        """
        if self.why:
            raise ValueError(self.why)
        header = header or self.header
        head = _head(header, "replay", "replay-1" if header is not None else "")
        head["row_fields"] = list(ROW_FIELDS)
        if marks is not None:
            head["marks"] = marks
        return _parts(head, "rows", b",".join(self._rows).decode(), self.end, at_end)


def replay_payload(trace: Trace | Iterable[Record], at_end: bool = False) -> str:
    """A recorded run (its trace, or its records; the last run in them) as the page takes it, in JSON."""
    maker = ReplayMaker()
    for record in trace.records() if isinstance(trace, Trace) else trace:
        maker(record)
    return maker.payload(at_end)


def script_json(payload: str) -> str:
    """JSON text made safe inside a ``<script type="application/json">`` element.

    No ``<`` at all: ``</script>`` would end the element, and ``<!--<script`` would keep the
    real end from ending it. JSON has ``<`` only inside strings, where ``\\u003c`` is the same text.
    """
    return payload.replace("<", "\\u003c")


def _page(data_element: str) -> str:
    page = static_text("index.html")
    style = f"<style>\n{static_text('app.css')}</style>"
    page = page.replace('<link rel="stylesheet" href="static/app.css">', style)
    script = f"{data_element}\n<script>\n{static_text('app.js')}</script>"
    return page.replace('<script src="static/app.js"></script>', script)


def standalone_html(trace: Trace | Iterable[Record], at_end: bool = False) -> str:
    """The page frozen on a whole recorded run, in one file with nothing to fetch.

    Args:
        trace: The run: a trace, or its records.
        at_end: Open on the run's last tick (where it ended), not its first.
    """
    data = script_json(replay_payload(trace, at_end))
    return _page(f'<script id="run-data" type="application/json">{data}</script>')


#: The id of the element that holds the framed viewer in a page that holds runs (:func:`runs_host_head`).
VIEWER_ID = "autonomy-viewer"


@functools.cache
def _viewer_json() -> str:
    # the page with no run of its own: framed, it asks the page it is in for its run
    return script_json(json.dumps(_page('<script id="run-from-page" type="application/json">{}</script>')))


def runs_host_head() -> str:
    """What a page that holds runs for viewers puts in its head: the viewer, once, and the script that frames it.

    Each ``<iframe data-run="ID">`` of the page gets the viewer as its ``srcdoc``; the viewer, in
    its frame, asks the page for its run (:data:`RUN_REQUEST`, by ``postMessage``) and gets the
    text of the page's ``<script type="application/json" id="ID">`` (made by :func:`script_json`).
    The viewer's code is in the page once, however many runs it holds, and no run is escaped
    into an attribute.
    """
    return (
        f'<script id="{VIEWER_ID}" type="application/json">{_viewer_json()}</script>\n'
        "<script>\n"
        'addEventListener("DOMContentLoaded", () => {\n'
        f'  const viewer = JSON.parse(document.getElementById("{VIEWER_ID}").textContent);\n'
        '  for (const frame of document.querySelectorAll("iframe[data-run]")) frame.srcdoc = viewer;\n'
        "});\n"
        'addEventListener("message", (event) => {\n'
        f'  if (event.data !== "{RUN_REQUEST}") return;\n'
        '  for (const frame of document.querySelectorAll("iframe[data-run]")) {\n'
        "    if (frame.contentWindow !== event.source) continue;\n"
        "    const data = document.getElementById(frame.dataset.run);\n"
        '    if (data) frame.contentWindow.postMessage(data.textContent, "*");\n'
        "  }\n"
        "});\n"
        "</script>"
    )

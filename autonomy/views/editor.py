"""``autonomy edit``: a page with a mission as blocks and as text side by side, that checks and saves the file.

The page holds no mapping of its own: it sends the text to be made blocks (``api/blocks``) and the
blocks to be made text (``api/text``), and both go through :mod:`autonomy.mission.blocks`. Every
request carries the page's key (``Authorization: Bearer KEY``, from the address's ``#KEY``): a
page of another site, or another user of the machine, cannot save over the file. The server is a
:class:`~autonomy.views.web.BoundedServer`, bounded as the run's view is. Blockly is served from
the package (``static/vendor/blockly``, its version, licence and each file's sha256 in
``VENDOR.json``), and so is CodeMirror, the text's editor (``static/vendor/codemirror``, one file
bundled from its packages by ``make vendor``): the page loads nothing from the internet.

``GET  /api/mission``  the file's name, its text, the blocks' definitions and toolbox, and its blocks or its problems
``POST /api/blocks``   ``{"text": TEXT}`` -> ``{"ok": true, "workspace": ...}`` or ``{"ok": false, "problems": [...]}``;
                       ``?line=N``: ``selected`` is the block of the node on the text's line N
``POST /api/text``     ``{"workspace": ...}`` -> ``{"ok": true, "text": TEXT}`` or the problems, at their blocks;
                       ``?selected=ID``: ``line`` is where that block's node begins in the text
``POST /api/save``     ``{"text": TEXT}`` -> saved, with the text's problems if it has any (a draft is saved too)
``POST /api/run``      ``{"text": TEXT}`` -> run on the emulator in real time (its world, at most 5 minutes), shown
                       in the live view (``view``: a :class:`~autonomy.views.web.ViewServer` beside the editor,
                       framed in its page); or the text's problems, or why not (a run is under way)
``GET  /api/run``      the run's state: ``running``, then its ``outcome`` and ``summary``
``POST /api/stop``     ``{"stop": true}`` -> the run under way ends after its tick, the robot stopped
"""

from __future__ import annotations

import asyncio
import functools
import hmac
import json
import os
import secrets
import stat
import threading
from concurrent.futures import ThreadPoolExecutor
from importlib import resources
from pathlib import Path
from typing import Any
from urllib.parse import quote

from aiohttp import web

from autonomy.client import Client
from autonomy.errors import AutonomyError
from autonomy.mission import MissionInvalid, validate_text
from autonomy.mission.blocks import (
    block_at_line,
    block_definitions,
    from_workspace,
    load_words,
    problems_at_blocks,
    to_workspace,
    toolbox,
    workspace_json,
)
from autonomy.mission.catalogue import json_schema
from autonomy.runner import Runner
from autonomy.source import MAX_FILE_BYTES, Problem, UnreadableFile, read_text
from autonomy.views.page import static_text
from autonomy.views.web import BoundedServer, ViewServer, nonced_page, page_file, query_line, query_selected

#: The editor's own files, and their types.
EDITOR_FILES = {
    "editor.js": "text/javascript",
    "editor.css": "text/css",
    "blocks.js": "text/javascript",
    "text.js": "text/javascript",
    "contrast.js": "text/javascript",
    "contrast.css": "text/css",
}
#: The libraries served from the package, each in ``static/vendor/NAME`` with its ``VENDOR.json``.
VENDORED = ("blockly", "codemirror")
#: The types of the vendored files served.
VENDOR_TYPES = {
    ".js": "text/javascript",
    ".css": "text/css",
    ".svg": "image/svg+xml",
    ".gif": "image/gif",
    ".cur": "image/x-icon",
}
#: A run from the editor ends after this long at most (Stop ends it sooner).
MAX_RUN_S = 300.0
#: Largest request body: a mission file's text (or its workspace, a few times its size) at most.
MAX_EDIT_BYTES = 8 * MAX_FILE_BYTES
#: The page's policy: its own scripts and styles and Blockly's pictures; nothing from elsewhere. Blockly writes one
#: style attribute (the direction of a bubble's text): style attributes are allowed. CodeMirror puts its themes in
#: a <style> element of its own: it carries the response's nonce (:func:`~autonomy.views.web.nonced_page`), and
#: no other <style> element, and no script but the server's, is taken.
EDITOR_POLICY = (
    "default-src 'none'; script-src 'self'; style-src 'self'; style-src-attr 'unsafe-inline'; img-src 'self' data:; "
    "connect-src 'self'; "
    "base-uri 'none'; form-action 'none'; frame-ancestors 'none'"
)


def vendored(library: str = "blockly") -> dict[str, Any]:
    """A vendored library's record: ``name``, ``version``, ``licence`` and each file's ``sha256`` (``files``)."""
    root = resources.files("autonomy.views").joinpath("static", "vendor", library)
    return json.loads(root.joinpath("VENDOR.json").read_text(encoding="utf-8"))


def vendor_bytes(library: str, name: str) -> bytes:
    """A vendored file, as served."""
    return resources.files("autonomy.views").joinpath("static", "vendor", library, *name.split("/")).read_bytes()


def vendor_response(library: str, name: str) -> web.Response:
    """A vendored file (``/vendor/LIBRARY/NAME``), or not found: only the files its ``VENDOR.json`` lists."""
    kind = VENDOR_TYPES.get(Path(name).suffix)
    if library not in VENDORED or name not in vendored(library)["files"] or kind is None:
        raise web.HTTPNotFound()
    return web.Response(body=vendor_bytes(library, name), content_type=kind, headers={"Cache-Control": "max-age=3600"})


def origins(host: str, port: int) -> list[str]:
    """The origins the editor's page is opened at: on a loopback address, as every browser names this machine.

    A policy names no IPv6 address (its grammar has none: a browser drops ``http://[::1]:8766`` as invalid), so
    the page is opened at 127.0.0.1 or localhost, as printed.
    """
    if host in ("127.0.0.1", "localhost", "::1"):
        return [f"http://127.0.0.1:{port}", f"http://localhost:{port}"]
    if host in ("", "0.0.0.0", "::"):  # every interface: the machine's names are the browser's to choose
        return [f"http://*:{port}"]
    return [f"http://{host}:{port}" if ":" not in host else f"http://[{host}]:{port}"]


def _problems(problems: list[Problem]) -> list[dict[str, Any]]:
    return [{"line": p.line, "column": p.column, "path": p.path, "message": p.message} for p in problems]


class EditorServer(BoundedServer):
    """Serves the editor of one mission file in a thread of its own.

    Args:
        path: The mission file (it is made when it does not exist yet, at the first save).
        host: The interface (127.0.0.1 unless asked otherwise).
        port: The TCP port (0: any free one).
        words: What the blocks say (default: the English words).
    """

    max_request_bytes = MAX_EDIT_BYTES

    def __init__(self, path: Path, host: str = "127.0.0.1", port: int = 8766, words: Any = None) -> None:
        super().__init__(host, port, "editor")
        self.path = Path(path)
        self.key = secrets.token_urlsafe(18)
        self._words = words or load_words()
        self._work = ThreadPoolExecutor(1, thread_name_prefix="autonomy-editor")  # conversions, off the loop
        self.view: ViewServer | None = None  # the runs' live view, on a port of its own
        self._running: tuple[Runner, threading.Thread] | None = None
        self._last_run: dict[str, Any] = {}
        self._run_lock = threading.Lock()
        self._runs_closed = False  # the editor is stopping: no run starts any more

    def start(self) -> None:
        """Serves the editor, and beside it the live view its runs are shown in (framed in the editor's page).

        Raises:
            OSError: a port cannot be bound.
        """
        super().start()
        self.view = ViewServer(self.host, 0, framed_by=" ".join(origins(self.host, self.port)))
        try:
            self.view.start()
        except OSError:
            super().stop()
            raise

    def stop(self) -> None:
        """Stops a run under way (the robot stopped), then the view and the editor; no run starts after."""
        with self._run_lock:  # a run being checked now is refused: it would start after the robot's stop
            self._runs_closed = True
            running = self._running
        if running is not None:
            running[0].request_stop("the editor stopped")
            running[1].join(timeout=30)
        if self.view is not None:
            self.view.stop()
        super().stop()

    @property
    def page_url(self) -> str:
        """The page's address, with its key."""
        return f"{self.url}#{self.key}"

    def _routes(self, app: web.Application) -> None:
        app.router.add_get("/", self._index)
        app.router.add_get("/static/{name}", self._static)
        app.router.add_get("/vendor/{library}/{name:.+}", self._vendor)
        app.router.add_get("/api/mission", self._mission)
        app.router.add_post("/api/blocks", self._blocks)
        app.router.add_post("/api/text", self._text)
        app.router.add_post("/api/save", self._save)
        app.router.add_post("/api/run", self._run)
        app.router.add_post("/api/stop", self._stop_run)
        app.router.add_get("/api/run", self._run_state)

    def _closing(self) -> None:
        self._work.shutdown(wait=False, cancel_futures=True)

    # ------------------------------------------------------------------ pages

    async def _index(self, request: web.Request) -> web.Response:
        view_port = self.view.port if self.view is not None else 0
        frames = " ".join(origins(self.host, view_port))  # the run's live view, and nothing else
        return nonced_page(static_text("editor.html"), f"{EDITOR_POLICY}; frame-src {frames}")

    async def _static(self, request: web.Request) -> web.Response:
        return page_file(request.match_info["name"], EDITOR_FILES)

    async def _vendor(self, request: web.Request) -> web.Response:
        return vendor_response(request.match_info["library"], request.match_info["name"])

    # ------------------------------------------------------------------ the API

    def _allowed(self, request: web.Request) -> bool:
        sent = request.headers.get("Authorization", "")
        given = sent.removeprefix("Bearer ").strip()  # "Bearer KEY", nothing else
        return sent.startswith("Bearer ") and bool(given) and hmac.compare_digest(given.encode(), self.key.encode())

    async def _body(self, request: web.Request, key: str) -> Any:
        """The JSON body's ``key``, or a refusal to raise."""
        if not self._allowed(request):
            raise web.HTTPUnauthorized(text="this editor's page has a key in its address: open the address printed")
        try:
            body = json.loads(await request.read())
        except (ValueError, RecursionError):
            body = None
        except web.HTTPRequestEntityTooLarge:
            raise web.HTTPRequestEntityTooLarge(MAX_EDIT_BYTES, request.content_length or 0) from None
        if not isinstance(body, dict) or key not in body:
            raise web.HTTPBadRequest(text=f'the body is JSON: {{"{key}": ...}}')
        return body[key]

    async def _off_loop(self, work: Any, *args: Any) -> Any:
        return await asyncio.get_running_loop().run_in_executor(self._work, functools.partial(work, *args))

    def _as_blocks(self, text: str, line: int | None = None) -> dict[str, Any]:
        """The text's blocks, or its problems; ``selected``: the block of the node on ``line`` (None: none)."""
        try:
            spec = validate_text(text, self.path.name, self.path.parent, check_world=False)
        except MissionInvalid as err:
            return {"ok": False, "problems": _problems(err.problems)}
        placed: dict[str, tuple[int, int]] = {}
        workspace = to_workspace(spec, text, placed)
        return {"ok": True, "workspace": workspace, "selected": None if line is None else block_at_line(placed, line)}

    def _as_text(self, workspace: Any, selected: str | None = None) -> dict[str, Any]:
        """The blocks' text, or their problems, each with the id of the block it is at (``block``).

        ``line``: where the ``selected`` block's node begins in the text (None: no such block).
        """
        lines: dict[str, int] = {}
        try:
            sent = workspace_json(workspace)
            text, _ = from_workspace(sent, "the blocks", base_dir=self.path.parent, lines=lines)
        except MissionInvalid as err:
            return {"ok": False, "problems": problems_at_blocks(sent, err.problems)}
        except (RecursionError, ValueError, TypeError):
            return {"ok": False, "problems": [{"line": 1, "column": 1, "path": "", "message": "not a workspace"}]}
        return {"ok": True, "text": text, "line": lines.get(selected) if selected else None}

    def _palette(self) -> dict[str, Any]:
        try:
            text = read_text(self.path)
            registry = validate_text(text, self.path.name, self.path.parent, check_world=False).registry
        except (UnreadableFile, MissionInvalid):
            registry = None
        from autonomy.mission import BUILTINS

        registry = registry or BUILTINS
        return {
            "blocks": block_definitions(registry, self._words),
            "toolbox": toolbox(registry),
            "schema": json_schema(registry),
        }

    async def _mission(self, request: web.Request) -> web.Response:
        if not self._allowed(request):
            raise web.HTTPUnauthorized(text="this editor's page has a key in its address: open the address printed")
        try:  # as every mission file is read: at most 500,000 bytes of UTF-8 text
            text = await self._off_loop(read_text, self.path) if self.path.exists() else ""
        except UnreadableFile as err:
            return web.json_response({"error": f"cannot read {self.path.name}: {err.reason}"}, status=422)
        shown = await self._off_loop(self._as_blocks, text) if text else {"ok": False, "problems": []}
        palette = await self._off_loop(self._palette)
        return web.json_response({"file": self.path.name, "text": text, "palette": palette, **shown})

    async def _blocks(self, request: web.Request) -> web.Response:
        text = await self._body(request, "text")
        if not isinstance(text, str):
            raise web.HTTPBadRequest(text='the body is JSON: {"text": "the mission\'s text"}')
        return web.json_response(await self._off_loop(self._as_blocks, text, query_line(request)))

    async def _text(self, request: web.Request) -> web.Response:
        workspace = await self._body(request, "workspace")
        return web.json_response(await self._off_loop(self._as_text, workspace, query_selected(request)))

    async def _save(self, request: web.Request) -> web.Response:
        text = await self._body(request, "text")
        if not isinstance(text, str):
            raise web.HTTPBadRequest(text='the body is JSON: {"text": "the mission\'s text"}')
        try:
            size = len(text.encode("utf-8"))
        except UnicodeEncodeError:
            raise web.HTTPBadRequest(
                text="the text holds a character that is not text (half of a surrogate pair)"
            ) from None
        if size > MAX_FILE_BYTES:
            raise web.HTTPBadRequest(text=f"a mission file is at most {MAX_FILE_BYTES:,} bytes; this text is {size:,}")
        try:
            await self._off_loop(self._write, text)
        except OSError as err:
            return web.json_response(
                {"ok": False, "error": f"cannot write {self.path.name}: {err.strerror}"}, status=500
            )
        checked = await self._off_loop(self._as_blocks, text)
        return web.json_response({"saved": self.path.name, "problems": checked.get("problems", [])})

    # ------------------------------------------------------------------ runs

    async def _run(self, request: web.Request) -> web.Response:
        text = await self._body(request, "text")
        if not isinstance(text, str):
            raise web.HTTPBadRequest(text='the body is JSON: {"text": "the mission\'s text"}')
        return web.json_response(await self._off_loop(self._start_run, text))

    def _start_run(self, text: str) -> dict[str, Any]:
        """Runs the text on the emulator, in real time, shown in the live view; or why not."""
        with self._run_lock:
            if self._runs_closed:
                return {"ok": False, "error": "the editor is stopping"}
            if self._running is not None and self._running[1].is_alive():
                return {"ok": False, "error": "a run is under way: stop it first"}
            try:  # checked as `autonomy run` checks it: its world too, its plugins from the file's folder
                spec = validate_text(text, self.path.name, self.path.parent)
            except MissionInvalid as err:
                theirs = [p for p in err.problems if p.file == self.path.name]
                if len(theirs) < len(err.problems):  # its world's (or another file's): said with their file
                    return {"ok": False, "error": "; ".join(str(p) for p in err.problems if p not in theirs)}
                return {"ok": False, "problems": _problems(err.problems)}
            world = spec.world or "box"
            try:
                client = Client.open(f"emu://?world={quote(world, safe='/')}", guardian=True)
            except AutonomyError as err:
                return {"ok": False, "error": str(err)}
            assert self.view is not None  # noqa: S101 - started with the editor
            try:  # a plugin's node is made here: whatever it raises (sys.exit too) is said, not a 500
                runner = Runner.for_mission(spec, client, max_seconds=MAX_RUN_S, listeners=[self.view.hub])
            except MissionInvalid as err:  # a node that cannot be made: said at its line
                client.close()
                return {"ok": False, "problems": _problems(err.problems)}
            except (Exception, SystemExit, KeyboardInterrupt) as err:  # noqa: BLE001 - said on the page
                client.close()
                return {"ok": False, "error": f"the mission's tree could not be made: {type(err).__name__}: {err}"}
            thread = threading.Thread(target=self._go, args=(runner, client), name="autonomy-edit-run", daemon=True)
            self._running = (runner, thread)
            self._last_run = {"running": True, "world": world}
            thread.start()
        return {"ok": True, "view": f"{self.view.url}", "view_port": self.view.port, "world": world, "max_s": MAX_RUN_S}

    def _go(self, runner: Runner, client: Client) -> None:
        """The run, on its thread; the robot is stopped at its end, however it ends."""
        try:
            summary = runner.run()
            self._last_run = {"running": False, "outcome": summary.outcome, "summary": summary.paragraph}
        except Exception as err:  # noqa: BLE001 - said on the page; the runner stopped the robot
            self._last_run = {"running": False, "outcome": "failed", "summary": f"the run failed: {err}"}
        finally:
            client.close()

    async def _stop_run(self, request: web.Request) -> web.Response:
        await self._body(request, "stop")
        running = self._running
        if running is not None and running[1].is_alive():
            running[0].request_stop("stopped from the editor")
        return web.json_response({"stopping": running is not None and running[1].is_alive()})

    async def _run_state(self, request: web.Request) -> web.Response:
        if not self._allowed(request):
            raise web.HTTPUnauthorized(text="this editor's page has a key in its address: open the address printed")
        return web.json_response(self._last_run or {"running": False})

    def _write(self, text: str) -> None:
        """Writes the file whole or not at all: a new file beside it, then put in its place.

        A link is followed (the file it names is written), and the file keeps who may read it.
        """
        target = self.path.resolve()
        made = target.with_name(f".{target.name}.{secrets.token_hex(4)}.saving")
        try:
            made.write_text(text, encoding="utf-8", errors="strict")
            if target.exists():
                os.chmod(made, stat.S_IMODE(target.stat().st_mode))
            os.replace(made, target)
        finally:
            made.unlink(missing_ok=True)

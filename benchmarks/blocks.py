"""How fast blocks show, and how fast a mission goes from blocks to text and back, in real Chromium on loopback.

Measures, each a median (and the slowest) over the rounds, in the page itself: from the click's own
time (the input event's) to the first frame after what it asked for is in the page, as a student
sees it (the test driver's own waits are no part of it):
  - the class's student page (``autonomy class serve garage``): from the click on "Blocks" to the
    mission's blocks drawn, the first time (Blockly loaded, the palette fetched) and again;
  - ``autonomy edit`` of a mission of 200 nodes: the text shown as blocks (the server's conversion,
    the answer, Blockly's drawing) after a value changed in the text (that field changed in place),
    after a node was added or taken away (that block made or disposed) and after a named step was
    added or taken away (that stack made or disposed), and the blocks written as text (Blockly's
    saving, the server's conversion and check, the answer);
  - the same two conversions in this process alone (``autonomy.mission.blocks``), without the page.

Targets (issue 39): the student's page with blocks shows in < 1 s; switching blocks <-> text on a
200-node mission < 200 ms.

Usage: python benchmarks/blocks.py [--rounds N]
"""

from __future__ import annotations

import argparse
import csv
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from playwright.sync_api import sync_playwright

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from autonomy.mission import validate_text  # noqa: E402
from autonomy.mission.blocks import from_workspace, to_workspace, workspace_json  # noqa: E402
from tests.conftest import CHROMIUM, CHROMIUM_ARGS  # noqa: E402
from tests.liveclass.test_class_cli import serve  # noqa: E402
from tests.views.conftest import until  # noqa: E402

#: A mission of 200 nodes: a sequence of 199 leaves of every kind a class uses.
LEAVES = [
    "move: {speed: 2, distance_mm: 300}",
    "turn: {left: 90}",
    "beep: {tones: [5, 7, 9], volume: 3}",
    "wait: {seconds: 1}",
    "move: {speed: 3, until_obstacle_mm: 150}",
]
BIG = "mission: big\ntree:\n  sequence:\n" + "".join(f"    - {LEAVES[i % len(LEAVES)]}\n" for i in range(199))


def watch(page, done: str) -> None:
    """Has the page note the time of its next click, and of the first frame after it where ``done`` (JS) holds."""
    page.evaluate(
        """() => {
          window.mark = {clicked: null, done: null};
          const look = () => {
            if (DONE) setTimeout(() => { mark.done = performance.now(); }); // once the frame is drawn
            else requestAnimationFrame(look);
          };
          document.addEventListener('click', (event) => {
            mark.clicked = event.timeStamp;
            requestAnimationFrame(look);
          }, {capture: true, once: true});
        }""".replace("DONE", done)
    )


def settle(page) -> None:
    """Waits until the page has drawn what it was last given (two frames)."""
    page.evaluate("() => new Promise((done) => requestAnimationFrame(() => requestAnimationFrame(done)))")


def took(page) -> float:
    """Seconds from the click :func:`watch` noted to the frame after what it waited for."""
    until(page, "window.mark.done !== null", 30_000)
    return page.evaluate("(mark.done - mark.clicked) / 1000")


def figures(values: list[float]) -> str:
    return f"median {statistics.median(values) * 1000:.0f} ms, slowest {max(values) * 1000:.0f} ms"


def student_page(browser, rounds: int) -> tuple[list[float], list[float]]:
    """The class page's Blocks, first and later: seconds from the click to the blocks drawn."""
    first, again = [], []
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        (folder / "roster.csv").write_text(
            "id,name,submission\n" + "".join(f"{n},Student {n},s{n}\n" for n in range(rounds))
        )
        process, port, _ = serve(folder)
        try:
            with (folder / "class" / "codes.csv").open() as stream:
                codes = [row["code"] for row in csv.DictReader(stream)]
            for code in codes:
                context = browser.new_context(viewport={"width": 1400, "height": 1000})
                page = context.new_page()
                page.on("pageerror", lambda error: print("the page:", error, file=sys.stderr))
                page.goto(f"http://127.0.0.1:{port}/")
                page.fill("#code", code)
                page.click("#sign-in-form button")
                until(page, "!document.getElementById('desk').hidden", 30_000)
                page.fill("#mission .cm-content", "mission: park\ntree:\n  move: {speed: 2, until_obstacle_mm: 150}\n")
                for times in (first, again):
                    shown = "document.getElementById('blocks').offsetParent !== null"
                    watch(page, f"{shown} && document.querySelectorAll('#blocks .blocklyDraggable').length >= 2")
                    page.click("#mode-blocks")
                    times.append(took(page))
                    page.click("#mode-text")
                    until(page, "!document.getElementById('text-panel').hidden", 30_000)
                context.close()
        finally:
            process.send_signal(signal.SIGINT)
            process.communicate(timeout=30)
    return first, again


def editor_switching(browser, rounds: int) -> tuple[list[float], list[float], list[float], list[float]]:
    """``autonomy edit`` of the 200-node mission: seconds for text -> blocks with a value changed, with a
    node more or less, with a named step more or less, and blocks -> text."""
    changed, node, whole, to_text = [], [], [], []
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "big.yaml"
        path.write_text(BIG)
        process = subprocess.Popen(
            [sys.executable, "-m", "autonomy", "edit", str(path), "--port", "0"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip
        try:
            url = process.stdout.readline().strip()
            page = browser.new_page(viewport={"width": 1400, "height": 1000})
            page.goto(url)
            page.wait_for_selector("body[data-ready=yes]", timeout=30_000)

            def switch(button: str, said: str, times: list[float]) -> None:
                settle(page)  # a student clicks after the change is on the screen, not within its frame
                watch(page, f"document.getElementById('status').textContent === '{said}'")
                page.get_by_role("button", name=button).click()
                times.append(took(page))
                page.evaluate("document.getElementById('status').textContent = ''")

            def to_blocks(times: list[float]) -> None:
                switch("Show the text as blocks", "The blocks are the text.", times)

            for round_ in range(rounds):
                # the text as a student changes it (set here without the editor's own conversion)
                page.evaluate(f"text.value = text.value.replace(/distance_mm: \\d+/, 'distance_mm: {301 + round_}')")
                to_blocks(changed)
                ending = "" if round_ % 2 else "    - stop\n"
                page.evaluate(f"text.value = text.value.replace(/(    - stop\\n)?$/, {ending!r})")
                to_blocks(node)
                named = "" if round_ % 2 else "subtrees:\n  idle: stop\n"
                page.evaluate(
                    f"text.value = text.value.replace(/(subtrees:\\n  idle: stop\\n)?tree:/, {named!r} + 'tree:')"
                )
                to_blocks(whole)
                switch("Write the blocks as text", "The text is the blocks.", to_text)
            page.close()
        finally:
            process.terminate()
            process.communicate(timeout=30)
    return changed, node, whole, to_text


def in_process(rounds: int) -> tuple[list[float], list[float]]:
    """The two conversions of the 200-node mission in this process: seconds each."""
    spec = validate_text(BIG, check_world=False)
    there, back = [], []
    for _ in range(rounds):
        started = time.perf_counter()
        workspace = workspace_json(to_workspace(validate_text(BIG, check_world=False), BIG))
        there.append(time.perf_counter() - started)
        started = time.perf_counter()
        from_workspace(workspace)
        back.append(time.perf_counter() - started)
    del spec
    return there, back


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=10)
    args = parser.parse_args()
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            first, again = student_page(browser, args.rounds)
            changed, node, whole, to_text = editor_switching(browser, args.rounds)
        finally:
            browser.close()
    there, back = in_process(args.rounds)
    print(f"student page, Blocks the first time (Blockly loaded): {figures(first)}  [target < 1,000 ms]")
    print(f"student page, Blocks again:                            {figures(again)}")
    print(f"200 nodes in the editor, text -> blocks, a value changed:      {figures(changed)}  [target < 200 ms]")
    print(f"200 nodes in the editor, text -> blocks, a node more or less:  {figures(node)}  [target < 200 ms]")
    print(f"200 nodes in the editor, text -> blocks, a named step more:    {figures(whole)}  [target < 200 ms]")
    print(f"200 nodes in the editor, blocks -> text:                       {figures(to_text)}  [target < 200 ms]")
    print(f"200 nodes in this process, text -> blocks:                     {figures(there)}")
    print(f"200 nodes in this process, blocks -> text:                     {figures(back)}")


if __name__ == "__main__":
    main()

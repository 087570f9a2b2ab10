"""The browser view as a person sees it, in a real headless Chromium: live, replayed, and saved."""

from __future__ import annotations

import itertools
import re
import signal
import socket
import subprocess
import sys
import time

import pytest

from autonomy.record import TreeState
from autonomy.trace import read_trace
from tests.views.conftest import ROOT, until

YELLOW, GREEN, RED, GREY = "rgb(255, 212, 59)", "rgb(140, 233, 154)", "rgb(255, 135, 135)", "rgb(241, 243, 245)"
FILL_OF = {"RUNNING": YELLOW, "SUCCESS": GREEN, "FAILURE": RED, "INVALID": GREY}
#: Puts the page in the background (True) or in view (False), as a browser does with its tabs.
HIDE = (
    "hidden => { Object.defineProperty(document, 'hidden', {get: () => hidden, configurable: true});"
    " document.dispatchEvent(new Event('visibilitychange')); }"
)


def fill(page, node_id: int) -> str:
    return page.eval_on_selector(f"#node-{node_id} rect", "el => getComputedStyle(el).fill")


#: What the page shows at one moment while a node runs, or null while it does not: its tree's fills,
#: the dead-reckoned path's points and the node's feedback, read in one evaluation.
SEEN_WHILE_RUNNING = """() => {
  const node = document.querySelector('#node-%d');
  if (node?.dataset.status !== 'RUNNING') return null;
  const fills = [0, 1, 2, 3].map(n => getComputedStyle(document.querySelector(`#node-${n} rect`)).fill);
  return {fills, points: document.querySelector('#path-dr').points.numberOfItems,
          feedback: node.querySelector('.feedback')?.textContent ?? ''};
}"""


def seen_while_running(page, node_id: int, timeout_s: float = 10.0) -> dict:
    """What the page shows at the first look that finds node ``node_id`` running."""
    deadline = time.monotonic() + timeout_s
    while (seen := page.evaluate(SEEN_WHILE_RUNNING % node_id)) is None:
        assert time.monotonic() < deadline, f"node {node_id} never seen running"
        page.wait_for_timeout(25)
    return seen


def path_points(page, which: str = "dr") -> int:
    return page.eval_on_selector(f"#path-{which}", "el => el.points.numberOfItems")


def record_trace(tmp_path, mission: str = "missions/wander.yaml") -> str:
    trace = tmp_path / "run.jsonl"
    result = subprocess.run(
        [sys.executable, "-m", "autonomy", "run", mission, "--fast", "--quiet", "--trace", str(trace)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=60,
    )
    assert result.returncode == 0, result.stderr
    return str(trace)


def test_a_live_run_colours_the_tree_and_draws_the_path(tmp_path, page, serve):
    mission = tmp_path / "drive.yaml"
    mission.write_text(
        "mission: drive\nworld: box\ntree:\n  sequence:\n"
        "    - move: {speed: 2, seconds: 3}\n    - turn: {left: 90}\n    - move: {speed: 2, seconds: 1}\n"
    )
    served = serve("run", str(mission), "--quiet", "--view")
    page.goto(served.url)
    # the page may open before the run's header: until then it has no tree
    # each look is one evaluation in the page: what it shows at one moment, however late a busy machine asks
    first = seen_while_running(page, 1)
    assert first["fills"][1:3] == [YELLOW, GREY]  # driving; the turn has not started
    turning = seen_while_running(page, 2)
    assert turning["fills"][1:3] == [GREEN, YELLOW]
    assert turning["points"] > first["points"] > 0  # the path grew
    assert turning["feedback"].endswith("deg to go")
    until(page, "document.querySelector('#state').textContent === 'succeeded'", timeout=10_000)
    assert [fill(page, n) for n in range(4)] == [GREEN] * 4
    assert path_points(page, "truth") == path_points(page)  # on the emulator, the truth is drawn too
    assert "It was stopped at the end." in page.text_content("#summary")
    assert page.eval_on_selector_all("#map .obstacle", "els => els.length") == 0
    assert page.eval_on_selector("#map .arena", "el => el.getAttribute('width')") == "2000"
    code, out, _ = served.interrupt()
    assert code == 0 and "succeeded" in out


@pytest.mark.parametrize("hidden", [False, True], ids=["in-view", "hidden-meanwhile"])
def test_a_page_left_on_a_finished_run_follows_the_next_run_on_the_same_port(tmp_path, page, serve, hidden):
    # As on a class's projector: the page stays open while one `autonomy run --view` ends and the next starts.
    # Or in a tab put in the background while no server answered, and shown again: it takes up its wait.
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    for name, leaf in (("first", "beep: {}"), ("second", "turn: {left: 90}")):
        (tmp_path / f"{name}.yaml").write_text(f"mission: {name}\nworld: box\ntree:\n  sequence:\n    - {leaf}\n")
    first = serve("run", str(tmp_path / "first.yaml"), "--fast", "--quiet", "--view", port=port)
    page.goto(first.url)
    until(page, "document.querySelector('#state').textContent === 'succeeded'", timeout=10_000)
    assert page.text_content("#mission") == "first"
    code, _, _ = first.interrupt()  # the first server is gone: the page keeps coming back for a run
    assert code == 0
    page.wait_for_timeout(1500)
    assert page.text_content("#mission") == "first"  # no server: the finished run stays on the page
    if hidden:
        page.evaluate(HIDE, True)
        page.wait_for_timeout(3500)  # longer than its next look for a server
        page.evaluate(HIDE, False)
    second = serve("run", str(tmp_path / "second.yaml"), "--fast", "--quiet", "--view", port=port)
    assert second.url == first.url
    until(page, "document.querySelector('#mission').textContent === 'second'", timeout=10_000)
    until(page, "document.querySelector('#state').textContent === 'succeeded'", timeout=10_000)
    assert page.eval_on_selector("#node-1", "el => el.dataset.status") == "SUCCESS"
    assert "turn left 90 deg" in page.text_content("#node-1")
    second.interrupt()


@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGKILL], ids=["ctrl-c", "kill"])
def test_a_page_on_a_run_stopped_midway_moves_to_the_next_run_without_mixing_them(tmp_path, page, serve, stop):
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    (tmp_path / "first.yaml").write_text("mission: first\nworld: box\ntree:\n  sequence:\n    - wait: {seconds: 30}\n")
    (tmp_path / "second.yaml").write_text(
        "mission: second\nworld: box\ntree:\n  sequence:\n    - wait: {seconds: 30}\n"
    )
    first = serve("run", str(tmp_path / "first.yaml"), "--quiet", "--view", port=port)  # in real time
    page.goto(first.url)
    until(page, "document.querySelector('#node-1')?.dataset.status === 'RUNNING'", timeout=10_000)
    until(page, "window.autonomyView.view.ticks.length > 20", timeout=10_000)
    first.process.send_signal(stop)
    first.process.communicate(timeout=20)
    if stop == signal.SIGINT:  # the run's end reaches the page before its server goes
        until(page, "document.querySelector('#state').textContent === 'interrupted'", timeout=10_000)
    else:  # nobody could tell the page: it still shows the run going
        assert page.text_content("#state") == "running"
    second = serve("run", str(tmp_path / "second.yaml"), "--quiet", "--view", port=port)  # in real time too
    until(page, "document.querySelector('#mission').textContent === 'second'", timeout=15_000)
    until(page, "window.autonomyView.view.ticks.length > 40", timeout=15_000)
    ticks = page.evaluate("window.autonomyView.view.ticks.map(t => t.tick)")
    assert ticks == list(range(1, len(ticks) + 1))  # the second run's ticks alone, from its first
    assert page.text_content("#state") == "running"
    second.interrupt()


def test_a_replay_slider_shows_the_tree_at_any_tick(tmp_path, page, serve):
    path = record_trace(tmp_path)
    trace = read_trace(path)
    served = serve("replay", path, "--view")
    page.goto(served.url)
    page.wait_for_selector("#controls:not([hidden])")
    assert page.text_content("#slider-label") == f"tick 1 / {len(trace.ticks)}"
    for index in (40, 333, len(trace.ticks) - 1, 7):
        page.locator("#slider").fill(str(index))
        state = TreeState(trace.header)
        for tick in trace.ticks[: index + 1]:
            state.apply(tick)
        seen = page.eval_on_selector_all(
            "#tree .node", "els => els.map(e => [+e.dataset.node, getComputedStyle(e.querySelector('rect')).fill])"
        )
        assert dict(seen) == {n: FILL_OF[s.status] for n, s in state.nodes.items()}
        assert page.text_content("#slider-label") == f"tick {index + 1} / {len(trace.ticks)}"
        assert path_points(page) == index + 1
        assert page.text_content("#clock") == f"{trace.ticks[index].time_s:.1f} s"
    page.evaluate(HIDE, True)  # a tab switch: a replay stays at the tick it shows
    page.evaluate(HIDE, False)
    page.wait_for_timeout(300)
    assert page.text_content("#slider-label") == f"tick 8 / {len(trace.ticks)}"
    page.select_option("#speed", "16")
    page.click("#play")
    until(page, "+document.querySelector('#slider').value > 60", timeout=10_000)
    assert page.text_content("#play") == "❚❚ pause"
    page.click("#play")
    assert served.interrupt()[0] == 0


def test_a_saved_page_works_offline_from_one_file(tmp_path, page):
    path = record_trace(tmp_path, "missions/square.yaml")
    html = tmp_path / "run.html"
    result = subprocess.run(
        [sys.executable, "-m", "autonomy", "plot", path, "-o", str(html)], capture_output=True, text=True, cwd=ROOT
    )
    assert result.returncode == 0, result.stderr
    requests: list[str] = []
    page.on("request", lambda request: requests.append(request.url))
    page.goto(html.as_uri())
    page.wait_for_selector("#controls:not([hidden])")
    assert [url for url in requests if not url.startswith(("file:", "data:"))] == []
    # it opens where the run ended, as a student hands it in: the outcome, the whole path
    assert page.text_content("#slider-label") == "tick 204 / 204" and page.text_content("#state") == "succeeded"
    assert path_points(page, "truth") > 100 and "Mission 'square' succeeded" in page.text_content("#summary")
    page.locator("#slider").fill("0")
    assert page.text_content("#state") == "replay"
    page.locator("#slider").fill("203")
    assert page.text_content("#state") == "succeeded" and fill(page, 0) == GREEN
    assert "Mission 'square' succeeded" in page.text_content("#summary")
    page.evaluate(HIDE, True)  # a tab switch: a saved page has no server to look for, and stays where it is
    page.evaluate(HIDE, False)
    page.wait_for_timeout(300)
    assert page.text_content("#slider-label") == "tick 204 / 204" and requests[-1].startswith("file:")
    # The last turn takes the heading from 355 to 0 degrees: the plot lifts its pen there, and
    # no stroke crosses it, while every other plot is one stroke.
    trace = read_trace(path)
    wraps = [
        i
        for i in range(1, len(trace.ticks))
        if trace.ticks[i - 1].status.heading_deg - trace.ticks[i].status.heading_deg > 180
    ]
    assert wraps == [203]
    strokes = page.eval_on_selector_all(
        "#plots .series", "els => els.map(e => e.getAttribute('d').split('M').length - 1)"
    )
    assert strokes == [1, 2, 1, 1, 1]
    page.locator("#slider").fill("202")
    assert (
        page.eval_on_selector("#plots svg[data-name=heading] .series", "e => e.getAttribute('d').split('M').length - 1")
        == 1
    )
    tallest = page.eval_on_selector(
        "#plots svg[data-name=heading] .series",
        "e => Math.max(...e.getAttribute('d').match(/[ML][^ML]+/g).map((s, n, all) => n && s[0] === 'L'"
        " ? Math.abs(+s.split(',')[1] - +all[n - 1].split(',')[1]) : 0))",
    )
    assert 0 < tallest < 22  # the turns draw slopes, none from one edge to the other (44 px tall)
    # a trace holds numbers in full; the page shows them to a tenth
    assert max(abs(t.speed_mm_s - round(t.speed_mm_s, 1)) for t in trace.ticks) > 0
    for name, unit in (("speed", "mm/s"), ("heading", "deg")):
        value, span = (page.text_content(f"#plots svg[data-name={name}] .{c}") for c in ("value", "range"))
        assert re.fullmatch(rf"-?\d+(\.\d)? {unit}", value), value
        assert re.fullmatch(rf"-?\d+(\.\d)? \.\. -?\d+(\.\d)? {unit}, 0 \.\. \d+\.\d s", span), span


def test_a_behaviortree_cpp_log_replays_in_the_page_with_its_tree_and_no_made_up_telemetry(tmp_path, page, serve):
    from autonomy.btlog import read_btlog
    from autonomy.mission import load_mission
    from tests.btcpp.reference import bt, factory, for_reference, leaf_names, wait_for_records

    spec = load_mission(ROOT / "missions" / "square.yaml")
    from autonomy.mission.btcpp import export_xml

    made = factory(spec)
    made.register_behavior_tree_from_text(for_reference(export_xml(spec), leaf_names(spec)))
    tree = made.create_tree(spec.name)
    log = tmp_path / "theirs.btlog"
    logger = bt.FileLogger(tree, str(log))
    for _ in range(3):
        tree.tick_once()
    wait_for_records(logger, log, 3)  # the repeat, the sequence and the move start
    del logger
    trace = read_btlog(log)
    served = serve("replay", str(log), "--view")
    page.goto(served.url)
    page.wait_for_selector("#controls:not([hidden])")
    assert page.eval_on_selector_all("#tree .node", "els => els.length") == len(trace.header.nodes) == 7
    assert "a BehaviorTree.CPP log: node statuses only, no telemetry" in page.text_content("#where")
    assert not page.is_visible("#map-panel") and not page.is_visible("#plots-panel")  # nothing made up
    state = TreeState(trace.header)
    index = 0
    for index, tick in enumerate(trace.ticks):  # noqa: B007 - the first tick at which something runs
        state.apply(tick)
        if "RUNNING" in [s.status for s in state.nodes.values()]:
            break
    page.locator("#slider").fill(str(index))
    seen = page.eval_on_selector_all(
        "#tree .node", "els => els.map(e => [+e.dataset.node, getComputedStyle(e.querySelector('rect')).fill])"
    )
    assert dict(seen) == {n: FILL_OF[s.status] for n, s in state.nodes.items()}
    assert YELLOW in dict(seen).values()  # the move runs: BehaviorTree.CPP's statuses are shown as they were
    assert served.interrupt()[0] == 0


def test_the_heading_plot_lifts_its_pen_wherever_the_heading_wrapped_between_two_drawn_points(tmp_path, page):
    # 8,000 ticks turning 10 degrees a tick: the plot draws about 400 of them, each 20 ticks (200
    # degrees) after the last, so the values of two drawn points alone cannot tell a wrap from a turn.
    import dataclasses

    import msgspec

    from autonomy.record import to_line

    recorded = read_trace(record_trace(tmp_path, "missions/square.yaml"))
    first = recorded.ticks[0]
    ticks = [
        msgspec.structs.replace(
            first,
            tick=n + 1,
            time_s=n * 0.05,
            status=dataclasses.replace(first.status, heading_deg=n * 10 % 360),
            nodes={},
            wire=[],
        )
        for n in range(8000)
    ]
    trace = tmp_path / "turning.jsonl"
    trace.write_text("".join(to_line(r) + "\n" for r in [recorded.header, *ticks, recorded.end]))
    html = tmp_path / "turning.html"
    result = subprocess.run(
        [sys.executable, "-m", "autonomy", "plot", str(trace), "-o", str(html)],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr
    page.goto(html.as_uri())
    page.wait_for_selector("#controls:not([hidden])")
    page.locator("#slider").fill("7999")
    d = page.eval_on_selector("#plots svg[data-name=heading] .series", "e => e.getAttribute('d')")
    drawn = [int(k) for k in page.evaluate("sampled(7999, MAX_PLOT_POINTS)")]
    headings = [t.status.heading_deg for t in ticks]
    wrapped = [any(headings[i] < headings[i - 1] for i in range(a + 1, b + 1)) for a, b in itertools.pairwise(drawn)]
    assert len(drawn) > 300 and 0 < sum(wrapped) < len(wrapped)
    assert [step[0] for step in d.split()] == ["M"] + ["M" if w else "L" for w in wrapped]


def test_a_wide_tree_stays_readable_and_the_panel_follows_the_step_that_runs(tmp_path, page, serve):
    """Forty steps of a sequence (in rows, some 800 px wide and 7 rows high) and a long mission name, on a projector."""
    name = "a mission whose name goes on and on " * 4
    mission = tmp_path / "waits.yaml"
    mission.write_text(f"mission: {name.strip()}\ntree:\n  sequence:\n" + "    - wait: {seconds: 0.25}\n" * 40)
    path = record_trace(tmp_path, str(mission))
    trace = read_trace(path)
    served = serve("replay", path, "--view")
    page.goto(served.url)
    page.wait_for_selector("#controls:not([hidden])")
    natural, shown = page.eval_on_selector(
        "#tree svg", "s => [+s.getAttribute('width'), s.getBoundingClientRect().width]"
    )
    assert natural < 1500 and shown >= 0.69 * natural  # in rows (once 5,000 px across), its words read
    for step in (3, 27, 40):  # the first, a middle and the last wait: each in view when it runs
        index = next(
            i for i, t in enumerate(trace.ticks) if t.nodes.get(step, None) and t.nodes[step].status == "RUNNING"
        )
        page.locator("#slider").fill(str(index))
        assert fill(page, step) == YELLOW
        inside = page.eval_on_selector(
            f"#node-{step}",
            "g => { const r = g.getBoundingClientRect(), b = document.querySelector('#tree').getBoundingClientRect();"
            " return r.left >= b.left && r.right <= b.right && r.top >= b.top && r.bottom <= b.bottom; }",
        )
        assert inside, step
    badge = page.eval_on_selector("#state", "el => el.getBoundingClientRect().right")
    assert (
        badge <= 1400 and page.evaluate("document.documentElement.scrollWidth") <= 1400
    )  # the name is cut, not the page
    assert served.interrupt()[0] == 0


def test_a_hidden_tab_lets_go_of_its_stream_and_takes_the_run_up_again_when_shown(tmp_path, page, serve):
    """A browser keeps six connections to a server: tabs in the background must not hold them all."""
    mission = tmp_path / "waits.yaml"
    # the second wait outlasts the hidden 2 s by 4 s: a busy machine's page has that long to take the run up again
    mission.write_text("mission: waits\ntree:\n  sequence:\n    - wait: {seconds: 1.5}\n    - wait: {seconds: 4.5}\n")
    served = serve("run", str(mission), "--quiet", "--view")
    page.goto(served.url)
    until(page, "document.querySelector('#node-1')?.dataset.status === 'RUNNING'", timeout=10_000)
    assert page.evaluate("window.autonomyView.streaming()")
    page.evaluate(HIDE, True)
    assert not page.evaluate("window.autonomyView.streaming()")
    page.wait_for_timeout(2_000)  # the second wait has started meanwhile; a hidden tab is not told
    assert fill(page, 2) == GREY
    page.evaluate(HIDE, False)
    until(page, "document.querySelector('#node-2')?.dataset.status === 'RUNNING'", timeout=10_000)
    assert page.evaluate("window.autonomyView.streaming()")
    until(page, "document.querySelector('#state').textContent === 'succeeded'", timeout=10_000)
    assert served.interrupt()[0] == 0


def test_eight_pages_in_view_all_load_and_follow_one_run(tmp_path, browser, serve):
    """A browser keeps six HTTP connections to a server: the pages' streams are WebSockets, which it does not count."""
    mission = tmp_path / "waits.yaml"
    mission.write_text("mission: waits\ntree:\n  sequence:\n    - wait: {seconds: 2}\n    - wait: {seconds: 1}\n")
    served = serve("run", str(mission), "--quiet", "--view")
    context = browser.new_context()
    try:
        pages = [context.new_page() for _ in range(8)]
        for page in pages:
            page.goto(served.url, timeout=10_000)
        for page in pages:
            until(page, "document.querySelector('#state').textContent === 'succeeded'", timeout=15_000)
            assert page.eval_on_selector("#node-2", "el => el.dataset.status") == "SUCCESS"
    finally:
        context.close()
    assert served.interrupt()[0] == 0


def test_a_saved_page_shows_texts_that_look_like_html_as_text(tmp_path, page):
    # "<!--<script" in the data would keep the page's data block from ending: nothing would be drawn
    import msgspec

    from autonomy.record import Event, NodeState, to_line

    recorded = read_trace(record_trace(tmp_path, "missions/square.yaml"))
    odd = "<!--<script> a </script> b \u2028 c <b>bold</b> \u202eXYZ\x07"
    ticks = list(recorded.ticks)
    ticks[3] = msgspec.structs.replace(ticks[3], events=[Event("log", odd)], nodes={1: NodeState("RUNNING", odd)})
    trace = tmp_path / "odd.jsonl"
    trace.write_text("".join(to_line(r) + "\n" for r in [recorded.header, *ticks, recorded.end]), encoding="utf-8")
    html = tmp_path / "odd.html"
    plot = [sys.executable, "-m", "autonomy", "plot", str(trace), "-o", str(html)]
    result = subprocess.run(plot, capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    assert "<!--" not in html.read_text(encoding="utf-8").split('id="run-data"')[1].split("</script>")[0]
    page.goto(html.as_uri())
    page.wait_for_selector("#controls:not([hidden])")
    page.locator("#slider").fill("5")
    assert page.text_content("#slider-label") == f"tick 6 / {len(ticks)}"  # the slider counts from 0
    logged = page.eval_on_selector_all("#log li", "els => els.map(e => e.textContent)")
    # as text, its line separator, right-to-left override and bell shown as \ufffd (as every view shows them)
    shown = "<!--<script> a </script> b \ufffd c <b>bold</b> \ufffdXYZ\ufffd"
    assert any(line.endswith(f"log: {shown}") for line in logged), logged
    assert page.eval_on_selector_all("#log li b", "els => els.length") == 0  # text, not markup


def test_a_picture_sent_to_the_page_is_drawn_without_anything_that_could_run(tmp_path, page):
    html = tmp_path / "run.html"
    made = subprocess.run(
        [sys.executable, "-m", "autonomy", "plot", record_trace(tmp_path, "missions/square.yaml"), "-o", str(html)],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert made.returncode == 0, made.stderr
    page.goto(html.as_uri())
    page.wait_for_selector("#controls:not([hidden])")
    hostile = (
        '<svg xmlns="http://www.w3.org/2000/svg"><script>document.title="owned"</script>'
        '<rect width="5" onload="document.title=1" style="x"/><a href="javascript:1"><text>t</text></a>'
        '<foreignObject><div xmlns="http://www.w3.org/1999/xhtml">x</div></foreignObject><g id="paths"/></svg>'
    )
    kept = page.evaluate("m => autonomyView.safeSvg(m).map(n => n.outerHTML).join('')", hostile)
    assert "<rect" in kept and 'width="5"' in kept and 'id="paths"' in kept
    for gone in ("script", "onload", "style=", "href", "foreignObject", "<a", "div"):
        assert gone not in kept, gone
    assert page.evaluate("autonomyView.safeSvg('<p>not a picture</p>').length") == 0
    assert page.title() != "owned"


def test_bidi_controls_in_a_crafted_mission_name_never_reach_the_page_s_title(tmp_path, page):
    """A right-to-left override in the title would show the tab's text reversed, and hide what follows it."""
    import dataclasses

    from autonomy.record import to_line

    recorded = read_trace(record_trace(tmp_path, "missions/square.yaml"))
    header = dataclasses.replace(recorded.header, mission="\u202etxt.exe\u2066 \x1b[31m")
    trace = tmp_path / "bidi.jsonl"
    trace.write_text("".join(to_line(r) + "\n" for r in [header, *recorded.ticks, recorded.end]), encoding="utf-8")
    html = tmp_path / "bidi.html"
    plot = [sys.executable, "-m", "autonomy", "plot", str(trace), "-o", str(html)]
    result = subprocess.run(plot, capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    page.goto(html.as_uri())
    page.wait_for_selector("#controls:not([hidden])")
    assert page.title() == "autonomy: \ufffdtxt.exe\ufffd \ufffd[31m"
    assert page.text_content("#mission") == "\ufffdtxt.exe\ufffd \ufffd[31m"

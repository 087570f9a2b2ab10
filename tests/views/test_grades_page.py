"""The grading report as a teacher sees it: one page in a real browser, nothing fetched."""

from __future__ import annotations

import re

from playwright.sync_api import expect

from autonomy.classroom import find_submissions, grade_class, load_exercise
from autonomy.classroom.exercise import seed_points
from autonomy.classroom.report import to_html
from tests.views.conftest import ROOT


def test_the_class_page_shows_the_table_and_every_path_on_its_map(page, tmp_path):
    exercise = load_exercise(ROOT / "exercises" / "bump.yaml")
    files = [ROOT / "exercises" / "solutions" / "bump.yaml", ROOT / "exercises" / "wrong" / "bump_no_return.yaml"]
    reports = grade_class(exercise, find_submissions(files), workers=2)
    path = tmp_path / "marks.html"
    path.write_text(to_html(exercise, reports))
    fetched: list[str] = []
    page.on("request", lambda request: fetched.append(request.url))
    page.goto(path.as_uri())
    assert fetched == [path.as_uri()]  # the page is whole in one file
    rows = page.locator("table.marks tr").all_inner_texts()
    assert rows[1].split("\t")[:2] == ["bump", "10"] and rows[2].split("\t")[:2] == ["bump_no_return", "3"]
    cells = page.locator("table.marks tr").nth(2).locator("td")
    assert cells.nth(2).get_attribute("class") == "full"  # it bumped
    assert cells.nth(3).get_attribute("class") == "none"  # never at rest in the goal
    maps = page.locator(".seed svg")
    assert maps.count() == 8
    # each path lies on its map, and the wrong solution's ends north of the goal, where it stopped
    for index in range(8):
        box = maps.nth(index).bounding_box()
        line = maps.nth(index).locator("polyline.path").bounding_box()
        assert line["width"] > 0.3 * box["width"]
        assert box["x"] <= line["x"] and line["x"] + line["width"] <= box["x"] + box["width"] + 1
    goal = maps.nth(4).locator('.zone[data-zone="goal"] rect').bounding_box()
    last = page.evaluate(
        "(() => { const l = document.querySelectorAll('.seed svg polyline.path')[4];"
        " const p = l.points[l.points.numberOfItems - 1]; const m = l.getScreenCTM();"
        " return [p.x * m.a + p.y * m.c + m.e, p.x * m.b + p.y * m.d + m.f]; })()"
    )
    assert last[1] < goal["y"]  # above the goal on the screen: y grows downward
    assert page.locator(".seed li.no").first.inner_text().startswith("✗ goal: came to rest")
    # the bump, and the four turns round the box, are drawn where they happened, each saying what it was
    first = maps.nth(0)
    assert first.locator(".collision").count() == 1 and first.locator(".turn").count() == 4
    assert first.locator(".collision title").text_content().startswith("collision at ")
    assert first.locator(".turn title").first.text_content().startswith("turned left 90 deg at ")
    bump = first.locator(".collision").bounding_box()
    box_drawn = first.locator("rect.obstacle").first.bounding_box()
    assert abs((bump["x"] + bump["width"] / 2) - box_drawn["x"]) < 0.1 * first.bounding_box()["width"]
    # its captions are read at a glance: 11 px of the picture's own, drawn at 10 px or more
    shown = first.evaluate("s => s.getBoundingClientRect().width / s.viewBox.baseVal.width")
    assert 11 * shown >= 10
    page.screenshot(path=str(tmp_path / "marks.png"), full_page=True)


def test_the_class_table_sorts_by_a_column_and_tells_a_file_not_graded_from_a_zero(page, tmp_path):
    exercise = load_exercise(ROOT / "exercises" / "square.yaml")
    broken = tmp_path / "broken.yaml"
    broken.write_text("mission: broken\ntree:\n  mvoe: {}\n")
    files = [
        ROOT / "exercises" / "solutions" / "square.yaml",
        ROOT / "exercises" / "wrong" / "square_turns_85.yaml",
        ROOT / "exercises" / "wrong" / "square_beeps_at_home.yaml",
        broken,
    ]
    reports = grade_class(exercise, find_submissions(files), workers=2)
    path = tmp_path / "marks.html"
    path.write_text(to_html(exercise, reports))
    fetched: list[str] = []
    page.on("request", lambda request: fetched.append(request.url))
    page.goto(path.as_uri())
    assert fetched == [path.as_uri()]

    def column(k):
        return [row.split("\t")[k] for row in page.locator("table.marks tbody tr").all_inner_texts()]

    assert column(0) == ["broken", "square", "square_beeps_at_home", "square_turns_85"]  # as graded: by name
    assert column(1) == ["not graded", "10", "0", "6.5"]  # a file that did not run is not a graded zero
    assert "unknown node 'mvoe'" in page.locator("td.notgraded").first.get_attribute("title")
    page.locator("th button", has_text="total").click()
    assert column(0) == ["broken", "square_beeps_at_home", "square_turns_85", "square"]  # lowest first
    assert page.locator("table.marks th").nth(1).get_attribute("aria-sort") == "ascending"
    page.locator("th button", has_text="total").click()
    assert column(1) == ["10", "6.5", "0", "not graded"]
    page.locator("th button", has_text="student").click()
    assert column(0)[0] == "broken"
    # the reference and the 85-degree square differ only in a number: a hint for the teacher
    assert page.locator("ul.similar li").all_inner_texts() == [
        "square and square_turns_85: the same tree but for numbers and names"
    ]


def test_a_student_s_feedback_page_shows_their_file_their_runs_at_their_end_and_plays(page, tmp_path):
    import os
    import subprocess
    import sys

    (tmp_path / "class").mkdir()
    for student, source in (("alice", "solutions/garage.yaml"), ("zed", "wrong/garage_until_bump.yaml")):
        (tmp_path / "class" / f"{student}.yaml").write_text((ROOT / "exercises" / source).read_text())
    (tmp_path / "class" / "oops.yaml").write_text("mission: oops\ntree:\n  mvoe: {speed: 2}\n")
    result = subprocess.run(
        [sys.executable, "-m", "autonomy", "grade", str(ROOT / "exercises" / "garage.yaml"), "class/alice.yaml",
         "class/zed.yaml", "class/oops.yaml", "--feedback", "pages", "--traces", "runs", "--html", "class.html"],
        capture_output=True, text=True, timeout=120, cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT)},
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "wrote 3 feedback pages in pages" in result.stdout
    assert sorted(p.name for p in (tmp_path / "pages").iterdir()) == ["alice.html", "oops.html", "zed.html"]
    assert sorted(p.name for p in (tmp_path / "runs" / "zed").iterdir()) == [
        "seed-52.jsonl", "seed-56.jsonl", "seed-8.jsonl", "seed-80.jsonl"
    ]  # fmt: skip
    replayed = subprocess.run(  # a kept trace plays back
        [sys.executable, "-m", "autonomy", "replay", "runs/zed/seed-8.jsonl", "--lines", "--speed", "1000"],
        capture_output=True, text=True, timeout=60, cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT)},
    )  # fmt: skip
    assert replayed.returncode == 0, replayed.stderr
    class_page = (tmp_path / "class.html").read_text()
    assert 'href="pages/zed.html"' in class_page and "alice" in (tmp_path / "pages" / "alice.html").read_text()
    assert "zed" not in (tmp_path / "pages" / "alice.html").read_text()  # a page tells one student only of themself

    fetched: list[str] = []
    page.on("request", lambda request: fetched.append(request.url))
    zed = (tmp_path / "pages" / "zed.html").as_uri()
    page.goto(zed)
    assert page.locator("pre.source span.line").count() == 11
    assert page.locator("pre.source span.line").nth(10).inner_text().strip().endswith("- move: {speed: 2}")
    frames = [frame for frame in page.frames if frame != page.main_frame]
    assert len(frames) == 4  # a replay of each seed's run
    for frame in frames:  # each opens on its last tick: where the run ended
        # waited for by the page's text: the page's policy lets no test code be evaluated in it as a string
        expect(frame.locator("#state")).to_have_text("succeeded")
        label = frame.locator("#slider-label").inner_text()
        ticks = label.split(" / ")
        assert ticks[0] == f"tick {ticks[1]}" and frame.locator("#state").inner_text() == "succeeded"
        assert frame.locator("#tree .node").count() >= 3  # the tree, coloured by the nodes' last states
    first = frames[0]
    first.evaluate("window.autonomyView.show(0)")
    first.locator("#play").click()
    expect(first.locator("#slider-label")).to_have_text(re.compile(r"tick ([6-9]|\d\d+) / "))  # it plays
    assert fetched == [zed]  # nothing fetched but the page itself
    # the same mission as its blocks: closed, and open at once on the page opened at #as-blocks
    assert page.locator("#as-blocks").get_attribute("open") is None
    page.goto("about:blank")
    page.goto(zed + "#as-blocks")
    expect(page.locator("#as-blocks[open] svg")).to_be_visible()
    assert "the robot has bumped into something" in page.locator("#as-blocks svg").text_content()
    oops = (tmp_path / "pages" / "oops.html").as_uri()
    page.goto(oops)
    marked = page.locator("pre.source span.problem")
    assert marked.count() == 1 and marked.get_attribute("data-line") == "3"
    assert "unknown node 'mvoe' (did you mean 'move'?)" in marked.inner_text()
    assert page.locator("#as-blocks").count() == 0  # a file with problems is no blocks


def test_a_feedback_replay_marks_each_beep_and_turn_as_it_reaches_it(page, tmp_path):
    from autonomy.classroom.job import grade_one
    from autonomy.classroom.report import write_feedback_page

    exercise = load_exercise(ROOT / "exercises" / "square.yaml")
    runs: list = []
    report = grade_one(exercise, "sam", ROOT / "exercises" / "solutions" / "square.yaml", runs=runs)
    first = report.seeds[0]
    assert len(first.beeps) == 4 and len(first.turns) >= 3
    page.goto(write_feedback_page(exercise, report, tmp_path, runs, "sam").as_uri())
    frame = [f for f in page.frames if f != page.main_frame][0]
    expect(frame.locator("#state")).to_have_text("succeeded")  # at the end: every mark
    assert frame.locator("#judged .beep").count() == 4 and frame.locator("#judged .turn").count() == len(first.turns)
    assert "beep" in frame.locator("#map-panel .legend").inner_text()
    frame.locator("#slider").fill("0")  # at the start: none yet
    expect(frame.locator("#state")).to_have_text("replay")
    assert frame.locator("#judged .beep").count() == 0 and frame.locator("#judged .turn").count() == 0


def test_the_class_page_opens_with_the_class_at_a_glance_each_map_a_link_to_the_student_s_page(page, tmp_path):
    from tests.axe import violations

    exercise = load_exercise(ROOT / "exercises" / "garage.yaml")
    names = ["solutions/garage.yaml", "wrong/garage_full_speed.yaml", "wrong/garage_stops_short.yaml"]
    reports = grade_class(exercise, find_submissions([ROOT / "exercises" / n for n in names]), workers=2)
    for report in reports:
        (tmp_path / f"{report.student}.html").write_text(f"<!doctype html><title>{report.student}</title><h1>x</h1>")
    pages = {r.student: f"{r.student}.html" for r in reports[:2]}  # the third has no page: its section instead
    path = tmp_path / "marks.html"
    path.write_text(to_html(exercise, reports, pages))
    page.goto(path.as_uri())
    glance = page.locator("section.overview")
    assert glance.locator("h2").text_content() == "The class at a glance"
    assert glance.locator(".says").text_content().startswith("3 students graded of 3; median ")
    bars = glance.locator("svg.spread rect.bin")
    assert bars.count() == 10 and "3 from" not in glance.locator("svg.spread").get_attribute("aria-label")
    # each bar between two marks: 0 to 10 at the bars' edges
    assert glance.locator("svg.spread text.edge").all_text_contents() == [str(k) for k in range(11)]
    heights = [bars.nth(k).bounding_box()["height"] for k in range(10)]
    totals = sorted(int(min(9, r.total)) for r in reports)
    assert all((heights[k] > 5) == (k in totals) for k in range(10))  # a bar stands where a mark is
    shares = glance.locator("table.shares tbody tr")
    assert shares.count() == len(exercise.criteria)
    assert shares.first.locator("th").text_content().startswith("Parked in the garage")
    assert shares.first.locator("td").first.text_content() == f"{exercise.criteria[0].points:g}"
    assert glance.locator("table.nodes tbody tr th").first.text_content() == "move"
    # every point lost is in a row, and the foot says so
    lost = sum(10 - r.total for r in reports)
    told = glance.locator("table.nodes tfoot").text_content()
    assert re.fullmatch(r"These rows hold ([\d.]+) of the \1 points lost across the class \(100%\)\.", told), told
    assert abs(float(told.split()[3]) - lost) < 0.02
    maps = glance.locator("li.map")
    assert maps.count() == 3 and maps.locator("svg.little").count() == 3
    worst = [min(range(len(r.seeds)), key=lambda k: seed_points(exercise, r.seeds[k])) for r in reports]
    least = [seed_points(exercise, r.seeds[k]) for r, k in zip(reports, worst, strict=True)]
    classes = [f"map {'full' if p >= 10 else 'none' if p <= 0 else 'part'}" for p in least]  # that seed's outcome
    assert [maps.nth(k).get_attribute("class") for k in range(3)] == classes and classes[0] == "map full"
    # the outcome in a sign and in words, not by colour alone; the words read out, not shown
    seed = reports[0].seeds[worst[0]].seed.split(" (")[0]
    assert maps.nth(0).locator(".mark").text_content() == f"✓ 10 / 10 full marks on {seed}"
    assert maps.nth(2).locator(".map-seed").text_content() == f"their mark {reports[2].total:g} / 10"
    assert maps.nth(0).locator(".mark .unseen").bounding_box()["width"] <= 1
    assert page.get_by_role("link", name="garage_stops_short ✓", exact=False).count() == 0
    assert page.get_by_role("link", name="part of the marks", exact=False).count() == 1
    links = [maps.nth(k).locator("a").get_attribute("href") for k in range(3)]  # each at the seed it shows
    assert links == [f"garage.html#seed-{worst[0] + 1}", f"garage_full_speed.html#seed-{worst[1] + 1}",
                     f"#s-2-seed-{worst[2] + 1}"]  # fmt: skip
    maps.nth(2).locator("a").click()  # in this page: that seed's part of it, in view
    shown = page.locator(f"#s-2-seed-{worst[2] + 1}")
    assert shown.locator("h3").text_content().startswith(f"{reports[2].seeds[worst[2]].seed}: ")
    expect(shown).to_be_in_viewport()
    page.goto(path.as_uri())
    # the full-speed robot's crash is drawn at the end wall of the seed it did worst on
    crash = maps.nth(1).locator("path.collision").bounding_box()
    wall = maps.nth(1).locator("rect.obstacle").bounding_box()
    assert abs(crash["x"] + crash["width"] / 2 - wall["x"]) < 0.06 * maps.nth(1).bounding_box()["width"]
    assert violations(page) == []
    maps.nth(1).locator("a").focus()  # from the keyboard: its page opens
    page.keyboard.press("Enter")
    page.wait_for_url(f"**/garage_full_speed.html#seed-{worst[1] + 1}")


def test_the_class_at_a_glance_holds_long_names_and_problems_and_tells_an_empty_class(page, tmp_path):
    from tests.axe import violations

    exercise = load_exercise(ROOT / "exercises" / "square.yaml")
    long = "S" * 180  # one word, as long as a file's name may be
    (tmp_path / f"{long}.yaml").write_text((ROOT / "exercises" / "solutions" / "square.yaml").read_text())
    (tmp_path / "typo.yaml").write_text(f"mission: typo\ntree:\n  {'x' * 70}: {{}}\n")
    reports = grade_class(exercise, find_submissions(sorted(tmp_path.glob("*.yaml"))), workers=2)
    path = tmp_path / "marks.html"
    path.write_text(to_html(exercise, reports))
    page.set_viewport_size({"width": 1024, "height": 800})
    page.goto(path.as_uri())
    assert page.evaluate("document.documentElement.scrollWidth") <= 1024  # nothing runs off the page's side
    glance = page.locator("section.overview")
    maps = page.locator("li.map")
    named, typo = maps.nth(0), maps.nth(1)
    assert named.locator(".who").text_content() == long and named.locator(".who").get_attribute("title") == long
    assert named.bounding_box()["height"] < 2 * typo.bounding_box()["height"] + 200  # the name cut to two lines
    for card in (named, typo):  # every line of a card inside it
        box = card.bounding_box()
        for k in range(card.locator("span").count()):
            line = card.locator("span").nth(k).bounding_box()
            if line and line["width"] > 1:
                assert line["x"] + line["width"] <= box["x"] + box["width"] + 1
    assert named.locator("circle.beep").count() == 4  # a beep at each corner, where it sounded
    turns = [c.label for c in exercise.criteria].index("turns 90") + 2  # a hint: no points, told how often it held
    assert exercise.criteria[turns - 2].points == 0
    hint = page.locator("table.marks tbody tr").first.locator("td").nth(turns)
    seeds = len(exercise.seeds)  # the solution turns left at each corner on every seed
    assert (hint.get_attribute("class"), hint.text_content()) == ("hint", f"held on {seeds} of {seeds}")
    assert glance.locator("table.shares tr.hint td").first.text_content() == "none (a hint)"
    assert typo.locator(".map-seed").text_content().startswith("typo.yaml:3:3: ")  # the file, not its folder
    assert violations(page) == []
    # a class with nothing graded says so rather than drawing empty bars
    path.write_text(to_html(exercise, [r for r in reports if r.problems]))
    page.goto(path.as_uri())
    assert glance.locator("figure.spread .none-yet").text_content().startswith("Nothing graded yet")
    assert glance.locator("svg.spread").count() == 0
    assert glance.locator("table.nodes tfoot").text_content() == "Nothing graded yet."
    assert violations(page) == []

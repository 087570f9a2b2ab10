"""The grading report as a teacher sees it: one page in a real browser, nothing fetched."""

from __future__ import annotations

from autonomy.classroom import find_submissions, grade_class, load_exercise
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
    rows = page.locator("table tr").all_inner_texts()
    assert rows[1].split("\t")[:2] == ["bump", "10"] and rows[2].split("\t")[:2] == ["bump_no_return", "3"]
    cells = page.locator("table tr").nth(2).locator("td")
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
    goal = maps.nth(4).locator(".zone rect").bounding_box()
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
    assert page.locator("th").nth(1).get_attribute("aria-sort") == "ascending"
    page.locator("th button", has_text="total").click()
    assert column(1) == ["10", "6.5", "0", "not graded"]
    page.locator("th button", has_text="student").click()
    assert column(0)[0] == "broken"
    # the reference and the 85-degree square differ only in a number: a hint for the teacher
    assert page.locator("ul.similar li").all_inner_texts() == [
        "square and square_turns_85: the same tree but for numbers and names"
    ]

"""``autonomy test --html``: each mission's tree, its nodes filled by coverage, as a person sees it in a browser."""

from __future__ import annotations

import shutil
import subprocess
import sys

from tests.axe import violations
from tests.views.conftest import ROOT


def test_the_coverage_page_fills_each_node_by_what_its_runs_saw_and_says_it_in_words_too(page, tmp_path):
    for name in ("patrol.yaml", "patrol.test.yaml", "beep_on_collision.yaml"):
        shutil.copy(ROOT / "missions" / name, tmp_path / name)
    shipped = (ROOT / "missions" / "beep_on_collision.test.yaml").read_text()  # its wide floor alone: no bump
    (tmp_path / "beep_on_collision.test.yaml").write_text(
        "scenarios:\n" + shipped[shipped.index("  - name: on a wide") :].split("\n  - name:")[0] + "\n"
    )
    html = tmp_path / "coverage.html"
    done = subprocess.run(
        [sys.executable, "-m", "autonomy", "test", str(tmp_path), "--html", str(html)],
        capture_output=True, text=True, timeout=120, cwd=ROOT,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    fetched: list[str] = []
    page.on("request", lambda request: fetched.append(request.url))
    page.goto(html.as_uri())
    assert fetched == [html.as_uri()]  # nothing else: the page is whole in one file

    # each node's box is filled as the table under its tree says of it, in words
    fills = {"full": "rgb(200, 230, 201)", "part": "rgb(255, 224, 178)", "none": "rgb(255, 205, 210)"}
    kinds = []
    for mission in (1, 2):
        rows = page.locator(f"table#m{mission} tr").all_inner_texts()[1:]
        for number, row in enumerate(rows):
            _, _, seen, never = row.split("\t")
            kinds.append("none" if seen == "nothing" else "full" if never == "-" else "part")
            box = page.locator(f"g#m{mission}-node-{number} rect")
            assert box.evaluate("r => getComputedStyle(r).fill") == fills[kinds[-1]], row
    # on the wide floor the bumper never bumped: its recovery never ran; the patrol's condition answered both ways
    assert set(kinds) == {"full", "part", "none"} and len(kinds) == 7 + 13
    rows = page.locator("table#m1 tr").all_inner_texts()
    assert "repeat x3/selector/bumped\tsequence\tnothing\tSUCCESS, FAILURE, RUNNING" in rows
    assert page.locator("h2").all_inner_texts() == ["beep_on_collision.yaml", "patrol.yaml"]
    assert violations(page) == []

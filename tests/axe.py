"""axe-core (tests/vendor/axe-core, pinned by package-lock.json) run in a page: what WCAG 2.2 AA finds wrong there."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

AXE = Path(__file__).resolve().parent / "vendor" / "axe-core"
#: The rules checked: WCAG 2.0, 2.1 and 2.2, levels A and AA.
WCAG_AA = ["wcag2a", "wcag2aa", "wcag21a", "wcag21aa", "wcag22a", "wcag22aa"]


def axe_source() -> str:
    """axe-core's script, checked against the sha256 its VENDOR.json records."""
    record = json.loads((AXE / "VENDOR.json").read_text())
    source = (AXE / "axe.min.js").read_bytes()
    assert hashlib.sha256(source).hexdigest() == record["files"]["axe.min.js"], "axe.min.js is not the one recorded"
    return source.decode("utf-8")


def violations(page: Any, tags: list[str] | None = None) -> list[dict[str, Any]]:
    """What axe finds in ``page`` as it is now: each rule broken, its impact, and where (at most five places).

    The script is given to the page by the browser's own debugging channel, which the page's policy does
    not govern: nothing is loaded from elsewhere, and the page itself runs no inline script.
    """
    page.evaluate(axe_source())
    return page.evaluate(
        """(tags) => axe.run(document, {runOnly: {type: 'tag', values: tags}, resultTypes: ['violations']})
            .then((found) => found.violations.map((rule) => ({
                id: rule.id, impact: rule.impact, help: rule.help,
                nodes: rule.nodes.slice(0, 5).map((node) => node.target.join(' ') + ': ' + node.failureSummary),
            })))""",
        tags or WCAG_AA,
    )

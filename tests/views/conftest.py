"""A real headless Chromium (Debian's package) driven by playwright, and `autonomy` serving pages."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def page(browser):
    context = browser.new_context(viewport={"width": 1400, "height": 1000})
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda error: errors.append(str(error)))
    yield page
    context.close()
    assert errors == [], errors


def until(page, expression: str, timeout: float = 10_000) -> None:
    """Waits until ``expression`` holds in ``page``, asking it from outside the page.

    Playwright's own ``wait_for_function`` evaluates a string inside the page, which the page's
    content security policy forbids (no ``eval``), as it should.
    """
    deadline = time.monotonic() + timeout / 1000
    while not page.evaluate(expression):
        if time.monotonic() > deadline:
            raise AssertionError(f"still not so after {timeout / 1000:g} s: {expression}")
        page.wait_for_timeout(25)


class Served:
    """An `autonomy` process that serves a page; its URL is read from what it prints."""

    def __init__(self, *args: str, port: int = 0) -> None:
        self.process = subprocess.Popen(
            [sys.executable, "-m", "autonomy", *args, "--view-port", str(port)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            cwd=ROOT,
        )
        self.url = ""
        for _ in range(20):
            line = self.process.stderr.readline()
            match = re.match(r"view: (http://\S+)", line)
            if match:
                self.url = match.group(1)
                break
        assert self.url, "no view URL was printed"

    def interrupt(self) -> tuple[int, str, str]:
        self.process.send_signal(signal.SIGINT)
        out, err = self.process.communicate(timeout=20)
        return self.process.returncode, out, err


@pytest.fixture
def serve() -> Iterator:
    started: list[Served] = []

    def start(*args: str, port: int = 0) -> Served:
        served = Served(*args, port=port)
        started.append(served)
        return served

    yield start
    for served in started:
        if served.process.poll() is None:
            served.process.kill()
            served.process.communicate()


@pytest.fixture
def editing(tmp_path):
    """``autonomy edit`` on a copy of the square, as a process; (its page's address, the file)."""
    opened = []

    def edit(text: str, name: str = "mission.yaml") -> tuple[str, Path]:
        path = tmp_path / name
        path.write_text(text)
        process = subprocess.Popen(
            [sys.executable, "-m", "autonomy", "edit", str(path), "--port", "0"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path,
        )  # fmt: skip
        opened.append(process)
        url = process.stdout.readline().strip()
        assert url.startswith("http://127.0.0.1:") and "#" in url, process.stderr.read()
        return url, path

    yield edit
    for process in opened:
        process.terminate()
        _, err = process.communicate(timeout=30)
        assert "Traceback" not in err, err

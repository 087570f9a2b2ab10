"""What every test process needs, whoever started it; and the one headless Chromium its page tests share."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

# A process started in the background by a shell without job control ignores Ctrl-C, and passes
# that on to every program it starts: the tests that stop a run or a server with SIGINT would
# then wait for it in vain. Ctrl-C is given back its usual meaning, here and so in the children.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


CHROMIUM = os.environ.get("AUTONOMY_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


@pytest.fixture(scope="session")
def browser():
    """A real headless Chromium (Debian's package) driven by playwright: one per test process."""
    from playwright.sync_api import sync_playwright

    assert Path(CHROMIUM).exists(), f"{CHROMIUM} is missing: `make test` installs it (apt-get install chromium)"
    with sync_playwright() as playwright:
        chromium = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        yield chromium
        chromium.close()

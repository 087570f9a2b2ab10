"""What the class's tests share: the class served as a teacher starts it."""

from __future__ import annotations

import csv
import signal

import pytest

from tests.liveclass.test_class_cli import serve


@pytest.fixture
def classroom(tmp_path):
    """``autonomy class serve garage`` for Ada and Bob: (student's URL, teacher's URL, codes)."""
    (tmp_path / "roster.csv").write_text("id,name,submission\n1001,Ada Lovelace,ada\n1002,Bob <b>Jones</b>,bob\n")
    process, port, token = serve(tmp_path)
    with (tmp_path / "class" / "codes.csv").open() as stream:
        codes = {row["id"]: row["code"] for row in csv.DictReader(stream)}
    yield f"http://127.0.0.1:{port}/", f"http://127.0.0.1:{port}/teacher#{token}", codes
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=30)
    assert process.returncode == 0 and "Traceback" not in err, err

"""The teacher's secret: a small file that draws an exercise's hidden seeds (HMAC-SHA-256), unknown to others."""

from __future__ import annotations

import hashlib
import hmac
from pathlib import Path

from autonomy.errors import AutonomyError

#: How long a teacher's secret may be, bytes (the file's, spaces and line ends around it aside), and how short.
SECRET_MOST_BYTES, SECRET_LEAST_BYTES = 4096, 16


class SecretError(AutonomyError):
    """A secret file that cannot be used: the message says why, in one line."""


def read_secret(path: str | Path) -> bytes:
    """The teacher's secret, from a small regular file (never a pipe or a device that does not end).

    Raises:
        SecretError: no such file, not a regular file, unreadable, or too short or too long.
    """
    given = Path(path)
    try:
        if not given.exists():
            raise SecretError(f"cannot read the secret file {path}: no such file")
        if not given.is_file():
            raise SecretError(f"the secret file {path} is not a file: give a small text file")
        with given.open("rb") as stream:
            secret = stream.read(SECRET_MOST_BYTES + 1).strip()
    except OSError as err:
        raise SecretError(f"cannot read the secret file {path}: {err.strerror or err}") from None
    if len(secret) > SECRET_MOST_BYTES:
        raise SecretError(f"the secret file {path} is over {SECRET_MOST_BYTES} bytes: give a short secret")
    if len(secret) < SECRET_LEAST_BYTES:
        raise SecretError(
            f"the secret file {path} holds {len(secret)} bytes: give it at least {SECRET_LEAST_BYTES} that nobody "
            "can guess, e.g. python3 -c 'import secrets; print(secrets.token_hex(16))' > secret.txt"
        )
    return secret


def hidden_seed(secret: bytes, exercise: str, index: int) -> int:
    """The ``index``-th hidden seed of ``exercise`` under ``secret`` (HMAC-SHA-256), 0..2**31-1."""
    digest = hmac.new(secret, f"{exercise}\n{index}".encode(), hashlib.sha256).digest()
    return int.from_bytes(digest[:4], "big") & 0x7FFFFFFF

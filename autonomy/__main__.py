"""``python -m autonomy``: the same as the ``autonomy`` command."""

from autonomy.cli import run

run()

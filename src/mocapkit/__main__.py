"""``python -m mocapkit``: the ``mocapkit`` command."""

from .cli import run

run()

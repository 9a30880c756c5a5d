"""``python -m mocapkit.cli``: the ``mocapkit`` command."""

from . import run

run()

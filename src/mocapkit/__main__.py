"""``python -m mocapkit``: the ``mocapkit`` command."""

import sys

from .cli import main

sys.exit(main())

"""``python -m mocapkit.cli``: the ``mocapkit`` command."""

import sys

from . import main

sys.exit(main())

"""``python -m sogdd``: the ``sogdd`` command."""

import sys

from .cli.main import main

sys.exit(main())

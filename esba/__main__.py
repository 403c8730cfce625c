"""``python -m esba``: the command line (the same as the ``esba`` script)."""

import sys

from .cli import main

sys.exit(main())

"""``python -m esba.cli``: the ``esba`` command."""

import sys

from . import main

sys.exit(main())

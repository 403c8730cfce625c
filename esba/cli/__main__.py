"""``python -m esba.cli``: the ``esba`` command."""

import sys

from esba.cli import main

sys.exit(main())

"""How ``esba`` commands end: exit codes, a table or JSON on stdout, validity warnings on stderr."""

from __future__ import annotations

import argparse
import sys
from typing import Callable

from esba.infra import jsonsafe

#: Exit codes: done; a solve failed or a result is not ok; bad input; interrupted (Ctrl-C).
EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2
EXIT_INTERRUPTED = 130


def print_result(args: argparse.Namespace, data: dict, table: Callable[[dict], str]) -> None:
    """``data`` as JSON (no NaN: :mod:`esba.infra.jsonsafe`) with ``--json``, else as ``table(data)``."""
    if getattr(args, "json", False):
        print(jsonsafe.dumps(data, indent=2, sort_keys=True))
    else:
        print(table(data))


def warn_findings(findings) -> None:
    """The validity findings of a result, one ``esba: warning:`` line each on stderr."""
    for f in findings:
        print(f"esba: warning: {f.message if hasattr(f, 'message') else f['message']}", file=sys.stderr)

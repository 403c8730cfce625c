"""The ``esba`` command line.

Every command prints a readable table, or JSON with ``--json`` (valid JSON: no NaN or Infinity,
see :mod:`esba.infra.jsonsafe`). Bad input (a flag, a scene file, an output path that cannot be
written, an unusable model cache) ends with one line ``esba: error: ...`` naming the value and
what is allowed, and exit code 2, before any long computation; a solve that fails or lands on an
unstable equilibrium says so and exits 1; a result outside the range the paper's model describes
is printed with ``esba: warning: ...`` lines (and a ``validity`` list in JSON). Where each
command writes is decided by :mod:`esba.infra.outputs`. A failure found while a command runs, not in
its input (a study whose Dask scheduler was lost, a full disk), ends with one line
``esba: error: ...`` and exit code 1; Ctrl-C ends with ``esba: interrupted`` and exit code 130.

One module per command group (:mod:`esba.cli.scenes`, :mod:`esba.cli.sweep`, ...), each adding its
subcommands to the parser; :mod:`esba.cli.arguments` and :mod:`esba.cli.results` hold what they
share. Building the parser imports no numerics: each command imports what it computes with. The
top floor of the house: it may import every package of esba.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from typing import Callable, Sequence

from esba.derive.effects import EffectError
from esba import __version__
from esba.infra import console
from esba.infra.errors import EsbaError
from esba.infra.interrupts import caused_by_interrupt

from .arguments import Parser, UsageError
from .bench import add_bench
from .cache import add_cache
from .contact import add_blocked, add_grasp
from .design import add_design
from .docs import add_docs
from .equilibria import add_equilibria
from .estimate import add_estimate
from .examples import add_example
from .export import add_export
from .figures import add_figures
from .fit import add_experiments, add_fit
from .map import add_map
from .models import add_audit, add_generate
from .path import add_path
from .results import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_OK, EXIT_USAGE
from .scenes import add_pressure, add_solve, add_stiffness, add_validate
from .section import add_section
from .sweep import add_sweep

__all__ = ["main", "build_parser", "COMMANDS", "EXIT_OK", "EXIT_FAILED", "EXIT_USAGE", "EXIT_INTERRUPTED"]

#: Functions that add one subcommand each, in the order ``esba --help`` lists them.
COMMANDS: list[Callable] = [add_generate, add_audit, add_solve, add_equilibria, add_path, add_blocked, add_grasp, add_stiffness, add_pressure, add_validate, add_sweep, add_bench, add_figures, add_design, add_fit, add_experiments, add_estimate, add_map, add_section, add_export, add_docs, add_example, add_cache]


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="esba", description="Models of eccentric soft bending actuators (Yang et al.).")
    parser.add_argument("--version", action="version", version=f"esba {__version__}")
    sub = parser.add_subparsers(dest="command", parser_class=Parser)
    for add in COMMANDS:
        add(sub)
    return parser


#: The longest error line printed: the messages cap what they quote (esba.infra.checks.quote);
#: this is the last guard, for a message that quotes something unforeseen.
MAX_LINE = 500


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    line = text[0] if text else type(exc).__name__
    return line if len(line) <= MAX_LINE else line[:MAX_LINE] + f"... ({len(line)} characters)"


def _run(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if not getattr(args, "func", None):
            raise UsageError("name a command: " + ", ".join(sorted(parser._subparsers._group_actions[0].choices)))  # type: ignore[union-attr]
        return int(args.func(args))
    except Exception as exc:
        # esba's own errors, by class (esba.infra.errors): bad input exits 2, a failure while running 1
        if isinstance(exc, (EsbaError, EffectError)):
            code = exc.exit_code if isinstance(exc, EsbaError) else EXIT_USAGE
            label = exc.label if isinstance(exc, EsbaError) else "error"
            print(f"esba: {label}: {_first_line(exc)}", file=sys.stderr)
            return code
        if isinstance(exc, (BrokenPipeError, MemoryError)) or os.environ.get("ESBA_DEBUG"):
            raise
        if caused_by_interrupt(exc):  # Ctrl-C that surfaced inside CasADi as a SystemError
            raise KeyboardInterrupt from None
        if isinstance(exc, OSError) and exc.errno is not None:  # an output that could not be written (a full disk, ...)
            where = f"{exc.filename}: " if exc.filename else ""
            print(f"esba: error: {where}{exc.strerror or exc}", file=sys.stderr)
            return EXIT_FAILED
        print(
            f"esba: internal error: {type(exc).__name__}: {_first_line(exc)} (a bug: please report the command; "
            "ESBA_DEBUG=1 shows the traceback)",
            file=sys.stderr,
        )
        return EXIT_FAILED


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit code.

    Called without ``argv`` (as the ``esba`` program), a Ctrl-C after the command returned, while
    Python still runs (threads joined, exit handlers), ends at once with ``esba: interrupted`` and
    exit code 130; in the interpreter's last teardown, where Python would die by the signal with
    no word, it is ignored: the output is complete and the command's exit code stands.
    """
    console.show_library_messages()
    try:
        with warnings.catch_warnings():
            # NumPy's floating-point RuntimeWarnings are no message for the user: a result that is
            # not finite is reported by the command itself (jsonsafe, validity, status); ESBA_DEBUG=1 shows them
            if not os.environ.get("ESBA_DEBUG"):
                warnings.simplefilter("ignore", RuntimeWarning)
            code = console.run(lambda: _run(argv))
    except KeyboardInterrupt:
        print("esba: interrupted", file=sys.stderr)
        code = EXIT_INTERRUPTED
    except MemoryError:
        print("esba: out of memory: ask for a smaller run", file=sys.stderr)
        code = EXIT_FAILED
    if argv is None:
        console.exit_on_late_interrupt(EXIT_INTERRUPTED, announce=code != EXIT_INTERRUPTED)
    return code

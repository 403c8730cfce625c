"""The ``esba`` command line.

Every command prints a readable table, or JSON with ``--json``. Bad input (a flag, a scene file)
ends with one line ``esba: error: ...`` naming the value and what is allowed, and exit code 2;
a solve that fails or lands on an unstable equilibrium says so and exits 1.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Callable, Sequence

from derive.effects import DEFAULT_EFFECTS, DEFAULT_VARIANT, VARIANTS, EffectError, EffectSet, check_segments

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2


class UsageError(ValueError):
    """Bad input from the command line: reported in one line with exit code 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse prints usage too)
        raise UsageError(message)


def _segments(text: str) -> int:
    try:
        return check_segments(text)
    except EffectError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _emit(args: argparse.Namespace, data: dict, table: Callable[[dict], str]) -> None:
    if getattr(args, "json", False):
        print(json.dumps(data, indent=2, sort_keys=True))
    else:
        print(table(data))


# ---------------------------------------------------------------------------------------------
# esba generate


def _cmd_generate(args: argparse.Namespace) -> int:
    from derive import emit  # SymPy: only for this command

    if args.refresh:
        rows = []

        def progress(path):
            rows.append(path.name)

        emit.refresh(args.out, progress=progress)
        _emit(args, {"refreshed": rows}, lambda d: "\n".join(f"wrote {r}" for r in d["refreshed"]))
        return EXIT_OK
    if args.segments is None:
        raise UsageError("generate needs --segments N (a whole number >= 1) or --refresh")
    try:
        effects = EffectSet.parse(args.effects)
    except EffectError as exc:
        raise UsageError(f"--effects: {exc}") from None
    t0 = time.perf_counter()
    path, entry = emit.write_model(args.segments, effects, args.variant, args.out)
    data = {
        "file": str(path),
        "segments": args.segments,
        "effects": effects.spec(),
        "variant": args.variant,
        "instructions": entry["instructions"],
        "generate_time_s": time.perf_counter() - t0,
    }
    _emit(args, data, lambda d: "\n".join(f"{k:>16}: {v}" for k, v in d.items()))
    return EXIT_OK


def _add_generate(sub) -> None:
    p = sub.add_parser("generate", help="derive and emit a CasADi model into generated/")
    p.add_argument("--segments", "-n", type=_segments, help="segment count n >= 1")
    p.add_argument("--effects", default=DEFAULT_EFFECTS, help=f"comma-separated effects (default {DEFAULT_EFFECTS}); payload:K for K payloads")
    p.add_argument("--variant", choices=VARIANTS, default=DEFAULT_VARIANT)
    p.add_argument("--out", default=None, help="folder (default: the generated/ package)")
    p.add_argument("--refresh", action="store_true", help="regenerate every committed model")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_generate)


# ---------------------------------------------------------------------------------------------
# esba audit


def _cmd_audit(args: argparse.Namespace) -> int:
    from derive import audit  # SymPy: only for this command

    if args.check:
        stale = audit.check_page(args.out)
        if stale:
            print(f"esba: {args.out or audit.DOC_PATH} is stale: run `esba audit` and commit it", file=sys.stderr)
            return EXIT_FAILED
        print("derivations page is up to date")
        return EXIT_OK
    path, verdicts = audit.write_page(args.out)
    data = {"page": str(path), "verdicts": {k: v.verdict for k, v in verdicts.items()}}
    _emit(args, data, lambda d: "\n".join([f"wrote {d['page']}"] + [f"  {k:<26} {v}" for k, v in d["verdicts"].items()]))
    return EXIT_OK


def _add_audit(sub) -> None:
    p = sub.add_parser("audit", help="check the paper's printed equations against the derivation; write docs/derivations.md")
    p.add_argument("--check", action="store_true", help="exit 1 when the committed page is stale")
    p.add_argument("--out", default=None, help="page to write (default docs/derivations.md)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_audit)


# ---------------------------------------------------------------------------------------------

#: Functions that add one subcommand each, in the order ``esba --help`` lists them.
COMMANDS: list[Callable] = [_add_generate, _add_audit]


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="esba", description="Models of eccentric soft bending actuators (Yang et al.).")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser)
    for add in COMMANDS:
        add(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit code."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if not getattr(args, "func", None):
            raise UsageError("name a command: " + ", ".join(sorted(parser._subparsers._group_actions[0].choices)))  # type: ignore[union-attr]
        return int(args.func(args))
    except (UsageError, EffectError) as exc:
        print(f"esba: error: {exc}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

"""``esba example``: copy the example files that ship with esba into the current folder."""

from __future__ import annotations

import argparse

from .arguments import UsageError
from .results import EXIT_OK, print_result


def _cmd_example(args: argparse.Namespace) -> int:
    from esba.infra.examples import ExampleError, copy_examples, example_names

    names = example_names()
    if not args.names and not args.all:
        print_result(args, {"examples": names}, lambda d: "\n".join(["examples (esba example NAME copies one into ./examples/; --all copies every one):", *(f"  {n}" for n in d["examples"])]))
        return EXIT_OK
    if args.all and args.names:
        raise UsageError("give example names or --all, not both")
    try:
        done = copy_examples(names if args.all else args.names, args.out)
    except ExampleError as exc:
        raise UsageError(str(exc)) from None
    data = {"files": [{"path": str(p), "action": a} for p, a in done]}
    print_result(args, data, lambda d: "\n".join(f"{f['action']} {f['path']}" for f in d["files"]))
    return EXIT_OK


def add_example(sub) -> None:
    p = sub.add_parser("example", help="copy an example scene or measurement file (those the README uses) into ./examples/")
    p.add_argument("names", nargs="*", metavar="NAME", help="an example (table2, table2.toml, measurements/paper_exp.csv, ...); none: list them")
    p.add_argument("--all", action="store_true", help="copy every example")
    p.add_argument("--out", default="examples", metavar="DIR", help="folder to copy into (default ./examples, created if missing)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_example)

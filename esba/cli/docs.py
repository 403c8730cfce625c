"""``esba docs``: every docs page, checked against a fresh computation or written again.

The pages are those of :mod:`esba.pages.registry`; each is also written by its own command
(``esba audit``, ``esba validate``, ``esba design --write-doc``, ...), which calls the same page.
Building this parser reads the registry only (no NumPy, no CasADi).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from esba.infra import outputs
from esba.pages.registry import ENTRIES, check_names

from .arguments import UsageError
from .results import EXIT_FAILED, EXIT_OK, print_result

_FAST = [e.name for e in ENTRIES.values() if not e.slow]
_SLOW = [e.name for e in ENTRIES.values() if e.slow]


def _folder(args: argparse.Namespace):
    if args.dir is None:
        return outputs.docs_dir(create=args.write is not None)
    if args.write is not None:
        return outputs.check_folder(args.dir, "--dir", create=False)
    folder = Path(args.dir)
    if not folder.is_dir():
        raise UsageError(f"--dir {args.dir!r}: not a folder (the folder of the pages to check)")
    return folder


def _progress(args: argparse.Namespace, name: str):
    def say(what) -> None:
        if not args.json:
            print(f"  {name}: {what}", file=sys.stderr)

    return say


def _list(args: argparse.Namespace) -> int:
    rows = [{"page": e.name, "file": e.file, "command": e.command, "slow": e.slow, "about": e.about} for e in ENTRIES.values()]

    def table(d: dict) -> str:
        width = max(len(r["page"]) for r in d["pages"])
        lines = [f"{r['page']:<{width}}  {r['file']:<20} {r['about']}" + ("  [benchmark: minutes]" if r["slow"] else "") for r in d["pages"]]
        lines.append("esba docs --check [NAME ...] compares them with a fresh computation; esba docs --write [NAME ...] writes them")
        return "\n".join(lines)

    print_result(args, {"pages": rows}, table)
    return EXIT_OK


def _cmd_docs(args: argparse.Namespace) -> int:
    if args.check is None and args.write is None:
        return _list(args)
    names = check_names(args.check if args.check is not None else args.write)
    folder = _folder(args)
    from esba.pages.registry import page

    if args.write is not None:
        written = []
        for name in names:
            p = page(name)
            t0 = time.perf_counter()
            w = p.write(folder / p.file, progress=_progress(args, name))
            written.append({"page": name, "path": str(w.path), "figures": [str(f) for f in w.figures], "seconds": time.perf_counter() - t0})
            if not args.json:  # each page as soon as it is written
                print("\n".join(f"wrote {f}" for f in (w.path, *w.figures)), flush=True)
        if args.json:
            print_result(args, {"written": written}, lambda d: "")
        return EXIT_OK
    checks = []
    width = max(len(name) for name in names)

    def line(c: dict) -> str:
        return f"{c['page']:<{width}}  {c['status']:<10}  {c['path']}" + (f": {c['detail']}" if c["detail"] else "")

    for name in names:
        p = page(name)
        t0 = time.perf_counter()
        c = dict(p.check(folder / p.file, progress=_progress(args, name)).to_dict(), seconds=time.perf_counter() - t0)
        checks.append(c)
        if not args.json:  # each page as soon as it is checked: a benchmark's check takes minutes
            print(line(c), flush=True)
    bad = [c for c in checks if c["status"] != "up to date"]
    if args.json:
        print_result(args, {"checks": checks, "ok": not bad}, lambda d: "")
    if bad:
        named = "; ".join(f"{c['page']} is {c['status']}" for c in bad)
        print(f"esba: {named}: run `esba docs --write {' '.join(c['page'] for c in bad)}` and commit the pages", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def add_docs(sub) -> None:
    p = sub.add_parser(
        "docs",
        help="check the docs pages against a fresh computation (times aside), or write them again",
        description=(
            "Every docs page, by name: " + ", ".join(_FAST) + " (seconds each); and the benchmarks "
            + ", ".join(_SLOW) + " (minutes each: their check reruns the benchmark once). Without --check or --write, list them."
        ),
    )
    what = p.add_mutually_exclusive_group()
    what.add_argument(
        "--check", nargs="*", metavar="NAME",
        help="compare each page (default: every page, the slow benchmarks too) with a fresh computation, times aside; exit 1 "
        "naming the pages that are stale or missing. Slow: " + ", ".join(_SLOW),
    )
    what.add_argument("--write", nargs="*", metavar="NAME", help="compute and write each page (default: every page) with its figures")
    p.add_argument("--dir", metavar="DIR", help="the folder of the pages (default: docs/ in a checkout, else the current folder)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_docs)

"""``esba cache``: where the model cache is, what it holds by kind, and clearing or pruning it."""

from __future__ import annotations

import argparse

from .arguments import UsageError
from .results import EXIT_OK, print_result


def _size(n: int | None) -> str:
    if n is None:
        return "none"
    for unit, scale in (("GB", 1 << 30), ("MB", 1 << 20), ("kB", 1 << 10)):
        if n >= scale:
            return f"{n / scale:.1f} {unit}"
    return f"{n} B"


def _table(d: dict) -> str:
    lines = [f"cache folder: {d['folder']}", f"bound: {_size(d['limit_bytes'])} (ESBA_CACHE_MAX; least recently used files go first)"]
    for kind, k in d["kinds"].items():
        if k["files"] or kind != "other":
            lines.append(f"  {kind:<10} {k['files']:>5} files  {_size(k['bytes']):>9}  {k['about']}")
    lines.append(f"  {'total':<10} {d['files']:>5} files  {_size(d['bytes']):>9}")
    if d.get("removed") is not None:
        lines.append(f"removed {d['removed']['files']} files, {_size(d['removed']['bytes'])}")
    return "\n".join(lines)


def _cmd_cache(args: argparse.Namespace) -> int:
    from esba.infra import cache

    if args.action != "prune" and args.to is not None:
        raise UsageError(f"--to {args.to!r}: goes with `esba cache prune` only")
    bound = cache.limit()  # a bad ESBA_CACHE_MAX is said here, in one line
    folder = cache.root()
    if folder.exists() and not folder.is_dir():
        raise cache.CacheError(f"ESBA_CACHE_DIR={str(folder)!r}: a file, expected a folder (point ESBA_CACHE_DIR at a writable folder)")
    removed = None
    if args.action == "clear":
        removed = cache.clear()
    elif args.action == "prune":
        target = cache.parse_size(args.to, "--to") if args.to is not None else bound
        if target is None:
            raise UsageError("esba cache prune: give --to SIZE (ESBA_CACHE_MAX is 0: no bound to prune to)")
        removed = cache.prune(target)
    data = cache.usage()
    if removed is not None:
        data["removed"] = {"files": len(removed), "bytes": sum(f.bytes for f in removed)}
    print_result(args, data, _table)
    return EXIT_OK


def add_cache(sub) -> None:
    p = sub.add_parser(
        "cache",
        help="the model cache: where it is and its size by kind; clear it, or prune it to a size",
        description=(
            "Models generated on demand, built CasADi Functions and compiled kernels are kept in $ESBA_CACHE_DIR, else "
            "$XDG_CACHE_HOME/esba, else ~/.cache/esba, within $ESBA_CACHE_MAX (default 1G; 0: no bound). Everything in it "
            "is made again when needed: removing it costs only time."
        ),
    )
    p.add_argument("action", nargs="?", choices=("clear", "prune"), help="clear: remove everything; prune: remove the least recently used files down to --to SIZE (default: the bound)")
    p.add_argument("--to", metavar="SIZE", help="with prune: the size to keep at most (e.g. 200M, 1G)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_cache)

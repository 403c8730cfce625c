"""``esba figures``: the paper-style figures into docs/figures/."""

from __future__ import annotations

import argparse

from esba.infra import outputs

from .arguments import UsageError
from .results import EXIT_OK, print_result


def _cmd_figures(args: argparse.Namespace) -> int:
    from pathlib import Path

    from esba.figures import paper as figures

    try:
        names = figures.check_names(args.only)
    except figures.FigureError as exc:
        raise UsageError(f"--only: {exc}") from None
    out = outputs.check_folder(outputs.figures_dir(create=True) if args.out is None else args.out, "--out")
    written = figures.write_all(out, names)
    data = {"out": str(Path(out).resolve()), "figures": {name: str(path.resolve()) for name, path in written.items()}}
    print_result(args, data, lambda d: "\n".join(f"wrote {path}" for path in d["figures"].values()))
    return EXIT_OK


def add_figures(sub) -> None:
    p = sub.add_parser("figures", help="regenerate the paper-style figures (Figs. 7b, 8c, 10, 11, 13a, 13b, 14) as PNG files (about 5 s)")
    p.add_argument("--out", metavar="DIR", default=None, help="folder to write (default docs/figures/ in a checkout, else ./figures/)")
    p.add_argument("--only", metavar="NAME", nargs="+", action="extend", default=None, help="write only these figures (e.g. fig7b fig11)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_figures)

"""``esba export c``: a model as dependency-free C for a controller (header, source, Makefile,
README and demo; :mod:`esba.export`)."""

from __future__ import annotations

import argparse

from esba.derive.effects import DEFAULT_EFFECTS, DEFAULT_VARIANT, VARIANTS, EffectError, EffectSet
from .arguments import Parser, UsageError, segments_arg
from .results import EXIT_OK, print_result


def _table(d: dict) -> str:
    rows = [
        ("model", f"n = {d['segments']}, effects {d['effects']}, variant {d['variant']}, {d['precision']} precision"),
        ("wrote", f"{d['folder']}: " + ", ".join(d["files"])),
        ("build", f"cd {d['folder']} && make   (make check: every warning an error; make cortex-m4)"),
        ("example", f"echo '{d['example']['input']}' | ./demo"),
        ("prints", d["example"]["output"]),
    ]
    return "\n".join(f"{k:>8}: {v}" for k, v in rows)


def _cmd_export_c(args: argparse.Namespace) -> int:
    try:
        effects = EffectSet.parse(args.effects if args.effects is not None else DEFAULT_EFFECTS)
    except EffectError as exc:
        raise UsageError(f"--effects: {exc}") from None
    from esba.export.ccode import ExportSpec
    from esba.export.writer import default_command, export_c

    spec = ExportSpec(args.segments, effects, args.variant or DEFAULT_VARIANT, "float" if args.float else "double")
    # the folder and the files in it are checked before anything is generated; a folder created for
    # an export that then fails (an unusable model cache) is removed again
    export = export_c(spec, args.out, default_command(spec, args.out), force=args.force)
    data = {
        "name": spec.name,
        "folder": str(export.folder),
        "files": [p.name for p in export.files],
        "segments": spec.n,
        "effects": spec.effects.spec(),
        "variant": spec.variant,
        "precision": spec.precision,
        "example": {"input": export.example_input, "output": export.example_output},
    }
    print_result(args, data, _table)
    return EXIT_OK


def add_export(sub) -> None:
    p = sub.add_parser("export", help="export a model as code for other targets (c: dependency-free C for a controller)")
    esub = p.add_subparsers(dest="target", parser_class=Parser, required=True, metavar="{c}")
    c = esub.add_parser("c", help="a model as C99 with no dependency but libm: header, source, Makefile, README, demo")
    c.add_argument("--segments", "-n", type=segments_arg, required=True, help="segment count n, 1 to 256")
    c.add_argument("--effects", default=None, help=f"comma-separated effects (default {DEFAULT_EFFECTS}); payload:K for K payloads")
    c.add_argument("--variant", choices=VARIANTS, default=None, help=f"model variant (default {DEFAULT_VARIANT})")
    c.add_argument("--out", required=True, metavar="DIR", help="folder to write (created when missing; its parent must exist); files in it that esba did not write are not replaced without --force")
    c.add_argument("--float", action="store_true", help="single precision (float) instead of double")
    c.add_argument("--force", action="store_true", help="replace files of the same names in DIR that esba did not write (a Makefile of yours)")
    c.add_argument("--json", action="store_true", help="print JSON")
    c.set_defaults(func=_cmd_export_c)

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


def _section_pairs(items) -> dict[str, str]:
    out = {}
    for item in items or ():
        name, sep, value = str(item).partition("=")
        if not sep or not name.strip():
            raise UsageError(f"--section {item!r}: expected NAME=VALUE, e.g. EI_side=4e5 (N*mm^2; names EI_side, GJ)")
        out[name.strip()] = value.strip()
    return out


def _cmd_export_c3d(args: argparse.Namespace) -> int:
    from esba.export.ccode import ExportError
    from esba.export.spatial import ExportSpec3D, default_command3d, export_c3d
    from esba.derive.effects3d import DEFAULT_EFFECTS_3D

    try:
        spec = ExportSpec3D(args.segments, args.effects if args.effects is not None else DEFAULT_EFFECTS_3D, args.variant or DEFAULT_VARIANT,
                            "float" if args.float else "double", tuple(_section_pairs(args.section).items()))
    except ExportError as exc:
        raise UsageError(str(exc)) from None
    export = export_c3d(spec, args.out, default_command3d(spec, args.out), force=args.force)
    data = {
        "name": spec.name,
        "folder": str(export.folder),
        "files": [p.name for p in export.files],
        "segments": spec.n,
        "effects": spec.effects.spec(),
        "variant": spec.variant,
        "precision": spec.precision,
        "section": spec.section_values(),
        "example": {"input": export.example_input, "output": export.example_output},
    }
    print_result(args, data, _table)
    return EXIT_OK


def _cmd_export_c(args: argparse.Namespace) -> int:
    if args.three_d:
        return _cmd_export_c3d(args)
    if args.section:
        raise UsageError(f"--section {args.section[0]!r}: a section stiffness is for the 3-D export only; add --3d")
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
    c.add_argument("--3d", dest="three_d", action="store_true", help="the 3-D model (theta, psi, tau a joint; payload directions in space, moments, gravity's direction at run time; docs/3d.md)")
    c.add_argument("--section", action="append", metavar="NAME=VALUE", help="with --3d: the section stiffness EI_side or GJ (N*mm^2) of the C's default params (repeatable; default Table 1's section)")
    c.add_argument("--force", action="store_true", help="replace files of the same names in DIR that esba did not write (a Makefile of yours)")
    c.add_argument("--json", action="store_true", help="print JSON")
    c.set_defaults(func=_cmd_export_c)

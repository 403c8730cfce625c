"""``esba generate`` and ``esba audit``: the generated models and the audit of their derivation."""

from __future__ import annotations

import argparse
import sys
import time

from esba.derive.effects import (
    DEFAULT_EFFECTS,
    DEFAULT_VARIANT,
    VARIANTS,
    EffectError,
    EffectSet,
)
from esba.infra import outputs

from .arguments import UsageError, refuse, segments_arg
from .results import EXIT_FAILED, EXIT_OK, print_result


def _cmd_generate3d(args: argparse.Namespace, out) -> int:
    """``esba generate --3d``: the spatial family (derive/emit3d.py)."""
    from esba.derive.effects3d import DEFAULT_EFFECTS_3D, Effects3D

    if args.refresh:
        from esba.derive import emit3d  # SymPy: only for this command

        refuse(args, ["effects"], "with --refresh: the committed models have the default effects (drop --refresh to generate others)")
        if out is None:
            raise UsageError("--refresh rewrites the repository's generated/: run it inside a checkout, or give --out DIR")
        chosen = [(n, e, v) for n, e, v in emit3d.COMMITTED_3D if args.segments in (None, n) and args.variant in (None, v)]
        rows = []
        for n, eff, var in chosen:
            print(f"esba: generating the 3-D model n = {n} ({eff}) into {out}", file=sys.stderr)
            rows.append(emit3d.write_model3d(n, eff, var, out)[0].name)
        print_result(args, {"refreshed": rows, "folder": str(out)}, lambda d: "\n".join(f"wrote {d['folder']}/{r}" for r in d["refreshed"]))
        return EXIT_OK
    try:
        effects = Effects3D.parse(args.effects if args.effects is not None else DEFAULT_EFFECTS_3D)
    except EffectError as exc:
        raise UsageError(f"--effects: {exc}") from None
    if args.segments is None:
        raise UsageError("generate --3d needs --segments N (a whole number from 1 to 256) or --refresh")
    variant = args.variant or DEFAULT_VARIANT
    t0 = time.perf_counter()
    if out is None:
        from esba.model.spatial import load_model3d

        model = load_model3d(args.segments, effects, variant)
        path, counts, where = model.path, {k: f.n_instructions() for k, f in model.functions.items()}, "the model cache"
    else:
        from esba.derive import emit3d  # SymPy: only for this command

        path, entry = emit3d.write_model3d(args.segments, effects, variant, out)
        counts, where = entry["instructions"], "the checkout's generated/" if args.out is None else "--out"
    data = {"file": str(path), "written_to": where, "segments": args.segments, "effects": effects.spec(), "variant": variant,
            "instructions": counts, "generate_time_s": time.perf_counter() - t0}
    print_result(args, data, _generate_table)
    return EXIT_OK


def _cmd_generate(args: argparse.Namespace) -> int:
    if getattr(args, "three_d", False):
        checkout = outputs.checkout_root()
        out = outputs.check_folder(args.out, "--out") if args.out is not None else (checkout / "generated" if checkout is not None else None)
        return _cmd_generate3d(args, out)
    if args.effects is not None:
        try:
            effects = EffectSet.parse(args.effects)
        except EffectError as exc:
            raise UsageError(f"--effects: {exc}") from None
    else:
        effects = EffectSet.parse(DEFAULT_EFFECTS)
    checkout = outputs.checkout_root()
    out = None
    if args.out is not None:
        out = outputs.check_folder(args.out, "--out")
    elif checkout is not None:
        out = checkout / "generated"
    if args.refresh:
        from esba.derive import emit  # SymPy: only for this command

        refuse(args, ["effects"], "with --refresh: the committed models have the default effects (drop --refresh to generate others)")
        if out is None:
            raise UsageError("--refresh rewrites the repository's generated/: run it inside a checkout, or give --out DIR")
        chosen = [(n, e, v) for n, e, v in emit.COMMITTED if args.segments in (None, n) and args.variant in (None, v)]
        if not chosen:
            have = sorted({n for n, _, _ in emit.COMMITTED})
            raise UsageError(f"--refresh --segments {args.segments}: the committed models are n = {have[0]}..{have[-1]}; drop --refresh to generate n = {args.segments}")
        rows = []
        for n, eff, var in chosen:
            print(f"esba: generating n = {n} ({var}) into {out}", file=sys.stderr)
            path, _ = emit.write_model(n, eff, var, out)
            rows.append(path.name)
        if args.segments is None and args.variant is None:  # the whole refresh: the 3-D family too
            from esba.derive import emit3d

            for n, eff, var in emit3d.COMMITTED_3D:
                print(f"esba: generating the 3-D model n = {n} ({eff}) into {out}", file=sys.stderr)
                rows.append(emit3d.write_model3d(n, eff, var, out)[0].name)
        print_result(args, {"refreshed": rows, "folder": str(out)}, lambda d: "\n".join(f"wrote {d['folder']}/{r}" for r in d["refreshed"]))
        return EXIT_OK
    if args.segments is None:
        raise UsageError("generate needs --segments N (a whole number from 1 to 256) or --refresh")
    variant = args.variant or DEFAULT_VARIANT
    t0 = time.perf_counter()
    if out is None:  # installed esba: the model cache, where esba finds models it was not shipped with
        from esba.model.generated import generate_into_cache

        path, entry = generate_into_cache(args.segments, effects, variant)
        where = "the model cache"
    else:
        from esba.derive import emit  # SymPy: only for this command

        print(f"esba: generating n = {args.segments} ({effects.spec()}, {variant}) into {out}", file=sys.stderr)
        path, entry = emit.write_model(args.segments, effects, variant, out)
        where = "the checkout's generated/" if args.out is None else "--out"
    data = {
        "file": str(path),
        "written_to": where,
        "segments": args.segments,
        "effects": effects.spec(),
        "variant": variant,
        "instructions": entry["instructions"],
        "generate_time_s": time.perf_counter() - t0,
    }
    print_result(args, data, _generate_table)
    return EXIT_OK


def _generate_table(d: dict) -> str:
    """What ``esba generate`` wrote, in words: the instruction counts as a list, the time rounded."""
    rows = [(k, d[k]) for k in ("file", "written_to", "segments", "effects", "variant")]
    rows.append(("instructions", ", ".join(f"{name} {count}" for name, count in d["instructions"].items())))
    rows.append(("generated in", f"{d['generate_time_s']:.1f} s"))
    return "\n".join(f"{k:>16}: {v}" for k, v in rows)


def add_generate(sub) -> None:
    p = sub.add_parser("generate", help="derive and emit a CasADi model (in a checkout: into generated/; else into the model cache)")
    p.add_argument("--segments", "-n", type=segments_arg, help="segment count n, 1 to 256 (with --refresh: refresh that n only)")
    p.add_argument("--effects", default=None, help=f"comma-separated effects (default {DEFAULT_EFFECTS}); payload:K for K payloads")
    p.add_argument("--variant", choices=VARIANTS, default=None, help=f"model variant (default {DEFAULT_VARIANT}; with --refresh: that variant only)")
    p.add_argument("--out", default=None, metavar="DIR", help="folder to write (default: generated/ in a checkout, else the model cache)")
    p.add_argument("--refresh", action="store_true", help="regenerate the committed models (n = 1..8, both variants) and the manifest")
    p.add_argument("--3d", dest="three_d", action="store_true",
                   help="the spatial model family (3 rotations a joint; effects add rod, moment:K; see docs/3d.md)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_generate)


def _cmd_audit(args: argparse.Namespace) -> int:
    from esba.pages.derivations import PAGE

    page = outputs.default_page("derivations.md", create=not args.check) if args.out is None else args.out
    if args.check:
        check = PAGE.check(page)
        stale = not check.ok
        print_result(args, {"page": str(page), "stale": stale, "status": check.status}, lambda d: f"{d['page']} is {'up to date' if not d['stale'] else d['status'].upper()}")
        if stale:
            print(f"esba: {page} is {check.status}: run `esba audit` and commit it", file=sys.stderr)
            return EXIT_FAILED
        return EXIT_OK
    page = outputs.check_file(page, "--out", (".md",))
    written = PAGE.write(page)
    data = {"page": str(written.path), "verdicts": written.data.verdicts()}
    print_result(args, data, lambda d: "\n".join([f"wrote {d['page']}"] + [f"  {k:<26} {v}" for k, v in d["verdicts"].items()]))
    return EXIT_OK


def add_audit(sub) -> None:
    p = sub.add_parser("audit", help="check the paper's printed equations against the derivation; write the derivations page")
    p.add_argument("--check", action="store_true", help="write nothing; exit 1 when the page is stale")
    p.add_argument("--out", default=None, metavar="FILE.md", help="page to write (default docs/derivations.md in a checkout, else ./derivations.md)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_audit)

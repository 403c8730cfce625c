"""The ``esba`` command line.

Every command prints a readable table, or JSON with ``--json`` (valid JSON: no NaN or Infinity,
see :mod:`esba.jsonsafe`). Bad input (a flag, a scene file, an output path that cannot be
written, an unusable model cache) ends with one line ``esba: error: ...`` naming the value and
what is allowed, and exit code 2, before any long computation; a solve that fails or lands on an
unstable equilibrium says so and exits 1; a result outside the range the paper's model describes
is printed with ``esba: warning: ...`` lines (and a ``validity`` list in JSON). Where each
command writes is decided by :mod:`esba.outputs`.
"""

from __future__ import annotations

import argparse
import math
import os
import re
import sys
import time
from typing import Callable, Sequence

from derive.effects import DEFAULT_EFFECTS, DEFAULT_VARIANT, VARIANTS, EffectError, EffectSet

from esba import __version__, checks, console, jsonsafe, outputs

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2
EXIT_INTERRUPTED = 130


class UsageError(ValueError):
    """Bad input from the command line: reported in one line with exit code 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse prints usage too)
        raise UsageError(message)


_WHOLE = re.compile(r"\s*\d+\s*")


def _segments(text: str) -> int:
    if not _WHOLE.fullmatch(text):
        raise argparse.ArgumentTypeError(f"segments={text!r}: expected a whole number from 1 to {checks.MAX_SEGMENTS}")
    try:
        return checks.segments(int(text))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _count(name: str, low: int, high: int, why: str = "") -> Callable[[str], int]:
    """An argparse type: a whole number from ``low`` to ``high`` (``why`` explains the bound)."""

    def parse(text: str) -> int:
        value = int(text) if _WHOLE.fullmatch(text) else None
        if value is None or not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{name}={text}: expected a whole number from {low} to {high}" + (f" ({why})" if why else ""))
        return value

    return parse


def _given(args: argparse.Namespace, *dests: str) -> list[str]:
    """The flags among ``dests`` that were given (not None, not False), as the user spells them."""
    return ["--" + d.replace("_", "-") for d in dests if getattr(args, d, None) not in (None, False)]


def _refuse(args: argparse.Namespace, dests: Sequence[str], why: str) -> None:
    """A usage error when any of ``dests`` was given: they would be silently ignored."""
    given = _given(args, *dests)
    if given:
        raise UsageError(f"{', '.join(given)} {'is' if len(given) == 1 else 'are'} not used {why}")


def _emit(args: argparse.Namespace, data: dict, table: Callable[[dict], str]) -> None:
    if getattr(args, "json", False):
        print(jsonsafe.dumps(data, indent=2, sort_keys=True))
    else:
        print(table(data))


def _warn(findings) -> None:
    """The validity findings of a result, one ``esba: warning:`` line each on stderr."""
    for f in findings:
        print(f"esba: warning: {f.message if hasattr(f, 'message') else f['message']}", file=sys.stderr)


# ---------------------------------------------------------------------------------------------
# esba generate


def _cmd_generate(args: argparse.Namespace) -> int:
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
        from derive import emit  # SymPy: only for this command

        _refuse(args, ["effects"], "with --refresh: the committed models have the default effects (drop --refresh to generate others)")
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
        _emit(args, {"refreshed": rows, "folder": str(out)}, lambda d: "\n".join(f"wrote {d['folder']}/{r}" for r in d["refreshed"]))
        return EXIT_OK
    if args.segments is None:
        raise UsageError("generate needs --segments N (a whole number from 1 to 256) or --refresh")
    variant = args.variant or DEFAULT_VARIANT
    t0 = time.perf_counter()
    if out is None:  # installed esba: the model cache, where esba finds models it was not shipped with
        from esba.model import generate_into_cache

        path, entry = generate_into_cache(args.segments, effects, variant)
        where = "the model cache"
    else:
        from derive import emit  # SymPy: only for this command

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
    _emit(args, data, lambda d: "\n".join(f"{k:>16}: {v}" for k, v in d.items()))
    return EXIT_OK


def _add_generate(sub) -> None:
    p = sub.add_parser("generate", help="derive and emit a CasADi model (in a checkout: into generated/; else into the model cache)")
    p.add_argument("--segments", "-n", type=_segments, help="segment count n, 1 to 256 (with --refresh: refresh that n only)")
    p.add_argument("--effects", default=None, help=f"comma-separated effects (default {DEFAULT_EFFECTS}); payload:K for K payloads")
    p.add_argument("--variant", choices=VARIANTS, default=None, help=f"model variant (default {DEFAULT_VARIANT}; with --refresh: that variant only)")
    p.add_argument("--out", default=None, metavar="DIR", help="folder to write (default: generated/ in a checkout, else the model cache)")
    p.add_argument("--refresh", action="store_true", help="regenerate the committed models (n = 1..8, both variants) and the manifest")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_generate)


# ---------------------------------------------------------------------------------------------
# esba audit


def _cmd_audit(args: argparse.Namespace) -> int:
    page = outputs.default_page("derivations.md") if args.out is None else args.out
    if args.check:
        from derive import audit  # SymPy: only for this command

        stale = audit.check_page(page)
        _emit(args, {"page": str(page), "stale": stale}, lambda d: f"{d['page']} is {'STALE' if d['stale'] else 'up to date'}")
        if stale:
            print(f"esba: {page} is stale: run `esba audit` and commit it", file=sys.stderr)
            return EXIT_FAILED
        return EXIT_OK
    page = outputs.check_file(page, "--out")
    from derive import audit  # SymPy: only for this command

    path, verdicts = audit.write_page(page)
    data = {"page": str(path), "verdicts": {k: v.verdict for k, v in verdicts.items()}}
    _emit(args, data, lambda d: "\n".join([f"wrote {d['page']}"] + [f"  {k:<26} {v}" for k, v in d["verdicts"].items()]))
    return EXIT_OK


def _add_audit(sub) -> None:
    p = sub.add_parser("audit", help="check the paper's printed equations against the derivation; write the derivations page")
    p.add_argument("--check", action="store_true", help="write nothing; exit 1 when the page is stale")
    p.add_argument("--out", default=None, metavar="FILE.md", help="page to write (default docs/derivations.md in a checkout, else ./derivations.md)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_audit)


# ---------------------------------------------------------------------------------------------
# esba solve / stiffness / pressure / validate: scenes and equilibria (issue 3)

#: Where ``esba solve`` writes its figure when no scene file is given and no --plot.
DEFAULT_SOLVE_FIGURE = "esba-solve.png"


def _float_arg(text: str) -> float:
    """A number as people write it; Python's ``float()`` would also read ``0_1`` as 1."""
    try:
        return checks.number("value", text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number (expected decimal digits such as 0.1 or 2e-3)") from None


#: ``--max-iter``'s bound (``esba.equilibrium.MAX_ITER_LIMIT``, written out so that building the
#: parser does not import CasADi; a test checks they agree).
_MAX_ITER = 100_000


def _add_scene_flags(p: argparse.ArgumentParser, payloads: bool = True) -> None:
    p.add_argument("scene", nargs="?", default=None, metavar="SCENE.toml", help="scene file (default: the main job, Table 1 with a 2 N horizontal tip payload, n = 3)")
    p.add_argument("--segments", "-n", type=_segments, help="segment count n, 1 to 256")
    drive = p.add_mutually_exclusive_group()
    drive.add_argument("--pressure", type=_float_arg, help="pressure, MPa")
    drive.add_argument("--target-angle", type=_float_arg, metavar="DEG", help="use the pressure that bends the unloaded actuator to DEG")
    if payloads:
        p.add_argument("--payload", type=_float_arg, action="append", metavar="N", help="payload magnitude in N (repeatable; replaces the scene's payloads)")
        p.add_argument("--payload-angle", type=_float_arg, action="append", metavar="DEG", help="direction Omega of the k-th payload from the vertical (90 = horizontal; one value applies to all)")
        p.add_argument("--payload-at", type=_float_arg, action="append", metavar="FRACTION", help="point of the k-th payload as a fraction of L (1 = tip; one value applies to all)")
        p.add_argument("--no-payload", action="store_true", help="no payloads (and no payload terms)")
    p.add_argument("--gravity", action="store_true", default=None, help="include the actuator's weight (Eq. 15)")
    p.add_argument("--no-fibres", action="store_true", help="leave out the fibre restraint (Eq. 18)")
    p.add_argument("--variant", choices=VARIANTS, default=None, help=f"model variant (default: the scene's, else {DEFAULT_VARIANT})")
    p.add_argument("--json", action="store_true", help="print JSON")


def _per_payload(flag: str, values: list[float] | None, count: int) -> list[float] | None:
    if values is None:
        return None
    if count == 0:
        raise UsageError(f"{flag} given but there is no payload: add --payload N")
    if len(values) == 1:
        return values * count
    if len(values) != count:
        raise UsageError(f"{flag} given {len(values)} times for {count} payloads: give it once (for all) or once per payload")
    return values


def _scene_changes(args: argparse.Namespace, skip: tuple[str, ...] = ()) -> dict:
    """The scene fields that the common flags override (flags a command lacks count as unset).

    ``skip`` names flags that mean something else to the command (a sweep's --pressure is a grid).
    """
    flags = {"segments": "segments", "pressure": "pressure", "target_angle": "target_angle_deg", "variant": "variant"}
    changes = {
        field: getattr(args, flag) for flag, field in flags.items() if flag not in skip and getattr(args, flag, None) is not None
    }
    if getattr(args, "gravity", False):
        changes["gravity"] = True
    if getattr(args, "no_fibres", False):
        changes["fibres"] = False
    return changes


def _load_scene(path: str | None, default):
    """The scene file ``path`` (an empty name is an error, not the default), else ``default``."""
    from esba.scene import SceneError, load_scene

    if path is None:
        return default
    if not path.strip():
        raise SceneError(f"scene file {path!r}: expected the path of a TOML scene file (or no argument for the default scene)")
    return load_scene(path)


def _scene_from_args(args: argparse.Namespace, payloads: bool = True):
    """The scene file (or the main job) with the flags applied; bad values are usage errors."""
    from esba.scene import MAIN_JOB, Payload, SceneError

    try:
        scene = _load_scene(args.scene, MAIN_JOB)
        changes = _scene_changes(args)
        if payloads:
            if args.no_payload and (args.payload or args.payload_angle or args.payload_at):
                raise UsageError("--no-payload cannot be combined with --payload, --payload-angle or --payload-at")
            current = list(scene.payloads)
            if args.no_payload:
                current = []
            elif args.payload is not None:
                current = [Payload(f) for f in args.payload]
            angles = _per_payload("--payload-angle", args.payload_angle, len(current))
            ats = _per_payload("--payload-at", args.payload_at, len(current))
            if args.no_payload or args.payload is not None or angles or ats:
                current = [
                    Payload(p.force, angles[k] if angles else p.angle_deg, ats[k] if ats else p.at) for k, p in enumerate(current)
                ]
                changes["payloads"] = tuple(current)
        return scene.replace(**changes) if changes else scene
    except SceneError as exc:
        raise UsageError(str(exc)) from None


def _fmt(values, digits: int = 3) -> str:
    return ", ".join(f"{v:.{digits}f}" for v in values)


def _solve_table(d: dict) -> str:
    terms = ", ".join(f"{k} {v:.3f}" for k, v in d["energy_terms_nmm"].items())
    loads = "; ".join(f"{p['force_n']:g} N at {p['angle_deg']:g} deg, s = {p['at']:g}" for p in d["payloads"]) or "none"
    rows = [
        ("scene", d["scene"]),
        ("effects", ", ".join(d["effects"])),
        ("payloads", loads),
        ("pressure", f"{d['pressure_mpa']:.7f} MPa ({d['pressure_from']})"),
        ("theta", f"({_fmt(d['theta_deg'], 2)}) deg"),
        ("total angle", f"{d['total_angle_deg']:.3f} deg"),
        ("tip x, y", f"{d['tip_mm'][0]:.3f}, {d['tip_mm'][1]:.3f} mm (orientation {d['tip_angle_deg']:.2f} deg)"),
        ("energy", f"{d['energy_nmm']:.4f} N mm ({terms})"),
        ("stability", f"{d['stability']} (Hessian eigenvalues {_fmt(d['eigenvalues'], 3)} N mm/rad^2)"),
        ("solver", f"{d['certificate'] or 'IPOPT ' + d['status']}; {d['steps']} path points and solves, {d['iterations']} iterations in all, {d['solve_time_s']:.3f} s"),
    ]
    if d.get("message"):
        rows.append(("NOT OK", d["message"]))
    for note in d.get("notes", []):
        rows.append(("note", note))
    if d.get("sensitivities"):
        rows += _sensitivity_rows(d)
    if d.get("uncertainty"):
        rows += _uncertainty_rows(d)
    if d.get("figure"):
        rows.append(("figure", f"wrote {d['figure']}"))
    return "\n".join(f"{k:>12}: {v}" for k, v in rows)


def _sensitivity_rows(d: dict) -> list[tuple[str, str]]:
    s = d["sensitivities"]
    if s["status"] != "ok":
        return [("sensitivity", s["message"])]
    rows = [("sensitivity", "per unit of each parameter (implicit function theorem, exact AD); fold: linear estimate of the change that reaches it")]
    rows.append(("", f"{'parameter':<14} {'value':>10} {'unit':<6} {'d angle (deg)':>14} {'d tip x (mm)':>13} {'d tip y (mm)':>13} {'fold':>10}"))
    for name, r in s["parameters"].items():
        fold = "-" if r["fold_distance"] is None else f"{r['fold_distance']:+.3g}"
        rows.append(("", f"{name:<14} {r['value']:>10.5g} {r['unit']:<6} {r['dtotal_angle_deg_per_unit']:>14.5g} "
                         f"{r['dtip_mm_per_unit'][0]:>13.5g} {r['dtip_mm_per_unit'][1]:>13.5g} {fold:>10}"))
    return rows


def _uncertainty_rows(d: dict) -> list[tuple[str, str]]:
    u = d["uncertainty"]
    given = ", ".join(f"{s['name']} {s['sigma']:.4g} {s['unit']}" + (" (uniform)" if s["distribution"] == "uniform" else "") for s in u["sigmas"])
    rows = [("sigmas", given)]
    if u["std_total_angle_deg"] is None:
        rows.append(("uncertainty", f"{u['status']}: {u['message']}"))
        return rows
    e = u["tip_ellipse_95"]
    rows.append(("first order", f"std total angle {u['std_total_angle_deg']:.4g} deg; std tip x, y {u['std_tip_mm'][0]:.4g}, {u['std_tip_mm'][1]:.4g} mm; "
                                f"95 % tip ellipse {e['semi_axes_mm'][0]:.3g} x {e['semi_axes_mm'][1]:.3g} mm at {e['angle_deg']:.1f} deg from x"))
    if u["status"] != "ok":
        rows.append(("NOT LINEAR", u["message"]))
    mc = d.get("monte_carlo")
    if mc:
        c = mc["counts"]
        std = mc["std"]

        def num(v):
            return "-" if v is None else f"{v:.4g}"

        rows.append(("Monte Carlo", f"{c['samples']} samples (seed {mc['seed']}, {mc['backend']}): {c['ok']} solved, {c['invalid']} outside the scene's rules, "
                                    f"{c['not_ok']} without a stable equilibrium; std total angle {num(std['total_angle'])} deg, tip x, y "
                                    f"{num(std['tip_x'])}, {num(std['tip_y'])} mm"))
        st = mc.get("study")
        if st:
            where = f"; samples in {st['out']}" + (f" (resumed at sample {st['resumed_from_sample']})" if st.get("resumed_from_sample") else "") if st.get("out") else ""
            rows.append(("solved", f"{st['runner']} in {st['seconds']:.1f} s{where}"))
        rows.append(("agreement", d["agreement"]["verdict"]))
    return rows


def _cmd_solve(args: argparse.Namespace) -> int:
    from esba.equilibrium import EquilibriumError, SolverOptions, solve

    if args.no_plot and args.plot is not None:
        raise UsageError("--plot and --no-plot: give one of the two")
    plot = args.plot
    if plot is None and args.scene is None and not args.no_plot:
        plot = DEFAULT_SOLVE_FIGURE
    figure = outputs.figure_file(plot, "--plot", DEFAULT_SOLVE_FIGURE) if plot and not args.no_plot else None
    scene = _scene_from_args(args)
    sigmas = _sigmas_for(args, scene)  # bad sigmas are usage errors, before any solve
    if args.monte_carlo is not None and not sigmas:
        raise UsageError("--monte-carlo needs uncertain parameters: --sigma NAME=SIGMA or an [uncertainty] table in the scene file")
    chunked = _on_cluster(args) or args.mc_out is not None or args.resume
    if chunked and args.monte_carlo is None:
        raise UsageError("--workers, --scheduler, --mc-out and --resume run the Monte Carlo: give --monte-carlo N (and --sigma)")
    if args.resume and args.mc_out is None:
        raise UsageError("--resume continues the Monte Carlo in its sample file: give --mc-out FILE.csv")
    mc_options = None
    if args.monte_carlo is not None:
        from esba.uncertainty import MonteCarloOptions, UncertaintyError

        try:
            extra = {} if args.mc_chunk is None else {"chunk": args.mc_chunk}
            mc_options = MonteCarloOptions(samples=args.monte_carlo, seed=args.seed, **extra)
        except UncertaintyError as exc:
            raise UsageError(f"--monte-carlo: {exc}") from None
    options = SolverOptions(max_iter=args.max_iter, continuation=not args.no_continuation)
    try:
        result = solve(scene, options)
    except EquilibriumError as exc:
        print(f"esba: failed: {exc}", file=sys.stderr)
        return EXIT_FAILED
    data = result.to_dict()
    data["scene"] = scene.describe()
    propagation = mc = None
    if args.sensitivities:
        from esba.sensitivity import sensitivities

        data["sensitivities"] = sensitivities(result).to_dict()
    if sigmas:
        from esba.uncertainty import compare, monte_carlo, propagate

        propagation = propagate(result, sigmas)
        data["uncertainty"] = propagation.to_dict()
        if mc_options is not None:
            if chunked:
                try:
                    mc, info = _monte_carlo_in_chunks(args, scene, sigmas, mc_options)
                except KeyboardInterrupt:
                    where = f": the samples solved so far are in {args.mc_out}; rerun with --resume to go on" if args.mc_out else ""
                    print(f"esba: interrupted{where}", file=sys.stderr)
                    return 130
            else:
                mc, info = monte_carlo(scene, sigmas, mc_options), None
            data["monte_carlo"] = mc.to_dict()
            if info is not None:
                data["monte_carlo"]["study"] = info
            data["agreement"] = compare(propagation, mc).to_dict()
    if figure is not None:
        from esba.plots import save_figure, solve_figure

        unloaded = solve(scene.replace(payloads=tuple(p.scaled(0.0) for p in scene.payloads), gravity=False), pressure=result.pressure)
        cov = propagation.cov_tip if propagation is not None and propagation.has_numbers else None
        tips = mc.tip[mc.ok] if mc is not None else None
        data["figure"] = str(save_figure(solve_figure(result, unloaded, tip_cov=cov, samples=tips), figure).resolve())
    _emit(args, data, _solve_table)
    _warn(result.validity)
    if not result.ok:
        print(f"esba: solve not ok: {result.message or result.status}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _monte_carlo_in_chunks(args: argparse.Namespace, scene, sigmas, options):
    """The Monte Carlo on --workers or --scheduler, or streamed to --mc-out (esba.mc_study)."""
    from esba.distributed import DistributedError, open_runner
    from esba.study import StudyError
    from esba.uncertainty import monte_carlo

    progress = sys.stderr.isatty()
    try:
        with open_runner(args.workers, args.scheduler, args.connect_timeout) as runner:
            if args.mc_out is None:
                t0 = time.perf_counter()
                mc = monte_carlo(scene, sigmas, options, runner=runner, progress=progress)
                return mc, {"runner": runner.description, "workers": runner.workers, "seconds": time.perf_counter() - t0}
            from esba.mc_study import monte_carlo_study

            return monte_carlo_study(scene, sigmas, options, runner=runner, out=args.mc_out, resume=args.resume, progress=progress)
    except (DistributedError, StudyError) as exc:
        raise UsageError(str(exc)) from None


def _sigmas_for(args: argparse.Namespace, scene) -> tuple:
    """The scene file's [uncertainty] table, then --sigma flags (a flag replaces the file's entry)."""
    from esba.uncertainty import UncertaintyError, load_sigmas, parse_sigma, resolve_sigmas

    try:
        specs = list(load_sigmas(args.scene)) if args.scene else []
        specs += [parse_sigma(text) for text in args.sigma or ()]
        return resolve_sigmas(scene, specs) if specs else ()
    except UncertaintyError as exc:
        raise UsageError(str(exc)) from None


def _sample_count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 10:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a whole number of samples >= 10")
    return value


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a whole number >= 0")
    return value


def _add_solve(sub) -> None:
    p = sub.add_parser("solve", help="solve a scene's equilibrium (no arguments: the paper's Table 2 case, n = 3)")
    _add_scene_flags(p)
    p.add_argument("--plot", metavar="FILE|DIR", help=f"write the deformed and unloaded shapes (default ./{DEFAULT_SOLVE_FIGURE} when no scene file is given; a folder gets {DEFAULT_SOLVE_FIGURE} inside it; no suffix: .png)")
    p.add_argument("--no-plot", action="store_true", help="write no figure")
    p.add_argument("--max-iter", type=_count("max_iter", 1, _MAX_ITER, "an equilibrium takes tens of iterations"), default=200, metavar="N", help="IPOPT iterations per solve (default 200, at most 100000)")
    p.add_argument("--no-continuation", action="store_true", help="one solve at the full load, no load ramp")
    p.add_argument("--sensitivities", action="store_true", help="d(angles, tip)/d(parameter) for every scene parameter (exact, implicit function theorem)")
    p.add_argument("--sigma", action="append", metavar="NAME=SIGMA", help="uncertain parameter: E=0.05 (in its unit), E=10%%, r2=±0.1 (a tolerance); repeatable; propagated to first order")
    p.add_argument("--monte-carlo", type=_sample_count, metavar="N", help="check the first-order uncertainty with N Monte Carlo samples on the batch path (e.g. 10000)")
    p.add_argument("--seed", type=_seed, default=0, help="seed of the Monte Carlo samples (default 0)")
    _add_cluster_flags(p, "the Monte Carlo")
    p.add_argument("--mc-chunk", type=_chunk_arg, metavar="K", help="Monte Carlo samples per chunk (default 2500)")
    p.add_argument("--mc-out", type=_output_file(".csv"), metavar="FILE.csv", help="stream every Monte Carlo sample to FILE.csv, chunk by chunk")
    p.add_argument("--resume", action="store_true", help="continue the Monte Carlo in --mc-out FILE.csv from the samples it holds")
    p.set_defaults(func=_cmd_solve)


def _stiffness_table(d: dict) -> str:
    lines = [
        f"secant stiffness K = F / delta from the unloaded state ({d['initial_angle_deg']:.2f} deg), "
        f"P = {d['pressure_mpa']:.7f} MPa held, tip payload at {d['payload_angle_deg']:g} deg; n = {d['segments']}, {d['variant']}",
        f"{'F (N)':>8} {'delta (mm)':>11} {'K (N/m)':>9} {'tip x, y (mm)':>18}",
    ]
    for f, dl, k, tip in zip(d["payloads_n"], d["displacement_mm"], d["stiffness_n_per_m"], d["tip_mm"]):
        lines.append(f"{f:8.3f} {dl:11.3f} {k:9.3f} {tip[0]:8.2f}, {tip[1]:7.2f}")
    t = d["tangent"]
    lines.append(f"tangent at F = 0: horizontal {t['horizontal_n_per_m']:.3f} N/m, vertical {t['vertical_n_per_m']:.3f} N/m")
    if t["matrix_n_per_m"] is not None:
        m = t["matrix_n_per_m"]
        lines.append(f"K_tip (N/m, x down, y horizontal): [[{m[0][0]:.2f}, {m[0][1]:.2f}], [{m[1][0]:.2f}, {m[1][1]:.2f}]]")
    else:
        lines.append("K_tip: singular (one segment moves the tip along one direction only)")
    for msg in d["messages"]:
        lines.append(f"NOT OK: {msg}")
    return "\n".join(lines)


def _cmd_stiffness(args: argparse.Namespace) -> int:
    from esba.equilibrium import EquilibriumError
    from esba.scene import SceneError
    from esba.stiffness import PAPER_FORCES, secant_stiffness

    scene = _scene_from_args(args, payloads=False)
    forces = tuple(args.payload) if args.payload else PAPER_FORCES
    try:
        result = secant_stiffness(scene, forces, angle_deg=args.payload_angle)
    except SceneError as exc:
        raise UsageError(str(exc)) from None
    except EquilibriumError as exc:
        print(f"esba: failed: {exc}", file=sys.stderr)
        return EXIT_FAILED
    data = result.to_dict()
    _emit(args, data, _stiffness_table)
    _warn(data.get("validity", []))
    if not result.ok:
        print("esba: stiffness not ok: a solve failed or was not stable", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _add_stiffness(sub) -> None:
    p = sub.add_parser("stiffness", help="secant stiffness of the tip (Section 4.4.3) and its tangent matrix")
    _add_scene_flags(p, payloads=False)
    p.add_argument("--payload", type=_float_arg, action="append", metavar="N", help="tip payload in N (repeatable; default 0.5, 1, 2)")
    p.add_argument("--payload-angle", type=_float_arg, default=90.0, metavar="DEG", help="direction Omega of the payload (default 90, horizontal)")
    p.set_defaults(func=_cmd_stiffness)


def _target_sentence(d: dict) -> str:
    """What the pressure was found for, as a sentence."""
    t = d["target"]
    if "target_angle_deg" in t:
        return f"bends the unloaded actuator to {t['target_angle_deg']:g} deg in total (n = {d['segments']}, {d['variant']})"
    if "total_angle_deg" in t:
        return f"bends the loaded actuator to {t['total_angle_deg']:g} deg in total (n = {d['segments']}, {d['variant']})"
    parts = [f"{axis} = {v:g} mm" for axis, v in zip(("x", "y"), t["tip_mm"]) if v is not None]
    return f"puts the loaded actuator's tip at {' and '.join(parts)} (n = {d['segments']}, {d['variant']})"


def _pressure_table(d: dict) -> str:
    rows = [("pressure", f"{d['pressure_mpa']:.7f} MPa"), ("target", f"the pressure that {_target_sentence(d)}"), ("method", d["method"])]
    if "residual" in d:
        rows.append(("residual", f"{d['residual']:.3g}"))
        rows.append(("theta", f"({_fmt(d['equilibrium']['theta_deg'], 2)}) deg"))
        rows.append(("tip x, y", f"{_fmt(d['equilibrium']['tip_mm'])} mm"))
    if d.get("message"):
        rows.append(("note" if d.get("ok", True) else "NOT OK", d["message"]))
    return "\n".join(f"{k:>10}: {v}" for k, v in rows)


def _cmd_pressure(args: argparse.Namespace) -> int:
    from esba.equilibrium import EquilibriumError, pressure_for_angle
    from esba.scene import SceneError
    from esba.stiffness import pressure_for_target

    chosen = [a for a in ("target_angle", "total_angle", "tip_x", "tip_y") if getattr(args, a) is not None]
    if args.target_angle is not None and len(chosen) > 1 or args.total_angle is not None and len(chosen) > 1:
        raise UsageError("give one target: --target-angle, --total-angle, or --tip-x/--tip-y")
    if not chosen:
        raise UsageError("pressure needs a target: --target-angle DEG (unloaded), --total-angle DEG or --tip-x/--tip-y MM (under the payloads)")
    if args.pressure is not None:
        raise UsageError("--pressure is what this command finds: give a target instead")
    if args.target_angle is not None:
        _refuse(args, ["payload", "payload_angle", "payload_at", "no_payload", "gravity"], "with --target-angle (the closed form is for the unloaded actuator; use --total-angle for a target under payloads)")
    keep_target, args.target_angle = args.target_angle, None
    scene = _scene_from_args(args)
    try:
        if keep_target is not None:
            scene = scene.replace(target_angle_deg=keep_target)
            p = pressure_for_angle(scene)
            data = {
                "ok": True,
                "pressure_mpa": p,
                "method": "closed form (U is linear in P; unloaded, uniform curvature)",
                "target": {"target_angle_deg": keep_target},
                "segments": scene.segments,
                "variant": scene.variant,
            }
        else:
            if not scene.payloads:
                raise UsageError("--total-angle/--tip-x/--tip-y are targets under payloads: add --payload N (or use --target-angle)")
            if args.total_angle is not None:
                r = pressure_for_target(scene, total_angle_deg=args.total_angle)
            else:
                r = pressure_for_target(scene, tip_mm=(args.tip_x, args.tip_y))
            data = r.to_dict()
            data["method"] = "NLP over (theta, P) with dU/dtheta = 0"
            data["segments"] = scene.segments
            data["variant"] = scene.variant
    except SceneError as exc:
        raise UsageError(str(exc)) from None
    except EquilibriumError as exc:
        print(f"esba: failed: {exc}", file=sys.stderr)
        return EXIT_FAILED
    _emit(args, data, _pressure_table)
    _warn(data.get("equilibrium", {}).get("validity", []))
    if not data["ok"]:
        print(f"esba: pressure not found: {data.get('message', '')}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _add_pressure(sub) -> None:
    p = sub.add_parser("pressure", help="the pressure for a target angle (closed form) or a loaded target (NLP)")
    _add_scene_flags(p)
    p.add_argument("--total-angle", type=_float_arg, metavar="DEG", help="target total angle under the payloads")
    p.add_argument("--tip-x", type=_float_arg, metavar="MM", help="target tip x under the payloads")
    p.add_argument("--tip-y", type=_float_arg, metavar="MM", help="target tip y under the payloads")
    p.set_defaults(func=_cmd_pressure)


def _cmd_validate(args: argparse.Namespace) -> int:
    from esba import validation

    page = outputs.default_page("validation.md") if args.out is None else args.out
    if not args.check:
        page = outputs.check_file(page, "--out")
    rows = validation.table2()
    if args.check:
        stale = validation.check_page(page, rows)
        if stale:
            print(f"esba: {page} is stale: run `esba validate` and commit it", file=sys.stderr)
            return EXIT_FAILED
    else:
        page = validation.write_page(page, rows)
    data = {"passed": all(r.passed for r in rows), "rows": [r.to_dict() for r in rows]}
    if not args.check:
        data["page"] = str(page)
    _emit(args, data, lambda d: validation.summary(rows) + (f"\nwrote {d['page']}" if "page" in d else f"\n{page} is up to date"))
    return EXIT_OK if data["passed"] else EXIT_FAILED


def _add_validate(sub) -> None:
    p = sub.add_parser("validate", help="compare with the paper's Table 2 (n = 1..4); write the validation page")
    p.add_argument("--check", action="store_true", help="write nothing; exit 1 when the page is stale")
    p.add_argument("--out", default=None, metavar="FILE.md", help="page to write (default docs/validation.md in a checkout, else ./validation.md)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_validate)


# ---------------------------------------------------------------------------------------------
# esba bench


def _cmd_bench_generation(args: argparse.Namespace) -> int:
    from esba import bench

    page = outputs.check_file(args.markdown, "--markdown") if args.markdown else None
    ns = [n for n in bench.GENERATION_NS if n <= args.max_n]

    def progress(n):
        print(f"  n = {n} done", file=sys.stderr)

    rows = bench.generation(ns, repeat=args.repeat, naive=not args.no_naive, progress=None if args.json else progress)
    exponent, why = bench.growth([r.n for r in rows], [r.total_s for r in rows])
    data = {"rows": [r.__dict__ for r in rows], "growth_exponent": exponent}
    if exponent is None:
        data["growth_exponent_reason"] = why
    _emit(args, data, lambda d: bench.generation_table(rows))
    if page is not None:
        command = f"esba bench generation --max-n {args.max_n} --repeat {args.repeat}{' --no-naive' if args.no_naive else ''} --markdown {args.markdown}"
        path = bench.write_generation_page(page, rows, command)
        print(f"esba: wrote {path}", file=sys.stderr)
    return EXIT_OK


def _cmd_bench_accuracy(args: argparse.Namespace) -> int:
    from esba import accuracy as acc

    if args.quick:
        _refuse(args, ["max_n", "reference_n", "fixed_n"], "with --quick (it fixes n <= 4, reference n = 16)")
    if args.no_write:
        _refuse(args, ["out", "figure"], "with --no-write")
    max_n = 128 if args.max_n is None else args.max_n
    reference_n = acc.REFERENCE_N if args.reference_n is None else args.reference_n
    fixed_n = 16 if args.fixed_n is None else args.fixed_n
    if args.quick:
        ns, ref_n, fixed_n, naive_ns, size = (1, 2, 3, 4), 16, 4, (3,), 1000
    else:
        ns, ref_n, naive_ns, size = tuple(n for n in acc.ACCURACY_NS if n <= max_n), reference_n, (3, 8, 16), 10_000
    if ref_n < 4 or ref_n % 4:
        raise UsageError(f"--reference-n {ref_n}: expected a multiple of 4 (the reference extrapolates from n/4, n/2, n)")
    doc = fig = None
    if not args.no_write:
        doc = outputs.check_file(outputs.default_page("accuracy-vs-time.md") if args.out is None else args.out, "--out")
        fig = outputs.figures_dir() / "accuracy-vs-time.png" if args.figure is None else args.figure
        if args.figure is None and outputs.checkout_root() is None:
            outputs.check_folder(fig.parent, "--figure")
        fig = outputs.figure_file(fig, "--figure", "accuracy-vs-time.png")

    def say(msg):
        if not args.json:
            print(f"  {msg}", file=sys.stderr)

    study = acc.accuracy_study(ns, ref_n, repeat=args.repeat, progress=say)
    say(f"tolerance study (n = {fixed_n})")
    tol = acc.tolerance_study(fixed_n, repeat=args.repeat)
    say(f"effect study (n = {fixed_n})")
    eff = acc.effect_study(fixed_n, repeat=args.repeat)
    for rows in (tol, eff):
        for r in rows:
            r["n"] = fixed_n
    say("naive BFGS against esba")
    naive = acc.naive_study(naive_ns, repeat=args.repeat)
    say(f"batch of {size}")
    batch = acc.batch_study(size)
    data = {
        "reference": study.reference,
        "rows": [r.__dict__ for r in study.rows],
        "costs": {n: c.__dict__ for n, c in study.costs.items()},
        "reach": {
            case: {f"{mm:g} mm": (None if (r := study.first_n_below(case, mm)) is None else r.n) for mm in (1.0, 0.1)} for case in study.reference
        },
        "tolerance": tol,
        "effects": eff,
        "naive": naive,
        "batch": batch,
    }
    if doc is not None:
        command = "esba bench accuracy" + (" --quick" if args.quick else "")
        if not args.quick and (max_n, reference_n, fixed_n, args.repeat) != (128, 256, 16, 5):
            command += f" --max-n {max_n} --reference-n {reference_n} --fixed-n {fixed_n} --repeat {args.repeat}"
        doc, fig = acc.write_page(study, tol, eff, naive, batch, command, doc=doc, fig_path=fig)
        data["page"], data["figure"] = str(doc), str(fig)

    def table(d: dict) -> str:
        lines = [f"{'case':>10} {'n':>4} {'error mm':>9} {'n vs n+1':>9} {'solve ms':>9}"]
        for r in study.rows:
            lines.append(f"{r.case:>10} {r.n:>4} {r.error_mm:9.3g} {r.next_mm:9.3g} {1e3 * r.solve_s:9.2f}")
        lines += [f"{case}: reaches {reach}" for case, reach in d["reach"].items()]
        lines.append(f"batch: {batch.get('compiled_us', batch['interpreted_us']):.1f} us per equilibrium; naive {batch['naive_us']:.0f} us; IPOPT {batch['ipopt_us']:.0f} us")
        if "page" in d:
            lines.append(f"wrote {d['page']} and {d['figure']}")
        return "\n".join(lines)

    _emit(args, data, table)
    return EXIT_OK


def _bench_progress(args: argparse.Namespace, form: str):
    """A progress line per finished part on stderr (none with --json)."""

    def progress(what):
        if not args.json:
            print(form.format(what), file=sys.stderr)

    return progress


def _bench_section(args: argparse.Namespace, name: str, body: str) -> None:
    """Write the ``name`` section of the --markdown page (checked when the command started)."""
    from esba import bench
    from esba.pages import write_section

    if args.markdown:
        command = f"esba bench {name} --repeat {args.repeat} --markdown {args.markdown}"
        print(f"wrote {write_section(args.markdown, name, body, command, bench.PERFORMANCE_TITLE)}", file=sys.stderr)


def _cmd_bench_solve(args: argparse.Namespace) -> int:
    from esba import bench_solve

    if args.markdown:
        outputs.check_file(args.markdown, "--markdown", (".md",))
    data = bench_solve.solve_benchmark(repeat=args.repeat, progress=_bench_progress(args, "  {} done"))
    _emit(args, data, bench_solve.solve_table)
    _bench_section(args, "solve", bench_solve.solve_section(data))
    return EXIT_OK


def _cmd_bench_path(args: argparse.Namespace) -> int:
    from esba import bench_path

    if args.markdown:
        outputs.check_file(args.markdown, "--markdown", (".md",))
    rows = bench_path.path_benchmark(repeat=args.repeat, progress=_bench_progress(args, "  n = {} done"))
    data = {"rows": [dict(r.__dict__, points_per_s=r.points_per_s, floor_s=r.floor_s) for r in rows]}
    _emit(args, data, lambda d: bench_path.path_table(rows))
    _bench_section(args, "path", bench_path.path_section(rows))
    return EXIT_OK


def _cmd_bench_batch(args: argparse.Namespace) -> int:
    from esba import accuracy as acc
    from esba.batch import check_size

    check_size(args.size, args.segments, "--size", UsageError)
    data = acc.batch_study(args.size, args.segments)

    def table(d: dict) -> str:
        rows = [("batch size", f"{d['size']} equilibria, n = {d['segments']} (pressures 0-0.2 MPa x horizontal tip payloads 0-2 N)")]
        if "compiled_us" in d:
            rows += [
                ("compiled, warm", f"{d['compiled_us']:.1f} us per equilibrium (fast path alone {d['compiled_fast_path_us']:.1f} us)"),
                ("compiled, first", f"{d['compiled_first_us']:.1f} us per equilibrium (compiling took {d['compiled_first_compile_s']:.1f} s)"),
            ]
        diff = d["max_theta_difference_vs_ipopt"]
        rows += [
            ("interpreted", f"{d['interpreted_us']:.1f} us per equilibrium"),
            ("IPOPT solve", f"{d['ipopt_us']:.0f} us per equilibrium (esba.equilibrium.solve, one by one, on {d['ipopt_samples']} of them)"),
            ("naive BFGS", f"{d['naive_us']:.0f} us per equilibrium (SciPy, numeric gradients)"),
            ("speed-up", f"{d['speedup_vs_naive']:.0f}x naive, {d['speedup_vs_ipopt']:.0f}x IPOPT"),
            ("answered by", str(d["counts"])),
            ("vs IPOPT", "no sample solved ok by both" if diff is None else f"largest angle difference {diff:.2g} rad on a sample"),
            ("backend", d["backend"]),
        ]
        return "\n".join(f"{k:>16}: {v}" for k, v in rows)

    _emit(args, data, table)
    return EXIT_OK


#: ``--repeat``'s bound: medians of more runs change nothing but the wait.
_MAX_REPEAT = 100
#: ``--size``'s bound before the memory check (esba.batch.check_size) refines it per n.
_MAX_SIZE = 10_000_000


def _cmd_bench_scaling(args: argparse.Namespace) -> int:
    from esba import bench_scaling, scaling_report
    from esba.distributed import DistributedError, require_dask

    if args.scheduler is not None and args.workers is not None:
        raise UsageError("--workers N lists local cluster sizes and --scheduler ADDRESS measures an existing cluster: give one of the two")
    try:
        require_dask("esba bench scaling")
    except DistributedError as exc:
        raise UsageError(str(exc)) from None

    def say(msg: str) -> None:
        if not args.json:
            print(f"  {msg}", file=sys.stderr)

    workers = tuple(args.workers) if args.workers else bench_scaling.DEFAULTS["workers"]
    try:
        data = bench_scaling.scaling_study(points=args.points, segments=args.segments, repeat=args.repeat, chunk=args.chunk,
                                           workers=workers, scheduler=args.scheduler, timeout=args.connect_timeout, progress=say)
    except DistributedError as exc:
        raise UsageError(str(exc)) from None
    if args.markdown:
        command = "esba bench scaling"
        defaults = bench_scaling.DEFAULTS
        for flag, value, default in (("--points", args.points, defaults["points"]), ("--segments", args.segments, defaults["segments"]),
                                     ("--repeat", args.repeat, defaults["repeat"]), ("--chunk", args.chunk, defaults["chunk"])):
            if value != default:
                command += f" {flag} {value}"
        if args.workers:
            command += "".join(f" --workers {w}" for w in args.workers)
        if args.scheduler:
            command += f" --scheduler {args.scheduler}"
        command += f" --markdown {args.markdown}"
        data["page"] = str(scaling_report.write_page(args.markdown, data, command))

    _emit(args, data, scaling_report.summary)
    return EXIT_OK


def _add_bench(sub) -> None:
    p = sub.add_parser("bench", help="benchmarks: tables of medians over repeated runs")
    bsub = p.add_subparsers(dest="bench", parser_class=_Parser, required=True)
    g = bsub.add_parser("generation", help="generation time and size against n; per-call time of U, gradient, Hessian (minutes)")
    g.add_argument("--max-n", type=_segments, default=100, help="largest n (default 100)")
    g.add_argument("--repeat", type=_count("repeat", 1, _MAX_REPEAT), default=3, help="runs per n, median reported (default 3, at most 100)")
    g.add_argument("--no-naive", action="store_true", help="skip the naive SymPy route")
    g.add_argument("--markdown", metavar="FILE", help="also write the table as a docs page (docs/performance.md)")
    g.add_argument("--json", action="store_true")
    g.set_defaults(func=_cmd_bench_generation)

    a = bsub.add_parser("accuracy", help="tip error against n, tolerance, effects, naive vs esba, batch (about 4 minutes); writes the accuracy page")
    a.add_argument("--max-n", type=_segments, default=None, help="largest n of the study (default 128)")
    a.add_argument("--reference-n", type=_segments, default=None, help="finest n; the reference extrapolates from n/4, n/2, n (default 256)")
    a.add_argument("--fixed-n", type=_segments, default=None, help="n of the tolerance and effect studies (default 16)")
    a.add_argument("--repeat", type=_count("repeat", 1, _MAX_REPEAT), default=5, help="solves per timing, median reported (default 5, at most 100)")
    a.add_argument("--quick", action="store_true", help="a small smoke run (n <= 4, reference n = 16, batch of 1000)")
    a.add_argument("--out", default=None, metavar="FILE", help="page to write (default docs/accuracy-vs-time.md in a checkout, else ./accuracy-vs-time.md)")
    a.add_argument("--figure", default=None, metavar="FILE", help="figure to write (default figures/accuracy-vs-time.png beside the page)")
    a.add_argument("--no-write", action="store_true", help="print only; write no page or figure")
    a.add_argument("--json", action="store_true")
    a.set_defaults(func=_cmd_bench_accuracy)
    so = bsub.add_parser("solve", help="single-scene calls (solve for n = 3..128, stiffness, design, model load, CLI) against naive SciPy and the compiled limit")
    so.add_argument("--repeat", type=_segments, default=11, help="runs per timing, median reported (default 11)")
    so.add_argument("--markdown", metavar="FILE", help="also write the solve section of a docs page (docs/performance.md)")
    so.add_argument("--json", action="store_true")
    so.set_defaults(func=_cmd_bench_solve)
    pa = bsub.add_parser("path", help="time to trace the 2 N pressure path 0 -> 0.3 MPa (n = 3, 32) against the IPOPT ramp and naive BFGS")
    pa.add_argument("--repeat", type=_segments, default=5, help="runs per timing, median reported (default 5)")
    pa.add_argument("--markdown", metavar="FILE", help="also write the path section of a docs page (docs/performance.md)")
    pa.add_argument("--json", action="store_true")
    pa.set_defaults(func=_cmd_bench_path)
    sc = bsub.add_parser("scaling", help="equilibria per second of a sweep in this process and on Dask (1, 2 workers), chunk sizes, overhead per chunk (docs/scaling.md)")
    sc.add_argument("--points", type=_count("points", 20, 1_000_000), default=12_000, help="grid size, 20 to 1000000 (default 12000)")
    sc.add_argument("--segments", "-n", type=_segments, default=16, help="segment count (default 16)")
    sc.add_argument("--repeat", type=_count("repeat", 1, 50), default=3, help="runs per timing, median reported (default 3)")
    sc.add_argument("--chunk", type=_chunk_arg, default=1000, metavar="K", help="points per chunk of the worker-count rows (default 1000)")
    sc.add_argument("--workers", type=_workers_arg, action="append", metavar="N", help="local cluster sizes to measure (repeatable; default 1 and 2)")
    sc.add_argument("--scheduler", type=_scheduler_arg, metavar="ADDRESS", help="measure the existing Dask cluster at ADDRESS instead (e.g. one started by dask-jobqueue)")
    sc.add_argument("--connect-timeout", type=_timeout_arg, default=10.0, metavar="S", help="seconds to wait for --scheduler (default 10)")
    sc.add_argument("--markdown", type=_output_file(".md"), metavar="FILE", help="also write the page (docs/scaling.md)")
    sc.add_argument("--json", action="store_true")
    sc.set_defaults(func=_cmd_bench_scaling)
    b = bsub.add_parser("batch", help="us per equilibrium of the batch path against IPOPT and naive BFGS")
    b.add_argument("--size", type=_count("size", 1, _MAX_SIZE), default=10_000, help="batch size (default 10000; bounded by the memory it takes)")
    b.add_argument("--segments", "-n", type=_segments, default=3, help="segment count (default 3)")
    b.add_argument("--json", action="store_true")
    b.set_defaults(func=_cmd_bench_batch)


# ---------------------------------------------------------------------------------------------
# esba figures


def _cmd_figures(args: argparse.Namespace) -> int:
    from pathlib import Path

    from esba import figures

    try:
        names = figures.check_names(args.only)
    except figures.FigureError as exc:
        raise UsageError(f"--only: {exc}") from None
    out = outputs.check_folder(outputs.figures_dir() if args.out is None else args.out, "--out")
    written = figures.write_all(out, names)
    data = {"out": str(Path(out).resolve()), "figures": {name: str(path.resolve()) for name, path in written.items()}}
    _emit(args, data, lambda d: "\n".join(f"wrote {path}" for path in d["figures"].values()))
    return EXIT_OK


def _add_figures(sub) -> None:
    p = sub.add_parser("figures", help="regenerate the paper-style figures (Figs. 7b, 8c, 10, 11, 13a, 13b, 14) as PNG files (a few minutes)")
    p.add_argument("--out", metavar="DIR", default=None, help="folder to write (default docs/figures/ in a checkout, else ./figures/)")
    p.add_argument("--only", metavar="NAME", nargs="+", action="extend", default=None, help="write only these figures (e.g. fig7b fig11)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_figures)


# ---------------------------------------------------------------------------------------------
# esba design (issue 4): IPOPT on the full-space NLP, PSO as the paper did


def _design_rows(d: dict) -> list[tuple[str, str]]:
    def num(v, fmt):
        return "-" if v is None else format(v, fmt)

    rows = [
        ("status", d["status"] + (f": {d['message']}" if d.get("message") else "")),
        ("r2, d", f"{num(d['r2_mm'], '.5f')}, {num(d['d_mm'], '.5f')} mm (wall {num(d['wall_mm'], '.4f')} mm)"),
        ("pressure", f"{num(d['pressure_mpa'], '.6f')} MPa (unloaded 90 deg)"),
        ("stiffness", f"{num(d['stiffness_n_per_m'], '.5f')} N/m (load path: {num(d['stiffness_check_n_per_m'], '.5f')})"),
        ("objective", f"{d['objective']} = {num(d['objective_value'], '.6g')} {d['objective_unit']}"),
    ]
    if d.get("best_reachable_stiffness") is not None:
        rows.append(("best K", f"{d['best_reachable_stiffness']:.5f} N/m reachable"))
    rows.append(("stable", f"{d['stable']}; on the load path: {d['on_load_path']}"))
    active = []
    for c in d["active_constraints"]:
        sens = "" if c["sensitivity"] is None else f" (d objective / d bound = {c['sensitivity']:+.4g} {d['objective_unit']}/{c['unit']})"
        active.append(f"{c['name']}: {c['description']}{sens}")
    rows.append(("active", "; ".join(active) or "none"))
    work = f"{d['iterations']} iterations, {d['evaluations']} starts" if d["method"] == "ipopt" else f"{d['evaluations']} designs"
    rows.append(("time", f"{d['solve_time_s']:.3f} s ({work}; set-up {d['setup_time_s']:.3f} s)"))
    return rows


def _design_table(d: dict) -> str:
    if d.get("method") != "both":
        lines = [d["problem"], f"method: {d['method']}"] + [f"{k:>10}: {v}" for k, v in _design_rows(d)]
    else:
        lines = [d["ipopt"]["problem"]]
        for name in ("ipopt", "pso"):
            lines.append(f"-- {name}")
            lines += [f"{k:>10}: {v}" for k, v in _design_rows(d[name])]
        diff = d["differences"]

        def num(v, fmt):
            return "-" if v is None else format(v, fmt)

        lines.append(
            f"-- PSO - IPOPT: r2 {num(diff['r2_mm'], '+.2e')} mm, d {num(diff['d_mm'], '+.2e')} mm, objective "
            f"{num(diff['objective_rel'], '+.2e')} (relative); PSO took {num(diff['time_ratio_pso_over_ipopt'], '.0f')} "
            f"times as long; agree (0.01 mm, 0.1 %): {diff['agree']}"
        )
    if d.get("figure"):
        lines.append(f"wrote {d['figure']}")
    return "\n".join(lines)


def _cmd_design(args: argparse.Namespace) -> int:
    from esba.design import DesignError, DesignOptions, DesignProblem, compare, optimise_ipopt, optimise_pso
    from esba.design_report import write_doc
    from esba.pso import PSOOptions, PSOOptionsError

    if args.write_doc:
        _refuse(args, ["method", "objective", "min_stiffness", "max_pressure", "target_angle", "min_wall", "variant", "plot"], "with --write-doc (the study runs its own problems)")
        page = outputs.check_file(args.write_doc, "--write-doc")
    method = args.method or "ipopt"
    if method == "ipopt":
        _refuse(args, ["particles", "iterations", "seed"], "with --method ipopt (they set the swarm: use --method pso or both)")
    if method == "pso":
        _refuse(args, ["starts"], "with --method pso (it sets IPOPT's starts: use --method ipopt or both)")
    figure = outputs.figure_file(args.plot, "--plot", "esba-design.png") if args.plot else None
    try:
        pso_options = PSOOptions(
            particles=30 if args.particles is None else args.particles,
            iterations=50 if args.iterations is None else args.iterations,
            seed=0 if args.seed is None else args.seed,
        )
        options = DesignOptions(starts=4 if args.starts is None else args.starts)
        if args.write_doc:
            path, _ = write_doc(page, segments=args.segments, options=options, pso_options=pso_options)
            _emit(args, {"page": str(path)}, lambda d: f"wrote {d['page']}")
            return EXIT_OK
        problem = DesignProblem(
            objective=args.objective or "stiffness",
            segments=args.segments,
            variant=args.variant or DEFAULT_VARIANT,
            min_stiffness=args.min_stiffness,
            max_pressure=args.max_pressure,
            target_angle_deg=args.target_angle,
            min_wall=0.0 if args.min_wall is None else args.min_wall,
        )
    except (DesignError, PSOOptionsError) as exc:
        raise UsageError(str(exc)) from None
    if method == "ipopt":
        run = optimise_ipopt(problem, options)
    elif method == "pso":
        run = optimise_pso(problem, options, pso_options)
    else:
        run = compare(problem, options, pso_options)
    data = run.to_dict()
    results = [run] if method != "both" else [run.ipopt, run.pso]
    for r, d in zip(results, [data] if method != "both" else [data["ipopt"], data["pso"]]):
        d["validity"] = _design_validity(r, d)
    if figure is not None:
        from esba.design_figures import design_figure

        data["figure"] = str(design_figure(run, figure).resolve())
    _emit(args, data, _design_table)
    for r, d in zip(results, [data] if method != "both" else [data["ipopt"], data["pso"]]):
        _warn(d["validity"])
    bad = [r for r in results if r.status != "optimal"]
    for r in bad:
        print(f"esba: design {r.status} ({r.method}): {r.message}", file=sys.stderr)
    return EXIT_FAILED if bad else EXIT_OK


def _design_validity(result, d: dict) -> list[dict]:
    """The validity findings (:mod:`esba.validity`) of each state of a design (its start and loaded states)."""
    import math

    from esba.validity import assess_angles

    values = (d.get("r2_mm"), d.get("d_mm"), d.get("pressure_mpa"))
    if any(v is None or not math.isfinite(v) for v in values) or not isinstance(d.get("theta_deg"), dict):
        return []
    r2, dd, start_pressure = values
    # the start and loaded states are at the 90 degree pressure; free at max_pressure; target at its own
    pressures = {"free": d.get("max_pressure"), "target": d.get("target_pressure_mpa")}
    out = []
    for state, degrees in d["theta_deg"].items():
        pressure = pressures.get(state) or start_pressure
        if degrees is None or not all(math.isfinite(v) for v in degrees) or not math.isfinite(pressure):
            continue
        scene = result.problem.scene(r2, dd, pressure, loaded=(state == "loaded"))
        for f in assess_angles(scene, [math.radians(v) for v in degrees], pressure):
            out.append({**f.to_dict(), "state": state, "message": f"{result.method} design, {state} state: {f.message}"})
    return out


#: ``esba.design.METHODS`` and ``esba.design.OBJECTIVES`` (written out so that building the parser
#: does not import CasADi; a test checks they agree).
_DESIGN_METHODS = ("ipopt", "pso", "both")
_DESIGN_OBJECTIVES = ("stiffness", "angle", "pressure")


def _add_design(sub) -> None:
    p = sub.add_parser("design", help="optimise the chamber (r2, d): IPOPT on the full-space NLP, PSO as in the paper")
    p.add_argument("--segments", "-n", type=_segments, default=3, help="segment count n, 1 to 256 (default 3)")
    p.add_argument("--method", choices=_DESIGN_METHODS, default=None, help="ipopt (default), pso, or both side by side")
    p.add_argument("--objective", choices=_DESIGN_OBJECTIVES, default=None, help="maximise the stiffness (default), the free angle at --max-pressure, or minimise the pressure for --target-angle")
    p.add_argument("--min-stiffness", type=_float_arg, metavar="K", help="K >= K N/m (required by angle and pressure)")
    p.add_argument("--max-pressure", type=_float_arg, metavar="P", help="pressure budget, MPa (the pressure of the free angle for --objective angle)")
    p.add_argument("--target-angle", type=_float_arg, metavar="DEG", help="target unloaded angle of --objective pressure (default 90)")
    p.add_argument("--min-wall", type=_float_arg, default=None, metavar="T", help="thinnest wall r1 - r2 - d, mm (default 0: r2 + d < r1)")
    p.add_argument("--variant", choices=VARIANTS, default=None, help=f"model variant (default {DEFAULT_VARIANT})")
    p.add_argument("--seed", type=_count("seed", 0, 2**32 - 1), default=None, help="PSO seed (default 0)")
    p.add_argument("--particles", type=_count("particles", 2, 500_000, "particles x (iterations + 1) is at most 1000000"), default=None, help="PSO swarm size (default 30, the paper's)")
    p.add_argument("--iterations", type=_count("iterations", 1, 500_000, "particles x (iterations + 1) is at most 1000000"), default=None, help="PSO iterations (default 50, the paper's)")
    p.add_argument("--starts", type=_count("starts", 1, 8), default=None, help="IPOPT starts (1 to 8, default 4)")
    p.add_argument("--plot", metavar="FILE|DIR", help="write the stiffness map with the design(s) (and the swarm); a folder gets esba-design.png")
    p.add_argument("--write-doc", metavar="FILE", help="run the whole study (both methods, every problem; minutes) and write it, e.g. docs/design.md")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_design)


# ---------------------------------------------------------------------------------------------
# studies on Dask (issue 11): --workers, --scheduler (esba.distributed)


def _checked(check: Callable) -> Callable[[str], object]:
    """An argparse type from a check of :mod:`esba.distributed` (imports no Dask)."""

    def parse(text: str):
        from esba.distributed import DistributedError

        try:
            return check(text, flag=None)
        except DistributedError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    return parse


def _workers_arg(text: str) -> int:
    from esba.distributed import check_workers

    return _checked(check_workers)(text)


def _scheduler_arg(text: str) -> str:
    from esba.distributed import check_address

    return _checked(check_address)(text)


def _timeout_arg(text: str) -> float:
    from esba.distributed import check_timeout

    return _checked(check_timeout)(text)


def _chunk_arg(text: str) -> int:
    from esba.study import MAX_CHUNK

    try:
        value = int(text)
    except ValueError:
        value = 0
    if not 1 <= value <= MAX_CHUNK:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a whole number of points per chunk from 1 to {MAX_CHUNK}")
    return value


def _add_cluster_flags(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--workers", type=_workers_arg, metavar="N", help=f"solve {what} on a local Dask cluster of N worker processes (the esba[dask] extra)")
    p.add_argument("--scheduler", type=_scheduler_arg, metavar="ADDRESS", help=f"solve {what} on the Dask cluster of the scheduler at ADDRESS (tcp://HOST:PORT)")
    p.add_argument("--connect-timeout", type=_timeout_arg, default=10.0, metavar="S", help="seconds to wait for --scheduler and its first worker (default 10)")


def _on_cluster(args: argparse.Namespace) -> bool:
    """Whether the study runs on Dask; checks --workers, --scheduler and the extra before any computation."""
    if args.workers is not None and args.scheduler is not None:
        raise UsageError("--workers N starts a local cluster and --scheduler ADDRESS uses an existing one: give one of the two")
    if args.workers is None and args.scheduler is None:
        return False
    from esba.distributed import DistributedError, require_dask

    try:
        require_dask("--workers" if args.workers is not None else "--scheduler")
    except DistributedError as exc:
        raise UsageError(str(exc)) from None
    return True


# ---------------------------------------------------------------------------------------------
# esba sweep (issue 5): grids on the batch path


def _values_arg(text: str) -> list[float]:
    from esba.sweep import SweepError, parse_values

    try:
        return parse_values(text)
    except SweepError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _sweep_table(d: dict) -> str:
    lines = [f"base: {d['base']}", "axes: " + "; ".join(f"{k} {v['values']} {v['unit']}" for k, v in d["axes"].items())]
    lines.append(f"points: {d['counts']}; {d['backend']}")
    st = d.get("study")
    if st:
        resumed = f", resumed at row {st['resumed_from_row']}" if st["resumed_from_row"] else ""
        lines.append(f"study: {st['chunks_solved']} chunks of up to {st['chunk']} points {st['runner']} in {st['seconds']:.1f} s{resumed}")
    rows = d.get("rows")

    def num(v, fmt: str) -> str:
        return "-" if v is None else format(v, fmt)

    if rows is not None and len(rows) <= 60:
        head = f"{'P MPa':>9} {'F N':>6} {'Om deg':>7} {'r2':>6} {'d':>6} {'angle deg':>10} {'tip x, y mm':>18}  status"
        lines.append(head)
        for r in rows:
            ang = "" if r["total_angle_deg"] is None else f"{r['total_angle_deg']:10.3f}"
            tip = "" if r["tip_x_mm"] is None else f"{r['tip_x_mm']:8.2f}, {r['tip_y_mm']:8.2f}"
            lines.append(f"{num(r['pressure_mpa'], '9.5f'):>9} {num(r['payload_n'], '6.3g'):>6} {num(r['payload_angle_deg'], '7.3g'):>7} "
                         f"{num(r['r2_mm'], '6.3g'):>6} {num(r['d_mm'], '6.3g'):>6} {ang:>10} {tip:>18}  {r['status']}")
    else:
        total = sum(d["counts"].values())
        lines.append(f"{total} rows" + (f" in {d['out']}" if d.get("out") else ": write them with --out FILE.csv or FILE.json"))
    for k in ("out", "figure"):
        if d.get(k):
            lines.append(f"wrote {d[k]}")
    return "\n".join(lines)


def _cmd_sweep(args: argparse.Namespace) -> int:
    from esba.batch import BatchOptions
    from esba.plots import save_figure
    from esba.scene import Scene
    from esba.sweep import fig12, sweep, sweep_figure

    if args.fig12:
        _refuse(args, ["pressure", "payload", "payload_angle", "r2", "d", "target_angle", "out", "plot"], "with --fig12 (it draws its own grid: r2 and d at P = 0.2 MPa, no payload)")
        figure = outputs.figure_file(args.fig12, "--fig12", "sweep-fig12.png")
        out = None
    else:
        if args.pressure is not None:
            _refuse(args, ["target_angle"], "with --pressure (it sets the pressure of designs swept without --pressure)")
        out = outputs.check_file(args.out, "--out", (".csv", ".json")) if args.out else None
        figure = outputs.figure_file(args.plot, "--plot", "esba-sweep.png") if args.plot else None
    base = _load_scene(args.scene, None) or Scene()
    changes = _scene_changes(args, skip=("pressure",))
    base = base.replace(**changes) if changes else base
    options = BatchOptions(compile="never" if args.no_compile else "auto", progress=not (args.json or args.no_progress))
    if _on_cluster(args) or args.resume:
        return _sweep_in_chunks(args, base, options, out, figure)
    if args.fig12:
        fig, sweeps = fig12(base.replace(pressure=0.2, payloads=()), options=options)
        path = save_figure(fig, figure)
        curves = [s for group in sweeps.values() for s in group]
        bad = sum(int((s.status == "not ok").sum()) for s in curves)
        data = {"figure": str(path), "curves": len(curves), "points": sum(len(s.status) for s in curves), "not_ok": bad}
        _emit(args, data, lambda d: f"wrote {d['figure']}: {d['curves']} curves, {d['points']} points, {d['not_ok']} not ok")
        return EXIT_OK if bad == 0 else EXIT_FAILED
    result = sweep(base, pressure=args.pressure, payload=args.payload, payload_angle=args.payload_angle, r2=args.r2, d=args.d, options=options)
    if figure is not None:
        drawn = sweep_figure(result)  # refuses a figure with too many curves before anything is written
    data = result.to_dict()
    if out is not None:
        data["out"] = str(result.write(out))
    if figure is not None:
        data["figure"] = str(save_figure(drawn, figure))
    _emit(args, data, _sweep_table)
    _warn_sweep(result.validity)
    if data["counts"]["not ok"]:
        print(f"esba: {data['counts']['not ok']} point(s) not ok: see their status and message", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _warn_sweep(validity, outside: int = 0, out: str | None = None) -> None:
    """One ``esba: warning:`` line per kind of finding of a sweep's points (per-point
    :mod:`esba.validity` findings), or their count when the rows were streamed to ``out``."""
    found = [f for point in validity for f in point]
    for check in dict.fromkeys(f.check for f in found):
        first = next(f for f in found if f.check == check)
        count = sum(1 for point in validity if any(f.check == check for f in point))
        print(f"esba: warning: {count} point(s) outside the model's range, e.g. {first.message}", file=sys.stderr)
    if not validity and outside:
        print(f"esba: warning: {outside} point(s) outside the model's range: see the validity column of {out}", file=sys.stderr)


def _sweep_in_chunks(args: argparse.Namespace, base, options, out: str | None, figure) -> int:
    """``esba sweep`` chunk by chunk (--workers, --scheduler, --resume): esba.sweep_study."""
    from esba.distributed import DistributedError, open_runner
    from esba.plots import save_figure
    from esba.scene import SceneError
    from esba.study import StudyError
    from esba.sweep import SweepError, plan_sweep, sweep_figure
    from esba.sweep_study import sweep_study

    if args.fig12:
        raise UsageError("--fig12 draws its own small grid in this process: give it without --workers, --scheduler or --resume")
    out = None if out is None else str(out)
    streamed = out is not None and out.lower().endswith(".csv")
    if args.resume and not streamed:
        raise UsageError(f"--resume continues a study from the CSV file it streams to: give --out FILE.csv (given: {out!r})")
    if args.plot and streamed:
        raise UsageError("--plot needs every row in memory, and with --out FILE.csv on --workers, --scheduler or --resume the rows stream to the file: plot in a run without them")
    try:
        plan = plan_sweep(base, pressure=args.pressure, payload=args.payload, payload_angle=args.payload_angle, r2=args.r2, d=args.d)
    except (SweepError, SceneError) as exc:
        raise UsageError(str(exc)) from None
    try:
        with open_runner(args.workers, args.scheduler, args.connect_timeout) as runner:
            study = sweep_study(plan, options, runner=runner, chunk=args.chunk, out=out if streamed else None, resume=args.resume, progress=options.progress)
    except (DistributedError, StudyError) as exc:
        raise UsageError(str(exc)) from None
    except KeyboardInterrupt:
        where = f": the rows solved so far are in {out}; rerun with --resume to go on" if streamed else ""
        print(f"esba: interrupted{where}", file=sys.stderr)
        return 130
    # streamed rows stay in the file (a study may not fit in memory); a small grid's table reads them back
    data = study.to_dict(rows=not streamed or (plan.size <= 60 and not args.json))
    if streamed:
        data["out"] = out
    elif out is not None:
        data["out"] = str(study.result.write(out))
    if args.plot:
        try:
            data["figure"] = str(save_figure(sweep_figure(study.result), figure))
        except SweepError as exc:
            raise UsageError(str(exc)) from None
    _emit(args, data, _sweep_table)
    _warn_sweep(study.result.validity if study.result is not None else (), study.outside, out)
    if data["counts"]["not ok"]:
        print(f"esba: {data['counts']['not ok']} point(s) not ok: see their status and message", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _add_sweep(sub) -> None:
    p = sub.add_parser("sweep", help="solve a grid over pressure, payload, r2, d as one batch; CSV/JSON out; Fig. 12")
    p.add_argument("scene", nargs="?", default=None, metavar="SCENE.toml", help="base scene (default: Table 1 at its 90 degree pressure, no payload, n = 3)")
    values = "VALUES: start:stop:count or v1,v2,..."
    p.add_argument("--pressure", type=_values_arg, metavar="VALUES", help=f"pressures, MPa ({values}; default: the base scene's)")
    p.add_argument("--payload", type=_values_arg, metavar="VALUES", help="tip payload magnitudes, N (one payload, horizontal unless --payload-angle)")
    p.add_argument("--payload-angle", type=_values_arg, metavar="VALUES", help="payload directions Omega from the vertical, degrees")
    p.add_argument("--r2", type=_values_arg, metavar="VALUES", help="chamber radii, mm")
    p.add_argument("--d", type=_values_arg, metavar="VALUES", help="eccentric distances, mm")
    p.add_argument("--segments", "-n", type=_segments, help="segment count n, 1 to 256")
    p.add_argument("--target-angle", type=_float_arg, metavar="DEG", help="without --pressure: each design at the pressure that bends it unloaded to DEG")
    p.add_argument("--gravity", action="store_true", help="include the actuator's weight (Eq. 15)")
    p.add_argument("--no-fibres", action="store_true", help="leave out the fibre restraint (Eq. 18)")
    p.add_argument("--variant", choices=VARIANTS, default=None, help="model variant")
    p.add_argument("--out", metavar="FILE", help="write every point to FILE.csv or FILE.json (no file is written by default)")
    p.add_argument("--plot", metavar="FILE|DIR", help="total angle against the first swept axis, one curve per other value (a folder gets esba-sweep.png)")
    p.add_argument("--fig12", metavar="FILE|DIR", help="write the paper's Fig. 12 (angle vs r2 for d = 0, 2, 4, 6; vs d for r2 = 2, 4, 6; P = 0.2 MPa)")
    p.add_argument("--no-compile", action="store_true", help="use CasADi's interpreter, not compiled C")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print JSON (every row)")
    _add_cluster_flags(p, "the grid")
    p.add_argument("--chunk", type=_chunk_arg, default=1000, metavar="K", help="points per chunk with --workers, --scheduler or --resume (default 1000)")
    p.add_argument("--resume", action="store_true", help="stream the rows chunk by chunk to --out FILE.csv and continue the study that file holds (a new one if there is none)")
    p.set_defaults(func=_cmd_sweep)


# ---------------------------------------------------------------------------------------------
# esba path (issue 8): branches, special points, hysteresis

#: Where ``esba path`` writes its branches and figure unless told otherwise (the current folder).
DEFAULT_PATH_OUT = "esba-path.csv"
DEFAULT_PATH_FIGURE = "esba-path.png"

#: The parameters of ``esba path --param`` (``esba.path_problem.PARAMETERS``, written out so that
#: building the parser does not import CasADi; a test checks they agree).
_PATH_PARAMETERS = ("pressure", "payload", "omega", "at", "load", "r2", "d", "rho", "E", "L", "r1", "M")


def _path_table(d: dict) -> str:
    unit = d["unit"].split(" ")[0]
    unit = "" if unit == "1" else f" {unit}"
    lines = [f"scene: {d['scene']}", f"path in {d['parameter']} from {d['from']:g} to {d['to']:g}{unit}"]
    head = f"  {'':2} {'point':<13} {d['parameter'] + unit:>16} {'angle deg':>10} {'tip x, y mm':>17}  {'Morse':>5}  status"
    for b in d["branches"]:
        lines.append(f"{b['label'] or 'branch'}: {b['points']} points; {b['stop_reason']}")
        if b["special_points"]:
            lines.append(head)
        for sp in b["special_points"]:
            tip = f"{sp['tip_mm'][0]:7.2f}, {sp['tip_mm'][1]:7.2f}"
            lines.append(
                f"  {sp['label']:2} {sp['kind']:<13} {sp['lambda']:16.9g} {sp['total_angle_deg']:10.3f} {tip:>17}  "
                f"{sp['morse_before']} -> {sp['morse_after']}  {sp['status']}"
            )
    for r in d["loading"]:
        what = f"quasi-static {d['parameter']} {r['from']:g} -> {r['to']:g}{unit}"
        for lam in r["branch_points_crossed"]:
            lines.append(f"{what}: passes the branch point {lam:.9g}{unit} and goes on along the stable branch crossing there")
        if not r["jumps"]:
            lines.append(f"{what}: no jump" + ("" if r["reached"] else f"; NOT reached: {r['message']}"))
        for j in r["jumps"]:
            lines.append(
                f"{what}: jumps at the {j['kind']} {j['lambda']:.9g}{unit}: angle {j['total_angle_before_deg']:.2f} -> "
                f"{j['total_angle_after_deg']:.2f} deg, tip moves {j['distance_mm']:.1f} mm"
            )
    if d.get("hysteresis"):
        h = d["hysteresis"]
        lines.append(f"hysteresis: up jumps at {h['up'][0]:.9g}, down at {h['down'][-1]:.9g}{unit}; width {h['width']:.6g}{unit}")
    for k in ("out", "figure"):
        if d.get(k):
            lines.append(f"wrote {d[k]}")
    return "\n".join(lines)


def _path_write_doc(args: argparse.Namespace) -> int:
    """``esba path --write-doc FILE``: the whole study of docs/paths.md (no other path flags)."""
    given = [flag for flag, v in (("--to", args.to), ("--from", args.start), ("--out", args.out), ("--plot", args.plot), ("SCENE.toml", args.scene)) if v is not None]
    if given:
        raise UsageError(f"--write-doc runs its own studies of the Table 1 actuator: give no {', '.join(given)} with it")
    outputs.check_file(args.write_doc, "--write-doc", (".md",))
    from esba.paths_report import paths_data, write_page

    def say(msg):
        if not args.json:
            print(f"  {msg}", file=sys.stderr)

    data = paths_data(progress=say)
    page = write_page(args.write_doc, data, f"esba path --write-doc {args.write_doc}")
    _emit(args, {"page": str(page.resolve())}, lambda d: f"wrote {d['page']}")
    return EXIT_OK


def _cmd_path(args: argparse.Namespace) -> int:
    import math

    if args.write_doc:
        return _path_write_doc(args)
    if args.to is None:
        raise UsageError("the following arguments are required: --to")
    if not math.isfinite(args.to):
        raise UsageError(f"--to {args.to!r}: expected the finite value of --param to trace to")
    out = None if args.no_out else outputs.check_file(args.out or DEFAULT_PATH_OUT, "--out", (".csv", ".json"))
    plot = None if args.no_plot else outputs.figure_file(args.plot or DEFAULT_PATH_FIGURE, "--plot", DEFAULT_PATH_FIGURE)
    from esba.equilibrium import EquilibriumError
    from esba.path import PathOptions, write_branches
    from esba.path_problem import PathError
    from esba.path_study import study

    scene = _scene_from_args(args)
    param = args.param
    if args.payload_index != 1:
        if param not in ("payload", "omega", "at"):
            raise UsageError(f"--payload-index {args.payload_index}: only means something with --param payload, omega or at")
        param = f"{param}{args.payload_index}"
    try:
        options = PathOptions(locate=args.locate, max_steps=args.max_steps, ds_max=args.ds_max, ds=min(0.05, args.ds_max))
        result = study(scene, param, args.to, start=args.start, options=options, switch=not args.no_switch, loading=not args.no_loading)
    except PathError as exc:
        raise UsageError(str(exc)) from None
    except EquilibriumError as exc:
        print(f"esba: failed: {exc}", file=sys.stderr)
        return EXIT_FAILED
    data = result.to_dict(points=bool(args.json and args.points))
    if out:
        extra = {k: v for k, v in result.to_dict(points=False).items() if k != "branches"}
        data["out"] = str(write_branches(result.branches, out, extra).resolve())
    if plot:
        from esba.path_figures import save_figure, study_figure

        data["figure"] = str(save_figure(study_figure(result, args.y), plot).resolve())
    _emit(args, data, _path_table)
    _warn(data["validity"])
    reached = result.main.stopped == "loop" or (len(result.main) and result.main.lam[-1] == args.to)
    if not reached:
        print(f"esba: the branch did not reach --to {args.to:g}: {result.main.stop_reason}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _add_path(sub) -> None:
    p = sub.add_parser(
        "path",
        help="trace the equilibria as one parameter changes: folds, branch points, stability, hysteresis (CSV/JSON, figure)",
    )
    _add_scene_flags(p)
    p.add_argument("--param", choices=_PATH_PARAMETERS, default="pressure", help="the parameter to follow (default pressure; payload, omega and at are payload 1's: use --payload-index for another)")
    p.add_argument("--payload-index", type=_count("--payload-index", 1, 16, "a model carries at most 16 payloads"), default=1, metavar="K", help="which payload --param payload/omega/at means (default 1)")
    p.add_argument("--to", type=_float_arg, metavar="VALUE", help="trace to this value (MPa, N, deg, mm, ... as the parameter; required)")
    p.add_argument("--from", dest="start", type=_float_arg, metavar="VALUE", help="start here (default: the scene's own value)")
    p.add_argument("--locate", choices=("extended", "bisection"), default="extended", help="how folds are located (default: the extended system)")
    p.add_argument("--max-steps", type=_count("--max-steps", 1, 1_000_000, "each step stores a point"), default=2000, metavar="N", help="steps per branch (default 2000, at most 1000000)")
    p.add_argument("--ds-max", type=_float_arg, default=0.1, metavar="DS", help="largest step in the scaled arclength (default 0.1)")
    p.add_argument("--no-switch", action="store_true", help="do not trace the branches crossing at branch points")
    p.add_argument("--no-loading", action="store_true", help="do not follow quasi-static loading up and down (the hysteresis)")
    p.add_argument("--y", choices=("total-angle", "tip-x", "tip-y"), default="total-angle", help="what the figure shows against the parameter")
    p.add_argument("--out", metavar="FILE", help=f"the branches as CSV or JSON (default {DEFAULT_PATH_OUT})")
    p.add_argument("--no-out", action="store_true", help="write no branch file")
    p.add_argument("--plot", metavar="FILE", help=f"the figure (default {DEFAULT_PATH_FIGURE})")
    p.add_argument("--no-plot", action="store_true", help="write no figure")
    p.add_argument("--points", action="store_true", help="with --json: print every point, not only the special ones")
    p.add_argument("--write-doc", metavar="FILE", help="run the studies of docs/paths.md (Table 1: bistable ranges, buckling for n = 1..8) and write the page and its figures (about a minute)")
    p.set_defaults(func=_cmd_path)


# ---------------------------------------------------------------------------------------------
# esba fit (issue 10): parameters from measurements


def _output_file(*suffixes: str) -> Callable[[str], str]:
    """An argparse type for a file to write (:func:`esba.outputs.check_file`), checked when the flags are
    parsed, before any computation."""

    def check(text: str) -> str:
        try:
            outputs.check_file(text, "file", suffixes)
        except outputs.OutputError as exc:
            raise argparse.ArgumentTypeError(str(exc).removeprefix("file ")) from None
        return text

    return check


def _free_arg(text: str) -> list[str]:
    names = [s.strip() for s in text.split(",") if s.strip()]
    if not names:
        raise argparse.ArgumentTypeError(f"{text!r}: expected names such as E,rho")
    return names


def _level_arg(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a confidence level between 0 and 1 (0.95 for 95 %)")
    return value


def _fit_table(d: dict) -> str:
    def num(v, fmt=".5g"):
        return "-" if v is None else format(v, fmt)

    level = round(100 * d["level"])
    lines = [
        f"fit of {', '.join(d['parameters'])} to {d['measurements']} measured values in {d['rows']} rows of {d['source']}; "
        f"n = {d['segments']}, {d['variant']}",
        f"status: {d['status']}" + (f": {d['message']}" if d["message"] else ": every fitted state a stable minimum on its load path")
        + f" (IPOPT {d['iterations']} iterations, {d['solve_time_s']:.2f} s)",
        f"{'parameter':<10} {'unit':<5} {'start':>10} {'estimate':>12} {'std error':>11} {level} % interval",
    ]
    for name, p in d["parameters"].items():
        iv = p[f"interval_{level}"]
        lines.append(f"{name:<10} {p['unit']:<5} {num(p['start']):>10} {num(p['estimate'], '.6g'):>12} {num(p['std_error'], '.3g'):>11} "
                     f"[{num(iv[0], '.5g')}, {num(iv[1], '.5g')}]")
    names = list(d["parameters"])
    if len(names) > 1:
        pairs = [f"{a}-{b} {num(d['correlation'][i][j], '+.3f')}" for i, a in enumerate(names) for j, b in enumerate(names) if j > i]
        lines.append("correlation: " + ", ".join(pairs))
    lines.append(f"residual variance s^2 = {num(d['residual_variance'], '.4g')} ({d['dof']} degrees of freedom; "
                 "standard errors scaled by it)")
    lines.append(f"{'row':<22} {'quantity':<12} {'measured':>10} {'predicted':>10} {'residual':>10} {'sd':>7} {'r / sd':>7}")
    for r in d["residuals"]:
        sd = f"{r['sd']:.3g}" + ("" if r["sd_given"] else "*")
        lines.append(f"{r['row'][:22]:<22} {r['quantity']:<12} {r['measured']:>10.4g} {r['predicted']:>10.4g} {r['residual']:>+10.3g} "
                     f"{sd:>7} {r['normalised']:>+7.2f}")
    if any(not r["sd_given"] for r in d["residuals"]):
        lines.append("* no standard deviation given: 1 deg, 1 mm or 1 N/m assumed (only their ratios matter once scaled by s^2)")
    for s in d["states"]:
        if s["message"]:
            lines.append(f"NOT OK: row {s['row']!r}: {s['message']}")
    for w in d["warnings"]:
        lines.append(f"WARNING: {w}")
    if d.get("figure"):
        lines.append(f"wrote {d['figure']}")
    return "\n".join(lines)


def _cmd_fit(args: argparse.Namespace) -> int:
    from esba.fit import FitError, FitOptions, fit, predict
    from esba.measurements import MeasurementError, load_measurements
    from esba.scene import SceneError, load_scene

    try:
        base = load_scene(args.scene) if args.scene else None
        data = load_measurements(args.measurements, base)
        changes = {k: v for k, v in (("segments", args.segments), ("variant", args.variant)) if v is not None}
        if changes:  # the flags override the scene (the file's [scene], --scene or Table 1)
            data = load_measurements(args.measurements, data.base.replace(**changes))
        result = fit(data, args.free, FitOptions(level=args.level))
    except (MeasurementError, FitError, SceneError) as exc:
        raise UsageError(str(exc)) from None
    out = result.to_dict()
    if args.plot:
        from esba.fit_plots import Series, measured_vs_predicted, save_figure

        sds = {(r["row"], r["quantity"]): r["sd"] for r in out["residuals"] if r["sd_given"]}
        start = predict(data)
        cov = result.covariance if all(math.isfinite(v) for v in result.covariance.ravel()) else None
        fitted = predict(data, result.params(), cov)
        fig = measured_vs_predicted([
            Series("start: " + ", ".join(f"{n} = {v:g}" for n, v in zip(result.free, result.start)), start, sds, "s", "0.5"),
            Series("fitted: " + ", ".join(f"{n} = {v:.4g}" for n, v in result.params().items()) + " (95 %)", fitted, sds, "o", "C0"),
        ], title=f"{data.source}: measured against predicted")
        try:
            out["figure"] = str(save_figure(fig, args.plot).resolve())
        except OSError as exc:
            raise UsageError(f"--plot {args.plot!r}: cannot write: {exc}") from None
    _emit(args, out, _fit_table)
    for w in result.warnings:
        if w.startswith("not identifiable"):
            print(f"esba: warning: {w}", file=sys.stderr)
    if not result.ok:
        print(f"esba: fit failed: {result.message}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _add_fit(sub) -> None:
    p = sub.add_parser("fit", help="fit actuator parameters (E, rho, ...) to a measurement file; intervals, correlations, residuals")
    p.add_argument("measurements", metavar="MEASUREMENTS", help="measurement file, .csv or .toml (see esba/measurements.py for the columns)")
    p.add_argument("--scene", metavar="SCENE.toml", help="the actuator and model of the rows (default: the file's [scene], else Table 1, n = 3)")
    p.add_argument("--free", type=_free_arg, default=["E", "rho"], metavar="NAMES", help="parameters to fit, comma-separated (default E,rho; any of L,r1,r2,d,rho,E,M)")
    p.add_argument("--segments", "-n", type=_segments, help="segment count n >= 1 (overrides the scene's)")
    p.add_argument("--variant", choices=VARIANTS, default=None, help="model variant (overrides the scene's)")
    p.add_argument("--level", type=_level_arg, default=0.95, help="confidence level of the intervals (default 0.95)")
    p.add_argument("--plot", type=_output_file(".png", ".pdf", ".svg"), metavar="FILE", help="write measured against predicted, with error bars (.png, .pdf, .svg)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_fit)


# ---------------------------------------------------------------------------------------------
# esba experiments (issue 10): the paper's EXP and FEM values, docs/experiments.md


def _experiments_table(d: dict) -> str:
    lines = [f"{'column':<6} {'measurement':<22} {'quantity':<12} {'paper':>9} {'esba':>9} {'esba - paper':>13}"]
    for col in d["columns"]:
        for p in col["nominal"]:
            lines.append(f"{col['name']:<6} {p['row'][:22]:<22} {p['quantity']:<12} {p['measured']:>9.4g} {p['predicted']:>9.4g} {p['error']:>+13.3f}")
    for col in d["columns"]:
        for key in ("fit_e", "fit_both"):
            f = col[key]
            est = ", ".join(f"{n} = {v['estimate']:.5g} +- {'-' if v['std_error'] is None else format(v['std_error'], '.2g')} {v['unit']}"
                            for n, v in f["parameters"].items())
            lines.append(f"{col['name']} fit: {est}" + (f" ({'; '.join(f['warnings'])})" if f["warnings"] else ""))
    lines.append(f"E +-20 % on the main job: {d['modulus']['verdict']}")
    if d.get("page"):
        lines.append(f"wrote {d['page']} and its figure")
    return "\n".join(lines)


def _cmd_experiments(args: argparse.Namespace) -> int:
    from esba import experiments_page

    if args.check:
        if experiments_page.check_page(args.check):
            print(f"esba: {args.check} is stale: run `{experiments_page.DOC_COMMAND}` and commit it", file=sys.stderr)
            return EXIT_FAILED
        print("experiments page is up to date")
        return EXIT_OK
    from esba.experiments import run_study

    study = run_study()
    data = {
        "columns": [
            {"name": c.name, "nominal": [p.to_dict() for p in c.nominal], "fit_e": c.fit_e.to_dict(), "fit_both": c.fit_both.to_dict()}
            for c in study.columns
        ],
        "modulus": study.modulus_agreement.to_dict(),
    }
    if args.write_doc:
        try:
            path, _ = experiments_page.write_page(args.write_doc, study)
        except OSError as exc:
            raise UsageError(f"--write-doc {args.write_doc!r}: cannot write: {exc}") from None
        data["page"] = str(path)
    _emit(args, data, _experiments_table)
    return EXIT_OK


def _add_experiments(sub) -> None:
    p = sub.add_parser("experiments", help="the paper's EXP and FEM values against the model, fits and cross-validation (docs/experiments.md)")
    p.add_argument("--write-doc", type=_output_file(".md"), metavar="FILE", help="write the page (e.g. docs/experiments.md) and figures/experiments.png beside it")
    p.add_argument("--check", metavar="FILE", help="exit 1 when the page FILE differs from what --write-doc would write")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_experiments)


# ---------------------------------------------------------------------------------------------

#: Functions that add one subcommand each, in the order ``esba --help`` lists them.
COMMANDS: list[Callable] = [_add_generate, _add_audit, _add_solve, _add_path, _add_stiffness, _add_pressure, _add_validate, _add_sweep, _add_bench, _add_figures, _add_design, _add_fit, _add_experiments]


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="esba", description="Models of eccentric soft bending actuators (Yang et al.).")
    parser.add_argument("--version", action="version", version=f"esba {__version__}")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser)
    for add in COMMANDS:
        add(sub)
    return parser


def _input_error(exc: BaseException) -> bool:
    """An error class of esba's own that reports bad input (SceneError, OutputError, CacheError, ...)."""
    module = type(exc).__module__
    return isinstance(exc, ValueError) and (module.startswith("esba.") or module.startswith("derive."))


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text else type(exc).__name__


def _run(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if not getattr(args, "func", None):
            raise UsageError("name a command: " + ", ".join(sorted(parser._subparsers._group_actions[0].choices)))  # type: ignore[union-attr]
        return int(args.func(args))
    except Exception as exc:
        # an EquilibriumError can only come from esba.equilibrium once it is imported (--help never imports it)
        equilibrium = sys.modules.get("esba.equilibrium")
        if equilibrium is not None and isinstance(exc, equilibrium.EquilibriumError):
            print(f"esba: failed: {_first_line(exc)}", file=sys.stderr)
            return EXIT_FAILED
        if _input_error(exc):
            print(f"esba: error: {_first_line(exc)}", file=sys.stderr)
            return EXIT_USAGE
        if isinstance(exc, (BrokenPipeError, MemoryError)) or os.environ.get("ESBA_DEBUG"):
            raise
        print(
            f"esba: internal error: {type(exc).__name__}: {_first_line(exc)} (a bug: please report the command; "
            "ESBA_DEBUG=1 shows the traceback)",
            file=sys.stderr,
        )
        return EXIT_FAILED


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit code."""
    console.show_library_messages()
    try:
        return console.run(lambda: _run(argv))
    except KeyboardInterrupt:
        print("esba: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except MemoryError:
        print("esba: out of memory: ask for a smaller run", file=sys.stderr)
        return EXIT_FAILED


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

"""``esba fit`` and ``esba experiments``: parameters from measurements, the paper's EXP
and FEM values against the model."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from esba.derive.effects import VARIANTS
from esba.infra import outputs

from .arguments import UsageError, actuator_changes, add_actuator_flags, output_file_arg, segments_arg
from .results import EXIT_FAILED, EXIT_OK, print_result


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


def _has_scene_table(path: str) -> bool:
    """Does the TOML measurement file ``path`` carry a [scene] table? (False for CSV and unreadable files:
    those get their own message from load_measurements.)"""
    if not path.lower().endswith(".toml"):
        return False
    try:
        import tomllib
    except ImportError:  # pragma: no cover - Python 3.10
        import tomli as tomllib
    try:
        with open(path, "rb") as fh:
            return "scene" in tomllib.load(fh)
    except (OSError, ValueError):
        return False


def _cmd_fit(args: argparse.Namespace) -> int:
    from esba.calibration.fit import fit_table
    from esba.calibration.fit import FitError, FitOptions, fit, predict
    from esba.calibration.measurements import MeasurementError, load_measurements
    from esba.model.scene import SceneError, load_scene

    args.free_given = args.free is not None
    from esba.calibration.poses3d import is_3d

    if args.measurements.lower().endswith(".csv") and is_3d(args.measurements):  # a 3-D tracker's poses: EI_side, GJ (fit3d)
        from .estimate3d import run_fit3d

        try:
            from esba.model.scene import Scene

            base3 = load_scene(args.scene) if args.scene else Scene()
            changes = {k: v for k, v in (("segments", args.segments), ("variant", args.variant)) if v is not None}
            changes.update(actuator_changes(args))
            base3 = base3.replace(**changes) if changes else base3
        except SceneError as exc:
            raise UsageError(str(exc)) from None
        return run_fit3d(args, base3)
    if args.section:
        raise UsageError("--section is for a 3-D file (tip_z_mm, tip_R11..., psi1_deg, ...): this file is planar")
    if args.free is None:
        args.free = ["E", "rho"]
    try:
        base = load_scene(args.scene) if args.scene else None
        if base is not None and _has_scene_table(args.measurements):
            raise UsageError(f"--scene {args.scene}: {args.measurements} has a [scene] table of its own; give the actuator in one place")
        data = load_measurements(args.measurements, base)
        changes = {k: v for k, v in (("segments", args.segments), ("variant", args.variant)) if v is not None}
        changes.update(actuator_changes(args))
        if changes:  # the flags override the scene (the file's [scene], --scene or Table 1)
            data = load_measurements(args.measurements, data.base.replace(**changes))
        result = fit(data, args.free, FitOptions(level=args.level))
    except (MeasurementError, FitError, SceneError) as exc:
        raise UsageError(str(exc)) from None
    out = result.to_dict()
    if args.plot:
        from esba.figures.fit import Series, measured_vs_predicted, parameters_text, save_figure

        sds = {(r["row"], r["quantity"]): r["sd"] for r in out["residuals"] if r["sd_given"]}
        start = predict(data)
        cov = result.covariance if all(math.isfinite(v) for v in result.covariance.ravel()) else None
        fitted = predict(data, result.params(), cov)
        fig = measured_vs_predicted([
            Series("start: " + parameters_text(result.free, result.start, result.units), start, sds, "s", "0.5"),
            Series("fitted: " + parameters_text(result.free, result.estimate, result.units, result.std_error) + " (bars: 95 %)",
                   fitted, sds, "o", "C0", face="C0"),
        ], title=f"{data.source}: the model's error against each measured value")
        try:
            out["figure"] = str(save_figure(fig, args.plot).resolve())
        except OSError as exc:
            raise UsageError(f"--plot {args.plot!r}: cannot write: {exc}") from None
    print_result(args, out, fit_table)
    for w in result.warnings:
        if w.startswith("not identifiable"):
            print(f"esba: warning: {w}", file=sys.stderr)
    if not result.ok:
        print(f"esba: fit failed: {result.message}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def add_fit(sub) -> None:
    p = sub.add_parser("fit", help="fit actuator parameters (E, rho, ...) to a measurement file; intervals, correlations, residuals")
    p.add_argument("measurements", metavar="MEASUREMENTS", help="measurement file, .csv or .toml: one row a scene (pressure_mpa, _kpa or _bar, or target_angle_deg; payload_n, "
                   "payload_angle_deg, payload_at; the row's own L_mm, r1_mm, r2_mm, d_mm, rho_deg, E_mpa, M_kg) and what was measured "
                   "(total_angle_deg, tip_x_mm, tip_y_mm, stiffness_n_per_m, each with an optional <name>_sd_<unit>, e.g. "
                   "total_angle_sd_deg); TOML: one [[measurement]] table a row, and an optional [scene]")
    p.add_argument("--scene", metavar="SCENE.toml", help="the actuator and model of the rows (default: the file's [scene], else Table 1, n = 3)")
    p.add_argument("--free", type=_free_arg, default=None, metavar="NAMES",
                   help="parameters to fit, comma-separated (default E,rho; any of L,r1,r2,d,rho,E,M); a 3-D file: EI_side, GJ (default both)")
    p.add_argument("--section", action="append", metavar="NAME=VALUE", help="3-D file: the start values EI_side=..., GJ=... (N*mm^2; default the eccentric section's)")
    p.add_argument("--segments", "-n", type=segments_arg, help="segment count n >= 1 (overrides the scene's)")
    p.add_argument("--variant", choices=VARIANTS, default=None, help="model variant (overrides the scene's)")
    add_actuator_flags(p, note="; a row's own L_mm, E_mpa, ... still win for that row")
    p.add_argument("--level", type=_level_arg, default=0.95, help="confidence level of the intervals (default 0.95)")
    p.add_argument("--plot", type=output_file_arg(".png", ".pdf", ".svg"), metavar="FILE", help="write measured against predicted, with error bars (.png, .pdf, .svg)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_fit)


def _experiments_table(d: dict) -> str:
    lines = [f"{'column':<6} {'measurement':<22} {'quantity':<12} {'paper':>9} {'esba':>9} {'esba - paper':>13}"]
    for col in d["columns"]:
        for p in col["nominal"]:
            lines.append(f"{col['name']:<6} {p['row'][:22]:<22} {p['quantity']:<12} {p['measured']:>9.4g} {p['predicted']:>9.4g} {p['error']:>+13.3f}")
    for col in d["columns"]:
        for key in ("fit_e", "fit_both"):
            f = col[key]
            est = ", ".join(f"{n} = {v['estimate']:.5g} {v['unit']} (no standard error)" if v["std_error"] is None else
                            f"{n} = {v['estimate']:.5g} +- {v['std_error']:.2g} {v['unit']}"
                            for n, v in f["parameters"].items())
            lines.append(f"{col['name']} fit: {est}" + (f" ({'; '.join(f['warnings'])})" if f["warnings"] else ""))
    lines.append(f"E +-20 % on the main job: {d['modulus']['verdict']}")
    if d.get("page"):
        lines.append(f"wrote {d['page']} and its figure")
    return "\n".join(lines)


def _cmd_experiments(args: argparse.Namespace) -> int:
    from esba.pages.experiments import DOC_COMMAND, PAGE

    if args.check:
        if args.write_doc:
            raise UsageError("--check writes nothing: give the page to check as --check FILE, not --write-doc")
        page = outputs.default_page("experiments.md") if args.check is True else args.check
        check = PAGE.check(page)
        if not check.ok:
            again = DOC_COMMAND if Path(page).resolve() == outputs.default_page("experiments.md").resolve() else f"esba experiments --write-doc {page}"
            print(f"esba: {page} is {check.status}: run `{again}` and commit it", file=sys.stderr)
            return EXIT_FAILED
        print(f"{page} is up to date")
        return EXIT_OK
    if args.write_doc:
        outputs.check_file(args.write_doc, "--write-doc", (".md",))  # before the comparison runs
    comparison = PAGE.compute()
    data = {
        "columns": [
            {"name": c.name, "nominal": [p.to_dict() for p in c.nominal], "fit_e": c.fit_e.to_dict(), "fit_both": c.fit_both.to_dict()}
            for c in comparison.columns
        ],
        "modulus": comparison.modulus_agreement.to_dict(),
    }
    if args.write_doc:
        try:
            path = PAGE.write(args.write_doc, data=comparison).path
        except OSError as exc:
            raise UsageError(f"--write-doc {args.write_doc!r}: cannot write: {exc}") from None
        data["page"] = str(path)
    print_result(args, data, _experiments_table)
    return EXIT_OK


def add_experiments(sub) -> None:
    p = sub.add_parser("experiments", help="the paper's EXP and FEM values against the model, fits and cross-validation (docs/experiments.md)")
    p.add_argument("--write-doc", metavar="FILE", help="write the page (e.g. docs/experiments.md) and figures/experiments.png beside it")
    p.add_argument("--check", nargs="?", const=True, default=None, metavar="FILE",
                   help="write nothing; exit 1 when the page is stale (FILE, default docs/experiments.md in a checkout, else ./experiments.md)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_experiments)

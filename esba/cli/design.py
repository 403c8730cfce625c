"""``esba design``: the stiffest (r2, d) by IPOPT on the full-space NLP, and by PSO as the paper did."""

from __future__ import annotations

import argparse
import math
import sys

from esba.derive.effects import DEFAULT_VARIANT, VARIANTS
from esba.infra import outputs

from .arguments import UsageError, actuator_changes, add_actuator_flags, count_arg, float_arg, refuse, segments_arg
from .results import EXIT_FAILED, EXIT_OK, print_result, warn_findings


def _envelope_table(d: dict) -> str:
    def one(r: dict) -> list[str]:
        c = r["clearance"] or {}
        near = c.get("nearest_fold")
        where = "none up to twice the payload bound" if not near else (
            f"{near['kind']} at P = {near['pressure_mpa']:.6g} MPa, F = {near['payload_n']:.6g} N, Omega = {near.get('omega_deg', near['direction_deg']):.6g} deg"
            + (f", Beta = {near['beta_deg']:.6g} deg" if near.get("beta_deg") else "")
        )
        lines = [
            f"    status: {r['status']}" + (f": {r['message']}" if r.get("message") else ""),
            f"     r2, d: {r['r2_mm']:.5f}, {r['d_mm']:.5f} mm",
            f"  pressure: {r['pressure_mpa']:.6f} MPa (unloaded 90 deg)",
            f" stiffness: {r['stiffness_n_per_m']:.5f} N/m",
            f"      fold: nearest {where}; clear: {c.get('clear')} (c = {c.get('value') if c.get('value') is None else format(c['value'], '.3g')})",
            f"    active: {', '.join(r['active_constraints']) or 'none'}",
        ]
        if "sideways_value" in c:
            side = "none up to twice the payload bound" if c["sideways_payload_n"] is None else f"{c['sideways_payload_n']:.6g} N"
            lines.append(f"  sideways: loses stability sideways at {side} (c = {c['sideways_value'] if c['sideways_value'] is None else format(c['sideways_value'], '.3g')}); "
                         f"largest twist at the payload bound {c['twist_deg']:.4g} deg (c = {c['twist_value']:.3g}); section EI_side {c['section_nmm2']['EI_side']:.6g}, GJ {c['section_nmm2']['GJ']:.6g} N mm^2")
        lines += [
            f"      time: {r['solve_time_s']:.2f} s ({r['evaluations']} designs)",
        ]
        return lines

    first = d if d.get("method") != "both" else d["map"]
    u = first["unconstrained"]
    lines = [first["problem"], f"envelope: {d.get('envelope_text', '')}"]
    if u.get("clearance"):
        uc = u["clearance"]
        snap = "snaps inside the envelope" if uc["snaps_inside"] else ("is clear of folds" if uc["clear"] else "has a fold within the margin")
        lines.append(f"without the fold constraint (IPOPT): r2 = {u['r2_mm']:.5f}, d = {u['d_mm']:.5f} mm, K = {u['stiffness_n_per_m']:.5f} N/m: {snap}")
    for name in ("map", "pso") if d.get("method") == "both" else (d["method"],):
        r = d if d.get("method") != "both" else d[name]
        lines.append(f"-- {name}")
        lines += one(r)
    if d.get("method") == "both":
        diff = d["differences"]
        lines.append(f"-- PSO - map: r2 {diff['r2_mm']:+.2e} mm, d {diff['d_mm']:+.2e} mm, K {diff['stiffness_rel']:+.2e} (relative)")
    return "\n".join(lines)


def _cmd_envelope(args: argparse.Namespace) -> int:
    """``esba design --envelope-pressure P --envelope-payload F``: the stiffest design clear of folds."""
    from esba.design.envelope import Envelope, optimise_envelope
    from esba.design.problem import DesignError, DesignOptions, DesignProblem
    from esba.solvers.pso import PSOOptions, PSOOptionsError

    refuse(args, ["write_doc", "plot", "min_stiffness", "target_angle"], "with an operating envelope (it optimises the stiffness)")
    if args.objective not in (None, "stiffness"):
        raise UsageError(f"--objective {args.objective}: an operating envelope goes with the stiffness objective")
    if args.envelope_pressure is None or args.envelope_payload is None:
        raise UsageError("an operating envelope needs both --envelope-pressure P and --envelope-payload F")
    method = {"ipopt": "map", None: "map", "pso": "pso", "both": "both"}[args.method]
    try:
        envelope = Envelope(
            args.envelope_pressure, args.envelope_payload, tuple(args.envelope_angle or (90.0,)),
            1.0 if args.envelope_at is None else args.envelope_at, 0.1 if args.fold_margin is None else args.fold_margin,
        )
        problem = DesignProblem(segments=args.segments, variant=args.variant or DEFAULT_VARIANT, max_pressure=args.max_pressure, actuator=_design_actuator(args),
                                min_wall=0.0 if args.min_wall is None else args.min_wall)
        options = DesignOptions(starts=4 if args.starts is None else args.starts)
        pso_options = PSOOptions(particles=12 if args.particles is None else args.particles, iterations=15 if args.iterations is None else args.iterations,
                                 seed=0 if args.seed is None else args.seed)
    except (DesignError, PSOOptionsError) as exc:
        raise UsageError(str(exc)) from None
    spatial = None
    if args.cone is not None or args.max_twist is not None or args.section:
        from esba.design.spatial import SpatialEnvelope, optimise_envelope3d

        from .scenes import _section_arg

        section = _section_arg(args.section)
        try:
            spatial = SpatialEnvelope(envelope, 0.0 if args.cone is None else args.cone, 10.0 if args.max_twist is None else args.max_twist, section)
        except DesignError as exc:
            flag = "--cone" if "cone" in str(exc) else ("--max-twist" if "twist" in str(exc) else "--section")
            raise UsageError(f"{flag}: {exc}") from None
        run = optimise_envelope3d(problem, spatial, method, options, pso_options)
    else:
        run = optimise_envelope(problem, envelope, method, options, pso_options)
    if method == "both":
        m, p = run
        data = {"method": "both", "map": m.to_dict(), "pso": p.to_dict(),
                "differences": {"r2_mm": p.r2_mm - m.r2_mm, "d_mm": p.d_mm - m.d_mm, "stiffness_rel": (p.stiffness_n_per_m - m.stiffness_n_per_m) / m.stiffness_n_per_m}}
        results = [m, p]
    else:
        data, results = run.to_dict(), [run]
    data["envelope_text"] = envelope.describe() if spatial is None else spatial.describe()
    print_result(args, data, _envelope_table)
    bad = [r for r in results if r.status != "optimal"]
    for r in bad:
        print(f"esba: design {r.status} ({r.method}): {r.message}", file=sys.stderr)
    return EXIT_FAILED if bad else EXIT_OK


def _cmd_design(args: argparse.Namespace) -> int:
    if any(getattr(args, k) is not None for k in ("envelope_pressure", "envelope_payload", "envelope_angle", "envelope_at", "fold_margin", "cone", "max_twist", "section")):
        return _cmd_envelope(args)
    from esba.design.optimise import (
        DesignError,
        DesignOptions,
        DesignProblem,
        compare,
        design_table,
        optimise_ipopt,
        optimise_pso,
    )
    from esba.pages.design import PAGE, DesignSettings
    from esba.solvers.pso import PSOOptions, PSOOptionsError

    if args.write_doc:
        refuse(args, ["method", "objective", "min_stiffness", "max_pressure", "target_angle", "min_wall", "variant", "plot", *DESIGN_ACTUATOR],
               "with --write-doc (the page runs its own design cases)")
        page = outputs.check_file(args.write_doc, "--write-doc", (".md",))
    method = args.method or "ipopt"
    if method == "ipopt":
        refuse(args, ["particles", "iterations", "seed"], "with --method ipopt (they set the swarm: use --method pso or both)")
    if method == "pso":
        refuse(args, ["starts"], "with --method pso (it sets IPOPT's starts: use --method ipopt or both)")
    figure = outputs.figure_file(args.plot, "--plot", "esba-design.png") if args.plot is not None else None
    try:
        pso_options = PSOOptions(
            particles=30 if args.particles is None else args.particles,
            iterations=50 if args.iterations is None else args.iterations,
            seed=0 if args.seed is None else args.seed,
        )
        options = DesignOptions(starts=4 if args.starts is None else args.starts)
        if args.write_doc:
            path = PAGE.write(page, DesignSettings(args.segments, options, pso_options)).path
            print_result(args, {"page": str(path)}, lambda d: f"wrote {d['page']}")
            return EXIT_OK
        problem = DesignProblem(
            objective=args.objective or "stiffness",
            actuator=_design_actuator(args),
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
        from esba.figures.design import design_figure

        data["figure"] = str(design_figure(run, figure).resolve())
    print_result(args, data, design_table)
    for r, d in zip(results, [data] if method != "both" else [data["ipopt"], data["pso"]]):
        warn_findings(d["validity"])
    bad = [r for r in results if r.status != "optimal"]
    for r in bad:
        print(f"esba: design {r.status} ({r.method}): {r.message}", file=sys.stderr)
    return EXIT_FAILED if bad else EXIT_OK


def _design_validity(result, d: dict) -> list[dict]:
    """The validity findings (:mod:`esba.model.validity`) of each state of a design (its start and loaded states)."""

    from esba.model.validity import assess_angles

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


#: The actuator's fields a design holds fixed (flags as in a scene file's [actuator] table): the chamber
#: (r2, d) is what it designs, and the mass plays no part without gravity.
DESIGN_ACTUATOR = ("L", "r1", "rho_deg", "E")


def _design_actuator(args: argparse.Namespace):
    """Table 1's actuator with the flags of :data:`DESIGN_ACTUATOR`; its chamber is a placeholder
    that the design replaces (inside any r1: a quarter of it, concentric)."""
    from esba.model.scene import Actuator, SceneError

    fixed = actuator_changes(args, DESIGN_ACTUATOR)
    chamber = {"r2": fixed["r1"] / 4, "d": 0.0} if "r1" in fixed else {}
    try:
        return Actuator(**chamber, **fixed)
    except SceneError as exc:
        raise UsageError(str(exc)) from None


#: ``esba.design.optimise.METHODS`` and ``esba.design.optimise.OBJECTIVES`` (written out so that building the parser
#: does not import CasADi; a test checks they agree).
_DESIGN_METHODS = ("ipopt", "pso", "both")


_DESIGN_OBJECTIVES = ("stiffness", "angle", "pressure")


def add_design(sub) -> None:
    p = sub.add_parser("design", help="optimise the chamber (r2, d): IPOPT on the full-space NLP, PSO as in the paper")
    p.add_argument("--segments", "-n", type=segments_arg, default=3, help="segment count n, 1 to 256 (default 3)")
    p.add_argument("--method", choices=_DESIGN_METHODS, default=None, help="ipopt (default), pso, or both side by side")
    p.add_argument("--objective", choices=_DESIGN_OBJECTIVES, default=None, help="maximise the stiffness (default), the free angle at --max-pressure, or minimise the pressure for --target-angle")
    p.add_argument("--min-stiffness", type=float_arg, metavar="K", help="K >= K N/m (required by angle and pressure)")
    p.add_argument("--max-pressure", type=float_arg, metavar="P", help="pressure budget, MPa (the pressure of the free angle for --objective angle)")
    p.add_argument("--target-angle", type=float_arg, metavar="DEG", help="target unloaded angle of --objective pressure (default 90)")
    p.add_argument("--min-wall", type=float_arg, default=None, metavar="T", help="thinnest wall r1 - r2 - d, mm (default 0: r2 + d < r1)")
    p.add_argument("--variant", choices=VARIANTS, default=None, help=f"model variant (default {DEFAULT_VARIANT})")
    p.add_argument("--seed", type=count_arg("seed", 0, 2**32 - 1), default=None, help="PSO seed (default 0)")
    p.add_argument("--particles", type=count_arg("particles", 2, 500_000, "particles x (iterations + 1) is at most 1000000"), default=None, help="PSO swarm size (default 30, the paper's)")
    p.add_argument("--iterations", type=count_arg("iterations", 1, 500_000, "particles x (iterations + 1) is at most 1000000"), default=None, help="PSO iterations (default 50, the paper's)")
    p.add_argument("--starts", type=count_arg("starts", 1, 8), default=None, help="IPOPT starts (1 to 8, default 4)")
    p.add_argument("--plot", metavar="FILE|DIR", help="write the stiffness map with the design(s) (and the swarm); a folder gets esba-design.png")
    p.add_argument("--write-doc", metavar="FILE", help="run every design case of the page (both methods, every problem; about 5 s) and write it, e.g. docs/design.md")
    p.add_argument("--envelope-pressure", type=float_arg, metavar="P", help="operating envelope: pressures up to P MPa; with --envelope-payload, the stiffest design with no fold in the envelope (docs/maps.md)")
    p.add_argument("--envelope-payload", type=float_arg, metavar="F", help="operating envelope: tip payloads up to F N")
    p.add_argument("--envelope-angle", type=float_arg, action="append", metavar="DEG", help="a payload direction of the envelope, degrees from the vertical (repeatable; default 90)")
    p.add_argument("--envelope-at", type=float_arg, metavar="FRACTION", help="the envelope's payload point, a fraction of L (default 1, the tip)")
    p.add_argument("--fold-margin", type=float_arg, metavar="M", help="no fold up to (1 + M) times the envelope (default 0.1)")
    p.add_argument("--cone", type=float_arg, metavar="DEG", help="with an envelope: also no lateral-torsional buckling (3-D model) for payload directions within DEG of the envelope's (0 to 90; docs/design.md)")
    p.add_argument("--max-twist", type=float_arg, metavar="DEG", help="with an envelope: the twist |sum tau| at the payload bound at most DEG over the cone (default 10 with --cone)")
    p.add_argument("--section", action="append", metavar="NAME=VALUE", help="with --cone: section stiffnesses EI_side=..., GJ=... for every design (N*mm^2; default each design's eccentric section)")
    p.add_argument("--json", action="store_true", help="print JSON")
    add_actuator_flags(p, DESIGN_ACTUATOR, note="; the chamber r2, d is what the design finds")
    p.set_defaults(func=_cmd_design)

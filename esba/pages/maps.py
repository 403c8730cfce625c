"""The page ``docs/maps.md`` and its figures: the stability maps of the Table 1 actuator and the design
plane at an operating envelope (``esba map --write-doc docs/maps.md`` writes them; ``esba docs
--check maps`` says whether the committed page is stale).

Presentation only: the maps come from :func:`esba.analysis.map_cases.map_cases`, the design plane
from :func:`esba.design.envelope.design_plane`; nothing here traces a curve.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from esba.analysis.map3d_cases import GRIPPER, GRIPPER_COMMAND, PATH_PAYLOADS, PATH_RANGE, STIFF_SECTION, Map3DCases, map3d_cases
from esba.analysis.map_cases import MapCaseResult, map_cases
from esba.analysis.maps3d import BRUTE_STARTS, BRUTE_STEPS, CLASSES
from esba.analysis.maps import MAX_STARTS, STARTS_PER_SEGMENT
from esba.design.envelope import DesignPlane, Envelope, design_plane
from esba.figures.maps import design_plane_figure, map_figure

from .page import TIMES, Page, Progress, Rendered, Times

__all__ = ["PAGE", "MapsPage", "MapsSettings", "ENVELOPE", "FIGURES", "render_page"]

#: The operating envelope of the design plane: the paper's optimum (r2 = 1.5305 mm, d = 0) snaps inside it.
ENVELOPE = Envelope(0.3, 2.5, (90.0,), 1.0, 0.05)
#: The design plane's grid.
R2_GRID = tuple(float(v) for v in np.linspace(0.25, 7.75, 16))
D_GRID = tuple(float(v) for v in np.linspace(0.0, 7.5, 16))
#: The page's figures, in ``figures/`` beside it.
FIGURES = {"pressure-payload": "map-pressure-payload.png", "omega-payload": "map-omega-payload.png",
           "pressure-omega": "map-pressure-omega.png", "design": "map-design-plane.png", "gripper-3d": "map-3d-gripper.png"}


@dataclass(frozen=True, eq=False)
class MapsData:
    maps: list[MapCaseResult]
    design: DesignPlane
    spatial: Map3DCases


def _unit(u: str) -> str:
    return f" {u}" if u and u != "1" else ""


def _special_rows(r: MapCaseResult) -> list[str]:
    nx, ny = r.map.names
    ux, uy = r.map.plane.units
    rows = [f"| point | {nx} ({ux}) | {ny} ({uy}) | total angle (deg) | critical vector | status |", "|---|---|---|---|---|---|"]
    for p in r.map.special:
        vec = ", ".join(f"{v:.4f}" for v in p.vector)
        rows.append(f"| {p.kind} | {p.x:.10g} | {p.y:.10g} | {np.degrees(np.sum(p.theta)):.3f} | ({vec}) | {p.status} |")
    return rows


def _check_line(r: MapCaseResult) -> str:
    c = r.check
    agree = c.k * c.k - c.mismatches - c.near_mismatches
    counts = sorted({int(cell[3]) for cell in c.cells})
    return (
        f"Brute force (a damped Newton descent from {min(STARTS_PER_SEGMENT ** r.map.plane.n, MAX_STARTS)} starts at each cell centre, `esba.analysis.maps.stable_states`) on a "
        f"{c.k} x {c.k} grid finds {' or '.join(str(k) for k in counts)} stable state{'s' if counts[-1] != 1 else ''} per cell; the map agrees in **{agree} of {c.k * c.k}** cells"
        + (f" ({c.mismatches + c.near_mismatches} disagree)." if c.mismatches + c.near_mismatches else ".")
    )


def _jumps(r: MapCaseResult, which: str) -> list[list[float]]:
    return r.map.jumps.get(which, [])


def render_page(data: MapsData, command: str, times: Times = TIMES) -> str:
    fig = Path("figures")
    pp, op, po = data.maps
    cusp_pp = next(p for p in pp.map.special if p.kind == "cusp")
    cusp_op = next(p for p in op.map.special if p.kind == "cusp")
    bp_op = [p for p in op.map.special if p.kind == "branch point of the y-path"]
    cusps_po = [p for p in po.map.special if p.kind == "cusp"]
    lines = [
        "# Stability maps: where the actuator has one stable state, and where it snaps",
        "",
        f"<!-- Written by `{command}`; rerun it to refresh. -->",
        "",
        "`docs/paths.md` follows the equilibria of the Table 1 actuator (n = 3, variant `paper`) along one",
        "parameter at a time. A designer's question has two: over which pressures and payloads does the",
        "actuator have one stable state, and where does it snap? This page answers it by continuing the",
        "folds themselves in two parameters (`esba map`, `esba/analysis/folds.py`): the extended system",
        "g = 0, H v = 0, v0 . v = 1 (2n + 1 equations in theta, v and the two parameters) is followed by",
        "pseudo-arclength continuation, seeded at the folds that the path engine finds on one-parameter",
        "paths across the plane. Along each fold curve three test functions locate the codimension-two points",
        "to round-off (Brent's method on the curve's arclength, each point a converged solution of the",
        "extended system): a **cusp** (c = v . (d(Hv)/dtheta) v = 0: the two folds of a path are born",
        "together) and the points where the fold curve **meets a branch point** of a path in x or in y",
        "(v . dg/dy = 0: the curve is tangent to the path there, which folds twice on one side and not at",
        "all on the other).",
        "",
        "Each region is shaded by its number of stable states: counted once by brute force at a corner of",
        "the map and carried across the plane, +1 or -1 at each crossing of a *stable* fold curve (one that",
        "joins a stable and an unstable state) according to the side on which the fold's pair exists (its",
        "normal form). Solid black lines are the fold curves, stars the cusps, diamonds the fold/branch-point",
        "meetings; the triangles mark where the quasi-static history in x jumps, rising (right) and",
        "falling (left), at a set of values of y (`esba.paths.loading.history`).",
        "",
    ]
    # --- pressure-payload
    lines += [
        "## Pressure and horizontal tip payload",
        "",
        f"![{pp.case.title}]({fig / FIGURES['pressure-payload']})",
        "",
        f"`{pp.case.command}` draws this map.",
        "",
        "The bistable window opens at a cusp: below its payload every pressure has one stable state; above",
        "it a band of pressures has two, between the loading fold (where inflating snaps) and the unloading",
        "fold (where deflating snaps back).",
        "",
    ]
    lines += _special_rows(pp)
    lines += [
        "",
        f"The cusp lies at **F = {cusp_pp.y:.6f} N, P = {cusp_pp.x:.6f} MPa** (docs/paths.md found 1.645 N by",
        "bisection to 1e-3 N over repeated path traces). Its fold/branch-point neighbour is where the fold",
        "curve is tangent to a payload path (the pressure is extremal on the curve): the curve's axis is",
        "nearly parallel to the payload axis, so the two points almost coincide.",
        "",
        "The folds of the pressure paths in `docs/paths.md`, read off the fold curve (the extended system at",
        "the payload):",
        "",
        "| payload (N) | folds on the curve (MPa) |",
        "|---|---|",
    ]
    lines += [f"| {f:g} | {', '.join(f'{v:.8f}' for v in vals)} |" for f, vals in pp.lines.items()]
    lines += ["", _check_line(pp), ""]
    # --- omega-payload
    lines += [
        "## Payload direction and magnitude at the 90 degree pressure",
        "",
        f"![{op.case.title}]({fig / FIGURES['omega-payload']})",
        "",
        f"`{op.case.command}` draws this map.",
        "",
    ]
    lines += _special_rows(op)
    window = f"{bp_op[0].x:.4f} to {cusp_op.x:.4f} deg" if bp_op else "-"
    lines += [
        "",
        f"The bistable region opens at the cusp (**Omega = {cusp_op.x:.6f} deg, F = {cusp_op.y:.6f} N**).",
        ("Just above it the fold curve turns back in Omega at a branch point of the payload path "
         f"(**Omega = {bp_op[0].x:.6f} deg, F = {bp_op[0].y:.6f} N**): for directions in the window {window} a payload "
         "path from F = 0 folds twice, outside it not at all (the puzzle of `docs/paths.md` near 122.2 deg).") if bp_op else "",
        "",
        "Under 2 N the fold curve gives the folds of the direction path of `docs/paths.md`:",
        f"{', '.join(f'{v:.6f}' for v in op.lines.get(2.0, []))} deg.",
        "",
        _check_line(op),
        "",
    ]
    # --- pressure-omega
    lines += [
        "## Pressure and payload direction under 2 N",
        "",
        f"![{po.case.title}]({fig / FIGURES['pressure-omega']})",
        "",
        f"`{po.case.command}` draws this map.",
        "",
    ]
    lines += _special_rows(po)
    lines += [
        "",
        ("The bistable band closes at a cusp at **Omega = "
         f"{cusps_po[0].y:.4f} deg, P = {cusps_po[0].x:.6f} MPa**: with the payload turned further towards the "
         "base there is no snap at any pressure.") if cusps_po else "",
        "At Omega = 90 deg the curve crosses at "
        f"{', '.join(f'{v:.8f}' for v in po.lines.get(90.0, []))} MPa, the folds of the first map at 2 N.",
        "",
        _check_line(po),
        "",
    ]
    # --- design plane
    dp = data.design
    env = dp.envelope
    best = dp.optimum or ()
    m = best[0] if best else None
    p = best[1] if len(best) > 1 else None
    u = m.unconstrained if m else {}
    uc = u.get("clearance") or {}
    near = (uc.get("nearest_fold") or {})
    lines += [
        "## The design plane (r2, d) at an operating envelope",
        "",
        f"The envelope: {env.describe()}. A design is *clear* when no stable fold lies at pressures up to",
        f"{env.pressure_bound:g} MPa and payloads up to {env.payload_bound:g} N (the envelope and its margin); "
        "`esba.design.envelope.fold_clearance`",
        "finds the lowest fold payload on the design's fold curves in the (pressure, payload) plane.",
        "",
        f"![design plane]({fig / FIGURES['design']})",
        "",
        f"Of the {len(dp.state)} designs of the grid, {dp.count('clear')} are clear of folds, {dp.count('margin')} have a fold within",
        f"the margin, {dp.count('snaps')} snap inside the envelope and {dp.count('over budget')} need more than {env.max_pressure:g} MPa to bend to 90 deg.",
        "",
    ]
    if m is not None:
        lines += [
            f"Without the fold constraint the stiffest design (IPOPT, the paper's problem) is r2 = {u.get('r2_mm', float('nan')):.4f} mm,",
            f"d = {u.get('d_mm', float('nan')):.4f} mm (K = {u.get('stiffness_n_per_m', float('nan')):.4f} N/m): the paper's optimum. It "
            + ("**snaps inside the envelope**" if uc.get("snaps_inside") else "is clear")
            + (f": its {near.get('kind')} lies at P = {near.get('pressure_mpa', float('nan')):.5f} MPa, F = {near.get('payload_n', float('nan')):.5f} N." if near else "."),
            "",
            "| method | r2 (mm) | d (mm) | K (N/m) | 90 deg pressure (MPa) | nearest fold | active constraints | designs | time (s) |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for r in best:
            nf = r.clearance.nearest if r.clearance else None
            nf_text = f"{nf['kind']}: P = {nf['pressure_mpa']:.5f} MPa, F = {nf['payload_n']:.5f} N" if nf else "none"
            lines.append(
                f"| {r.method} | {r.r2_mm:.5f} | {r.d_mm:.5f} | {r.stiffness_n_per_m:.4f} | {r.pressure_mpa:.5f} | {nf_text} | "
                f"{', '.join(r.active) or 'none'} | {r.evaluations} | {times(r.solve_time_s, '.1f')} |"
            )
        if p is not None:
            lines += [
                "",
                f"The swarm (12 particles, 15 iterations, Deb's rules on the same constraint) lands {abs(p.r2_mm - m.r2_mm):.4f} mm from the",
                f"map-based design in r2 and {abs(p.d_mm - m.d_mm):.4f} mm in d, with a stiffness {100 * (m.stiffness_n_per_m - p.stiffness_n_per_m) / m.stiffness_n_per_m:.3f} % lower.",
            ]
        lines += [
            "",
            f"`esba design --envelope-pressure {env.max_pressure:g} --envelope-payload {env.max_payload:g} --fold-margin {env.margin:g} --method both` runs both.",
            "",
        ]
    lines += _spatial_lines(data.spatial, fig, times)
    # --- designer
    lines += [
        "## What a designer should take from each map",
        "",
        f"- **Pressure and side load**: below {cusp_pp.y:.3f} N of horizontal tip payload the Table 1 actuator has one",
        "  stable state at every pressure and no pressure command snaps it. Above it, a band of pressures",
        "  widening with the payload is bistable: keep operating pressures outside the band, or expect the",
        "  history (inflate first or load first) to decide the shape.",
        f"- **Direction and magnitude**: at the 90 degree pressure, payloads below {cusp_op.y:.3f} N never snap",
        f"  whatever their direction in {op.case.xrange[0]:g} to {op.case.xrange[1]:g} deg; heavier ones snap when turned across the",
        "  fold curve, and the history lines show the snap-up and snap-back directions differ (hysteresis in",
        "  the direction). Near the cusp the window of directions in which a growing load snaps is a tenth",
        "  of a degree wide: a task there is on a knife edge.",
        "- **Pressure and direction under 2 N**: the bistable band moves to lower pressures as the load",
        "  turns towards the base"
        + (f" and closes at {cusps_po[0].y:.1f} deg" if cusps_po else "")
        + ": a controller that knows the load's direction knows which pressures to avoid.",
        f"- **Design plane**: the stiffest chamber of the paper snaps inside a {env.max_payload:g} N, {env.max_pressure:g} MPa envelope; the",
        "  fold constraint moves the optimum to a smaller chamber"
        + (f" (r2 = {m.r2_mm:.3f} mm), giving up {100 * (1 - m.stiffness_n_per_m / u['stiffness_n_per_m']):.1f} % of the stiffness" if m is not None and u.get("stiffness_n_per_m") else "")
        + " for an actuator that",
        "  cannot snap in its envelope.",
        "",
        "The fold curves' cost against the brute-force grid they replace is benchmarked on",
        "[performance.md](performance.md) (`esba bench maps`).",
        "",
    ]
    return "\n".join(line for line in lines)


def _spatial_lines(c: Map3DCases, fig: Path, times: Times) -> list[str]:
    """The 3-D section: the gripper map and the pressure paths' folds and branch points."""
    g = c.gripper
    reg = g.regions()
    (_, xr), (_, yr) = GRIPPER["x"], GRIPPER["y"]
    ck = c.check
    agree = ck.k * ck.k - ck.mismatches - ck.near_mismatches
    counts = sorted({int(cell[4]) for cell in ck.cells})
    brute = sorted({CLASSES[int(cell[3])] for cell in ck.cells})
    bps = [p for p in g.paths if p.kind == "branch point"]
    twist = sorted((b for b in g.boundaries if b.kind == "twist bound" and b.along == "y"), key=lambda b: (b.x, b.y))
    low = [b for b in twist if b.y < 90.0]
    high = [b for b in twist if b.y >= 90.0]
    lines = [
        "## In 3-D: in the plane, flipped sideways, or snapped",
        "",
        "The maps above are planar. In space a payload can also turn the finger out of its plane: at a **branch point**",
        "the in-plane state loses a sideways-twist mode (lateral-torsional buckling; the 3n x 3n Hessian of the 3-D model",
        "singular while its in-plane block stays positive definite), and a payload that points out of the plane twists",
        "the finger more and more (the same branch point made imperfect: a smooth twist, or a fold of the twisted branch).",
        "`esba map --3d` (`esba/analysis/maps3d.py`) classifies every point of a plane of two of pressure, payload,",
        "its in-plane angle Omega, its angle out of the plane Beta, its direction *around* the actuator (turned about the",
        "base axis from the scene's direction) and its point, by the state the history *pressurise, then raise the",
        "payload from 0* reaches there: **in plane** (stable all the way, the total twist |sum tau_i| within a bound,",
        "10 deg here), **twisted** (stable, but twisted beyond the bound), **flips** (it lost stability on the way at a",
        "sideways mode) or **snaps** (it lost stability at an in-plane mode: a fold). Along the ramp the state is",
        "continued by Newton's method with step control; a converged step onto an indefinite Hessian brackets a branch",
        "point (Brent's method on the smallest eigenvalue), steps that shrink to nothing mark a fold (Newton on the",
        "extended system, `esba.statics.spatial.fold3d`). Boundaries between cells of different regions are located by",
        "Brent's method on the critical load minus the load, or on the twist minus the bound; paths along each axis",
        "(rising and falling) give the folds and branch points of the plane.",
        "",
        "### The gripper map",
        "",
        f"![the gripper map]({fig / FIGURES['gripper-3d']})",
        "",
        f"`{GRIPPER_COMMAND}` draws this map: the Table 1 actuator under a 0.5 N tip payload whose direction turns",
        "about the actuator's base axis (around = 0: horizontal in the bending plane, the Table 2 direction; 90 would be",
        f"straight out of the plane) from {yr[0]:g} to {yr[1]:g} deg, over pressures {xr[0]:g} to {xr[1]:g} MPa, with the eccentric",
        f"section's stiffnesses (`esba section`: EI_side = {c.section['EI_side']:.0f} N mm^2, GJ = {c.section['GJ']:.0f} N mm^2).",
        "",
        f"On the {len(g.grid_x)} x {len(g.grid_y)} raster the finger **stays in its plane** on {100 * reg['stays in its plane']:.1f} %, "
        f"**flips sideways** on {100 * reg['flips sideways']:.1f} % and **snaps** on {100 * reg['snaps']:.1f} %.",
    ]
    if bps:
        lines += [
            "",
            "In the plane (around = 0) the pressure path loses the in-plane state at branch points, "
            + ", ".join(f"{p.x:.8f} MPa ({p.direction})" for p in bps)
            + ": between them a 0.5 N horizontal payload flips the finger sideways.",
        ]
    if low or high:
        lines += [
            "Turned out of the plane, the payload twists the finger past 10 deg smoothly (no loss of stability): at "
            + ", ".join(f"{b.x:g} MPa beyond {b.y:.3f} deg" for b in low[:4])
            + (" and, from the other side, below " + ", ".join(f"{b.y:.3f} deg at {b.x:g} MPa" for b in high[:4]) if high else "")
            + ("; at these pressures it stays in its plane only for loads within "
               + f"{min(low, key=lambda b: b.y).y:.1f} deg (at {min(low, key=lambda b: b.y).x:g} MPa) to {max(low, key=lambda b: b.y).y:.1f} deg (at {max(low, key=lambda b: b.y).x:g} MPa) of it." if low else "."),
        ]
    lines += [
        "",
        f"Brute force at the centres of a {ck.k} x {ck.k} grid (a fixed ramp of {BRUTE_STEPS} equal steps of the damped Newton method, "
        f"classified by the same rules, and a multistart of {BRUTE_STARTS[0] * BRUTE_STARTS[1] * BRUTE_STARTS[2]} damped Newton descents "
        f"from bent, sideways and twisted starts, `esba.analysis.maps3d.check_grid3d`) finds the classes {', '.join(brute)} and "
        f"{' or '.join(str(k) for k in counts)} stable state{'s' if counts[-1] != 1 else ''} per cell; the map agrees in **{agree} of {ck.k * ck.k}** cells"
        + (f" ({ck.mismatches + ck.near_mismatches} disagree)" if ck.mismatches + ck.near_mismatches else "")
        + ", and the multistart finds the map's state among the stable ones wherever it is stable"
        + (f" (missed in {ck.missed})." if ck.missed else "."),
        "",
        "### The pressure paths in 3-D",
        "",
        f"The pressure raised from {PATH_RANGE[0]:g} MPa and lowered from {PATH_RANGE[1]:g} MPa under a horizontal tip payload (Omega = 90 deg,",
        "in the plane), followed in 3-D until the state loses stability (`esba.analysis.maps3d.path_points`). With a section",
        f"stiff out of the plane (EI_side = {STIFF_SECTION['EI_side']:g}, GJ = {STIFF_SECTION['GJ']:g} N mm^2) the losses are the planar folds (the first",
        "map's fold curve; they agree with the planar path engine's to 1e-10 MPa in `tests/analysis/test_maps3d.py`, their",
        "mode has no sideways part); with the eccentric section the in-plane state flips sideways first:",
        "",
        "| payload (N) | stiff section: rising, falling (MPa) | eccentric section: rising, falling (MPa) |",
        "|---|---|---|",
    ]

    def cell(pts) -> str:
        out = []
        for direction in ("rising", "falling"):
            hit = [p for p in pts if p[0] == direction]
            if not hit:
                out.append("none")
            elif hit[0][2] == "unstable at the start":
                out.append(f"unstable at {hit[0][1]:g}")
            else:
                out.append(f"{hit[0][2]} at {hit[0][1]:.8f}")
        return "; ".join(out)

    for f in PATH_PAYLOADS:
        lines.append(f"| {f:g} | {cell(c.stiff[f])} | {cell(c.eccentric[f])} |")
    from esba.model.closed_form import pressure_for_angle
    from esba.model.scene import MAIN_JOB

    p90 = pressure_for_angle(MAIN_JOB.unloaded())

    def flipped(pts) -> bool:  # the in-plane state at p90 lies past the rising loss and before the falling one
        up = [p[1] for p in pts if p[0] == "rising"]
        down = [p[1] for p in pts if p[0] == "falling"]
        return bool(up) and up[0] < p90 and (not down or down[0] > p90)

    unstable = [f for f in PATH_PAYLOADS if flipped(c.eccentric[f])]
    stable = [f for f in PATH_PAYLOADS if f not in unstable]
    lines += [
        "",
        f"At the 90 degree pressure ({p90:.5f} MPa), with the stiffnesses the eccentric section gives (the layer's width and thickness",
        "and the fibres' state assumed, `docs/3d.md`), the in-plane state under a horizontal payload of "
        + (", ".join(f"{f:g}" for f in unstable) + " N lies past the rising path's branch point (and before the falling path's, where it has one): "
           "it is sideways-unstable" if unstable else "none of these payloads is sideways-unstable")
        + ("; under " + ", ".join(f"{f:g}" for f in stable) + " N it is stable" if stable else "")
        + ". Whether the real finger flips depends on the torsional stiffness the paper does not give.",
        "",
    ]
    return lines + _curve_lines(c)


def _curve_lines(c: Map3DCases) -> list[str]:
    """The 3-D fold and branch-point curves: their special points, and what a tilted payload does to them."""
    if c.curves is None or c.tilted is None:
        return []
    from esba.analysis.map3d_cases import CURVES_COMMAND, CURVES_TILT, TILTED_COMMAND

    def rows(curves) -> list[str]:
        def deg(part) -> str:  # no "-0.000" from a round-off twist
            return f"{round(math.degrees(float(np.sum(part))), 3) + 0.0:.3f}"

        return [f"| {p.kind} | {p.x:.10g} | {p.y:.10g} | {deg(p.theta[: p.segments])} | {deg(p.theta[2 * p.segments:])} | {p.status} |"
                for k in curves for p in k.special]

    lines = [
        "### Fold and branch-point curves in 3-D",
        "",
        "The folds and branch points of the paths above, continued in pressure and payload together (`esba.analysis.folds` on",
        "the 3-D model, `esba.analysis.branch_curves`): a fold curve solves g = 0, H v = 0; a branch-point curve of the",
        "in-plane state solves the in-plane equilibrium with a null vector of the Hessian's sideways-twist block",
        "(g_theta = 0, H_ss w = 0), both continued by pseudo-arclength with their codimension-two points located on them.",
        f"`{CURVES_COMMAND}` prints them for the horizontal payload in the plane (eccentric section):",
        "",
        "| point | pressure (MPa) | payload (N) | total angle (deg) | twist (deg) | status |",
        "|---|---|---|---|---|---|",
        *rows(c.curves.folds),
        *rows(c.curves.branch_points),
        "",
        "The fold curve is the planar one (its cusp that of the first map); in this box, below the branch-point curve's lowest",
        "payload no pressure path flips the finger sideways, and left of its lowest pressure no payload path does.",
        "",
        f"Tilted {CURVES_TILT:g} deg out of the plane (`{TILTED_COMMAND}`) the payload twists the finger and the plane is no longer a",
        "symmetry: the branch points unfold, and at low pressure the twisted state folds (a sideways fold, the loading and unloading",
        f"folds of a pressure path) on {len(c.tilted.folds)} fold curve{'s' if len(c.tilted.folds) != 1 else ''}:",
        "",
        "| point | pressure (MPa) | payload (N) | total angle (deg) | twist (deg) | status |",
        "|---|---|---|---|---|---|",
        *rows(c.tilted.folds),
        "",
    ]
    return lines


@dataclass(frozen=True)
class MapsSettings:
    """The page's one setting: the command it names as its writer."""

    command: str


class MapsPage(Page):
    """``docs/maps.md`` and its four figures in ``figures/`` beside it."""

    name = "maps"

    def settings(self) -> MapsSettings:
        return MapsSettings(self.command)

    def compute(self, settings: MapsSettings | None = None, progress: Progress | None = None) -> MapsData:
        maps = map_cases(progress)
        if progress:
            progress("design plane")
        design = design_plane(None, ENVELOPE, R2_GRID, D_GRID, optimum="both", progress=progress)
        return MapsData(maps, design, map3d_cases(progress))

    def render(self, data: MapsData, settings: MapsSettings, path: Path, times: Times = TIMES) -> Rendered:
        figures: dict[Path, Any] = {path.parent / "figures" / FIGURES[r.case.name]: (lambda r=r: map_figure(r.map, r.case.title)) for r in data.maps}
        figures[path.parent / "figures" / FIGURES["design"]] = lambda: design_plane_figure(data.design)
        figures[path.parent / "figures" / FIGURES["gripper-3d"]] = lambda: _gripper_figure(data.spatial)
        return Rendered(render_page(data, settings.command, times), figures)


def _gripper_figure(c: Map3DCases):
    from esba.figures.maps3d import map3d_figure

    return map3d_figure(c.gripper, "3-D: 0.5 N tip payload turned around the actuator, eccentric section (Table 1)")


PAGE = MapsPage()

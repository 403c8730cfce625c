"""The page ``docs/design.md``: the paper's design problem and the constrained ones, rendered.

Presentation only: :func:`esba.design.cases.design_cases` runs every optimisation (IPOPT and PSO on
every problem of the page, the pressure/stiffness trade-off, the optimum against n) and returns
them; :func:`render_page` turns them into Markdown. ``esba design --write-doc docs/design.md`` and
``esba docs --write design`` write the page; ``esba docs --check design`` checks it, times aside
(every wall-clock time on the page is written through :class:`esba.pages.page.Times`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from esba.design.cases import MAX_PRESSURE, MIN_STIFFNESS, WALLS, DesignCases, design_cases
from esba.design.optimise import DEFAULT_DESIGN_OPTIONS, Comparison, DesignOptions, DesignResult
from esba.design.spatial import AZIMUTHS, PRESSURES, OffPlaneCheck, off_plane_check
from esba.infra.roundoff import floored
from esba.solvers.pso import PSOOptions

from .page import TIMES, Page, Progress, Rendered, Times, figure_link
from .registry import ENTRIES

__all__ = ["PAGE", "DesignPage", "DesignSettings", "render_page", "DOC_COMMAND"]


#: The command that writes the page.
DOC_COMMAND = ENTRIES["design"].command



#: Differences of designs below this (mm) and of objectives below ``ROUND_OFF_REL`` (relative) are
#: the solvers' own tolerance (both stop at 1e-10 relative), not a difference: the page prints them
#: as "< floor" so that it does not change with the last digits of the arithmetic.
ROUND_OFF_MM = 1e-8
ROUND_OFF_REL = 1e-9


def _mm(x: float, spec: str) -> str:
    return floored(x, spec, ROUND_OFF_MM)


def _percent(rel: float, spec: str) -> str:
    return floored(100 * rel, spec, 100 * ROUND_OFF_REL)

def _fmt_active(r: DesignResult) -> str:
    if not r.active_constraints:
        return "none"
    parts = []
    for c in r.active_constraints:
        if c.sensitivity is None:
            parts.append(f"`{c.name}`")
        else:
            parts.append(f"`{c.name}` ({c.sensitivity:+.4g} {r.problem.unit}/{c.unit})")
    return ", ".join(parts)


def _row(r: DesignResult, t: Times) -> str:
    obj = f"{r.objective:.6g} {r.problem.unit}"
    work = f"{r.iterations} iterations, {r.evaluations} starts" if r.method == "ipopt" else f"{r.evaluations} designs evaluated"
    return (
        f"| {r.method} | {r.status} | {r.r2_mm:.5f} | {r.d_mm:.5f} | {r.pressure_mpa:.5f} | {r.stiffness_n_per_m:.4f} | {obj} | "
        f"{t(r.solve_time_s, '.3f')} | {work} |"
    )


_HEAD = (
    "| method | status | r2 (mm) | d (mm) | P at 90 deg (MPa) | K (N/m) | objective | time (s) | work |\n"
    "|---|---|---|---|---|---|---|---|---|"
)


def _comparison_block(title: str, c: Comparison, t: Times) -> list[str]:
    lines = [f"**{title}.** {c.ipopt.problem.describe()}.", "", _HEAD, _row(c.ipopt, t), _row(c.pso, t), ""]
    if c.ipopt.ok and c.pso.ok:
        lines.append(
            f"PSO - IPOPT: r2 {_mm(c.r2_diff_mm, '+.2e')} mm, d {_mm(c.d_diff_mm, '+.2e')} mm, objective {_percent(c.objective_rel_diff, '+.2e')} %; "
            f"{'they agree' if c.agree else '**they do not agree**'} (design within 0.01 mm, objective within 0.1 %); PSO took "
            f"{t(c.speedup, '.0f')} times as long as IPOPT."
        )
    else:
        lines.append(f"IPOPT: {c.ipopt.status} ({c.ipopt.message or 'ok'}); PSO: {c.pso.status} ({c.pso.message or 'ok'}).")
    lines.append(f"Active at the IPOPT optimum (sensitivity of the objective to each bound): {_fmt_active(c.ipopt)}.")
    lines.append(
        f"Checks: every equilibrium stable: {c.ipopt.stable} (IPOPT), {c.pso.stable} (PSO); the loaded state is the one "
        f"reached by inflating and then loading: {c.ipopt.on_load_path} / {c.pso.on_load_path}; K recomputed on that "
        f"load path {c.ipopt.stiffness_check_n_per_m:.6g} N/m."
    )
    return lines + [""]


def _off_plane_lines(c: OffPlaneCheck) -> list[str]:
    """Do the paper's optimum and today's snap-free design survive an off-plane load of the envelope's size?"""
    sp = c.spatial["eccentric"]
    env = sp.envelope
    L = [
        "## Off the plane: do these designs survive a sideways load?",
        "",
        "The designs above are planar: nothing in them stops a load out of the bending plane from flipping the finger",
        "sideways (lateral-torsional buckling) or twisting it. `esba design --envelope-pressure P --envelope-payload F --cone DEG",
        "--max-twist DEG` (`esba/design/spatial.py`) adds both to the envelope's fold constraint, in the 3-D model: every",
        "payload up to (1 + margin) F within DEG of the envelope's direction, at every pressure up to (1 + margin) P, must be",
        "carried from the unloaded state without a loss of stability sideways and with the twist |sum tau_i| within the bound",
        f"(sampled: {PRESSURES} pressures; the envelope's direction and {AZIMUTHS} directions on each of the circles at half the cone and",
        "at the cone). The optimum is checked against PSO on the same constraint as the planar envelope's.",
        "",
        f"Here the envelope of `docs/maps.md` ({env.describe()}) with payloads within {sp.cone_deg:g} deg of it and a twist",
        f"bound of {sp.max_twist_deg:g} deg (`esba.design.spatial.off_plane_check`):",
        "",
        "| design | r2, d (mm) | K (N/m) | section (EI_side, GJ; N mm^2) | planar fold constraint | flips sideways at (N) | largest twist at the payload bound (deg) | survives |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, r2, d, K in c.designs:
        for key in ("eccentric", "stiff"):
            r = c.results[(name, key)]
            sec = f"{r.section['EI_side']:.0f}, {r.section['GJ']:.0f}" + (" (its eccentric section)" if key == "eccentric" else " (assumed)")
            flips = "no, up to twice the bound" if not np.isfinite(r.sideways_payload) else f"{r.sideways_payload:.4f}"
            planar = "clear" if r.planar.clear else ("snaps inside" if r.planar.inside else "within the margin")
            L.append(f"| {name} | {r2:.4f}, {d:.4f} | {K:.4f} | {sec} | {planar} | {flips} | {r.twist_deg:.2f} | {'**yes**' if r.clear else '**no**'} |")
    def why(r) -> str:
        if r.clear:
            return "survives"
        reasons = []
        if not r.planar.clear:
            reasons.append("it snaps in the plane")
        if r.sideways_value < 0:
            reasons.append(f"it flips sideways at {r.sideways_payload:.3f} N")
        if r.twist_value < 0:
            reasons.append(f"it twists {r.twist_deg:.0f} deg")
        return "does not survive (" + ", ".join(reasons) + ")"

    verdict = []
    for name, *_ in c.designs:
        e, s = c.results[(name, "eccentric")], c.results[(name, "stiff")]
        verdict.append(f"{name} {why(e)} with its eccentric section and {why(s)} with the stiff one")
    L += [
        "",
        "So " + "; ".join(verdict) + ". With the stiffnesses the eccentric section gives (the layer's width and thickness and",
        "the fibres' state assumed, `docs/3d.md`), a payload of the envelope's size tilted out of the plane turns the finger",
        "far beyond any bound: the torsional stiffness, which the paper does not give, decides whether a snap-free design is",
        "also safe sideways, and `--cone` with `--section` makes it part of the design.",
        "",
    ]
    return L


def render_page(cases: DesignCases, t: Times = TIMES, page_dir: Path | None = None, spatial: OffPlaneCheck | None = None) -> str:
    """The Markdown of ``docs/design.md`` from :func:`esba.design.cases.design_cases`; with
    ``page_dir`` (the page's folder) a figure that is not in ``figures/`` there is named, not linked."""

    def figure(name: str, alt: str) -> str:
        return figure_link(page_dir, f"figures/{name}.png", alt, f"esba figures --only {name} --out {{dir}}")

    segments, options, pso_options, base = cases.segments, cases.options, cases.pso_options, cases.base
    runs, best, trade, hard, infeasible, by_n = cases.runs, cases.best, cases.trade_off, cases.hard, cases.infeasible, cases.by_segments
    r2_line, line, line_angle, line_terms, t1 = cases.line_r2, cases.line, cases.line_angle, cases.line_terms, cases.table1
    km, pm = MIN_STIFFNESS, MAX_PRESSURE
    p = runs["paper"]
    L = []
    L.append("# Design optimisation: the stiffest chamber, by IPOPT and by a particle swarm")
    L.append("")
    L.append(f"Written by `{DOC_COMMAND}` (do not edit by hand; rerun it). Figures by `esba figures --only fig13a fig13b fig14`.")
    L.append(
        f"Numbers from one run on this machine (n = {segments}, variant `{base.variant}`); times are wall-clock "
        "and vary with the machine's load, their ratio much less."
    )
    L.append("")
    L.append("## The problem")
    L.append("")
    L.append(
        "Section 5 of the paper looks for the chamber radius r2 and eccentric distance d that make the actuator of "
        "Table 1 (L = 135 mm, r1 = 8 mm, rho = 10 deg, E = 0.54 MPa) as stiff as possible. The stiffness is the "
        "secant stiffness of Section 4.4.3: the actuator is inflated, unloaded, to 90 deg; then, with the pressure "
        "held, a 2 N horizontal payload is applied at the tip and K = Delta F / Delta y = 1000 F / (y0 - y1) in N/m. "
        "Every design gets its own pressure (the one that bends it to 90 deg), so the pressure is an output of the "
        "design, not an input. The geometry allows 0 < r2, 0 <= d and r2 + d < r1 (the chamber inside the actuator)."
    )
    L.append("")
    L.append("## The NLP (full space, IPOPT with exact second derivatives)")
    L.append("")
    L.append("One NLP in CasADi's dict form `{\"x\", \"f\", \"g\"}` (`esba/design/nlp.py`):")
    L.append("")
    L.append("| | |")
    L.append("|---|---|")
    L.append("| variables | r2, d, P (the 90 deg pressure), theta_s (n unloaded angles), theta_l (n loaded angles); plus theta_f (n) for `angle`, P_t and theta_t (n) for `pressure` |")
    L.append("| equilibria | dU/dtheta(theta_s; r2, d, P, F = 0) = 0 and dU/dtheta(theta_l; r2, d, P, F = 2 N) = 0 with the generated gradient (and the same for theta_f at P_max, theta_t at P_t) |")
    L.append("| 90 deg | sum(theta_s) = pi/2 (and sum(theta_t) = target for `pressure`) |")
    L.append("| geometry | r2 >= 0.01 mm, d >= 0, r1 - r2 - d >= max(t_min, 0.001 mm) (the wall) |")
    L.append("| model domain | Eq. (10) on the loaded state: 1 + n r1^3 theta_i / (L r2^2) >= 1e-6 (the square root), 1 + n (r1 + d) theta_i / L >= 1e-6 (its denominator) |")
    L.append("| options | K >= K_min; P <= P_max (and P_t <= P_max); free angle <= 3600 deg |")
    L.append("| objective | `stiffness`: max K = 1000 F / (u . (tip(theta_l) - tip(theta_s))); `angle`: max sum(theta_f) at P_max; `pressure`: min P_t |")
    L.append("")
    L.append(
        "CasADi differentiates the generated gradient once more, so IPOPT gets the exact Hessian of the Lagrangian. "
        f"IPOPT starts from {options.starts} designs spread over the triangle, each with its equilibria from the batched "
        "evaluator (so every start is on the physical branch); the best converged result is kept. The result is then "
        "checked: the Hessian of U is positive definite at every state (stable), the loaded state is the one "
        "`esba.statics.equilibrium.solve` reaches by inflating and then loading (the NLP alone only asks for a stationary "
        "point), and the active bounds are reported with IPOPT's multipliers turned into sensitivities: "
        "d(objective*)/d(bound), the first-order change of the optimum per unit of the bound."
    )
    L.append("")
    L.append(
        f"The swarm (`esba/solvers/pso.py`) is the paper's: {pso_options.particles} particles, {pso_options.iterations} iterations, "
        "random initial positions and velocities in the box, Clerc-Kennedy constriction coefficients (w = 0.7298, "
        "c1 = c2 = 1.49618), r2 + d <= r1 - wall enforced (a particle stops where its step crosses the boundary), "
        f"K_min and P_max by Deb's feasibility rules, seed {pso_options.seed}. Each iteration evaluates the whole swarm "
        "in one call: a CasADi Function mapped over the particles gives each design's 90 deg pressure in closed form "
        f"(U is linear in P) and its loaded state by Newton's method along a ramp of the payload in {options.load_steps} steps "
        "(the generated gradient, with the generated Hessian as Jacobian)."
    )
    L.append("")
    L.append("## The optimum")
    L.append("")
    L.append(_HEAD)
    L.append(_row(p.ipopt, t))
    L.append(_row(p.pso, t))
    L.append("")
    L.append(
        f"**r2 = {best.r2_mm:.4f} mm, d = {best.d_mm:.4f} mm, K = {best.stiffness_n_per_m:.4f} N/m at P = "
        f"{best.pressure_mpa:.5f} MPa** (the Table 1 design: K = {t1.stiffness[0]:.2f} N/m at {t1.pressure[0]:.5f} MPa). "
        f"PSO - IPOPT: r2 {_mm(p.r2_diff_mm, '+.1e')} mm, d {_mm(p.d_diff_mm, '+.1e')} mm, K {_percent(p.stiffness_rel_diff, '+.1e')} %. "
        f"IPOPT: {t(p.ipopt.solve_time_s * 1000, '.0f')} ms; PSO: {t(p.pso.solve_time_s, '.2f')} s, {t(p.speedup, '.0f')} times as long, "
        f"in the same run (IPOPT's one-off set-up, building the NLP and its derivatives: {t(p.ipopt.setup_time_s, '.2f')} s). "
        f"Differences below {ROUND_OFF_MM:g} mm, or {100 * ROUND_OFF_REL:g} % of an objective, lie within both solvers' tolerance "
        "and are printed as \"within ±floor\" (their digits would change with the machine's arithmetic)."
    )
    L.append("")
    L.append(
        f"Active constraints: {_fmt_active(best)}. The optimum sits **on the bound d = 0**: a concentric chamber. "
        f"Its multiplier says that each mm of eccentricity would cost {abs(best.active_constraints[0].sensitivity) if best.active_constraints else float('nan'):.2f} N/m; "
        "r2 is interior (its derivative is zero there), and the wall is far from thin "
        f"({best.wall_mm:.2f} mm). Hessian eigenvalues (N mm/rad^2): unloaded "
        f"{', '.join(f'{v:.1f}' for v in best.eigenvalues['start'])}; loaded {', '.join(f'{v:.1f}' for v in best.eigenvalues['loaded'])}: "
        f"both equilibria stable. Loaded angles {', '.join(f'{v:.2f}' for v in best.theta_deg['loaded'])} deg."
    )
    L.append("")
    L.append(figure("fig13b", "stiffness over the triangle"))
    L.append("")
    L.append("## Why the optimum lies where it does")
    L.append("")
    L.append(
        "In this model the pressure only ever pushes with a constant moment: -P dV (Eq. 5) and the fibre term (Eq. 18) "
        "are linear in the segment angles, so the pressure adds nothing to the stiffness by itself. What resists the payload "
        "is the rubber: the axial strain energy (Eq. 8), whose bending coefficient 5 r1^4 - 4 r2^2 (r1 + d)^2 - r2^4 hardly "
        "changes while the chamber is small, and the radial strain energy of the chamber wall (Eq. 13), which depends strongly "
        "on r2 through the chamber's expansion Delta r2 of Eq. (10). For a thin chamber Delta r2 grows like the square root of "
        "the bend, so that energy is nearly linear in theta (a constant moment again) and resists little; for a wide chamber "
        "Delta r2 is proportional to theta / r2, so the energy is quadratic in theta but its coefficient falls as r2 grows. "
        "The payload's own term (Eq. 14) softens every design alike, since they all start from the same 90 deg arc. The "
        "curvature of each term at the 90 deg start (per segment, `term_curvatures`) shows it: the radial term peaks near "
        "r2 = 2 mm and the sum with it, so the stiffness peaks in between a thin and a wide chamber. The secant over the "
        "whole 2 N load peaks a little lower, at r2 = %.2f mm: it also feels the loaded states, where the first segment of "
        "a thin chamber straightens towards the edge of Eq. (10)'s domain and the radial energy stiffens there." % best.r2_mm
    )
    L.append("")
    L.append(
        "The pressure follows the stiffness: the 90 deg pressure is the elastic moment at 90 deg divided by the pressure's "
        "lever (pi r1^3 less the fibre term), so a stiffer design needs more pressure to reach the starting angle. That is the "
        "paper's observation that the stiff designs 'need more pressure to bend to 90 deg'; here it is the cost, not the cause, "
        "of the stiffness. Along d = 0:"
    )
    L.append("")
    L.append(
        f"| r2 (mm) | P at 90 deg (MPa) | K (N/m) | free angle at {pm:g} MPa (deg) | axial | radial | payload | "
        "sum (N mm/rad^2, at 90 deg) |"
    )
    L.append("|---|---|---|---|---|---|---|---|")
    for r2v, P, K, a, c in zip(r2_line, line.pressure, line.stiffness, line_angle, line_terms):
        L.append(
            f"| {r2v:.3f} | {P:.4f} | {K:.2f} | {a:.1f} | {c['axial']:.1f} | {c['radial']:.1f} | {c['payload1']:.1f} | "
            f"{sum(c.values()):.1f} |"
        )
    L.append("")
    L.append(
        "Eccentricity only softens: d enters Eq. (8) through -4 r2^2 (r1 + d)^2 (the chamber further from the inextensible "
        "layer removes more bending stiffness) and the denominator of Eq. (10) (more elongation of the chamber, less radial "
        "expansion). Both lower K, so d sits on its bound; but near the optimum the chamber is small and r2^2 (r1 + d)^2 is "
        "small against 5 r1^4, which is why the multiplier of d >= 0 is only a couple of N/m per mm. Eccentricity is what "
        "buys bending angle per MPa (Fig. 13a), and the designer's trade-off is between the two."
    )
    L.append("")
    L.append(figure("fig13a", "free bending angle at 0.2 MPa"))
    L.append("")
    L.append("### The pressure/stiffness trade-off")
    L.append("")
    L.append(
        "The lowest pressure that bends the unloaded actuator to 90 deg, for a stiffness of at least K_min (problem (b) "
        "with IPOPT): giving up a little stiffness saves a lot of pressure, because K is flat at its maximum while the "
        "pressure falls steadily with r2."
    )
    L.append("")
    L.append("| K_min (N/m) | P (MPa) | r2 (mm) | d (mm) | active | sensitivity dP*/dK_min (MPa per N/m) |")
    L.append("|---|---|---|---|---|---|")
    for r in trade:
        sens = next((c.sensitivity for c in r.active_constraints if c.name == "min_stiffness"), None)
        L.append(
            f"| {r.problem.min_stiffness:g} | {r.objective:.5f} | {r.r2_mm:.4f} | {r.d_mm:.4f} | "
            f"{', '.join(c.name for c in r.active_constraints) or 'none'} | {'' if sens is None else f'{sens:.3g}'} |"
        )
    L.append("")
    L.append("## Stiffness-constrained designs (IPOPT and PSO, each from one run)")
    L.append("")
    L.extend(_comparison_block("Stiffness with a pressure budget", runs["max_pressure"], t))
    L.extend(_comparison_block("(a) The largest free bending angle", runs["angle"], t))
    L.extend(_comparison_block("(b) The lowest pressure for 90 deg", runs["pressure"], t))
    L.extend(_comparison_block("(c) A minimum wall, stiffness objective", runs["wall_stiffness"], t))
    L.extend(_comparison_block("(c) A minimum wall, angle objective", runs["wall_angle"], t))
    a, b = runs["angle"].ipopt, runs["pressure"].ipopt
    w = runs["wall_angle"].ipopt
    L.append(
        f"Here (K_min = {km:g} N/m) problems (a) and (b) land on the same design (r2 = {a.r2_mm:.4f} vs {b.r2_mm:.4f} mm, "
        f"d = {a.d_mm:.4f} vs {b.d_mm:.4f} mm): along the stiffness constraint both the free angle and the pressure saving grow "
        "with r2, and d lowers K faster than it helps them, so both run along d = 0 until K = K_min. With a wall of "
        f"{WALLS[1]:g} mm the chamber cannot grow that far: the active constraints there are "
        f"{', '.join(c.name for c in w.active_constraints) or 'none'}, and K = {w.stiffness_n_per_m:.2f} N/m "
        f"{'> K_min: the stiffness constraint is slack' if w.stiffness_n_per_m > km * (1 + 1e-6) else '= K_min'}."
    )
    L.append("")
    L.extend(_comparison_block("A harder case: (b) with K_min = 30 N/m", hard, t))
    L.append(
        "Between K_min of about 25 and 30 N/m the lowest-pressure design leaves the d = 0 edge (see the trade-off table: "
        "at 25 N/m it sits on the wall with a large eccentricity), and along the curve K = K_min the pressure is nearly "
        "constant: designs tenths of a mm apart differ by a few 1e-4 in pressure. IPOPT's multipliers settle it; a swarm of "
        f"{pso_options.particles} can stagnate there after {pso_options.iterations} iterations (seed {pso_options.seed}), "
        "with its objective within 0.1 % but its design further than 0.01 mm away."
    )
    L.append("")
    L.append("**An infeasible request.** " + infeasible.ipopt.problem.describe() + ".")
    L.append("")
    L.append(f"- IPOPT: `{infeasible.ipopt.status}`: {infeasible.ipopt.message}.")
    L.append(f"- PSO: `{infeasible.pso.status}`: {infeasible.pso.message}.")
    L.append("")
    L.append("## The optimum against the segment count (IPOPT)")
    L.append("")
    L.append("| n | r2 (mm) | d (mm) | P (MPa) | K (N/m) | active | time (s) |")
    L.append("|---|---|---|---|---|---|---|")
    for r in by_n:
        L.append(
            f"| {r.problem.segments} | {r.r2_mm:.4f} | {r.d_mm:.4f} | {r.pressure_mpa:.5f} | {r.stiffness_n_per_m:.4f} | "
            f"{', '.join(c.name for c in r.active_constraints) or 'none'} | {t(r.solve_time_s, '.3f')} |"
        )
    L.append("")
    L.append("## The swarm")
    L.append("")
    L.append(figure("fig14", "swarm positions per iteration"))
    L.append("")
    hist = p.pso.pso.history.best_value
    first = int(np.argmax(np.abs(hist - hist[-1]) <= 1e-3 * abs(hist[-1])))
    L.append(
        f"With the paper's settings the swarm's best is within 0.1 % of its final stiffness after {first} iterations; "
        "the wall d = 0 absorbs the particles, so the swarm collapses onto the bound and then along it. It needs "
        f"{p.pso.evaluations} evaluations of the stiffness (each a closed-form pressure and a {options.load_steps}-step "
        f"Newton ramp), against IPOPT's {p.ipopt.iterations} iterations of the full-space NLP over {p.ipopt.evaluations} starts."
    )
    L.append("")
    if spatial is not None:
        L += _off_plane_lines(spatial)
    L.append("## Limits")
    L.append("")
    L.append(
        "- The batched Newton ramp does not converge for the thinnest chambers (r2 below about 0.1 mm, where the loaded "
        "state presses against the domain of Eq. 10) and for chambers that nearly fill the actuator (r2 > 7.5 mm, where "
        "the loaded shape folds back by more than 70 deg); the swarm treats those designs as failed (far from every "
        "optimum here) and the figures solve them again with `esba.analysis.stiffness.secant_stiffness`."
    )
    L.append(
        "- From starts far from the optimum IPOPT can wander towards r2 -> 0, where the loaded equilibrium sits on the "
        "domain boundary; such starts end without convergence and are dropped, which is why there are several starts."
    )
    L.append(
        "- `angle` and `pressure` need K_min: without it their optimum runs to the thinnest wall (the chamber fills the "
        "actuator, the free angle grows without bound)."
    )
    L.append("")
    return "\n".join(L)


@dataclass(frozen=True, eq=False)
class DesignData:
    """What the page computes: the planar design cases and the off-plane check of two of its designs
    (attributes not found here are the cases')."""

    cases: DesignCases
    spatial: OffPlaneCheck

    def __getattr__(self, name: str):
        return getattr(self.__dict__["cases"], name) if "cases" in self.__dict__ else super().__getattribute__(name)


@dataclass(frozen=True)
class DesignSettings:
    """What ``esba design --write-doc`` takes: the segment count, IPOPT's starts and the swarm."""

    segments: int = 3
    options: DesignOptions = DEFAULT_DESIGN_OPTIONS
    pso_options: PSOOptions = PSOOptions()


class DesignPage(Page):
    """``docs/design.md`` (its figures are ``esba figures``'s fig13a, fig13b and fig14)."""

    name = "design"

    def settings(self) -> DesignSettings:
        return DesignSettings()

    def compute(self, settings: DesignSettings | None = None, progress: Progress | None = None) -> DesignData:
        settings = self.settings() if settings is None else settings
        return DesignData(design_cases(settings.segments, settings.options, settings.pso_options, progress), off_plane_check(progress))

    def render(self, data: DesignData, settings: DesignSettings, path: Path, times: Times = TIMES) -> Rendered:
        if isinstance(data, DesignCases):  # the planar cases alone
            return Rendered(render_page(data, times, path.parent))
        return Rendered(render_page(data.cases, times, path.parent, data.spatial))


PAGE = DesignPage()

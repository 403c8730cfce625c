"""The 3-D section of ``docs/contact.md``, rendered from :func:`esba.analysis.contact3d_cases.contact3d_cases`
(presentation only; :mod:`esba.pages.contact` places it and writes its figure)."""

from __future__ import annotations

from pathlib import Path

from esba.analysis.contact3d_cases import RANDOM_SEEDS, Contact3DCases
from esba.infra.roundoff import floored

from .page import TIMES, Times

__all__ = ["spatial_section", "FIGURE_3D"]

#: The section's figure, in ``figures/`` beside the page.
FIGURE_3D = "contact3d-tilted-cylinder.png"

#: KKT numbers below these are round-off: the gaps, forces and complementarity (mm, N, N mm) of a
#: solve polished to 1e-13 L, and the stationarity (N mm/rad) of one polished to 1e-11 of the gradient.
FLOOR = 1e-10
STATIONARITY_FLOOR = 1e-8
#: The issue's bounds: the planar result reproduced; the dead load that holds the same shape.
PLANAR_BOUND = 1e-10
DEAD_LOAD_BOUND = 1e-9


def _contact_rows(r) -> list[str]:
    lines = ["| where | s | force (N) | force vector (N) | point (mm) |", "|---|---|---|---|---|"]
    for c in r.contacts:
        v, p = c.force_vector, c.point
        lines.append(f"| {c.where} | {c.s:.4f} | {c.force:.4f} | ({v[0]:.4f}, {v[1]:.4f}, {v[2]:.4f}) | ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) |")
    k = r.kkt
    gaps = ", ".join("-" if g is None else floored(g, '.3f', 5e-4) for g in r.gaps)
    lines += [
        "",
        f"Least gap elsewhere {gaps} mm; KKT: stationarity {floored(k.stationarity, '.1e', STATIONARITY_FLOOR)} N mm/rad, least gap "
        f"{floored(k.min_gap, ' .1e', FLOOR)} mm, least force {floored(k.min_force, ' .1e', FLOOR)} N, complementarity "
        f"{floored(k.complementarity, '.1e', FLOOR)} N mm; the Lagrangian's Hessian on the tangent space of the {k.active} active "
        f"constraint(s): least eigenvalue {k.reduced_eigenvalues[0]:.2f} N mm/rad^2 ({k.stability}). Sideways bend up to "
        f"{abs(r.psi).max() * 57.29577951308232:.2f} deg, twist up to {abs(r.tau).max() * 57.29577951308232:.2f} deg a joint.",
    ]
    return lines


def _path_rows(path, spec: str) -> list[str]:
    """A 3-D contact path's contact force against pressure and its events."""
    lines = [
        "| P (MPa) | " + " | ".join(f"{p.pressure:{spec}}" for p in path.points) + " |",
        "|---|" + "---|" * len(path.points),
        "| contact force (N) | " + " | ".join(f"{f:.4f}" for f in path.forces()) + " |",
        "| where | " + " | ".join(", ".join(dict.fromkeys(c.where for c in p.contacts)) or "-" for p in path.points) + " |",
        "",
    ]
    return lines + ([f"- {e.describe()}" for e in path.events] or ["- no event"]) + [""]


def _ranges(seeds) -> str:
    """Consecutive seeds as ranges: ``11 to 18 and 20 to 31``."""
    runs: list[list[int]] = []
    for v in seeds:
        if runs and v == runs[-1][-1] + 1:
            runs[-1].append(v)
        else:
            runs.append([v])
    return " and ".join(f"{r[0]} to {r[-1]}" if len(r) > 1 else f"{r[0]}" for r in runs)


def spatial_section(d: Contact3DCases, fig: Path, t: Times = TIMES) -> list[str]:
    """The lines of the section ``Contact in 3-D``."""
    lines = [
        "## Contact in 3-D",
        "",
        "`esba solve --3d SCENE.toml` with 3-D obstacles, or `esba.statics.contact.spatial.solve_contact3d(scene)`:",
        "the same constrained problem on the spatial model (`docs/3d.md`: three rotations a joint, theta, psi, tau).",
        "",
        "- **Obstacles** (`esba/model/contact/spatial.py`): `kind = \"plane\"` (`at = [x, y, z]`, `normal = [nx, ny, nz]`,",
        "  the half-space behind it), `\"sphere\"` (`centre = [x, y, z]`, `radius`) and `\"cylinder\"` with an `axis = [ax, ay,",
        "  az]` and a three-number centre (infinitely long). A planar obstacle in a 3-D solve is its extrusion across the",
        "  bending plane, with its planar side, so a planar scene file means the same in 3-D. A 3-D obstacle needs the 3-D",
        "  model: `esba solve`, `path` and `equilibria` pick it by themselves for such a scene (as for an out-of-plane",
        "  payload), while the planar `solve_contact` refuses it in one line. One line also refuses an obstacle in the",
        "  actuator at rest, a plane whose point `at` is behind the base (x < 0, as the planar half-plane's), a radius <= 0,",
        "  NaN, a zero normal or axis.",
        "- **Where the body touches.** Segment i is the piece of helix exp(sigma hat(Xi_i)) of the SE(3) product of",
        "  exponentials; the points along it are CasADi expressions of the 3n joint rotations, built at run time from the",
        "  closed-form exponential (a series near the straight segment). An obstacle touches the `tube` (default for 3-D",
        "  obstacles): the body of radius r1 about its axis, r1 off the layer, whose gap is the axis's gap less r1 wherever",
        "  around the section it touches (its ends rounded); or a material line of the surface, `inner` (the layer),",
        "  `outer` (the dorsal line, 2 r1 off it), `+z`, `-z` (the sides), which a twist turns with the section.",
        "- **Constraints** per obstacle and segment: the gap at the segment's end, at its least interior gap (moved there",
        "  between IPOPT solves, then among the unknowns of Newton on the KKT system, d gap/d sigma = 0 its equation), and at",
        "  four fixed points of the segment (they keep a step from letting a segment through an obstacle between its points).",
        "  While nothing touches, a step of the load history is the free Newton step; from first touch, the contact solve.",
        "  The KKT check is the planar one, with the least gap's curvature in the Lagrangian's Hessian at interior contacts.",
        "",
        "### The planar contact is its restriction",
        "",
        f"The same scene with the planar obstacle (`esba.statics.contact.solve_contact`) and with the 3-D one (n = 3);",
        f"differences below {PLANAR_BOUND:.0e} (the issue's bound) are printed as such:",
        "",
        "| case | contacts | max abs(theta_3D - theta_planar) (rad) | max abs(force difference) (N) | max abs(psi), abs(tau) (rad) |",
        "|---|---|---|---|---|",
    ]
    for name, count, dth, dfo, side in d.restriction:
        lines.append(f"| {name} | {count} | {floored(dth, '.1e', PLANAR_BOUND)} | {floored(dfo, '.1e', PLANAR_BOUND)} | {floored(side, '.1e', 1e-15)} |")
    gap, dq = d.out_of_reach
    ztip, zwall, force, ddead = d.wall
    lines += [
        "",
        f"**Out of reach.** A sphere of radius 20 mm at (0, 0, 300) with the 0.3 N tip load straight out of the plane: no",
        f"contact (least gap {gap:.2f} mm) and the free 3-D solution (max abs(q - q_free) {floored(dq, '.1e', PLANAR_BOUND)} rad).",
        "",
        f"**A sideways wall.** The same load pushes the free tip to z = {ztip:.3f} mm; a wall z = {zwall:.3f} mm (normal -z,",
        f"touching the layer, `side = \"inner\"`, so that the contact point is the payload's point) stops it at the tip with",
        f"{force:.6f} N. That force as a dead load at the tip (`Payload(force, 0, 1, -90)`, the model's own payload terms)",
        f"holds the same shape: max abs(q_dead - q_contact) {floored(ddead, '.1e', DEAD_LOAD_BOUND)} rad.",
        "",
        "### A sphere, and a cylinder of tilted axis",
        "",
        "A sphere of radius 10 mm at (66, 52, 3) inside the bend at 0.14 MPa (n = 3, the section's stiffnesses of",
        "`esba section`): it pushes the finger sideways and twists it.",
        "",
    ]
    lines += _contact_rows(d.sphere)
    lines += [
        "",
        "The finger at 0.2 MPa (n = 8) against a cylinder of radius 15 mm about (70, 45, 0) whose axis leans out of the",
        "plane, (0, 0.5, 1): it wraps the cylinder and slides along its slope.",
        "",
    ]
    lines += _contact_rows(d.tilted)
    lines += ["", f"![the finger against a tilted cylinder]({fig / FIGURE_3D})", ""]
    if d.path is not None:
        lines += [
            "### A path through contact events",
            "",
            "`esba.statics.contact.spatial_path.contact_path3d` (`esba path --3d SCENE.toml --to P` with obstacles): the sphere scene",
            "at 0 to 0.2 MPa, each point warm-started from the previous one, a change of where the obstacle touches (a touch, a",
            "lift-off, a slide onto the tip or a joint or across one) located by bisection on the pressure (to 1e-6 MPa; two",
            "changes within 1e-5 MPa of each other are one event):",
            "",
        ]
        lines += _path_rows(d.path, ".2f")
    if d.tip_path is not None:
        lines += [
            "A cylinder of tilted axis beside the tip (`esba.analysis.contact3d_cases.TIP_SLIDE_SCENE`), the pressure falling from",
            "0.095 to 0.065 MPa: the contact slides from inside segment 3 onto the rounded tip, and lifts off it.",
            "",
        ]
        lines += _path_rows(d.tip_path, ".3f")
    ok = sum(1 for r in d.random if r[2])
    lost = [r for r in d.random if not r[2]]
    lines += [
        "### Random scenes",
        "",
        f"Seeds {_ranges(RANDOM_SEEDS)} of `esba.analysis.contact3d_cases.random_scene` (a random pressure and",
        "off-plane payload, and a sphere, plane or tilted cylinder placed 1 to 6 mm into the free shape; tests/statics/test_contact3d.py",
        f"solves the same ones): {ok} of {len(d.random)} solved and stable on the constrained set at the scene's loads.",
    ]
    if lost:
        lines += [
            "The others find no equilibrium in contact beyond some load: a sphere near the tip that the pressure pushes the",
            "finger around, the least reduced-Hessian eigenvalue falling as the contact slides sideways, until the branch ends",
            "(a fold: the contact slides off and the finger jumps, which the solve does not follow). Its steps, halved down to",
            "2^-10 of the history, fail there; it says so (`Contact_Equilibrium_Lost`) and returns its last equilibrium, at that",
            "load (the table's numbers are that state's: a KKT point too).",
        ]
    lines += [
        "",
        "| seed | obstacle | ok | contacts | stationarity (N mm/rad) | complementarity (N mm) | least gap (mm) "
        "| least reduced eigenvalue (N mm/rad^2) | reached (pressure, loads) | status |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for seed, kind, good, count, st, co, mg, status, reached, eig in d.random:
        lines.append(f"| {seed} | {kind} | {'yes' if good else 'NO'} | {count} | {floored(st, '.1e', STATIONARITY_FLOOR)} | {floored(co, '.1e', FLOOR)} "
                     f"| {floored(mg, ' .1e', FLOOR)} | {eig:.2f} | ({reached[0]:.4f}, {reached[1]:.4f}) | {status} |")
    lines += [
        "",
        "### What 3-D contact costs",
        "",
        "Medians of 5 on a shared 2-core machine (`esba bench contact` prints the same line):",
        "",
        "| what | median (ms) |",
        "|---|---|",
    ]
    for name, s in d.costs:
        lines.append(f"| {name} | {t(1e3 * s, '.1f')} |")
    lines += [
        "",
        f"A 3-D contact solve at n = 3 takes {t(d.ratio, '.1f')} times the free 3-D solve: a few IPOPT solves with 6 n",
        "constraints an obstacle, the closest points on CasADi's virtual machine, Newton on the KKT system.",
        "",
        "### Not done in 3-D",
        "",
        "- A path in a load or a prescribed displacement; the jump where a contact branch ends (a contact sliding off the",
        "  rounded tip or off a sphere with force left): the 3-D solve stops at its last equilibrium and says so",
        "  (`Contact_Equilibrium_Lost`) rather than following the jump to where the finger lands.",
        "- Friction, in 3-D as in the plane: Coulomb's cone is a second-order cone constraint per contact (IPOPT takes it",
        "  smoothed), and a sliding contact's work depends on its path, so the statics are no longer a minimum of energy:",
        "  an incremental (load-stepped) problem with the friction force's direction as unknowns. Not clean enough yet.",
        "",
    ]
    return lines

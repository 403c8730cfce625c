"""The page ``docs/contact.md`` and its figures, rendered from :func:`esba.analysis.contact_cases.contact_cases`
(``esba docs --write contact`` writes them; ``esba docs --check contact`` says whether the committed page is stale).

Presentation only: every number comes from the cases; nothing here solves.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from esba.analysis.contact_cases import CYLINDER, TESTER_PRESSURE, ContactCases, contact_cases
from esba.figures.contact import blocked_figure, grasp_figure, tester_figure
from esba.infra.roundoff import floored

from esba.figures.contact3d import contact3d_figure

from .contact3d import FIGURE_3D, spatial_section
from .page import TIMES, Page, Progress, Rendered, Times

__all__ = ["PAGE", "ContactPage", "ContactSettings", "render_page", "FIGURES"]

#: The page's figures, in ``figures/`` beside it.
FIGURES = {"blocked": "contact-blocked.png", "tester": "contact-tester.png", "grasp": "contact-grasp.png"}


#: KKT numbers below this are round-off: printed as ``< 1e-12`` (esba.infra.roundoff).
FLOOR = 1e-12
#: The dead-load check's bound (the issue's 1e-9 rad): differences below it are printed as ``< 1e-09``,
#: their digits being the solvers' last ones.
DEAD_LOAD_BOUND = 1e-9


def _kkt_rows(path, picks) -> list[str]:
    lines = [
        "| P (MPa) | contacts: where, s, force (N) | max stationarity (N mm/rad) | least gap (mm) | least force (N) | max complementarity (N mm) | reduced Hessian eigenvalues (N mm/rad^2) | how |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for i in picks:
        p = path.points[i]
        k = p.kkt
        where = "; ".join(f"{c.where}, {c.s:.3f}, {c.force:.4f}" for c in p.contacts) or "none"
        eig = ", ".join(f"{v:.1f}" for v in k.reduced_eigenvalues[:3]) + (", ..." if len(k.reduced_eigenvalues) > 3 else "")
        lines.append(
            f"| {p.pressure:.2f} | {where} | {floored(k.stationarity, '.1e', FLOOR)} | {floored(k.min_gap, ' .1e', FLOOR)} | {floored(k.min_force, ' .1e', FLOOR)} "
            f"| {floored(k.complementarity, '.1e', FLOOR)} | {eig} | {p.status} |"
        )
    return lines


def render_page(data: ContactCases, command: str, t: Times = TIMES) -> str:
    """The Markdown of ``docs/contact.md``; its figures (:data:`FIGURES`) are in ``figures/`` beside it."""
    fig = Path("figures")
    b = data.blocked
    kkt_max = {
        "stationarity": max(p.kkt.stationarity for p in b.points + data.grasp.points),
        "complementarity": max(p.kkt.complementarity for p in b.points + data.grasp.points),
        "gap": min(p.kkt.min_gap for p in b.points + data.grasp.points),
        "force": min(p.kkt.min_force for p in b.points + data.grasp.points),
    }
    picks = [0, 5, 10, 15, 20, 25, 30]
    lines = [
        "# Contact: blocked force, a probe that pushes, a finger that closes on an object",
        "",
        f"<!-- Written by `{command}`; rerun it to refresh. -->",
        "",
        "Every other load in esba is a dead load. A probe, a wall, an object the finger closes on push back with a",
        "force that depends on the shape: here they are *constraints*, and their forces the constraints' multipliers",
        "(`esba/statics/contact/`, the obstacles in `esba/model/contact/`). Table 1 actuator, E = 0.54 MPa, variant",
        "`paper`; n as said.",
        "",
        "## Formulation",
        "",
        "- **Obstacles** are part of a scene (`[[obstacles]]` in a scene file, `Scene(obstacles=...)`): a flat probe or",
        "  wall, the half-plane beyond a line through `at` whose face looks along (cos Omega, -sin Omega) (`normal_deg`,",
        "  measured as a payload's angle), and a cylinder across the bending plane (a disc: `centre`, `radius`). A scene",
        "  without obstacles is solved as before; with any, `solve` solves the constrained problem. One line refuses an",
        "  obstacle that reaches into the actuator at rest, a half-plane whose face is behind the base, a radius <= 0, NaN.",
        "- **Where the body touches.** The model bends the inextensible layer (the chain of arcs of Eq. 1-2 *is* the layer,",
        "  on the inside of the bend): an obstacle on the bending side touches the layer (`inner`). The rest of the body",
        "  stands on the layer: the cross-section is a disc of radius r1 tangent to it (Section 3.2.2), so the dorsal",
        "  surface is the layer offset by 2 r1 to the outside of the bend (`outer`), the side an obstacle behind the",
        "  actuator touches. `side = \"auto\"` picks by the side of the obstacle at rest; the end caps are not surfaces of contact.",
        "- **Along whole segments, not only at the joints.** Each segment is a circular arc; its gap to a line or a",
        "  circle has at most one interior local minimum, found exactly (a grid, then Newton on d(gap)/d(sigma) = 0).",
        "  Per obstacle and segment two constraints: gap >= 0 at the joint, and at that closest point, a parameter",
        "  sigma of the NLP. With sigma at the minimum, the constraint's gradient is the least gap's (the envelope",
        "  theorem); the least gap's curvature, -g_theta,sigma g_sigma,theta / g_sigma,sigma, enters the Hessian of the",
        "  Lagrangian.",
        "- **The equilibrium** minimises U(theta) subject to gap >= 0: IPOPT with the generated exact gradient and",
        "  Hessian of U and CasADi's AD of the closed-form chain for the gaps; the closest points are moved to the",
        "  exact minima between IPOPT passes, and a Newton solve of the KKT system on the active set finishes. The",
        "  contact forces are the multipliers, recovered as the non-negative least-squares solution over the points",
        "  that touch (IPOPT's multipliers of a degenerate contact are barrier values). From a neighbouring state",
        "  (a sweep's previous point) a primal-dual active set (Newton on the previous active set; add the deepest",
        "  penetration, drop a negative force) is tried first and kept when every KKT condition holds; IPOPT otherwise",
        "  (`ContactOptions(certify=True)`, `--certify`: IPOPT also from every Newton result, which it moves by round-off).",
        "  The load history from rest is followed in steps halved where a step fails or where the shapes between two",
        "  states pass through an obstacle rather than meet it.",
        "- **Displacement control.** `Displacement(x=..., y=...)` prescribes the tip's coordinates (two more equality",
        "  constraints); their multipliers are the reaction force.",
        "- **Events on a path** (touch, lift-off, a contact sliding onto a joint or the tip) are bracketed between two",
        "  points and located by Brent's method on the continuation of the old active set: the gap of the point that",
        "  touches, the force of the contact that lifts off (`esba/paths/events.py`). A lift-off is kept where the",
        "  active-set solve just before it holds the contact with almost no force; where a contact branch ends with",
        "  force left (the contact slides off an edge and the actuator snaps: no equilibrium in contact follows), the",
        "  event is a `contact lost`, located by bisection on the load to the same relative 1e-10, each solve from the",
        "  last equilibrium in contact (`esba grasp --at -30,0 --radius 5 --no-plot` prints one: the tip slides off a",
        "  small cylinder beside the base; tests/statics/test_contact.py).",
        "- **Frictionless only.** Coulomb friction would add a tangential multiplier per contact with a cone",
        "  constraint and a stick/slip alternative: a complementarity problem that a minimisation does not pose (the",
        "  friction force is not the gradient of a potential), so not here.",
        "",
        "## The checks",
        "",
        f"Every result carries its KKT numbers. Over the {len(b.points)} points of the blocked-force curve and the",
        f"{len(data.grasp.points)} of the grasp below: stationarity of the Lagrangian at most **{floored(kkt_max['stationarity'], '.1e', FLOOR)} N mm/rad**,",
        f"complementarity |lambda gap| at most **{floored(kkt_max['complementarity'], '.1e', FLOOR)} N mm**, the least gap **{floored(kkt_max['gap'], ' .1e', FLOOR)} mm**",
        f"(no penetration), the least force **{floored(kkt_max['force'], ' .1e', FLOOR)} N**, and every reduced Hessian (the Lagrangian's, on the",
        f"tangent space of the active constraints) positive definite: stable on the constrained set. (Numbers below {FLOOR:.0e} are",
        "round-off and printed as such, not with their digits.)",
        "",
        "A check esba can do on itself: the probe at the tip is a horizontal dead load of the contact force's size.",
        "The contact solve against `solve` with `Payload(force, 90 deg, at = 1)` from the same state:",
        "",
        "| n | P (MPa) | contact force (N) | max abs(theta_contact - theta_dead) (rad) |",
        "|---|---|---|---|",
    ]
    for n, p, f, d in data.dead_load:
        lines.append(f"| {n} | {p:g} | {f:.6f} | {floored(d, '.1e', DEAD_LOAD_BOUND)} |")
    lines += [
        "",
        "## The blocked-force curve",
        "",
        "`esba blocked --pressure 0:0.3:31 -n 8`: a frictionless flat probe, the half-plane y >= 0 through the tip of",
        "the unpressurised actuator, on the bending side. At P = 0 the layer lies on it with no force; as the pressure",
        "rises the tip stays on the probe and the actuator bends away from it at the base and towards it near the tip,",
        "an S. The blocked force is the contact force:",
        "",
        "| P (MPa) | blocked force (N) | contact | tip x (mm) | theta_1 (deg) | theta_n (deg) |",
        "|---|---|---|---|---|---|",
    ]
    for i in picks:
        p = b.points[i]
        where = ", ".join(c.where for c in p.contacts) or "none (touching)"
        lines.append(f"| {p.pressure:.2f} | {b.forces[i]:.4f} | {where} | {p.tip[0]:.2f} | {np.degrees(p.theta[0]):.2f} | {np.degrees(p.theta[-1]):.2f} |")
    lines += [""]
    lines += _kkt_rows(b, picks[1::2])
    lines += [
        "",
        f"![blocked force]({fig / FIGURES['blocked']})",
        "",
        "## The tester through the snap",
        "",
        f"The 2 N case of [paths.md](paths.md) has its folds at 0.1735 / 0.1636 MPa: between them two stable states",
        f"share the same 2 N horizontal load. At P = {TESTER_PRESSURE:g} MPa, inside that window, a tester prescribes the",
        "tip's horizontal coordinate y (x free, a frictionless tester: `displacement_path`) and reads the",
        "reaction; a force-controlled tester ramps a horizontal dead load instead (`force_ramp`, each step an IPOPT",
        "solve from the previous state).",
        "",
    ]
    t_ = data.tester
    ys = np.array([p.tip[1] for p in t_.points])
    fs = -t_.reactions[:, 1]
    soft = [k for k, p in enumerate(t_.points) if not p.kkt.dead_load_stable]
    thetas = np.array([p.theta for p in t_.points])
    jump = int(np.argmax(np.max(np.abs(np.diff(thetas, axis=0)), axis=1))) if len(t_.points) > 1 else 0
    fmin = int(np.nanargmin(fs[: jump + 1]))
    down = data.ramp_down.jumps
    lines += [
        f"- Under displacement control the force falls from {fs[0]:.3f} N at y = {ys[0]:.1f} mm to its least, **{fs[fmin]:.4f} N**",
        f"  at y = {ys[fmin]:.1f} mm, and then *rises* again while the tip goes on moving against it: negative stiffness,",
        f"  from y = {ys[soft[0]]:.1f} to {ys[soft[-1]] if soft else float('nan'):.1f} mm ({len(soft)} points), where the same forces as",
        "  dead loads would not hold the state (the full Hessian of the Lagrangian has a negative eigenvalue) while the",
        "  prescribed displacement does (the reduced Hessian stays positive).",
        f"- The force-controlled ramp down from {data.ramp_down.forces[0]:.3f} N (steps of {abs(data.ramp_down.forces[1] - data.ramp_down.forces[0]):.3f} N) follows the same curve",
        "  and snaps at its first step past the least force: " + ("; ".join(f"at {f_:.3f} N from y = {a:.1f} to {b_:.1f} mm" for f_, a, b_ in down) or "no jump in the steps taken") + ".",
        f"- Displacement control itself ends at y = {ys[jump]:.1f} mm, where y stops increasing along the branch (the reduced",
        f"  Hessian's least eigenvalue falls to {min(p.kkt.reduced_eigenvalues[0] for p in t_.points[: jump + 1]):.1f} N mm/rad^2) and it jumps to the strongly bent",
        "  branch; a tester controlling another coordinate would go on.",
        f"- The ramp up from 0 N (from the unloaded state) stays on the strongly bent branch: at 2 N it is the other",
        "  stable state of the window.",
        "",
        f"![tester through the snap]({fig / FIGURES['tester']})",
        "",
        "## A finger closing on a cylinder",
        "",
        f"`esba grasp --radius {CYLINDER[1]:g} --at {CYLINDER[0][0]:g},{CYLINDER[0][1]:g} --pressure 0:0.3:31 -n 8`: a cylinder of radius",
        f"{CYLINDER[1]:g} mm at ({CYLINDER[0][0]:g}, {CYLINDER[0][1]:g}) mm on the bending side; the finger first touches it at",
        f"**P = {data.grasp.first_touch:.6f} MPa** (located by Brent's method on the gap)." if data.grasp.first_touch is not None else "it never touches it.",
        "",
        "| P (MPa) | total contact force (N) | contacts: where, s | length within 0.1 mm (mm) |",
        "|---|---|---|---|",
    ]
    for i in picks:
        p = data.grasp.points[i]
        where = "; ".join(f"{c.where}, {c.s:.3f}" for c in p.contacts) or "none"
        lines.append(f"| {p.pressure:.2f} | {data.grasp.forces[i]:.4f} | {where} | {p.contact_length():.1f} |")
    lines += ["", "Events along the pressure:", ""]
    for e in data.grasp.events:
        lines.append(f"- {e.describe()}: P = {e.parameter:.6f} MPa ({e.status})")
    lines += [
        "",
        "A slide is located where the slope of the gap at the segment's end changes sign (the layer is",
        "tangent-continuous at a joint, so a contact crosses it at one instant); a `guess` would be an event the old",
        "active set could not be continued to (the bracket's midpoint). The model's arcs touch a cylinder at points,",
        "one per segment at most; the length within 0.1 mm says how far the finger lies on it.",
        "",
        f"![finger closing on a cylinder]({fig / FIGURES['grasp']})",
        "",
        "## The cost of contact",
        "",
        "Medians on a shared 2-core machine (the benchmark with naive SciPy and the compiled limit is the contact",
        "section of [performance.md](performance.md), `esba bench contact`):",
        "",
        "| what | median (ms) |",
        "|---|---|",
    ]
    for name, s in data.costs:
        lines.append(f"| {name} | {t(1e3 * s, '.2f')} |")
    lines += [
        "",
        f"A contact solve at n = 3 takes {t(data.ratio, '.2f')} times the free solve of the same equilibrium.",
        "",
    ]
    if data.spatial is not None:  # the 3-D section (esba/pages/contact3d.py)
        lines += spatial_section(data.spatial, fig, t)
    lines += [
        "## Not done yet",
        "",
        "- Friction (above; in 3-D, its section).",
        "",
        "## Where else obstacles go",
        "",
        "`esba solve SCENE.toml` with `[[obstacles]]` prints the contacts and the KKT numbers (and `--history` chooses",
        "the load history from rest, with contact); `esba path SCENE.toml --to P` follows the pressure with contact and",
        "locates the events; `esba equilibria SCENE.toml` solves the contact problem from the load history's state and",
        "from every equilibrium of the free actuator (a multistart, `esba/statics/contact/multistart.py`). In Python,",
        "`esba.statics.contact.sweeps.contact_path` follows the pressure or a prescribed tip coordinate. In 3-D, `esba solve",
        "--3d SCENE.toml` (`examples/finger_sphere3d.toml`) solves a scene with planar or 3-D obstacles (the section above).",
        "`esba path --3d SCENE.toml --to P` follows the pressure with 3-D obstacles in 31 points and locates the touches,",
        "lift-offs, slides (onto the tip, across a joint) and where the contact branch is lost. `esba equilibria --3d",
        "SCENE.toml` solves the 3-D contact problem from the load history's state and from every free 3-D equilibrium",
        "(`esba.statics.contact.multistart.contact_equilibria3d`: a state that lay through a sphere may come out on its far",
        "side, a constrained equilibrium all the same), each with its contacts and its stability on the constrained set.",
        "",
    ]
    return "\n".join(lines)


@dataclass(frozen=True)
class ContactSettings:
    """The page's one setting: the command it names as its writer."""

    command: str


class ContactPage(Page):
    """``docs/contact.md`` and its three figures in ``figures/`` beside it."""

    name = "contact"

    def settings(self) -> ContactSettings:
        return ContactSettings(self.command)

    def compute(self, settings: ContactSettings | None = None, progress: Progress | None = None) -> ContactCases:
        return contact_cases(progress)

    def render(self, data: ContactCases, settings: ContactSettings, path: Path, times: Times = TIMES) -> Rendered:
        figures = {
            path.parent / "figures" / FIGURES["blocked"]: lambda: blocked_figure(data.blocked),
            path.parent / "figures" / FIGURES["tester"]: lambda: tester_figure(data.tester, (data.ramp_down, data.ramp_up), force=2.0),
            path.parent / "figures" / FIGURES["grasp"]: lambda: grasp_figure(data.grasp),
        }
        if data.spatial is not None:
            figures[path.parent / "figures" / FIGURE_3D] = lambda: contact3d_figure(data.spatial.tilted)
        return Rendered(render_page(data, settings.command, times), figures)


PAGE = ContactPage()

"""Equilibria of the spatial (3-D) model with obstacles: frictionless contact, forces as multipliers.

The planar contact (:mod:`.equilibrium`) in three dimensions. The unknowns are the 3n joint rotations
q = (theta, psi, tau) of :mod:`esba.model.spatial`; each obstacle (:mod:`esba.model.contact.spatial`:
a plane, a sphere, a cylinder of any axis, or a planar obstacle extruded across the plane) touches the
tube of the actuator's body (its axis, the gap less r1) or one line of its surface, whose points along each helical segment are CasADi expressions of q
built here from the SE(3) product of exponentials (:func:`esba.model.contact.spatial.symbolic_line`).

For each obstacle and segment, as in the plane, the gap at the segment's end and the gap at the
fraction sigma of the segment where the gap has its interior least value (found on a grid and by
Newton on d gap / d sigma = 0; the midpoint when the least gap is at an end); and, unlike the plane,
the gaps at four fixed points of the segment (:data:`SAMPLES`), which keep a step from letting a
segment through an obstacle between its points. IPOPT solves
min U(q) subject to every gap >= 0 at fixed sigma, the sigmas are moved to the exact minima, and again
(outer passes); then Newton on the KKT system of the active set, with the interior contacts' sigmas
among the unknowns (d gap / d sigma = 0 their equations), polishes the result to round-off. A moving
point that goes back and forth between two passes (a contact sliding along a segment that wraps the
obstacle) is moved to the secant root of closest(sigma) - sigma, and the fixed points near a moving point
that jumped stay constraints; Newton takes the force of a fixed point on a segment with an interior
least gap as that point's.

The load history is the free 3-D solve's (:func:`esba.statics.spatial.solve3d`): the pressure raised
from 0, then every load, ``options.ramp_steps`` legs each (1 unless given), each leg in adaptive steps:
halved when the step fails or the shapes between its ends pass through a sphere or a cylinder, doubled
after one that succeeds. While nothing touches, a step is the free damped Newton step, kept when the new
shape stays clear of every obstacle (else it is halved, up to 6 times, to meet the obstacle closer); from
there each step is the contact solve: first Newton on the KKT system of the last step's active set (kept
when every KKT condition holds at the exact closest points: ``Newton_Active_Set``, the continuation of the
contacts, which follows a branch up to its fold), else IPOPT and its passes. A step still bad at
:data:`MIN_STEP` of a leg ends the solve with the last equilibrium, at its load (``reached``):
``Contact_Equilibrium_Lost`` when it was in contact (near a fold of the contact branch, where the contact
slides off and the actuator jumps, which the solve does not follow; the message gives the least
reduced-Hessian eigenvalue there, which falls towards 0 as the fold nears).

The result lists each contact (where along the length, the point, the force vector and its size), the
least gap of each obstacle elsewhere, and the KKT conditions with their numbers
(:class:`esba.statics.contact.equilibrium.KKT`): stationarity, no penetration, non-negative forces,
complementarity, and the eigenvalues of the Lagrangian's Hessian (with the least gap's curvature at
interior contacts) on the tangent space of the active constraints.

Examples
--------
>>> from esba.model.scene import Scene
>>> from esba.model.contact.spatial import Sphere
>>> r = solve_contact3d(Scene(pressure=0.14, obstacles=(Sphere(centre=(66.0, 52.0, 3.0), radius=10.0),)))
>>> r.ok, [c.where for c in r.contacts], round(r.contacts[0].force, 4), r.kkt.complementarity < 1e-9
(True, ['inside segment 3'], 0.3607, True)
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import casadi as ca
import numpy as np
from scipy.optimize import nnls

from esba.infra import checks
from esba.infra.threads import single_threaded
from esba.model.contact.spatial import SpatialObstacle, lift, side_inflate, side_offset, symbolic_line
from esba.model.scene import Scene, SceneError
from esba.model.spatial import Model3D, centreline3d, load_model3d
from esba.model.stability import stability_verdict

from .equilibrium import KKT, ContactOptions, ContactOptionsError, next_fractions

__all__ = ["Contact3D", "ContactEquilibrium3D", "ContactProblem3D", "solve_contact3d", "DEFAULT_CONTACT_3D"]

INF = float("inf")

#: The 3-D solve's default settings: the planar ones (the load history in one step of each kind, halved where
#: needed), with at most 12 closest-point passes a step.
DEFAULT_CONTACT_3D = ContactOptions(max_outer=12)

#: Grid points per segment on which the least gap is first bracketed.
GRID = 17

#: Fixed points of each segment (fractions) that are constraints too: they keep a step of the load history
#: from letting a segment through an obstacle between its end and its closest point (0.5 is where a
#: segment without an interior least gap puts its moving point).
SAMPLES = (0.2, 0.4, 0.6, 0.8)

#: How close (a fraction of the segment) to its end a least gap counts as its joint's.
END = 1e-6

#: A fixed point of a segment within NEAR of its moving point is not a constraint (two constraints so near
#: each other make the problem degenerate for IPOPT); within NEAR_KEPT once the moving point has jumped.
NEAR, NEAR_KEPT = 0.1, 0.03

#: How far (a fraction of the segment) a moving point may move between two passes before the fixed
#: points near it are kept as constraints (:func:`_stage`).
JUMP = 0.05

#: The most times a solve halves a free step that would reach into an obstacle (to meet it closer).
MAX_TOUCH = 6

#: The status of a solve that finds no equilibrium in contact beyond some load (near a fold of the contact
#: branch: the contact slides off and the actuator jumps); its result is the last equilibrium found.
LOST = "Contact_Equilibrium_Lost"

#: The least step of the load history (a fraction of one leg of it, 2^-10): a step that still fails, or
#: passes through an obstacle, ends the solve.
MIN_STEP = 2.0**-10


def _size(kind: str) -> int:
    return {"plane": 6, "sphere": 4, "cylinder": 7}[kind]


@dataclass(frozen=True, eq=False)
class _NLP:
    solver: ca.Function
    warm: ca.Function
    terms: ca.Function      # (q, P, lam) -> g, jac_g, grad, hess, hess(lam . g)
    interior: ca.Function   # (q, pm, po, sig) -> gaps, d/dsigma, d2/dsigma2, d2/dq dsigma (Kn x 3n)
    along: ca.Function      # (q, pm, po, sig) -> gaps, d/dsigma, d2/dsigma2
    grid: ca.Function       # (q, pm, po, sig (Kn x GRID)) -> the gaps at each column of sig
    kkt: ca.Function        # (q, pm, po, sig, lam) -> residual, Jacobian in (q, sig, lam)
    line: ca.Function       # (q, pm, po, sig) -> the touching lines' points at sig (3 x Kn)
    kinds: tuple


def _nlp(model: Model3D, kinds: tuple, tol: float, max_iter: int, linear_solver: str) -> _NLP:
    key = ("contact3d", kinds, tol, max_iter, linear_solver, SAMPLES)
    found = model.registry.get(key)
    if found is not None:
        return found
    from esba.model.contact.spatial import SPATIAL_KINDS

    n, names = model.n, model.parameters
    N = 3 * n
    x = ca.SX.sym("q", N)
    pm = ca.SX.sym("pm", len(names))
    args = ca.vertsplit(pm) if len(names) else []
    length = pm[names.index("L")]
    K = len(kinds)
    po = ca.SX.sym("po", sum(_size(k) + 3 for k in kinds))  # per obstacle: its numbers, the curve's offset (y, z), what the gap loses
    sig = ca.SX.sym("sigma", K * n)
    ends, inner, fixed, points = [], [], [], []
    at = 0
    for k, kind in enumerate(kinds):
        cls = SPATIAL_KINDS[kind][0]
        par = po[at:at + _size(kind)]
        off = po[at + _size(kind):at + _size(kind) + 2]
        infl = po[at + _size(kind) + 2]
        at += _size(kind) + 3
        e, i = symbolic_line(x, length, off, sig[k * n:(k + 1) * n])
        ends.append([cls.symbolic_distance(v, par) - infl for v in e])
        inner.append([cls.symbolic_distance(v, par) - infl for v in i])
        at_samples = [symbolic_line(x, length, off, [h] * n)[1] for h in SAMPLES]
        fixed.append([cls.symbolic_distance(at_samples[h][i], par) - infl for i in range(n) for h in range(len(SAMPLES))])
        points += i
    g = ca.vertcat(*[ca.vertcat(*ends[k], *inner[k], *fixed[k]) for k in range(K)])
    gi = ca.vertcat(*[v for k in range(K) for v in inner[k]])
    u = model["energy"](x, *args)[0]
    grad = model["gradient"](x, *args)
    hess = model["hessian"](x, *args)
    P = ca.vertcat(pm, po, sig)
    lam = ca.SX.sym("lam", g.shape[0])
    hess_g = ca.hessian(ca.dot(lam, g), x)[0]
    jac_g = ca.jacobian(g, x)
    lam_f = ca.SX.sym("lam_f")
    grad_f = ca.Function("grad_f", [x, P], [u, grad], ["x", "p"], ["f", "grad_f"])
    hess_lag = ca.Function("hess_lag", [x, P, lam_f, lam], [ca.triu(lam_f * hess + hess_g)], ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])

    def solver(warm: bool) -> ca.Function:
        opts = {"grad_f": grad_f, "hess_lag": hess_lag, "print_time": False, "calc_lam_p": False, "show_eval_warnings": False,
                "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.tol": tol, "ipopt.max_iter": max_iter, "ipopt.linear_solver": linear_solver}
        if warm:
            opts.update({"ipopt.warm_start_init_point": "yes", "ipopt.mu_init": 1e-8, "ipopt.warm_start_bound_push": 1e-9,
                         "ipopt.warm_start_mult_bound_push": 1e-9, "ipopt.warm_start_slack_bound_push": 1e-9})
        return ca.nlpsol("esba_contact3d", "ipopt", {"x": x, "f": u, "g": g, "p": P}, opts)

    terms = ca.Function("contact3d_terms", [x, P, lam], [g, jac_g, grad, hess, hess_g])
    ds = ca.diag(ca.jacobian(gi, sig))
    dss = ca.diag(ca.jacobian(ds, sig))
    dxs = ca.jacobian(ds, x)
    interior = ca.Function("contact3d_interior", [x, pm, po, sig], [gi, ds, dss, dxs])
    along = ca.Function("contact3d_along", [x, pm, po, sig], [gi, ds, dss])
    grid = ca.Function("contact3d_gaps", [x, pm, po, sig], [gi]).map(GRID)
    force = ca.SX.sym("force", g.shape[0])  # the forces, >= 0: the Lagrangian is U - force . g
    r = ca.vertcat(grad - ca.mtimes(jac_g.T, force), ds, g)
    z = ca.vertcat(x, sig, force)
    kkt = ca.Function("contact3d_kkt", [x, pm, po, sig, force], [r, ca.jacobian(r, z)])
    line = ca.Function("contact3d_line", [x, pm, po, sig], [ca.horzcat(*points)])
    found = _NLP(solver(False), solver(True), terms, interior, along, grid, kkt, line, kinds)
    model.registry[key] = found
    return found


@dataclass(frozen=True)
class Contact3D:
    """One contact: obstacle, where along the length (``s`` the fraction of L; ``where`` says ``tip``,
    ``joint k`` or ``inside segment i``), the point on the touching line (mm), the force's size (N,
    the constraint's multiplier) and the unit vector along which the obstacle pushes the actuator."""

    obstacle: int
    kind: str
    surface: str
    s: float
    where: str
    point: tuple
    force: float
    direction: tuple
    gap: float

    @property
    def force_vector(self) -> np.ndarray:
        return self.force * np.asarray(self.direction)

    def to_dict(self) -> dict[str, Any]:
        return {"obstacle": self.obstacle, "kind": self.kind, "surface": self.surface, "s": self.s, "where": self.where,
                "point_mm": list(self.point), "force_n": self.force, "direction": list(self.direction),
                "force_vector_n": self.force_vector.tolist(), "gap_mm": self.gap}


@dataclass(frozen=True, eq=False)
class ContactEquilibrium3D:
    """One solved 3-D scene with obstacles (see the module's docstring). ``forces`` are the multipliers
    of every constraint (per obstacle: the n segment ends, the n points at ``sigma``, the points at
    :data:`SAMPLES` of each segment in turn)."""

    scene: Scene
    pressure: float
    q: np.ndarray
    n: int
    tip: np.ndarray
    tip_rotation: np.ndarray
    energy: float
    contacts: tuple
    gaps: tuple
    kkt: KKT
    status: str
    success: bool
    iterations: int
    outer: int
    halvings: int
    solve_time_s: float
    values: dict = field(repr=False)
    forces: np.ndarray = field(repr=False)
    sigma: np.ndarray = field(repr=False)
    obstacles: tuple = field(repr=False, default=())
    sides: tuple = ()
    message: str = ""
    model: str = ""
    reached: tuple = (1.0, 1.0)  # how far along the history (pressure, loads) the state is: (1, 1) when it succeeded

    @property
    def theta(self) -> np.ndarray:
        return self.q[: self.n]

    @property
    def psi(self) -> np.ndarray:
        return self.q[self.n: 2 * self.n]

    @property
    def tau(self) -> np.ndarray:
        return self.q[2 * self.n:]

    @property
    def ok(self) -> bool:
        """Converged, the KKT conditions hold and the equilibrium is stable on the constrained set."""
        return self.success and self.kkt.stability == "stable"

    @property
    def total_force(self) -> np.ndarray:
        return sum((c.force_vector for c in self.contacts), np.zeros(3))

    def to_dict(self) -> dict[str, Any]:
        return {
            "ok": self.ok, "pressure_mpa": self.pressure, "theta_deg": np.degrees(self.theta).tolist(), "psi_deg": np.degrees(self.psi).tolist(),
            "tau_deg": np.degrees(self.tau).tolist(), "tip_mm": self.tip.tolist(), "energy_nmm": self.energy,
            "contacts": [c.to_dict() for c in self.contacts], "total_contact_force_n": self.total_force.tolist(),
            "gaps_elsewhere_mm": list(self.gaps), "kkt": self.kkt.to_dict(),
            "obstacles": [{**o.to_dict(), "touches": s} for o, s in zip(self.obstacles, self.sides)],
            "status": self.status, "message": self.message, "iterations": self.iterations, "outer_passes": self.outer,
            "halvings": self.halvings, "reached": list(self.reached), "segments": self.n, "solve_time_s": self.solve_time_s, "model": self.model,
        }


class ContactProblem3D:
    """One scene's 3-D contact problem: the model, its parameter values, the obstacles and the NLP."""

    def __init__(self, scene: Scene, section: Mapping[str, float] | None = None, gravity_direction=None,
                 options: ContactOptions = DEFAULT_CONTACT_3D):
        from esba.statics.spatial import scene_values3d

        if not isinstance(scene, Scene):
            raise SceneError(f"scene={checks.quote(scene)}: expected an esba.model.scene.Scene")
        if not isinstance(options, ContactOptions):
            raise ContactOptionsError(f"options={checks.quote(options)}: expected a ContactOptions")
        if not scene.obstacles:
            raise SceneError("solve_contact3d: the scene has no obstacles (use esba.statics.spatial.solve_scene3d)")
        self.scene, self.options = scene, options
        self.effects, self.values = scene_values3d(scene.replace(obstacles=()), section, scene.down(gravity_direction))  # the pressure of the free actuator
        self.model = load_model3d(scene.segments, self.effects, scene.variant)
        L, r1 = scene.actuator.L, scene.actuator.r1
        self.obstacles: list[SpatialObstacle] = [lift(o) for o in scene.obstacles]
        self.sides = [o.resolved_side(L, r1) for o in self.obstacles]
        self.offsets = [side_offset(s, r1) for s in self.sides]
        self.kinds = tuple(o.kind for o in self.obstacles)
        self.n, self.K = scene.segments, len(self.obstacles)
        self.stride = (2 + len(SAMPLES)) * self.n  # constraints per obstacle
        self.m = self.stride * self.K
        self.nlp = _nlp(self.model, self.kinds, options.tol, options.max_iter, options.linear_solver)
        self.inflate = [side_inflate(s, r1) for s in self.sides]
        self.po = np.concatenate([np.concatenate([o.parameters(), off, [infl]]) for o, off, infl in zip(self.obstacles, self.offsets, self.inflate)])

    def lower(self, sigma: np.ndarray, interior: np.ndarray, keep: np.ndarray | None = None) -> np.ndarray:
        """The constraints' lower bounds: 0, but -inf for a fixed point within :data:`NEAR` of its segment's
        moving point (two constraints so near each other make the problem degenerate for IPOPT), within
        :data:`NEAR_KEPT` where ``keep`` says so (its moving point has jumped: see :func:`_stage`)."""
        lbg = np.zeros(self.m)
        n, S = self.n, len(SAMPLES)
        for k in range(self.K):
            for i in range(n):
                if interior[k * n + i]:
                    window = NEAR_KEPT if keep is not None and keep[k * n + i] else NEAR
                    for h, frac in enumerate(SAMPLES):
                        if abs(frac - sigma[k * n + i]) < window:
                            lbg[k * self.stride + 2 * n + i * S + h] = -INF
        return lbg

    def P(self, pv: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        return np.concatenate([pv, self.po, sigma.ravel()])

    def closest(self, q: np.ndarray, pv: np.ndarray, steps: int = 30) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per obstacle and segment (flat, K n): the fraction of the least interior gap, whether there
        is one, and the gap there; the midpoint (and not interior) where the least gap is at an end."""
        n, K = self.n, self.K
        grid = np.linspace(0.0, 1.0, GRID)
        d = np.asarray(self.nlp.grid(q, pv, self.po, np.broadcast_to(grid, (K * n, GRID))))  # (K n, GRID)
        inner = d[:, 1:-1]
        is_min = (inner <= d[:, :-2]) & (inner <= d[:, 2:])
        masked = np.where(is_min, inner, np.inf)
        j = np.argmin(masked, axis=1) + 1
        has = np.isfinite(masked[np.arange(K * n), j - 1])
        h = 1.0 / (GRID - 1)
        # a minimum in the first or last grid interval: the slope into the segment at its end
        _, ds0, _ = (np.asarray(v) for v in self.nlp.along(q, pv, self.po, np.zeros(K * n)))
        _, ds1, _ = (np.asarray(v) for v in self.nlp.along(q, pv, self.po, np.ones(K * n)))
        first = ~has & (ds0.ravel() < 0) & (d[:, 0] <= d[:, -1])
        last = ~has & ~first & (ds1.ravel() > 0)
        lo = np.where(first, 0.0, np.where(last, 1.0 - h, (j - 1) * h))
        hi = np.where(first, h, np.where(last, 1.0, (j + 1) * h))
        sg = np.where(first, 0.5 * h, np.where(last, 1.0 - 0.5 * h, j * h))
        cand = has | first | last
        for _ in range(steps):
            _, ds, dss = (np.asarray(v) for v in self.nlp.along(q, pv, self.po, sg))
            ds, dss = ds.ravel(), dss.ravel()
            step = np.where(dss > 0, ds / np.where(dss > 0, dss, 1.0), 0.0)
            new = np.clip(sg - step, lo, hi)
            done = float(np.max(np.abs(new - sg)[cand], initial=0.0)) <= 1e-13  # quadratic: the next step is round-off
            sg = new
            if done:
                break
        gap, ds, _ = (np.asarray(v) for v in self.nlp.along(q, pv, self.po, sg))
        gap, ds = gap.ravel(), ds.ravel()
        L = float(self.values["L"])
        # a least gap within 1e-6 of a segment's end is its joint's (one constraint for one point: the
        # gap between them is below (1e-6 L/n)^2 times the curvature, far below gap_tol)
        ok = cand & (sg > END) & (sg < 1.0 - END) & (np.abs(ds) <= 1e-9 * max(L / n, 1.0))
        sigma = np.where(ok, sg, 0.5)
        least = np.where(ok, gap, np.minimum(d[:, 0], d[:, -1]))
        return sigma, ok, np.minimum(least, d.min(axis=1))  # a line through a thin cylinder's axis (a kink): the grid's least


def _lb(prob: ContactProblem3D, values: Mapping[str, float]) -> np.ndarray:
    from esba.statics.spatial import _bounds

    return _bounds(prob.model, values)


def _forces(prob: ContactProblem3D, q: np.ndarray, P: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """The contact forces as the non-negative least-squares solution of dU/dq = J^T f over the points
    that touch (gap <= 1e-6 mm): IPOPT's multipliers of a degenerate contact are barrier values."""
    g, jac, grad = (np.asarray(v, dtype=float) for v in prob.nlp.terms(q, P, lam)[:3])
    g, grad = g.ravel(), grad.ravel()
    touching = np.flatnonzero(g <= 1e-6)
    out = np.zeros(prob.m)
    if touching.size:
        x, _ = nnls(jac[touching].T, grad)
        out[touching] = x
    return out


def _newton(prob: ContactProblem3D, pv: np.ndarray, q: np.ndarray, force: np.ndarray, sigma: np.ndarray, interior: np.ndarray,
            lb: np.ndarray, steps: int = 25) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """Newton on the KKT system of the active set (forces > force_tol): stationarity, gap = 0 there, and
    d gap / d sigma = 0 at the active interior points (their sigmas unknowns too). True when it
    converged to round-off and every KKT condition holds (gaps >= 0 elsewhere, forces >= 0)."""
    opts, n, K = prob.options, prob.n, prob.K
    N, L = 3 * n, float(prob.values["L"])
    active = force > opts.force_tol
    force = np.where(active, force, 0.0)
    for j in np.flatnonzero(active):  # a fixed point's force on a segment with a least interior gap: that point's
        k, local = divmod(j, prob.stride)
        if local >= 2 * n:
            i = (local - 2 * n) // len(SAMPLES)
            if interior[k * n + i]:
                force[k * prob.stride + n + i] += force[j]
                force[j], active[j], active[k * prob.stride + n + i] = 0.0, False, True
    act_int = np.zeros(K * n, dtype=bool)
    for j in np.flatnonzero(active):
        k, local = divmod(j, prob.stride)
        if local >= 2 * n:  # a fixed sample point
            continue
        if local >= n:
            if not interior[k * n + local - n]:
                return q, force, sigma, False
            act_int[k * n + local - n] = True
    force = np.where(active, force, 0.0)
    rows = np.concatenate([np.arange(N), N + np.flatnonzero(act_int), N + K * n + np.flatnonzero(active)])
    q, sigma = q.copy(), sigma.copy()
    converged = False
    for _ in range(steps):
        r, J = (np.asarray(v, dtype=float) for v in prob.nlp.kkt(q, pv, prob.po, sigma, force))
        r = r.ravel()[rows]
        grad = np.asarray(prob.nlp.terms(q, prob.P(pv, sigma), force)[2]).ravel()
        if float(np.max(np.abs(r[:N]))) <= 1e-11 * max(1.0, float(np.max(np.abs(grad)))) and float(np.max(np.abs(r[N:]), initial=0.0)) <= 1e-13 * L:
            converged = True
            break
        try:
            dz = np.linalg.solve(J[np.ix_(rows, rows)], -r)
        except np.linalg.LinAlgError:
            return q, force, sigma, False
        q = q + dz[:N]
        ni = int(act_int.sum())
        sigma[act_int] += dz[N:N + ni]
        force[active] += dz[N + ni:]
        if not np.all(np.isfinite(q)) or np.any(q <= lb) or np.any((sigma[act_int] <= 0.0) | (sigma[act_int] >= 1.0)):
            return q, force, sigma, False
    if not converged:
        return q, force, sigma, False
    new, inside, gaps = prob.closest(q, pv)
    keep = act_int
    sigma = np.where(keep, sigma, new)
    g = np.asarray(prob.nlp.terms(q, prob.P(pv, sigma), force)[0], dtype=float).ravel()
    ok = bool(np.all(g >= -opts.gap_tol) and np.all(gaps >= -opts.gap_tol) and np.all(force >= -opts.force_tol))
    return q, force, sigma, ok


def _stage(prob: ContactProblem3D, pv: np.ndarray, q0: np.ndarray, force0: np.ndarray | None, lb: np.ndarray):
    """One step of the load history: (q, forces, sigma, interior, status, success, iterations, outer passes)."""
    opts = prob.options
    sigma, interior, _ = prob.closest(q0, pv)
    if force0 is not None and np.any(force0 > opts.force_tol):  # first Newton on the last active set: its continuation, if every KKT condition holds
        polished = _newton(prob, pv, q0, force0, sigma, interior, lb)
        if polished[3]:
            q, force, sigma = polished[:3]
            return q, force, sigma, prob.closest(q, pv)[1], "Newton_Active_Set", True, 0, 0
    q, lam = q0, (None if force0 is None or not np.any(force0) else -force0)
    iterations, status, success = 0, "", False
    lbx = np.where(np.isfinite(lb), lb, -ca.inf)
    keep = np.zeros(prob.K * prob.n, dtype=bool)
    prev_sigma, prev_step, prev_int = sigma, np.zeros_like(sigma), np.zeros_like(keep)
    for outer in range(1, opts.max_outer + 1):
        solver = prob.nlp.warm if lam is not None else prob.nlp.solver
        x0 = np.where(np.isfinite(lb), np.maximum(q, np.where(np.isfinite(lb), lb, 0.0) + 1e-9 * np.maximum(1.0, np.abs(np.where(np.isfinite(lb), lb, 0.0)))), q)
        kw = {"x0": x0, "p": prob.P(pv, sigma), "lbx": lbx, "lbg": prob.lower(sigma, interior, keep), "ubg": np.full(prob.m, INF)}
        if lam is not None:
            kw["lam_g0"] = lam
        sol = solver(**kw)
        stats = solver.stats()
        q = np.asarray(sol["x"], dtype=float).ravel()
        lam = np.asarray(sol["lam_g"], dtype=float).ravel()
        iterations += int(stats.get("iter_count", 0))
        status, success = str(stats.get("return_status", "unknown")), bool(stats.get("success", False))
        if not success:
            return q, -lam, sigma, interior, status, False, iterations, outer
        force = _forces(prob, q, prob.P(pv, sigma), lam)
        new, inside, gaps = prob.closest(q, pv)
        near = inside & interior & (gaps < 1e-3 * float(prob.values["L"]))
        moved = float(np.max(np.abs(new - sigma)[near], initial=0.0))
        changed = bool(np.any(inside != interior))
        polished = _newton(prob, pv, q, force, new, inside, lb)
        if polished[3]:
            q, force, sigma = polished[:3]
            _, interior, _ = prob.closest(q, pv)
            return q, force, sigma, interior, status, True, iterations, outer
        if moved <= 1e-7 and float(np.min(gaps, initial=INF)) >= -opts.gap_tol:  # no penetration at the exact closest points
            sigma = np.where(inside, new, 0.5)
            force = _forces(prob, q, prob.P(pv, sigma), lam)
            return q, force, sigma, inside, status, True, iterations, outer
        # a moving point that jumped along its segment: the fixed points near it stay constraints from now
        # on (without them the segment sags between the old and the new point, and the passes cycle)
        keep |= inside & interior & (np.abs(new - sigma) > JUMP)
        # a moving point that goes back and forth (the closest point of the solution constrained at a lies
        # beyond b, and that of b back before a): the fixed point of sigma -> closest(sigma) lies between,
        # and the secant of closest(sigma) - sigma through the last two passes finds it
        step = new - sigma
        nxt = next_fractions(sigma, new, prev_sigma, prev_step, inside & interior & prev_int)
        prev_sigma, prev_step, prev_int = sigma, step, inside & interior
        sigma, interior = nxt, inside
    return q, -lam, sigma, interior, "Closest_Points_Not_Converged", False, iterations, opts.max_outer


def _crosses(prob: ContactProblem3D, pv: np.ndarray, before: np.ndarray, after: np.ndarray) -> bool:
    """Whether the shapes between two states (linear in q), or the last, reach deep into a sphere or a
    cylinder (deeper than min(1 mm, R/4)): the step passed through it rather than meeting it."""
    deep = [min(1.0, 0.25 * o.radius) if o.kind in ("sphere", "cylinder") else INF for o in prob.obstacles]
    if all(math.isinf(v) for v in deep):
        return False
    for t in (0.25, 0.5, 0.75, 1.0):
        qt = (1 - t) * before + t * after
        gaps = np.asarray(prob.nlp.grid(qt, pv, prob.po, np.broadcast_to(np.linspace(0.0, 1.0, GRID), (prob.K * prob.n, GRID))))
        for k in range(prob.K):
            if float(np.min(gaps[k * prob.n:(k + 1) * prob.n])) < -deep[k]:
                return True
    return False


@single_threaded
def solve_contact3d(scene: Scene, section: Mapping[str, float] | None = None, options: ContactOptions | None = None, *,
                    gravity_direction=None, problem: ContactProblem3D | None = None,
                    history: Sequence[tuple[float, float]] | None = None, pressure: float | None = None,
                    warm: ContactEquilibrium3D | None = None) -> ContactEquilibrium3D:
    """The 3-D equilibrium of a scene with obstacles (frictionless contact), its contacts and KKT check.

    Parameters
    ----------
    scene : Scene
        With at least one obstacle (planar ones are extruded across the bending plane).
    section : mapping, optional
        EI_side and GJ (N mm^2), as :func:`esba.statics.spatial.solve_scene3d`.
    options : ContactOptions, optional
        :data:`DEFAULT_CONTACT_3D` unless given.
    gravity_direction : three numbers
        The direction of the weight in the base frame (with gravity; default the scene's ``gravity_direction``).
    history : sequence of (float, float), optional
        (pressure, load) fractions of the load history from rest, ending at (1, 1).
    pressure : float, optional
        Instead of the scene's (MPa).
    warm : ContactEquilibrium3D, optional
        A neighbouring equilibrium of the same scene at another pressure (a path's previous point): the
        pressure is moved from there in one step (halved as needed), the loads held.
    """
    options = DEFAULT_CONTACT_3D if options is None else options
    prob = problem if problem is not None else ContactProblem3D(scene, section, gravity_direction, options)
    from esba.statics.spatial import load_names, newton3d

    t0 = time.perf_counter()
    model, values = prob.model, dict(prob.values)
    loads = load_names(model)
    if pressure is not None:
        from esba.model.scene import check_pressure

        values["P"] = check_pressure(pressure)
    pressure = float(values.get("P", 0.0))
    p_from = 0.0 if warm is None else float(warm.pressure)
    steps = options.ramp_steps
    if warm is not None:
        history = [(1.0, 1.0)]
    elif history is None:
        history = [(k / steps, 0.0) for k in range(1, steps + 1)]
        if loads and any(values[k] != 0.0 for k in loads):
            history += [(1.0, k / steps) for k in range(1, steps + 1)]

    def at(frac: tuple[float, float]) -> dict[str, float]:
        v = dict(values)
        v["P"] = p_from + frac[0] * (pressure - p_from)
        v.update({k: frac[1] * float(values[k]) for k in loads})
        return v

    q = np.zeros(model.size)
    force: np.ndarray | None = None
    sigma, interior = np.full(prob.K * prob.n, 0.5), np.zeros(prob.K * prob.n, dtype=bool)
    if warm is not None:
        q, force, sigma = warm.q.copy(), warm.forces.copy(), warm.sigma.copy()
        interior = prob.closest(q, model.param_vector(at((0.0, 1.0))))[1]
    iterations = outer = halvings = 0
    status, success = "", True
    here = (0.0, 0.0) if warm is None else (0.0, 1.0)
    touch, touched = 0, warm is not None and bool(np.any(force > options.force_tol))
    for target in history:  # each leg of the history in adaptive steps: halved when a step fails, doubled when it succeeds
        origin, t, dt = here, 0.0, 1.0
        while success and t < 1.0:
            dt = min(dt, 1.0 - t)
            t_try = 1.0 if 1.0 - (t + dt) < 1e-12 else t + dt
            frac = tuple(a + t_try * (b - a) for a, b in zip(origin, target))
            v = at(frac)
            pv, lb = model.param_vector(v), _lb(prob, v)
            if force is None or not np.any(force > options.force_tol):  # nothing touches yet: the free step, if it stays clear
                qf, fine, _ = newton3d(model, v, q, lb=lb)
                if fine:
                    sf, inf_, gf = prob.closest(qf, pv)
                    if float(np.min(gf)) >= -options.gap_tol and not _crosses(prob, pv, q, qf):
                        q, force, sigma, interior, here, t, dt = qf, np.zeros(prob.m), sf, inf_, frac, t_try, 2.0 * dt
                        continue
                    if touch < MAX_TOUCH:  # it would reach into an obstacle: a smaller step, to meet it closer
                        touch += 1
                        dt *= 0.5
                        continue
            qn, fn, sn, inn, status, success, it, out = _stage(prob, pv, q, force, lb)
            touched = True
            iterations += it
            outer += out
            bad = not success or _crosses(prob, pv, q, qn)
            if bad and dt > MIN_STEP:
                halvings += 1
                dt *= 0.5
                success = True
                continue
            if bad:  # no equilibrium reached from the last one: the solve ends there, and says where
                ended = status if not success else "Passed_Through_Obstacle"
                status, success = (LOST if force is not None and np.any(force > options.force_tol) else ended), False
                break
            q, force, sigma, interior, here = qn, fn, sn, inn, frac
            t, dt = t_try, 2.0 * dt
    if success and not touched:
        status = "Newton (free, clear of every obstacle)"
    last = values if success else at(here)  # a failed solve reports its last equilibrium, at that load
    pv = model.param_vector(last)
    out = _result(prob, pv, float(last.get("P", 0.0)), q, force if force is not None else np.zeros(prob.m), sigma, interior, status, success,
                  iterations, outer, halvings, time.perf_counter() - t0, _lb(prob, last))
    if not success:
        eig = out.kkt.reduced_eigenvalues
        soft = f"; its least reduced-Hessian eigenvalue {eig[0]:.3g} N mm/rad^2" if eig.size else ""
        where = f"beyond {here[0]:.4g} of the pressure and {here[1]:.4g} of the loads (P = {last.get('P', 0.0):.6g} MPa)"
        if status == LOST:
            why = (f"no equilibrium in contact found {where}: steps down to {MIN_STEP:.2g} of the history further end {ended} (near a fold of the "
                   "contact branch, where the contact slides off and the actuator jumps, which the solve does not follow)")
        else:
            why = f"the contact solve did not converge ({status}) {where}"
        out = dataclasses.replace(out, message=f"{why}; the state shown is the last equilibrium, at that load{soft}")
    return dataclasses.replace(out, values=last, reached=(1.0, 1.0) if success else tuple(float(v) for v in here))


def _result(prob: ContactProblem3D, pv, pressure, q, force, sigma, interior, status, success, iterations, outer, halvings, elapsed, lb) -> ContactEquilibrium3D:
    opts, n, K, m = prob.options, prob.n, prob.K, prob.m
    N = 3 * n
    P = prob.P(pv, sigma)
    g, jac, grad, hess, hess_g = (np.asarray(v, dtype=float) for v in prob.nlp.terms(q, P, force))
    g, grad = g.ravel(), grad.ravel()
    stationarity = float(np.max(np.abs(grad - jac.T @ force)))
    active = force > opts.force_tol
    lagrangian = hess - hess_g
    _, _, dss, dxs = (np.asarray(v, dtype=float) for v in prob.nlp.interior(q, pv, prob.po, sigma))
    dss, dxs = dss.ravel(), dxs.reshape(K * n, N)
    for k in range(K):
        for i in range(n):
            j = k * prob.stride + n + i
            if active[j] and interior[k * n + i] and dss[k * n + i] > 0:  # the least gap's curvature
                lagrangian = lagrangian + force[j] * np.outer(dxs[k * n + i], dxs[k * n + i]) / dss[k * n + i]
    rows = jac[active]
    if rows.shape[0]:
        _, sv, vt = np.linalg.svd(rows)
        rank = int(np.sum(sv > 1e-10 * max(sv[0], 1e-300)))
        z = vt[rank:].T
    else:
        z = np.eye(N)
    reduced = z.T @ lagrangian @ z
    eig = np.sort(np.linalg.eigvalsh(0.5 * (reduced + reduced.T))) if z.shape[1] else np.zeros(0)
    verdict = stability_verdict(eig, opts.critical_tol) if eig.size else "stable"
    movable = np.linalg.norm(jac, axis=1) > 1e-12
    grazing = int(np.sum((g <= opts.gap_tol) & ~active & movable))
    kkt = KKT(stationarity=stationarity, min_gap=float(np.min(g, initial=INF)), min_force=float(np.min(force, initial=INF)),
              complementarity=float(np.max(np.abs(force * g), initial=0.0)), reduced_eigenvalues=eig, active=int(rows.shape[0]),
              grazing=grazing, stability=verdict, dead_load_eigenvalues=np.sort(np.linalg.eigvalsh(0.5 * (lagrangian + lagrangian.T))))
    L = float(prob.values["L"])
    ends = np.ones(K * n)
    pts_end = np.asarray(prob.nlp.line(q, pv, prob.po, ends)).T
    pts_in = np.asarray(prob.nlp.line(q, pv, prob.po, sigma)).T
    pts_at = [np.asarray(prob.nlp.line(q, pv, prob.po, np.full(K * n, h))).T for h in SAMPLES]
    contacts, gaps = [], []
    for k, o in enumerate(prob.obstacles):
        rest = []
        for local in range(prob.stride):
            j = k * prob.stride + local
            if not active[j]:
                if movable[j]:
                    rest.append(g[j])
                continue
            if local < n:
                i, frac, pt = local, 1.0, pts_end[k * n + local]
                where = "tip" if i == n - 1 else f"joint {i + 1}"
            elif local < 2 * n:
                i, frac, pt = local - n, float(sigma[k * n + local - n]), pts_in[k * n + local - n]
                where = f"inside segment {i + 1}"
            else:
                i, h = divmod(local - 2 * n, len(SAMPLES))
                frac, pt = SAMPLES[h], pts_at[h][k * n + i]
                where = f"inside segment {i + 1}"
            normal = o.normal_at(pt[None, :])[0]
            pt = pt - prob.inflate[k] * normal  # the tube: the point of its surface that touches
            contacts.append(Contact3D(k, o.kind, prob.sides[k], (i + frac) / n, where, tuple(float(v) for v in pt), float(force[j]),
                                      tuple(float(v) for v in normal), float(g[j])))
        gaps.append(float(min(rest)) if rest else None)
    contacts.sort(key=lambda c: (c.s, c.obstacle))
    message = ""
    if not success:
        message = f"the contact solve did not converge: {status}"
    elif np.any(q[:n] <= lb[:n] + 1e-6 * np.maximum(1.0, np.abs(lb[:n]))):
        success, status = False, "At_Bound"
        message = "the solve stopped on the model's domain boundary (Eq. 10: the chamber closes): not an equilibrium"
    elif kkt.min_gap < -opts.gap_tol:
        success, message = False, f"penetration {-kkt.min_gap:.3g} mm > gap_tol"
    elif verdict != "stable":
        message = f"the equilibrium is {verdict} on the constrained set: smallest reduced-Hessian eigenvalue {eig[0]:.3g} N mm/rad^2"
    tip, rot, _ = prob.model.pose(q, L)
    return ContactEquilibrium3D(
        scene=prob.scene, pressure=pressure, q=q, n=n, tip=tip, tip_rotation=rot, energy=prob.model.energy(q, pv), contacts=tuple(contacts),
        gaps=tuple(gaps), kkt=kkt, status=status, success=success, iterations=iterations, outer=outer, halvings=halvings,
        solve_time_s=elapsed, values=dict(prob.values), forces=force, sigma=sigma, obstacles=tuple(prob.obstacles), sides=tuple(prob.sides),
        message=message, model=prob.model.path.name,
    )


def centreline(result: ContactEquilibrium3D, per_segment: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """The layer's mid-line of a result: points (m, 3) and frames (m, 3, 3)."""
    return centreline3d(result.n, result.q, float(result.values["L"]), per_segment)

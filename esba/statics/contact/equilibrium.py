"""The equilibrium with contact: min U(theta) with every gap >= 0, the contact forces as multipliers.

Frictionless contact between rigid obstacles (:mod:`esba.model.contact.obstacles`) and the
actuator's surface (the inextensible layer, or the dorsal surface 2 r1 off it), along whole
segments (:mod:`.nlp`). IPOPT solves the NLP; the fractions of each segment's closest point are
updated until they are the exact minima of the gap (:func:`esba.model.contact.surface.closest_points`),
a few outer passes, each a warm-started IPOPT solve.

The result lists each contact (where along the length, its force and direction), the least gap of
each obstacle elsewhere, and the KKT conditions checked with their numbers
(:class:`KKT`): stationarity of the Lagrangian, no penetration, non-negative forces,
complementarity, and second-order stability on the constrained set (the eigenvalues of the
Hessian of the Lagrangian, with the exact least gap's curvature, reduced to the tangent space of
the active constraints).

A prescribed tip displacement (:class:`Displacement`: x, y or both, as a tester imposes) is two
more constraints; their multipliers are the reaction force the tester applies.

Examples
--------
>>> from esba.model.scene import Scene
>>> from esba.model.contact import HalfPlane
>>> r = solve_contact(Scene(pressure=0.1, obstacles=(HalfPlane(at=(135.0, 0.0)),)))
>>> r.ok, [c.where for c in r.contacts], round(r.contacts[0].force, 4)
(True, ['tip'], 1.8298)
>>> r.kkt.complementarity < 1e-8
True
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any, Sequence

import numpy as np
from scipy.optimize import nnls

from esba.infra import checks
from esba.infra.errors import InputError
from esba.infra.threads import single_threaded
from esba.model.closed_form import pressure_for_angle
from esba.model.contact.obstacles import Cylinder
from esba.model.contact.surface import closest_points, offset_of, surface_points
from esba.model.generated import Model, near_domain_bound
from esba.model.scene import Scene, SceneError, check_pressure
from esba.model.stability import stability_verdict
from esba.solvers.minimise import LINEAR_SOLVERS

from .nlp import ContactNLP, contact_nlp

__all__ = ["ContactOptions", "ContactOptionsError", "ContactProblem", "Displacement", "Contact", "KKT", "ContactState", "ContactEquilibrium", "solve_contact"]

INF = float("inf")

#: The distance (mm) within which the surface counts as lying on an obstacle in :meth:`ContactEquilibrium.contact_length`.
WRAP_MM = 0.1
#: Samples per segment of that length.
WRAP_SAMPLES = 200


class ContactOptionsError(InputError):
    """A contact option or a prescribed displacement that is not allowed."""


@dataclass(frozen=True)
class ContactOptions:
    """Settings of :func:`solve_contact`, validated on creation.

    Parameters
    ----------
    tol : float
        IPOPT's tolerance.
    max_iter : int
        IPOPT's iteration limit per solve.
    linear_solver : str
        ``mumps`` or ``spral``.
    ramp_steps : int
        Steps of the load history from the rest state (pressure, then payloads), each a warm-started
        contact solve: contact depends on the way there. A step that fails, or whose shape passes
        through an obstacle on the way (:func:`_crosses`), is halved (up to :data:`MAX_HALVINGS` times).
    max_outer : int
        Passes that move each segment's constraint point to its exact closest point.
    force_tol : float
        A contact force above this (N) makes its constraint active in the second-order check.
    gap_tol : float
        Penetration tolerated (mm) and the gap below which a point counts as touching.
    critical_tol : float
        Relative size below which a reduced-Hessian eigenvalue counts as zero.
    samples_per_segment : int
        Points per segment of the result's centre-line.
    newton : bool
        From a warm start, try Newton on the KKT system of the previous active set first; its
        result is kept when every KKT condition holds there (else IPOPT solves).
    certify : bool
        Also run IPOPT from a Newton result (with its multipliers) and report its status and how far
        it moved the state (the KKT numbers certify the result either way; IPOPT costs a few ms more).
    """

    tol: float = 1e-10
    max_iter: int = 300
    linear_solver: str = "mumps"
    ramp_steps: int = 1
    max_outer: int = 30
    force_tol: float = 1e-7
    gap_tol: float = 1e-7
    critical_tol: float = 1e-9
    samples_per_segment: int = 20
    newton: bool = True
    certify: bool = False

    def __post_init__(self) -> None:
        for name in ("tol", "force_tol", "gap_tol", "critical_tol"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not 0 < v < 1:
                raise ContactOptionsError(f"{name}={checks.quote(v)}: expected a number > 0 and < 1")
        checks.whole("max_iter", self.max_iter, 1, ContactOptionsError, 100_000)
        checks.whole("ramp_steps", self.ramp_steps, 1, ContactOptionsError, 1000)
        checks.whole("max_outer", self.max_outer, 1, ContactOptionsError, 1000)
        checks.whole("samples_per_segment", self.samples_per_segment, 1, ContactOptionsError, 1000)
        for name in ("newton", "certify"):
            if not isinstance(getattr(self, name), bool):
                raise ContactOptionsError(f"{name}={checks.quote(getattr(self, name))}: expected True or False")
        if self.linear_solver not in LINEAR_SOLVERS:
            raise ContactOptionsError(f"linear_solver={checks.quote(self.linear_solver)}: allowed are {', '.join(LINEAR_SOLVERS)}")


DEFAULT_CONTACT = ContactOptions()


@dataclass(frozen=True)
class Displacement:
    """A prescribed tip position, as a tester imposes it: x, y (mm) or both; None leaves it free (one
    of them at least is given). :meth:`check_reach` refuses a target the actuator cannot reach.

    >>> Displacement(y=float("nan"))
    Traceback (most recent call last):
    ...
    esba.statics.contact.equilibrium.ContactOptionsError: displacement.y=nan: expected a finite number
    >>> Displacement()
    Traceback (most recent call last):
    ...
    esba.statics.contact.equilibrium.ContactOptionsError: displacement: no coordinate given: expected x, y or both (mm)
    >>> Displacement(x=140.0, y=60.0).check_reach(135.0)
    Traceback (most recent call last):
    ...
    esba.statics.contact.equilibrium.ContactOptionsError: displacement=(x=140, y=60): the target is 152.3 mm from the base, farther than the actuator's length L = 135 mm: expected a target within L of the base
    """

    x: float | None = None
    y: float | None = None

    def __post_init__(self) -> None:
        for name in ("x", "y"):
            v = getattr(self, name)
            if v is not None:
                v = checks.finite(f"displacement.{name}", v, ContactOptionsError)
                if abs(v) > 1e6:
                    raise ContactOptionsError(f"displacement.{name}={v:g}: expected |value| <= 1e6 mm")
                object.__setattr__(self, name, v)
        if self.x is None and self.y is None:
            raise ContactOptionsError("displacement: no coordinate given: expected x, y or both (mm)")

    def check_reach(self, L: float) -> None:
        """Refuse a target farther from the base than the length L (mm) of the inextensible layer: its
        tip cannot get there (for one coordinate, |coordinate| > L)."""
        given = [(name, v) for name, v in (("x", self.x), ("y", self.y)) if v is not None]
        reach = math.hypot(*(v for _, v in given))
        if reach > L:
            what = ", ".join(f"{name}={v:g}" for name, v in given)
            raise ContactOptionsError(
                f"displacement=({what}): the target is {reach:.4g} mm from the base, farther than the actuator's length "
                f"L = {L:g} mm: expected a target within L of the base"
            )

    def bounds(self) -> tuple[list[float], list[float]]:
        lo = [-INF if v is None else v for v in (self.x, self.y)]
        hi = [INF if v is None else v for v in (self.x, self.y)]
        return lo, hi


@dataclass(frozen=True)
class Contact:
    """One contact: obstacle, where along the length, the force and its direction.

    ``s`` is the fraction of L from the base; ``where`` says ``tip``, ``joint k`` or ``inside
    segment i``; ``point`` the contact point on the touching surface (mm); ``force`` its size (N,
    the constraint's multiplier); ``direction`` the unit vector along which the obstacle pushes the
    actuator (the obstacle's normal there); ``surface`` ``inner`` (the layer) or ``outer``.
    """

    obstacle: int
    kind: str
    surface: str
    s: float
    where: str
    point: tuple[float, float]
    force: float
    direction: tuple[float, float]
    gap: float

    @property
    def force_vector(self) -> np.ndarray:
        """The force on the actuator, N."""
        return self.force * np.asarray(self.direction)

    def to_dict(self) -> dict[str, Any]:
        return {
            "obstacle": self.obstacle, "kind": self.kind, "surface": self.surface, "s": self.s, "where": self.where,
            "point_mm": list(self.point), "force_n": self.force, "direction": list(self.direction),
            "force_vector_n": self.force_vector.tolist(), "gap_mm": self.gap,
        }


@dataclass(frozen=True)
class KKT:
    """The KKT conditions at a contact equilibrium, with their numbers.

    ``stationarity`` max |dU/dtheta - J^T lambda - J_tip^T R| (N mm/rad); ``min_gap`` (mm, >= -gap_tol:
    no penetration); ``min_force`` (N, >= -force_tol); ``complementarity`` max |lambda_j gap_j| (N mm);
    ``reduced_eigenvalues`` of the Lagrangian's Hessian on the tangent space of the ``active``
    constraints (N mm/rad^2; all > 0: stable on the constrained set); ``grazing``: points that touch
    with no force (at an event: touch or lift-off), left out of the tangent space.
    A grazing point is reported in the count, not as a failure: the equilibrium is a KKT point.
    ``dead_load_eigenvalues``: of the same Hessian on every direction, i.e. with each contact force
    and reaction replaced by a dead load of its size: negative ones mark where a force-controlled
    load would not hold the state (negative stiffness) while the constraint does.
    """

    stationarity: float
    min_gap: float
    min_force: float
    complementarity: float
    reduced_eigenvalues: np.ndarray
    active: int
    grazing: int
    stability: str
    dead_load_eigenvalues: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def dead_load_stable(self) -> bool:
        """The state would hold under dead loads of the same forces (no negative stiffness)."""
        return stability_verdict(self.dead_load_eigenvalues) == "stable" if self.dead_load_eigenvalues.size else True

    def to_dict(self) -> dict[str, Any]:
        return {
            "stationarity_nmm": self.stationarity, "min_gap_mm": self.min_gap, "min_force_n": self.min_force,
            "complementarity_nmm": self.complementarity, "reduced_eigenvalues": [float(v) for v in self.reduced_eigenvalues],
            "active": self.active, "grazing": self.grazing, "stability": self.stability,
            "dead_load_eigenvalues": [float(v) for v in self.dead_load_eigenvalues], "dead_load_stable": self.dead_load_stable,
        }


@dataclass(frozen=True, eq=False)
class ContactState:
    """What a sweep carries from one equilibrium to the next: angles, multipliers and closest-point fractions."""

    theta: np.ndarray
    lam_g: np.ndarray
    sigma: np.ndarray
    pressure: float = 0.0
    load: float = 1.0


@dataclass(frozen=True, eq=False)
class ContactEquilibrium:
    """One solved scene with obstacles (see the module's docstring).

    ``reaction`` is the force (N, [x, y]) a prescribed displacement takes (None without one, or when
    the solve failed: ``message`` says why); ``newton_steps``, ``ipopt_steps`` and ``halvings`` the load
    history's steps taken by active-set Newton and by IPOPT, and the steps halved on the way;
    ``gaps`` each obstacle's least gap (mm) over the points not in contact; ``state`` the warm start
    for a neighbouring solve.
    """

    scene: Scene
    pressure: float
    theta: np.ndarray
    tip: np.ndarray
    centreline: np.ndarray = field(repr=False)
    energy: float
    contacts: tuple[Contact, ...]
    gaps: tuple[float, ...]
    kkt: KKT
    reaction: np.ndarray | None
    displacement: Displacement | None
    status: str
    success: bool
    iterations: int
    outer: int
    solve_time_s: float
    state: ContactState = field(repr=False)
    message: str = ""
    newton_steps: int = 0
    ipopt_steps: int = 0
    halvings: int = 0

    @property
    def ok(self) -> bool:
        """Converged, the KKT conditions hold and the equilibrium is stable on the constrained set."""
        return self.success and self.kkt.stability == "stable"

    @property
    def total_force(self) -> np.ndarray:
        """The sum of the contact forces on the actuator, N."""
        return sum((c.force_vector for c in self.contacts), np.zeros(2))

    @property
    def contact_span(self) -> float:
        """The length of the actuator between its first and last contact, mm (0 with one or none)."""
        if len(self.contacts) < 2:
            return 0.0
        s = [c.s for c in self.contacts]
        return (max(s) - min(s)) * self.scene.actuator.L

    def contact_length(self, within_mm: float = WRAP_MM) -> float:
        """The length of the touching surfaces that lies within ``within_mm`` of an obstacle, mm: how
        far the actuator wraps an object (the model's arcs touch a cylinder at points; this is the
        length that lies on it to that tolerance; 0 with no contact, and a point inside an obstacle
        deeper than that does not lie on it)."""
        if not self.contacts:
            return 0.0
        n, L = self.scene.segments, self.scene.actuator.L
        sigma = np.broadcast_to(np.linspace(0.0, 1.0, WRAP_SAMPLES + 1)[:-1] + 0.5 / WRAP_SAMPLES, (n, WRAP_SAMPLES))
        near = np.zeros((n, WRAP_SAMPLES), dtype=bool)
        for o in self.scene.obstacles:
            q = surface_points(self.theta, L, offset_of(o.resolved_side(), self.scene.actuator.r1), sigma)
            near |= np.abs(o.distance(q)) <= within_mm
        return float(np.sum(near)) * L / (n * WRAP_SAMPLES)

    @property
    def total_angle_deg(self) -> float:
        return math.degrees(float(np.sum(self.theta)))

    def to_dict(self, centreline: bool = False) -> dict[str, Any]:
        out = {
            "ok": self.ok, "pressure_mpa": self.pressure, "theta_deg": np.degrees(self.theta).tolist(),
            "total_angle_deg": self.total_angle_deg, "tip_mm": [float(self.tip[0]), float(self.tip[1])],
            "tip_angle_deg": math.degrees(float(self.tip[2])), "energy_nmm": self.energy,
            "contacts": [c.to_dict() for c in self.contacts],
            "total_contact_force_n": self.total_force.tolist(), "contact_span_mm": self.contact_span,
            f"contact_length_within_{WRAP_MM:g}mm": self.contact_length(),
            "gaps_elsewhere_mm": list(self.gaps), "kkt": self.kkt.to_dict(),
            "obstacles": [o.to_dict() for o in self.scene.obstacles],
            "displacement": None if self.displacement is None else {"x": self.displacement.x, "y": self.displacement.y},
            "reaction_n": None if self.reaction is None else self.reaction.tolist(),
            "status": self.status, "message": self.message, "iterations": self.iterations, "outer_passes": self.outer,
            "newton_steps": self.newton_steps, "ipopt_steps": self.ipopt_steps, "halvings": self.halvings,
            "segments": self.scene.segments, "solve_time_s": self.solve_time_s,
        }
        if centreline:
            out["centreline_mm"] = self.centreline[:, :2].tolist()
        return out


# ---------------------------------------------------------------------------------------------


def _pack(pv: np.ndarray, scene: Scene, offsets: Sequence[float], sigma: np.ndarray) -> np.ndarray:
    parts = [pv]
    for k, o in enumerate(scene.obstacles):
        parts += [np.asarray(o.parameters(), dtype=float), [offsets[k]], sigma[k]]
    return np.concatenate(parts)


def _closest(scene: Scene, theta: np.ndarray, offsets: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    L, n = scene.actuator.L, scene.segments
    found = [closest_points(theta, L, offsets[k], o) for k, o in enumerate(scene.obstacles)]
    return np.array([f[0] for f in found]).reshape(-1, n), np.array([f[1] for f in found], dtype=bool).reshape(-1, n)


class ContactProblem:
    """One scene's contact NLP with its bounds: the pieces every solve of a sweep shares."""

    def __init__(self, scene: Scene, options: ContactOptions, displacement: Displacement | None):
        if not scene.obstacles and displacement is None:
            raise SceneError("solve_contact: the scene has no obstacles and no prescribed displacement (use esba.statics.equilibrium.solve)")
        if displacement is not None:
            displacement.check_reach(scene.actuator.L)  # before the model is loaded or generated
        self.scene, self.options = scene, options
        self.model: Model = scene.model()
        self.nlp: ContactNLP = contact_nlp(self.model, tuple(o.kind for o in scene.obstacles), options.tol, options.max_iter, options.linear_solver)
        self.sides = [o.resolved_side() for o in scene.obstacles]
        self.offsets = [offset_of(s, scene.actuator.r1) for s in self.sides]
        self.K, self.n = len(scene.obstacles), scene.segments
        self.m = 2 * self.n * self.K
        self.set_displacement(displacement)

    def set_displacement(self, displacement: Displacement | None) -> None:
        """Prescribe the tip (or free it): the bounds of the last two constraints."""
        if displacement is not None:
            displacement.check_reach(self.scene.actuator.L)
        self.displacement = displacement
        x, y = (None, None) if displacement is None else (displacement.x, displacement.y)
        self.fixed = np.array([x is not None, y is not None])
        self.targets = np.array([0.0 if x is None else x, 0.0 if y is None else y])
        lo, hi = ([-INF, -INF], [INF, INF]) if displacement is None else displacement.bounds()
        self.lbg = np.concatenate([np.zeros(self.m), lo])
        self.ubg = np.concatenate([np.full(self.m, INF), hi])

    def solve(self, pv: np.ndarray, theta0: np.ndarray, lam_g0: np.ndarray | None, lbx: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, str, bool, int, int]:
        """The outer passes: IPOPT at fixed closest-point fractions, then the fractions moved to the exact minima."""
        opts = self.options
        sigma, _ = _closest(self.scene, theta0, self.offsets)
        theta, lam = theta0, lam_g0
        iterations, status, success = 0, "", False
        prev_sigma, prev_step = sigma.copy(), np.zeros_like(sigma)
        for outer in range(1, opts.max_outer + 1):
            solver = self.nlp.warm_solver if lam is not None else self.nlp.solver
            x0 = np.maximum(theta, lbx + 1e-9 * np.maximum(1.0, np.abs(lbx)))
            kw = {"x0": x0, "p": _pack(pv, self.scene, self.offsets, sigma), "lbx": lbx, "lbg": self.lbg, "ubg": self.ubg}
            if lam is not None:
                kw["lam_g0"] = lam
            sol = solver(**kw)
            stats = solver.stats()
            theta = np.asarray(sol["x"], dtype=float).ravel()
            lam = np.asarray(sol["lam_g"], dtype=float).ravel()
            iterations += int(stats.get("iter_count", 0))
            status, success = str(stats.get("return_status", "unknown")), bool(stats.get("success", False))
            if not success:
                return theta, lam, sigma, status, success, iterations, outer
            new, interior = _closest(self.scene, theta, self.offsets)
            gaps = np.array([o.distance(_points(self.scene, theta, self.offsets[k], new[k])) for k, o in enumerate(self.scene.obstacles)]).reshape(-1, self.n)
            near = interior & (gaps < 1e-3 * self.scene.actuator.L)
            moved = float(np.max(np.abs(new - sigma)[near], initial=0.0))
            forces = _multipliers(self, pv, theta, lam, sigma)
            if moved <= 1e-10 and float(np.min(gaps, initial=INF)) >= -opts.gap_tol:
                polished = _newton(self, pv, theta, forces, sigma, lbx, steps=4)
                if polished[3]:
                    theta, forces, sigma = polished[:3]
                return theta, forces, sigma, status, success, iterations, outer
            # IPOPT found the active set at the old closest points; Newton on it, the points moving
            # with theta and the least gap's curvature in the Hessian, converges quadratically
            polished = _newton(self, pv, theta, forces, sigma, lbx, steps=20)
            if polished[3]:
                return (*polished[:3], status, success, iterations, outer)
            sigma, prev_sigma, prev_step = next_fractions(sigma, new, prev_sigma, prev_step, near), sigma, new - sigma
        return theta, lam, sigma, "Closest_Points_Not_Converged", False, iterations, opts.max_outer


def next_fractions(sigma: np.ndarray, new: np.ndarray, prev_sigma: np.ndarray, prev_step: np.ndarray, near: np.ndarray) -> np.ndarray:
    """The closest-point fractions of the next outer pass: ``new``, except for a point near contact
    that turned back (its move against the last one): the closest point of the state constrained at
    one fraction lies beyond the other and back, so the fixed point of sigma -> closest(sigma) lies
    between them, and the secant of closest(sigma) - sigma through the last two passes finds it
    (without it the passes cycle; the 3-D contact solve, :mod:`esba.statics.contact.spatial`, takes it too)."""
    step = new - sigma
    flip = near & (step * prev_step < 0)
    if not flip.any():
        return new
    with np.errstate(divide="ignore", invalid="ignore"):
        secant = sigma - step * (sigma - prev_sigma) / np.where(flip, step - prev_step, 1.0)
    lo, hi = np.minimum(sigma, prev_sigma), np.maximum(sigma, prev_sigma)
    return np.where(flip & np.isfinite(secant), np.clip(secant, lo, hi), new)


def _envelope_curvature(prob: ContactProblem, theta: np.ndarray, p: np.ndarray, force: np.ndarray, active: np.ndarray) -> np.ndarray:
    """The Lagrangian's Hessian term of the least gaps at active interior contacts: sum of
    lambda g_theta,sigma g_theta,sigma^T / g_sigma,sigma (the least gap min_sigma g is more concave than g at fixed sigma)."""
    n, K = prob.n, prob.K
    if not any(active[k * 2 * n + n:(k + 1) * 2 * n].any() for k in range(K)):
        return np.zeros((n, n))
    _, dss, dxs = (np.asarray(v, dtype=float) for v in prob.nlp.interior(theta, p))
    dss, dxs = dss.ravel(), dxs.reshape(K * n, n)
    out = np.zeros((n, n))
    for k in range(K):
        for i in range(n):
            j = k * 2 * n + n + i
            if active[j] and dss[k * n + i] > 0:
                v = dxs[k * n + i]
                out += force[j] * np.outer(v, v) / dss[k * n + i]
    return out


#: The most times a solve halves a step of its load history (a step that fails, or whose shape passes through an obstacle).
MAX_HALVINGS = 40


def _crosses(prob: ContactProblem, before: np.ndarray, after: np.ndarray) -> bool:
    """Whether the shapes between two states (linear in theta) reach deep into an obstacle: the step
    passed through it rather than meeting it (a deeper reach than min(1 mm, R/4))."""
    L = prob.scene.actuator.L
    grid = np.tile(np.linspace(0.0, 1.0, 9), (prob.n, 1))
    for k, o in enumerate(prob.scene.obstacles):
        if not isinstance(o, Cylinder):  # nothing passes through a half-plane: its far side is all inside it
            continue
        deep = min(1.0, 0.25 * o.radius)
        for t in (0.25, 0.5, 0.75):
            q = surface_points((1 - t) * before + t * after, L, prob.offsets[k], grid)
            if float(np.min(o.distance(q))) < -deep:
                return True
    return False


def _predicted_set(prob: ContactProblem, pv: np.ndarray, theta: np.ndarray, lam: np.ndarray, sigma: np.ndarray, active: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The active set of the quadratic model of the problem at the start (one evaluation, then
    linear algebra only): the same add/drop rule on H d + grad + J_A^T lam_A = 0, g_A + J_A d = 0 (the
    prescribed coordinates at their targets). The nonlinear active set starts from it, and Newton
    from theta + d (the model's step on it)."""
    opts, m, n = prob.options, prob.m, prob.n
    g, jac, grad, hess, hess_g, _ = (np.asarray(v, dtype=float) for v in prob.nlp.terms(theta, _pack(pv, prob.scene, prob.offsets, sigma), lam))
    g, grad = g.ravel() - np.concatenate([np.zeros(m), prob.targets]), grad.ravel()
    h = hess + hess_g
    active = active.copy()
    d = np.zeros(n)
    for _ in range(2 * m + 2):
        idx = np.flatnonzero(active)
        a = jac[idx]
        try:
            sol = np.linalg.solve(np.block([[h, a.T], [a, np.zeros((idx.size, idx.size))]]), -np.concatenate([grad, g[idx]]))
        except np.linalg.LinAlgError:
            return active, np.zeros(n)
        d, mult = sol[:n], sol[n:]
        force = np.full(m, np.inf)
        inside = idx < m
        force[idx[inside]] = -mult[inside]
        predicted = g[:m] + jac[:m] @ d
        if m and force.min() < -opts.force_tol:
            active[int(np.argmin(force))] = False
        elif m and np.where(active[:m], np.inf, predicted).min() < -opts.gap_tol:
            active[int(np.argmin(np.where(active[:m], np.inf, predicted)))] = True
        else:
            break
    return active, d


def _active_set(prob: ContactProblem, pv: np.ndarray, theta: np.ndarray, lam: np.ndarray, sigma: np.ndarray, lbx: np.ndarray):
    """A primal-dual active-set method from a neighbouring equilibrium: Newton on the previous active
    set; a point that penetrates is added, a contact whose force comes out negative dropped, one at
    a time, until every first-order KKT condition holds. (theta, lam_g, sigma) or None when it fails
    (IPOPT then solves)."""
    opts, m = prob.options, prob.m
    active, step = _predicted_set(prob, pv, theta, lam, sigma, np.concatenate([-lam[:m] > opts.force_tol, prob.fixed]))
    start = theta + step if np.all(theta + step > lbx) and np.all(np.isfinite(step)) else theta
    for _ in range(4 * prob.n + 2):
        th, lm, sg, fine = _newton(prob, pv, start, np.where(active, np.minimum(lam, 0.0), 0.0), sigma, lbx, steps=30, active=active, checked=False)
        if not fine:
            return None
        force = -lm[:m]
        gaps = np.asarray(prob.nlp.terms(th, _pack(pv, prob.scene, prob.offsets, sg), lm)[0], dtype=float).ravel()[:m]
        if m and force.min() < -opts.force_tol:
            active[int(np.argmin(force))] = False
        elif m and gaps.min() < -opts.gap_tol:
            active[int(np.argmin(gaps))] = True
        else:
            return th, lm, sg
    return None


def _multipliers(prob: ContactProblem, pv: np.ndarray, theta: np.ndarray, lam: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """The contact forces as the non-negative least-squares solution of dU/dtheta = J^T lambda over
    the points that touch (gap <= 1e-6 mm), the prescribed coordinates' multipliers free.

    IPOPT's multipliers of a degenerate contact (many points touching with no force, as the whole
    layer lies on the probe at P = 0) are barrier values of order mu / gap; this gives the forces
    that hold the equilibrium, 0 where none is needed, and the same forces as IPOPT where they are unique."""
    m = prob.m
    p = _pack(pv, prob.scene, prob.offsets, sigma)
    g, jac, grad = (np.asarray(v, dtype=float) for v in prob.nlp.terms(theta, p, lam)[:3])
    g, grad = g.ravel(), grad.ravel()
    touching = np.flatnonzero(g[:m] <= 1e-6)
    fixed = np.flatnonzero(prob.fixed) + m
    cols = [jac[touching].T, jac[fixed].T, -jac[fixed].T]
    a = np.hstack(cols) if touching.size + fixed.size else np.zeros((prob.n, 0))
    if a.shape[1] == 0:
        return np.zeros_like(lam)
    x, _ = nnls(a, grad)
    out = np.zeros_like(lam)
    out[touching] = -x[:touching.size]
    out[fixed] = -(x[touching.size:touching.size + fixed.size] - x[touching.size + fixed.size:])
    return out


def _newton(prob: ContactProblem, pv: np.ndarray, theta: np.ndarray, lam: np.ndarray, sigma: np.ndarray, lbx: np.ndarray,
            steps: int = 8, active: np.ndarray | None = None, checked: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """Newton on the KKT system of the active set of ``lam`` (the contacts with force, the prescribed
    coordinates), or of ``active`` (a mask of the m + 2 constraints): stationarity and gap = 0 there,
    the other multipliers 0; the closest points moved with it. True when it converged to round-off
    and, when ``checked``, with every check of a KKT point met (gaps >= 0 elsewhere, forces >= 0);
    the caller falls back to IPOPT otherwise."""
    opts, m = prob.options, prob.m
    lam = lam.copy()
    if active is None:
        active = np.concatenate([-lam[:m] > opts.force_tol, prob.fixed])
    lam[~active] = 0.0
    n, m2 = prob.n, 2 * prob.n
    active = active.copy()
    for j in np.flatnonzero(active[:m]):  # an interior point at the end of its segment is its joint's twin
        k, local = divmod(j, m2)
        if local >= n:
            i = local - n
            twin = k * m2 + i if sigma[k][i] >= 1.0 - 1e-12 else (k * m2 + i - 1 if sigma[k][i] <= 1e-12 and i > 0 else -1)
            if twin >= 0 and active[twin]:
                lam[twin] += lam[j]
                lam[j] = 0.0
                active[j] = False
    idx = np.flatnonzero(active)
    interior = np.array([j % m2 >= n for j in idx[idx < m]], dtype=bool)
    target = np.concatenate([np.zeros(m), prob.targets])
    converged = False
    for _ in range(steps):
        p = _pack(pv, prob.scene, prob.offsets, sigma)
        g, jac, grad, hess, hess_g, _ = (np.asarray(v, dtype=float) for v in prob.nlp.terms(theta, p, lam))
        g = g.ravel()
        r1 = grad.ravel() + jac.T @ lam
        r2 = (g - target)[idx]
        res = max(float(np.max(np.abs(r1))), float(np.max(np.abs(r2), initial=0.0)))
        if res <= 1e-11 * max(1.0, float(np.max(np.abs(grad)))):
            if not interior.any():
                converged = True
                break
            new, _ = _closest(prob.scene, theta, prob.offsets)  # an interior contact: its point moves with theta
            moving = np.zeros_like(sigma, dtype=bool)
            for j in idx[idx < m]:
                k, local = divmod(j, m2)
                moving[k, local - n] = local >= n
            if float(np.max(np.abs(new - sigma)[moving], initial=0.0)) <= 1e-12:
                sigma = new
                converged = True
                break
            sigma = new
            continue
        a = jac[idx]
        lagrangian = hess + hess_g
        if interior.any():
            lagrangian = lagrangian + _envelope_curvature(prob, theta, p, -lam[:m], active[:m])
        kkt = np.block([[lagrangian, a.T], [a, np.zeros((idx.size, idx.size))]])
        try:
            step = np.linalg.solve(kkt, -np.concatenate([r1, r2]))
        except np.linalg.LinAlgError:
            return theta, lam, sigma, False
        theta = theta + step[:n]
        lam[idx] = lam[idx] + step[n:]
        if not np.all(np.isfinite(theta)) or np.any(theta <= lbx):
            return theta, lam, sigma, False
        if interior.any():
            sigma, _ = _closest(prob.scene, theta, prob.offsets)
    if not converged:
        return theta, lam, sigma, False
    sigma, _ = _closest(prob.scene, theta, prob.offsets)
    if not checked:
        return theta, lam, sigma, True
    p = _pack(pv, prob.scene, prob.offsets, sigma)
    g = np.asarray(prob.nlp.terms(theta, p, lam)[0], dtype=float).ravel()
    ok = bool(np.all(g[:m] >= -opts.gap_tol) and np.all(-lam[:m] >= -opts.force_tol)) and float(np.max(np.abs(g[m:] - prob.targets)[prob.fixed], initial=0.0)) <= opts.gap_tol
    return theta, lam, sigma, ok


def _points(scene: Scene, theta: np.ndarray, offset: float, sigma: np.ndarray) -> np.ndarray:
    return surface_points(theta, scene.actuator.L, offset, sigma[:, None])[:, 0]


def _merged(contacts: list[Contact]) -> list[Contact]:
    """Contacts in order along the length, one per point (a joint's and its segment's end point are one)."""
    out: list[Contact] = []
    for c in sorted(contacts, key=lambda c: (c.obstacle, c.s)):
        if out and out[-1].obstacle == c.obstacle and abs(out[-1].s - c.s) <= 1e-12:
            prev = out.pop()
            c = Contact(c.obstacle, c.kind, c.surface, c.s, c.where, c.point, prev.force + c.force, c.direction, min(prev.gap, c.gap))
        out.append(c)
    return sorted(out, key=lambda c: c.s)


def _resolve(scene: Scene, pressure: float | None) -> float:
    if pressure is not None:
        return check_pressure(pressure)
    if scene.pressure is not None:
        return scene.pressure
    return pressure_for_angle(scene.unloaded().replace(obstacles=()))


def _ramp(scene: Scene, pressure: float, steps: int, history: Sequence[tuple[float, float]] | None = None) -> list[tuple[float, float]]:
    """(pressure, load factor) of the load history with contact: inflate, then load, ``steps`` each;
    or the (pressure, load) fraction steps of ``history`` (:mod:`esba.statics.history`)."""
    if history is not None:
        return [(pressure * pf, lf) for pf, lf in history]
    out = [(pressure * k / steps, 0.0) for k in range(1, steps + 1)]
    if scene.payloads or scene.gravity:
        out += [(pressure, k / steps) for k in range(1, steps + 1)]
    return out


@single_threaded
def solve_contact(
    scene: Scene,
    options: ContactOptions | None = None,
    *,
    pressure: float | None = None,
    displacement: Displacement | None = None,
    warm: ContactState | None = None,
    problem: Any = None,
    history: Sequence[tuple[float, float]] | None = None,
) -> ContactEquilibrium:
    """The equilibrium of a scene with obstacles (frictionless contact), its contacts and KKT check.

    Parameters
    ----------
    scene : Scene
        With at least one obstacle.
    options : ContactOptions, optional
    pressure : float, optional
        Instead of the scene's (MPa).
    displacement : Displacement, optional
        Prescribe the tip's x, y or both: the result's ``reaction`` is the force it takes.
    warm : ContactState, optional
        A neighbouring equilibrium (a sweep's previous point): one solve from there, no load history.
        Without it the load history is followed from the rest state (pressure, then payloads, in
        ``options.ramp_steps`` steps each).
    history : sequence of (float, float), optional
        The load history from rest as (pressure, load) fraction steps ending at (1, 1), instead
        (``esba.statics.history.history_steps`` of a name or of steps); each step halved as needed.
    """
    options = DEFAULT_CONTACT if options is None else options
    if not isinstance(options, ContactOptions):
        raise ContactOptionsError(f"options={checks.quote(options)}: expected a ContactOptions")
    if not isinstance(scene, Scene):
        raise SceneError(f"scene={checks.quote(scene)}: expected an esba.model.scene.Scene")
    if displacement is not None and not isinstance(displacement, Displacement):
        raise ContactOptionsError(f"displacement={checks.quote(displacement)}: expected a Displacement")
    if problem is None:
        prob = ContactProblem(scene, options, displacement)
    else:
        prob = problem
        prob.set_displacement(displacement)
    pressure = _resolve(scene, pressure)
    t0 = time.perf_counter()
    model = prob.model
    full = scene.parameters(pressure)
    lbx = model.lower_bounds(full)
    iterations = outer = 0
    if warm is not None:
        steps = [(pressure, 1.0)]
        theta, lam = np.asarray(warm.theta, dtype=float), np.asarray(warm.lam_g, dtype=float)
        sigma, here = np.asarray(warm.sigma, dtype=float), (float(warm.pressure), float(warm.load))
    else:
        steps = _ramp(scene, pressure, options.ramp_steps, history)
        theta, lam = np.zeros(scene.segments), np.zeros(prob.m + 2)
        sigma, here = np.full((prob.K, scene.segments), 0.5), (0.0, 0.0)  # at rest: the midpoints (moved once theta moves)
    status, success, newton_steps, ipopt_steps, halvings = "", True, 0, 0, 0
    todo = list(reversed(steps))
    while todo:
        target = todo.pop()
        values = scene.parameters(*target)
        pv, lbx_k = model.param_vector(values), model.lower_bounds(values)
        found, how = None, ""
        if options.newton:  # the fast path: Newton from the previous state on an active set it adjusts, checked
            found, how = _active_set(prob, pv, theta, lam, sigma, lbx_k), "newton"
        if found is None:
            th, lm, sg, status, success, it, out = prob.solve(pv, theta, lam if np.any(lam) else None, lbx_k)
            iterations += it
            outer += out
            found, how = ((th, lm, sg) if success else None), "ipopt"
        if found is None or _crosses(prob, theta, found[0]):
            if halvings < MAX_HALVINGS:  # a smaller step of the load history
                halvings += 1
                todo += [target, (0.5 * (here[0] + target[0]), 0.5 * (here[1] + target[1]))]
                continue
            if found is None:
                theta, lam, sigma = th, lm, sg
                break
            status = "Passed_Through_Obstacle"
            success = False
        theta, lam, sigma = found
        here = target
        newton_steps += how == "newton"
        ipopt_steps += how == "ipopt"
        if not success:
            break
    if success and ipopt_steps == 0:
        status = "Newton_Active_Set"
    pv = model.param_vector(full)
    if success and ipopt_steps == 0 and options.certify:  # IPOPT from the Newton result, with its multipliers
        th, lm, sg, how, fine, it, out = prob.solve(pv, theta, lam, lbx)
        iterations += it
        outer += out
        moved = float(np.max(np.abs(th - theta)))
        status = f"Newton_Active_Set; IPOPT {how}: {it} iterations from it, moved {moved:.1e} rad"
        if fine:
            theta, lam, sigma = th, lm, sg
        else:
            success = False
    r = _result(prob, pv, pressure, theta, lam, sigma, status, success, iterations, outer, time.perf_counter() - t0, lbx)
    return replace(r, newton_steps=newton_steps, ipopt_steps=ipopt_steps, halvings=halvings)


def _result(prob: ContactProblem, pv: np.ndarray, pressure: float, theta: np.ndarray, lam: np.ndarray, sigma: np.ndarray, status: str,
            success: bool, iterations: int, outer: int, elapsed: float, lbx: np.ndarray) -> ContactEquilibrium:
    scene, opts, n, K = prob.scene, prob.options, prob.n, prob.K
    p = _pack(pv, scene, prob.offsets, sigma)
    g, jac, grad, hess, hess_g, tip = (np.asarray(v, dtype=float) for v in prob.nlp.terms(theta, p, lam))
    g, grad, tip = g.ravel(), grad.ravel(), tip.ravel()
    m = prob.m
    force = -lam[:m]
    gap = g[:m]
    stationarity = float(np.max(np.abs(grad + jac.T @ lam)))
    active = force > opts.force_tol
    lagrangian = hess + hess_g + _envelope_curvature(prob, theta, p, force, active)
    rows = [jac[j] for j in range(m) if active[j]]
    if prob.displacement is not None:
        rows += [jac[m + c] for c, v in enumerate((prob.displacement.x, prob.displacement.y)) if v is not None]
    if rows:
        a = np.array(rows)
        _, sv, vt = np.linalg.svd(a)
        rank = int(np.sum(sv > 1e-10 * max(sv[0], 1e-300)))
        z = vt[rank:].T
    else:
        z = np.eye(n)
    reduced = z.T @ lagrangian @ z
    eig = np.sort(np.linalg.eigvalsh(0.5 * (reduced + reduced.T))) if z.shape[1] else np.zeros(0)
    verdict = stability_verdict(eig, opts.critical_tol) if eig.size else "stable"
    movable = np.linalg.norm(jac[:m], axis=1) > 1e-12  # the base point (and a segment's end at it) cannot move
    grazing = int(np.sum((gap <= opts.gap_tol) & ~active & movable))
    kkt = KKT(
        stationarity=stationarity,
        min_gap=float(np.min(gap, initial=INF)) if m else INF,
        min_force=float(np.min(force, initial=INF)) if m else INF,
        complementarity=float(np.max(np.abs(force * gap), initial=0.0)),
        reduced_eigenvalues=eig,
        active=len(rows),
        grazing=grazing,
        stability=verdict,
        dead_load_eigenvalues=np.sort(np.linalg.eigvalsh(0.5 * (hess + hess_g + (hess + hess_g).T))),
    )
    contacts, gaps = [], []
    L = scene.actuator.L
    for k, o in enumerate(scene.obstacles):
        idx = [k * 2 * n + j for j in range(2 * n)]
        for j in idx:
            if not active[j]:
                continue
            local = j - k * 2 * n
            if local < n:
                i, frac = local, 1.0
                where = "tip" if i == n - 1 else f"joint {i + 1}"
            else:
                i, frac = local - n, float(sigma[k][local - n])
                if frac >= 1.0 - 1e-12:
                    where = "tip" if i == n - 1 else f"joint {i + 1}"
                elif frac <= 1e-12:
                    where = f"joint {i}" if i else "base"
                else:
                    where = f"inside segment {i + 1}"
            q = surface_points(theta, L, prob.offsets[k], np.array([[frac]] * n))[i, 0]
            _, normal, _ = o.derivatives(q[None, :])
            contacts.append(Contact(k, o.kind, prob.sides[k], (i + frac) / n, where, (float(q[0]), float(q[1])), float(force[j]),
                                    (float(normal[0, 0]), float(normal[0, 1])), float(gap[j])))
        rest = [gap[j] for j in idx if not active[j]]
        gaps.append(float(min(rest)) if rest else float("nan"))
    contacts = _merged(contacts)
    message = ""
    if not success:
        message = f"IPOPT did not converge: {status}"
    elif near_domain_bound(theta, lbx):
        success, status = False, "At_Bound"
        message = "the solve stopped on the model's domain boundary (Eq. 10: the chamber closes): not an equilibrium"
    elif kkt.min_gap < -opts.gap_tol:
        success, message = False, f"penetration {-kkt.min_gap:.3g} mm > gap_tol"
    elif verdict != "stable":
        message = f"the equilibrium is {verdict} on the constrained set: smallest reduced-Hessian eigenvalue {eig[0]:.3g} N mm/rad^2"
    reaction = None  # only an equilibrium has one: a failed solve's multipliers are no force
    if prob.displacement is not None and success:
        reaction = -lam[m:m + 2] * np.array([prob.displacement.x is not None, prob.displacement.y is not None])
    elif prob.displacement is not None:
        message += "; no reaction: the prescribed tip was not reached in equilibrium"
    model = prob.model
    cl = model.centreline(theta, L, samples=n * opts.samples_per_segment + 1)
    energy = model.energy(theta, pv)
    gaps_clean = tuple(g_ if math.isfinite(g_) else None for g_ in gaps)
    return ContactEquilibrium(
        scene=scene, pressure=pressure, theta=theta, tip=tip, centreline=cl, energy=energy, contacts=tuple(contacts),
        gaps=gaps_clean, kkt=kkt, reaction=reaction, displacement=prob.displacement, status=status, success=success,
        iterations=iterations, outer=outer, solve_time_s=elapsed, state=ContactState(theta, lam, sigma, pressure, 1.0), message=message,
    )

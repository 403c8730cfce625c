"""Designs that do not snap: the stiffest chamber whose operating envelope holds no fold.

An operating envelope (:class:`Envelope`) is the set of loads a design must carry without a
snap-through: pressures from 0 to ``max_pressure``, tip payloads from 0 to ``max_payload`` in each of
``directions_deg`` at the point ``at``. A design (r2, d) *snaps inside* it when a stable fold (a
stable and an unstable state meet: a quasi-static load there jumps) lies in it. With a margin m the
constraint is that no stable fold lies at pressures up to (1 + m) max_pressure and payloads up to
(1 + m) max_payload:

    c(r2, d) = F_fold / max_payload - (1 + m) >= 0,

F_fold the smallest payload of a stable fold at pressures in [0, (1 + m) max_pressure], over the
directions: the fold curves of the (pressure, payload) plane (:mod:`esba.analysis.folds`), their
minimum in the payload located exactly (a cusp, a point where the curve is tangent to a
pressure path, or the fold of the payload path at the pressure bound). :func:`fold_clearance`
computes it, with the nearest fold.

:func:`optimise_envelope` maximises the secant stiffness of the paper's problem
(:class:`esba.design.problem.DesignProblem`, the 90 degree pressure at most ``max_pressure``) under
the fold constraint, a *map-based* method: IPOPT's unconstrained optimum
(:func:`esba.design.optimise.optimise_ipopt`) when it is clear of folds; else the best clear
design of a grid over (r2, d), refined by SLSQP with the fold constraint (finite differences of
the evaluator's K and of c). ``method="pso"`` runs the paper's particle swarm on the same
constraint (Deb's feasibility rules), and ``"both"`` compares them.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from esba.analysis.folds import Plane, fold_curves, folds_at
from esba.infra import checks
from esba.model.scene import Payload, Scene
from esba.solvers.pso import PSOOptions, PSOResult, minimize

from .evaluate import evaluate
from .optimise import optimise_ipopt
from .problem import DEFAULT_DESIGN_OPTIONS, DesignError, DesignOptions, DesignProblem

__all__ = ["Envelope", "FoldClearance", "EnvelopeDesign", "fold_clearance", "optimise_envelope", "ENVELOPE_METHODS"]

#: How :func:`optimise_envelope` may solve.
ENVELOPE_METHODS = ("map", "pso", "both")
#: Designs per side of the grid of the map-based method.
GRID = 17
#: A constraint is reported active when its value is within this (relative) of its bound.
ACTIVE_TOL = 1e-4
#: A design is clear when c >= -CLEAR_TOL: a design on the constraint's boundary has its fold
#: located to round-off (c ~ 1e-14), not to an exact zero.
CLEAR_TOL = 1e-9
#: Finite-difference step of SLSQP's gradients, mm.
FD_STEP = 1e-5


@dataclass(frozen=True)
class Envelope:
    """The loads a design must carry without a snap, validated on creation.

    Parameters
    ----------
    max_pressure : float
        MPa, > 0.
    max_payload : float
        N, > 0.
    directions_deg : tuple of float
        Directions Omega of the payload from the vertical, degrees (90 = horizontal).
    at : float
        The payload's point, a fraction of L in (0, 1].
    margin : float
        The fold must lie beyond (1 + margin) times the envelope in pressure and payload (>= 0).

    Examples
    --------
    >>> Envelope(0.35, 2.5).describe()
    'pressures 0 to 0.35 MPa, payloads 0 to 2.5 N at 90 deg, at s = 1, margin 10 %'
    >>> Envelope(0.35, -1.0)
    Traceback (most recent call last):
    ...
    esba.design.problem.DesignError: max_payload=-1: expected a number > 0
    """

    max_pressure: float
    max_payload: float
    directions_deg: tuple[float, ...] = (90.0,)
    at: float = 1.0
    margin: float = 0.1

    def __post_init__(self) -> None:
        for name in ("max_pressure", "max_payload"):
            v = checks.finite(name, getattr(self, name), DesignError)
            if v <= 0:
                raise DesignError(f"{name}={v:g}: expected a number > 0")
        m = checks.finite("margin", self.margin, DesignError)
        if m < 0:
            raise DesignError(f"margin={m:g}: expected a number >= 0")
        if not isinstance(self.directions_deg, tuple) or not self.directions_deg:
            raise DesignError(f"directions_deg={self.directions_deg!r}: expected a tuple of at least one direction (degrees)")
        unique: list[float] = []
        for a in self.directions_deg:
            a = checks.finite("direction", a, DesignError)
            if not any(math.isclose((a - u + 180.0) % 360.0 - 180.0, 0.0, abs_tol=1e-9) for u in unique):
                unique.append(a)  # a direction is periodic: 450 deg is 90 deg, checked once
        object.__setattr__(self, "directions_deg", tuple(unique))
        at = checks.finite("at", self.at, DesignError)
        if not 0 < at <= 1:
            raise DesignError(f"at={at:g}: expected a fraction of L in (0, 1]")

    @property
    def pressure_bound(self) -> float:
        return (1.0 + self.margin) * self.max_pressure

    @property
    def payload_bound(self) -> float:
        return (1.0 + self.margin) * self.max_payload

    def describe(self) -> str:
        dirs = ", ".join(f"{a:g}" for a in self.directions_deg)
        return f"pressures 0 to {self.max_pressure:g} MPa, payloads 0 to {self.max_payload:g} N at {dirs} deg, at s = {self.at:g}, margin {100 * self.margin:g} %"

    def to_dict(self) -> dict[str, Any]:
        return {"max_pressure_mpa": self.max_pressure, "max_payload_n": self.max_payload, "directions_deg": list(self.directions_deg), "at": self.at, "margin": self.margin}


@dataclass(frozen=True)
class FoldClearance:
    """The fold constraint at one design.

    ``fold_payload`` (N): the smallest payload of a stable fold at pressures up to the pressure
    bound, over the directions (inf when there is none up to twice the payload bound);
    ``value`` = fold_payload / max_payload - (1 + margin) (>= 0: clear); ``inside``: a stable fold
    lies in the envelope itself (the design snaps there); ``nearest``: where that fold is
    (direction, pressure, payload, what kind of point), or None.
    """

    r2: float
    d: float
    fold_payload: float
    value: float
    inside: bool
    nearest: dict[str, Any] | None

    @property
    def clear(self) -> bool:
        return self.value >= -CLEAR_TOL

    def to_dict(self) -> dict[str, Any]:
        return {
            "r2_mm": self.r2,
            "d_mm": self.d,
            "fold_payload_n": self.fold_payload if math.isfinite(self.fold_payload) else None,
            "value": self.value if math.isfinite(self.value) else None,
            "clear": self.clear,
            "snaps_inside": self.inside,
            "nearest_fold": self.nearest,
        }


def _plane(problem: DesignProblem, envelope: Envelope, r2: float, d: float, direction: float) -> Plane:
    base = problem.scene(r2, d, pressure=0.0, loaded=False)
    scene = Scene(base.actuator, pressure=0.0, payloads=(Payload(envelope.max_payload, direction, envelope.at),), segments=problem.segments, variant=problem.variant)
    return Plane.from_scene(scene, "pressure", "payload")


def fold_clearance(problem: DesignProblem, envelope: Envelope, r2: float, d: float) -> FoldClearance:
    """The fold constraint of design (r2, d) (see the module).

    Examples
    --------
    >>> c = fold_clearance(DesignProblem(), Envelope(0.35, 2.5), 1.5305, 0.0)   # the paper's optimum
    >>> c.inside, round(c.fold_payload, 4), c.nearest["kind"]
    (True, 2.2308, 'cusp')
    """
    p_hi, f_hi = envelope.pressure_bound, 2.0 * envelope.payload_bound
    box = ((0.0, p_hi), (0.0, f_hi))
    best, nearest = math.inf, None
    for direction in envelope.directions_deg:
        plane = _plane(problem, envelope, r2, d, direction)
        curves = fold_curves(plane, *box, lines=3)
        candidates: list[tuple[float, float, str]] = []
        for c in curves:
            inside = c.stable & (c.xs >= 0) & (c.xs <= p_hi)
            candidates += [(float(y), float(x), "fold curve point") for x, y in zip(c.xs[inside], c.ys[inside])]
            candidates += [(p.y, p.x, p.kind) for p in c.special if 0 <= p.x <= p_hi and p.kind != "branch point of the y-path"]
        if curves:
            candidates += [(y, p_hi, "fold of the payload path at the pressure bound") for y in folds_at(plane, curves, box, x=p_hi)]
        for y, x, kind in candidates:
            if 0 <= y < best:
                best, nearest = y, {"direction_deg": float(direction), "pressure_mpa": x, "payload_n": y, "kind": kind}
    value = best / envelope.max_payload - (1.0 + envelope.margin) if math.isfinite(best) else math.inf
    inside = bool(nearest is not None and best <= envelope.max_payload and nearest["pressure_mpa"] <= envelope.max_pressure)
    return FoldClearance(float(r2), float(d), best, value, inside, nearest)


@dataclass(frozen=True, eq=False)
class EnvelopeDesign:
    """The stiffest design clear of folds in an envelope (or why there is none).

    ``unconstrained``: IPOPT's optimum without the fold constraint and its clearance (does it snap
    inside?); ``active``: the constraints at their bounds (``fold clearance``, ``pressure``,
    ``wall``, ``d >= 0``); ``clearance``: the fold constraint at the design, with the nearest fold.
    """

    method: str
    problem: DesignProblem
    envelope: Envelope
    status: str
    message: str
    r2_mm: float
    d_mm: float
    pressure_mpa: float
    stiffness_n_per_m: float
    clearance: FoldClearance | None
    active: tuple[str, ...]
    unconstrained: dict[str, Any]
    evaluations: int
    solve_time_s: float
    pso: PSOResult | None = field(default=None, repr=False)

    def to_dict(self) -> dict[str, Any]:
        return {
            "method": self.method,
            "problem": self.problem.describe(),
            "envelope": self.envelope.to_dict(),
            "status": self.status,
            "message": self.message,
            "r2_mm": self.r2_mm,
            "d_mm": self.d_mm,
            "pressure_mpa": self.pressure_mpa,
            "stiffness_n_per_m": self.stiffness_n_per_m,
            "clearance": None if self.clearance is None else self.clearance.to_dict(),
            "active_constraints": list(self.active),
            "unconstrained": self.unconstrained,
            "evaluations": self.evaluations,
            "solve_time_s": self.solve_time_s,
        }


def _problem(problem: DesignProblem | None, envelope: Envelope) -> DesignProblem:
    problem = DesignProblem() if problem is None else problem
    if problem.objective != "stiffness":
        raise DesignError(f"objective={problem.objective!r}: an operating envelope goes with the stiffness objective")
    return problem.replace(max_pressure=envelope.max_pressure if problem.max_pressure is None else min(problem.max_pressure, envelope.max_pressure))


def _active(problem: DesignProblem, envelope: Envelope, r2: float, d: float, pressure: float, clearance: FoldClearance) -> tuple[str, ...]:
    out = []
    if abs(clearance.value) <= ACTIVE_TOL * (1.0 + envelope.margin):
        out.append("fold clearance")
    if problem.max_pressure is not None and pressure >= problem.max_pressure * (1 - ACTIVE_TOL):
        out.append("pressure")
    if problem.actuator.r1 - r2 - d <= problem.wall + 1e-6:
        out.append("wall")
    if d <= 1e-6:
        out.append("d >= 0")
    return tuple(out)


def _unconstrained(problem: DesignProblem, envelope: Envelope, options: DesignOptions, clearance=None) -> tuple[dict[str, Any], FoldClearance | None, Any]:
    run = optimise_ipopt(problem, options)
    if run.status != "optimal":
        return {"status": run.status, "message": run.message}, None, run
    c = (clearance or fold_clearance)(problem, envelope, run.r2_mm, run.d_mm)
    return {
        "status": run.status,
        "r2_mm": run.r2_mm,
        "d_mm": run.d_mm,
        "stiffness_n_per_m": run.stiffness_n_per_m,
        "pressure_mpa": run.pressure_mpa,
        "clearance": c.to_dict(),
    }, c, run


def _score(problem: DesignProblem, envelope: Envelope, options: DesignOptions, r2: np.ndarray, d: np.ndarray, clearance=None):
    """K (nan where it fails), the pressure and the fold constraint's value of designs (``clearance``:
    the constraint, :func:`fold_clearance` unless given, e.g. :func:`esba.design.spatial.sideways_clearance`)."""
    e = evaluate(problem, r2, d, options)
    # the folds only where the rest is met (a design over the pressure budget is out anyway)
    c = np.array([(clearance or fold_clearance)(problem, envelope, a, b).value if ok and p <= problem.max_pressure else -math.inf for a, b, ok, p in zip(r2, d, e.ok, e.pressure)])
    return np.where(e.ok, e.stiffness, np.nan), e.pressure, c


def _finish(method, problem, envelope, options, r2, d, evaluations, seconds, unconstrained, pso=None, status="optimal", message="", clearance=None) -> EnvelopeDesign:
    e = evaluate(problem, [r2], [d], options)
    c = (clearance or fold_clearance)(problem, envelope, r2, d)
    if status == "optimal" and not (c.clear and e.ok[0]):
        status, message = "failed", message or "the design found is not clear of folds"
    return EnvelopeDesign(
        method, problem, envelope, status, message, float(r2), float(d), float(e.pressure[0]), float(e.stiffness[0]), c,
        _active(problem, envelope, r2, d, float(e.pressure[0]), c), unconstrained, evaluations, seconds, pso,
    )


def _map_method(problem: DesignProblem, envelope: Envelope, options: DesignOptions, clearance=None) -> EnvelopeDesign:
    from scipy.optimize import minimize as scipy_minimize

    t0 = time.perf_counter()
    info, c0, run = _unconstrained(problem, envelope, options, clearance)
    if c0 is not None and c0.clear:
        return _finish("map", problem, envelope, options, run.r2_mm, run.d_mm, 1, time.perf_counter() - t0, info,
                       message="IPOPT's optimum without the fold constraint is clear of folds: the constraint is inactive", clearance=clearance)
    room = problem.actuator.r1 - problem.wall
    r2s, ds = np.meshgrid(np.linspace(options.r2_min + 0.05, room - 0.05, GRID), np.linspace(0.0, room - 0.1, GRID))
    keep = r2s + ds <= room
    r2s, ds = r2s[keep], ds[keep]
    # the stiffest grid design clear of folds: K of every design in one batch, the folds in order of K
    e = evaluate(problem, r2s, ds, options)
    order = [int(i) for i in np.argsort(-np.where(e.ok & (e.pressure <= problem.max_pressure), e.stiffness, -np.inf)) if e.ok[i] and e.pressure[i] <= problem.max_pressure]
    evaluations = len(r2s) + 1
    x0 = None
    for i in order:
        evaluations += 1
        if (clearance or fold_clearance)(problem, envelope, r2s[i], ds[i]).clear:
            x0 = np.array([r2s[i], ds[i]])
            break
    if x0 is None:
        return _finish("map", problem, envelope, options, run.r2_mm if c0 is not None else r2s[0], run.d_mm if c0 is not None else ds[0],
                       evaluations, time.perf_counter() - t0, info, status="infeasible",
                       message=f"no design of the {GRID} x {GRID} grid is clear of folds in the envelope", clearance=clearance)
    memo: dict[tuple[float, float], tuple[float, float, float]] = {}

    def score(x) -> tuple[float, float, float]:
        key = (float(x[0]), float(x[1]))
        if key not in memo:
            k_, p_, c_ = _score(problem, envelope, options, np.array([key[0]]), np.array([key[1]]), clearance)
            # finite stand-ins where a design fails or is over the pressure budget: SLSQP needs numbers
            memo[key] = (float(k_[0]) if np.isfinite(k_[0]) else 0.0, float(p_[0]) if np.isfinite(p_[0]) else 10.0 * problem.max_pressure,
                         float(c_[0]) if np.isfinite(c_[0]) else -1.0)
        return memo[key]

    def gradient(x, k: int) -> np.ndarray:
        """Forward differences of score()[k] in r2 and d (steps of FD_STEP mm, inwards at a bound)."""
        f0 = score(x)[k]
        out = np.zeros(2)
        for j in range(2):
            h = FD_STEP if x[j] + FD_STEP <= (room if j == 0 else room - x[0]) else -FD_STEP
            xh = np.array(x, dtype=float)
            xh[j] += h
            out[j] = (score(xh)[k] - f0) / h
        return out

    scale = 50.0  # K of these designs is tens of N/m
    step = (room - options.r2_min) / (GRID - 1)  # SLSQP stays within one grid spacing of the grid's best

    res = scipy_minimize(
        lambda x: -score(x)[0] / scale,
        x0,
        method="SLSQP",
        jac=lambda x: -gradient(x, 0) / scale,
        bounds=[(max(options.r2_min, x0[0] - step), min(room, x0[0] + step)), (max(0.0, x0[1] - step), min(room, x0[1] + step))],
        constraints=[
            {"type": "ineq", "fun": lambda x: score(x)[2], "jac": lambda x: gradient(x, 2)},
            {"type": "ineq", "fun": lambda x: (problem.max_pressure - score(x)[1]) / problem.max_pressure, "jac": lambda x: -gradient(x, 1) / problem.max_pressure},
            {"type": "ineq", "fun": lambda x: room - x[0] - x[1]},
        ],
        options={"ftol": 1e-10, "maxiter": 60},
    )
    x = res.x if np.all(np.isfinite(res.x)) else x0
    if not (score(x)[2] >= -CLEAR_TOL and np.isfinite(score(x)[0])):
        x = x0
    return _finish("map", problem, envelope, options, float(x[0]), float(x[1]), evaluations + len(memo), time.perf_counter() - t0, info,
                   message="" if res.success else f"SLSQP: {res.message}", clearance=clearance)


def _pso_method(problem: DesignProblem, envelope: Envelope, options: DesignOptions, pso_options: PSOOptions, info=None, clearance=None) -> EnvelopeDesign:
    t0 = time.perf_counter()
    room = problem.actuator.r1 - problem.wall

    def swarm(X: np.ndarray):
        K, P, c = _score(problem, envelope, options, X[:, 0], X[:, 1], clearance)
        v = np.maximum(0.0, -c) + np.maximum(0.0, (P - problem.max_pressure) / problem.max_pressure)
        return -K, np.where(np.isfinite(K), v, np.inf)

    res = minimize(swarm, [options.r2_min, 0.0], [room, room], linear=([[1.0, 1.0]], [room]), options=pso_options)
    status = "optimal" if res.feasible else "infeasible"
    return _finish("pso", problem, envelope, options, float(res.x[0]), float(res.x[1]), res.evaluations, time.perf_counter() - t0, info or {},
                   pso=res, status=status, message="" if res.feasible else "the swarm found no design clear of folds", clearance=clearance)


def optimise_envelope(
    problem: DesignProblem | None,
    envelope: Envelope,
    method: str = "map",
    options: DesignOptions | None = None,
    pso_options: PSOOptions | None = None,
    clearance=None,
) -> EnvelopeDesign | tuple[EnvelopeDesign, EnvelopeDesign]:
    """The stiffest design clear of folds in ``envelope`` (see the module); ``"both"`` returns (map, pso).
    ``clearance``: the constraint (problem, envelope, r2, d) -> its value and more, :func:`fold_clearance`
    unless given (:func:`esba.design.spatial.sideways_clearance` adds sideways buckling and twist)."""
    if method not in ENVELOPE_METHODS:
        raise DesignError(f"method={method!r}: allowed are {', '.join(ENVELOPE_METHODS)}")
    if not isinstance(envelope, Envelope):
        raise DesignError(f"envelope={envelope!r}: expected an Envelope")
    problem = _problem(problem, envelope)
    options = DEFAULT_DESIGN_OPTIONS if options is None else options
    pso_options = PSOOptions(particles=12, iterations=15) if pso_options is None else pso_options
    if method == "map":
        return _map_method(problem, envelope, options, clearance)
    if method == "pso":
        return _pso_method(problem, envelope, options, pso_options, clearance=clearance)
    m = _map_method(problem, envelope, options, clearance)
    return m, _pso_method(problem, envelope, options, pso_options, m.unconstrained, clearance)


# ---------------------------------------------------------------------------------------------
# the design plane


@dataclass(frozen=True, eq=False)
class DesignPlane:
    """Designs on a grid over (r2, d) against an envelope.

    Per design (flat arrays): ``stiffness`` (N/m, nan where it fails), ``pressure`` (the 90 degree
    pressure, MPa), ``value`` (the fold constraint c; nan over the pressure budget, where it is not
    computed), ``state``: ``"clear"``, ``"margin"`` (a fold beyond the envelope but within the
    margin), ``"snaps"`` (a stable fold inside the envelope) or ``"over budget"`` (the 90 degree
    pressure is above max_pressure). ``optimum``: (map, pso) designs, or None.
    """

    problem: DesignProblem
    envelope: Envelope
    r2: np.ndarray
    d: np.ndarray
    stiffness: np.ndarray
    pressure: np.ndarray
    value: np.ndarray
    state: tuple[str, ...]
    optimum: tuple[EnvelopeDesign, ...] | None
    seconds: float

    def count(self, state: str) -> int:
        return sum(1 for s in self.state if s == state)


def design_plane(
    problem: DesignProblem | None,
    envelope: Envelope,
    r2_values,
    d_values,
    *,
    optimum: str | None = "both",
    options: DesignOptions | None = None,
    pso_options: PSOOptions | None = None,
    progress=None,
) -> DesignPlane:
    """The fold constraint and the stiffness of every design (r2, d) of the grid with r2 + d inside the
    geometry, and (``optimum``: a method of :data:`ENVELOPE_METHODS`) the stiffest clear design."""
    say = progress or (lambda msg: None)
    problem = _problem(problem, envelope)
    options = DEFAULT_DESIGN_OPTIONS if options is None else options
    t0 = time.perf_counter()
    room = problem.actuator.r1 - problem.wall
    R2, D = np.meshgrid(np.asarray(r2_values, dtype=float), np.asarray(d_values, dtype=float))
    keep = R2 + D <= room
    r2, d = R2[keep], D[keep]
    say(f"{len(r2)} designs: stiffness")
    e = evaluate(problem, r2, d, options)
    value = np.full(len(r2), np.nan)
    state = []
    say(f"{len(r2)} designs: fold curves")
    for i in range(len(r2)):
        if not e.ok[i] or e.pressure[i] > problem.max_pressure:
            state.append("over budget" if e.ok[i] else "fails")
            continue
        c = fold_clearance(problem, envelope, r2[i], d[i])
        value[i] = c.value
        state.append("clear" if c.clear else ("snaps" if c.inside else "margin"))
    best = None
    if optimum:
        say(f"the stiffest clear design ({optimum})")
        run = optimise_envelope(problem, envelope, optimum, options, pso_options)
        best = run if isinstance(run, tuple) else (run,)
    return DesignPlane(problem, envelope, r2, d, np.where(e.ok, e.stiffness, np.nan), e.pressure, value, tuple(state), best, time.perf_counter() - t0)


__all__ += ["DesignPlane", "design_plane"]

"""Global-best particle swarm optimisation with linear and nonlinear constraints, vectorised.

The paper (Section 5) searches (r2, d) with a particle swarm: 30 particles, random initial
positions and velocities in the box, the geometric constraint r2 + d < r1. This module is a
small implementation of the standard global-best PSO for any box-bounded problem, written so
that the whole swarm is evaluated in **one call** of the objective per iteration (the ESBA
objective maps a CasADi Function over the swarm, see :mod:`esba.design.optimise`).

Update rule (Kennedy & Eberhart 1995 with the constriction of Clerc & Kennedy 2002, "The
particle swarm - explosion, stability, and convergence in a multidimensional complex space",
IEEE Trans. Evol. Comput. 6(1):58-73), per particle i and dimension k, with fresh uniform
random numbers u1, u2 in [0, 1)::

    v_ik <- w v_ik + c1 u1 (p_ik - x_ik) + c2 u2 (g_k - x_ik)
    x_ik <- x_ik + v_ik

where p_i is the particle's own best position and g the swarm's best. The defaults are Clerc and
Kennedy's constriction coefficients written in inertia form: chi = 0.7298 with phi = 4.1
(c1 = c2 = 2.05 chi = 1.49618, w = chi = 0.7298), the values recommended for the standard PSO
(Bratton & Kennedy 2007, "Defining a standard for particle swarm optimization", IEEE SIS).

Initialisation follows SPSO 2011 (Zambrano-Bigiarini, Clerc & Rojas 2013): positions uniform
in the feasible part of the box (rejection sampling against the linear constraints), velocities
v = u - x with u uniform in the box (so x + v lies in the box).

Constraints:

* the box: a particle that leaves it is put back on the violated face and that velocity
  component is zeroed (absorbing walls; Robinson & Rahmat-Samii 2004);
* linear constraints ``A x <= b`` (the ESBA's r2 + d <= r1 - wall): never violated. The
  initial swarm is sampled inside them, and a particle whose step would leave them stops where
  the step crosses the boundary (the largest fraction t of the step that stays feasible; the
  velocity is scaled by t), so the objective is only ever evaluated where it is defined, and
  an optimum on the boundary is reached exactly rather than approached from one side;
* nonlinear constraints returned by the objective as a violation >= 0 (e.g. a minimum stiffness).
  An optimum on a curved constraint is approached from the feasible side only, so the swarm
  closes in along such a boundary more slowly than along a wall (see ``tests/solvers/test_pso.py``).

Particles are compared with Deb's feasibility rules (Deb 2000, "An efficient constraint
handling method for genetic algorithms", Comput. Methods Appl. Mech. Eng. 186:311-338): a
feasible point beats an infeasible one, two feasible points compare by objective, two
infeasible ones by violation. No penalty weight to tune, and an infeasible point never becomes a
personal or global best while a feasible one is known.

Examples
--------
Minimise (x - 1)^2 + (y - 2)^2 subject to x + y <= 2 (optimum (0.5, 1.5)):

>>> import numpy as np
>>> def sphere(X):
...     return (X[:, 0] - 1.0) ** 2 + (X[:, 1] - 2.0) ** 2
>>> r = minimize(sphere, [0, 0], [3, 3], linear=([[1.0, 1.0]], [2.0]), options=PSOOptions(seed=1, iterations=80))
>>> [round(float(v), 4) for v in r.x]
[0.5, 1.5]
>>> r.history.positions.shape   # iterations + 1 snapshots of 30 particles in 2 dimensions
(81, 30, 2)
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from esba.infra import checks
from esba.infra.errors import InputError

__all__ = ["PSOOptions", "PSOOptionsError", "PSOHistory", "PSOResult", "minimize", "CLERC_KENNEDY"]

#: Clerc & Kennedy (2002) constriction, phi = 4.1: (w, c1, c2).
CLERC_KENNEDY = (0.7298, 1.49618, 1.49618)


#: The most objective evaluations a run may ask for, particles x (iterations + 1): the swarm's
#: history keeps every position, and each evaluation of the ESBA objective solves equilibria
#: (the paper's run is 30 x 51 = 1530).
MAX_EVALUATIONS = 1_000_000
#: Upper bound of the rejection-sampling rounds of the initial swarm.
MAX_TRIES = 1_000_000


class PSOOptionsError(InputError):
    """A PSO setting that is not allowed: the message names the setting, the value and what is allowed."""


def _whole(name: str, value, low: int, high: int | None = None, why: str = "") -> int:
    return checks.whole(name, value, low, PSOOptionsError, high, why)


def _real(name: str, value, low: float, high: float | None = None, *, open_low: bool = False) -> float:
    ok = not isinstance(value, bool) and isinstance(value, (int, float, np.floating)) and math.isfinite(value)
    if ok:
        ok = value > low if open_low else value >= low
    if ok and high is not None:
        ok = value < high
    if not ok:
        rel = ">" if open_low else ">="
        rng = f"{rel} {low:g}" + (f" and < {high:g}" if high is not None else "")
        raise PSOOptionsError(f"{name}={value!r}: expected a finite number {rng}")
    return float(value)


@dataclass(frozen=True)
class PSOOptions:
    """Settings of :func:`minimize`, validated on creation.

    Parameters
    ----------
    particles : int
        Swarm size (the paper: 30), >= 2.
    iterations : int
        Velocity-and-position updates after the initial swarm (the paper: 50), >= 1; particles x
        (iterations + 1) is at most :data:`MAX_EVALUATIONS`.
    inertia : float
        w, 0 <= w < 1 (default Clerc & Kennedy's 0.7298).
    cognitive : float
        c1, the pull towards the particle's own best, >= 0 (default 1.49618).
    social : float
        c2, the pull towards the swarm's best, >= 0 (default 1.49618).
    max_velocity : float
        Velocity clamp per dimension as a fraction of the box width, > 0 (default 1: one box width).
    seed : int or None
        Seed of the ``numpy.random.Generator``; the same seed gives the same run.
    max_tries : int
        Rejection-sampling rounds for feasible initial positions, >= 1.

    Examples
    --------
    >>> PSOOptions().particles, PSOOptions().iterations
    (30, 50)
    >>> PSOOptions(inertia=1.2)
    Traceback (most recent call last):
    ...
    esba.solvers.pso.PSOOptionsError: inertia=1.2: expected a finite number >= 0 and < 1
    """

    particles: int = 30
    iterations: int = 50
    inertia: float = CLERC_KENNEDY[0]
    cognitive: float = CLERC_KENNEDY[1]
    social: float = CLERC_KENNEDY[2]
    max_velocity: float = 1.0
    seed: int | None = 0
    max_tries: int = 1000

    def __post_init__(self) -> None:
        why = f"particles x (iterations + 1) is at most {MAX_EVALUATIONS} evaluations"
        _whole("particles", self.particles, 2, MAX_EVALUATIONS // 2, why)
        _whole("iterations", self.iterations, 1, MAX_EVALUATIONS // 2 - 1, why)
        if self.particles * (self.iterations + 1) > MAX_EVALUATIONS:
            raise PSOOptionsError(
                f"particles={self.particles} with iterations={self.iterations}: {self.particles * (self.iterations + 1)} "
                f"evaluations, at most {MAX_EVALUATIONS} (the swarm's history keeps every position; the paper's run is 30 x 51)"
            )
        _real("inertia", self.inertia, 0.0, 1.0)
        _real("cognitive", self.cognitive, 0.0)
        _real("social", self.social, 0.0)
        _real("max_velocity", self.max_velocity, 0.0, open_low=True)
        if self.seed is not None:
            _whole("seed", self.seed, 0)
        _whole("max_tries", self.max_tries, 1, MAX_TRIES)


@dataclass(frozen=True, eq=False)
class PSOHistory:
    """What the swarm did, one row per snapshot (the initial swarm, then after each iteration).

    Attributes
    ----------
    positions : ndarray, shape (iterations + 1, particles, dims)
    values : ndarray, shape (iterations + 1, particles)
        Objective at each position (nan where the evaluation failed).
    violations : ndarray, shape (iterations + 1, particles)
        Constraint violation at each position (0 = feasible).
    best_value : ndarray, shape (iterations + 1,)
        The swarm's best objective so far (inf while nothing feasible is known).
    best_position : ndarray, shape (iterations + 1, dims)
    """

    positions: np.ndarray
    values: np.ndarray
    violations: np.ndarray
    best_value: np.ndarray
    best_position: np.ndarray


@dataclass(frozen=True, eq=False)
class PSOResult:
    """The swarm's best point and the run's history.

    Attributes
    ----------
    x : ndarray
        Best position found.
    fun : float
        Objective there (to be minimised).
    violation : float
        Constraint violation there (0: feasible).
    feasible : bool
        Whether any feasible point was found (``violation == 0``).
    evaluations : int
        Points passed to the objective.
    calls : int
        Calls of the objective (one per iteration, plus the initial swarm).
    time_s : float
        Wall time, s.
    history : PSOHistory
    options : PSOOptions
    """

    x: np.ndarray
    fun: float
    violation: float
    feasible: bool
    evaluations: int
    calls: int
    time_s: float
    history: PSOHistory = field(repr=False)
    options: PSOOptions = field(repr=False)


def _better(f_new, v_new, f_old, v_old) -> np.ndarray:
    """Deb's rules, elementwise: is (f_new, v_new) strictly better than (f_old, v_old)?"""
    feas_new, feas_old = v_new <= 0.0, v_old <= 0.0
    both = feas_new & feas_old
    return (feas_new & ~feas_old) | (both & (f_new < f_old)) | (~feas_new & ~feas_old & (v_new < v_old))


def _best_index(f, v) -> int:
    """Index of the best point by Deb's rules."""
    feasible = v <= 0.0
    if np.any(feasible):
        idx = np.flatnonzero(feasible)
        return int(idx[np.argmin(f[idx])])
    return int(np.argmin(v))


def minimize(
    objective: Callable[[np.ndarray], np.ndarray | tuple[np.ndarray, np.ndarray]],
    lower: Sequence[float],
    upper: Sequence[float],
    *,
    linear: tuple[Sequence[Sequence[float]], Sequence[float]] | None = None,
    options: PSOOptions | None = None,
) -> PSOResult:
    """Minimise ``objective`` over the box [lower, upper] with a global-best particle swarm.

    Parameters
    ----------
    objective : callable
        ``objective(X)`` with X of shape (particles, dims), the whole swarm (every point inside
        the box and the linear constraints), returns the objective values, or a pair (values,
        violations) with violations >= 0 for nonlinear constraints (0 = satisfied). A value that
        is not finite counts as a failed evaluation: infinitely violated.
    lower, upper : sequence of float
        The box, lower < upper in every dimension.
    linear : (A, b), optional
        Linear constraints A x <= b that must hold wherever the objective is evaluated.
    options : PSOOptions, optional

    Returns
    -------
    PSOResult
    """
    options = PSOOptions() if options is None else options
    if not isinstance(options, PSOOptions):
        raise PSOOptionsError(f"options={options!r}: expected a PSOOptions")
    lo = np.asarray(lower, dtype=float).ravel()
    hi = np.asarray(upper, dtype=float).ravel()
    if lo.shape != hi.shape or lo.size == 0 or not np.all(np.isfinite(lo) & np.isfinite(hi)) or np.any(lo >= hi):
        raise PSOOptionsError(f"lower={list(lo)}, upper={list(hi)}: expected finite bounds with lower < upper in each dimension")
    dims = lo.size
    if linear is not None:
        A = np.atleast_2d(np.asarray(linear[0], dtype=float))
        b = np.asarray(linear[1], dtype=float).ravel()
        if A.shape != (b.size, dims):
            raise PSOOptionsError(f"linear: A has shape {A.shape}, b has {b.size} rows: expected A of shape ({b.size}, {dims})")
    else:
        A, b = np.zeros((0, dims)), np.zeros(0)

    t0 = time.perf_counter()
    rng = np.random.default_rng(options.seed)
    N, width = options.particles, hi - lo
    vmax = options.max_velocity * width

    def linear_violation(X: np.ndarray) -> np.ndarray:
        if not b.size:
            return np.zeros(len(X))
        return np.max(np.maximum(X @ A.T - b, 0.0), axis=1)

    # initial positions: uniform in the box, rejection-sampled into the linear constraints
    X = rng.uniform(lo, hi, size=(N, dims))
    bad = linear_violation(X) > 0
    for _ in range(options.max_tries):
        if not np.any(bad):
            break
        X[bad] = rng.uniform(lo, hi, size=(int(bad.sum()), dims))
        bad = linear_violation(X) > 0
    if np.any(bad):
        raise PSOOptionsError(f"no point inside the linear constraints found in {options.max_tries} rounds of sampling the box")
    V = np.clip(rng.uniform(lo, hi, size=(N, dims)) - X, -vmax, vmax)

    evaluations = calls = 0

    def evaluate(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        nonlocal evaluations, calls
        out = objective(X)
        calls += 1
        evaluations += len(X)
        if isinstance(out, tuple):
            f, v = (np.asarray(o, dtype=float).ravel() for o in out)
        else:
            f, v = np.asarray(out, dtype=float).ravel(), np.zeros(len(X))
        if f.shape != (len(X),) or v.shape != (len(X),):
            raise ValueError(f"objective returned {f.shape} values and {v.shape} violations for {len(X)} points")
        failed = ~np.isfinite(f) | ~np.isfinite(v)
        return np.where(failed, np.nan, f), np.where(failed, np.inf, np.maximum(v, 0.0))

    def step_fraction(X: np.ndarray, step: np.ndarray) -> np.ndarray:
        """Largest t in [0, 1] with A (X + t step) <= b, for feasible X (a convex set)."""
        if not b.size:
            return np.ones(len(X))
        slack = np.maximum(b - X @ A.T, 0.0)  # (N, m) >= 0
        rate = step @ A.T
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(rate > 0.0, slack / rate, np.inf)
        return np.clip(np.min(t, axis=1), 0.0, 1.0)

    f, v = evaluate(X)
    fcmp = np.where(np.isnan(f), np.inf, f)
    pbest_x, pbest_f, pbest_v = X.copy(), fcmp.copy(), v.copy()
    g = _best_index(pbest_f, pbest_v)
    gbest_x, gbest_f, gbest_v = pbest_x[g].copy(), float(pbest_f[g]), float(pbest_v[g])

    hist_x, hist_f, hist_v = [X.copy()], [f.copy()], [v.copy()]
    hist_bf, hist_bx = [gbest_f if gbest_v <= 0 else np.inf], [gbest_x.copy()]
    w, c1, c2 = options.inertia, options.cognitive, options.social
    for _ in range(options.iterations):
        u1 = rng.random((N, dims))
        u2 = rng.random((N, dims))
        V = w * V + c1 * u1 * (pbest_x - X) + c2 * u2 * (gbest_x - X)
        V = np.clip(V, -vmax, vmax)
        moved = X + V
        below, above = moved < lo, moved > hi
        moved = np.where(below, lo, np.where(above, hi, moved))
        V = np.where(below | above, 0.0, V)
        t = step_fraction(X, moved - X)
        X = X + t[:, None] * (moved - X)
        V = t[:, None] * V
        f, v = evaluate(X)
        fcmp = np.where(np.isnan(f), np.inf, f)
        improved = _better(fcmp, v, pbest_f, pbest_v)
        pbest_x[improved] = X[improved]
        pbest_f[improved] = fcmp[improved]
        pbest_v[improved] = v[improved]
        g = _best_index(pbest_f, pbest_v)
        if _better(pbest_f[g : g + 1], pbest_v[g : g + 1], np.array([gbest_f]), np.array([gbest_v]))[0]:
            gbest_x, gbest_f, gbest_v = pbest_x[g].copy(), float(pbest_f[g]), float(pbest_v[g])
        hist_x.append(X.copy())
        hist_f.append(f.copy())
        hist_v.append(v.copy())
        hist_bf.append(gbest_f if gbest_v <= 0 else np.inf)
        hist_bx.append(gbest_x.copy())

    history = PSOHistory(
        positions=np.array(hist_x),
        values=np.array(hist_f),
        violations=np.array(hist_v),
        best_value=np.array(hist_bf),
        best_position=np.array(hist_bx),
    )
    return PSOResult(
        x=gbest_x,
        fun=gbest_f,
        violation=gbest_v,
        feasible=bool(gbest_v <= 0.0),
        evaluations=evaluations,
        calls=calls,
        time_s=time.perf_counter() - t0,
        history=history,
        options=options,
    )

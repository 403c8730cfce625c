"""Equilibrium paths: pseudo-arclength continuation with folds, branch points and stability.

An equilibrium of the actuator is a root of the generated gradient, g(theta, lambda) = dU/dtheta = 0,
and as one scene parameter lambda changes (the pressure, a payload's magnitude, direction or point,
a design parameter, or a homotopy such as the load factor of :func:`esba.equilibrium.solve`) the
roots form curves in (theta, lambda): *branches*. A branch can turn back in lambda (a *fold*, or
limit point: two equilibria meet and vanish, and a load ramp snaps) or cross another branch (a
*branch point*, such as the buckling of a straight actuator under a compressive tip load).

This module follows a branch the way structural mechanics does (Riks in Abaqus, AUTO-07p,
BifurcationKit), with the model's exact derivatives:

* **the problem** (:class:`PathProblem`): the generated gradient g and Hessian H, and dg/dlambda
  by CasADi's forward AD of the generated gradient along the parameter direction; the parameter
  vector is affine in lambda, p(lambda) = p0 + lambda dp, which covers one scene parameter
  (:meth:`PathProblem.from_scene`) and homotopies between two parameter sets
  (:meth:`PathProblem.homotopy`);
* **the settings** (:class:`PathOptions`): one frozen, validated dataclass (step lengths, corrector
  targets, turning limit, how special points are located);
* **the trace** (:func:`trace`): tangent predictor, Newton corrector on the bordered system
  [[H, dg/dlambda], [t^T]] with the arclength ds^2 = w |dtheta|^2 + (dlambda / sigma)^2 (w = n, so
  that a step means about the same change of the total angle whatever n is; sigma a typical size of
  lambda), adaptive step (grown or shrunk towards ``target_iterations`` corrector iterations,
  rejected and halved on a failed corrector, a sharp turn or two eigenvalue crossings in one step),
  stops exactly at the parameter bounds, at a step count, a total-angle or user event, at the
  model's domain boundary, or on returning to the start;
* **stability** at every point: the Hessian's eigenvalues, the Morse index (the number of negative
  ones) and stable / unstable (:mod:`esba.stability`);
* **special points**, located precisely, not bracketed: a fold through the extended system
  g = 0, H v = 0, v0 . v = 1 (Newton with third derivatives by AD), or by eigenvalue bisection
  (Brent's method on the crossing eigenvalue along the arclength) (``locate``); branch points by
  eigenvalue bisection (the extended system is singular there). Each has its type, lambda, theta,
  tip, the critical eigenvector, and a status (``converged`` / ``guess``);
* **branch switching** (:func:`bifurcating_branches`): at a branch point the directions of the
  crossing branches solve the algebraic bifurcation equation built from the second derivatives of
  v . g; both sides of the new branch are traced, each with its own stability and folds (the
  eccentric chamber makes U not even in theta, so they need not mirror each other).

The result of a trace is a :class:`Branch`: arrays of lambda, theta, tip, arclength, eigenvalues
and Morse index per point, the special points, and why it stopped; ``to_dict()``, CSV and JSON.

Examples
--------
A straight actuator (P = 0) pushed along its axis: the straight state buckles at a branch point.

>>> from esba.scene import Scene, Payload
>>> column = Scene(pressure=0.0, payloads=(Payload(1.0, 180.0),), segments=2)
>>> b = trace(PathProblem.from_scene(column, "payload"), [0.0, 0.0], 1.0, to=12.0)
>>> b.stop_reason
'reached payload1 = 12 N'
>>> bp = b.special[0]
>>> bp.kind, bp.morse_before, bp.morse_after, round(bp.lam, 4)
('branch point', 0, 1, 3.3303)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Callable, Sequence

import numpy as np

from . import checks
from .branch import Branch, SpecialPoint, branches_csv, write_branches
from .path_problem import PARAMETERS, PathError, PathProblem
from .stability import CRITICAL_TOL, morse_index
from .threads import single_threaded

__all__ = [
    "PathError",
    "PathOptions",
    "PathProblem",
    "SpecialPoint",
    "Branch",
    "trace",
    "bifurcating_branches",
    "PARAMETERS",
    "LOCATE_METHODS",
    "branches_csv",
    "write_branches",
]


#: How a fold is located: Newton on the extended system, or Brent's method on the eigenvalue.
LOCATE_METHODS = ("extended", "bisection")


def _check_pos(name: str, value: Any) -> float:
    v = checks.finite(name, value, PathError)
    if v <= 0:
        raise PathError(f"{name}={value!r}: expected a finite number > 0")
    return v


@dataclass(frozen=True)
class PathOptions:
    """Settings of the continuation, validated on creation (BifurcationKit's ``ContinuationPar``).

    Step lengths are in the scaled arclength ds^2 = w |dtheta|^2 + (dlambda / sigma)^2: about radians
    of total bending angle, or fractions of sigma in the parameter.

    Parameters
    ----------
    ds : float
        First step.
    ds_min, ds_max : float
        Smallest and largest step; a step that must be halved below ``ds_min`` ends the trace.
    max_steps : int
        Steps before the trace stops (``max_steps`` points after the start).
    target_iterations : int
        Corrector iterations aimed at: the step grows when fewer are needed, shrinks when more.
    max_iterations : int
        Corrector iterations before a step is rejected and halved.
    tol : float
        Largest max |dU/dtheta_i| of a converged point, N mm/rad.
    max_turn_deg : float
        Largest angle between successive tangents, degrees; a sharper turn halves the step.
    locate : str
        How folds are located: ``"extended"`` (Newton on g = 0, H v = 0, v0 . v = 1) or
        ``"bisection"`` (Brent's method on the crossing eigenvalue). Branch points always by the latter.
    detect : bool
        Detect and locate folds and branch points.
    critical_tol : float
        Eigenvalues within this fraction of the largest magnitude count as zero (Morse index).
    theta_weight : float or None
        w in the arclength; default n (the segment count).
    scale : float or None
        sigma, a typical size of lambda in its unit; default the span of the trace, else the
        parameter's own typical size.
    stop_total_angle_deg : float or None
        Stop where the total bending angle crosses this value (located like a special point).

    Examples
    --------
    >>> PathOptions().locate
    'extended'
    >>> PathOptions(ds_min=1.0, ds=0.1)
    Traceback (most recent call last):
    ...
    esba.path_problem.PathError: ds_min=1.0, ds=0.1, ds_max=0.25: expected 0 < ds_min <= ds <= ds_max
    """

    ds: float = 0.05
    ds_min: float = 1e-7
    ds_max: float = 0.25
    max_steps: int = 2000
    target_iterations: int = 3
    max_iterations: int = 12
    tol: float = 1e-10
    max_turn_deg: float = 25.0
    locate: str = "extended"
    detect: bool = True
    critical_tol: float = CRITICAL_TOL
    theta_weight: float | None = None
    scale: float | None = None
    stop_total_angle_deg: float | None = None

    def __post_init__(self) -> None:
        for name in ("ds", "ds_min", "ds_max", "tol", "max_turn_deg", "critical_tol"):
            _check_pos(name, getattr(self, name))
        if not self.ds_min <= self.ds <= self.ds_max:
            raise PathError(f"ds_min={self.ds_min!r}, ds={self.ds!r}, ds_max={self.ds_max!r}: expected 0 < ds_min <= ds <= ds_max")
        checks.whole("max_steps", self.max_steps, 1, PathError)
        if self.max_steps > 1_000_000:
            raise PathError(f"max_steps={self.max_steps!r}: expected at most 1000000 (each step stores a point)")
        checks.whole("target_iterations", self.target_iterations, 1, PathError)
        checks.whole("max_iterations", self.max_iterations, 2, PathError)
        if self.target_iterations >= self.max_iterations:
            raise PathError(f"target_iterations={self.target_iterations!r}: expected fewer than max_iterations={self.max_iterations!r}")
        if self.locate not in LOCATE_METHODS:
            raise PathError(f"locate={self.locate!r}: allowed are {', '.join(LOCATE_METHODS)}")
        if not isinstance(self.detect, bool):
            raise PathError(f"detect={self.detect!r}: expected True or False")
        if self.max_turn_deg >= 180.0:
            raise PathError(f"max_turn_deg={self.max_turn_deg!r}: expected a number > 0 and < 180")
        if self.critical_tol >= 1.0:
            raise PathError(f"critical_tol={self.critical_tol!r}: expected a number > 0 and < 1")
        for name in ("theta_weight", "scale"):
            if getattr(self, name) is not None:
                _check_pos(name, getattr(self, name))
        if self.stop_total_angle_deg is not None:
            checks.finite("stop_total_angle_deg", self.stop_total_angle_deg, PathError)


DEFAULT_PATH_OPTIONS = PathOptions()


# ---------------------------------------------------------------------------------------------
# the engine


@dataclass
class _Point:
    theta: np.ndarray
    lam: float
    g: np.ndarray
    h: np.ndarray
    gl: np.ndarray
    iterations: int = 0
    residuals: tuple[float, ...] = ()
    eig: np.ndarray | None = None
    vec: np.ndarray | None = None
    morse: int = 0
    tangent: np.ndarray | None = None


class _Engine:
    """One trace's state: the problem, the metric and the corrector."""

    def __init__(self, problem: PathProblem, options: PathOptions, scale: float):
        self.prob = problem
        self.opts = options
        self.n = problem.n
        self.w = float(options.theta_weight if options.theta_weight is not None else problem.n)
        self.sigma = float(scale)
        self.evaluations = 0

    # metric: <a, b> = w a_theta . b_theta + a_lam b_lam / sigma^2 on (theta, lambda) vectors
    def dot(self, a: np.ndarray, b: np.ndarray) -> float:
        return float(self.w * (a[:-1] @ b[:-1]) + a[-1] * b[-1] / self.sigma**2)

    def norm(self, a: np.ndarray) -> float:
        return math.sqrt(max(self.dot(a, a), 0.0))

    def row(self, t: np.ndarray) -> np.ndarray:
        """The metric's row c with c . x = <t, x>."""
        out = self.w * t.copy()
        out[-1] = t[-1] / self.sigma**2
        return out

    def evaluate(self, theta: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        self.evaluations += 1
        return self.prob.ghl(theta, lam)

    def admissible(self, theta: np.ndarray, lam: float) -> bool:
        return self.prob.defined(theta, lam)

    def correct(self, x: np.ndarray, c: np.ndarray, c0: float) -> _Point | None:
        """Newton on g(theta, lambda) = 0, c . x = c0 from x; None when it fails."""
        opts = self.opts
        residuals: list[float] = []
        n = self.n
        for it in range(opts.max_iterations + 1):
            theta, lam = x[:-1], float(x[-1])
            if not self.admissible(theta, lam):
                return None
            g, h, gl = self.evaluate(theta, lam)
            if not (np.all(np.isfinite(g)) and np.all(np.isfinite(h)) and np.all(np.isfinite(gl))):
                return None
            r_c = float(c @ x - c0)
            res = float(np.max(np.abs(g)))
            residuals.append(res)
            if res <= opts.tol and abs(r_c) <= 1e-12 * (1.0 + abs(c0)):
                return _Point(theta.copy(), lam, g, h, gl, it, tuple(residuals))
            if it == opts.max_iterations:
                return None
            if len(residuals) >= 3 and residuals[-1] > residuals[-2] > residuals[-3]:
                return None  # diverging
            jac = np.empty((n + 1, n + 1))
            jac[:n, :n] = h
            jac[:n, n] = gl
            jac[n, :] = c
            try:
                step = np.linalg.solve(jac, -np.concatenate([g, [r_c]]))
            except np.linalg.LinAlgError:
                return None
            if not np.all(np.isfinite(step)):
                return None
            x = x + step
            if np.max(np.abs(step)) <= 1e-15 * (1.0 + float(np.max(np.abs(x)))) and res <= 1e3 * opts.tol:
                # stagnating at round-off just above tol: accept what the arithmetic allows
                g2, h2, gl2 = self.evaluate(x[:-1], float(x[-1]))
                residuals.append(float(np.max(np.abs(g2))))
                return _Point(x[:-1].copy(), float(x[-1]), g2, h2, gl2, it + 1, tuple(residuals))
        return None  # pragma: no cover

    def at_lambda(self, theta: np.ndarray, lam: float) -> _Point | None:
        """A point at fixed lambda (natural-parameter Newton) from theta."""
        c = np.zeros(self.n + 1)
        c[-1] = 1.0
        return self.correct(np.concatenate([theta, [lam]]), c, lam)

    def on_segment(self, a: _Point, s: float) -> _Point | None:
        """The point at arclength s from ``a`` along its tangent (pseudo-arclength corrector)."""
        xa = np.concatenate([a.theta, [a.lam]])
        c = self.row(a.tangent)
        return self.correct(xa + s * a.tangent, c, float(c @ xa) + s)

    def tangent(self, pt: _Point, previous: np.ndarray | None, direction: float = 1.0) -> np.ndarray | None:
        """The unit tangent at ``pt`` oriented along ``previous`` (or with d lambda of ``direction``'s sign)."""
        n = self.n
        if previous is None:
            try:
                z = np.linalg.solve(pt.h, -pt.gl)
            except np.linalg.LinAlgError:
                return None
            t = np.concatenate([z, [1.0]]) * direction
        else:
            jac = np.empty((n + 1, n + 1))
            jac[:n, :n] = pt.h
            jac[:n, n] = pt.gl
            jac[n, :] = self.row(previous)
            rhs = np.zeros(n + 1)
            rhs[-1] = 1.0
            try:
                t = np.linalg.solve(jac, rhs)
            except np.linalg.LinAlgError:
                return None
        if not np.all(np.isfinite(t)):
            return None
        return t / self.norm(t)

    def spectrum(self, pt: _Point) -> None:
        eig, vec = np.linalg.eigh(pt.h)
        pt.eig, pt.vec = eig, vec
        pt.morse = morse_index(eig, self.opts.critical_tol)


def _crossing_index(morse_a: int, morse_b: int) -> int:
    """Index (ascending order) of the eigenvalue that crosses zero between Morse indices a and b."""
    return min(morse_a, morse_b)


def _special_from(
    eng: _Engine, kind: str, pt: _Point, idx: int | None, a: _Point, b: _Point, status: str, method: str
) -> SpecialPoint:
    if pt.eig is None:
        eng.spectrum(pt)
    if idx is None:
        eigval, vec = math.nan, np.zeros(0)
    else:
        eigval, vec = float(pt.eig[idx]), pt.vec[:, idx].copy()
        k = int(np.argmax(np.abs(vec)))
        vec = vec * np.sign(vec[k])  # a sign convention: the largest component positive
    return SpecialPoint(
        kind=kind,
        lam=float(pt.lam),
        theta=pt.theta.copy(),
        tip=eng.prob.tip(pt.theta, pt.lam),
        eigenvalue=eigval,
        eigenvector=vec,
        morse_before=a.morse,
        morse_after=b.morse,
        status=status,
        bracket=(float(a.lam), float(b.lam)),
        method=method,
    )


def _brent_on_segment(eng: _Engine, a: _Point, s_b: float, f: Callable[[_Point], float], f_a: float, f_b: float):
    """Brent's method on s in [0, s_b] for f(point(s)) = 0; returns (point, converged)."""
    cache: dict[float, _Point | None] = {}

    def point(s: float) -> _Point | None:
        if s not in cache:
            cache[s] = eng.on_segment(a, s)
        return cache[s]

    def fs(s: float) -> float:
        if s == 0.0:
            return f_a
        if s == s_b:
            return f_b
        pt = point(s)
        if pt is None:
            raise _SegmentError
        return f(pt)

    from scipy.optimize import brentq  # SciPy's optimize takes ~0.2 s to import: only when a point is located

    try:
        s_star = brentq(fs, 0.0, s_b, xtol=1e-15 * max(1.0, s_b), rtol=1e-15, maxiter=200)
    except (_SegmentError, ValueError, RuntimeError):
        return None, False
    pt = point(s_star) if 0.0 < s_star < s_b else None
    if pt is None:
        pt = eng.on_segment(a, s_star)
    return pt, pt is not None


class _SegmentError(Exception):
    pass


def _locate_crossing(eng: _Engine, a: _Point, b: _Point, s_b: float, fold: bool) -> tuple[_Point, str, str]:
    """The point where the crossing eigenvalue vanishes between a and b: (point, status, method)."""
    idx = _crossing_index(a.morse, b.morse)
    idx = min(idx, eng.n - 1)
    f_a, f_b = float(a.eig[idx]), float(b.eig[idx])
    nearer = a if abs(f_a) <= abs(f_b) else b
    if fold and eng.opts.locate == "extended":
        pt = _fold_newton(eng, nearer, idx, a, b)
        if pt is not None:
            return pt, "converged", "extended system (g = 0, H v = 0, v0 . v = 1)"
    if not fold:
        # a branch point: the corrector is singular there, so Brent's method may not get close; the
        # minimally extended system is regular
        pt = _branch_point_newton(eng, nearer, idx, a, b)
        if pt is not None:
            return pt, "converged", "extended system (g + mu phi = 0, H phi = 0, phi . phi = 1, phi . dg/dlambda = 0)"
    if f_a * f_b < 0:

        def crit(pt: _Point) -> float:
            return float(np.linalg.eigvalsh(pt.h)[idx])

        pt, ok = _brent_on_segment(eng, a, s_b, crit, f_a, f_b)
        if ok and pt is not None:
            return pt, "converged", "eigenvalue bisection (Brent's method on the arclength)"
    best = a if abs(f_a) <= abs(f_b) else b
    return best, "guess", "bracketed only (the end with the smaller critical eigenvalue)"


def _fold_newton(eng: _Engine, start: _Point, idx: int, a: _Point, b: _Point) -> _Point | None:
    """Newton on the extended system g = 0, H v = 0, v0 . v = 1 from ``start``; None when it fails
    or lands outside the bracket."""
    prob, n = eng.prob, eng.n
    v0 = start.vec[:, idx].copy()
    theta, lam, v = start.theta.copy(), float(start.lam), v0.copy()
    tol = eng.opts.tol
    for _ in range(40):
        if not eng.admissible(theta, lam):
            return None
        g, h, gl = eng.evaluate(theta, lam)
        hv, hv_t, hv_l, _ = prob.fold_terms(theta, lam, v)
        res = np.concatenate([g, hv, [v0 @ v - 1.0]])
        if not np.all(np.isfinite(res)):
            return None
        hscale = max(1.0, float(np.max(np.abs(h))))
        if np.max(np.abs(g)) <= tol and np.max(np.abs(hv)) <= 1e-13 * hscale and abs(res[-1]) <= 1e-14:
            break
        jac = np.zeros((2 * n + 1, 2 * n + 1))
        jac[:n, :n] = h
        jac[:n, n] = gl
        jac[n : 2 * n, :n] = hv_t
        jac[n : 2 * n, n] = hv_l
        jac[n : 2 * n, n + 1 :] = h
        jac[2 * n, n + 1 :] = v0
        try:
            step = np.linalg.solve(jac, -res)
        except np.linalg.LinAlgError:
            return None
        theta = theta + step[:n]
        lam = lam + float(step[n])
        v = v + step[n + 1 :]
        if np.max(np.abs(step)) <= 1e-15 * (1.0 + np.max(np.abs(theta)) + abs(lam)):
            break
    else:
        return None
    g, h, gl = eng.evaluate(theta, lam)
    if np.max(np.abs(g)) > 1e3 * tol:
        return None
    # the fold lies on the path between a and b (lambda, extremal there, may lie just beyond both)
    span = eng.norm(np.concatenate([b.theta - a.theta, [b.lam - a.lam]]))
    for end in (a, b):
        if eng.norm(np.concatenate([theta - end.theta, [lam - end.lam]])) > 1.5 * span + 1e-12:
            return None
    return _Point(theta, lam, g, h, gl)


def _branch_point_newton(eng: _Engine, start: _Point, idx: int, a: _Point, b: _Point) -> _Point | None:
    """Newton on Moore's extended system for a simple branch point from ``start``:
    g + mu phi = 0, H phi = 0, phi . phi = 1, phi . dg/dlambda = 0 in (theta, lambda, phi, mu)
    (regular at a simple branch point, where mu = 0); None when it fails or lands off the bracket."""
    prob, n = eng.prob, eng.n
    theta, lam = start.theta.copy(), float(start.lam)
    phi = start.vec[:, idx].copy()
    mu = 0.0
    tol = eng.opts.tol
    for _ in range(40):
        if not eng.admissible(theta, lam):
            return None
        g, h, gl = eng.evaluate(theta, lam)
        hv, hv_t, hv_l, vgll = prob.fold_terms(theta, lam, phi)
        res = np.concatenate([g + mu * phi, hv, [phi @ phi - 1.0, phi @ gl]])
        if not np.all(np.isfinite(res)):
            return None
        hscale = max(1.0, float(np.max(np.abs(h))))
        if np.max(np.abs(g)) <= tol and np.max(np.abs(hv)) <= 1e-13 * hscale and abs(res[2 * n]) <= 1e-14 and abs(res[-1]) <= tol:
            break
        jac = np.zeros((2 * n + 2, 2 * n + 2))
        jac[:n, :n] = h
        jac[:n, n] = gl
        jac[:n, n + 1 : 2 * n + 1] = mu * np.eye(n)
        jac[:n, 2 * n + 1] = phi
        jac[n : 2 * n, :n] = hv_t
        jac[n : 2 * n, n] = hv_l
        jac[n : 2 * n, n + 1 : 2 * n + 1] = h
        jac[2 * n, n + 1 : 2 * n + 1] = 2.0 * phi
        jac[2 * n + 1, :n] = hv_l  # d(phi . g_lambda)/dtheta = (d(H phi)/dlambda) at fixed phi
        jac[2 * n + 1, n] = vgll
        jac[2 * n + 1, n + 1 : 2 * n + 1] = gl
        try:
            step = np.linalg.solve(jac, -res)
        except np.linalg.LinAlgError:
            return None
        theta = theta + step[:n]
        lam = lam + float(step[n])
        phi = phi + step[n + 1 : 2 * n + 1]
        mu = mu + float(step[-1])
        if np.max(np.abs(step)) <= 1e-15 * (1.0 + np.max(np.abs(theta)) + abs(lam)):
            break
    else:
        return None
    g, h, gl = eng.evaluate(theta, lam)
    if np.max(np.abs(g)) > 1e3 * tol:
        return None
    span = eng.norm(np.concatenate([b.theta - a.theta, [b.lam - a.lam]]))
    for end in (a, b):
        if eng.norm(np.concatenate([theta - end.theta, [lam - end.lam]])) > 1.5 * span + 1e-12:
            return None
    return _Point(theta, lam, g, h, gl)


def _locate_value(eng: _Engine, a: _Point, b: _Point, s_b: float, f: Callable[[_Point], float]) -> _Point | None:
    """The point between a and b where f crosses zero (a bound, a user value, an event)."""
    f_a, f_b = f(a), f(b)
    if f_a == 0.0:
        return a
    if f_b == 0.0:
        return b
    pt, ok = _brent_on_segment(eng, a, s_b, f, f_a, f_b)
    return pt if ok else None


def _lam_delta(problem: PathProblem, d: float) -> float:
    if problem.period is None:
        return d
    p = problem.period
    return (d + 0.5 * p) % p - 0.5 * p


@single_threaded
def trace(
    problem: PathProblem,
    theta0: Sequence[float],
    lam0: float,
    *,
    to: float | None = None,
    bounds: tuple[float, float] | None = None,
    options: PathOptions | None = None,
    direction: float | None = None,
    tangent: Sequence[float] | None = None,
    milestones: Sequence[float] = (),
    stop_on_instability: bool = False,
    event: Callable[[float, np.ndarray], float] | None = None,
    label: str = "",
) -> Branch:
    """Follow the branch through (theta0, lam0) of ``problem``.

    Parameters
    ----------
    problem : PathProblem
    theta0 : sequence of float
        A point on (or near) the branch at ``lam0``, rad; it is corrected at fixed lambda first.
    lam0 : float
        Lambda at the start, in the parameter's unit.
    to : float, optional
        Trace towards this value and stop exactly on it; the branch may turn back at folds on the
        way, and then stops exactly at the other end of [lam0, to] if it returns there.
    bounds : (low, high), optional
        The interval of lambda to stay in (instead of [lam0, to]); always cut to the model's domain.
    options : PathOptions, optional
    direction : float, optional
        +1 or -1: the sign of d lambda of the first step (default: towards ``to``, else +1).
    tangent : sequence of float, optional
        The first tangent (theta, lambda) instead (used to leave a branch point).
    milestones : sequence of float
        Values of lambda at which points are located exactly (user points), wherever the
        branch crosses them.
    stop_on_instability : bool
        Stop at the first special point where the Morse index rises from 0 (the end of a stable
        branch for a load ramp).
    event : callable, optional
        ``event(lam, theta) -> float``: the trace stops where it changes sign (located).
    label : str
        A name for the branch (in its JSON and CSV).

    Returns
    -------
    Branch
    """
    opts = DEFAULT_PATH_OPTIONS if options is None else options
    if not isinstance(opts, PathOptions):
        raise PathError(f"options={options!r}: expected a PathOptions")
    if not isinstance(problem, PathProblem):
        raise PathError(f"problem={problem!r}: expected a PathProblem")
    lam0 = checks.finite("lam0", lam0, PathError)
    theta0 = np.asarray(theta0, dtype=float).ravel()
    if theta0.shape != (problem.n,) or not np.all(np.isfinite(theta0)):
        raise PathError(f"theta0 has shape {theta0.shape}: expected {problem.n} finite angles (rad)")
    dom_lo, dom_hi = problem.domain
    if to is not None:
        to = checks.finite("to", to, PathError)
        lo, hi = min(lam0, to), max(lam0, to)
    elif bounds is not None:
        lo, hi = (checks.finite("bounds", v, PathError) for v in bounds)
        if not lo <= lam0 <= hi:
            raise PathError(f"bounds=({lo:g}, {hi:g}): the start {lam0:g} must lie inside")
    else:
        lo, hi = dom_lo, dom_hi
    lo, hi = max(lo, dom_lo), min(hi, dom_hi)
    if not problem.in_range(lam0):
        raise PathError(f"{problem.describe(lam0)}: outside the parameter's range ({dom_lo:g} to {dom_hi:g} {problem.unit})")
    if lo > hi:
        raise PathError(f"{problem.name}: nothing to trace between {lo:g} and {hi:g} {problem.unit} inside the range {dom_lo:g} to {dom_hi:g}")
    if opts.scale is not None:
        sigma = opts.scale
    elif math.isfinite(hi - lo) and hi > lo:
        sigma = hi - lo
    else:
        sigma = problem.scale
    eng = _Engine(problem, opts, sigma)
    first = eng.at_lambda(theta0, lam0)
    if first is None:
        pts: list[_Point] = []
        return _branch(eng, pts, [], "start", f"no equilibrium found near the start at {problem.describe(lam0)}", label)
    eng.spectrum(first)
    if tangent is not None:
        t = np.asarray(tangent, dtype=float).ravel()
        first.tangent = t / eng.norm(t)
    else:
        sign = direction if direction is not None else (1.0 if to is None or to >= lam0 else -1.0)
        first.tangent = eng.tangent(first, None, math.copysign(1.0, sign))
        if first.tangent is None:
            return _branch(eng, [first], [], "start", f"the start at {problem.describe(lam0)} is singular: give a tangent", label)
    if to is not None and to == lam0:
        return _branch(eng, [first], [], "bound", f"reached {problem.describe(to)}", label)

    points: list[_Point] = [first]
    kinds: list[str] = ["start"]
    specials: list[tuple[int, SpecialPoint]] = []
    arclength = [0.0]
    ds = opts.ds
    start_x = np.concatenate([first.theta, [first.lam]])
    travelled = 0.0
    stopped, reason = "max_steps", f"stopped after max_steps = {opts.max_steps} steps"
    max_turn = math.radians(opts.max_turn_deg)
    marks = sorted(float(m) for m in milestones)
    total_event = None if opts.stop_total_angle_deg is None else math.radians(opts.stop_total_angle_deg)

    steps = 0
    beyond = None
    while steps < opts.max_steps:
        a = points[-1]
        b = eng.on_segment(a, ds)
        reject = b is None
        if not reject:
            b.tangent = eng.tangent(b, a.tangent)
            reject = b.tangent is None
        if not reject:
            turn = math.acos(max(-1.0, min(1.0, eng.dot(a.tangent, b.tangent))))
            eng.spectrum(b)
            sharp = turn > max_turn
            double = abs(b.morse - a.morse) > 1
            reject = (sharp or double) and ds > opts.ds_min * 1.0000001
        if reject:
            if ds <= opts.ds_min * 1.0000001:
                out = _why_stuck(eng, a, ds)
                stopped, reason = out
                break
            ds = max(opts.ds_min, ds / 2.0)
            continue
        steps += 1
        s_b = ds
        # events on the segment a -> b, by arclength
        found: list[tuple[float, str, _Point, SpecialPoint | None]] = []
        # the bounds of lambda
        for bound in (lo, hi):
            if math.isfinite(bound) and (a.lam - bound) * (b.lam - bound) < 0 or (b.lam == bound and a.lam != bound):
                pt = _locate_value(eng, a, b, s_b, lambda p, v=bound: p.lam - v)
                if pt is not None:
                    pt = eng.at_lambda(pt.theta, bound) or pt  # exactly on the bound
                    sp = None
                    if bound in marks:  # a requested value at the end
                        sp = _special_from(eng, "user", pt, None, a, b, "converged", "at the requested value (Newton at fixed lambda)")
                    found.append((_s_of(eng, a, pt), "end", pt, sp))
        for m in marks:
            if m in (lo, hi):
                continue
            if (a.lam - m) * (b.lam - m) < 0 or (b.lam == m and a.lam != m):
                pt = _locate_value(eng, a, b, s_b, lambda p, v=m: p.lam - v)
                if pt is not None:
                    pt = eng.at_lambda(pt.theta, m) or pt
                    sp = _special_from(eng, "user", pt, None, a, b, "converged", "at the requested value (Newton at fixed lambda)")
                    found.append((_s_of(eng, a, pt), "user", pt, sp))
        if opts.detect and (b.morse != a.morse or np.sign(b.tangent[-1]) != np.sign(a.tangent[-1]) and a.tangent[-1] != 0):
            fold = np.sign(b.tangent[-1]) != np.sign(a.tangent[-1])
            kind = "fold" if fold else "branch point"
            pt, status, method = _locate_crossing(eng, a, b, s_b, fold)
            idx = min(_crossing_index(a.morse, b.morse), eng.n - 1)
            if fold and a.morse == b.morse:
                eng.spectrum(pt)
                idx = int(np.argmin(np.abs(pt.eig)))
            sp = _special_from(eng, kind, pt, idx, a, b, status, method)
            found.append((_s_of(eng, a, pt), kind, pt, sp))
        for f_ev, name in (
            (event, "the user event"),
            (None if total_event is None else (lambda lam, th: float(np.sum(th)) - total_event), f"the total angle of {float(opts.stop_total_angle_deg or 0.0):g} deg"),
        ):
            if f_ev is None:
                continue
            fa, fb = f_ev(a.lam, a.theta), f_ev(b.lam, b.theta)
            if fa * fb < 0 or (fb == 0 and fa != 0):
                pt = _locate_value(eng, a, b, s_b, lambda p, fe=f_ev: fe(p.lam, p.theta))
                if pt is not None:
                    sp = _special_from(eng, "event", pt, None, a, b, "converged", f"{name} (Brent's method on the arclength)")
                    found.append((_s_of(eng, a, pt), "event", pt, sp))
        found.sort(key=lambda item: item[0])
        stop_here = None
        for s_pt, kind, pt, sp in found:
            if pt is not a and pt is not b:
                if pt.eig is None:
                    eng.spectrum(pt)
                pt.tangent = eng.tangent(pt, a.tangent) if pt.tangent is None else pt.tangent
                if pt.tangent is None:
                    pt.tangent = a.tangent
                points.append(pt)
                kinds.append(kind)
                arclength.append(travelled + s_pt)
            else:
                if pt is b:
                    points.append(b)
                    kinds.append(kind)
                    arclength.append(travelled + s_b)
            if sp is not None:
                specials.append((len(points) - 1, sp))
            if kind == "end":
                stop_here = ("bound", f"reached {problem.describe(pt.lam)}")
                break
            if kind == "event":
                stop_here = ("event", f"stopped at {sp.method.split(' (')[0]} at {problem.describe(pt.lam)}")
                break
            if stop_on_instability and kind in ("fold", "branch point") and sp.morse_before == 0 and sp.morse_after > 0:
                stop_here = ("instability", f"the stable branch ends at a {kind} at {problem.describe(pt.lam)}")
                break
        if stop_here is not None:
            stopped, reason = stop_here
            # keep the crossing step's far end for what happens next (the unstable side of a fold)
            beyond = (float(b.lam), b.theta.copy())
            break
        if not points or points[-1] is not b:
            points.append(b)
            kinds.append("regular")
            arclength.append(travelled + s_b)
        travelled += s_b
        # step control: towards target_iterations corrector iterations
        factor = 2.0 ** ((opts.target_iterations - max(b.iterations, 1)) / 2.0)
        ds = min(opts.ds_max, max(opts.ds_min, ds * min(2.0, max(0.5, factor))))
        # back at the start: a closed branch
        if steps >= 3 and travelled > 2.0 * opts.ds_max:
            d = np.concatenate([b.theta - start_x[:-1], [_lam_delta(problem, b.lam - start_x[-1])]])
            if eng.norm(d) < 0.5 * s_b and eng.dot(b.tangent, first.tangent) > 0:
                stopped, reason = "loop", f"returned to the start (a closed branch) after {steps} steps"
                break
    return _branch(eng, points, specials, stopped, reason, label, kinds, arclength, beyond)


def _s_of(eng: _Engine, a: _Point, pt: _Point) -> float:
    return float(eng.dot(a.tangent, np.concatenate([pt.theta - a.theta, [pt.lam - a.lam]])))


def _why_stuck(eng: _Engine, a: _Point, ds: float) -> tuple[str, str]:
    """Why no step of ds_min can be taken from ``a``."""
    prob = eng.prob
    x = np.concatenate([a.theta, [a.lam]]) + ds * a.tangent
    lam = float(x[-1])
    if not prob.defined(x[:-1], lam) or np.any(a.theta - prob.lower_bound(a.lam) < 1e-3 * max(1.0, abs(prob.lower_bound(a.lam)))):
        return "domain", f"the branch reaches the model's domain boundary (Eq. 10: the chamber closes) at {prob.describe(a.lam)}"
    return "corrector", f"the corrector fails even at ds_min = {eng.opts.ds_min:g} after {prob.describe(a.lam)}"


def _branch(
    eng: _Engine,
    points: list[_Point],
    specials: list[tuple[int, SpecialPoint]],
    stopped: str,
    reason: str,
    label: str,
    kinds: list[str] | None = None,
    arclength: list[float] | None = None,
    beyond: tuple[float, np.ndarray] | None = None,
) -> Branch:
    prob, n = eng.prob, eng.n
    for pt in points:
        if pt.eig is None:
            eng.spectrum(pt)
    m = len(points)
    kinds = kinds if kinds is not None else (["start"] + ["regular"] * (m - 1))[:m]
    arclength = arclength if arclength is not None else [0.0] * m
    special = tuple(replace(sp, index=i, arclength=float(arclength[i])) for i, sp in specials)
    return Branch(
        name=prob.name,
        unit=prob.unit,
        lam=np.array([pt.lam for pt in points], dtype=float),
        theta=np.array([pt.theta for pt in points], dtype=float).reshape(m, n),
        tip=np.array([prob.tip(pt.theta, pt.lam) for pt in points], dtype=float).reshape(m, 3),
        arclength=np.array(arclength, dtype=float),
        eigenvalues=np.array([pt.eig for pt in points], dtype=float).reshape(m, n),
        morse=np.array([pt.morse for pt in points], dtype=int),
        kind=np.array(kinds, dtype=object).astype(str) if m else np.array([], dtype=str),
        special=special,
        stopped=stopped,
        stop_reason=reason,
        iterations=np.array([pt.iterations for pt in points], dtype=int),
        residuals=tuple(pt.residuals for pt in points),
        critical_tol=eng.opts.critical_tol,
        label=label,
        beyond=beyond,
        evaluations=eng.evaluations,
    )


# ---------------------------------------------------------------------------------------------
# branch switching


def bifurcation_tangents(problem: PathProblem, point: SpecialPoint, branch_tangent: np.ndarray, w: float, sigma: float) -> np.ndarray:
    """The tangent (theta, lambda) of the branch crossing the traced one at a branch point.

    Both tangents lie in the plane of t_a = (psi, 1), psi = -H^+ dg/dlambda orthogonal to the null
    vector phi, and t_b = (phi, 0), and solve the algebraic bifurcation equation
    phi . D2g[t, t] = a alpha^2 + 2 b alpha beta + c beta^2 = 0 for t = alpha t_a + beta t_b, with
    the second derivatives from d(H phi)/d(theta, lambda) and d2(phi . g)/dlambda2 (AD). Of its two
    roots the one farther from ``branch_tangent`` (the traced branch's) is returned, unit in the metric
    w |dtheta|^2 + (dlambda / sigma)^2.
    """
    n = problem.n
    phi = point.eigenvector / np.linalg.norm(point.eigenvector)
    _, h, gl = problem.ghl(point.theta, point.lam)
    _, hv_t, hv_l, vgll = problem.fold_terms(point.theta, point.lam, phi)
    m = np.zeros((n + 1, n + 1))
    m[:n, :n] = 0.5 * (hv_t + hv_t.T)
    m[:n, n] = hv_l
    m[n, :n] = hv_l
    m[n, n] = vgll
    psi = np.linalg.lstsq(h, -gl, rcond=1e-10)[0]
    psi = psi - (psi @ phi) * phi
    t_a = np.concatenate([psi, [1.0]])
    t_b = np.concatenate([phi, [0.0]])
    a, b, c = t_a @ m @ t_a, t_a @ m @ t_b, t_b @ m @ t_b
    disc = b * b - a * c
    scale = max(abs(a), abs(b), abs(c), 1e-300)
    if disc < -1e-12 * scale**2:
        raise PathError(f"branch point at {problem.describe(point.lam)}: no real crossing direction (b^2 - ac = {disc:.3g})")
    root = math.sqrt(max(disc, 0.0))
    if abs(a) >= abs(c) and abs(a) > 1e-12 * scale:
        pairs = [((-b + root) / a, 1.0), ((-b - root) / a, 1.0)]  # (alpha, beta)
    elif abs(c) > 1e-12 * scale:
        pairs = [(1.0, (-b + root) / c), (1.0, (-b - root) / c)]
    else:  # a = c = 0: the two branches are t_a and t_b themselves
        pairs = [(1.0, 0.0), (0.0, 1.0)]

    def unit(t: np.ndarray) -> np.ndarray:
        return t / math.sqrt(w * float(t[:n] @ t[:n]) + float(t[n]) ** 2 / sigma**2)

    candidates = [unit(al * t_a + be * t_b) for al, be in pairs]
    traced = unit(np.asarray(branch_tangent, dtype=float))

    def alignment(t: np.ndarray) -> float:
        return abs(w * float(t[:n] @ traced[:n]) + float(t[n] * traced[n]) / sigma**2)

    return min(candidates, key=alignment)


@single_threaded
def bifurcating_branches(
    problem: PathProblem,
    point: SpecialPoint,
    branch_tangent: np.ndarray | None = None,
    *,
    to: float | None = None,
    bounds: tuple[float, float] | None = None,
    options: PathOptions | None = None,
    label: str = "",
) -> list[Branch]:
    """Trace the branch that crosses at a branch point, on both sides (two :class:`Branch`).

    Parameters
    ----------
    problem : PathProblem
    point : SpecialPoint
        A branch point of a trace of ``problem`` (``kind == "branch point"``).
    branch_tangent : ndarray, optional
        The traced branch's tangent there (theta, lambda); default: along lambda with
        dtheta/dlambda = -H^-1 dg/dlambda projected off the null vector.
    to, bounds, options, label :
        As for :func:`trace`; each side is traced until it stops.
    """
    if point.kind != "branch point":
        raise PathError(f"bifurcating_branches needs a branch point, got a {point.kind}")
    opts = DEFAULT_PATH_OPTIONS if options is None else options
    n = problem.n
    w = float(opts.theta_weight if opts.theta_weight is not None else n)
    if bounds is None:
        bounds = (min(point.lam, to), max(point.lam, to)) if to is not None else problem.domain
    lo, hi = max(bounds[0], problem.domain[0]), min(bounds[1], problem.domain[1])
    sigma = opts.scale if opts.scale is not None else (hi - lo if math.isfinite(hi - lo) and hi > lo else problem.scale)
    t_new = bifurcation_tangents(problem, point, _branch_tangent(problem, point, branch_tangent), w, sigma)
    out = []
    for side, sign in (("+", 1.0), ("-", -1.0)):
        name = f"{label}{side}" if label else f"bifurcating {side}"
        eng = _Engine(problem, opts, sigma)
        start, anchor = step_off(eng, point, sign * t_new)
        if start is None:
            out.append(_branch(eng, [], [], "start", f"no point found off the branch point on side {side}", name))
            continue
        tangent = eng.tangent(start, anchor.tangent)
        br = trace(problem, start.theta, start.lam, bounds=(min(lo, start.lam), max(hi, start.lam)), options=opts, tangent=tangent, label=name)
        out.append(br)
    return out


def _branch_tangent(problem: PathProblem, point: SpecialPoint, given: np.ndarray | None) -> np.ndarray:
    """The traced branch's tangent at a branch point: given, or along lambda with
    dtheta/dlambda = -H^+ dg/dlambda (the pseudo-inverse: H is singular there)."""
    if given is not None:
        return np.asarray(given, dtype=float)
    _, h, gl = problem.ghl(point.theta, point.lam)
    z = np.linalg.lstsq(h, -gl, rcond=1e-10)[0]
    return np.concatenate([z, [1.0]])


def step_off(eng: _Engine, point: SpecialPoint, direction: np.ndarray) -> tuple[_Point | None, _Point]:
    """The first point of the crossing branch from a branch point along ``direction`` (pseudo-arclength
    corrector, the step halved until the point lands on the new branch, not back on the old one)."""
    problem, opts = eng.prob, eng.opts
    phi = point.eigenvector / np.linalg.norm(point.eigenvector)
    anchor = _Point(point.theta.copy(), point.lam, *problem.ghl(point.theta, point.lam))
    anchor.tangent = direction
    ds = opts.ds
    while ds >= opts.ds_min:
        start = eng.on_segment(anchor, ds)
        if start is not None:
            moved = float((start.theta - point.theta) @ phi)
            predicted = float(ds * direction[:-1] @ phi)
            if predicted != 0 and moved / predicted > 0.5:
                eng.spectrum(start)
                return start, anchor
        ds /= 2.0
    return None, anchor

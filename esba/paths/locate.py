"""Special points of a branch, located precisely between two traced points a and b.

* A **fold** (lambda turns back, one eigenvalue of H crosses zero) by Newton on the extended system
  g = 0, H v = 0, v0 . v = 1 in (theta, lambda, v), with the third derivatives d(H v)/d(theta, lambda)
  by AD (:meth:`esba.paths.problem.PathProblem.fold_terms`); or by Brent's method on the crossing
  eigenvalue along the arclength between a and b ("eigenvalue bisection").
* A **branch point** (an eigenvalue crosses zero and lambda goes on) by Newton on Moore's extended
  system g + mu phi = 0, H phi = 0, phi . phi = 1, phi . dg/dlambda = 0 in (theta, lambda, phi, mu),
  regular at a simple branch point where the fold system and the corrector are singular; or by
  Brent's method.
* A **value** (a bound, a requested lambda, an event) by Brent's method on the arclength.

A point found by an extended system is accepted only when it lies on the traced segment: its
arclength along a's tangent within [0, s_b] and the pseudo-arclength corrector at that arclength
landing on it; otherwise (a neighbouring fold, near a cusp) Brent's method decides, and when that
cannot bracket it the better end is reported as a ``guess``.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .branch import SpecialPoint
from .corrector import Corrector, Point

__all__ = ["locate_crossing", "locate_value", "special_from", "orthogonality", "classify_branch_point", "BRANCH_ORTHOGONALITY", "PITCHFORK_TOL"]

#: A zero eigenvalue of H with critical vector phi is a branch point when |phi . dg/dlambda| is at most
#: this fraction of |dg/dlambda| (Moore's extended system: dg/dlambda in the range of H), a fold when
#: it is more. A branch point located to the corrector's tolerance gives about 1e-11; a fold next to
#: a branch point (an imperfect bifurcation, a near-cusp) gives 1e-3 and more.
BRANCH_ORTHOGONALITY = 1e-6

#: A branch point is a pitchfork when its cubic coefficient c = d3U[phi, phi, phi] is at most this
#: fraction of the largest third derivative along phi, ||d(H phi)/dtheta||_2 (or when there is no third
#: derivative at all: below 1e-12 of ||H||_2), transcritical otherwise.
PITCHFORK_TOL = 1e-6


class _SegmentError(Exception):
    pass


def orthogonality(corr: Corrector, pt: Point, phi: np.ndarray) -> float:
    """|phi . dg/dlambda| / |dg/dlambda| at ``pt`` for its unit critical vector ``phi``: 0 at a branch
    point, not at a fold. Where dg/dlambda itself vanishes, within 1e3 times the corrector's
    tolerance over the trace's scale of lambda (|dg/dlambda| sigma <= 1e3 tol: the straight column,
    an equilibrium under every load), it is 0: the zero eigenvalue there is a branch point's."""
    gl = pt.gl
    size = float(np.linalg.norm(gl))
    if not size * corr.sigma > 1e3 * corr.opts.tol:
        return 0.0
    return float(abs(phi @ gl)) / size


def classify_branch_point(problem, theta: np.ndarray, lam: float, phi: np.ndarray) -> tuple[str, float]:
    """(``"transcritical"`` or ``"pitchfork"``, c) at a branch point with unit null vector ``phi``.

    c = phi . D2g[phi, phi] = d3U[phi, phi, phi] is the coefficient of beta^2 in the algebraic
    bifurcation equation (:func:`esba.paths.continuation.bifurcation_tangents`): with c = 0 the crossing
    branch leaves along (phi, 0), at constant lambda (a pitchfork); with c != 0 its lambda changes
    linearly with the amplitude along phi, rising on one side and falling on the other
    (transcritical). The rule: :data:`PITCHFORK_TOL`."""
    phi = np.asarray(phi, dtype=float)
    phi = phi / np.linalg.norm(phi)
    _, h, _ = problem.ghl(theta, lam)
    _, hv_t, _, _ = problem.fold_terms(theta, lam, phi)
    cubic = float(phi @ hv_t @ phi)
    third = float(np.linalg.norm(hv_t, 2))
    if third <= 1e-12 * float(np.linalg.norm(h, 2)) or abs(cubic) <= PITCHFORK_TOL * third:
        return "pitchfork", cubic
    return "transcritical", cubic


def special_from(
    corr: Corrector, kind: str, pt: Point, idx: int | None, a: Point, b: Point, status: str, method: str, vector: np.ndarray | None = None
) -> SpecialPoint:
    """A :class:`SpecialPoint` at ``pt``: ``idx`` is the critical eigenvalue's index (None for a value);
    ``vector`` the critical vector when the extended system found it (its Rayleigh quotient is then
    the critical eigenvalue, without an eigendecomposition)."""
    if idx is None:
        eigval, vec = float("nan"), np.zeros(0)
    elif vector is not None:
        vec = vector / np.linalg.norm(vector)
        eigval = float(vec @ pt.h @ vec)
    else:
        corr.spectrum(pt)
        eigval, vec = float(pt.eig[idx]), pt.vec[:, idx].copy()
    orth, bifurcation, cubic = float("nan"), "", float("nan")
    if idx is not None:
        k = int(np.argmax(np.abs(vec)))
        vec = vec * np.sign(vec[k])  # a sign convention: the largest component positive
        orth = orthogonality(corr, pt, vec)
        if kind == "branch point":
            bifurcation, cubic = classify_branch_point(corr.prob, pt.theta, pt.lam, vec)
    return SpecialPoint(
        kind=kind,
        lam=float(pt.lam),
        theta=pt.theta.copy(),
        tip=corr.prob.tips(pt.theta[None, :], np.array([pt.lam]))[0],
        eigenvalue=eigval,
        eigenvector=vec,
        morse_before=a.morse,
        morse_after=b.morse,
        status=status,
        bracket=(float(a.lam), float(b.lam)),
        method=method,
        orthogonality=orth,
        bifurcation=bifurcation,
        cubic=cubic,
    )


def _brent(corr: Corrector, a: Point, s_b: float, f: Callable[[Point], float], f_a: float, f_b: float) -> Point | None:
    """Brent's method on s in [0, s_b] for f(point(s)) = 0; None when it cannot."""
    cache: dict[float, Point | None] = {}

    def point(s: float) -> Point | None:
        if s not in cache:
            cache[s] = corr.on_segment(a, s)
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

    from scipy.optimize import (
        brentq,  # SciPy's optimize takes ~0.2 s to import: only when a point is located
    )

    try:
        s_star = brentq(fs, 0.0, s_b, xtol=1e-15 * max(1.0, s_b), rtol=1e-15, maxiter=200)
    except (_SegmentError, ValueError, RuntimeError):
        return None
    return point(s_star) if 0.0 < s_star < s_b else corr.on_segment(a, s_star)


def locate_value(corr: Corrector, a: Point, b: Point, s_b: float, f: Callable[[Point], float]) -> Point | None:
    """The point between a and b where f crosses zero (a bound, a user value, an event)."""
    f_a, f_b = f(a), f(b)
    if f_a == 0.0:
        return a
    if f_b == 0.0:
        return b
    return _brent(corr, a, s_b, f, f_a, f_b)


def _on_segment(corr: Corrector, a: Point, s_b: float, pt: Point) -> bool:
    """``pt`` lies on the traced segment from a (arclength 0) to s_b: the corrector at its arclength lands on it."""
    s = corr.arclength_of(a, pt)
    slack = 0.05 * s_b
    if not -slack <= s <= s_b + slack:
        return False
    there = corr.on_segment(a, s, dense=True)
    return there is not None and corr.distance(there, pt) <= 1e-6 * max(1.0, corr.norm(pt.x))


def _extended_newton(corr: Corrector, z: np.ndarray, system: Callable[[np.ndarray], tuple], max_iter: int = 40) -> np.ndarray | None:
    """Newton on an extended system: ``system(z) -> (residual, jacobian, converged)``, or (None, None, False).

    A step of at most 1e-7 (relative) after one that it squares (quadratic convergence) leaves the
    next one at round-off: z + step is returned without evaluating the system there again (the
    caller checks the gradient at the point it gets)."""
    previous = np.inf
    for _ in range(max_iter):
        res, jac, converged = system(z)
        if res is None:
            return None
        if converged:
            return z
        try:
            step = np.linalg.solve(jac, -res)
        except np.linalg.LinAlgError:
            return None
        if not np.all(np.isfinite(step)):
            return None
        z = z + step
        size = float(np.max(np.abs(step))) / (1.0 + float(np.max(np.abs(z))))
        if size <= 1e-15 or (size <= 1e-7 and size <= previous**1.5):
            return z
        previous = size
    return None


def _fold_system(corr: Corrector, v0: np.ndarray):
    """g = 0, H v = 0, v0 . v = 1 in z = (theta, lambda, v)."""
    prob, n, tol = corr.prob, corr.n, corr.opts.tol

    def system(z: np.ndarray):
        theta, lam, v = z[:n], float(z[n]), z[n + 1 :]
        if not corr.admissible(theta, lam):
            return None, None, False
        corr.evaluations += 1
        g, h, gl, hv, hv_t, hv_l, _ = prob.extended_terms(theta, lam, v)
        res = np.concatenate([g, hv, [v0 @ v - 1.0]])
        if not np.all(np.isfinite(res)):
            return None, None, False
        hscale = max(1.0, float(np.max(np.abs(h))))
        done = np.max(np.abs(g)) <= tol and np.max(np.abs(hv)) <= 1e-13 * hscale and abs(res[-1]) <= 1e-14
        jac = np.zeros((2 * n + 1, 2 * n + 1))
        jac[:n, :n] = h
        jac[:n, n] = gl
        jac[n : 2 * n, :n] = hv_t
        jac[n : 2 * n, n] = hv_l
        jac[n : 2 * n, n + 1 :] = h
        jac[2 * n, n + 1 :] = v0
        return res, jac, done

    return system


def _branch_point_system(corr: Corrector):
    """Moore's g + mu phi = 0, H phi = 0, phi . phi = 1, phi . dg/dlambda = 0 in z = (theta, lambda, phi, mu)."""
    prob, n, tol = corr.prob, corr.n, corr.opts.tol

    def system(z: np.ndarray):
        theta, lam, phi, mu = z[:n], float(z[n]), z[n + 1 : 2 * n + 1], float(z[-1])
        if not corr.admissible(theta, lam):
            return None, None, False
        corr.evaluations += 1
        g, h, gl, hv, hv_t, hv_l, vgll = prob.extended_terms(theta, lam, phi)
        res = np.concatenate([g + mu * phi, hv, [phi @ phi - 1.0, phi @ gl]])
        if not np.all(np.isfinite(res)):
            return None, None, False
        hscale = max(1.0, float(np.max(np.abs(h))))
        done = np.max(np.abs(g)) <= tol and np.max(np.abs(hv)) <= 1e-13 * hscale and abs(res[2 * n]) <= 1e-14 and abs(res[-1]) <= tol
        jac = np.zeros((2 * n + 2, 2 * n + 2))
        jac[:n, :n] = h
        jac[:n, n] = gl
        jac[:n, n + 1 : 2 * n + 1] = mu * np.eye(n)
        jac[:n, 2 * n + 1] = phi
        jac[n : 2 * n, :n] = hv_t
        jac[n : 2 * n, n] = hv_l
        jac[n : 2 * n, n + 1 : 2 * n + 1] = h
        jac[2 * n, n + 1 : 2 * n + 1] = 2.0 * phi
        jac[2 * n + 1, :n] = hv_l  # d(phi . g_lambda)/dtheta = d(H phi)/dlambda at fixed phi
        jac[2 * n + 1, n] = vgll
        jac[2 * n + 1, n + 1 : 2 * n + 1] = gl
        return res, jac, done

    return system


def _extended(corr: Corrector, start: Point, v0: np.ndarray, fold: bool) -> tuple[Point, np.ndarray] | None:
    """Newton on the fold (or Moore's branch point) system from ``start`` and the critical vector ``v0``:
    the point and its critical vector (the null vector of H there)."""
    n = corr.n
    v0 = v0 / np.linalg.norm(v0)
    if fold:
        z = _extended_newton(corr, np.concatenate([start.theta, [start.lam], v0]), _fold_system(corr, v0))
    else:
        z = _extended_newton(corr, np.concatenate([start.theta, [start.lam], v0, [0.0]]), _branch_point_system(corr))
    if z is None:
        return None
    theta, lam, v = z[:n], float(z[n]), z[n + 1 : 2 * n + 1]
    if not corr.admissible(theta, lam) or not np.all(np.isfinite(v)):
        return None
    pt = corr.point(theta, lam)
    if np.max(np.abs(pt.g)) > 1e3 * corr.opts.tol:
        return None
    return pt, v / np.linalg.norm(v)


def _fold_start(corr: Corrector, a: Point, b: Point, s_b: float) -> tuple[Point, np.ndarray] | None:
    """A start for the fold system: the corrected point where the tangent's lambda component,
    interpolated linearly between a and b, is zero, and its tangent's theta part (at a fold the
    tangent is (v, 0) with H v = 0: the critical vector, without an eigendecomposition)."""
    ta, tb = float(a.tangent[-1]), float(b.tangent[-1])
    if ta == tb:
        return None
    s = s_b * ta / (ta - tb)
    if not 0.0 < s < s_b:
        return None
    guess = corr.on_segment(a, s)
    if guess is None:
        return None
    t = corr.tangent(guess, a.tangent)
    if t is None or not np.any(t[:-1]):
        return None
    return guess, t[:-1]


def locate_crossing(corr: Corrector, a: Point, b: Point, s_b: float, fold: bool, idx: int, method: str = "extended") -> tuple[Point, str, str, np.ndarray | None]:
    """The point between a and b where eigenvalue ``idx`` (ascending) crosses zero: (point, status,
    method, critical vector or None).

    ``fold``: lambda turns back there (else a branch point). ``method``: ``"extended"`` tries the
    extended system first (always for a branch point: the corrector is singular there), then Brent.
    A fold's extended system starts where the tangent's lambda component, interpolated between a
    and b, vanishes, with the tangent as its critical vector; a branch point's from the nearer end
    and the crossing eigenvector.
    """
    if method == "extended" or not fold:
        found = None
        if fold:
            start = _fold_start(corr, a, b, s_b)
            if start is not None:
                found = _extended(corr, start[0], start[1], True)
        if found is None:
            corr.spectrum(a)
            corr.spectrum(b)
            nearer = a if abs(float(a.eig[idx])) <= abs(float(b.eig[idx])) else b
            found = _extended(corr, nearer, nearer.vec[:, idx].copy(), fold)
        if found is not None and _on_segment(corr, a, s_b, found[0]):
            how = "extended system (g = 0, H v = 0, v0 . v = 1)" if fold else "extended system (g + mu phi = 0, H phi = 0, phi . phi = 1, phi . dg/dlambda = 0)"
            return found[0], "converged", how, found[1]
    corr.spectrum(a)
    corr.spectrum(b)
    f_a, f_b = float(a.eig[idx]), float(b.eig[idx])
    nearer = a if abs(f_a) <= abs(f_b) else b
    if f_a * f_b < 0:
        pt = _brent(corr, a, s_b, lambda p: float(np.linalg.eigvalsh(p.h)[idx]), f_a, f_b)
        if pt is not None:
            return pt, "converged", "eigenvalue bisection (Brent's method on the arclength)", None
    return nearer, "guess", "bracketed only (the end with the smaller critical eigenvalue)", None

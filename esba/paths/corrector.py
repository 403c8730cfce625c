"""The corrector of path following: points on a branch, the arclength metric, Newton on the bordered system.

A point of a branch is a root of g(theta, lambda) = dU/dtheta = 0 (:class:`esba.paths.problem.PathProblem`).
The :class:`Corrector` finds one from a guess under one extra linear condition c . (theta, lambda) = c0:

* the pseudo-arclength condition <t, x - x_a> = s (a step of length s along the tangent t at x_a),
* a fixed lambda (the natural parameter: a requested value, a bound),

by Newton's method on the bordered system [[H, dg/dlambda], [c]], and computes the unit tangent
and the spectrum of the Hessian (eigenvalues, Morse index) at a point. Lengths are measured in
the metric ds^2 = w |dtheta|^2 + (dlambda / sigma)^2: w = n (by default), so that a step is about
the same change of the total bending angle whatever the segment count, and sigma a typical size
of lambda (the span of the trace, or the parameter's own typical size) — :meth:`Corrector.for_trace`
decides both, for every user of the corrector.

Examples
--------
>>> import numpy as np
>>> from esba.model.scene import Scene, Payload
>>> from esba.paths.problem import PathProblem
>>> problem = PathProblem.from_scene(Scene(pressure=0.1, payloads=(Payload(1.0),)), "payload")
>>> corr = Corrector.for_trace(problem, 0.0, 2.0)
>>> corr.w, corr.sigma
(3.0, 2.0)
>>> p = corr.at_lambda(np.zeros(3), 1.0)
>>> bool(np.max(np.abs(p.g)) < 1e-10), p.lam
(True, 1.0)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from esba.model.stability import CRITICAL_TOL, morse_index

from .problem import PathProblem

__all__ = ["Point", "Corrector", "Settings"]


@dataclass(frozen=True)
class Settings:
    """What the corrector needs of the path options: tolerance, iteration limit, critical band, metric weight."""

    tol: float = 1e-10
    max_iterations: int = 12
    critical_tol: float = CRITICAL_TOL
    theta_weight: float | None = None
    scale: float | None = None


@dataclass
class Point:
    """A point of a branch: theta, lambda, and g, H, dg/dlambda there; its tangent and spectrum when computed."""

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

    @property
    def x(self) -> np.ndarray:
        """(theta, lambda) as one vector."""
        return np.concatenate([self.theta, [self.lam]])


class Corrector:
    """Newton on the bordered system of one problem, in the metric w |dtheta|^2 + (dlambda / sigma)^2."""

    def __init__(self, problem: PathProblem, settings, w: float, sigma: float):
        self.prob = problem
        self.opts = settings
        self.n = problem.n
        self.w = float(w)
        self.sigma = float(sigma)
        self.evaluations = 0

    @classmethod
    def for_trace(cls, problem: PathProblem, lo: float, hi: float, settings=None) -> Corrector:
        """The corrector of a trace over [lo, hi]: w from the settings or n, sigma from the settings,
        else the span hi - lo when it is finite and positive, else the parameter's typical size."""
        settings = Settings() if settings is None else settings
        w = settings.theta_weight if settings.theta_weight is not None else problem.n
        if settings.scale is not None:
            sigma = settings.scale
        elif math.isfinite(hi - lo) and hi > lo:
            sigma = hi - lo
        else:
            sigma = problem.scale
        return cls(problem, settings, w, sigma)

    # -- the metric ---------------------------------------------------------------------------

    def dot(self, a: np.ndarray, b: np.ndarray) -> float:
        """<a, b> = w a_theta . b_theta + a_lam b_lam / sigma^2 for (theta, lambda) vectors."""
        return float(self.w * (a[:-1] @ b[:-1]) + a[-1] * b[-1] / self.sigma**2)

    def norm(self, a: np.ndarray) -> float:
        return math.sqrt(max(self.dot(a, a), 0.0))

    def distance(self, a: Point, b: Point) -> float:
        return self.norm(b.x - a.x)

    def row(self, t: np.ndarray) -> np.ndarray:
        """The metric's row c with c . x = <t, x>."""
        out = self.w * np.array(t, dtype=float)
        out[-1] = t[-1] / self.sigma**2
        return out

    # -- evaluation ---------------------------------------------------------------------------

    def evaluate(self, theta: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        self.evaluations += 1
        return self.prob.ghl(theta, lam)

    def admissible(self, theta: np.ndarray, lam: float) -> bool:
        return self.prob.defined(theta, lam)

    def spectrum(self, pt: Point) -> None:
        """Eigenvalues (ascending), eigenvectors and Morse index of the Hessian at ``pt``."""
        eig, vec = np.linalg.eigh(pt.h)
        pt.eig, pt.vec = eig, vec
        pt.morse = morse_index(eig, self.opts.critical_tol)

    # -- correcting ----------------------------------------------------------------------------

    def correct(self, x: np.ndarray, c: np.ndarray, c0: float) -> Point | None:
        """Newton on g(theta, lambda) = 0, c . x = c0 from x; None when it fails (leaves the model's
        domain, is not finite, diverges, or needs more than ``max_iterations``)."""
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
                return Point(theta.copy(), lam, g, h, gl, it, tuple(residuals))
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
                return Point(x[:-1].copy(), float(x[-1]), g2, h2, gl2, it + 1, tuple(residuals))
        return None  # pragma: no cover

    def at_lambda(self, theta: np.ndarray, lam: float) -> Point | None:
        """A point at fixed lambda (natural-parameter Newton) from theta."""
        c = np.zeros(self.n + 1)
        c[-1] = 1.0
        return self.correct(np.concatenate([theta, [lam]]), c, lam)

    def on_segment(self, a: Point, s: float) -> Point | None:
        """The point at arclength s from ``a`` along its tangent (pseudo-arclength corrector)."""
        c = self.row(a.tangent)
        return self.correct(a.x + s * a.tangent, c, float(c @ a.x) + s)

    def arclength_of(self, a: Point, pt: Point) -> float:
        """How far along ``a``'s tangent ``pt`` lies: <t_a, x - x_a>."""
        return self.dot(a.tangent, pt.x - a.x)

    def tangent(self, pt: Point, previous: np.ndarray | None, direction: float = 1.0) -> np.ndarray | None:
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
        size = self.norm(t)
        return t / size if size > 0 else None

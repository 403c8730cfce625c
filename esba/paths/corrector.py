"""The corrector of path following: points on a branch, the arclength metric, Newton on the bordered system.

A point of a branch is a root of g(theta, lambda) = dU/dtheta = 0 (:class:`esba.paths.problem.PathProblem`).
The :class:`Corrector` finds one from a guess under one extra linear condition c . (theta, lambda) = c0:

* the pseudo-arclength condition <t, x - x_a> = s (a step of length s along the tangent t at x_a),
* a fixed lambda (the natural parameter: a requested value, a bound),

by Newton's method on the bordered system [[H, dg/dlambda], [c]]. Each call runs
:data:`esba.solvers.newton.BORDERED_ITERATIONS` Newton steps in one compiled CasADi Function
(:func:`esba.solvers.newton.bordered_function`: the block elimination with two O(n) structured
solves of H, the residuals, the domain margin, H's LDL^T pivots and the tangent at the result), so
that a converged point costs one call from Python. The pivots give the Morse index (Sylvester's
law of inertia); the eigenvalues and eigenvectors of H are computed only where they are asked for
(:meth:`Corrector.spectrum`: at special points, and for the branch's table). Near a fold or branch
point, where H is singular and the elimination loses digits, a corrector that fails is run again
on the dense bordered system.

Lengths are measured in the metric ds^2 = w |dtheta|^2 + (dlambda / sigma)^2: w = n (by
default), so that a step is about the same change of the total bending angle whatever the segment
count, and sigma a typical size of lambda (the span of the trace, or the parameter's own typical
size) — :meth:`Corrector.for_trace` decides both, for every user of the corrector.

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
>>> bool(np.max(np.abs(p.g)) < 1e-10), p.lam, p.morse
(True, 1.0, 0)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from esba.model.stability import CRITICAL_TOL, morse_index
from esba.solvers.native import Kernel
from esba.solvers.newton import BORDERED_ITERATIONS, bordered_function, bordered_layout, critical_function

from .problem import PathProblem

__all__ = ["Point", "Corrector", "Settings", "pivot_morse"]


@dataclass(frozen=True)
class Settings:
    """What the corrector needs of the path options: tolerance, iteration limit, critical band, metric weight."""

    tol: float = 1e-10
    max_iterations: int = 12
    critical_tol: float = CRITICAL_TOL
    theta_weight: float | None = None
    scale: float | None = None


def pivot_morse(pivots: np.ndarray, critical_tol: float = CRITICAL_TOL) -> tuple[int, float]:
    """(Morse index, smallest pivot relative to the largest magnitude) from H's LDL^T pivots: the
    pivots have the eigenvalues' signs, so the index is the number below ``-critical_tol`` times the
    largest magnitude (as :func:`esba.model.stability.morse_index` counts eigenvalues)."""
    scale = max(float(np.max(np.abs(pivots))), 1e-300)
    return int(np.sum(pivots < -critical_tol * scale)), float(np.min(pivots)) / scale


class Point:
    """A point of a branch: theta and lambda, how the corrector reached it, the Morse index from H's
    pivots, the tangent when computed; g, H and dg/dlambda, and H's spectrum, computed when asked for."""

    __slots__ = ("theta", "lam", "iterations", "residuals", "morse", "min_pivot", "small_pivot", "pivot_scale", "tangent", "eig", "vec", "_problem", "_ghl", "_u")

    def __init__(self, theta, lam, problem: PathProblem, iterations: int = 0, residuals=(), ghl=None, pivots=None, critical_tol: float = CRITICAL_TOL):
        self.theta = np.asarray(theta, dtype=float)
        self.lam = float(lam)
        self._problem = problem
        self.iterations = int(iterations)
        self.residuals = tuple(residuals)
        self._ghl = ghl
        self._u = None
        self.tangent: np.ndarray | None = None
        self.eig: np.ndarray | None = None
        self.vec: np.ndarray | None = None
        if pivots is None:  # a point the dense corrector found (next to a singular H): its eigenvalues
            pivots = np.linalg.eigvalsh(self.h)
        pivots = np.asarray(pivots, dtype=float)
        self.morse, self.min_pivot = pivot_morse(pivots, critical_tol)
        #: the smallest pivot in magnitude, relative to the largest (0 at a singular H)
        self.pivot_scale = max(float(np.max(np.abs(pivots))), 1e-300)
        self.small_pivot = float(np.min(np.abs(pivots))) / self.pivot_scale

    def _evaluate(self):
        if self._ghl is None:
            self._ghl = self._problem.ghl(self.theta, self.lam)
        return self._ghl

    @property
    def g(self) -> np.ndarray:
        """dU/dtheta at the point."""
        return self._evaluate()[0]

    @property
    def h(self) -> np.ndarray:
        """The Hessian (symmetrised) at the point."""
        return self._evaluate()[1]

    @property
    def gl(self) -> np.ndarray:
        """dg/dlambda at the point."""
        return self._evaluate()[2]

    @property
    def x(self) -> np.ndarray:
        """(theta, lambda) as one vector."""
        return np.concatenate([self.theta, [self.lam]])


def corrector_kernel(model, compile: str = "auto") -> tuple[Kernel, int]:
    """The corrector's kernel of ``model`` and its Newton steps per call: one step per call when it
    runs compiled (a C call costs microseconds, so the corrector stops as soon as it converges),
    :data:`~esba.solvers.newton.BORDERED_ITERATIONS` per call through CasADi's interpreter."""

    def build() -> tuple[Kernel, int]:
        one = Kernel(bordered_function(model, 1), compile, model.n)
        if one.compiled:
            return one, 1
        return Kernel(bordered_function(model, BORDERED_ITERATIONS), "never", model.n), BORDERED_ITERATIONS

    return model.derived("corrector_kernel", build, settings=(compile,), persist=False)


class Corrector:
    """Newton on the bordered system of one problem, in the metric w |dtheta|^2 + (dlambda / sigma)^2."""

    def __init__(self, problem: PathProblem, settings, w: float, sigma: float):
        self.prob = problem
        self.opts = settings
        self.n = problem.n
        self.w = float(w)
        self.sigma = float(sigma)
        self._weights = np.concatenate([np.full(self.n, self.w), [1.0 / self.sigma**2]])
        self.evaluations = 0
        own = getattr(problem, "corrector_kernels", None)
        if own is not None:  # a problem whose Hessian has no chain structure brings its own kernels (the 3-D model's)
            self._kernel, self._k, self._critical = own(getattr(settings, "compile", "auto"))
        else:
            self._kernel, self._k = corrector_kernel(problem.model, getattr(settings, "compile", "auto"))
            self._critical = problem.model.derived("critical_kernel", lambda: Kernel(critical_function(problem.model), "auto", self.n), persist=False)
        self._layout = bordered_layout(self.n, self._k)

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
        return float(np.dot(a * self._weights, b))

    def norm(self, a: np.ndarray) -> float:
        return math.sqrt(max(float(np.dot(a * self._weights, a)), 0.0))

    def distance(self, a: Point, b: Point) -> float:
        return self.norm(b.x - a.x)

    def row(self, t: np.ndarray) -> np.ndarray:
        """The metric's row c with c . x = <t, x>."""
        return np.asarray(t, dtype=float) * self._weights

    # -- evaluation ---------------------------------------------------------------------------

    def evaluate(self, theta: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        self.evaluations += 1
        return self.prob.ghl(theta, lam)

    def point(self, theta: np.ndarray, lam: float, iterations: int = 0, residuals=()) -> Point:
        """A :class:`Point` at (theta, lambda) with g, H and dg/dlambda evaluated (dense)."""
        ghl = self.evaluate(theta, lam)
        return Point(theta, lam, self.prob, iterations, residuals, ghl=ghl, critical_tol=self.opts.critical_tol)

    def admissible(self, theta: np.ndarray, lam: float) -> bool:
        return self.prob.defined(theta, lam)

    def spectrum(self, pt: Point) -> None:
        """Eigenvalues (ascending) and eigenvectors of the Hessian at ``pt`` (its Morse index stays the pivots')."""
        if pt.eig is None:
            eig, vec = np.linalg.eigh(pt.h)
            pt.eig, pt.vec = eig, vec

    # -- correcting ----------------------------------------------------------------------------

    def correct(self, x: np.ndarray, c: np.ndarray, c0: float, dense: bool = False) -> Point | None:
        """Newton on g(theta, lambda) = 0, c . x = c0 from x; None when it fails (leaves the model's
        domain, is not finite, diverges, or needs more than ``max_iterations``). ``dense``: on the
        dense bordered system at once (next to a special point, where H is singular)."""
        if dense:
            return self._correct_dense(np.asarray(x, dtype=float), c, c0)
        pt = self._correct_compiled(np.asarray(x, dtype=float), c, c0)
        if pt is None or pt == "singular":
            dense = self._correct_dense(np.asarray(x, dtype=float), c, c0) if pt == "singular" else None
            return dense
        return pt

    def _correct_compiled(self, x: np.ndarray, c: np.ndarray, c0: float):
        """The corrector on the O(n) kernel; ``"singular"`` when it failed next to a singular Hessian
        (for the dense corrector), None when it failed elsewhere."""
        opts = self.opts
        kernel, k_per, lay = self._kernel, self._k, self._layout
        prob = self.prob
        n1 = self.n + 1
        tol, max_it = opts.tol, opts.max_iterations
        crit = opts.critical_tol
        scale_c = 1e-12 * (1.0 + abs(c0))
        residuals: list[float] = []
        first = 0  # a later call starts at the last iterate of the one before: already checked
        z = np.concatenate([x, c, [c0, crit], prob.p0, prob.dp])
        res_at, rc_at, st_at, mg_at = lay["res"].start, lay["rc"].start, lay["steps"].start, lay["margin"].start
        while True:
            out = kernel.run(z)
            self.evaluations += k_per + 1
            small = out[lay["small_pivot"].start]
            near_singular = not (small * small >= 1e-12)  # also for a NaN pivot
            for k in range(first, k_per + 1):
                res, rc, margin = out[res_at + k], out[rc_at + k], out[mg_at + k]
                if not (margin > 0 and res < math.inf and rc < math.inf):
                    return "singular" if near_singular else None
                residuals.append(float(res))
                converged = res <= tol and rc <= scale_c
                if not converged and k > 0 and res <= 1e3 * tol and out[st_at + k - 1] < 1e-11:
                    converged = out[st_at + k - 1] <= 1e-15 * (1.0 + float(np.max(np.abs(out[:n1]))))  # stagnating at round-off
                if converged:
                    # the iterates after a converged one stay at the root: the call's end is the point
                    last = out[res_at + k_per]
                    if not (last <= max(res, tol) * 10 and out[mg_at + k_per] > 0):
                        return "singular" if near_singular else None
                    x_end = out[:n1]
                    pt = Point.__new__(Point)
                    pt.theta, pt.lam, pt._problem = x_end[:-1].copy(), float(x_end[-1]), prob
                    pt.iterations, pt.residuals, pt._ghl = len(residuals) - 1, tuple(residuals), None
                    pt.tangent = pt.eig = pt.vec = None
                    pt.morse, pt.min_pivot = int(out[lay["morse"].start]), float(out[lay["min_pivot"].start])
                    pt.small_pivot = float(small)
                    pt.pivot_scale = float(out[lay["pivot_scale"].start])
                    pt._u = out[lay["u"]].copy()
                    return pt
                if len(residuals) > max_it:
                    return "singular" if near_singular else None
                if len(residuals) >= 3 and residuals[-1] > residuals[-2] > residuals[-3]:
                    return "singular" if near_singular else None  # diverging
            z[:n1] = out[:n1]
            first = 1

    def _correct_dense(self, x: np.ndarray, c: np.ndarray, c0: float) -> Point | None:
        """Newton on the dense bordered system (where H is singular and the block elimination is not)."""
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
                return Point(theta.copy(), lam, self.prob, it, residuals, ghl=(g, h, gl), critical_tol=opts.critical_tol)
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
                return Point(x[:-1].copy(), float(x[-1]), self.prob, it + 1, residuals, ghl=(g2, h2, gl2), critical_tol=opts.critical_tol)
        return None  # pragma: no cover

    def at_lambda(self, theta: np.ndarray, lam: float) -> Point | None:
        """A point at fixed lambda (natural-parameter Newton) from theta."""
        c = np.zeros(self.n + 1)
        c[-1] = 1.0
        return self.correct(np.concatenate([np.asarray(theta, dtype=float), [lam]]), c, lam)

    def on_segment(self, a: Point, s: float, dense: bool = False) -> Point | None:
        """The point at arclength s from ``a`` along its tangent (pseudo-arclength corrector)."""
        c = self.row(a.tangent)
        return self.correct(a.x + s * a.tangent, c, float(c @ a.x) + s, dense)

    def arclength_of(self, a: Point, pt: Point) -> float:
        """How far along ``a``'s tangent ``pt`` lies: <t_a, x - x_a>."""
        return self.dot(a.tangent, pt.x - a.x)

    def tangent(self, pt: Point, previous: np.ndarray | None, direction: float = 1.0) -> np.ndarray | None:
        """The unit tangent at ``pt`` oriented along ``previous`` (or with d lambda of ``direction``'s sign).

        It solves [[H, dg/dlambda], [c]] t = e (c the metric row of ``previous``): by the structured
        elimination the corrector already did (t is a multiple of (-H^-1 dg/dlambda, 1)) where H is
        regular, else densely.
        """
        u = pt._u
        if u is not None and pt.small_pivot * pt.small_pivot >= 1e-12:
            wu = u * self._weights
            if previous is None:
                t = u * direction
            else:
                along = float(np.dot(previous, wu))
                t = u / along if abs(along) >= 1e-10 * math.sqrt(abs(float(np.dot(u, wu)))) else None
            if t is not None:
                size = math.sqrt(abs(float(np.dot(t * self._weights, t))))
                if size > 0 and math.isfinite(size):
                    return t / size
        return self._tangent_dense(pt, previous, direction)

    def _tangent_dense(self, pt: Point, previous: np.ndarray | None, direction: float) -> np.ndarray | None:
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

    def critical_mode(self, pt: Point, start: np.ndarray, direction: np.ndarray) -> tuple[np.ndarray, float, float]:
        """The eigenpair of H nearest zero at ``pt`` by inverse iteration from ``start`` (O(n)), and the
        eigenvalue's rate of change along ``direction`` (theta, lambda): (v, mu, d mu / ds)."""
        n = self.n
        out = self._critical(np.concatenate([pt.theta, [pt.lam], start, direction, self.prob.p0, self.prob.dp]))
        return out[:n], float(out[n]), float(out[n + 1])

    def morse_of_spectrum(self, pt: Point) -> int:
        """The Morse index from the eigenvalues (computing them if needed): the pivots' count, checked."""
        self.spectrum(pt)
        return morse_index(pt.eig, self.opts.critical_tol)

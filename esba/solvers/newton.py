"""Newton kernels of the continuation engine: CasADi Functions, O(n) from the Hessian's structure.

Every linear solve with the chain's Hessian H = diag(e) + C, C[j, k] = c[max(j, k)], is the O(n)
sweep of :mod:`esba.model.structured` (only row 0 and the diagonal of H are computed), and its
pivots, which have the signs of H's eigenvalues (Sylvester's law of inertia), give the Morse index
and the distance to a fold or branch point without an eigendecomposition. The kernels, each one
CasADi Function kept in the model's registry (:meth:`esba.model.generated.Model.derived`):

* :func:`newton_parts`: (theta, p, dp) -> g, H^-1 g, H^-1 dg/dlambda, the smallest relative pivot
  and every pivot: one Newton step's worth of work.
* :func:`natural_function`: natural-parameter continuation of lambda from 0 to lambda1 in ``steps``
  equal steps, each a tangent predictor and ``newton`` Newton corrections, ``final`` more at the
  end; one call from Python for a whole ramp, and the graph that the batch maps over many
  elements and compiles to C (:mod:`esba.statics.compiled`).
* :func:`bordered_function`: ``iterations`` Newton steps on the bordered system
  [[H, dg/dlambda], [c]] (a pseudo-arclength step, or a fixed lambda), solved by block elimination
  with two structured solves, with every residual, the domain margin, the pivots and the tangent at
  the result: one call per corrector of :mod:`esba.paths.corrector`.

One rule accepts what these kernels did (:class:`Acceptance`): finite and stationary at the end,
every Hessian met positive definite (its smallest pivot above ``critical_tol`` times the largest:
no fold or branch point was crossed), every step's Newton iteration contracting (the second
correction at most :data:`CONTRACTION` of the first, Deuflhard's test that the predictor lay in the
corrector's region of convergence) and no corrector moving the state farther than its predictor did
(:data:`JUMP`: a step over a fold lands on another stable branch with positive pivots and a
contracting iteration, but far from where the predictor pointed). A natural ramp
that breaks it is refused and handed on to pseudo-arclength continuation, which locates what
happened (:mod:`esba.paths.continuation`).

Examples
--------
>>> import numpy as np
>>> from esba.model.scene import MAIN_JOB
>>> m = MAIN_JOB.model()
>>> p_from = m.param_vector(MAIN_JOB.parameters(0.1238739, load_factor=0.0))
>>> p_to = m.param_vector(MAIN_JOB.parameters(0.1238739))
>>> r = run_natural(m, np.full(3, np.pi / 6), p_from, p_to - p_from, 1.0)
>>> r.accepted(), [round(float(np.degrees(t)), 2) for t in r.theta]
(True, [-3.29, 7.17, 21.44])
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from esba.infra.errors import InputError
from esba.model import structured
from esba.model.generated import Model, domain_lower_bound
from esba.model.stability import CRITICAL_TOL
from esba.model.structured import matvec_sx, pivots_sx, solve_sx
from esba.solvers.native import HOT_RUNS, Kernel, packed

__all__ = [
    "Acceptance",
    "ACCEPTANCE",
    "CONTRACTION",
    "JUMP",
    "TINY",
    "NaturalRun",
    "run_natural",
    "natural_function",
    "natural_kernel",
    "natural_expression",
    "newton_parts",
    "parts_function",
    "correction_function",
    "newton_correction",
    "correction_kernel",
    "SOLVE_COMPILE_MAX_N",
    "state_kernel",
    "state",
    "bordered_function",
    "bordered_layout",
    "critical_function",
    "BORDERED_ITERATIONS",
    "STEPS",
    "NEWTON",
    "FINAL",
]

#: Steps, Newton corrections per step and at the end of the natural ramp of a solve.
STEPS, NEWTON, FINAL = 4, 3, 2
#: Largest accepted ratio of a step's second Newton correction to its first.
CONTRACTION = 0.25
#: Corrections smaller than this (rad) are round-off: their ratio says nothing.
TINY = 1e-10
#: Largest accepted ratio of the distance a step's corrector moved the state to the distance its
#: predictor moved it: a corrector that must go farther than the predictor went has left the branch
#: the predictor followed (stepped over a fold onto another stable branch, with every pivot positive
#: and its Newton iteration contracting).
JUMP = 1.0
#: The kernels of a solve and of the search for equilibria are compiled up to this n: gcc's time
#: grows with the generated Hessian (seconds at n = 10, a minute at n = 32), a solve's share in
#: these kernels falls (at n = 16 a solve takes 1.6 ms).
SOLVE_COMPILE_MAX_N = 16
#: Newton iterations of one call of the bordered corrector (a corrector that needs more calls again).
BORDERED_ITERATIONS = 4


# ---------------------------------------------------------------------------------------------
# the one acceptance rule


@dataclass(frozen=True)
class Acceptance:
    """The rule by which a natural ramp (or a batch element, or a design's load ramp) is accepted.

    Parameters
    ----------
    tol : float
        Largest max |dU/dtheta_i| at the end, N mm/rad.
    critical_tol : float
        Every Hessian met must have its smallest LDL^T pivot above this fraction of the largest.
    contraction : float
        Largest ratio of a step's second Newton correction to its first.
    jump : float
        Largest ratio of the distance a step's corrector moved the state to the distance its
        predictor moved it (:data:`JUMP`).

    Examples
    --------
    >>> a = Acceptance()
    >>> a.why_not(1e-12, 0.3, 0.01), a.why_not(1e-12, -0.1, 0.01).split(" (")[0]
    ('', 'met a Hessian that is not positive definite')
    >>> a.accepted_arrays(np.array([1e-12, 1e-3]), np.array([0.3, 0.3]), np.array([0.0, 0.0])).tolist()
    [True, False]
    """

    tol: float = 1e-9
    critical_tol: float = CRITICAL_TOL
    contraction: float = CONTRACTION
    jump: float = JUMP

    def __post_init__(self) -> None:
        for name in ("tol", "critical_tol", "contraction", "jump"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise InputError(f"{name}={v!r}: expected a finite number > 0")

    def accepted_arrays(self, gradient_norm, min_pivot, contraction, jump=0.0, finite=True) -> np.ndarray:
        """The verdict for arrays of ramps (elementwise): True where every part of the rule holds."""
        with np.errstate(invalid="ignore"):
            return (
                np.asarray(finite, dtype=bool)
                & np.isfinite(gradient_norm)
                & (np.asarray(gradient_norm) <= self.tol)
                & (np.asarray(min_pivot) > self.critical_tol)
                & (np.asarray(contraction) <= self.contraction)
                & (np.asarray(jump) <= self.jump)
            )

    def why_not(self, gradient_norm: float, min_pivot: float, contraction: float, finite: bool = True, jump: float = 0.0) -> str:
        """Why one ramp is not accepted (empty when it is)."""
        if not finite or not math.isfinite(gradient_norm):
            return "left the model's domain (non-finite values)"
        if not min_pivot > self.critical_tol:
            return f"met a Hessian that is not positive definite (relative pivot {min_pivot:.3g}): a fold or branch point"
        if not contraction <= self.contraction:
            return f"a step's Newton iteration contracted by only {contraction:.3g} (> {self.contraction:g}): it may have left its branch"
        if not jump <= self.jump:
            return f"a step's corrector moved the state {jump:.3g} times as far as its predictor (> {self.jump:g}): it left the predicted branch"
        if gradient_norm > self.tol:
            return f"ended with max |dU/dtheta| = {gradient_norm:.3g} N mm/rad > {self.tol:g}"
        return ""

    def contracts(self, first: float, second: float, floor: float = TINY) -> bool:
        """A Newton iteration whose second correction (or residual) is at most ``contraction`` of its
        first, or whose first is already below ``floor`` (round-off: the ratio says nothing)."""
        return not (first > floor and second > self.contraction * first)


#: The default rule.
ACCEPTANCE = Acceptance()


# ---------------------------------------------------------------------------------------------
# one Newton step's worth of work


def parts_function(gradient: ca.Function, hessian: ca.Function, name: str = "esba_newton_parts") -> ca.Function:
    """(theta, p, dp) -> g, the Newton step H^-1 g, H^-1 dg/dlambda (dp the parameter direction), the
    smallest LDL^T pivot relative to the largest, every pivot and dg/dlambda, in one Function, for any
    ``gradient(theta, p)`` and ``hessian(theta, p)`` of a chain model (solves in O(n))."""
    n = gradient.size1_in(0)
    npar = gradient.size1_in(1)
    th = ca.SX.sym("theta", n)
    p = ca.SX.sym("p", npar)
    dp = ca.SX.sym("dp", npar)
    g = gradient(th, p)
    h = hessian(th, p)
    piv = pivots_sx(h)
    rel = ca.mmin(piv) / (ca.mmax(ca.fabs(piv)) + 1e-300)
    hs = ca.SX.sym("hs", n, n)
    bs = ca.SX.sym("b", n)
    solve = ca.Function("esba_structured_solve", [hs, bs], [solve_sx(hs, bs)], {"cse": True})
    gl = ca.jtimes(g, p, dp)
    return ca.Function(
        name,
        [th, p, dp],
        [g, solve(h, g), solve(h, gl), rel, piv, gl],
        ["theta", "p", "dp"],
        ["g", "newton", "dtheta", "min_pivot", "pivots", "g_lambda"],
        {"cse": True},
    )


def newton_parts(model: Model) -> ca.Function:
    """:func:`parts_function` of a generated model, its parameters as one vector in the model's order."""

    def build() -> ca.Function:
        n, npar = model.n, len(model.parameters)
        th = ca.SX.sym("theta", n)
        p = ca.SX.sym("p", npar)
        args = ca.vertsplit(p) if npar else []
        gradient = ca.Function("g", [th, p], [model["gradient"](th, *args)])
        hessian = ca.Function("h", [th, p], [model["hessian"](th, *args)])
        return parts_function(gradient, hessian)

    return model.derived("newton_parts", build, builder_files=(__file__, structured.__file__))


def correction_function(gradient: ca.Function, hessian: ca.Function, name: str = "esba_newton_correction") -> ca.Function:
    """(theta, p) -> g, the Newton step H^-1 g and the smallest relative pivot: a corrector's step,
    without the parameter derivative (half the work of :func:`parts_function`)."""
    n = gradient.size1_in(0)
    npar = gradient.size1_in(1)
    th = ca.SX.sym("theta", n)
    p = ca.SX.sym("p", npar)
    g = gradient(th, p)
    h = hessian(th, p)
    piv = pivots_sx(h)
    rel = ca.mmin(piv) / (ca.mmax(ca.fabs(piv)) + 1e-300)
    return ca.Function(name, [th, p], [g, solve_sx(h, g), rel], ["theta", "p"], ["g", "newton", "min_pivot"], {"cse": True})


def newton_correction(model: Model) -> ca.Function:
    """:func:`correction_function` of a generated model (its parameters as one vector)."""

    def build() -> ca.Function:
        n, npar = model.n, len(model.parameters)
        th = ca.SX.sym("theta", n)
        p = ca.SX.sym("p", npar)
        args = ca.vertsplit(p) if npar else []
        gradient = ca.Function("g", [th, p], [model["gradient"](th, *args)])
        hessian = ca.Function("h", [th, p], [model["hessian"](th, *args)])
        return correction_function(gradient, hessian)

    return model.derived("newton_correction", build, builder_files=(__file__, structured.__file__))


def correction_kernel(model: Model) -> Kernel:
    """:func:`newton_correction` packed, (theta, p) -> [g, H^-1 g, smallest relative pivot], compiled
    to C when it pays (:class:`esba.solvers.native.Kernel`): one Newton step in about a microsecond
    at small n, where a call through CasADi costs tens. The kernels of a solve are compiled up to
    :data:`SOLVE_COMPILE_MAX_N` segments, once a process has run them
    :data:`esba.solvers.native.HOT_RUNS` times (then loaded from the cache, or compiled)."""
    return model.derived("correction_kernel", lambda: Kernel(packed(newton_correction(model)), _mode(model), model.n, HOT_RUNS), persist=False)


def _mode(model: Model) -> str:
    """How the kernels of a solve run: compiled when they pay (``auto``) up to :data:`SOLVE_COMPILE_MAX_N` segments."""
    return "auto" if model.n <= SOLVE_COMPILE_MAX_N else "never"


def state_kernel(model: Model) -> Kernel:
    """:meth:`esba.model.generated.Model.state_function` packed, compiled to C when it pays (up to
    :data:`NATURAL_COMPILE_MAX_N` segments: its outputs are n x n)."""

    def build() -> Kernel:
        return Kernel(packed(model.state_function()), _mode(model), model.n, HOT_RUNS)

    return model.derived("state_kernel", build, persist=False)


def state(model: Model, theta: np.ndarray, pv: np.ndarray) -> dict:
    """:meth:`esba.model.generated.Model.state` through :func:`state_kernel` (the same numbers to round-off)."""
    n, k = model.n, len(model.terms)
    out = state_kernel(model)(np.concatenate([np.asarray(theta, dtype=float).ravel(), np.asarray(pv, dtype=float).ravel()]))
    a = 1 + k + n
    return model.state_dict(out[0], out[1 : 1 + k], out[1 + k : a], out[a : a + n * n].reshape(n, n, order="F"), out[a + n * n : a + n * n + 3], out[a + n * n + 3 :].reshape(2, n + 1, order="F"))


# ---------------------------------------------------------------------------------------------
# natural-parameter continuation


def natural_expression(parts: ca.Function, theta0, p0, dp, lam1, steps: int = STEPS, newton: int = NEWTON, final: int = FINAL, correction: ca.Function | None = None):
    """The natural ramp of lambda from 0 to ``lam1`` as CasADi expressions of its (MX) inputs:
    (theta, g, min_pivot, contraction, states, jump) at the end, ``states`` the n x steps matrix of
    the state reached at each step and ``jump`` the largest ratio, over the steps, of the distance
    the corrector moved the state to the distance the predictor moved it (see :class:`Acceptance`).

    ``parts`` (:func:`parts_function`) gives each step's predictor; ``correction``
    (:func:`correction_function`, default ``parts``) each Newton correction."""

    def correct(theta, p):
        if correction is None:
            g, step, _, piv, _, _ = parts(theta, p, dp)
        else:
            g, step, piv = correction(theta, p)
        return g, step, piv

    theta = theta0
    low = ca.MX(1.0)
    worst = ca.MX(0.0)
    jump = ca.MX(0.0)
    states = []
    for k in range(1, steps + 1):
        lam_prev, lam = lam1 * (k - 1) / steps, lam1 * k / steps
        _, _, dtheta, piv, _, _ = parts(theta, p0 + lam_prev * dp, dp)
        low = ca.fmin(low, piv)
        start = theta
        predicted = theta - (lam - lam_prev) * dtheta  # tangent predictor: H dtheta/dlambda = -dg/dlambda
        theta = predicted
        first = None
        for j in range(newton):
            _, step, piv = correct(theta, p0 + lam * dp)
            low = ca.fmin(low, piv)
            size = ca.mmax(ca.fabs(step))
            if j == 0:
                first = size
            elif j == 1:
                worst = ca.fmax(worst, ca.if_else(first > TINY, size / (first + 1e-300), 0.0))
            theta = theta - step
        moved = ca.mmax(ca.fabs(theta - predicted))
        along = ca.mmax(ca.fabs(predicted - start))
        jump = ca.fmax(jump, ca.if_else(moved > TINY, moved / (along + 1e-300), 0.0))
        states.append(theta)
    for _ in range(final):
        _, step, piv = correct(theta, p0 + lam1 * dp)
        low = ca.fmin(low, piv)
        theta = theta - step
    g, _, piv = correct(theta, p0 + lam1 * dp)
    return theta, g, ca.fmin(low, piv), worst, ca.horzcat(*states), jump


def natural_function(model: Model, steps: int = STEPS, newton: int = NEWTON, final: int = FINAL) -> ca.Function:
    """(theta0, p0, dp, lam1) -> theta, g, min_pivot, contraction, states: a natural ramp as one Function."""

    def build() -> ca.Function:
        n, npar = model.n, len(model.parameters)
        theta0 = ca.MX.sym("theta0", n)
        p0 = ca.MX.sym("p0", npar)
        dp = ca.MX.sym("dp", npar)
        lam1 = ca.MX.sym("lam1")
        outs = natural_expression(newton_parts(model), theta0, p0, dp, lam1, steps, newton, final, newton_correction(model))
        return ca.Function(
            "esba_natural", [theta0, p0, dp, lam1], list(outs), ["theta0", "p0", "dp", "lam1"], ["theta", "g", "min_pivot", "contraction", "states", "jump"]
        )

    return model.derived("natural", build, settings=(steps, newton, final), persist=False)


@dataclass(frozen=True, eq=False)
class NaturalRun:
    """What a natural ramp returned (its end and the state at each step), and the verdict on it."""

    theta: np.ndarray
    gradient_norm: float
    min_pivot: float
    contraction: float
    states: np.ndarray  # (steps, n)
    jump: float = 0.0

    def accepted(self, tol: float = 1e-9, critical_tol: float = CRITICAL_TOL) -> bool:
        """The one rule (:class:`Acceptance`): finite, stationary, positive definite all the way, contracting."""
        return not self.why_not(tol, critical_tol)

    def why_not(self, tol: float = 1e-9, critical_tol: float = CRITICAL_TOL) -> str:
        """Why :meth:`accepted` is False (empty when it is True)."""
        finite = bool(np.all(np.isfinite(self.theta)))
        return Acceptance(tol, critical_tol).why_not(self.gradient_norm, self.min_pivot, self.contraction, finite, self.jump)


def run_natural(model: Model, theta0: np.ndarray, p0: np.ndarray, dp: np.ndarray, lam1: float, steps: int = STEPS, newton: int = NEWTON, final: int = FINAL) -> NaturalRun:
    """Ramp lambda from 0 to ``lam1`` from the equilibrium ``theta0`` at lambda = 0 (see the module)."""
    kernel = natural_kernel(model, steps, newton, final)
    n = model.n
    z = np.concatenate([np.asarray(theta0, dtype=float).ravel(), np.asarray(p0, dtype=float).ravel(), np.asarray(dp, dtype=float).ravel(), [float(lam1)]])
    with np.errstate(invalid="ignore"):
        out = kernel(z)
    theta, g = out[:n], out[n : 2 * n]
    low, worst = out[2 * n], out[2 * n + 1]
    states = out[2 * n + 2 : 2 * n + 2 + n * steps].reshape(steps, n)  # column-major n x steps: a row per step
    jump = out[2 * n + 2 + n * steps]
    gnorm = float(np.max(np.abs(g)))
    if not gnorm < math.inf:
        gnorm = math.inf
    return NaturalRun(theta, gnorm, float(low), float(worst), states, float(jump))




def natural_kernel(model: Model, steps: int = STEPS, newton: int = NEWTON, final: int = FINAL) -> Kernel:
    """:func:`natural_function` packed (input [theta0, p0, dp, lam1], output [theta, g, min_pivot,
    contraction, states (n x steps, column-major), jump]), compiled to C when it pays (see
    :func:`correction_kernel`): a solve's load ramp in one C call."""

    def build() -> Kernel:
        return Kernel(packed(natural_function(model, steps, newton, final)), _mode(model), model.n, HOT_RUNS)

    return model.derived("natural_kernel", build, settings=(steps, newton, final), persist=False)


# ---------------------------------------------------------------------------------------------
# Newton on the bordered system (the corrector of pseudo-arclength continuation)


def _domain_margin(model: Model, theta, p):
    """min over the segments of theta_i - (Eq. 10's lowest angle), and of the geometry's own margins
    (L, r1, r2, r1 - r2 - d, r1 + d > 0): positive exactly where the model is defined."""
    names = model.parameters
    L, r1, r2, d = (p[names.index(k)] for k in ("L", "r1", "r2", "d"))
    lb = domain_lower_bound(model.n, L, r1, r2, d, maximum=ca.fmax)
    return ca.fmin(ca.mmin(theta - lb), ca.fmin(ca.fmin(L, r1), ca.fmin(r2, ca.fmin(r1 - r2 - d, d + r1))))


def bordered_function(model: Model, iterations: int = BORDERED_ITERATIONS) -> ca.Function:
    """``iterations`` Newton steps on g(theta, lambda) = 0, c . x = c0 (x = (theta, lambda)), one
    Function with one packed input and one packed output (a :class:`esba.solvers.native.Kernel`).

    Input ``z`` = [x0 (n + 1), c (n + 1), c0, critical_tol, p0, dp] (p = p0 + lambda dp). Each step
    solves [[H, g_lambda], [c]] dx = -[g, c . x - c0] by block elimination: y = H^-1 g and
    z = H^-1 g_lambda by the structured sweep, d lambda = (c_theta . y - r_c) / (c_lambda - c_theta . z),
    d theta = -y - z d lambda. Output (see :func:`bordered_layout`): ``x`` after the last step;
    ``res`` (iterations + 1): max |g| at each iterate, the last at ``x``; ``rc``: |c . x - c0| at
    each; ``steps``: max |dx| of each step; ``margin``: the domain margin at each iterate (> 0 inside
    the model's domain); at ``x``: the Morse index (pivots below -critical_tol times the largest),
    the smallest pivot and the smallest in magnitude, each relative to the largest magnitude, the
    largest magnitude, and
    ``u`` = (-H^-1 g_lambda, 1), the unnormalised tangent of the branch there.

    Near a fold H is nearly singular and the elimination loses digits (y and z grow like 1/pivot);
    the caller sees it in the residuals and falls back to a dense solve of the bordered system.
    """

    def build() -> ca.Function:
        n, npar = model.n, len(model.parameters)
        parts = newton_parts(model)
        zin = ca.MX.sym("z", 2 * (n + 1) + 2 + 2 * npar)
        x0, c, c0, crit = zin[: n + 1], zin[n + 1 : 2 * n + 2], zin[2 * n + 2], zin[2 * n + 3]
        p0, dp = zin[2 * n + 4 : 2 * n + 4 + npar], zin[2 * n + 4 + npar :]
        margin_fn = _margin_function(model)
        x = x0
        res, rcs, sizes, margins = [], [], [], []
        ct, cl = c[:n], c[n]
        for _ in range(iterations):
            theta, lam = x[:n], x[n]
            p = p0 + lam * dp
            g, y, z, _, _, _ = parts(theta, p, dp)
            r_c = ca.dot(c, x) - c0
            res.append(ca.mmax(ca.fabs(g)))
            rcs.append(ca.fabs(r_c))
            margins.append(margin_fn(theta, p))
            dlam = (ca.dot(ct, y) - r_c) / (cl - ca.dot(ct, z))
            dx = ca.vertcat(-y - z * dlam, dlam)
            sizes.append(ca.mmax(ca.fabs(dx)))
            x = x + dx
        theta, lam = x[:n], x[n]
        p = p0 + lam * dp
        g, _, z, _, piv, _ = parts(theta, p, dp)
        res.append(ca.mmax(ca.fabs(g)))
        rcs.append(ca.fabs(ca.dot(c, x) - c0))
        margins.append(margin_fn(theta, p))
        scale = ca.mmax(ca.fabs(piv)) + 1e-300
        morse = ca.sum1(piv < -crit * scale)
        out = ca.vertcat(x, *res, *rcs, *sizes, *margins, morse, ca.mmin(piv) / scale, ca.mmin(ca.fabs(piv)) / scale, scale, -z, 1.0)
        return ca.Function("esba_bordered", [zin], [out], ["z"], ["out"])

    return model.derived("bordered", build, settings=(iterations,), persist=False)


def bordered_layout(n: int, iterations: int) -> dict[str, slice]:
    """Where each output of :func:`bordered_function` lies in its packed vector."""
    k = iterations
    sizes = [("x", n + 1), ("res", k + 1), ("rc", k + 1), ("steps", k), ("margin", k + 1), ("morse", 1), ("min_pivot", 1), ("small_pivot", 1), ("pivot_scale", 1), ("u", n + 1)]
    out, at = {}, 0
    for name, size in sizes:
        out[name] = slice(at, at + size)
        at += size
    return out


def critical_function(model: Model, iterations: int = 10) -> ca.Function:
    """The eigenpair of H nearest zero and its rate of change along a direction, in O(n), one packed Function.

    Input ``z`` = [theta (n), lambda, v0 (n), t (n + 1), p0, dp]; ``iterations`` steps of inverse
    iteration v <- H^-1 v / |H^-1 v| from ``v0`` (the structured solve), then mu = v . H v (the
    structured product) and d mu / ds along t = (t_theta, t_lambda) at fixed v (for an eigenvector,
    the eigenvalue's derivative). Output [v (n), mu, d mu / ds]. Inverse iteration converges to the
    eigenvalue of smallest magnitude: the one that crosses zero at a fold or branch point.
    """

    def build() -> ca.Function:
        n, npar = model.n, len(model.parameters)
        th = ca.SX.sym("theta", n)
        lam = ca.SX.sym("lam")
        v0 = ca.SX.sym("v0", n)
        t = ca.SX.sym("t", n + 1)
        p0 = ca.SX.sym("p0", npar)
        dp = ca.SX.sym("dp", npar)
        p = p0 + lam * dp
        h = model["hessian"](th, *ca.vertsplit(p))
        hs = ca.SX.sym("hs", n, n)
        bs = ca.SX.sym("b", n)
        solve = ca.Function("esba_structured_solve", [hs, bs], [solve_sx(hs, bs)], {"cse": True})
        v = v0 / ca.norm_2(v0)
        for _ in range(iterations):
            w = solve(h, v)
            v = w / ca.norm_2(w)
        vf = ca.SX.sym("vf", n)
        mu_of = ca.dot(vf, matvec_sx(h, vf))
        mu = ca.substitute(mu_of, vf, v)
        slope = ca.substitute(ca.jtimes(mu_of, ca.vertcat(th, lam), t), vf, v)
        z = ca.vertcat(th, lam, v0, t, p0, dp)
        return ca.Function("esba_critical", [z], [ca.vertcat(v, mu, slope)], ["z"], ["out"], {"cse": True})

    return model.derived("critical", build, settings=(iterations,), builder_files=(__file__, structured.__file__))


def _margin_function(model: Model) -> ca.Function:
    """(theta, p) -> the domain margin of :func:`_domain_margin`, as an SX Function."""

    def build() -> ca.Function:
        th = ca.SX.sym("theta", model.n)
        p = ca.SX.sym("p", len(model.parameters))
        return ca.Function("esba_domain_margin", [th, p], [_domain_margin(model, th, p)], {"cse": True})

    return model.derived("domain_margin", build, persist=False)

"""The fast path of a quasi-static ramp: one CasADi Function, accepted only on one stable branch.

A ramp of lambda from 0 to lambda1 (p = p0 + lambda dp: the pressure of an unloaded actuator, or the
load factor of its payloads and weight) in ``steps`` equal steps: at each, a tangent predictor
theta + dlambda dtheta/dlambda with dtheta/dlambda = -H^-1 dg/dlambda, then ``newton`` Newton
corrections, every linear solve in O(n) from the Hessian's structure (:mod:`esba.model.structured`);
``final`` more corrections at lambda1. The whole ramp is one CasADi Function (the generated
gradient, the Hessian's generators and dg/dlambda are SX Functions it calls), so a ramp costs one
call from Python.

It is a path trace with a natural parameter, and it is accepted (:meth:`RampRun.accepted`) only
when it demonstrably followed one stable branch: every Hessian met (at the start of each step and
at every Newton iterate) positive definite, its smallest LDL^T pivot above ``critical_tol`` times
the largest (no fold or branch point was crossed: there an eigenvalue would vanish), every step's
Newton iteration contracting (the second correction at most a quarter of the first, Deuflhard's
test that the predictor was inside the corrector's region of convergence, so it could not have
slid to another branch), and the end stationary. Anything else is left to the adaptive
pseudo-arclength trace of :mod:`esba.paths.continuation` and :mod:`esba.paths.loading`, which locates what happened.

Examples
--------
>>> import numpy as np
>>> from esba.model.scene import MAIN_JOB
>>> m = MAIN_JOB.model()
>>> p_from = m.param_vector(MAIN_JOB.parameters(0.1238739, load_factor=0.0))
>>> p_to = m.param_vector(MAIN_JOB.parameters(0.1238739))
>>> r = run_ramp(m, np.full(3, np.pi / 6), p_from, p_to - p_from, 1.0)
>>> r.accepted(), [round(float(np.degrees(t)), 2) for t in r.theta]
(True, [-3.29, 7.17, 21.44])
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from esba.model import structured
from esba.model.generated import Model
from esba.model.stability import CRITICAL_TOL
from esba.model.structured import pivots_sx, solve_sx

__all__ = ["RampRun", "run_ramp", "ramp_function", "ramp_expression", "newton_parts", "parts_function", "STEPS", "NEWTON", "FINAL", "CONTRACTION"]

#: Steps, Newton corrections per step and at the end (the fixed shape of the graph).
STEPS, NEWTON, FINAL = 4, 3, 2
#: Largest accepted ratio of a step's second Newton correction to its first.
CONTRACTION = 0.25
#: Corrections smaller than this (rad) are round-off: their ratio says nothing.
TINY = 1e-10

_PARTS: dict[str, ca.Function] = {}
_RAMPS: dict[tuple, ca.Function] = {}


def parts_function(gradient: ca.Function, hessian: ca.Function, name: str = "esba_ramp_parts") -> ca.Function:
    """(theta, p, dp) -> g, the Newton step H^-1 g, H^-1 dg/dlambda (dp the parameter direction) and the
    smallest LDL^T pivot relative to the largest, in one Function, for any ``gradient(theta, p)`` and
    ``hessian(theta, p)`` of a chain model: the solves in O(n) from the Hessian's structure
    (:mod:`esba.model.structured`), so only row 0 and the diagonal of H are computed."""
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
    return ca.Function(
        name,
        [th, p, dp],
        [g, solve(h, g), solve(h, ca.jtimes(g, p, dp)), rel],
        ["theta", "p", "dp"],
        ["g", "newton", "dtheta", "min_pivot"],
        {"cse": True},
    )


def newton_parts(model: Model) -> ca.Function:
    """:func:`parts_function` of a generated model, its parameters as one vector in the model's order (cached)."""
    key = str(model.path)
    fun = _PARTS.get(key)
    if fun is None:

        def build() -> ca.Function:
            n, npar = model.n, len(model.parameters)
            th = ca.SX.sym("theta", n)
            p = ca.SX.sym("p", npar)
            args = ca.vertsplit(p) if npar else []
            gradient = ca.Function("g", [th, p], [model["gradient"](th, *args)])
            hessian = ca.Function("h", [th, p], [model["hessian"](th, *args)])
            return parts_function(gradient, hessian)

        fun = _PARTS[key] = model.derived("newton_parts", (__file__, structured.__file__), build)
    return fun


def ramp_expression(parts: ca.Function, theta0, p0, dp, lam1, steps: int = STEPS, newton: int = NEWTON, final: int = FINAL):
    """The ramp of lambda from 0 to ``lam1`` as CasADi expressions of its (MX) inputs:
    (theta, g, min_pivot, contraction) at the end (see the module)."""
    theta = theta0
    low = ca.MX(1.0)
    worst = ca.MX(0.0)
    for k in range(1, steps + 1):
        lam_prev, lam = lam1 * (k - 1) / steps, lam1 * k / steps
        _, _, dtheta, piv = parts(theta, p0 + lam_prev * dp, dp)
        low = ca.fmin(low, piv)
        theta = theta - (lam - lam_prev) * dtheta  # tangent predictor: H dtheta/dlambda = -dg/dlambda
        first = None
        for j in range(newton):
            _, step, _, piv = parts(theta, p0 + lam * dp, dp)
            low = ca.fmin(low, piv)
            size = ca.mmax(ca.fabs(step))
            if j == 0:
                first = size
            elif j == 1:
                worst = ca.fmax(worst, ca.if_else(first > TINY, size / (first + 1e-300), 0.0))
            theta = theta - step
    for _ in range(final):
        _, step, _, piv = parts(theta, p0 + lam1 * dp, dp)
        low = ca.fmin(low, piv)
        theta = theta - step
    g, _, _, piv = parts(theta, p0 + lam1 * dp, dp)
    return theta, g, ca.fmin(low, piv), worst


def ramp_function(model: Model, steps: int = STEPS, newton: int = NEWTON, final: int = FINAL) -> ca.Function:
    """(theta0, p0, dp, lam1) -> theta, g, min_pivot, contraction: the ramp as one Function (cached)."""
    key = (str(model.path), steps, newton, final)
    fun = _RAMPS.get(key)
    if fun is not None:
        return fun
    n, npar = model.n, len(model.parameters)
    theta0 = ca.MX.sym("theta0", n)
    p0 = ca.MX.sym("p0", npar)
    dp = ca.MX.sym("dp", npar)
    lam1 = ca.MX.sym("lam1")
    outs = ramp_expression(newton_parts(model), theta0, p0, dp, lam1, steps, newton, final)
    fun = ca.Function("esba_ramp", [theta0, p0, dp, lam1], list(outs), ["theta0", "p0", "dp", "lam1"], ["theta", "g", "min_pivot", "contraction"])
    _RAMPS[key] = fun
    return fun


@dataclass(frozen=True, eq=False)
class RampRun:
    """What the fast ramp returned, and the verdict on it."""

    theta: np.ndarray
    gradient_norm: float
    min_pivot: float
    contraction: float

    def accepted(self, tol: float = 1e-9, critical_tol: float = CRITICAL_TOL) -> bool:
        """Finite, stationary to ``tol``, positive definite all the way and contracting at every step."""
        return bool(
            np.all(np.isfinite(self.theta))
            and np.isfinite(self.gradient_norm)
            and self.gradient_norm <= tol
            and self.min_pivot > critical_tol
            and self.contraction <= CONTRACTION
        )

    def why_not(self, tol: float = 1e-9, critical_tol: float = CRITICAL_TOL) -> str:
        """Why :meth:`accepted` is False (empty when it is True)."""
        if not np.all(np.isfinite(self.theta)) or not np.isfinite(self.gradient_norm):
            return "left the model's domain"
        if self.min_pivot <= critical_tol:
            return f"met a Hessian that is not positive definite (relative pivot {self.min_pivot:.3g}): a fold or branch point"
        if self.contraction > CONTRACTION:
            return f"a Newton step contracted by only {self.contraction:.3g} (> {CONTRACTION:g})"
        if self.gradient_norm > tol:
            return f"ended with max |dU/dtheta| = {self.gradient_norm:.3g}"
        return ""


def run_ramp(model: Model, theta0: np.ndarray, p0: np.ndarray, dp: np.ndarray, lam1: float) -> RampRun:
    """Ramp lambda from 0 to ``lam1`` from the equilibrium ``theta0`` at lambda = 0 (see the module)."""
    fun = ramp_function(model)
    with np.errstate(invalid="ignore"):
        theta, g, low, worst = fun(np.asarray(theta0, dtype=float), p0, dp, float(lam1))
    theta = np.asarray(theta, dtype=float).ravel()
    g = np.asarray(g, dtype=float).ravel()
    gnorm = float(np.max(np.abs(g))) if np.all(np.isfinite(g)) else float("inf")
    return RampRun(theta, gnorm, float(low), float(worst))

"""IPOPT on the generated model: the minimiser of record for every equilibrium esba returns.

``min U(theta; p)`` over theta with the model's exact gradient and Hessian (the generated
Functions, no AD at solve time) and the model's domain as lower bounds on theta (the square root
of Eq. 10 and L + n (d + r1) theta_i > 0, see :func:`esba.model.generated.domain_lower_bound`). After IPOPT a
few Newton steps on the exact Hessian polish the stationarity to round-off.

The path engine (:mod:`esba.paths.continuation`) supplies the start; this module certifies that the point is a
minimiser, or finds the state a snap-through lands in.

Examples
--------
>>> import numpy as np
>>> from esba.model.scene import MAIN_JOB
>>> m = MAIN_JOB.model()
>>> values = MAIN_JOB.parameters(0.1238739)
>>> r = minimise(m, np.full(3, np.pi / 6), m.param_vector(values), m.lower_bounds(values))
>>> r.success, r.status
(True, 'Solve_Succeeded')
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from esba.model.generated import Model

from .newton import correction_kernel

__all__ = ["Minimum", "minimise", "ipopt_solver", "LINEAR_SOLVERS"]

#: IPOPT's linear solvers in CasADi's wheel (the HSL solvers are not bundled).
LINEAR_SOLVERS = ("mumps", "spral")

#: IPOPT's initial barrier parameter from a start that is already (nearly) an equilibrium. Its
#: default, 0.1, pushes the iterate away from the bounds by about mu / (theta - lbx) / lambda_min: near
#: a buckling load (a small lambda_min) that is enough to leave a strict minimum that is still stable.
#: With the bound multipliers started at mu / slack as well, IPOPT accepts a start that already
#: meets its tolerances after evaluating its optimality conditions there (0 iterations), and
#: converges from a perturbed one in a few.
WARM_MU_INIT = 1e-11


def ipopt_solver(model: Model, tol: float = 1e-10, max_iter: int = 200, linear_solver: str = "mumps", warm: bool = False) -> ca.Function:
    """IPOPT for min U(theta; p) with the model's exact gradient and Hessian (cached per model and settings).

    ``warm``: the start is (nearly) an equilibrium; a small initial barrier parameter keeps IPOPT
    at the minimiser next to it instead of pushing it off (see :data:`WARM_MU_INIT`).
    """
    return model.derived("ipopt", lambda: _build(model, tol, max_iter, linear_solver, warm), settings=(tol, max_iter, linear_solver, warm), persist=False)


def _build(model: Model, tol: float, max_iter: int, linear_solver: str, warm: bool) -> ca.Function:
    n, npar = model.n, len(model.parameters)
    x = ca.MX.sym("x", n)
    p = ca.MX.sym("p", npar)
    args = [x, *ca.vertsplit(p)] if npar else [x]
    f = model["energy"](*args)[0]
    grad = model["gradient"](*args)
    hess = model["hessian"](*args)
    lam_f = ca.MX.sym("lam_f")
    lam_g = ca.MX.sym("lam_g", 0)
    grad_f = ca.Function("grad_f", [x, p], [f, grad], ["x", "p"], ["f", "grad_f"])
    hess_lag = ca.Function(
        "hess_lag", [x, p, lam_f, lam_g], [ca.triu(lam_f * hess)], ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"]
    )
    opts = {
        "grad_f": grad_f,
        "hess_lag": hess_lag,
        "print_time": False,
        "calc_lam_p": False,  # no parametric sensitivities (the payload point s_k is not smooth there)
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "show_eval_warnings": False,  # a NaN at a trial point is IPOPT's to handle, not a flood on stderr
        "ipopt.tol": tol,
        "ipopt.max_iter": max_iter,
        "ipopt.linear_solver": linear_solver,
    }
    if warm:
        opts["ipopt.mu_init"] = WARM_MU_INIT
        opts["ipopt.bound_mult_init_method"] = "mu-based"
    return ca.nlpsol("esba_equilibrium", "ipopt", {"x": x, "f": f, "p": p}, opts)


@dataclass(frozen=True, eq=False)
class Minimum:
    """What IPOPT (and the polish) returned: the point, IPOPT's status, success and iterations."""

    theta: np.ndarray
    status: str
    success: bool
    iterations: int


def polish(model: Model, theta: np.ndarray, pv: np.ndarray, lbx: np.ndarray, steps: int = 4) -> np.ndarray:
    """A few Newton steps on the exact Hessian while it is positive definite, inside the domain and
    each step reduces max |dU/dtheta| (one call per step: g, the step and the smallest pivot, solved
    in O(n) from the Hessian's structure, :func:`esba.solvers.newton.correction_kernel`)."""
    kernel = correction_kernel(model)
    n = len(theta)
    z = np.concatenate([theta, np.asarray(pv, dtype=float).ravel()])
    out = kernel(z)
    for _ in range(steps):
        gnorm = float(np.max(np.abs(out[:n])))
        if not gnorm >= 1e-13 or not out[2 * n] > 0:  # stationary to round-off, not finite, or not convex here
            break
        new = theta - out[n : 2 * n]
        if np.any(new <= lbx) or not np.all(np.isfinite(new)):
            break
        z[:n] = new
        out2 = kernel(z)
        if not float(np.max(np.abs(out2[:n]))) < gnorm:
            break
        theta, out = new, out2
    return theta


def minimise(
    model: Model,
    theta0: np.ndarray,
    pv: np.ndarray,
    lbx: np.ndarray,
    *,
    tol: float = 1e-10,
    max_iter: int = 200,
    linear_solver: str = "mumps",
    polish_steps: int = 4,
    warm: bool = False,
) -> Minimum:
    """Minimise U(theta; pv) from ``theta0`` with IPOPT, theta >= ``lbx``; then polish.

    ``theta0`` is moved inside the bounds if it lies on or below them. ``warm``: ``theta0`` is
    (nearly) an equilibrium, e.g. the end of a path trace (see :func:`ipopt_solver`).
    """
    solver = ipopt_solver(model, tol, max_iter, linear_solver, warm)
    x0 = np.maximum(np.asarray(theta0, dtype=float), lbx + 1e-9 * np.maximum(1.0, np.abs(lbx)))
    sol = solver(x0=x0, p=pv, lbx=lbx)
    stats = solver.stats()
    theta = np.asarray(sol["x"], dtype=float).ravel()
    success = bool(stats.get("success", False))
    if success and polish_steps:
        theta = polish(model, theta, pv, lbx, polish_steps)
    return Minimum(theta, str(stats.get("return_status", "unknown")), success, int(stats.get("iter_count", 0)))

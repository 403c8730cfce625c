"""The design problems as one full-space NLP for IPOPT.

One NLP in CasADi's dict form ``{"x", "f", "g"}``, full space: the design (r2, d), the pressure P
of the 90 degree state, the unloaded angles theta_s (n) and the loaded angles theta_l (n) are all
variables; the equilibria are constraints

    dU/dtheta(theta_s; r2, d, P, F = 0) = 0,   dU/dtheta(theta_l; r2, d, P, F) = 0,
    sum(theta_s) = 90 deg,

with the generated gradient (:mod:`esba.model.generated`), the model's domain (Eq. 10: the square root
and its denominator) as inequality constraints on theta_l, the geometry r2 >= r2_min, d >= 0,
r1 - r2 - d >= max(t_min, 1 um) and, as options, P <= P_max and K >= K_min. CasADi
differentiates the generated gradient once more for the exact Hessian of the Lagrangian. The
objective is one of

* ``stiffness``: maximise K (the paper's problem);
* ``angle``: maximise the free bending angle at ``max_pressure`` (one more unloaded state
  theta_f at P_max among the variables), usually with K >= K_min;
* ``pressure``: minimise the pressure that bends the unloaded actuator to ``target_angle_deg``
  (a state theta_t at a pressure P_t), usually with K >= K_min.

The NLP is built with :class:`esba.solvers.eqnlp.EquilibriumNLP`, the builder the fit to measurements
(:mod:`esba.calibration.fit`) shares. The active constraints at a solution are reported with their multipliers turned into
sensitivities (:class:`ActiveConstraint`). Solving and checking is :func:`esba.design.optimise.optimise_ipopt`.
"""

from __future__ import annotations

import math
import time

import casadi as ca
import numpy as np

from esba.solvers.eqnlp import ActiveConstraint, EquilibriumNLP

from .evaluate import Evaluation, design_model
from .problem import OBJECTIVE_SCALING, START_FRACTIONS, DesignOptions, DesignProblem

__all__ = ["ActiveConstraint"]  # (from esba.solvers.eqnlp, the builder this NLP is made with)


# ---------------------------------------------------------------------------------------------
# IPOPT on the full-space NLP


class _NLP:
    """The full-space NLP of one problem: layout, bounds, the IPOPT solver (built once by :mod:`esba.solvers.eqnlp`)."""

    def __init__(self, problem: DesignProblem, options: DesignOptions):
        t0 = time.perf_counter()
        pc = design_model(problem)
        self.problem, self.options, self.pieces = problem, options, pc
        n, r1, L = pc.n, pc.r1, pc.L
        F = problem.payload_n
        pmax = problem.max_pressure
        b = EquilibriumNLP("esba_design")
        r2 = b.variable("r2", lb=options.r2_min, lower=("r2_min", f"r2 >= {options.r2_min:g} mm", "mm"))
        d = b.variable("d", lb=0.0, lower=("d_min", "d >= 0 mm", "mm"))
        P = b.variable(
            "P", lb=0.0, ub=math.inf if pmax is None else pmax,
            lower=("min_pressure", "P >= 0 MPa", "MPa"), upper=("max_pressure", f"P <= {pmax} MPa (the 90 deg state)", "MPa"),
        )
        theta_s = b.variable("theta_s", n)
        theta_l = b.variable("theta_l", n)
        if problem.objective == "angle":
            theta_f = b.variable("theta_f", n)
        if problem.objective == "pressure":
            P_t = b.variable(
                "P_t", lb=0.0, ub=math.inf if pmax is None else pmax,
                lower=("min_pressure_target", "P_t >= 0 MPa", "MPa"),
                upper=("max_pressure_target", f"P_t <= {pmax} MPa (the target state)", "MPa"),
            )
            theta_t = b.variable("theta_t", n)

        b.equilibrium(pc.grad(theta_s, r2, d, P, 0.0), "start")
        start = math.radians(problem.start_angle_deg)
        b.constraint(ca.sum1(theta_s) - start, "start_angle", f"unloaded angle = {problem.start_angle_deg:g} deg", "rad", 0.0, 0.0)
        b.equilibrium(pc.grad(theta_l, r2, d, P, F), "loaded")
        b.constraint(r1 - r2 - d, "wall", f"wall r1 - r2 - d >= {problem.wall:g} mm", "mm", problem.wall, math.inf, True)
        b.domain(theta_l, L, r1, r2, d, "loaded")
        K = pc.stiffness_expr(theta_s, theta_l)
        if problem.min_stiffness is not None and problem.objective != "stiffness":
            b.constraint(K, "min_stiffness", f"K >= {problem.min_stiffness:g} N/m", "N/m", problem.min_stiffness, math.inf, True)
        if problem.objective == "angle":
            b.equilibrium(pc.grad(theta_f, r2, d, problem.max_pressure, 0.0), "free")
            J = ca.sum1(theta_f) * 180.0 / math.pi
            cap = options.max_free_angle_deg
            b.constraint(J, "max_free_angle", f"free angle <= {cap:g} deg (the search range)", "deg", -math.inf, cap, True)
        elif problem.objective == "pressure":
            b.equilibrium(pc.grad(theta_t, r2, d, P_t, 0.0), "target")
            b.constraint(ca.sum1(theta_t) - math.radians(problem.target), "target_angle", f"unloaded angle = {problem.target:g} deg", "rad", 0.0, 0.0)
            J = P_t
        else:
            J = K
        sign, scale = OBJECTIVE_SCALING[problem.objective]
        self.sign, self.scale = sign, scale
        self.built = b.build(
            sign * J / scale,
            {
                "show_eval_warnings": False,  # IPOPT backs off from a NaN (outside Eq. 10's domain) itself
                "ipopt.tol": options.tol,
                "ipopt.max_iter": options.max_iter,
                "ipopt.linear_solver": options.linear_solver,
                # the bounds hold to 1e-10 relative at the optimum (IPOPT's default relaxes them by 1e-8)
                "ipopt.bound_relax_factor": 1e-10,
            },
        )
        self.slices, self.solver = self.built.slices, self.built.solver
        self.lbx, self.ubx, self.lbg, self.ubg = self.built.lbx, self.built.ubx, self.built.lbg, self.built.ubg
        self.build_time = time.perf_counter() - t0

    def x0(self, e: Evaluation, i: int, extra: dict) -> np.ndarray:
        z = np.zeros(self.lbx.size)
        n = self.pieces.n
        z[self.slices["r2"]] = e.r2[i]
        z[self.slices["d"]] = e.d[i]
        z[self.slices["P"]] = e.pressure[i]
        z[self.slices["theta_s"]] = math.radians(self.problem.start_angle_deg) / n
        z[self.slices["theta_l"]] = e.theta_loaded[i]
        for name, value in extra.items():
            z[self.slices[name]] = value
        return z

    def active(self, z: np.ndarray, g: np.ndarray, lam_g: np.ndarray, lam_x: np.ndarray) -> tuple[ActiveConstraint, ...]:
        """Inequalities and bounds at their bound, with multipliers and sensitivities."""
        # dJ*/d(bound) = -lambda * scale * sign
        return self.built.active(z, g, lam_g, lam_x, self.options.active_tol, -self.sign * self.scale)


def design_nlp(problem: DesignProblem, options: DesignOptions) -> tuple[_NLP, float]:
    """The NLP of ``problem`` (built once, in the model's registry) and the seconds this call spent building it."""
    key = (problem, options.tol, options.max_iter, options.linear_solver, options.r2_min, options.max_free_angle_deg)
    built = []

    def build() -> _NLP:
        built.append(True)
        return _NLP(problem, options)

    nlp = design_model(problem).model.derived("design_nlp", build, settings=key, persist=False)
    return nlp, nlp.build_time if built else 0.0


def start_designs(problem: DesignProblem, options: DesignOptions) -> tuple[np.ndarray, np.ndarray]:
    room = problem.actuator.r1 - problem.wall
    fr = np.array(START_FRACTIONS[: options.starts])
    r2 = np.maximum(fr[:, 0] * room, options.r2_min * 2)
    d = fr[:, 1] * room
    return r2, d


def extra_start(problem: DesignProblem, e: Evaluation, i: int, n: int) -> dict:
    if problem.objective == "angle":
        a = e.free_angle_deg[i]
        return {"theta_f": np.full(n, math.radians(a if np.isfinite(a) else problem.start_angle_deg) / n)}
    if problem.objective == "pressure":
        return {"P_t": e.target_pressure[i], "theta_t": np.full(n, math.radians(problem.target) / n)}
    return {}


def extra_states(problem: DesignProblem, nlp: _NLP, z: np.ndarray) -> dict:
    if problem.objective == "angle":
        return {"free": (z[nlp.slices["theta_f"]], problem.max_pressure)}
    if problem.objective == "pressure":
        return {"target": (z[nlp.slices["theta_t"]], float(z[nlp.slices["P_t"]][0]))}
    return {}



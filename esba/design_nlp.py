"""The design problems as one full-space NLP for IPOPT.

One NLP in CasADi's dict form ``{"x", "f", "g"}``, full space: the design (r2, d), the pressure P
of the 90 degree state, the unloaded angles theta_s (n) and the loaded angles theta_l (n) are all
variables; the equilibria are constraints

    dU/dtheta(theta_s; r2, d, P, F = 0) = 0,   dU/dtheta(theta_l; r2, d, P, F) = 0,
    sum(theta_s) = 90 deg,

with the generated gradient (:mod:`esba.model`), the model's domain (Eq. 10: the square root
and its denominator) as inequality constraints on theta_l, the geometry r2 >= r2_min, d >= 0,
r1 - r2 - d >= max(t_min, 1 um) and, as options, P <= P_max and K >= K_min. CasADi
differentiates the generated gradient once more for the exact Hessian of the Lagrangian. The
objective is one of

* ``stiffness``: maximise K (the paper's problem);
* ``angle``: maximise the free bending angle at ``max_pressure`` (one more unloaded state
  theta_f at P_max among the variables), usually with K >= K_min;
* ``pressure``: minimise the pressure that bends the unloaded actuator to ``target_angle_deg``
  (a state theta_t at a pressure P_t), usually with K >= K_min.

The active constraints at a solution are reported with their multipliers turned into
sensitivities (:class:`ActiveConstraint`). Solving and checking is :func:`esba.design.optimise_ipopt`.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from .design_batch import Evaluation, _pieces
from .design_problem import _OBJECTIVE_SCALING, _START_FRACTIONS, DesignOptions, DesignProblem

__all__ = ["ActiveConstraint"]


@dataclass(frozen=True)
class ActiveConstraint:
    """One constraint or bound that holds at the optimum.

    Attributes
    ----------
    name : str
        ``d_min`` (d >= 0), ``r2_min``, ``wall`` (r1 - r2 - d >= wall), ``min_stiffness``,
        ``max_pressure`` (start state), ``max_pressure_target``, ``domain_sqrt[i]``,
        ``domain_denominator[i]``.
    description : str
        The constraint in words.
    value : float
        The constrained quantity at the optimum (in ``unit``).
    bound : float
        Its bound (in ``unit``).
    unit : str
    multiplier : float or None
        IPOPT's multiplier (CasADi's sign convention: > 0 at an upper bound, < 0 at a lower one),
        for the NLP as scaled; None for PSO.
    sensitivity : float or None
        d(objective*) / d(bound), in the objective's unit per ``unit``: what moving the bound by
        one unit would change the optimum by (first order). None for PSO.
    """

    name: str
    description: str
    value: float
    bound: float
    unit: str
    multiplier: float | None
    sensitivity: float | None

    def to_dict(self) -> dict:
        """JSON-ready form."""
        return dataclasses.asdict(self)


# ---------------------------------------------------------------------------------------------
# IPOPT on the full-space NLP


@dataclass
class _Constraint:
    name: str
    description: str
    unit: str
    lb: float
    ub: float
    report: bool  # an inequality whose multiplier is worth reporting
    scale: float = 1.0  # the expression in g is (quantity) / scale


class _NLP:
    """The full-space NLP of one problem: layout, bounds, the IPOPT solver (built once)."""

    def __init__(self, problem: DesignProblem, options: DesignOptions):
        t0 = time.perf_counter()
        pc = _pieces(problem)
        self.problem, self.options, self.pieces = problem, options, pc
        n, r1, L = pc.n, pc.r1, pc.L
        F = problem.payload_n
        sizes = [("r2", 1), ("d", 1), ("P", 1), ("theta_s", n), ("theta_l", n)]
        if problem.objective == "angle":
            sizes.append(("theta_f", n))
        if problem.objective == "pressure":
            sizes += [("P_t", 1), ("theta_t", n)]
        self.slices: dict[str, slice] = {}
        k = 0
        for name, size in sizes:
            self.slices[name] = slice(k, k + size)
            k += size
        x = ca.SX.sym("x", k)
        v = {name: x[s] for name, s in self.slices.items()}
        r2, d, P = v["r2"], v["d"], v["P"]
        g, cons = [], []

        def add(expr, con: _Constraint):
            g.append(expr)
            cons.append(con)

        def equilibrium(theta, pressure, force, label):
            grad = pc.grad(theta, r2, d, pressure, force)
            for i in range(n):
                add(grad[i], _Constraint(f"equilibrium_{label}[{i}]", f"dU/dtheta_{i + 1} = 0 ({label})", "N mm/rad", 0.0, 0.0, False))

        equilibrium(v["theta_s"], P, 0.0, "start")
        start = math.radians(problem.start_angle_deg)
        add(ca.sum1(v["theta_s"]) - start, _Constraint("start_angle", f"unloaded angle = {problem.start_angle_deg:g} deg", "rad", 0.0, 0.0, False))
        equilibrium(v["theta_l"], P, F, "loaded")
        add(
            r1 - r2 - d,
            _Constraint("wall", f"wall r1 - r2 - d >= {problem.wall:g} mm", "mm", problem.wall, math.inf, True),
        )
        # Eq. (10): L r2^2 + n r1^3 theta_i >= 0 and L + n (r1 + d) theta_i > 0, as ratios (1e-6 margin)
        for i in range(n):
            th = v["theta_l"][i]
            add(1.0 + n * r1**3 * th / (L * r2**2), _Constraint(f"domain_sqrt[{i}]", f"Eq. (10) square root of segment {i + 1} (loaded) >= 0", "1", 1e-6, math.inf, True))
            add(1.0 + n * (r1 + d) * th / L, _Constraint(f"domain_denominator[{i}]", f"Eq. (10) denominator of segment {i + 1} (loaded) > 0", "1", 1e-6, math.inf, True))
        K = pc.stiffness_expr(v["theta_s"], v["theta_l"])
        if problem.min_stiffness is not None and problem.objective != "stiffness":
            add(K, _Constraint("min_stiffness", f"K >= {problem.min_stiffness:g} N/m", "N/m", problem.min_stiffness, math.inf, True))
        if problem.objective == "angle":
            equilibrium(v["theta_f"], problem.max_pressure, 0.0, "free")
            J = ca.sum1(v["theta_f"]) * 180.0 / math.pi
            cap = options.max_free_angle_deg
            add(J, _Constraint("max_free_angle", f"free angle <= {cap:g} deg (the search range)", "deg", -math.inf, cap, True))
        elif problem.objective == "pressure":
            equilibrium(v["theta_t"], v["P_t"], 0.0, "target")
            add(
                ca.sum1(v["theta_t"]) - math.radians(problem.target),
                _Constraint("target_angle", f"unloaded angle = {problem.target:g} deg", "rad", 0.0, 0.0, False),
            )
            J = v["P_t"]
        else:
            J = K
        sign, scale = _OBJECTIVE_SCALING[problem.objective]
        self.sign, self.scale = sign, scale
        self.constraints = cons
        self.lbg = np.array([c.lb for c in cons])
        self.ubg = np.array([c.ub for c in cons])
        inf = math.inf
        lbx, ubx = np.full(k, -inf), np.full(k, inf)
        lbx[self.slices["r2"]] = options.r2_min
        lbx[self.slices["d"]] = 0.0
        lbx[self.slices["P"]] = 0.0
        pmax = problem.max_pressure
        if pmax is not None:
            ubx[self.slices["P"]] = pmax
        if "P_t" in self.slices:
            lbx[self.slices["P_t"]] = 0.0
            if pmax is not None:
                ubx[self.slices["P_t"]] = pmax
        self.lbx, self.ubx = lbx, ubx
        self.bound_names = {
            ("r2", "lower"): ("r2_min", f"r2 >= {options.r2_min:g} mm", "mm"),
            ("d", "lower"): ("d_min", "d >= 0 mm", "mm"),
            ("P", "lower"): ("min_pressure", "P >= 0 MPa", "MPa"),
            ("P", "upper"): ("max_pressure", f"P <= {pmax} MPa (the 90 deg state)", "MPa"),
            ("P_t", "lower"): ("min_pressure_target", "P_t >= 0 MPa", "MPa"),
            ("P_t", "upper"): ("max_pressure_target", f"P_t <= {pmax} MPa (the target state)", "MPa"),
        }
        self.nlp = {"x": x, "f": sign * J / scale, "g": ca.vertcat(*g)}
        self.K_fun = ca.Function("K", [x], [K], ["x"], ["K"])
        self.solver = ca.nlpsol(
            "esba_design",
            "ipopt",
            self.nlp,
            {
                "print_time": False,
                "show_eval_warnings": False,  # IPOPT backs off from a NaN (outside Eq. 10's domain) itself
                "ipopt.print_level": 0,
                "ipopt.sb": "yes",
                "ipopt.tol": options.tol,
                "ipopt.max_iter": options.max_iter,
                "ipopt.linear_solver": options.linear_solver,
                # the bounds hold to 1e-10 relative at the optimum (IPOPT's default relaxes them by 1e-8)
                "ipopt.bound_relax_factor": 1e-10,
            },
        )
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
        tol = self.options.active_tol
        out = []
        factor = -self.sign * self.scale  # dJ*/d(bound) = -lambda * scale * sign

        def scaled_tol(bound):
            return tol * max(1.0, abs(bound))

        for c, value, lam in zip(self.constraints, g, lam_g):
            if not c.report:
                continue
            for kind, bound in (("lower", c.lb), ("upper", c.ub)):
                if math.isfinite(bound) and abs(value - bound) <= scaled_tol(bound):
                    out.append(ActiveConstraint(c.name, c.description, float(value), float(bound), c.unit, float(lam), float(factor * lam)))
        for var, s in self.slices.items():
            if s.stop - s.start != 1:
                continue
            value, lam = float(z[s][0]), float(lam_x[s][0])
            for kind, bound in (("lower", self.lbx[s][0]), ("upper", self.ubx[s][0])):
                if math.isfinite(bound) and abs(value - bound) <= scaled_tol(bound) and (var, kind) in self.bound_names:
                    name, desc, unit = self.bound_names[(var, kind)]
                    out.append(ActiveConstraint(name, desc, value, float(bound), unit, lam, float(factor * lam)))
        return tuple(out)


_NLPS: dict[tuple, _NLP] = {}


def _nlp(problem: DesignProblem, options: DesignOptions) -> tuple[_NLP, float]:
    key = (problem, options.tol, options.max_iter, options.linear_solver, options.r2_min, options.max_free_angle_deg)
    nlp = _NLPS.get(key)
    if nlp is not None:
        return nlp, 0.0
    nlp = _NLPS[key] = _NLP(problem, options)
    return nlp, nlp.build_time


def _start_designs(problem: DesignProblem, options: DesignOptions) -> tuple[np.ndarray, np.ndarray]:
    room = problem.actuator.r1 - problem.wall
    fr = np.array(_START_FRACTIONS[: options.starts])
    r2 = np.maximum(fr[:, 0] * room, options.r2_min * 2)
    d = fr[:, 1] * room
    return r2, d


def _extra_start(problem: DesignProblem, e: Evaluation, i: int, n: int) -> dict:
    if problem.objective == "angle":
        a = e.free_angle_deg[i]
        return {"theta_f": np.full(n, math.radians(a if np.isfinite(a) else problem.start_angle_deg) / n)}
    if problem.objective == "pressure":
        return {"P_t": e.target_pressure[i], "theta_t": np.full(n, math.radians(problem.target) / n)}
    return {}


def _extra_states(problem: DesignProblem, nlp: _NLP, z: np.ndarray) -> dict:
    if problem.objective == "angle":
        return {"free": (z[nlp.slices["theta_f"]], problem.max_pressure)}
    if problem.objective == "pressure":
        return {"target": (z[nlp.slices["theta_t"]], float(z[nlp.slices["P_t"]][0]))}
    return {}



"""Design optimisation of the chamber: IPOPT on the full-space NLP, checked against a swarm.

The paper's problem (Section 5): choose the chamber radius r2 and eccentricity d of the Table 1
actuator (r1 = 8 mm) for the largest secant stiffness K = Delta F / Delta y (Section 4.4.3):
each design is first inflated, unloaded, to 90 degrees (so the pressure depends on the design),
then a 2 N horizontal tip payload is applied with the pressure held, and K = 1000 F / delta
(N/m, delta in mm along the force). The geometry allows 0 < r2, 0 <= d, r2 + d < r1.

**IPOPT** (:func:`optimise_ipopt`): one NLP in CasADi's dict form ``{"x", "f", "g", "p"}``,
full space: the design (r2, d), the pressure P of the 90 degree state, the unloaded angles
theta_s (n) and the loaded angles theta_l (n) are all variables; the equilibria are constraints

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

IPOPT is started from a few designs spread over the triangle (each with its equilibria from the
batched evaluator below, so every start lies on the physical branch), and the best converged
result is kept. After the solve the result is checked: the Hessian of U is positive definite at
every state (stable equilibria), the loaded state is the one reached along the load path
(:func:`esba.equilibrium.solve` at the optimum's pressure, inflate first, then load), and the
active constraints are reported with their multipliers, turned into sensitivities: how much the
objective would gain per unit of each active bound (e.g. N/m per mm for d >= 0).

**PSO** (:func:`optimise_pso`): the paper's method, :func:`esba.pso.minimize` over (r2, d) with
the whole swarm evaluated in one call: a CasADi Function mapped over the swarm
(``Function.map(N, "thread", 2)``) gives each design's 90 degree pressure in closed form (U is
linear in P) and its loaded state by Newton's method (``casadi.rootfinder("newton")`` on the
generated gradient with the generated Hessian as Jacobian) along a ramp of the payload from 0,
the same load path as the physical test. Free angles at a given pressure come from a bracketed
bisection on the closed-form pressure of the uniform unloaded shape.

An infeasible request (K_min above every design's stiffness) returns ``status="infeasible"``
with the best stiffness reachable, not an exception.

Examples
--------
>>> r = optimise_ipopt(DesignProblem())
>>> r.status, round(r.r2_mm, 3), round(r.d_mm, 3), round(r.stiffness_n_per_m, 2)
('optimal', 1.53, 0.0, 45.29)
>>> [c.name for c in r.active_constraints]
['d_min']
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import casadi as ca
import numpy as np

from derive.effects import DEFAULT_VARIANT, VARIANTS, EffectSet

from . import checks
from .equilibrium import SolverOptions, solve, stability_verdict
from .model import Model, load_model
from .pso import PSOOptions, PSOResult, minimize
from .scene import Actuator, Payload, Scene, SceneError

__all__ = [
    "OBJECTIVES",
    "METHODS",
    "GEOMETRY_EPS",
    "DesignError",
    "DesignProblem",
    "DesignOptions",
    "ActiveConstraint",
    "DesignResult",
    "Comparison",
    "Evaluation",
    "evaluate",
    "free_angle",
    "optimise_ipopt",
    "optimise_pso",
    "compare",
    "design_report",
    "term_curvatures",
    "write_doc",
    "DOC_PATH",
    "DOC_COMMAND",
]

#: What a design problem may optimise.
OBJECTIVES = ("stiffness", "angle", "pressure")
#: How ``esba design`` may solve it.
METHODS = ("ipopt", "pso", "both")
#: The smallest wall r1 - r2 - d (mm) that keeps the paper's strict r2 + d < r1.
GEOMETRY_EPS = 1e-3

_OBJECTIVE_UNITS = {"stiffness": "N/m", "angle": "deg", "pressure": "MPa"}
#: Each objective as (sign, scale): IPOPT minimises sign * J / scale.
_OBJECTIVE_SCALING = {"stiffness": (-1.0, 10.0), "angle": (-1.0, 90.0), "pressure": (1.0, 0.1)}


class DesignError(ValueError):
    """A design setting that is not allowed: the message names the value and what is allowed."""


def _finite(name: str, value: Any, low: float | None = None, *, open_low: bool = False) -> float:
    value = checks.finite(name, value, DesignError)
    if low is not None and (value <= low if open_low else value < low):
        raise DesignError(f"{name}={value:g}: expected a number {'>' if open_low else '>='} {low:g}")
    return value


def _whole(name: str, value: Any, low: int, high: int | None = None, why: str = "") -> int:
    return checks.whole(name, value, low, DesignError, high, why)


# ---------------------------------------------------------------------------------------------
# the problem and the settings


@dataclass(frozen=True)
class DesignProblem:
    """What to optimise over the chamber (r2, d); everything else is fixed.

    Parameters
    ----------
    objective : str
        ``"stiffness"`` (maximise K, the paper's problem), ``"angle"`` (maximise the free bending
        angle at ``max_pressure``) or ``"pressure"`` (minimise the pressure that bends the
        unloaded actuator to ``target_angle_deg``).
    segments : int
        Segment count n (the paper: 3).
    variant : str
        Model variant, ``"paper"`` or ``"printed"``.
    actuator : Actuator
        The fixed part: L, r1, rho, E (Table 1 by default); its r2 and d are ignored.
    payload_n : float
        Tip payload of the stiffness test, N (> 0; the paper: 2 N).
    payload_angle_deg : float
        Its direction Omega from the vertical (90 = horizontal, the paper's case).
    start_angle_deg : float
        Unloaded bending angle at which the stiffness is measured, degrees (the paper: 90).
    min_stiffness : float or None
        K >= min_stiffness (N/m, > 0): the constraint of ``angle`` and ``pressure`` (required
        there); for ``stiffness`` the request is checked (infeasible when the optimum is below it).
    max_pressure : float or None
        MPa (> 0). Required by ``angle`` (the pressure of the free angle). For every objective the
        90 degree state, and for ``pressure`` the target state, must be reached with P <= max_pressure.
    target_angle_deg : float or None
        Target unloaded angle of ``pressure`` (degrees > 0; default ``start_angle_deg``).
    min_wall : float
        Thinnest wall r1 - r2 - d allowed, mm (>= 0 and < r1); below ``GEOMETRY_EPS`` the wall is
        ``GEOMETRY_EPS`` (the paper's strict r2 + d < r1).

    Examples
    --------
    >>> DesignProblem().wall
    0.001
    >>> DesignProblem(objective="angle", min_stiffness=40.0)
    Traceback (most recent call last):
    ...
    esba.design.DesignError: objective='angle' needs max_pressure (the pressure of the free bending angle, MPa)
    """

    objective: str = "stiffness"
    segments: int = 3
    variant: str = DEFAULT_VARIANT
    actuator: Actuator = field(default_factory=Actuator)
    payload_n: float = 2.0
    payload_angle_deg: float = 90.0
    start_angle_deg: float = 90.0
    min_stiffness: float | None = None
    max_pressure: float | None = None
    target_angle_deg: float | None = None
    min_wall: float = 0.0

    def __post_init__(self) -> None:
        if self.objective not in OBJECTIVES:
            raise DesignError(f"objective={self.objective!r}: allowed are {', '.join(OBJECTIVES)}")
        checks.segments(self.segments, DesignError)
        if self.variant not in VARIANTS:
            raise DesignError(f"variant={self.variant!r}: allowed are {', '.join(VARIANTS)}")
        if not isinstance(self.actuator, Actuator):
            raise DesignError(f"actuator={self.actuator!r}: expected an Actuator")
        object.__setattr__(self, "payload_n", _finite("payload_n", self.payload_n, 0.0, open_low=True))
        object.__setattr__(self, "payload_angle_deg", _finite("payload_angle_deg", self.payload_angle_deg))
        object.__setattr__(self, "start_angle_deg", _finite("start_angle_deg", self.start_angle_deg, 0.0, open_low=True))
        for name in ("min_stiffness", "max_pressure", "target_angle_deg"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, _finite(name, value, 0.0, open_low=True))
        wall = _finite("min_wall", self.min_wall, 0.0)
        if wall >= self.actuator.r1:
            raise DesignError(f"min_wall={wall:g}: expected 0 <= min_wall < r1 = {self.actuator.r1:g} mm")
        object.__setattr__(self, "min_wall", wall)
        if self.objective == "angle" and self.max_pressure is None:
            raise DesignError("objective='angle' needs max_pressure (the pressure of the free bending angle, MPa)")
        if self.objective != "stiffness" and self.min_stiffness is None:
            raise DesignError(
                f"objective={self.objective!r} needs min_stiffness (N/m): without it the optimum runs off to "
                "the thinnest wall, where the chamber fills the actuator and the stiffness is lowest"
            )
        if self.objective != "pressure" and self.target_angle_deg is not None:
            raise DesignError(f"target_angle_deg={self.target_angle_deg:g} is only used with objective='pressure'")

    @property
    def wall(self) -> float:
        """The wall bound used: max(min_wall, GEOMETRY_EPS), mm."""
        return max(self.min_wall, GEOMETRY_EPS)

    @property
    def target(self) -> float:
        """Target angle of the ``pressure`` objective, degrees."""
        return self.start_angle_deg if self.target_angle_deg is None else self.target_angle_deg

    @property
    def unit(self) -> str:
        """Unit of the objective."""
        return _OBJECTIVE_UNITS[self.objective]

    def replace(self, **changes: Any) -> DesignProblem:
        """A new validated problem with some fields changed."""
        return dataclasses.replace(self, **changes)

    def stiffest(self) -> DesignProblem:
        """The stiffness problem with the same geometry and pressure limits (no K_min)."""
        return self.replace(objective="stiffness", min_stiffness=None, target_angle_deg=None)

    def scene(self, r2: float, d: float, pressure: float | None = None, loaded: bool = True) -> Scene:
        """The scene of design (r2, d): the stiffness test's payload, the 90 degree start."""
        act = dataclasses.replace(self.actuator, r2=float(r2), d=float(d))
        payloads = (Payload(self.payload_n, self.payload_angle_deg, 1.0),) if loaded else ()
        if pressure is None:
            return Scene(act, target_angle_deg=self.start_angle_deg, payloads=payloads, segments=self.segments, variant=self.variant)
        return Scene(act, pressure=float(pressure), payloads=payloads, segments=self.segments, variant=self.variant)

    def describe(self) -> str:
        """One line: the objective and the constraints."""
        if self.objective == "stiffness":
            goal = "maximise the secant stiffness K"
        elif self.objective == "angle":
            goal = f"maximise the free bending angle at {self.max_pressure:g} MPa"
        else:
            goal = f"minimise the pressure that bends the unloaded actuator to {self.target:g} deg"
        cons = [f"0 < r2, 0 <= d, r1 - r2 - d >= {self.wall:g} mm"]
        if self.min_stiffness is not None:
            cons.append(f"K >= {self.min_stiffness:g} N/m")
        if self.max_pressure is not None:
            cons.append(f"P <= {self.max_pressure:g} MPa")
        a = self.actuator
        return (
            f"{goal} subject to {', '.join(cons)}; K = 1000 F / delta for a {self.payload_n:g} N tip payload at "
            f"{self.payload_angle_deg:g} deg from the unloaded {self.start_angle_deg:g} deg state; "
            f"L={a.L:g} r1={a.r1:g} rho={a.rho_deg:g} deg E={a.E:g} MPa; n={self.segments}, {self.variant}"
        )


@dataclass(frozen=True)
class DesignOptions:
    """Settings of the design solvers, validated on creation.

    Parameters
    ----------
    tol : float
        IPOPT's tolerance (``ipopt.tol``), 0 < tol < 1.
    max_iter : int
        IPOPT's iteration limit per start.
    linear_solver : str
        ``"mumps"`` or ``"spral"``.
    starts : int
        IPOPT starts spread over the triangle (1 to 8; the best converged result is kept).
    load_steps : int
        Steps of the payload ramp in the batched evaluator (Newton per step), >= 1.
    newton_max_iter : int
        Newton iterations per ramp step, >= 1.
    equilibrium_tol : float
        Largest |dU/dtheta| (N mm/rad) the evaluator accepts as an equilibrium.
    r2_min : float
        Lower bound of r2, mm (> 0: the paper's open bound r2 > 0).
    max_free_angle_deg : float
        Largest free bending angle searched, degrees (larger counts as failed).
    critical_tol : float
        Relative eigenvalue tolerance of the stability verdict.
    load_path_tol : float
        Largest difference (rad) between the NLP's loaded angles and the load-path solve.
    active_tol : float
        A constraint is active when within this distance of its bound (in its own units).
    threads : int
        Threads of the mapped evaluator (``Function.map(N, "thread", threads)``).

    Examples
    --------
    >>> DesignOptions().starts
    4
    >>> DesignOptions(starts=0)
    Traceback (most recent call last):
    ...
    esba.design.DesignError: starts=0: expected a whole number from 1 to 8
    """

    tol: float = 1e-10
    max_iter: int = 200
    linear_solver: str = "mumps"
    starts: int = 4
    load_steps: int = 16
    newton_max_iter: int = 30
    equilibrium_tol: float = 1e-8
    r2_min: float = 0.01
    max_free_angle_deg: float = 3600.0
    critical_tol: float = 1e-9
    load_path_tol: float = 1e-6
    active_tol: float = 1e-6
    threads: int = 2

    def __post_init__(self) -> None:
        tol = _finite("tol", self.tol, 0.0, open_low=True)
        if tol >= 1.0:
            raise DesignError(f"tol={tol:g}: expected 0 < tol < 1")
        _whole("max_iter", self.max_iter, 1, 100_000, "an optimum takes tens of iterations; IPOPT counts in a 32-bit int")
        if self.linear_solver not in ("mumps", "spral"):
            raise DesignError(f"linear_solver={self.linear_solver!r}: allowed are mumps, spral")
        if isinstance(self.starts, bool) or not isinstance(self.starts, int) or not 1 <= self.starts <= len(_START_FRACTIONS):
            raise DesignError(f"starts={self.starts!r}: expected a whole number from 1 to {len(_START_FRACTIONS)}")
        _whole("load_steps", self.load_steps, 1, 1_000, "each step is unrolled into the mapped evaluator")
        _whole("newton_max_iter", self.newton_max_iter, 1, 1_000, "each iteration is unrolled into the mapped evaluator")
        _whole("threads", self.threads, 1, 256)
        for name in ("equilibrium_tol", "r2_min", "max_free_angle_deg", "critical_tol", "load_path_tol", "active_tol"):
            _finite(name, getattr(self, name), 0.0, open_low=True)


#: Starting designs of IPOPT as fractions (r2, d) of the room r1 - wall, spread over the triangle.
_START_FRACTIONS = ((0.25, 0.05), (0.2, 0.5), (0.35, 0.6), (0.55, 0.05), (0.1, 0.8), (0.8, 0.05), (0.45, 0.3), (0.65, 0.25))

DEFAULT_DESIGN_OPTIONS = DesignOptions()


# ---------------------------------------------------------------------------------------------
# symbolic pieces shared by the evaluator and the NLP


class _Pieces:
    """The generated model with the fixed parameters bound: CasADi Functions of (theta, r2, d, P, F)."""

    def __init__(self, problem: DesignProblem):
        self.problem = problem
        self.model: Model = load_model(problem.segments, EffectSet.parse("air,axial,radial,fibres,payload"), problem.variant)
        n = self.n = problem.segments
        a = problem.actuator
        self.L, self.r1 = a.L, a.r1
        fixed = {"L": a.L, "r1": a.r1, "rho": math.radians(a.rho_deg), "E": a.E, "Omega1": math.radians(problem.payload_angle_deg), "s1": 1.0}
        th = ca.SX.sym("theta", n)
        r2, d, P, F = (ca.SX.sym(s) for s in ("r2", "d", "P", "F"))
        values = dict(fixed, r2=r2, d=d, P=P, F1=F)
        args = [values[name] for name in self.model.parameters]
        grad = self.model["gradient"](th, *args)
        hess = self.model["hessian"](th, *args)
        names = ["theta", "r2", "d", "P", "F"]
        self.grad = ca.Function("gradient_u", [th, r2, d, P, F], [grad], names, ["grad"])
        self.hess = ca.Function("hessian_u", [th, r2, d, P, F], [hess], names, ["hess"])
        tip = self.model["kinematics"](th, a.L)[0]
        self.tip = ca.Function("tip", [th], [tip[:2]], ["theta"], ["tip"])
        om = math.radians(problem.payload_angle_deg)
        self.u = np.array([math.cos(om), -math.sin(om)])  # unit vector of the payload, Eq. (14)
        # closed-form pressure of the uniform unloaded shape of total angle Theta (U linear in P)
        Theta = ca.SX.sym("Theta")
        uni = ca.repmat(Theta / n, n, 1)
        g0 = self.grad(uni, r2, d, 0.0, 0.0)
        g1 = self.grad(uni, r2, d, 1.0, 0.0) - g0
        self.pressure_closed = ca.Function(
            "pressure_closed", [Theta, r2, d], [-ca.dot(g0, g1) / ca.dot(g1, g1)], ["Theta", "r2", "d"], ["P"]
        )

    def stiffness_expr(self, theta_s, theta_l):
        """K = 1000 F / delta (N/m), delta = tip displacement along the payload (mm)."""
        delta = ca.dot(ca.DM(self.u), self.tip(theta_l) - self.tip(theta_s))
        return 1000.0 * self.problem.payload_n / delta


_PIECES: dict[tuple, _Pieces] = {}


def _pieces_key(problem: DesignProblem) -> tuple:
    a = problem.actuator
    return (problem.segments, problem.variant, a.L, a.r1, a.rho_deg, a.E, problem.payload_n, problem.payload_angle_deg)


def _pieces(problem: DesignProblem) -> _Pieces:
    key = _pieces_key(problem)
    p = _PIECES.get(key)
    if p is None:
        p = _PIECES[key] = _Pieces(problem)
    return p


# ---------------------------------------------------------------------------------------------
# the batched evaluator (PSO, IPOPT's starts, the figures)


class _Evaluator:
    """One design -> start pressure, loaded state (Newton along the payload ramp), mapped over designs."""

    def __init__(self, problem: DesignProblem, options: DesignOptions):
        pc = _pieces(problem)
        self.pieces, self.problem, self.options = pc, problem, options
        n, F = pc.n, problem.payload_n
        th = ca.SX.sym("theta", n)
        z = ca.SX.sym("z", 4)  # r2, d, P, F
        G = ca.Function("G", [th, z], [pc.grad(th, z[0], z[1], z[2], z[3])], ["theta", "z"], ["g"])
        J = ca.Function("J", [th, z], [pc.hess(th, z[0], z[1], z[2], z[3]), G(th, z)])
        rf = ca.rootfinder(
            "newton_equilibrium",
            "newton",
            G,
            {"jacobian_function": J, "error_on_fail": False, "abstol": 1e-12, "max_iter": options.newton_max_iter, "show_eval_warnings": False},
        )
        x = ca.MX.sym("x", 2)
        r2, d = x[0], x[1]
        start = math.radians(problem.start_angle_deg)
        P = pc.pressure_closed(start, r2, d)
        theta_s = ca.DM.ones(n) * (start / n)
        theta = ca.MX(theta_s)
        worst = ca.MX(0)
        for k in range(1, options.load_steps + 1):
            Fk = F * k / options.load_steps
            theta = rf(theta, ca.vertcat(r2, d, P, Fk))
            worst = ca.fmax(worst, ca.norm_inf(pc.grad(theta, r2, d, P, Fk)))
        K = pc.stiffness_expr(theta_s, theta)
        hess = pc.hess(theta, r2, d, P, F)
        self.single = ca.Function(
            "design_eval", [x], [P, theta, K, worst, ca.reshape(hess, n * n, 1)], ["x"], ["P", "theta_l", "K", "residual", "hess_l"]
        )
        self._maps: dict[int, ca.Function] = {}
        self._pmaps: dict[int, ca.Function] = {}

    def _map(self, cache: dict, fun: ca.Function, size: int) -> ca.Function:
        f = cache.get(size)
        if f is None:
            f = cache[size] = fun.map(size, "thread", self.options.threads)
        return f

    def pressure(self, Theta: np.ndarray, r2: np.ndarray, d: np.ndarray) -> np.ndarray:
        """Closed-form pressure (MPa) of the uniform unloaded shape of total angle Theta (rad), batched."""
        Theta, r2, d = np.broadcast_arrays(*(np.asarray(v, dtype=float).ravel() for v in (Theta, r2, d)))
        f = self._map(self._pmaps, self.pieces.pressure_closed, Theta.size)
        return np.asarray(f(Theta.reshape(1, -1), r2.reshape(1, -1), d.reshape(1, -1)), dtype=float).ravel()

    def __call__(self, r2: np.ndarray, d: np.ndarray) -> dict[str, np.ndarray]:
        r2 = np.asarray(r2, dtype=float).ravel()
        d = np.asarray(d, dtype=float).ravel()
        N, n = r2.size, self.pieces.n
        f = self._map(self._maps, self.single, N)
        P, theta, K, res, hess = (np.asarray(v, dtype=float) for v in f(np.vstack([r2, d])))
        H = hess.T.reshape(N, n, n)
        ok = np.isfinite(res.ravel()) & (res.ravel() <= self.options.equilibrium_tol) & np.all(np.isfinite(H), axis=(1, 2))
        min_eig = np.full(N, np.nan)
        if np.any(ok):
            ev = np.linalg.eigvalsh(0.5 * (H[ok] + np.transpose(H[ok], (0, 2, 1))))
            min_eig[ok] = ev[:, 0] / np.maximum(np.abs(ev[:, -1]), 1e-300)
        ok &= min_eig > self.options.critical_tol
        K = np.where(ok, K.ravel(), np.nan)
        return {"pressure": P.ravel(), "theta_l": theta.T, "stiffness": K, "ok": ok}


_EVALUATORS: dict[tuple, _Evaluator] = {}


def _evaluator(problem: DesignProblem, options: DesignOptions) -> _Evaluator:
    key = (_pieces_key(problem), problem.start_angle_deg, options.load_steps, options.newton_max_iter, options.equilibrium_tol,
           options.critical_tol, options.threads)
    e = _EVALUATORS.get(key)
    if e is None:
        e = _EVALUATORS[key] = _Evaluator(problem, options)
    return e


def free_angle(
    problem: DesignProblem, r2: Sequence[float], d: Sequence[float], pressure: float, options: DesignOptions | None = None
) -> np.ndarray:
    """Free (unloaded) bending angle, degrees, of designs (r2, d) at ``pressure`` (MPa), batched.

    Without payload the equilibrium is the uniform shape theta_i = Theta / n, whose pressure is
    a closed form P(Theta) (U is linear in P). The angle reached by raising the pressure from 0 is
    the first Theta with P(Theta) = pressure: bracketed on a grid of Theta, then bisected. Designs
    that need more than ``options.max_free_angle_deg`` give nan.

    Examples
    --------
    >>> [round(float(a), 2) for a in free_angle(DesignProblem(), [3.0], [4.0], 0.12387387453)]
    [90.0]
    """
    options = DEFAULT_DESIGN_OPTIONS if options is None else options
    ev = _evaluator(problem, options)
    r2 = np.asarray(r2, dtype=float).ravel()
    d = np.asarray(d, dtype=float).ravel()
    N = r2.size
    top = math.radians(options.max_free_angle_deg)
    grid = np.linspace(0.0, top, 65)[1:]
    P = ev.pressure(np.repeat(grid[None, :], N, axis=0), np.repeat(r2, grid.size), np.repeat(d, grid.size)).reshape(N, grid.size)
    reached = P >= pressure
    found = np.any(reached, axis=1)
    first = np.argmax(reached, axis=1)
    hi = grid[first]
    lo = np.where(first > 0, grid[np.maximum(first - 1, 0)], 0.0)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        above = ev.pressure(mid, r2, d) >= pressure
        hi = np.where(above, mid, hi)
        lo = np.where(above, lo, mid)
    return np.where(found, np.degrees(0.5 * (lo + hi)), np.nan)


@dataclass(frozen=True, eq=False)
class Evaluation:
    """Designs evaluated by the batched evaluator (arrays, one entry per design).

    Attributes
    ----------
    r2, d : ndarray
        The designs, mm.
    pressure : ndarray
        Pressure of the unloaded start state (90 degrees), MPa.
    stiffness : ndarray
        Secant stiffness, N/m (nan where the loaded solve failed or was not stable).
    theta_loaded : ndarray, shape (designs, n)
        Loaded segment angles, rad.
    free_angle_deg : ndarray or None
        Free bending angle at ``max_pressure`` (objective ``angle``), degrees.
    target_pressure : ndarray or None
        Pressure of the target angle (objective ``pressure``), MPa.
    ok : ndarray of bool
        The loaded state converged along the ramp and is stable.
    """

    r2: np.ndarray
    d: np.ndarray
    pressure: np.ndarray
    stiffness: np.ndarray
    theta_loaded: np.ndarray
    free_angle_deg: np.ndarray | None
    target_pressure: np.ndarray | None
    ok: np.ndarray


def evaluate(problem: DesignProblem, r2: Sequence[float], d: Sequence[float], options: DesignOptions | None = None) -> Evaluation:
    """Evaluate designs (r2, d) in one batched call: pressure, stiffness and the objective's state.

    Examples
    --------
    >>> e = evaluate(DesignProblem(), [3.0, 1.5], [4.0, 0.0])
    >>> [round(float(k), 2) for k in e.stiffness], [round(float(p), 5) for p in e.pressure]
    ([26.41, 45.29], [0.12387, 0.23362])
    """
    options = DEFAULT_DESIGN_OPTIONS if options is None else options
    r2 = np.asarray(r2, dtype=float).ravel()
    d = np.asarray(d, dtype=float).ravel()
    ev = _evaluator(problem, options)
    out = ev(r2, d)
    free = target = None
    if problem.objective == "angle":
        free = free_angle(problem, r2, d, problem.max_pressure, options)
    if problem.objective == "pressure":
        target = ev.pressure(math.radians(problem.target), r2, d)
    return Evaluation(
        r2=r2,
        d=d,
        pressure=out["pressure"],
        stiffness=out["stiffness"],
        theta_loaded=out["theta_l"],
        free_angle_deg=free,
        target_pressure=target,
        ok=out["ok"],
    )


def _objective_of(problem: DesignProblem, e: Evaluation) -> np.ndarray:
    """The objective J of evaluated designs, in its units (nan where undefined)."""
    if problem.objective == "stiffness":
        return e.stiffness
    if problem.objective == "angle":
        return np.where(e.ok, e.free_angle_deg, np.nan)
    return np.where(e.ok, e.target_pressure, np.nan)


def _violation_of(problem: DesignProblem, e: Evaluation) -> np.ndarray:
    """Relative violation of the nonlinear constraints (0 = feasible; inf = evaluation failed)."""
    v = np.zeros(e.r2.size)
    if problem.min_stiffness is not None and problem.objective != "stiffness":
        v += np.maximum(0.0, (problem.min_stiffness - e.stiffness) / problem.min_stiffness)
    if problem.max_pressure is not None:
        v += np.maximum(0.0, (e.pressure - problem.max_pressure) / problem.max_pressure)
        if e.target_pressure is not None:
            v += np.maximum(0.0, (e.target_pressure - problem.max_pressure) / problem.max_pressure)
    J = _objective_of(problem, e)
    return np.where(np.isfinite(J) & e.ok, v, np.inf)


# ---------------------------------------------------------------------------------------------
# results


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


@dataclass(frozen=True, eq=False)
class DesignResult:
    """An optimised design (or why there is none).

    Attributes
    ----------
    method : str
        ``"ipopt"`` or ``"pso"``.
    problem : DesignProblem
    status : str
        ``"optimal"``, ``"infeasible"`` (nothing meets the constraints; see
        ``best_reachable_stiffness``) or ``"failed"`` (the solver did not converge, or the optimum
        failed the checks).
    message : str
    r2_mm, d_mm : float
        The design (for ``infeasible``: the stiffest design).
    pressure_mpa : float
        Pressure of the unloaded start state (90 degrees).
    stiffness_n_per_m : float
        Secant stiffness K.
    objective : float
        The objective's value, in ``problem.unit``.
    free_angle_deg : float or None
        Free bending angle at ``max_pressure`` (objective ``angle``).
    target_pressure_mpa : float or None
        Pressure of the target angle (objective ``pressure``).
    theta_deg : dict
        Segment angles per state: ``start``, ``loaded`` and ``free`` or ``target``.
    eigenvalues : dict
        Hessian eigenvalues of U per state, N mm/rad^2.
    stable : bool
        Every state is a stable equilibrium (Hessian positive definite).
    on_load_path : bool
        The loaded state is the one :func:`esba.equilibrium.solve` reaches along the load path
        (inflate, then load), and the free or target state is the uniform shape reached by
        raising the pressure from 0.
    stiffness_check_n_per_m : float
        K recomputed from that load-path solve.
    active_constraints : tuple of ActiveConstraint
    best_reachable_stiffness : float or None
        For ``infeasible``: the largest K any design reaches under the other constraints.
    solve_time_s : float
        Wall time of the optimisation (evaluating IPOPT's starts and all its solves; PSO: the
        whole swarm run), without the checks.
    setup_time_s : float
        Building the solver or evaluator (0 when it was cached).
    iterations : int
        IPOPT iterations over all starts, or PSO iterations.
    evaluations : int
        PSO: designs evaluated; IPOPT: starts run.
    pso : PSOResult or None
        The swarm's run (history for Fig. 14).
    """

    method: str
    problem: DesignProblem
    status: str
    message: str
    r2_mm: float
    d_mm: float
    pressure_mpa: float
    stiffness_n_per_m: float
    objective: float
    free_angle_deg: float | None
    target_pressure_mpa: float | None
    theta_deg: dict
    eigenvalues: dict
    stable: bool
    on_load_path: bool
    stiffness_check_n_per_m: float
    active_constraints: tuple[ActiveConstraint, ...]
    best_reachable_stiffness: float | None
    solve_time_s: float
    setup_time_s: float
    iterations: int
    evaluations: int
    pso: PSOResult | None = field(default=None, repr=False)

    @property
    def ok(self) -> bool:
        """An optimal, stable design on the load path."""
        return self.status == "optimal"

    @property
    def wall_mm(self) -> float:
        """r1 - r2 - d, mm."""
        return self.problem.actuator.r1 - self.r2_mm - self.d_mm

    def to_dict(self) -> dict:
        """JSON-ready form (the keys ``esba design --json`` prints)."""
        out = {
            "method": self.method,
            "status": self.status,
            "message": self.message,
            "objective": self.problem.objective,
            "objective_value": self.objective,
            "objective_unit": self.problem.unit,
            "r2_mm": self.r2_mm,
            "d_mm": self.d_mm,
            "wall_mm": self.wall_mm,
            "pressure_mpa": self.pressure_mpa,
            "stiffness_n_per_m": self.stiffness_n_per_m,
            "stiffness_check_n_per_m": self.stiffness_check_n_per_m,
            "free_angle_deg": self.free_angle_deg,
            "target_pressure_mpa": self.target_pressure_mpa,
            "theta_deg": {k: list(v) for k, v in self.theta_deg.items()},
            "eigenvalues": {k: list(v) for k, v in self.eigenvalues.items()},
            "stable": self.stable,
            "on_load_path": self.on_load_path,
            "active_constraints": [c.to_dict() for c in self.active_constraints],
            "best_reachable_stiffness": self.best_reachable_stiffness,
            "solve_time_s": self.solve_time_s,
            "setup_time_s": self.setup_time_s,
            "iterations": self.iterations,
            "evaluations": self.evaluations,
            "segments": self.problem.segments,
            "variant": self.problem.variant,
            "min_stiffness": self.problem.min_stiffness,
            "max_pressure": self.problem.max_pressure,
            "min_wall": self.problem.min_wall,
            "problem": self.problem.describe(),
        }
        if self.problem.objective == "pressure":
            out["target_angle_deg"] = self.problem.target
        if self.pso is not None:
            out["pso"] = {
                "particles": self.pso.options.particles,
                "iterations": self.pso.options.iterations,
                "seed": self.pso.options.seed,
                "best_value_per_iteration": [float(v) for v in self.pso.history.best_value],
            }
        return _json_ready(out)


# ---------------------------------------------------------------------------------------------
# the checks every result gets


def _json_ready(value: Any) -> Any:
    """Non-finite floats become None (JSON has no NaN), recursively."""
    if isinstance(value, dict):
        return {k: _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def _uniform_state(n: int, angle_deg: float) -> np.ndarray:
    """theta_i = Theta / n: the unloaded equilibrium of total angle Theta (rad)."""
    return np.full(n, math.radians(angle_deg) / n)


def _checked(
    method: str,
    problem: DesignProblem,
    options: DesignOptions,
    r2: float,
    d: float,
    pressure: float,
    theta_loaded: np.ndarray,
    extra: dict,
    *,
    status: str,
    message: str,
    active: tuple[ActiveConstraint, ...],
    times: tuple[float, float],
    counts: tuple[int, int],
    best_reachable: float | None = None,
    pso: PSOResult | None = None,
) -> DesignResult:
    """Stability of every state, the load path, K recomputed: the result as reported."""
    pc = _pieces(problem)
    states = {"start": _uniform_state(pc.n, problem.start_angle_deg), "loaded": np.asarray(theta_loaded, dtype=float)}
    pressures = {"start": pressure, "loaded": pressure}
    forces = {"start": 0.0, "loaded": problem.payload_n}
    for name, (theta, p) in extra.items():
        states[name], pressures[name], forces[name] = np.asarray(theta, dtype=float), p, 0.0
    eig = {}
    stable = True
    for name, theta in states.items():
        h = np.asarray(pc.hess(theta, r2, d, pressures[name], forces[name]), dtype=float)
        ev = np.sort(np.linalg.eigvalsh(0.5 * (h + h.T)))
        eig[name] = [float(v) for v in ev]
        stable &= bool(np.all(np.isfinite(ev))) and stability_verdict(ev, options.critical_tol) == "stable"
    tip0 = np.asarray(pc.tip(states["start"])).ravel()
    tip1 = np.asarray(pc.tip(states["loaded"])).ravel()
    K = 1000.0 * problem.payload_n / float(pc.u @ (tip1 - tip0))
    on_path, K_check = False, math.nan
    try:
        eq = solve(problem.scene(r2, d, pressure), SolverOptions(), pressure=pressure)
        if eq.ok:
            on_path = float(np.max(np.abs(eq.theta - states["loaded"]))) <= options.load_path_tol
            K_check = 1000.0 * problem.payload_n / float(pc.u @ (eq.tip[:2] - tip0))
    except (SceneError, ValueError, RuntimeError) as exc:  # a design outside the scene's rules
        message = (message + "; " if message else "") + f"load-path check failed: {exc}"
    # the unloaded free/target states: the uniform shape reached by raising the pressure from 0
    if "free" in states:
        reached = free_angle(problem, [r2], [d], problem.max_pressure, options)[0]
        on_path &= bool(abs(math.degrees(float(np.sum(states["free"]))) - reached) <= math.degrees(options.load_path_tol))
    for name in ("free", "target"):
        if name in states:
            on_path &= bool(np.ptp(states[name]) <= options.load_path_tol)
    if status == "optimal" and not stable:
        status = "failed"
        message = (message + "; " if message else "") + "an equilibrium of the optimum is not stable"
    if status == "optimal" and not on_path:
        status = "failed"
        message = (message + "; " if message else "") + (
            "a state is not the one reached along the load path (inflate, then load; or raise the pressure from 0)"
        )
    free = target = None
    objective = K
    if problem.objective == "angle":
        free = math.degrees(float(np.sum(states["free"])))
        objective = free
    elif problem.objective == "pressure":
        target = float(pressures["target"])
        objective = target
    return DesignResult(
        method=method,
        problem=problem,
        status=status,
        message=message,
        r2_mm=float(r2),
        d_mm=float(d),
        pressure_mpa=float(pressure),
        stiffness_n_per_m=float(K),
        objective=float(objective),
        free_angle_deg=free,
        target_pressure_mpa=target,
        theta_deg={k: [math.degrees(float(t)) for t in v] for k, v in states.items()},
        eigenvalues=eig,
        stable=stable,
        on_load_path=on_path,
        stiffness_check_n_per_m=float(K_check),
        active_constraints=active,
        best_reachable_stiffness=best_reachable,
        solve_time_s=times[0],
        setup_time_s=times[1],
        iterations=counts[0],
        evaluations=counts[1],
        pso=pso,
    )


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


def _infeasible_stiffness(method: str, problem: DesignProblem, best: DesignResult) -> DesignResult:
    """The stiffest design, reported as the answer to a request no design meets.

    The objective is nan (no design is feasible); the design fields are the stiffest design's.
    """
    msg = (
        f"K >= {problem.min_stiffness:g} N/m is above the stiffest design "
        f"(K = {best.stiffness_n_per_m:.4g} N/m at r2 = {best.r2_mm:.4f} mm, d = {best.d_mm:.4f} mm"
        + (f", with P <= {problem.max_pressure:g} MPa" if problem.max_pressure is not None else "")
        + (f", wall >= {problem.wall:g} mm" if problem.min_wall > 0 else "")
        + ")"
    )
    return dataclasses.replace(
        best, method=method, problem=problem, status="infeasible", message=msg, objective=math.nan,
        free_angle_deg=None, target_pressure_mpa=None, active_constraints=(), best_reachable_stiffness=best.stiffness_n_per_m,
    )


def optimise_ipopt(problem: DesignProblem | None = None, options: DesignOptions | None = None) -> DesignResult:
    """Solve a design problem with IPOPT on the full-space NLP, from several starts.

    Parameters
    ----------
    problem : DesignProblem, optional
        Default: the paper's problem (maximise K, n = 3, Table 1).
    options : DesignOptions, optional

    Returns
    -------
    DesignResult
        ``status`` says whether it is an optimum; an infeasible request is a result, not an error.

    Examples
    --------
    >>> r = optimise_ipopt(DesignProblem(objective="pressure", min_stiffness=1000.0))
    >>> r.status, round(r.best_reachable_stiffness, 2)
    ('infeasible', 45.29)
    """
    problem = DesignProblem() if problem is None else problem
    options = DEFAULT_DESIGN_OPTIONS if options is None else options
    if not isinstance(problem, DesignProblem) or not isinstance(options, DesignOptions):
        raise DesignError("optimise_ipopt(problem, options): expected a DesignProblem and DesignOptions")
    stiffest = None
    extra_r2, extra_d = [], []
    if problem.min_stiffness is not None and problem.objective != "stiffness":
        stiffest = optimise_ipopt(problem.stiffest(), options)
        if stiffest.status != "optimal":
            return dataclasses.replace(stiffest, problem=problem, message=f"the stiffest-design subproblem: {stiffest.status}: {stiffest.message}")
        if stiffest.stiffness_n_per_m < problem.min_stiffness:
            return _infeasible_stiffness("ipopt", problem, stiffest)
        extra_r2, extra_d = [stiffest.r2_mm], [stiffest.d_mm]
    nlp, setup = _nlp(problem, options)
    t_eval = time.perf_counter()
    _evaluator(problem, options)
    setup += time.perf_counter() - t_eval
    t0 = time.perf_counter()
    r2s, ds = _start_designs(problem, options)
    r2s, ds = np.r_[r2s, extra_r2], np.r_[ds, extra_d]
    e = evaluate(problem, r2s, ds, options)
    best, statuses, iterations, starts = None, [], 0, 0
    for i in range(r2s.size):
        if not e.ok[i]:
            continue
        z0 = nlp.x0(e, i, _extra_start(problem, e, i, nlp.pieces.n))
        sol = nlp.solver(x0=z0, lbx=nlp.lbx, ubx=nlp.ubx, lbg=nlp.lbg, ubg=nlp.ubg)
        stats = nlp.solver.stats()
        starts += 1
        iterations += int(stats.get("iter_count", 0))
        statuses.append(str(stats.get("return_status")))
        if not stats.get("success", False):
            continue
        f = float(sol["f"])
        if best is None or f < best[0] - 1e-12 * max(1.0, abs(f)):
            best = (f, sol)
    solve_time = time.perf_counter() - t0
    if stiffest is not None:
        solve_time += stiffest.solve_time_s
        setup += stiffest.setup_time_s
    if best is None:
        infeasible = any("Infeasible" in s for s in statuses)
        msg = (
            f"IPOPT found no {'feasible design' if infeasible else 'optimum'} from {starts} starts "
            f"(IPOPT: {', '.join(sorted(set(statuses))) or 'no start evaluated'})"
        )
        r2, d = math.nan, math.nan
        return DesignResult(
            method="ipopt", problem=problem, status="infeasible" if infeasible else "failed", message=msg,
            r2_mm=r2, d_mm=d, pressure_mpa=math.nan, stiffness_n_per_m=math.nan, objective=math.nan,
            free_angle_deg=None, target_pressure_mpa=None, theta_deg={}, eigenvalues={}, stable=False,
            on_load_path=False, stiffness_check_n_per_m=math.nan, active_constraints=(),
            best_reachable_stiffness=stiffest.stiffness_n_per_m if stiffest is not None else None,
            solve_time_s=solve_time, setup_time_s=setup, iterations=iterations, evaluations=starts,
        )
    sol = best[1]
    # IPOPT relaxes the bounds by 1e-10 relative (bound_relax_factor): report the design on them
    z = np.clip(np.asarray(sol["x"], dtype=float).ravel(), nlp.lbx, nlp.ubx)
    g = np.asarray(sol["g"], dtype=float).ravel()
    active = nlp.active(z, g, np.asarray(sol["lam_g"], dtype=float).ravel(), np.asarray(sol["lam_x"], dtype=float).ravel())
    result = _checked(
        "ipopt",
        problem,
        options,
        float(z[nlp.slices["r2"]][0]),
        float(z[nlp.slices["d"]][0]),
        float(z[nlp.slices["P"]][0]),
        z[nlp.slices["theta_l"]],
        _extra_states(problem, nlp, z),
        status="optimal",
        message="",
        active=active,
        times=(solve_time, setup),
        counts=(iterations, starts),
    )
    if problem.objective == "stiffness" and problem.min_stiffness is not None and result.ok and result.stiffness_n_per_m < problem.min_stiffness:
        return _infeasible_stiffness("ipopt", problem, result)
    return result


# ---------------------------------------------------------------------------------------------
# PSO


def _pso_active(problem: DesignProblem, options: DesignOptions, r2: float, d: float, e: Evaluation) -> tuple[ActiveConstraint, ...]:
    """Constraints the swarm's best sits on (within 1e-6 relative); no multipliers."""
    out = []
    tol = 1e-6
    r1 = problem.actuator.r1
    if d <= tol:
        out.append(ActiveConstraint("d_min", "d >= 0 mm", d, 0.0, "mm", None, None))
    if r2 <= options.r2_min * (1 + tol):
        out.append(ActiveConstraint("r2_min", f"r2 >= {options.r2_min:g} mm", r2, options.r2_min, "mm", None, None))
    wall = r1 - r2 - d
    if wall <= problem.wall + tol * r1:
        out.append(ActiveConstraint("wall", f"wall r1 - r2 - d >= {problem.wall:g} mm", wall, problem.wall, "mm", None, None))
    if problem.min_stiffness is not None and problem.objective != "stiffness":
        k = float(e.stiffness[0])
        if k <= problem.min_stiffness * (1 + 1e-4):
            out.append(ActiveConstraint("min_stiffness", f"K >= {problem.min_stiffness:g} N/m", k, problem.min_stiffness, "N/m", None, None))
    if problem.max_pressure is not None:
        p = float(e.pressure[0])
        if p >= problem.max_pressure * (1 - 1e-4):
            out.append(ActiveConstraint("max_pressure", f"P <= {problem.max_pressure:g} MPa (the 90 deg state)", p, problem.max_pressure, "MPa", None, None))
        if e.target_pressure is not None and float(e.target_pressure[0]) >= problem.max_pressure * (1 - 1e-4):
            out.append(ActiveConstraint("max_pressure_target", f"P_t <= {problem.max_pressure:g} MPa (the target state)", float(e.target_pressure[0]), problem.max_pressure, "MPa", None, None))
    return tuple(out)


def optimise_pso(
    problem: DesignProblem | None = None, options: DesignOptions | None = None, pso_options: PSOOptions | None = None
) -> DesignResult:
    """Solve a design problem with the paper's particle swarm (30 particles, 50 iterations by default).

    The swarm moves in the box r2 in [r2_min, r1 - wall], d in [0, r1 - wall] with
    r2 + d <= r1 - wall enforced (:func:`esba.pso.minimize`); the nonlinear constraints (K >=
    K_min, P <= P_max) are handled by Deb's feasibility rules, so when no design meets K_min the
    swarm ends at the stiffest design it found, reported as ``infeasible``.

    Examples
    --------
    >>> r = optimise_pso(DesignProblem(), pso_options=PSOOptions(seed=0, iterations=20))
    >>> r.status, round(r.stiffness_n_per_m, 1), r.pso.history.best_value.shape
    ('optimal', 45.3, (21,))
    """
    problem = DesignProblem() if problem is None else problem
    options = DEFAULT_DESIGN_OPTIONS if options is None else options
    pso_options = PSOOptions() if pso_options is None else pso_options
    t_setup = time.perf_counter()
    _evaluator(problem, options)
    setup = time.perf_counter() - t_setup
    sign = -1.0 if problem.objective in ("stiffness", "angle") else 1.0

    def swarm(X: np.ndarray):
        e = evaluate(problem, X[:, 0], X[:, 1], options)
        J = _objective_of(problem, e)
        return sign * J, _violation_of(problem, e)

    room = problem.actuator.r1 - problem.wall
    t0 = time.perf_counter()
    res = minimize(swarm, [options.r2_min, 0.0], [room, room], linear=([[1.0, 1.0]], [room]), options=pso_options)
    solve_time = time.perf_counter() - t0
    r2, d = (float(v) for v in res.x)
    e = evaluate(problem, [r2], [d], options)
    status, message, best_reachable = "optimal", "", None
    if not res.feasible:
        if problem.min_stiffness is not None and np.isfinite(e.stiffness[0]):
            status = "infeasible"
            best_reachable = float(e.stiffness[0])
            wanted = [f"K >= {problem.min_stiffness:g} N/m"] + ([f"P <= {problem.max_pressure:g} MPa"] if problem.max_pressure else [])
            message = (
                f"no design the swarm visited meets {' and '.join(wanted)}; the least violating one "
                f"(K = {best_reachable:.4g} N/m at r2 = {r2:.4f} mm, d = {d:.4f} mm) is reported"
            )
        else:
            status, message = "failed", "the swarm found no design that meets the constraints"
    elif problem.objective == "stiffness" and problem.min_stiffness is not None and e.stiffness[0] < problem.min_stiffness:
        status, best_reachable = "infeasible", float(e.stiffness[0])
        message = f"K >= {problem.min_stiffness:g} N/m is above the stiffest design found (K = {best_reachable:.4g} N/m)"
    pc = _pieces(problem)
    extra = {}
    if problem.objective == "angle" and np.isfinite(e.free_angle_deg[0]):
        extra["free"] = (np.full(pc.n, math.radians(float(e.free_angle_deg[0])) / pc.n), problem.max_pressure)
    if problem.objective == "pressure":
        extra["target"] = (np.full(pc.n, math.radians(problem.target) / pc.n), float(e.target_pressure[0]))
    if not e.ok[0]:
        return DesignResult(
            method="pso", problem=problem, status="failed", message=message or "the swarm's best design did not evaluate",
            r2_mm=r2, d_mm=d, pressure_mpa=float(e.pressure[0]), stiffness_n_per_m=math.nan, objective=math.nan,
            free_angle_deg=None, target_pressure_mpa=None, theta_deg={}, eigenvalues={}, stable=False, on_load_path=False,
            stiffness_check_n_per_m=math.nan, active_constraints=(), best_reachable_stiffness=best_reachable,
            solve_time_s=solve_time, setup_time_s=setup, iterations=pso_options.iterations, evaluations=res.evaluations, pso=res,
        )
    result = _checked(
        "pso",
        problem,
        options,
        r2,
        d,
        float(e.pressure[0]),
        e.theta_loaded[0],
        extra,
        status=status,
        message=message,
        active=_pso_active(problem, options, r2, d, e),
        times=(solve_time, setup),
        counts=(pso_options.iterations, res.evaluations),
        best_reachable=best_reachable,
        pso=res,
    )
    if status == "infeasible":
        result = dataclasses.replace(result, objective=math.nan, free_angle_deg=None, target_pressure_mpa=None)
    return result


# ---------------------------------------------------------------------------------------------
# both, side by side


@dataclass(frozen=True, eq=False)
class Comparison:
    """IPOPT and PSO on the same problem, and how far apart they are.

    Attributes
    ----------
    ipopt, pso : DesignResult
    r2_diff_mm, d_diff_mm : float
        PSO minus IPOPT.
    objective_rel_diff : float
        (PSO - IPOPT) / |IPOPT| of the objective.
    stiffness_rel_diff : float
        The same for K.
    speedup : float
        PSO time / IPOPT time.
    """

    ipopt: DesignResult
    pso: DesignResult
    r2_diff_mm: float
    d_diff_mm: float
    objective_rel_diff: float
    stiffness_rel_diff: float
    speedup: float

    @property
    def agree(self) -> bool:
        """Same status, and for optima: design within 0.01 mm, objective within 0.1 %."""
        if self.ipopt.status != self.pso.status:
            return False
        if self.ipopt.status != "optimal":
            return True
        return max(abs(self.r2_diff_mm), abs(self.d_diff_mm)) <= 0.01 and abs(self.objective_rel_diff) <= 1e-3

    def to_dict(self) -> dict:
        """JSON-ready form (``esba design --method both --json``)."""
        out = {
            "method": "both",
            "ipopt": self.ipopt.to_dict(),
            "pso": self.pso.to_dict(),
            "differences": {
                "r2_mm": self.r2_diff_mm,
                "d_mm": self.d_diff_mm,
                "objective_rel": self.objective_rel_diff,
                "stiffness_rel": self.stiffness_rel_diff,
                "time_ratio_pso_over_ipopt": self.speedup,
                "agree": self.agree,
            },
        }
        return _json_ready(out)


def compare(
    problem: DesignProblem | None = None, options: DesignOptions | None = None, pso_options: PSOOptions | None = None
) -> Comparison:
    """Run IPOPT and PSO on the same problem and compare them."""
    problem = DesignProblem() if problem is None else problem
    a = optimise_ipopt(problem, options)
    b = optimise_pso(problem, options, pso_options)

    def rel(x, y):
        return (y - x) / abs(x) if x not in (0.0,) and math.isfinite(x) and math.isfinite(y) else math.nan

    return Comparison(
        ipopt=a,
        pso=b,
        r2_diff_mm=b.r2_mm - a.r2_mm,
        d_diff_mm=b.d_mm - a.d_mm,
        objective_rel_diff=rel(a.objective, b.objective),
        stiffness_rel_diff=rel(a.stiffness_n_per_m, b.stiffness_n_per_m),
        speedup=b.solve_time_s / a.solve_time_s if a.solve_time_s > 0 else math.inf,
    )


# ---------------------------------------------------------------------------------------------
# the report (docs/design.md)


#: Where :func:`write_doc` writes by default.
DOC_PATH = Path(__file__).resolve().parent.parent / "docs" / "design.md"
#: The command that writes the page.
DOC_COMMAND = "esba design --write-doc docs/design.md"

#: The stiffness-constrained requests of the page: K_min (N/m), P_max (MPa), walls (mm).
DOC_MIN_STIFFNESS = 40.0
DOC_MAX_PRESSURE = 0.2
DOC_WALLS = (6.6, 5.8)


def _fmt_active(r: DesignResult) -> str:
    if not r.active_constraints:
        return "none"
    parts = []
    for c in r.active_constraints:
        if c.sensitivity is None:
            parts.append(f"`{c.name}`")
        else:
            parts.append(f"`{c.name}` ({c.sensitivity:+.4g} {r.problem.unit}/{c.unit})")
    return ", ".join(parts)


def _row(r: DesignResult) -> str:
    obj = f"{r.objective:.6g} {r.problem.unit}"
    work = f"{r.iterations} iterations, {r.evaluations} starts" if r.method == "ipopt" else f"{r.evaluations} designs evaluated"
    return (
        f"| {r.method} | {r.status} | {r.r2_mm:.5f} | {r.d_mm:.5f} | {r.pressure_mpa:.5f} | {r.stiffness_n_per_m:.4f} | {obj} | "
        f"{r.solve_time_s:.3f} | {work} |"
    )


_HEAD = (
    "| method | status | r2 (mm) | d (mm) | P at 90 deg (MPa) | K (N/m) | objective | time (s) | work |\n"
    "|---|---|---|---|---|---|---|---|---|"
)


def _comparison_block(title: str, c: Comparison) -> list[str]:
    lines = [f"**{title}.** {c.ipopt.problem.describe()}.", "", _HEAD, _row(c.ipopt), _row(c.pso), ""]
    if c.ipopt.ok and c.pso.ok:
        lines.append(
            f"PSO - IPOPT: r2 {c.r2_diff_mm:+.2e} mm, d {c.d_diff_mm:+.2e} mm, objective {100 * c.objective_rel_diff:+.2e} %; "
            f"{'they agree' if c.agree else '**they do not agree**'} (design within 0.01 mm, objective within 0.1 %); PSO took "
            f"{c.speedup:.0f} times as long as IPOPT."
        )
    else:
        lines.append(f"IPOPT: {c.ipopt.status} ({c.ipopt.message or 'ok'}); PSO: {c.pso.status} ({c.pso.message or 'ok'}).")
    lines.append(f"Active at the IPOPT optimum (sensitivity of the objective to each bound): {_fmt_active(c.ipopt)}.")
    lines.append(
        f"Checks: every equilibrium stable: {c.ipopt.stable} (IPOPT), {c.pso.stable} (PSO); the loaded state is the one "
        f"reached by inflating and then loading: {c.ipopt.on_load_path} / {c.pso.on_load_path}; K recomputed on that "
        f"load path {c.ipopt.stiffness_check_n_per_m:.6g} N/m."
    )
    return lines + [""]


def term_curvatures(problem: DesignProblem, r2: float, d: float) -> dict[str, float]:
    """d^2 U_term / d theta_1^2 (N mm/rad^2) of each energy term at the unloaded start state.

    At the uniform start shape (90 degrees), at the design's start pressure, with the stiffness
    test's payload applied: how much each term of Eq. (3) resists (> 0) or helps (< 0) a
    further bend of one segment. The pressure's terms are linear in theta and give 0.

    Examples
    --------
    >>> c = term_curvatures(DesignProblem(), 3.0, 4.0)
    >>> sorted(c), round(c["air"], 9)
    (['air', 'axial', 'fibres', 'payload1', 'radial'], 0.0)
    """
    pc = _pieces(problem)
    m = pc.model
    n = pc.n
    th = ca.SX.sym("theta", n)
    theta = _uniform_state(pc.n, problem.start_angle_deg)
    P = float(pc.pressure_closed(math.radians(problem.start_angle_deg), r2, d))
    a = problem.actuator
    values = {"L": a.L, "r1": a.r1, "r2": r2, "d": d, "rho": math.radians(a.rho_deg), "E": a.E, "P": P,
              "F1": problem.payload_n, "Omega1": math.radians(problem.payload_angle_deg), "s1": 1.0}
    terms = m["energy"](th, *[values[k] for k in m.parameters])[1]
    out = {}
    for k, name in enumerate(m.terms):
        h = ca.Function("term_hessian", [th], [ca.hessian(terms[k], th)[0]])
        out[name] = float(np.asarray(h(theta))[0, 0])
    return out


def design_report(
    segments: int = 3, options: DesignOptions | None = None, pso_options: PSOOptions | None = None
) -> tuple[str, dict]:
    """Run the study of ``docs/design.md`` and return (markdown, data).

    The paper's problem and the stiffness-constrained ones, each with IPOPT and PSO from one
    run (times side by side), the pressure/stiffness trade-off, and the optimum against n.
    """
    options = DEFAULT_DESIGN_OPTIONS if options is None else options
    pso_options = PSOOptions() if pso_options is None else pso_options
    base = DesignProblem(segments=segments)
    km, pm = DOC_MIN_STIFFNESS, DOC_MAX_PRESSURE
    runs = {
        "paper": compare(base, options, pso_options),
        "max_pressure": compare(base.replace(max_pressure=pm), options, pso_options),
        "angle": compare(base.replace(objective="angle", max_pressure=pm, min_stiffness=km), options, pso_options),
        "pressure": compare(base.replace(objective="pressure", min_stiffness=km), options, pso_options),
        "wall_stiffness": compare(base.replace(min_wall=DOC_WALLS[0]), options, pso_options),
        "wall_angle": compare(base.replace(objective="angle", max_pressure=pm, min_stiffness=km, min_wall=DOC_WALLS[1]), options, pso_options),
    }
    best = runs["paper"].ipopt
    k_infeasible = 5.0 * math.ceil((best.stiffness_n_per_m + 1.0) / 5.0)
    infeasible = compare(base.replace(objective="pressure", min_stiffness=k_infeasible), options, pso_options)
    # the pressure/stiffness trade-off: the lowest 90 degree pressure for each K_min
    trade = []
    for k in (20.0, 25.0, 30.0, 35.0, 40.0, 42.5, 44.0, 45.0):
        if k < best.stiffness_n_per_m:
            trade.append(optimise_ipopt(base.replace(objective="pressure", min_stiffness=k), options))
    # along d = 0 and at the Table 1 design
    r2_line = np.array([0.3, 0.5, 1.0, best.r2_mm, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0])
    line = evaluate(base, r2_line, np.zeros_like(r2_line), options)
    line_angle = free_angle(base, r2_line, np.zeros_like(r2_line), pm, options)
    line_terms = [term_curvatures(base, float(v), 0.0) for v in r2_line]
    hard = compare(base.replace(objective="pressure", min_stiffness=30.0), options, pso_options)
    t1 = evaluate(base, [base.actuator.r2], [base.actuator.d], options)
    by_n = [optimise_ipopt(DesignProblem(segments=k), options) for k in (1, 2, 3, 4, 5, 6)]

    p = runs["paper"]
    L = []
    L.append("# Design optimisation: the stiffest chamber, by IPOPT and by a particle swarm")
    L.append("")
    L.append(f"Written by `{DOC_COMMAND}` (do not edit by hand; rerun it). Figures by `esba figures --only fig13a fig13b fig14`.")
    L.append(
        f"Numbers from one run on this machine (n = {segments}, variant `{base.variant}`); times are wall-clock "
        "and vary with the machine's load, their ratio much less."
    )
    L.append("")
    L.append("## The problem")
    L.append("")
    L.append(
        "Section 5 of the paper looks for the chamber radius r2 and eccentric distance d that make the actuator of "
        "Table 1 (L = 135 mm, r1 = 8 mm, rho = 10 deg, E = 0.54 MPa) as stiff as possible. The stiffness is the "
        "secant stiffness of Section 4.4.3: the actuator is inflated, unloaded, to 90 deg; then, with the pressure "
        "held, a 2 N horizontal payload is applied at the tip and K = Delta F / Delta y = 1000 F / (y0 - y1) in N/m. "
        "Every design gets its own pressure (the one that bends it to 90 deg), so the pressure is an output of the "
        "design, not an input. The geometry allows 0 < r2, 0 <= d and r2 + d < r1 (the chamber inside the actuator)."
    )
    L.append("")
    L.append("## The NLP (full space, IPOPT with exact second derivatives)")
    L.append("")
    L.append("One NLP in CasADi's dict form `{\"x\", \"f\", \"g\"}` (`esba/design.py`):")
    L.append("")
    L.append("| | |")
    L.append("|---|---|")
    L.append("| variables | r2, d, P (the 90 deg pressure), theta_s (n unloaded angles), theta_l (n loaded angles); plus theta_f (n) for `angle`, P_t and theta_t (n) for `pressure` |")
    L.append("| equilibria | dU/dtheta(theta_s; r2, d, P, F = 0) = 0 and dU/dtheta(theta_l; r2, d, P, F = 2 N) = 0 with the generated gradient (and the same for theta_f at P_max, theta_t at P_t) |")
    L.append("| 90 deg | sum(theta_s) = pi/2 (and sum(theta_t) = target for `pressure`) |")
    L.append("| geometry | r2 >= 0.01 mm, d >= 0, r1 - r2 - d >= max(t_min, 0.001 mm) (the wall) |")
    L.append("| model domain | Eq. (10) on the loaded state: 1 + n r1^3 theta_i / (L r2^2) >= 1e-6 (the square root), 1 + n (r1 + d) theta_i / L >= 1e-6 (its denominator) |")
    L.append("| options | K >= K_min; P <= P_max (and P_t <= P_max); free angle <= 3600 deg |")
    L.append("| objective | `stiffness`: max K = 1000 F / (u . (tip(theta_l) - tip(theta_s))); `angle`: max sum(theta_f) at P_max; `pressure`: min P_t |")
    L.append("")
    L.append(
        "CasADi differentiates the generated gradient once more, so IPOPT gets the exact Hessian of the Lagrangian. "
        f"IPOPT starts from {options.starts} designs spread over the triangle, each with its equilibria from the batched "
        "evaluator (so every start is on the physical branch); the best converged result is kept. The result is then "
        "checked: the Hessian of U is positive definite at every state (stable), the loaded state is the one "
        "`esba.equilibrium.solve` reaches by inflating and then loading (the NLP alone only asks for a stationary "
        "point), and the active bounds are reported with IPOPT's multipliers turned into sensitivities: "
        "d(objective*)/d(bound), the first-order change of the optimum per unit of the bound."
    )
    L.append("")
    L.append(
        f"The swarm (`esba/pso.py`) is the paper's: {pso_options.particles} particles, {pso_options.iterations} iterations, "
        "random initial positions and velocities in the box, Clerc-Kennedy constriction coefficients (w = 0.7298, "
        "c1 = c2 = 1.49618), r2 + d <= r1 - wall enforced (a particle stops where its step crosses the boundary), "
        f"K_min and P_max by Deb's feasibility rules, seed {pso_options.seed}. Each iteration evaluates the whole swarm "
        "in one call: a CasADi Function mapped over the particles gives each design's 90 deg pressure in closed form "
        f"(U is linear in P) and its loaded state by Newton's method along a {options.load_steps}-step ramp of the payload "
        "(the generated gradient, with the generated Hessian as Jacobian)."
    )
    L.append("")
    L.append("## The optimum")
    L.append("")
    L.append(_HEAD)
    L.append(_row(p.ipopt))
    L.append(_row(p.pso))
    L.append("")
    L.append(
        f"**r2 = {best.r2_mm:.4f} mm, d = {best.d_mm:.4f} mm, K = {best.stiffness_n_per_m:.4f} N/m at P = "
        f"{best.pressure_mpa:.5f} MPa** (the Table 1 design: K = {t1.stiffness[0]:.2f} N/m at {t1.pressure[0]:.5f} MPa). "
        f"PSO - IPOPT: r2 {p.r2_diff_mm:+.1e} mm, d {p.d_diff_mm:+.1e} mm, K {100 * p.stiffness_rel_diff:+.1e} %. "
        f"IPOPT: {p.ipopt.solve_time_s * 1000:.0f} ms; PSO: {p.pso.solve_time_s:.2f} s, {p.speedup:.0f} times as long, "
        f"in the same run (IPOPT's one-off set-up, building the NLP and its derivatives: {p.ipopt.setup_time_s:.2f} s)."
    )
    L.append("")
    L.append(
        f"Active constraints: {_fmt_active(best)}. The optimum sits **on the bound d = 0**: a concentric chamber. "
        f"Its multiplier says that each mm of eccentricity would cost {abs(best.active_constraints[0].sensitivity) if best.active_constraints else float('nan'):.2f} N/m; "
        "r2 is interior (its derivative is zero there), and the wall is far from thin "
        f"({best.wall_mm:.2f} mm). Hessian eigenvalues (N mm/rad^2): unloaded "
        f"{', '.join(f'{v:.1f}' for v in best.eigenvalues['start'])}; loaded {', '.join(f'{v:.1f}' for v in best.eigenvalues['loaded'])}: "
        f"both equilibria stable. Loaded angles {', '.join(f'{v:.2f}' for v in best.theta_deg['loaded'])} deg."
    )
    L.append("")
    L.append("![stiffness over the triangle](figures/fig13b.png)")
    L.append("")
    L.append("## Why the optimum lies where it does")
    L.append("")
    L.append(
        "In this model the pressure only ever pushes with a constant moment: -P dV (Eq. 5) and the fibre term (Eq. 18) "
        "are linear in the segment angles, so the pressure adds nothing to the stiffness by itself. What resists the payload "
        "is the rubber: the axial strain energy (Eq. 8), whose bending coefficient 5 r1^4 - 4 r2^2 (r1 + d)^2 - r2^4 hardly "
        "changes while the chamber is small, and the radial strain energy of the chamber wall (Eq. 13), which depends strongly "
        "on r2 through the chamber's expansion Delta r2 of Eq. (10). For a thin chamber Delta r2 grows like the square root of "
        "the bend, so that energy is nearly linear in theta (a constant moment again) and resists little; for a wide chamber "
        "Delta r2 is proportional to theta / r2, so the energy is quadratic in theta but its coefficient falls as r2 grows. "
        "The payload's own term (Eq. 14) softens every design alike, since they all start from the same 90 deg arc. The "
        "curvature of each term at the 90 deg start (per segment, `term_curvatures`) shows it: the radial term peaks near "
        "r2 = 2 mm and the sum with it, so the stiffness peaks in between a thin and a wide chamber. The secant over the "
        "whole 2 N load peaks a little lower, at r2 = %.2f mm: it also feels the loaded states, where the first segment of "
        "a thin chamber straightens towards the edge of Eq. (10)'s domain and the radial energy stiffens there." % best.r2_mm
    )
    L.append("")
    L.append(
        "The pressure follows the stiffness: the 90 deg pressure is the elastic moment at 90 deg divided by the pressure's "
        "lever (pi r1^3 less the fibre term), so a stiffer design needs more pressure to reach the starting angle. That is the "
        "paper's observation that the stiff designs 'need more pressure to bend to 90 deg'; here it is the cost, not the cause, "
        "of the stiffness. Along d = 0:"
    )
    L.append("")
    L.append(
        f"| r2 (mm) | P at 90 deg (MPa) | K (N/m) | free angle at {pm:g} MPa (deg) | axial | radial | payload | "
        "sum (N mm/rad^2, at 90 deg) |"
    )
    L.append("|---|---|---|---|---|---|---|---|")
    for r2v, P, K, a, c in zip(r2_line, line.pressure, line.stiffness, line_angle, line_terms):
        L.append(
            f"| {r2v:.3f} | {P:.4f} | {K:.2f} | {a:.1f} | {c['axial']:.1f} | {c['radial']:.1f} | {c['payload1']:.1f} | "
            f"{sum(c.values()):.1f} |"
        )
    L.append("")
    L.append(
        "Eccentricity only softens: d enters Eq. (8) through -4 r2^2 (r1 + d)^2 (the chamber further from the inextensible "
        "layer removes more bending stiffness) and the denominator of Eq. (10) (more elongation of the chamber, less radial "
        "expansion). Both lower K, so d sits on its bound; but near the optimum the chamber is small and r2^2 (r1 + d)^2 is "
        "small against 5 r1^4, which is why the multiplier of d >= 0 is only a couple of N/m per mm. Eccentricity is what "
        "buys bending angle per MPa (Fig. 13a), and the designer's trade-off is between the two."
    )
    L.append("")
    L.append("![free bending angle at 0.2 MPa](figures/fig13a.png)")
    L.append("")
    L.append("### The pressure/stiffness trade-off")
    L.append("")
    L.append(
        "The lowest pressure that bends the unloaded actuator to 90 deg, for a stiffness of at least K_min (problem (b) "
        "with IPOPT): giving up a little stiffness saves a lot of pressure, because K is flat at its maximum while the "
        "pressure falls steadily with r2."
    )
    L.append("")
    L.append("| K_min (N/m) | P (MPa) | r2 (mm) | d (mm) | active | sensitivity dP*/dK_min (MPa per N/m) |")
    L.append("|---|---|---|---|---|---|")
    for r in trade:
        sens = next((c.sensitivity for c in r.active_constraints if c.name == "min_stiffness"), None)
        L.append(
            f"| {r.problem.min_stiffness:g} | {r.objective:.5f} | {r.r2_mm:.4f} | {r.d_mm:.4f} | "
            f"{', '.join(c.name for c in r.active_constraints) or 'none'} | {'' if sens is None else f'{sens:.3g}'} |"
        )
    L.append("")
    L.append("## Stiffness-constrained designs (IPOPT and PSO, each from one run)")
    L.append("")
    L.extend(_comparison_block("Stiffness with a pressure budget", runs["max_pressure"]))
    L.extend(_comparison_block("(a) The largest free bending angle", runs["angle"]))
    L.extend(_comparison_block("(b) The lowest pressure for 90 deg", runs["pressure"]))
    L.extend(_comparison_block("(c) A minimum wall, stiffness objective", runs["wall_stiffness"]))
    L.extend(_comparison_block("(c) A minimum wall, angle objective", runs["wall_angle"]))
    a, b = runs["angle"].ipopt, runs["pressure"].ipopt
    w = runs["wall_angle"].ipopt
    L.append(
        f"Here (K_min = {km:g} N/m) problems (a) and (b) land on the same design (r2 = {a.r2_mm:.4f} vs {b.r2_mm:.4f} mm, "
        f"d = {a.d_mm:.4f} vs {b.d_mm:.4f} mm): along the stiffness constraint both the free angle and the pressure saving grow "
        "with r2, and d lowers K faster than it helps them, so both run along d = 0 until K = K_min. With a wall of "
        f"{DOC_WALLS[1]:g} mm the chamber cannot grow that far: the active constraints there are "
        f"{', '.join(c.name for c in w.active_constraints) or 'none'}, and K = {w.stiffness_n_per_m:.2f} N/m "
        f"{'> K_min: the stiffness constraint is slack' if w.stiffness_n_per_m > km * (1 + 1e-6) else '= K_min'}."
    )
    L.append("")
    L.extend(_comparison_block("A harder case: (b) with K_min = 30 N/m", hard))
    L.append(
        "Between K_min of about 25 and 30 N/m the lowest-pressure design leaves the d = 0 edge (see the trade-off table: "
        "at 25 N/m it sits on the wall with a large eccentricity), and along the curve K = K_min the pressure is nearly "
        "constant: designs tenths of a mm apart differ by a few 1e-4 in pressure. IPOPT's multipliers settle it; a swarm of "
        f"{pso_options.particles} can stagnate there after {pso_options.iterations} iterations (seed {pso_options.seed}), "
        "with its objective within 0.1 % but its design further than 0.01 mm away."
    )
    L.append("")
    L.append("**An infeasible request.** " + infeasible.ipopt.problem.describe() + ".")
    L.append("")
    L.append(f"- IPOPT: `{infeasible.ipopt.status}`: {infeasible.ipopt.message}.")
    L.append(f"- PSO: `{infeasible.pso.status}`: {infeasible.pso.message}.")
    L.append("")
    L.append("## The optimum against the segment count (IPOPT)")
    L.append("")
    L.append("| n | r2 (mm) | d (mm) | P (MPa) | K (N/m) | active | time (s) |")
    L.append("|---|---|---|---|---|---|---|")
    for r in by_n:
        L.append(
            f"| {r.problem.segments} | {r.r2_mm:.4f} | {r.d_mm:.4f} | {r.pressure_mpa:.5f} | {r.stiffness_n_per_m:.4f} | "
            f"{', '.join(c.name for c in r.active_constraints) or 'none'} | {r.solve_time_s:.3f} |"
        )
    L.append("")
    L.append("## The swarm")
    L.append("")
    L.append("![swarm positions per iteration](figures/fig14.png)")
    L.append("")
    hist = p.pso.pso.history.best_value
    first = int(np.argmax(np.abs(hist - hist[-1]) <= 1e-3 * abs(hist[-1])))
    L.append(
        f"With the paper's settings the swarm's best is within 0.1 % of its final stiffness after {first} iterations; "
        "the wall d = 0 absorbs the particles, so the swarm collapses onto the bound and then along it. It needs "
        f"{p.pso.evaluations} evaluations of the stiffness (each a closed-form pressure and a {options.load_steps}-step "
        f"Newton ramp), against IPOPT's {p.ipopt.iterations} iterations of the full-space NLP over {p.ipopt.evaluations} starts."
    )
    L.append("")
    L.append("## Limits")
    L.append("")
    L.append(
        "- The batched Newton ramp does not converge for the thinnest chambers (r2 below about 0.1 mm, where the loaded "
        "state presses against the domain of Eq. 10) and for chambers that nearly fill the actuator (r2 > 7.5 mm, where "
        "the loaded shape folds back by more than 70 deg); the swarm treats those designs as failed (far from every "
        "optimum here) and the figures solve them again with `esba.stiffness.secant_stiffness`."
    )
    L.append(
        "- From starts far from the optimum IPOPT can wander towards r2 -> 0, where the loaded equilibrium sits on the "
        "domain boundary; such starts end without convergence and are dropped, which is why there are several starts."
    )
    L.append(
        "- `angle` and `pressure` need K_min: without it their optimum runs to the thinnest wall (the chamber fills the "
        "actuator, the free angle grows without bound)."
    )
    L.append("")
    data = {k: v.to_dict() for k, v in runs.items()}
    data["infeasible"] = infeasible.to_dict()
    data["hard"] = hard.to_dict()
    data["trade_off"] = [r.to_dict() for r in trade]
    data["by_segments"] = [r.to_dict() for r in by_n]
    return "\n".join(L), data


def write_doc(path: str | Path | None = None, segments: int = 3, options: DesignOptions | None = None, pso_options: PSOOptions | None = None) -> tuple[Path, dict]:
    """Run :func:`design_report` and write the page (default ``docs/design.md``); return (path, data)."""
    path = DOC_PATH if path is None else Path(path)
    text, data = design_report(segments, options, pso_options)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path, data

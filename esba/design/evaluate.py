"""Designs evaluated in batches: the swarm's objective, IPOPT's starts and the figures.

One design (r2, d) -> its 90 degree pressure in closed form (U is linear in P), its loaded state
along a ramp of the payload from 0 (the same load path as the physical test: tangent predictor and
Newton corrections solved in O(n) from the Hessian's structure, :mod:`esba.solvers.newton`, accepted only when
every Hessian met is positive definite and every step contracts, so that no snap-through is taken
silently), and its secant stiffness; a CasADi Function mapped over the designs
(``Function.map(N, "thread", 2)``) evaluates a whole swarm in one call (:func:`evaluate`). Free
angles at a given pressure come from a bracketed bisection on the closed-form pressure of the
uniform unloaded shape (:func:`free_angle`). :func:`term_curvatures` splits the stiffness of the
start state by energy term.

Examples
--------
>>> from esba.design.problem import DesignProblem
>>> e = evaluate(DesignProblem(), [3.0, 1.5], [4.0, 0.0])
>>> [round(float(k), 2) for k in e.stiffness], [round(float(p), 5) for p in e.pressure]
([26.41, 45.29], [0.12387, 0.23362])
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import casadi as ca
import numpy as np

from esba.derive.effects import EffectSet
from esba.model.closed_form import unloaded_pressure
from esba.model.generated import Model, load_model
from esba.solvers.newton import Acceptance, correction_function, natural_expression, parts_function

from .problem import DEFAULT_DESIGN_OPTIONS, DesignOptions, DesignProblem

__all__ = ["Evaluation", "evaluate", "free_angle", "term_curvatures"]

# ---------------------------------------------------------------------------------------------
# the design problem's model: a design (r2, d), its pressure and payload -> the model's parameters


class DesignModel:
    """The generated model of a design problem with its fixed parameters bound: every parameter
    vector is a function of the design (r2, d), the pressure P and the payload F (numbers or CasADi
    expressions), and the evaluator, the NLP and the checks ask the model's own Functions."""

    def __init__(self, problem: DesignProblem):
        self.problem = problem
        self.model: Model = load_model(problem.segments, EffectSet.parse("air,axial,radial,fibres,payload"), problem.variant)
        self.n = problem.segments
        a = problem.actuator
        self.L, self.r1 = a.L, a.r1
        self.fixed = {"L": a.L, "r1": a.r1, "rho": math.radians(a.rho_deg), "E": a.E, "Omega1": math.radians(problem.payload_angle_deg), "s1": 1.0}
        om = math.radians(problem.payload_angle_deg)
        self.u = np.array([math.cos(om), -math.sin(om)])  # unit vector of the payload, Eq. (14)

    def values(self, r2, d, P, F) -> dict:
        """Every model parameter by name."""
        return dict(self.fixed, r2=r2, d=d, P=P, F1=F)

    def params(self, r2, d, P, F):
        """The model's parameter vector (a CasADi column when any argument is symbolic)."""
        v = self.values(r2, d, P, F)
        return ca.vertcat(*[v[k] for k in self.model.parameters])

    def grad(self, theta, r2, d, P, F):
        """dU/dtheta of the design's model."""
        v = self.values(r2, d, P, F)
        return self.model["gradient"](theta, *[v[k] for k in self.model.parameters])

    def hess(self, theta, r2, d, P, F):
        """d2U/dtheta2 of the design's model."""
        v = self.values(r2, d, P, F)
        return self.model["hessian"](theta, *[v[k] for k in self.model.parameters])

    def tip(self, theta):
        """Tip [x, y] (mm): numbers for numbers, an expression for symbols."""
        if isinstance(theta, (ca.SX, ca.MX)):
            return self.model["kinematics"](theta, self.L)[0][:2]
        return self.model.tips(np.asarray(theta, dtype=float)[None, :], self.L)[0, :2]

    def pressure_closed(self, Theta, r2, d):
        """The closed-form pressure of the uniform unloaded shape of total angle Theta
        (:func:`esba.model.closed_form.unloaded_pressure`)."""
        return unloaded_pressure(self.model, Theta, self.values(r2, d, 0.0, 0.0))

    def kernels(self) -> tuple[ca.Function, ca.Function]:
        """The engine's Newton kernels (:func:`esba.solvers.newton.parts_function`,
        :func:`~esba.solvers.newton.correction_function`) of this design's model, in z = (r2, d, P, F):
        the fixed parameters are constants of the graph, so CasADi folds them (a swarm evaluates
        thousands of designs)."""

        def build() -> tuple[ca.Function, ca.Function]:
            th = ca.SX.sym("theta", self.n)
            z = ca.SX.sym("z", 4)
            G = ca.Function("G", [th, z], [self.grad(th, z[0], z[1], z[2], z[3])])
            H = ca.Function("H", [th, z], [self.hess(th, z[0], z[1], z[2], z[3])])
            return parts_function(G, H, "design_parts"), correction_function(G, H, "design_correction")

        return self.model.derived("design_kernels", build, settings=design_model_key(self.problem), persist=False)

    def stiffness_expr(self, theta_s, theta_l):
        """K = 1000 F / delta (N/m), delta = tip displacement along the payload (mm)."""
        delta = ca.dot(ca.DM(self.u), self.tip(theta_l) - self.tip(theta_s))
        return 1000.0 * self.problem.payload_n / delta


def design_model_key(problem: DesignProblem) -> tuple:
    a = problem.actuator
    return (problem.segments, problem.variant, a.L, a.r1, a.rho_deg, a.E, problem.payload_n, problem.payload_angle_deg)


def design_model(problem: DesignProblem) -> DesignModel:
    """The :class:`DesignModel` of ``problem`` (one per problem's fixed values, in the model's registry)."""
    model = load_model(problem.segments, EffectSet.parse("air,axial,radial,fibres,payload"), problem.variant)
    return model.derived("design_model", lambda: DesignModel(problem), settings=design_model_key(problem), persist=False)


# ---------------------------------------------------------------------------------------------
# the batched evaluator (PSO, IPOPT's starts, the figures): the engine's natural continuation


class _Evaluator:
    """One design -> start pressure, loaded state (natural continuation of the payload), mapped over designs."""

    def __init__(self, problem: DesignProblem, options: DesignOptions):
        pc = design_model(problem)
        self.pieces, self.problem, self.options = pc, problem, options
        self.rule = Acceptance(tol=options.equilibrium_tol, critical_tol=options.critical_tol)
        self.single = self._single(options.load_steps)
        self._dense: ca.Function | None = None  # the retry's ramp, four times the steps, built when needed
        self._maps: dict[int, ca.Function] = {}
        self._dense_maps: dict[int, ca.Function] = {}
        r2, d, Theta = (ca.SX.sym(k) for k in ("r2", "d", "Theta"))
        self._pressure = ca.Function("pressure_closed", [Theta, r2, d], [pc.pressure_closed(Theta, r2, d)], ["Theta", "r2", "d"], ["P"])
        self._pmaps: dict[int, ca.Function] = {}

    def _single(self, steps: int) -> ca.Function:
        """One design -> P, loaded theta, K, residual, loaded Hessian, smallest pivot, worst contraction, worst jump."""
        pc, n, F = self.pieces, self.pieces.n, self.problem.payload_n
        x = ca.MX.sym("x", 2)
        r2, d = x[0], x[1]
        start = math.radians(self.problem.start_angle_deg)
        P = pc.pressure_closed(start, r2, d)
        theta_s = ca.DM.ones(n) * (start / n)
        parts, correction = pc.kernels()
        # the payload ramp from the unloaded state on the engine: accepted by the one rule, or refused
        theta, g, low, contraction, _, jump = natural_expression(
            parts, ca.MX(theta_s), ca.vertcat(r2, d, P, 0.0), ca.vertcat(0.0, 0.0, 0.0, F), 1.0, steps, self.options.newton_steps, 2, correction
        )
        K = pc.stiffness_expr(theta_s, theta)
        hess = pc.hess(theta, r2, d, P, F)
        return ca.Function(
            "design_eval",
            [x],
            [P, theta, K, ca.norm_inf(g), ca.reshape(hess, n * n, 1), low, contraction, jump],
            ["x"],
            ["P", "theta_l", "K", "residual", "hess_l", "min_pivot", "contraction", "jump"],
        )

    def _map(self, cache: dict, fun: ca.Function, size: int) -> ca.Function:
        f = cache.get(size)
        if f is None:
            f = cache[size] = fun.map(size, "thread", self.options.threads)
        return f

    def pressure(self, Theta: np.ndarray, r2: np.ndarray, d: np.ndarray) -> np.ndarray:
        """Closed-form pressure (MPa) of the uniform unloaded shape of total angle Theta (rad), batched."""
        Theta, r2, d = np.broadcast_arrays(*(np.asarray(v, dtype=float).ravel() for v in (Theta, r2, d)))
        f = self._map(self._pmaps, self._pressure, Theta.size)
        return np.asarray(f(Theta.reshape(1, -1), r2.reshape(1, -1), d.reshape(1, -1)), dtype=float).ravel()

    def _run(self, fun: ca.Function, cache: dict, r2: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, ...]:
        N, n = r2.size, self.pieces.n
        f = self._map(cache, fun, N)
        P, theta, K, res, hess, low, contraction, jump = (np.asarray(v, dtype=float) for v in f(np.vstack([r2, d])))
        H = hess.T.reshape(N, n, n)
        finite = np.all(np.isfinite(H), axis=(1, 2))
        # the one acceptance rule: stationary, every Hessian met positive definite (no fold or
        # branch point passed), every step contracting, no corrector going farther than its predictor
        ok = self.rule.accepted_arrays(res.ravel(), low.ravel(), contraction.ravel(), jump.ravel(), finite)
        min_eig = np.full(N, np.nan)
        if np.any(ok):
            ev = np.linalg.eigvalsh(0.5 * (H[ok] + np.transpose(H[ok], (0, 2, 1))))
            min_eig[ok] = ev[:, 0] / np.maximum(np.abs(ev[:, -1]), 1e-300)
        ok &= min_eig > self.options.critical_tol
        return P.ravel(), theta.T, K.ravel(), ok

    def __call__(self, r2: np.ndarray, d: np.ndarray) -> dict[str, np.ndarray]:
        r2 = np.asarray(r2, dtype=float).ravel()
        d = np.asarray(d, dtype=float).ravel()
        P, theta, K, ok = self._run(self.single, self._maps, r2, d)
        redo = np.flatnonzero(~ok)
        if len(redo):  # a finer ramp for the designs the first could not follow (huge bends, thin walls)
            if self._dense is None:
                self._dense = self._single(4 * self.options.load_steps)
            P2, theta2, K2, ok2 = self._run(self._dense, self._dense_maps, r2[redo], d[redo])
            P[redo], theta[redo], K[redo], ok[redo] = P2, theta2, K2, ok2
        K = np.where(ok, K, np.nan)
        return {"pressure": P, "theta_l": theta, "stiffness": K, "ok": ok}


def evaluator(problem: DesignProblem, options: DesignOptions) -> _Evaluator:
    key = (design_model_key(problem), problem.start_angle_deg, options.load_steps, options.newton_steps, options.equilibrium_tol,
           options.critical_tol, options.threads)
    return design_model(problem).model.derived("design_evaluator", lambda: _Evaluator(problem, options), settings=key, persist=False)


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
    ev = evaluator(problem, options)
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
    ev = evaluator(problem, options)
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


def objective_of(problem: DesignProblem, e: Evaluation) -> np.ndarray:
    """The objective J of evaluated designs, in its units (nan where undefined)."""
    if problem.objective == "stiffness":
        return e.stiffness
    if problem.objective == "angle":
        return np.where(e.ok, e.free_angle_deg, np.nan)
    return np.where(e.ok, e.target_pressure, np.nan)


def violation_of(problem: DesignProblem, e: Evaluation) -> np.ndarray:
    """Relative violation of the nonlinear constraints (0 = feasible; inf = evaluation failed)."""
    v = np.zeros(e.r2.size)
    if problem.min_stiffness is not None and problem.objective != "stiffness":
        v += np.maximum(0.0, (problem.min_stiffness - e.stiffness) / problem.min_stiffness)
    if problem.max_pressure is not None:
        v += np.maximum(0.0, (e.pressure - problem.max_pressure) / problem.max_pressure)
        if e.target_pressure is not None:
            v += np.maximum(0.0, (e.target_pressure - problem.max_pressure) / problem.max_pressure)
    J = objective_of(problem, e)
    return np.where(np.isfinite(J) & e.ok, v, np.inf)


def uniform_state(n: int, angle_deg: float) -> np.ndarray:
    """theta_i = Theta / n: the unloaded equilibrium of total angle Theta (rad)."""
    return np.full(n, math.radians(angle_deg) / n)


# ---------------------------------------------------------------------------------------------
# what each energy term contributes to the stiffness


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
    pc = design_model(problem)
    m = pc.model
    n = pc.n
    th = ca.SX.sym("theta", n)
    theta = uniform_state(pc.n, problem.start_angle_deg)
    P = float(pc.pressure_closed(math.radians(problem.start_angle_deg), r2, d))
    values = pc.values(r2, d, P, problem.payload_n)
    terms = m["energy"](th, *[values[k] for k in m.parameters])[1]
    out = {}
    for k, name in enumerate(m.terms):
        h = ca.Function("term_hessian", [th], [ca.hessian(terms[k], th)[0]])
        out[name] = float(np.asarray(h(theta))[0, 0])
    return out

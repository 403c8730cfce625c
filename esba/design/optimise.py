"""Design optimisation of the chamber: IPOPT on the full-space NLP, checked against a swarm.

The problems are :mod:`esba.design.problem` (the paper's: the stiffest (r2, d) of the Table 1
actuator, each design at its own 90 degree pressure under a 2 N horizontal tip payload).

**IPOPT** (:func:`optimise_ipopt`): the full-space NLP of :mod:`esba.design.nlp`, started from a
few designs spread over the triangle (each with its equilibria from the batched evaluator of
:mod:`esba.design.evaluate`, so every start lies on the physical branch); the best converged result
is kept. After the solve the result is checked: the Hessian of U is positive definite at every
state (stable equilibria), the loaded state is the one reached along the load path
(:func:`esba.statics.equilibrium.solve` at the optimum's pressure, inflate first, then load), and the
active constraints are reported with their multipliers, turned into sensitivities: how much the
objective would gain per unit of each active bound (e.g. N/m per mm for d >= 0).

**PSO** (:func:`optimise_pso`): the paper's method, :func:`esba.solvers.pso.minimize` over (r2, d) with
the whole swarm evaluated in one call by :func:`esba.design.evaluate.evaluate`.

An infeasible request (K_min above every design's stiffness) returns ``status="infeasible"``
with the best stiffness reachable, not an exception. The page ``docs/design.md`` is written by
:mod:`esba.pages.design`.

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

import numpy as np

from esba.infra import jsonsafe
from esba.infra.report import Report
from esba.model.scene import SceneError
from esba.solvers.pso import PSOOptions, PSOResult, minimize
from esba.statics.equilibrium import STEP_OPTIONS, solve, stability_verdict

from .evaluate import (
    Evaluation,
    design_model,
    evaluate,
    evaluator,
    free_angle,
    objective_of,
    term_curvatures,
    uniform_state,
    violation_of,
)
from .nlp import ActiveConstraint, design_nlp, extra_start, extra_states, start_designs
from .problem import (
    DEFAULT_DESIGN_OPTIONS,
    GEOMETRY_EPS,
    METHODS,
    OBJECTIVES,
    DesignError,
    DesignOptions,
    DesignProblem,
)

__all__ = [
    "optimise",
    "OBJECTIVES",
    "METHODS",
    "GEOMETRY_EPS",
    "DEFAULT_DESIGN_OPTIONS",
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
    "term_curvatures",
]


# ---------------------------------------------------------------------------------------------
# results


@dataclass(frozen=True, eq=False, repr=False)
class DesignResult(Report):
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
        The loaded state is the one :func:`esba.statics.equilibrium.solve` reaches along the load path
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

    _plotter = "esba.figures.results:draw_design_result"

    def headline(self) -> str:
        """One line: the method, the status and the design with its objective."""
        return (f"{self.method} {self.status}: r2 = {self.r2_mm:.4f}, d = {self.d_mm:.4f} mm, "
                f"{self.problem.objective} = {self.objective:.5g} {self.problem.unit}")

    def summary(self) -> str:
        """The text ``esba design`` prints for this run."""
        return design_table(self.to_dict())

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
        return jsonsafe.clean(out)


# ---------------------------------------------------------------------------------------------
# the checks every result gets


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
    pc = design_model(problem)
    states = {"start": uniform_state(pc.n, problem.start_angle_deg), "loaded": np.asarray(theta_loaded, dtype=float)}
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
        eq = solve(problem.scene(r2, d, pressure), STEP_OPTIONS, pressure=pressure)
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
# IPOPT on the full-space NLP, from several starts


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
    nlp, setup = design_nlp(problem, options)
    t_eval = time.perf_counter()
    evaluator(problem, options)
    setup += time.perf_counter() - t_eval
    t0 = time.perf_counter()
    r2s, ds = start_designs(problem, options)
    r2s, ds = np.r_[r2s, extra_r2], np.r_[ds, extra_d]
    e = evaluate(problem, r2s, ds, options)
    best, statuses, iterations, starts = None, [], 0, 0
    for i in range(r2s.size):
        if not e.ok[i]:
            continue
        z0 = nlp.x0(e, i, extra_start(problem, e, i, nlp.pieces.n))
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
        extra_states(problem, nlp, z),
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
    r2 + d <= r1 - wall enforced (:func:`esba.solvers.pso.minimize`); the nonlinear constraints (K >=
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
    evaluator(problem, options)
    setup = time.perf_counter() - t_setup
    sign = -1.0 if problem.objective in ("stiffness", "angle") else 1.0

    def swarm(X: np.ndarray):
        e = evaluate(problem, X[:, 0], X[:, 1], options)
        J = objective_of(problem, e)
        return sign * J, violation_of(problem, e)

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
    pc = design_model(problem)
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


@dataclass(frozen=True, eq=False, repr=False)
class Comparison(Report):
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

    _plotter = "esba.figures.results:draw_design_result"

    def headline(self) -> str:
        """One line: both designs and whether they agree."""
        return f"IPOPT and PSO {'agree' if self.agree else 'differ'}: {self.ipopt.headline()}; PSO r2 = {self.pso.r2_mm:.4f}, d = {self.pso.d_mm:.4f} mm"

    def summary(self) -> str:
        """The text ``esba design --method both`` prints."""
        return design_table(self.to_dict())

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
        return jsonsafe.clean(out)


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


def optimise(
    problem: DesignProblem | None = None,
    method: str = "ipopt",
    options: DesignOptions | None = None,
    pso_options: PSOOptions | None = None,
) -> DesignResult | Comparison:
    """The optimal chamber of ``problem`` by ``method``: ``"ipopt"`` (:func:`optimise_ipopt`),
    ``"pso"`` (:func:`optimise_pso`) or ``"both"`` (:func:`compare`, IPOPT checked against PSO).

    Raises
    ------
    DesignError
        for a method not in :data:`METHODS`.
    """
    if method == "ipopt":
        return optimise_ipopt(problem, options)
    if method == "pso":
        return optimise_pso(problem, options, pso_options)
    if method == "both":
        return compare(problem, options, pso_options)
    raise DesignError(f"method={method!r}: allowed are {', '.join(METHODS)}")


def design_rows(d: dict) -> list[tuple[str, str]]:
    """The rows ``esba design`` prints for one run's :meth:`DesignResult.to_dict`."""
    def num(v, fmt):
        return "-" if v is None else format(v, fmt)

    rows = [
        ("status", d["status"] + (f": {d['message']}" if d.get("message") else "")),
        ("r2, d", f"{num(d['r2_mm'], '.5f')}, {num(d['d_mm'], '.5f')} mm (wall {num(d['wall_mm'], '.4f')} mm)"),
        ("pressure", f"{num(d['pressure_mpa'], '.6f')} MPa (unloaded 90 deg)"),
        ("stiffness", f"{num(d['stiffness_n_per_m'], '.5f')} N/m (load path: {num(d['stiffness_check_n_per_m'], '.5f')})"),
        ("objective", f"{d['objective']} = {num(d['objective_value'], '.6g')} {d['objective_unit']}"),
    ]
    if d.get("best_reachable_stiffness") is not None:
        rows.append(("best K", f"{d['best_reachable_stiffness']:.5f} N/m reachable"))
    rows.append(("stable", f"{d['stable']}; on the load path: {d['on_load_path']}"))
    active = []
    for c in d["active_constraints"]:
        sens = "" if c["sensitivity"] is None else f" (d objective / d bound = {c['sensitivity']:+.4g} {d['objective_unit']}/{c['unit']})"
        active.append(f"{c['name']}: {c['description']}{sens}")
    rows.append(("active", "; ".join(active) or "none"))
    work = f"{d['evaluations']} designs"
    if d["method"] == "ipopt":
        work = f"{d['iterations']} iterations, {d['evaluations']} starts"
        if d.get("min_stiffness") is not None and d.get("objective") != "stiffness" and d["evaluations"]:
            # the stiffest design, found first to see whether the floor can be met, is a start too
            work += f" ({d['evaluations'] - 1} of --starts and the stiffest design, found first for K >= {d['min_stiffness']:g} N/m)"
    rows.append(("time", f"{d['solve_time_s']:.3f} s ({work}; set-up {d['setup_time_s']:.3f} s)"))
    return rows


def design_table(d: dict) -> str:
    """The text ``esba design`` prints for :meth:`DesignResult.to_dict` or :meth:`Comparison.to_dict` (and the ``figure`` the command adds)."""
    if d.get("method") != "both":
        lines = [d["problem"], f"method: {d['method']}"] + [f"{k:>10}: {v}" for k, v in design_rows(d)]
    else:
        lines = [d["ipopt"]["problem"]]
        for name in ("ipopt", "pso"):
            lines.append(f"-- {name}")
            lines += [f"{k:>10}: {v}" for k, v in design_rows(d[name])]
        diff = d["differences"]

        def num(v, fmt):
            return "-" if v is None else format(v, fmt)

        lines.append(
            f"-- PSO - IPOPT: r2 {num(diff['r2_mm'], '+.2e')} mm, d {num(diff['d_mm'], '+.2e')} mm, objective "
            f"{num(diff['objective_rel'], '+.2e')} (relative); PSO took {num(diff['time_ratio_pso_over_ipopt'], '.0f')} "
            f"times as long; agree (0.01 mm, 0.1 %): {diff['agree']}"
        )
    if d.get("figure"):
        lines.append(f"wrote {d['figure']}")
    return "\n".join(lines)

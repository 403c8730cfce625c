"""Calibration: actuator parameters from measurements, with their uncertainty and identifiability.

**The estimate.** Weighted least squares over the measured values y_i (total angles, tip
coordinates, secant stiffnesses; :mod:`esba.calibration.measurements`),

    minimise 1/2 sum_i ((y_i(theta, p) - m_i) / sd_i)^2,

as one full-space IPOPT problem built with :class:`esba.solvers.eqnlp.EquilibriumNLP` (the builder the
design optimisation uses): the variables are the free parameters p (E and rho by default; any of
L, r1, r2, d, rho, E, M) and every row's segment angles (and, for a stiffness, its unloaded
angles), held to equilibrium by dU/dtheta = 0 with the generated gradient, inside the model's
domain (Eq. 10). CasADi differentiates the generated gradient once more for the exact Hessian of
the Lagrangian. The measured values and weights are the NLP's parameters, so one solver serves
many data sets of the same layout. IPOPT starts from the file's actuator, with each row's
equilibrium from :func:`esba.statics.equilibrium.solve`.

**The checks.** Each fitted state must be a stable minimum (Hessian positive definite) and the
one :func:`esba.statics.equilibrium.solve` reaches along the row's load path at the fitted parameters
(the NLP alone only asks for stationarity).

**The uncertainty.** The Jacobian J of the weighted residuals r_i = (y_i - m_i) / sd_i with
respect to p comes from the implicit function theorem (dtheta/dp = -H^-1 dG/dp, CasADi AD; the
sensitivities of :mod:`esba.analysis.sensitivity`, row by row). The Gauss-Newton (Fisher) matrix F = J^T J,
scaled by the residual variance s^2 = sum r_i^2 / (m - k), gives the covariance s^2 F^-1, the
standard errors, the correlation matrix and intervals with Student's t on m - k degrees of
freedom (the scaling makes the intervals honest when the stated standard deviations are not).

**Identifiability.** When F is nearly singular (its smallest eigenvalue, for relative changes of
the parameters, below ``identifiability_tol`` times its largest) some combination of the
parameters does not change the predictions, or some parameter hardly changes them at all: the
result says which, and gives no standard errors for the parameters in it. For example E and rho trade off exactly when only unloaded bends at given
pressures are measured (both enter the unloaded equilibrium only through
P pi r1^2 (r1 - 4 r2 tan^2 rho) / E), and rho drops out altogether at a target angle (the pressure
absorbs it).

Examples
--------
>>> from esba.calibration.measurements import measurements_from_rows
>>> data = measurements_from_rows("example", [
...     ("row 1", {"pressure_mpa": 0.2, "total_angle_deg": 176.8}),
...     ("row 2", {"target_angle_deg": 90, "payload_n": 2, "payload_angle_deg": 90, "total_angle_deg": 28.8}),
...     ("row 3", {"target_angle_deg": 90, "payload_n": 2, "payload_angle_deg": 0, "total_angle_deg": 53.2})])
>>> r = fit(data, ["E"])
>>> r.ok, round(r.value("E"), 4), [round(float(v), 3) for v in r.interval[0]]
(True, 0.5465, [0.527, 0.566])
>>> r = fit(data)   # E and rho: these rows want rho < 0, where the model stops depending on it
>>> r.identifiable, round(r.value("rho"), 3)
(False, 0.0)
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Any, Sequence

import casadi as ca
import numpy as np
from scipy import stats

from esba.analysis.sensitivity import (
    UNITS,
    model_values,
    parameter_names,
    scene_parameters,
    with_parameters,
)
from esba.infra import checks, jsonsafe
from esba.infra.errors import InputError
from esba.infra.report import Report
from esba.infra.roundoff import ROUNDOFF_RATIO, floored
from esba.model.scene import Payload, Scene, SceneError
from esba.model.validity import assess_angles
from esba.solvers.eqnlp import EquilibriumNLP, model_gradient
from esba.statics.equilibrium import (
    STEP_OPTIONS,
    EquilibriumError,
    SolverOptions,
    solve,
    stability_verdict,
)

from .measurements import QUANTITIES, Measurement, MeasurementError, MeasurementSet

__all__ = ["FitError", "FitOptions", "FitResult", "fit", "predict", "Prediction", "identifiability", "Identifiability", "identifiability_rule", "fisher_correlation", "FITTABLE", "DEFAULT_FREE", "DEFAULT_SD"]

#: Parameters a fit may free (the actuator's; pressures and payloads are each row's own).
FITTABLE = ("L", "r1", "r2", "d", "rho", "E", "M")
#: Freed by default.
DEFAULT_FREE = ("E", "rho")
#: Standard deviation of a measured value whose row gives none (deg, mm, mm, N/m). With the
#: Fisher matrix scaled by the residual variance only their ratios matter.
DEFAULT_SD = {"total_angle": 1.0, "tip_x": 1.0, "tip_y": 1.0, "stiffness": 1.0}

#: Bounds of the free parameters (scene-file units): lower, upper.
_BOUNDS = {"L": (1e-3, math.inf), "r1": (1e-3, math.inf), "r2": (1e-3, math.inf), "d": (0.0, math.inf),
           "rho": (0.0, 89.0), "E": (1e-6, math.inf), "M": (0.0, math.inf)}


class FitError(InputError):
    """A fit setting that is not allowed: the message names it, the value and what is allowed."""


@dataclass(frozen=True)
class FitOptions:
    """Settings of :func:`fit`, validated on creation.

    Parameters
    ----------
    tol : float
        IPOPT's tolerance, 0 < tol < 1.
    max_iter : int
        IPOPT's iteration limit.
    linear_solver : str
        ``"mumps"`` or ``"spral"``.
    level : float
        Confidence level of the intervals, 0 < level < 1.
    identifiability_tol : float
        The Fisher matrix of relative parameter changes is *nearly singular* below this ratio of
        its smallest to its largest eigenvalue.
    identifiability_floor : float
        A parameter (or a combination) is also undetermined when a 100 % change of it moves the
        residuals, each weighted by its standard deviation, by less than sqrt(floor) on average:
        the predictions do not depend on it, whatever the ratio says (one free parameter has ratio 1).
    load_path_tol : float
        Largest difference, rad, between a fitted state and the load-path solve at the fitted
        parameters.

    >>> FitOptions(level=95)
    Traceback (most recent call last):
    ...
    esba.calibration.fit.FitError: level=95: expected a number with 0 < level < 1 (0.95 for 95 %)
    """

    tol: float = 1e-10
    max_iter: int = 500
    linear_solver: str = "mumps"
    level: float = 0.95
    identifiability_tol: float = 1e-6
    identifiability_floor: float = 1e-12
    load_path_tol: float = 1e-6

    def __post_init__(self) -> None:
        for name in ("tol", "level", "identifiability_tol", "identifiability_floor"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 < v < 1.0:
                hint = " (0.95 for 95 %)" if name == "level" else ""
                raise FitError(f"{name}={v!r}: expected a number with 0 < {name} < 1{hint}")
        checks.whole("max_iter", self.max_iter, 1, FitError)
        if self.linear_solver not in ("mumps", "spral"):
            raise FitError(f"linear_solver={self.linear_solver!r}: allowed are mumps, spral")
        checks.finite("load_path_tol", self.load_path_tol, FitError)
        if self.load_path_tol <= 0:
            raise FitError(f"load_path_tol={self.load_path_tol!r}: expected a number > 0")


def check_free(data: MeasurementSet, free: Sequence[str]) -> tuple[str, ...]:
    """``free`` if it names fittable parameters the rows depend on; else a :class:`FitError`.

    A text is read as the command line reads ``--free``: names separated by commas (``"E,rho"``).
    """
    if isinstance(free, str):
        free = [s.strip() for s in free.split(",") if s.strip()]
    if not isinstance(free, (list, tuple)) or not all(isinstance(n, str) for n in free):
        raise FitError(f"free={checks.quote(free)}: expected names of parameters to fit, such as ['E', 'rho'] or 'E,rho'")
    free = tuple(free)
    if not free:
        raise FitError(f"free parameters: none given; choose from {', '.join(FITTABLE)}")
    for name in free:
        if name not in FITTABLE:
            raise FitError(f"free parameter {name!r}: allowed are {', '.join(FITTABLE)} (pressures and payloads belong to each row)")
    dup = sorted({n for n in free if free.count(n) > 1})
    if dup:
        raise FitError(f"free parameter(s) {', '.join(dup)} given twice")
    if "M" in free and not data.base.gravity:
        raise FitError("free parameter 'M': the mass only acts with gravity (set gravity = true in the scene)")
    for name in free:
        if all(name in m.own for m in data.rows):
            raise FitError(f"free parameter {name!r}: every row sets its own {name}, so no row depends on the fitted one")
    return free


# ---------------------------------------------------------------------------------------------
# one row: equilibrium residuals and predictions as CasADi expressions


class _Row:
    """A row's equilibria and predicted values in terms of the free parameters p = scale * z."""

    def __init__(self, m: Measurement, free: tuple[str, ...], z: Any, scale: np.ndarray, theta_l: Any, theta_u: Any | None):
        scene = m.scene
        self.m, self.model = m, scene.model()
        self.quantities = tuple(q for q in QUANTITIES if q in m.values)
        names = parameter_names(scene)
        base = [p.value for p in scene_parameters(scene)]
        p_row = [scale[free.index(nm)] * z[free.index(nm)] if nm in free and nm not in m.own else v for nm, v in zip(names, base)]
        mv = model_values(self.model, names, p_row)
        self.values = mv
        self.target = scene.pressure is None  # P is then the closed form of the target angle: keep it >= 0
        self.theta_l, self.theta_u = theta_l, theta_u
        G = [model_gradient(self.model, theta_l, mv)]
        L = mv["L"]
        tip_l = self.model["kinematics"](theta_l, L)[0]
        y = {"total_angle": ca.sum1(theta_l) * (180.0 / math.pi), "tip_x": tip_l[0], "tip_y": tip_l[1]}
        if "stiffness" in self.quantities:
            mv_u = dict(mv, F1=0.0)
            G.append(model_gradient(self.model, theta_u, mv_u))
            tip_u = self.model["kinematics"](theta_u, L)[0]
            p = scene.payloads[0]
            om = math.radians(p.angle_deg)
            delta = math.cos(om) * (tip_l[0] - tip_u[0]) - math.sin(om) * (tip_l[1] - tip_u[1])
            y["stiffness"] = 1000.0 * p.force / delta
        self.G = G
        self.y = ca.vertcat(*[y[q] for q in self.quantities])
        X = theta_l if theta_u is None else ca.vertcat(theta_l, theta_u)
        R = ca.vertcat(*G)
        ins = [z, theta_l] + ([theta_u] if theta_u is not None else [])
        self.function = ca.Function(
            "esba_fit_row", ins, [R, self.y, ca.jacobian(R, X), ca.jacobian(R, z), ca.jacobian(self.y, X), ca.jacobian(self.y, z)]
        )

    def unloaded_scene(self, scene: Scene) -> Scene:
        """The row's scene with its payload's force at 0 (the start of the secant stiffness)."""
        return scene.replace(payloads=(Payload(0.0, scene.payloads[0].angle_deg, scene.payloads[0].at),))

    def evaluate(self, z: np.ndarray, theta_l: np.ndarray, theta_u: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, float]:
        """(predicted values, d predictions / dz, largest |dU/dtheta|) at a solution."""
        args = [z, theta_l] + ([theta_u] if self.theta_u is not None else [])
        R, y, R_X, R_z, y_X, y_z = (np.asarray(v, dtype=float) for v in self.function(*args))
        dX = -np.linalg.solve(R_X, R_z)  # the implicit function theorem, state by state (block diagonal)
        return y.ravel(), y_z + y_X @ dX, float(np.max(np.abs(R)))


def _fitted_scene(m: Measurement, free: tuple[str, ...], p: np.ndarray) -> Scene:
    return with_parameters(m.scene, {name: float(v) for name, v in zip(free, p) if name not in m.own})


def _scale(data: MeasurementSet, free: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Start values (scene-file units) and the scale of each free parameter."""
    start = np.array([next(p.value for p in scene_parameters(data.base) if p.name == name) for name in free])
    return start, np.where(np.abs(start) > 0, np.abs(start), 1.0)


def _states(m: Measurement, scene: Scene, options: SolverOptions) -> tuple[np.ndarray, np.ndarray | None, str]:
    """Load-path solves of a row: loaded angles, unloaded angles (stiffness rows), and why not ok."""
    theta_l, theta_u, why, _ = _states_and_snaps(m, scene, options)
    return theta_l, theta_u, why


def _snap_notes(r) -> list[str]:
    """The sentences in which ``solve`` reported the snap-throughs of its load path."""
    return [note for note in r.notes if note.startswith("the quasi-static path jumps")]


def _states_and_snaps(m: Measurement, scene: Scene, options: SolverOptions) -> tuple[np.ndarray, np.ndarray | None, str, list[str]]:
    """:func:`_states` and the snap-throughs on the row's load path (one sentence each)."""
    try:
        r = solve(scene, options)
    except (EquilibriumError, SceneError) as exc:  # a target angle that needs a negative pressure, scales the solver cannot resolve
        return np.full(scene.segments, np.nan), None, str(exc), []
    snaps = _snap_notes(r)
    if not r.ok:
        return r.theta, None, r.message or r.status, snaps
    if "stiffness" not in m.values:
        return r.theta, None, "", snaps
    u = solve(scene.replace(payloads=(Payload(0.0, scene.payloads[0].angle_deg, scene.payloads[0].at),)), options, pressure=r.pressure)
    return r.theta, u.theta, "" if u.ok else (u.message or u.status), snaps + _snap_notes(u)


# ---------------------------------------------------------------------------------------------
# the NLP


@dataclass(eq=False)
class _FitNLP:
    built: Any
    rows: list
    free: tuple
    scale: np.ndarray


#: Fit NLPs kept for reuse, one per layout of a data set (its rows' scenes and measured quantities):
#: a cache of the data, not of a model (a model's derived Functions live in its registry,
#: :meth:`esba.model.generated.Model.derived`), so it is bounded and forgets the oldest.
_NLPS: dict[tuple, _FitNLP] = {}

#: Solvers and row functions kept for reuse (the oldest go first): one per layout of the data.
CACHE_SIZE = 32


def _remember(cache: dict, key: tuple, value):
    """Keep ``value`` under ``key``, forgetting the oldest entry beyond :data:`CACHE_SIZE`."""
    cache[key] = value
    while len(cache) > CACHE_SIZE:
        cache.pop(next(iter(cache)))
    return value


def _layout_key(data: MeasurementSet, free: tuple[str, ...], options: FitOptions) -> tuple:
    rows = tuple((m.scene, tuple(q for q in QUANTITIES if q in m.values), m.own) for m in data.rows)
    return (data.base.actuator, rows, free, options.tol, options.max_iter, options.linear_solver)


def _fit_nlp(data: MeasurementSet, free: tuple[str, ...], options: FitOptions) -> _FitNLP:
    key = _layout_key(data, free, options)
    cached = _NLPS.get(key)
    if cached is not None:
        return cached
    start, scale = _scale(data, free)
    b = EquilibriumNLP("esba_fit")
    lb = np.array([_BOUNDS[n][0] for n in free]) / scale
    ub = np.array([_BOUNDS[n][1] for n in free]) / scale
    z = b.variable("z", len(free), lb, ub)
    geometry_free = any(n in free for n in ("L", "r1", "r2", "d"))
    rows = []
    count = 0
    for i, m in enumerate(data.rows):
        n = m.scene.segments
        model = m.scene.model()
        fixed_lb = model.lower_bounds(m.scene.parameters(0.0)) if not geometry_free else -math.inf
        th_l = b.variable(f"theta_l{i}", n, fixed_lb)
        th_u = b.variable(f"theta_u{i}", n, fixed_lb) if "stiffness" in m.values else None
        row = _Row(m, free, z, scale, th_l, th_u)
        b.equilibrium(row.G[0], f"{m.label}")
        if row.target:
            b.constraint(row.values["P"], f"pressure[{i}]", f"the pressure of {m.label!r} (from its target angle) >= 0", "MPa", 0.0, math.inf, True)
        if th_u is not None:
            b.equilibrium(row.G[1], f"{m.label}, unloaded")
        if geometry_free:
            v = row.values
            b.domain(th_l, v["L"], v["r1"], v["r2"], v["d"], m.label)
            if th_u is not None:
                b.domain(th_u, v["L"], v["r1"], v["r2"], v["d"], f"{m.label}, unloaded")
        rows.append(row)
        count += len(row.quantities)
    if any(n in free for n in ("r1", "r2", "d")):
        v = rows[0].values if not rows[0].m.own & {"r1", "r2", "d"} else None
        if v is not None:
            b.constraint(v["r1"] - v["r2"] - v["d"], "wall", "wall r1 - r2 - d >= 0.001 mm", "mm", 1e-3, math.inf, True)
    measured = b.parameter("measured", count)
    weight = b.parameter("weight", count)
    y = ca.vertcat(*[r.y for r in rows])
    objective = 0.5 * ca.sumsqr((y - measured) * weight)
    built = b.build(objective, {
        "show_eval_warnings": False,
        "ipopt.tol": options.tol,
        "ipopt.max_iter": options.max_iter,
        "ipopt.linear_solver": options.linear_solver,
    })
    nlp = _remember(_NLPS, key, _FitNLP(built, rows, free, scale))
    return nlp


# ---------------------------------------------------------------------------------------------
# the result


@dataclass(frozen=True, eq=False, repr=False)
class FitResult(Report):
    """A fit: estimates, their uncertainty, the residuals and the checks.

    Attributes
    ----------
    data : MeasurementSet
    free : tuple of str
        The fitted parameters; ``units`` their units (scene-file units: rho in degrees).
    start, estimate : ndarray
    std_error : ndarray
        NaN for parameters in a direction the data do not determine.
    interval : ndarray, shape (k, 2)
        ``level`` confidence intervals (NaN where the standard error is).
    covariance, correlation : ndarray, shape (k, k)
    fisher : ndarray, shape (k, k)
        J^T J of the weighted residuals (unscaled).
    residual_variance : float
        s^2 = sum r_i^2 / (m - k) (NaN without degrees of freedom).
    dof : int
        m - k.
    residuals : tuple of dict
        Per measured value: ``row``, ``quantity``, ``unit``, ``measured``, ``predicted``, ``sd``
        (and ``sd_given``), ``residual`` (predicted - measured), ``normalised`` (residual / sd).
    rows : tuple of dict
        Per row: ``row``, ``stable``, ``min_eigenvalue``, ``on_load_path``, ``message``, ``validity``
        (the :mod:`esba.model.validity` findings of its fitted states) and ``snaps`` (the snap-throughs on
        its load path at the fitted parameters), both also among ``warnings``.
    identifiable : bool
    fisher_ratio : float
        Smallest over largest eigenvalue of the Fisher matrix of relative parameter changes.
    warnings : tuple of str
    status : str
        ``ok`` or ``failed`` (IPOPT did not converge, or a fitted state is not a stable minimum on
        its load path).
    message : str
    iterations : int
    solve_time_s : float
    """

    data: MeasurementSet
    free: tuple[str, ...]
    units: tuple[str, ...]
    level: float
    start: np.ndarray
    estimate: np.ndarray
    std_error: np.ndarray
    interval: np.ndarray
    covariance: np.ndarray
    correlation: np.ndarray
    fisher: np.ndarray
    residual_variance: float
    dof: int
    residuals: tuple[dict, ...]
    rows: tuple[dict, ...]
    identifiable: bool
    fisher_ratio: float
    warnings: tuple[str, ...]
    status: str
    message: str
    iterations: int
    solve_time_s: float

    _plotter = "esba.figures.results:draw_fit"

    def headline(self) -> str:
        """One line: the status and each fitted parameter with its standard error."""
        est = ", ".join(f"{n} = {v:.5g} +- {se:.2g} {u}" if math.isfinite(se) else f"{n} = {v:.5g} {u} (not identifiable)"
                        for n, u, v, se in zip(self.free, self.units, self.estimate, self.std_error))
        return f"{self.status}: {est}"

    def summary(self) -> str:
        """The text ``esba fit`` prints for this fit."""
        return fit_table(self.to_dict())

    @property
    def ok(self) -> bool:
        """IPOPT converged and every fitted state is a stable minimum on its load path."""
        return self.status == "ok"

    def value(self, name: str) -> float:
        """The estimate of a free parameter."""
        return float(self.estimate[self.free.index(name)])

    def params(self) -> dict[str, float]:
        """Estimates by name."""
        return {n: float(v) for n, v in zip(self.free, self.estimate)}

    def to_dict(self) -> dict:
        """JSON-ready form (``esba fit --json``)."""
        return jsonsafe.clean({
            "status": self.status,
            "message": self.message,
            "source": self.data.source,
            "segments": self.data.base.segments,
            "variant": self.data.base.variant,
            "measurements": len(self.residuals),
            "rows": len(self.rows),
            "parameters": {
                n: {"unit": u, "start": s, "estimate": e, "std_error": se, f"interval_{round(100 * self.level)}": list(iv)}
                for n, u, s, e, se, iv in zip(self.free, self.units, self.start, self.estimate, self.std_error, self.interval)
            },
            "level": self.level,
            "correlation": self.correlation.tolist(),
            "covariance": self.covariance.tolist(),
            "fisher": self.fisher.tolist(),
            "fisher_ratio": self.fisher_ratio,
            "identifiable": self.identifiable,
            "residual_variance": self.residual_variance,
            "dof": self.dof,
            "residuals": list(self.residuals),
            "states": list(self.rows),
            "warnings": list(self.warnings),
            "iterations": self.iterations,
            "solve_time_s": self.solve_time_s,
        })


def identifiability_rule(F: np.ndarray, count: int, free: tuple[str, ...], scale: np.ndarray, estimate: np.ndarray, at_bound: Sequence[str],
                         tol: float, floor: float, units: Sequence[str] | None = None) -> tuple[bool, float, np.ndarray, list[str], dict]:
    """(identifiable, eigenvalue ratio, parameters in an undetermined direction, warnings, the first
    undetermined direction as relative changes {name: dp/p}) of a Fisher matrix of ``count``
    weighted residuals. ``units`` name each parameter's unit in the warnings (default: by name,
    from :data:`esba.analysis.sensitivity.UNITS`). The load estimate of
    :mod:`esba.calibration.sensing` judges its loads by this same rule.

    Judged on the Fisher matrix of *relative* parameter changes, S F S with S = diag(scale) (each
    parameter's start value, or 1 where that is 0), in two steps:

    - a parameter the predictions do not depend on: a 100 % change of it moves the weighted
      residuals by less than ``sqrt(floor)`` each (its diagonal entry below ``floor`` times the
      number of measured values), whatever the other parameters do;
    - a trade-off among the others: the smallest eigenvalue of their block below ``tol`` times the
      largest, or below that same absolute floor.
    """
    k = len(free)
    unit = dict(zip(free, units)) if units is not None else {name: UNITS[name] for name in free}
    warnings = []
    Frel = scale[:, None] * F * scale[None, :]
    w_all = np.linalg.eigvalsh(Frel)
    ratio = float(max(w_all[0], 0.0) / w_all[-1]) if w_all[-1] > 0 else 0.0
    absolute = floor * max(count, 1)
    unknown = np.diag(Frel) < absolute
    direction: dict = {}
    for j in np.flatnonzero(unknown):
        where = " (on its bound)" if free[j] in at_bound else ""
        warnings.append(f"not identifiable: the predictions do not depend on {free[j]} at {estimate[j]:.4g} {unit[free[j]]}{where} "
                        f"(a 100 % change of it moves the residuals by less than {math.sqrt(floor):.0e} of their standard deviations), "
                        "so these data do not determine it")
        if not direction:
            direction = {free[i]: float(i == j) for i in range(k)}
    rest = np.flatnonzero(~unknown)
    if len(rest) > 1:
        w, V = np.linalg.eigh(Frel[np.ix_(rest, rest)])
        sub_ratio = float(max(w[0], 0.0) / w[-1])
        null = V[:, w < max(tol * w[-1], absolute)]
        for c in range(null.shape[1]):
            rel = null[:, c] / null[np.argmax(np.abs(null[:, c])), c]
            full = np.zeros(k)
            full[rest] = rel
            if not direction:
                direction = {free[j]: float(full[j]) for j in range(k)}
            involved = np.abs(full) > 1e-2
            unknown |= involved
            names = [free[j] for j in range(k) if involved[j]]
            head = (f"not identifiable: the Fisher matrix is nearly singular (smallest / largest eigenvalue {floored(sub_ratio, '.2g', ROUNDOFF_RATIO)}, below {tol:g}, "
                    "relative parameter changes): ")
            if len(names) == 1:
                j = free.index(names[0])
                where = " (on its bound)" if names[0] in at_bound else ""
                warnings.append(head + f"the predictions hardly depend on {names[0]} at {estimate[j]:.4g} {unit[names[0]]}{where}, "
                                "so these data do not determine it")
                continue
            combo = ", ".join(f"d{free[j]}/{free[j]} = {full[j]:+.3g}" for j in range(k) if involved[j])
            warnings.append(head + f"the data do not separate {' and '.join(names)}; changing them together as {combo} "
                            "leaves every prediction unchanged to first order")
    identifiable = not bool(np.any(unknown))
    for name in at_bound:
        warnings.append(f"{name} ended on its bound ({estimate[free.index(name)]:.4g} {unit[name]}): the fit would take it further; "
                        "its interval is not meaningful")
    return identifiable, ratio, unknown, warnings, direction


def fisher_correlation(F: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """The correlation matrix of the parameters from their Fisher matrix ``F`` (pseudo-inverse of the
    one of relative changes, ``scale`` each parameter's size): defined even where F is singular,
    +-1 along a direction the data do not determine. The load estimate uses it too.

    >>> fisher_correlation(np.array([[2.0, 1.0], [1.0, 2.0]]), np.ones(2)).round(4).tolist()
    [[1.0, -0.5], [-0.5, 1.0]]
    >>> fisher_correlation(np.array([[1.0, 1.0], [1.0, 1.0]]), np.ones(2)).round(9).tolist()  # a trade-off
    [[1.0, 1.0], [1.0, 1.0]]
    """
    Finv = np.linalg.pinv(scale[:, None] * F * scale[None, :])
    d = np.sqrt(np.abs(np.diag(Finv)))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = Finv / np.outer(d, d)
    np.fill_diagonal(corr, 1.0)
    return corr


def _statistics(J: np.ndarray, r: np.ndarray, free: tuple[str, ...], scale: np.ndarray, estimate: np.ndarray, at_bound: list[str],
                all_sd_given: bool, options: FitOptions) -> dict:
    """Fisher matrix, covariance, standard errors, intervals, correlation and identifiability."""
    m, k = J.shape
    F = J.T @ J
    dof = m - k
    identifiable, ratio, unknown, warnings, _ = identifiability_rule(F, m, free, scale, estimate, at_bound, options.identifiability_tol,
                                                                 options.identifiability_floor)
    rss = float(r @ r)
    s2 = rss / dof if dof > 0 else math.nan
    cov = np.full((k, k), np.nan)
    quantile = math.nan
    if dof > 0:
        quantile = float(stats.t.ppf(0.5 + options.level / 2, dof))
        scale2 = s2
    elif all_sd_given:
        quantile = float(stats.norm.ppf(0.5 + options.level / 2))
        scale2 = 1.0
        warnings.append(f"no degrees of freedom left ({m} measured values for {k} parameters): the intervals use the stated standard deviations unscaled")
    else:
        scale2 = math.nan
        warnings.append(f"no degrees of freedom left ({m} measured values for {k} parameters) and no stated standard deviations: no intervals")
    known = ~unknown
    if np.any(known) and math.isfinite(scale2):
        # the determined parameters, with the undetermined ones held where they are
        cov[np.ix_(known, known)] = scale2 * np.linalg.inv(F[np.ix_(known, known)])
    se = np.sqrt(np.where(np.isfinite(np.diag(cov)), np.maximum(np.diag(cov), 0.0), np.nan))
    interval = np.column_stack([estimate - quantile * se, estimate + quantile * se])
    corr = fisher_correlation(F, scale)
    if identifiable:
        for a in range(k):
            for c in range(a + 1, k):
                if abs(corr[a, c]) > 0.99:
                    warnings.append(f"{free[a]} and {free[c]} are strongly correlated ({corr[a, c]:+.4f}): the data determine them mostly together")
    return {"fisher": F, "dof": dof, "s2": s2, "cov": cov, "se": se, "interval": interval, "corr": corr,
            "identifiable": identifiable, "ratio": ratio, "warnings": warnings}


def fit(data: MeasurementSet, free: Sequence[str] = DEFAULT_FREE, options: FitOptions | None = None,
        solver_options: SolverOptions | None = None) -> FitResult:
    """Fit free actuator parameters to measurements (see the module docstring).

    Parameters
    ----------
    data : MeasurementSet
        From :func:`esba.calibration.measurements.load_measurements`; its base scene gives the start values.
    free : sequence of str
        Parameters to fit (default E and rho), from :data:`FITTABLE`.
    options : FitOptions, optional
    solver_options : SolverOptions, optional
        Settings of the load-path solves (start and check).

    Raises
    ------
    FitError
        for bad free parameters.
    MeasurementError
        for a row that cannot be solved at the start values (naming the row), before the fit.
    """
    options = FitOptions() if options is None else options
    solver_options = STEP_OPTIONS if solver_options is None else solver_options
    if not isinstance(options, FitOptions) or not isinstance(solver_options, SolverOptions):
        raise FitError("fit(data, free, options, solver_options): expected FitOptions and SolverOptions")
    if not isinstance(data, MeasurementSet):
        raise FitError(f"data={data!r}: expected a MeasurementSet (esba.calibration.measurements.load_measurements)")
    free = check_free(data, free)
    start, scale = _scale(data, free)
    # every row at the start values, along its load path: the NLP's start, and a check of the row
    starts = []
    for m in data.rows:
        theta_l, theta_u, why = _states(m, m.scene, solver_options)
        if why:
            raise MeasurementError(f"{m.where}: the row cannot be solved at the starting parameters ({m.scene.describe()}): {why}")
        starts.append((theta_l, theta_u))
    t0 = time.perf_counter()
    nlp = _fit_nlp(data, free, options)
    x0 = {"z": start / scale}
    for i, (tl, tu) in enumerate(starts):
        x0[f"theta_l{i}"] = tl
        if tu is not None:
            x0[f"theta_u{i}"] = tu
    measured = [m.values[q] for m in data.rows for q in QUANTITIES if q in m.values]
    sds = [m.sds.get(q, DEFAULT_SD[q]) for m in data.rows for q in QUANTITIES if q in m.values]
    sol = nlp.built.solve(nlp.built.x0(**x0), nlp.built.p(measured=measured, weight=1.0 / np.asarray(sds)))
    elapsed = time.perf_counter() - t0
    z = np.clip(sol["z"], nlp.built.lbx[nlp.built.slices["z"]], nlp.built.ubx[nlp.built.slices["z"]])
    estimate = scale * z
    # predictions, the Jacobian of the weighted residuals, and the checks of every state
    residuals, J_rows, r_rows, row_checks = [], [], [], []
    messages = [] if sol.success else [f"IPOPT did not converge: {sol.status}"]
    for i, (m, row) in enumerate(zip(data.rows, nlp.rows)):
        tl = sol[f"theta_l{i}"]
        tu = sol[f"theta_u{i}"] if row.theta_u is not None else None
        y, dy_dz, _ = row.evaluate(z, tl, tu)
        dy = dy_dz / scale[None, :]
        for q, yq, dq in zip(row.quantities, y, dy):
            sd = m.sds.get(q, DEFAULT_SD[q])
            meas = m.values[q]
            residuals.append({"row": m.label, "quantity": q, "unit": QUANTITIES[q], "measured": meas, "predicted": float(yq),
                              "sd": sd, "sd_given": q in m.sds, "residual": float(yq - meas), "normalised": float((yq - meas) / sd)})
            J_rows.append(dq / sd)
            r_rows.append((yq - meas) / sd)
        row_checks.append(_check_row(m, row, free, estimate, tl, tu, solver_options, options))
    bad = [r for r in row_checks if not (r["stable"] and r["on_load_path"])]
    for r in bad:
        messages.append(f"row {r['row']!r}: {r['message']}")
    lbz, ubz = nlp.built.lbx[nlp.built.slices["z"]], nlp.built.ubx[nlp.built.slices["z"]]
    at_bound = [n for n, zz, lo, hi in zip(free, z, lbz, ubz)
                if (math.isfinite(lo) and zz <= lo + 1e-5 * max(1.0, abs(lo))) or (math.isfinite(hi) and zz >= hi - 1e-5 * max(1.0, abs(hi)))]
    st = _statistics(np.array(J_rows), np.array(r_rows), free, scale, estimate, at_bound, all(d["sd_given"] for d in residuals), options)
    for r in row_checks:
        st["warnings"] += [f"row {r['row']!r} is outside the model's range at the fitted parameters: {v}" for v in r["validity"]]
        st["warnings"] += [f"row {r['row']!r}: at the fitted parameters {v}; the row is compared with the state after the jump"
                           for v in r["snaps"]]
    if messages:  # not a minimum of the fit, or not a state the data describe: its curvature means nothing
        for key in ("se", "interval", "cov"):
            st[key] = np.full_like(st[key], np.nan)
        st["warnings"].append("no standard errors or intervals: the fit failed (see its message)")
    return FitResult(
        data=data, free=free, units=tuple(UNITS[n] for n in free), level=options.level, start=start, estimate=estimate,
        std_error=st["se"], interval=st["interval"], covariance=st["cov"], correlation=st["corr"], fisher=st["fisher"],
        residual_variance=st["s2"], dof=st["dof"], residuals=tuple(residuals), rows=tuple(row_checks),
        identifiable=st["identifiable"], fisher_ratio=st["ratio"], warnings=tuple(st["warnings"]),
        status="ok" if not messages else "failed", message="; ".join(messages), iterations=sol.iterations, solve_time_s=elapsed,
    )


def _check_row(m: Measurement, row: _Row, free: tuple[str, ...], p: np.ndarray, theta_l: np.ndarray, theta_u: np.ndarray | None,
               solver_options: SolverOptions, options: FitOptions) -> dict:
    """Is the fitted state a stable minimum, and the one the load path reaches?"""
    out = {"row": m.label, "stable": False, "min_eigenvalue": math.nan, "on_load_path": False, "message": "", "validity": [],
           "snaps": []}
    try:
        scene = _fitted_scene(m, free, p)
    except SceneError as exc:
        out["message"] = f"the fitted parameters are outside the scene's rules: {exc}"
        return out
    model = scene.model()
    try:
        pressure = _pressure(scene)  # both states of a stiffness row share the row's pressure
    except EquilibriumError as exc:
        out["message"] = str(exc)
        return out
    states = [(theta_l, scene)]
    if theta_u is not None:
        states.append((theta_u, row.unloaded_scene(scene)))
    eig_min, stable = math.inf, True
    findings: dict[str, str] = {}
    for theta, sc in states:
        ev = np.linalg.eigvalsh(model.hessian(theta, model.param_vector(sc.parameters(pressure))))
        eig_min = min(eig_min, float(ev[0]))
        stable &= stability_verdict(ev, solver_options.critical_tol) == "stable"
        for f in assess_angles(sc, theta, pressure):
            findings.setdefault(f.check, f.message)
    out["validity"] = list(findings.values())
    out["stable"], out["min_eigenvalue"] = bool(stable), eig_min
    theta_path, theta_u_path, why, snaps = _states_and_snaps(m, scene, solver_options)
    out["snaps"] = snaps
    if why:
        out["message"] = f"the load-path solve at the fitted parameters is not ok: {why}"
        return out
    gap = float(np.max(np.abs(theta_path - theta_l)))
    if theta_u is not None and theta_u_path is not None:
        gap = max(gap, float(np.max(np.abs(theta_u_path - theta_u))))
    out["on_load_path"] = gap <= options.load_path_tol
    if not stable:
        out["message"] = f"the fitted state is not a stable minimum (smallest Hessian eigenvalue {eig_min:.3g} N mm/rad^2)"
    elif not out["on_load_path"]:
        out["message"] = f"the fitted state is {gap:.3g} rad from the one the load path reaches at the fitted parameters"
    return out


def _pressure(scene: Scene) -> float:
    from esba.statics.equilibrium import pressure_for_angle

    return scene.pressure if scene.pressure is not None else pressure_for_angle(scene)


# ---------------------------------------------------------------------------------------------
# predictions with their uncertainty (held-out rows, the experiments page)


@dataclass(frozen=True)
class Prediction:
    """A model prediction of one measured value, with its propagated uncertainty.

    ``sd`` is the first-order standard deviation from the parameters' covariance (NaN without
    one); ``ok`` says the row was solved to a stable equilibrium.
    """

    row: str
    quantity: str
    unit: str
    measured: float
    predicted: float
    sd: float
    ok: bool
    message: str = ""

    @property
    def error(self) -> float:
        """predicted - measured."""
        return self.predicted - self.measured

    def to_dict(self) -> dict:
        """JSON-ready form."""
        return jsonsafe.clean(dataclasses.asdict(self) | {"error": self.error})


_ROW_FUNCTIONS: dict[tuple, _Row] = {}


def predict(data: MeasurementSet, params: dict[str, float] | None = None, covariance: np.ndarray | None = None,
            solver_options: SolverOptions | None = None) -> tuple[Prediction, ...]:
    """Every measured value of ``data`` as the model predicts it at ``params``, with sd from ``covariance``.

    Parameters
    ----------
    data : MeasurementSet
    params : dict, optional
        Actuator parameters (scene-file units) that replace the file's (rows' own values stay).
    covariance : ndarray, optional
        Covariance of ``params`` (in the order given): propagated to first order through the
        implicit-function-theorem Jacobian of each prediction.
    """
    if not isinstance(data, MeasurementSet):
        raise FitError(f"data={checks.quote(data)}: expected a MeasurementSet (esba.calibration.measurements.load_measurements)")
    if params is not None and not isinstance(params, dict):
        raise FitError(f"params={checks.quote(params)}: expected a dict of parameter values, such as {{'E': 0.54}}")
    params = {} if params is None else dict(params)
    free = check_free(data, list(params)) if params else ()
    for name in free:
        checks.finite(name, params[name], FitError)
    if covariance is not None:
        if not free:
            raise FitError("covariance given without params: it is the covariance of the params given")
        covariance = checks.covariance("covariance", covariance, len(free), FitError)  # a negative variance is refused
    usable = covariance is not None and bool(np.all(np.isfinite(covariance)))
    out = []
    for m, quantities, y, dy, why in _rows_at(data, free, np.array([params[n] for n in free], dtype=float), solver_options):
        for j, q in enumerate(quantities):
            if why:
                out.append(Prediction(m.label, q, QUANTITIES[q], m.values[q], math.nan, math.nan, False, why))
                continue
            sd = math.sqrt(max(float(dy[j] @ covariance @ dy[j]), 0.0)) if usable else math.nan
            out.append(Prediction(m.label, q, QUANTITIES[q], m.values[q], float(y[j]), sd, True))
    return tuple(out)


def _rows_at(data: MeasurementSet, free: tuple[str, ...], p: np.ndarray, solver_options: SolverOptions | None):
    """Per row: (measurement, quantities, predictions, d predictions / dp, why not solved)."""
    solver_options = STEP_OPTIONS if solver_options is None else solver_options
    for m in data.rows:
        quantities = tuple(q for q in QUANTITIES if q in m.values)
        try:
            scene = _fitted_scene(m, free, p) if free else m.scene
        except SceneError as exc:
            yield m, quantities, None, None, str(exc)
            continue
        theta_l, theta_u, why = _states(m, scene, solver_options)
        if why:
            yield m, quantities, None, None, why
            continue
        key = (m.scene, quantities, m.own, free)
        row = _ROW_FUNCTIONS.get(key)
        if row is None:
            n = m.scene.segments
            z = ca.SX.sym("z", len(free))
            row = _remember(_ROW_FUNCTIONS, key, _Row(m, free, z, np.ones(len(free)), ca.SX.sym("theta_l", n),
                                                      ca.SX.sym("theta_u", n) if "stiffness" in m.values else None))
        y, dy, _ = row.evaluate(p, theta_l, theta_u)
        yield m, quantities, y, dy, ""


@dataclass(frozen=True)
class Identifiability:
    """Whether measurements like these can determine the free parameters, before any fit.

    Attributes
    ----------
    free : tuple of str
    at : dict
        The parameter values where the Fisher matrix was evaluated.
    fisher : ndarray
        J^T J of the residuals weighted by the rows' standard deviations.
    ratio : float
        Smallest over largest eigenvalue of the Fisher matrix of relative parameter changes.
    identifiable : bool
    warnings : tuple of str
    direction : dict
        Where not identifiable: the relative changes {name: dp/p} (largest 1) that leave every
        prediction unchanged to first order.
    """

    free: tuple[str, ...]
    at: dict
    fisher: np.ndarray
    ratio: float
    identifiable: bool
    warnings: tuple[str, ...]
    direction: dict


def identifiability(data: MeasurementSet, free: Sequence[str] = DEFAULT_FREE, params: dict[str, float] | None = None,
                    options: FitOptions | None = None) -> Identifiability:
    """The Fisher matrix of ``data``'s rows at ``params`` (default: the file's) and what it cannot determine.

    Only the layout of the data matters (which rows, which quantities, their standard deviations),
    not the measured values: this says whether an experiment can determine the parameters.

    >>> from esba.calibration.measurements import measurements_from_rows
    >>> bends = measurements_from_rows("bends", [("a", {"pressure_mpa": 0.1, "total_angle_deg": 60}),
    ...                                          ("b", {"pressure_mpa": 0.2, "total_angle_deg": 170})])
    >>> identifiability(bends).identifiable
    False
    """
    options = FitOptions() if options is None else options
    free = check_free(data, free)
    start, scale = _scale(data, free)
    p = start if params is None else np.array([params.get(n, s) for n, s in zip(free, start)], dtype=float)
    rows = []
    for m, quantities, y, dy, why in _rows_at(data, free, p, None):
        if why:
            raise MeasurementError(f"{m.where}: the row cannot be solved at {dict(zip(free, p))}: {why}")
        for j, q in enumerate(quantities):
            rows.append(dy[j] / m.sds.get(q, DEFAULT_SD[q]))
    F = np.array(rows).T @ np.array(rows)
    ok, ratio, _, warnings, direction = identifiability_rule(F, len(rows), free, scale, p, [], options.identifiability_tol, options.identifiability_floor)
    return Identifiability(free, dict(zip(free, map(float, p))), F, ratio, ok, tuple(warnings), direction)


def fit_table(d: dict) -> str:
    """The text ``esba fit`` prints for :meth:`FitResult.to_dict` (and the ``figure`` the command adds)."""

    def num(v, fmt=".5g"):
        return "-" if v is None else format(v, fmt)

    level = round(100 * d["level"])
    lines = [
        f"fit of {', '.join(d['parameters'])} to {d['measurements']} measured values in {d['rows']} rows of {d['source']}; "
        f"n = {d['segments']}, {d['variant']}",
        f"status: {d['status']}" + (f": {d['message']}" if d["message"] else ": every fitted state a stable minimum on its load path")
        + f" (IPOPT {d['iterations']} iterations, {d['solve_time_s']:.2f} s)",
        f"{'parameter':<10} {'unit':<5} {'start':>10} {'estimate':>12} {'std error':>11} {level} % interval",
    ]
    for name, p in d["parameters"].items():
        iv = p[f"interval_{level}"]
        lines.append(f"{name:<10} {p['unit']:<5} {num(p['start']):>10} {num(p['estimate'], '.6g'):>12} {num(p['std_error'], '.3g'):>11} "
                     f"[{num(iv[0], '.5g')}, {num(iv[1], '.5g')}]")
    names = list(d["parameters"])
    if len(names) > 1:
        pairs = [f"{a}-{b} {num(d['correlation'][i][j], '+.3f')}" for i, a in enumerate(names) for j, b in enumerate(names) if j > i]
        lines.append("correlation: " + ", ".join(pairs))
    if d["dof"] > 0:
        lines.append(f"residual variance s^2 = {num(d['residual_variance'], '.4g')} ({d['dof']} degrees of freedom; "
                     "standard errors scaled by it)")
    else:
        lines.append(f"no residual variance: {d['measurements']} measured values for {len(d['parameters'])} parameters leave no degrees of freedom")
    lines.append(f"{'row':<22} {'quantity':<12} {'unit':<5} {'measured':>10} {'predicted':>10} {'residual':>10} {'sd':>7} {'r / sd':>7}")
    for r in d["residuals"]:
        sd = f"{r['sd']:.3g}" + ("" if r["sd_given"] else "*")
        lines.append(f"{r['row'][:22]:<22} {r['quantity']:<12} {r['unit']:<5} {r['measured']:>10.4g} {r['predicted']:>10.4g} "
                     f"{r['residual']:>+10.3g} {sd:>7} {r['normalised']:>+7.2f}")
    if any(not r["sd_given"] for r in d["residuals"]):
        lines.append("* no standard deviation given: 1 deg, 1 mm or 1 N/m assumed (only their ratios matter once scaled by s^2)")
    for s in d["states"]:
        if s["message"]:
            lines.append(f"NOT OK: row {s['row']!r}: {s['message']}")
    for w in d["warnings"]:
        lines.append(f"WARNING: {w}")
    if d.get("figure"):
        lines.append(f"wrote {d['figure']}")
    return "\n".join(lines)

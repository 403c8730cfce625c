"""The actuator as a force sensor: the payload estimated from the measured shape, with its uncertainty.

A finger that holds an object bends under its weight, so the shape it takes at a known pressure
measures the load ("intrinsic" or deflection-based force sensing of continuum robots).

**The estimate.** Weighted least squares over the unknown loads z (any of each payload's magnitude
F, direction Omega and point s, in scene-file units: N, deg, fraction of L),

    minimise 1/2 sum_i ((y_i(theta(z)) - m_i) / sd_i)^2,   with   dU/dtheta (theta(z), z) = 0,

over every pose (a pressure and what was measured there: segment angles, the total angle, the tip
position, or the position of a marker at a fraction of L, each with its standard deviation). Poses
that name the same load share its unknowns: a known object lifted at several pressures.
The state theta(z) is an equilibrium of the generated model, followed from the current one by
Newton on the generated gradient and Hessian with the first-order predictor
theta + dtheta/dz dz (the implicit function theorem, dtheta/dz = -H^-1 dG/dz, CasADi AD), so the
Levenberg-Marquardt iteration in z stays on the branch the data chose; a step whose Newton does not
converge, or whose state changes stability (a fold in between), is refused and shortened.

**The starts.** A shape can have been reached by more than one history, and a load can hold more
than one shape. The iteration therefore runs from several loads (``starts``: magnitudes up to
``max_force`` and directions all round, and the scene's own payload), each from the state the
load history (inflate, then load) reaches at that load. Then, at each start load and each load
found, every other stable state of that load (:func:`esba.statics.equilibria.equilibria`, deflated
Newton) starts it again: a load that explains the data on a branch no load history reaches is found
too. Each pose's states at such a load are ranked by how well each alone explains that pose, and
run r starts every pose from its r-th best, so the runs are one per rank, not one per pose and
state (the work stays linear in the poses). The list of starts decides what is found, not round-off: runs whose residual sums agree to
:data:`CHI2_RESOLUTION` keep the order of their starts (the first is the estimate).

**Unique?** Every distinct load whose weighted residual sum lies within the ``level`` quantile of
chi-square with k degrees of freedom (k unknowns) of the best one explains the data equally well
within the noise: all of them are listed, and the estimate is called unique only when there is
one.

**The uncertainty.** J, the Jacobian of the weighted residuals in z, gives the Fisher matrix
F = J^T J and the covariance F^-1 (the stated standard deviations are taken as they are: with
typically one or two measured values more than unknowns, scaling by the residual variance as
:mod:`esba.calibration.fit` does would make the intervals very uncertain themselves; the residual
chi-square and its p-value say whether the stated deviations fit). Intervals are
``estimate +- z_{level} * std_error``. Actuator parameters carried with a covariance (for example
a fit's E and rho) add A Sigma_p A^T to the measurement covariance (A = dy/dp at the state), and
the residuals are whitened by it (generalised least squares, linearised).

**Identifiability.** The rule of :func:`esba.calibration.fit.identifiability_rule` on F: a direction
of the loads that does not move the predictions is reported in words, for example "the data do not
separate the payload's magnitude and direction" for a tip load seen only through the total angle.

**Checks.** Each pose's state must be a stable equilibrium (else the estimate is flagged
``unstable``: the actuator cannot hold that shape) inside the model's range
(:mod:`esba.model.validity`); when the inflate-then-load history at the estimated load reaches a
different state, the result says so (the shape is then another stable state of that load).

Examples
--------
>>> from esba.model.scene import Scene, Payload
>>> scene = Scene(pressure=0.15, payloads=(Payload(1.0, 60.0),))
>>> from esba.statics.equilibrium import solve
>>> theta = [round(float(t), 4) for t in solve(scene).theta_deg]
>>> theta
[17.6024, 25.7773, 34.9497]
>>> pose = Pose(0.15, (Measured("theta", tuple(theta), 0.05),))
>>> r = estimate_load([pose], ("F1", "Omega1"), base=scene.replace(payloads=(Payload(0.5, 0.0),)))
>>> r.ok, r.unique, [round(float(v), 3) for v in r.estimate], [round(float(v), 3) for v in r.std_error]
(True, True, [1.0, 60.0], [0.004, 0.861])
"""

from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass, field
from typing import Any, Sequence

import casadi as ca
import numpy as np
from scipy import stats

from esba.analysis.sensitivity import implicit_functions, model_values, parameter_names, scene_parameters, with_parameters
from esba.calibration.fit import fisher_correlation, identifiability_rule
from esba.infra import checks, jsonsafe
from esba.infra.errors import InputError
from esba.infra.report import Report
from esba.infra.threads import single_threaded
from esba.model import resolution
from esba.model.generated import Model, near_domain_bound
from esba.model.scene import Payload, Scene, SceneError
from esba.model.validity import assess
from esba.statics.equilibria import EquilibriaOptions, equilibria
from esba.statics.equilibrium import DEFAULT_OPTIONS, STEP_OPTIONS, EquilibriumError, solve

__all__ = [
    "SensingError",
    "MISFIT_P",
    "Measured",
    "Pose",
    "SensingOptions",
    "Candidate",
    "LoadEstimate",
    "Information",
    "KINDS",
    "LOAD_KINDS",
    "free_names",
    "estimate_load",
    "information",
    "predict_pose",
]

#: What can be measured: kind -> (values per measurement, unit).
KINDS = {"theta": (None, "deg"), "total_angle": (1, "deg"), "tip": (2, "mm"), "marker": (2, "mm")}

#: The load unknowns of payload k: F{k} (N), Omega{k} (deg), s{k} (fraction of L); on the command
#: line ``force``, ``angle`` and ``at`` name those of payload 1.
LOAD_KINDS = {"F": ("N", "force"), "Omega": ("deg", "angle"), "s": ("1", "at")}

_ALIASES = {"force": "F", "angle": "Omega", "at": "s"}
#: A load unknown's name: its kind and payload number (ASCII digits, no leading zero).
_FREE = re.compile(r"(F|Omega|s)([1-9][0-9]{0,2})")

#: The pose's pressure (MPa) and unloaded target angle (deg) allowed, as in a pose file.
MAX_PRESSURE = 10.0
MAX_TARGET_DEG = 720.0

#: Carried actuator parameters that may have a covariance.
ACTUATOR = ("L", "r1", "r2", "d", "rho", "E", "M")


#: A fit whose chi-square has a p-value below this explains nothing: no load reproduces the data
#: within the stated standard deviations (status ``misfit``, not ``ok``).
MISFIT_P = 1e-3


class SensingError(InputError):
    """Bad input to the load estimate (exit 2 on the command line)."""


def _quote(value: Any, limit: int = 60) -> str:
    """``repr(value)``, cut to ``limit`` characters: a message quotes what it was given, briefly."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


# ---------------------------------------------------------------------------------------------
# what was measured


@dataclass(frozen=True)
class Measured:
    """One measured quantity of a pose, with its standard deviation.

    Parameters
    ----------
    kind : str
        ``theta`` (every segment angle, deg), ``total_angle`` (deg), ``tip`` (x, y in mm; x down
        the base's axis, y horizontal) or ``marker`` (x, y in mm of the point at fraction ``at``
        of L along the centre-line).
    values : tuple of float
    sd : float
        Standard deviation of each value (deg or mm), > 0.
    at : float, optional
        The marker's fraction of L, 0 < at <= 1 (markers only).

    >>> Measured("tip", (120.0,), 1.0)
    Traceback (most recent call last):
    ...
    esba.calibration.sensing.SensingError: tip=(120.0,): expected 2 values (x, y in mm)
    """

    kind: str
    values: tuple[float, ...]
    sd: float
    at: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.kind, str) or self.kind not in KINDS:
            raise SensingError(f"measured kind {_quote(self.kind)}: allowed are {', '.join(KINDS)}")
        count, unit = KINDS[self.kind]
        values = self.values if isinstance(self.values, (tuple, list, np.ndarray)) else (self.values,)
        values = tuple(checks.finite(self.kind, v, SensingError) for v in values)
        if count is not None and len(values) != count:
            what = "value" if count == 1 else "values (x, y in mm)"
            raise SensingError(f"{self.kind}={_quote(self.values)}: expected {count} {what}")
        if not values:
            raise SensingError(f"{self.kind}: expected at least one value")
        limit = 1e4 if unit == "deg" else 1e5
        for v in values:
            if abs(v) > limit:
                raise SensingError(f"{self.kind}={v:g} {unit}: expected |value| <= {limit:g} {unit}")
        object.__setattr__(self, "values", values)
        sd = checks.finite(f"{self.kind} sd", self.sd, SensingError)
        if not 1e-9 <= sd <= 1e4:
            raise SensingError(f"{self.kind} sd={sd:g} {unit}: expected a standard deviation with 1e-9 <= sd <= 1e4 {unit}")
        object.__setattr__(self, "sd", sd)
        if self.kind == "marker":
            at = checks.finite("marker at", self.at, SensingError) if self.at is not None else math.nan
            if not 0.0 < at <= 1.0:
                raise SensingError(f"marker at={self.at!r}: expected a fraction of the length with 0 < at <= 1")
            object.__setattr__(self, "at", at)
        elif self.at is not None:
            raise SensingError(f"{self.kind}: only a marker has a point (at={self.at!r})")

    @property
    def unit(self) -> str:
        return KINDS[self.kind][1]

    @property
    def label(self) -> str:
        return f"marker at {self.at:g} L" if self.kind == "marker" else self.kind.replace("_", " ")

    def quantities(self) -> list[str]:
        """One name per value (``theta1``, ``tip_x``, ``marker0.5_y``)."""
        if self.kind == "theta":
            return [f"theta{i + 1}" for i in range(len(self.values))]
        if self.kind == "total_angle":
            return ["total_angle"]
        head = "tip" if self.kind == "tip" else f"marker{self.at:g}"
        return [f"{head}_x", f"{head}_y"]


@dataclass(frozen=True)
class Pose:
    """One pose: the pressure it was held at and what was measured there.

    Parameters
    ----------
    pressure : float or None
        MPa; or None with ``target_angle_deg``, the unloaded bend that sets it (closed form).
    measured : tuple of Measured
    load : str
        Which load the pose holds: poses with the same name share its unknowns (one object lifted at
        several pressures); different names are estimated separately, in one run.
    label : str
        How the output names the pose.
    target_angle_deg : float, optional
    """

    pressure: float | None
    measured: tuple[Measured, ...]
    load: str = "load"
    label: str = ""
    target_angle_deg: float | None = None

    def __post_init__(self) -> None:
        where = self.label or "pose"
        if self.pressure is None and self.target_angle_deg is None:
            raise SensingError(f"{where}: give its pressure (MPa) or the unloaded target angle that sets it")
        if self.pressure is not None and self.target_angle_deg is not None:
            raise SensingError(f"{where}: pressure={self.pressure!r} and target_angle_deg={self.target_angle_deg!r}: give one of the two")
        if self.pressure is not None:
            p = checks.finite(f"{where}: pressure", self.pressure, SensingError)
            if not 0.0 <= p <= MAX_PRESSURE:
                raise SensingError(f"{where}: pressure={p:g} MPa: expected a pressure from 0 to {MAX_PRESSURE:g} MPa")
        else:
            t = checks.finite(f"{where}: target_angle_deg", self.target_angle_deg, SensingError)
            if not 0.0 < t <= MAX_TARGET_DEG:
                raise SensingError(f"{where}: target_angle_deg={t:g}: expected an angle with 0 < angle <= {MAX_TARGET_DEG:g} deg")
        measured = tuple(self.measured) if isinstance(self.measured, (tuple, list)) else (self.measured,)
        if not measured or not all(isinstance(m, Measured) for m in measured):
            raise SensingError(f"{where}: measured={_quote(self.measured)}: expected one or more Measured")
        object.__setattr__(self, "measured", measured)
        if not isinstance(self.load, str) or not self.load.strip():
            raise SensingError(f"{where}: load={_quote(self.load)}: expected a non-empty name")

    def scene(self, base: Scene) -> Scene:
        """``base`` at this pose's pressure (validated like any scene)."""
        if self.pressure is not None:
            return base.replace(pressure=self.pressure)
        return base.replace(target_angle_deg=self.target_angle_deg)

    def count(self) -> int:
        return sum(len(m.values) for m in self.measured)


# ---------------------------------------------------------------------------------------------
# options and results


@dataclass(frozen=True)
class SensingOptions:
    """Settings of :func:`estimate_load`, validated on creation.

    Parameters
    ----------
    level : float
        Confidence level of the intervals and of "explains the data equally well" (0 < level < 1).
    starts : int
        Number of start loads besides the scene's own (magnitudes ``max_force`` x (0.1, 0.4, 0.8),
        directions spread all round); 0 starts only from the scene's payload.
    max_force : float
        The largest magnitude a start takes, N (the estimate itself is not bounded by it).
    branches : bool
        Also start from every other stable state of each load found (the equilibria search).
    max_iterations : int
        Levenberg-Marquardt iterations per start.
    tol : float
        Stop when a step changes no unknown by more than ``tol`` relative to its scale.
    identifiability_tol, identifiability_floor : float
        As in :class:`esba.calibration.fit.FitOptions`.
    """

    level: float = 0.95
    starts: int = 12
    max_force: float = 4.0
    branches: bool = True
    max_iterations: int = 100
    tol: float = 1e-10
    identifiability_tol: float = 1e-6
    identifiability_floor: float = 1e-12

    def __post_init__(self) -> None:
        level = checks.finite("level", self.level, SensingError)
        if not 0.0 < level < 1.0:
            raise SensingError(f"level={self.level!r}: expected a confidence level between 0 and 1 (0.95 for 95 %)")
        for name, low, high in (("starts", 0, 200), ("max_iterations", 1, 10_000)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not low <= v <= high:
                raise SensingError(f"{name}={v!r}: expected an integer from {low} to {high}")
        f = checks.finite("max_force", self.max_force, SensingError)
        if not 0.0 < f <= 1e3:
            raise SensingError(f"max_force={self.max_force!r}: expected a magnitude with 0 < max_force <= 1000 N")
        if not isinstance(self.branches, bool):
            raise SensingError(f"branches={self.branches!r}: expected True or False")
        for name in ("tol", "identifiability_tol", "identifiability_floor"):
            v = checks.finite(name, getattr(self, name), SensingError)
            if not 0.0 < v < 1.0:
                raise SensingError(f"{name}={getattr(self, name)!r}: expected a number with 0 < {name} < 1")


@dataclass(frozen=True, eq=False)
class Candidate:
    """One load that explains the data: its unknowns, residual and each pose's state."""

    estimate: np.ndarray
    chi2: float
    states: tuple[np.ndarray, ...]
    stable: tuple[bool, ...]
    min_eigenvalue: tuple[float, ...]
    start: str

    def to_dict(self, labels: Sequence[str], poses: Sequence[Pose]) -> dict:
        return jsonsafe.clean({
            "estimate": dict(zip(labels, map(float, self.estimate))),
            "chi2": self.chi2,
            "states": [{"pose": p.label, "theta_deg": np.degrees(t).tolist(), "total_angle_deg": math.degrees(float(np.sum(t))),
                        "stable": s, "min_eigenvalue": e}
                       for p, t, s, e in zip(poses, self.states, self.stable, self.min_eigenvalue)],
            "found_from": self.start,
        })


@dataclass(frozen=True, eq=False, repr=False)
class LoadEstimate(Report):
    """The estimated loads, their uncertainty, the residuals, and whether they are unique.

    Attributes
    ----------
    labels, units : tuple of str
        The unknowns (``F1``, ``Omega1``, ``s1``; with several loads ``F1[name]``) and their units.
    estimate, std_error : ndarray
        std_error is NaN for an unknown the data do not determine.
    interval : ndarray, shape (k, 2)
    covariance, correlation : ndarray, shape (k, k)
    fisher : ndarray
        J^T J of the whitened residuals.
    identifiable : bool
    undetermined : tuple of str
        In words, which directions of the load the data cannot see.
    unique : bool
        No other load explains the data within the noise.
    alternatives : tuple of Candidate
        Every distinct load that explains the data within the noise, best first (the estimate is the first).
    chi2, dof, p_value : float, int, float
        The residual sum of squares (whitened), its degrees of freedom and the chance of one as large.
    residuals : tuple of dict
        Per measured value: pose, quantity, unit, measured, predicted, sd, residual / sd.
    states : tuple of dict
        Per pose: theta (deg), total angle, tip, stable, smallest eigenvalue, on the load history, validity.
    status : str
        ``ok``; ``unstable`` (a pose's state is not stable); ``misfit`` (no load explains the data:
        the chi-square's p-value is below :data:`MISFIT_P`, or with no degrees of freedom left, the
        chi-square is above its 1 - MISFIT_P quantile on one); ``failed`` (no start converged).
    warnings : tuple of str
    """

    labels: tuple[str, ...]
    units: tuple[str, ...]
    level: float
    estimate: np.ndarray
    std_error: np.ndarray
    interval: np.ndarray
    covariance: np.ndarray
    correlation: np.ndarray
    fisher: np.ndarray
    identifiable: bool
    undetermined: tuple[str, ...]
    unique: bool
    alternatives: tuple[Candidate, ...]
    chi2: float
    dof: int
    p_value: float
    residuals: tuple[dict, ...]
    states: tuple[dict, ...]
    poses: tuple[Pose, ...] = field(repr=False)
    status: str
    message: str
    warnings: tuple[str, ...]
    starts: int
    iterations: int
    solve_time_s: float

    _plotter = "esba.figures.results:draw_load_estimate"

    def headline(self) -> str:
        """One line: the status and each unknown with its standard error."""
        est = ", ".join(f"{n} = {v:.4g} +- {se:.2g} {u}" if math.isfinite(se) else f"{n} = {v:.4g} {u} (not determined)"
                        for n, u, v, se in zip(self.labels, self.units, self.estimate, self.std_error))
        return f"{self.status}: {est}" + ("" if self.unique else "; not unique")

    def summary(self) -> str:
        """The text ``esba estimate`` prints for this estimate."""
        return estimate_table(self.to_dict())

    @property
    def ok(self) -> bool:
        """Converged, every state stable."""
        return self.status == "ok"

    def value(self, label: str) -> float:
        """The estimate of one unknown."""
        if label not in self.labels:
            raise SensingError(f"unknown {label!r}: allowed are {', '.join(self.labels)}")
        return float(self.estimate[self.labels.index(label)])

    def to_dict(self) -> dict:
        """JSON-ready form (``esba estimate --json``)."""
        key = f"interval_{round(100 * self.level)}"
        return jsonsafe.clean({
            "status": self.status,
            "message": self.message,
            "level": self.level,
            "unknowns": {lab: {"unit": u, "estimate": e, "std_error": se, key: list(iv)}
                         for lab, u, e, se, iv in zip(self.labels, self.units, self.estimate, self.std_error, self.interval)},
            "correlation": self.correlation.tolist(),
            "covariance": self.covariance.tolist(),
            "identifiable": self.identifiable,
            "undetermined": list(self.undetermined),
            "unique": self.unique,
            "alternatives": [c.to_dict(self.labels, self.poses) for c in self.alternatives],
            "chi2": self.chi2,
            "dof": self.dof,
            "p_value": self.p_value,
            "residuals": list(self.residuals),
            "states": list(self.states),
            "warnings": list(self.warnings),
            "starts": self.starts,
            "iterations": self.iterations,
            "solve_time_s": self.solve_time_s,
        })


# ---------------------------------------------------------------------------------------------
# the unknowns


def free_names(base: Scene, free: Sequence[str]) -> tuple[str, ...]:
    """The load unknowns as scene-parameter names (``force`` -> ``F1``); checked against ``base``'s payloads.

    >>> from esba.model.scene import Scene, Payload
    >>> free_names(Scene(payloads=(Payload(1.0),)), ["force", "angle"])
    ('F1', 'Omega1')
    >>> free_names(Scene(payloads=(Payload(1.0),)), ["E"])
    Traceback (most recent call last):
    ...
    esba.calibration.sensing.SensingError: free 'E': expected a load unknown: force, angle, at (payload 1) or F1, Omega1, s1 (payload k)
    """
    if isinstance(free, str):
        free = [s.strip() for s in free.split(",") if s.strip()]
    if not isinstance(free, (list, tuple)) or not free:
        raise SensingError(f"free={_quote(free)}: expected one or more of force, angle, at (or F1, Omega1, s1, ...)")
    out: list[str] = []
    count = max(len(base.payloads), 1)
    allowed = "force, angle, at (payload 1) or F1, Omega1, s1 (payload k)"
    for name in free:
        if not isinstance(name, str):
            raise SensingError(f"free {_quote(name)}: expected a name: {allowed}")
        name = _ALIASES[name] + "1" if name in _ALIASES else name
        match = _FREE.fullmatch(name)
        if match is None:
            raise SensingError(f"free {_quote(name)}: expected a load unknown: {allowed}")
        k = int(match.group(2))
        if not 1 <= k <= count:
            raise SensingError(f"free {name!r}: the scene has {count} payload{'s' if count > 1 else ''}; allowed payloads are 1 to {count}")
        if name in out:
            raise SensingError(f"free {name!r} is given twice")
        out.append(name)
    return tuple(out)


def _label(name: str, load: str, loads: Sequence[str]) -> str:
    return name if len(loads) == 1 else f"{name}[{load}]"


def _unit(name: str) -> str:
    return next(u for k, (u, _) in LOAD_KINDS.items() if name.startswith(k))


# ---------------------------------------------------------------------------------------------
# one pose: its model function and its equilibrium


def _layout(pose: Pose) -> tuple[tuple, ...]:
    return tuple(("marker", m.at) if m.kind == "marker" else (m.kind,) for m in pose.measured)


def _build(model: Model, names: tuple[str, ...], fixed_names: tuple[str, ...], layout: tuple[tuple, ...]) -> ca.Function:
    n = model.n
    th = ca.SX.sym("theta", n)
    p = ca.SX.sym("p", len(names))
    fx = ca.SX.sym("fixed", len(fixed_names))
    out = implicit_functions(model, names, fixed_names)(th, p, fx, ca.DM.zeros(n))
    G, H, G_p, tip = out[0], out[1], out[2], out[3]
    L = model_values(model, names, ca.vertsplit(p), dict(zip(fixed_names, ca.vertsplit(fx))))["L"]
    ys = []
    for item in layout:
        if item[0] == "theta":
            ys.append(th * (180.0 / math.pi))
        elif item[0] == "total_angle":
            ys.append(ca.sum1(th) * (180.0 / math.pi))
        elif item[0] == "tip":
            ys.append(tip)
        else:
            ys.append(model["centreline"](th, L, item[1])[:2])
    y = ca.vertcat(*ys)
    return ca.Function("esba_sensing", [th, p, fx], [G, H, G_p, y, ca.jacobian(y, th), ca.jacobian(y, p)],
                       ["theta", "p", "fixed"], ["G", "H", "G_p", "y", "y_theta", "y_p"])


class _PoseModel:
    """One pose's generated functions, its scene-parameter vector and its measured values."""

    def __init__(self, pose: Pose, scene: Scene, free: tuple[str, ...], carried: tuple[str, ...]):
        self.pose, self.scene = pose, scene
        self.model = scene.model()
        self.names = parameter_names(scene)
        self.fixed_names = tuple(k for k in self.model.parameters if k == "g" and "g" not in self.names)
        self.fixed = np.array([scene.g for _ in self.fixed_names])
        layout = _layout(pose)
        self.fun = self.model.derived("sensing", lambda: _build(self.model, self.names, self.fixed_names, layout),
                                      settings=(self.names, self.fixed_names, layout), persist=False)
        self.p0 = np.array([q.value for q in scene_parameters(scene)])
        self.free_idx = np.array([self.names.index(f) for f in free], dtype=int)
        self.carried_idx = np.array([self.names.index(c) for c in carried], dtype=int)
        self.measured = np.array([v for m in pose.measured for v in m.values])
        self.sd = np.array([m.sd for m in pose.measured for _ in m.values])
        self.quantities = [(m, q) for m in pose.measured for q in m.quantities()]
        full = scene.parameters(self.pressure)
        self.lbx = self.model.lower_bounds(full)

    @property
    def pressure(self) -> float:
        if self.scene.pressure is not None:
            return float(self.scene.pressure)
        from esba.model.closed_form import unloaded_pressure

        v = model_values(self.model, self.names, list(self.p0), dict(zip(self.fixed_names, self.fixed)))
        return float(unloaded_pressure(self.model, math.radians(self.scene.target_angle_deg), v))

    def params(self, z: np.ndarray) -> np.ndarray:
        p = self.p0.copy()
        p[self.free_idx] = z
        return p

    def call(self, theta: np.ndarray, p: np.ndarray) -> list[np.ndarray]:
        out = self.fun(theta, p, self.fixed)
        n, m = self.model.n, len(self.names)
        return [np.asarray(out[0], float).ravel(), np.asarray(out[1], float), np.asarray(out[2], float).reshape(n, m),
                np.asarray(out[3], float).ravel(), np.asarray(out[4], float).reshape(-1, n), np.asarray(out[5], float).reshape(-1, m)]

    def newton(self, theta: np.ndarray, p: np.ndarray, iterations: int = 40) -> np.ndarray | None:
        """The equilibrium next to ``theta`` at parameters ``p`` (any stability), or None."""
        theta = np.array(theta, dtype=float)
        for _ in range(iterations):
            G, H = self.call(theta, p)[:2]
            if not (np.all(np.isfinite(G)) and np.all(np.isfinite(H))):
                return None
            gnorm = float(np.max(np.abs(G)))
            if gnorm < 1e-9:
                return None if near_domain_bound(theta, self.lbx) else theta
            try:
                step = -np.linalg.solve(H, G)
            except np.linalg.LinAlgError:
                return None
            t = 1.0
            limit = float(np.max(np.abs(step)))
            if limit > 0.5:  # no Newton step turns a segment by more than ~30 deg
                t = 0.5 / limit
            while True:
                trial = theta + t * step
                if np.all(trial > self.lbx):
                    break
                t *= 0.5
                if t < 1e-6:
                    return None
            theta = trial
        G = self.call(theta, p)[0]
        return theta if float(np.max(np.abs(G))) < 1e-7 else None

    def misfit(self, theta: np.ndarray, p: np.ndarray) -> float:
        """The whitened residual sum of squares of this pose alone at the state ``theta`` (its own deviations)."""
        y = self.call(theta, p)[3]
        return float(np.sum(((y - self.measured) / self.sd) ** 2))

    def history_state(self, p: np.ndarray) -> np.ndarray | None:
        """The state the inflate-then-load history reaches at ``p`` (None where it fails)."""
        try:
            scene = with_parameters(self.scene, dict(zip(self.names, p)))
            r = solve(scene, STEP_OPTIONS)
        except (SceneError, EquilibriumError):
            return None
        return np.asarray(r.theta, float) if r.success else None


# ---------------------------------------------------------------------------------------------
# the problem over all poses


class _Problem:
    def __init__(self, poses: tuple[Pose, ...], base: Scene, free: tuple[str, ...], carried: tuple[str, ...],
                 carried_cov: np.ndarray | None):
        self.poses = poses
        self.loads = tuple(dict.fromkeys(p.load for p in poses))
        self.free = free
        self.pm = [_PoseModel(p, p.scene(base), free, carried) for p in poses]
        self.k = len(free)
        self.blocks = [self.loads.index(p.load) for p in poses]
        self.carried_cov = carried_cov
        self.size = self.k * len(self.loads)
        self.labels = tuple(_label(f, ld, self.loads) for ld in self.loads for f in free)
        self.units = tuple(_unit(f) for _ in self.loads for f in free)
        self.payloads = len(base.payloads)

    def scale_of(self, label: str) -> float:
        return float(self.scales(np.zeros(self.size))[self.labels.index(label)])

    def z_of(self, x: np.ndarray, i: int) -> np.ndarray:
        b = self.blocks[i]
        return x[b * self.k:(b + 1) * self.k]

    def project(self, x: np.ndarray) -> np.ndarray:
        x = x.copy()
        for j, f in enumerate(self.free):
            idx = np.arange(j, self.size, self.k)
            if f.startswith("F"):
                x[idx] = np.maximum(x[idx], 0.0)
            elif f.startswith("s"):
                x[idx] = np.clip(x[idx], 1e-3, 1.0)
        return x

    def scales(self, x: np.ndarray) -> np.ndarray:
        out = []
        for _ in self.loads:
            for f in self.free:
                out.append(1.0 if f.startswith("F") else (30.0 if f.startswith("Omega") else 0.3))
        return np.array(out)

    def evaluate(self, x: np.ndarray, thetas: Sequence[np.ndarray]):
        """Whitened residuals r, their Jacobian J in x, and each pose's (H, y) at states ``thetas``."""
        rs, Js, parts = [], [], []
        for i, pm in enumerate(self.pm):
            p = pm.params(self.z_of(x, i))
            G, H, G_p, y, y_th, y_p = pm.call(thetas[i], p)
            dth = -np.linalg.solve(H, G_p)
            A = y_th @ dth + y_p
            C = np.diag(pm.sd**2)
            if len(pm.carried_idx) and self.carried_cov is not None:
                Ac = A[:, pm.carried_idx]
                C = C + Ac @ self.carried_cov @ Ac.T
            Lc = np.linalg.cholesky(C)
            r = np.linalg.solve(Lc, y - pm.measured)
            Jz = np.zeros((len(y), self.size))
            b = self.blocks[i]
            Jz[:, b * self.k:(b + 1) * self.k] = np.linalg.solve(Lc, A[:, pm.free_idx])
            rs.append(r)
            Js.append(Jz)
            parts.append((H, y, dth[:, pm.free_idx], Lc))
        return np.concatenate(rs), np.vstack(Js), parts

    def follow(self, x_old: np.ndarray, x_new: np.ndarray, thetas, parts) -> list[np.ndarray] | None:
        """Each pose's state at ``x_new``, followed from ``thetas`` at ``x_old`` (first-order predictor, Newton)."""
        out = []
        for i, pm in enumerate(self.pm):
            dz = self.z_of(x_new, i) - self.z_of(x_old, i)
            guess = thetas[i] + parts[i][2] @ dz
            if np.any(guess <= pm.lbx):
                guess = thetas[i]
            t = pm.newton(guess, pm.params(self.z_of(x_new, i)))
            if t is None or float(np.max(np.abs(t - guess))) > 0.2 + 2.0 * float(np.max(np.abs(guess - thetas[i]))):
                return None  # no equilibrium close to the predicted one: a fold, or another branch
            out.append(t)
        return out


def _levenberg_marquardt(prob: _Problem, x: np.ndarray, thetas: list[np.ndarray], options: SensingOptions):
    """Minimise 1/2 |r|^2 from ``x`` with the states followed; (x, thetas, chi2, J, parts, iterations, converged)."""
    r, J, parts = prob.evaluate(x, thetas)
    cost = float(r @ r)
    mu = 1e-3
    scale = prob.scales(x)
    converged = False
    it = 0
    for it in range(1, options.max_iterations + 1):
        g = J.T @ r
        A = J.T @ J
        D = np.diag(np.maximum(np.diag(A), 1e-12 / scale**2))
        accepted = False
        for _ in range(30):
            try:
                step = -np.linalg.solve(A + mu * D, g)
            except np.linalg.LinAlgError:
                mu *= 10.0
                continue
            step_limit = np.max(np.abs(step) / (scale * 0.5))
            if step_limit > 1.0:  # at most half a scale per step: the states are followed, not jumped
                step = step / step_limit
            x_new = prob.project(x + step)
            if np.max(np.abs(x_new - x) / scale) < options.tol:
                converged = True
                break
            t_new = prob.follow(x, x_new, thetas, parts)
            if t_new is not None:
                r_new, J_new, parts_new = prob.evaluate(x_new, t_new)
                cost_new = float(r_new @ r_new)
                if np.isfinite(cost_new) and cost_new <= cost and _same_stability(parts, parts_new):
                    small = np.max(np.abs(x_new - x) / scale) < 1e3 * options.tol or cost - cost_new <= 1e-14 * max(cost, 1e-30)
                    x, thetas, r, J, parts, cost = x_new, t_new, r_new, J_new, parts_new, cost_new
                    mu = max(mu / 5.0, 1e-12)
                    accepted = True
                    converged = small and float(np.max(np.abs(J.T @ r))) < 1e-6 * max(1.0, math.sqrt(cost))
                    break
            mu *= 10.0
        if converged or not accepted:
            converged = converged or float(np.max(np.abs(J.T @ r))) < 1e-6 * max(1.0, math.sqrt(cost))
            break
    return x, thetas, cost, J, parts, it, converged


#: Residual sums (chi-square) closer than this are one: which of two runs that explain the data
#: equally well comes first (the estimate) is then the order of the starts, not round-off.
CHI2_RESOLUTION = 1e-8


def _ranked(runs: list) -> list:
    """The runs by their residual sum to :data:`CHI2_RESOLUTION`, in the order they ran among equals."""
    return sorted(runs, key=lambda r: round(r[0] / CHI2_RESOLUTION))


def _same_stability(parts: list, parts_new: list) -> bool:
    """Whether each pose's state keeps its stability over a step (a stable branch ends at a fold: the
    iteration does not follow it on to the unstable branch, where the prediction's Jacobian blows up
    and where the last digits of round-off, a BLAS kernel or a compiled kernel, decide where it ends)."""
    return all((np.linalg.eigvalsh(a[0])[0] > 0) == (np.linalg.eigvalsh(b[0])[0] > 0) for a, b in zip(parts, parts_new))


def _start_loads(prob: _Problem, base_z: np.ndarray, options: SensingOptions) -> list[tuple[str, np.ndarray]]:
    """The scene's own load, then ``options.starts`` loads spread over magnitude and direction."""
    out = [("the scene's payload", base_z)]
    if options.starts == 0:
        return out
    free = prob.free
    count = options.starts
    mags = [0.1, 0.4, 0.8]
    dirs = max(1, math.ceil(count / len(mags)))
    for j in range(count):
        m = mags[j % len(mags)] * options.max_force
        d = (360.0 * (j // len(mags)) / dirs + (45.0 if j % 2 else 0.0)) % 360.0 - 180.0
        z = base_z.copy()
        for a, f in enumerate(free):
            if f.startswith("F"):
                z[a] = m
            elif f.startswith("Omega"):
                z[a] = d
            elif f.startswith("s"):
                z[a] = (0.5, 1.0, 0.75)[j % 3]
        out.append((f"start {j + 1}: " + ", ".join(f"{f}={v:.3g}" for f, v in zip(free, z)), z))
    return out


#: The equilibria search for a pose's other stable states.
OTHER_STATES = EquilibriaOptions(check=False, connect=False, history=False)


def _other_states(pm: _PoseModel, p: np.ndarray, theta: np.ndarray) -> list[np.ndarray]:
    """The other stable states of the load ``p`` (the equilibria search)."""
    try:  # the stable states only: no completeness check, barriers or history of its own (the run has one);
        # the state in hand is one of the search's starts
        res = equilibria(with_parameters(pm.scene, dict(zip(pm.names, p))), OTHER_STATES, [theta])
    except (SceneError, EquilibriumError):
        return []
    return [np.asarray(s.theta, float) for s in res.stable if float(np.max(np.abs(np.asarray(s.theta) - theta))) > 1e-6]


def _wrap(x: np.ndarray, prob: _Problem) -> np.ndarray:
    x = x.copy()
    for j, f in enumerate(prob.labels):
        if f.startswith("Omega"):
            x[j] = (x[j] + 180.0) % 360.0 - 180.0
    return x


def _distinct(a: np.ndarray, b: np.ndarray, prob: _Problem, se: np.ndarray, mask: np.ndarray) -> bool:
    """Do loads ``a`` and ``b`` (their components ``mask``) differ by more than the iteration's own accuracy?"""
    if not len(a):
        return False
    labels = [lab for lab, m in zip(prob.labels, mask) if m]
    d = np.abs(np.array([((v + 180.0) % 360.0 - 180.0) if lab.startswith("Omega") else v for v, lab in zip(a - b, labels)]))
    scale = prob.scales(np.zeros(prob.size))[mask]
    tol = np.maximum(1e-5 * scale, np.where(np.isfinite(se) & (se > 0), 1e-3 * se, 0.0))
    return bool(np.any(d > tol))


# ---------------------------------------------------------------------------------------------
# words for what the data do not see


def _measured_words(poses: Sequence[Pose]) -> str:
    kinds = sorted({m.label for p in poses for m in p.measured})
    words = {"total angle": "the total angle", "tip": "a tip position", "theta": "the segment angles"}
    named = [words.get(k, f"a {k}") for k in kinds]
    return (named[0] + " alone") if len(named) == 1 else "these measurements (" + ", ".join(named) + ")"


def _load_words(names: Sequence[str], payloads: int) -> str:
    """"the payload's magnitude and direction" for F1, Omega1 (one payload); by payload and load otherwise."""
    what = {"F": "magnitude", "Omega": "direction", "s": "point"}
    groups: dict[str, list[str]] = {}
    for n in names:
        base = n.split("[")[0]
        kind = next(k for k in LOAD_KINDS if base.startswith(k))
        k = base[len(kind):]
        load = n[len(base):]
        who = "the payload" if payloads == 1 else f"payload {k}"
        groups.setdefault(f"{who}{(' ' + load) if load else ''}", []).append(what[kind])
    parts = []
    for who, items in groups.items():
        items = items if len(items) < 3 else [", ".join(items[:-1]), items[-1]]
        parts.append(f"{who}'s {' and '.join(items)}")
    return " and ".join(parts)


def _undetermined_words(prob: _Problem, unknown: np.ndarray, direction: dict, poses: Sequence[Pose]) -> list[str]:
    if not np.any(unknown):
        return []
    names = [prob.labels[j] for j in np.flatnonzero(unknown)]
    seen = _measured_words(poses)
    words = _load_words(names, prob.payloads)
    if len(names) == 1:
        return [f"{words} is not determined by {seen}"]
    combo = ", ".join(f"{k} by {v:+.3g} x {prob.scale_of(k):g}" + ("" if _unit(k) == "1" else f" {_unit(k)}")
                      for k, v in direction.items() if abs(v) > 1e-2) if direction else ""
    return [f"the data do not separate {words}: from {seen}, only a combination of them is determined"
            + (f" (changing {combo} together leaves every prediction unchanged to first order)" if combo else "")]


# ---------------------------------------------------------------------------------------------
# the estimate


def _check(poses: Any, base: Any, carried: Any, carried_covariance: Any) -> tuple[tuple[Pose, ...], tuple[str, ...], np.ndarray | None]:
    if isinstance(poses, Pose):
        poses = (poses,)
    if not isinstance(poses, (list, tuple)) or not poses or not all(isinstance(p, Pose) for p in poses):
        raise SensingError(f"poses={_quote(poses)}: expected one or more Pose")
    if len(poses) > 10_000:
        raise SensingError(f"poses: {len(poses)} given; at most 10000")
    if not isinstance(base, Scene):
        raise SensingError(f"base={_quote(base)}: expected a Scene")
    for p in poses:
        for m in p.measured:
            if m.kind == "theta" and len(m.values) != base.segments:
                raise SensingError(f"{p.label or 'pose'}: theta has {len(m.values)} values; the scene has {base.segments} segments")
    carried = (carried,) if isinstance(carried, str) else tuple(carried or ())
    for c in carried:
        if c not in ACTUATOR:
            raise SensingError(f"carried parameter {_quote(c)}: allowed are {', '.join(ACTUATOR)}")
    if len(set(carried)) != len(carried):
        raise SensingError(f"carried={carried!r}: a parameter is given twice")
    if not carried and carried_covariance is not None:
        raise SensingError("carried_covariance is given without carried (the names of the parameters it is the covariance of)")
    cov = None
    if carried:
        try:
            cov = np.array(carried_covariance, dtype=float)
        except (TypeError, ValueError):
            cov = None
        if cov is None or cov.shape != (len(carried), len(carried)) or not np.all(np.isfinite(cov)):
            raise SensingError(f"parameter covariance: expected a finite {len(carried)} x {len(carried)} matrix for {', '.join(carried)}")
        if not np.allclose(cov, cov.T, rtol=1e-8, atol=0.0) or np.min(np.linalg.eigvalsh((cov + cov.T) / 2)) < -1e-12 * max(1.0, np.abs(cov).max()):
            raise SensingError("parameter covariance: expected a symmetric positive semi-definite matrix")
        values = {p.name: p.value for p in scene_parameters(base)}
        for c, var in zip(carried, np.diag(cov)):
            # a first-order propagation of a standard deviation larger than the value itself means nothing
            if math.sqrt(var) > abs(values[c]):
                raise SensingError(f"parameter covariance: {c}'s standard deviation {math.sqrt(var):.3g} exceeds its value "
                                   f"{values[c]:.4g}: expected one smaller than the value (first order)")
    return tuple(poses), carried, cov


@single_threaded  # one BLAS thread, as solve() has: the answer does not change with OMP_NUM_THREADS
def estimate_load(
    poses: Sequence[Pose] | Pose,
    free: Sequence[str] = ("F1", "Omega1"),
    base: Scene | None = None,
    options: SensingOptions | None = None,
    *,
    carried: Sequence[str] = (),
    carried_covariance: Any = None,
    progress: str | None = None,
) -> LoadEstimate:
    """Estimate the payload(s) that explain the measured poses (see the module docstring).

    Parameters
    ----------
    poses : Pose or sequence of Pose
    free : sequence of str
        The unknowns: ``F1``, ``Omega1``, ``s1`` (or ``force``, ``angle``, ``at``), and those of
        further payloads of ``base``. Everything else is held at ``base``'s values.
    base : Scene
        The actuator and its settings (a fit's values, say); its payloads give the values of what
        is not free and a first start. Default: the Table 1 actuator with one tip payload, n = 3.
    options : SensingOptions
    carried, carried_covariance :
        Actuator parameters (scene-file units: rho in deg) whose uncertainty is carried into the
        load's, with their covariance (e.g. from ``esba fit --json``).
    progress : str, optional
        The label of a tqdm bar on stderr (only on a terminal), with its forecast: over the loads
        (poses of separate loads), or over the starts and the loads searched for other states.

    The work is about linear in the poses: poses of separate loads share no unknown and are
    estimated one load at a time (:func:`_separate`); for one load, each start's run evaluates
    every pose once an iteration, and the search for other stable states runs once per rank of
    the poses' states (not once per pose and state).

    Raises
    ------
    SensingError
        for bad input, before anything is solved.
    """
    options = SensingOptions() if options is None else options
    if not isinstance(options, SensingOptions):
        raise SensingError(f"options={_quote(options)}: expected a SensingOptions")
    if base is None:
        base = Scene(payloads=(Payload(1.0, 90.0),))
    poses, carried, cov = _check(poses, base, carried, carried_covariance)
    if not base.payloads:
        base = base.replace(payloads=(Payload(1.0, 90.0),))
    free = free_names(base, free)
    t0 = time.perf_counter()
    prob = _Problem(poses, base, free, carried, cov)
    for pm in prob.pm:  # scales the solver cannot resolve are refused, as solve() refuses them, before anything is solved
        try:
            resolution.check_resolvable(pm.scene, pm.pressure, DEFAULT_OPTIONS.stationarity_tol)
        except SceneError as exc:
            raise SensingError(f"{pm.pose.label or 'pose'}: {exc}") from None
    if len(prob.loads) > 1:  # separate loads share no unknown: one estimate each, the work linear in the loads
        return _separate(prob, base, options, carried, cov, progress, t0)
    m = sum(p.count() for p in poses)
    base_z = prob.pm[0].p0[prob.pm[0].free_idx]
    starts = [(why, np.tile(z, len(prob.loads))) for why, z in _start_loads(prob, base_z, options)]
    runs: list[tuple[float, np.ndarray, list, np.ndarray, list, str]] = []
    iterations = 0
    bar = _bar(progress, len(starts), "start")

    def run(x0: np.ndarray, thetas0: list[np.ndarray] | None, why: str) -> None:
        nonlocal iterations
        x0 = prob.project(x0)
        if thetas0 is None:
            thetas0 = []
            for i, pm in enumerate(prob.pm):
                t = pm.history_state(pm.params(prob.z_of(x0, i)))
                if t is None:
                    return
                thetas0.append(t)
        try:
            x, thetas, cost, J, parts, its, ok = _levenberg_marquardt(prob, x0, thetas0, options)
        except np.linalg.LinAlgError:
            return
        iterations += its
        if np.isfinite(cost):
            runs.append((cost, x, thetas, J, parts, why))

    for why, x0 in starts:
        run(x0, None, why)
        bar.update(1)
    if not runs:
        bar.close()
        return _failed(prob, poses, options, len(starts), iterations, time.perf_counter() - t0,
                       "no start converged: no load found whose equilibrium the iteration could follow")
    chi_k = float(stats.chi2.ppf(options.level, prob.size))
    if options.branches:
        # every other stable state of each load found that explains the data, and of each start load
        # too: a shape on a branch no load history reaches. The start loads always: whether a run
        # from a start happens to cross to another branch is not something to count on (it depends
        # on the last digits of the arithmetic), the list of starts is.
        best = min(r[0] for r in runs)
        loads: list[tuple[np.ndarray, list | None]] = []
        for cost, x, thetas, _, _, _ in _ranked(runs):
            same = any(not _distinct(_wrap(x, prob), _wrap(y, prob), prob, np.zeros(prob.size), np.ones(prob.size, bool))
                       and all(np.max(np.abs(a - b)) < 1e-6 for a, b in zip(thetas, ts)) for y, ts in loads)
            if cost <= best + chi_k and not same:  # each distinct load (and state) searched once
                loads.append((x, thetas))
        for _, x0 in starts:
            x0 = prob.project(x0)
            if not any(ts is None and not _distinct(_wrap(x0, prob), _wrap(y, prob), prob, np.zeros(prob.size), np.ones(prob.size, bool))
                       for y, ts in loads):
                loads.append((x0, None))
        bar.total += len(loads)
        bar.refresh()
        for x, thetas in loads:
            bar.update(1)
            # each pose's stable states at this load (its own first), ranked by how well each alone
            # explains the pose; run r starts every pose from its r-th best: one run per rank, not
            # per pose and state, so the runs do not multiply with the poses
            own = list(thetas) if thetas is not None else [pm.history_state(pm.params(prob.z_of(x, i))) for i, pm in enumerate(prob.pm)]
            if any(t is None for t in own):
                continue
            ranked = []
            for i, pm in enumerate(prob.pm):
                p = pm.params(prob.z_of(x, i))
                ranked.append(sorted([own[i], *_other_states(pm, p, own[i])], key=lambda t, pm=pm, p=p: pm.misfit(t, p)))
            for r in range(max(len(states) for states in ranked)):
                t0s = [states[min(r, len(states) - 1)] for states in ranked]
                if all(np.array_equal(a, b) for a, b in zip(t0s, own)):
                    continue  # the states the load's own run started from
                moved = [pm.pose.label or f"pose {i + 1}" for i, (pm, a, b) in enumerate(zip(prob.pm, t0s, own)) if not np.array_equal(a, b)]
                run(x, t0s, f"another stable state of {', '.join(moved[:3])}{' and more' if len(moved) > 3 else ''} at the load " + ", ".join(
                    f"{lab}={v:.4g}" for lab, v in zip(prob.labels, x)))
    bar.close()
    runs[:] = _ranked(runs)
    # among the loads that explain the data equally well, one whose states the actuator can hold comes first
    stable_runs = [r for r in runs if r[0] <= runs[0][0] + chi_k and all(np.linalg.eigvalsh(part[0])[0] > 0 for part in r[4])]
    if stable_runs:
        runs.remove(stable_runs[0])
        runs.insert(0, stable_runs[0])
    cost, x, thetas, J, parts, why = runs[0]
    F = J.T @ J
    scale = prob.scales(x)
    ident, _, unknown, _, direction = identifiability_rule(F, m, prob.labels, scale, x, [], options.identifiability_tol,
                                                          options.identifiability_floor, prob.units)
    known = ~unknown
    cov_x, se = _covariance(F, known)
    # the distinct loads that explain the data within the noise
    candidates: list[Candidate] = []
    for c, xr, th, _, pr, w in runs:
        if c > cost + chi_k:
            continue
        # along a direction the data do not see, every point explains them: those are one continuum, listed once
        if any(not _distinct(xr[known], cand.estimate[known], prob, se[known], known) for cand in candidates):
            continue
        eig0 = [float(np.linalg.eigvalsh(part[0])[0]) for part in pr]
        candidates.append(Candidate(_wrap(xr, prob), c, tuple(th), tuple(e > 0 for e in eig0), tuple(eig0), w))
    x = _wrap(x, prob)
    q = float(stats.norm.ppf(0.5 + options.level / 2))
    interval = np.column_stack([x - q * se, x + q * se])
    corr = fisher_correlation(F, scale)
    dof = m - prob.size
    p_value = float(stats.chi2.sf(cost, dof)) if dof > 0 else math.nan
    warnings: list[str] = []
    undetermined = _undetermined_words(prob, unknown, direction, poses)
    warnings += [f"not identifiable: {u}" for u in undetermined]
    misfit = ""
    if dof > 0 and p_value < MISFIT_P:
        misfit = (f"no load explains the data: chi-square {cost:.3g} on {dof} degrees of freedom (p = {p_value:.2g} < {MISFIT_P:g}); "
                  "the model, the pressure or the standard deviations are off, and the estimate and its interval mean nothing")
    elif dof <= 0 and cost > float(stats.chi2.ppf(1.0 - MISFIT_P, 1)):
        misfit = (f"no load explains the data within the stated standard deviations: chi-square {cost:.3g} with no degrees of freedom "
                  "left; the model, the pressure or the standard deviations are off")
    if len(candidates) > 1:
        warnings.append(f"not unique: {len(candidates)} loads explain the data equally well within the noise (listed under alternatives)")
    if undetermined:
        warnings.append("not unique: a continuum of loads along the undetermined direction explains the data; one of them is the estimate")
    residuals, states, status = [], [], "ok"
    message = ""
    off = 0
    r_all, _, _ = prob.evaluate(x, thetas)
    for i, pm in enumerate(prob.pm):
        H, y = parts[i][0], parts[i][1]
        label = pm.pose.label or f"pose {i + 1}"
        for j, (meas, qn) in enumerate(pm.quantities):
            residuals.append({"pose": label, "quantity": qn, "unit": meas.unit, "measured": float(pm.measured[j]),
                              "predicted": float(y[j]), "sd": float(pm.sd[j]), "normalised": float(r_all[off + j])})
        off += len(pm.quantities)
        eig = np.linalg.eigvalsh(H)
        p = pm.params(prob.z_of(x, i))
        scene = with_parameters(pm.scene, dict(zip(pm.names, p)))
        hist = pm.history_state(p)
        on_history = hist is not None and float(np.max(np.abs(hist - thetas[i]))) < 1e-6
        tip = pm.model.tip(thetas[i], scene.actuator.L)
        findings = assess(scene, thetas[i], pm.pressure, tip)
        stable = bool(eig[0] > 0)
        states.append({"pose": label, "theta_deg": np.degrees(thetas[i]).tolist(), "total_angle_deg": math.degrees(float(np.sum(thetas[i]))),
                       "tip_mm": [float(tip[0]), float(tip[1])], "stable": stable, "min_eigenvalue": float(eig[0]),
                       "on_load_history": on_history, "validity": [f.message for f in findings]})
        if not stable:
            status = "unstable"
            message = f"{label}: the state that explains it is unstable (smallest Hessian eigenvalue {eig[0]:.3g}): the actuator cannot hold it"
            warnings.append(message)
        if not on_history and hist is not None:
            warnings.append(f"{label}: inflating and then loading with the estimated load reaches another state "
                            f"(total angle {math.degrees(float(np.sum(hist))):.2f} deg); the measured shape is another stable state of that load")
        warnings += [f"{label}: outside the model's range: {f.message}" for f in findings]
    if any(not all(c.stable) for c in candidates[1:]):
        warnings.append("some alternatives hold an unstable state (marked): the actuator could not hold those")
    if misfit:  # an estimate that explains nothing is no estimate, whatever else holds
        status, message = "misfit", misfit
    return LoadEstimate(
        labels=prob.labels, units=prob.units, level=options.level, estimate=x, std_error=se, interval=interval, covariance=cov_x,
        correlation=corr, fisher=F, identifiable=ident, undetermined=tuple(undetermined), unique=len(candidates) == 1 and ident,
        alternatives=tuple(candidates), chi2=cost, dof=dof, p_value=p_value, residuals=tuple(residuals), states=tuple(states),
        poses=poses, status=status, message=message, warnings=tuple(warnings), starts=len(starts), iterations=iterations,
        solve_time_s=time.perf_counter() - t0)


class _NoBar:
    total = 0

    def update(self, k: int) -> None:
        pass

    def refresh(self) -> None:
        pass

    def close(self) -> None:
        pass


def _bar(label: str | None, total: int, unit: str):
    """A tqdm bar on stderr named ``label`` (only on a terminal), or one that shows nothing."""
    if not label:
        return _NoBar()
    from tqdm.auto import tqdm

    return tqdm(total=total, unit=unit, desc=label, leave=False, disable=None)  # None: only on a terminal


def _block_diagonal(blocks: Sequence[np.ndarray]) -> np.ndarray:
    size = sum(len(b) for b in blocks)
    out = np.zeros((size, size))
    at = 0
    for b in blocks:
        out[at:at + len(b), at:at + len(b)] = b
        at += len(b)
    return out


def _separate(prob: _Problem, base: Scene, options: SensingOptions, carried: tuple[str, ...], cov: np.ndarray | None,
              progress: str | None, t0: float) -> LoadEstimate:
    """The estimate of poses of several loads: the loads share no unknown (each pose's residual
    depends on its own load only, and the actuator's carried uncertainty enters each pose's own
    covariance), so the least-squares problem is block-diagonal and each load is estimated on its
    own; their results are put together (estimates, block-diagonal covariance and Fisher matrix,
    chi-square summed). An alternative is one load's alternative with the others at their estimate."""
    bar = _bar(progress, len(prob.loads), "load")
    subs = []
    for ld in prob.loads:
        subs.append(estimate_load(tuple(p for p in prob.poses if p.load == ld), prob.free, base, options, carried=carried,
                                  carried_covariance=cov))
        bar.update(1)
    bar.close()
    poses = tuple(p for ld in prob.loads for p in prob.poses if p.load == ld)
    estimate = np.concatenate([s.estimate for s in subs])
    std_error = np.concatenate([s.std_error for s in subs])
    chi2 = float(sum(s.chi2 for s in subs))
    m = sum(p.count() for p in poses)
    dof = m - prob.size
    p_value = float(stats.chi2.sf(chi2, dof)) if dof > 0 and math.isfinite(chi2) else math.nan
    warnings = [w if w.startswith(f"{ld}: ") else f"load {ld}: {w}" for ld, s in zip(prob.loads, subs) for w in s.warnings]  # a row that is its own load names itself
    best = [s.alternatives[0] if s.alternatives else None for s in subs]
    candidates: list[Candidate] = []
    if all(b is not None for b in best):
        def joined(parts: Sequence[Candidate], start: str) -> Candidate:
            return Candidate(np.concatenate([c.estimate for c in parts]), float(sum(c.chi2 for c in parts)),
                             tuple(t for c in parts for t in c.states), tuple(v for c in parts for v in c.stable),
                             tuple(e for c in parts for e in c.min_eigenvalue), start)

        candidates.append(joined(best, "each load's estimate"))
        for j, s in enumerate(subs):
            for alt in s.alternatives[1:]:
                candidates.append(joined([alt if k == j else b for k, b in enumerate(best)], f"load {prob.loads[j]}: {alt.start}"))
    status, message = "ok", ""
    for rank in ("unstable", "misfit", "failed"):  # the worst of the loads' statuses, named
        bad = [ld for ld, s in zip(prob.loads, subs) if s.status == rank]
        if bad:
            status = rank
            message = "; ".join(f"load {ld}: {s.message}" for ld, s in zip(prob.loads, subs) if s.status == rank)
    return LoadEstimate(
        labels=prob.labels, units=prob.units, level=options.level, estimate=estimate, std_error=std_error,
        interval=np.vstack([s.interval for s in subs]), covariance=_block_diagonal([s.covariance for s in subs]),
        correlation=_block_diagonal([s.correlation for s in subs]), fisher=_block_diagonal([s.fisher for s in subs]),
        identifiable=all(s.identifiable for s in subs), undetermined=tuple(f"load {ld}: {u}" for ld, s in zip(prob.loads, subs) for u in s.undetermined),
        unique=all(s.unique for s in subs), alternatives=tuple(candidates), chi2=chi2, dof=dof, p_value=p_value,
        residuals=tuple(r for s in subs for r in s.residuals), states=tuple(st for s in subs for st in s.states), poses=poses,
        status=status, message=message, warnings=tuple(warnings), starts=subs[0].starts, iterations=sum(s.iterations for s in subs),
        solve_time_s=time.perf_counter() - t0)


def _failed(prob: _Problem, poses, options, starts, iterations, seconds, message) -> LoadEstimate:
    k = prob.size
    nan = np.full(k, np.nan)
    return LoadEstimate(
        labels=prob.labels, units=prob.units, level=options.level, estimate=nan, std_error=nan, interval=np.full((k, 2), np.nan),
        covariance=np.full((k, k), np.nan), correlation=np.full((k, k), np.nan), fisher=np.full((k, k), np.nan), identifiable=False,
        undetermined=(), unique=False, alternatives=(), chi2=math.nan, dof=sum(p.count() for p in poses) - k, p_value=math.nan,
        residuals=(), states=(), poses=poses, status="failed", message=message, warnings=(message,), starts=starts,
        iterations=iterations, solve_time_s=seconds)


# ---------------------------------------------------------------------------------------------
# what an experiment can see, before measuring


@dataclass(frozen=True, eq=False)
class Information:
    """The first-order information a measurement layout carries about a known load.

    ``fisher`` (k x k) and ``covariance`` (its inverse where determined) for the unknowns
    ``labels``; ``std_error``; ``undetermined`` in words; ``stable`` and ``theta`` of the state.
    """

    labels: tuple[str, ...]
    units: tuple[str, ...]
    value: np.ndarray
    fisher: np.ndarray
    covariance: np.ndarray
    std_error: np.ndarray
    undetermined: tuple[str, ...]
    theta: np.ndarray
    stable: bool
    tip: np.ndarray
    force_covariance: np.ndarray


def predict_pose(scene: Scene, kinds: Sequence[Measured], theta: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(theta, predicted values) of ``scene`` (solved along its history unless ``theta`` is given) for the layout of ``kinds``."""
    pose = Pose(scene.pressure, tuple(kinds), target_angle_deg=scene.target_angle_deg if scene.pressure is None else None)
    pm = _PoseModel(pose, scene, (), ())
    if theta is None:
        r = solve(scene, STEP_OPTIONS)
        theta = np.asarray(r.theta, float)
    return theta, pm.call(theta, pm.p0)[3]


@single_threaded
def information(scene: Scene, kinds: Sequence[Measured], free: Sequence[str] = ("F1", "Omega1"), options: SensingOptions | None = None,
                theta: np.ndarray | None = None) -> Information:
    """What the layout ``kinds`` (their kinds, points and standard deviations; their values are not
    used) would tell about ``scene``'s load: the Fisher matrix at the state its history reaches.

    >>> from esba.model.scene import Scene, Payload
    >>> s = Scene(target_angle_deg=90.0, payloads=(Payload(1.0, 90.0),))
    >>> info = information(s, [Measured("total_angle", (0.0,), 0.1)])
    >>> info.undetermined[0][:84]
    "the data do not separate the payload's magnitude and direction: from the total angle"
    """
    options = SensingOptions() if options is None else options
    free = free_names(scene, free)
    pose = Pose(scene.pressure, tuple(kinds), target_angle_deg=scene.target_angle_deg if scene.pressure is None else None)
    prob = _Problem((pose,), scene, free, (), None)
    pm = prob.pm[0]
    if theta is None:
        theta = pm.history_state(pm.p0)
        if theta is None:
            raise EquilibriumError(f"{scene.describe()}: the load history does not reach an equilibrium")
    x = pm.p0[pm.free_idx]
    pm.measured = pm.call(theta, pm.p0)[3]
    _, J, parts = prob.evaluate(x, [theta])
    F = J.T @ J
    ident, _, unknown, _, direction = identifiability_rule(F, pose.count(), prob.labels, prob.scales(x), x, [], options.identifiability_tol,
                                                          options.identifiability_floor, prob.units)
    cov, se = _covariance(F, ~unknown)
    fc = _force_covariance(prob.labels, x, cov)
    eig0 = float(np.linalg.eigvalsh(parts[0][0])[0])
    return Information(prob.labels, prob.units, x, F, cov, se, tuple(_undetermined_words(prob, unknown, direction, [pose])), theta,
                       eig0 > 0, pm.model.tip(theta, scene.actuator.L), fc)


def _covariance(F: np.ndarray, known: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(covariance, standard errors) of the unknowns from the Fisher matrix: the determined ones
    (``known``) with the others held where they are; NaN for the undetermined."""
    cov = np.full(F.shape, np.nan)
    if np.any(known):
        cov[np.ix_(known, known)] = np.linalg.inv(F[np.ix_(known, known)])
    diag = np.diag(cov)
    return cov, np.sqrt(np.where(np.isfinite(diag), np.maximum(diag, 0.0), np.nan))


def _force_covariance(labels: Sequence[str], x: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """The covariance of the force vector (x, y components in N, base frame) from that of (F1, Omega1)."""
    if "F1" not in labels or "Omega1" not in labels:
        return np.full((2, 2), np.nan)
    i, j = labels.index("F1"), labels.index("Omega1")
    F, om = x[i], math.radians(x[j])
    # force = F (cos Omega, -sin Omega); Omega in deg
    Jf = np.array([[math.cos(om), -F * math.sin(om) * math.pi / 180.0], [-math.sin(om), -F * math.cos(om) * math.pi / 180.0]])
    sub = cov[np.ix_([i, j], [i, j])]
    return Jf @ sub @ Jf.T


def estimate_table(d: dict) -> str:
    """The text ``esba estimate`` prints for :meth:`LoadEstimate.to_dict`."""

    key = f"interval_{round(100 * d['level'])}"

    def num(v, fmt=".4g"):
        return "-" if v is None else format(v, fmt)

    lines = [f"load estimate: {d['status']}" + (f": {d['message']}" if d["message"] else "")
             + f" ({d['starts']} starts, {d['iterations']} iterations, {d['solve_time_s']:.2f} s)"]
    lines.append(f"{'unknown':<14} {'unit':<4} {'estimate':>10} {'std error':>10} {round(100 * d['level'])} % interval")
    for name, u in d["unknowns"].items():
        iv = u[key]
        lines.append(f"{name:<14} {u['unit']:<4} {num(u['estimate'], '.5g'):>10} {num(u['std_error'], '.3g'):>10} [{num(iv[0], '.4g')}, {num(iv[1], '.4g')}]")
    names = list(d["unknowns"])
    if len(names) > 1:
        lines.append("correlation: " + ", ".join(f"{a}-{b} {num(d['correlation'][i][j], '+.3f')}" for i, a in enumerate(names)
                                                 for j, b in enumerate(names) if j > i))
    if d["dof"] > 0:
        fit = f"chi-square {num(d['chi2'], '.3g')} on {d['dof']} degrees of freedom" + (f" (p = {num(d['p_value'], '.2g')})" if d["p_value"] is not None else "")
    else:
        fit = f"chi-square {num(d['chi2'], '.3g')}, no degrees of freedom left"
    lines.append(f"unique: {'yes' if d['unique'] else 'no'}; identifiable: {'yes' if d['identifiable'] else 'no'}; {fit}")
    for u in d["undetermined"]:
        lines.append(f"cannot see: {u}")
    if len(d["alternatives"]) > 1:
        lines.append("loads that explain the data equally well:")
        for c in d["alternatives"]:
            est = ", ".join(f"{k} = {v:.4g}" for k, v in c["estimate"].items())
            st = "; ".join(f"{s['total_angle_deg']:.2f} deg {'stable' if s['stable'] else 'UNSTABLE'}" for s in c["states"])
            lines.append(f"  {est}: chi-square {c['chi2']:.3g}, state {st}")
    lines.append(f"{'pose':<12} {'quantity':<14} {'unit':<4} {'measured':>10} {'predicted':>10} {'r / sd':>7}")
    for r in d["residuals"]:
        lines.append(f"{r['pose'][:12]:<12} {r['quantity']:<14} {r['unit']:<4} {r['measured']:>10.4g} {r['predicted']:>10.4g} {r['normalised']:>+7.2f}")
    for s in d["states"]:
        lines.append(f"{s['pose'][:12]:<12} state: theta ({', '.join(f'{t:.2f}' for t in s['theta_deg'])}) deg, total {s['total_angle_deg']:.2f} deg, "
                     f"{'stable' if s['stable'] else 'UNSTABLE'}, {'on' if s['on_load_history'] else 'not on'} the inflate-then-load history")
    return "\n".join(lines)  # the warnings go to stderr, one line each

"""Parameter sensitivities of an equilibrium: the implicit function theorem on the generated model.

At an equilibrium theta*(p) the gradient vanishes, G(theta*, p) = dU/dtheta = 0, for every scene
parameter p near its value. Differentiating that identity,

    H dtheta/dp + dG/dp = 0,   so   dtheta/dp = -H^-1 dG/dp,

with H = d2U/dtheta2 the generated Hessian and dG/dp the derivative of the generated gradient
with respect to p, taken by CasADi's automatic differentiation (exact, no step size). The tip
follows as d tip/dp = J dtheta/dp + d tip/dL (J = d tip/dtheta; the tip also depends on L
directly), the total angle as the sum of dtheta/dp.

The scene parameters (:func:`scene_parameters`, in the units of the scene file) are the
actuator's L, r1, r2, d, rho (deg), E, with gravity M and g; the pressure P, or, when the scene
sets the pressure by an unloaded target angle, that angle (deg; the pressure then follows it in
closed form, so dP/dp is part of every other derivative); and each payload's F (N), Omega (deg)
and point s (fraction of L).

**Near a fold** H is nearly singular and dtheta/dp grows without bound: the first-order answer
holds only for vanishing changes. When the smallest eigenvalue of H is below ``fold_tol`` times
the largest, or reaches zero (to first order) within ``fold_distance_tol`` of a parameter's value,
the result says so (``status="near_fold"``) and gives no numbers. For every
parameter the result also estimates, to first order, how far the parameter may move before the
smallest eigenvalue reaches zero (:attr:`Sensitivities.fold_distance`): a first-order answer
(and a first-order uncertainty, :mod:`esba.calibration.uncertainty`) is trustworthy only for changes well
inside that distance.

**The payload point s.** The point enters the generated model through min/max clamps, sigma_j =
min(max(n s - (j - 1), 0), 1) (how much of segment j lies before the point); CasADi's AD of the
generated gradient with respect to s takes half the one-sided value at the clamps' ties (at a
segment end, and at the tip). The column of s is instead the derivative of the payload's gradient term -f . dp(s)/dtheta_j, with dp/ds =
L (cos h, sin h) the tangent of the inextensible layer at the point (h = sum_j sigma_j theta_j its
heading, from the generated ``centreline`` function):

    d(dU/dtheta_j)/ds_k = F_k L sin(Omega_k + h(s_k)) sigma_j(s_k),

continuous across segment ends (the layer is tangent-continuous), one-sided at the tip. The
tests check it against differences of the generated gradient and of solves.

Examples
--------
>>> from esba.model.scene import MAIN_JOB
>>> from esba.statics.equilibrium import solve
>>> s = sensitivities(solve(MAIN_JOB))
>>> s.status, round(s.total_angle("E"), 2), round(s.total_angle("F1"), 2)   # deg per MPa, per N
('ok', 101.76, -27.47)
>>> s.total_angle("rho")   # at a target angle the pressure absorbs the fibres entirely (round-off: ROUND_OFF)
0.0
>>> s.held["parameter"]     # what the derivatives hold fixed: the target angle, so the pressure moves
'target_angle'
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import casadi as ca
import numpy as np

from esba.infra import checks, jsonsafe
from esba.infra.errors import InputError
from esba.infra.report import Report
from esba.model.closed_form import unloaded_pressure
from esba.model.generated import Model
from esba.model.scene import Payload, Scene, SceneError
from esba.statics.equilibrium import Equilibrium

__all__ = [
    "Parameter",
    "SensitivityError",
    "SensitivityOptions",
    "Sensitivities",
    "scene_parameters",
    "parameter_names",
    "with_parameters",
    "model_values",
    "implicit_functions",
    "sensitivities",
    "UNITS",
    "ROUND_OFF",
    "held_fixed",
    "fold_check",
]

#: User units of every kind of scene parameter (as in the scene file).
UNITS = {
    "L": "mm",
    "r1": "mm",
    "r2": "mm",
    "d": "mm",
    "rho": "deg",
    "E": "MPa",
    "M": "kg",
    "g": "m/s^2",
    "P": "MPa",
    "target_angle": "deg",
    "F": "N",
    "Omega": "deg",
    "s": "1",
}

_DESCRIPTIONS = {
    "L": "length",
    "r1": "external radius",
    "r2": "chamber radius",
    "d": "eccentric distance",
    "rho": "fibre angle",
    "E": "Young's modulus",
    "M": "mass",
    "g": "gravitational acceleration",
    "P": "pressure",
    "target_angle": "unloaded target angle (sets the pressure)",
    "F": "force of payload",
    "Omega": "direction of payload",
    "s": "point of payload (fraction of L)",
}

#: A derivative is round-off, and reported as 0, when the change it predicts for a change of its
#: parameter by the parameter's own size (|p|, or one unit where p = 0) is at most this fraction of
#: the largest such change of the same quantity (theta_i, the total angle, tip x or tip y) over all the
#: scene's parameters. Such a derivative is exactly zero in the model (d/d rho at a held target
#: angle: the pressure absorbs the fibres entirely), and what the arithmetic leaves of it is about
#: 1e-16 of the others.
ROUND_OFF = 1e-12


def _zero_round_off(d: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """``d`` (rows: quantities, columns: parameters) with the entries :data:`ROUND_OFF` calls round-off set to 0."""
    change = np.abs(d) * scale
    largest = np.max(change, axis=1, keepdims=True) if d.size else change
    return np.where(change <= ROUND_OFF * largest, 0.0, d)


def held_fixed(scene: Scene) -> dict[str, Any]:
    """What every derivative holds fixed besides the other parameters: the pressure or, when the
    scene sets the pressure by an unloaded target angle, that angle (the pressure then moves)."""
    if scene.pressure is None:
        value = float(scene.target_angle_deg)
        return {
            "parameter": "target_angle",
            "value": value,
            "unit": "deg",
            "meaning": f"the unloaded target angle is held at {value:g} deg, so the pressure moves with every other parameter "
            "(closed form) and each derivative includes that move; give the pressure (--pressure) to hold it instead",
        }
    value = float(scene.pressure)
    return {
        "parameter": "P",
        "value": value,
        "unit": "MPa",
        "meaning": f"the pressure is held at {value:g} MPa; set the pressure by an unloaded target angle (--target-angle) to hold that angle instead",
    }


class SensitivityError(InputError):
    """A parameter name or option that is not allowed: the message names it and what is allowed."""


def _kind(name: str) -> tuple[str, int]:
    """("F", 2) for "F2", ("E", 0) for "E"."""
    for kind in ("Omega", "F", "s"):
        if name.startswith(kind) and name[len(kind):].isdigit() and int(name[len(kind):]) >= 1:
            return kind, int(name[len(kind):])
    return name, 0


def parameter_names(scene: Scene) -> tuple[str, ...]:
    """The scene's parameters, in order (see the module docstring).

    >>> from esba.model.scene import MAIN_JOB
    >>> parameter_names(MAIN_JOB)
    ('L', 'r1', 'r2', 'd', 'rho', 'E', 'target_angle', 'F1', 'Omega1', 's1')
    """
    names = ["L", "r1", "r2", "d", "rho", "E"]
    if scene.gravity:
        names += ["M", "g"]
    names.append("P" if scene.pressure is not None else "target_angle")
    for k in range(1, len(scene.payloads) + 1):
        names += [f"F{k}", f"Omega{k}", f"s{k}"]
    return tuple(names)


def _value(scene: Scene, name: str) -> float:
    kind, k = _kind(name)
    a = scene.actuator
    if kind in ("L", "r1", "r2", "d", "E", "M"):
        return float(getattr(a, kind))
    if kind == "rho":
        return a.rho_deg
    if kind == "g":
        return scene.g
    if kind == "P":
        return float(scene.pressure)
    if kind == "target_angle":
        return float(scene.target_angle_deg)
    p = scene.payloads[k - 1]
    return {"F": p.force, "Omega": p.angle_deg, "s": p.at}[kind]


@dataclass(frozen=True)
class Parameter:
    """One scene parameter: its name, unit (as in the scene file), meaning and value."""

    name: str
    unit: str
    description: str
    value: float


def scene_parameters(scene: Scene) -> tuple[Parameter, ...]:
    """The parameters of ``scene`` with their units and values.

    >>> from esba.model.scene import MAIN_JOB
    >>> [(p.name, p.unit, p.value) for p in scene_parameters(MAIN_JOB)][4:7]
    [('rho', 'deg', 10.0), ('E', 'MPa', 0.54), ('target_angle', 'deg', 90.0)]
    """
    out = []
    for name in parameter_names(scene):
        kind, k = _kind(name)
        desc = _DESCRIPTIONS[kind] + (f" {k}" if k else "")
        out.append(Parameter(name, UNITS[kind], desc, _value(scene, name)))
    return tuple(out)


def check_names(scene: Scene, names: Sequence[str], where: str = "parameter") -> tuple[str, ...]:
    """``names`` if each is a parameter of ``scene``; else a :class:`SensitivityError` naming it."""
    allowed = parameter_names(scene)
    for name in names:
        if name not in allowed:
            hint = ""
            if name == "P" and "target_angle" in allowed:
                hint = " (this scene sets the pressure by target_angle_deg: use target_angle, or give a pressure)"
            elif name == "target_angle" and "P" in allowed:
                hint = " (this scene gives a pressure: use P)"
            raise SensitivityError(f"{where} {name!r} is not a parameter of this scene{hint}; allowed are {', '.join(allowed)}")
    return tuple(names)


def with_parameters(scene: Scene, values: Mapping[str, float]) -> Scene:
    """``scene`` with some parameters set (scene-file units); validated like any scene.

    Raises
    ------
    SensitivityError
        for a name that is not a parameter of the scene.
    SceneError
        for a value the scene does not allow (e.g. r2 + d >= r1).

    >>> from esba.model.scene import MAIN_JOB
    >>> s = with_parameters(MAIN_JOB, {"E": 0.6, "Omega1": 0.0})
    >>> s.actuator.E, s.payloads[0].angle_deg
    (0.6, 0.0)
    """
    if not isinstance(values, Mapping):
        raise SensitivityError(f"values={checks.quote(values)}: expected a mapping of parameter name to value, such as {{'E': 0.6}}")
    check_names(scene, list(values))
    act, top = {}, {}
    payloads = list(scene.payloads)
    for name, value in values.items():
        value = checks.finite(name, value, SceneError)
        kind, k = _kind(name)
        if kind in ("L", "r1", "r2", "d", "E", "M"):
            act[kind] = value
        elif kind == "rho":
            act["rho_deg"] = value
        elif kind == "g":
            top["g"] = value
        elif kind == "P":
            top["pressure"] = value
        elif kind == "target_angle":
            top["target_angle_deg"] = value
        else:
            p = payloads[k - 1]
            field = {"F": "force", "Omega": "angle_deg", "s": "at"}[kind]
            payloads[k - 1] = dataclasses.replace(p, **{field: value})
    if act:
        top["actuator"] = dataclasses.replace(scene.actuator, **act)
    if payloads != list(scene.payloads):
        top["payloads"] = tuple(Payload(p.force, p.angle_deg, p.at, p.out_of_plane_deg) for p in payloads)
    return dataclasses.replace(scene, **top) if top else scene


def model_values(model: Model, names: Sequence[str], p: Sequence[Any], fixed: Mapping[str, float] | None = None) -> dict[str, Any]:
    """The model's parameter values (radians inside) from scene parameters ``p`` (numbers or CasADi).

    ``names`` are scene-parameter names (:func:`parameter_names`) matching ``p``; ``fixed`` gives
    model parameters not among them (e.g. ``g``). A ``target_angle`` sets P in closed form
    (:func:`esba.model.closed_form.unloaded_pressure`).
    """
    v: dict[str, Any] = dict(fixed or {})
    target = None
    for name, value in zip(names, p):
        kind, k = _kind(name)
        if kind == "rho":
            v["rho"] = value * (math.pi / 180.0)
        elif kind == "Omega":
            v[f"Omega{k}"] = value * (math.pi / 180.0)
        elif kind == "target_angle":
            target = value * (math.pi / 180.0)
        else:
            v[name] = value
    if target is not None:
        v["P"] = unloaded_pressure(model, target, v)
    return v


@dataclass(frozen=True)
class SensitivityOptions:
    """Settings of :func:`sensitivities`, validated on creation.

    Parameters
    ----------
    fold_tol : float
        The equilibrium is *near a fold* when the smallest Hessian eigenvalue is below
        ``fold_tol`` times the largest (0 < fold_tol < 1). Away from folds the ratio is about 0.4
        for the Table 1 actuator at any n; 1e-3 means 400 times softer than that.
    fold_distance_tol : float
        ... or when, to first order, the smallest eigenvalue reaches 0 within this fraction of some
        nonzero parameter's value (:attr:`Sensitivities.fold_distance`; near a fold the linear
        estimate is about twice the true distance). The eigenvalue falls like the square root of
        the distance, so the ratio alone lets states 0.01 % short of a fold through.

    >>> SensitivityOptions(fold_tol=2.0)
    Traceback (most recent call last):
    ...
    esba.analysis.sensitivity.SensitivityError: fold_tol=2.0: expected a number with 0 < fold_tol < 1
    """

    fold_tol: float = 1e-3
    fold_distance_tol: float = 1e-3

    def __post_init__(self) -> None:
        for name in ("fold_tol", "fold_distance_tol"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 < v < 1.0:
                raise SensitivityError(f"{name}={v!r}: expected a number with 0 < {name} < 1")


# ---------------------------------------------------------------------------------------------
# the CasADi functions (one set per model and pressure mode)

def implicit_functions(model: Model, names: tuple[str, ...], fixed_names: tuple[str, ...]) -> ca.Function:
    """(theta, p, fixed, v) -> G, dG/dtheta, dG/dp, tip, dtip/dtheta, dtip/dp, d(v'Hv)/dtheta, d(v'Hv)/dp
    (in the model's registry, per set of parameter names): p are scene parameters ``names`` in
    scene-file units, ``fixed`` the model parameters ``fixed_names`` that are not among them. The
    load estimate (:mod:`esba.calibration.sensing`) builds on the same function."""
    return model.derived("sensitivity", lambda: _build(model, names, fixed_names), settings=(names, fixed_names), persist=False)


def _build(model: Model, names: tuple[str, ...], fixed_names: tuple[str, ...]) -> ca.Function:
    n = model.n
    th = ca.SX.sym("theta", n)
    p = ca.SX.sym("p", len(names))
    fx = ca.SX.sym("fixed", len(fixed_names))
    v = ca.SX.sym("v", n)
    values = model_values(model, names, ca.vertsplit(p), dict(zip(fixed_names, ca.vertsplit(fx))))
    args = [values[k] for k in model.parameters]
    G = model["gradient"](th, *args)
    H = model["hessian"](th, *args)
    L = values["L"]
    tip = model["kinematics"](th, L)[0][:2]
    curv = ca.dot(v, ca.mtimes(H, v))  # v' H v: the smallest eigenvalue's derivative along v
    G_p, curv_p = ca.jacobian(G, p), ca.gradient(curv, p)
    columns, curv_columns = [], []
    for j, name in enumerate(names):
        kind, k = _kind(name)
        if kind != "s":
            columns.append(G_p[:, j])
            curv_columns.append(curv_p[j])
            continue
        # the payload point: the closed form of the module docstring (AD halves it at the clamps' ties)
        s = p[j]
        sigma = ca.vertcat(*[ca.fmin(ca.fmax(n * s - i, 0.0), 1.0) for i in range(n)])
        h = model["centreline"](th, L, s)[2]
        F, Om = values[f"F{k}"], values[f"Omega{k}"]
        columns.append(F * L * ca.sin(Om + h) * sigma)
        curv_columns.append(F * L * ca.cos(Om + h) * ca.dot(sigma, v) ** 2)
    fun = ca.Function(
        "esba_sensitivity",
        [th, p, fx, v],
        [G, H, ca.horzcat(*columns), tip, ca.jacobian(tip, th), ca.jacobian(tip, p), ca.gradient(curv, th), ca.vertcat(*curv_columns)],
        ["theta", "p", "fixed", "v"],
        ["G", "H", "G_p", "tip", "tip_theta", "tip_p", "curv_theta", "curv_p"],
    )
    return fun


def fold_check(eig: np.ndarray, dlam: np.ndarray, p: np.ndarray, names: Sequence[str], units: Sequence[str], options: SensitivityOptions,
               not_stable: str | None = None, *, hessian: str = "Hessian", where: str = "a fold (a snap-through)", unknown: str = "dtheta") -> tuple:
    """Whether derivatives at a state with Hessian eigenvalues ``eig`` (ascending) mean anything:
    ``(ratio, fold_distance, status, message)``. ``dlam`` is d(smallest eigenvalue)/dp per
    parameter, so the linear distance to a zero eigenvalue is -eig[0]/dlam (inf when it does not
    fall); ``not_stable`` says why the state is not a converged stable equilibrium (None: it is).
    The planar sensitivities and the 3-D ones (:mod:`esba.analysis.sensitivity3d`, ``hessian``,
    ``where`` and ``unknown`` in their words) judge by this one rule."""
    ratio = float(eig[0] / max(abs(eig[-1]), 1e-300))
    with np.errstate(divide="ignore", invalid="ignore"):
        dist = np.where(dlam * eig[0] < 0, -eig[0] / dlam, np.inf)
        relative = np.where(p != 0.0, np.abs(dist) / np.abs(p), np.inf)
    closest = int(np.argmin(relative))
    status, message = "ok", ""
    if not_stable is not None:
        status = "not_stable"
        message = f"no sensitivities: the state is not a converged stable equilibrium ({not_stable})"
    elif ratio < options.fold_tol or relative[closest] < options.fold_distance_tol:
        status = "near_fold"
        why = (f"{ratio:.2g} x the largest < fold_tol = {options.fold_tol:g}" if ratio < options.fold_tol else
               f"it reaches 0 when {names[closest]} changes by {dist[closest]:+.3g} {units[closest]}, "
               f"{relative[closest]:.2g} of its value < fold_distance_tol = {options.fold_distance_tol:g}")
        message = (
            f"no sensitivities: the {hessian} is nearly singular (smallest eigenvalue {eig[0]:.3g} N mm/rad^2; {why}): the equilibrium "
            f"is at or next to {where}, where {unknown}/dp grows without bound and a first-order answer holds for no "
            "finite change"
        )
    return ratio, dist, status, message


class ParameterColumns:
    """What the planar and the 3-D sensitivities share: ``status`` and ``parameters`` (a column each)."""

    status: str
    parameters: tuple[Parameter, ...]

    @property
    def ok(self) -> bool:
        """The derivatives are meaningful (a stable equilibrium away from a fold)."""
        return self.status == "ok"

    @property
    def names(self) -> tuple[str, ...]:
        """The parameter names, in column order."""
        return tuple(p.name for p in self.parameters)

    def index(self, name: str) -> int:
        """Column of parameter ``name``."""
        try:
            return self.names.index(name)
        except ValueError:
            raise SensitivityError(f"parameter {name!r}: allowed are {', '.join(self.names)}") from None


@dataclass(frozen=True, eq=False, repr=False)
class Sensitivities(ParameterColumns, Report):
    """First-order response of an equilibrium to each scene parameter.

    Derivatives are per unit of the parameter (:attr:`Parameter.unit`); angles in radians, tip
    in mm (the ``*_deg`` accessors and :meth:`to_dict` give degrees).

    Attributes
    ----------
    parameters : tuple of Parameter
    dtheta : ndarray, shape (n, m)
        d theta_i / d p_j, rad per unit.
    dtotal : ndarray, shape (m,)
        d theta_TOL / d p_j, rad per unit.
    dtip : ndarray, shape (2, m)
        d [x, y]_tip / d p_j, mm per unit.
    fold_distance : ndarray, shape (m,)
        The change of p_j at which the smallest Hessian eigenvalue would reach 0, extrapolated
        linearly (signed: the direction of the fold; inf when it does not move toward 0). Near a
        fold the eigenvalue falls like the square root of the distance to it, so the fold is
        about half as far as this estimate.
    status : str
        ``ok``; ``near_fold`` (H nearly singular: no numbers); ``not_stable`` (the state is not a
        converged stable equilibrium: no numbers).
    message : str
        Why there are no numbers.
    eigenvalue_ratio : float
        Smallest over largest Hessian eigenvalue.
    held : dict
        What each derivative holds fixed besides the other parameters (:func:`held_fixed`): the
        pressure, or the unloaded target angle (then the pressure moves with the parameter).

    Derivatives that are round-off of an exact zero are 0 (:data:`ROUND_OFF`).
    """

    parameters: tuple[Parameter, ...]
    dtheta: np.ndarray
    dtotal: np.ndarray
    dtip: np.ndarray
    fold_distance: np.ndarray
    status: str
    message: str
    eigenvalue_ratio: float
    held: dict = dataclasses.field(default_factory=dict)

    _plotter = "esba.figures.results:draw_sensitivities"

    def headline(self) -> str:
        """One line: the status and the parameters."""
        names = [p.name for p in self.parameters]
        shown = ", ".join(names[:8]) + (", ..." if len(names) > 8 else "")
        return f"{self.status}: d(angles, tip)/d(parameter) for {len(names)} parameters ({shown})" if self.ok else f"{self.status}: {self.message}"

    def summary(self) -> str:
        """The sensitivity lines ``esba solve --sensitivities`` prints."""
        from esba.statics.text import sensitivity_rows

        return "\n".join(f"{k:>12}: {v}" for k, v in sensitivity_rows({"sensitivities": self.to_dict()}))

    def total_angle(self, name: str) -> float:
        """d theta_TOL / d p, degrees per unit of p."""
        return math.degrees(float(self.dtotal[self.index(name)]))

    def tip(self, name: str) -> np.ndarray:
        """d [x, y]_tip / d p, mm per unit of p."""
        return self.dtip[:, self.index(name)].copy()

    def to_dict(self) -> dict:
        """JSON-ready form (``esba solve --sensitivities --json``): per unit of each parameter; None unless ok."""
        out: dict[str, Any] = {
            "status": self.status,
            "message": self.message,
            "eigenvalue_ratio": jsonsafe.clean(self.eigenvalue_ratio),
            "held_fixed": dict(self.held),
            "round_off": f"a derivative is 0 when the change it predicts for a change of its parameter by the parameter's own size "
            f"(or one unit where it is 0) is at most {ROUND_OFF:g} of the largest such change of the same quantity",
        }
        rows = {}
        ok = self.ok
        for j, p in enumerate(self.parameters):
            fd = self.fold_distance[j]
            rows[p.name] = {
                "description": p.description,
                "value": p.value,
                "unit": p.unit,
                "dtheta_deg_per_unit": [math.degrees(float(v)) for v in self.dtheta[:, j]] if ok else None,
                "dtotal_angle_deg_per_unit": math.degrees(float(self.dtotal[j])) if ok else None,
                "dtip_mm_per_unit": [float(v) for v in self.dtip[:, j]] if ok else None,
                "fold_distance": float(fd) if ok and math.isfinite(fd) else None,
            }
        out["parameters"] = rows
        return jsonsafe.clean(out)


def sensitivities(result: Equilibrium, parameters: Sequence[str] | None = None, options: SensitivityOptions | None = None) -> Sensitivities:
    """d theta/dp, d theta_TOL/dp and d tip/dp at a solved equilibrium, for every scene parameter.

    Parameters
    ----------
    result : Equilibrium
        A solve (:func:`esba.statics.equilibrium.solve`); its scene, pressure, angles and model are used.
    parameters : sequence of str, optional
        Which parameters (default all of :func:`parameter_names`).
    options : SensitivityOptions, optional

    Returns
    -------
    Sensitivities
        Check :attr:`Sensitivities.ok`: near a fold, or at a state that is not a converged stable
        equilibrium, it carries a message instead of numbers.
    """
    options = SensitivityOptions() if options is None else options
    if not isinstance(result, Equilibrium):
        raise SensitivityError(f"result={result!r}: expected an Equilibrium (from esba.statics.equilibrium.solve)")
    scene, model = result.scene, result.model
    names = parameter_names(scene)
    if isinstance(parameters, str):  # one name, as the CLI's single NAME
        parameters = [parameters]
    if parameters is not None and not isinstance(parameters, (list, tuple)):
        raise SensitivityError(f"parameters={checks.quote(parameters)}: expected a list of parameter names, such as ['E', 'rho']")
    chosen = names if parameters is None else check_names(scene, list(parameters))
    twice = sorted({p for p in chosen if chosen.count(p) > 1})
    if twice:
        raise SensitivityError(f"parameters: {', '.join(twice)} given twice")
    params = scene_parameters(scene)
    p = np.array([q.value for q in params])
    fixed_names = tuple(k for k in model.parameters if k == "g" and "g" not in names)
    fixed = np.array([scene.g for _ in fixed_names])
    fun = implicit_functions(model, names, fixed_names)
    theta = np.asarray(result.theta, dtype=float)
    n, m = model.n, len(names)
    eig, vecs = np.linalg.eigh(np.asarray(model.hessian(theta, model.param_vector(result.parameters))))
    v = vecs[:, 0]
    out = fun(theta, p, fixed, v)
    H, G_p = np.asarray(out[1], dtype=float), np.asarray(out[2], dtype=float).reshape(n, m)
    tip_th, tip_p = np.asarray(out[4], dtype=float).reshape(2, n), np.asarray(out[5], dtype=float).reshape(2, m)
    curv_th, curv_p = np.asarray(out[6], dtype=float).ravel(), np.asarray(out[7], dtype=float).ravel()
    dtheta = -np.linalg.solve(H, G_p)
    dtip = tip_th @ dtheta + tip_p
    # d(lambda_min)/dp = v' (dH/dp + dH/dtheta dtheta/dp) v, then the linear distance to lambda_min = 0
    ratio, dist, status, message = fold_check(eig, curv_p + curv_th @ dtheta, p, names, [q.unit for q in params], options,
                                              None if result.ok else (result.message or result.status))
    # round-off of exact zeros, judged against every parameter of the scene (whatever subset is asked for)
    scale = np.where(p != 0.0, np.abs(p), 1.0)
    dtotal = _zero_round_off(np.sum(dtheta, axis=0)[None, :], scale)[0]
    dtheta, dtip = _zero_round_off(dtheta, scale), _zero_round_off(dtip, scale)
    cols = [names.index(c) for c in chosen]
    return Sensitivities(
        parameters=tuple(params[j] for j in cols),
        dtheta=dtheta[:, cols],
        dtotal=dtotal[cols],
        dtip=dtip[:, cols],
        fold_distance=np.asarray(dist)[cols],
        status=status,
        message=message,
        eigenvalue_ratio=ratio,
        held=held_fixed(scene),
    )

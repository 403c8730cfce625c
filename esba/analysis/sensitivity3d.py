"""Parameter sensitivities of a 3-D equilibrium: the implicit function theorem on the generated 3-D model.

The planar derivation (:mod:`esba.analysis.sensitivity`) carried over to the spatial model's state
q = (theta, psi, tau): at an equilibrium G(q*, p) = dU/dq = 0, so dq/dp = -H^-1 dG/dp with H the
generated 3n x 3n Hessian and dG/dp the derivative of the generated 3-D gradient by CasADi's
automatic differentiation. The outputs y are the tip (x, y, z, mm), the total in-plane bend
sum(theta), the total sideways bend sum(psi) and the total twist sum(tau) (rad), with
dy/dp = dy/dq dq/dp + dy/dp|q (the tip also depends on L directly).

The parameters (:func:`parameter_names3d`) are the planar scene's (the same names, units and
meaning, a target angle included: the pressure then follows it in closed form) and, in 3-D,
each payload's angle out of the bending plane ``Beta1``, ... (deg, the scene's
``out_of_plane_deg``) and the section's sideways and torsional stiffness ``EI_side``, ``GJ``
(N mm^2). A scene's point moments and couples are held (no moment is a parameter). The section is an input here: when it comes from the eccentric section
(:func:`esba.statics.spatial.check_section`) it is derived once for the nominal scene and held,
so a change of E or r2 does not move EI_side and GJ (give them their own sigma); the 3-D sweep
(:mod:`esba.studies.sweep3d`) holds the section the same way.

The payload point s enters the model through the clamps of the segment fractions (see the planar
module): its column is the derivative from the left (evaluated a relative 1e-13 inside the
segment, where the clamps are smooth), continuous across segment ends and one-sided at the tip.

Near a fold, or at a state that is not stable, the result gives no numbers, by the planar rules
(:class:`esba.analysis.sensitivity.SensitivityOptions`), now on the 3n x 3n Hessian: a sideways
buckling mode counts as a fold.

For a scene whose loads lie in the bending plane the 3-D Hessian splits into the in-plane block
(the planar model's) and the out-of-plane block, so dtheta/dp, the tip's x and y and the total
angle are the planar sensitivities (tested to 1e-10), and psi and tau do not move (except with
Beta, which pushes the finger out of its plane).

>>> from esba.model.scene import Payload, Scene
>>> from esba.statics.spatial import check_section, solve_scene3d
>>> scene = Scene(pressure=0.12, payloads=(Payload(0.6, 90.0, 1.0, 20.0),))
>>> section = check_section({"EI_side": 4e5, "GJ": 1e5}, scene)
>>> s = sensitivities3d(scene, section, solve_scene3d(scene, section))
>>> s.status, round(s.output("tip_z", "Beta1"), 4), round(s.output("twist", "GJ") * 1e6, 4)   # mm per deg; deg per N mm^2, x 1e6
('ok', 0.0296, -4.264)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import casadi as ca
import numpy as np

from esba.infra import checks, jsonsafe
from esba.infra.report import Report
from esba.model.scene import Payload, Scene, SceneError

from .sensitivity import (
    Parameter,
    ParameterColumns,
    SensitivityError,
    SensitivityOptions,
    held_fixed,
    _zero_round_off,
    fold_check,
    model_values,
    parameter_names,
    scene_parameters,
    with_parameters,
)

__all__ = ["OUTPUTS3D", "UNITS3D", "parameter_names3d", "scene_parameters3d", "check_names3d", "with_parameters3d", "Sensitivities3D",
           "sensitivities3d"]

#: The 3-D outputs: name, unit as reported (angles in degrees at the edges), index in y.
OUTPUTS3D = (("tip_x", "mm"), ("tip_y", "mm"), ("tip_z", "mm"), ("total_angle", "deg"), ("sideways", "deg"), ("twist", "deg"))

#: Units of the parameters only the 3-D model has.
UNITS3D = {"Beta": "deg", "EI_side": "N*mm^2", "GJ": "N*mm^2"}
_DESCRIPTIONS3D = {"Beta": "angle of payload out of the bending plane", "EI_side": "sideways bending stiffness", "GJ": "torsional stiffness"}
_SECTION = ("EI_side", "GJ")


def _beta(name: str) -> int:
    """k of ``Beta<k>`` (k >= 1), else 0."""
    return int(name[4:]) if name.startswith("Beta") and name[4:].isdigit() and int(name[4:]) >= 1 else 0


def parameter_names3d(scene: Scene) -> tuple[str, ...]:
    """The 3-D scene's parameters: the planar ones, ``Beta<k>`` of each payload, ``EI_side`` and ``GJ``.

    >>> from esba.model.scene import MAIN_JOB
    >>> parameter_names3d(MAIN_JOB)[-3:]
    ('Beta1', 'EI_side', 'GJ')
    """
    return (*parameter_names(scene), *[f"Beta{k}" for k in range(1, len(scene.payloads) + 1)], *_SECTION)


def scene_parameters3d(scene: Scene, section: Mapping[str, float]) -> tuple[Parameter, ...]:
    """The 3-D parameters with units, meanings and values (``section``: both stiffnesses, N mm^2)."""
    out = list(scene_parameters(scene))
    for k, p in enumerate(scene.payloads, start=1):
        out.append(Parameter(f"Beta{k}", UNITS3D["Beta"], f"{_DESCRIPTIONS3D['Beta']} {k}", float(p.out_of_plane_deg)))
    out += [Parameter(name, UNITS3D[name], _DESCRIPTIONS3D[name], float(section[name])) for name in _SECTION]
    return tuple(out)


def check_names3d(scene: Scene, names: Sequence[str], where: str = "parameter") -> tuple[str, ...]:
    """``names`` if each is a 3-D parameter of ``scene``; else a :class:`SensitivityError` naming it."""
    allowed = parameter_names3d(scene)
    for name in names:
        if name not in allowed:
            hint = " (this scene sets the pressure by target_angle_deg: use target_angle, or give a pressure)" if name == "P" and "target_angle" in allowed else ""
            raise SensitivityError(f"{where} {name!r} is not a parameter of this 3-D scene{hint}; allowed are {', '.join(allowed)}")
    return tuple(names)


def with_parameters3d(scene: Scene, section: Mapping[str, float], values: Mapping[str, float]) -> tuple[Scene, dict]:
    """``(scene, section)`` with some 3-D parameters set (scene-file units), validated like any scene.

    Raises
    ------
    SensitivityError
        for a name that is not a 3-D parameter of the scene.
    SceneError
        for a value the scene does not allow (r2 + d >= r1, |Beta| > 90, a stiffness <= 0).

    >>> from esba.model.scene import MAIN_JOB
    >>> s, sec = with_parameters3d(MAIN_JOB, {"EI_side": 4e5, "GJ": 1e5}, {"E": 0.6, "Beta1": 20.0, "GJ": 2e4})
    >>> s.actuator.E, s.payloads[0].out_of_plane_deg, sec
    (0.6, 20.0, {'EI_side': 400000.0, 'GJ': 20000.0})
    """
    if not isinstance(values, Mapping):
        raise SensitivityError(f"values={checks.quote(values)}: expected a mapping of parameter name to value, such as {{'E': 0.6}}")
    check_names3d(scene, list(values))
    planar = {k: v for k, v in values.items() if not _beta(k) and k not in _SECTION}
    scene = with_parameters(scene, planar) if planar else scene
    payloads = list(scene.payloads)
    section = dict(section)
    for name, value in values.items():
        k = _beta(name)
        if k:
            p = payloads[k - 1]
            payloads[k - 1] = Payload(p.force, p.angle_deg, p.at, checks.finite(name, value, SceneError))
        elif name in _SECTION:
            v = checks.finite(name, value, SceneError)
            if not v > 0.0:
                raise SceneError(f"{name}={v:g}: expected a stiffness > 0 N*mm^2")
            section[name] = v
    if payloads != list(scene.payloads):
        scene = scene.replace(payloads=tuple(payloads))
    return scene, section


def _build(model, unloaded, names: tuple[str, ...], down: tuple[float, float, float], fixed: tuple[str, ...]) -> ca.Function:
    """(q, p, fixed, v) -> G, H, dG/dp, y, dy/dq, dy/dp, d(v'Hv)/dq, d(v'Hv)/dp, p in scene-file units;
    ``fixed`` the model's parameters that no scene parameter sets (a moment's components: held)."""
    n = model.n
    q = ca.SX.sym("q", model.size)
    p = ca.SX.sym("p", len(names))
    fx = ca.SX.sym("fixed", len(fixed))
    v = ca.SX.sym("v", model.size)
    parts = ca.vertsplit(p)
    values: dict[str, Any] = model_values(unloaded, names, parts, dict(zip(fixed, ca.vertsplit(fx))))  # a target angle sets P
    for name, x in zip(names, parts):
        if _beta(name):
            values[name] = x * (math.pi / 180.0)
    if "g" in values:
        values.update(gx=values["g"] * down[0], gy=values["g"] * down[1], gz=values["g"] * down[2])
    args = [values[k] for k in model.parameters]
    G = model.functions["gradient"](q, *args)
    H = model.functions["hessian"](q, *args)
    tip = model.functions["kinematics"](q, values["L"])[0]
    y = ca.vertcat(tip, ca.sum1(q[:n]), ca.sum1(q[n:2 * n]), ca.sum1(q[2 * n:]))
    curv = ca.dot(v, ca.mtimes(H, v))
    return ca.Function("esba3d_sensitivity", [q, p, fx, v],
                       [G, H, ca.jacobian(G, p), y, ca.jacobian(y, q), ca.jacobian(y, p), ca.gradient(curv, q), ca.gradient(curv, p)],
                       {"cse": True})


def _function(model, scene: Scene, names: tuple[str, ...], down, fixed: tuple[str, ...]) -> ca.Function:
    key = ("sensitivity3d", names, tuple(float(x) for x in down), scene.variant, fixed)
    found = model.registry.get(key)
    if found is None:
        found = _build(model, scene.unloaded().model(), names, tuple(float(x) for x in down), fixed)
        model.registry[key] = found
    return found


def _fixed(model, names: Sequence[str]) -> tuple[str, ...]:
    """The model's parameters that no scene parameter of ``names`` sets (a moment's components)."""
    made = {*names, "P", "gx", "gy", "gz"}  # model_values keeps each name (a target angle sets P); gravity's components follow g
    return tuple(k for k in model.parameters if k not in made)


@dataclass(frozen=True, eq=False, repr=False)
class Sensitivities3D(ParameterColumns, Report):
    """First-order response of a 3-D equilibrium to each parameter (per unit of the parameter).

    Attributes
    ----------
    parameters : tuple of Parameter
    dq : ndarray, shape (3n, m)
        d(theta, psi, tau)/dp, rad per unit.
    dout : ndarray, shape (6, m)
        d(tip x, y, z [mm]; total angle, sideways, twist [rad])/dp per unit (:data:`OUTPUTS3D`).
    fold_distance : ndarray, shape (m,)
        As :attr:`esba.analysis.sensitivity.Sensitivities.fold_distance`, on the 3n x 3n Hessian.
    status, message : str
        ``ok``, ``near_fold`` or ``not_stable`` (no numbers), as in the plane.
    eigenvalue_ratio : float
    held : dict
        What each derivative holds fixed (:func:`esba.analysis.sensitivity.held_fixed`); the section is held too.
    """

    parameters: tuple[Parameter, ...]
    dq: np.ndarray
    dout: np.ndarray
    fold_distance: np.ndarray
    status: str
    message: str
    eigenvalue_ratio: float
    held: dict

    def headline(self) -> str:
        return f"{self.status}: d(q, tip, total angles)/d(parameter) for {len(self.parameters)} parameters" if self.ok else f"{self.status}: {self.message}"

    def summary(self) -> str:
        if not self.ok:
            return self.headline()
        rows = []
        for j, p in enumerate(self.parameters):
            d = [self.output(o, p.name) for o, _ in OUTPUTS3D]
            rows.append(f"{p.name:>12}: d tip {d[0]:.4g}, {d[1]:.4g}, {d[2]:.4g} mm, d angle {d[3]:.4g}, sideways {d[4]:.4g}, twist {d[5]:.4g} deg per {p.unit}")
        return "\n".join(rows)

    def output(self, output: str, name: str) -> float:
        """d output / d parameter, in the output's reported unit (mm or deg) per unit of the parameter."""
        i = [o for o, _ in OUTPUTS3D].index(output)
        v = float(self.dout[i, self.index(name)])
        return math.degrees(v) if i >= 3 else v

    def to_dict(self) -> dict:
        ok = self.ok
        rows = {}
        for j, p in enumerate(self.parameters):
            fd = self.fold_distance[j]
            rows[p.name] = {"description": p.description, "value": p.value, "unit": p.unit,
                            **{f"d{o}_{u}_per_unit": (self.output(o, p.name) if ok else None) for o, u in OUTPUTS3D},
                            "fold_distance": float(fd) if ok and math.isfinite(fd) else None}
        return jsonsafe.clean({"status": self.status, "message": self.message, "eigenvalue_ratio": self.eigenvalue_ratio,
                               "held_fixed": dict(self.held), "parameters": rows})


def sensitivities3d(scene: Scene, section: Mapping[str, float], result, parameters: Sequence[str] | None = None,
                    options: SensitivityOptions | None = None, *, gravity_direction=None) -> Sensitivities3D:
    """dq/dp and d(tip, total angles)/dp at a 3-D equilibrium ``result``
    (:class:`esba.statics.spatial.Equilibrium3D` of ``scene`` with the complete ``section``)."""
    from esba.model.spatial import load_model3d
    from esba.statics.spatial import Equilibrium3D, check_direction, scene_values3d

    options = SensitivityOptions() if options is None else options
    if not isinstance(result, Equilibrium3D):
        raise SensitivityError(f"result={checks.quote(result)}: expected an Equilibrium3D (from esba.statics.spatial.solve_scene3d)")
    down = tuple(check_direction("gravity direction", scene.down(gravity_direction)))
    effects, _ = scene_values3d(scene, section, down)
    model = load_model3d(scene.segments, effects, scene.variant)
    names = parameter_names3d(scene)
    if isinstance(parameters, str):
        parameters = [parameters]
    chosen = names if parameters is None else check_names3d(scene, list(parameters))
    params = scene_parameters3d(scene, section)
    p = np.array([x.value for x in params])
    fixed = _fixed(model, names)
    fun = _function(model, scene, names, down, fixed)
    q = np.asarray(result.q, dtype=float)
    values = scene_values3d(scene, section, down)[1]
    fx = np.array([float(values[k]) for k in fixed])
    eig, vecs = np.linalg.eigh(model.hessian(q, values))
    v = vecs[:, 0]
    out = [np.asarray(x, dtype=float) for x in fun(q, p, fx, v)]
    N, m = model.size, len(names)
    H, G_p, y_q, y_p = out[1], out[2].reshape(N, m), out[4].reshape(6, N), out[5].reshape(6, m)
    curv_q, curv_p = out[6].ravel(), out[7].ravel()
    s_cols = [j for j, nm in enumerate(names) if nm[:1] == "s" and nm[1:].isdigit()]
    if s_cols:  # the payload point: from the left, where the segment fractions' clamps are smooth
        left = p.copy()
        left[s_cols] *= 1.0 - 1e-13
        ol = [np.asarray(x, dtype=float) for x in fun(q, left, fx, v)]
        G_p[:, s_cols] = ol[2].reshape(N, m)[:, s_cols]
        curv_p[s_cols] = ol[7].ravel()[s_cols]
    dq = -np.linalg.solve(H, G_p)
    dout = y_q @ dq + y_p
    why = None if result.ok else ("not converged" if not result.converged else "unstable: the 3n x 3n Hessian is not positive definite")
    ratio, dist, status, message = fold_check(eig, curv_p + curv_q @ dq, p, names, [x.unit for x in params], options, why,
                                              hessian="3n x 3n Hessian", where="a fold or a sideways buckling point", unknown="dq")
    scale = np.where(p != 0.0, np.abs(p), 1.0)
    dq, dout = _zero_round_off(dq, scale), _zero_round_off(dout, scale)
    cols = [names.index(c) for c in chosen]
    return Sensitivities3D(tuple(params[j] for j in cols), dq[:, cols], dout[:, cols], np.asarray(dist)[cols], status, message, ratio,
                           {**held_fixed(scene), "section": "held at the given or nominal scene's EI_side and GJ unless they are parameters"})


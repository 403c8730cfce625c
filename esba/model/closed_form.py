"""The one closed form of the statics: the pressure that holds the unloaded actuator at a total angle.

Without payloads and weight the equilibrium is the uniform bend theta_i = Theta / n, and the
energy is linear in the pressure P (Eq. 5 and 18), so at that shape dU/dtheta = g0 + P g1 and

    P(Theta) = -(g0 . g1) / (g1 . g1)

exactly, from the generated gradient at P = 0 and P = 1 (payload forces and g set to 0).
:func:`unloaded_pressure` is that formula on CasADi expressions (an NLP, a compiled batch, the
design evaluator build it into their graphs) or on numbers; :func:`pressure_for_angle` is the
same for a :class:`~esba.model.scene.Scene`, with its checks, kept per scene and angle.

Examples
--------
>>> from esba.model.scene import Scene
>>> round(pressure_for_angle(Scene(), 90.0), 7)
0.1238739
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any, Mapping, Sequence

import casadi as ca
import numpy as np

from esba.infra import checks
from esba.infra.errors import EquilibriumError

from .generated import Model
from .scene import Scene, SceneError, check_target_angle

__all__ = ["pressure_for_angle", "unloaded_pressure", "load_parameter", "chain_tip"]


def load_parameter(name: str) -> bool:
    """True for the model parameters that carry a load: a payload's force ``F<k>`` and gravity's ``g``."""
    return (name.startswith("F") and name[1:].isdigit()) or name == "g"


def unloaded_pressure(model: Model, total_angle: Any, values: Mapping[str, Any]) -> Any:
    """The pressure that holds the unloaded actuator at a uniform bend of ``total_angle`` (rad).

    ``values`` maps every name of ``model.parameters`` to a number or a CasADi expression
    (radians for ``rho`` and ``Omega_k``); ``P`` and the loads are ignored (the loads are set to 0).
    Returns a CasADi expression (a DM for numbers).
    """
    n = model.n
    symbolic = isinstance(total_angle, (ca.SX, ca.MX))
    uniform = ca.repmat(total_angle / n, n, 1) if symbolic else ca.DM.ones(n) * (float(total_angle) / n)
    base = {k: (0.0 if load_parameter(k) else values[k]) for k in model.parameters if k != "P"}

    def gradient(pressure: float) -> Any:
        return model["gradient"](uniform, *[pressure if k == "P" else base[k] for k in model.parameters])

    g0 = gradient(0.0)
    g1 = gradient(1.0) - g0
    return -ca.dot(g0, g1) / ca.dot(g1, g1)


def pressure_for_angle(scene: Scene, angle_deg: float | None = None) -> float:
    """The pressure (MPa) that bends the unloaded actuator of ``scene`` to a total angle, in closed form.

    Parameters
    ----------
    scene : Scene
        Actuator, fibres, segment count and variant (payloads and gravity are ignored).
    angle_deg : float, optional
        Target total angle Theta in degrees; default the scene's ``target_angle_deg``.

    Raises
    ------
    EquilibriumError
        when no pressure >= 0 holds the actuator at that angle.
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"scene={scene!r}: expected an esba.model.scene.Scene")
    if angle_deg is None:
        angle_deg = scene.target_angle_deg
    if angle_deg is None:
        raise EquilibriumError("pressure_for_angle needs angle_deg (the scene gives a pressure, not a target angle)")
    return _pressure_for_angle(scene, check_target_angle(angle_deg))  # the bounds a Scene's target angle has


@lru_cache(maxsize=1024)
def _pressure_for_angle(scene: Scene, angle_deg: float) -> float:
    """:func:`pressure_for_angle`, kept per scene and angle (a stiffness computation asks several times)."""
    model = scene.model()
    values = scene.parameters(0.0, load_factor=0.0)
    with np.errstate(all="ignore"):
        pressure = float(unloaded_pressure(model, math.radians(angle_deg), values))
    if not math.isfinite(pressure):
        raise EquilibriumError(f"target_angle_deg={angle_deg:g}: outside the model's domain for this actuator")
    if pressure < 0:
        raise EquilibriumError(f"target_angle_deg={angle_deg:g}: would need a negative pressure ({pressure:.4g} MPa)")
    return pressure


def chain_tip(theta: Sequence[float], L: float) -> tuple[float, float]:
    """The tip (x, y in mm) of the chain of arcs (Eq. 1-2) of segment angles ``theta`` (rad) and
    length ``L``, in closed form: each segment an arc of length L/n turning by theta_i, its chord
    2 (L/n) sin(theta_i/2) / theta_i along the mean heading. The generated kinematics' tip, without
    a model (a resumed study checks its rows' tips with it).

    >>> [round(v, 6) for v in chain_tip([0.3, 0.5, 0.9], 135.0)]
    [96.008697, 71.253767]
    """
    n = len(theta)
    seg = L / n
    x = y = heading = 0.0
    for t in theta:
        t = float(t)
        chord = seg * (1.0 - t * t / 24.0) if abs(t) < 1e-6 else 2.0 * seg * math.sin(t / 2.0) / t
        x += chord * math.cos(heading + t / 2.0)
        y += chord * math.sin(heading + t / 2.0)
        heading += t
    return x, y


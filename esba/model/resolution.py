"""Whether the solver can resolve a scene at all: its stiffness and loads against the tolerances.

An equilibrium is accepted when max |dU/dtheta_i| <= ``stationarity_tol`` (N mm/rad, absolute).
That test means something only when the scene's scales fit it:

* The bending stiffness of a segment at theta = 0, from Eq. (8),
  k = n E pi (5 r1^4 - 4 r2^2 (r1 + d)^2 - r2^4) / (4 L), turns the tolerance into an angle,
  tol / k. Above :data:`ANGLE_RESOLUTION` rad, every nearby angle passes as an equilibrium:
  with E = 1e-300 a 90 degree target "converged" to 110 degrees and said ok.
* The loads' moments on a segment (P pi r1^3 from Eq. 5, F L, M g L) are what the gradient
  balances; in double precision it cannot be computed closer to zero than a few machine epsilons
  of them, so moments beyond ``tol / (ROUNDOFF_FACTOR eps)`` cannot meet the tolerance (a
  pressure of 1e300 MPa flooded stderr with CasADi warnings and never converged).

:func:`check_resolvable` refuses such a scene before solving, with one line naming the field,
its value and the bound for this actuator.

Examples
--------
>>> from esba.model.scene import MAIN_JOB
>>> round(segment_stiffness(MAIN_JOB), 1)
143.4
>>> check_resolvable(MAIN_JOB.replace(E=1e-9), 0.1, 1e-7)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
esba.model.scene.SceneError: actuator.E=1e-09 MPa: the bending stiffness of a segment, 2.66e-07 N mm/rad, is too small ...
"""

from __future__ import annotations

import math

import numpy as np

from .scene import Scene, SceneError

__all__ = ["ANGLE_RESOLUTION", "ROUNDOFF_FACTOR", "MIN_DOMAIN_WIDTH", "segment_stiffness", "min_modulus", "max_pressure", "check_stiffness", "min_chamber_radius", "check_domain", "check_resolvable"]

#: The largest angle (rad) the stationarity tolerance may leave undetermined: tol / k.
ANGLE_RESOLUTION = 1e-3
#: The narrowest domain of segment angles (rad) the solver can work in: Eq. (10)'s chamber closes
#: at theta_i = -L r2^2 / (n r1^3), and a solve within 1e-7 rad of that edge is not accepted as an
#: equilibrium (:func:`esba.model.generated.near_domain_bound`), so a narrower domain leaves no room even
#: for the straight state.
MIN_DOMAIN_WIDTH = 1e-5
#: Round-off allowance: moments up to tol / (ROUNDOFF_FACTOR * machine epsilon) can be balanced
#: to tol in double precision.
ROUNDOFF_FACTOR = 100.0


def segment_stiffness(scene: Scene) -> float:
    """The bending stiffness of one segment at theta = 0 (second derivative of Eq. 8), N mm/rad."""
    a = scene.actuator
    return scene.segments * a.E * math.pi * (5 * a.r1**4 - 4 * a.r2**2 * (a.r1 + a.d) ** 2 - a.r2**4) / (4 * a.L)


def min_modulus(scene: Scene, tol: float) -> float:
    """The smallest Young's modulus (MPa) for which ``tol`` pins the angles of the scene's geometry."""
    return tol / (ANGLE_RESOLUTION * segment_stiffness(scene) / scene.actuator.E)


def max_pressure(r1: float, stationarity_tol: float) -> float:
    """The largest pressure (MPa) whose moment on a segment of external radius ``r1`` (mm)
    double precision balances to ``stationarity_tol`` (the bound :func:`check_resolvable` applies).

    >>> round(max_pressure(8.0, 1e-7))
    2800
    """
    return stationarity_tol / (ROUNDOFF_FACTOR * np.finfo(float).eps) / (math.pi * r1**3)


def check_stiffness(scene: Scene, stationarity_tol: float) -> None:
    """Refuse a segment so stiff that the round-off of its bending moment, about machine epsilon
    times its stiffness per radian, is more than double precision can balance to
    ``stationarity_tol`` (the bound on a pressure's moment in :func:`check_resolvable`). The
    message names the one of E and L that is further from Table 1 (E = 0.54 MPa, L = 135 mm).

    >>> from esba.model.scene import MAIN_JOB
    >>> check_stiffness(MAIN_JOB.replace(L=1e-300), 1e-7)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    esba.model.scene.SceneError: actuator.L=1e-300 mm: the bending stiffness of a segment, 1.94e+304 N mm/rad, ...
    """
    a = scene.actuator
    k = segment_stiffness(scene)
    limit = stationarity_tol / (ROUNDOFF_FACTOR * np.finfo(float).eps)
    if math.isfinite(k) and k <= limit:
        return
    scale = limit / k if math.isfinite(k) and k > 0 else 0.0
    by_e = abs(math.log(a.E / 0.54)) >= abs(math.log(a.L / 135.0))
    if by_e:
        name, value, unit, bound = "E", a.E, "MPa", f"expected E <= {a.E * scale:.3g} MPa for this actuator (rubbers: 0.1 to 10 MPa)"
    else:
        name, value, unit, bound = "L", a.L, "mm", f"expected L >= {a.L / scale if scale else math.inf:.3g} mm for this actuator"
    raise SceneError(
        f"actuator.{name}={value:g} {unit}: the bending stiffness of a segment, {k:.3g} N mm/rad, is more than double precision "
        f"can balance to stationarity_tol = {stationarity_tol:g} N mm/rad; {bound}"
    )


def min_chamber_radius(scene: Scene) -> float:
    """The smallest chamber radius r2 (mm) whose domain (Eq. 10) is :data:`MIN_DOMAIN_WIDTH` wide."""
    a = scene.actuator
    return math.sqrt(MIN_DOMAIN_WIDTH * scene.segments * a.r1**3 / a.L)


def check_domain(scene: Scene) -> None:
    """Refuse a chamber so small that Eq. (10)'s domain of segment angles is narrower than
    :data:`MIN_DOMAIN_WIDTH` (:class:`SceneError`).

    >>> from esba.model.scene import MAIN_JOB
    >>> check_domain(MAIN_JOB.replace(r2=0.001))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    esba.model.scene.SceneError: actuator.r2=0.001 mm: the chamber closes (Eq. 10) at a segment angle of -8.79e-08 rad, ...
    """
    a = scene.actuator
    width = a.L * a.r2**2 / (scene.segments * a.r1**3)
    if not width >= MIN_DOMAIN_WIDTH:
        raise SceneError(
            f"actuator.r2={a.r2:g} mm: the chamber closes (Eq. 10) at a segment angle of {-width if width else 0.0:.3g} rad, too close to the "
            f"straight state for the solver to tell an equilibrium from that edge (allowed {MIN_DOMAIN_WIDTH:g} rad); "
            f"expected r2 >= {min_chamber_radius(scene):.3g} mm for this actuator at n = {scene.segments}"
        )


def check_resolvable(scene: Scene, pressure: float, stationarity_tol: float, reference_tol: float | None = None) -> None:
    """Refuse a scene whose scales the solver cannot resolve to its tolerance (:class:`SceneError`).

    Parameters
    ----------
    scene : Scene
    pressure : float
        The pressure of the solve, MPa (the scene's, or the one found for its target angle).
    stationarity_tol : float
        The solve's tolerance on max |dU/dtheta_i|, N mm/rad.
    reference_tol : float, optional
        For the stiffness test, the smaller of this and ``stationarity_tol`` is used, so that a
        tolerance loosened on purpose (to study IPOPT alone) never admits a scene the default
        tolerance refuses.
    """
    check_stiffness(scene, stationarity_tol)
    check_domain(scene)
    a = scene.actuator
    k = segment_stiffness(scene)
    tol_angle = stationarity_tol if reference_tol is None else min(stationarity_tol, reference_tol)
    if not math.isfinite(k) or tol_angle > ANGLE_RESOLUTION * k:
        play = tol_angle / k if k > 0 else math.inf
        raise SceneError(
            f"actuator.E={a.E:g} MPa: the bending stiffness of a segment, {k:.3g} N mm/rad, is too small for the solver to "
            f"place the angles (a stationarity tolerance of {tol_angle:g} N mm/rad leaves {play:.3g} rad of play, allowed "
            f"{ANGLE_RESOLUTION:g}); expected E >= {min_modulus(scene, tol_angle):.3g} MPa for this actuator (rubbers: 0.1 to 10 MPa)"
        )
    limit = stationarity_tol / (ROUNDOFF_FACTOR * np.finfo(float).eps)
    moments = {"pressure": pressure * math.pi * a.r1**3}
    for j, p in enumerate(scene.payloads, start=1):
        moments[f"payload {j} force"] = p.force * a.L
    if scene.gravity:
        moments["actuator.M (gravity)"] = a.M * scene.g * a.L
    name, moment = max(moments.items(), key=lambda kv: kv[1])
    if not math.isfinite(moment) or moment > limit:
        unit, value, per = ("MPa", pressure, math.pi * a.r1**3) if name == "pressure" else ("N", moment / a.L, a.L)
        origin = "" if name != "pressure" or scene.pressure is not None else f" (for target_angle_deg={scene.target_angle_deg:g})"
        raise SceneError(
            f"{name}={value:g} {unit}{origin}: its moment on a segment, {moment:.3g} N mm, is more than double precision can "
            f"balance to stationarity_tol = {stationarity_tol:g} N mm/rad; expected at most {limit / per:.3g} {unit} for this actuator"
        )

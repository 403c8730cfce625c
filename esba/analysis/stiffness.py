"""Stiffness of the tip and inverse problems for the pressure.

* :func:`secant_stiffness`: the paper's definition (Section 4.4.3): from the unloaded state at
  the 90 degree pressure, pressure held, a tip payload F at direction Omega (horizontal by
  default) moves the tip by delta along the force; K = F / delta, in N/m (K[N/m] = 1000 F[N] /
  delta[mm]). For Omega = 90 degrees delta = -Delta y, the paper's K = Delta F / Delta y.
* :func:`tangent_stiffness`: the 2x2 tip stiffness of any equilibrium from the Hessian: a small
  tip force dF moves the tip by dp = C dF with the compliance C = J H^-1 J^T (J = d tip / d theta);
  K_tip = C^-1 (N/m). The secant stiffness tends, as F -> 0, to the *directional* stiffness
  1 / (u^T C u) along the force's unit vector u (:meth:`TangentStiffness.along`), which is not
  u^T K_tip u: the tip is free to move across the force too.
* :func:`pressure_for_angle` (closed form, from :mod:`esba.statics.equilibrium`), and
  :func:`pressure_for_target`: the pressure that brings the loaded actuator to a total angle or
  a tip position (an NLP over theta and P with dU/dtheta = 0 as constraints, then checked by a
  solve along the physical load path).

Examples
--------
>>> from esba.model.scene import Scene
>>> k = secant_stiffness(Scene(segments=3), forces=(2.0,))
>>> round(k.stiffness_n_per_m[0], 1)
26.4
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Sequence

import casadi as ca
import numpy as np

from esba.infra import checks, jsonsafe
from esba.infra.report import Report
from esba.infra.threads import single_threaded
from esba.model.generated import Model
from esba.model.scene import MAX_PAYLOAD, MAX_TARGET_ANGLE_DEG, Payload, Scene, SceneError, check_pressure
from esba.solvers.eqnlp import EquilibriumNLP, model_gradient
from esba.statics.equilibrium import (
    STEP_OPTIONS,
    Equilibrium,
    EquilibriumError,
    SolverOptions,
    pressure_for_angle,
    solve,
)

__all__ = [
    "TangentStiffness",
    "SecantStiffness",
    "PressureTarget",
    "tangent_stiffness",
    "secant_stiffness",
    "pressure_for_angle",
    "pressure_for_target",
    "tip_jacobian",
    "PAPER_FORCES",
]

#: The payloads of the paper's stiffness study (Section 4.4.3), N.
PAPER_FORCES: tuple[float, ...] = (0.5, 1.0, 2.0)

#: The most payloads one stiffness call solves for (one equilibrium each).
MAX_FORCES = 1_000

#: The smallest payload, N, whose secant stiffness is refused as round-off below it: on Table 1's
#: actuator at the 90 degree target (tangent 55.761 N/m) 1e-9 N moves the tip 1.8e-8 mm of its
#: 86 mm and the secant is 55.7609 N/m; 1e-12 N gives 55.67 (0.2 % off); 1e-300 N gave 2.3e-284 N/m.
MIN_FORCE = 1e-9

def tip_jacobian(model: Model, theta: Sequence[float], L: float) -> np.ndarray:
    """J = d[x, y]_tip / d theta, shape (2, n), mm/rad (CasADi AD of the generated kinematics)."""

    def build() -> ca.Function:
        th = ca.SX.sym("theta", model.n)
        length = ca.SX.sym("L")
        tip = model["kinematics"](th, length)[0]
        return ca.Function("tip_jacobian", [th, length], [ca.jacobian(tip[:2], th)], ["theta", "L"], ["J"])

    fun = model.derived("tip_jacobian", build, builder_files=(__file__,))
    return np.asarray(fun(np.asarray(theta, dtype=float), float(L)), dtype=float).reshape(2, model.n)


def _uniform(scene: Scene) -> np.ndarray:
    """The unloaded state of a scene given by its target angle: every segment at Theta / n (exact)."""
    return np.full(scene.segments, math.radians(scene.target_angle_deg) / scene.segments)


def _unit(angle_deg: float) -> np.ndarray:
    """Unit vector of a force at Omega from the vertical: (cos Omega, -sin Omega), Eq. (14)."""
    om = math.radians(angle_deg)
    return np.array([math.cos(om), -math.sin(om)])


#: Where :attr:`SecantStiffness.tangent` is taken, and how its two readings differ (``esba stiffness``).
TANGENT_STATE = (
    "the unloaded state (F = 0), where every secant K starts; along a direction u, 1 / (u^T C u) is the stiffness "
    "with the tip free to move across the force (what the secant K tends to as F -> 0), while K_tip = C^-1 holds the "
    "tip in the other direction, so its diagonal entries are larger"
)


@dataclass(frozen=True, eq=False)
class TangentStiffness:
    """The tip's tangent stiffness at one equilibrium (loads held as dead loads).

    Attributes
    ----------
    compliance : ndarray
        C = J H^-1 J^T, 2x2, m/N (rows/columns: x down, y horizontal).
    matrix : ndarray or None
        K_tip = C^-1, 2x2, N/m; None when C is singular (n = 1: one degree of freedom moves the
        tip along one direction only).
    """

    compliance: np.ndarray
    matrix: np.ndarray | None

    def along(self, angle_deg: float) -> float:
        """Stiffness for a small tip force at Omega (degrees): 1 / (u^T C u), N/m.

        This is what the secant stiffness tends to as the force tends to 0.
        """
        u = _unit(angle_deg)
        c = float(u @ self.compliance @ u)
        return 1.0 / c if c > 0 else math.inf  # the tip does not move along u to first order (straight, along its axis)

    def to_dict(self) -> dict:
        """JSON-ready form (N/m and m/N); a direction the tip does not move along to first order
        has no finite stiffness: null, with the reason beside it (strict JSON, :mod:`esba.infra.jsonsafe`)."""
        out: dict = {
            "matrix_n_per_m": None if self.matrix is None else self.matrix.tolist(),
            "compliance_m_per_n": self.compliance.tolist(),
        }
        for key, angle in (("horizontal_n_per_m", 90.0), ("vertical_n_per_m", 0.0)):
            k = self.along(angle)
            out[key] = k if math.isfinite(k) else None
            if not math.isfinite(k):
                out[f"{key}_reason"] = "infinite: the tip does not move along this direction to first order"
        return out


@single_threaded
def tangent_stiffness(result: Equilibrium) -> TangentStiffness:
    """The 2x2 tangent stiffness of the tip at an equilibrium, from the generated Hessian.

    Examples
    --------
    >>> from esba.model.scene import Scene
    >>> from esba.statics.equilibrium import solve
    >>> t = tangent_stiffness(solve(Scene(segments=3)))
    >>> round(t.along(90.0), 1)
    55.8
    """
    if not isinstance(result, Equilibrium):
        raise SceneError(f"result={checks.quote(result)}: expected an Equilibrium (from esba.statics.equilibrium.solve)")
    if not result.ok:
        raise EquilibriumError(f"tangent stiffness needs a stable equilibrium: {result.message or result.status}")
    model = result.model
    values = result.parameters
    h = model.hessian(result.theta, model.param_vector(values))
    j = tip_jacobian(model, result.theta, values["L"])
    c_mm = j @ np.linalg.solve(h, j.T)  # mm/N
    c = 0.5 * (c_mm + c_mm.T) / 1000.0  # m/N
    ev = np.linalg.eigvalsh(c)
    k = None if ev[0] <= 1e-10 * ev[-1] else np.linalg.inv(c)
    return TangentStiffness(compliance=c, matrix=k)


@dataclass(frozen=True, eq=False, repr=False)
class SecantStiffness(Report):
    """The paper's secant stiffness for each payload (Section 4.4.3).

    Attributes
    ----------
    pressure : float
        The pressure held, MPa.
    angle_deg : float
        Direction Omega of the tip payload (90 = horizontal).
    forces : tuple of float
        The payloads, N.
    displacement_mm : tuple of float
        Tip displacement along the force from the unloaded state, mm.
    stiffness_n_per_m : tuple of float
        K = 1000 F / displacement, N/m.
    initial : Equilibrium
        The unloaded state (a payload of 0 N).
    loaded : tuple of Equilibrium
        The state under each payload.
    tangent : TangentStiffness
        The tangent stiffness of the unloaded state.
    """

    pressure: float
    angle_deg: float
    forces: tuple[float, ...]
    displacement_mm: tuple[float, ...]
    stiffness_n_per_m: tuple[float, ...]
    initial: Equilibrium = field(repr=False)
    loaded: tuple[Equilibrium, ...] = field(repr=False)

    _plotter = "esba.figures.results:draw_stiffness"

    def headline(self) -> str:
        """One line: the secant stiffness at each payload."""
        ks = ", ".join(f"{k:.2f}" for k in self.stiffness_n_per_m)
        fs = ", ".join(f"{f:g}" for f in self.forces)
        return f"K = {ks} N/m at F = {fs} N ({self.angle_deg:g} deg), P = {self.pressure:.5g} MPa" + ("" if self.ok else "; NOT OK")

    def summary(self) -> str:
        """The text ``esba stiffness`` prints."""
        return stiffness_table(self.to_dict())

    @cached_property
    def tangent(self) -> TangentStiffness:
        """The tangent stiffness of the unloaded state (computed when first asked for)."""
        return tangent_stiffness(self.initial) if self.initial.ok else TangentStiffness(np.full((2, 2), np.nan), None)

    @property
    def ok(self) -> bool:
        """Every solve converged to a stable equilibrium."""
        return self.initial.ok and all(r.ok for r in self.loaded)

    def to_dict(self) -> dict:
        """JSON-ready form (the keys ``esba stiffness --json`` prints); a payload that does not move
        the tip (along a straight actuator's axis) has no finite secant stiffness: null, with the reason."""
        infinite = [f"{f:g} N" for f, k in zip(self.forces, self.stiffness_n_per_m) if not math.isfinite(k)]
        reason = {"stiffness_n_per_m_reason": f"infinite at {', '.join(infinite)}: the payload does not move the tip (displacement 0)"} if infinite else {}
        return jsonsafe.clean({**{
            "ok": self.ok,
            "pressure_mpa": self.pressure,
            "payload_angle_deg": self.angle_deg,
            "payloads_n": list(self.forces),
            "stiffness_n_per_m": list(self.stiffness_n_per_m),
            "displacement_mm": list(self.displacement_mm),
            "tip_mm": [r.tip_mm for r in self.loaded],
            "initial_tip_mm": self.initial.tip_mm,
            "initial_angle_deg": self.initial.total_angle_deg,
            "tangent": {**self.tangent.to_dict(), "state": TANGENT_STATE},
            "segments": self.initial.scene.segments,
            "variant": self.initial.scene.variant,
            "messages": [r.message for r in (self.initial, *self.loaded) if r.message],
            "validity": self.validity(),
        }, **reason})

    def validity(self) -> list[dict]:
        """The validity findings of every solve (:mod:`esba.model.validity`), each with its payload in N."""
        out = []
        for force, r in zip((0.0, *self.forces), (self.initial, *self.loaded)):
            for f in r.validity:
                out.append({**f.to_dict(), "payload_n": force, "message": f"at {force:g} N: {f.message}"})
        return out


@single_threaded
def secant_stiffness(
    scene: Scene,
    forces: Sequence[float] = PAPER_FORCES,
    *,
    angle_deg: float = 90.0,
    options: SolverOptions | None = None,
    pressure: float | None = None,
) -> SecantStiffness:
    """Secant stiffness K = F / delta of the tip from the unloaded state, pressure held.

    Parameters
    ----------
    scene : Scene
        Actuator, pressure setting (default: the 90 degree target), segments, variant, fibres,
        gravity. Its payloads are replaced by one tip payload at ``angle_deg``.
    forces : sequence of float
        Payload magnitudes, N (> 0).
    angle_deg : float
        Direction Omega of the payload (90 = horizontal, the paper's case).
    options : SolverOptions, optional
    pressure : float, optional
        Pressure (MPa) instead of the scene's.

    Returns
    -------
    SecantStiffness
        Check :attr:`SecantStiffness.ok`.
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"scene={scene!r}: expected an esba.model.scene.Scene")
    if isinstance(forces, (str, bytes)):
        raise SceneError(f"forces={checks.quote(forces)}: expected a list of payloads in N")
    try:
        forces = tuple(checks.finite("forces", f, SceneError) for f in forces)
    except TypeError:
        raise SceneError(f"forces={forces!r}: expected a list of payloads in N") from None
    except SceneError:
        raise SceneError(f"forces={list(forces)!r}: expected one or more finite payloads > 0 N") from None
    if not forces or any(f <= 0 for f in forces):
        raise SceneError(f"forces={list(forces)!r}: expected one or more payloads > 0 N")
    if max(forces) > MAX_PAYLOAD:
        raise SceneError(f"forces={list(forces)!r}: expected payloads of at most {MAX_PAYLOAD:g} N (a scene's bound: the model means nothing beyond)")
    small = [f for f in forces if f < MIN_FORCE]
    if small:
        raise SceneError(
            f"payload {small[0]:g} N: below {MIN_FORCE:g} N, the tip would move less than double precision resolves (the secant stiffness would be round-off)"
        )
    if len(forces) > MAX_FORCES:
        raise SceneError(f"forces: {len(forces)} given, at most {MAX_FORCES} (one solve each)")
    checks.finite("angle_deg", angle_deg, SceneError)
    if pressure is not None:
        check_pressure(pressure)
    options = STEP_OPTIONS if options is None else options
    base = scene.replace(payloads=(Payload(0.0, angle_deg, 1.0),))
    if pressure is None:
        pressure = scene.pressure if scene.pressure is not None else pressure_for_angle(scene)
        initial = solve(base, options, pressure=pressure, unloaded=None if scene.pressure is not None else _uniform(scene))
    else:
        initial = solve(base, options, pressure=pressure)
    u = _unit(angle_deg)
    loaded, disp, stiff = [], [], []
    start = initial.theta if initial.ok else None  # every payload ramps from the same unloaded state
    for f in forces:
        r = solve(base.replace(payloads=(Payload(f, angle_deg, 1.0),)), options, pressure=pressure, unloaded=start)
        delta = float(u @ (r.tip[:2] - initial.tip[:2]))
        loaded.append(r)
        disp.append(delta)
        stiff.append(1000.0 * f / delta if delta != 0 else math.inf)
    return SecantStiffness(
        pressure=float(pressure),
        angle_deg=float(angle_deg),
        forces=forces,
        displacement_mm=tuple(disp),
        stiffness_n_per_m=tuple(stiff),
        initial=initial,
        loaded=tuple(loaded),
    )


# ---------------------------------------------------------------------------------------------
# pressure for a target under payloads


@dataclass(frozen=True, eq=False)
class PressureTarget:
    """The pressure that brings the loaded actuator to a target.

    Attributes
    ----------
    pressure : float
        MPa.
    target : dict
        What was asked: ``total_angle_deg`` or ``tip_mm`` (a component may be None = free).
    residual : float
        Distance from the target at the result: degrees for an angle, mm for a tip position.
    equilibrium : Equilibrium
        The stable equilibrium at that pressure (a solve warm-started from the NLP's solution).
    on_load_path : bool
        Whether inflating first and then applying the payloads (:func:`esba.statics.equilibrium.solve`
        with continuation) reaches the same equilibrium. A scene can be multistable: with a 2 N
        horizontal tip payload, pressures above about 0.17 MPa make the actuator curl past the
        load when it is inflated first, while the same pressure raised under the load holds 90 deg.
    ok : bool
        The NLP converged, the residual is within ``tolerance``, and the equilibrium is stable.
    message : str
        Why not ok, and a note when the equilibrium is not on the load path.
    """

    pressure: float
    target: dict
    residual: float
    equilibrium: Equilibrium = field(repr=False)
    on_load_path: bool
    ok: bool
    message: str = ""

    def to_dict(self) -> dict:
        """JSON-ready form."""
        out = {"ok": self.ok, "pressure_mpa": self.pressure, "target": self.target, "residual": self.residual}
        out["on_load_path"] = self.on_load_path
        out["message"] = self.message
        out["equilibrium"] = self.equilibrium.to_dict()
        return out


@single_threaded
def pressure_for_target(
    scene: Scene,
    *,
    total_angle_deg: float | None = None,
    tip_mm: Sequence[float | None] | None = None,
    options: SolverOptions | None = None,
    tolerance: float = 1e-3,
    max_pressure: float = 10.0,
) -> PressureTarget:
    """The pressure that brings ``scene`` (with its payloads) to a total angle or a tip position.

    An NLP over (theta, P): minimise the squared distance to the target subject to
    dU/dtheta(theta, P) = 0 (the generated gradient), theta inside the model's domain and
    0 <= P <= ``max_pressure``. The equilibrium found is then checked against the one the scene
    reaches along its load path at that pressure (:func:`esba.statics.equilibrium.solve`); see
    :attr:`PressureTarget.on_load_path`.

    Parameters
    ----------
    scene : Scene
        The actuator and its payloads; its own pressure setting is the starting guess.
    total_angle_deg : float, optional
        Target total bending angle, degrees.
    tip_mm : (x, y), optional
        Target tip position, mm; one component may be None (free). Give this or ``total_angle_deg``.
    options : SolverOptions, optional
    tolerance : float
        Largest residual accepted (degrees or mm).
    max_pressure : float
        Upper bound on P, MPa.

    Examples
    --------
    >>> from esba.model.scene import MAIN_JOB
    >>> t = pressure_for_target(MAIN_JOB, total_angle_deg=45.0)
    >>> t.ok, round(t.equilibrium.total_angle_deg, 6)
    (True, 45.0)
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"scene={scene!r}: expected an esba.model.scene.Scene")
    if (total_angle_deg is None) == (tip_mm is None):
        raise SceneError("pressure_for_target: give one of total_angle_deg or tip_mm")
    if total_angle_deg is not None:
        total = checks.finite("total_angle_deg", total_angle_deg, SceneError)
        if abs(total) > MAX_TARGET_ANGLE_DEG:
            raise SceneError(f"total_angle_deg={total:g}: expected an angle of at most {MAX_TARGET_ANGLE_DEG:g} degrees in magnitude (as a scene's target angle)")
    if tip_mm is not None and (not isinstance(tip_mm, (list, tuple, np.ndarray)) or len(tip_mm) != 2):
        raise SceneError(f"tip_mm={tip_mm!r}: expected [x, y] in mm (one may be None, not both)")
    for name, value in (("tolerance", tolerance), ("max_pressure", max_pressure)):
        if checks.finite(name, value, SceneError) <= 0:
            raise SceneError(f"{name}={value!r}: expected a number > 0")
    options = STEP_OPTIONS if options is None else options
    model = scene.model()
    n = model.n
    values = scene.parameters(0.0)
    # the equilibrium-constrained NLP over (theta, P), built as the design and the fit build theirs
    b = EquilibriumNLP("esba_pressure_target")
    theta = b.variable("theta", n, lb=model.lower_bounds(values))
    P = b.variable("P", lb=0.0, ub=max_pressure)
    b.equilibrium(model_gradient(model, theta, dict(values, P=P)), "target")
    if total_angle_deg is not None:
        target_value = float(total_angle_deg)
        if not math.isfinite(target_value):
            raise SceneError(f"total_angle_deg={total_angle_deg!r}: expected a finite angle in degrees")
        target = {"total_angle_deg": target_value}
        miss = ca.sum1(theta) - math.radians(target_value)
        objective = miss**2
        residual_fun = ca.Function("residual", [theta], [ca.fabs(miss) * 180.0 / math.pi])
    else:
        if len(tip_mm) != 2 or all(v is None for v in tip_mm):
            raise SceneError(f"tip_mm={tip_mm!r}: expected [x, y] in mm (one may be None, not both)")
        tip = model["kinematics"](theta, values["L"])[0]
        parts = []
        for k, v in enumerate(tip_mm):
            if v is None:
                continue
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise SceneError(f"tip_mm={list(tip_mm)!r}: expected finite numbers in mm")
            parts.append(tip[k] - float(v))
        miss_vec = ca.vertcat(*parts)
        objective = ca.sumsqr(miss_vec)
        target = {"tip_mm": [None if v is None else float(v) for v in tip_mm]}
        residual_fun = ca.Function("residual", [theta], [ca.norm_2(miss_vec)])
    nlp = b.build(
        objective,
        {
            "calc_lam_p": False,
            "show_eval_warnings": False,
            "ipopt.tol": options.tol,
            "ipopt.max_iter": max(options.max_iter, 500),
            "ipopt.linear_solver": options.linear_solver,
        },
    )
    # start: the scene's own pressure setting and its equilibrium there
    start = solve(scene, options)
    sol = nlp.solve(nlp.x0(theta=start.theta, P=start.pressure))
    z = sol.x
    # IPOPT relaxes its bounds by about 1e-8 (bound_relax_factor): a pressure on a bound comes back just outside it
    pressure = min(max(float(z[-1]), 0.0), max_pressure)
    theta_nlp = z[:-1]
    # the NLP only asks for stationarity: confirm a stable equilibrium there ...
    eq = solve(scene, options, pressure=pressure, theta0=theta_nlp)
    # ... and say whether the paper's load path (inflate, then load) reaches it
    path = solve(scene, options, pressure=pressure)
    on_path = bool(path.ok and float(np.max(np.abs(path.theta - eq.theta))) < 1e-6)
    residual = float(residual_fun(eq.theta))
    messages = []
    if not sol.success:
        messages.append(f"IPOPT: {sol.status}")
    if not eq.ok:
        messages.append(eq.message or f"the equilibrium at {pressure:.6g} MPa is not ok ({eq.status})")
    elif float(np.max(np.abs(eq.theta - theta_nlp))) > 1e-6:
        messages.append("the NLP's stationary point is not a stable equilibrium (a solve from it moved away)")
    if residual > tolerance:
        unit = "deg" if total_angle_deg is not None else "mm"
        messages.append(f"the target is not reachable: closest residual {residual:.4g} {unit} > tolerance {tolerance:g}")
    if pressure >= max_pressure * (1 - 1e-9):
        messages.append(f"the pressure reached its bound max_pressure={max_pressure:g} MPa")
    note = ""
    if not on_path:
        note = (
            "inflating first and then loading reaches a different equilibrium at this pressure "
            f"(total angle {path.total_angle_deg:.2f} deg): the scene is multistable there"
        )
    return PressureTarget(
        pressure=pressure,
        target=target,
        residual=residual,
        equilibrium=eq,
        on_load_path=on_path,
        ok=not messages,
        message="; ".join(messages + ([note] if note else [])),
    )


def stiffness_table(d: dict) -> str:
    """The text ``esba stiffness`` prints for :meth:`SecantStiffness.to_dict`."""

    lines = [
        f"secant stiffness K = F / delta from the unloaded state ({d['initial_angle_deg']:.2f} deg), "
        f"P = {d['pressure_mpa']:.7f} MPa held, tip payload at {d['payload_angle_deg']:g} deg; n = {d['segments']}, {d['variant']}",
        f"{'F (N)':>8} {'delta (mm)':>11} {'K (N/m)':>9} {'tip x, y (mm)':>18}",
    ]
    for f, dl, k, tip in zip(d["payloads_n"], d["displacement_mm"], d["stiffness_n_per_m"], d["tip_mm"]):
        lines.append(f"{f:8.3f} {dl:11.3f} {'unbounded' if k is None else format(k, '9.3f'):>9} {tip[0]:8.2f}, {tip[1]:7.2f}")
    t = d["tangent"]
    def k(v):
        return "unbounded (the tip does not move that way to first order)" if v is None or not math.isfinite(v) else f"{v:.3f} N/m"

    lines.append(f"tangent stiffness of the unloaded state (F = 0, {d['initial_angle_deg']:.2f} deg), where every secant K starts "
                 "(C = J H^-1 J^T the tip's compliance there):")
    lines.append(f"  along the force, the tip free to move across it, 1 / (u^T C u) (the limit of K as F -> 0): "
                 f"horizontal {k(t['horizontal_n_per_m'])}, vertical {k(t['vertical_n_per_m'])}")
    if t["matrix_n_per_m"] is not None:
        m = t["matrix_n_per_m"]
        lines.append(f"  K_tip = C^-1 (N/m, x down, y horizontal): [[{m[0][0]:.2f}, {m[0][1]:.2f}], [{m[1][0]:.2f}, {m[1][1]:.2f}]]: "
                     "each diagonal entry holds the tip still in the other direction, so it is stiffer than the value above")
    else:
        lines.append("  K_tip: singular (one segment moves the tip along one direction only)")
    for msg in d["messages"]:
        lines.append(f"NOT OK: {msg}")
    return "\n".join(lines)

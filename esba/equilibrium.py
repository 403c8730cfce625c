"""Static equilibria: minimise the total potential energy U(theta), Eq. (3)-(4), with IPOPT.

IPOPT (``casadi.nlpsol``) is given the generated model's exact gradient and Hessian, the model's
domain as bounds on theta (the square root of Eq. 10 and L + n (d + r1) theta_i > 0), and a start
on the physical load path: from a known state (the unloaded constant-curvature shape, exact when
the pressure comes from a target angle, else reached by ramping the pressure from theta = 0),
payloads and weight are ramped in steps, each solve warm-started from the last, with the step
halved when a solve fails. After IPOPT a few Newton steps on the exact Hessian polish the
stationarity to round-off.

Every result carries a stability verdict from the Hessian's eigenvalues (``stable`` /
``unstable`` / ``critical``), IPOPT's return status, iterations and time. A solve that fails,
stops on a bound or lands on an equilibrium that is not stable has ``ok == False`` and says why
in ``message``; :meth:`Equilibrium.check` turns that into an :class:`EquilibriumError`.

Examples
--------
>>> from esba.scene import MAIN_JOB
>>> r = solve(MAIN_JOB)
>>> r.ok, r.stability
(True, 'stable')
>>> [round(t, 2) for t in r.theta_deg]
[-3.29, 7.17, 21.44]
>>> [round(v, 2) for v in r.tip_mm]
[133.24, 10.22]
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Sequence

import casadi as ca
import numpy as np

from . import checks, resolution
from .model import Model
from .scene import Scene, SceneError, check_pressure
from .validity import Finding, assess

__all__ = [
    "SolverOptions",
    "SolverOptionsError",
    "Equilibrium",
    "EquilibriumError",
    "solve",
    "evaluate",
    "pressure_for_angle",
    "stability_verdict",
    "STABILITY",
]

#: The stability verdicts, from the smallest eigenvalue of the Hessian relative to the largest.
STABILITY = ("stable", "critical", "unstable")

_LINEAR_SOLVERS = ("mumps", "spral")

#: Upper bounds of the counts in SolverOptions (IPOPT keeps its iteration limit in a 32-bit int,
#: and each count multiplies the work of one solve).
MAX_ITER_LIMIT = 100_000
MAX_STEPS_LIMIT = 10_000
MAX_HALVINGS_LIMIT = 30
MAX_SAMPLES_LIMIT = 1_000


class SolverOptionsError(ValueError):
    """A solver option that is not allowed: the message names the option, the value and what is allowed."""


class EquilibriumError(RuntimeError):
    """A solve that failed or did not reach a stable equilibrium (or an unreachable target)."""


def _check_int(name: str, value: Any, low: int, high: int | None = None, why: str = "") -> int:
    return checks.whole(name, value, low, SolverOptionsError, high, why)


def _check_pos(name: str, value: Any, high: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise SolverOptionsError(f"{name}={value!r}: expected a finite number > 0")
    if high is not None and value >= high:
        raise SolverOptionsError(f"{name}={value!r}: expected a number > 0 and < {high:g}")
    return float(value)


@dataclass(frozen=True)
class SolverOptions:
    """Settings of :func:`solve`, validated on creation.

    Parameters
    ----------
    tol : float
        IPOPT's convergence tolerance (``ipopt.tol``), > 0.
    max_iter : int
        IPOPT's iteration limit per solve, 1 to 100000 (an equilibrium takes tens).
    linear_solver : str
        IPOPT's linear solver: ``"mumps"`` or ``"spral"`` (the HSL solvers are not in the wheel).
    continuation : bool
        Follow the load path (pressure, then payloads and weight) from a known state. When False,
        or when :func:`solve` is given ``theta0``, one solve at the full load.
    pressure_steps : int
        Steps of the pressure ramp from theta = 0, used when the pressure is given (not a target
        angle), 1 to 10000.
    load_steps : int
        Steps of the payload and weight ramp from the unloaded state, 1 to 10000.
    max_halvings : int
        How often (0 to 30) a continuation step may be halved (after a failed solve, or a jump larger than
        ``max_jump_deg``) before the solve is reported failed (or the jump accepted and noted).
    max_jump_deg : float
        Largest change of any segment angle in one continuation step, degrees, before the step is
        halved; a jump that persists at the smallest step (a snap-through, or a very steep path)
        is followed and noted.
    polish : bool
        Newton steps on the exact Hessian after IPOPT (stationarity to round-off).
    stationarity_tol : float
        Largest |dU/dtheta_i| (N mm/rad) accepted as an equilibrium.
    critical_tol : float
        A Hessian whose smallest eigenvalue is within ``critical_tol`` times its largest (in
        absolute value) of zero is ``critical``; below that ``unstable``, above ``stable``.
    samples_per_segment : int
        Centre-line samples per segment in the result (1 to 1000).

    Examples
    --------
    >>> SolverOptions().tol
    1e-10
    >>> SolverOptions(load_steps=0)
    Traceback (most recent call last):
    ...
    esba.equilibrium.SolverOptionsError: load_steps=0: expected a whole number from 1 to 10000
    """

    tol: float = 1e-10
    max_iter: int = 200
    linear_solver: str = "mumps"
    continuation: bool = True
    pressure_steps: int = 4
    load_steps: int = 4
    max_halvings: int = 6
    max_jump_deg: float = 15.0
    polish: bool = True
    stationarity_tol: float = 1e-7
    critical_tol: float = 1e-9
    samples_per_segment: int = 20

    def __post_init__(self) -> None:
        _check_pos("tol", self.tol, 1.0)
        _check_int("max_iter", self.max_iter, 1, MAX_ITER_LIMIT, "an equilibrium takes tens of iterations; IPOPT counts in a 32-bit int")
        if self.linear_solver not in _LINEAR_SOLVERS:
            raise SolverOptionsError(f"linear_solver={self.linear_solver!r}: allowed are {', '.join(_LINEAR_SOLVERS)}")
        for name in ("continuation", "polish"):
            if not isinstance(getattr(self, name), bool):
                raise SolverOptionsError(f"{name}={getattr(self, name)!r}: expected True or False")
        _check_int("pressure_steps", self.pressure_steps, 1, MAX_STEPS_LIMIT)
        _check_int("load_steps", self.load_steps, 1, MAX_STEPS_LIMIT)
        _check_int("max_halvings", self.max_halvings, 0, MAX_HALVINGS_LIMIT, "a step halved 30 times is a billionth of the ramp")
        _check_pos("max_jump_deg", self.max_jump_deg)
        _check_pos("stationarity_tol", self.stationarity_tol)
        _check_pos("critical_tol", self.critical_tol, 1.0)
        _check_int("samples_per_segment", self.samples_per_segment, 1, MAX_SAMPLES_LIMIT)


DEFAULT_OPTIONS = SolverOptions()


def stability_verdict(eigenvalues: Sequence[float], critical_tol: float = DEFAULT_OPTIONS.critical_tol) -> str:
    """``stable``, ``critical`` or ``unstable`` from the Hessian's eigenvalues.

    Examples
    --------
    >>> stability_verdict([2.0, 5.0]), stability_verdict([-1.0, 5.0]), stability_verdict([1e-14, 5.0])
    ('stable', 'unstable', 'critical')
    """
    return str(stability_verdicts(np.asarray(eigenvalues, dtype=float)[None, :], critical_tol)[0])


def stability_verdicts(eigenvalues: np.ndarray, critical_tol: float = DEFAULT_OPTIONS.critical_tol) -> np.ndarray:
    """:func:`stability_verdict` for every row of an (m, n) array of eigenvalues.

    The smallest eigenvalue is compared with ``critical_tol`` times the largest magnitude; a row
    with a non-finite eigenvalue is ``unknown``.

    >>> stability_verdicts(np.array([[2.0, 5.0], [np.nan, 1.0]])).tolist()
    ['stable', 'unknown']
    """
    eig = np.asarray(eigenvalues, dtype=float)
    out = np.full(len(eig), "unknown", dtype=object)
    finite = np.all(np.isfinite(eig), axis=1)
    safe = np.where(finite[:, None], eig, 0.0)
    scale = np.maximum(np.max(np.abs(safe), axis=1), 1e-300)
    low = np.min(safe, axis=1)
    out[finite] = "critical"
    out[finite & (low > critical_tol * scale)] = "stable"
    out[finite & (low < -critical_tol * scale)] = "unstable"
    return out.astype(str)


# ---------------------------------------------------------------------------------------------
# the result


@dataclass(frozen=True, eq=False)
class Equilibrium:
    """One solved scene: the equilibrium, its stability and how it was found.

    Angles are in radians (``theta``, ``total_angle``, ``tip[2]``) with degree twins; lengths in
    mm, energies in N mm, pressure in MPa.

    Attributes
    ----------
    scene : Scene
        The scene solved.
    model : Model
        The generated model used (the scene's effects).
    pressure : float
        The pressure, MPa (from the scene, or found from its target angle).
    theta : ndarray
        Bending angle of each segment, rad.
    tip : ndarray
        Tip pose [x, y, orientation] in the base frame (x down, y horizontal), mm, mm, rad.
    centreline : ndarray
        Deformed centre-line (the inextensible layer), shape (k, 3): x, y (mm), heading (rad),
        at ``samples_per_segment`` points along each arc.
    energy : float
        Total potential energy U, N mm.
    terms : dict
        Each energy term by name, N mm.
    gradient_norm : float
        max |dU/dtheta_i| at the result, N mm/rad.
    eigenvalues : ndarray
        Eigenvalues of the Hessian at the result, ascending, N mm/rad^2.
    stability : str
        ``stable``, ``critical`` or ``unstable`` (see :func:`stability_verdict`).
    status : str
        IPOPT's return status of the last solve, or ``Continuation_Failed`` / ``At_Bound`` /
        ``Not_Stationary``.
    success : bool
        The solver converged to a stationary point inside the domain.
    iterations : int
        IPOPT iterations over every continuation step.
    steps : int
        IPOPT solves made (continuation steps, including halved ones).
    solve_time_s : float
        Wall time of the whole solve, s.
    message : str
        Why the result is not ok (empty when it is).
    notes : tuple of str
        What happened on the way that the result does not show (a jump on the load path).
    validity : tuple of Finding
        Where the result leaves the range the paper's model describes (strains past 1, a bend past
        360 deg, the tip behind the base, loads far outside the paper's): see :mod:`esba.validity`.
        Empty when it is inside; a result can be ``ok`` and still outside.
    """

    scene: Scene
    model: Model = field(repr=False)
    pressure: float
    theta: np.ndarray
    tip: np.ndarray
    centreline: np.ndarray = field(repr=False)
    energy: float
    terms: dict[str, float]
    gradient_norm: float
    eigenvalues: np.ndarray
    stability: str
    status: str
    success: bool
    iterations: int
    steps: int
    solve_time_s: float
    message: str = ""
    notes: tuple[str, ...] = ()
    validity: tuple[Finding, ...] = ()

    @property
    def ok(self) -> bool:
        """True for a converged, stable equilibrium; anything else is not an answer."""
        return self.success and self.stability == "stable"

    @property
    def theta_deg(self) -> list[float]:
        """Segment angles in degrees."""
        return [math.degrees(t) for t in self.theta]

    @property
    def total_angle(self) -> float:
        """Total bending angle theta_TOL, Eq. (17), rad."""
        return float(np.sum(self.theta))

    @property
    def total_angle_deg(self) -> float:
        """Total bending angle, degrees."""
        return math.degrees(self.total_angle)

    @property
    def tip_mm(self) -> list[float]:
        """Tip position [x, y], mm."""
        return [float(self.tip[0]), float(self.tip[1])]

    @property
    def parameters(self) -> dict[str, float]:
        """The model parameter values of this solve (radians)."""
        return self.scene.parameters(self.pressure)

    def check(self) -> Equilibrium:
        """Return self when :attr:`ok`, else raise :class:`EquilibriumError` with the message."""
        if not self.ok:
            raise EquilibriumError(self.message or f"solve not ok: status {self.status}, {self.stability}")
        return self

    def to_dict(self, centreline: bool = False) -> dict[str, Any]:
        """A JSON-ready summary (the keys ``esba solve --json`` prints)."""
        out: dict[str, Any] = {
            "ok": self.ok,
            "theta_deg": self.theta_deg,
            "total_angle_deg": self.total_angle_deg,
            "tip_mm": self.tip_mm,
            "tip_angle_deg": math.degrees(float(self.tip[2])),
            "pressure_mpa": self.pressure,
            "pressure_from": "pressure" if self.scene.pressure is not None else f"target_angle_deg={self.scene.target_angle_deg:g}",
            "stable": self.stability == "stable",
            "stability": self.stability,
            "eigenvalues": [float(v) for v in self.eigenvalues],
            "status": self.status,
            "message": self.message,
            "notes": list(self.notes),
            "validity": [f.to_dict() for f in self.validity],
            "iterations": self.iterations,
            "steps": self.steps,
            "gradient_norm": self.gradient_norm,
            "energy_nmm": self.energy,
            "energy_terms_nmm": dict(self.terms),
            "effects": list(self.scene.effects.names()),
            "segments": self.scene.segments,
            "variant": self.scene.variant,
            "payloads": [{"force_n": p.force, "angle_deg": p.angle_deg, "at": p.at} for p in self.scene.payloads],
            "gravity": self.scene.gravity,
            "solve_time_s": self.solve_time_s,
        }
        if centreline:
            out["centreline_mm"] = self.centreline[:, :2].tolist()
        return out


# ---------------------------------------------------------------------------------------------
# the closed-form unloaded pressure


def pressure_for_angle(scene: Scene, angle_deg: float | None = None) -> float:
    """The pressure (MPa) that bends the unloaded actuator to a total angle, in closed form.

    Without payloads and weight the equilibrium is uniform, theta_i = Theta / n, and U is linear
    in P (Eq. 5 and 18), so dU/dtheta = g0 + P g1 at that shape: P = -g0 / g1, from the generated
    gradient evaluated at P = 0 and P = 1.

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

    Examples
    --------
    >>> from esba.scene import Scene
    >>> round(pressure_for_angle(Scene(), 90.0), 7)
    0.1238739
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"scene={scene!r}: expected an esba.scene.Scene")
    if angle_deg is None:
        angle_deg = scene.target_angle_deg
    if angle_deg is None:
        raise EquilibriumError("pressure_for_angle needs angle_deg (the scene gives a pressure, not a target angle)")
    checks.finite("target_angle_deg", angle_deg, SceneError)
    angle = math.radians(float(angle_deg))
    model = scene.model()
    theta = np.full(scene.segments, angle / scene.segments)
    g0 = model.gradient(theta, model.param_vector(scene.parameters(0.0, load_factor=0.0)))
    g1 = model.gradient(theta, model.param_vector(scene.parameters(1.0, load_factor=0.0))) - g0
    if not np.all(np.isfinite(g0)) or not np.all(np.isfinite(g1)) or float(g1 @ g1) == 0.0:
        raise EquilibriumError(f"target_angle_deg={angle_deg:g}: outside the model's domain for this actuator")
    pressure = float(-(g0 @ g1) / (g1 @ g1))
    if pressure < 0:
        raise EquilibriumError(f"target_angle_deg={angle_deg:g}: would need a negative pressure ({pressure:.4g} MPa)")
    return pressure


# ---------------------------------------------------------------------------------------------
# IPOPT on the generated functions

_SOLVERS: dict[tuple, ca.Function] = {}


def _nlp_solver(model: Model, options: SolverOptions) -> ca.Function:
    """IPOPT for min U(theta; p) with the model's exact gradient and Hessian (cached per model)."""
    key = (str(model.path), options.tol, options.max_iter, options.linear_solver)
    solver = _SOLVERS.get(key)
    if solver is not None:
        return solver
    n, npar = model.n, len(model.parameters)
    x = ca.MX.sym("x", n)
    p = ca.MX.sym("p", npar)
    args = [x, *ca.vertsplit(p)] if npar else [x]
    f = model["energy"](*args)[0]
    grad = model["gradient"](*args)
    hess = model["hessian"](*args)
    lam_f = ca.MX.sym("lam_f")
    lam_g = ca.MX.sym("lam_g", 0)
    grad_f = ca.Function("grad_f", [x, p], [f, grad], ["x", "p"], ["f", "grad_f"])
    hess_lag = ca.Function(
        "hess_lag", [x, p, lam_f, lam_g], [ca.triu(lam_f * hess)], ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"]
    )
    opts = {
        "grad_f": grad_f,
        "hess_lag": hess_lag,
        "print_time": False,
        "calc_lam_p": False,  # no parametric sensitivities (the payload point s_k is not smooth there)
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "show_eval_warnings": False,  # a NaN at a trial point is IPOPT's to handle, not a flood on stderr
        "ipopt.tol": options.tol,
        "ipopt.max_iter": options.max_iter,
        "ipopt.linear_solver": options.linear_solver,
    }
    solver = ca.nlpsol("esba_equilibrium", "ipopt", {"x": x, "f": f, "p": p}, opts)
    _SOLVERS[key] = solver
    return solver


@dataclass
class _Attempt:
    theta: np.ndarray
    status: str
    success: bool
    iterations: int


def _polish(model: Model, theta: np.ndarray, pv: np.ndarray, lbx: np.ndarray) -> np.ndarray:
    """A few Newton steps on the exact Hessian while it is positive definite and inside the domain."""
    for _ in range(4):
        g = model.gradient(theta, pv)
        if float(np.max(np.abs(g))) < 1e-13:
            break
        h = model.hessian(theta, pv)
        try:
            np.linalg.cholesky(h)
        except np.linalg.LinAlgError:
            break
        new = theta - np.linalg.solve(h, g)
        if np.any(new <= lbx) or not np.all(np.isfinite(new)):
            break
        if float(np.max(np.abs(model.gradient(new, pv)))) >= float(np.max(np.abs(g))):
            break
        theta = new
    return theta


def _ipopt(model: Model, options: SolverOptions, theta0: np.ndarray, pv: np.ndarray, lbx: np.ndarray) -> _Attempt:
    solver = _nlp_solver(model, options)
    x0 = np.maximum(np.asarray(theta0, dtype=float), lbx + 1e-9 * np.maximum(1.0, np.abs(lbx)))
    sol = solver(x0=x0, p=pv, lbx=lbx)
    stats = solver.stats()
    theta = np.asarray(sol["x"], dtype=float).ravel()
    success = bool(stats.get("success", False))
    if success and options.polish:
        theta = _polish(model, theta, pv, lbx)
    return _Attempt(theta, str(stats.get("return_status", "unknown")), success, int(stats.get("iter_count", 0)))


def _accepted(model: Model, options: SolverOptions, attempt: _Attempt, pv: np.ndarray, lbx: np.ndarray) -> bool:
    if not attempt.success:
        return False
    if float(np.max(np.abs(model.gradient(attempt.theta, pv)))) > options.stationarity_tol:
        return False
    return stability_verdict(np.linalg.eigvalsh(model.hessian(attempt.theta, pv)), options.critical_tol) == "stable"


def _near_bound(theta: np.ndarray, lbx: np.ndarray) -> bool:
    return bool(np.any(theta - lbx <= 1e-7 * np.maximum(1.0, np.abs(lbx))))


def _check_inputs(scene: Any, pressure: Any, options: Any) -> SolverOptions:
    """The checks the command line makes, for the Python API: the scene, a pressure, the options."""
    if not isinstance(scene, Scene):
        raise SceneError(f"scene={scene!r}: expected an esba.scene.Scene")
    if pressure is not None:
        check_pressure(pressure)
    options = DEFAULT_OPTIONS if options is None else options
    if not isinstance(options, SolverOptions):
        raise SolverOptionsError(f"options={options!r}: expected a SolverOptions")
    return options


def _resolve_pressure(scene: Scene, pressure: float | None) -> tuple[float, np.ndarray | None]:
    """The pressure to use and, when it comes from the target angle, the exact unloaded state."""
    if pressure is not None:
        return float(pressure), None
    if scene.pressure is not None:
        return scene.pressure, None
    p = pressure_for_angle(scene)
    return p, np.full(scene.segments, math.radians(scene.target_angle_deg) / scene.segments)


def evaluate(
    scene: Scene,
    theta: Sequence[float],
    pressure: float | None = None,
    options: SolverOptions | None = None,
    *,
    status: str = "Evaluated",
    success: bool = True,
    iterations: int = 0,
    steps: int = 0,
    solve_time_s: float = 0.0,
    message: str = "",
    notes: Sequence[str] = (),
) -> Equilibrium:
    """An :class:`Equilibrium` for given angles: energy, tip, centre-line, stationarity and stability.

    :func:`solve` ends here; call it directly to assess angles found some other way (e.g. by an
    NLP that only asks for dU/dtheta = 0). ``success`` is withdrawn when theta is on the domain
    boundary or not stationary within ``options.stationarity_tol``.

    Examples
    --------
    >>> from esba.scene import Scene, Payload
    >>> column = Scene(pressure=0.0, payloads=(Payload(20.0, 180.0),))   # a 20 N push up the axis
    >>> r = evaluate(column, [0.0, 0.0, 0.0])
    >>> r.stability, r.ok
    ('unstable', False)
    """
    options = _check_inputs(scene, pressure, options)
    model = scene.model()
    pressure, _ = _resolve_pressure(scene, pressure)
    resolution.check_resolvable(scene, pressure, options.stationarity_tol, DEFAULT_OPTIONS.stationarity_tol)
    theta = _angles("theta", theta, scene.segments)
    full = scene.parameters(pressure)
    lbx = model.lower_bounds(full)
    pv = model.param_vector(full)
    if np.any(theta < lbx):
        raise EquilibriumError(f"theta={np.degrees(theta).round(3).tolist()} deg lies outside the model's domain (Eq. 10)")
    grad = model.gradient(theta, pv)
    gnorm = float(np.max(np.abs(grad)))
    hess = model.hessian(theta, pv)
    energy = model.energy(theta, pv)
    finite = bool(np.all(np.isfinite(hess)) and np.isfinite(gnorm) and np.isfinite(energy))
    eig = np.sort(np.linalg.eigvalsh(hess)) if finite else np.full(scene.segments, np.nan)
    verdict = stability_verdict(eig, options.critical_tol)
    if not finite:
        success, status = False, "Not_Finite"
        message = "the model's energy, gradient or Hessian is not finite at the result (overflow): not an equilibrium"
    elif success and _near_bound(theta, lbx):
        success, status = False, "At_Bound"
        message = "the solve stopped on the model's domain boundary (Eq. 10: the chamber closes): not an equilibrium"
    elif success and gnorm > options.stationarity_tol:
        success, status = False, "Not_Stationary"
        message = f"max |dU/dtheta| = {gnorm:.3g} N mm/rad > stationarity_tol = {options.stationarity_tol:g}"
    if success and verdict != "stable":
        message = f"the equilibrium is {verdict}: smallest Hessian eigenvalue {eig[0]:.3g} N mm/rad^2 (largest {eig[-1]:.3g})"
    cl = model.centreline(theta, full["L"], samples=scene.segments * options.samples_per_segment + 1)
    tip = model.tip(theta, full["L"])
    return Equilibrium(
        scene=scene,
        model=model,
        pressure=pressure,
        theta=theta,
        tip=tip,
        centreline=cl,
        energy=energy,
        terms=model.energy_terms(theta, pv),
        gradient_norm=gnorm,
        eigenvalues=eig,
        stability=verdict,
        status=status,
        success=success,
        iterations=iterations,
        steps=steps,
        solve_time_s=solve_time_s,
        message=message,
        notes=tuple(notes),
        validity=assess(scene, theta, pressure, tip),
    )


def _angles(name: str, values: Any, n: int) -> np.ndarray:
    """``values`` as n finite angles (rad), else :class:`SolverOptionsError` naming ``name``."""
    try:
        theta = np.asarray(values, dtype=float).ravel()
    except (TypeError, ValueError):
        raise SolverOptionsError(f"{name}={values!r}: expected {n} finite angles (rad)") from None
    if theta.shape != (n,) or not np.all(np.isfinite(theta)):
        raise SolverOptionsError(f"{name} has shape {theta.shape}: expected {n} finite angles (rad)")
    return theta


def solve(
    scene: Scene,
    options: SolverOptions | None = None,
    *,
    pressure: float | None = None,
    theta0: Sequence[float] | None = None,
) -> Equilibrium:
    """The equilibrium of ``scene`` reached along its load path.

    Parameters
    ----------
    scene : Scene
        What to solve (the model is ``scene.model()``).
    options : SolverOptions, optional
        Solver settings; defaults to ``SolverOptions()``.
    pressure : float, optional
        Use this pressure (MPa) instead of the scene's (saves the closed form in sweeps).
    theta0 : sequence of float, optional
        Warm start (rad): one solve at the full load from here, no continuation.

    Raises
    ------
    SceneError
        for a scene that is not a :class:`~esba.scene.Scene`, a bad ``pressure`` (the same
        messages as the scene's own field), or scales the solver cannot resolve to its
        tolerances (a Young's modulus so small that every angle passes as an equilibrium, a
        pressure or payload whose moments exceed double precision), all checked before solving.
    SolverOptionsError
        for ``options`` that are not a :class:`SolverOptions`, or a bad ``theta0``.

    Returns
    -------
    Equilibrium
        Check :attr:`Equilibrium.ok` (or call :meth:`Equilibrium.check`): a failed or unstable
        solve is returned with ``ok == False`` and a ``message``. A jump on the load path (the
        angles change by more than ``options.max_jump_deg`` however small the step: a
        snap-through, or a very steep path) is followed, as the actuator would, and recorded in
        ``notes``.
    """
    options = _check_inputs(scene, pressure, options)
    if theta0 is not None:
        theta0 = _angles("theta0", theta0, scene.segments)
    model = scene.model()  # loaded (or generated) before the clock starts
    t_start = time.perf_counter()
    n = scene.segments
    pressure, known_unloaded = _resolve_pressure(scene, pressure)
    resolution.check_resolvable(scene, pressure, options.stationarity_tol, DEFAULT_OPTIONS.stationarity_tol)
    full = scene.parameters(pressure)
    lbx = model.lower_bounds(full)
    pv_full = model.param_vector(full)
    loaded = bool(scene.payloads) or scene.gravity
    max_jump = math.radians(options.max_jump_deg)

    iterations = 0
    steps = 0
    message = ""
    notes: list[str] = []

    def attempt(theta_start: np.ndarray, pv: np.ndarray) -> _Attempt:
        nonlocal iterations, steps
        a = _ipopt(model, options, theta_start, pv, lbx)
        iterations += a.iterations
        steps += 1
        return a

    def ramp(theta: np.ndarray, pv_at, what: str, n_steps: int) -> tuple[np.ndarray, str]:
        """Follow factor 0 -> 1 from theta; return the state at 1 (or the last good one and why not)."""
        base = 1.0 / n_steps
        smallest = base / 2**options.max_halvings
        lam, dlam = 0.0, base
        while lam < 1.0:
            target = min(1.0, lam + dlam)
            pv = pv_at(target)
            a = attempt(theta, pv)
            good = _accepted(model, options, a, pv, lbx) and not _near_bound(a.theta, lbx)
            jump = float(np.max(np.abs(a.theta - theta))) if good else math.inf
            if good and (jump <= max_jump or dlam <= smallest * (1 + 1e-9)):
                if jump > max_jump:
                    notes.append(
                        f"the angles jump by up to {math.degrees(jump):.1f} deg as the {what} goes from "
                        f"{100 * lam:.4g}% to {100 * target:.4g}% of its value: a snap-through, or a path "
                        "too steep to follow in the smallest continuation step"
                    )
                theta, lam = a.theta, target
                dlam = min(base, 2.0 * dlam)
                continue
            if dlam <= smallest * (1 + 1e-9):
                reason = a.status if not a.success else ("a domain bound" if _near_bound(a.theta, lbx) else "no stable equilibrium")
                return theta, (
                    f"the {what} ramp from the known state stopped at {100 * lam:.4g}% "
                    f"(the step to {100 * target:.4g}% gave {reason}): the branch followed is lost there "
                    "or the solver cannot follow it"
                )
            dlam /= 2.0
        return theta, ""

    if theta0 is not None:
        theta = theta0
    elif not options.continuation:
        theta = known_unloaded if known_unloaded is not None else np.zeros(n)
    else:
        if known_unloaded is not None:
            theta = known_unloaded
        else:
            unloaded = scene.parameters(pressure, load_factor=0.0)

            def at_pressure(lam: float) -> np.ndarray:
                v = dict(unloaded)
                v["P"] = lam * pressure
                return model.param_vector(v)

            theta, message = ramp(np.zeros(n), at_pressure, "pressure", options.pressure_steps)
        if loaded and not message:
            theta, message = ramp(
                theta, lambda lam: model.param_vector(scene.parameters(pressure, load_factor=lam)), "load", options.load_steps
            )

    final = attempt(theta, pv_full)
    if message:  # continuation failed: report the full-load solve from the last good state, not as an answer
        status, success = "Continuation_Failed", False
    else:
        status, success = final.status, final.success
        if not success:
            message = f"IPOPT did not converge: {final.status}"
    return evaluate(
        scene,
        final.theta,
        pressure,
        options,
        status=status,
        success=success,
        iterations=iterations,
        steps=steps,
        solve_time_s=time.perf_counter() - t_start,
        message=message,
        notes=notes,
    )

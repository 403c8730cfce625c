"""Static equilibria: minimise the total potential energy U(theta), Eq. (3)-(4).

:func:`solve` finds the state an actuator reaches along its *load history*: from a known state
(the unloaded constant-curvature shape, exact when the pressure comes from a target angle; else
theta = 0 at P = 0 and the pressure raised quasi-statically), the payloads and weight are raised
together from 0 to their values. Each ramp is a path trace (:mod:`esba.paths.continuation`, pseudo-arclength
continuation on the generated exact gradient and Hessian) that stops exactly at the target. When
the stable branch ends before the target, at a fold (or a branch point with no stable way on), the
quasi-static load snaps: :mod:`esba.paths.loading` finds the state it lands in, and the result says
where it jumped and from which state to which (:attr:`Equilibrium.jumps`). A straight actuator
that buckles at a branch point goes on along the stable bent branch, and the result says so.

The state the path reaches is certified a minimiser. A few Newton steps polish its stationarity
to round-off; when the exact gradient and Hessian there show a strict local minimiser to IPOPT's
tolerance (max |dU/dtheta| <= ``tol``, every angle strictly inside the model's domain, the Hessian
positive definite: the first-order conditions IPOPT would accept there without iterating, and the
second-order ones it does not check), that is the certificate; otherwise IPOPT (``casadi.nlpsol``,
:mod:`esba.solvers.minimise`), the solver of record, starts there and certifies the minimiser with
the generated exact gradient and Hessian and the model's domain as bounds on theta (the square
root of Eq. 10 and L + n (d + r1) theta_i > 0). ``SolverOptions(certify="ipopt")`` calls IPOPT always.

Every result carries a stability verdict from the Hessian's eigenvalues (``stable`` /
``unstable`` / ``critical``), IPOPT's return status, iterations and time. A solve that fails,
stops on a bound or lands on an equilibrium that is not stable has ``ok == False`` and says why
in ``message``; :meth:`Equilibrium.check` turns that into an :class:`EquilibriumError`.

Examples
--------
>>> from esba.model.scene import MAIN_JOB
>>> r = solve(MAIN_JOB)
>>> r.ok, r.stability, r.status, r.certificate.split(",")[0]
(True, 'stable', 'Solve_Succeeded', "Solve_Succeeded from the exact gradient and Hessian at the path's end")
>>> solve(MAIN_JOB, SolverOptions(certify="ipopt")).certificate.split(":")[0]
'IPOPT Solve_Succeeded'
>>> [round(t, 2) for t in r.theta_deg]
[-3.29, 7.17, 21.44]
>>> [round(v, 2) for v in r.tip_mm]
[133.24, 10.22]
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any, Sequence

import numpy as np

from esba.infra import checks
from esba.infra.errors import EquilibriumError, InputError
from esba.infra.report import Report
from esba.infra.threads import single_threaded
from esba.model import resolution
from esba.model.closed_form import pressure_for_angle
from esba.model.generated import Model, near_domain_bound
from esba.model.scene import Scene, SceneError, check_pressure
from esba.model.stability import STABILITY, stability_verdict, stability_verdicts
from esba.model.validity import Finding, assess
from esba.paths.continuation import PathOptions, SpecialPoint
from esba.paths.loading import Jump
from esba.solvers.minimise import LINEAR_SOLVERS, Minimum, minimise, polish
from esba.solvers.newton import state as compiled_state

from .equilibria import AUTO_MAX_SEGMENTS, MULTISTABILITY, Multistability, SOLVE_CHECK, check_multistability, not_looked, state_of
from .history import DEFAULT_HISTORY, HistoryError, LoadHistory, _unloaded, history_name, history_steps, load_history

__all__ = [
    "SolverOptions",
    "SolverOptionsError",
    "Equilibrium",
    "EquilibriumError",
    "solve",
    "evaluate",
    "pressure_for_angle",
    "stability_verdict",
    "stability_verdicts",
    "STABILITY",
    "LoadHistory",
    "load_history",
    "HistoryError",
    "Multistability",
]


#: The values of ``SolverOptions.certify``.
CERTIFY = ("auto", "ipopt")

#: Upper bounds of the counts in SolverOptions (IPOPT keeps its iteration limit in a 32-bit int,
#: and each count multiplies the work of one solve).
MAX_ITER_LIMIT = 100_000
MAX_SAMPLES_LIMIT = 1_000


class SolverOptionsError(InputError):
    """A solver option that is not allowed: the message names the option, the value and what is allowed."""


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
        IPOPT's iteration limit per solve, >= 1.
    linear_solver : str
        IPOPT's linear solver: ``"mumps"`` or ``"spral"`` (the HSL solvers are not in the wheel).
    continuation : bool
        Follow the load history (pressure, then payloads and weight) from a known state by path
        following. When False, or when :func:`solve` is given ``theta0``, one IPOPT solve at the
        full load.
    path : PathOptions
        Settings of the path traces of the load history (:class:`esba.paths.continuation.PathOptions`).
    fast : bool
        Try each ramp of the load history first as one compiled natural-parameter continuation
        (:mod:`esba.solvers.newton`), accepted only when it provably stayed on one stable branch; otherwise,
        and always when False, the adaptive path trace of :mod:`esba.paths.loading` follows it.
    polish : bool
        Newton steps on the exact Hessian after IPOPT (stationarity to round-off).
    stationarity_tol : float
        Largest |dU/dtheta_i| (N mm/rad) accepted as an equilibrium.
    critical_tol : float
        A Hessian whose smallest eigenvalue is within ``critical_tol`` times its largest (in
        absolute value) of zero is ``critical``; below that ``unstable``, above ``stable``.
    samples_per_segment : int
        Centre-line samples per segment in the result (>= 1).
    history : str or sequence of (float, float)
        The load history (:mod:`esba.statics.history`): ``inflate-then-load`` (the default),
        ``load-then-inflate``, ``together``, or a list of (pressure, load) fraction steps ending
        at (1, 1). Where the scene is multistable it decides the state reached.
    multistability : str
        Look for other stable states of the scene (:func:`esba.statics.equilibria.check_multistability`):
        ``auto`` (when n <= 8, where the search costs about a solve), ``always`` or ``never``.
    certify : str
        How the state the load history reached is certified: ``auto``, from the exact gradient and
        Hessian there when they show a strict local minimiser to ``tol`` (the conditions IPOPT would
        accept without iterating, and positive definiteness), else by IPOPT; ``ipopt``, always by
        IPOPT (warm-started there). A solve from ``theta0`` or without continuation always calls IPOPT.

    Examples
    --------
    >>> SolverOptions().tol
    1e-10
    >>> SolverOptions(max_iter=0)
    Traceback (most recent call last):
    ...
    esba.statics.equilibrium.SolverOptionsError: max_iter=0: expected a whole number from 1 to 100000 (an equilibrium takes tens of iterations; IPOPT counts in a 32-bit int)
    """

    tol: float = 1e-10
    max_iter: int = 200
    linear_solver: str = "mumps"
    continuation: bool = True
    path: PathOptions = field(default_factory=PathOptions)
    fast: bool = True
    polish: bool = True
    stationarity_tol: float = 1e-7
    critical_tol: float = 1e-9
    samples_per_segment: int = 20
    history: Any = DEFAULT_HISTORY
    multistability: str = "auto"
    certify: str = "auto"

    def __post_init__(self) -> None:
        _check_pos("tol", self.tol, 1.0)
        _check_int("max_iter", self.max_iter, 1, MAX_ITER_LIMIT, "an equilibrium takes tens of iterations; IPOPT counts in a 32-bit int")
        if self.linear_solver not in LINEAR_SOLVERS:
            raise SolverOptionsError(f"linear_solver={self.linear_solver!r}: allowed are {', '.join(LINEAR_SOLVERS)}")
        for name in ("continuation", "polish", "fast"):
            if not isinstance(getattr(self, name), bool):
                raise SolverOptionsError(f"{name}={getattr(self, name)!r}: expected True or False")
        if not isinstance(self.path, PathOptions):
            raise SolverOptionsError(f"path={self.path!r}: expected a PathOptions")
        _check_pos("stationarity_tol", self.stationarity_tol)
        _check_pos("critical_tol", self.critical_tol, 1.0)
        _check_int("samples_per_segment", self.samples_per_segment, 1, MAX_SAMPLES_LIMIT)
        try:
            steps = history_steps(self.history)
        except HistoryError as exc:
            raise SolverOptionsError(str(exc)) from None
        if not isinstance(self.history, str):
            object.__setattr__(self, "history", steps)  # hashable, as the frozen options are
        if self.multistability not in MULTISTABILITY:
            raise SolverOptionsError(f"multistability={self.multistability!r}: allowed are {', '.join(MULTISTABILITY)}")
        if self.certify not in CERTIFY:
            raise SolverOptionsError(f"certify={self.certify!r}: allowed are {', '.join(CERTIFY)}")


DEFAULT_OPTIONS = SolverOptions()

#: The default for computations that call :func:`solve` as one step of their own (a stiffness's
#: solves, a design's check, a fit's rows, a load estimate's histories) and report nothing of a
#: scene's other stable states: the same solve without the multistability check.
STEP_OPTIONS = SolverOptions(multistability="never")



# ---------------------------------------------------------------------------------------------
# the result


@dataclass(frozen=True, eq=False, repr=False)
class Equilibrium(Report):
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
        The certifying step's status: IPOPT's return status, ``Solve_Succeeded`` too when the exact
        gradient and Hessian certified the state without IPOPT (see ``certificate``); or
        ``Continuation_Failed`` / ``At_Bound`` / ``Not_Stationary``.
    success : bool
        The solver converged to a stationary point inside the domain.
    iterations : int
        Newton corrector iterations along the load history plus IPOPT iterations.
    steps : int
        Points traced along the load history plus IPOPT solves (1 without continuation; 0 when the
        exact gradient and Hessian certified the state).
    solve_time_s : float
        Wall time of the whole solve, s (the multistability check's own time is in
        ``multistability.search_time_s``).
    message : str
        Why the result is not ok (empty when it is).
    notes : tuple of str
        What happened on the way that the result does not show (a jump, a buckling).
    jumps : tuple of Jump
        The snap-throughs of the load history (:class:`esba.paths.loading.Jump`): the fold's lambda and
        the states before and after.
    branch_points : tuple of SpecialPoint
        Branch points the load history went through along a stable crossing branch (buckling).
    certificate : str
        What certified the returned state as a minimiser, in one line: the gradient's size, the margin
        to the domain bound and the Hessian's smallest eigenvalue at the path's end (no IPOPT call
        needed), or IPOPT's status from there and how far it moved the state.
    validity : tuple of Finding
        Where the result leaves the range the paper's model describes (strains past 1, a bend past
        360 deg, the tip behind the base, loads far outside the paper's): see :mod:`esba.model.validity`.
        Empty when it is inside; a result can be ``ok`` and still outside.
    history : str
        The load history followed (its name or steps), or how the state was found without one.
    multistability : Multistability or None
        The other stable states of the scene, which one the history reached and why, or why
        ``solve`` did not look (:mod:`esba.statics.equilibria`); None for :func:`evaluate`.
    contact : ContactEquilibrium or None
        For a scene with obstacles, the constrained solve (:mod:`esba.statics.contact`): its
        contacts, gaps and KKT numbers. ``gradient_norm`` is then the Lagrangian's stationarity and
        ``eigenvalues`` those of the reduced Hessian on the active constraints' tangent space.
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
    jumps: tuple[Jump, ...] = ()
    branch_points: tuple[SpecialPoint, ...] = ()
    certificate: str = ""
    validity: tuple[Finding, ...] = ()
    history: str = ""
    multistability: Multistability | None = None
    contact: Any = None

    _plotter = "esba.figures.results:draw_equilibrium"

    def headline(self) -> str:
        """One line: the verdict, pressure, bend and tip."""
        x, y = self.tip_mm
        verdict = self.stability if self.ok else f"NOT OK ({self.stability}, {self.status})"
        return f"{verdict}, P = {self.pressure:.5g} MPa, total angle {self.total_angle_deg:.3f} deg, tip ({x:.2f}, {y:.2f}) mm, n = {self.scene.segments}"

    def summary(self) -> str:
        """The text ``esba solve`` prints for this scene (without its figure)."""
        from .text import solve_table

        return solve_table({**self.to_dict(), "scene": self.scene.describe()})

    @property
    def multistable(self) -> bool | None:
        """True when the scene has other stable states, False when the search found none, None when it did not look."""
        return None if self.multistability is None else self.multistability.multistable

    @property
    def other_stable_states(self) -> tuple:
        """The other stable states found (:class:`esba.statics.equilibria.State`), empty when none or not looked."""
        return () if self.multistability is None else self.multistability.others

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
            "jumps": [j.to_dict() for j in self.jumps],
            "branch_points": [
                {"lambda": b.lam, "total_angle_deg": b.total_angle_deg, "tip_mm": [float(b.tip[0]), float(b.tip[1])], "status": b.status}
                for b in self.branch_points
            ],
            "certificate": self.certificate,
            "validity": [f.to_dict() for f in self.validity],
            "history": self.history,
            "multistable": self.multistable,
            "multistability": None if self.multistability is None else self.multistability.to_dict(),
            "contact": None if self.contact is None else {k: v for k, v in self.contact.to_dict().items() if k in CONTACT_KEYS},
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
# solving


def _check_inputs(scene: Any, pressure: Any, options: Any) -> SolverOptions:
    """The checks the command line makes, for the Python API: the scene, a pressure, the options."""
    if not isinstance(scene, Scene):
        raise SceneError(f"scene={scene!r}: expected an esba.model.scene.Scene")
    if pressure is not None:
        check_pressure(pressure)
    options = DEFAULT_OPTIONS if options is None else options
    if not isinstance(options, SolverOptions):
        raise SolverOptionsError(f"options={options!r}: expected a SolverOptions")
    resolution.check_stiffness(scene, DEFAULT_OPTIONS.stationarity_tol)  # before a target angle's pressure is sought
    return options


#: The largest |segment angle| (rad) accepted as a solve's start (:func:`evaluate` takes any finite
#: angles, and says where the model overflows): far beyond any
#: equilibrium (a segment turned 160 times), small enough that sin and cos keep their digits.
MAX_ANGLE = 1e3


def _angles(name: str, values: Any, n: int, bounded: bool = False) -> np.ndarray:
    """``values`` as n finite angles (rad), else :class:`SolverOptionsError` naming ``name``."""
    try:
        theta = np.asarray(values, dtype=float).ravel()
    except (TypeError, ValueError, OverflowError):
        raise SolverOptionsError(f"{name}={checks.quote(values)}: expected {n} finite angles (rad)") from None
    if theta.shape != (n,) or not np.all(np.isfinite(theta)):
        raise SolverOptionsError(f"{name} has shape {theta.shape}: expected {n} finite angles (rad)")
    if bounded and np.any(np.abs(theta) > MAX_ANGLE):
        raise SolverOptionsError(f"{name}={checks.quote(theta.tolist())}: expected {n} angles (rad) with |angle| <= {MAX_ANGLE:g} (a segment bent {MAX_ANGLE / (2 * np.pi):.0f} turns)")
    return theta


def _resolve_pressure(scene: Scene, pressure: float | None) -> tuple[float, np.ndarray | None]:
    """The pressure to use and, when it comes from the target angle, the exact unloaded state."""
    if pressure is not None:
        return float(pressure), None
    if scene.pressure is not None:
        return scene.pressure, None
    p = pressure_for_angle(scene)
    return p, np.full(scene.segments, math.radians(scene.target_angle_deg) / scene.segments)


@single_threaded
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
    jumps: Sequence[Jump] = (),
    branch_points: Sequence[SpecialPoint] = (),
    certificate: str = "",
) -> Equilibrium:
    """An :class:`Equilibrium` for given angles: energy, tip, centre-line, stationarity and stability.

    :func:`solve` ends here; call it directly to assess angles found some other way (e.g. by an
    NLP that only asks for dU/dtheta = 0). ``success`` is withdrawn when theta is on the domain
    boundary or not stationary within ``options.stationarity_tol``.

    Examples
    --------
    >>> from esba.model.scene import Scene, Payload
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
    return _assemble(
        scene, model, theta, pressure, full, model.param_vector(full), model.lower_bounds(full), options,
        status=status, success=success, iterations=iterations, steps=steps, solve_time_s=solve_time_s, message=message,
        notes=notes, jumps=jumps, branch_points=branch_points, certificate=certificate,
    )


def _assemble(
    scene: Scene,
    model: Model,
    theta: np.ndarray,
    pressure: float,
    full: dict[str, float],
    pv: np.ndarray,
    lbx: np.ndarray,
    options: SolverOptions,
    *,
    status: str,
    success: bool,
    iterations: int,
    steps: int,
    solve_time_s: float,
    message: str,
    notes: Sequence[str],
    jumps: Sequence[Jump],
    branch_points: Sequence[SpecialPoint],
    certificate: str,
    state: dict | None = None,
) -> Equilibrium:
    """:func:`evaluate` on checked inputs (``full``, ``pv`` and ``lbx`` the parameters at ``pressure``;
    ``state`` the model's state at ``theta`` when it is known)."""
    if np.any(theta < lbx):
        raise EquilibriumError(f"theta={np.degrees(theta).round(3).tolist()} deg lies outside the model's domain (Eq. 10)")
    if state is None:
        state = compiled_state(model, theta, pv)
    gnorm = float(np.max(np.abs(state["gradient"])))
    finite = bool(np.all(np.isfinite(state["hessian"])) and np.isfinite(gnorm) and np.isfinite(state["energy"]))
    eig = np.sort(np.linalg.eigvalsh(state["hessian"])) if finite else np.full(scene.segments, np.nan)
    verdict = stability_verdict(eig, options.critical_tol)
    if not finite:
        success, status = False, "Not_Finite"
        message = "the model's energy, gradient or Hessian is not finite at the result (overflow): not an equilibrium"
    elif success and near_domain_bound(theta, lbx):
        success, status = False, "At_Bound"
        message = "the solve stopped on the model's domain boundary (Eq. 10: the chamber closes): not an equilibrium"
    elif success and gnorm > options.stationarity_tol:
        success, status = False, "Not_Stationary"
        message = f"max |dU/dtheta| = {gnorm:.3g} N mm/rad > stationarity_tol = {options.stationarity_tol:g}"
    if success and verdict != "stable":
        message = f"the equilibrium is {verdict}: smallest Hessian eigenvalue {eig[0]:.3g} N mm/rad^2 (largest {eig[-1]:.3g})"
    cl = model.centreline(theta, full["L"], samples=scene.segments * options.samples_per_segment + 1, points=state["points"])
    return Equilibrium(
        scene=scene,
        model=model,
        pressure=pressure,
        theta=theta,
        tip=state["tip"],
        centreline=cl,
        energy=state["energy"],
        terms=state["terms"],
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
        jumps=tuple(jumps),
        branch_points=tuple(branch_points),
        certificate=certificate,
        validity=assess(scene, theta, pressure, state["tip"]),
    )


@single_threaded
def solve(
    scene: Scene,
    options: SolverOptions | None = None,
    *,
    pressure: float | None = None,
    theta0: Sequence[float] | None = None,
    unloaded: Sequence[float] | None = None,
) -> Equilibrium:
    """The equilibrium of ``scene`` reached along its load history.

    Parameters
    ----------
    scene : Scene
        What to solve (the model is ``scene.model()``).
    options : SolverOptions, optional
        Solver settings; defaults to ``SolverOptions()``.
    pressure : float, optional
        Use this pressure (MPa) instead of the scene's (saves the closed form in sweeps).
    theta0 : sequence of float, optional
        Warm start (rad): one IPOPT solve at the full load from here, no load history.
    unloaded : sequence of float, optional
        The unloaded equilibrium at this pressure (rad), when it is already known (a stiffness
        study solves several payloads at one pressure): the load ramp starts there.

    Raises
    ------
    SceneError
        for a scene that is not a :class:`~esba.model.scene.Scene`, a bad ``pressure`` (the same
        messages as the scene's own field), or scales the solver cannot resolve to its
        tolerances (a Young's modulus so small that every angle passes as an equilibrium, a
        pressure or payload whose moments exceed double precision), all checked before solving.
    SolverOptionsError
        for ``options`` that are not a :class:`SolverOptions`, or a bad ``theta0`` or ``unloaded``.

    Returns
    -------
    Equilibrium
        Check :attr:`Equilibrium.ok` (or call :meth:`Equilibrium.check`): a failed or unstable
        solve is returned with ``ok == False`` and a ``message``. The load history is: the
        unloaded state at the pressure (exact for a target angle, else the pressure raised from 0),
        then the payloads and weight raised together from 0. A snap-through on the way (the stable
        branch ends at a fold) is followed as the actuator would, and recorded in ``jumps`` and
        ``notes``; so is buckling at a branch point (``branch_points``).
    """
    options = _check_inputs(scene, pressure, options)
    if theta0 is not None:
        theta0 = _angles("theta0", theta0, scene.segments, bounded=True)
    if unloaded is not None:
        unloaded = _angles("unloaded", unloaded, scene.segments)
    if scene.obstacles:
        return _solve_with_contact(scene, options, pressure, theta0)
    model = scene.model()  # loaded (or generated) before the clock starts
    t_start = time.perf_counter()
    n = scene.segments
    pressure, known_unloaded = _resolve_pressure(scene, pressure)
    resolution.check_resolvable(scene, pressure, options.stationarity_tol, DEFAULT_OPTIONS.stationarity_tol)
    if unloaded is not None:
        known_unloaded = unloaded
    full = scene.parameters(pressure)
    lbx = model.lower_bounds(full)
    pv_full = model.param_vector(full)
    history = None
    if theta0 is not None:
        theta = theta0
    elif not options.continuation:
        theta = known_unloaded if known_unloaded is not None else np.zeros(n)
    else:
        history = load_history(model, pressure, pv_full, known_unloaded, options)
        theta = history.theta
    message = history.message if history is not None else ""
    loaded = bool(np.any(pv_full != _unloaded(model, pv_full)))
    traced = (history is not None and history.ramps) or (known_unloaded is not None and theta0 is None and not loaded)
    if history is not None and history.ramps:
        start_from = "the path's end"
    else:
        start_from = "the known unloaded state" if known_unloaded is not None and theta0 is None else "the start"
    direct = _certify(model, theta, pv_full, lbx, options, start_from) if traced and not message and options.certify == "auto" else None
    if direct is not None:
        final, state, certificate = direct
        ipopt_solves = 0
    else:
        final = minimise(
            model,
            theta,
            pv_full,
            lbx,
            tol=options.tol,
            max_iter=options.max_iter,
            linear_solver=options.linear_solver,
            polish_steps=4 if options.polish else 0,
            warm=bool(traced),
        )
        state, ipopt_solves = None, 1
        certificate = f"IPOPT {final.status}: {final.iterations} iterations from {start_from}, which it moved by {float(np.max(np.abs(final.theta - theta))):.2g} rad"
    moved = float(np.max(np.abs(final.theta - theta)))
    notes = history.notes(model, pv_full, pressure) if history is not None else []
    if history is not None and history.ramps and final.success and moved > 1e-6:
        notes.append(f"IPOPT moved the path's end by {moved:.3g} rad: the certified state is not the one the path reached")
    if message:  # the load history failed: report the full-load solve from the last good state, not as an answer
        status, success = "Continuation_Failed", False
    else:
        status, success = final.status, final.success
        if not success:
            message = f"IPOPT did not converge: {final.status}"
    iterations = final.iterations + (history.iterations if history is not None else 0)
    steps = ipopt_solves + (history.points if history is not None else 0)
    result = _assemble(
        scene,
        model,
        final.theta,
        pressure,
        full,
        pv_full,
        lbx,
        options,
        status=status,
        success=success,
        iterations=iterations,
        steps=steps,
        solve_time_s=time.perf_counter() - t_start,
        message=message,
        notes=notes,
        jumps=history.jumps if history is not None else (),
        branch_points=history.branch_points if history is not None else (),
        certificate=certificate,
        state=state,
    )
    if history is not None:
        how = history_name(options.history)
    elif theta0 is not None:
        how = "none (one IPOPT solve from the given theta0)"
    else:
        how = "none (one IPOPT solve at the full load)"
    multistability = _multistability(scene, model, result, how, history, options)
    return replace(result, history=how, multistability=multistability)


def _certify(model: Model, theta: np.ndarray, pv: np.ndarray, lbx: np.ndarray, options: SolverOptions, start_from: str) -> tuple[Minimum, dict, str] | None:
    """The certificate of a state the load history reached, from the exact gradient and Hessian there,
    without IPOPT: after the Newton polish (``options.polish``), max |dU/dtheta| <= ``options.tol``,
    every angle strictly inside its domain bound (not within :func:`near_domain_bound` of it) and
    the Hessian positive definite beyond ``options.critical_tol`` (a *stable* verdict). These are
    the first-order conditions IPOPT would accept there without an iteration (its ``Solve_Succeeded``
    after 0 iterations: IPOPT divides the gradient by a scale of at least 1 before comparing it with
    ``tol``, so this test is at least as strict), and the second-order ones it does not check:
    together, a strict local minimiser. Returns (the point,
    its state, the certificate), or None when a condition fails (IPOPT then certifies, as it did
    for every solve before)."""
    point = polish(model, theta, pv, lbx, 4) if options.polish else np.asarray(theta, dtype=float)
    state = compiled_state(model, point, pv)
    h, g = state["hessian"], state["gradient"]
    if not (np.all(np.isfinite(h)) and np.all(np.isfinite(g)) and np.isfinite(state["energy"])):
        return None
    gnorm = float(np.max(np.abs(g)))
    if not gnorm <= options.tol or np.any(point <= lbx) or near_domain_bound(point, lbx):
        return None
    eig = np.sort(np.linalg.eigvalsh(h))
    if stability_verdict(eig, options.critical_tol) != "stable":
        return None
    margin = float(np.min(point - lbx))
    certificate = (
        f"Solve_Succeeded from the exact gradient and Hessian at {start_from}, no IPOPT iteration needed: "
        f"max |dU/dtheta| = {gnorm:.2g} N mm/rad <= tol = {options.tol:g}, every angle {margin:.3g} rad or more inside its bound (Eq. 10), "
        f"Hessian positive definite (smallest eigenvalue {eig[0]:.4g} N mm/rad^2): a strict local minimiser; "
        f"the Newton polish moved it by {float(np.max(np.abs(point - theta))):.2g} rad"
    )
    return Minimum(point, "Solve_Succeeded", True, 0), state, certificate
#: What ``Equilibrium.to_dict`` keeps of a contact solve (its shape and angles are the result's own).
CONTACT_KEYS = ("contacts", "total_contact_force_n", "contact_span_mm", "gaps_elsewhere_mm", "kkt", "obstacles", "outer_passes",
                "newton_steps", "ipopt_steps", "halvings")


def _solve_with_contact(scene: Scene, options: SolverOptions, pressure: float | None, theta0: np.ndarray | None) -> Equilibrium:
    """A scene with obstacles: the constrained equilibrium along the load history from rest
    (:func:`esba.statics.contact.solve_contact`, the options' history), or from ``theta0`` at the full
    load, as an :class:`Equilibrium` with its ``contact``."""
    from esba.model.contact.surface import closest_points, offset_of

    from .contact import ContactOptions, ContactState, solve_contact

    copts = ContactOptions(tol=options.tol, max_iter=options.max_iter, linear_solver=options.linear_solver,
                           critical_tol=options.critical_tol, samples_per_segment=options.samples_per_segment)
    warm = None
    if theta0 is not None:
        p = _resolve_pressure(scene, pressure)[0]
        sigma = np.array([closest_points(theta0, scene.actuator.L, offset_of(o.resolved_side(), scene.actuator.r1), o)[0] for o in scene.obstacles])
        warm = ContactState(np.asarray(theta0, dtype=float), np.zeros(2 * scene.segments * len(scene.obstacles) + 2), sigma, p, 1.0)
    rc = solve_contact(scene, copts, pressure=pressure, warm=warm, history=None if warm is not None else history_steps(options.history))
    model = scene.model()
    pv = model.param_vector(scene.parameters(rc.pressure))
    state = model.state(rc.theta, pv)
    how = (f"{history_name(options.history)} with contact, from rest (steps halved where one fails or passes through an obstacle)"
           if theta0 is None else "none (the contact solve from the given theta0)")
    return Equilibrium(
        scene=scene, model=model, pressure=rc.pressure, theta=rc.theta, tip=rc.tip, centreline=rc.centreline,
        energy=rc.energy, terms=state["terms"], gradient_norm=rc.kkt.stationarity, eigenvalues=rc.kkt.reduced_eigenvalues,
        stability=rc.kkt.stability, status=rc.status, success=rc.success, iterations=rc.iterations, steps=rc.outer,
        solve_time_s=rc.solve_time_s, message=rc.message, certificate=f"the contact solve (active-set Newton on the KKT system, IPOPT with gap >= 0 constraints where it fails): {rc.status}",
        validity=assess(scene, rc.theta, rc.pressure, rc.tip), history=how,
        multistability=not_looked("a scene with obstacles: the search for other states is of the free actuator"), contact=rc,
    )


def _multistability(scene: Scene, model: Model, result: Equilibrium, how: str, history: LoadHistory | None, options: SolverOptions) -> Multistability:
    """Look for the scene's other stable states when ``options.multistability`` says so."""
    n = scene.segments
    if options.multistability == "never":
        return not_looked("SolverOptions(multistability='never')")
    if options.multistability == "auto" and n > AUTO_MAX_SEGMENTS:
        return not_looked(
            f"n = {n} > {AUTO_MAX_SEGMENTS} segments, where the search costs several solves (docs/performance.md); "
            "multistability='always' (esba solve --multistability always, or esba equilibria) looks"
        )
    if not result.ok:
        return not_looked("the solve did not reach a stable equilibrium")
    if history is None:
        why = "IPOPT converged there from its start"
    elif history.jumps:
        why = "its stable branch ended at a fold on the way and it snapped to this state"
    elif history.branch_points:
        why = "it buckled at a branch point onto this branch and followed it"
    else:
        why = "it followed one stable branch from the straight, unloaded state"
    known = state_of(result.theta, result.tip, result.energy, result.eigenvalues, result.gradient_norm, SOLVE_CHECK.critical_tol, "the load history's state",
                     tuple(result.validity))
    return check_multistability(scene, model, result.pressure, result.theta, how, why, known)

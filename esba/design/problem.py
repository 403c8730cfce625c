"""Design problems: what to optimise over the chamber (r2, d), and the solvers' settings.

The paper's problem (Section 5): choose the chamber radius r2 and eccentricity d of the Table 1
actuator (r1 = 8 mm) for the largest secant stiffness K = Delta F / Delta y (Section 4.4.3):
each design is first inflated, unloaded, to 90 degrees (so the pressure depends on the design),
then a 2 N horizontal tip payload is applied with the pressure held, and K = 1000 F / delta
(N/m, delta in mm along the force). The geometry allows 0 < r2, 0 <= d, r2 + d < r1.
:class:`DesignProblem` states it (and the stiffness-constrained variants: the largest free
angle, the lowest pressure), :class:`DesignOptions` the settings of both solvers; both are
validated on creation. Solving them is :mod:`esba.design.optimise`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from esba.derive.effects import DEFAULT_VARIANT, VARIANTS
from esba.infra import checks
from esba.infra.errors import InputError
from esba.model import resolution
from esba.model.scene import MAX_PAYLOAD, MAX_TARGET_ANGLE_DEG, Actuator, Payload, Scene
from esba.statics.equilibrium import DEFAULT_OPTIONS

__all__ = ["OBJECTIVES", "METHODS", "GEOMETRY_EPS", "DesignError", "DesignProblem", "DesignOptions", "DEFAULT_DESIGN_OPTIONS"]

#: What a design problem may optimise.
OBJECTIVES = ("stiffness", "angle", "pressure")
#: How ``esba design`` may solve it.
METHODS = ("ipopt", "pso", "both")
#: The smallest wall r1 - r2 - d (mm) that keeps the paper's strict r2 + d < r1.
GEOMETRY_EPS = 1e-3

_OBJECTIVE_UNITS = {"stiffness": "N/m", "angle": "deg", "pressure": "MPa"}
#: Each objective as (sign, scale): IPOPT minimises sign * J / scale.
OBJECTIVE_SCALING = {"stiffness": (-1.0, 10.0), "angle": (-1.0, 90.0), "pressure": (1.0, 0.1)}


class DesignError(InputError):
    """A design setting that is not allowed: the message names the value and what is allowed."""


def _finite(name: str, value: Any, low: float | None = None, *, open_low: bool = False) -> float:
    value = checks.finite(name, value, DesignError)
    if low is not None and (value <= low if open_low else value < low):
        raise DesignError(f"{name}={value:g}: expected a number {'>' if open_low else '>='} {low:g}")
    return value


def _whole(name: str, value: Any, low: int, high: int | None = None, why: str = "") -> int:
    return checks.whole(name, value, low, DesignError, high, why)


# ---------------------------------------------------------------------------------------------
# the problem and the settings


@dataclass(frozen=True)
class DesignProblem:
    """What to optimise over the chamber (r2, d); everything else is fixed.

    Parameters
    ----------
    objective : str
        ``"stiffness"`` (maximise K, the paper's problem), ``"angle"`` (maximise the free bending
        angle at ``max_pressure``) or ``"pressure"`` (minimise the pressure that bends the
        unloaded actuator to ``target_angle_deg``).
    segments : int
        Segment count n (the paper: 3).
    variant : str
        Model variant, ``"paper"`` or ``"printed"``.
    actuator : Actuator
        The fixed part: L, r1, rho, E (Table 1 by default); its r2 and d are ignored.
    payload_n : float
        Tip payload of the stiffness test, N (> 0; the paper: 2 N).
    payload_angle_deg : float
        Its direction Omega from the vertical (90 = horizontal, the paper's case).
    start_angle_deg : float
        Unloaded bending angle at which the stiffness is measured, degrees (the paper: 90).
    min_stiffness : float or None
        K >= min_stiffness (N/m, > 0): the constraint of ``angle`` and ``pressure`` (required
        there); for ``stiffness`` the request is checked (infeasible when the optimum is below it).
    max_pressure : float or None
        MPa (> 0). Required by ``angle`` (the pressure of the free angle). For every objective the
        90 degree state, and for ``pressure`` the target state, must be reached with P <= max_pressure.
    target_angle_deg : float or None
        Target unloaded angle of ``pressure`` (degrees > 0; default ``start_angle_deg``).
    min_wall : float
        Thinnest wall r1 - r2 - d allowed, mm (>= 0 and < r1); below ``GEOMETRY_EPS`` the wall is
        ``GEOMETRY_EPS`` (the paper's strict r2 + d < r1).

    Examples
    --------
    >>> DesignProblem().wall
    0.001
    >>> DesignProblem(objective="angle", min_stiffness=40.0)
    Traceback (most recent call last):
    ...
    esba.design.problem.DesignError: objective='angle' needs max_pressure (the pressure of the free bending angle, MPa)
    """

    objective: str = "stiffness"
    segments: int = 3
    variant: str = DEFAULT_VARIANT
    actuator: Actuator = field(default_factory=Actuator)
    payload_n: float = 2.0
    payload_angle_deg: float = 90.0
    start_angle_deg: float = 90.0
    min_stiffness: float | None = None
    max_pressure: float | None = None
    target_angle_deg: float | None = None
    min_wall: float = 0.0

    def __post_init__(self) -> None:
        if self.objective not in OBJECTIVES:
            raise DesignError(f"objective={self.objective!r}: allowed are {', '.join(OBJECTIVES)}")
        checks.segments(self.segments, DesignError)
        if self.variant not in VARIANTS:
            raise DesignError(f"variant={self.variant!r}: allowed are {', '.join(VARIANTS)}")
        if not isinstance(self.actuator, Actuator):
            raise DesignError(f"actuator={self.actuator!r}: expected an Actuator")
        object.__setattr__(self, "payload_n", _finite("payload_n", self.payload_n, 0.0, open_low=True))
        if self.payload_n > MAX_PAYLOAD:
            raise DesignError(f"payload_n={self.payload_n:g} N: expected at most {MAX_PAYLOAD:g} N (a scene's bound: the model means nothing beyond)")
        object.__setattr__(self, "payload_angle_deg", _finite("payload_angle_deg", self.payload_angle_deg))
        object.__setattr__(self, "start_angle_deg", _finite("start_angle_deg", self.start_angle_deg, 0.0, open_low=True))
        for name in ("min_stiffness", "max_pressure", "target_angle_deg"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, _finite(name, value, 0.0, open_low=True))
        for name in ("start_angle_deg", "target_angle_deg"):  # as a scene's target angle
            value = getattr(self, name)
            if value is not None and value > MAX_TARGET_ANGLE_DEG:
                raise DesignError(f"{name}={value:g}: expected an angle <= {MAX_TARGET_ANGLE_DEG:g} degrees (ten turns; past one the actuator already passes through itself)")
        wall = _finite("min_wall", self.min_wall, 0.0)
        if wall >= self.actuator.r1:
            raise DesignError(f"min_wall={wall:g}: expected 0 <= min_wall < r1 = {self.actuator.r1:g} mm")
        object.__setattr__(self, "min_wall", wall)
        if self.max_pressure is not None:  # the bound of every solve (esba.model.resolution), up front
            top = resolution.max_pressure(self.actuator.r1, DEFAULT_OPTIONS.stationarity_tol)
            if self.max_pressure > top:
                raise DesignError(
                    f"max_pressure={self.max_pressure:g} MPa: its moment on a segment is more than double precision can "
                    f"balance; expected at most {top:.3g} MPa for r1 = {self.actuator.r1:g} mm"
                )
        if self.objective == "angle" and self.max_pressure is None:
            raise DesignError("objective='angle' needs max_pressure (the pressure of the free bending angle, MPa)")
        if self.objective != "stiffness" and self.min_stiffness is None:
            raise DesignError(
                f"objective={self.objective!r} needs min_stiffness (N/m): without it the optimum runs off to "
                "the thinnest wall, where the chamber fills the actuator and the stiffness is lowest"
            )
        if self.objective != "pressure" and self.target_angle_deg is not None:
            raise DesignError(f"target_angle_deg={self.target_angle_deg:g} is only used with objective='pressure'")

    @property
    def wall(self) -> float:
        """The wall bound used: max(min_wall, GEOMETRY_EPS), mm."""
        return max(self.min_wall, GEOMETRY_EPS)

    @property
    def target(self) -> float:
        """Target angle of the ``pressure`` objective, degrees."""
        return self.start_angle_deg if self.target_angle_deg is None else self.target_angle_deg

    @property
    def unit(self) -> str:
        """Unit of the objective."""
        return _OBJECTIVE_UNITS[self.objective]

    def replace(self, **changes: Any) -> DesignProblem:
        """A new validated problem with some fields changed."""
        return dataclasses.replace(self, **changes)

    def stiffest(self) -> DesignProblem:
        """The stiffness problem with the same geometry and pressure limits (no K_min)."""
        return self.replace(objective="stiffness", min_stiffness=None, target_angle_deg=None)

    def scene(self, r2: float, d: float, pressure: float | None = None, loaded: bool = True) -> Scene:
        """The scene of design (r2, d): the stiffness test's payload, the 90 degree start."""
        act = dataclasses.replace(self.actuator, r2=float(r2), d=float(d))
        payloads = (Payload(self.payload_n, self.payload_angle_deg, 1.0),) if loaded else ()
        if pressure is None:
            return Scene(act, target_angle_deg=self.start_angle_deg, payloads=payloads, segments=self.segments, variant=self.variant)
        return Scene(act, pressure=float(pressure), payloads=payloads, segments=self.segments, variant=self.variant)

    def describe(self) -> str:
        """One line: the objective and the constraints."""
        if self.objective == "stiffness":
            goal = "maximise the secant stiffness K"
        elif self.objective == "angle":
            goal = f"maximise the free bending angle at {self.max_pressure:g} MPa"
        else:
            goal = f"minimise the pressure that bends the unloaded actuator to {self.target:g} deg"
        cons = [f"0 < r2, 0 <= d, r1 - r2 - d >= {self.wall:g} mm"]
        if self.min_stiffness is not None:
            cons.append(f"K >= {self.min_stiffness:g} N/m")
        if self.max_pressure is not None:
            cons.append(f"P <= {self.max_pressure:g} MPa")
        a = self.actuator
        return (
            f"{goal} subject to {', '.join(cons)}; K = 1000 F / delta for a {self.payload_n:g} N tip payload at "
            f"{self.payload_angle_deg:g} deg from the unloaded {self.start_angle_deg:g} deg state; "
            f"L={a.L:g} r1={a.r1:g} rho={a.rho_deg:g} deg E={a.E:g} MPa; n={self.segments}, {self.variant}"
        )


@dataclass(frozen=True)
class DesignOptions:
    """Settings of the design solvers, validated on creation.

    Parameters
    ----------
    tol : float
        IPOPT's tolerance (``ipopt.tol``), 0 < tol < 1.
    max_iter : int
        IPOPT's iteration limit per start.
    linear_solver : str
        ``"mumps"`` or ``"spral"``.
    starts : int
        IPOPT starts spread over the triangle (1 to 8; the best converged result is kept).
    load_steps : int
        Steps of the payload ramp in the batched evaluator (a tangent predictor and ``newton_steps``
        Newton corrections each, :mod:`esba.solvers.newton`), >= 1.
    newton_steps : int
        Newton corrections per ramp step, >= 2 (the second measures the first's contraction).
    equilibrium_tol : float
        Largest |dU/dtheta| (N mm/rad) the evaluator accepts as an equilibrium.
    r2_min : float
        Lower bound of r2, mm (> 0: the paper's open bound r2 > 0).
    max_free_angle_deg : float
        Largest free bending angle searched, degrees (larger counts as failed).
    critical_tol : float
        Relative eigenvalue tolerance of the stability verdict.
    load_path_tol : float
        Largest difference (rad) between the NLP's loaded angles and the load-path solve.
    active_tol : float
        A constraint is active when within this distance of its bound (in its own units).
    threads : int
        Threads of the mapped evaluator (``Function.map(N, "thread", threads)``).

    Examples
    --------
    >>> DesignOptions().starts
    4
    >>> DesignOptions(starts=0)
    Traceback (most recent call last):
    ...
    esba.design.problem.DesignError: starts=0: expected a whole number from 1 to 8
    """

    tol: float = 1e-10
    max_iter: int = 200
    linear_solver: str = "mumps"
    starts: int = 4
    load_steps: int = 8
    newton_steps: int = 3
    equilibrium_tol: float = 1e-8
    r2_min: float = 0.01
    max_free_angle_deg: float = 3600.0
    critical_tol: float = 1e-9
    load_path_tol: float = 1e-6
    active_tol: float = 1e-6
    threads: int = 2

    def __post_init__(self) -> None:
        tol = _finite("tol", self.tol, 0.0, open_low=True)
        if tol >= 1.0:
            raise DesignError(f"tol={tol:g}: expected 0 < tol < 1")
        _whole("max_iter", self.max_iter, 1, 100_000, "an optimum takes tens of iterations; IPOPT counts in a 32-bit int")
        if self.linear_solver not in ("mumps", "spral"):
            raise DesignError(f"linear_solver={self.linear_solver!r}: allowed are mumps, spral")
        if isinstance(self.starts, bool) or not isinstance(self.starts, int) or not 1 <= self.starts <= len(START_FRACTIONS):
            raise DesignError(f"starts={self.starts!r}: expected a whole number from 1 to {len(START_FRACTIONS)}")
        _whole("load_steps", self.load_steps, 1, 1_000, "each step is unrolled into the mapped evaluator")
        _whole("newton_steps", self.newton_steps, 2, 1_000, "each step is unrolled into the mapped evaluator")
        _whole("threads", self.threads, 1, 256)
        for name in ("equilibrium_tol", "r2_min", "max_free_angle_deg", "critical_tol", "load_path_tol", "active_tol"):
            _finite(name, getattr(self, name), 0.0, open_low=True)


#: Starting designs of IPOPT as fractions (r2, d) of the room r1 - wall, spread over the triangle.
START_FRACTIONS = ((0.25, 0.05), (0.2, 0.5), (0.35, 0.6), (0.55, 0.05), (0.1, 0.8), (0.8, 0.05), (0.45, 0.3), (0.65, 0.25))

DEFAULT_DESIGN_OPTIONS = DesignOptions()

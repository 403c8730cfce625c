"""Scenes: an actuator, its loads and the model settings, validated once and then frozen.

A scene is everything :func:`esba.statics.equilibrium.solve` needs: the actuator's geometry and material
(:class:`Actuator`, defaults = the paper's Table 1 with E = 0.54 MPa), the pressure or the unloaded
bending angle from which the pressure is found, any number of point payloads (:class:`Payload`),
gravity and fibres on/off, the segment count and the model variant.

The scene decides the model: :attr:`Scene.effects` is exactly the scene's effect set (no payload,
no payload terms; gravity only when asked), and :meth:`Scene.model` loads that generated model.

Degrees appear only here, at the edge (the fibre angle ``rho_deg``, the payload direction
``angle_deg``, the target angle ``target_angle_deg``); :meth:`Scene.parameters` hands the model
radians. Units: mm, N, MPa, kg, m/s^2.

A scene file is TOML; every key is optional::

    segments = 3              # n, 1 to 256
    variant = "paper"         # or "printed"
    gravity = false
    fibres = true

    [actuator]                # Table 1 (E from Section 4.2)
    L = 135.0                 # mm
    r1 = 8.0                  # mm
    r2 = 3.0                  # mm
    d = 4.0                   # mm
    rho_deg = 10.0            # fibre angle, degrees
    E = 0.54                  # MPa
    M = 0.035                 # kg (only used with gravity)

    [loads]
    target_angle_deg = 90.0   # the pressure that bends the unloaded actuator this far ...
    # pressure = 0.12         # ... or a pressure in MPa (give one of the two)
    g = 9.81                  # m/s^2
    # gravity_direction = [1.0, 0.0, 0.0]  # with gravity: its direction in the base frame (default
                              # down, the paper's); any other needs the 3-D model

    [[payloads]]              # repeat for more payloads
    force = 2.0               # N
    angle_deg = 90.0          # Omega from the vertical: 0 down, 90 horizontal against the bend
    at = 1.0                  # point of application, fraction of L from the base (1 = tip)

    [[obstacles]]             # repeat for more; contact is solved only when there is one
    kind = "half-plane"       # a flat probe or wall (esba.model.contact.obstacles) ...
    at = [135.0, 0.0]         # a point on its face, mm
    normal_deg = 90.0         # where its face looks, as a payload's angle_deg
    # kind = "cylinder"       # ... or a cylinder across the bending plane
    # centre = [90.0, 30.0]   # mm
    # radius = 12.0           # mm
    # side = "auto"           # the surface it touches: auto, inner (the layer), outer (2 r1 off it)
    # 3-D (esba solve --3d; esba.model.contact.spatial): kind = "plane" (at = [x, y, z], normal = [nx, ny, nz]),
    # "sphere" (centre = [x, y, z], radius), "cylinder" with axis = [ax, ay, az] and a 3-number centre

    [uncertainty]             # optional: standard deviations (see esba.calibration.uncertainty)
    E = "10%"                 # relative; 0.05 (MPa) absolute; "±0.1" a tolerance

Examples
--------
>>> s = Scene(payloads=(Payload(2.0),))
>>> s.effects.spec()
'air,axial,radial,fibres,payload'
>>> s.replace(segments=4).segments
4
>>> Scene(segments=0)
Traceback (most recent call last):
...
esba.model.scene.SceneError: segments=0: expected a whole number from 1 to 256 (the finest model of the accuracy benchmark; larger n costs n^2 memory and minutes to generate for no accuracy)
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from esba.derive.effects import DEFAULT_VARIANT, MAX_PAYLOADS, VARIANTS, EffectSet
from esba.infra import checks, inputs
from esba.infra.errors import InputError

from .contact.kinds import obstacle_from_dict
from .contact.obstacles import MAX_OBSTACLES, Obstacle, ObstacleError
from .generated import Model, load_model

__all__ = ["Actuator", "ACTUATOR_RULES", "check_actuator_field", "actuator_rule", "Payload", "Moment", "Scene", "SceneError", "MAIN_JOB", "load_scene", "scene_from_dict", "check_pressure", "check_target_angle", "check_gravity_direction", "DOWN", "MAX_PRESSURE", "MAX_PAYLOAD"]

#: The largest target angle (the unloaded bend a pressure is sought for), degrees: ten turns, as a
#: measurement file allows (:data:`esba.calibration.measurements.MAX_ANGLE_DEG`); 1e6 deg is a typo.
MAX_TARGET_ANGLE_DEG = 3600.0

#: The largest pressure a scene takes, MPa: ten times the range :mod:`esba.model.validity` calls
#: far outside the paper's (FAR_FACTOR = 5 times its 0.2 MPa), where the linear-elastic model
#: means nothing (strains of hundreds); up to it a result is computed and warned of.
MAX_PRESSURE = 10.0
#: The largest payload a scene takes, N: ten times validity's far range (5 times the paper's 2 N).
MAX_PAYLOAD = 100.0
#: The largest point moment, N mm: the largest payload on a 1 m arm.
MAX_MOMENT = MAX_PAYLOAD * 1000.0

#: Standard gravity, m/s^2.
STANDARD_GRAVITY = 9.81


class SceneError(InputError):
    """A scene value that is not allowed: the message names the field, the value and what is allowed."""


def _number(where: str, value: Any) -> float:
    return checks.finite(where, value, SceneError)


def _positive(where: str, value: Any) -> float:
    value = _number(where, value)
    if value <= 0:
        raise SceneError(f"{where}={value:g}: expected a number > 0")
    return value


def check_pressure(value: Any, where: str = "pressure") -> float:
    """A pressure in MPa: a finite number >= 0 (the check of :attr:`Scene.pressure`, for every entry point).

    >>> check_pressure(float("inf"))
    Traceback (most recent call last):
    ...
    esba.model.scene.SceneError: pressure=inf: expected a finite number
    """
    p = _number(where, value)
    if p < 0:
        raise SceneError(f"{where}={p:g}: expected a pressure >= 0 MPa")
    if p > MAX_PRESSURE:
        raise SceneError(f"{where}={p:g} MPa: expected at most {MAX_PRESSURE:g} MPa (50 times the paper's largest, 0.2 MPa: "
                         "the linear-elastic model means nothing there)")
    return p


def check_target_angle(value: Any, where: str = "target_angle_deg") -> float:
    """A target total angle in degrees: finite, > 0 and at most :data:`MAX_TARGET_ANGLE_DEG` (the
    check of :attr:`Scene.target_angle_deg`, for every entry point).

    >>> check_target_angle(3601)
    Traceback (most recent call last):
    ...
    esba.model.scene.SceneError: target_angle_deg=3601: expected an angle <= 3600 degrees (ten turns; past one the actuator already passes through itself)
    """
    target = _number(where, value)
    if target <= 0:
        raise SceneError(f"{where}={target:g}: expected an angle > 0 degrees")
    if target > MAX_TARGET_ANGLE_DEG:
        raise SceneError(
            f"{where}={target:g}: expected an angle <= {MAX_TARGET_ANGLE_DEG:g} degrees (ten turns; past one the actuator already passes through itself)"
        )
    return target


def _flag(where: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise SceneError(f"{where}={checks.quote(value)}: expected true or false")
    return value


#: What each field of :class:`Actuator` allows on its own (the chamber must also lie inside the
#: actuator, r2 + d < r1): name -> (lowest, lowest allowed?, highest or None, unit, meaning). The one
#: definition of the actuator's fields for scene files, the command line's flags and sweep axes.
ACTUATOR_RULES: dict[str, tuple[float, bool, float | None, str, str]] = {
    "L": (0.0, False, None, "mm", "length of the inextensible layer"),
    "r1": (0.0, False, None, "mm", "external radius"),
    "r2": (0.0, False, None, "mm", "chamber radius"),
    "d": (0.0, True, None, "mm", "eccentric distance of the chamber"),
    "rho_deg": (0.0, True, 90.0, "deg", "fibre winding angle rho"),
    "E": (0.0, False, None, "MPa", "Young's modulus of the rubber"),
    "M": (0.0, True, None, "kg", "mass (used only with gravity)"),
}


def actuator_rule(name: str) -> str:
    """What actuator field ``name`` allows on its own, as a message says it (``"> 0"``, ``"0 <= rho_deg < 90"``)."""
    low, closed, high, _, _ = ACTUATOR_RULES[name]
    if high is not None:
        return f"{low:g} {'<=' if closed else '<'} {name} < {high:g}"
    return f"{'>=' if closed else '>'} {low:g}"


def check_actuator_field(name: str, value: Any, where: str | None = None) -> float:
    """Actuator field ``name`` checked on its own (:data:`ACTUATOR_RULES`); ``where`` names it in the
    message (default ``actuator.NAME``).

    >>> check_actuator_field("rho_deg", 95)
    Traceback (most recent call last):
    ...
    esba.model.scene.SceneError: actuator.rho_deg=95: expected 0 <= rho_deg < 90
    """
    where = f"actuator.{name}" if where is None else where
    low, closed, high, _, _ = ACTUATOR_RULES[name]
    value = _number(where, value)
    if value < low or (value == low and not closed) or (high is not None and value >= high):
        rule = actuator_rule(name)
        raise SceneError(f"{where}={value:g}: expected {rule if high is not None else 'a number ' + rule}")
    return value


@dataclass(frozen=True)
class Actuator:
    """Geometry and material of one ESBA (Table 1 of the paper by default).

    Parameters
    ----------
    L : float
        Length of the inextensible layer, mm (> 0).
    r1 : float
        External radius, mm (> 0).
    r2 : float
        Radius of the chamber, mm (> 0).
    d : float
        Eccentric distance of the chamber, mm (>= 0), with r2 + d < r1.
    rho_deg : float
        Winding angle of the fibres, degrees, 0 <= rho < 90.
    E : float
        Young's modulus of the rubber, MPa (> 0).
    M : float
        Mass, kg (>= 0; used only with gravity).

    Examples
    --------
    >>> Actuator().r2
    3.0
    >>> Actuator(r2=5.0)
    Traceback (most recent call last):
    ...
    esba.model.scene.SceneError: actuator.r2=5 with d=4, r1=8: the chamber must lie inside the actuator, r2 + d < r1
    """

    L: float = 135.0
    r1: float = 8.0
    r2: float = 3.0
    d: float = 4.0
    rho_deg: float = 10.0
    E: float = 0.54
    M: float = 0.035

    def __post_init__(self) -> None:
        for name in ACTUATOR_RULES:
            object.__setattr__(self, name, check_actuator_field(name, getattr(self, name)))
        if not self.r2 + self.d < self.r1:
            raise SceneError(
                f"actuator.r2={self.r2:g} with d={self.d:g}, r1={self.r1:g}: "
                "the chamber must lie inside the actuator, r2 + d < r1"
            )

    def parameters(self) -> dict[str, float]:
        """The model parameters of the actuator (radians): L, r1, r2, d, rho, E, M."""
        return {
            "L": self.L,
            "r1": self.r1,
            "r2": self.r2,
            "d": self.d,
            "rho": math.radians(self.rho_deg),
            "E": self.E,
            "M": self.M,
        }


@dataclass(frozen=True)
class Payload:
    """A constant point force on the actuator (Eq. 14, generalised to any point).

    Parameters
    ----------
    force : float
        Magnitude, N (>= 0).
    angle_deg : float
        Direction Omega from the vertical, degrees: the force is F (cos Omega, -sin Omega) in the
        base frame (x down, y horizontal); 0 pulls down, 90 pushes horizontally against the
        bending direction (Table 2).
    at : float
        Point of application as a fraction of L from the base, 0 < at <= 1 (1 = tip).
    out_of_plane_deg : float
        Angle Beta of the force out of the bending plane, degrees in [-90, 90]: the force is
        F (cos Beta cos Omega, -cos Beta sin Omega, sin Beta). 0 (the default) is the planar
        payload; any other value needs the 3-D model (:mod:`esba.statics.spatial`, ``esba solve --3d``).

    Examples
    --------
    >>> Payload(2.0).angle_deg
    90.0
    >>> Payload(1.0, at=1.5)
    Traceback (most recent call last):
    ...
    esba.model.scene.SceneError: payload.at=1.5: expected a fraction of the length with 0 < at <= 1 (1 = tip)
    """

    force: float
    angle_deg: float = 90.0
    at: float = 1.0
    out_of_plane_deg: float = 0.0

    def __post_init__(self) -> None:
        force = _number("payload.force", self.force)
        if force < 0:
            raise SceneError(f"payload.force={force:g}: expected a magnitude >= 0 N (turn angle_deg by 180 to reverse it)")
        if force > MAX_PAYLOAD:
            raise SceneError(f"payload.force={force:g} N: expected at most {MAX_PAYLOAD:g} N (50 times the paper's largest, 2 N: "
                             "the linear-elastic model means nothing there)")
        object.__setattr__(self, "force", force)
        object.__setattr__(self, "angle_deg", _number("payload.angle_deg", self.angle_deg))
        at = _number("payload.at", self.at)
        if not 0.0 < at <= 1.0:
            raise SceneError(f"payload.at={at:g}: expected a fraction of the length with 0 < at <= 1 (1 = tip)")
        object.__setattr__(self, "at", at)
        beta = _number("payload.out_of_plane_deg", self.out_of_plane_deg)
        if not -90.0 <= beta <= 90.0:
            raise SceneError(f"payload.out_of_plane_deg={beta:g}: expected an angle from -90 to 90 degrees out of the bending plane (turn angle_deg for the rest)")
        object.__setattr__(self, "out_of_plane_deg", beta)

    def scaled(self, factor: float) -> Payload:
        """The same payload with its magnitude times ``factor``."""
        return Payload(self.force * factor, self.angle_deg, self.at, self.out_of_plane_deg)


def _vector3(where: str, value: Any) -> tuple[float, float, float]:
    if isinstance(value, (str, bytes)) or not isinstance(value, (tuple, list)) or len(value) != 3:
        raise SceneError(f"{where}={checks.quote(value)}: expected three numbers [x, y, z]")
    return tuple(_number(where, v) for v in value)  # type: ignore[return-value]


#: Gravity's direction when none is given: +x of the base frame, down (the paper's, and the only one
#: the planar model carries).
DOWN = (1.0, 0.0, 0.0)


def check_gravity_direction(value: Any, where: str = "gravity_direction") -> tuple[float, float, float]:
    """A direction of gravity in the base frame as a unit 3-vector: three finite numbers, not all zero."""
    try:
        v = _vector3(where, value)
    except SceneError:
        raise SceneError(f"{where}={checks.quote(value)}: expected three finite numbers [x, y, z] of the base frame") from None
    size = math.sqrt(sum(x * x for x in v))
    if size == 0.0:
        raise SceneError(f"{where}={_show(v)}: a zero vector has no direction; give one such as [1, 0, 0] (down, the paper's)")
    return tuple(x / size for x in v)  # type: ignore[return-value]


def _show(v) -> str:
    return "[" + ", ".join(f"{x:g}" for x in v) + "]"


@dataclass(frozen=True)
class Moment:
    """A point moment on the actuator (3-D only: the planar model has no moment term).

    Parameters
    ----------
    moment : (mx, my, mz)
        N mm, in the axes of the straight actuator: x along it (the paper's x, down), y the bending
        direction, z the layer's normal (a moment about z bends in the paper's plane).
    at : float
        Point of application as a fraction of L from the base, 0 < at <= 1 (1 = tip).
    arm : (ax, ay, az) or None
        With an arm, the moment is a *couple*: two dead forces, +f at the section's centre plus the
        arm and -f at the centre, f = (m x e) / |e|^2 fixed in space, on a rigid arm e fixed to the
        section (perpendicular to ``moment``). It is ``moment`` at the straight state and turns with
        the arm: a real lever with weights, conservative at any rotation. Without an arm, the moment
        is a generalised force on the joint rotations: exact for a moment about z in the bending
        plane (a constant bending moment, as in B2 of docs/3d.md), a first-order stand-in for the
        other components (docs/3d.md says when that matters).

    Examples
    --------
    >>> Moment((20.0, 0.0, 0.0), arm=(0.0, 1.0, 0.0)).kind
    'couple'
    >>> Moment((20.0, 0.0, 0.0), arm=(1.0, 0.0, 0.0))
    Traceback (most recent call last):
    ...
    esba.model.scene.SceneError: moment.arm=[1, 0, 0]: expected a direction perpendicular to moment=[20, 0, 0] (then the couple's forces make exactly that moment)
    """

    moment: tuple[float, float, float]
    at: float = 1.0
    arm: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        m = _vector3("moment.moment", self.moment)
        size = math.sqrt(sum(v * v for v in m))
        if size > MAX_MOMENT:
            raise SceneError(f"moment.moment={_show(m)}: its size {size:g} N mm is more than {MAX_MOMENT:g} N mm "
                             f"({MAX_PAYLOAD:g} N on a 1 m arm: the linear-elastic model means nothing there)")
        object.__setattr__(self, "moment", m)
        at = _number("moment.at", self.at)
        if not 0.0 < at <= 1.0:
            raise SceneError(f"moment.at={at:g}: expected a fraction of the length with 0 < at <= 1 (1 = tip)")
        object.__setattr__(self, "at", at)
        if self.arm is not None:
            e = _vector3("moment.arm", self.arm)
            length = math.sqrt(sum(v * v for v in e))
            if length == 0.0:
                raise SceneError("moment.arm=[0, 0, 0]: a zero vector has no direction; expected the arm's direction in the section, e.g. [0, 1, 0]")
            if abs(sum(a * b for a, b in zip(e, m))) > 1e-9 * length * size:
                raise SceneError(f"moment.arm={_show(e)}: expected a direction perpendicular to moment={_show(m)} "
                                 "(then the couple's forces make exactly that moment)")
            object.__setattr__(self, "arm", e)

    @property
    def kind(self) -> str:
        """``"couple"`` (dead forces on an arm) or ``"joint"`` (a generalised force on the joint rotations)."""
        return "joint" if self.arm is None else "couple"

    def describe(self) -> str:
        arm = "" if self.arm is None else f" as a couple on arm {_show(self.arm)}"
        return f"moment {_show(self.moment)} N mm{arm}, s={self.at:g}"


@dataclass(frozen=True)
class Scene:
    """An actuator, its loads and the model settings; validated on creation, frozen after.

    Parameters
    ----------
    actuator : Actuator
        Geometry and material (Table 1 by default).
    pressure : float or None
        Pressure in MPa (>= 0). Give this or ``target_angle_deg``; when neither is given the
        target is 90 degrees (the paper's starting state, Section 4.4.2).
    target_angle_deg : float or None
        Find the pressure that bends the unloaded actuator (no payloads, no gravity) to this
        total angle, degrees (> 0): :func:`esba.analysis.stiffness.pressure_for_angle`.
    payloads : tuple of Payload
        Point payloads (any number, up to the model's limit); none means no payload terms.
    gravity : bool
        Include the actuator's weight (Eq. 15) with mass ``actuator.M`` and ``g``.
    g : float
        Gravitational acceleration, m/s^2 (> 0).
    gravity_direction : three numbers
        With ``gravity``, its direction in the base frame (x down, y the bending direction, z the
        layer's normal), kept as a unit vector; default :data:`DOWN` (+x, the paper's). Any other
        needs the 3-D model (the planar one's weight acts along +x only); without gravity it is unused.
    fibres : bool
        Include the fibre restraint (Eq. 18).
    segments : int
        Segment count n, 1 to :data:`esba.infra.checks.MAX_SEGMENTS` (256).
    variant : str
        ``"paper"`` (default) or ``"printed"`` (see :mod:`derive.effects`).
    moments : tuple of Moment
        Point moments or couples (3-D only: a scene with any needs ``esba solve --3d``).
    obstacles : tuple of Obstacle
        Rigid obstacles the actuator may touch (:mod:`esba.model.contact.obstacles`); with any, the
        equilibrium is the constrained one of :mod:`esba.statics.contact` (frictionless contact).
        None may reach into the actuator at rest.
    """

    actuator: Actuator = field(default_factory=Actuator)
    pressure: float | None = None
    target_angle_deg: float | None = None
    payloads: tuple[Payload, ...] = ()
    gravity: bool = False
    g: float = STANDARD_GRAVITY
    fibres: bool = True
    segments: int = 3
    variant: str = DEFAULT_VARIANT
    obstacles: tuple[Obstacle, ...] = ()
    moments: tuple[Moment, ...] = ()
    gravity_direction: tuple[float, float, float] = DOWN

    def __post_init__(self) -> None:
        if not isinstance(self.actuator, Actuator):
            raise SceneError(f"actuator={checks.quote(self.actuator)}: expected an Actuator")
        if self.pressure is not None and self.target_angle_deg is not None:
            raise SceneError(
                f"pressure={checks.quote(self.pressure)} and target_angle_deg={checks.quote(self.target_angle_deg)}: give one of the two, not both"
            )
        if self.pressure is not None:
            object.__setattr__(self, "pressure", check_pressure(self.pressure))
        else:
            target = check_target_angle(90.0 if self.target_angle_deg is None else self.target_angle_deg)
            object.__setattr__(self, "target_angle_deg", target)
        payloads = self.payloads
        if isinstance(payloads, Payload):
            payloads = (payloads,)
        if not isinstance(payloads, (tuple, list)) or not all(isinstance(p, Payload) for p in payloads):
            raise SceneError(f"payloads={checks.quote(self.payloads)}: expected a list of Payload")
        object.__setattr__(self, "payloads", tuple(payloads))
        moments = self.moments
        if isinstance(moments, Moment):
            moments = (moments,)
        if not isinstance(moments, (tuple, list)) or not all(isinstance(m, Moment) for m in moments):
            raise SceneError(f"moments={checks.quote(self.moments)}: expected a list of Moment")
        if len(moments) > MAX_PAYLOADS:
            raise SceneError(f"moments: {len(moments)} given; at most {MAX_PAYLOADS}")
        object.__setattr__(self, "moments", tuple(moments))
        object.__setattr__(self, "gravity", _flag("gravity", self.gravity))
        object.__setattr__(self, "fibres", _flag("fibres", self.fibres))
        object.__setattr__(self, "g", _positive("g", self.g))
        object.__setattr__(self, "gravity_direction", check_gravity_direction(self.gravity_direction))
        object.__setattr__(self, "segments", checks.segments(self.segments, SceneError))
        if self.variant not in VARIANTS:
            raise SceneError(f"variant={checks.quote(self.variant)}: allowed are {', '.join(VARIANTS)}")
        obstacles = self.obstacles
        if isinstance(obstacles, Obstacle):
            obstacles = (obstacles,)
        if not isinstance(obstacles, (tuple, list)) or not all(isinstance(o, Obstacle) for o in obstacles):
            raise SceneError(f"obstacles={checks.quote(self.obstacles)}: expected a list of obstacles (HalfPlane, Cylinder; Plane, Sphere, Cylinder3D in 3-D)")
        if len(obstacles) > MAX_OBSTACLES:
            raise SceneError(f"obstacles: {len(obstacles)} given; at most {MAX_OBSTACLES} (each adds 2 n constraints to every solve)")
        for k, o in enumerate(obstacles, start=1):
            o.check_at_rest(self.actuator.L, self.actuator.r1, f"obstacle #{k}")
        object.__setattr__(self, "obstacles", tuple(obstacles))
        try:
            self.effects  # noqa: B018 - the payload count limit lives in EffectSet
        except ValueError as exc:
            raise SceneError(f"payloads: {len(self.payloads)} given; {exc}") from None

    # -- what the scene implies --------------------------------------------------------------

    @property
    def effects(self) -> EffectSet:
        """Exactly the effects of this scene (no payload terms without payloads)."""
        return EffectSet(fibres=self.fibres, payloads=len(self.payloads), gravity=self.gravity)

    @property
    def needs_3d(self) -> bool:
        """True when a payload points out of the bending plane, the scene has a moment, an obstacle
        is a 3-D one or its weight acts along another direction than +x (only the 3-D model carries them)."""
        return (any(p.out_of_plane_deg != 0.0 for p in self.payloads) or bool(self.moments)
                or any(o.dimension == 3 for o in self.obstacles) or self.turned_gravity)

    @property
    def turned_gravity(self) -> bool:
        """True when the scene has gravity along another direction than +x (down, the planar model's)."""
        return self.gravity and self.gravity_direction != DOWN

    def down(self, direction=None) -> tuple[float, float, float]:
        """The direction of gravity for a 3-D solve: ``direction`` when given (a flag or an API
        keyword, which override the scene), else the scene's :attr:`gravity_direction`."""
        return self.gravity_direction if direction is None else tuple(float(x) for x in direction)  # type: ignore[return-value]

    def model(self) -> Model:
        """The generated model for this scene's segments, effects and variant (generated if missing).

        Raises SceneError when the scene needs the 3-D model (:attr:`needs_3d`).
        """
        for k, p in enumerate(self.payloads, start=1):
            if p.out_of_plane_deg != 0.0:
                raise SceneError(
                    f"payload {k}: out_of_plane_deg={p.out_of_plane_deg:g} points out of the bending plane, which the planar model "
                    "cannot carry: solve it in 3-D (esba solve --3d; esba.statics.spatial.solve_scene3d)"
                )
        if self.turned_gravity:
            raise SceneError(f"gravity_direction={_show(self.gravity_direction)}: the planar model's weight acts along +x "
                             "(down) only: solve it in 3-D (esba solve --3d; esba.statics.spatial.solve_scene3d)")
        if self.moments:
            raise SceneError(f"moment 1: {self.moments[0].describe()}: the planar model has no moment term: solve it in 3-D "
                             "(esba solve --3d; esba.statics.spatial.solve_scene3d)")
        for k, o in enumerate(self.obstacles, start=1):
            if o.dimension == 3:
                raise SceneError(f"obstacle #{k}: {o.describe()} is a 3-D obstacle, which the planar model cannot carry: solve it in 3-D (esba solve --3d; esba.statics.contact.spatial.solve_contact3d)")
        return load_model(self.segments, self.effects, self.variant)

    def parameters(self, pressure: float, load_factor: float = 1.0) -> dict[str, float]:
        """Model parameter values (radians) at ``pressure`` with payloads and weight scaled by ``load_factor``.

        Every parameter any model may need is present; :meth:`Model.param_vector` picks its own.
        """
        values = self.actuator.parameters()
        values["P"] = float(pressure)
        values["g"] = self.g * load_factor
        for k, p in enumerate(self.payloads, start=1):
            values[f"F{k}"] = p.force * load_factor
            values[f"Omega{k}"] = math.radians(p.angle_deg)
            values[f"s{k}"] = p.at
            values[f"Beta{k}"] = math.radians(p.out_of_plane_deg)
        joints = [m for m in self.moments if m.kind == "joint"]
        couples = [m for m in self.moments if m.kind == "couple"]
        for k, m in enumerate(joints, start=1):
            values.update({f"mx{k}": m.moment[0] * load_factor, f"my{k}": m.moment[1] * load_factor,
                           f"mz{k}": m.moment[2] * load_factor, f"sm{k}": m.at})
        for k, m in enumerate(couples, start=1):
            values.update({f"cx{k}": m.moment[0] * load_factor, f"cy{k}": m.moment[1] * load_factor,
                           f"cz{k}": m.moment[2] * load_factor, f"ax{k}": m.arm[0], f"ay{k}": m.arm[1], f"az{k}": m.arm[2],
                           f"sc{k}": m.at})
        return values

    # -- derived scenes ----------------------------------------------------------------------

    def replace(self, **changes: Any) -> Scene:
        """A new validated scene with some fields changed (``actuator`` fields may be given by name).

        Setting ``pressure`` clears ``target_angle_deg`` and the other way round, unless both are given.
        """
        act_fields = {f.name for f in dataclasses.fields(Actuator)}
        act_changes = {k: changes.pop(k) for k in list(changes) if k in act_fields}
        if act_changes:
            changes["actuator"] = dataclasses.replace(changes.get("actuator", self.actuator), **act_changes)
        if "pressure" in changes and "target_angle_deg" not in changes and changes["pressure"] is not None:
            changes["target_angle_deg"] = None
        if "target_angle_deg" in changes and "pressure" not in changes and changes["target_angle_deg"] is not None:
            changes["pressure"] = None
        unknown = set(changes) - {f.name for f in dataclasses.fields(Scene)}
        if unknown:
            allowed = ", ".join(sorted({f.name for f in dataclasses.fields(Scene)} | act_fields))
            raise SceneError(f"unknown scene field(s) {', '.join(sorted(unknown))}: allowed are {allowed}")
        return dataclasses.replace(self, **changes)

    def unloaded(self) -> Scene:
        """The same actuator and pressure setting without payloads, moments and gravity."""
        return dataclasses.replace(self, payloads=(), moments=(), gravity=False)

    def describe(self) -> str:
        """A one-line summary, e.g. for a table header."""
        a = self.actuator
        drive = f"P={self.pressure:g} MPa" if self.pressure is not None else f"unloaded angle {self.target_angle_deg:g} deg"
        loads = "; ".join(f"{p.force:g} N at {p.angle_deg:g} deg" + (f" ({p.out_of_plane_deg:g} deg out of plane)" if p.out_of_plane_deg else "") + f", s={p.at:g}" for p in self.payloads) or "no payload"
        extra = (", gravity" + (f" along {_show(self.gravity_direction)}" if self.turned_gravity else "") if self.gravity else "")
        extra += "" if self.fibres else ", no fibres"
        extra += "".join(f"; {m.describe()}" for m in self.moments)
        extra += "".join(f"; {o.describe()}" for o in self.obstacles)
        return (
            f"L={a.L:g} r1={a.r1:g} r2={a.r2:g} d={a.d:g} rho={a.rho_deg:g} deg E={a.E:g} MPa; "
            f"{drive}; {loads}; n={self.segments}, {self.variant}{extra}"
        )


#: The main job (``esba solve`` without arguments): Table 1 at its 90 degree pressure, a 2 N
#: horizontal tip payload, n = 3 (Table 2 of the paper).
MAIN_JOB = Scene(target_angle_deg=90.0, payloads=(Payload(2.0, 90.0, 1.0),), segments=3)


# ---------------------------------------------------------------------------------------------
# TOML

#: ``uncertainty`` (standard deviations of the parameters) is read by :func:`esba.calibration.uncertainty.load_sigmas`.
_TOP_KEYS = {"segments", "variant", "gravity", "fibres", "actuator", "loads", "payloads", "moments", "obstacles", "uncertainty"}
_LOAD_KEYS = {"pressure", "target_angle_deg", "g", "gravity_direction"}
_PAYLOAD_KEYS = {"force", "angle_deg", "at", "out_of_plane_deg"}
_MOMENT_KEYS = {"moment", "at", "arm"}


def _check_keys(where: str, table: Any, allowed: set[str]) -> Mapping[str, Any]:
    if not isinstance(table, Mapping):
        raise SceneError(f"{where}: expected a table, got {checks.quote(table)}")
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise SceneError(f"{where}: unknown key(s) {checks.some(unknown)}; allowed are {', '.join(sorted(allowed))}")
    return table


def scene_from_dict(data: Mapping[str, Any]) -> Scene:
    """Build a validated :class:`Scene` from the nested mapping of a scene file.

    Examples
    --------
    >>> s = scene_from_dict({"segments": 2, "payloads": [{"force": 1.0, "angle_deg": 0}]})
    >>> s.segments, s.payloads[0].angle_deg, s.target_angle_deg
    (2, 0.0, 90.0)
    >>> scene_from_dict({"actuator": {"R1": 8}})
    Traceback (most recent call last):
    ...
    esba.model.scene.SceneError: [actuator]: unknown key(s) R1; allowed are E, L, M, d, r1, r2, rho_deg
    """
    data = _check_keys("scene", data, _TOP_KEYS)
    act_keys = {f.name for f in dataclasses.fields(Actuator)}
    actuator = Actuator(**_check_keys("[actuator]", data.get("actuator", {}), act_keys))
    loads = dict(_check_keys("[loads]", data.get("loads", {}), _LOAD_KEYS))
    if "gravity_direction" in loads:
        loads["gravity_direction"] = check_gravity_direction(loads["gravity_direction"], "[loads] gravity_direction")
        if loads["gravity_direction"] != DOWN and data.get("gravity") is not True:
            raise SceneError(f"[loads] gravity_direction={_show(loads['gravity_direction'])}: turns the weight, and the scene has none: "
                             "add gravity = true (or leave gravity_direction out)")
    raw_payloads = data.get("payloads", [])
    if not isinstance(raw_payloads, list):
        raise SceneError(f"payloads={checks.quote(raw_payloads)}: expected an array of tables [[payloads]]")
    payloads = []
    for k, item in enumerate(raw_payloads, start=1):
        item = _check_keys(f"[[payloads]] #{k}", item, _PAYLOAD_KEYS)
        if "force" not in item:
            raise SceneError(f"[[payloads]] #{k}: missing key force (N)")
        payloads.append(Payload(**item))
    raw_moments = data.get("moments", [])
    if not isinstance(raw_moments, list):
        raise SceneError(f"moments={checks.quote(raw_moments)}: expected an array of tables [[moments]]")
    moments = []
    for k, item in enumerate(raw_moments, start=1):
        item = _check_keys(f"[[moments]] #{k}", item, _MOMENT_KEYS)
        if "moment" not in item:
            raise SceneError(f"[[moments]] #{k}: missing key moment ([mx, my, mz], N mm)")
        try:
            moments.append(Moment(**item))
        except SceneError as exc:
            raise SceneError(f"[[moments]] #{k}: {exc}") from None
    raw_obstacles = data.get("obstacles", [])
    if not isinstance(raw_obstacles, list):
        raise SceneError(f"obstacles={checks.quote(raw_obstacles)}: expected an array of tables [[obstacles]]")
    obstacles = tuple(obstacle_from_dict(f"[[obstacles]] #{k}", item) for k, item in enumerate(raw_obstacles, start=1))
    kwargs: dict[str, Any] = {k: data[k] for k in ("segments", "variant", "gravity", "fibres") if k in data}
    kwargs.update(loads)
    return Scene(actuator=actuator, payloads=tuple(payloads), moments=tuple(moments), obstacles=obstacles, **kwargs)


def load_scene(path: str | Path) -> Scene:
    """Read and validate a TOML scene file.

    Raises
    ------
    SceneError
        when the file is missing, is not valid TOML (with the line), or holds a bad value.
    """
    if isinstance(path, bytes) or not isinstance(path, (str, Path)) or not str(path).strip():
        raise SceneError(f"scene file {checks.quote(path)}: expected the path of a TOML scene file")
    path = Path(path)
    data = inputs.load_toml(path, "scene file", SceneError)  # a regular file of bounded size, BOM or not
    try:
        return scene_from_dict(data)
    except (SceneError, ObstacleError) as exc:
        raise SceneError(f"scene file {str(path)!r}: {exc}") from None
    except TypeError as exc:  # pragma: no cover - guarded by the key checks
        raise SceneError(f"scene file {str(path)!r}: {exc}") from None

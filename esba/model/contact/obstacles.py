"""Rigid obstacles in the plane of the actuator: a flat probe or wall (a half-plane) and a cylinder (a disc).

Coordinates are the base frame's (x down along the unbent actuator, y horizontal, towards the side it
bends to), mm. Each obstacle has a signed distance: positive outside, zero on its surface, negative
inside; its gradient in the point is the unit normal out of the obstacle, the direction in which it
pushes what touches it (frictionless).

The actuator touches an obstacle with one of its two surfaces in the bending plane (the ``side``):

* ``inner``: the inextensible layer, the curve the model bends (the chain of arcs of Eq. 1-2), on
  the inside of the bend (the side of +y at rest);
* ``outer``: the dorsal surface, the layer offset by the actuator's diameter 2 r1 to the outside of
  the bend (the cross-section is a disc of radius r1 standing on the layer, Section 3.2.2);
* ``auto`` (default): ``inner`` for an obstacle on the bending side of the layer at rest, else
  ``outer``; a scene says which it chose (:meth:`Obstacle.resolved_side`).

The end faces (base and tip caps) are not surfaces of contact.

A half-plane's direction ``normal_deg`` is measured as a payload's ``angle_deg`` (Omega from the
vertical): its face looks along (cos Omega, -sin Omega), so a probe with ``normal_deg = 90`` on the
bending side pushes exactly as a payload at 90 degrees does.

Examples
--------
>>> probe = HalfPlane(at=(135.0, 0.0))           # the blocked-force probe: the face y = 0, bending side
>>> float(probe.distance((100.0, -2.0))), probe.resolved_side()
(2.0, 'inner')
>>> Cylinder(centre=(100.0, 40.0), radius=-1.0)
Traceback (most recent call last):
...
esba.model.contact.obstacles.ObstacleError: cylinder.radius=-1: expected a radius > 0 mm
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from esba.infra import checks
from esba.infra.errors import InputError

__all__ = ["Obstacle", "HalfPlane", "Cylinder", "ObstacleError", "obstacle_from_dict", "OBSTACLE_KINDS", "SIDES", "MAX_OBSTACLES"]

#: The surfaces of the actuator an obstacle may touch (see the module's docstring).
SIDES = ("auto", "inner", "outer")

#: The most obstacles a scene may hold: each adds 2 n constraints to every solve.
MAX_OBSTACLES = 8

#: How far (mm) an obstacle may reach into the actuator at rest and still count as touching it
#: (round-off of the coordinates a user types).
REST_TOLERANCE_MM = 1e-9

#: The largest coordinate or radius accepted, mm (a kilometre: far beyond any actuator; larger
#: values lose the digits of a gap of a micrometre).
MAX_COORDINATE_MM = 1e6


class ObstacleError(InputError):
    """An obstacle that is not allowed: the message names the field, the value and what is allowed."""


def _coordinate(where: str, value: Any) -> float:
    v = checks.finite(where, value, ObstacleError)
    if abs(v) > MAX_COORDINATE_MM:
        raise ObstacleError(f"{where}={v:g}: expected |value| <= {MAX_COORDINATE_MM:g} mm")
    return v


def _point(where: str, value: Any) -> tuple[float, float]:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise ObstacleError(f"{where}={checks.quote(value)}: expected a point [x, y] in mm")
    return (_coordinate(f"{where}[0]", value[0]), _coordinate(f"{where}[1]", value[1]))


def _side(where: str, value: Any) -> str:
    if value not in SIDES:
        raise ObstacleError(f"{where}={checks.quote(value)}: allowed are {', '.join(SIDES)}")
    return value


class Obstacle:
    """What every obstacle answers (planar today; a 3-D obstacle answers the same in three coordinates).

    Attributes ``kind`` (its name in scene files), ``dimension`` (2) and ``side``.
    """

    kind: str = ""
    dimension: int = 2
    side: str = "auto"

    def parameters(self) -> tuple[float, ...]:  # pragma: no cover - abstract
        """The numbers of :meth:`symbolic_distance`, in its order."""
        raise NotImplementedError

    @staticmethod
    def symbolic_distance(q: Any, params: Any) -> Any:  # pragma: no cover - abstract
        """The signed distance of the point ``q`` for parameters ``params`` (CasADi or NumPy)."""
        raise NotImplementedError

    def distance(self, q: Any) -> Any:
        """Signed distance of points ``q`` (shape (..., 2)), mm: > 0 outside."""
        q = np.asarray(q, dtype=float)
        return self._distance(q)

    def derivatives(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover - abstract
        """Distance, gradient (..., 2) and Hessian (..., 2, 2) in the point, for points (..., 2)."""
        raise NotImplementedError

    def resolved_side(self) -> str:  # pragma: no cover - abstract
        """``inner`` or ``outer``: :attr:`side`, or the one ``auto`` chooses."""
        raise NotImplementedError

    def rest_distance(self, L: float, r1: float) -> float:  # pragma: no cover - abstract
        """The signed distance of the actuator's body at rest (the band 0 <= x <= L, -2 r1 <= y <= 0)."""
        raise NotImplementedError

    def check_at_rest(self, L: float, r1: float, where: str) -> None:
        """Refuse an obstacle that reaches into the actuator at rest (touching it is allowed)."""
        d = self.rest_distance(L, r1)
        if d < -REST_TOLERANCE_MM:
            raise ObstacleError(
                f"{where}: {self.describe()} reaches {-d:.4g} mm into the actuator at rest "
                f"(the band 0 <= x <= L = {L:g}, -2 r1 = {-2 * r1:g} <= y <= 0 mm): move it out; touching is allowed"
            )

    def describe(self) -> str:  # pragma: no cover - abstract
        raise NotImplementedError

    def to_dict(self) -> dict[str, Any]:  # pragma: no cover - abstract
        raise NotImplementedError


def _rest_band(L: float, r1: float) -> np.ndarray:
    return np.array([[0.0, 0.0], [L, 0.0], [L, -2.0 * r1], [0.0, -2.0 * r1]])


@dataclass(frozen=True)
class HalfPlane(Obstacle):
    """A flat probe or wall: every point on the far side of a line.

    Parameters
    ----------
    at : (float, float)
        A point on its face, mm, with x >= 0 (not behind the base).
    normal_deg : float
        The direction its face looks (out of the obstacle), degrees, as a payload's ``angle_deg``:
        (cos Omega, -sin Omega). 90 (default): the face looks towards -y, the obstacle on the bending side.
    side : str
        The surface it touches: ``auto``, ``inner`` (the layer) or ``outer`` (the dorsal surface).

    Examples
    --------
    >>> HalfPlane(at=(-5.0, 0.0))
    Traceback (most recent call last):
    ...
    esba.model.contact.obstacles.ObstacleError: half-plane.at=[-5, 0]: the face is behind the base (x < 0, where the actuator is clamped): expected x >= 0 mm
    """

    at: tuple[float, float] = (0.0, 0.0)
    normal_deg: float = 90.0
    side: str = "auto"
    kind = "half-plane"

    def __post_init__(self) -> None:
        at = _point("half-plane.at", self.at)
        if at[0] < 0.0:
            raise ObstacleError(
                f"half-plane.at=[{at[0]:g}, {at[1]:g}]: the face is behind the base (x < 0, where the actuator is clamped): expected x >= 0 mm"
            )
        object.__setattr__(self, "at", at)
        object.__setattr__(self, "normal_deg", checks.finite("half-plane.normal_deg", self.normal_deg, ObstacleError))
        object.__setattr__(self, "side", _side("half-plane.side", self.side))

    @property
    def normal(self) -> np.ndarray:
        """The unit normal out of the obstacle, (cos Omega, -sin Omega)."""
        quarter = self.normal_deg / 90.0
        if quarter.is_integer():  # exact at the axes (cos 90 deg is 6e-17 in floating point)
            return np.array([(1.0, 0.0, -1.0, 0.0)[int(quarter) % 4], -(0.0, 1.0, 0.0, -1.0)[int(quarter) % 4]])
        w = math.radians(self.normal_deg)
        return np.array([math.cos(w), -math.sin(w)])

    def parameters(self) -> tuple[float, ...]:
        nx, ny = self.normal
        return (self.at[0], self.at[1], float(nx), float(ny))

    @staticmethod
    def symbolic_distance(q: Any, params: Any) -> Any:
        return params[2] * (q[0] - params[0]) + params[3] * (q[1] - params[1])

    def _distance(self, q: np.ndarray) -> np.ndarray:
        return (q - np.asarray(self.at)) @ self.normal

    def derivatives(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q = np.asarray(q, dtype=float)
        d = self._distance(q)
        grad = np.broadcast_to(self.normal, q.shape).copy()
        return d, grad, np.zeros(q.shape + (2,))

    def resolved_side(self) -> str:
        if self.side != "auto":
            return self.side
        return "inner" if self.normal[1] < 0.0 else "outer"

    def rest_distance(self, L: float, r1: float) -> float:
        return float(np.min(self._distance(_rest_band(L, r1))))

    def describe(self) -> str:
        return f"half-plane through [{self.at[0]:g}, {self.at[1]:g}] facing {self.normal_deg:g} deg"

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "at": list(self.at), "normal_deg": self.normal_deg, "side": self.side, "touches": self.resolved_side()}


@dataclass(frozen=True)
class Cylinder(Obstacle):
    """A cylinder across the bending plane (a disc in the plane), e.g. an object a finger closes on.

    Parameters
    ----------
    centre : (float, float)
        Its axis's point in the plane, mm.
    radius : float
        Its radius, mm (> 0).
    side : str
        The surface it touches: ``auto``, ``inner`` (the layer) or ``outer`` (the dorsal surface).
    """

    centre: tuple[float, float] = (0.0, 0.0)
    radius: float = 10.0
    side: str = "auto"
    kind = "cylinder"

    def __post_init__(self) -> None:
        object.__setattr__(self, "centre", _point("cylinder.centre", self.centre))
        r = _coordinate("cylinder.radius", self.radius)
        if r <= 0:
            raise ObstacleError(f"cylinder.radius={r:g}: expected a radius > 0 mm")
        object.__setattr__(self, "radius", r)
        object.__setattr__(self, "side", _side("cylinder.side", self.side))

    def parameters(self) -> tuple[float, ...]:
        return (self.centre[0], self.centre[1], self.radius)

    @staticmethod
    def symbolic_distance(q: Any, params: Any) -> Any:
        dx, dy = q[0] - params[0], q[1] - params[1]
        return (dx * dx + dy * dy) ** 0.5 - params[2]

    def _distance(self, q: np.ndarray) -> np.ndarray:
        return np.linalg.norm(q - np.asarray(self.centre), axis=-1) - self.radius

    def derivatives(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q = np.asarray(q, dtype=float)
        rel = q - np.asarray(self.centre)
        rho = np.linalg.norm(rel, axis=-1)
        u = rel / rho[..., None]
        hess = (np.eye(2) - u[..., :, None] * u[..., None, :]) / rho[..., None, None]
        return rho - self.radius, u, hess

    def resolved_side(self) -> str:
        if self.side != "auto":
            return self.side
        return "inner" if self.centre[1] > 0.0 else "outer"

    def rest_distance(self, L: float, r1: float) -> float:
        c = np.asarray(self.centre)
        nearest = np.array([min(max(c[0], 0.0), L), min(max(c[1], -2.0 * r1), 0.0)])
        if 0.0 <= c[0] <= L and -2.0 * r1 <= c[1] <= 0.0:  # the axis inside the band: as deep as it is from the band's edge, plus R
            return -self.radius - float(min(c[0], L - c[0], -c[1], c[1] + 2.0 * r1))
        return float(np.linalg.norm(c - nearest)) - self.radius

    def describe(self) -> str:
        return f"cylinder of radius {self.radius:g} at [{self.centre[0]:g}, {self.centre[1]:g}]"

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "centre": list(self.centre), "radius": self.radius, "side": self.side, "touches": self.resolved_side()}


#: The obstacles a scene file may name in ``[[obstacles]] kind = ...``, and their keys.
OBSTACLE_KINDS: dict[str, tuple[type, frozenset]] = {
    "half-plane": (HalfPlane, frozenset({"kind", "at", "normal_deg", "side"})),
    "cylinder": (Cylinder, frozenset({"kind", "centre", "radius", "side"})),
}


def obstacle_from_dict(where: str, item: Any) -> Obstacle:
    """An obstacle from a scene file's ``[[obstacles]]`` table.

    >>> obstacle_from_dict("[[obstacles]] #1", {"kind": "cylinder", "centre": [90, 30], "radius": 12})
    Cylinder(centre=(90.0, 30.0), radius=12.0, side='auto')
    >>> obstacle_from_dict("[[obstacles]] #1", {"kind": "sphere"})
    Traceback (most recent call last):
    ...
    esba.model.contact.obstacles.ObstacleError: [[obstacles]] #1: kind='sphere': allowed are half-plane, cylinder (a sphere, a plane and a cylinder of any axis come with the 3-D model)
    """
    if not isinstance(item, Mapping):
        raise ObstacleError(f"{where}: expected a table, got {checks.quote(item)}")
    kind = item.get("kind")
    if kind not in OBSTACLE_KINDS:
        raise ObstacleError(
            f"{where}: kind={checks.quote(kind)}: allowed are {', '.join(OBSTACLE_KINDS)} "
            "(a sphere, a plane and a cylinder of any axis come with the 3-D model)"
        )
    cls, keys = OBSTACLE_KINDS[kind]
    unknown = sorted(set(item) - keys)
    if unknown:
        raise ObstacleError(f"{where}: unknown key(s) {checks.some(unknown)} for a {kind}; allowed are {', '.join(sorted(keys))}")
    try:
        return cls(**{k: v for k, v in item.items() if k != "kind"})
    except ObstacleError as exc:
        raise ObstacleError(f"{where}: {exc}") from None

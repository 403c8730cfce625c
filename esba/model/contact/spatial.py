"""Obstacles in 3-D (a plane of any normal, a sphere, a cylinder of any axis) and the lines of the
actuator's surface that touch them, along whole helical segments of the spatial model.

Coordinates are the base frame's (x down along the unbent actuator, y towards the side it bends to,
z sideways), mm. Each obstacle has a signed distance (> 0 outside, 0 on its surface), whose gradient
in the point is the unit normal out of the obstacle: the direction in which it pushes what touches it
(frictionless).

**Where the body touches.** The spatial model bends the inextensible layer: segment i is the piece
of helix exp(sigma hat(Xi_i)), Xi_i = [L/n, 0, 0, tau_i, psi_i, theta_i], sigma in [0, 1]
(:func:`esba.model.spatial.segment_pose`). The cross-section is a disc of radius r1 standing on the
layer (its axis r1 off the layer along the section's -y). An obstacle touches

==========  =================================  ==========================================
side        the curve, offset from the layer   at rest
            in the section's frame (y, z)
==========  =================================  ==========================================
``tube``    (-r1, 0), the gap less r1          the whole body: every point of the tube
``inner``   (0, 0)                             the layer itself, y = 0 (the bending side)
``outer``   (-2 r1, 0)                         the dorsal line, y = -2 r1
``+z``      (-r1, +r1)                         the side line at z = +r1
``-z``      (-r1, -r1)                         the side line at z = -r1
==========  =================================  ==========================================

``tube`` is the body: the tube of radius r1 about its axis is the union of the balls of radius r1
about the axis's points (while the bend's radius exceeds r1), so its gap to a plane, a sphere or a
cylinder is the axis's gap less r1, wherever around the section it touches; its ends are rounded (a
half ball beyond each end face). The lines are material lines of the surface (a twist turns them
about the tangent), as in the plane (:mod:`.obstacles`): ``inner`` and ``outer`` are the planar
model's surfaces. ``auto`` (default): ``tube`` for a 3-D obstacle; a planar obstacle in a 3-D solve
keeps its planar side, so that it means what it means in the plane. The end faces of a line are not
surfaces of contact.

A planar obstacle in a 3-D solve is its extrusion across the bending plane (:func:`lift`): a
half-plane is a plane whose normal lies in the bending plane, a planar cylinder one whose axis is z.
So a planar scene means the same in 3-D.

Scene files (``[[obstacles]]``)::

    kind = "plane";    at = [x, y, z];     normal = [nx, ny, nz]            # the half-space behind it
    kind = "sphere";   centre = [x, y, z]; radius = R
    kind = "cylinder"; centre = [x, y, z]; axis = [ax, ay, az]; radius = R  # infinitely long
    side = "auto"      # or tube, inner, outer, +z, -z

(a ``cylinder`` with a two-number centre and no axis is the planar one, as before).

Examples
--------
>>> Sphere(centre=(100.0, 0.0, 30.0), radius=10.0).distance(np.array([100.0, 0.0, 0.0]))
array(20.)
>>> Plane(at=(0, 0, 20), normal=(0, 0, 0))
Traceback (most recent call last):
...
esba.model.contact.obstacles.ObstacleError: plane.normal=[0, 0, 0]: a zero vector has no direction; expected three numbers, not all 0
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import casadi as ca
import numpy as np

from esba.infra import checks

from .obstacles import REST_TOLERANCE_MM, Cylinder, HalfPlane, Obstacle, ObstacleError, _coordinate

__all__ = ["Plane", "Sphere", "Cylinder3D", "SIDES_3D", "SPATIAL_KINDS", "lift", "side_offset", "side_inflate", "spatial_obstacle_from_dict", "segment_points", "symbolic_line"]

#: The lines of the surface a 3-D obstacle may touch (see the module's docstring).
SIDES_3D = ("auto", "tube", "inner", "outer", "+z", "-z")


def side_offset(side: str, r1: float) -> np.ndarray:
    """The offset of a touching curve from the layer in the section's frame (y, z), mm."""
    return {"tube": np.array([-r1, 0.0]), "inner": np.array([0.0, 0.0]), "outer": np.array([-2.0 * r1, 0.0]),
            "+z": np.array([-r1, r1]), "-z": np.array([-r1, -r1])}[side]


def side_inflate(side: str, r1: float) -> float:
    """What the gap of the touching curve loses: r1 for the tube (the axis's gap less r1), else 0."""
    return float(r1) if side == "tube" else 0.0


def _vector(where: str, value: Any) -> np.ndarray:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 3:
        raise ObstacleError(f"{where}={checks.quote(value)}: expected three numbers [x, y, z] in mm")
    return np.array([_coordinate(f"{where}[{i}]", v) for i, v in enumerate(value)])


def _direction(where: str, value: Any) -> np.ndarray:
    v = _vector(where, value)
    size = float(np.linalg.norm(v))
    if size == 0.0:
        raise ObstacleError(f"{where}=[{v[0]:g}, {v[1]:g}, {v[2]:g}]: a zero vector has no direction; expected three numbers, not all 0")
    return v / size


def _radius(where: str, value: Any) -> float:
    r = _coordinate(where, value)
    if r <= 0:
        raise ObstacleError(f"{where}={r:g}: expected a radius > 0 mm")
    return r


def _side3(where: str, value: Any) -> str:
    if value not in SIDES_3D:
        raise ObstacleError(f"{where}={checks.quote(value)}: allowed are {', '.join(SIDES_3D)}")
    return value


def _fmt(v) -> str:
    return "[" + ", ".join(f"{float(x):g}" for x in v) + "]"


class SpatialObstacle(Obstacle):
    """What a 3-D obstacle answers (the planar protocol in three coordinates)."""

    dimension = 3

    def _distance(self, q: np.ndarray) -> np.ndarray:
        return np.asarray(self.symbolic_distance_np(q))

    def symbolic_distance_np(self, q: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def derivatives(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Distance and gradient (the unit normal out of the obstacle) at points (..., 3); no Hessian."""
        q = np.asarray(q, dtype=float)
        return self._distance(q), self.normal_at(q), np.zeros(q.shape + (3,))

    def normal_at(self, q: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _body_distance(self, L: float, r1: float) -> float:  # pragma: no cover - abstract
        raise NotImplementedError

    def resolved_side(self, L: float = 0.0, r1: float = 0.0) -> str:
        """The curve it touches: :attr:`side`, or ``tube`` for ``auto``."""
        return "tube" if self.side == "auto" else self.side

    def rest_distance(self, L: float, r1: float) -> float:
        """The signed distance of the actuator's body at rest: the solid cylinder 0 <= x <= L,
        (y + r1)^2 + z^2 <= r1^2 (the disc of radius r1 standing on the layer); for the ``tube`` side,
        with its rounded ends (the axis's segment from (0, -r1, 0) to (L, -r1, 0), less r1)."""
        if self.resolved_side() == "tube":
            return self._axis_distance(L, r1) - r1
        return self._body_distance(L, r1)

    def _axis_distance(self, L: float, r1: float) -> float:
        """The least signed distance of the rest axis's segment (a convex function of x along it)."""
        from scipy.optimize import minimize_scalar  # imported when used: a scene loads without scipy.optimize

        f = lambda x: float(self._distance(np.array([x, -r1, 0.0])))  # noqa: E731
        xs = np.linspace(0.0, L, 65)
        i = int(np.argmin([f(x) for x in xs]))
        res = minimize_scalar(f, bounds=(xs[max(i - 1, 0)], xs[min(i + 1, xs.size - 1)]), method="bounded", options={"xatol": 1e-12})
        return float(min(f(xs[i]), res.fun))

    def check_at_rest(self, L: float, r1: float, where: str) -> None:
        d = self.rest_distance(L, r1)
        if d < -REST_TOLERANCE_MM:
            body = ("the tube of radius r1 = {r1:g} mm about (x, -r1, 0), 0 <= x <= L = {L:g}, with rounded ends" if self.resolved_side() == "tube"
                    else "the cylinder 0 <= x <= L = {L:g}, (y + r1)^2 + z^2 <= r1^2 = {r1:g}^2 mm").format(r1=r1, L=L)
            raise ObstacleError(f"{where}: {self.describe()} reaches {-d:.4g} mm into the actuator at rest ({body}): move it out; touching is allowed")


def _closest_in_body(f, grad, L: float, r1: float, start: np.ndarray) -> tuple[float, np.ndarray]:
    """The least of a convex function over the rest body (the solid cylinder): SLSQP from ``start``."""
    from scipy.optimize import minimize  # imported when used: a scene loads without scipy.optimize

    cons = [{"type": "ineq", "fun": lambda x: r1 * r1 - (x[1] + r1) ** 2 - x[2] ** 2, "jac": lambda x: np.array([0.0, -2 * (x[1] + r1), -2 * x[2]])}]
    res = minimize(f, start, jac=grad, bounds=[(0.0, L), (-2 * r1, 0.0), (-r1, r1)], constraints=cons, method="SLSQP", options={"ftol": 1e-14, "maxiter": 200})
    return float(res.fun), res.x


@dataclass(frozen=True)
class Plane(SpatialObstacle):
    """A flat wall or probe of any orientation: the half-space behind the plane through ``at``.

    Parameters
    ----------
    at : (float, float, float)
        A point on its face, mm, with x >= 0 (not behind the base), as the planar half-plane's.
    normal : (float, float, float)
        The direction its face looks (out of the obstacle); any length but 0 (made a unit vector).
    side : str
        The line of the surface it touches: ``auto``, ``inner``, ``outer``, ``+z``, ``-z``.
    """

    at: tuple = (0.0, 0.0, 0.0)
    normal: tuple = (0.0, 0.0, -1.0)
    side: str = "auto"
    kind = "plane"

    def __post_init__(self) -> None:
        at = _vector("plane.at", self.at)
        if at[0] < 0.0:
            raise ObstacleError(
                f"plane.at={_fmt(at)}: the point is behind the base (x < 0, where the actuator is clamped): "
                "expected a point of its face with x >= 0 mm"
            )
        object.__setattr__(self, "at", tuple(float(v) for v in at))
        object.__setattr__(self, "normal", tuple(float(v) for v in _direction("plane.normal", self.normal)))
        object.__setattr__(self, "side", _side3("plane.side", self.side))

    def parameters(self) -> tuple[float, ...]:
        return (*self.at, *self.normal)

    @staticmethod
    def symbolic_distance(q: Any, params: Any) -> Any:
        return params[3] * (q[0] - params[0]) + params[4] * (q[1] - params[1]) + params[5] * (q[2] - params[2])

    def symbolic_distance_np(self, q: np.ndarray) -> np.ndarray:
        return (q - np.asarray(self.at)) @ np.asarray(self.normal)

    def normal_at(self, q: np.ndarray) -> np.ndarray:
        return np.broadcast_to(np.asarray(self.normal), np.shape(q)).copy()

    def _body_distance(self, L: float, r1: float) -> float:
        nv = np.asarray(self.normal)
        radial = r1 * math.hypot(nv[1], nv[2])
        ends = np.array([[0.0, -r1, 0.0], [L, -r1, 0.0]])
        return float(np.min(self.symbolic_distance_np(ends))) - radial

    def describe(self) -> str:
        return f"plane through {_fmt(self.at)} facing {_fmt(np.round(self.normal, 6))}"

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "at": list(self.at), "normal": list(self.normal), "side": self.side}


@dataclass(frozen=True)
class Sphere(SpatialObstacle):
    """A ball of ``radius`` (mm, > 0) about ``centre`` (mm), e.g. an object a finger closes on."""

    centre: tuple = (0.0, 0.0, 0.0)
    radius: float = 10.0
    side: str = "auto"
    kind = "sphere"

    def __post_init__(self) -> None:
        object.__setattr__(self, "centre", tuple(float(v) for v in _vector("sphere.centre", self.centre)))
        object.__setattr__(self, "radius", _radius("sphere.radius", self.radius))
        object.__setattr__(self, "side", _side3("sphere.side", self.side))

    def parameters(self) -> tuple[float, ...]:
        return (*self.centre, self.radius)

    @staticmethod
    def symbolic_distance(q: Any, params: Any) -> Any:
        dx, dy, dz = q[0] - params[0], q[1] - params[1], q[2] - params[2]
        return (dx * dx + dy * dy + dz * dz) ** 0.5 - params[3]

    def symbolic_distance_np(self, q: np.ndarray) -> np.ndarray:
        return np.linalg.norm(q - np.asarray(self.centre), axis=-1) - self.radius

    def normal_at(self, q: np.ndarray) -> np.ndarray:
        rel = q - np.asarray(self.centre)
        return rel / np.linalg.norm(rel, axis=-1)[..., None]

    def _body_distance(self, L: float, r1: float) -> float:
        c = np.asarray(self.centre)
        rho = math.hypot(c[1] + r1, c[2])
        axial = max(0.0, -c[0], c[0] - L)
        radial = max(0.0, rho - r1)
        if axial == 0.0 and radial == 0.0:  # the centre inside the body: as deep as it is from the surface, plus R
            return -self.radius - float(min(r1 - rho, c[0], L - c[0]))
        return math.hypot(axial, radial) - self.radius

    def describe(self) -> str:
        return f"sphere of radius {self.radius:g} at {_fmt(self.centre)}"

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "centre": list(self.centre), "radius": self.radius, "side": self.side}


@dataclass(frozen=True)
class Cylinder3D(SpatialObstacle):
    """An infinitely long cylinder of ``radius`` (mm, > 0) about the line through ``centre`` along
    ``axis`` (any length but 0). ``axis = (0, 0, 1)`` is the planar :class:`~.obstacles.Cylinder`."""

    centre: tuple = (0.0, 0.0, 0.0)
    axis: tuple = (0.0, 0.0, 1.0)
    radius: float = 10.0
    side: str = "auto"
    kind = "cylinder"

    def __post_init__(self) -> None:
        object.__setattr__(self, "centre", tuple(float(v) for v in _vector("cylinder.centre", self.centre)))
        object.__setattr__(self, "axis", tuple(float(v) for v in _direction("cylinder.axis", self.axis)))
        object.__setattr__(self, "radius", _radius("cylinder.radius", self.radius))
        object.__setattr__(self, "side", _side3("cylinder.side", self.side))

    def parameters(self) -> tuple[float, ...]:
        return (*self.centre, *self.axis, self.radius)

    @staticmethod
    def symbolic_distance(q: Any, params: Any) -> Any:
        d = [q[i] - params[i] for i in range(3)]
        along = d[0] * params[3] + d[1] * params[4] + d[2] * params[5]
        r = [d[i] - along * params[3 + i] for i in range(3)]
        return (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) ** 0.5 - params[6]

    def _radial(self, q: np.ndarray) -> np.ndarray:
        rel = q - np.asarray(self.centre)
        a = np.asarray(self.axis)
        return rel - (rel @ a)[..., None] * a

    def symbolic_distance_np(self, q: np.ndarray) -> np.ndarray:
        return np.linalg.norm(self._radial(q), axis=-1) - self.radius

    def normal_at(self, q: np.ndarray) -> np.ndarray:
        r = self._radial(q)
        return r / np.linalg.norm(r, axis=-1)[..., None]

    def _body_distance(self, L: float, r1: float) -> float:
        a, c = np.asarray(self.axis), np.asarray(self.centre)
        proj = np.eye(3) - np.outer(a, a)

        def f(x):
            r = proj @ (x - c)
            return float(r @ r)

        def grad(x):
            return 2.0 * proj @ (proj @ (x - c))

        starts = [np.array([t * L, -r1, 0.0]) for t in (0.0, 0.5, 1.0)]
        best = min(_closest_in_body(f, grad, L, r1, s)[0] for s in starts)
        dist = math.sqrt(max(best, 0.0))
        return dist - self.radius if dist > 1e-9 else -self.radius

    def describe(self) -> str:
        return f"cylinder of radius {self.radius:g} about {_fmt(self.centre)} along {_fmt(np.round(self.axis, 6))}"

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "centre": list(self.centre), "axis": list(self.axis), "radius": self.radius, "side": self.side}


#: The 3-D obstacles a scene file may name, and their keys.
SPATIAL_KINDS: dict[str, tuple[type, frozenset]] = {
    "plane": (Plane, frozenset({"kind", "at", "normal", "side"})),
    "sphere": (Sphere, frozenset({"kind", "centre", "radius", "side"})),
    "cylinder": (Cylinder3D, frozenset({"kind", "centre", "axis", "radius", "side"})),
}


def is_spatial(item: Mapping[str, Any]) -> bool:
    """Whether a scene file's ``[[obstacles]]`` table is a 3-D obstacle (a planar cylinder has a
    two-number centre and no axis)."""
    kind = item.get("kind")
    if kind in ("plane", "sphere"):
        return True
    if kind == "cylinder":
        centre = item.get("centre")
        return "axis" in item or (hasattr(centre, "__len__") and not isinstance(centre, (str, bytes)) and len(centre) == 3)
    return False


def spatial_obstacle_from_dict(where: str, item: Mapping[str, Any]) -> Obstacle:
    """A 3-D obstacle from a scene file's ``[[obstacles]]`` table (see the module's docstring)."""
    cls, keys = SPATIAL_KINDS[item["kind"]]
    unknown = sorted(set(item) - keys)
    if unknown:
        raise ObstacleError(f"{where}: unknown key(s) {checks.some(unknown)} for a 3-D {item['kind']}; allowed are {', '.join(sorted(keys))}")
    try:
        return cls(**{k: v for k, v in item.items() if k != "kind"})
    except TypeError as exc:  # pragma: no cover - keys are checked above
        raise ObstacleError(f"{where}: {exc}") from None
    except ObstacleError as exc:
        raise ObstacleError(f"{where}: {exc}") from None


def lift(o: Obstacle) -> SpatialObstacle:
    """A planar obstacle as the 3-D one it is (its extrusion across the bending plane); a 3-D one as it is."""
    if isinstance(o, SpatialObstacle):
        return o
    if isinstance(o, HalfPlane):
        nx, ny = o.normal
        return Plane(at=(o.at[0], o.at[1], 0.0), normal=(float(nx), float(ny), 0.0), side=o.resolved_side())
    if isinstance(o, Cylinder):
        return Cylinder3D(centre=(o.centre[0], o.centre[1], 0.0), axis=(0.0, 0.0, 1.0), radius=o.radius, side=o.resolved_side())
    raise ObstacleError(f"obstacle {o!r}: not known to the 3-D model")  # pragma: no cover


# ---------------------------------------------------------------------------------------------
# the touching lines along each helical segment, NumPy and CasADi

#: Below this |w| (rad) the coefficients of the exponential are their series (8 terms: exact to round-off).
SERIES_SWITCH = 0.5


def _coefficients_np(r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r2 = r * r
    # Horner forms of sin(r)/r, (1 - cos r)/r^2, (r - sin r)/r^3 in r^2
    s1 = s2 = s3 = np.zeros_like(r2)
    for k in range(8, -1, -1):
        sign = -1.0 if k % 2 else 1.0
        s1 = s1 * r2 + sign / math.factorial(2 * k + 1)
        s2 = s2 * r2 + sign / math.factorial(2 * k + 2)
        s3 = s3 * r2 + sign / math.factorial(2 * k + 3)
    safe = np.where(r < SERIES_SWITCH, 1.0, r)
    c1 = np.where(r < SERIES_SWITCH, s1, np.sin(safe) / safe)
    c2 = np.where(r < SERIES_SWITCH, s2, (1 - np.cos(safe)) / safe**2)
    c3 = np.where(r < SERIES_SWITCH, s3, (safe - np.sin(safe)) / safe**3)
    return c1, c2, c3


def _hat(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def segment_points(q: Any, L: float, offset: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Points of the touching line at ``offset`` (section frame y, z) at fractions ``sigma`` (n, m) of
    each segment, shape (n, m, 3) (NumPy; :func:`symbolic_line` is the same on CasADi symbols)."""
    q = np.asarray(q, dtype=float).ravel()
    n = q.size // 3
    sigma = np.asarray(sigma, dtype=float)
    seg = L / n
    out = np.empty(sigma.shape + (3,))
    R, p = np.eye(3), np.zeros(3)
    for i in range(n):
        w = np.array([q[2 * n + i], q[n + i], q[i]])
        for j, s in enumerate(sigma[i]):
            ws = s * w
            W = _hat(ws)
            f1, f2, f3 = (float(v) for v in _coefficients_np(np.array(np.linalg.norm(ws))))
            A = np.eye(3) + f1 * W + f2 * W @ W
            t = (np.eye(3) + f2 * W + f3 * W @ W) @ np.array([s * seg, 0.0, 0.0])
            out[i, j] = p + R @ t + (R @ A) @ np.array([0.0, offset[0], offset[1]])
        W = _hat(w)
        f1, f2, f3 = (float(v) for v in _coefficients_np(np.array(np.linalg.norm(w))))
        A = np.eye(3) + f1 * W + f2 * W @ W
        t = (np.eye(3) + f2 * W + f3 * W @ W) @ np.array([seg, 0.0, 0.0])
        p, R = p + R @ t, R @ A
    return out


def _coefficients_ca(r2: Any) -> tuple[Any, Any, Any]:
    """f1, f2, f3 of |w|^2 on CasADi symbols: the series below SERIES_SWITCH (both branches finite, so
    their derivatives are exact at a straight segment)."""
    s1 = s2 = s3 = 0
    for k in range(8, -1, -1):
        sign = -1.0 if k % 2 else 1.0
        s1 = s1 * r2 + sign / math.factorial(2 * k + 1)
        s2 = s2 * r2 + sign / math.factorial(2 * k + 2)
        s3 = s3 * r2 + sign / math.factorial(2 * k + 3)
    small = r2 < SERIES_SWITCH**2
    r = ca.sqrt(r2 + ca.if_else(small, 1, 0))
    c1 = ca.if_else(small, s1, ca.sin(r) / r)
    c2 = ca.if_else(small, s2, (1 - ca.cos(r)) / r**2)
    c3 = ca.if_else(small, s3, (r - ca.sin(r)) / r**3)
    return c1, c2, c3


def _exp_ca(w: Any, length: Any) -> tuple[Any, Any]:
    """exp(hat([length, 0, 0, w])): its rotation A (3 x 3) and translation t (3) on CasADi symbols."""
    W = ca.skew(w)
    f1, f2, f3 = _coefficients_ca(ca.dot(w, w))
    W2 = W @ W
    A = ca.SX.eye(3) + f1 * W + f2 * W2
    V = ca.SX.eye(3) + f2 * W + f3 * W2
    return A, V @ ca.vertcat(length, 0, 0)


def symbolic_line(q: Any, L: Any, offset: Any, sigma: Any) -> tuple[list, list]:
    """The touching line at ``offset`` (a 2-vector, section frame y, z) on CasADi symbols: the
    segments' end points 1..n and the points at ``sigma[i]`` of each segment, as lists of 3-vectors."""
    n = q.shape[0] // 3
    seg = L / n
    R, p = ca.SX.eye(3), ca.SX.zeros(3)
    off = ca.vertcat(0, offset[0], offset[1])
    ends, inside = [], []
    for i in range(n):
        w = ca.vertcat(q[2 * n + i], q[n + i], q[i])
        A, t = _exp_ca(sigma[i] * w, sigma[i] * seg)
        inside.append(p + R @ t + R @ A @ off)
        A, t = _exp_ca(w, seg)
        p, R = p + R @ t, R @ A
        ends.append(p + R @ off)
    return ends, inside

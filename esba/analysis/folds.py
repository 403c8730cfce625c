"""Fold curves in two scene parameters: where the actuator snaps, as a curve in a plane of loads.

A fold of a one-parameter path (:mod:`esba.paths.continuation`) is a point where g = dU/dtheta = 0
and H = d2U/dtheta2 is singular. With two scene parameters (x, y) the folds form curves in the
plane: the solutions of the extended system

    g(theta; x, y) = 0,   H(theta; x, y) v = 0,   v0 . v = 1

(2n + 1 equations in the 2n + 2 unknowns theta, x, y, v), which the path engine continues by
pseudo-arclength continuation (:func:`esba.paths.extended.follow`; codimension-two continuation,
AUTO-07p's LP continuation). The
terms of the system and its Jacobian (with the third derivatives d(H v)/d(theta, x, y) by AD) come
from the path engine's problem (:meth:`esba.paths.problem.PathProblem.extended_terms`, the
``path_fold`` Function in the model's registry), one :class:`~esba.paths.problem.PathProblem`
per parameter; the curves are seeded at the folds that the engine's :func:`~esba.paths.continuation.trace`
finds on one-parameter paths across the plane.

The same machinery runs on the 3-D model (:meth:`Plane.from_scene3d`: one
:class:`~esba.statics.spatial_paths.SpatialPathProblem` per parameter, of pressure, payload, omega,
beta, at, load): theta is then the 3n-vector q = [theta; psi; tau]. For loads in the bending plane
its in-plane folds are the planar ones; a payload out of the plane (beta != 0) unfolds the
sideways branch points of the in-plane state into folds of the twisted state, whose curves this
traces as well (the branch points themselves, for in-plane loads, are curves of another extended
system: :mod:`esba.analysis.branch_curves`).

Along a fold curve three test functions locate the codimension-two points (Brent's method on the
curve's arclength, each point a converged solution of the extended system):

* a **cusp**: c = v . (d(H v)/dtheta) v = 0, the quadratic coefficient of the fold's normal form;
  the curve turns back in the plane and the two folds of a path merge;
* a **branch point of the y-path** (the fold curve meets a branch point): v . dg/dy = 0, where the
  curve is tangent to the line x = const (x extremal on the curve): the path in y at that x touches
  the fold curve and has a branch point there; at nearby x it folds twice or not at all;
* likewise a **branch point of the x-path**: v . dg/dx = 0 (y extremal on the curve).

A fold where every other eigenvalue of H is positive joins a stable and an unstable state
(a *stable fold*: crossing it changes the number of stable states by one); the side on which the
pair exists is n = -(v . dg/dx, v . dg/dy) / c (the fold's normal form), which
:mod:`esba.analysis.maps` uses to count stable states in each region of the plane.

Examples
--------
>>> from esba.model.scene import Scene, Payload
>>> plane = Plane.from_scene(Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),)), "pressure", "payload")
>>> curves = fold_curves(plane, (0.1, 0.25), (1.0, 3.0))
>>> [(round(c.x, 5), round(c.y, 4)) for c in curves[0].cusps]  # the cusp: pressure (MPa), payload (N)
[(0.16858, 1.6452)]
>>> [round(p, 5) for p in folds_at(plane, curves, ((0.1, 0.25), (1.0, 3.0)), y=2.0)]  # the folds under 2 N
[0.1636, 0.17354]
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable, ClassVar, Mapping, Sequence

import numpy as np

from esba.infra import jsonsafe, outputs
from esba.model.scene import Scene
from esba.model.stability import CRITICAL_TOL
from esba.paths import extended
from esba.paths.continuation import MAX_SPAN, PathOptions, trace
from esba.paths.extended import Crossing, Node
from esba.paths.problem import PathError, PathProblem
from esba.statics.equilibrium import EquilibriumError, solve

__all__ = ["Plane", "FoldOptions", "FoldCurve", "CodimTwo", "trace_fold_curve", "fold_curves", "fold_curves_csv", "write_fold_curves", "KINDS"]

#: The codimension-two points located on a fold curve.
KINDS = ("cusp", "branch point of the x-path", "branch point of the y-path")


# ---------------------------------------------------------------------------------------------
# the plane of two scene parameters


@dataclass(frozen=True, eq=False)
class Plane:
    """Two scene parameters x and y of one scene: g(theta; x, y) with the model parameters affine in both.

    Built by :meth:`from_scene` from two :class:`~esba.paths.problem.PathProblem` (one per
    parameter, each with its unit and physical range), or by :meth:`from_scene3d` from two
    :class:`~esba.statics.spatial_paths.SpatialPathProblem` (the 3-D model: the unknowns are
    q = [theta; psi; tau], 3n of them); the other parameters stay at the scene's.
    """

    px: Any  # a PathProblem, or a SpatialPathProblem (esba.paths.problem.PROBLEM_INTERFACE)
    py: Any
    base: np.ndarray  # the model parameter vector of the scene itself

    @classmethod
    def from_scene(cls, scene: Scene, x: str, y: str, *, pressure: float | None = None) -> Plane:
        """The plane of ``x`` and ``y`` (names of :data:`esba.paths.problem.PARAMETERS`) through ``scene``."""
        px = PathProblem.from_scene(scene, x, pressure=pressure)
        return cls._of(px, PathProblem.from_scene(scene, y, pressure=px.pressure), x, y)

    @classmethod
    def from_scene3d(cls, scene: Scene, x: str, y: str, section: Mapping[str, float] | None = None) -> Plane:
        """The plane of ``x`` and ``y`` (names of :data:`esba.statics.spatial_paths.PARAMETERS_3D`:
        pressure, payload, omega, beta, at, load) through ``scene`` in the 3-D model, with the section
        stiffnesses ``section`` (EI_side, GJ; those not given the eccentric section's)."""
        from esba.statics.spatial_paths import SpatialPathProblem

        return cls._of(SpatialPathProblem.from_scene(scene, x, section), SpatialPathProblem.from_scene(scene, y, section), x, y)

    @classmethod
    def _of(cls, px, py, x: str, y: str) -> Plane:
        if np.any((px.dp != 0) & (py.dp != 0)):
            raise PathError(f"x={x!r}, y={y!r}: the two parameters move the same model parameter; choose two different ones")
        return cls(px, py, px.p0 + px.lam0 * px.dp)

    @property
    def n(self) -> int:
        """Unknowns per state: the segment count (planar), or 3 x it (3-D)."""
        return self.px.n

    @property
    def spatial(self) -> bool:
        """The plane is the 3-D model's."""
        return not isinstance(self.px, PathProblem)

    @property
    def segments(self) -> int:
        """The segment count."""
        return self.px.segments if self.spatial else self.px.n

    @property
    def names(self) -> tuple[str, str]:
        return self.px.name, self.py.name

    @property
    def units(self) -> tuple[str, str]:
        return self.px.unit_short.strip(), self.py.unit_short.strip()

    @property
    def scene(self) -> Scene:
        return self.px.scene  # type: ignore[return-value]

    def along_x(self, y: float) -> PathProblem:
        """The path problem in x at fixed y (lambda = x)."""
        return replace(self.px, p0=self.base - self.px.lam0 * self.px.dp + (y - self.py.lam0) * self.py.dp)

    def along_y(self, x: float) -> PathProblem:
        """The path problem in y at fixed x (lambda = y)."""
        return replace(self.py, p0=self.base - self.py.lam0 * self.py.dp + (x - self.px.lam0) * self.px.dp)

    def params(self, x: float, y: float) -> np.ndarray:
        """The model parameter vector at (x, y)."""
        return self.base + (x - self.px.lam0) * self.px.dp + (y - self.py.lam0) * self.py.dp

    def values(self, x: float, y: float) -> dict[str, float]:
        """The model's parameter values at (x, y), by name."""
        return dict(zip(self.px.model.parameters, map(float, self.params(x, y))))

    def scene_at(self, x: float, y: float) -> Scene:
        """The scene at (x, y) (planar planes)."""
        return self.along_y(x).scene_at(y) if self.py.name != "load" else self.along_x(y).scene_at(x)

    def equilibrium(self, x: float, y: float) -> np.ndarray | None:
        """The state the scene at (x, y) settles in along its load history (the planar solve, or the
        3-D one certified by IPOPT), or None when it fails."""
        if not self.spatial:
            try:
                return solve(self.scene_at(x, y)).theta
            except (EquilibriumError, PathError):
                return None
        from esba.statics.spatial import solve3d

        eq = solve3d(self.px.model, self.values(x, y))
        return eq.q if eq.converged else None

    def in_range(self, x: float, y: float) -> bool:
        return self.px.in_range(x) and self.py.in_range(y)

    def defined(self, theta: np.ndarray, x: float, y: float) -> bool:
        """The model is defined at (theta; x, y) and both parameters are in their physical ranges."""
        return self.in_range(x, y) and self.along_x(y).defined(theta, x)

    def terms(self, theta: np.ndarray, x: float, y: float, v: np.ndarray):
        """g, H, dg/dx, dg/dy, H v, d(Hv)/dtheta, d(Hv)/dx, d(Hv)/dy at (theta; x, y) and v."""
        g, h, gx, hv, hvt, hvx, _ = self.along_x(y).extended_terms(theta, x, v)
        _, _, gy, _, _, hvy, _ = self.along_y(x).extended_terms(theta, y, v)
        return g, h, gx, gy, hv, hvt, hvx, hvy


# ---------------------------------------------------------------------------------------------
# results


#: Short labels of the special points of the curves, by kind: a fold curve's (:data:`KINDS`) and a
#: branch-point curve's (:data:`esba.analysis.branch_curves.KINDS_BP`).
LABELS = {
    "cusp": "CP",
    "branch point of the x-path": "BPx",
    "branch point of the y-path": "BPy",
    "meets an in-plane fold": "FBP",
    "two branch points of the x-path merge": "BBx",
    "two branch points of the y-path merge": "BBy",
}


def _angles(q: np.ndarray, segments: int) -> dict[str, list[float]]:
    """A state's angles in degrees by name: ``theta`` (planar, ``segments`` = 0), or ``theta``, ``psi``
    and ``tau`` (the 3-D model's in-plane bend, sideways bend and twist, ``segments`` each)."""
    deg = np.degrees(np.asarray(q, dtype=float))
    if not segments:
        return {"theta": deg.tolist()}
    return {k: deg[i * segments : (i + 1) * segments].tolist() for i, k in enumerate(("theta", "psi", "tau"))}


def _sideways_share(v: np.ndarray, segments: int) -> float:
    """The out-of-plane (psi, tau) share of a 3-D mode's squared size."""
    v = np.asarray(v, dtype=float)
    total = float(v @ v)
    return float(v[segments:] @ v[segments:] / total) if total > 0 else 0.0


@dataclass(frozen=True, eq=False)
class CodimTwo:
    """A cusp, or a point where a curve of special points meets another kind (see :data:`LABELS`).

    ``kind`` names it; ``x``, ``y`` the parameters (their units); ``theta`` rad (the 3-D state
    q = [theta; psi; tau] when ``segments`` > 0); ``vector`` the critical vector (unit, largest
    component positive); ``status`` ``converged`` (the test function's root to round-off on the
    converged curve) or ``guess``; ``arclength`` along its curve.
    """

    kind: str
    x: float
    y: float
    theta: np.ndarray
    vector: np.ndarray
    status: str
    arclength: float
    curve: int = 0
    segments: int = 0

    @property
    def label(self) -> str:
        return LABELS[self.kind]

    def to_dict(self, names: tuple[str, str] = ("x", "y")) -> dict[str, Any]:
        m = self.segments or len(self.theta)
        d = {"kind": self.kind, "label": self.label, names[0]: self.x, names[1]: self.y}
        d.update({f"{k}_deg": v for k, v in _angles(self.theta, self.segments).items()})
        d["total_angle_deg"] = math.degrees(float(np.sum(self.theta[:m])))
        if self.segments:
            d["twist_deg"] = math.degrees(float(np.sum(self.theta[2 * m :])))
            d["sideways_share"] = _sideways_share(self.vector, m)
        d.update({"critical_vector": [float(v) for v in self.vector], "status": self.status, "arclength": self.arclength, "curve": self.curve})
        return d


@dataclass(frozen=True, eq=False)
class Curve:
    """A traced curve of special points in two parameters: one row per point (x, y, the state, its
    critical vector, the curve's three test functions), its special points, why it ended.

    ``theta`` is the state (the 3-D q = [theta; psi; tau] when ``segments`` > 0, the 3-D model's
    segment count), ``v`` its critical vector; ``stable`` per point: every eigenvalue of H but the
    critical one is positive; ``tests`` (points x 3) the test functions whose zeros are the special
    points (:attr:`TESTS` names them).
    """

    names: tuple[str, str]
    units: tuple[str, str]
    xs: np.ndarray
    ys: np.ndarray
    theta: np.ndarray
    v: np.ndarray
    stable: np.ndarray
    tests: np.ndarray
    arclength: np.ndarray
    special: tuple[CodimTwo, ...]
    stop_reason: str
    index: int = 0
    seconds: float = 0.0
    segments: int = 0

    #: The test functions, the first of them a column of the CSV.
    TESTS: ClassVar[tuple[str, str, str]] = ("test0", "test1", "test2")
    #: The column of :attr:`stable` in the CSV.
    STABLE: ClassVar[str] = "stable"

    def __len__(self) -> int:
        return len(self.xs)

    @property
    def x(self) -> np.ndarray:
        return self.xs

    @property
    def total_angle_deg(self) -> np.ndarray:
        """The in-plane bend, sum of theta, per point (deg)."""
        return np.degrees(self.theta[:, : self.segments or None].sum(axis=1))

    @property
    def twist_deg(self) -> np.ndarray:
        """The 3-D model's total twist, sum of tau, per point (deg; zeros for the planar model)."""
        if not self.segments:
            return np.zeros(len(self))
        return np.degrees(self.theta[:, 2 * self.segments :].sum(axis=1))

    def to_dict(self, points: bool = True) -> dict[str, Any]:
        d: dict[str, Any] = {
            "index": self.index,
            "points": len(self),
            "stop_reason": self.stop_reason,
            "x_range": [float(np.min(self.xs)), float(np.max(self.xs))] if len(self) else None,
            "y_range": [float(np.min(self.ys)), float(np.max(self.ys))] if len(self) else None,
            "stable_fraction": float(np.mean(self.stable)) if len(self) else 0.0,
            "special_points": [p.to_dict(self.names) for p in self.special],
            "seconds": self.seconds,
        }
        if points:
            d["curve"] = [
                {self.names[0]: float(a), self.names[1]: float(b), "total_angle_deg": float(t), "stable": bool(s)}
                for a, b, t, s in zip(self.xs, self.ys, self.total_angle_deg, self.stable)
            ]
            if self.segments:
                for row, tw in zip(d["curve"], self.twist_deg):
                    row["twist_deg"] = float(tw)
        return d

    def _angle_columns(self, q: np.ndarray) -> dict[str, float]:
        return {f"{k}{i + 1}_deg": float(a) for k, vals in _angles(q, self.segments).items() for i, a in enumerate(vals)}

    def csv_rows(self) -> list[dict[str, Any]]:
        rows = []
        m = self.segments
        for k in range(len(self)):
            row = {"curve": self.index, "point": k, self.names[0]: self.xs[k], self.names[1]: self.ys[k], "arclength": self.arclength[k]}
            row.update(self._angle_columns(self.theta[k]))
            row["total_angle_deg"] = float(self.total_angle_deg[k])
            if m:
                row["twist_deg"] = float(self.twist_deg[k])
            row.update({self.STABLE: int(self.stable[k]), self.TESTS[0]: self.tests[k, 0], "special": ""})
            row.update({f"v{i + 1}": "" for i in range(self.theta.shape[1])})
            rows.append(row)
        for p in self.special:
            row = {"curve": self.index, "point": "", self.names[0]: p.x, self.names[1]: p.y, "arclength": p.arclength}
            row.update(self._angle_columns(p.theta))
            row["total_angle_deg"] = math.degrees(float(np.sum(p.theta[: m or None])))
            if m:
                row["twist_deg"] = math.degrees(float(np.sum(p.theta[2 * m :])))
            row.update({self.STABLE: "", self.TESTS[0]: "", "special": p.kind})
            row.update({f"v{i + 1}": float(v) for i, v in enumerate(p.vector)})  # the critical vector, as the JSON's critical_vector
            rows.append(row)
        return rows


@dataclass(frozen=True, eq=False)
class FoldCurve(Curve):
    """A traced fold curve (see :class:`Curve`): its tests are the cusp test c = v . (d(Hv)/dtheta) v and
    v . dg/dx, v . dg/dy; ``stable`` per point says that the fold joins a stable and an unstable
    state; :meth:`side` the unit normal in the (x, y) plane (in the parameters' units scaled by
    the map's spans) pointing to where the fold's two states exist.
    """

    TESTS = ("cusp_test", "bx", "by")
    STABLE = "stable_fold"

    @property
    def cusp_test(self) -> np.ndarray:
        return self.tests[:, 0]

    @property
    def bx(self) -> np.ndarray:
        return self.tests[:, 1]

    @property
    def by(self) -> np.ndarray:
        return self.tests[:, 2]

    @property
    def cusps(self) -> tuple[CodimTwo, ...]:
        return tuple(p for p in self.special if p.kind == "cusp")

    def side(self, spans: tuple[float, float] = (1.0, 1.0)) -> np.ndarray:
        """Per point, the unit normal (in x / span_x, y / span_y) towards the side where the fold's pair exists."""
        with np.errstate(divide="ignore", invalid="ignore"):
            nx, ny = -self.bx * spans[0] / self.cusp_test, -self.by * spans[1] / self.cusp_test
            size = np.hypot(nx, ny)
            return np.column_stack([nx / size, ny / size])


def fold_curves_csv(curves: Sequence[Curve]) -> str:
    """Every point and special point of ``curves`` as CSV (one row each; special points name their kind;
    curves of different kinds side by side leave the other kind's columns empty)."""
    rows = [r for c in curves for r in c.csv_rows()]
    buf = io.StringIO()
    if rows:
        fields = list(dict.fromkeys(k for r in rows for k in r))
        w = csv.DictWriter(buf, fieldnames=fields, restval="", lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.12g}" if isinstance(v, float) else v) for k, v in r.items()})
    return buf.getvalue()


def write_fold_curves(curves: Sequence[Curve], path: str | Path, extra: Mapping[str, Any] | None = None, key: str = "fold_curves") -> Path:
    """Write ``curves`` as CSV (``.csv``) or JSON (``.json``, with ``extra``; the curves under ``key``)."""
    path = Path(path)
    if path.suffix.lower() == ".json":
        data = dict(extra or {})
        data[key] = [c.to_dict() for c in curves]
        outputs.write_text(path, json.dumps(jsonsafe.clean(data), indent=1) + "\n")  # WriteFailed naming the file on a full disk
    else:
        outputs.write_text(path, fold_curves_csv(curves))
    return path


# ---------------------------------------------------------------------------------------------
# continuation of the extended system


@dataclass(frozen=True)
class FoldOptions:
    """Settings of fold-curve continuation (steps in the scaled unknowns: theta in rad, x and y in spans, v).

    ``margin``: how far (a fraction of the span) beyond the map's box a curve is followed before it
    ends; ``tol``: the largest |dU/dtheta| (N mm/rad) of a converged point.
    """

    ds: float = 0.02
    ds_min: float = 1e-7
    ds_max: float = 0.04
    max_steps: int = 3000
    max_iterations: int = 10
    tol: float = 1e-10
    margin: float = 0.02
    critical_tol: float = CRITICAL_TOL

    def __post_init__(self) -> None:
        for name in ("ds", "ds_min", "ds_max", "tol", "margin", "critical_tol"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise PathError(f"{name}={v!r}: expected a finite number > 0")
        if not self.ds_min <= self.ds <= self.ds_max:
            raise PathError(f"ds={self.ds!r}: expected ds_min <= ds <= ds_max ({self.ds_min:g} .. {self.ds_max:g})")
        for name in ("max_steps", "max_iterations"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise PathError(f"{name}={v!r}: expected a whole number >= 1")


class CurveSystem:
    """An extended system of one plane whose solutions form a curve: the equilibrium in the state
    unknowns q[S] (the others held at 0) and a null vector of the Hessian's block on the indices K,

        g[S](q; x, y) = 0,   H[K, K](q; x, y) w = 0,   w0 . w = 1   (w0 the anchor's w),

    in the scaled unknowns u = (q[S], x / sx, y / sy, w) (an :class:`esba.paths.extended.ExtendedSystem`;
    |S| + |K| + 1 equations in |S| + |K| + 2 unknowns). A fold curve has S = K = every index; the
    3-D branch-point curves (:mod:`esba.analysis.branch_curves`) S = theta and K = (psi, tau).
    The terms come from :meth:`Plane.terms` with v = w on K (0 elsewhere). A subclass gives the test
    functions (:meth:`tests`) and its curve type (``curve``, a :class:`Curve`).
    """

    curve: type = Curve
    what = "curve"

    def __init__(self, plane: Plane, spans: tuple[float, float], opts: FoldOptions, state: np.ndarray | None = None, vector: np.ndarray | None = None):
        self.plane, self.opts = plane, opts
        everything = np.arange(plane.n)
        self.si = everything if state is None else np.asarray(state)
        self.vi = everything if vector is None else np.asarray(vector)
        self.m, self.k = len(self.si), len(self.vi)
        self.sx, self.sy = spans
        self.evaluations = 0

    def split(self, u):
        m = self.m
        return u[:m], float(u[m]) * self.sx, float(u[m + 1]) * self.sy, u[m + 2 :]

    def join(self, state, x, y, vector) -> np.ndarray:
        return np.concatenate([state, [x / self.sx, y / self.sy], vector])

    def full(self, state: np.ndarray, vector: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The model's state and critical vector of the unknowns' parts."""
        q, v = np.zeros(self.plane.n), np.zeros(self.plane.n)
        q[self.si], v[self.vi] = state, vector
        return q, v

    def reduce(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The unknowns' parts of a model state and critical vector."""
        return np.asarray(q)[self.si], np.asarray(v)[self.vi]

    def anchor(self, u: np.ndarray) -> np.ndarray:
        u = u.copy()
        u[self.m + 2 :] /= np.linalg.norm(u[self.m + 2 :])
        return u

    def evaluate(self, u, anchor):
        """(residual, Jacobian, terms) at u, or None outside the model's domain."""
        state, x, y, w = self.split(u)
        q, v = self.full(state, w)
        if not self.plane.along_x(y).defined(q, x):
            return None
        self.evaluations += 1
        g, h, gx, gy, hv, hvt, hvx, hvy = terms = self.plane.terms(q, x, y, v)
        m, k, si, vi = self.m, self.k, self.si, self.vi
        res = np.concatenate([g[si], hv[vi], [anchor[m + 2 :] @ w - 1.0]])
        if not np.all(np.isfinite(res)):
            return None
        jac = np.zeros((m + k + 1, m + k + 2))
        jac[:m, :m] = h[np.ix_(si, si)]
        jac[:m, m] = gx[si] * self.sx
        jac[:m, m + 1] = gy[si] * self.sy
        jac[m : m + k, :m] = hvt[np.ix_(vi, si)]
        jac[m : m + k, m] = hvx[vi] * self.sx
        jac[m : m + k, m + 1] = hvy[vi] * self.sy
        jac[m : m + k, m + 2 :] = h[np.ix_(vi, vi)]
        jac[m + k, m + 2 :] = anchor[m + 2 :]
        return res, jac, terms

    def converged(self, res, terms) -> bool:
        m, k = self.m, self.k
        hscale = max(1.0, float(np.max(np.abs(terms[1]))))
        return float(np.max(np.abs(res[:m]))) <= self.opts.tol and float(np.max(np.abs(res[m : m + k]))) <= 1e-12 * hscale and abs(res[-1]) <= 1e-13

    def acceptable(self, res, terms) -> bool:
        return float(np.max(np.abs(res[: self.m]))) <= 1e3 * self.opts.tol

    def correct(self, u, row: np.ndarray, c0: float) -> Node | None:
        """Newton on the system and row . u = c0 (the engine's corrector)."""
        return extended.correct(self, u, row, c0, self.opts.max_iterations)

    def stable(self, node: Node) -> bool:
        """Every eigenvalue of H but the one nearest zero is positive (``node.data[1]`` is H)."""
        eig = np.linalg.eigvalsh(node.data[1])
        scale = max(float(np.max(np.abs(eig))), 1e-300)
        k = int(np.argmin(np.abs(eig)))
        others = np.delete(eig, k)
        return bool(np.all(others > self.opts.critical_tol * scale))


class _FoldSystem(CurveSystem):
    """The fold system of one plane: g = 0, H v = 0, v0 . v = 1 (v0 the anchor's v) in
    u = (theta, x / sx, y / sy, v); 2n + 1 equations in 2n + 2 unknowns."""

    curve = FoldCurve
    what = "fold curve"

    def tests(self, node: Node) -> np.ndarray:
        """(c, v . dg/dx, v . dg/dy): the cusp test and the two branch-point tests (v unit)."""
        _, _, gx, gy, _, hvt, _, _ = node.data
        v = node.u[self.m + 2 :]
        v = v / np.linalg.norm(v)
        return np.array([float(v @ hvt @ v), float(v @ gx), float(v @ gy)])


def _special(fs: CurveSystem, c: Crossing, kinds: Sequence[str]) -> CodimTwo:
    state, x, y, vector = fs.split(c.node.u)
    q, v = fs.full(state, vector)
    v = v / np.linalg.norm(v)
    v = v * np.sign(v[int(np.argmax(np.abs(v)))])
    return CodimTwo(kinds[c.index], x, y, q.copy(), v, c.status, c.arclength, segments=fs.plane.segments if fs.plane.spatial else 0)


def _stop(fs: CurveSystem, start: Node, box, opts: FoldOptions, known: list[np.ndarray]):
    """When a curve ends: beyond the box's margin and going away, back at its start, or on a curve already traced."""
    (xlo, xhi), (ylo, yhi) = box

    def away(u) -> float:
        _, x, y, _ = fs.split(u)
        return max(xlo - x, x - xhi, 0.0) / fs.sx + max(ylo - y, y - yhi, 0.0) / fs.sy

    state = {"outside": away(start.u)}

    def stop(nodes, ds: float) -> tuple[str, bool]:
        u = nodes[-1].u
        out = away(u)
        if out > opts.margin and out >= state["outside"]:  # beyond the margin and not coming back in
            return "left the map", False
        state["outside"] = out
        here = u[: fs.m + 2]
        if len(nodes) > 5 and np.linalg.norm(here - start.u[: fs.m + 2]) < 0.6 * ds:
            return "closed (returned to its start)", False
        for other in known:
            # within a step of a traced curve's points: the same curve (its last point overlaps it and goes)
            if np.min(np.linalg.norm(other - here, axis=1)) < 0.75 * opts.ds_max:
                return f"joined a {fs.what} already traced", True
        return "", False

    return stop


def _positions(fs: CurveSystem, c: Curve) -> np.ndarray:
    """A traced curve's points as the unknowns' (state, x / sx, y / sy)."""
    state = np.array([fs.reduce(q, v)[0] for q, v in zip(c.theta, c.v)]).reshape(len(c), fs.m)
    return np.column_stack([state, c.xs / fs.sx, c.ys / fs.sy])


def trace_curve(fs: CurveSystem, u: np.ndarray, box, kinds: Sequence[str], known: Sequence[Curve] = (), index: int = 0) -> Curve | None:
    """The curve of ``fs`` through (near) u, both ways, within ``box`` ((xlo, xhi), (ylo, yhi)) and a
    margin, by :func:`esba.paths.extended.follow`, its special points named by ``kinds`` (one per
    test function); None when the start does not converge."""
    import time

    opts = fs.opts
    t_start = time.perf_counter()
    row = np.zeros(len(u))
    row[fs.m + 1] = 1.0  # the start at its own y
    start = fs.correct(u, row, float(u[fs.m + 1]))
    if start is None:
        return None
    known_u = [_positions(fs, c) for c in known if len(c)]
    fwd, sp_f, why_f = extended.follow(fs, start, 1.0, opts, _stop(fs, start, box, opts, known_u))
    back_start = Node(start.u.copy(), start.data)
    if why_f.startswith("closed"):
        bwd, sp_b, why_b = [back_start], [], why_f
    else:
        bwd, sp_b, why_b = extended.follow(fs, back_start, -1.0, opts, _stop(fs, back_start, box, opts, known_u))
    s_f = np.concatenate([[0.0], np.cumsum([np.linalg.norm(b.u - a.u) for a, b in zip(fwd, fwd[1:])])])
    s_b = np.concatenate([[0.0], np.cumsum([np.linalg.norm(b.u - a.u) for a, b in zip(bwd, bwd[1:])])])
    nodes = bwd[::-1] + fwd[1:]
    arclength = np.concatenate([-s_b[::-1], s_f[1:]])
    special = [replace(_special(fs, c, kinds), arclength=-c.arclength, curve=index) for c in sp_b]
    special += [replace(_special(fs, c, kinds), curve=index) for c in sp_f]
    special.sort(key=lambda p: p.arclength)
    parts = [fs.split(nd.u) for nd in nodes]
    states = [fs.full(p[0], p[3]) for p in parts]
    stop = why_f if why_f == why_b else f"one way: {why_b}; the other: {why_f}"
    return fs.curve(
        fs.plane.names,
        fs.plane.units,
        np.array([p[1] for p in parts]),
        np.array([p[2] for p in parts]),
        np.array([q for q, _ in states]),
        np.array([v / np.linalg.norm(v) for _, v in states]),
        np.array([fs.stable(nd) for nd in nodes]),
        np.array([fs.tests(nd) for nd in nodes]),
        arclength,
        tuple(special),
        stop,
        index,
        time.perf_counter() - t_start,
        fs.plane.segments if fs.plane.spatial else 0,
    )


def trace_fold_curve(
    plane: Plane,
    theta: np.ndarray,
    x: float,
    y: float,
    v: np.ndarray,
    box: tuple[tuple[float, float], tuple[float, float]],
    options: FoldOptions | None = None,
    known: Sequence[FoldCurve] = (),
    index: int = 0,
) -> FoldCurve | None:
    """The fold curve through the fold (theta; x, y) with critical vector v, both ways, within ``box``
    ((xlo, xhi), (ylo, yhi)) and a margin, by :func:`esba.paths.extended.follow`; None when the start
    does not converge."""
    spans = (box[0][1] - box[0][0], box[1][1] - box[1][0])
    fs = _FoldSystem(plane, spans, options or FoldOptions())
    u = fs.join(np.asarray(theta, dtype=float), x, y, np.asarray(v, dtype=float) / np.linalg.norm(v))
    return trace_curve(fs, u, box, KINDS, known, index)  # type: ignore[return-value]


# ---------------------------------------------------------------------------------------------
# seeds: the special points of one-parameter paths across the plane


#: Path settings of the seeding traces.
SEED_OPTIONS = PathOptions(ds_max=0.1)


def seed_points(plane: Plane, box, lines: int = 5, kind: str = "fold") -> list[tuple[np.ndarray, float, float, np.ndarray]]:
    """The converged special points of ``kind`` (``fold`` or ``branch point``), as (theta, x, y, v),
    of ``lines`` paths in x (at evenly spaced y) and in y (at evenly spaced x), each traced by the
    path engine from the state at the box's low end (:meth:`Plane.equilibrium`) to one span beyond
    its high end (a path that reaches a fold beyond the box comes back into it through the fold's
    partner; a curve seeded outside is followed while it comes nearer the box)."""
    (xlo, xhi), (ylo, yhi) = box
    seeds = []
    for along, other_range, (lo, hi) in (("x", (ylo, yhi), (xlo, xhi)), ("y", (xlo, xhi), (ylo, yhi))):
        for other in np.linspace(*other_range, lines):
            other = float(other)
            theta = plane.equilibrium(lo, other) if along == "x" else plane.equilibrium(other, lo)
            if theta is None:
                continue
            problem = plane.along_x(other) if along == "x" else plane.along_y(other)
            b = trace(problem, theta, lo, to=min(hi + (hi - lo), problem.domain[1]), options=SEED_OPTIONS)
            points = [f for f in b.special if f.kind == kind and f.status == "converged"]
            seeds += [(f.theta, f.lam, other, f.eigenvector) if along == "x" else (f.theta, other, f.lam, f.eigenvector) for f in points]
    return seeds


def seed_folds(plane: Plane, box, lines: int = 5) -> list[tuple[np.ndarray, float, float, np.ndarray]]:
    """Folds (theta, x, y, v) of ``lines`` paths in x and in y across the box (:func:`seed_points`)."""
    return seed_points(plane, box, lines, "fold")


def check_box(plane: Plane, box) -> None:
    """Refuse a box wider than the path engine follows (the seeding traces run one span beyond it)."""
    for (lo, hi), prob, axis in ((box[0], plane.px, "x"), (box[1], plane.py, "y")):
        if hi - lo > 0.5 * MAX_SPAN * prob.scale:
            raise PathError(
                f"{axis} range {lo:g}..{hi:g}{prob.unit_short}: at most {0.5 * MAX_SPAN * prob.scale:g}{prob.unit_short} wide "
                f"({0.5 * MAX_SPAN:g} typical sizes of {prob.name})"
            )


def _box(plane: Plane, xrange, yrange):
    box = (tuple(map(float, xrange)), tuple(map(float, yrange)))
    if not (box[0][0] < box[0][1] and box[1][0] < box[1][1]):
        raise PathError(f"ranges {xrange!r}, {yrange!r}: expected FROM < TO for both parameters")
    check_box(plane, box)
    return box


def trace_curves(plane: Plane, xrange, yrange, system: type, seeder: Callable, kinds: Sequence[str], options: FoldOptions | None = None,
                 lines: int = 5, seeds: Sequence[tuple[np.ndarray, float, float, np.ndarray]] | None = None) -> list[Curve]:
    """Every curve of ``system`` (a :class:`CurveSystem` type, ``system(plane, spans, options)``) in the
    box through the seeds (theta, x, y, v; by default ``seeder(plane, box, lines)``), its special
    points named by ``kinds``: each seed already on a traced curve is skipped; each curve runs both
    ways until it leaves the box (by a margin), closes, or joins a traced curve; a curve wholly
    outside the box is not kept."""
    box = _box(plane, xrange, yrange)
    seeds = seeder(plane, box, lines) if seeds is None else list(seeds)
    spans = (box[0][1] - box[0][0], box[1][1] - box[1][0])
    fs = system(plane, spans, options or FoldOptions())
    curves: list[Curve] = []
    for theta, x, y, v in seeds:
        state, vector = fs.reduce(np.asarray(theta, dtype=float), np.asarray(v, dtype=float))
        here = np.concatenate([state, [x / spans[0], y / spans[1]]])
        on = [np.min(np.linalg.norm(_positions(fs, c) - here, axis=1)) for c in curves]
        if on and min(on) < 0.05:
            continue
        c = trace_curve(fs, fs.join(state, x, y, vector / np.linalg.norm(vector)), box, kinds, curves, len(curves))
        if c is not None and len(c) > 1:
            inside = (c.xs >= box[0][0]) & (c.xs <= box[0][1]) & (c.ys >= box[1][0]) & (c.ys <= box[1][1])
            if inside.any():  # a piece wholly outside the box (seeded beyond it) is not the map's
                curves.append(c)
    return curves


def fold_curves(
    plane: Plane,
    xrange: tuple[float, float],
    yrange: tuple[float, float],
    options: FoldOptions | None = None,
    lines: int = 5,
    seeds: Sequence[tuple[np.ndarray, float, float, np.ndarray]] | None = None,
) -> list[FoldCurve]:
    """Every fold curve in the box that a path of ``lines`` x-paths and y-paths crosses (or from ``seeds``).

    Each seed already on a traced curve is skipped; each curve runs both ways until it leaves the
    box (by a margin), closes, or joins a traced curve.
    """
    return trace_curves(plane, xrange, yrange, _FoldSystem, seed_folds, KINDS, options, lines, seeds)  # type: ignore[return-value]


def fold_summary(curves: Sequence[Curve], kinds: Sequence[str] = KINDS) -> dict[str, Any]:
    """How many curves, points and special points of each kind (``kinds``, and any other found)."""
    special = [p for c in curves for p in c.special]
    kinds = list(dict.fromkeys(list(kinds) + [p.kind for p in special]))
    return {
        "curves": len(curves),
        "points": int(sum(len(c) for c in curves)),
        **{kind: sum(1 for p in special if p.kind == kind) for kind in kinds},
    }


def crossings(fs: CurveSystem, curves: Sequence[Curve], *, x: float | None = None, y: float | None = None) -> list[tuple[float, Node]]:
    """Where the curves cross the line y = const (or x = const): each crossing of a curve's polyline
    corrected on ``fs`` at that y (or x), as (the other parameter there, the converged point), sorted."""
    if (x is None) == (y is None):
        raise PathError("folds_at: give exactly one of x= or y=")
    k = 1 if y is not None else 0
    value = y if y is not None else x
    found: list[tuple[float, Node]] = []
    for c in curves:
        along = c.ys if k == 1 else c.xs
        for i in np.flatnonzero(np.sign(along[:-1] - value) * np.sign(along[1:] - value) <= 0):
            w = (value - along[i]) / (along[i + 1] - along[i]) if along[i + 1] != along[i] else 0.0
            state, vector = fs.reduce((1 - w) * c.theta[i] + w * c.theta[i + 1], (1 - w) * c.v[i] + w * c.v[i + 1])
            xx = (1 - w) * c.xs[i] + w * c.xs[i + 1]
            yy = (1 - w) * c.ys[i] + w * c.ys[i + 1]
            u = fs.join(state, xx if k == 1 else value, value if k == 1 else yy, vector / np.linalg.norm(vector))
            row = np.zeros(len(u))
            row[fs.m + k] = 1.0
            node = fs.correct(u, row, float(u[fs.m + k]))
            if node is not None:
                _, fx, fy, _ = fs.split(node.u)
                other = fx if k == 1 else fy
                if not any(abs(other - f) <= 1e-9 * max(1.0, abs(f)) for f, _ in found):
                    found.append((other, node))
    return sorted(found, key=lambda p: p[0])


def folds_at(plane: Plane, curves: Sequence[FoldCurve], box, *, x: float | None = None, y: float | None = None, options: FoldOptions | None = None) -> list[float]:
    """Where the fold curves cross the line y = const (the folds of the x-path there; or x = const):
    each crossing of a curve's polyline corrected on the extended system at that y (or x), sorted."""
    spans = (box[0][1] - box[0][0], box[1][1] - box[1][0])
    return [f for f, _ in crossings(_FoldSystem(plane, spans, options or FoldOptions()), curves, x=x, y=y)]


__all__ += ["Curve", "CurveSystem", "trace_curve", "trace_curves", "crossings", "LABELS", "fold_summary", "seed_points", "seed_folds", "SEED_OPTIONS", "folds_at", "check_box"]

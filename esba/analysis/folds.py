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
from typing import Any, Mapping, Sequence

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
    parameter, each with its unit and physical range); the other parameters stay at the scene's.
    """

    px: PathProblem
    py: PathProblem
    base: np.ndarray  # the model parameter vector of the scene itself

    @classmethod
    def from_scene(cls, scene: Scene, x: str, y: str, *, pressure: float | None = None) -> Plane:
        """The plane of ``x`` and ``y`` (names of :data:`esba.paths.problem.PARAMETERS`) through ``scene``."""
        px = PathProblem.from_scene(scene, x, pressure=pressure)
        py = PathProblem.from_scene(scene, y, pressure=px.pressure)
        if np.any((px.dp != 0) & (py.dp != 0)):
            raise PathError(f"x={x!r}, y={y!r}: the two parameters move the same model parameter; choose two different ones")
        return cls(px, py, px.p0 + px.lam0 * px.dp)

    @property
    def n(self) -> int:
        return self.px.n

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

    def scene_at(self, x: float, y: float) -> Scene:
        """The scene at (x, y)."""
        return self.along_y(x).scene_at(y) if self.py.name != "load" else self.along_x(y).scene_at(x)

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


@dataclass(frozen=True, eq=False)
class CodimTwo:
    """A cusp, or a point where a fold curve meets a branch point of a one-parameter path.

    ``kind`` is one of :data:`KINDS`; ``x``, ``y`` the parameters (their units); ``theta`` rad;
    ``vector`` the critical vector (unit, largest component positive); ``status`` ``converged``
    (the test function's root to round-off on the converged curve) or ``guess``; ``arclength``
    along its curve.
    """

    kind: str
    x: float
    y: float
    theta: np.ndarray
    vector: np.ndarray
    status: str
    arclength: float
    curve: int = 0

    @property
    def label(self) -> str:
        return {"cusp": "CP", "branch point of the x-path": "BPx", "branch point of the y-path": "BPy"}[self.kind]

    def to_dict(self, names: tuple[str, str] = ("x", "y")) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "label": self.label,
            names[0]: self.x,
            names[1]: self.y,
            "theta_deg": np.degrees(self.theta).tolist(),
            "total_angle_deg": math.degrees(float(np.sum(self.theta))),
            "critical_vector": [float(v) for v in self.vector],
            "status": self.status,
            "arclength": self.arclength,
            "curve": self.curve,
        }


@dataclass(frozen=True, eq=False)
class FoldCurve:
    """A traced fold curve: one row per point (x, y, theta, v, test functions), its special points, why it ended.

    ``stable`` per point: every eigenvalue of H but the critical one is positive (the fold joins a
    stable and an unstable state); ``cusp_test`` c = v . (d(Hv)/dtheta) v; ``bx``, ``by`` v . dg/dx and
    v . dg/dy; ``side`` the unit normal in the (x, y) plane (in the parameters' units scaled by
    the map's spans) pointing to where the fold's two states exist.
    """

    names: tuple[str, str]
    units: tuple[str, str]
    xs: np.ndarray
    ys: np.ndarray
    theta: np.ndarray
    v: np.ndarray
    stable: np.ndarray
    cusp_test: np.ndarray
    bx: np.ndarray
    by: np.ndarray
    arclength: np.ndarray
    special: tuple[CodimTwo, ...]
    stop_reason: str
    index: int = 0
    seconds: float = 0.0

    def __len__(self) -> int:
        return len(self.xs)

    @property
    def x(self) -> np.ndarray:
        return self.xs

    @property
    def cusps(self) -> tuple[CodimTwo, ...]:
        return tuple(p for p in self.special if p.kind == "cusp")

    @property
    def total_angle_deg(self) -> np.ndarray:
        return np.degrees(self.theta.sum(axis=1))

    def side(self, spans: tuple[float, float] = (1.0, 1.0)) -> np.ndarray:
        """Per point, the unit normal (in x / span_x, y / span_y) towards the side where the fold's pair exists."""
        with np.errstate(divide="ignore", invalid="ignore"):
            nx, ny = -self.bx * spans[0] / self.cusp_test, -self.by * spans[1] / self.cusp_test
            size = np.hypot(nx, ny)
            return np.column_stack([nx / size, ny / size])

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
        return d

    def csv_rows(self) -> list[dict[str, Any]]:
        rows = []
        for k in range(len(self)):
            row = {"curve": self.index, "point": k, self.names[0]: self.xs[k], self.names[1]: self.ys[k], "arclength": self.arclength[k]}
            row.update({f"theta{i + 1}_deg": float(np.degrees(t)) for i, t in enumerate(self.theta[k])})
            row.update({"total_angle_deg": float(self.total_angle_deg[k]), "stable_fold": int(self.stable[k]), "cusp_test": self.cusp_test[k], "special": ""})
            row.update({f"v{i + 1}": "" for i in range(self.theta.shape[1])})
            rows.append(row)
        for p in self.special:
            row = {"curve": self.index, "point": "", self.names[0]: p.x, self.names[1]: p.y, "arclength": p.arclength}
            row.update({f"theta{i + 1}_deg": float(np.degrees(t)) for i, t in enumerate(p.theta)})
            row.update({"total_angle_deg": math.degrees(float(np.sum(p.theta))), "stable_fold": "", "cusp_test": "", "special": p.kind})
            row.update({f"v{i + 1}": float(v) for i, v in enumerate(p.vector)})  # the critical vector, as the JSON's critical_vector
            rows.append(row)
        return rows


def fold_curves_csv(curves: Sequence[FoldCurve]) -> str:
    """Every point and special point of ``curves`` as CSV (one row each; special points name their kind)."""
    rows = [r for c in curves for r in c.csv_rows()]
    buf = io.StringIO()
    if rows:
        fields = list(rows[0].keys())
        w = csv.DictWriter(buf, fieldnames=fields, lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.12g}" if isinstance(v, float) else v) for k, v in r.items()})
    return buf.getvalue()


def write_fold_curves(curves: Sequence[FoldCurve], path: str | Path, extra: Mapping[str, Any] | None = None) -> Path:
    """Write ``curves`` as CSV (``.csv``) or JSON (``.json``, with ``extra``)."""
    path = Path(path)
    if path.suffix.lower() == ".json":
        data = dict(extra or {})
        data["fold_curves"] = [c.to_dict() for c in curves]
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


class _FoldSystem:
    """The fold system of one plane in the scaled unknowns u = (theta, x / sx, y / sy, v): g = 0,
    H v = 0, v0 . v = 1 (v0 the anchor's v), an :class:`esba.paths.extended.ExtendedSystem`."""

    def __init__(self, plane: Plane, spans: tuple[float, float], opts: FoldOptions):
        self.plane, self.opts = plane, opts
        self.n = plane.n
        self.sx, self.sy = spans
        self.evaluations = 0

    def split(self, u):
        n = self.n
        return u[:n], float(u[n]) * self.sx, float(u[n + 1]) * self.sy, u[n + 2 :]

    def join(self, theta, x, y, v) -> np.ndarray:
        return np.concatenate([theta, [x / self.sx, y / self.sy], v])

    def anchor(self, u: np.ndarray) -> np.ndarray:
        u = u.copy()
        u[self.n + 2 :] /= np.linalg.norm(u[self.n + 2 :])
        return u

    def evaluate(self, u, anchor):
        """(residual, Jacobian (2n+1) x (2n+2), terms) at u, or None outside the model's domain."""
        theta, x, y, v = self.split(u)
        v0 = anchor[self.n + 2 :]
        if not self.plane.along_x(y).defined(theta, x):
            return None
        self.evaluations += 1
        g, h, gx, gy, hv, hvt, hvx, hvy = terms = self.plane.terms(theta, x, y, v)
        n = self.n
        res = np.concatenate([g, hv, [v0 @ v - 1.0]])
        if not np.all(np.isfinite(res)):
            return None
        jac = np.zeros((2 * n + 1, 2 * n + 2))
        jac[:n, :n] = h
        jac[:n, n] = gx * self.sx
        jac[:n, n + 1] = gy * self.sy
        jac[n : 2 * n, :n] = hvt
        jac[n : 2 * n, n] = hvx * self.sx
        jac[n : 2 * n, n + 1] = hvy * self.sy
        jac[n : 2 * n, n + 2 :] = h
        jac[2 * n, n + 2 :] = v0
        return res, jac, terms

    def converged(self, res, terms) -> bool:
        n = self.n
        hscale = max(1.0, float(np.max(np.abs(terms[1]))))
        return float(np.max(np.abs(res[:n]))) <= self.opts.tol and float(np.max(np.abs(res[n : 2 * n]))) <= 1e-12 * hscale and abs(res[-1]) <= 1e-13

    def acceptable(self, res, terms) -> bool:
        return float(np.max(np.abs(res[: self.n]))) <= 1e3 * self.opts.tol

    def correct(self, u, row: np.ndarray, c0: float) -> Node | None:
        """Newton on the fold system and row . u = c0 (the engine's corrector)."""
        return extended.correct(self, u, row, c0, self.opts.max_iterations)

    # -- what a point says ----------------------------------------------------------------------

    def tests(self, node: Node) -> np.ndarray:
        """(c, v . dg/dx, v . dg/dy): the cusp test and the two branch-point tests (v unit)."""
        _, _, gx, gy, _, hvt, _, _ = node.data
        v = node.u[self.n + 2 :]
        v = v / np.linalg.norm(v)
        return np.array([float(v @ hvt @ v), float(v @ gx), float(v @ gy)])

    def stable(self, node: Node) -> bool:
        eig = np.linalg.eigvalsh(node.data[1])
        scale = max(float(np.max(np.abs(eig))), 1e-300)
        k = int(np.argmin(np.abs(eig)))
        others = np.delete(eig, k)
        return bool(np.all(others > self.opts.critical_tol * scale))


def _special(fs: _FoldSystem, c: Crossing) -> CodimTwo:
    theta, x, y, v = fs.split(c.node.u)
    v = v / np.linalg.norm(v)
    v = v * np.sign(v[int(np.argmax(np.abs(v)))])
    return CodimTwo(KINDS[c.index], x, y, theta.copy(), v, c.status, c.arclength)


def _stop(fs: _FoldSystem, start: Node, box, opts: FoldOptions, known: list[np.ndarray]):
    """When a fold curve ends: beyond the box's margin and going away, back at its start, or on a curve already traced."""
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
        here = u[: fs.n + 2]
        if len(nodes) > 5 and np.linalg.norm(here - start.u[: fs.n + 2]) < 0.6 * ds:
            return "closed (returned to its start)", False
        for other in known:
            # within a step of a traced curve's points: the same curve (its last point overlaps it and goes)
            if np.min(np.linalg.norm(other - here, axis=1)) < 0.75 * opts.ds_max:
                return "joined a fold curve already traced", True
        return "", False

    return stop


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
    import time

    opts = options or FoldOptions()
    t_start = time.perf_counter()
    spans = (box[0][1] - box[0][0], box[1][1] - box[1][0])
    fs = _FoldSystem(plane, spans, opts)
    u = fs.join(np.asarray(theta, dtype=float), x, y, np.asarray(v, dtype=float) / np.linalg.norm(v))
    row = np.zeros(len(u))
    row[fs.n + 1] = 1.0  # the start at its own y
    start = fs.correct(u, row, float(u[fs.n + 1]))
    if start is None:
        return None
    known_u = [np.column_stack([c.theta, c.xs / fs.sx, c.ys / fs.sy]) for c in known if len(c)]
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
    special = [replace(_special(fs, c), arclength=-c.arclength, curve=index) for c in sp_b] + [replace(_special(fs, c), curve=index) for c in sp_f]
    special.sort(key=lambda p: p.arclength)
    parts = [fs.split(nd.u) for nd in nodes]
    tests = np.array([fs.tests(nd) for nd in nodes])
    stop = why_f if why_f == why_b else f"one way: {why_b}; the other: {why_f}"
    return FoldCurve(
        plane.names,
        plane.units,
        np.array([p[1] for p in parts]),
        np.array([p[2] for p in parts]),
        np.array([p[0] for p in parts]),
        np.array([p[3] / np.linalg.norm(p[3]) for p in parts]),
        np.array([fs.stable(nd) for nd in nodes]),
        tests[:, 0],
        tests[:, 1],
        tests[:, 2],
        arclength,
        tuple(special),
        stop,
        index,
        time.perf_counter() - t_start,
    )


# ---------------------------------------------------------------------------------------------
# seeds: the folds of one-parameter paths across the plane


#: Path settings of the seeding traces.
SEED_OPTIONS = PathOptions(ds_max=0.1)


def _equilibrium(plane: Plane, x: float, y: float) -> np.ndarray | None:
    try:
        return solve(plane.scene_at(x, y)).theta
    except (EquilibriumError, PathError):
        return None


def seed_folds(plane: Plane, box, lines: int = 5) -> list[tuple[np.ndarray, float, float, np.ndarray]]:
    """Folds (theta, x, y, v) of ``lines`` paths in x (at evenly spaced y) and in y (at evenly spaced x),
    each traced from the box's low end to one span beyond its high end (a path that reaches a fold
    beyond the box comes back into it through the fold's partner; a curve seeded outside is
    followed while it comes nearer the box)."""
    (xlo, xhi), (ylo, yhi) = box
    seeds = []
    for y in np.linspace(ylo, yhi, lines):
        theta = _equilibrium(plane, xlo, y)
        if theta is None:
            continue
        problem = plane.along_x(float(y))
        to = min(xhi + (xhi - xlo), problem.domain[1])
        b = trace(problem, theta, xlo, to=to, options=SEED_OPTIONS)
        seeds += [(f.theta, f.lam, float(y), f.eigenvector) for f in b.folds if f.status == "converged"]
    for x in np.linspace(xlo, xhi, lines):
        theta = _equilibrium(plane, x, ylo)
        if theta is None:
            continue
        problem = plane.along_y(float(x))
        to = min(yhi + (yhi - ylo), problem.domain[1])
        b = trace(problem, theta, ylo, to=to, options=SEED_OPTIONS)
        seeds += [(f.theta, float(x), f.lam, f.eigenvector) for f in b.folds if f.status == "converged"]
    return seeds


def check_box(plane: Plane, box) -> None:
    """Refuse a box wider than the path engine follows (the seeding traces run one span beyond it)."""
    for (lo, hi), prob, axis in ((box[0], plane.px, "x"), (box[1], plane.py, "y")):
        if hi - lo > 0.5 * MAX_SPAN * prob.scale:
            raise PathError(
                f"{axis} range {lo:g}..{hi:g}{prob.unit_short}: at most {0.5 * MAX_SPAN * prob.scale:g}{prob.unit_short} wide "
                f"({0.5 * MAX_SPAN:g} typical sizes of {prob.name})"
            )


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
    box = (tuple(map(float, xrange)), tuple(map(float, yrange)))
    if not (box[0][0] < box[0][1] and box[1][0] < box[1][1]):
        raise PathError(f"ranges {xrange!r}, {yrange!r}: expected FROM < TO for both parameters")
    check_box(plane, box)
    seeds = seed_folds(plane, box, lines) if seeds is None else list(seeds)
    spans = (box[0][1] - box[0][0], box[1][1] - box[1][0])
    curves: list[FoldCurve] = []
    for theta, x, y, v in seeds:
        here = np.concatenate([theta, [x / spans[0], y / spans[1]]])
        on = [np.min(np.linalg.norm(np.column_stack([c.theta, c.xs / spans[0], c.ys / spans[1]]) - here, axis=1)) for c in curves]
        if on and min(on) < 0.05:
            continue
        c = trace_fold_curve(plane, theta, x, y, v, box, options, known=curves, index=len(curves))
        if c is not None and len(c) > 1:
            inside = (c.xs >= box[0][0]) & (c.xs <= box[0][1]) & (c.ys >= box[1][0]) & (c.ys <= box[1][1])
            if inside.any():  # a piece wholly outside the box (seeded beyond it) is not the map's
                curves.append(c)
    return curves


def fold_summary(curves: Sequence[FoldCurve]) -> dict[str, Any]:
    """How many curves, points and special points of each kind."""
    special = [p for c in curves for p in c.special]
    return {
        "curves": len(curves),
        "points": int(sum(len(c) for c in curves)),
        **{kind: sum(1 for p in special if p.kind == kind) for kind in KINDS},
    }


def folds_at(plane: Plane, curves: Sequence[FoldCurve], box, *, x: float | None = None, y: float | None = None, options: FoldOptions | None = None) -> list[float]:
    """Where the fold curves cross the line y = const (the folds of the x-path there; or x = const):
    each crossing of a curve's polyline corrected on the extended system at that y (or x), sorted."""
    if (x is None) == (y is None):
        raise PathError("folds_at: give exactly one of x= or y=")
    opts = options or FoldOptions()
    spans = (box[0][1] - box[0][0], box[1][1] - box[1][0])
    fs = _FoldSystem(plane, spans, opts)
    k = 1 if y is not None else 0
    value = y if y is not None else x
    found = []
    for c in curves:
        along = c.ys if k == 1 else c.xs
        for i in np.flatnonzero(np.sign(along[:-1] - value) * np.sign(along[1:] - value) <= 0):
            w = (value - along[i]) / (along[i + 1] - along[i]) if along[i + 1] != along[i] else 0.0
            th = (1 - w) * c.theta[i] + w * c.theta[i + 1]
            v = (1 - w) * c.v[i] + w * c.v[i + 1]
            xx = (1 - w) * c.xs[i] + w * c.xs[i + 1]
            yy = (1 - w) * c.ys[i] + w * c.ys[i + 1]
            u = fs.join(th, xx if k == 1 else value, value if k == 1 else yy, v / np.linalg.norm(v))
            row = np.zeros(len(u))
            row[fs.n + k] = 1.0
            node = fs.correct(u, row, float(u[fs.n + k]))
            if node is not None:
                _, fx, fy, _ = fs.split(node.u)
                other = fx if k == 1 else fy
                if not any(abs(other - f) <= 1e-9 * max(1.0, abs(f)) for f in found):
                    found.append(other)
    return sorted(found)


__all__ += ["fold_summary", "seed_folds", "SEED_OPTIONS", "folds_at", "check_box"]

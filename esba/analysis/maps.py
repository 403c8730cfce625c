"""Stability maps: how many stable states the actuator has at each point of a plane of two parameters.

:func:`stability_map` traces the fold curves of the plane (:mod:`esba.analysis.folds`), counts the
stable states at one reference point by brute force (:func:`stable_states`, a multistart damped
Newton minimisation of U), and carries the count over the plane: crossing a *stable* fold curve
(a stable and an unstable state meet there) changes it by one, up on the side where the fold's pair
exists (its normal form, :meth:`esba.analysis.folds.FoldCurve.side`), so that each region of the
plane gets its number of stable states without a solve in it. It also follows the quasi-static
history in x (up from the low end and back down) at a set of y and records where it jumps: the
loading and unloading lines.

:func:`check_grid` checks a map against brute force: at the centre of each cell of a K x K grid it
counts the stable states by :func:`stable_states` and compares with the map's count there.

Examples
--------
>>> from esba.model.scene import Scene, Payload
>>> from esba.analysis.folds import Plane
>>> plane = Plane.from_scene(Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),)), "pressure", "payload")
>>> len(stable_states(plane, 0.168, 2.5)), len(stable_states(plane, 0.168, 1.0))
(2, 1)
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Any, Callable, Sequence

import casadi as ca
import numpy as np

from esba.infra.errors import RunError
from esba.infra.report import Report
from esba.model.generated import Model
from esba.model.stability import CRITICAL_TOL
from esba.paths.loading import history
from esba.paths.problem import PathError, PathProblem

from .folds import FoldCurve, FoldOptions, Plane, fold_curves, fold_summary

__all__ = ["StabilityMap", "stability_map", "periodic_map", "periodic_jumps", "MAX_PERIODS", "stable_states", "check_grid", "GridCheck", "count_at", "jump_lines"]

#: Starts per segment of the multistart search (their product, at most MAX_STARTS, is used).
STARTS_PER_SEGMENT = 5
#: The most starts of the multistart search (beyond, a fixed pseudo-random sample of the box).
MAX_STARTS = 400
#: The largest segment angle a start takes, rad (the actuator's states lie below it).
START_HIGH = 2.2
#: Largest max |dU/dtheta| of a stationary point, N mm/rad.
STATES_TOL = 1e-9
#: Point-segment pairs per block when counting crossings (memory: a few arrays of this many doubles).
CROSSING_BLOCK = 1_000_000
#: Two minima closer than this (max over the segments, rad) are one state.
SAME_STATE = 1e-5
#: The most points of one count whose crossings give an impossible count (below 0) recounted by brute force.
MAX_RECOUNTS = 200
#: The most periods a periodic axis (a payload direction) may span: one period is mapped and its
#: fold curves repeated, so the work is that of one period; the curves written grow with the count.
MAX_PERIODS = 1000


# ---------------------------------------------------------------------------------------------
# brute force: every stable state at one point


def _batch(model: Model, m: int) -> ca.Function:
    def build() -> ca.Function:
        th = ca.SX.sym("theta", model.n)
        p = ca.SX.sym("p", len(model.parameters))
        args = ca.vertsplit(p)
        one = ca.Function(
            "esba_multistart", [th, p], [model["energy"](th, *args)[0], model["gradient"](th, *args), ca.vec(model["hessian"](th, *args))], {"cse": True}
        )
        return one.map(m, "serial")

    return model.derived("multistart_map", build, settings=(m,), persist=False)


def _starts(n: int, low: np.ndarray) -> np.ndarray:
    per = [np.linspace(lo + 0.05 * (START_HIGH - lo), START_HIGH, STARTS_PER_SEGMENT) for lo in low]
    if STARTS_PER_SEGMENT**n <= MAX_STARTS:
        grid = np.meshgrid(*per, indexing="ij")
        return np.column_stack([g.ravel() for g in grid])
    rng = np.random.default_rng(20260101)
    return low + 0.05 * (START_HIGH - low) + rng.random((MAX_STARTS, n)) * 0.95 * (START_HIGH - low)


def _evaluate(model: Model, theta: np.ndarray, p: np.ndarray):
    m, n = theta.shape
    fun = _batch(model, m)
    u, g, h = fun(theta.T, p)
    return np.asarray(u).ravel(), np.asarray(g).T, np.asarray(h).T.reshape(m, n, n)


def stable_states(plane: Plane, x: float, y: float, starts: np.ndarray | None = None, max_iterations: int = 200) -> list[np.ndarray]:
    """Every stable equilibrium (local minimum of U) at (x, y) that a damped Newton descent from a grid
    of starts finds, distinct, sorted by total angle.

    The descent takes Newton steps on H with its eigenvalues replaced by their magnitudes (at least
    1e-6 of the largest), at most 0.3 rad, kept inside Eq. 10's domain (at most 90 % of the way to
    its edge) and halved until U decreases (Armijo); a start is done when max |dU/dtheta| <=
    :data:`STATES_TOL` at a positive definite Hessian.
    """
    prob = plane.along_x(y)
    model = prob.model
    p = prob.params(x)
    low = np.full(prob.n, prob.lower_bound(x))
    theta = _starts(prob.n, low) if starts is None else np.array(starts, dtype=float)
    m = len(theta)
    done = np.zeros(m, dtype=bool)
    alive = np.ones(m, dtype=bool)
    u, g, h = _evaluate(model, theta, p)
    for _ in range(max_iterations):
        active = alive & ~done
        if not active.any():
            break
        w, q = np.linalg.eigh(h)
        scale = np.max(np.abs(w), axis=1, keepdims=True)
        w_mod = np.maximum(np.abs(w), 1e-6 * scale)
        d = -np.einsum("mij,mj->mi", q, np.einsum("mji,mj->mi", q, g) / w_mod)
        big = np.max(np.abs(d), axis=1, keepdims=True)
        d = d * np.minimum(1.0, 0.3 / np.maximum(big, 1e-300))
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(d < 0, 0.9 * (theta - low) / -d, np.inf)
        alpha = np.minimum(1.0, np.min(room, axis=1))
        slope = np.einsum("mi,mi->m", g, d)
        trying = active.copy()
        new_theta, new_u, new_g, new_h = theta.copy(), u.copy(), g.copy(), h.copy()
        for _ in range(40):
            if not trying.any():
                break
            cand = theta[trying] + alpha[trying, None] * d[trying]
            cu, cg, ch = _evaluate(model, cand, p)
            good = np.isfinite(cu) & (cu <= u[trying] + 1e-4 * alpha[trying] * slope[trying] + 1e-13 * np.abs(u[trying]))
            idx = np.flatnonzero(trying)
            ok = idx[good]
            new_theta[ok], new_u[ok], new_g[ok], new_h[ok] = cand[good], cu[good], cg[good], ch[good]
            trying[ok] = False
            alpha[idx[~good]] *= 0.5
        alive &= ~trying  # no decrease after 40 halvings: round-off at a minimum, or stuck
        theta, u, g, h = new_theta, new_u, new_g, new_h
        gmax = np.max(np.abs(g), axis=1)
        done |= gmax <= STATES_TOL
    found: list[np.ndarray] = []
    gmax = np.max(np.abs(g), axis=1)
    for k in np.flatnonzero(gmax <= STATES_TOL):
        eig = np.linalg.eigvalsh(0.5 * (h[k] + h[k].T))
        if eig[0] <= CRITICAL_TOL * np.max(np.abs(eig)):
            continue
        if any(np.max(np.abs(theta[k] - f)) <= SAME_STATE for f in found):
            continue
        found.append(theta[k].copy())
    found.sort(key=lambda t: float(np.sum(t)))
    return found


# ---------------------------------------------------------------------------------------------
# counting across fold curves


def _with_cusps(c: FoldCurve, spans) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The curve's points in scaled coordinates with each located cusp inserted at its arclength:
    points (m, 2), side normals (m, 2; NaN at a cusp, where the normal flips), stable (m,), is-a-cusp (m,).

    The side normal flips at a cusp, so that a segment across one would carry the average of two
    opposite normals; with the cusp a point of the polyline no segment spans one.
    """
    pts = np.column_stack([c.xs / spans[0], c.ys / spans[1]])
    side = c.side(spans)
    stable = np.asarray(c.stable, dtype=bool)
    cusp = np.zeros(len(c), dtype=bool)
    s = np.asarray(c.arclength, dtype=float)
    if len(c) < 2 or not np.all(np.diff(s) > 0):
        return pts, side, stable, cusp
    for p in sorted(c.cusps, key=lambda q: q.arclength, reverse=True):  # from the end: earlier indices stay valid
        k = int(np.searchsorted(s, p.arclength))  # s[k - 1] < p.arclength <= s[k]
        if not (0 < k < len(s)) or not math.isfinite(p.arclength):
            continue
        at = np.array([p.x / spans[0], p.y / spans[1]])
        pts = np.insert(pts, k, at, axis=0)
        side = np.insert(side, k, [np.nan, np.nan], axis=0)
        stable = np.insert(stable, k, bool(stable[k - 1] and stable[k]))
        cusp = np.insert(cusp, k, True)
        s = np.insert(s, k, p.arclength)
    return pts, side, stable, cusp


def _segments(curves: Sequence[FoldCurve], spans) -> tuple[np.ndarray, np.ndarray]:
    """The stable fold curves' segments in scaled coordinates, (k, 2, 2), and each one's side normal (k, 2):
    the sum of its ends' normals, or at a cusp (a point of the polyline, see :func:`_with_cusps`) the other end's."""
    segs, sides = [], []
    for c in curves:
        if len(c) < 2:
            continue
        pts, side, stable, cusp = _with_cusps(c, spans)
        finite = np.all(np.isfinite(side), axis=1)
        usable = finite | cusp
        keep = stable[:-1] & stable[1:] & usable[:-1] & usable[1:] & (finite[:-1] | finite[1:])
        known = np.where(finite[:, None], side, 0.0)
        mid = known[:-1] + known[1:]
        segs.append(np.stack([pts[:-1], pts[1:]], axis=1)[keep])
        sides.append(mid[keep])
    if not segs:
        return np.zeros((0, 2, 2)), np.zeros((0, 2))
    return np.concatenate(segs), np.concatenate(sides)


def _crossings(p0: np.ndarray, p1: np.ndarray, segs: np.ndarray, sides: np.ndarray) -> np.ndarray:
    """Signed count of stable-fold crossings of each path segment p0[i] -> p1[i] (+1 into the side with the pair)."""
    if len(segs) == 0:
        return np.zeros(len(p0), dtype=int)
    a, b = segs[:, 0], segs[:, 1]  # (k, 2)
    r = (p1 - p0)[:, None, :]  # (m, 1, 2)
    s = (b - a)[None, :, :]  # (1, k, 2)
    qp = a[None, :, :] - p0[:, None, :]  # (m, k, 2)
    cross = r[..., 0] * s[..., 1] - r[..., 1] * s[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qp[..., 0] * s[..., 1] - qp[..., 1] * s[..., 0]) / cross
        u = (qp[..., 0] * r[..., 1] - qp[..., 1] * r[..., 0]) / cross
    hit = (cross != 0) & (t >= 0) & (t < 1) & (u >= 0) & (u < 1)
    sign = np.sign(r[..., 0] * sides[None, :, 0] + r[..., 1] * sides[None, :, 1])
    return np.sum(np.where(hit, sign, 0), axis=1).astype(int)


def count_at(curves: Sequence[FoldCurve], spans, reference: tuple[float, float, int], x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The number of stable states at the points (x, y): the reference count plus the signed crossings
    of stable fold curves on the way from the reference (first along y, then along x)."""
    segs, sides = _segments(curves, spans)
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    xr, yr, nr = reference
    out = np.empty(len(x), dtype=int)
    chunk = max(1, CROSSING_BLOCK // max(1, len(segs)))  # points per block: bounded memory
    for start in range(0, len(x), chunk):
        xs, ys = x[start : start + chunk], y[start : start + chunk]
        p0 = np.column_stack([np.full_like(xs, xr / spans[0]), np.full_like(ys, yr / spans[1])])
        corner = np.column_stack([np.full_like(xs, xr / spans[0]), ys / spans[1]])
        end = np.column_stack([xs / spans[0], ys / spans[1]])
        out[start : start + chunk] = nr + _crossings(p0, corner, segs, sides) + _crossings(corner, end, segs, sides)
    return out


def _recount(plane: Plane, x: np.ndarray, y: np.ndarray, counts: np.ndarray) -> list[list[float]]:
    """Recount by brute force, in place, where ``counts`` is impossible (below 0): the crossings
    went wrong there (a fold curve traced too coarsely, a cusp not located). Returns [x, y, crossing
    count, brute-force count] per recounted point."""
    bad = np.flatnonzero(counts < 0)
    if len(bad) > MAX_RECOUNTS:
        raise RunError(
            f"the stability map counts below 0 stable states at {len(bad)} points (at most {MAX_RECOUNTS} are recounted by brute force): "
            "its fold curves are traced too coarsely; try a smaller box"
        )
    done = []
    for i in bad:
        n = len(stable_states(plane, float(x[i]), float(y[i])))
        done.append([float(x[i]), float(y[i]), int(counts[i]), n])
        counts[i] = n
    return done


def _distance_to_curves(curves: Sequence[FoldCurve], spans, x: float, y: float) -> float:
    best = math.inf
    for c in curves:
        if len(c):
            best = min(best, float(np.min(np.hypot((c.xs - x) / spans[0], (c.ys - y) / spans[1]))))
    return best


# ---------------------------------------------------------------------------------------------
# loading and unloading


def jump_lines(plane: Plane, xrange, yrange, lines: int = 21) -> dict[str, list[list[float]]]:
    """Where the quasi-static history in x jumps, at ``lines`` values of y: ``loading`` (x rising from
    its low end) and ``unloading`` (x falling back), each a list of [x, y]."""
    from esba.statics.equilibrium import EquilibriumError, solve

    out: dict[str, list[list[float]]] = {"loading": [], "unloading": []}
    for y in np.linspace(yrange[0], yrange[1], lines):
        try:
            theta = solve(plane.scene_at(xrange[0], float(y))).theta
            ramps = history(plane.along_x(float(y)), theta, xrange[0], [xrange[1], xrange[0]])
        except (EquilibriumError, PathError):
            continue
        for name, ramp in zip(("loading", "unloading"), ramps):
            out[name] += [[float(j.lam), float(y)] for j in ramp.jumps]
    return out


# ---------------------------------------------------------------------------------------------
# the map


@dataclass(frozen=True, eq=False, repr=False)
class StabilityMap(Report):
    """A stability map: the fold curves of the plane, the number of stable states on a raster, the jump lines.

    ``reference`` (x, y, count): where the count was anchored by brute force; ``grid_x``, ``grid_y``
    the raster's coordinates and ``counts`` (len(grid_y), len(grid_x)) the number of stable states;
    ``jumps`` the loading and unloading lines; ``seconds`` the time of each part; ``recounted`` the
    raster points (x, y, crossing count, brute-force count) where the crossings gave an impossible
    count (below 0) and brute force counted instead.
    """

    plane: Plane
    xrange: tuple[float, float]
    yrange: tuple[float, float]
    curves: tuple[FoldCurve, ...]
    reference: tuple[float, float, int]
    grid_x: np.ndarray
    grid_y: np.ndarray
    counts: np.ndarray
    jumps: dict[str, list[list[float]]]
    seconds: dict[str, float]
    recounted: tuple[tuple[float, float, int, int], ...] = ()
    #: For an axis that spans more than its period (a direction past a turn): the map of one period
    #: (its fold curves traced once, :attr:`curves` its copies over the range) and the periods (x, y).
    base: StabilityMap | None = None
    periods: tuple[float | None, float | None] = (None, None)

    _plotter = "esba.figures.results:draw_stability_map"

    def headline(self) -> str:
        """One line: the two parameters, their ranges, the fold curves and cusps."""
        (x, y), (ux, uy) = self.names, self.plane.units
        cusps = sum(1 for p in self.special if p.kind == "cusp")
        return (f"{x} {self.xrange[0]:g}..{self.xrange[1]:g} {ux} by {y} {self.yrange[0]:g}..{self.yrange[1]:g} {uy}: "
                f"{len(self.curves)} fold curve{'s' if len(self.curves) != 1 else ''}, {cusps} cusp{'s' if cusps != 1 else ''}, "
                f"{int(self.counts.min())} to {int(self.counts.max())} stable states")

    def summary(self) -> str:
        """The text ``esba map`` prints for this map (without its files)."""
        return map_table({**self.to_dict(points=False), "scene": self.plane.scene.describe()})

    @property
    def spans(self) -> tuple[float, float]:
        return (self.xrange[1] - self.xrange[0], self.yrange[1] - self.yrange[0])

    @property
    def names(self) -> tuple[str, str]:
        return self.plane.names

    @property
    def special(self):
        return [p for c in self.curves for p in c.special]

    def count(self, x, y) -> np.ndarray:
        """The number of stable states the map gives at the points (x, y) (by brute force where the
        crossings give an impossible count, below 0)."""
        x = np.asarray(x, dtype=float).ravel()
        y = np.asarray(y, dtype=float).ravel()
        if self.base is not None:  # the same state count one period on
            return self.base.count(*self._fold(x, y))
        counts = count_at(self.curves, self.spans, self.reference, x, y)
        _recount(self.plane, x, y, counts)
        return counts

    def distance(self, x: float, y: float) -> float:
        """Distance from (x, y) to the nearest fold curve point, in spans (of one period, on a periodic axis)."""
        if self.base is not None:
            fx, fy = self._fold(np.array([x]), np.array([y]))
            return self.base.distance(float(fx[0]), float(fy[0]))
        return _distance_to_curves(self.curves, self.spans, x, y)

    def stable_summary(self) -> dict[str, Any]:
        """The fewest and most stable states on the raster and the fraction with more than one; on a
        periodic axis past its period, those of one period's raster (the same over the whole range:
        a coarse raster of many periods would sample each at the same few phases)."""
        counts = self.counts if self.base is None else self.base.counts
        return {
            "max": int(np.max(counts)) if counts.size else 0,
            "min": int(np.min(counts)) if counts.size else 0,
            "fraction_multistable": float(np.mean(counts > 1)) if counts.size else 0.0,
        }

    def _fold(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(x, y) taken into the base period's window (the axes that are not periodic as they are)."""
        assert self.base is not None
        out = []
        for v, period, lo in ((x, self.periods[0], self.base.xrange[0]), (y, self.periods[1], self.base.yrange[0])):
            out.append(v if period is None else lo + np.mod(v - lo, period))
        return out[0], out[1]

    def to_dict(self, points: bool = False) -> dict[str, Any]:
        nx, ny = self.names
        return {
            "x": {"parameter": nx, "unit": self.plane.units[0], "from": self.xrange[0], "to": self.xrange[1], "period": self.periods[0]},
            "y": {"parameter": ny, "unit": self.plane.units[1], "from": self.yrange[0], "to": self.yrange[1], "period": self.periods[1]},
            "periodic": None if self.base is None else {
                "mapped": {nx: list(self.base.xrange), ny: list(self.base.yrange)},
                "curves_per_period": len(self.base.curves),
                "text": "; ".join(f"{name} is periodic ({period:g} {unit}): one period mapped, its fold curves repeated over {span / period:.4g} periods"
                                  for name, unit, period, span in zip(self.names, self.plane.units, self.periods, self.spans) if period is not None),
            },
            "summary": fold_summary(self.curves),
            "special_points": [p.to_dict(self.names) for p in self.special],
            "fold_curves": [c.to_dict(points) for c in self.curves],
            "reference": {nx: self.reference[0], ny: self.reference[1], "stable_states": self.reference[2]},
            "stable_states": self.stable_summary(),
            "recounted": [{nx: r[0], ny: r[1], "crossings": r[2], "brute_force": r[3]} for r in self.recounted],
            "jumps": self.jumps,
            "seconds": self.seconds,
        }


def stability_map(
    plane: Plane,
    xrange: tuple[float, float],
    yrange: tuple[float, float],
    *,
    resolution: int = 101,
    history_lines: int = 21,
    options: FoldOptions | None = None,
    progress: Callable[[str], None] | None = None,
) -> StabilityMap:
    """The stability map of ``plane`` over xrange x yrange (see the module).

    A periodic axis (a payload direction, 360 deg) that spans more than its period is mapped over
    one period from its low end, and the map repeated: the fold curves are traced once and copied
    a period on, the counts taken modulo the period (:func:`periodic_map`).
    """
    say = progress or (lambda msg: None)
    xrange = (float(xrange[0]), float(xrange[1]))
    yrange = (float(yrange[0]), float(yrange[1]))
    periods = tuple(_period(prob, r) for prob, r in ((plane.px, xrange), (plane.py, yrange)))
    if any(p is not None for p in periods):
        return periodic_map(plane, xrange, yrange, periods, resolution=resolution, history_lines=history_lines, options=options, progress=say)
    seconds = {}
    t = time.perf_counter()
    say("fold curves")
    curves = tuple(fold_curves(plane, xrange, yrange, options))
    seconds["fold_curves"] = time.perf_counter() - t
    spans = (xrange[1] - xrange[0], yrange[1] - yrange[0])
    t = time.perf_counter()
    say("stable states at the reference point")
    # the reference: the corner, or the first of a few points clear of every fold curve
    candidates = [(xrange[0], yrange[0]), (xrange[1], yrange[0]), (xrange[0], yrange[1]), (xrange[1], yrange[1])]
    ref = max(candidates, key=lambda c: _distance_to_curves(curves, spans, *c))
    reference = (ref[0], ref[1], len(stable_states(plane, *ref)))
    seconds["reference"] = time.perf_counter() - t
    t = time.perf_counter()
    gx = np.linspace(xrange[0], xrange[1], resolution)
    gy = np.linspace(yrange[0], yrange[1], resolution)
    mx, my = np.meshgrid(gx, gy)
    counts = count_at(curves, spans, reference, mx, my)
    recounted = _recount(plane, mx.ravel(), my.ravel(), counts)
    if recounted:
        say(f"{len(recounted)} raster points counted below 0 stable states by the crossings: recounted by brute force")
    counts = counts.reshape(mx.shape)
    seconds["regions"] = time.perf_counter() - t
    t = time.perf_counter()
    say("loading and unloading")
    jumps = jump_lines(plane, xrange, yrange, history_lines) if history_lines else {"loading": [], "unloading": []}
    seconds["jumps"] = time.perf_counter() - t
    return StabilityMap(plane, xrange, yrange, curves, reference, gx, gy, counts, jumps, seconds, tuple(tuple(r) for r in recounted))


def _period(prob: PathProblem, span: tuple[float, float]) -> float | None:
    """The period of the axis when the range spans more than one (else None); refused past :data:`MAX_PERIODS`."""
    period = prob.period
    if period is None or span[1] - span[0] <= period:
        return None
    periods = (span[1] - span[0]) / period
    if periods > MAX_PERIODS:
        raise PathError(
            f"{prob.name} range {span[0]:g}..{span[1]:g}{prob.unit_short}: {periods:.4g} periods of {period:g}{prob.unit_short}; "
            f"expected at most {MAX_PERIODS} (the map repeats every {period:g}{prob.unit_short}: map one period)"
        )
    return float(period)


def _shifted(c: FoldCurve, dx: float, dy: float, index: int) -> FoldCurve:
    special = tuple(replace(p, x=p.x + dx, y=p.y + dy, curve=index) for p in c.special)
    return replace(c, xs=c.xs + dx, ys=c.ys + dy, special=special, index=index)


def _copies(lo: float, hi: float, period: float | None, base_lo: float) -> list[float]:
    """The shifts k * period of the copies of one period's window [base_lo, base_lo + period] that meet [lo, hi]."""
    if period is None:
        return [0.0]
    return [k * period for k in range(int(math.ceil((hi - base_lo) / period)))]


def periodic_jumps(plane: Plane, xrange, yrange, period: float | None, lines: int) -> dict[str, list[list[float]]]:
    """:func:`jump_lines` when x is periodic and spans more than two periods: the history is
    followed over two periods (up from the low end, then back down). Rising, its jumps in the first
    period are kept as they are and those of the second, where the history repeats itself each
    turn, are copied a period on up to the high end; falling, those of the second period down (the
    lower one) are copied over the range."""
    lo, hi = xrange
    if period is None or hi - lo <= 2 * period:
        return jump_lines(plane, xrange, yrange, lines)
    raw = jump_lines(plane, (lo, lo + 2 * period), yrange, lines)

    def repeat(jumps: list[list[float]]) -> list[list[float]]:
        out = []
        for x, y in jumps:
            out += [[x + k * period, y] for k in range(int((hi - x) // period) + 1)]
        return out

    loading = [j for j in raw["loading"] if j[0] < lo + period] + repeat([j for j in raw["loading"] if j[0] >= lo + period])
    unloading = repeat([j for j in raw["unloading"] if j[0] < lo + period])
    return {"loading": sorted(loading), "unloading": sorted(unloading, reverse=True)}


def periodic_map(
    plane: Plane,
    xrange: tuple[float, float],
    yrange: tuple[float, float],
    periods: tuple[float | None, float | None],
    *,
    resolution: int = 101,
    history_lines: int = 21,
    options: FoldOptions | None = None,
    progress: Callable[[str], None] | None = None,
) -> StabilityMap:
    """The map over a range of a periodic axis longer than its period: :func:`stability_map` of one
    period from the low end (fold curves, reference, counts), its curves copied a period on over the
    range, the raster's counts those of the same point one period back, the jump lines from
    :func:`periodic_jumps`. The work is that of one period (and two of history), whatever the range."""
    say = progress or (lambda msg: None)
    px, py = periods
    bx = xrange if px is None else (xrange[0], xrange[0] + px)
    by = yrange if py is None else (yrange[0], yrange[0] + py)
    for name, unit, period, r in zip(plane.names, plane.units, periods, (xrange, yrange)):
        if period is not None:
            say(f"{name} is periodic ({period:g} {unit}): one period mapped, repeated over {(r[1] - r[0]) / period:.4g} periods")
    t = time.perf_counter()
    base = stability_map(plane, bx, by, resolution=resolution, history_lines=0, options=options, progress=progress)
    curves = []
    for dx in _copies(*xrange, px, bx[0]):
        for dy in _copies(*yrange, py, by[0]):
            for c in base.curves:
                xs, ys = c.xs + dx, c.ys + dy
                if np.any((xs >= xrange[0]) & (xs <= xrange[1]) & (ys >= yrange[0]) & (ys <= yrange[1])):
                    curves.append(_shifted(c, dx, dy, len(curves)))
    gx = np.linspace(xrange[0], xrange[1], resolution)
    gy = np.linspace(yrange[0], yrange[1], resolution)
    mx, my = np.meshgrid(gx, gy)
    smap = StabilityMap(plane, xrange, yrange, tuple(curves), base.reference, gx, gy, np.zeros(mx.shape, dtype=int), {}, {}, base.recounted,
                        base=base, periods=(px, py))
    counts = smap.count(mx.ravel(), my.ravel()).reshape(mx.shape)
    seconds = dict(base.seconds)
    say("loading and unloading")
    tj = time.perf_counter()
    jumps = periodic_jumps(plane, xrange, yrange, px, history_lines) if history_lines else {"loading": [], "unloading": []}
    seconds["jumps"] = time.perf_counter() - tj
    seconds["total"] = time.perf_counter() - t
    return replace(smap, counts=counts, jumps=jumps, seconds=seconds, recounted=base.recounted)


# ---------------------------------------------------------------------------------------------
# the check against brute force


@dataclass(frozen=True)
class GridCheck:
    """The map against brute force on a K x K grid of cell centres.

    ``cells``: per cell [x, y, map count, brute-force count, distance to the nearest fold curve
    (spans)]; a cell within ``near`` of a fold curve is compared too but reported apart
    (``near_mismatches``), since the count there changes within the cell.
    """

    k: int
    cells: list[list[float]]
    mismatches: int
    near_mismatches: int
    near: float
    seconds: float

    @property
    def agrees(self) -> bool:
        return self.mismatches == 0

    def to_dict(self) -> dict[str, Any]:
        return {
            "k": self.k,
            "cells": [{"x": c[0], "y": c[1], "map": int(c[2]), "brute_force": int(c[3]), "distance_to_fold": c[4]} for c in self.cells],
            "mismatches": self.mismatches,
            "near_mismatches": self.near_mismatches,
            "near": self.near,
            "agrees": self.agrees,
            "seconds": self.seconds,
        }


def check_grid(smap: StabilityMap, k: int, near: float = 0.01) -> GridCheck:
    """Count the stable states by :func:`stable_states` at the centres of a k x k grid and compare with the map."""
    t = time.perf_counter()
    xs = smap.xrange[0] + (np.arange(k) + 0.5) * smap.spans[0] / k
    ys = smap.yrange[0] + (np.arange(k) + 0.5) * smap.spans[1] / k
    cells, bad, bad_near = [], 0, 0
    for y in ys:
        for x in xs:
            mapped = int(smap.count([x], [y])[0])
            brute = len(stable_states(smap.plane, float(x), float(y)))
            dist = smap.distance(float(x), float(y))
            if mapped != brute:
                if dist < near:
                    bad_near += 1
                else:
                    bad += 1
            cells.append([float(x), float(y), mapped, brute, dist])
    return GridCheck(k, cells, bad, bad_near, near, time.perf_counter() - t)


#: The most fold curves ``esba map`` lists (a periodic axis over many turns repeats them).
MAX_LISTED = 20


def map_table(d: dict) -> str:
    """The text ``esba map`` prints for :meth:`StabilityMap.to_dict` (with ``scene``, and the ``check_grid``, ``out`` and ``figure`` the command adds)."""

    x, y = d["x"], d["y"]
    ux = f" {x['unit']}" if x["unit"] and x["unit"] != "1" else ""
    uy = f" {y['unit']}" if y["unit"] and y["unit"] != "1" else ""
    s = d["summary"]
    lines = [
        f"scene: {d['scene']}",
        f"map of {x['parameter']} {x['from']:g}..{x['to']:g}{ux} by {y['parameter']} {y['from']:g}..{y['to']:g}{uy}",
        f"fold curves: {s['curves']} ({s['points']} points); cusps: {s['cusp']}; "
        f"fold/branch-point meetings: {s['branch point of the x-path'] + s['branch point of the y-path']}",
    ]
    if d.get("periodic"):
        lines.append(d["periodic"]["text"] + f" ({d['periodic']['curves_per_period']} curves a period)")
    for c in d["fold_curves"][:MAX_LISTED]:
        lines.append(f"  curve {c['index']}: {c['points']} points, {x['parameter']} {c['x_range'][0]:.6g}..{c['x_range'][1]:.6g}{ux}, "
                     f"{y['parameter']} {c['y_range'][0]:.6g}..{c['y_range'][1]:.6g}{uy}; {c['stop_reason']}")
    if len(d["fold_curves"]) > MAX_LISTED:
        lines.append(f"  ... {len(d['fold_curves']) - MAX_LISTED} more curves (--out FILE lists them)")
    for p in d["special_points"][:2 * MAX_LISTED]:
        lines.append(f"  {p['label']:3} {p['kind']:<27} {x['parameter']} = {p[x['parameter']]:.10g}{ux}, {y['parameter']} = {p[y['parameter']]:.10g}{uy}, "
                     f"total angle {p['total_angle_deg']:.3f} deg  {p['status']}")
    if len(d["special_points"]) > 2 * MAX_LISTED:
        lines.append(f"  ... {len(d['special_points']) - 2 * MAX_LISTED} more special points (--out FILE.json lists them)")
    st = d["stable_states"]
    lines.append(f"stable states: {st['min']} to {st['max']}; more than one on {100 * st['fraction_multistable']:.1f}% of the map "
                 f"(anchored by brute force at {x['parameter']} = {d['reference'][x['parameter']]:g}, {y['parameter']} = {d['reference'][y['parameter']]:g}: "
                 f"{d['reference']['stable_states']})")
    if d.get("recounted"):
        lines.append(f"counted by brute force at {len(d['recounted'])} raster points where the fold-curve crossings gave fewer than 0 stable states")
    for name in ("loading", "unloading"):
        pts = d["jumps"][name]
        if pts:
            lines.append(f"{x['parameter']} {'rising' if name == 'loading' else 'falling'}: jumps at " + ", ".join(f"{p[0]:.6g}{ux} ({y['parameter']} {p[1]:.4g})" for p in pts))
    if d.get("check_grid"):
        g = d["check_grid"]
        lines.append(f"check against brute force on a {g['k']} x {g['k']} grid: {g['k'] ** 2 - g['mismatches'] - g['near_mismatches']} cells agree, "
                     f"{g['mismatches']} disagree, {g['near_mismatches']} disagree within {g['near']:g} of a fold curve")
    for k in ("out", "figure"):
        if d.get(k):
            lines.append(f"wrote {d[k]}")
    return "\n".join(lines)

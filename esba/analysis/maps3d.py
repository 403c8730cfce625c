"""Stability maps in 3-D: where the actuator stays in its plane, flips sideways, or snaps.

A planar map (:mod:`esba.analysis.maps`) counts stable states. In space a load can also turn the
finger out of its plane: a branch point of the in-plane states (lateral-torsional buckling: the
3n x 3n Hessian loses a sideways-twist mode while the in-plane block stays positive), or, for a
load that points out of the plane, the fold of the imperfect branch and a twist that grows with
the load. So a 3-D map classifies the state each point of the plane reaches along the
**history** "pressurise, then raise the payload from 0 to its magnitude" (the principal state):

==========  ===============================================================================
class       meaning
==========  ===============================================================================
in plane    stable all the way; the total twist |sum(tau_i)| at the end is within the bound
twisted     stable all the way, but twisted beyond the bound (the finger turned sideways)
flips       the state lost stability on the way at a sideways mode (a branch point; or the
            fold of the imperfect branch under an off-plane load): it flips sideways
snaps       the state lost stability on the way at an in-plane mode (a fold): it snaps
==========  ===============================================================================

The gripper's three regions are *stays in its plane* (in plane), *flips sideways* (twisted or
flips) and *snaps*.

Along the ramp (:func:`principal`) the equilibrium is continued by Newton's method with a secant
predictor; a step is accepted when it converges, moves no joint more than :data:`MAX_MOVE` and
leaves the Hessian positive definite, else it is halved. Where a converged step crosses to an
indefinite Hessian the crossing is a **branch point** (the branch goes on through it), located by
Brent's method on the smallest eigenvalue; where the steps shrink below :data:`MIN_STEP` with no
state beyond, it is a **fold**, located by Newton on the extended system (:func:`esba.statics.spatial.fold3d`).
Which way it goes is the critical mode's: sideways when its out-of-plane part (psi, tau) is the
larger. The map's boundaries are located between raster cells of different class by Brent's
method on the critical load minus the load (stability boundaries) or on the twist minus the bound.

:func:`check_grid3d` checks a map cell by cell against brute force: at each cell centre a fixed
fine ramp (:data:`BRUTE_STEPS` equal steps of the damped :func:`esba.statics.spatial.newton3d`, no
step control, no location) classifies the cell again, and a multistart (damped Newton descents from
:data:`BRUTE_STARTS` starts bent, sideways and twisted) counts the stable 3-D states there and must
find the principal state among them where it is stable.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Mapping

import numpy as np

from esba.infra.errors import InputError
from esba.model.scene import Scene

__all__ = [
    "AXES3D", "CLASSES", "REGIONS", "Map3DError", "Plane3D", "Outcome", "principal", "Boundary", "StabilityMap3D",
    "stability_map3d", "GridCheck3D", "check_grid3d", "map3d_table", "DEFAULT_MAX_TWIST_DEG", "Curves3D", "curves3d", "curves_plane",
]

#: The parameters of a 3-D map: (unit, what it is). A payload's direction "around" the actuator turns
#: the scene's payload direction about the base axis x (0: the scene's, 90: out of the plane toward +z).
AXES3D = {
    "pressure": ("MPa", "the pressure"),
    "payload": ("N", "the payload's magnitude"),
    "omega": ("deg", "the payload's in-plane angle Omega from the vertical"),
    "beta": ("deg", "the payload's angle Beta out of the bending plane"),
    "around": ("deg", "the payload's direction turned about the actuator's base axis from the scene's"),
    "at": ("1", "the payload's point, a fraction of L"),
}
#: The classes of a cell (see the module), by code.
CLASSES = ("in plane", "twisted", "flips", "snaps")
#: The gripper's regions, by class code.
REGIONS = {0: "stays in its plane", 1: "flips sideways", 2: "flips sideways", 3: "snaps"}
#: Default bound on the total twist |sum(tau_i)|, degrees.
DEFAULT_MAX_TWIST_DEG = 10.0
#: Largest change of a joint angle in one accepted step of the ramp, rad (beyond: a jump).
MAX_MOVE = 0.2
#: Ramp steps at the start (the step grows by 1.5 after an accepted one, up to this many per ramp).
RAMP_STEPS = 16
#: Smallest ramp step, relative to the ramp's top: below it the state is lost at a fold.
MIN_STEP = 1e-7
#: Newton's tolerance on max |gradient|, relative to max |Hessian|.
NEWTON_TOL = 1e-12
#: Fine ramp and multistart of the brute-force check.
BRUTE_STEPS = 120
BRUTE_STARTS = (5, 3, 3)  # bend angles x sideways x twist
#: Two stable states closer than this (max over the joints, rad) are one.
SAME_STATE = 1e-5


class Map3DError(InputError):
    """A bad input to a 3-D map (one line naming it)."""


def _axis_value(name: str, v: float) -> None:
    if name in ("pressure", "payload") and v < 0:
        raise Map3DError(f"{name} {v:g}: expected >= 0 ({AXES3D[name][0]})")
    if name == "beta" and not -90.0 <= v <= 90.0:
        raise Map3DError(f"beta {v:g}: expected an angle from -90 to 90 degrees")
    if name == "at" and not 0.0 < v <= 1.0:
        raise Map3DError(f"at {v:g}: expected a fraction of L in (0, 1]")


@dataclass(frozen=True, eq=False)
class Plane3D:
    """Two parameters (:data:`AXES3D`) of a scene with one payload, in the 3-D model.

    ``section``: EI_side and GJ (N mm^2); those not given are the eccentric section's
    (:func:`esba.statics.spatial.check_section`). ``max_twist``: the twist bound, rad.
    """

    scene: Scene
    x: str
    y: str
    section: Mapping[str, float]
    max_twist: float
    model: Any
    base: Mapping[str, float]

    @classmethod
    def from_scene(cls, scene: Scene, x: str, y: str, section: Mapping[str, float] | None = None, max_twist_deg: float = DEFAULT_MAX_TWIST_DEG) -> Plane3D:
        from esba.model.spatial import load_model3d
        from esba.statics.spatial import check_section, scene_values3d

        for flag, name in (("--x", x), ("--y", y)):
            if name not in AXES3D:
                raise Map3DError(f"{flag} {name!r}: unknown 3-D map parameter; allowed are {', '.join(AXES3D)}")
        if x == y:
            raise Map3DError(f"--x and --y are both {x!r}: a map needs two different parameters")
        if "around" in (x, y) and ({"omega", "beta"} & {x, y}):
            raise Map3DError("around turns the payload's direction (both of its angles): it cannot be mapped against omega or beta")
        if len(scene.payloads) != 1:
            raise Map3DError(f"payloads: {len(scene.payloads)} given; a 3-D map takes a scene with exactly one payload (its magnitude is ramped)")
        if scene.gravity:
            raise Map3DError("gravity: a 3-D map takes the payload as its only load (no --gravity)")
        t = float(max_twist_deg)
        if not (math.isfinite(t) and 0.0 < t < 180.0):
            raise Map3DError(f"--max-twist {max_twist_deg!r}: expected an angle in (0, 180) degrees")
        sec = check_section(section, scene)
        effects, values = scene_values3d(scene, sec, scene.down())
        model = load_model3d(scene.segments, effects, scene.variant)
        return cls(scene, x, y, dict(sec), math.radians(t), model, dict(values))

    @property
    def names(self) -> tuple[str, str]:
        return self.x, self.y

    @property
    def units(self) -> tuple[str, str]:
        return AXES3D[self.x][0], AXES3D[self.y][0]

    @property
    def n(self) -> int:
        return self.model.n

    def check_range(self, flag: str, name: str, lo: float, hi: float) -> None:
        for v in (lo, hi):
            try:
                _axis_value(name, v)
            except Map3DError as exc:
                raise Map3DError(f"{flag} {name}:{lo:g}:{hi:g}: {exc}") from None

    def values(self, x: float, y: float) -> dict[str, float]:
        """The model's parameter values at (x, y)."""
        v = dict(self.base)
        for name, val in ((self.x, x), (self.y, y)):
            if name == "pressure":
                v["P"] = val
            elif name == "payload":
                v["F1"] = val
            elif name == "omega":
                v["Omega1"] = math.radians(val)
            elif name == "beta":
                v["Beta1"] = math.radians(val)
            elif name == "at":
                v["s1"] = val
            elif name == "around":
                om, be = self.base["Omega1"], self.base["Beta1"]
                d0 = np.array([math.cos(be) * math.cos(om), -math.cos(be) * math.sin(om), math.sin(be)])
                c, s = math.cos(math.radians(val)), math.sin(math.radians(val))
                d = np.array([d0[0], c * d0[1] - s * d0[2], s * d0[1] + c * d0[2]])  # turned about x, -y toward +z
                v["Beta1"] = math.asin(max(-1.0, min(1.0, float(d[2]))))
                v["Omega1"] = math.atan2(-float(d[1]), float(d[0]))
        return v

    def in_plane(self, values: Mapping[str, float]) -> bool:
        """True when the payload lies in the bending plane (the plane is then a symmetry)."""
        return math.sin(values["Beta1"]) == 0.0 or values["F1"] == 0.0

    def describe(self) -> str:
        return (f"{self.scene.describe()}; EI_side {self.section['EI_side']:.6g} N mm^2, GJ {self.section['GJ']:.6g} N mm^2; "
                f"twist bound {math.degrees(self.max_twist):g} deg")


# ---------------------------------------------------------------------------------------------
# the principal state: pressurise, then raise the payload


@dataclass
class Outcome:
    """The principal state at one point: its class code (:data:`CLASSES`), the load ``critical`` (N)
    at which it loses stability on the way up to ``top`` (inf when it does not), the kind of that
    point (``"fold"``, ``"branch point"`` or ``"fold (not located)"``), the out-of-plane share of its
    mode, and the states at the recorded loads (load -> q)."""

    critical: float
    kind: str
    sideways_share: float
    mode: np.ndarray | None
    q_critical: np.ndarray | None
    states: dict[float, np.ndarray] = field(default_factory=dict)

    def lost_sideways(self) -> bool:
        return self.sideways_share > 0.5


def _newton(fun, p: np.ndarray, q: np.ndarray, lb: np.ndarray, max_iter: int = 12) -> tuple[np.ndarray, bool, np.ndarray]:
    """Plain Newton from q (converges to the nearby equilibrium, stable or not): (q, ok, Hessian)."""
    q = np.array(q, dtype=float)
    for _ in range(max_iter):
        _, g, h = fun(q, p)
        g, h = np.asarray(g).ravel(), np.asarray(h)
        if not np.all(np.isfinite(g)):
            return q, False, h
        if float(np.abs(g).max()) <= NEWTON_TOL * max(1.0, float(np.abs(h).max())):
            return q, True, h
        try:
            step = np.linalg.solve(h, -g)
        except np.linalg.LinAlgError:
            return q, False, h
        q = q + step
        if not (np.all(np.isfinite(q)) and np.all(q > lb)):
            return q, False, h
    return q, False, h


def _unloaded(plane: Plane3D, values: Mapping[str, float]) -> np.ndarray:
    from esba.statics.spatial import _bounds, newton3d

    vals = dict(values, F1=0.0)
    q, ok, _ = newton3d(plane.model, vals, np.zeros(plane.model.size), lb=_bounds(plane.model, vals))
    if not ok:
        raise RuntimeError(f"no unloaded equilibrium at pressure {values['P']:g} MPa")
    return q


def _share(model, v: np.ndarray) -> float:
    v = np.asarray(v, dtype=float)
    total = float(v @ v)
    return float(v[model.n:] @ v[model.n:] / total) if total > 0 else 0.0


def principal(plane: Plane3D, values: Mapping[str, float], top: float, record=()) -> Outcome:
    """The principal state at ``values`` with the payload raised from 0 to ``top`` (see the module);
    the states at the loads in ``record`` (<= top) are kept."""
    vals = dict(values)
    return follow(plane, vals, "F1", 0.0, top, _unloaded(plane, vals), record)


def follow(plane: Plane3D, values: Mapping[str, float], param: str, start: float, end: float, q0, record=()) -> Outcome:
    """The stable equilibrium from ``q0`` (at ``param`` = ``start``) continued toward ``end``, until
    it loses stability (see the module): an :class:`Outcome` whose ``critical`` is the value of
    ``param`` there (inf when it stays stable to ``end``); the states at the values in ``record`` are kept."""
    from scipy.optimize import brentq

    from esba.statics.spatial import _bounds, fold3d

    model = plane.model
    vals = dict(values)
    vals[param] = start
    lb = _bounds(model, vals)
    fun = model.state_function()
    index = list(model.parameters).index(param)
    p = model.param_vector(vals)
    sign = 1.0 if end >= start else -1.0
    span = abs(end - start)
    scale = max(abs(start), abs(end), 1e-300)
    marks = sorted({abs(float(r) - start) for r in record if min(start, end) <= r <= max(start, end)})
    states: dict[float, np.ndarray] = {}
    q = np.array(q0, dtype=float)
    t, rate = 0.0, np.zeros(model.size)

    def value(tt: float) -> float:
        return end if tt == span else start + sign * tt

    if marks and marks[0] == 0.0:
        states[start] = q.copy()
    hmax = span / RAMP_STEPS
    h = hmax
    while t < span:
        nxt = next((m for m in marks if m > t), span)
        h = min(h, nxt - t)
        trial = nxt if h >= nxt - t else t + h  # the marks are hit exactly
        p[index] = value(trial)
        qn, ok, H = _newton(fun, p, q + h * rate, lb)
        moved = float(np.abs(qn - q).max()) if ok else math.inf
        if ok and moved <= MAX_MOVE:
            w, V = np.linalg.eigh(H)
            if w[0] > 0:
                rate = (qn - q) / h
                q, t = qn, trial
                if t == nxt and t in marks:
                    states[value(t) if t != 0 else start] = q.copy()
                h = min(hmax, 1.5 * h)
                continue
            # a converged state past an indefinite Hessian: the branch goes on, a branch point lies between
            qa, lo = q.copy(), t

            def smallest(x: float) -> float:
                pp = p.copy()
                pp[index] = start + sign * x
                qx, okx, Hx = _newton(fun, pp, qa + (x - lo) * rate, lb)
                if not okx:
                    raise RuntimeError("lost the branch inside a bracket")
                return float(np.linalg.eigvalsh(Hx)[0])

            try:
                x_star = brentq(smallest, lo, trial, xtol=1e-15 * scale, rtol=4 * np.finfo(float).eps, maxiter=200)
                pp = p.copy()
                pp[index] = start + sign * x_star
                qs, oks, Hs = _newton(fun, pp, qa + (x_star - lo) * rate, lb)
                w, V = np.linalg.eigh(Hs)
                # a true crossing: the state there is the branch's (close to the last one) and its Hessian singular
                if oks and abs(w[0]) <= 1e-6 * np.abs(w).max() and float(np.abs(qs - qa).max()) <= MAX_MOVE:
                    return Outcome(start + sign * x_star, "branch point", _share(model, V[:, 0]), V[:, 0], qs, states)
            except (RuntimeError, ValueError):
                pass  # fall through: halve as at a fold
        h *= 0.5
        if h < MIN_STEP * max(span, 1e-300):
            vals[param] = start + sign * t
            try:
                x_star, qs, v = fold3d(model, vals, param, q)
                if not (-1e-6 * span <= sign * (x_star - vals[param]) <= 1e-4 * span):
                    raise RuntimeError("fold3d went elsewhere")
                return Outcome(float(x_star), "fold", _share(model, v), v / np.linalg.norm(v), qs, states)
            except RuntimeError:
                w, V = np.linalg.eigh(model.hessian(q, vals))
                return Outcome(vals[param], "fold (not located)", _share(model, V[:, 0]), V[:, 0], q, states)
    return Outcome(math.inf, "", 0.0, None, None, states)


def twist_of(model, q: np.ndarray) -> float:
    """The total twist |sum(tau_i)|, rad."""
    return float(abs(np.sum(np.asarray(q)[2 * model.n:])))


def classify(plane: Plane3D, out: Outcome, load: float) -> int:
    """The class code of the principal state at payload ``load`` (<= the ramp's top, recorded)."""
    if out.critical <= load:
        return 2 if out.lost_sideways() else 3
    q = out.states[load]
    return 1 if twist_of(plane.model, q) > plane.max_twist else 0


# ---------------------------------------------------------------------------------------------
# fold curves and branch-point curves in the map's plane


@dataclass(frozen=True, eq=False)
class Curves3D:
    """The fold curves (:func:`esba.analysis.folds.fold_curves`) and, for loads in the bending plane,
    the branch-point curves of the in-plane state (:func:`esba.analysis.branch_curves.branch_point_curves`)
    of a map's plane, continued in its two parameters; ``notes`` say what was not traced and why."""

    folds: tuple[Any, ...]
    branch_points: tuple[Any, ...]
    notes: tuple[str, ...]
    seconds: float

    def to_dict(self, points: bool = False) -> dict[str, Any]:
        from esba.analysis.branch_curves import KINDS_BP
        from esba.analysis.folds import fold_summary

        return {
            "fold_curves": [c.to_dict(points) for c in self.folds],
            "branch_point_curves": [c.to_dict(points) for c in self.branch_points],
            "fold_summary": fold_summary(self.folds),
            "branch_point_summary": fold_summary(self.branch_points, KINDS_BP),
            "notes": list(self.notes),
            "seconds": self.seconds,
        }


def curves_plane(plane: Plane3D, xrange, yrange):
    """The :class:`esba.analysis.folds.Plane` of a map's two parameters in the 3-D model, refused in
    one line (:class:`Map3DError`) for an axis that is not one model parameter (around) or a box
    wider than the path engine follows."""
    from esba.analysis.folds import Plane, check_box
    from esba.paths.problem import PathError

    for flag, name in (("--x", plane.x), ("--y", plane.y)):
        if name not in _PARAM:
            raise Map3DError(f"{flag} {name}: {name} turns two angles of the payload at once: its fold curves are not traced; map omega or beta instead")
    try:
        folds_plane = Plane.from_scene3d(plane.scene, plane.x, plane.y, plane.section)
        check_box(folds_plane, (tuple(xrange), tuple(yrange)))
    except PathError as exc:
        raise Map3DError(str(exc)) from None
    return folds_plane


def curves3d(plane: Plane3D, xrange, yrange, lines: int = 5) -> Curves3D:
    """The fold curves and (loads in the plane) branch-point curves of the map's plane over the box,
    seeded on ``lines`` paths each way (:class:`Curves3D`)."""
    from esba.analysis.branch_curves import branch_point_curves, check_symmetric
    from esba.analysis.folds import fold_curves
    from esba.paths.problem import PathError

    t0 = time.perf_counter()
    folds_plane = curves_plane(plane, xrange, yrange)
    box = (tuple(map(float, xrange)), tuple(map(float, yrange)))
    folds = fold_curves(folds_plane, *box, lines=max(lines, 2))
    notes = []
    try:
        check_symmetric(folds_plane, box)
        branches = branch_point_curves(folds_plane, *box, lines=max(lines, 2))
    except PathError:
        branches = []
        notes.append("the payload leaves the bending plane: its branch points unfold into folds (the fold curves); no branch-point curves")
    # named as the map's axes (the path problems name a payload's parameters by its number: payload1)
    named = [tuple(replace(c, names=plane.names) for c in cs) for cs in (folds, branches)]
    return Curves3D(named[0], named[1], tuple(notes), time.perf_counter() - t0)


# ---------------------------------------------------------------------------------------------
# the map


@dataclass(frozen=True)
class Boundary:
    """A located point of a region boundary: (x, y), its kind (``fold``, ``branch point``,
    ``sideways fold`` (a fold at a sideways mode), ``twist bound``, or ``... (not located)``), which
    way the boundary was crossed (``"x"`` or ``"y"``), the total angle and twist there (deg)."""

    x: float
    y: float
    kind: str
    along: str
    total_angle_deg: float
    twist_deg: float

    def to_dict(self, names: tuple[str, str]) -> dict[str, Any]:
        return {names[0]: self.x, names[1]: self.y, "kind": self.kind, "along": self.along,
                "total_angle_deg": self.total_angle_deg, "twist_deg": self.twist_deg}


@dataclass(frozen=True, eq=False)
class StabilityMap3D:
    """A 3-D map: the class of every raster point (``classes``, (len(grid_y), len(grid_x)), codes of
    :data:`CLASSES`), the critical load there (``critical``, N; inf where none up to the ramp's top),
    the located boundaries, and the time of each part."""

    plane: Plane3D
    xrange: tuple[float, float]
    yrange: tuple[float, float]
    grid_x: np.ndarray
    grid_y: np.ndarray
    classes: np.ndarray
    critical: np.ndarray
    boundaries: tuple[Boundary, ...]
    seconds: dict[str, float]
    paths: tuple[PathPoint, ...] = ()
    notes: tuple[str, ...] = ()
    curves: Curves3D | None = None

    def path_kinds(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for b in self.paths:
            out[b.kind] = out.get(b.kind, 0) + 1
        return dict(sorted(out.items()))

    @property
    def names(self) -> tuple[str, str]:
        return self.plane.names

    def fractions(self) -> dict[str, float]:
        """The share of the raster in each class."""
        return {name: float(np.mean(self.classes == k)) for k, name in enumerate(CLASSES)}

    def regions(self) -> dict[str, float]:
        """The share of the raster in each of the gripper's regions."""
        out: dict[str, float] = {}
        for k, name in REGIONS.items():
            out[name] = out.get(name, 0.0) + float(np.mean(self.classes == k))
        return out

    def kinds(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for b in self.boundaries:
            out[b.kind] = out.get(b.kind, 0) + 1
        return dict(sorted(out.items()))

    def to_dict(self, raster: bool = False) -> dict[str, Any]:
        nx, ny = self.names
        ux, uy = self.plane.units
        d = {
            "x": {"parameter": nx, "unit": ux, "from": self.xrange[0], "to": self.xrange[1]},
            "y": {"parameter": ny, "unit": uy, "from": self.yrange[0], "to": self.yrange[1]},
            "history": "pressurise, then raise the payload from 0 to its magnitude",
            "twist_bound_deg": math.degrees(self.plane.max_twist),
            "section_nmm2": dict(self.plane.section),
            "classes": self.fractions(),
            "regions": self.regions(),
            "boundary_kinds": self.kinds(),
            "boundaries": [b.to_dict(self.names) for b in self.boundaries],
            "path_kinds": self.path_kinds(),
            "path_points": [b.to_dict(self.names) for b in self.paths],
            "notes": list(self.notes),
            "seconds": self.seconds,
        }
        if self.curves is not None:
            d["curves"] = self.curves.to_dict(points=raster)
        if raster:
            d["raster"] = {"x": self.grid_x.tolist(), "y": self.grid_y.tolist(), "classes": self.classes.tolist(),
                           "critical_n": [[v if math.isfinite(v) else None for v in row] for row in self.critical.tolist()]}
        return d


class _Evaluator:
    """The principal state at points of the plane, memoised; with the payload an axis, one ramp to
    the top of its range per value of the other axis serves that whole line."""

    def __init__(self, plane: Plane3D, xrange, yrange, record=()):
        self.plane = plane
        self.memo: dict[Any, Outcome] = {}
        self.axis = 0 if plane.x == "payload" else (1 if plane.y == "payload" else None)
        self.top = None if self.axis is None else float((xrange, yrange)[self.axis][1])
        self.record = tuple(float(r) for r in record)
        self.ramps = 0

    def outcome(self, x: float, y: float, need_state: bool = True) -> tuple[Outcome, float]:
        """(outcome, the load at (x, y)); with ``need_state`` the state at that load is recorded."""
        vals = self.plane.values(x, y)
        load = vals["F1"]
        if self.axis is None:
            key, top, marks = (x, y), load, {load}
        else:
            key, top, marks = (x, y)[1 - self.axis], self.top, set(self.record) | {load}
        found = self.memo.get(key)
        if found is None or (need_state and load < found.critical and load not in found.states):
            if found is not None:
                marks |= set(found.states)
            found = principal(self.plane, vals, max(top, load), sorted(marks))
            self.ramps += 1
            self.memo[key] = found
        return found, load


def _boundary(ev: _Evaluator, a: tuple[float, float], b: tuple[float, float], ca: int, cb: int, along: str) -> Boundary | None:
    """The boundary between raster points a and b (classes ca != cb), located by Brent's method."""
    from scipy.optimize import brentq

    pl = ev.plane
    stable_a, stable_b = ca in (0, 1), cb in (0, 1)
    if REGIONS[ca] == REGIONS[cb] or (not stable_a and not stable_b):
        return None  # the same region of the gripper (twisted or flipped), or two ways of losing stability meet: not located

    def point(t: float) -> tuple[float, float]:
        return a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])

    if stable_a != stable_b:
        def f(t: float) -> float:
            out, load = ev.outcome(*point(t), need_state=False)
            return min(out.critical, 2.0 * max(load, 1e-300)) - load
        kind_of = "stability"
    else:
        def f(t: float) -> float:
            out, load = ev.outcome(*point(t))
            if out.critical <= load:
                return math.nan
            return twist_of(pl.model, out.states[load]) - pl.max_twist
        kind_of = "twist"
    try:
        fa, fb = f(0.0), f(1.0)
        if not (np.isfinite(fa) and np.isfinite(fb)) or fa * fb > 0:
            return None
        t = brentq(f, 0.0, 1.0, xtol=1e-12, rtol=4 * np.finfo(float).eps, maxiter=100)
    except (RuntimeError, ValueError):
        return None
    x, y = point(t)
    out, load = ev.outcome(x, y)
    if kind_of == "twist":
        q = out.states[load]
        kind = "twist bound"
    else:
        q = out.q_critical
        located = q is not None and abs(out.critical - load) <= 1e-8 * max(1.0, load)
        base = "branch point" if out.kind == "branch point" else ("sideways fold" if out.lost_sideways() else "fold")
        kind = base if located and "not located" not in out.kind else base + " (not located)"
        if q is None:
            return None
    n = pl.n
    return Boundary(float(x), float(y), kind, along, math.degrees(float(np.sum(q[:n]))), math.degrees(float(np.sum(q[2 * n:]))))


#: The model parameter of each axis that is one, and its factor from the axis's unit.
_PARAM = {"pressure": ("P", 1.0), "payload": ("F1", 1.0), "omega": ("Omega1", math.pi / 180.0), "beta": ("Beta1", math.pi / 180.0), "at": ("s1", 1.0)}


@dataclass(frozen=True)
class PathPoint:
    """Where the stable state followed along a line of the map (a path in x at fixed y, or in y at
    fixed x; ``rising`` or ``falling``) loses stability: (x, y), its kind (``fold``: an in-plane
    mode, the actuator snaps; ``sideways fold``: a fold at a sideways mode; ``branch point``: a
    sideways mode of an in-plane state, the plane's symmetry broken), the out-of-plane share of the
    mode, the total angle and twist there (deg)."""

    x: float
    y: float
    along: str
    direction: str
    kind: str
    sideways_share: float
    total_angle_deg: float
    twist_deg: float

    def to_dict(self, names: tuple[str, str]) -> dict[str, Any]:
        return {names[0]: self.x, names[1]: self.y, "along": self.along, "direction": self.direction, "kind": self.kind,
                "sideways_share": self.sideways_share, "total_angle_deg": self.total_angle_deg, "twist_deg": self.twist_deg}


def _kind(out: Outcome) -> str:
    if out.kind == "branch point":
        return "branch point"
    base = "sideways fold" if out.lost_sideways() else "fold"
    return base + (" (not located)" if "not located" in out.kind else "")


def path_points(plane: Plane3D, xrange, yrange, lines: int = 11, axes: tuple[str, ...] = ("x", "y")) -> tuple[list[PathPoint], list[str]]:
    """The first loss of stability along paths in x (at ``lines`` values of y) and in y (at ``lines``
    values of x), each rising from the low end and falling from the high end, started from the
    principal state there: the fold curves and branch points of the map, sampled, each point
    located exactly. Returns the points and notes (axes that are not one model parameter)."""
    out: list[PathPoint] = []
    notes: list[str] = []
    n = plane.n
    for along, (rng, other_rng) in (("x", (xrange, yrange)), ("y", (yrange, xrange))):
        if along not in axes:
            continue
        name = plane.x if along == "x" else plane.y
        if name not in _PARAM:
            notes.append(f"{name} turns two angles of the payload at once: no paths along it (its boundaries are the raster's)")
            continue
        param, factor = _PARAM[name]
        for other in np.linspace(other_rng[0], other_rng[1], lines):
            for direction, (a, b) in (("rising", rng), ("falling", rng[::-1])):
                xy = (a, float(other)) if along == "x" else (float(other), a)
                vals = plane.values(*xy)
                try:
                    F = vals["F1"]
                    if F > 0:
                        first = principal(plane, vals, F, (F,))
                        if first.critical <= F:
                            continue  # the line's start is not stable on the history
                        q0 = first.states[F]
                    else:
                        q0 = _unloaded(plane, vals)
                    res = follow(plane, vals, param, a * factor, b * factor, q0)
                except RuntimeError:
                    continue
                if not math.isfinite(res.critical) or res.q_critical is None:
                    continue
                c = res.critical / factor
                x, y = (c, float(other)) if along == "x" else (float(other), c)
                q = res.q_critical
                out.append(PathPoint(float(x), float(y), along, direction, _kind(res), res.sideways_share,
                                     math.degrees(float(np.sum(q[:n]))), math.degrees(float(np.sum(q[2 * n:])))))
    return out, notes


def stability_map3d(plane: Plane3D, xrange, yrange, *, resolution: int = 21, locate: bool = True, lines: int = 11,
                    progress: Callable[[str], None] | None = None, curves: bool = False) -> StabilityMap3D:
    """The 3-D map of ``plane`` over xrange x yrange on a ``resolution`` x ``resolution`` raster, with
    its boundaries located between raster points (``locate``), and with ``curves`` its fold and
    branch-point curves continued in the two parameters (:func:`curves3d`)."""
    say = progress or (lambda msg: None)
    xrange = (float(xrange[0]), float(xrange[1]))
    yrange = (float(yrange[0]), float(yrange[1]))
    plane.check_range("--x", plane.x, *xrange)
    plane.check_range("--y", plane.y, *yrange)
    if not (xrange[0] < xrange[1] and yrange[0] < yrange[1]):
        raise Map3DError("the map's ranges must have FROM < TO")
    gx = np.linspace(*xrange, resolution)
    gy = np.linspace(*yrange, resolution)
    if "payload" not in plane.names and plane.base["F1"] <= 0:
        raise Map3DError("payload: the scene's payload is 0 N; give --payload F (or map the payload)")
    if curves:
        curves_plane(plane, xrange, yrange)  # refused before the raster
    ev = _Evaluator(plane, xrange, yrange, gy if plane.y == "payload" else (gx if plane.x == "payload" else ()))
    t0 = time.perf_counter()
    say(f"principal states on the {resolution} x {resolution} raster")
    classes = np.zeros((resolution, resolution), dtype=int)
    critical = np.full((resolution, resolution), math.inf)
    for j, y in enumerate(gy):
        for i, x in enumerate(gx):
            out, load = ev.outcome(float(x), float(y))
            classes[j, i] = classify(plane, out, load)
            critical[j, i] = out.critical
    seconds = {"raster": time.perf_counter() - t0}
    boundaries: list[Boundary] = []
    if locate:
        t0 = time.perf_counter()
        say("boundaries")
        for j, y in enumerate(gy):
            for i in range(resolution - 1):
                if classes[j, i] != classes[j, i + 1]:
                    b = _boundary(ev, (float(gx[i]), float(y)), (float(gx[i + 1]), float(y)), classes[j, i], classes[j, i + 1], "x")
                    if b is not None:
                        boundaries.append(b)
        for i, x in enumerate(gx):
            for j in range(resolution - 1):
                if classes[j, i] != classes[j + 1, i]:
                    b = _boundary(ev, (float(x), float(gy[j])), (float(x), float(gy[j + 1])), classes[j, i], classes[j + 1, i], "y")
                    if b is not None:
                        boundaries.append(b)
        seconds["boundaries"] = time.perf_counter() - t0
    seconds["ramps"] = float(ev.ramps)
    points, notes = [], []
    if lines:
        t0 = time.perf_counter()
        say(f"paths along {lines} lines each way")
        points, notes = path_points(plane, xrange, yrange, lines)
        seconds["paths"] = time.perf_counter() - t0
    traced = None
    if curves:
        say("fold and branch-point curves")
        traced = curves3d(plane, xrange, yrange, lines or 5)
        seconds["curves"] = traced.seconds
    return StabilityMap3D(plane, xrange, yrange, gx, gy, classes, critical, tuple(boundaries), seconds, tuple(points), tuple(notes), traced)


# ---------------------------------------------------------------------------------------------
# the check against brute force


def _brute_ramp(plane: Plane3D, values: Mapping[str, float]) -> tuple[int, np.ndarray | None]:
    """The class by a fixed fine ramp of the damped Newton method (no step control): (code, final q or None)."""
    from esba.statics.spatial import _bounds, newton3d

    model = plane.model
    vals = dict(values)
    F = vals["F1"]
    lb = _bounds(model, vals)
    q = _unloaded(plane, vals)
    for lam in np.linspace(0.0, F, BRUTE_STEPS + 1)[1:]:
        vals["F1"] = float(lam)
        qn, ok, _ = newton3d(model, vals, q, lb=lb, max_iter=40)
        w = np.linalg.eigvalsh(model.hessian(qn, vals))[0] if ok else -1.0
        if not ok or w <= 0 or np.abs(qn - q).max() > 2 * MAX_MOVE:
            vals["F1"] = float(lam - F / BRUTE_STEPS)
            wq, V = np.linalg.eigh(model.hessian(q, vals))
            return (2 if _share(model, V[:, 0]) > 0.5 else 3), None
        q = qn
    return (1 if twist_of(model, q) > plane.max_twist else 0), q


def brute_states(plane: Plane3D, values: Mapping[str, float]) -> list[np.ndarray]:
    """Every stable 3-D state at ``values`` that damped Newton descents from a grid of starts find:
    uniform bends 0.1..2.2 rad per joint, sideways bends and twists of 0 and +-0.4 rad per joint."""
    from esba.statics.spatial import _bounds, newton3d

    model, n = plane.model, plane.n
    lb = _bounds(model, values)
    found: list[np.ndarray] = []
    nb, ns, nt = BRUTE_STARTS
    for th in np.linspace(0.1, 2.2, nb) / n:
        for ps in np.linspace(-0.4, 0.4, ns) / n:
            for ta in np.linspace(-0.4, 0.4, nt) / n:
                q0 = np.concatenate([np.full(n, th), np.full(n, ps), np.full(n, ta)])
                q0[:n] = np.maximum(q0[:n], lb[:n] + 1e-3)
                q, ok, _ = newton3d(model, values, q0, lb=lb, max_iter=200)
                if not ok or np.linalg.eigvalsh(model.hessian(q, values))[0] <= 0:
                    continue
                if not any(np.abs(q - f).max() <= SAME_STATE for f in found):
                    found.append(q)
    return found


@dataclass(frozen=True)
class GridCheck3D:
    """The map against brute force on a K x K grid of cell centres: per cell [x, y, map class, brute
    class, stable states found by the multistart, principal state among them (1/0; 1 where there is
    none to find), distance to the nearest located boundary (spans)]; a disagreement within ``near``
    of a boundary is reported apart."""

    k: int
    cells: list[list[float]]
    mismatches: int
    near_mismatches: int
    missed: int
    near: float
    seconds: float

    @property
    def agrees(self) -> bool:
        return self.mismatches == 0 and self.missed == 0

    def to_dict(self) -> dict[str, Any]:
        return {
            "k": self.k,
            "cells": [{"x": c[0], "y": c[1], "map": CLASSES[int(c[2])], "brute_force": CLASSES[int(c[3])], "stable_states": int(c[4]),
                       "principal_found": bool(c[5]), "distance_to_boundary": c[6] if math.isfinite(c[6]) else None} for c in self.cells],
            "mismatches": self.mismatches, "near_mismatches": self.near_mismatches, "principal_missed": self.missed,
            "near": self.near, "agrees": self.agrees, "seconds": self.seconds,
        }


def check_grid3d(smap: StabilityMap3D, k: int, near: float = 0.02) -> GridCheck3D:
    """Classify the centres of a k x k grid by brute force (see the module) and compare with the map."""
    t = time.perf_counter()
    pl = smap.plane
    sx, sy = smap.xrange[1] - smap.xrange[0], smap.yrange[1] - smap.yrange[0]
    xs = smap.xrange[0] + (np.arange(k) + 0.5) * sx / k
    ys = smap.yrange[0] + (np.arange(k) + 0.5) * sy / k
    ev = _Evaluator(pl, smap.xrange, smap.yrange, ys if pl.y == "payload" else (xs if pl.x == "payload" else ()))
    cells, bad, bad_near, missed = [], 0, 0, 0
    for y in ys:
        for x in xs:
            out, load = ev.outcome(float(x), float(y))
            mapped = classify(pl, out, load)
            vals = pl.values(float(x), float(y))
            brute, qb = _brute_ramp(pl, vals)
            states = brute_states(pl, vals)
            found = 1
            if mapped in (0, 1):
                found = int(any(np.abs(out.states[load] - s).max() <= 1e-6 for s in states))
                missed += 1 - found
            dist = min((math.hypot((b.x - x) / sx, (b.y - y) / sy) for b in smap.boundaries), default=math.inf)
            if mapped != brute:
                if dist < near:
                    bad_near += 1
                else:
                    bad += 1
            cells.append([float(x), float(y), mapped, brute, len(states), found, dist])
    return GridCheck3D(k, cells, bad, bad_near, missed, near, time.perf_counter() - t)


# ---------------------------------------------------------------------------------------------
# text


def _curve_lines(c: dict, nx: str, ny: str, ux: str, uy: str) -> list[str]:
    """The text of a map's fold and branch-point curves (:meth:`Curves3D.to_dict`)."""
    out = []
    for key, what in (("fold_curves", "fold curves"), ("branch_point_curves", "branch-point curves")):
        out.append(f"{what} (continued in {nx} and {ny}): {len(c[key])}")
        for curve in c[key]:
            out.append(f"  curve {curve['index']}: {curve['points']} points, {nx} {curve['x_range'][0]:.6g}..{curve['x_range'][1]:.6g}{ux}, "
                       f"{ny} {curve['y_range'][0]:.6g}..{curve['y_range'][1]:.6g}{uy}; {curve['stop_reason']}")
            for p in curve["special_points"]:
                out.append(f"    {p['kind']:<40} {nx} = {p[nx]:.10g}{ux}, {ny} = {p[ny]:.10g}{uy}, total angle {p['total_angle_deg']:.3f} deg, "
                           f"twist {p['twist_deg']:.3f} deg ({p['status']})")
    for note in c["notes"]:
        out.append(f"  note: {note}")
    return out


def map3d_table(d: dict) -> str:
    """The text ``esba map --3d`` prints for :meth:`StabilityMap3D.to_dict` (with ``scene`` and the check)."""
    x, y = d["x"], d["y"]

    def u(a):
        return f" {a['unit']}" if a["unit"] and a["unit"] != "1" else ""

    lines = [
        f"scene: {d['scene']}",
        f"3-D map of {x['parameter']} {x['from']:g}..{x['to']:g}{u(x)} by {y['parameter']} {y['from']:g}..{y['to']:g}{u(y)} "
        f"(history: {d['history']}; twist bound {d['twist_bound_deg']:g} deg)",
        "regions: " + ", ".join(f"{k} {100 * v:.1f}%" for k, v in d["regions"].items()),
        "classes: " + ", ".join(f"{k} {100 * v:.1f}%" for k, v in d["classes"].items()),
    ]
    lines.append("paths (rising and falling along each axis): " + (", ".join(f"{k} {v}" for k, v in d["path_kinds"].items()) or "stable throughout"))
    for note in d["notes"]:
        lines.append(f"  note: {note}")
    for b in d["path_points"][:40]:
        lines.append(f"  {b['kind']:<28} {x['parameter']} = {b[x['parameter']]:.10g}{u(x)}, {y['parameter']} = {b[y['parameter']]:.10g}{u(y)} "
                     f"({b['direction']} in {b['along']}), total angle {b['total_angle_deg']:.3f} deg, twist {b['twist_deg']:.3f} deg")
    if len(d["path_points"]) > 40:
        lines.append(f"  ... {len(d['path_points']) - 40} more (--out FILE lists them)")
    lines.append("region boundaries: " + (", ".join(f"{k} {v}" for k, v in d["boundary_kinds"].items()) or "none"))
    for b in d["boundaries"][:40]:
        lines.append(f"  {b['kind']:<28} {x['parameter']} = {b[x['parameter']]:.10g}{u(x)}, {y['parameter']} = {b[y['parameter']]:.10g}{u(y)}, "
                     f"total angle {b['total_angle_deg']:.3f} deg, twist {b['twist_deg']:.3f} deg")
    if len(d["boundaries"]) > 40:
        lines.append(f"  ... {len(d['boundaries']) - 40} more (--out FILE lists them)")
    if d.get("curves"):
        lines += _curve_lines(d["curves"], x["parameter"], y["parameter"], u(x), u(y))
    if d.get("check_grid"):
        g = d["check_grid"]
        lines.append(f"check against brute force on a {g['k']} x {g['k']} grid: {g['k'] ** 2 - g['mismatches'] - g['near_mismatches']} cells agree, "
                     f"{g['mismatches']} disagree, {g['near_mismatches']} disagree within {g['near']:g} of a boundary; "
                     f"principal state missed by the multistart in {g['principal_missed']}")
    for k in ("out", "figure"):
        if d.get(k):
            lines.append(f"wrote {d[k]}")
    return "\n".join(lines)

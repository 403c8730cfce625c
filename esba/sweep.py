"""Grid sweeps over pressure, payload and geometry, solved as one batch (:mod:`esba.batch`).

:func:`sweep` takes a base scene and values for any of the axes ``pressure`` (MPa), ``payload``
(N, one payload at the base scene's first payload's direction and point, else horizontal at the
tip), ``payload_angle`` (degrees), ``r2`` and ``d`` (mm), and solves every point of their
Cartesian product. Geometries outside the design space (r2 + d >= r1) are rows marked
``infeasible`` and not solved; every other row is ok or says why not.

:func:`load_path` follows one scene's payloads from 0 to their full magnitude by path tracing
(:mod:`esba.loading`) and reports where the path jumps (a snap-through at a fold) instead of
connecting the two branches silently.

:func:`fig12` draws the paper's Fig. 12: the bending angle against r2 for d = 0, 2, 4, 6 mm and
against d for r2 = 2, 4, 6 mm, at rho = 10 degrees and P = 0.2 MPa without payload.

Examples
--------
>>> from esba.scene import Scene
>>> s = sweep(Scene(pressure=0.1), r2=[2.0, 3.0, 5.0], d=[2.0, 4.0], options=BatchOptions(compile="never"))
>>> s.shape, int(s.ok.sum()), s.status.tolist()
((3, 2), 5, ['ok', 'ok', 'ok', 'ok', 'ok', 'infeasible'])
>>> s.total_angle_deg[:2].round(1).tolist()
[34.8, 37.2]
"""

from __future__ import annotations

import csv
import dataclasses
import io
import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import checks, jsonsafe, resolution
from .batch import BatchOptions, BatchResult, check_size, solve_arrays
from .equilibrium import DEFAULT_OPTIONS, EquilibriumError, pressure_for_angle, solve
from .loading import follow
from .path import PathOptions, PathProblem
from .scene import Payload, Scene, SceneError
from .validity import Finding, assess_arrays

__all__ = ["AXES", "SweepResult", "LoadPath", "sweep", "load_path", "fig12", "sweep_figure", "parse_values", "SweepError"]

#: The axes of a sweep, in the order of the grid's dimensions, with their units.
AXES: dict[str, str] = {"pressure": "MPa", "payload": "N", "payload_angle": "deg", "r2": "mm", "d": "mm"}


#: The most points a sweep grid may have: its rows are kept and written whole (about 1 kB each in
#: JSON); a larger study is a set of smaller sweeps.
MAX_POINTS = 200_000


class SweepError(ValueError):
    """A sweep that cannot be set up: the message names the axis and the value."""


def parse_values(text: str) -> list[float]:
    """Axis values from ``"a:b:k"`` (k evenly spaced values from a to b) or ``"v1,v2,..."``.

    Examples
    --------
    >>> parse_values("0:0.2:5")
    [0.0, 0.05, 0.1, 0.15, 0.2]
    >>> parse_values("2,4,6")
    [2.0, 4.0, 6.0]
    >>> parse_values("1:2")
    Traceback (most recent call last):
    ...
    esba.sweep.SweepError: '1:2': expected start:stop:count (count from 1 to 200000) or a comma-separated list of numbers
    """
    msg = f"{text!r}: expected start:stop:count (count from 1 to {MAX_POINTS}) or a comma-separated list of numbers"
    try:
        if ":" in text:
            parts = text.split(":")
            if len(parts) != 3:
                raise SweepError(msg)
            a, b = checks.number("start", parts[0]), checks.number("stop", parts[1])
            k = checks.whole_text("count", parts[2])
            if not 1 <= k <= MAX_POINTS:
                raise SweepError(msg)
            values = [a] if k == 1 else [float(v) for v in np.linspace(a, b, k)]
        else:
            values = [checks.number("value", v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise SweepError(msg) from None
    if not values or not all(math.isfinite(v) for v in values) or len(values) > MAX_POINTS:
        raise SweepError(msg)
    return [round(v, 12) for v in values]


@dataclass(frozen=True, eq=False)
class SweepResult:
    """Every point of a sweep grid: the axes, the status and the equilibrium of each point.

    Attributes
    ----------
    base : Scene
        The scene the grid varies.
    axes : dict
        Axis name -> values, for the axes swept (in :data:`AXES` order).
    points : dict
        Axis name -> value of every point (flattened grid, C order), for every axis of
        :data:`AXES` (fixed ones repeat the base scene's value; ``payload`` 0 without payload).
    status : ndarray of str
        ``ok``, ``infeasible`` (geometry outside the design space, not solved) or ``not ok``.
    messages : tuple of str
        Why a point is not ok (empty when it is).
    notes : tuple of tuple of str
        What happened on a point's load path (a jump, noted by the IPOPT fallback).
    validity : tuple of tuple of Finding
        Where each point leaves the range the paper's model describes (:mod:`esba.validity`).
    batch : BatchResult or None
        The solves of the feasible points (None when there is none).
    """

    base: Scene
    axes: dict[str, list[float]]
    points: dict[str, np.ndarray]
    status: np.ndarray
    messages: tuple[str, ...]
    pressure: np.ndarray
    theta: np.ndarray
    tip: np.ndarray
    stability: np.ndarray
    method: np.ndarray
    batch: BatchResult | None = field(repr=False)
    notes: tuple[tuple[str, ...], ...] = ()
    validity: tuple[tuple[Finding, ...], ...] = ()

    @property
    def shape(self) -> tuple[int, ...]:
        """The grid's shape, one entry per swept axis."""
        return tuple(len(v) for v in self.axes.values())

    @property
    def ok(self) -> np.ndarray:
        """Converged and stable, per point (flattened)."""
        return self.status == "ok"

    @property
    def total_angle_deg(self) -> np.ndarray:
        """Total bending angle per point, degrees (NaN where infeasible: see :attr:`status`)."""
        return np.degrees(np.sum(self.theta, axis=1))

    def scene(self, i: int) -> Scene:
        """The scene of point ``i`` (the base scene with the point's axis values)."""
        changes: dict[str, Any] = {"r2": float(self.points["r2"][i]), "d": float(self.points["d"][i])}
        if "pressure" in self.axes or self.base.pressure is not None:
            changes["pressure"] = float(self.points["pressure"][i])
        if "payload" in self.axes or "payload_angle" in self.axes:
            at = self.base.payloads[0].at if self.base.payloads else 1.0
            changes["payloads"] = (Payload(float(self.points["payload"][i]), float(self.points["payload_angle"][i]), at),)
        return self.base.replace(**changes)

    def grid(self, values: np.ndarray) -> np.ndarray:
        """A flattened per-point array reshaped to the grid."""
        return np.asarray(values).reshape(self.shape)

    def rows(self) -> list[dict[str, Any]]:
        """One dict per point: the axes, status, angles (degrees), tip (mm), solver facts, validity.

        Values that do not exist (an infeasible point's angles, the pressure of an infeasible
        point swept by target angle) are None, never NaN.
        """
        out = []
        n = self.theta.shape[1]
        for i in range(len(self.status)):
            feasible = self.status[i] != "infeasible"
            pressure = float(self.pressure[i]) if feasible else float(self.points["pressure"][i])
            row: dict[str, Any] = {
                "pressure_mpa": pressure if math.isfinite(pressure) else None,
                "payload_n": float(self.points["payload"][i]),
                "payload_angle_deg": float(self.points["payload_angle"][i]),
                "r2_mm": float(self.points["r2"][i]),
                "d_mm": float(self.points["d"][i]),
                "status": str(self.status[i]),
                "stability": str(self.stability[i]),
                "method": str(self.method[i]),
                "total_angle_deg": float(self.total_angle_deg[i]) if feasible else None,
                "tip_x_mm": float(self.tip[i, 0]) if feasible else None,
                "tip_y_mm": float(self.tip[i, 1]) if feasible else None,
            }
            for k in range(n):
                row[f"theta{k + 1}_deg"] = float(math.degrees(self.theta[i, k])) if feasible else None
            row["message"] = self.messages[i]
            row["notes"] = " | ".join(self.notes[i])
            row["validity"] = " | ".join(f.message for f in self.validity[i]) if self.validity else ""
            out.append(row)
        return out

    def to_csv(self) -> str:
        """The rows as CSV text (empty cells where a point is infeasible)."""
        rows = self.rows()
        buf = io.StringIO()
        writer = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        for r in rows:
            writer.writerow({k: ("" if v is None else v) for k, v in r.items()})
        return buf.getvalue()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the base scene, the axes, counts, the backend and every row."""
        counts = {s: int(np.sum(self.status == s)) for s in ("ok", "not ok", "infeasible")}
        return {
            "base": self.base.describe(),
            "segments": self.base.segments,
            "axes": {k: {"values": v, "unit": AXES[k]} for k, v in self.axes.items()},
            "counts": counts,
            "outside_model_range": sum(1 for v in self.validity if v),
            "backend": self.batch.backend if self.batch is not None else "",
            "timings_s": dict(self.batch.timings) if self.batch is not None else {},
            "rows": self.rows(),
        }

    def write(self, path: str | Path) -> Path:
        """Write CSV (``.csv``) or JSON (``.json``, no NaN) by the file's suffix; the folder must exist."""
        path = Path(path)
        if path.suffix.lower() == ".csv":
            text = self.to_csv()
        elif path.suffix.lower() == ".json":
            text = jsonsafe.dumps(self.to_dict(), indent=1)
        else:
            raise SweepError(f"output {str(path)!r}: expected a .csv or .json file")
        path.write_text(text, encoding="utf-8")
        return path


def _axis(name: str, values) -> list[float] | None:
    if values is None:
        return None
    vals = [float(v) for v in (values if isinstance(values, (list, tuple, np.ndarray)) else [values])]
    if not vals or not all(math.isfinite(v) for v in vals):
        raise SweepError(f"{name}={values!r}: expected one or more finite numbers")
    if name in ("pressure", "payload", "d") and min(vals) < 0:
        raise SweepError(f"{name}: {min(vals):g} {AXES[name]} given; expected values >= 0")
    if name == "r2" and min(vals) <= 0:
        raise SweepError(f"r2: {min(vals):g} mm given; expected values > 0")
    return vals


def sweep(
    base: Scene | None = None,
    *,
    pressure=None,
    payload=None,
    payload_angle=None,
    r2=None,
    d=None,
    options: BatchOptions | None = None,
) -> SweepResult:
    """Solve every point of the grid of the given axes around ``base`` in one batch.

    Parameters
    ----------
    base : Scene, optional
        Everything not swept (default ``Scene()``: Table 1 at its 90 degree pressure, n = 3).
        Without a ``pressure`` axis the base scene's pressure (or target angle, per geometry) is used.
    pressure, payload, payload_angle, r2, d : float or sequence of float, optional
        Axis values (MPa, N, degrees, mm, mm). A ``payload`` or ``payload_angle`` axis replaces
        the base scene's payloads with one payload.
    options : BatchOptions, optional

    Returns
    -------
    SweepResult
    """
    base = Scene() if base is None else base
    if not isinstance(base, Scene):
        raise SweepError(f"base={base!r}: expected a Scene")
    given = {"pressure": pressure, "payload": payload, "payload_angle": payload_angle, "r2": r2, "d": d}
    axes = {k: v for k, v in ((k, _axis(k, given[k])) for k in AXES) if v is not None}
    if not axes:
        raise SweepError("sweep needs at least one axis: pressure, payload, payload_angle, r2 or d")

    payload_swept = "payload" in axes or "payload_angle" in axes
    first = base.payloads[0] if base.payloads else Payload(0.0, 90.0, 1.0)
    if payload_swept:
        base = base.replace(payloads=(first,))
    fixed = {
        "pressure": base.pressure if base.pressure is not None else float("nan"),
        "payload": first.force if base.payloads else 0.0,
        "payload_angle": first.angle_deg,
        "r2": base.actuator.r2,
        "d": base.actuator.d,
    }
    size = math.prod(len(v) for v in axes.values())
    if size > MAX_POINTS:
        counts = " x ".join(f"{len(v)} {k}" for k, v in axes.items())
        raise SweepError(f"the grid has {size} points ({counts}): at most {MAX_POINTS}; sweep fewer values, or split the grid")
    check_size(size, base.segments, "the sweep", SweepError)
    grid = list(itertools.product(*axes.values()))
    cols = {k: np.full(size, float(fixed[k])) for k in AXES}
    for j, name in enumerate(axes):
        cols[name] = np.array([pt[j] for pt in grid])
    angle_mode = "pressure" not in axes and base.pressure is None

    def scene_of(i: int) -> Scene:
        changes: dict[str, Any] = {"r2": float(cols["r2"][i]), "d": float(cols["d"][i])}
        if not angle_mode:
            changes["pressure"] = float(cols["pressure"][i])
        if payload_swept:
            changes["payloads"] = (Payload(float(cols["payload"][i]), float(cols["payload_angle"][i]), first.at),)
        return base.replace(**changes)

    # geometry: validated once per distinct (r2, d)
    status = np.full(size, "ok", dtype=object)
    messages = [""] * size
    bad: dict[tuple[float, float], str] = {}
    for key in set(zip(cols["r2"].tolist(), cols["d"].tolist())):
        try:
            dataclasses.replace(base.actuator, r2=key[0], d=key[1])
        except SceneError as exc:
            bad[key] = str(exc)
    for i, key in enumerate(zip(cols["r2"].tolist(), cols["d"].tolist())):
        if key in bad:
            status[i], messages[i] = "infeasible", bad[key]
    feasible = np.where(status != "infeasible")[0]
    if len(feasible):  # scales the solver cannot resolve are refused before the batch starts
        strongest = float(np.max(cols["payload"][feasible])) if payload_swept else 0.0
        for r2_, d_ in {(float(cols["r2"][i]), float(cols["d"][i])) for i in feasible}:
            extreme = base.replace(r2=r2_, d=d_)
            if payload_swept:
                extreme = extreme.replace(payloads=(Payload(strongest, first.angle_deg, first.at),))
            if not angle_mode:
                extreme = extreme.replace(pressure=float(np.max(cols["pressure"][feasible])))
                resolution.check_resolvable(extreme, extreme.pressure, DEFAULT_OPTIONS.stationarity_tol)
                continue
            try:
                top = pressure_for_angle(extreme)
            except EquilibriumError:  # that design's points are reported not ok by the batch
                continue
            resolution.check_resolvable(extreme, top, DEFAULT_OPTIONS.stationarity_tol)

    n = base.segments
    theta = np.full((size, n), np.nan)
    tip = np.full((size, 3), np.nan)
    pres = cols["pressure"].copy()
    stability = np.full(size, "", dtype=object)
    method = np.full(size, "", dtype=object)
    batch = None
    notes: list[tuple[str, ...]] = [()] * size
    if len(feasible):
        model = base.model()
        values: dict[str, Any] = base.parameters(0.0 if angle_mode else fixed["pressure"])
        values = {k: np.full(len(feasible), float(values[k])) for k in model.parameters}
        values["r2"] = cols["r2"][feasible]
        values["d"] = cols["d"][feasible]
        if not angle_mode:
            values["P"] = cols["pressure"][feasible]
        if payload_swept:
            values["F1"] = cols["payload"][feasible]
            values["Omega1"] = np.radians(cols["payload_angle"][feasible])
        target = math.radians(base.target_angle_deg) if angle_mode else None
        batch = solve_arrays(model, values, target_angle=target, options=options, scene_of=lambda j: scene_of(int(feasible[j])))
        theta[feasible] = batch.theta
        tip[feasible] = batch.tip
        pres[feasible] = batch.pressure
        stability[feasible] = batch.stability
        method[feasible] = batch.method
        for j, i in enumerate(feasible):
            notes[i] = batch.notes[j]
            if not batch.ok[j]:
                status[i], messages[i] = "not ok", batch.messages[j]
    validity: list[tuple[Finding, ...]] = [()] * size
    if len(feasible):
        a = base.actuator
        found = assess_arrays(
            n, a.L, a.r1, cols["r2"][feasible], cols["d"][feasible], theta[feasible], tip[feasible, 0], pres[feasible],
            cols["payload"][feasible] if payload_swept else max((p.force for p in base.payloads), default=0.0),
        )
        for j, i in enumerate(feasible):
            validity[i] = found[j]
    return SweepResult(
        base=base,
        axes=axes,
        points=cols,
        status=status.astype(str),
        messages=tuple(messages),
        pressure=pres,
        theta=theta,
        tip=tip,
        stability=stability.astype(str),
        method=method.astype(str),
        batch=batch,
        notes=tuple(notes),
        validity=tuple(validity),
    )


# ---------------------------------------------------------------------------------------------
# one load path, jumps reported


@dataclass(frozen=True, eq=False)
class LoadPath:
    """Equilibria along a payload ramp from 0 to the full load, and where the path jumps.

    Attributes
    ----------
    factors : ndarray
        Load factors of the points (0 ... 1), in the order the ramp met them.
    theta : ndarray, shape (k, n)
        Angles at each point, rad.
    tip : ndarray, shape (k, 3)
        Tip pose at each point.
    min_eigenvalue : ndarray
        Smallest Hessian eigenvalue at each point (it falls to 0 at a fold, where the path snaps).
    kind : ndarray of str
        What each point is (``start``, ``regular``, ``fold``, ``branch point``, ``end``; see
        :class:`esba.branch.Branch`).
    jumps : list of dict
        Each jump: the load factor of the fold and just after it, the tip before and after (mm),
        the distance, and the kind of special point.
    ok : bool
        The ramp reached the full load on a stable equilibrium.
    message : str
        What went wrong, when ``ok`` is False.
    """

    factors: np.ndarray
    theta: np.ndarray
    tip: np.ndarray
    min_eigenvalue: np.ndarray
    kind: np.ndarray
    jumps: list[dict]
    ok: bool
    message: str = ""

    @property
    def continuous(self) -> bool:
        """True when no jump was found."""
        return not self.jumps


def load_path(scene: Scene, options: PathOptions | None = None) -> LoadPath:
    """Follow ``scene``'s payloads (and weight) from 0 to full, quasi-statically.

    The load factor is followed by path tracing (:func:`esba.loading.follow`): every fold where
    the stable branch ends is located, and the jump from it is recorded (a snap-through to another
    branch), not smoothed over.

    Examples
    --------
    >>> from esba.scene import Scene, Payload
    >>> p = load_path(Scene(target_angle_deg=90.0, payloads=(Payload(2.0),)))
    >>> p.ok, p.continuous, round(float(p.tip[-1, 1]), 2)
    (True, True, 10.22)
    """
    unloaded = solve(scene.replace(payloads=tuple(p.scaled(0.0) for p in scene.payloads), gravity=False))
    if not unloaded.ok or not (scene.payloads or scene.gravity):
        one = np.array([0.0])
        kind = np.array(["start"])
        return LoadPath(one, unloaded.theta[None, :], unloaded.tip[None, :], np.array([unloaded.eigenvalues[0]]), kind, [], unloaded.ok, unloaded.message)
    problem = PathProblem.from_scene(scene, "load", pressure=unloaded.pressure)
    ramp = follow(problem, unloaded.theta, 0.0, 1.0, options)
    pieces = ramp.pieces
    jumps = [
        {
            "kind": j.kind,
            "from_factor": j.lam,
            "to_factor": j.lam_after,
            "tip_before_mm": [float(v) for v in j.tip_before[:2]],
            "tip_after_mm": [float(v) for v in j.tip_after[:2]],
            "distance_mm": j.distance_mm,
            "min_eigenvalue_before": j.point.eigenvalue,
        }
        for j in ramp.jumps
    ]
    return LoadPath(
        factors=np.concatenate([b.lam for b in pieces]),
        theta=np.vstack([b.theta for b in pieces]),
        tip=np.vstack([b.tip for b in pieces]),
        min_eigenvalue=np.concatenate([b.eigenvalues[:, 0] for b in pieces]),
        kind=np.concatenate([b.kind for b in pieces]),
        jumps=jumps,
        ok=ramp.reached,
        message=ramp.message,
    )


#: The sweep axes a path can follow (:data:`esba.path_problem.PARAMETERS` names).
_PATH_OF_AXIS = {"pressure": "pressure", "payload": "payload", "payload_angle": "omega", "r2": "r2", "d": "d"}


def _traced(result: SweepResult, idx: np.ndarray, x_name: str):
    """The branch through the first ok point of a curve, traced over the curve's range; None when
    the curve cannot be one branch (each design at its own pressure) or has no ok point."""
    from .path import PathOptions, PathProblem, trace

    if x_name in ("r2", "d") and "pressure" not in result.axes and result.base.pressure is None:
        return None  # every design at the pressure of its own target angle: not one path
    ok = [i for i in idx if result.status[i] == "ok"]
    if not ok:
        return None
    i0 = ok[0]
    xs = result.points[x_name][idx]
    try:
        scene = result.scene(int(i0))
        problem = PathProblem.from_scene(scene, _PATH_OF_AXIS[x_name], pressure=float(result.pressure[i0]))
        return trace(problem, result.theta[i0], float(result.points[x_name][i0]), to=float(xs.max()), options=PathOptions(ds_max=0.1))
    except (ValueError, RuntimeError):
        return None


def sweep_figure(result: SweepResult, max_curves: int = 12, traced: bool = True):
    """Total bending angle against the first swept axis with more than one value, one curve per
    combination of the other axes (points that are not ok are left out, not drawn as zero).

    With ``traced`` each curve is the branch of equilibria through its first point, traced over
    the axis (:mod:`esba.path`): stable solid, unstable dashed, folds marked, so that a bistable
    range shows its unstable middle and its folds instead of a line through the jump; the grid
    points themselves are the markers (each solved along the scene's own load history).
    """
    from .path_figures import draw_branch
    from .plots import new_figure

    names = [k for k, v in result.axes.items() if len(v) > 1] or list(result.axes)
    x_name = names[0]
    others = [k for k in result.axes if k != x_name]
    combos = list(itertools.product(*(result.axes[k] for k in others)))
    if len(combos) > max_curves:
        raise SweepError(f"the figure would have {len(combos)} curves (> {max_curves}): sweep fewer values of {', '.join(others)}")
    fig = new_figure(6.5, 4.5)
    ax = fig.subplots()
    angle = np.where(result.ok, result.total_angle_deg, np.nan)
    any_traced = any_fold = False
    for k, combo in enumerate(combos):
        mask = np.ones(len(angle), dtype=bool)
        for name, v in zip(others, combo):
            mask &= np.isclose(result.points[name], v)
        label = ", ".join(f"{name} = {v:g} {AXES[name]}" for name, v in zip(others, combo)) or None
        idx = np.flatnonzero(mask)
        idx = idx[np.argsort(result.points[x_name][idx], kind="stable")]
        branch = _traced(result, idx, x_name) if traced and len(idx) > 1 else None
        color = f"C{k % 10}"
        if branch is not None:
            any_traced = True
            any_fold = any_fold or bool(branch.folds)
            draw_branch(ax, branch, "total-angle", color, label)
            ax.plot(result.points[x_name][idx], angle[idx], "o", color=color, ms=3)
        else:
            ax.plot(result.points[x_name][idx], angle[idx], "o-", color=color, ms=3, label=label)
    ax.set_xlabel(f"{x_name} ({AXES[x_name]})")
    ax.set_ylabel("total bending angle (deg)")
    ax.grid(True, color="0.9", lw=0.6)
    if any_traced:
        ax.plot([], [], "o", color="0.4", ms=3, label="grid points (each along its load history)")
        ax.plot([], [], color="0.4", ls="--", label="unstable (traced branch)")
        if any_fold:
            ax.plot([], [], "o", mfc="white", mec="0.4", label="fold")
    if (combos and others) or any_traced:
        ax.legend(fontsize=7)
    a, b = result.base.actuator, result.base
    fixed = [f"L={a.L:g} r1={a.r1:g}" + ("" if "r2" in result.axes else f" r2={a.r2:g}") + ("" if "d" in result.axes else f" d={a.d:g}")]
    fixed.append(f"rho={a.rho_deg:g} deg E={a.E:g} MPa")
    if "pressure" not in result.axes:
        fixed.append(f"P={b.pressure:g} MPa" if b.pressure is not None else f"P for an unloaded {b.target_angle_deg:g} deg")
    if b.payloads:
        p = b.payloads[0]
        fixed.append(
            "payload"
            + ("" if "payload" in result.axes else f" {p.force:g} N")
            + ("" if "payload_angle" in result.axes else f" at {p.angle_deg:g} deg")
            + f", s={p.at:g}"
        )
    fixed.append(f"n={b.segments}")
    ax.set_title("; ".join(fixed) + " (esba sweep --plot)", fontsize=8)
    return fig


# ---------------------------------------------------------------------------------------------
# Fig. 12


#: The paper's Fig. 12: rho = 10 degrees, P = 0.2 MPa, no payload; d = 0, 2, 4, 6 (a), r2 = 2, 4, 6 (b).
FIG12_D = (0.0, 2.0, 4.0, 6.0)
FIG12_R2 = (2.0, 4.0, 6.0)


def fig12(base: Scene | None = None, points: int = 60, options: BatchOptions | None = None):
    """Fig. 12 of the paper: bending angle against r2 (for each d) and against d (for each r2).

    Each curve runs to the edge of the design space, r2 + d = r1 - 0.05 mm. Returns the figure
    and the sweeps: ``{"r2": [one per d], "d": [one per r2]}``.
    """
    from .plots import new_figure

    base = Scene(pressure=0.2, segments=3) if base is None else base
    r1 = base.actuator.r1
    edge = 0.05  # mm: the thinnest chamber wall of the sweep
    sweeps: dict[str, list[SweepResult]] = {"r2": [], "d": []}
    fig = new_figure(10.0, 4.2)
    ax_a, ax_b = fig.subplots(1, 2)
    for dv in FIG12_D:
        s = sweep(base, d=dv, r2=list(np.linspace(0.1, r1 - dv - edge, points)), options=options)
        sweeps["r2"].append(s)
        ax_a.plot(s.points["r2"], np.where(s.ok, s.total_angle_deg, np.nan), label=f"d = {dv:g} mm")
    for rv in FIG12_R2:
        s = sweep(base, r2=rv, d=list(np.linspace(0.0, r1 - rv - edge, points)), options=options)
        sweeps["d"].append(s)
        ax_b.plot(s.points["d"], np.where(s.ok, s.total_angle_deg, np.nan), label=f"r2 = {rv:g} mm")
    ax_a.set_xlabel("chamber radius r2 (mm)")
    ax_a.set_ylabel("bending angle (deg, log scale)")
    ax_a.set_yscale("log")
    ax_a.set_title("(a) bending angle against r2")
    ax_b.set_xlabel("eccentric distance d (mm)")
    ax_b.set_ylabel("bending angle (deg)")
    ax_b.set_title("(b) bending angle against d")
    for ax in (ax_a, ax_b):
        ax.grid(True, which="both", color="0.9", lw=0.6)
        ax.legend()
    a = base.actuator
    fig.suptitle(
        f"Fig. 12 type: r1 = {a.r1:g} mm, rho = {a.rho_deg:g} deg, P = {base.pressure:g} MPa, no payload, n = {base.segments}\n"
        f"each curve ends at the design-space edge r2 + d = r1 - {edge:g} mm (esba sweep --fig12)",
        fontsize=10,
    )
    return fig, sweeps

"""Grid sweeps over pressure, payload and geometry, solved as one batch (:mod:`esba.statics.batch`).

:func:`sweep` takes a base scene and values for any of the axes ``pressure`` (MPa), ``payload``
(N, one payload at the base scene's first payload's direction and point, else horizontal at the
tip), ``payload_angle`` (degrees) and any field of the actuator, named as in a scene file's
``[actuator]`` table (``L``, ``r1``, ``r2``, ``d`` in mm, ``rho_deg`` in degrees, ``E`` in MPa, ``M``
in kg), and solves every point of their Cartesian product. Each value is checked by the scene's
own rule for its field; geometries outside the design space (r2 + d >= r1) are rows marked
``infeasible`` and not solved; every other row is ok or says why not.

A sweep is a :class:`SweepPlan` (:func:`plan_sweep`: the validated grid, plain values only) and
:func:`solve_points`, a pure function of (plan, first point, end point, batch options) that solves
any range of the grid's points and returns plain arrays. :func:`sweep` solves the whole grid with
it in one call; :mod:`esba.studies.sweep_runner` solves it chunk by chunk, in this process or on Dask
workers (:mod:`esba.studies.distributed`), with the same answers element for element.

:mod:`esba.figures.sweeps` draws a sweep, and the paper's Fig. 12.

Examples
--------
>>> from esba.model.scene import Scene
>>> s = sweep(Scene(pressure=0.1), r2=[2.0, 3.0, 5.0], d=[2.0, 4.0], options=BatchOptions(compile="never"))
>>> s.shape, int(s.ok.sum()), s.status.tolist()
((3, 2), 5, ['ok', 'ok', 'ok', 'ok', 'ok', 'infeasible'])
>>> s.total_angle_deg[:2].round(1).tolist()
[34.8, 37.2]
>>> plan = plan_sweep(Scene(pressure=0.1), r2=[2.0, 3.0, 5.0], d=[2.0, 4.0])
>>> part = solve_points(plan, 4, 6, BatchOptions(compile="never"))
>>> part["status"].tolist(), bool(part["theta"][0, 0] == s.theta[4, 0])
(['ok', 'infeasible'], True)
"""

from __future__ import annotations

import csv
import dataclasses
import io
import itertools
import math
from dataclasses import dataclass
from numbers import Real
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from esba.infra import checks, jsonsafe, outputs
from esba.infra.errors import InputError
from esba.infra.report import Report
from esba.model import resolution
from esba.model.closed_form import chain_tip
from esba.model.scene import ACTUATOR_RULES, MAX_PAYLOAD, MAX_PRESSURE, Actuator, Payload, Scene, SceneError, actuator_rule, check_actuator_field
from esba.model.validity import Finding, Tally, assess_arrays
from esba.statics.batch import METHODS, BatchOptions, check_size, decide_backend, solve_arrays
from esba.statics.batch_options import DEFAULT_BATCH_OPTIONS
from esba.statics.equilibrium import (
    DEFAULT_OPTIONS,
    EquilibriumError,
    pressure_for_angle,
)

__all__ = [
    "AXES",
    "ACTUATOR_AXES",
    "AXIS_COLUMNS",
    "SweepPlan",
    "SweepResult",
    "plan_sweep",
    "solve_points",
    "sweep",
    "parse_values",
    "row_fields",
    "point_rows",
    "SweepError",
    "check_points",
    "check_resolvable",
    "MAX_POINTS",
    "MAX_STUDY_POINTS",
]

#: The actuator's axes of a sweep: every field of a scene's ``[actuator]`` table
#: (:data:`esba.model.scene.ACTUATOR_RULES`), in its order.
ACTUATOR_AXES: tuple[str, ...] = tuple(ACTUATOR_RULES)

#: The axes of a sweep, in the order of the grid's dimensions, with their units.
AXES: dict[str, str] = {"pressure": "MPa", "payload": "N", "payload_angle": "deg", **{k: ACTUATOR_RULES[k][3] for k in ACTUATOR_AXES}}

#: The column of each axis in a sweep's rows (and CSV file).
AXIS_COLUMNS: dict[str, str] = {
    "pressure": "pressure_mpa", "payload": "payload_n", "payload_angle": "payload_angle_deg",
    "L": "L_mm", "r1": "r1_mm", "r2": "r2_mm", "d": "d_mm", "rho_deg": "rho_deg", "E": "E_mpa", "M": "M_kg",
}

#: Columns of a sweep's rows that hold text (every other column is a number, empty when undefined).
TEXT_FIELDS = ("status", "stability", "method", "message", "notes", "validity")


#: The most points a sweep grid solved in memory (:func:`sweep`, a study gathered in memory) may
#: have: its rows are kept and written whole (about 1 kB each in JSON).
MAX_POINTS = 200_000

#: The most points of a grid streamed to a CSV file chunk by chunk (:mod:`esba.studies.sweep_runner`): a
#: few GB of rows at n = 16; a larger study is a set of smaller ones.
MAX_STUDY_POINTS = 10_000_000


class SweepError(InputError):
    """A sweep that cannot be set up: the message names the axis and the value."""


def parse_values(text: str) -> list[float]:
    """Axis values from ``"a:b:k"`` (k evenly spaced values from a to b) or ``"v1,v2,..."``.

    Examples
    --------
    >>> parse_values("0:0.2:5")
    [0.0, 0.05, 0.1, 0.15, 0.2]
    >>> parse_values("2,4,6")
    [2.0, 4.0, 6.0]
    >>> parse_values("1e-13,2e-13"), parse_values("0:1e-12:3")
    ([1e-13, 2e-13], [0.0, 5e-13, 1e-12])
    >>> parse_values("1:2")
    Traceback (most recent call last):
    ...
    esba.studies.sweep.SweepError: '1:2': expected start:stop:count (count from 1 to 200000) or a comma-separated list of numbers
    """
    if not isinstance(text, str):
        raise SweepError(f"values={checks.quote(text)}: expected a text start:stop:count or v1,v2,...")
    msg = f"{checks.quote(text)}: expected start:stop:count (count from 1 to {MAX_POINTS}) or a comma-separated list of numbers"
    try:
        if ":" in text:
            parts = text.split(":")
            if len(parts) != 3:
                raise SweepError(msg)
            a, b = checks.number("start", parts[0]), checks.number("stop", parts[1])
            k = checks.whole_text("count", parts[2])
            if not 1 <= k <= MAX_POINTS or not (math.isfinite(a) and math.isfinite(b)):
                raise SweepError(msg)
            # 12 significant digits drop linspace's round-off (0.15000000000000002) and keep small values
            values = [a] if k == 1 else [float(f"{v:.12g}") for v in np.linspace(a, b, k)]
        else:
            values = [checks.number("value", v) for v in text.split(",")]  # an empty item (1,,2) is not a number
    except ValueError:
        raise SweepError(msg) from None
    if not values or not all(math.isfinite(v) for v in values) or len(values) > MAX_POINTS:
        raise SweepError(msg)
    return values


# ---------------------------------------------------------------------------------------------
# the grid, and solving any range of its points


@dataclass(frozen=True, eq=False)
class SweepPlan:
    """A validated sweep grid before it is solved: plain values only (no model, no CasADi object),
    so that it can travel to another process.

    Attributes
    ----------
    base : Scene
        Everything not swept (with one payload when a payload axis is swept).
    axes : dict
        Axis name -> values, for the axes swept (in :data:`AXES` order).
    fixed : dict
        The value of every axis of :data:`AXES` at the base scene (``pressure`` NaN when each
        design is at the pressure of its target angle; ``payload`` 0 without payload).
    at : float
        Point of application of a swept payload (fraction of L).
    payload_swept, angle_mode : bool
        A payload axis is swept; the pressure comes from the base scene's target angle.
    """

    base: Scene
    axes: dict[str, list[float]]
    fixed: dict[str, float]
    at: float
    payload_swept: bool
    angle_mode: bool

    @property
    def shape(self) -> tuple[int, ...]:
        """The grid's shape, one entry per swept axis."""
        return tuple(len(v) for v in self.axes.values())

    @property
    def size(self) -> int:
        """Number of points of the grid."""
        return math.prod(self.shape)

    def columns(self, start: int = 0, stop: int | None = None) -> dict[str, np.ndarray]:
        """Axis name -> value of points ``start`` to ``stop`` (flattened grid, C order), for every axis of :data:`AXES`."""
        stop = self.size if stop is None else stop
        if not 0 <= start <= stop <= self.size:
            raise SweepError(f"points {start}:{stop}: expected 0 <= start <= stop <= {self.size}")
        idx = np.arange(start, stop)
        cols = {k: np.full(len(idx), float(self.fixed[k])) for k in AXES}
        multi = np.unravel_index(idx, self.shape)
        for j, name in enumerate(self.axes):
            cols[name] = np.asarray(self.axes[name], dtype=float)[multi[j]]
        return cols

    def scene_of(self, cols: Mapping[str, np.ndarray], i: int) -> Scene:
        """The scene of point ``i`` of ``cols`` (from :meth:`columns`)."""
        changes: dict[str, Any] = {k: float(cols[k][i]) for k in ACTUATOR_AXES}
        if not self.angle_mode:
            changes["pressure"] = float(cols["pressure"][i])
        if self.payload_swept:
            changes["payloads"] = (Payload(float(cols["payload"][i]), float(cols["payload_angle"][i]), self.at),)
        return self.base.replace(**changes)

    def describe(self) -> dict[str, Any]:
        """Everything that fixes the grid's answers, as plain JSON-ready values (a study's identity)."""
        return {
            "base": dataclasses.asdict(self.base),
            "axes": {k: list(v) for k, v in self.axes.items()},
            "segments": self.base.segments,
            "effects": self.base.effects.spec(),
            "variant": self.base.variant,
        }


def _axis(name: str, values) -> list[float] | None:
    if values is None:
        return None
    if isinstance(values, str):  # as the command line takes it: start:stop:count or v1,v2,...
        try:
            vals = parse_values(values)
        except SweepError as exc:
            raise SweepError(f"{name}: {exc}") from None
    else:
        items = values.tolist() if isinstance(values, np.ndarray) else values
        items = items if isinstance(items, (list, tuple)) else [items]
        if not all(isinstance(v, Real) and not isinstance(v, bool) for v in items):
            raise SweepError(f"{name}={checks.quote(values)}: expected one or more finite numbers, or a text start:stop:count")
        vals = [float(v) for v in items]
    if len(vals) > MAX_POINTS:
        raise SweepError(f"{name}: {len(vals)} values; expected at most {MAX_POINTS}")
    if not vals or not all(math.isfinite(v) for v in vals):
        raise SweepError(f"{name}={checks.quote(values)}: expected one or more finite numbers")
    if name in ("pressure", "payload") and min(vals) < 0:
        raise SweepError(f"{name}: {min(vals):g} {AXES[name]} given; expected values >= 0")
    if name == "r2" and min(vals) <= 0:
        raise SweepError(f"r2: {min(vals):g} mm given; expected values > 0")
    bound = {"pressure": MAX_PRESSURE, "payload": MAX_PAYLOAD}.get(name)
    if bound is not None and max(vals) > bound:  # a scene's own bounds (esba.model.scene), before any point is solved
        raise SweepError(f"{name}: {max(vals):g} {AXES[name]} given; expected values <= {bound:g} (the model means nothing beyond)")
    if name in ACTUATOR_RULES:  # each value by the scene's own rule for the field
        for v in vals:
            try:
                check_actuator_field(name, v)
            except SceneError:
                raise SweepError(f"{name}: {v:g} {AXES[name]} given; expected values {actuator_rule(name)}") from None
    return vals


def plan_sweep(base: Scene | None = None, *, pressure=None, payload=None, payload_angle=None, **actuator) -> SweepPlan:
    """The validated grid of :func:`sweep` (same arguments but the options), not solved."""
    base = Scene() if base is None else base
    if not isinstance(base, Scene):
        raise SweepError(f"base={checks.quote(base)}: expected a Scene")
    unknown = sorted(set(actuator) - set(ACTUATOR_AXES))
    if unknown:
        raise SweepError(f"unknown sweep axis {checks.some(unknown)}: allowed are {', '.join(AXES)}")
    given = {"pressure": pressure, "payload": payload, "payload_angle": payload_angle, **actuator}
    axes = {k: v for k, v in ((k, _axis(k, given.get(k))) for k in AXES) if v is not None}
    if not axes:
        raise SweepError(f"sweep needs at least one axis: {', '.join(AXES)}")
    payload_swept = "payload" in axes or "payload_angle" in axes
    first = base.payloads[0] if base.payloads else Payload(0.0, 90.0, 1.0)
    if payload_swept:
        base = base.replace(payloads=(first,))
    fixed = {
        "pressure": base.pressure if base.pressure is not None else float("nan"),
        "payload": first.force if base.payloads else 0.0,
        "payload_angle": first.angle_deg,
        **{k: getattr(base.actuator, k) for k in ACTUATOR_AXES},
    }
    angle_mode = "pressure" not in axes and base.pressure is None
    plan = SweepPlan(base, axes, {k: float(v) for k, v in fixed.items()}, first.at, payload_swept, angle_mode)
    check_points(plan, MAX_STUDY_POINTS)
    return plan


def check_points(plan: SweepPlan, limit: int = MAX_POINTS) -> None:
    """A :class:`SweepError` when the grid has more than ``limit`` points, naming its axes and both
    bounds (:data:`MAX_POINTS` in memory, :data:`MAX_STUDY_POINTS` streamed to a file)."""
    if plan.size > limit:
        counts = " x ".join(f"{len(v)} {k}" for k, v in plan.axes.items())
        raise SweepError(
            f"the grid has {plan.size} points ({counts}): at most {MAX_POINTS} in memory, {MAX_STUDY_POINTS} streamed "
            "chunk by chunk to --out FILE.csv with --resume or --workers; sweep fewer values, or split the grid"
        )


def check_resolvable(plan: SweepPlan) -> None:
    """Refuse, before anything is solved, a grid whose most demanding point is at a scale the
    solver cannot resolve (:func:`esba.model.resolution.check_resolvable`).

    The checks are bounded whatever the grid's size: at each corner of the box of the other
    actuator axes (L, r1, rho, E, M: their least and largest values, at most 32 corners), the
    stiffness test at the least stiff feasible design (the segment stiffness is closed form), the
    moment test at the strongest payload and pressure of the corner designs of the (r2, d) box,
    where the pressure that a target angle needs is largest (a thin chamber or a concentric one
    needs the most).
    """
    others = [k for k in ACTUATOR_AXES if k not in ("r2", "d")]
    spans = [sorted({min(plan.axes[k]), max(plan.axes[k])}) if k in plan.axes else [plan.fixed[k]] for k in others]
    for corner in itertools.product(*spans):
        _check_resolvable_at(plan, dict(zip(others, corner)))


def _check_resolvable_at(plan: SweepPlan, corner: dict[str, float]) -> None:
    """:func:`check_resolvable` over the (r2, d) box at one corner of the other actuator axes."""
    r2s = np.asarray(plan.axes.get("r2", [plan.fixed["r2"]]), dtype=float)
    ds = np.asarray(plan.axes.get("d", [plan.fixed["d"]]), dtype=float)
    r1 = corner["r1"]
    # the stiffness of Eq. (8) at theta = 0 falls with r2 and with d: at each r2 the least stiff
    # feasible design has the largest d with r2 + d < r1 (Actuator's rule)
    ds_sorted = np.sort(ds)
    top = np.searchsorted(ds_sorted, r1 - r2s, side="left") - 1  # index of the largest d < r1 - r2
    ok = top >= 0
    if not ok.any():
        return
    r2_ok, d_top = r2s[ok], ds_sorted[top[ok]]
    stiffness = 5 * r1**4 - 4 * r2_ok**2 * (r1 + d_top) ** 2 - r2_ok**4  # up to a positive factor
    soft = int(np.argmin(stiffness))
    designs = {(float(r2_ok[soft]), float(d_top[soft]))}
    for r2_ in (r2s.min(), r2s.max()):
        column = ds[ds + r2_ < r1]  # the feasible d at this r2 (Actuator: r2 + d < r1)
        if column.size:
            designs |= {(float(r2_), float(column.min())), (float(r2_), float(column.max()))}
    payloads = plan.axes.get("payload", [plan.fixed["payload"]])
    strongest = max(payloads) if plan.payload_swept else 0.0
    top_pressure = None if plan.angle_mode else max(plan.axes.get("pressure", [plan.fixed["pressure"]]))
    for r2_, d_ in sorted(designs):
        try:
            extreme = plan.base.replace(r2=r2_, d=d_, **corner)
        except SceneError:  # infeasible: reported as such, not solved
            continue
        resolution.check_stiffness(extreme, DEFAULT_OPTIONS.stationarity_tol)
        resolution.check_domain(extreme)
        if plan.payload_swept:
            extreme = extreme.replace(payloads=(Payload(strongest, plan.fixed["payload_angle"], plan.at),))
        if top_pressure is not None:
            extreme = extreme.replace(pressure=top_pressure)
            resolution.check_resolvable(extreme, top_pressure, DEFAULT_OPTIONS.stationarity_tol)
            continue
        try:
            top = pressure_for_angle(extreme)
        except EquilibriumError:  # that design's points are reported not ok by the batch
            continue
        resolution.check_resolvable(extreme, top, DEFAULT_OPTIONS.stationarity_tol)


def solve_points(plan: SweepPlan, start: int, stop: int, options: BatchOptions | None = None) -> dict[str, Any]:
    """Solve points ``start`` to ``stop`` of a sweep grid on the batch path: a pure function of its
    arguments, so that any chunk of a grid can be solved anywhere (another process, a Dask worker).

    The model is loaded with :meth:`esba.model.scene.Scene.model` (:func:`esba.model.generated.load_model`, once
    per process). Each point's answer depends on the point alone: any split of the grid gives
    the same arrays, element for element, when ``options.compile`` is the same for every chunk
    (``"always"`` or ``"never"``: see :func:`esba.statics.batch.decide_backend`).

    Returns
    -------
    dict
        ``status`` (str array), ``messages``, ``notes`` and ``validity`` (lists: text, text,
        :class:`esba.model.validity.Finding` tuples), ``pressure`` (k,),
        ``theta`` (k, n) rad, ``tip`` (k, 3), ``stability`` and ``method`` (str arrays),
        ``backend`` (str) and ``timings`` (dict, s).
    """
    cols = plan.columns(start, stop)
    size = stop - start
    # the actuator: validated once per distinct design (each value is checked by plan_sweep; a
    # chamber outside the actuator, r2 + d >= r1, is infeasible)
    status = np.full(size, "ok", dtype=object)
    messages = [""] * size
    bad: dict[tuple[float, ...], str] = {}
    designs = list(zip(*(cols[k].tolist() for k in ACTUATOR_AXES)))
    for key in set(designs):
        try:
            Actuator(**dict(zip(ACTUATOR_AXES, key)))
        except SceneError as exc:
            bad[key] = str(exc)
    for i, key in enumerate(designs):
        if key in bad:
            status[i], messages[i] = "infeasible", bad[key]
    feasible = np.where(status != "infeasible")[0]

    base = plan.base
    n = base.segments
    theta = np.full((size, n), np.nan)
    tip = np.full((size, 3), np.nan)
    pres = cols["pressure"].copy()
    stability = np.full(size, "", dtype=object)
    method = np.full(size, "", dtype=object)
    notes: list[tuple[str, ...]] = [()] * size
    validity: list[tuple[Finding, ...]] = [()] * size
    backend, timings = "", {}
    if len(feasible):
        model = base.model()
        values: dict[str, Any] = base.parameters(0.0 if plan.angle_mode else plan.fixed["pressure"])
        values = {k: np.full(len(feasible), float(values[k])) for k in model.parameters}
        for k in plan.axes.keys() & set(ACTUATOR_AXES):  # the model's parameter: rho in radians
            name, column = ("rho", np.radians(cols[k][feasible])) if k == "rho_deg" else (k, cols[k][feasible])
            if name in values:
                values[name] = column
        if not plan.angle_mode:
            values["P"] = cols["pressure"][feasible]
        if plan.payload_swept:
            values["F1"] = cols["payload"][feasible]
            values["Omega1"] = np.radians(cols["payload_angle"][feasible])
        target = math.radians(base.target_angle_deg) if plan.angle_mode else None
        batch = solve_arrays(model, values, target_angle=target, options=options)
        theta[feasible] = batch.theta
        tip[feasible] = batch.tip
        pres[feasible] = batch.pressure
        stability[feasible] = batch.stability
        method[feasible] = batch.method
        ok = batch.ok  # a property computed over the whole batch: read once, not once per point
        for j, i in enumerate(feasible):
            notes[i] = batch.notes[j]
            if not ok[j]:
                status[i], messages[i] = "not ok", batch.messages[j]
        backend, timings = batch.backend, dict(batch.timings)
        found = assess_arrays(
            n, cols["L"][feasible], cols["r1"][feasible], cols["r2"][feasible], cols["d"][feasible], theta[feasible], tip[feasible, 0], pres[feasible],
            cols["payload"][feasible] if plan.payload_swept else max((p.force for p in base.payloads), default=0.0),
        )
        for j, i in enumerate(feasible):
            validity[i] = found[j]
    return {
        "status": status.astype(str),
        "messages": messages,
        "notes": notes,
        "validity": validity,
        "pressure": pres,
        "theta": theta,
        "tip": tip,
        "stability": stability.astype(str),
        "method": method.astype(str),
        "backend": backend,
        "timings": timings,
    }


# ---------------------------------------------------------------------------------------------
# rows


def row_fields(n: int) -> list[str]:
    """The columns of a sweep's rows (and CSV file) for n segments."""
    head = [*AXIS_COLUMNS.values(), "status", "stability", "method", "total_angle_deg", "tip_x_mm", "tip_y_mm"]
    return head + [f"theta{k + 1}_deg" for k in range(n)] + ["message", "notes", "validity"]


def _number(v: float) -> float | None:
    """A finite float, else None (an empty cell, JSON null: never NaN)."""
    v = float(v)
    return v if math.isfinite(v) else None


def point_rows(points: Mapping[str, np.ndarray], part: Mapping[str, Any]) -> list[dict[str, Any]]:
    """One dict per point (the columns of :func:`row_fields`): the axes, status, angles (degrees),
    tip (mm), solver facts; None where a value is undefined (an infeasible point, a solve that
    left no finite angle).

    ``points`` are the points' axis columns (:meth:`SweepPlan.columns`), ``part`` the arrays of
    :func:`solve_points` (or of a :class:`SweepResult`).
    """
    out = []
    theta, tip = part["theta"], part["tip"]
    n = theta.shape[1]
    for i in range(len(part["status"])):
        feasible = part["status"][i] != "infeasible"
        row: dict[str, Any] = {column: _number(points[axis][i]) for axis, column in AXIS_COLUMNS.items()}
        row["pressure_mpa"] = _number(part["pressure"][i] if feasible else points["pressure"][i])
        row.update({
            "status": str(part["status"][i]),
            "stability": str(part["stability"][i]),
            "method": str(part["method"][i]),
            "total_angle_deg": _number(math.degrees(float(np.sum(theta[i])))) if feasible else None,
            "tip_x_mm": _number(tip[i, 0]) if feasible else None,
            "tip_y_mm": _number(tip[i, 1]) if feasible else None,
        })
        for k in range(n):
            row[f"theta{k + 1}_deg"] = _number(math.degrees(theta[i, k])) if feasible else None
        row["message"] = part["messages"][i]
        row["notes"] = " | ".join(part["notes"][i])
        found = part.get("validity")
        row["validity"] = " | ".join(f.message for f in found[i]) if found else ""
        out.append(row)
    return out


def csv_cells(row: Mapping[str, Any]) -> dict[str, Any]:
    """A row as CSV cells: None as an empty cell."""
    return {k: ("" if v is None else v) for k, v in row.items()}


def parse_row(cells: Mapping[str, str]) -> dict[str, Any]:
    """A row read back from CSV: numbers as floats (exact: Python writes floats in their shortest
    round-trip form), empty cells as None, text as text.

    >>> parse_row({"pressure_mpa": "0.1", "tip_x_mm": "", "status": "ok"})
    {'pressure_mpa': 0.1, 'tip_x_mm': None, 'status': 'ok'}
    """
    return {k: (v if k in TEXT_FIELDS else (float(v) if v != "" else None)) for k, v in cells.items()}


_STATUSES = ("ok", "not ok", "infeasible")


def _cell_number(text: Any) -> float | None:
    """A numeric cell as the writer writes it: '' (None) or a finite decimal number; else ValueError."""
    if text is None or text == "":
        return None
    value = checks.number("cell", text, subnormal=True) if isinstance(text, str) else float(text)  # as written: any double
    if not math.isfinite(value):
        raise ValueError(text)
    return value


def resumed_row_problem(plan: SweepPlan, index: int, cells: Mapping[str, Any], points: Mapping[str, np.ndarray] | None = None) -> str:
    """Why row ``index`` (0-based) of a study file cannot be point ``index`` of ``plan`` solved,
    or ``""`` when it can.

    The row's axis values must be the plan's point ``index`` (the pressure too, unless the grid
    finds each point's pressure from a target angle), exactly: numbers are written in their
    shortest round-trip form. Its result cells must be what a solved row holds: a status the
    sweep writes; for ``ok`` a stable equilibrium with finite angles, tip and pressure, a total
    angle that is the sum of the angles and a tip within the actuator's length of the base; for
    ``infeasible`` no result; never NaN or infinity. ``cells`` are text (as read from the file)
    or numbers; ``points`` are the plan's axis columns of the rows around ``index``
    (:meth:`SweepPlan.columns`; computed when not given).

    This takes the plan and a row, not a file: any reader of a study's rows can call it.

    >>> from esba.model.scene import Scene
    >>> plan = plan_sweep(Scene(pressure=0.1), pressure=[0.0, 0.1])
    >>> resumed_row_problem(plan, 1, {"pressure_mpa": "0.123456", "status": "infeasible"})
    'has pressure_mpa=0.123456 where the plan has 0.1 (an edited or misplaced row)'
    """
    if points is None:
        points = plan.columns(index, index + 1)
        at = 0
    else:
        at = index
    for axis, column in AXIS_COLUMNS.items():
        if axis == "pressure" and plan.angle_mode:
            continue
        raw = cells.get(column)
        try:
            value = _cell_number(raw)
        except ValueError:
            return f"has a {column} cell that is not a finite number"
        want = float(points[axis][at])
        if value != want:
            shown = raw if isinstance(raw, str) else repr(value)
            return f"has {column}={shown} where the plan has {want!r} (an edited or misplaced row)"
    status = cells.get("status")
    if status not in _STATUSES:
        return f"has status={checks.quote(status, 30)}; a sweep writes {', '.join(_STATUSES)}"
    numbers = ["pressure_mpa", "total_angle_deg", "tip_x_mm", "tip_y_mm"] + [f"theta{k + 1}_deg" for k in range(plan.base.segments)]
    got: dict[str, float | None] = {}
    for column in numbers:
        try:
            got[column] = _cell_number(cells.get(column))
        except ValueError:
            return f"has a {column} cell that is neither a finite number nor empty"
    results = numbers[1:]
    if status == "infeasible":
        filled = [c for c in results if got[c] is not None]
        return f"is infeasible but has {filled[0]}={cells.get(filled[0])}" if filled else ""
    if status == "not ok":
        return ""
    missing = [c for c in numbers if got[c] is None]
    if missing:
        return f"is ok but has no {missing[0]}"
    if cells.get("stability") != "stable" or cells.get("method") not in METHODS[:-1]:
        return f"is ok but its stability is {checks.quote(cells.get('stability'), 30)} and method {checks.quote(cells.get('method'), 30)}"
    if got["pressure_mpa"] < 0:
        return f"is ok at pressure_mpa={cells.get('pressure_mpa')} < 0"
    total = sum(got[f"theta{k + 1}_deg"] for k in range(plan.base.segments))
    if abs(total - got["total_angle_deg"]) > 1e-9 * max(1.0, abs(total)):
        return f"has total_angle_deg={cells.get('total_angle_deg')}, not the sum of its angles ({total:.12g})"
    L = float(points["L"][at])
    if math.hypot(got["tip_x_mm"], got["tip_y_mm"]) > L * (1 + 1e-9):
        return f"has its tip ({cells.get('tip_x_mm')}, {cells.get('tip_y_mm')}) mm further from the base than the length L"
    x, y = chain_tip([math.radians(got[f"theta{k + 1}_deg"]) for k in range(plan.base.segments)], L)
    if max(abs(x - got["tip_x_mm"]), abs(y - got["tip_y_mm"])) > 1e-8 * L:
        return f"has its tip ({cells.get('tip_x_mm')}, {cells.get('tip_y_mm')}) mm where its angles put it at ({x:.12g}, {y:.12g}) mm"
    return ""


def check_resumed_rows(plan: SweepPlan, rows: Sequence[Mapping[str, Any]], where: str = "study file") -> int:
    """:func:`resumed_row_problem` for every row, in order; the number of rows.

    Raises
    ------
    SweepError
        naming the first bad row (1-based) and what is wrong with it.
    """
    if len(rows) > plan.size:
        raise SweepError(f"{where}: {len(rows)} rows; the plan has {plan.size} points")
    points = plan.columns(0, len(rows))
    for i, row in enumerate(rows):
        problem = resumed_row_problem(plan, i, row, points)
        if problem:
            raise SweepError(f"{where}: row {i + 1} {problem}")
    return len(rows)


# ---------------------------------------------------------------------------------------------
# the result


@dataclass(frozen=True, eq=False, repr=False)
class SweepResult(Report):
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
        Where each point leaves the range the paper's model describes (:mod:`esba.model.validity`).
    backend : str
        How the batch path ran (compiled or interpreted, and why), decided once for the grid.
    timings : dict
        Wall times of the batch path in s (summed over chunks).
    identity : dict or None
        What fixes the study's answers (:func:`study_identity`), for the metadata of its CSV file.
    settings : dict
        Decisions taken when it ran (``compile``: ``always`` or ``never``; ``backend``).
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
    backend: str = ""
    timings: dict = dataclasses.field(default_factory=dict)
    notes: tuple[tuple[str, ...], ...] = ()
    validity: tuple[tuple[Finding, ...], ...] = ()
    identity: dict | None = None
    settings: dict = dataclasses.field(default_factory=dict)

    _plotter = "esba.figures.results:draw_sweep"

    def headline(self) -> str:
        """One line: the axes, the points and how many are ok."""
        axes = ", ".join(f"{k} ({len(v)})" for k, v in self.axes.items())
        c = self.counts()
        return f"{self.status.size} points over {axes}: {c['ok']} ok, {c['not ok']} not ok, {c['infeasible']} infeasible"

    def summary(self) -> str:
        """The text ``esba sweep`` prints for this grid."""
        return sweep_table(self.to_dict())

    @classmethod
    def from_parts(cls, plan: SweepPlan, parts: Sequence[Mapping[str, Any]], backend: str,
                   identity: dict | None = None, settings: Mapping[str, Any] | None = None) -> SweepResult:
        """The result of a whole grid from the :func:`solve_points` arrays of its chunks, in order."""
        timings: dict[str, float] = {}
        for p in parts:
            for k, v in p["timings"].items():
                timings[k] = timings.get(k, 0.0) + v
        return cls(
            base=plan.base,
            axes=plan.axes,
            points=plan.columns(),
            status=np.concatenate([p["status"] for p in parts]),
            messages=tuple(m for p in parts for m in p["messages"]),
            pressure=np.concatenate([p["pressure"] for p in parts]),
            theta=np.vstack([p["theta"] for p in parts]),
            tip=np.vstack([p["tip"] for p in parts]),
            stability=np.concatenate([p["stability"] for p in parts]),
            method=np.concatenate([p["method"] for p in parts]),
            backend=backend,
            timings=timings,
            notes=tuple(tuple(t) for p in parts for t in p["notes"]),
            validity=tuple(tuple(v) for p in parts for v in p.get("validity", [()] * len(p["status"]))),
            identity=identity,
            settings=dict(settings or {}),
        )

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

    def counts(self) -> dict[str, int]:
        """Points ok, not ok and infeasible."""
        return {s: int(np.sum(self.status == s)) for s in ("ok", "not ok", "infeasible")}

    def tally(self) -> Tally:
        """The points outside the model's range, by check (:class:`esba.model.validity.Tally`)."""
        t = Tally()
        for found in self.validity:
            t.add(found)
        return t

    def scene(self, i: int) -> Scene:
        """The scene of point ``i`` (the base scene with the point's axis values)."""
        changes: dict[str, Any] = {k: float(self.points[k][i]) for k in ACTUATOR_AXES}
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
        """One dict per point: the axes, status, angles (degrees), tip (mm), solver facts, validity (:func:`point_rows`)."""
        part = {
            "status": self.status, "stability": self.stability, "method": self.method, "pressure": self.pressure,
            "theta": self.theta, "tip": self.tip, "messages": self.messages, "notes": self.notes,
            "validity": self.validity,
        }
        return point_rows(self.points, part)

    def to_csv(self) -> str:
        """The rows as CSV text (empty cells where a value is undefined)."""
        buf = io.StringIO()
        writer = csv.DictWriter(buf, fieldnames=row_fields(self.base.segments), lineterminator="\n")
        writer.writeheader()
        for r in self.rows():
            writer.writerow(csv_cells(r))
        return buf.getvalue()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the base scene, the axes, counts, the backend and every row."""
        return {
            "base": self.base.describe(),
            "segments": self.base.segments,
            "axes": {k: {"values": v, "unit": AXES[k]} for k, v in self.axes.items()},
            "counts": self.counts(),
            "outside_model_range": sum(1 for v in self.validity if v),
            "backend": self.backend,
            "timings_s": dict(self.timings),
            "rows": self.rows(),
        }

    def write(self, path: str | Path) -> Path:
        """Write CSV (``.csv``) or JSON (``.json``, no NaN) by the file's suffix; the folder must exist.

        A CSV file is a study file, as a sweep on Dask writes it: the rows (``pandas.read_csv(path)``
        reads them), the study's metadata beside them (:func:`esba.studies.chunks.sidecar`), and
        the study lock while it is written (:class:`esba.studies.chunks.StudyFile`).
        """
        path = Path(path)
        if path.suffix.lower() == ".csv":
            from .chunks import write_study

            identity = self.identity if self.identity is not None else study_identity(plan_sweep(self.base, **self.axes), DEFAULT_BATCH_OPTIONS)
            rows = [csv_cells(r) for r in self.rows()]
            write_study(path, "sweep", identity, row_fields(self.base.segments), rows, self.settings)
            return path
        if path.suffix.lower() == ".json":
            text = jsonsafe.dumps(self.to_dict(), indent=1)
        else:
            raise SweepError(f"output {str(path)!r}: expected a .csv or .json file")
        return outputs.write_text(path, text)  # WriteFailed (one line naming the file) when the disk is full


def sweep(
    base: Scene | None = None,
    *,
    pressure=None,
    payload=None,
    payload_angle=None,
    options: BatchOptions | None = None,
    **actuator,
) -> SweepResult:
    """Solve every point of the grid of the given axes around ``base`` in one batch.

    Parameters
    ----------
    base : Scene, optional
        Everything not swept (default ``Scene()``: Table 1 at its 90 degree pressure, n = 3).
        Without a ``pressure`` axis the base scene's pressure (or target angle, per geometry) is used.
    pressure, payload, payload_angle : float or sequence of float, optional
        Axis values (MPa, N, degrees). A ``payload`` or ``payload_angle`` axis replaces the base
        scene's payloads with one payload.
    **actuator : float or sequence of float, optional
        Any field of the actuator as an axis, named as in a scene file's ``[actuator]`` table:
        ``L``, ``r1``, ``r2``, ``d`` (mm), ``rho_deg`` (degrees), ``E`` (MPa), ``M`` (kg).
    options : BatchOptions, optional
        ``compile="auto"`` is decided once for the whole grid (:func:`esba.statics.batch.decide_backend`).

    Returns
    -------
    SweepResult
    """
    if options is not None and not isinstance(options, BatchOptions):
        raise SweepError(f"options={checks.quote(options)}: expected a BatchOptions (esba.statics.batch.BatchOptions) or None")
    plan = plan_sweep(base, pressure=pressure, payload=payload, payload_angle=payload_angle, **actuator)
    check_points(plan)
    check_size(plan.size, plan.base.segments, "the sweep", SweepError)
    check_resolvable(plan)
    identity = study_identity(plan, DEFAULT_BATCH_OPTIONS if options is None else options)
    options, backend = decide_backend(plan.base.model(), options, plan.angle_mode, plan.size)
    part = solve_points(plan, 0, plan.size, options)
    return SweepResult.from_parts(plan, [part], backend, identity, {"compile": options.compile, "backend": backend})


def study_identity(plan: SweepPlan, options: BatchOptions) -> dict[str, Any]:
    """Everything that fixes a sweep's rows (the grid, the scene, the batch settings as given, the
    esba code): the identity in its study file's metadata (:class:`esba.studies.chunks.StudyFile`),
    the same whether it ran in this process or chunk by chunk."""
    from .distributed import code_digest

    batch = {k: v for k, v in dataclasses.asdict(options).items() if k not in ("progress", "cache")}
    return {"plan": plan.describe(), "batch": batch, "esba": code_digest()}


def sweep_table(d: dict) -> str:
    """The text ``esba sweep`` prints for :meth:`SweepResult.to_dict` (or a study's, with the ``out`` and ``figure`` the command adds)."""

    def axis(k: str, v: dict) -> str:  # a long axis as its range (JSON keeps every value)
        values = v["values"]
        return f"{k} {values} {v['unit']}" if len(values) <= 8 else f"{k} {len(values)} values from {min(values):g} to {max(values):g} {v['unit']}"

    lines = [f"base: {d['base']}", "axes: " + "; ".join(axis(k, v) for k, v in d["axes"].items())]
    lines.append("points: " + ", ".join(f"{count} {status}" for status, count in d["counts"].items()) + f"; {d['backend']}")
    st = d.get("study")
    if st:
        resumed = f", resumed at row {st['resumed_from_row']}" if st["resumed_from_row"] else ""
        lines.append(f"study: {st['chunks_solved']} chunks of up to {st['chunk']} points {st['runner']} in {st['seconds']:.1f} s{resumed}")
    rows = d.get("rows")

    def num(v, fmt: str) -> str:
        return "-" if v is None else format(v, fmt)

    if rows is not None and len(rows) <= 60:
        extra = [k for k in d["axes"] if k in ACTUATOR_AXES and k not in ("r2", "d")]  # other swept actuator fields
        head = (f"{'P MPa':>9} {'F N':>6} {'Om deg':>7} {'r2':>6} {'d':>6}" + "".join(f" {k.removesuffix('_deg'):>7}" for k in extra)
                + f" {'angle deg':>10} {'tip x, y mm':>18}  status")
        lines.append(head)
        snapped = 0
        for r in rows:
            ang = "" if r["total_angle_deg"] is None else f"{r['total_angle_deg']:10.3f}"
            tip = "" if r["tip_x_mm"] is None else f"{r['tip_x_mm']:8.2f}, {r['tip_y_mm']:8.2f}"
            snap = "snap-through" in (r.get("notes") or "")
            snapped += snap
            lines.append(f"{num(r['pressure_mpa'], '9.5f'):>9} {num(r['payload_n'], '6.3g'):>6} {num(r['payload_angle_deg'], '7.3g'):>7} "
                         f"{num(r['r2_mm'], '6.3g'):>6} {num(r['d_mm'], '6.3g'):>6}" + "".join(f" {num(r[AXIS_COLUMNS[k]], '7.4g'):>7}" for k in extra)
                         + f" {ang:>10} {tip:>18}  {r['status']}"
                         + (", snapped" if snap else ""))
        if snapped:
            lines.append(f"snapped: {snapped} point(s) jumped on their load path (a fold); where and from which state: the notes (--json, --out)")
    else:
        total = sum(d["counts"].values())
        lines.append(f"{total} rows" + (f" in {d['out']}" if d.get("out") else ": write them with --out FILE.csv or FILE.json"))
    nothing = bool(st) and st["chunks_solved"] == 0 and st["resumed_from_row"] == st["rows"]
    for k in ("out", "figure"):
        if d.get(k):
            if k == "out" and nothing:
                lines.append(f"{d[k]} already holds every row of this study ({st['rows']}): nothing solved, nothing written")
            else:
                lines.append(f"wrote {d[k]}")
    return "\n".join(lines)

"""Sweeps of 3-D scenes: the 3-D model (:mod:`esba.statics.spatial`) over a grid of scene parameters,
in this process or on Dask workers, written as one CSV study file with its ``FILE.study.json``.

Axes (any of them, values in the units of the scene file and the flags):

==========================  =========  ====================================================
axis                        unit       what it sets
==========================  =========  ====================================================
``pressure``                MPa        the pressure
``payload``                 N          the first payload's magnitude
``payload_angle``           deg        its direction Omega in the bending plane
``payload_out_of_plane``    deg        its angle beta out of the plane (-90..90)
``EI_side``, ``GJ``         N mm^2     the section's sideways and torsional stiffness
``L``, ``r1``, ..., ``M``   as ever    any actuator field (``rho_deg`` in degrees)
==========================  =========  ====================================================

Each point is solved on its own along its load history (:func:`esba.statics.spatial.solve3d`:
inflate, then raise the loads; no warm start from a neighbour), so its answer depends on the point
alone: any split into chunks, any runner, gives the same rows. A row is ``ok`` (converged and
stable), ``not ok`` (with the reason) or ``infeasible`` (an actuator outside the design space).

The chunks run through :func:`esba.studies.chunks.run_chunks` on a runner of
:mod:`esba.studies.distributed` (serial, or Dask), as the planar sweep's do; with ``out`` the rows
stream to a CSV :class:`esba.studies.chunks.StudyFile` (kind ``sweep3d``) and its metadata beside it,
and ``resume=True`` continues an interrupted study from the rows its file holds (each checked against
the plan: :func:`resumed_row_problem3d`), here or on Dask.

>>> from esba.model.scene import Scene, Payload
>>> plan = plan_sweep3d(Scene(pressure=0.1, payloads=(Payload(0.5, 90.0),)), {"EI_side": 4e5, "GJ": 1e5}, payload_out_of_plane=[0.0, 30.0])
>>> s = sweep3d_study(plan)
>>> [r["status"] for r in s.rows], [round(r["tip_z_mm"], 3) for r in s.rows]
(['ok', 'ok'], [0.0, 0.654])
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from esba.infra import checks
from esba.infra.errors import InputError
from esba.model.scene import ACTUATOR_RULES, MAX_PAYLOAD, MAX_PRESSURE, Payload, Scene, SceneError, check_actuator_field

__all__ = ["AXES3D", "Sweep3DPlan", "Sweep3DError", "plan_sweep3d", "solve_points3d", "row_fields3d", "sweep3d_study", "Sweep3DStudy",
           "MAX_POINTS_3D"]

#: The most points of a 3-D sweep (each a load history of damped Newton solves in Python, about 10 ms at n = 3).
MAX_POINTS_3D = 100_000

#: Each non-actuator axis: (unit, CSV column).
_LOAD_AXES = {"pressure": ("MPa", "pressure_mpa"), "payload": ("N", "payload_n"), "payload_angle": ("deg", "payload_angle_deg"),
              "payload_out_of_plane": ("deg", "payload_out_of_plane_deg"), "EI_side": ("N*mm^2", "EI_side_nmm2"), "GJ": ("N*mm^2", "GJ_nmm2")}
_ACTUATOR_COLUMNS = {"L": "L_mm", "r1": "r1_mm", "r2": "r2_mm", "d": "d_mm", "rho_deg": "rho_deg", "E": "E_mpa", "M": "M_kg"}
#: Every axis and its unit.
AXES3D = {**{k: v[0] for k, v in _LOAD_AXES.items()}, **{k: ("deg" if k == "rho_deg" else "") for k in _ACTUATOR_COLUMNS}}


class Sweep3DError(InputError):
    """A bad 3-D sweep (one line naming the axis, the value and what is allowed)."""


def _check(name: str, value: Any) -> float:
    v = checks.finite(f"axis {name}", value, Sweep3DError)
    if name == "pressure" and not 0.0 <= v <= MAX_PRESSURE:
        raise Sweep3DError(f"axis pressure={v:g}: expected a pressure from 0 to {MAX_PRESSURE:g} MPa")
    if name == "payload" and not 0.0 <= v <= MAX_PAYLOAD:
        raise Sweep3DError(f"axis payload={v:g}: expected a magnitude from 0 to {MAX_PAYLOAD:g} N")
    if name == "payload_out_of_plane" and not -90.0 <= v <= 90.0:
        raise Sweep3DError(f"axis payload_out_of_plane={v:g}: expected an angle from -90 to 90 deg")
    if name in ("EI_side", "GJ") and not v > 0.0:
        raise Sweep3DError(f"axis {name}={v:g}: expected a stiffness > 0 N*mm^2")
    if name in ACTUATOR_RULES:
        try:
            check_actuator_field(name, v, f"axis {name}")
        except SceneError as exc:
            raise Sweep3DError(str(exc)) from None
    return v


@dataclass(frozen=True)
class Sweep3DPlan:
    """A validated 3-D grid: the base scene, the section, and the axes (name -> values), in C order."""

    base: Scene
    section: dict
    axes: dict

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(v) for v in self.axes.values())

    @property
    def size(self) -> int:
        return int(np.prod(self.shape)) if self.axes else 1

    def point(self, i: int) -> dict[str, float]:
        """The axis values of point ``i``."""
        idx = np.unravel_index(i, self.shape) if self.axes else ()
        return {k: float(v[j]) for (k, v), j in zip(self.axes.items(), idx)}

    def identity(self) -> dict[str, Any]:
        """Everything that fixes the rows (JSON-ready): the scene, the section, the axes and the esba code."""
        import dataclasses

        from esba.studies.distributed import code_digest

        return {"model": "3d", "base": self.base.describe(), "scene": dataclasses.asdict(self.base), "segments": self.base.segments,
                "variant": self.base.variant, "section": dict(self.section), "axes": {k: list(v) for k, v in self.axes.items()}, "esba": code_digest()}


def plan_sweep3d(base: Scene | None = None, section: Mapping[str, float] | None = None, **axes: Sequence[float]) -> Sweep3DPlan:
    """A 3-D sweep grid over ``axes`` (see the module), on ``base`` with the ``section`` stiffnesses
    (the eccentric section's where not given). Every value is checked before anything is solved."""
    from esba.statics.spatial import SpatialError, check_section

    base = Scene() if base is None else base
    if not isinstance(base, Scene):
        raise Sweep3DError(f"base={base!r:.60}: expected a Scene")
    if getattr(base, "obstacles", ()):
        raise Sweep3DError("base: the scene has obstacles (contact), which only the planar model carries")
    try:
        section = check_section(section, base)
    except SpatialError as exc:
        raise Sweep3DError(str(exc)) from None
    clean: dict[str, tuple[float, ...]] = {}
    for name, values in axes.items():
        if name not in AXES3D:
            raise Sweep3DError(f"axis {name!r}: allowed are {', '.join(AXES3D)}")
        if values is None:
            continue
        vals = tuple(_check(name, v) for v in (values if isinstance(values, (list, tuple, np.ndarray)) else [values]))
        if not vals:
            raise Sweep3DError(f"axis {name}: expected at least one value")
        clean[name] = vals
    if base.pressure is None and "pressure" not in clean:
        raise Sweep3DError("the base scene sets a target angle: give the pressure (a pressure axis, or Scene(pressure=...))")
    if not base.payloads and any(k.startswith("payload") for k in clean):
        base = base.replace(payloads=(Payload(0.0, 90.0),))
    size = int(np.prod([len(v) for v in clean.values()])) if clean else 1
    if size > MAX_POINTS_3D:
        raise Sweep3DError(f"a 3-D grid of {size} points: at most {MAX_POINTS_3D}")
    return Sweep3DPlan(base, dict(section), clean)


def row_fields3d(n: int, plan: Sweep3DPlan) -> list[str]:
    """The CSV columns of a 3-D sweep's rows."""
    cols = [(_LOAD_AXES[k][1] if k in _LOAD_AXES else _ACTUATOR_COLUMNS[k]) for k in plan.axes]
    cols += ["status", "stable", "min_eigenvalue"]
    cols += [f"{c}{i}_deg" for c in ("theta", "psi", "tau") for i in range(1, n + 1)]
    cols += ["total_angle_deg", "total_twist_deg", "tip_x_mm", "tip_y_mm", "tip_z_mm", "message"]
    return cols


def _scene_of(plan: Sweep3DPlan, point: Mapping[str, float]) -> tuple[Scene, dict]:
    scene = plan.base
    changes: dict[str, Any] = {k: v for k, v in point.items() if k in _ACTUATOR_COLUMNS}
    if "pressure" in point:
        changes["pressure"] = point["pressure"]
    if any(k.startswith("payload") for k in point):
        p = scene.payloads[0]
        first = Payload(point.get("payload", p.force), point.get("payload_angle", p.angle_deg), p.at,
                        point.get("payload_out_of_plane", p.out_of_plane_deg))
        changes["payloads"] = (first, *scene.payloads[1:])
    scene = scene.replace(**changes) if changes else scene
    section = {k: point.get(k, plan.section[k]) for k in ("EI_side", "GJ")}
    return scene, section


def solve_points3d(plan: Sweep3DPlan, start: int, stop: int) -> list[dict[str, Any]]:
    """The rows of points ``start`` to ``stop``: a pure function of its arguments (any chunk, anywhere)."""
    from esba.model.spatial import load_model3d
    from esba.statics.spatial import scene_values3d, solve3d

    n = plan.base.segments
    rows = []
    for i in range(start, stop):
        point = plan.point(i)
        row: dict[str, Any] = {(_LOAD_AXES[k][1] if k in _LOAD_AXES else _ACTUATOR_COLUMNS[k]): v for k, v in point.items()}
        try:
            scene, section = _scene_of(plan, point)
        except SceneError as exc:
            row.update(status="infeasible", message=str(exc))
            rows.append(row)
            continue
        effects, values = scene_values3d(scene, section, scene.down())
        model = load_model3d(n, effects, scene.variant)
        eq = solve3d(model, values, certify=False, descend=True)
        status = "ok" if eq.ok else "not ok"
        why = "" if eq.ok else ("not converged" if not eq.converged else "unstable: the 3n x 3n Hessian is not positive definite")
        q = np.degrees(eq.q)
        row.update(status=status, stable=bool(eq.stable), min_eigenvalue=float(eq.min_eigenvalue), message="; ".join(x for x in (why, *eq.notes) if x))
        for c, block in zip(("theta", "psi", "tau"), (q[:n], q[n:2 * n], q[2 * n:])):
            row.update({f"{c}{j + 1}_deg": float(v) for j, v in enumerate(block)})
        row.update(total_angle_deg=float(np.sum(q[:n])), total_twist_deg=float(np.sum(q[2 * n:])),
                   tip_x_mm=float(eq.tip[0]), tip_y_mm=float(eq.tip[1]), tip_z_mm=float(eq.tip[2]))
        rows.append(row)
    return rows


_STATUSES3D = ("ok", "not ok", "infeasible")


def resumed_row_problem3d(plan: Sweep3DPlan, index: int, cells: Mapping[str, str]) -> str:
    """Why row ``index`` (0-based) of a 3-D study file cannot be point ``index`` of ``plan`` solved, or ``""``.

    Its axis cells must be the plan's point exactly (numbers are written in their shortest
    round-trip form); its status one the sweep writes; an ``ok`` row a stable state with finite
    angles and tip, whose total angle and twist are the sums of its angles.

    >>> plan = plan_sweep3d(Scene(pressure=0.1), {"EI_side": 4e5, "GJ": 1e5}, GJ=[1e4, 2e4])
    >>> resumed_row_problem3d(plan, 1, {"GJ_nmm2": "10000.0", "status": "infeasible"})
    'has GJ_nmm2=10000.0 where the plan has 20000.0 (an edited or misplaced row)'
    """
    n = plan.base.segments

    def number(column: str) -> float:
        raw = cells.get(column, "")
        value = checks.number(column, raw, subnormal=True) if raw != "" else float("nan")
        if raw != "" and not np.isfinite(value):
            raise ValueError(raw)
        return value

    point = plan.point(index)
    try:
        for axis, want in point.items():
            column = _LOAD_AXES[axis][1] if axis in _LOAD_AXES else _ACTUATOR_COLUMNS[axis]
            if number(column) != want:
                return f"has {column}={cells.get(column)} where the plan has {want!r} (an edited or misplaced row)"
        status = cells.get("status")
        if status not in _STATUSES3D:
            return f"has status={checks.quote(status, 30)}; a 3-D sweep writes {', '.join(_STATUSES3D)}"
        angles = {c: [number(f"{c}{i}_deg") for i in range(1, n + 1)] for c in ("theta", "psi", "tau")}
        results = [number(c) for c in ("min_eigenvalue", "total_angle_deg", "total_twist_deg", "tip_x_mm", "tip_y_mm", "tip_z_mm")]
    except ValueError:
        return "has a cell that is not a finite number (as written, an empty cell is no value)"
    if status == "ok":
        if cells.get("stable") != "True" or any(np.isnan(v) for v in [*results, *sum(angles.values(), [])]):
            return "is ok but is not a stable state with every angle and the tip"
        for total, c in ((results[1], "theta"), (results[2], "tau")):
            s = float(np.sum(angles[c]))
            if abs(total - s) > 1e-9 * max(1.0, abs(s)):
                return f"is ok but its total of {c} ({total!r}) is not the sum of its angles ({s:.12g})"
    return ""


@dataclass
class Sweep3DStudy:
    plan: Sweep3DPlan
    rows: list = field(default_factory=list)
    counts: dict = field(default_factory=dict)
    runner: str = ""
    chunks: int = 0
    seconds: float = 0.0
    out: Path | None = None
    hash: str | None = None
    resumed_from: int = 0


def sweep3d_study(plan: Sweep3DPlan, *, runner=None, chunk: int = 8, out: str | Path | None = None, resume: bool = False) -> Sweep3DStudy:
    """Solve the grid chunk by chunk on ``runner`` (default in this process); with ``out`` (a .csv)
    stream the rows to a study file with its ``.study.json`` (else keep them in memory). With
    ``resume`` continue the study in ``out`` from the rows it holds (each checked against the plan
    by :func:`resumed_row_problem3d`; a new study when the file does not exist or is empty), as the
    planar study does (:func:`esba.studies.sweep_runner.sweep_study`): every point is solved alone,
    so the resumed file is the uninterrupted one, byte for byte."""
    from esba.studies.chunks import StudyFile, checked_rows, chunk_bounds, run_chunks
    from esba.studies.distributed import ModelKey, SerialRunner

    if isinstance(chunk, bool) or not isinstance(chunk, int) or not 1 <= chunk <= 10_000:
        raise Sweep3DError(f"chunk={chunk!r}: expected a whole number of points from 1 to 10000")
    if resume and out is None:
        raise Sweep3DError("resume=True needs the study's file: give out=FILE.csv")
    runner = SerialRunner() if runner is None else runner
    t0 = time.perf_counter()
    columns = row_fields3d(plan.base.segments, plan)
    file = None
    rows: list[dict[str, Any]] = []
    counts: dict[str, int] = {}
    start = 0
    if out is not None:
        file = StudyFile(out, "sweep3d", plan.identity(), columns, plan.size)

        def count(row: dict[str, str]) -> None:  # each row the file holds, once checked
            counts[row["status"]] = counts.get(row["status"], 0) + 1

        if resume and file.path.exists() and file.path.stat().st_size > 0:
            start = file.resume(checked_rows(out, lambda i, row: resumed_row_problem3d(plan, i, row), count))
        else:
            file.start({})

    def keep(a: int, b: int, part: list[dict[str, Any]]) -> None:
        for r in part:
            counts[r["status"]] = counts.get(r["status"], 0) + 1
        if file is not None:
            file.append([{c: r.get(c) for c in columns} for r in part])
        else:
            rows.extend(part)

    bounds = chunk_bounds(start, plan.size, chunk)
    try:
        run_chunks(runner, ModelKey.of(plan.base), solve_points3d, bounds, lambda a, b: (plan, a, b), keep)
    finally:
        if file is not None:
            file.close()
    return Sweep3DStudy(plan, rows, counts, runner.description, len(bounds), time.perf_counter() - t0,
                        file.path if file is not None else None, file.hash if file is not None else None, start)

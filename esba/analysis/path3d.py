"""The path analysis of a scene in 3-D: ``esba path --3d``.

As :func:`esba.analysis.path_analysis.analyse` for the planar model, on a
:class:`esba.statics.spatial_paths.SpatialPathProblem`: the 3-D equilibrium at the start
(:func:`esba.statics.spatial.solve3d`, certified by IPOPT), its branch in one parameter by
pseudo-arclength continuation (the planar engine, :func:`esba.paths.continuation.trace`) with its
folds and branch points located, both sides of the branch crossing at each branch point (where an
in-plane state loses stability sideways: the sideways branches), and the quasi-static ramps up and
back (:func:`esba.paths.loading.history`) with where they jump.

Per point the state is split into the in-plane bend (sum of theta), the sideways bend (sum of psi)
and the twist (sum of tau), and the tip is a point in space (x, y, z).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from esba.paths.branch import Branch, SpecialPoint
from esba.paths.continuation import PathOptions, bifurcating_branches, trace
from esba.paths.loading import Ramp, follow
from esba.paths.problem import PathError
from esba.statics.spatial import solve3d
from esba.statics.spatial_paths import SpatialPathProblem

from .path_analysis import trace_window

__all__ = ["analyse3d", "PathAnalysis3D", "path3d_table", "split_angles"]

#: A state is "in the plane" when its sideways bend and twist are below this (rad, largest joint).
IN_PLANE_TOL = 1e-7


def split_angles(q: np.ndarray, n: int) -> tuple[float, float, float]:
    """(in-plane bend, sideways bend, twist) of a state: the sums of theta, psi and tau, degrees."""
    q = np.asarray(q, dtype=float)
    return tuple(math.degrees(float(np.sum(q[k * n:(k + 1) * n]))) for k in range(3))  # type: ignore[return-value]


def _mode_kind(vec: np.ndarray, n: int) -> str:
    """Where a critical mode moves the actuator: ``in-plane`` (theta only), ``sideways`` (psi, tau only) or ``mixed``."""
    if vec.size == 0:
        return ""
    a, b = float(np.linalg.norm(vec[:n])), float(np.linalg.norm(vec[n:]))
    if b <= 1e-6 * max(a, b):
        return "in-plane"
    if a <= 1e-6 * max(a, b):
        return "sideways"
    return "mixed"


def _special(sp: SpecialPoint, n: int) -> dict[str, Any]:
    bend, side, twist = split_angles(sp.theta, n)
    return {
        "kind": sp.kind,
        "label": sp.label,
        "lambda": sp.lam,
        "status": sp.status,
        "method": sp.method,
        "bifurcation": sp.bifurcation or None,
        "mode": _mode_kind(sp.eigenvector, n),
        "morse_before": sp.morse_before,
        "morse_after": sp.morse_after,
        "eigenvalue": sp.eigenvalue if math.isfinite(sp.eigenvalue) else None,
        "in_plane_deg": bend,
        "sideways_deg": side,
        "twist_deg": twist,
        "tip_mm": [float(v) for v in sp.tip],
        "q_deg": np.degrees(sp.theta).tolist(),
    }


def branch_dict(b: Branch, n: int, points: bool) -> dict[str, Any]:
    """A 3-D branch in JSON-ready form (degrees, mm)."""
    stable = b.stable
    out: dict[str, Any] = {
        "label": b.label,
        "parameter": b.name,
        "unit": b.unit,
        "points": len(b),
        "stopped": b.stopped,
        "stop_reason": b.stop_reason,
        "lambda_range": [float(np.min(b.lam)), float(np.max(b.lam))] if len(b) else None,
        "stable_points": int(np.sum(stable)),
        "special_points": [_special(s, n) for s in b.special],
    }
    if points and len(b):
        angles = np.array([split_angles(q, n) for q in b.theta])
        out.update({
            "lambda": b.lam.tolist(),
            "in_plane_deg": angles[:, 0].tolist(),
            "sideways_deg": angles[:, 1].tolist(),
            "twist_deg": angles[:, 2].tolist(),
            "tip_mm": b.tip.tolist(),
            "q_deg": np.degrees(b.theta).tolist(),
            "min_eigenvalue": b.eigenvalues[:, 0].tolist(),
            "morse_index": b.morse.astype(int).tolist(),
            "stable": stable.tolist(),
            "kind": [str(k) for k in b.kind],
        })
    return out


def _side_label(b: Branch, point: SpecialPoint, n: int, label: str) -> str:
    """A crossing branch named by where it goes: sideways to +z or -z (the tip's), or in the plane."""
    if not len(b):
        return b.label
    k = min(len(b) - 1, 1)
    dq = b.theta[k] - point.theta
    if float(np.linalg.norm(dq[n:])) > 1e-9 * max(1.0, float(np.linalg.norm(dq))):
        dz = float(b.tip[k, 2] - point.tip[2])
        return f"{label}sideways {'+z' if dz >= 0 else '-z'}"
    return f"{label}in the plane, {'bend up' if float(np.sum(dq[:n])) > 0 else 'bend down'}"


#: How far past a branch point met from a crossing branch a ramp looks for the stable state (times the parameter's typical size).
PAST_TOUCH = 1e-4
#: At most this many such branch points a ramp passes.
MAX_TOUCHES = 8


def _touch(ramp: Ramp, direction: float) -> SpecialPoint | None:
    """The last point where the ramp's stable branch turned back in lambda with its critical eigenvalue
    touching zero and no change of stability (Morse index 0 on both sides): where a sideways branch
    meets the in-plane one it came off (a supercritical pitchfork seen from its crossing branch)."""
    for piece in reversed(ramp.pieces):
        for sp in reversed(piece.special):
            if sp.kind == "fold" and sp.morse_before == 0 and sp.morse_after == 0 and (sp.lam - ramp.start) * direction >= 0:
                return sp
    return None


def ramps3d(problem: SpatialPathProblem, q0, lam0: float, values, options: PathOptions | None = None) -> list[Ramp]:
    """Quasi-static ramps from ``lam0`` to each value in turn (:func:`esba.paths.loading.follow`), and
    one thing more: a ramp that comes back along a sideways branch to the branch point where it left
    the in-plane branch turns back there in lambda with no loss of stability, so the engine's trace
    does not stop; the actuator goes on along the in-plane branch (the only stable state just past
    it), found by IPOPT just past the point and followed on. The ramp then lists the point among
    its ``branch_points`` (passed without a jump)."""
    out: list[Ramp] = []
    q, lam = np.asarray(q0, dtype=float), float(lam0)
    for target in values:
        target = float(target)
        direction = 1.0 if target >= lam else -1.0
        r = follow(problem, q, lam, target, options)
        for _ in range(MAX_TOUCHES):
            if r.reached:
                break
            sp = _touch(r, direction)
            if sp is None:
                break
            lam_j = sp.lam + direction * PAST_TOUCH * problem.scale
            qj, _ = problem.minimum(sp.theta, lam_j, 1e-10)
            if qj is None:
                break
            rest = follow(problem, qj, lam_j, target, options)
            r = dataclasses.replace(rest, start=r.start, jumps=r.jumps + rest.jumps, branch_points=r.branch_points + (sp,) + rest.branch_points,
                                    pieces=r.pieces + rest.pieces)
        out.append(r)
        if not r.reached:
            break
        q, lam = r.theta, r.lam
    return out


@dataclass(frozen=True, eq=False)
class PathAnalysis3D:
    """What :func:`analyse3d` found (the fields of :class:`esba.analysis.path_analysis.PathAnalysis`)."""

    scene: Any
    problem: SpatialPathProblem
    start_q: np.ndarray
    main: Branch
    crossing: tuple[Branch, ...]
    loading: tuple[Ramp, ...]
    lam_from: float
    lam_to: float
    section: Mapping[str, float]

    @property
    def branches(self) -> tuple[Branch, ...]:
        return (self.main, *self.crossing)

    @property
    def hysteresis(self) -> dict[str, Any] | None:
        if len(self.loading) < 2 or not self.loading[0].jumps or not self.loading[1].jumps:
            return None
        up = [j.lam for j in self.loading[0].jumps]
        down = [j.lam for j in self.loading[1].jumps]
        loops = [{"up": a, "down": b, "width": abs(a - b)} for a, b in zip(up, reversed(down))]
        return {"up": up, "down": down, "width": loops[0]["width"], "loops": loops}

    def to_dict(self, points: bool = True) -> dict[str, Any]:
        n = self.problem.segments
        p = self.problem
        bend, side, twist = split_angles(self.start_q, n)
        ramps = []
        for r in self.loading:
            jumps = []
            for j in r.jumps:
                tb, ta = np.asarray(j.tip_before, dtype=float), np.asarray(j.tip_after, dtype=float)
                before, after = split_angles(j.theta_before, n), split_angles(j.theta_after, n)
                jumps.append({"kind": j.kind, "lambda": j.lam, "lambda_after": j.lam_after,
                              "mode": _mode_kind(j.point.eigenvector, n),
                              "angles_before_deg": list(before), "angles_after_deg": list(after),
                              "tip_before_mm": tb.tolist(), "tip_after_mm": ta.tolist(),
                              "distance_mm": float(np.linalg.norm(ta - tb)), "status": j.point.status})
            ramps.append({"from": r.start, "to": r.target, "reached": r.reached, "message": r.message, "jumps": jumps,
                          "branch_points_crossed": [s.lam for s in r.branch_points]})
        return {
            "scene": self.scene.describe() if self.scene is not None else "",
            "model": p.model.path.name,
            "three_d": True,
            "section_nmm2": {k: float(v) for k, v in self.section.items()},
            "parameter": p.name,
            "unit": p.unit,
            "from": self.lam_from,
            "to": self.lam_to,
            "start": {"in_plane_deg": bend, "sideways_deg": side, "twist_deg": twist,
                      "tip_mm": p.tip(self.start_q, self.lam_from).tolist(), "stability": "stable"},
            "branches": [branch_dict(b, n, points) for b in self.branches],
            "loading": ramps,
            "hysteresis": self.hysteresis,
        }


def analyse3d(scene, parameter: str, to: float, *, start: float | None = None, options: PathOptions | None = None, section: Mapping[str, float] | None = None,
              gravity_direction=None, switch: bool = True, loading: bool = True) -> PathAnalysis3D:
    """Trace ``scene``'s 3-D branch in ``parameter`` from ``start`` (default: the scene's value) to ``to``.

    Raises
    ------
    PathError
        for a parameter the 3-D path does not follow, or values outside its range (one line).
    RuntimeError
        when the scene has no stable 3-D equilibrium at the start value to begin from.
    """
    problem = SpatialPathProblem.from_scene(scene, parameter, section, gravity_direction=gravity_direction)
    lo, hi = problem.domain
    values = {"from": problem.lam0 if start is None else start, "to": to}
    for name, value in values.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or not lo <= value <= hi:
            raise PathError(f"{name}={value!r}: outside the range of {problem.name}, {lo:g} to {hi:g}{problem.unit_short}")
    lam_from, to = float(values["from"]), float(to)
    first = solve3d(problem.model, problem.values(lam_from))
    if not first.ok:
        why = "not converged" if not first.converged else f"unstable (smallest eigenvalue {first.min_eigenvalue:.3g})"
        raise RuntimeError(f"no stable 3-D equilibrium at the start ({problem.describe(lam_from)}) to trace from: {why}; "
                           f"start where the actuator is stable (--from), e.g. with no load, or see every equilibrium there with esba equilibria --3d")
    window = trace_window(problem, lam_from, to)
    main = trace(problem, first.q, lam_from, to=to, bounds=window, options=options, label="main")
    crossing: list[Branch] = []
    n = problem.segments
    if switch:
        for k, bp in enumerate(main.branch_points, start=1):
            for b in bifurcating_branches(problem, bp, bounds=window, options=options, label=f"BP{k} "):
                crossing.append(dataclasses.replace(b, label=_side_label(b, bp, n, f"BP{k} ")))
    ramps = tuple(ramps3d(problem, first.q, lam_from, [to, lam_from], options)) if loading and to != lam_from else ()
    sec = {k: problem.values(lam_from)[k] for k in ("EI_side", "GJ")}
    return PathAnalysis3D(scene, problem, first.q, main, tuple(crossing), ramps, lam_from, to, sec)


def path3d_table(d: dict) -> str:
    """The text ``esba path --3d`` prints."""
    unit = d["unit"].split(" ")[0]
    unit = "" if unit in ("1", "model") else f" {unit}"
    s = d["start"]
    lines = [f"scene: {d['scene']} (3-D: {d['model']}; EI_side {d['section_nmm2']['EI_side']:.6g}, GJ {d['section_nmm2']['GJ']:.6g} N mm^2)",
             f"path in {d['parameter']} from {d['from']:g} to {d['to']:g}{unit}",
             f"start: in-plane {s['in_plane_deg']:.3f} deg, sideways {s['sideways_deg']:.3f} deg, twist {s['twist_deg']:.3f} deg, stable"]
    for b in d["branches"]:
        lam = b["lambda_range"]
        span = f"{lam[0]:.6g} to {lam[1]:.6g}{unit}" if lam else "no points"
        lines.append(f"{b['label'] or 'branch'}: {b['points']} points, {span}, {b['stable_points']} stable; stopped: {b['stop_reason']}")
        if b["special_points"]:
            lines.append(f"  {'':2} {'point':<13} {d['parameter'] + unit:>16} {'in-plane':>9} {'sideways':>9} {'twist':>8} {'tip x, y, z mm':>26}  {'Morse':>5}  mode")
        for sp in b["special_points"]:
            tip = ", ".join(f"{v:7.2f}" for v in sp["tip_mm"])
            kind = sp["kind"] + (f" ({sp['bifurcation']})" if sp["bifurcation"] else "")
            lines.append(f"  {sp['label']:2} {sp['kind']:<13} {sp['lambda']:16.9g} {sp['in_plane_deg']:9.3f} {sp['sideways_deg']:9.3f} {sp['twist_deg']:8.3f} "
                         f"{tip:>26}  {sp['morse_before']}->{sp['morse_after']:<2}  {sp['mode'] or '-'}{'' if sp['status'] == 'converged' else ' [' + sp['status'] + ']'}"
                         + ("" if kind == sp["kind"] else f"; {sp['bifurcation']}"))
    for r in d["loading"]:
        what = f"quasi-static {d['parameter']} {r['from']:g} -> {r['to']:g}{unit}"
        for lam in r["branch_points_crossed"]:
            lines.append(f"{what}: passes the branch point {lam:.9g}{unit} and goes on along the stable branch crossing there")
        if not r["jumps"]:
            lines.append(f"{what}: no jump" + ("" if r["reached"] else f"; NOT reached: {r['message']}"))
        for j in r["jumps"]:
            a, b = j["angles_before_deg"], j["angles_after_deg"]
            lines.append(f"{what}: jumps at the {j['kind']} {j['lambda']:.9g}{unit} ({j['mode']} mode): in-plane {a[0]:.2f} -> {b[0]:.2f}, "
                         f"sideways {a[1]:.2f} -> {b[1]:.2f}, twist {a[2]:.2f} -> {b[2]:.2f} deg; tip moves {j['distance_mm']:.1f} mm")
        if r["jumps"] and not r["reached"]:
            lines.append(f"{what}: NOT reached: {r['message']}")
    if d.get("hysteresis"):
        for k, loop in enumerate(d["hysteresis"]["loops"], start=1):
            lines.append(f"hysteresis{'' if len(d['hysteresis']['loops']) == 1 else f' loop {k}'}: towards --to it jumps at {loop['up']:.9g}, back at {loop['down']:.9g}{unit}; "
                         f"width {loop['width']:.6g}{unit}")
    for k in ("out", "figure"):
        if d.get(k):
            lines.append(f"wrote {d[k]}")
    return "\n".join(lines)


def branches3d_csv(analysis: PathAnalysis3D) -> str:
    """Every point of every 3-D branch as CSV text (one header; a ``branch`` column names the branch)."""
    import csv
    import io

    n = analysis.problem.segments
    p = analysis.problem
    rows = []
    for b in analysis.branches:
        if not len(b):
            continue
        tips, eig, stable = b.tip, b.eigenvalues, b.stable
        for i in range(len(b)):
            bend, side, twist = split_angles(b.theta[i], n)
            row = {"branch": b.label, "point": i, "kind": str(b.kind[i]), "arclength": float(b.arclength[i]),
                   f"{p.name} ({p.unit.split(' ')[0]})": float(b.lam[i]), "in_plane_deg": bend, "sideways_deg": side, "twist_deg": twist,
                   "tip_x_mm": float(tips[i, 0]), "tip_y_mm": float(tips[i, 1]), "tip_z_mm": float(tips[i, 2]),
                   "min_eigenvalue": float(eig[i, 0]), "morse_index": int(b.morse[i]), "stable": bool(stable[i])}
            for name, k in (("theta", 0), ("psi", 1), ("tau", 2)):
                for j in range(n):
                    row[f"{name}{j + 1}_deg"] = math.degrees(float(b.theta[i, k * n + j]))
            rows.append(row)
    buf = io.StringIO()
    fields = list(rows[0]) if rows else ["branch", "point", "kind", "arclength", "lambda", "in_plane_deg", "sideways_deg", "twist_deg", "tip_x_mm", "tip_y_mm", "tip_z_mm"]
    writer = csv.DictWriter(buf, fieldnames=fields, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return buf.getvalue()


def write_branches3d(analysis: PathAnalysis3D, path) -> "Path":
    """Write the 3-D branches to ``path``: CSV for ``.csv``, JSON (every point) for ``.json``."""
    import json
    from pathlib import Path

    from esba.infra import outputs

    path = Path(path)
    if path.suffix.lower() == ".csv":
        outputs.write_text(path, branches3d_csv(analysis))
    elif path.suffix.lower() == ".json":
        outputs.write_text(path, json.dumps(analysis.to_dict(points=True), indent=1, sort_keys=True, allow_nan=False) + "\n")
    else:
        raise PathError(f"{str(path)!r}: expected a file name ending in .csv or .json")
    return path

"""The path analysis of a scene: its branch in one parameter, the branches crossing it, and the hysteresis.

:func:`analyse` is what ``esba path`` runs: from the scene's equilibrium (:func:`esba.statics.equilibrium.solve`)
at the start value of the parameter, it traces the branch to the target value (:func:`esba.paths.continuation.trace`),
traces both sides of every branch point on it (:func:`esba.paths.continuation.bifurcating_branches`), and loads
quasi-statically up to the target and back down (:func:`esba.paths.loading.history`), so that a bistable
range shows its folds, its unstable middle and the jumps of its hysteresis loop.

:func:`column_buckling_load` is the closed form of the straight actuator's buckling under a
compressive tip load, the check of every branch point found on that path.

Examples
--------
>>> from esba.model.scene import Scene, Payload
>>> s = analyse(Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),)), "pressure", 0.3)
>>> [(p.kind, round(p.lam, 5)) for p in s.main.special]
[('fold', 0.17354), ('fold', 0.1636)]
>>> round(s.hysteresis["width"], 5)
0.00993
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from esba.infra import checks
from esba.infra.report import Report
from esba.model.scene import Actuator, Scene, SceneError
from esba.model.validity import assess
from esba.paths.branch import Branch, branch_lines, special_counts
from esba.paths.continuation import PathOptions, bifurcating_branches, trace
from esba.paths.loading import Ramp, history
from esba.paths.problem import PathError, PathProblem
from esba.statics.equilibrium import Equilibrium, EquilibriumError, solve

__all__ = ["PathAnalysis", "analyse", "column_buckling_load"]


def column_buckling_load(actuator: Actuator | None = None, segments: int = 3) -> float:
    """The tip load (N) along the axis (Omega = 180 deg) at which the straight, unpressurised actuator buckles.

    At theta = 0 and P = 0 the Hessian of U is k0 I + F X'', where k0 is one segment's elastic
    stiffness at theta = 0 (Eq. 8 and Eq. 13 with Delta r2 = 0) and X'' the Hessian of the tip's x
    (a chain of arcs: x = L - (L / 2n) sum (phi_{i-1}^2 + phi_{i-1} theta_i + theta_i^2 / 3) + O(theta^4)).
    It is singular at F = k0 / lambda_max(-X'').

    Examples
    --------
    >>> round(column_buckling_load(segments=4), 4)
    3.2054
    """
    a = Actuator() if actuator is None else actuator
    if not isinstance(a, Actuator):
        raise SceneError(f"actuator={checks.quote(a)}: expected an esba.model.scene.Actuator (or None for Table 1)")
    n = checks.segments(segments, SceneError)  # 2.5 is refused, not taken as 2; at most MAX_SEGMENTS (an n x n eigenproblem)
    L, r1, r2, d, E = a.L, a.r1, a.r2, a.d, a.E
    k_axial = n * E * math.pi * (5 * r1**4 - 4 * r2**2 * (r1 + d) ** 2 - r2**4) / (4 * L)
    slope = n * (r1**3 - r2**2 * (d + r1)) / (2 * r2 * L)  # d Delta r2 / d theta_i at 0, Eq. (10)
    k_radial = E * math.pi * L * (r1 + r2) / (n * (r1 - r2)) * slope**2
    lower = np.tril(np.ones((n, n)), -1)  # row i: phi_{i-1} = sum_{j<i} theta_j
    eye = np.eye(n)
    quad = 2 * lower.T @ lower + lower.T @ eye + eye @ lower + (2.0 / 3.0) * eye
    return (k_axial + k_radial) / float(np.max(np.linalg.eigvalsh(L / (2 * n) * quad)))


@dataclass(frozen=True, eq=False, repr=False)
class PathAnalysis(Report):
    """What :func:`analyse` found.

    Attributes
    ----------
    scene : Scene
        The scene (the parameter at its start value).
    problem : PathProblem
    start : Equilibrium
        The scene's equilibrium at the start value (where every trace begins).
    main : Branch
        The branch through the start, traced to the target.
    crossing : tuple of Branch
        Both sides of the branch crossing at each branch point of ``main``.
    loading : tuple of Ramp
        Quasi-static loading up to the target and back to the start (empty when not asked).
    """

    scene: Scene
    problem: PathProblem = field(repr=False)
    start: Equilibrium = field(repr=False)
    main: Branch
    crossing: tuple[Branch, ...]
    loading: tuple[Ramp, ...]
    lam_from: float
    lam_to: float

    _plotter = "esba.figures.results:draw_path"

    def headline(self) -> str:
        """One line: the parameter's range, the branches and their special points."""
        special = [s for b in (self.main, *self.crossing) for s in b.special]
        kinds = special_counts(special)
        count = 1 + len(self.crossing)
        return f"{self.main.name} {self.lam_from:g} to {self.lam_to:g}: {count} branch{'es' if count > 1 else ''}" + (f"; {kinds}" if kinds else "")

    def summary(self) -> str:
        """The text ``esba path`` prints (without its files)."""
        return path_table(self.to_dict(points=False))

    @property
    def branches(self) -> tuple[Branch, ...]:
        """The main branch first, then the crossing ones."""
        return (self.main, *self.crossing)

    def validity(self) -> list[dict[str, Any]]:
        """Where each branch leaves the range the paper's model describes (:mod:`esba.model.validity`): for
        each kind of finding, the first point of the branch where it appears, with lambda."""
        out = []
        for branch in self.branches:
            seen: set[str] = set()
            for lam, theta, tip in zip(branch.lam, branch.theta, branch.tip):
                try:
                    scene = self.problem.scene_at(float(lam))
                except PathError:  # on the range's edge (a degenerate geometry): nothing more to assess
                    continue
                pressure = float(lam) if self.problem.name == "pressure" else self.problem.pressure
                for f in assess(scene, theta, pressure, tip):
                    if f.check not in seen:
                        seen.add(f.check)
                        where = f"{branch.label or 'branch'}, from {self.problem.describe(float(lam))} on"
                        out.append({**f.to_dict(), "branch": branch.label, "lambda": float(lam), "message": f"{where}: {f.message}"})
        return out

    @property
    def hysteresis(self) -> dict[str, Any] | None:
        """When the ramp from the start to the target ("up", whichever way lambda goes) and back
        ("down") jump at different values: where, and the loops they make. The k-th jump out is
        closed by the k-th jump back counted from the end (nested loops pair up like brackets);
        ``width`` is the first loop's."""
        if len(self.loading) < 2 or not self.loading[0].jumps or not self.loading[1].jumps:
            return None
        up = [j.lam for j in self.loading[0].jumps]
        down = [j.lam for j in self.loading[1].jumps]
        loops = [{"up": a, "down": b, "width": abs(a - b)} for a, b in zip(up, reversed(down))]
        return {"up": up, "down": down, "width": loops[0]["width"], "loops": loops}

    def to_dict(self, points: bool = True) -> dict[str, Any]:
        """JSON-ready form (degrees, mm; no NaN)."""
        return {
            "scene": self.scene.describe(),
            "parameter": self.problem.name,
            "unit": self.problem.unit,
            "from": self.lam_from,
            "to": self.lam_to,
            "start": {"total_angle_deg": self.start.total_angle_deg, "tip_mm": self.start.tip_mm, "stability": self.start.stability},
            "branches": [b.to_dict(points) for b in self.branches],
            "loading": [
                {
                    "from": r.start,
                    "to": r.target,
                    "reached": r.reached,
                    "message": r.message,
                    "jumps": [j.to_dict() for j in r.jumps],
                    "branch_points_crossed": [s.lam for s in r.branch_points],
                }
                for r in self.loading
            ],
            "hysteresis": self.hysteresis,
            "validity": self.validity(),
        }


def trace_window(problem: PathProblem, lam_from: float, to: float) -> tuple[float, float]:
    """The interval the branches of an analysis stay in: from ``to`` back past the start by as much
    again (cut to the parameter's range). A start inside a bistable range lies between two folds,
    so the branch through it runs back past the start along its unstable middle before it turns
    to the far stable branch and reaches ``to``; a branch crossing at a branch point may likewise
    leave on the start's side."""
    lo, hi = problem.domain
    span = abs(to - lam_from)
    if to >= lam_from:
        return max(lo, lam_from - span), to
    return to, min(hi, lam_from + span)


def analyse(
    scene: Scene,
    parameter: str,
    to: float,
    *,
    start: float | None = None,
    options: PathOptions | None = None,
    switch: bool = True,
    loading: bool = True,
) -> PathAnalysis:
    """Trace ``scene``'s branch in ``parameter`` from ``start`` (default: the scene's value) to ``to``.

    Raises
    ------
    PathError
        for a parameter the scene lacks, or values outside its range (the message names them).
    EquilibriumError
        when the scene has no stable equilibrium at the start value to begin from.
    """
    problem = PathProblem.from_scene(scene, parameter)
    lo, hi = problem.domain
    values = {"from": problem.lam0 if start is None else start, "to": to}
    for name, value in values.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or not lo <= value <= hi:
            raise PathError(f"{name}={value!r}: outside the range of {problem.name}, {lo:g} to {hi:g}{problem.unit_short}")
    lam_from, to = float(values["from"]), float(to)
    # the start state solves the scene at the start value; the trace keeps lambda as the scene defines it
    # (for the load factor: a fraction of the scene's own payloads and weight)
    start_scene = problem.scene_at(lam_from) if lam_from != problem.lam0 else scene
    first = solve(start_scene, pressure=None if problem.name == "pressure" else problem.pressure)
    if not first.ok:
        raise EquilibriumError(f"no stable equilibrium at the start ({problem.describe(lam_from)}) to trace from: {first.message}")
    window = trace_window(problem, lam_from, to)
    main = trace(problem, first.theta, lam_from, to=to, bounds=window, options=options, label="main")
    crossing: list[Branch] = []
    if switch:
        for k, bp in enumerate(main.branch_points, start=1):
            crossing += bifurcating_branches(problem, bp, bounds=window, options=options, label=f"BP{k} ")
    ramps = tuple(history(problem, first.theta, lam_from, [to, lam_from], options)) if loading and to != lam_from else ()
    return PathAnalysis(scene, problem, first, main, tuple(crossing), ramps, lam_from, to)


def path_table(d: dict) -> str:
    """The text ``esba path`` prints for :meth:`PathAnalysis.to_dict` (and the ``out`` and ``figure`` the command adds)."""

    unit = d["unit"].split(" ")[0]
    unit = "" if unit == "1" else f" {unit}"
    lines = [f"scene: {d['scene']}", f"path in {d['parameter']} from {d['from']:g} to {d['to']:g}{unit}"]
    for b in d["branches"]:
        lines += branch_lines(b)
    if any(b["label"].endswith(("away from chamber", "towards chamber")) for b in d["branches"]):
        lines.append("the branches off a branch point are named by the way they bend: away from the chamber (the total angle rises), towards it (falls)")
    for r in d["loading"]:
        what = f"quasi-static {d['parameter']} {r['from']:g} -> {r['to']:g}{unit}"
        for lam in r["branch_points_crossed"]:
            lines.append(f"{what}: passes the branch point {lam:.9g}{unit} and goes on along the stable branch crossing there")
        if not r["jumps"]:
            lines.append(f"{what}: no jump" + ("" if r["reached"] else f"; NOT reached: {r['message']}"))
        for j in r["jumps"]:
            lines.append(
                f"{what}: jumps at the {j['kind']} {j['lambda']:.9g}{unit}: angle {j['total_angle_before_deg']:.2f} -> "
                f"{j['total_angle_after_deg']:.2f} deg, tip moves {j['distance_mm']:.1f} mm"
            )
    if d.get("hysteresis"):
        h = d["hysteresis"]
        for k, loop in enumerate(h["loops"], start=1):
            name = "hysteresis" if len(h["loops"]) == 1 else f"hysteresis loop {k}"
            lines.append(f"{name}: towards --to it jumps at {loop['up']:.9g}, back at {loop['down']:.9g}{unit}; "
                         f"width {loop['width']:.6g}{unit}")
    for k in ("out", "figure"):
        if d.get(k):
            lines.append(f"wrote {d[k]}")
    return "\n".join(lines)

"""The path cases of ``docs/paths.md``: where the Table 1 actuator snaps, how wide its hysteresis
is, where it buckles. This module computes; :mod:`esba.pages.paths` renders.

:func:`path_cases` traces (with :func:`esba.analysis.path_analysis.analyse` and
:func:`esba.paths.continuation.trace`):

* the pressure under the 2 N horizontal tip payload (Table 2's load): the bistable range, its two
  folds and the hysteresis of inflating and deflating under the load;
* the same for payloads of 0.5 to 3 N: how the bistable range opens with the payload, and the
  payload at which it is born (the cusp);
* the payload direction at the 90 degree pressure (2 N): the bistable range near 120 degrees;
* the fold pressures against n (how many segments the folds need);
* the payload magnitude at directions around 122.2 degrees: the narrow window of directions in
  which loading snaps, and its two sides;
* the straight actuator pushed along its axis, n = 1..8: the buckling load found by the trace
  against the closed form (:func:`esba.analysis.path_analysis.column_buckling_load`), the branch
  point's type (transcritical or pitchfork, computed) and what each side of the crossing branch does.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from esba.model.scene import Payload, Scene
from esba.paths.continuation import (
    PathOptions,
    PathProblem,
    bifurcating_branches,
    side_of,
    trace,
)
from esba.statics.equilibrium import solve

from .path_analysis import PathAnalysis, analyse, column_buckling_load

__all__ = ["PathCases", "path_cases", "PAYLOADS", "FOLD_NS", "COLUMN_NS", "OPTIONS", "WINDOW_OMEGAS", "WINDOW_TO"]

#: Payloads of the bistable-range table, N.
PAYLOADS = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0)
#: Segment counts of the fold convergence table.
FOLD_NS = (1, 2, 3, 4, 6, 8, 16)
#: Segment counts of the buckling table.
COLUMN_NS = tuple(range(1, 9))


#: Path settings of the cases: a finer largest step than the default, for the figures.
OPTIONS = PathOptions(ds_max=0.1)


@dataclass(frozen=True, eq=False)
class PathCases:
    """What :func:`path_cases` found.

    ``pressure``, ``direction`` and ``column``: the analyses of the pressure under 2 N, the payload
    direction at the 90 degree pressure and the straight column (n = 4) pushed along its axis;
    ``by_payload``: the folds (MPa) per payload (N); ``cusp_n``: the payload at which the two folds
    are born (None when the table does not bracket it); ``history_mpa``: the pressure above which
    :func:`esba.statics.equilibrium.solve`'s history reaches the upper state (None when not
    found); ``by_segments``: the folds under 2 N per n; ``buckling``: per n, the closed-form and the
    traced buckling loads, the branch point's type and what each side of the crossing branch does;
    ``window``: the payload magnitude (0 to 6 N) at the 90 degree pressure for the directions of
    :data:`WINDOW_OMEGAS` (:func:`_window_case`).
    """

    pressure: PathAnalysis
    direction: PathAnalysis
    column: PathAnalysis
    by_payload: list[dict[str, Any]]
    cusp_n: float | None
    history_mpa: float | None
    by_segments: list[dict[str, Any]]
    buckling: list[dict[str, Any]]
    window: list[dict[str, Any]]


def _folds(problem: PathProblem, theta: np.ndarray, lam0: float, to: float) -> list[float]:
    b = trace(problem, theta, lam0, to=to, options=OPTIONS)
    return [f.lam for f in b.folds]


def _pressure_folds(force: float, segments: int = 3, to: float = 0.4) -> list[float]:
    scene = Scene(pressure=0.0, payloads=(Payload(force, 90.0),), segments=segments)
    return _folds(PathProblem.from_scene(scene, "pressure"), solve(scene).theta, 0.0, to)


#: Payload directions (deg) of the snapping window: a payload path from 0 to 6 N at the 90 degree
#: pressure folds and snaps for directions inside the window (here 122.179 and 122.19) and is
#: monotonic on both sides of it (122.17: it bends back towards the chamber; 122.28: past the cusp
#: where the two folds meet, it bends on away from it).
WINDOW_OMEGAS = (122.17, 122.179, 122.19, 122.28)
#: The payload path's end, N (``esba path --param payload --target-angle 90 --payload-angle OMEGA --from 0 --to 6``).
WINDOW_TO = 6.0


def _window_case(omega: float) -> dict[str, Any]:
    """The payload path of a 2 N-scene at direction ``omega`` from 0 to :data:`WINDOW_TO` N at the 90
    degree pressure, with the default path settings of ``esba path`` (the case where a step once
    jumped to a neighbouring branch): its folds, branch points, jumps and where it ends."""
    run = analyse(Scene(payloads=(Payload(2.0, omega),)), "payload", WINDOW_TO, start=0.0, options=PathOptions(ds_max=0.1), switch=False)
    up, down = (list(r.jumps) for r in run.loading) if len(run.loading) == 2 else ([], [])
    return {
        "omega_deg": omega,
        "folds": [(f.lam, f.total_angle_deg) for f in run.main.folds],
        "branch_points": [bp.lam for bp in run.main.branch_points],
        "jumps_up": [(j.kind, j.lam, j.distance_mm, float(np.degrees(np.sum(j.theta_before))), float(np.degrees(np.sum(j.theta_after)))) for j in up],
        "jumps_down": [(j.kind, j.lam, j.distance_mm, float(np.degrees(np.sum(j.theta_before))), float(np.degrees(np.sum(j.theta_after)))) for j in down],
        "end_angle_deg": float(run.main.total_angle_deg[-1]),
        "reached": bool(run.main.stopped == "bound" and run.main.lam[-1] == WINDOW_TO),
    }


def _bisect(low: float, high: float, above, tol: float) -> float:
    """The boundary in [low, high] where ``above`` turns True (False at low, True at high)."""
    while high - low > tol:
        mid = 0.5 * (low + high)
        if above(mid):
            high = mid
        else:
            low = mid
    return 0.5 * (low + high)


def path_cases(progress: Callable[[str], None] | None = None) -> PathCases:
    """Trace every case of ``docs/paths.md`` (about half a minute); ``progress`` hears of each."""
    say = progress or (lambda msg: None)

    say("pressure under 2 N")
    p_run = analyse(Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),)), "pressure", 0.3, options=OPTIONS)
    say("payload direction at the 90 degree pressure")
    d_run = analyse(Scene(payloads=(Payload(2.0, 90.0),)), "omega", 150.0, options=OPTIONS)
    say("bistable range against the payload")
    by_payload = [{"payload_n": f, "folds_mpa": _pressure_folds(f)} for f in PAYLOADS]
    without = [r["payload_n"] for r in by_payload if len(r["folds_mpa"]) < 2]
    with_folds = [r["payload_n"] for r in by_payload if len(r["folds_mpa"]) == 2]
    cusp = None
    if without and with_folds and max(without) < min(with_folds):
        cusp = _bisect(max(without), min(with_folds), lambda f: len(_pressure_folds(f)) == 2, 1e-3)
    say("which state solve()'s history reaches in the bistable range")
    upper, lower = (f.lam for f in p_run.main.folds[:2]) if len(p_run.main.folds) >= 2 else (None, None)
    history_p = None
    if upper is not None:

        def reaches_upper(p: float) -> bool:
            r = solve(Scene(pressure=p, payloads=(Payload(2.0, 90.0),)))
            return r.total_angle_deg > p_run.main.folds[0].total_angle_deg

        if reaches_upper(upper) and not reaches_upper(lower):
            history_p = _bisect(lower, upper, reaches_upper, 1e-5)
    say("fold pressures against n")
    by_segments = [{"n": n, "folds_mpa": _pressure_folds(2.0, n, 0.3)} for n in FOLD_NS]
    say("column buckling, n = 1..8")
    buckling = []
    for n in COLUMN_NS:
        f_cr = column_buckling_load(segments=n)
        scene = Scene(pressure=0.0, payloads=(Payload(0.5 * f_cr, 180.0),), segments=n)
        problem = PathProblem.from_scene(scene, "payload")
        b = trace(problem, np.zeros(n), 0.5 * f_cr, to=1.5 * f_cr)
        row: dict[str, Any] = {"n": n, "closed_form_n": f_cr, "traced_n": None, "sides": []}
        if b.branch_points:
            bp = b.branch_points[0]
            row["traced_n"] = bp.lam
            row["status"] = bp.status
            row["bifurcation"], row["cubic"] = bp.bifurcation, bp.cubic
            for side in bifurcating_branches(problem, bp, bounds=(0.5 * f_cr, 1.5 * f_cr), options=OPTIONS):
                row["sides"].append(
                    {
                        "direction": side_of(side.theta[min(1, len(side) - 1)], bp.theta),
                        "load_after": "falls" if len(side) > 1 and side.lam[1] < bp.lam else "rises",
                        "stable_at_first": bool(side.stable[min(1, len(side) - 1)]),
                        "folds_n": [f.lam for f in side.folds],
                        "fold_angles_deg": [f.total_angle_deg for f in side.folds],
                    }
                )
        buckling.append(row)
    say("payload magnitude near 122.2 deg: the snapping window")
    window = [_window_case(omega) for omega in WINDOW_OMEGAS]
    say("column, n = 4, for the figure")
    c_run = analyse(Scene(pressure=0.0, payloads=(Payload(1.0, 180.0),), segments=4), "payload", 6.4, options=OPTIONS)
    return PathCases(p_run, d_run, c_run, by_payload, cusp, history_p, by_segments, buckling, window)

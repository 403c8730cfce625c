"""``result.plot(ax)``: each result drawn into matplotlib axes with the figures of the commands.

A result class names its function here in ``_plotter`` (:class:`esba.infra.report.Report`), and
``plot(ax=None)`` imports this module by name when it is called, so the results (in the floors
below) never import the figures. Each function is ``draw_X(result, ax, **options)`` and reuses the
drawing of the command that shows the same result (``esba solve``, ``equilibria``, ``path``,
``map``, ``sweep``, ``fit``, ``estimate``, ``stiffness``).

Examples
--------
>>> from esba import Scene, Payload, solve
>>> from esba.figures.scenes import new_figure
>>> ax = solve(Scene(pressure=0.1, payloads=(Payload(1.0),))).plot(new_figure().add_subplot())
>>> ax.get_xlabel()
'y (mm)'
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
from matplotlib.axes import Axes

from .equilibria import draw_equilibria as _draw_states
from .maps import draw_map, map_title, scene_line
from .paths import Y_AXES, draw_branch as _draw_branch, draw_path as _draw_path
from .scenes import draw_solution, set_title
from .sweeps import draw_sweep as _draw_sweep

__all__ = [
    "draw_equilibrium",
    "draw_equilibria",
    "draw_branch",
    "draw_path",
    "draw_stability_map",
    "draw_sweep",
    "draw_fit",
    "draw_load_estimate",
    "draw_stiffness",
    "draw_design_result",
    "draw_propagation",
    "draw_sensitivities",
]


def draw_equilibrium(result, ax: Axes) -> None:
    """An :class:`esba.statics.equilibrium.Equilibrium`: its shape and payloads, as ``esba solve --plot`` draws it."""
    draw_solution(ax, result)


def draw_equilibria(result, ax: Axes) -> None:
    """An :class:`esba.statics.equilibria.Equilibria`: every state, as ``esba equilibria --plot`` draws them
    (the legend below the axes, where it hides no shape)."""
    _draw_states(ax, result)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), fontsize=7.5)
    set_title(ax, f"every equilibrium at P = {result.pressure:.4g} MPa ({len(result.stable)} stable of {len(result.states)})", 9)


def draw_branch(result, ax: Axes, y: str = "total-angle") -> None:
    """A :class:`esba.paths.branch.Branch`: stable solid, unstable dashed, its folds and branch points."""
    _draw_branch(ax, result, y, "C0", result.label or "branch")
    unit = result.unit.split(" ")[0]
    ax.set_xlabel(f"{result.name}" + ("" if unit == "1" else f" ({unit})"))
    name, yunit = Y_AXES[y]
    ax.set_ylabel(f"{name} ({yunit})")
    ax.grid(True, color="0.9", lw=0.6)
    ax.legend(fontsize=7.5, loc="best")
    set_title(ax, result.headline(), 8)


def draw_path(result, ax: Axes, y: str = "total-angle") -> None:
    """An :class:`esba.analysis.path_analysis.PathAnalysis`, as ``esba path --plot`` draws it."""
    from .paths import path_title

    _draw_path(ax, result, y)
    ax.set_title(path_title(result), fontsize=8)


def draw_stability_map(result, ax: Axes) -> None:
    """An :class:`esba.analysis.maps.StabilityMap`, as ``esba map --plot`` draws it, with its title and scene line."""
    draw_map(ax, result)
    set_title(ax, f"{map_title(result)}\n{scene_line(result)}", 8)


def draw_sweep(result, ax: Axes, max_curves: int = 12, traced: bool = True) -> None:
    """A :class:`esba.studies.sweep.SweepResult`, as ``esba sweep --plot`` draws it."""
    _draw_sweep(ax, result, max_curves, traced)


def _residual_bars(ax: Axes, residuals: Sequence[dict[str, Any]], who: str, title: str) -> None:
    """Each measured value's residual in its standard deviations (predicted - measured) / sd, a bar
    per value, with the band |r| <= 2 where 95 % of them fall when the model and the sds are right."""
    names = [f"{r[who][:14]}: {r['quantity']}" for r in residuals]
    values = np.array([r["normalised"] for r in residuals], dtype=float)
    k = np.arange(len(values))
    ax.axhspan(-2.0, 2.0, color="0.92", zorder=0, label="|r / sd| <= 2")
    ax.bar(k, values, color=["C0" if abs(v) <= 2 else "C3" for v in values], zorder=2)
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xticks(k, names, rotation=60, ha="right", fontsize=7)
    ax.set_ylabel("(predicted - measured) / sd (1)")
    ax.legend(fontsize=7, loc="best")
    set_title(ax, title, 8)


def draw_fit(result, ax: Axes) -> None:
    """A :class:`esba.calibration.fit.FitResult`: each measured value's residual at the fitted
    parameters, in its standard deviations (``esba fit --plot`` draws the values themselves)."""
    _residual_bars(ax, result.to_dict()["residuals"], "row", f"fit: {result.headline()}")


def draw_load_estimate(result, ax: Axes) -> None:
    """An :class:`esba.calibration.sensing.LoadEstimate`: each measured value's residual at the
    estimated load, in its standard deviations."""
    _residual_bars(ax, result.to_dict()["residuals"], "pose", f"load estimate: {result.headline()}")


def draw_stiffness(result, ax: Axes) -> None:
    """An :class:`esba.analysis.stiffness.SecantStiffness`: K against the payload, and its limit as
    F -> 0 (the tangent stiffness of the unloaded state along the force) where it is bounded."""
    ax.plot(result.forces, result.stiffness_n_per_m, "o-", color="C0", label="secant stiffness K = F / delta")
    t = result.tangent.to_dict()
    limit = t["horizontal_n_per_m"] if abs(math.sin(math.radians(result.angle_deg))) >= 0.5 else t["vertical_n_per_m"]
    if limit is not None and math.isfinite(limit):
        ax.plot([0.0], [limit], "s", mfc="white", mec="C0", label=f"F -> 0: tangent {limit:.2f} N/m")
    ax.set_xlabel("payload F (N)")
    ax.set_ylabel("stiffness (N/m)")
    ax.set_xlim(left=0.0)
    ax.grid(True, color="0.9", lw=0.6)
    ax.legend(fontsize=7.5, loc="best")
    set_title(ax, f"secant stiffness at P = {result.pressure:.5g} MPa, payload at {result.angle_deg:g} deg", 9)


def draw_design_result(result, ax: Axes, points: int = 40) -> None:
    """A :class:`esba.design.optimise.DesignResult` or ``Comparison``: the stiffness map with the
    design(s), as ``esba design --plot`` draws it."""
    from .design import draw_design_into

    draw_design_into(ax, result, points)


def draw_propagation(result, ax: Axes) -> None:
    """A :class:`esba.calibration.uncertainty.Propagation`: the tip's 95 % ellipse around the solved tip."""
    from .scenes import draw_tip_ellipse

    x, y = (float(v) for v in result.nominal_tip[:2])
    ax.plot([y], [x], "o", color="C0", label=f"solved tip ({x:.2f}, {y:.2f}) mm")
    if result.has_numbers:
        draw_tip_ellipse(ax, result.nominal_tip[:2], result.cov_tip, 0.95, label="95 % ellipse (first order)", lw=1.5)
    ax.set_aspect("equal", adjustable="datalim")
    if not ax.yaxis_inverted():
        ax.invert_yaxis()
    ax.set_xlabel("y (mm)")
    ax.set_ylabel("x (mm), downwards")
    ax.grid(True, color="0.9", lw=0.6)
    ax.legend(fontsize=7.5, loc="best")
    set_title(ax, f"the tip's uncertainty: {result.headline()}", 8)


def draw_sensitivities(result, ax: Axes) -> None:
    """A :class:`esba.analysis.sensitivity.Sensitivities`: how far the total angle moves when each
    parameter grows by 1 % (its derivative times 1 % of its value: one scale for every unit)."""
    rows = result.to_dict().get("parameters") or {}
    names = [n for n, r in rows.items() if r["value"]]
    moves = [0.01 * rows[n]["value"] * rows[n]["dtotal_angle_deg_per_unit"] for n in names]
    k = np.arange(len(names))
    ax.barh(k, moves, color=["C0" if m >= 0 else "C3" for m in moves])
    ax.set_yticks(k, names)
    ax.axvline(0.0, color="0.5", lw=0.8)
    ax.set_xlabel("change of the total angle for +1 % of the parameter (deg)")
    ax.grid(True, axis="x", color="0.9", lw=0.6)
    set_title(ax, f"sensitivities (first order): {result.headline()}", 8)

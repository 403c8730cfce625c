"""Figures of the parameter sweep and the design optimisation (the paper's Figs. 13 and 14).

* :func:`draw_13a`: the free bending angle over the (r2, d) triangle at 0.2 MPa (Fig. 13a);
* :func:`draw_13b`: the secant stiffness over the triangle (each design at its own 90 degree
  pressure, 2 N horizontal tip payload), with the IPOPT optimum marked (Fig. 13b);
* :func:`draw_14`: the swarm's positions per iteration, coloured by iteration (Fig. 14).

Each returns the Figure; :mod:`esba.figures.paper` lists them as ``fig13a``, ``fig13b``, ``fig14``
for ``esba figures``, which writes them. The numbers behind them come from :func:`triangle_grid`,
:func:`stiffness_map` and :func:`angle_map`, so that tests can check them without drawing.
:func:`draw_design` draws one ``esba design`` run, :func:`design_figure` writes it (``--plot``).

Examples
--------
>>> g = triangle_grid(8.0, 5)
>>> bool(np.all(g[:, 0] + g[:, 1] < 8.0)), g.shape[1]
(True, 2)
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.tri import Triangulation

from esba.analysis.stiffness import secant_stiffness
from esba.design.optimise import (
    Comparison,
    DesignProblem,
    DesignResult,
    evaluate,
    free_angle,
    optimise_ipopt,
    optimise_pso,
)
from esba.model.scene import SceneError
from esba.solvers.pso import PSOOptions

from .scenes import new_figure, save_figure, set_title

__all__ = [
    "FIG13A_PRESSURE",
    "RESOLUTION",
    "triangle_grid",
    "stiffness_map",
    "angle_map",
    "draw_13a",
    "draw_13b",
    "draw_14",
    "draw_design",
    "draw_design_into",
    "design_figure",
]

#: The pressure of Fig. 13a, MPa (Section 4.4.4).
FIG13A_PRESSURE = 0.2
#: Grid points per side of the triangle in the figures.
RESOLUTION = 60


def triangle_grid(r1: float, points: int, margin: float = 0.1) -> np.ndarray:
    """Designs (r2, d) on a regular grid of the triangle r2 > 0, d >= 0, r2 + d < r1, shape (m, 2).

    ``margin`` (mm) keeps the grid off the open edges r2 = 0 and r2 + d = r1.
    """
    r2 = np.linspace(margin, r1 - margin, points)
    d = np.linspace(0.0, r1 - 2 * margin, points)
    R2, D = np.meshgrid(r2, d)
    keep = R2 + D <= r1 - margin + 1e-12
    return np.column_stack([R2[keep], D[keep]])


def stiffness_map(problem: DesignProblem | None = None, points: int = RESOLUTION) -> tuple[np.ndarray, np.ndarray]:
    """Secant stiffness (N/m) over the triangle: (designs (m, 2), K (m,)).

    The batched evaluator of :mod:`esba.design.optimise` first; the few designs where its Newton ramp does
    not converge (the thinnest chambers, and chambers filling the actuator, whose loaded shape
    folds back by more than 70 degrees) are solved again with :func:`esba.analysis.stiffness.secant_stiffness`.
    """
    problem = DesignProblem() if problem is None else problem
    grid = triangle_grid(problem.actuator.r1, points)
    e = evaluate(problem, grid[:, 0], grid[:, 1])
    K = e.stiffness.copy()
    for i in np.flatnonzero(~e.ok):
        try:
            s = secant_stiffness(problem.scene(grid[i, 0], grid[i, 1], loaded=False), forces=(problem.payload_n,), angle_deg=problem.payload_angle_deg)
        except (SceneError, ValueError, RuntimeError):
            continue
        if s.ok:
            K[i] = s.stiffness_n_per_m[0]
    return grid, K


def angle_map(
    problem: DesignProblem | None = None, pressure: float = FIG13A_PRESSURE, points: int = RESOLUTION
) -> tuple[np.ndarray, np.ndarray]:
    """Free bending angle (degrees) at ``pressure`` over the triangle: (designs (m, 2), angle (m,))."""
    problem = DesignProblem() if problem is None else problem
    grid = triangle_grid(problem.actuator.r1, points)
    return grid, free_angle(problem, grid[:, 0], grid[:, 1], pressure)


def _triangle_axes(ax: Axes, r1: float) -> None:
    ax.plot([0, r1, 0, 0], [0, 0, r1, 0], color="0.3", lw=0.8)
    ax.set_xlim(0, r1)
    ax.set_ylim(0, r1)
    ax.set_aspect("equal")
    ax.set_xlabel("chamber radius r2 (mm)")
    ax.set_ylabel("eccentric distance d (mm)")


def _contour(fig, ax: Axes, grid: np.ndarray, values: np.ndarray, levels, label: str, cmap: str, extend: str = "neither"):
    ok = ~np.isnan(values)
    tri = Triangulation(grid[ok, 0], grid[ok, 1])
    if extend == "max":
        # values above the top level keep their size (the fill's extension colours them): clipped to
        # just above it, a steep field's top contour was drawn between a value and its clipped
        # neighbour, as far out as the clip happened to put it (a jagged 720 deg line on Fig. 13a);
        # only a value off every scale (inf) is drawn as twice the largest one there is
        finite = values[ok][np.isfinite(values[ok])]
        cap = 2.0 * max(float(finite.max()) if finite.size else levels[-1], levels[-1])
        shown = np.clip(values[ok], levels[0], cap)
    else:
        shown = np.clip(values[ok], levels[0], levels[-1])
    cs = ax.tricontourf(tri, shown, levels=levels, cmap=cmap, extend=extend)
    lines = ax.tricontour(tri, shown, levels=levels[::2], colors="k", linewidths=0.4, alpha=0.6)
    ax.clabel(lines, fmt="%g", fontsize=7)
    fig.colorbar(cs, ax=ax, label=label, shrink=0.85)
    return tri


def draw_13a(problem: DesignProblem | None = None, points: int = RESOLUTION) -> Figure:
    """Fig. 13a: the free bending angle at 0.2 MPa over the (r2, d) triangle."""
    problem = DesignProblem() if problem is None else problem
    grid, angle = angle_map(problem, FIG13A_PRESSURE, points)
    fig = new_figure(6.2, 5.0)
    ax = fig.add_subplot()
    levels = np.arange(0.0, 721.0, 45.0)
    # nan: the pressure does not suffice for the whole search range (beyond 3600 deg): off the scale
    angle = np.where(np.isnan(angle), np.inf, angle)
    _contour(fig, ax, grid, angle, levels, "free bending angle (deg)", "viridis", extend="max")
    a = problem.actuator
    ax.plot([a.r2], [a.d], "w^", mec="k", ms=8, label=f"Table 1 (r2 = {a.r2:g}, d = {a.d:g} mm)")
    _triangle_axes(ax, a.r1)
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"Fig. 13a: unloaded bending angle at {FIG13A_PRESSURE:g} MPa (n = {problem.segments}; yellow: > 720 deg)", fontsize=9)
    return fig


def draw_13b(problem: DesignProblem | None = None, points: int = RESOLUTION) -> Figure:
    """Fig. 13b: the secant stiffness over the triangle with the optimum marked."""
    problem = DesignProblem() if problem is None else problem
    grid, K = stiffness_map(problem, points)
    best = optimise_ipopt(problem)
    fig = new_figure(6.2, 5.0)
    ax = fig.add_subplot()
    top = 5.0 * math.ceil(np.nanmax(K) / 5.0)
    levels = np.arange(0.0, top + 0.1, 2.5)
    _contour(fig, ax, grid, K, levels, "secant stiffness K (N/m)", "magma")
    a = problem.actuator
    ax.plot([a.r2], [a.d], "w^", mec="k", ms=8, label=f"Table 1: K = {_k(problem, a.r2, a.d):.1f} N/m")
    ax.plot(
        [best.r2_mm], [best.d_mm], "*", color="cyan", mec="k", ms=16, clip_on=False, zorder=5,
        label=f"optimum: r2 = {best.r2_mm:.3f}, d = {best.d_mm:.3f} mm, K = {best.stiffness_n_per_m:.2f} N/m",
    )
    _triangle_axes(ax, a.r1)
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(
        f"Fig. 13b: stiffness, {problem.payload_n:g} N horizontal tip payload from {problem.start_angle_deg:g} deg (n = {problem.segments})",
        fontsize=9,
    )
    return fig


def _k(problem: DesignProblem, r2: float, d: float) -> float:
    return float(evaluate(problem, [r2], [d]).stiffness[0])


def plt_viridis(x: float):
    """The viridis colour at x in [0, 1]."""
    from matplotlib import colormaps

    return colormaps["viridis"](x)


def _swarm_axes(fig, ax: Axes, result: DesignResult, problem: DesignProblem) -> None:
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    h = result.pso.history
    iters, particles = h.positions.shape[:2]
    norm = Normalize(0, iters - 1)
    cmap = colormaps["viridis"]
    # the latest iterations on top: they crowd at the optimum
    for k in range(iters):
        p = h.positions[k]
        ax.scatter(p[:, 0], p[:, 1], s=16, facecolors="none", edgecolors=[cmap(norm(k))], linewidths=0.8, alpha=0.85)
    fig.colorbar(ScalarMappable(norm, cmap), ax=ax, label="iteration", shrink=0.85)
    ax.plot(h.best_position[:, 0], h.best_position[:, 1], "-", color="C3", lw=1.0, label="swarm's best so far")
    ax.plot([result.r2_mm], [result.d_mm], "*", color="C3", mec="k", ms=14, clip_on=False, zorder=5,
            label=f"PSO: r2 = {result.r2_mm:.4f}, d = {result.d_mm:.4f} mm")
    _triangle_axes(ax, problem.actuator.r1)


def draw_14(problem: DesignProblem | None = None, pso_options: PSOOptions | None = None, map_points: int = 30) -> Figure:
    """Fig. 14: the swarm's positions per iteration (paper's settings, seed 0), over the stiffness
    contours (a map of ``map_points`` per side)."""
    problem = DesignProblem() if problem is None else problem
    result = optimise_pso(problem, pso_options=pso_options)
    grid, K = stiffness_map(problem.stiffest(), map_points)
    fig = new_figure(10.5, 4.6)
    ax, ax2 = fig.subplots(1, 2, width_ratios=[1.25, 1])
    ok = np.isfinite(K)
    lines = ax.tricontour(Triangulation(grid[ok, 0], grid[ok, 1]), K[ok], levels=np.arange(10.0, 46.0, 5.0), colors="0.6", linewidths=0.5)
    ax.clabel(lines, fmt="%g N/m", fontsize=6)
    _swarm_axes(fig, ax, result, problem)
    ax.legend(loc="lower right", fontsize=7)
    # zoom on the optimum (the empty corner r2 + d > r1 holds the inset)
    zoom = ax.inset_axes([0.56, 0.58, 0.42, 0.3])
    h = result.pso.history
    for k in range(h.positions.shape[0]):
        p = h.positions[k]
        zoom.scatter(p[:, 0], p[:, 1], s=10, facecolors="none", edgecolors=[plt_viridis(k / (h.positions.shape[0] - 1))], linewidths=0.6)
    zoom.plot([result.r2_mm], [result.d_mm], "*", color="C3", mec="k", ms=10, clip_on=False, zorder=5)
    zoom.set_xlim(result.r2_mm - 0.5, result.r2_mm + 0.5)
    zoom.set_ylim(-0.02, 0.3)
    zoom.tick_params(labelsize=6)
    zoom.set_xlabel("r2 (mm)", fontsize=6, labelpad=1)
    zoom.set_ylabel("d (mm)", fontsize=6, labelpad=1)
    zoom.set_title("near the optimum", fontsize=7)
    o = result.pso.options
    ax.set_title(f"Fig. 14: {o.particles} particles, {o.iterations} iterations (seed {o.seed}), n = {problem.segments}", fontsize=9)
    best = result.pso.history.best_value
    ax2.plot(np.arange(best.size), -best if problem.objective != "pressure" else best, "o-", ms=3)
    ax2.set_xlabel("iteration")
    ax2.set_ylabel(f"swarm's best {problem.objective} ({problem.unit})")
    ax2.grid(True, color="0.9")
    inset = ax2.inset_axes([0.35, 0.12, 0.6, 0.5])
    err = np.abs(best - best[-1])
    inset.semilogy(np.arange(best.size)[err > 0], err[err > 0], ".-", ms=2, lw=0.8)
    inset.set_title(f"|best - final| ({problem.unit})", fontsize=7)
    inset.set_xlabel("iteration", fontsize=6, labelpad=1)
    inset.tick_params(labelsize=6)
    return fig


def draw_design(run: DesignResult | Comparison, points: int = 40) -> Figure:
    """The stiffness map with the run's design(s), the K_min contour and the swarm (``esba design --plot``)."""
    fig = new_figure(6.4, 5.2)
    draw_design_into(fig.add_subplot(), run, points)
    return fig


def draw_design_into(ax: Axes, run: DesignResult | Comparison, points: int = 40) -> None:
    """:func:`draw_design`'s drawing into ``ax`` (its colour bar beside it)."""
    fig = ax.figure
    results = [run.ipopt, run.pso] if isinstance(run, Comparison) else [run]
    problem = results[0].problem
    grid, K = stiffness_map(problem.stiffest(), points)
    top = 5.0 * math.ceil(np.nanmax(K) / 5.0)
    tri = _contour(fig, ax, grid, K, np.arange(0.0, top + 0.1, 2.5), "secant stiffness K (N/m)", "magma")
    if problem.min_stiffness is not None:
        ok = ~np.isnan(K)
        cs = ax.tricontour(tri, K[ok], levels=[problem.min_stiffness], colors="cyan", linewidths=1.5)
        ax.clabel(cs, fmt=f"K_min = {problem.min_stiffness:g}", fontsize=7)
    for r in results:
        if r.pso is not None:
            pts = r.pso.history.positions.reshape(-1, 2)
            ax.plot(pts[:, 0], pts[:, 1], "o", mfc="none", mec="0.8", ms=3, alpha=0.5)
    # IPOPT's star filled, PSO's circle open and larger on top of it: both show where they coincide
    markers = {"ipopt": ("*", "cyan", 16, "cyan", 5), "pso": ("o", "C2", 14, "none", 6)}
    for r in results:
        m, c, s, face, z = markers[r.method]
        if math.isfinite(r.r2_mm):
            ax.plot([r.r2_mm], [r.d_mm], m, color=c, mec="k" if face != "none" else c, mfc=face, mew=1.0 if face != "none" else 2.0, ms=s, clip_on=False, zorder=z,
                    label=f"{r.method} ({r.status}): r2 = {r.r2_mm:.4f}, d = {r.d_mm:.4f} mm, {problem.objective} = {r.objective:.4g} {problem.unit}")
    if problem.min_wall > 0:
        w = problem.actuator.r1 - problem.min_wall
        ax.plot([0, w], [w, 0], "--", color="w", lw=1.0, label=f"wall = {problem.min_wall:g} mm")
    _triangle_axes(ax, problem.actuator.r1)
    ax.legend(loc="upper right", fontsize=7)
    set_title(ax, problem.describe(), 7)


def design_figure(run: DesignResult | Comparison, path: str | Path, points: int = 40) -> Path:
    """Write :func:`draw_design` to ``path``; return the path."""
    return save_figure(draw_design(run, points), path)


"""Figures of the load estimate's cases (:mod:`esba.calibration.sensing_cases`): where the actuator
is blind to a tip load, and the error ellipses of the force over the workspace."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from esba.calibration.sensing_cases import BlindMap, Ellipse

from .scenes import draw_tip_ellipse, new_figure, setup_frame_axes

__all__ = ["blind_figure", "ellipse_figure", "ARROW_MM_PER_N"]

#: Drawing scale of a force (and of its ellipse) at the tip, mm per N.
ARROW_MM_PER_N = 25.0


def blind_figure(blind: BlindMap) -> Figure:
    """The standard error of a 1 N tip load's magnitude over pressure and direction (log colour),
    with the blind region (error past the load itself) hatched and outlined."""
    fig = new_figure(6.5, 4.2)
    ax = fig.add_subplot()
    se = np.where(np.isfinite(blind.se_force), blind.se_force, np.nan)
    d, p = np.asarray(blind.directions), np.asarray(blind.pressures)
    mesh = ax.pcolormesh(d, p, np.log10(se), shading="nearest", cmap="viridis", vmin=-2.0, vmax=1.0)
    cbar = fig.colorbar(mesh, ax=ax)
    cbar.set_label(f"log10 std error of F (N), segment angles ± {blind.sd_deg:g}°")
    ax.contourf(d, p, blind.blind.astype(float), levels=[0.5, 1.5], colors="none", hatches=["///"])
    ax.contour(d, p, blind.blind.astype(float), levels=[0.5], colors="w", linewidths=1.2)
    ax.set_xlabel("direction Ω of the 1 N tip load (deg; 0 pulls down, 90 horizontal)")
    ax.set_ylabel("pressure (MPa)")
    ax.set_title("Where the shape does not show the load (hatched: error > the load)")
    return fig


def ellipse_figure(items: list[Ellipse], sd_deg: float) -> Figure:
    """Each state's shape, its 1 N tip load as an arrow and the load's 95 % error ellipse drawn at
    the arrow's head (scale :data:`ARROW_MM_PER_N`)."""
    fig = new_figure(6.5, 6.0)
    ax = fig.add_subplot()
    setup_frame_axes(ax)
    colours = {p: f"C{k}" for k, p in enumerate(sorted({e.pressure for e in items}))}
    labelled = set()
    for e in items:
        c = colours[e.pressure]
        label = None if e.pressure in labelled else f"{e.pressure:g} MPa"
        labelled.add(e.pressure)
        ax.plot(e.shape_mm[:, 1], e.shape_mm[:, 0], color=c, lw=0.8, alpha=0.6, label=label)
        om = np.radians(e.direction)
        f = np.array([np.cos(om), -np.sin(om)]) * ARROW_MM_PER_N  # 1 N in the base frame (x down, y right)
        ax.annotate("", xy=(e.tip[1] + f[1], e.tip[0] + f[0]), xytext=(e.tip[1], e.tip[0]),
                    arrowprops={"arrowstyle": "->", "color": c, "lw": 0.8})
        if np.all(np.isfinite(e.force_covariance)):
            draw_tip_ellipse(ax, e.tip + f, e.force_covariance * ARROW_MM_PER_N**2, color=c, lw=1.0)
    ax.legend(loc="lower left", fontsize=8, title="pressure")
    ax.set_title(f"1 N tip loads and their 95 % ellipses from the segment angles ± {sd_deg:g}°\n"
                 f"(arrow and ellipse: {ARROW_MM_PER_N:g} mm per N)", fontsize=9)
    return fig

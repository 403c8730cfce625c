"""3-D stability maps: the raster's classes (in plane, twisted, flips, snaps), the located region
boundaries, where paths along the axes lose stability (folds, sideways folds, branch points), and
the fold and branch-point curves continued in the two parameters.

Presentation only: the map is :class:`esba.analysis.maps3d.StabilityMap3D`.
"""

from __future__ import annotations

import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from esba.analysis.maps3d import CLASSES, StabilityMap3D

from .scenes import new_figure, save_figure, set_title

__all__ = ["map3d_figure", "save_figure", "CLASS_COLOURS"]

#: Shades of in plane, twisted, flips, snaps.
CLASS_COLOURS = ("#ffffff", "#fdd0a2", "#f16913", "#6baed6")
_MARKERS = {"fold": ("k", "o"), "sideways fold": ("#7f2704", "s"), "branch point": ("#d62728", "D"), "twist bound": ("#8c6d31", ".")}


def _label(name: str, unit: str) -> str:
    return f"{name} ({unit})" if unit and unit != "1" else name


def map3d_figure(smap: StabilityMap3D, title: str | None = None) -> Figure:
    """The map's classes as shaded cells, its boundaries and its path points; its fold curves (solid)
    and branch-point curves (dashed) with their special points (stars, labelled) when traced."""
    fig = new_figure(6.4, 4.8)
    ax = fig.add_subplot(111)
    cmap = ListedColormap(CLASS_COLOURS)
    norm = BoundaryNorm(np.arange(-0.5, len(CLASSES) + 0.5), cmap.N)
    ax.pcolormesh(smap.grid_x, smap.grid_y, smap.classes, cmap=cmap, norm=norm, shading="nearest")
    handles = [Patch(facecolor=c, edgecolor="0.6", label=name) for c, name in zip(CLASS_COLOURS, CLASSES) if np.any(smap.classes == CLASSES.index(name))]
    seen = set()
    for pts in (smap.boundaries, smap.paths):
        for p in pts:
            base = p.kind.replace(" (not located)", "")
            colour, marker = _MARKERS.get(base, ("0.3", "x"))
            label = None
            key = (base, pts is smap.paths)
            if key not in seen:
                seen.add(key)
                label = base + (" (path)" if pts is smap.paths else " (boundary)")
            ax.plot([p.x], [p.y], marker=marker, color=colour, ms=4 if pts is smap.paths else 2.5, ls="none", label=label)
    if smap.curves is not None:
        for curves, colour, style, what in ((smap.curves.folds, "k", "-", "fold curve"), (smap.curves.branch_points, "#d62728", "--", "branch-point curve")):
            for i, c in enumerate(curves):
                ax.plot(c.xs, c.ys, color=colour, ls=style, lw=1.0, label=what if i == 0 else None)
                for p in c.special:
                    ax.plot([p.x], [p.y], marker="*", color=colour, ms=7, ls="none")
                    ax.annotate(p.label, (p.x, p.y), textcoords="offset points", xytext=(4, 4), fontsize=7, color=colour)
    ux, uy = smap.plane.units
    ax.set_xlabel(_label(smap.plane.x, ux))
    ax.set_ylabel(_label(smap.plane.y, uy))
    ax.set_xlim(*smap.xrange)
    ax.set_ylim(*smap.yrange)
    lines, labels = ax.get_legend_handles_labels()
    ax.legend(handles + lines, [h.get_label() for h in handles] + labels, fontsize=7, loc="best", framealpha=0.85)
    set_title(ax, title or f"3-D map: {smap.plane.x} by {smap.plane.y}")
    return fig

"""Stability maps: regions shaded by their number of stable states, fold curves, cusps, jump lines.

A map (:class:`esba.analysis.maps.StabilityMap`) is drawn in its two parameters: each region
shaded by how many stable states the actuator has there (one colour per count), the fold curves
(solid where the fold joins a stable and an unstable state, dotted where it joins two unstable
ones), the cusps (stars, ``CP``) and the points where a fold curve meets a branch point of a
one-parameter path (diamonds, ``BP``), and where the quasi-static history in x jumps: up (loading,
triangles pointing right) and back down (unloading, triangles pointing left).

Examples
--------
>>> import tempfile, pathlib
>>> from esba.model.scene import Scene, Payload
>>> from esba.analysis.folds import Plane
>>> from esba.analysis.maps import stability_map
>>> plane = Plane.from_scene(Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),)), "pressure", "payload")
>>> m = stability_map(plane, (0.1, 0.25), (1.0, 3.0), resolution=41, history_lines=5)
>>> out = pathlib.Path(tempfile.mkdtemp()) / "map.png"
>>> save_figure(map_figure(m), out).exists()
True
"""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure

from esba.analysis.maps import StabilityMap

from .paths import parameter_label
from .scenes import new_figure, save_figure, set_title

__all__ = ["map_figure", "map_title", "scene_line", "draw_map", "save_figure", "COUNT_COLOURS"]

#: Shades of 0, 1, 2, 3, 4+ stable states.
COUNT_COLOURS = ("#f2f2f2", "#ffffff", "#c6dbef", "#6baed6", "#2171b5")


def _what(problem) -> str:
    """A parameter in words (``payload direction from the vertical``), as the axis says it, without the unit."""
    return parameter_label(problem).rsplit(" (", 1)[0]


def draw_map(ax: Axes, smap: StabilityMap) -> None:
    """Draw ``smap`` into ``ax`` (see the module)."""
    counts = np.clip(smap.counts, 0, len(COUNT_COLOURS) - 1)
    cmap = ListedColormap(COUNT_COLOURS)
    norm = BoundaryNorm(np.arange(-0.5, len(COUNT_COLOURS)), cmap.N)
    ax.pcolormesh(smap.grid_x, smap.grid_y, counts, cmap=cmap, norm=norm, shading="nearest", rasterized=True)
    for k in sorted(set(int(c) for c in np.unique(counts))):
        ax.fill_between([], [], color=COUNT_COLOURS[k], label=f"{k} stable state{'s' if k != 1 else ''}")
    per_period = None if smap.base is None else len(smap.base.curves)  # a periodic axis: the copies of one period's curves
    for c in smap.curves:
        x, y = np.asarray(c.xs, dtype=float), np.asarray(c.ys, dtype=float)
        stable = np.asarray(c.stable, dtype=bool)
        xs, ys = np.where(stable, x, np.nan), np.where(stable, y, np.nan)
        copy = per_period is not None and c.index >= per_period
        name = "_nolegend_" if copy else f"fold curve {c.index}" + (" (and its copies a period on)" if per_period is not None else "")
        ax.plot(xs, ys, "-", color="k", lw=1.6, label=name)
        if not stable.all():
            ax.plot(np.where(stable, np.nan, x), np.where(stable, np.nan, y), ":", color="k", lw=1.2,
                    label="_nolegend_" if copy else f"fold curve {c.index} (unstable pair)")
    cusps = [p for p in smap.special if p.kind == "cusp"]
    bps = [p for p in smap.special if p.kind != "cusp"]
    if cusps:
        ax.plot([p.x for p in cusps], [p.y for p in cusps], "*", color="C3", ms=12, label="cusp (CP)")
    if bps:
        ax.plot([p.x for p in bps], [p.y for p in bps], "D", color="C2", ms=6, label="fold meets branch point (BP)")
    up, down = smap.jumps.get("loading", []), smap.jumps.get("unloading", [])
    if up:
        ax.plot([p[0] for p in up], [p[1] for p in up], ">", color="C1", ms=6, label=f"jump, {_what(smap.plane.px)} rising")
    if down:
        ax.plot([p[0] for p in down], [p[1] for p in down], "<", color="C4", ms=6, label=f"jump, {_what(smap.plane.px)} falling")
    ax.set_xlim(*smap.xrange)
    ax.set_ylim(*smap.yrange)
    ax.set_xlabel(parameter_label(smap.plane.px))
    ax.set_ylabel(parameter_label(smap.plane.py))
    ax.legend(fontsize=7, loc="best")


def map_title(smap: StabilityMap) -> str:
    """What a map shows, in words: ``stable states over payload direction ... and payload magnitude``."""
    return f"stable states over {_what(smap.plane.px)} and {_what(smap.plane.py)}"


def scene_line(smap: StabilityMap) -> str:
    """The scene a map varies two parameters of, in one line (the pressure the map holds)."""
    x, y = smap.names
    return f"{smap.plane.scene.describe()}; P = {smap.plane.px.pressure:.5g} MPa held; {x} and {y} vary"


def map_figure(smap: StabilityMap, title: str | None = None) -> Figure:
    """A figure of one stability map, titled ``title`` (default :func:`map_title`) over its scene line."""
    fig = new_figure(6.0, 5.0)
    ax = fig.add_subplot(1, 1, 1)
    draw_map(ax, smap)
    set_title(ax, f"{title or map_title(smap)}\n{scene_line(smap)}", 8)
    return fig


#: Colours of the design plane's states.
DESIGN_STATES = {"clear": "#ffffff", "margin": "#fdd49e", "snaps": "#ef6548", "over budget": "#d9d9d9", "fails": "#969696"}


def design_plane_figure(plane) -> Figure:
    """The design plane (:class:`esba.design.envelope.DesignPlane`): each design coloured by whether a
    fold lies in its envelope, contours of the stiffness, the optimum without and with the constraint."""
    fig = new_figure(6.0, 5.2)
    ax = fig.add_subplot(1, 1, 1)
    labels = {"clear": "clear of folds", "margin": "fold within the margin", "snaps": "snaps inside the envelope",
              "over budget": "90 deg pressure over the budget", "fails": "no stable loaded state"}
    states = np.array(plane.state)
    for s, colour in DESIGN_STATES.items():
        pick = states == s
        if pick.any():
            ax.scatter(plane.r2[pick], plane.d[pick], s=60, marker="s", c=colour, edgecolors="0.5", linewidths=0.5, label=labels[s])
    ok = np.isfinite(plane.stiffness)
    if ok.sum() >= 3:
        cs = ax.tricontour(plane.r2[ok], plane.d[ok], plane.stiffness[ok], levels=8, colors="C0", linewidths=0.8)
        ax.clabel(cs, fontsize=7, fmt="%.0f N/m")
        ax.plot([], [], color="C0", lw=0.8, label="secant stiffness K (N/m)")
    if plane.optimum:
        u = plane.optimum[0].unconstrained
        if u.get("r2_mm") is not None:
            ax.plot([u["r2_mm"]], [u["d_mm"]], "X", color="k", ms=10, clip_on=False, zorder=4, label="stiffest design (no fold constraint)")
        # the map's star open and larger, the swarm's plus inside it: both show where they coincide
        styles = ({"marker": "*", "ms": 20, "mfc": "none", "mec": "C3", "mew": 2.0, "zorder": 6},
                  {"marker": "P", "ms": 8, "mfc": "C2", "mec": "k", "mew": 0.5, "zorder": 5})
        for r, style in zip(plane.optimum, styles):
            ax.plot([r.r2_mm], [r.d_mm], ls="none", clip_on=False, label=f"stiffest clear design ({r.method}): r2 = {r.r2_mm:.3f}, d = {r.d_mm:.3f} mm", **style)
    ax.set_xlabel("chamber radius r2 (mm)")
    ax.set_ylabel("eccentric distance d (mm)")
    ax.legend(fontsize=7, loc="upper right")
    p = plane.problem
    set_title(ax, f"the design plane: which designs snap inside the envelope\n({plane.envelope.describe()})\n"
                  f"each design at its {p.start_angle_deg:g} deg pressure; n = {p.segments}, {p.variant}", 8)
    return fig


__all__ += ["design_plane_figure", "DESIGN_STATES"]

"""Figures of contact: the blocked-force curve with its S-shapes, a finger wrapping a cylinder, a tester's path.

Each takes what :mod:`esba.statics.contact.sweeps` returns and draws it; :func:`esba.figures.scenes.save_figure` writes it.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from esba.model.contact.obstacles import Cylinder, HalfPlane
from esba.statics.contact.equilibrium import ContactEquilibrium
from esba.statics.contact.sweeps import ContactPath, ForceRamp

from .scenes import new_figure, setup_frame_axes

__all__ = ["blocked_figure", "grasp_figure", "tester_figure", "contact_states_figure", "draw_obstacles", "draw_contact_shape"]


def draw_obstacles(ax: Axes, point: ContactEquilibrium, extent: float) -> None:
    """The obstacles of a scene: a half-plane as a hatched band along its face, a cylinder as a disc."""
    for o in point.scene.obstacles:
        if isinstance(o, HalfPlane):
            nrm = o.normal
            along = np.array([-nrm[1], nrm[0]])
            a = np.asarray(o.at)
            face = np.array([a - extent * along, a + extent * along])
            back = face - 6.0 * nrm
            poly = np.vstack([face, back[::-1]])
            ax.fill(poly[:, 1], poly[:, 0], color="0.8", hatch="//", edgecolor="0.5", lw=0.5, zorder=0)
            ax.plot(face[:, 1], face[:, 0], color="0.3", lw=1.2)
        elif isinstance(o, Cylinder):
            ax.add_patch(Circle((o.centre[1], o.centre[0]), o.radius, color="0.8", ec="0.3", zorder=0))


def draw_contact_shape(ax: Axes, point: ContactEquilibrium, color, label: str | None = None, arrows: float = 8.0) -> None:
    """The layer of one equilibrium, its contacts as dots and their forces as arrows (mm per N)."""
    cl = point.centreline
    ax.plot(cl[:, 1], cl[:, 0], color=color, lw=1.4, label=label)
    for c in point.contacts:
        ax.plot(c.point[1], c.point[0], "o", color=color, ms=3.5)
        f = c.force_vector
        if c.force > 1e-6:
            ax.annotate("", xy=(c.point[1], c.point[0]), xytext=(c.point[1] - arrows * f[1], c.point[0] - arrows * f[0]),
                        arrowprops={"arrowstyle": "->", "color": color, "lw": 1.0})


def _shapes(ax: Axes, path: ContactPath, picks: Sequence[int]) -> None:
    setup_frame_axes(ax)
    cmap = __import__("matplotlib").colormaps["viridis"]
    L = path.points[0].scene.actuator.L
    draw_obstacles(ax, path.points[0], 0.8 * L)
    biggest = max([c.force for i in picks for c in path.points[i].contacts] + [1e-9])
    for k, i in enumerate(picks):
        p = path.points[i]
        draw_contact_shape(ax, p, cmap(k / max(len(picks) - 1, 1)), label=f"{p.pressure:.3g} MPa", arrows=0.2 * L / biggest)
    ax.legend(fontsize=7, loc="best")


def _picks(m: int, count: int = 6) -> list[int]:
    return sorted(set(np.linspace(0, m - 1, min(count, m)).round().astype(int).tolist()))


def blocked_figure(path: ContactPath) -> Figure:
    """Blocked force against pressure (left) and the S-shapes against the probe (right)."""
    fig = new_figure(10.0, 4.6)
    a, b = fig.subplots(1, 2)
    a.plot(path.values, path.forces, "o-", ms=3)
    for e in path.events:
        a.axvline(e.parameter, color="0.6", lw=0.8, ls=":")
    a.set_xlabel("pressure (MPa)")
    a.set_ylabel("blocked force (N)")
    a.set_title(f"blocked force, n = {path.points[0].scene.segments}, frictionless flat probe at the tip", fontsize=9)
    a.grid(alpha=0.3)
    _shapes(b, path, _picks(len(path.points)))
    b.set_title("the layer against the probe (arrows: contact force, to scale)", fontsize=9)
    return fig


def grasp_figure(path: ContactPath) -> Figure:
    """Contact force and wrapped length against pressure (left) and the wrapped shapes (right)."""
    fig = new_figure(10.0, 4.6)
    a, b = fig.subplots(1, 2)
    a.plot(path.values, path.forces, "o-", ms=3, label="total contact force (N)")
    a.set_xlabel("pressure (MPa)")
    a.set_ylabel("contact force (N)")
    a2 = a.twinx()
    a2.plot(path.values, [p.contact_length() for p in path.points], "s--", ms=3, color="C1", label="length within 0.1 mm (mm)")
    a2.set_ylabel("contact length within 0.1 mm (mm)")
    if path.first_touch is not None:
        a.axvline(path.first_touch, color="C3", lw=0.8, ls=":")
        a.text(path.first_touch, 0, f" first touch {path.first_touch:.4g} MPa", color="C3", fontsize=7, rotation=90, va="bottom")
    a.legend(loc="upper left", fontsize=7)
    a2.legend(loc="lower right", fontsize=7)
    a.grid(alpha=0.3)
    touching = [i for i, p in enumerate(path.points) if p.contacts]
    picks = _picks(len(path.points), 3) + ([touching[len(touching) // 2], touching[-1]] if touching else [])
    _shapes(b, path, sorted(set(picks)))
    b.set_title("the finger closing on the cylinder", fontsize=9)
    return fig


def tester_figure(path: ContactPath, ramps: Sequence[ForceRamp] = (), force: float | None = None) -> Figure:
    """Force against the tip's horizontal position: the displacement-controlled path (points where a
    dead load would not hold marked red: negative stiffness) and force-controlled ramps with their jumps."""
    fig = new_figure(6.5, 4.8)
    ax = fig.subplots()
    y = np.array([p.tip[1] for p in path.points])
    f = -path.reactions[:, 1]
    soft = np.array([not p.kkt.dead_load_stable for p in path.points])
    ok = np.array([p.ok for p in path.points]) & np.isfinite(f)
    thetas = np.array([p.theta for p in path.points])
    cuts = [0] + [k + 1 for k in np.flatnonzero(np.max(np.abs(np.diff(thetas, axis=0)), axis=1) > 0.1)] + [len(y)]
    for k, (a, b) in enumerate(zip(cuts[:-1], cuts[1:])):  # one line per branch; a jump of the shape is drawn dotted
        part = np.arange(a, b)[ok[a:b]]
        ax.plot(y[part], f[part], "-", color="C0", lw=1.5, label="displacement control (tip y prescribed)" if k == 0 else None)
        if a > 0:
            ax.plot(y[a - 1:a + 1], f[a - 1:a + 1], ":", color="C0", lw=1.0)
    ax.plot(y[ok & soft], f[ok & soft], "o", color="C3", ms=4, label="... where force control is unstable")
    for k, r in enumerate(ramps):  # each ramp its own colour and legend entry: where it starts, which way it goes
        colour, marker = ("C2", "C4", "C1", "C5")[k % 4], (".", "x", "+", "1")[k % 4]
        way = "up" if r.forces[-1] >= r.forces[0] else "down"
        ax.plot(r.tip_y, r.forces, marker, color=colour, ms=4, alpha=0.8,
                label=f"force control, ramp {way} {r.forces[0]:.3g} to {r.forces[-1]:.3g} N" + (f" (jumps at {r.jumps[0][0]:.3g} N)" if r.jumps else ""))
        for fj, ya, yb in r.jumps:
            ax.annotate("", xy=(yb, fj), xytext=(ya, fj), arrowprops={"arrowstyle": "->", "color": colour, "lw": 1.2})
    if force is not None:
        ax.axhline(force, color="0.5", lw=0.8, ls="--")
        ax.text(ax.get_xlim()[0], force, f" {force:g} N", fontsize=7, va="bottom", color="0.4")
    p0 = path.points[0]
    ax.set_xlabel("tip y, horizontal (mm)")
    ax.set_ylabel("horizontal force against the bend (N)")
    ax.set_title(f"tester at P = {p0.pressure:g} MPa, n = {p0.scene.segments}", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return fig


def contact_states_figure(states: Sequence[ContactEquilibrium]) -> Figure:
    """Several equilibria of one scene with obstacles: stable on the constrained set solid, others dashed."""
    fig = new_figure(6.0, 5.5)
    ax = fig.subplots()
    setup_frame_axes(ax)
    draw_obstacles(ax, states[0], 0.8 * states[0].scene.actuator.L)
    for k, s in enumerate(states):
        cl = s.centreline
        ax.plot(cl[:, 1], cl[:, 0], "-" if s.ok else "--", color=f"C{k % 10}", label=f"#{k + 1}: {s.kkt.stability}, U = {s.energy:.3f} N mm")
        for c in s.contacts:
            ax.plot(c.point[1], c.point[0], "o", color=f"C{k % 10}", ms=3.5)
    ax.legend(fontsize=7)
    ax.set_title(f"equilibria with contact at P = {states[0].pressure:.4g} MPa", fontsize=9)
    return fig

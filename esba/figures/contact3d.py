"""The actuator in 3-D against its obstacles: the tube of :func:`esba.figures.spatial.tube_figure`, the
obstacles (a sphere, a cylinder of any axis, a patch of a plane) and the contact forces as arrows."""

from __future__ import annotations

from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from .spatial import tube_figure

__all__ = ["contact3d_figure", "draw_obstacles3d"]


def _frame(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors across ``axis``."""
    a = axis / np.linalg.norm(axis)
    b = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    b /= np.linalg.norm(b)
    return b, np.cross(a, b)


def draw_obstacles3d(ax, obstacles: Sequence, centre: np.ndarray, span: float) -> None:
    """Each obstacle within ``span`` of ``centre``: a sphere, a length 1.2 span of a cylinder about the
    point of its axis nearest ``centre``, a square of side span of a plane about the point nearest it."""
    u = np.linspace(0, 2 * np.pi, 32)
    for o in obstacles:
        if o.kind == "sphere":
            v = np.linspace(0, np.pi, 16)
            c, r = np.asarray(o.centre), o.radius
            X = c[0] + r * np.outer(np.cos(u), np.sin(v))
            Y = c[1] + r * np.outer(np.sin(u), np.sin(v))
            Z = c[2] + r * np.outer(np.ones_like(u), np.cos(v))
            ax.plot_surface(X, Y, Z, color="C1", alpha=0.35, linewidth=0)
        elif o.kind == "cylinder":
            a, c = np.asarray(o.axis), np.asarray(o.centre)
            mid = c + ((centre - c) @ a) * a
            b1, b2 = _frame(a)
            t = np.linspace(-0.6 * span, 0.6 * span, 2)
            ring = o.radius * (np.cos(u)[:, None] * b1 + np.sin(u)[:, None] * b2)
            P = mid + t[None, :, None] * a + ring[:, None, :]
            ax.plot_surface(P[..., 0], P[..., 1], P[..., 2], color="C1", alpha=0.35, linewidth=0)
        elif o.kind == "plane":
            nv, at = np.asarray(o.normal), np.asarray(o.at)
            mid = centre - ((centre - at) @ nv) * nv
            b1, b2 = _frame(nv)
            s = np.linspace(-0.5 * span, 0.5 * span, 2)
            P = mid + s[:, None, None] * b1 + s[None, :, None] * b2
            ax.plot_surface(P[..., 0], P[..., 1], P[..., 2], color="C1", alpha=0.3, linewidth=0)


def contact3d_figure(result, title: str = "") -> Figure:
    """A solved 3-D scene with obstacles (:class:`esba.statics.contact.spatial.ContactEquilibrium3D`): the
    tube, its payloads, the obstacles and each contact force (green) at its point."""
    scene = result.scene
    payloads = []
    for p in scene.payloads:
        om, be = np.radians(p.angle_deg), np.radians(p.out_of_plane_deg)
        payloads.append((p.force * np.array([np.cos(be) * np.cos(om), -np.cos(be) * np.sin(om), np.sin(be)]), p.at))
    if not title:
        forces = ", ".join(f"{c.force:.3f} N" for c in result.contacts) or "no contact"
        title = f"P = {result.pressure:.3g} MPa, n = {result.n}; contact forces {forces}\n" + "\n".join(o.describe() for o in result.obstacles)
    fig = tube_figure(result.n, result.q, result.values, payloads, title)
    ax = fig.axes[0]
    L = float(result.values["L"])
    from esba.model.spatial import centreline3d

    pts, _ = centreline3d(result.n, result.q, L)
    span = max(float(np.ptp(pts, axis=0).max()), L / 4)
    draw_obstacles3d(ax, result.obstacles, pts.mean(axis=0), span)
    biggest = max((c.force for c in result.contacts), default=0.0)
    for c in result.contacts:
        if biggest > 0:
            v = np.asarray(c.direction) * 0.25 * span * c.force / biggest
            ax.quiver(*np.asarray(c.point), *v, color="C2", lw=2, arrow_length_ratio=0.25)
    return fig

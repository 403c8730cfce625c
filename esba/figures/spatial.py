"""The deformed actuator in 3-D: a tube with its chamber side marked and its payloads as arrows."""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure

from esba.model.spatial import centreline3d

from .scenes import new_figure


def tube_figure(n: int, q, values: Mapping[str, float], payloads: Sequence[tuple[np.ndarray, float]] = (), title: str = "") -> Figure:
    """The actuator at state q: a tube of radius r1 whose axis lies r1 from the layer (the layer is the
    model's reference line; the body lies on the side away from the centre of curvature, local -y,
    as in Eq. 5-13), the line of the chamber's side (the outer surface, 2 r1 from the layer, toward
    which the chamber sits d off the axis) in red, and each payload (force vector, fraction s) as an
    arrow at its point."""
    L, r1 = float(values["L"]), float(values["r1"])
    pts, frames = centreline3d(n, q, L)
    fig = new_figure(6.5, 5.5)
    ax = fig.add_subplot(projection="3d")
    phi = np.linspace(0, 2 * np.pi, 25)
    axis = pts - frames[:, :, 1] * r1
    X = axis[:, None, :] + r1 * (np.cos(phi)[None, :, None] * frames[:, None, :, 1] + np.sin(phi)[None, :, None] * frames[:, None, :, 2])
    ax.plot_surface(X[..., 0], X[..., 1], X[..., 2], color="0.75", alpha=0.35, linewidth=0)
    ax.plot(*pts.T, color="k", lw=1.5, label="inextensible layer")
    side = pts - frames[:, :, 1] * 2 * r1
    ax.plot(*side.T, color="C3", lw=2.0, label="chamber side")
    span = max(float(np.ptp(pts, axis=0).max()), L / 4)
    for f, s in payloads:
        idx = int(round(s * (len(pts) - 1)))
        f = np.asarray(f, dtype=float)
        size = np.linalg.norm(f)
        if size > 0:
            v = f / size * 0.25 * span
            ax.quiver(*pts[idx], *v, color="C0", lw=2, arrow_length_ratio=0.25)
    ax.set_xlabel("x (mm, down)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    centre = pts.mean(axis=0)
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
        setter(c - 0.6 * span - r1, c + 0.6 * span + r1)
    ax.invert_xaxis()
    ax.legend(loc="upper left", fontsize=8)
    if title:
        ax.set_title(title, fontsize=9)
    return fig

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


_HTML = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>esba: the actuator in 3-D</title>
<style>body{font-family:sans-serif;margin:1em}canvas{border:1px solid #ccc;cursor:grab}</style></head>
<body><p>__TITLE__</p><p>Drag to turn, wheel to zoom. Grey: the tube (radius r1); black: the inextensible layer;
red: the chamber side; blue: payloads. Written by esba (no network needed).</p>
<canvas id="c" width="760" height="600"></canvas>
<script>
const D = __DATA__;
const c = document.getElementById('c'), g = c.getContext('2d');
let yaw = -0.6, pitch = 0.5, zoom = 1.0, drag = null;
const ctr = D.centre, sc = 0.8 * Math.min(c.width, c.height) / D.span;
function proj(p) {
  const x = p[0] - ctr[0], y = p[1] - ctr[1], z = p[2] - ctr[2];
  const cy = Math.cos(yaw), sy = Math.sin(yaw), cp = Math.cos(pitch), sp = Math.sin(pitch);
  const X = cy * y - sy * z, Z1 = sy * y + cy * z;
  const Y = cp * (-x) - sp * Z1;
  return [c.width / 2 + zoom * sc * X, c.height / 2 - zoom * sc * Y];
}
function line(pts, color, w) {
  g.strokeStyle = color; g.lineWidth = w; g.beginPath();
  pts.forEach((p, i) => { const q = proj(p); i ? g.lineTo(q[0], q[1]) : g.moveTo(q[0], q[1]); });
  g.stroke();
}
function draw() {
  g.clearRect(0, 0, c.width, c.height);
  D.rings.forEach(r => line(r.concat([r[0]]), 'rgba(120,120,120,0.35)', 1));
  for (let k = 0; k < D.rings[0].length; k += 4) line(D.rings.map(r => r[k]), 'rgba(120,120,120,0.35)', 1);
  line(D.layer, 'black', 2); line(D.side, '#c0392b', 3);
  D.arrows.forEach(a => { line([a[0], a[1]], '#1f77b4', 3); const q = proj(a[1]); g.fillStyle = '#1f77b4'; g.beginPath(); g.arc(q[0], q[1], 4, 0, 6.3); g.fill(); });
}
c.onmousedown = e => { drag = [e.clientX, e.clientY]; };
window.onmouseup = () => { drag = null; };
window.onmousemove = e => { if (!drag) return; yaw += (e.clientX - drag[0]) * 0.01; pitch += (e.clientY - drag[1]) * 0.01; drag = [e.clientX, e.clientY]; draw(); };
c.onwheel = e => { e.preventDefault(); zoom *= e.deltaY < 0 ? 1.1 : 1 / 1.1; draw(); };
draw();
</script></body></html>
"""


def tube_html(n: int, q, values: Mapping[str, float], payloads: Sequence[tuple[np.ndarray, float]] = (), title: str = "") -> str:
    """The same view as :func:`tube_figure` as one self-contained HTML page that a person can turn
    (a canvas and a few lines of script, no library and no network)."""
    import html
    import json

    L, r1 = float(values["L"]), float(values["r1"])
    pts, frames = centreline3d(n, q, L)
    phi = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    axis = pts - frames[:, :, 1] * r1
    rings = axis[:, None, :] + r1 * (np.cos(phi)[None, :, None] * frames[:, None, :, 1] + np.sin(phi)[None, :, None] * frames[:, None, :, 2])
    side = pts - frames[:, :, 1] * 2 * r1
    span = max(float(np.ptp(pts, axis=0).max()), L / 4) + 2 * r1
    arrows = []
    for f, s in payloads:
        f = np.asarray(f, dtype=float)
        if np.linalg.norm(f) > 0:
            p = pts[int(round(s * (len(pts) - 1)))]
            arrows.append([p.tolist(), (p + f / np.linalg.norm(f) * 0.25 * span).tolist()])
    data = {"rings": np.round(rings, 4).tolist(), "layer": np.round(pts, 4).tolist(), "side": np.round(side, 4).tolist(),
            "arrows": arrows, "centre": pts.mean(axis=0).tolist(), "span": span}
    return _HTML.replace("__TITLE__", html.escape(title)).replace("__DATA__", json.dumps(data))

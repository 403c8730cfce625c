"""Figures of solved scenes (matplotlib, object-oriented API on the Agg canvas: no pyplot state).

The paper's frame is drawn as the paper draws it (Fig. 2, Fig. 8c): the base at the top, x (the
unbent axis) pointing down, y horizontal to the right, equal scales.

Examples
--------
>>> import tempfile, pathlib
>>> from esba.model.scene import MAIN_JOB
>>> from esba.statics.equilibrium import solve
>>> r = solve(MAIN_JOB)
>>> out = pathlib.Path(tempfile.mkdtemp()) / "shape.png"
>>> save_figure(solve_figure(r, solve(MAIN_JOB.unloaded())), out).exists()
True
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from esba.infra import outputs
from esba.statics.equilibrium import Equilibrium

__all__ = ["new_figure", "save_figure", "set_title", "draw_shape", "draw_payloads", "draw_tip_ellipse", "setup_frame_axes", "solve_figure", "draw_solution"]


def new_figure(width: float = 5.5, height: float = 5.0) -> Figure:
    """A figure on the Agg canvas (inches)."""
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig: Figure, path: str | Path, dpi: int = 150) -> Path:
    """Write ``fig`` to ``path`` (format from the suffix); return the path.

    Raises
    ------
    esba.infra.outputs.WriteFailed
        naming the file when it cannot be written (a full disk): no half-written file is left.
    """
    path = Path(path)
    try:
        if path.parent and not path.parent.exists():
            path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=dpi)
    except OSError as exc:
        try:
            if path.is_file() and not path.is_symlink():
                path.unlink()
        except OSError:  # pragma: no cover - the folder went away meanwhile
            pass
        raise outputs.WriteFailed(f"{path}: cannot write ({exc.strerror or exc})") from None
    return path


def set_title(ax: Axes, text: str, fontsize: float = 9.0) -> None:
    """``ax``'s title, wrapped to the figure's width (never cut: a long scene line takes two lines)."""
    chars = max(20, int(0.95 * ax.figure.get_figwidth() * 72.0 / (0.62 * fontsize)))  # DejaVu Sans: about 0.6 em a character
    ax.set_title("\n".join(textwrap.fill(line, chars) for line in text.split("\n")), fontsize=fontsize)


def setup_frame_axes(ax: Axes, clamp_mm: float = 8.0) -> None:
    """Equal scales, y to the right, x downwards, labelled in mm, with the clamp at the origin: a
    hatched block as wide as the actuator (``clamp_mm`` either side, its external radius), above
    the base. A state bent past 180 degrees rises above the base beside it (the model has no
    contact with the mount)."""
    from matplotlib.patches import Rectangle

    ax.set_aspect("equal", adjustable="datalim")
    if not ax.yaxis_inverted():
        ax.invert_yaxis()
    ax.set_xlabel("y (mm)")
    ax.set_ylabel("x (mm), downwards")
    ax.add_patch(Rectangle((-clamp_mm, -0.6 * clamp_mm), 2 * clamp_mm, 0.6 * clamp_mm, facecolor="0.85", edgecolor="0.3", hatch="///", lw=1.0, zorder=0))
    ax.grid(True, color="0.9", lw=0.6)


def draw_shape(ax: Axes, result: Equilibrium, label: str | None = None, joints: bool = True, **style) -> None:
    """The deformed centre-line (inextensible layer) of ``result``, with the segment ends marked."""
    cl = result.centreline
    (line,) = ax.plot(cl[:, 1], cl[:, 0], label=label, **style)
    if joints:
        pts = result.model.points(result.theta, result.scene.actuator.L)
        ax.plot(pts[1], pts[0], "o", ms=3.5, color=line.get_color(), zorder=line.get_zorder() + 1)


def draw_payloads(ax: Axes, result: Equilibrium, length_mm: float = 25.0, color: str = "C3") -> None:
    """An arrow per payload at its point of application (length proportional to the force)."""
    if not result.scene.payloads:
        return
    biggest = max(p.force for p in result.scene.payloads) or 1.0
    s = np.array([p.at for p in result.scene.payloads])
    f = result.model["centreline"].map(len(s))
    pts = np.asarray(f(result.theta, result.scene.actuator.L, s.reshape(1, -1))).T
    for p, pt in zip(result.scene.payloads, pts):
        if p.force == 0:
            continue
        om = math.radians(p.angle_deg)
        scale = length_mm * p.force / biggest
        dx, dy = scale * math.cos(om), -scale * math.sin(om)
        # drawn above the shapes and markers, its head ending short of the point so that the
        # markers at the tip (segment ends, measured tips) do not hide it
        ax.annotate(
            "",
            xy=(pt[1], pt[0]),
            xytext=(pt[1] - dy, pt[0] - dx),
            arrowprops={"arrowstyle": "-|>,head_length=0.8,head_width=0.4", "color": color, "lw": 2.0, "shrinkA": 0, "shrinkB": 6},
            zorder=10,
        )
        ax.annotate(f"{p.force:g} N", xy=(pt[1] - dy, pt[0] - dx), color=color, fontsize=8, ha="center", va="bottom", zorder=10)
        ax.update_datalim([(pt[1] - dy, pt[0] - dx)])  # annotations do not scale the axes: the arrow's tail and its label stay inside
    ax.autoscale_view()


def draw_tip_ellipse(ax: Axes, centre: Sequence[float], cov: np.ndarray, level: float = 0.95, label: str | None = None, **style) -> None:
    """The ``level`` ellipse of a 2x2 tip covariance (mm^2, x down, y horizontal) around ``centre`` [x, y]."""
    k = math.sqrt(-2.0 * math.log(1.0 - level))
    w, v = np.linalg.eigh(0.5 * (np.asarray(cov) + np.asarray(cov).T))
    t = np.linspace(0.0, 2.0 * math.pi, 181)
    pts = (v * (k * np.sqrt(np.maximum(w, 0.0)))) @ np.vstack([np.cos(t), np.sin(t)])
    style.setdefault("color", "C1")
    ax.plot(centre[1] + pts[1], centre[0] + pts[0], label=label, **style)


def solve_figure(result: Equilibrium, unloaded: Equilibrium | None = None, tip_cov: np.ndarray | None = None, samples: np.ndarray | None = None) -> Figure:
    """The deformed shape of ``result`` next to the unloaded one (same pressure), with its payloads.

    With ``tip_cov`` (2x2, mm^2, from :func:`esba.calibration.uncertainty.propagate`) the tip's 95 % covariance
    ellipse is drawn; with ``samples`` (k x 2 tip positions, mm, from a Monte Carlo) the samples too.
    """
    fig = new_figure()
    ax = fig.add_subplot()
    draw_solution(ax, result, unloaded, tip_cov, samples)
    return fig


def draw_solution(ax: Axes, result: Equilibrium, unloaded: Equilibrium | None = None, tip_cov: np.ndarray | None = None,
                  samples: np.ndarray | None = None) -> None:
    """:func:`solve_figure`'s drawing into ``ax``: the frame, the shapes, the payloads, the tip's uncertainty."""
    setup_frame_axes(ax, result.scene.actuator.r1)
    if unloaded is not None:
        draw_shape(ax, unloaded, label=f"unloaded: {unloaded.total_angle_deg:.1f} deg", color="0.55", ls="--")
    verdict = "" if result.ok else f" [{result.stability}, {result.status}]"
    draw_shape(ax, result, label=f"loaded: {result.total_angle_deg:.1f} deg{verdict}", color="C0", lw=2)
    draw_payloads(ax, result)
    if samples is not None and len(samples):
        ax.plot(samples[:, 1], samples[:, 0], ".", ms=1.0, color="C2", alpha=0.3, label=f"Monte Carlo tips ({len(samples)})", zorder=1)
    if tip_cov is not None and np.all(np.isfinite(tip_cov)):
        draw_tip_ellipse(ax, result.tip[:2], tip_cov, 0.95, label="tip, 95 % ellipse (first order)", lw=1.5)
    s = result.scene
    ax.set_title(f"n = {s.segments}, P = {result.pressure:.4f} MPa, {s.variant} model", fontsize=10)
    ax.legend(loc="upper right", fontsize=8)

"""Figures of equilibrium paths: branches with their stability, special points and hysteresis.

A branch is drawn solid where it is stable and dashed where it is not (Morse index > 0); folds are
marked with circles (LP), branch points with squares (BP). Quasi-static loading up and down is
drawn over it: the stable pieces it follows as thick translucent lines and each snap-through as
an arrow at the value of the parameter where it happens.

Examples
--------
>>> import tempfile, pathlib
>>> from esba.model.scene import Scene, Payload
>>> from esba.analysis.path_analysis import analyse
>>> s = analyse(Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),)), "pressure", 0.3)
>>> out = pathlib.Path(tempfile.mkdtemp()) / "path.png"
>>> save_figure(path_figure(s), out).exists()
True
"""

from __future__ import annotations

import textwrap
from typing import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from esba.paths.branch import Branch
from esba.paths.loading import Ramp
from esba.paths.problem import PathError

from .scenes import new_figure, save_figure

__all__ = ["Y_AXES", "LOADING_BANDS", "branch_values", "draw_branch", "draw_loading", "draw_path", "path_figure", "parameter_label", "path_title", "save_figure"]

#: What a path figure can show against the parameter: name -> (label, unit).
Y_AXES = {"total-angle": ("total bending angle", "deg"), "tip-x": ("tip x, vertical, downwards", "mm"), "tip-y": ("tip y, horizontal", "mm")}


def values(theta: np.ndarray, tip: np.ndarray, y: str) -> np.ndarray:
    """The quantity ``y`` (a key of :data:`Y_AXES`) of states: theta (rad) and tip rows, or one state."""
    theta, tip = np.atleast_2d(theta), np.atleast_2d(tip)
    if y == "total-angle":
        return np.degrees(np.sum(theta, axis=1))
    if y in ("tip-x", "tip-y"):
        return tip[:, 0 if y == "tip-x" else 1]
    raise ValueError(f"y={y!r}: allowed are {', '.join(Y_AXES)}")


def branch_values(branch: Branch, y: str) -> np.ndarray:
    """The quantity ``y`` (a key of :data:`Y_AXES`) at every point of a branch."""
    return values(branch.theta, branch.tip, y)


def _point_value(theta: np.ndarray, tip: np.ndarray, y: str) -> float:
    return float(values(theta, tip, y)[0])


def draw_branch(ax: Axes, branch: Branch, y: str = "total-angle", color: str = "C0", label: str | None = None, swap: bool = False) -> None:
    """Draw one branch: stable solid, unstable dashed, folds (o) and branch points (s) marked.

    ``swap`` puts the parameter on the vertical axis (as the paper's Fig. 10 does).
    """
    if len(branch) == 0:
        return
    lam, val = branch.lam, branch_values(branch, y)
    stable = branch.stable
    # split into runs of equal stability; neighbouring runs share their end point
    start = 0
    first = True
    for i in range(1, len(lam) + 1):
        if i == len(lam) or stable[i] != stable[start]:
            end = min(i + 1, len(lam))
            xs, ys = lam[start:end], val[start:end]
            if swap:
                xs, ys = ys, xs
            ax.plot(xs, ys, color=color, lw=1.8, ls="-" if stable[start] else "--", label=label if first else None)
            first = False
            start = i
    for sp in branch.special:
        v = _point_value(sp.theta, sp.tip, y)
        x, yv = (v, sp.lam) if swap else (sp.lam, v)
        if sp.kind == "fold":
            ax.plot(x, yv, "o", mfc="white", mec=color, mew=1.5, ms=7, zorder=5)
        elif sp.kind == "branch point":
            ax.plot(x, yv, "s", mfc="white", mec=color, mew=1.5, ms=7, zorder=5)


#: The bands of quasi-static loading up and down: opaque light colours (a translucent pair blends,
#: where both follow the same piece, into a colour that neither legend entry shows) and two widths,
#: the narrower drawn over the wider, so that both stay visible where they coincide.
LOADING_BANDS = (("loading up", "#f4a3a3", 11.0), ("loading down", "#7fcf8f", 5.5))
#: Drawing order: the bands under the branches and their markers.
BAND_ZORDER = 1.0


def draw_loading(ax: Axes, ramps: Sequence[Ramp], y: str = "total-angle", swap: bool = False) -> None:
    """Draw quasi-static ramps: the stable pieces followed (bands, :data:`LOADING_BANDS`) and each jump (an arrow)."""
    for k, ramp in enumerate(ramps):
        name, color, width = LOADING_BANDS[k % 2]
        first = True
        for piece in ramp.pieces:
            xs, ys = piece.lam, branch_values(piece, y)
            if swap:
                xs, ys = ys, xs
            ax.plot(xs, ys, color=color, lw=width, solid_capstyle="round", zorder=BAND_ZORDER + 0.1 * k, label=name if first else None)
            first = False
        # a branch point passed without a jump: the state goes on from it to the crossing branch's first point
        for a, b in zip(ramp.pieces, ramp.pieces[1:]):
            if len(a) and len(b) and any(abs(float(a.lam[-1]) - bp.lam) <= 1e-9 * (1.0 + abs(bp.lam)) for bp in ramp.branch_points):
                xs = np.array([a.lam[-1], b.lam[0]])
                ys = np.array([branch_values(a, y)[-1], branch_values(b, y)[0]])
                if swap:
                    xs, ys = ys, xs
                ax.plot(xs, ys, color=color, lw=width, solid_capstyle="round", zorder=BAND_ZORDER + 0.1 * k)
        for j in ramp.jumps:
            a = _point_value(j.theta_before, j.tip_before, y)
            b = _point_value(j.theta_after, j.tip_after, y)
            start, end = ((a, j.lam), (b, j.lam_after)) if swap else ((j.lam, a), (j.lam_after, b))
            ax.annotate("", xy=end, xytext=start, arrowprops={"arrowstyle": "-|>", "color": ("C3", "C2")[k % 2], "lw": 1.6})


def path_figure(analysis, y: str = "total-angle", title: str | None = None) -> Figure:
    """The figure of a :class:`esba.analysis.path_analysis.PathAnalysis`: every branch, its special points, the hysteresis."""
    fig = new_figure(7.0, 4.8)
    ax = fig.add_subplot()
    draw_path(ax, analysis, y)
    ax.set_title(title or path_title(analysis), fontsize=8)
    return fig


def draw_path(ax: Axes, analysis, y: str = "total-angle") -> None:
    """Every branch of a :class:`esba.analysis.path_analysis.PathAnalysis`, its special points and the hysteresis, into ``ax``."""
    draw_loading(ax, analysis.loading, y)
    draw_branch(ax, analysis.main, y, "C0", "branch through the start")
    for k, b in enumerate(analysis.crossing):
        bp = k // 2 + 1
        draw_branch(ax, b, y, f"C{bp + 3}", f"branch crossing at BP{bp} (both sides)" if k % 2 == 0 else None)
    # legend entries for the line styles and markers
    ax.plot([], [], color="0.3", ls="-", label="stable")
    ax.plot([], [], color="0.3", ls="--", label="unstable")
    if any(b.folds for b in analysis.branches):
        ax.plot([], [], "o", mfc="white", mec="0.3", label="fold (LP)")
    if any(b.branch_points for b in analysis.branches):
        ax.plot([], [], "s", mfc="white", mec="0.3", label="branch point (BP)")
    ax.set_xlabel(parameter_label(analysis.problem))
    name, yunit = Y_AXES[y]
    ax.set_ylabel(f"{name} ({yunit})")
    ax.grid(True, color="0.9", lw=0.6)
    ax.legend(fontsize=7.5, loc="best")


def parameter_label(problem) -> str:
    """The axis label of a path's parameter in words, with its unit: ``payload magnitude (N)``,
    ``payload direction from the vertical (deg)``; a payload's number when the scene has several."""
    what = problem.what or problem.name
    k = problem.name[len(problem.name.rstrip("0123456789")):]
    scene = getattr(problem, "scene", None)
    if k and scene is not None and len(scene.payloads) > 1:
        what += f" of payload {k}"
    unit = problem.unit
    if unit.startswith("1"):
        unit = unit[1:].strip(" ()")
    return what + (f" ({unit})" if unit else "")


def path_title(analysis) -> str:
    """What a path figure shows: the parameter and its range, then the scene at the start of the
    path (its value of the parameter, not the scene's drive: a pressure path starts at its
    ``--from``, whatever pressure or target angle the scene had)."""
    problem = analysis.problem
    unit = problem.unit.split(" ")[0]
    unit = "" if unit == "1" else f" {unit}"
    try:
        scene = problem.scene_at(float(analysis.lam_from)).describe()
    except PathError:  # a path not built from a scene, or a start the scene cannot take: the scene as given
        scene = analysis.scene.describe()
    head = f"{problem.what or problem.name} from {analysis.lam_from:g} to {analysis.lam_to:g}{unit} (esba path --param {problem.name})"
    return "\n".join([head, *textwrap.wrap(f"at the start: {scene}", 90)])

"""Figures of sweeps: :func:`sweep_figure` draws a :class:`esba.studies.sweep.SweepResult`, each curve the
traced branch through its grid points; :func:`fig12` the paper's Fig. 12, the bending angle
against r2 for d = 0, 2, 4, 6 mm and against d for r2 = 2, 4, 6 mm, at rho = 10 degrees and
P = 0.2 MPa without payload.
"""

from __future__ import annotations

import itertools

import numpy as np

from esba.model.scene import Scene
from esba.statics.batch import BatchOptions
from esba.studies.sweep import ACTUATOR_AXES, AXES, SweepError, SweepResult, sweep

__all__ = ["sweep_figure", "draw_sweep", "fig12", "FIG12_D", "FIG12_R2"]


#: The sweep axes a path can follow (:data:`esba.paths.problem.PARAMETERS` names).
_PATH_OF_AXIS = {"pressure": "pressure", "payload": "payload", "payload_angle": "omega", "L": "L", "r1": "r1", "r2": "r2", "d": "d",
                 "rho_deg": "rho", "E": "E", "M": "M"}


def _traced(result: SweepResult, idx: np.ndarray, x_name: str):
    """The branch through the first ok point of a curve, traced over the curve's range; None when
    the curve cannot be one branch (each design at its own pressure) or has no ok point."""
    from esba.paths.continuation import PathOptions, PathProblem, trace

    if x_name in ACTUATOR_AXES and "pressure" not in result.axes and result.base.pressure is None:
        return None  # every design at the pressure of its own target angle: not one path
    ok = [i for i in idx if result.status[i] == "ok"]
    if not ok:
        return None
    i0 = ok[0]
    xs = result.points[x_name][idx]
    try:
        scene = result.scene(int(i0))
        problem = PathProblem.from_scene(scene, _PATH_OF_AXIS[x_name], pressure=float(result.pressure[i0]))
        return trace(problem, result.theta[i0], float(result.points[x_name][i0]), to=float(xs.max()), options=PathOptions(ds_max=0.1))
    except (ValueError, RuntimeError):
        return None


def sweep_figure(result: SweepResult, max_curves: int = 12, traced: bool = True):
    """Total bending angle against the first swept axis with more than one value, one curve per
    combination of the other axes (points that are not ok are left out, not drawn as zero).

    With ``traced`` each curve is the branch of equilibria through its first point, traced over
    the axis (:mod:`esba.paths.continuation`): stable solid, unstable dashed, folds marked, so that a bistable
    range shows its unstable middle and its folds instead of a line through the jump; the grid
    points themselves are the markers (each solved along the scene's own load history).
    """
    from .scenes import new_figure

    fig = new_figure(6.5, 4.5)
    draw_sweep(fig.subplots(), result, max_curves, traced)
    return fig


def draw_sweep(ax, result: SweepResult, max_curves: int = 12, traced: bool = True) -> None:
    """:func:`sweep_figure`'s drawing into ``ax``."""
    from .paths import draw_branch

    names = [k for k, v in result.axes.items() if len(v) > 1] or list(result.axes)
    x_name = names[0]
    others = [k for k in result.axes if k != x_name]
    combos = list(itertools.product(*(result.axes[k] for k in others)))
    if len(combos) > max_curves:
        raise SweepError(f"the figure would have {len(combos)} curves (> {max_curves}): sweep fewer values of {', '.join(others)}")
    angle = np.where(result.ok, result.total_angle_deg, np.nan)
    any_traced = any_fold = False
    for k, combo in enumerate(combos):
        mask = np.ones(len(angle), dtype=bool)
        for name, v in zip(others, combo):
            mask &= np.isclose(result.points[name], v)
        label = ", ".join(f"{name} = {v:g} {AXES[name]}" for name, v in zip(others, combo)) or None
        idx = np.flatnonzero(mask)
        idx = idx[np.argsort(result.points[x_name][idx], kind="stable")]
        branch = _traced(result, idx, x_name) if traced and len(idx) > 1 else None
        color = f"C{k % 10}"
        if branch is not None:
            any_traced = True
            any_fold = any_fold or bool(branch.folds)
            draw_branch(ax, branch, "total-angle", color, label)
            ax.plot(result.points[x_name][idx], angle[idx], "o", color=color, ms=3)
        else:
            ax.plot(result.points[x_name][idx], angle[idx], "o-", color=color, ms=3, label=label)
    ax.set_xlabel(f"{x_name} ({AXES[x_name]})")
    ax.set_ylabel("total bending angle (deg)")
    ax.grid(True, color="0.9", lw=0.6)
    if any_traced:
        ax.plot([], [], "o", color="0.4", ms=3, label="grid points (each along its load history)")
        ax.plot([], [], color="0.4", ls="--", label="unstable (traced branch)")
        if any_fold:
            ax.plot([], [], "o", mfc="white", mec="0.4", label="fold")
    if (combos and others) or any_traced:
        ax.legend(fontsize=7)
    a, b = result.base.actuator, result.base
    held = [f"{k}={getattr(a, k):g}" for k in ("L", "r1", "r2", "d") if k not in result.axes]
    held += [f"{k.removesuffix('_deg')}={getattr(a, k):g} {AXES[k]}" for k in ("rho_deg", "E") if k not in result.axes]
    if b.gravity and "M" not in result.axes:
        held.append(f"M={a.M:g} kg")
    fixed = [" ".join(held)] if held else []
    if "pressure" not in result.axes:
        fixed.append(f"P={b.pressure:g} MPa" if b.pressure is not None else f"P for an unloaded {b.target_angle_deg:g} deg")
    if b.payloads:
        p = b.payloads[0]
        fixed.append(
            "payload"
            + ("" if "payload" in result.axes else f" {p.force:g} N")
            + ("" if "payload_angle" in result.axes else f" at {p.angle_deg:g} deg")
            + f", s={p.at:g}"
        )
    fixed.append(f"n={b.segments}")
    ax.set_title("; ".join(fixed) + " (esba sweep --plot)", fontsize=8)



#: The paper's Fig. 12: rho = 10 degrees, P = 0.2 MPa, no payload; d = 0, 2, 4, 6 (a), r2 = 2, 4, 6 (b).
FIG12_D = (0.0, 2.0, 4.0, 6.0)
FIG12_R2 = (2.0, 4.0, 6.0)


def fig12(base: Scene | None = None, points: int = 60, options: BatchOptions | None = None):
    """Fig. 12 of the paper: bending angle against r2 (for each d) and against d (for each r2).

    Each curve runs to the edge of the design space, r2 + d = r1 - 0.05 mm. Returns the figure
    and the sweeps: ``{"r2": [one per d], "d": [one per r2]}``.
    """
    from .scenes import new_figure

    base = Scene(pressure=0.2, segments=3) if base is None else base
    r1 = base.actuator.r1
    edge = 0.05  # mm: the thinnest chamber wall of the sweep
    sweeps: dict[str, list[SweepResult]] = {"r2": [], "d": []}
    fig = new_figure(10.0, 4.2)
    ax_a, ax_b = fig.subplots(1, 2)
    for dv in FIG12_D:
        s = sweep(base, d=dv, r2=list(np.linspace(0.1, r1 - dv - edge, points)), options=options)
        sweeps["r2"].append(s)
        ax_a.plot(s.points["r2"], np.where(s.ok, s.total_angle_deg, np.nan), label=f"d = {dv:g} mm")
    for rv in FIG12_R2:
        s = sweep(base, r2=rv, d=list(np.linspace(0.0, r1 - rv - edge, points)), options=options)
        sweeps["d"].append(s)
        ax_b.plot(s.points["d"], np.where(s.ok, s.total_angle_deg, np.nan), label=f"r2 = {rv:g} mm")
    ax_a.set_xlabel("chamber radius r2 (mm)")
    ax_a.set_ylabel("bending angle (deg, log scale)")
    ax_a.set_yscale("log")
    ax_a.set_title("(a) bending angle against r2")
    ax_b.set_xlabel("eccentric distance d (mm)")
    ax_b.set_ylabel("bending angle (deg)")
    ax_b.set_title("(b) bending angle against d")
    for ax in (ax_a, ax_b):
        ax.grid(True, which="both", color="0.9", lw=0.6)
        ax.legend()
    a = base.actuator
    fig.suptitle(
        f"Fig. 12 type: r1 = {a.r1:g} mm, rho = {a.rho_deg:g} deg, P = {base.pressure:g} MPa, no payload, n = {base.segments}\n"
        f"each curve ends at the design-space edge r2 + d = r1 - {edge:g} mm (esba sweep --fig12)",
        fontsize=10,
    )
    return fig, sweeps

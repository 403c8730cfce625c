"""The paper's figures, regenerated from esba's model: a registry of figure functions.

Each figure is a function ``draw() -> Figure`` that solves what it needs (or takes the data it is
given) and draws it with matplotlib on the Agg canvas (:mod:`esba.figures.scenes`); :func:`write_all`
writes each as one PNG. The data behind each figure comes from a function of its own, so that
tests can check the numbers, and then that the figure shows them (its lines' data, its labels):

========  ==============================================  =================================
name      what                                            data
========  ==============================================  =================================
fig7b     unloaded bending angle against pressure,         :func:`pressure_angle_curves`
          0-0.2 MPa, fibre angles 5, 10, 15, 20 deg
fig8c     shapes for n = 1..4 under a 2 N horizontal       :func:`payload_shapes`
          tip payload at the 90 deg pressure
fig10     horizontal tip payload 0-2 N against the tip     :func:`payload_branch` (a traced
          position, n = 3                                  branch, :mod:`esba.paths.continuation`)
fig11     secant stiffness against payload (0.5, 1, 2 N    :func:`horizontal_payload_sweep`
          and a fine curve), n = 3
========  ==============================================  =================================

The design figures of the parameter sweep (``fig13a``, ``fig13b``, ``fig14``) live in
:mod:`esba.figures.design`; :func:`registry` lists them when that module is installed and
imports it only when one of them is drawn.

All figures use the Table 1 actuator (:class:`esba.model.scene.Actuator` defaults) and the paper's
frame (x down along the unbent axis, y horizontal). Units: mm, N, MPa; degrees on the axes.

Examples
--------
>>> list(registry())[:4]
['fig7b', 'fig8c', 'fig10', 'fig11']
>>> write_all("unused", names=["fig9"])  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
esba.figures.paper.FigureError: unknown figure 'fig9': allowed are fig7b, fig8c, fig10, fig11...
"""

from __future__ import annotations

import importlib
import importlib.util
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

import numpy as np
from matplotlib.figure import Figure

from esba.analysis.stiffness import PAPER_FORCES, SecantStiffness, secant_stiffness
from esba.infra.errors import InputError
from esba.infra.outputs import check_folder, figures_dir
from esba.model.scene import MAIN_JOB, Payload, Scene
from esba.statics.equilibrium import (
    Equilibrium,
    EquilibriumError,
    pressure_for_angle,
    solve,
)

from .scenes import draw_payloads, draw_shape, new_figure, save_figure, setup_frame_axes

__all__ = [
    "FigureError",
    "FIBRE_ANGLES_DEG",
    "PressureAngleCurve",
    "pressure_angle_curves",
    "PayloadShapes",
    "payload_shapes",
    "horizontal_payload_sweep",
    "payload_branch",
    "draw_7b",
    "draw_8c",
    "draw_10",
    "draw_11",
    "registry",
    "check_names",
    "write_all",
]

#: Fibre winding angles of Fig. 7b, degrees (10 is Table 1's).
FIBRE_ANGLES_DEG: tuple[float, ...] = (5.0, 10.0, 15.0, 20.0)

#: Largest pressure of Fig. 7b, MPa (Section 4.4.1).
FIG7B_MAX_PRESSURE = 0.2

#: The tip under 2 N horizontal in the paper's experiment and FEM (Table 2), (x, y) in mm.
TABLE2_EXP_TIP_MM = (133.5, 8.1)
TABLE2_FEM_TIP_MM = (125.6, 15.3)

#: The paper's analytical pressure for 90 degrees (Section 4.4.2), MPa (rounded as printed).
PAPER_90_DEG_PRESSURE = 0.123

#: The payloads of the fine curves of Figs. 10-11, N.
FINE_FORCES: tuple[float, ...] = tuple(float(f) for f in np.round(np.linspace(0.025, 2.0, 80), 10))


class FigureError(InputError):
    """A figure name that is not registered: the message lists the allowed names."""


def _checked(result: Equilibrium, what: str) -> Equilibrium:
    """``result`` when it is a stable equilibrium; a figure is never drawn from a failed solve."""
    if not result.ok:
        raise EquilibriumError(f"{what}: {result.message or result.status}")
    return result


def _zero_payload(scene: Scene) -> Scene:
    """``scene`` with a 0 N horizontal tip payload: unloaded, on the committed payload model."""
    return scene.replace(payloads=(Payload(0.0, 90.0, 1.0),), gravity=False)


# ---------------------------------------------------------------------------------------------
# Fig. 7b: pressure against bending angle, unloaded


@dataclass(frozen=True, eq=False)
class PressureAngleCurve:
    """The unloaded bending angle against pressure for one fibre angle.

    Attributes
    ----------
    rho_deg : float
        Fibre winding angle, degrees.
    pressure_mpa : ndarray
        Pressures, MPa, ascending from 0 to the largest pressure.
    angle_deg : ndarray
        Total bending angle at each pressure, degrees.
    check : Equilibrium
        The forward solve at the largest pressure, whose angle ends the curve.
    """

    rho_deg: float
    pressure_mpa: np.ndarray
    angle_deg: np.ndarray
    check: Equilibrium = field(repr=False)


def pressure_angle_curves(
    rhos_deg: Sequence[float] = FIBRE_ANGLES_DEG,
    max_pressure: float = FIG7B_MAX_PRESSURE,
    points: int = 61,
    scene: Scene | None = None,
) -> list[PressureAngleCurve]:
    """Unloaded bending angle against pressure, 0 to ``max_pressure``, one curve per fibre angle.

    Unloaded bending is of constant curvature (Section 4.4.1), so one segment is exact. The curve
    is drawn by inversion: an equilibrium solve at ``max_pressure`` gives the largest angle, then
    the closed-form pressure (:func:`esba.statics.equilibrium.pressure_for_angle`, U is linear in P) is
    evaluated on an even grid of angles from 0 to that angle. The grid's last pressure is the
    solve's own, so inversion and solve agree by construction of the end point and by the
    closed form in between.

    Parameters
    ----------
    rhos_deg : sequence of float
        Fibre winding angles, degrees.
    max_pressure : float
        Largest pressure, MPa.
    points : int
        Angles per curve (>= 2), including 0.
    scene : Scene, optional
        The actuator (default Table 1); its fibre angle, payloads and segment count are replaced.

    Returns
    -------
    list of PressureAngleCurve
        In the order of ``rhos_deg``.

    Examples
    --------
    >>> c = pressure_angle_curves([10.0], points=3)[0]
    >>> [round(float(p), 3) for p in c.pressure_mpa], round(float(c.angle_deg[-1]), 1)
    ([0.0, 0.124, 0.2], 179.4)
    """
    base = _zero_payload((scene or Scene()).replace(segments=1, pressure=float(max_pressure)))
    curves = []
    for rho in rhos_deg:
        s = base.replace(rho_deg=float(rho))
        end = _checked(solve(s), f"Fig. 7b, rho = {rho:g} deg at {max_pressure:g} MPa")
        angles = np.linspace(0.0, end.total_angle_deg, int(points))
        pressures = np.array([0.0] + [pressure_for_angle(s, a) for a in angles[1:]])
        curves.append(PressureAngleCurve(float(rho), pressures, angles, end))
    return curves


def draw_7b(curves: Sequence[PressureAngleCurve] | None = None) -> Figure:
    """Fig. 7b: unloaded bending angle against pressure for fibre angles 5, 10, 15, 20 deg
    (``curves``: :func:`pressure_angle_curves`, computed when not given)."""
    curves = pressure_angle_curves() if curves is None else curves
    fig = new_figure(6.0, 4.6)
    ax = fig.add_subplot()
    for k, c in enumerate(curves):
        ax.plot(c.pressure_mpa, c.angle_deg, color=f"C{k}", lw=1.8, label=f"ρ = {c.rho_deg:g}°")
    # the 90 degree state of Table 1 (rho = 10 deg), the start of Figs. 8-11
    p90 = pressure_for_angle(_zero_payload(Scene(segments=1)), 90.0)
    ax.axhline(90.0, color="0.6", lw=0.8, ls=":")
    ax.plot([p90], [90.0], "ko", ms=4, zorder=5)
    ax.annotate(
        f"90° at {p90:.4f} MPa (ρ = 10°)\npaper, analytical: {PAPER_90_DEG_PRESSURE} MPa",
        xy=(p90, 90.0),
        xytext=(p90 - 0.005, 118.0),
        ha="right",
        fontsize=8,
        arrowprops={"arrowstyle": "-", "color": "0.4", "lw": 0.8},
    )
    ax.set_xlim(0.0, FIG7B_MAX_PRESSURE)
    ax.set_ylim(0.0, None)
    ax.set_xlabel("input pressure P (MPa)")
    ax.set_ylabel("bending angle θ (deg)")
    ax.set_title(
        "Bending angle against pressure, no payload (cf. paper Fig. 7b)\n"
        "Table 1 actuator; n = 1 is exact here (constant curvature)",
        fontsize=10,
    )
    ax.grid(True, color="0.9", lw=0.6)
    ax.legend(title="fibre angle", loc="upper left", fontsize=8, title_fontsize=8)
    return fig


# ---------------------------------------------------------------------------------------------
# Fig. 8c: shapes for n = 1..4 under a 2 N horizontal tip payload


@dataclass(frozen=True, eq=False)
class PayloadShapes:
    """The unloaded 90 degree shape and the shapes under one tip payload for several n.

    Attributes
    ----------
    pressure : float
        The 90 degree pressure, MPa (held for every shape).
    unloaded : Equilibrium
        The unloaded shape (constant curvature).
    loaded : tuple of Equilibrium
        One loaded shape per segment count, in the order asked.
    """

    pressure: float
    unloaded: Equilibrium = field(repr=False)
    loaded: tuple[Equilibrium, ...] = field(repr=False)


def payload_shapes(segments: Sequence[int] = (1, 2, 3, 4), force: float = 2.0, angle_deg: float = 90.0) -> PayloadShapes:
    """Shapes under a tip payload at the unloaded 90 degree pressure, for each segment count.

    Parameters
    ----------
    segments : sequence of int
        Segment counts n.
    force : float
        Tip payload, N.
    angle_deg : float
        Its direction Omega (90 = horizontal, against the bend).

    Returns
    -------
    PayloadShapes

    Examples
    --------
    >>> s = payload_shapes(segments=(3,))
    >>> [round(v, 1) for v in s.loaded[0].tip_mm]
    [133.2, 10.2]
    """
    pressure = pressure_for_angle(_zero_payload(MAIN_JOB), 90.0)
    unloaded = _checked(solve(_zero_payload(MAIN_JOB.replace(segments=1)), pressure=pressure), "Fig. 8c, unloaded")
    loaded = tuple(
        _checked(
            solve(MAIN_JOB.replace(segments=int(n), payloads=(Payload(force, angle_deg, 1.0),)), pressure=pressure),
            f"Fig. 8c, n = {n}",
        )
        for n in segments
    )
    return PayloadShapes(pressure, unloaded, loaded)


def draw_8c(data: PayloadShapes | None = None) -> Figure:
    """Fig. 8c: shapes for n = 1..4 under a 2 N horizontal tip payload, with the unloaded 90 deg shape
    (``data``: :func:`payload_shapes`, computed when not given)."""
    data = payload_shapes() if data is None else data
    fig = new_figure(6.4, 6.0)
    ax = fig.add_subplot()
    setup_frame_axes(ax, data.unloaded.scene.actuator.r1)
    u = data.unloaded
    draw_shape(ax, u, label=f"no payload: {u.total_angle_deg:.1f}°", joints=False, color="0.55", ls="--", lw=1.5)
    for k, r in enumerate(data.loaded):
        x, y = r.tip_mm
        draw_shape(
            ax, r, color=f"C{k}", lw=1.6,
            label=f"n = {r.scene.segments}: θ = {r.total_angle_deg:.1f}°, tip ({x:.1f}, {y:.1f}) mm",
        )
    draw_payloads(ax, data.loaded[-1])
    ax.plot(TABLE2_EXP_TIP_MM[1], TABLE2_EXP_TIP_MM[0], "k*", ms=9, label="experiment tip (Table 2)")
    ax.plot(TABLE2_FEM_TIP_MM[1], TABLE2_FEM_TIP_MM[0], "kx", ms=7, label="FEM tip (Table 2)")
    ax.set_title(
        f"Shapes under a 2 N horizontal tip payload, P = {data.pressure:.4f} MPa\n(cf. paper Fig. 8c; dots: segment ends)",
        fontsize=10,
    )
    # fixed limits (room for the legend and below the tips); equal scales by the box, not the data
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlim(-30.0, 125.0)
    ax.set_ylim(145.0, -5.0)
    ax.legend(loc="upper right", fontsize=7.5)
    return fig


# ---------------------------------------------------------------------------------------------
# Figs. 10-11: horizontal tip payload from the 90 degree state, n = 3


def horizontal_payload_sweep(forces: Sequence[float] = FINE_FORCES, segments: int = 3) -> SecantStiffness:
    """The tip under horizontal tip payloads from the unloaded 90 degree state, pressure held.

    This is the paper's stiffness experiment (Section 4.4.3): :func:`esba.analysis.stiffness.secant_stiffness`
    on the Table 1 actuator at its 90 degree pressure. Every solve is checked.

    Parameters
    ----------
    forces : sequence of float
        Payloads, N (> 0); the unloaded state is :attr:`SecantStiffness.initial`.
    segments : int
        Segment count n (the paper uses 3 from Section 4.4.2 on).

    Returns
    -------
    SecantStiffness

    Examples
    --------
    >>> s = horizontal_payload_sweep([0.5, 1.0, 2.0])
    >>> [round(k, 1) for k in s.stiffness_n_per_m]
    [41.0, 31.3, 26.4]
    """
    forces = tuple(forces) if isinstance(forces, (list, tuple, np.ndarray)) else forces  # anything else: secant_stiffness says what it expected
    result = secant_stiffness(MAIN_JOB.replace(segments=segments), forces, angle_deg=90.0)  # the scene checks n (2.5 is refused, not 2)
    for f, r in zip((0.0, *result.forces), (result.initial, *result.loaded)):
        _checked(r, f"payload sweep, {f:g} N")
    return result


def payload_branch(segments: int = 3, to: float = 2.0, angle_deg: float = 90.0):
    """The branch of equilibria as a tip payload grows from 0 to ``to`` N at the 90 degree pressure.

    A path trace (:func:`esba.paths.continuation.trace`) from the unloaded 90 degree state, with exact points at
    the paper's payloads (0.5, 1, 2 N); a fold or branch point on the way is located and shown.

    Examples
    --------
    >>> b = payload_branch()
    >>> b.stop_reason, [(p.lam, round(float(p.tip[1]), 2)) for p in b.special if p.kind == "user"]
    ('reached payload1 = 2 N', [(0.5, 73.75), (1.0, 54.04), (2.0, 10.22)])
    """
    from esba.paths.continuation import PathOptions, PathProblem, trace

    scene = MAIN_JOB.replace(segments=segments, payloads=(Payload(0.0, angle_deg, 1.0),))
    start = _checked(solve(scene), "unloaded 90 deg state")
    problem = PathProblem.from_scene(scene, "payload", pressure=start.pressure)
    return trace(problem, start.theta, 0.0, to=to, milestones=PAPER_FORCES, options=PathOptions(ds_max=0.05))


def draw_10(branch=None) -> Figure:
    """Fig. 10: horizontal tip payload 0-2 N against the tip position, n = 3 (``branch``: the traced
    branch of :func:`payload_branch`, computed when not given)."""
    from .paths import draw_branch

    b = payload_branch() if branch is None else branch
    fig = new_figure(8.0, 4.4)
    ax_y, ax_x = fig.subplots(1, 2, sharey=True)
    y0 = b.tip[0, 1]
    stable = "all stable" if b.stable.all() else "dashed: unstable"
    draw_branch(ax_y, b, "tip-y", "C0", f"esba, n = 3: traced branch ({stable})", swap=True)
    # the paper's secants K = dF / dy from the unloaded state, at the exact points of the trace
    lines = ["secant K = ΔF/Δy from 0 N:"]
    for f, tip in ((p.lam, p.tip) for p in b.special if p.kind == "user"):
        ax_y.plot([y0, tip[1]], [0.0, f], color="0.5", lw=0.8, ls="--")
        ax_y.plot(tip[1], f, "C0o", ms=4)
        lines.append(f"{f:g} N: {1000 * f / (y0 - tip[1]):.1f} N/m")
    ax_y.text(0.97, 0.04, "\n".join(lines), transform=ax_y.transAxes, ha="right", va="bottom", fontsize=8)
    ax_y.plot(TABLE2_EXP_TIP_MM[1], 2.0, "k*", ms=9, label="experiment, 2 N (Table 2)")
    ax_y.plot(TABLE2_FEM_TIP_MM[1], 2.0, "kx", ms=7, label="FEM, 2 N (Table 2)")
    ax_y.invert_xaxis()  # the payload pushes the tip towards y = 0
    ax_y.set_xlabel("tip y, horizontal (mm)")
    ax_y.set_ylabel("horizontal tip payload F (N)")
    ax_y.set_title("horizontal position y (dashed: secants)", fontsize=9)
    ax_y.legend(loc="upper left", fontsize=7.5)
    draw_branch(ax_x, b, "tip-x", "C1", "esba, n = 3 (traced)", swap=True)
    ax_x.plot(TABLE2_EXP_TIP_MM[0], 2.0, "k*", ms=9, label="experiment, 2 N (Table 2)")
    ax_x.plot(TABLE2_FEM_TIP_MM[0], 2.0, "kx", ms=7, label="FEM, 2 N (Table 2)")
    ax_x.set_xlabel("tip x, vertical, downwards (mm)")
    ax_x.set_title("vertical position x", fontsize=9)
    ax_x.legend(loc="upper left", fontsize=7.5)
    for ax in (ax_y, ax_x):
        ax.grid(True, color="0.9", lw=0.6)
        ax.set_ylim(0.0, None)
    problem_pressure = pressure_for_angle(MAIN_JOB)
    fig.suptitle(
        f"Tip position under a horizontal tip payload from 90°, P = {problem_pressure:.4f} MPa held (cf. paper Fig. 10)",
        fontsize=10,
    )
    return fig


def draw_11(fine: SecantStiffness | None = None, paper: SecantStiffness | None = None) -> Figure:
    """Fig. 11: secant stiffness against payload (the paper's 0.5, 1, 2 N: ``paper``, and a fine curve:
    ``fine``; each :func:`horizontal_payload_sweep`, computed when not given), n = 3."""
    fine = horizontal_payload_sweep() if fine is None else fine
    paper = horizontal_payload_sweep(PAPER_FORCES) if paper is None else paper
    fig = new_figure(6.0, 4.4)
    ax = fig.add_subplot()
    ax.plot(fine.forces, fine.stiffness_n_per_m, "C0-", lw=1.8, label="secant K = ΔF/Δy, esba n = 3")
    ax.plot(paper.forces, paper.stiffness_n_per_m, "C0o", ms=6, label="the paper's payloads 0.5, 1, 2 N")
    for f, k in zip(paper.forces, paper.stiffness_n_per_m):
        ax.annotate(f"{k:.1f} N/m", xy=(f, k), xytext=(4, 6), textcoords="offset points", fontsize=8)
    k_min = int(np.argmin(fine.stiffness_n_per_m))
    if k_min < len(fine.forces) - 1:  # the secant stiffness has a minimum inside the range: show it
        f_min, s_min = fine.forces[k_min], fine.stiffness_n_per_m[k_min]
        ax.plot([f_min], [s_min], "v", color="C2", ms=6, label=f"smallest: {s_min:.2f} N/m at {f_min:.3g} N")
    k0 = fine.tangent.along(90.0)
    ax.plot([0.0], [k0], "o", mfc="white", mec="C3", ms=6, clip_on=False, zorder=5, label=f"tangent stiffness at 0 N: {k0:.1f} N/m")
    # room around the marker at F = 0 and above the largest value, so that nothing is cut off
    ax.set_xlim(-0.05, 2.2)
    ax.set_ylim(0.0, 1.1 * max(k0, float(np.max(fine.stiffness_n_per_m))))
    ax.set_xlabel("horizontal tip payload F (N)")
    ax.set_ylabel("stiffness K (N/m)")
    ax.set_title(
        f"Secant stiffness from the unloaded 90° state, P = {fine.pressure:.4f} MPa held\n(cf. paper Fig. 11)",
        fontsize=10,
    )
    ax.grid(True, color="0.9", lw=0.6)
    ax.legend(loc="upper right", fontsize=8)
    return fig


# ---------------------------------------------------------------------------------------------
# the registry

#: The figures of this module, in the paper's order: name -> draw() -> Figure.
FIGURES: dict[str, Callable[[], Figure]] = {
    "fig7b": draw_7b,
    "fig8c": draw_8c,
    "fig10": draw_10,
    "fig11": draw_11,
}

#: The parameter-sweep figures: registry name -> function name in :mod:`esba.figures.design`.
DESIGN_FIGURES: dict[str, str] = {"fig13a": "draw_13a", "fig13b": "draw_13b", "fig14": "draw_14"}
_DESIGN_MODULE = "esba.figures.design"


def _design_figure(function: str) -> Callable[[], Figure]:
    def draw() -> Figure:
        return getattr(importlib.import_module(_DESIGN_MODULE), function)()

    draw.__name__ = function
    draw.__doc__ = f"{_DESIGN_MODULE}.{function} (imported when drawn)."
    return draw


def registry() -> dict[str, Callable[[], Figure]]:
    """Every figure by name, in the paper's order: ``name -> draw() -> Figure``.

    The design figures are listed only when :mod:`esba.figures.design` is installed; the module is
    imported when one of them is drawn, not here.
    """
    out = dict(FIGURES)
    if importlib.util.find_spec(_DESIGN_MODULE) is not None:
        out.update({name: _design_figure(fn) for name, fn in DESIGN_FIGURES.items()})
    return out


def check_names(names: Sequence[str] | None) -> list[str] | None:
    """``names`` without repeats when every one is registered (None: all), else :class:`FigureError`."""
    if names is None:
        return None
    figures = registry()
    for name in names:
        if name not in figures:
            raise FigureError(f"unknown figure {name!r}: allowed are {', '.join(figures)}")
    return list(dict.fromkeys(names))


def write_all(out_dir: str | Path | None = None, names: Sequence[str] | None = None) -> dict[str, Path]:
    """Write figures into ``out_dir`` (created if its parent exists).

    Parameters
    ----------
    out_dir : str or Path, optional
        Folder for the PNG files (default :func:`esba.infra.outputs.figures_dir`: ``docs/figures/`` in a
        checkout, else ``./figures/``).
    names : sequence of str, optional
        Which figures (default: all of :func:`registry`), written in the order given.

    Returns
    -------
    dict
        name -> path written.

    Raises
    ------
    FigureError
        for a name that is not registered (checked before anything is drawn).
    EquilibriumError
        when a solve behind a figure fails or is not stable.
    """
    figures = registry()
    chosen = check_names(names) or list(figures)
    out = check_folder(figures_dir(create=True) if out_dir is None else out_dir, "out_dir")
    return {name: save_figure(figures[name](), Path(out) / f"{name}.png") for name in chosen}

"""The figure of every equilibrium of a scene (:func:`esba.statics.equilibria.equilibria`).

Each equilibrium's centre-line in the paper's frame (base at the top, x down): stable states
solid, unstable ones dashed, each labelled with its total bend, energy and Morse index.

Examples
--------
>>> import tempfile, pathlib
>>> from esba.model.scene import Scene, Payload
>>> from esba.statics.equilibria import EquilibriaOptions, equilibria
>>> res = equilibria(Scene(pressure=0.17, payloads=(Payload(2.0, 90.0),)), EquilibriaOptions(connect=False))
>>> out = pathlib.Path(tempfile.mkdtemp()) / "equilibria.png"
>>> save_figure(equilibria_figure(res), out).exists()
True
"""

from __future__ import annotations

from matplotlib.axes import Axes
from matplotlib.figure import Figure

from esba.statics.equilibria import Equilibria

from .scenes import new_figure, save_figure, set_title, setup_frame_axes

__all__ = ["equilibria_figure", "draw_equilibria", "save_figure"]


def equilibria_figure(res: Equilibria, title: str | None = None) -> Figure:
    """Every equilibrium of ``res``: stable solid, unstable dashed, labelled with its energy; the
    legend below the axes, where it hides no shape. A state that rises above the base (bent past
    180 degrees: the model has no contact with the mount) says so."""
    fig = new_figure(6.0, 6.2)
    ax = fig.add_subplot(1, 1, 1)
    draw_equilibria(ax, res)
    fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", fontsize=7.5, ncol=1)
    set_title(ax, title or f"every equilibrium at P = {res.pressure:.4g} MPa ({len(res.stable)} stable of {len(res.states)})\n{res.scene.describe()}", 9)
    return fig


def draw_equilibria(ax: Axes, res: Equilibria) -> None:
    """Every equilibrium of ``res`` into ``ax`` (the legend is the caller's: below the axes in :func:`equilibria_figure`)."""
    setup_frame_axes(ax, res.scene.actuator.r1)
    model = res.scene.model()
    length = res.scene.actuator.L
    for k, s in enumerate(res.states, start=1):
        cl = model.centreline(s.theta, length, samples=res.scene.segments * 20 + 1)
        style = {"ls": "-", "lw": 2.0} if s.stable else {"ls": "--", "lw": 1.4}
        what = "stable" if s.stable else f"unstable, Morse {s.morse_index}"
        above = "; rises above the base" if cl[:, 0].min() < -1e-9 * length else ""
        (line,) = ax.plot(cl[:, 1], cl[:, 0], label=f"#{k}: {s.total_angle_deg:.1f} deg, U = {s.energy:.2f} N mm ({what}{above})", **style)
        ax.annotate(f"#{k} U = {s.energy:.2f}", (s.tip[1], s.tip[0]), textcoords="offset points", xytext=(4, 4), fontsize=8, color=line.get_color())
        ax.plot([s.tip[1]], [s.tip[0]], "o", ms=4, color=line.get_color())

"""The figure of a 3-D path (``esba path --3d``): the in-plane bend and the sideways bend and twist
against the parameter, every branch stable solid and unstable dashed, folds (o) and branch points (s) marked.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from .scenes import new_figure

__all__ = ["path3d_figure"]


def _draw(ax, lam: np.ndarray, y: np.ndarray, stable: np.ndarray, color: str, label: str) -> None:
    if len(lam) == 0:
        return
    first = True
    start = 0
    for i in range(1, len(lam) + 1):
        if i == len(lam) or stable[i] != stable[start]:
            stop = min(i + 1, len(lam))
            ax.plot(lam[start:stop], y[start:stop], color=color, linestyle="-" if stable[start] else "--", label=label if first else None)
            first = False
            start = i


def path3d_figure(analysis, title: str | None = None) -> Figure:
    """Two panels: the in-plane bend (sum of theta) and the sideways bend (sum of psi, solid colour)
    with the twist (sum of tau, thin), degrees, against the parameter."""
    from esba.analysis.path3d import split_angles

    n = analysis.problem.segments
    fig = new_figure(10.0, 4.2)
    ax1, ax2 = fig.subplots(1, 2)
    p = analysis.problem
    for k, b in enumerate(analysis.branches):
        if not len(b):
            continue
        color = f"C{k % 10}"
        angles = np.array([split_angles(q, n) for q in b.theta])
        stable = b.stable
        _draw(ax1, b.lam, angles[:, 0], stable, color, b.label or "branch")
        _draw(ax2, b.lam, angles[:, 1], stable, color, f"{b.label or 'branch'}: sideways")
        ax2.plot(b.lam, angles[:, 2], color=color, linewidth=0.7, alpha=0.6)
        for sp in b.special:
            if sp.kind in ("fold", "branch point"):
                a = split_angles(sp.theta, n)
                marker = "o" if sp.kind == "fold" else "s"
                ax1.plot([sp.lam], [a[0]], marker, color="k", markerfacecolor="none")
                ax2.plot([sp.lam], [a[1]], marker, color="k", markerfacecolor="none")
    unit = p.unit.split(" ")[0]
    xlabel = f"{p.name}" + ("" if unit in ("1", "model") else f" ({unit})")
    ax1.set_xlabel(xlabel)
    ax2.set_xlabel(xlabel)
    ax1.set_ylabel("in-plane bend, sum of theta (deg)")
    ax2.set_ylabel("sideways bend, sum of psi (deg); twist, thin")
    ax1.grid(True, alpha=0.3)
    ax2.grid(True, alpha=0.3)
    ax2.legend(fontsize=7, loc="best")
    fig.suptitle(title or f"3-D path in {p.name}: stable solid, unstable dashed; o fold, s branch point", fontsize=9)
    return fig

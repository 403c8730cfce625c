"""What a matplotlib figure shows, read back from its artists (for tests: no PNG is read).

A figure test checks the drawn data against the computation behind it, the axis labels and the
number of lines; these helpers read them.
"""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from matplotlib.container import ErrorbarContainer
from matplotlib.figure import Figure
from matplotlib.lines import Line2D


def axes(fig: Figure) -> list[Axes]:
    """The figure's main axes (colour bars and insets left out), in the order they were made."""
    return [ax for ax in fig.axes if ax.get_label() != "<colorbar>" and ax.get_axes_locator() is None and not _is_inset(ax)]


def _is_inset(ax: Axes) -> bool:
    return any(ax in parent.child_axes for parent in ax.figure.axes if parent is not ax)


def lines(ax: Axes, drawn: bool = True) -> list[Line2D]:
    """The lines of ``ax``; with ``drawn``, only those holding data (legend proxies ``plot([], [])`` left out)."""
    return [ln for ln in ax.get_lines() if not drawn or len(ln.get_xdata()) > 0]


def labelled(ax: Axes, label: str) -> Line2D:
    """The one line of ``ax`` whose label is ``label``."""
    found = [ln for ln in ax.get_lines() if ln.get_label() == label]
    assert len(found) == 1, (label, [ln.get_label() for ln in ax.get_lines()])
    return found[0]


def starting(ax: Axes, prefix: str) -> list[Line2D]:
    """The lines of ``ax`` whose label starts with ``prefix``."""
    return [ln for ln in ax.get_lines() if str(ln.get_label()).startswith(prefix)]


def xy(line: Line2D) -> tuple[np.ndarray, np.ndarray]:
    """A line's data as float arrays."""
    return np.asarray(line.get_xdata(), dtype=float), np.asarray(line.get_ydata(), dtype=float)


def points(line: Line2D) -> list[list[float]]:
    """A line's data as a list of [x, y] points (plain floats, to compare with ``==``)."""
    return np.column_stack(xy(line)).tolist()


def data(line: Line2D) -> np.ndarray:
    """A line's data as an array of (x, y) rows."""
    return np.column_stack(xy(line))


def legend(ax: Axes) -> list[str]:
    """The texts of ``ax``'s legend."""
    leg = ax.get_legend()
    return [] if leg is None else [t.get_text() for t in leg.get_texts()]


def errorbars(ax: Axes) -> dict[str, np.ndarray]:
    """label -> the (x, y) points of each error-bar series on ``ax``."""
    out = {}
    for c in ax.containers:
        if isinstance(c, ErrorbarContainer):
            out[c.get_label()] = np.asarray(c.lines[0].get_xydata(), dtype=float)
    return out


def joined(lines_: list[Line2D]) -> tuple[np.ndarray, np.ndarray]:
    """The data of several line pieces (a branch drawn in runs of equal stability) in order,
    the point each run shares with the next taken once."""
    xs, ys = [], []
    for k, ln in enumerate(lines_):
        x, y = xy(ln)
        if k:
            x, y = x[1:], y[1:]
        xs.append(x)
        ys.append(y)
    return np.concatenate(xs), np.concatenate(ys)


def record_saved(monkeypatch) -> dict:
    """Record every figure saved from now on (``Figure.savefig`` still writes it): file -> Figure.

    A command's figure can then be checked for what it shows, not for the size of its PNG.
    """
    from pathlib import Path

    saved: dict = {}
    original = Figure.savefig

    def savefig(self, fname, *args, **kwargs):
        saved[Path(fname).resolve()] = self
        return original(self, fname, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return saved

"""The model's error against the measured value, with error bars (``esba fit --plot`` and ``docs/experiments.md``).

One panel per measured quantity (total angles in degrees, tip x and tip y in mm, each in its own
panel, stiffnesses in N/m): each series puts every measured value (x) against the prediction's error, predicted minus
measured (y), with the measurement's standard deviation as a horizontal bar and the prediction's
propagated uncertainty (95 %, from the fitted parameters' covariance) as a vertical one; the line
at 0 is a perfect model. (Predicted against measured put every series on the diagonal, where
their markers hid each other: the errors are a few percent of the values.)

Examples
--------
>>> import pathlib, tempfile
>>> from esba.calibration.fit import Prediction
>>> p = [Prediction("a", "total_angle", "deg", 90.0, 91.0, 0.5, True), Prediction("b", "tip_x", "mm", 120.0, 118.0, 1.0, True)]
>>> fig = measured_vs_predicted([Series("example", p, {("a", "total_angle"): 1.0})])
>>> out = pathlib.Path(tempfile.mkdtemp()) / "mvp.png"
>>> save_figure(fig, out).exists()
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure

from esba.calibration.fit import Prediction

from .scenes import new_figure, save_figure

__all__ = ["Series", "measured_vs_predicted", "parameters_text", "save_figure", "PANELS"]

#: The panels: (title, quantities, unit).
PANELS = (
    ("total angle", ("total_angle",), "deg"),
    ("tip x (down the unbent axis)", ("tip_x",), "mm"),
    ("tip y (horizontal)", ("tip_y",), "mm"),
    ("secant stiffness", ("stiffness",), "N/m"),
)


def parameters_text(names: Sequence[str], values: Sequence[float], units: Sequence[str], std_errors: Sequence[float] | None = None) -> str:
    """Parameter values with their units for a legend; with ``std_errors``, a parameter without a
    finite one is "not identifiable" (a value on its bound means nothing).

    >>> parameters_text(("E", "rho"), (0.5356, 11.46), ("MPa", "deg"))
    'E = 0.5356 MPa, rho = 11.46 deg'
    >>> parameters_text(("E", "rho"), (0.5356, 3e-5), ("MPa", "deg"), (0.003, float("nan")))
    'E = 0.5356 MPa, rho not identifiable'
    """
    ses = [0.0] * len(names) if std_errors is None else std_errors
    return ", ".join(f"{n} = {v:.4g} {u}" if math.isfinite(float(se)) else f"{n} not identifiable" for n, v, u, se in zip(names, values, units, ses))


@dataclass(frozen=True)
class Series:
    """One set of predictions to draw.

    Attributes
    ----------
    label : str
    predictions : sequence of Prediction
    measured_sd : mapping
        (row, quantity) -> the measurement's standard deviation (horizontal bar; none when missing).
    marker, color : str
    face : str
        The markers' fill: ``"none"`` (hollow) or a colour.
    level_z : float
        Half-width of the vertical bar in prediction standard deviations (1.96: 95 %).
    """

    label: str
    predictions: Sequence[Prediction]
    measured_sd: Mapping[tuple[str, str], float] = field(default_factory=dict)
    marker: str = "o"
    color: str = "C0"
    level_z: float = 1.96
    face: str = "none"


def measured_vs_predicted(series: Sequence[Series], title: str = "") -> Figure:
    """The figure: a panel per kind of measured value, a marker per measured value at (measured,
    predicted - measured)."""
    used = [p for p in PANELS if any(pr.quantity in p[1] for s in series for pr in s.predictions)]
    cols = len(used) if len(used) <= 3 else 2  # four panels: two rows of two
    rows = math.ceil(max(1, len(used)) / max(1, cols))
    fig = new_figure(4.0 * max(1, cols), 3.6 * rows + 0.8)
    axes = fig.subplots(rows, max(1, cols), squeeze=False).ravel()
    for ax in axes[len(used):]:
        ax.set_axis_off()
    for ax, (name, quantities, unit) in zip(axes, used):
        lo, hi = math.inf, -math.inf
        for s in series:
            pts = [p for p in s.predictions if p.quantity in quantities and p.ok and math.isfinite(p.predicted)]
            if not pts:
                continue
            x = np.array([p.measured for p in pts])
            y = np.array([p.predicted - p.measured for p in pts])
            xerr = np.array([s.measured_sd.get((p.row, p.quantity), 0.0) for p in pts])
            yerr = np.array([s.level_z * p.sd if math.isfinite(p.sd) else 0.0 for p in pts])
            ax.errorbar(x, y, xerr=xerr, yerr=yerr, fmt=s.marker, color=s.color, ms=5, capsize=2.5, lw=1, label=s.label, mfc=s.face)
            lo, hi = min(lo, x.min() - xerr.max()), max(hi, x.max() + xerr.max())
        if math.isfinite(lo):
            pad = 0.06 * (hi - lo if hi > lo else 1.0)
            ax.set_xlim(lo - pad, hi + pad)
        ax.axhline(0.0, color="0.6", lw=0.8, zorder=0)
        ax.set_xlabel(f"measured {name} ({unit})")
        ax.set_ylabel(f"predicted - measured ({unit})")
        ax.grid(True, color="0.9", lw=0.6)
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:  # below the panels, where it hides no marker
        fig.legend(handles, labels, fontsize=7.5, loc="outside lower center", ncol=min(len(handles), 2))
    if title:
        fig.suptitle(title, fontsize=10)
    return fig

"""The load estimate's figures show the cases' numbers (read from the artists, not the PNG)."""

from __future__ import annotations

import numpy as np
import pytest

from esba.calibration.sensing_cases import BlindMap, Ellipse
from esba.figures.sensing import ARROW_MM_PER_N, blind_figure, ellipse_figure

from .drawn import axes, legend, lines


def test_blind_figure_colours_the_error_and_outlines_the_blind_cells():
    se = np.array([[2.0, 0.5, 0.01], [0.3, 0.05, np.nan]])
    fig = blind_figure(BlindMap((0.05, 0.1), (-90.0, 0.0, 90.0), 1.0, se, se * 10))
    (ax,) = axes(fig)
    mesh = ax.collections[0]
    shown = np.ma.filled(mesh.get_array(), np.nan).reshape(se.shape)
    assert np.allclose(shown, np.log10(se), equal_nan=True)
    assert "pressure (MPa)" == ax.get_ylabel() and ax.get_xlabel().startswith("direction Ω")
    assert BlindMap((0.05, 0.1), (-90.0, 0.0, 90.0), 1.0, se, se).blind.tolist() == [[True, False, False], [False, False, True]]


def test_ellipse_figure_draws_each_shape_and_its_force_ellipse_at_the_arrow_head():
    shape = np.column_stack([np.linspace(0, 100, 11), np.linspace(0, 40, 11)])
    cov = np.diag([0.04, 0.01])  # N^2: 0.2 N along x, 0.1 N along y
    items = [Ellipse(0.1, 0.0, shape[-1], shape, cov), Ellipse(0.2, 90.0, shape[-1], shape, cov * np.nan)]
    fig = ellipse_figure(items, 1.0)
    (ax,) = axes(fig)
    drawn = lines(ax)  # the clamp is a block (a patch), not a line
    assert len(ax.patches) == 1
    assert len(drawn) == 3  # two shapes, one ellipse (the second load's covariance is undetermined: no ellipse)
    assert np.allclose(drawn[0].get_xdata(), shape[:, 1]) and np.allclose(drawn[0].get_ydata(), shape[:, 0])
    ellipse = drawn[1]
    y, x = np.asarray(ellipse.get_xdata()), np.asarray(ellipse.get_ydata())
    head = shape[-1] + np.array([1.0, 0.0]) * ARROW_MM_PER_N  # 1 N pulling down (Omega = 0)
    assert np.allclose([np.mean(x[:-1]), np.mean(y[:-1])], head, atol=1e-9)
    k = np.sqrt(-2.0 * np.log(0.05))  # the 95 % ellipse of two dimensions
    assert np.ptp(x) / 2 == pytest.approx(k * 0.2 * ARROW_MM_PER_N, rel=1e-6)
    assert np.ptp(y) / 2 == pytest.approx(k * 0.1 * ARROW_MM_PER_N, rel=1e-3)
    assert legend(ax) == ["0.1 MPa", "0.2 MPa"]

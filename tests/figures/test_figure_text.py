"""What the figures say: titles whole (never cut) and inside the figure, labelled contours with
units, markers that do not hide each other, legends that hide no curve, one quantity a panel."""

from __future__ import annotations

import re
from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.transforms import Bbox

from esba.calibration.fit import Prediction
from esba.design.envelope import DesignPlane, Envelope
from esba.design.problem import DesignProblem
from esba.figures.fit import PANELS, Series, measured_vs_predicted, parameters_text
from esba.figures.maps import design_plane_figure, map_figure
from esba.figures.scenes import new_figure, set_title
from esba.model.scene import Payload, Scene
from tests.figures import drawn


def _words(text: str) -> str:
    return re.sub(r"\s+", " ", text).strip()


def _inside_figure(fig, artist) -> bool:
    """The artist's drawn box lies inside the figure's (a title cut at the edge does not)."""
    fig.canvas.draw()
    box, page = artist.get_window_extent(), fig.bbox
    return box.x0 >= page.x0 - 1 and box.x1 <= page.x1 + 1 and box.y0 >= page.y0 - 1 and box.y1 <= page.y1 + 1


def test_set_title_wraps_and_keeps_every_word():
    fig = new_figure(5.0, 3.0)
    ax = fig.add_subplot()
    text = "maximise the secant stiffness K subject to " + "a long list of constraints, " * 8 + "the end"
    set_title(ax, text, 9)
    assert _words(ax.get_title()) == _words(text) and "\n" in ax.get_title()
    assert _inside_figure(fig, ax.title)


def test_design_figure_title_is_whole():
    from esba.design.optimise import optimise_ipopt
    from esba.figures.design import draw_design

    problem = DesignProblem()
    fig = draw_design(optimise_ipopt(problem), points=12)
    ax = drawn.axes(fig)[0]
    assert _words(ax.get_title()) == _words(problem.describe())
    assert ax.get_title().rstrip().endswith(f"n={problem.segments}, {problem.variant}")
    assert _inside_figure(fig, ax.title)


def _plane() -> DesignPlane:
    """A small design plane (made up stiffness), with the map and PSO optima at one point."""
    r2, d = np.meshgrid(np.linspace(0.5, 3.5, 5), np.linspace(0.0, 4.0, 5))
    r2, d = r2.ravel(), d.ravel()
    keep = r2 + d < 7.5
    r2, d = r2[keep], d[keep]
    k = 50.0 - 5.0 * r2 - 2.0 * d
    states = tuple("clear" if v > 35 else "snaps" for v in k)
    best = SimpleNamespace(r2_mm=1.0, d_mm=0.0, method="map", unconstrained={"r2_mm": 1.5, "d_mm": 0.0})
    pso = SimpleNamespace(r2_mm=1.0, d_mm=0.0, method="pso", unconstrained={})
    return DesignPlane(DesignProblem(), Envelope(0.3, 2.5), r2, d, k, np.full(r2.size, 0.1), np.zeros(r2.size), states, (best, pso), 0.0)


def test_design_plane_has_a_title_labelled_contours_and_both_optima():
    plane = _plane()
    fig = design_plane_figure(plane)
    ax = drawn.axes(fig)[0]
    title = ax.get_title()
    assert title.startswith("the design plane") and plane.envelope.describe() in _words(title)
    assert _inside_figure(fig, ax.title)
    labels = [t.get_text() for t in ax.texts]
    assert labels and all(t.endswith(" N/m") for t in labels), labels  # the contour numbers say their unit
    assert "secant stiffness K (N/m)" in drawn.legend(ax)
    star, plus = drawn.starting(ax, "stiffest clear design (map)")[0], drawn.starting(ax, "stiffest clear design (pso)")[0]
    assert drawn.points(star) == drawn.points(plus)  # the same design ...
    # ... and both visible: the star open (its inside shows the plus), larger, on top
    assert star.get_markerfacecolor() == "none" and star.get_markersize() > 1.5 * plus.get_markersize()
    assert star.get_zorder() > plus.get_zorder()


def test_map_figure_has_a_title_and_its_scene_line():
    from esba.analysis.folds import Plane
    from esba.analysis.maps import stability_map

    scene = Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),))
    smap = stability_map(Plane.from_scene(scene, "pressure", "payload"), (0.1, 0.25), (1.0, 3.0), resolution=21, history_lines=0)
    fig = map_figure(smap)
    ax = drawn.axes(fig)[0]
    title = _words(ax.get_title())
    assert title.startswith("stable states over pressure and payload magnitude")
    assert scene.describe() in title
    assert _inside_figure(fig, ax.title)
    named = map_figure(smap, "Fig. X")
    assert _words(drawn.axes(named)[0].get_title()).startswith("Fig. X " + scene.describe())


def test_equilibria_legend_hides_no_curve_and_says_which_state_rises_above_the_base():
    from esba.figures.equilibria import equilibria_figure
    from esba.statics.equilibria import EquilibriaOptions, equilibria

    res = equilibria(Scene(pressure=0.17, payloads=(Payload(2.0, 90.0),)), EquilibriaOptions(connect=False))
    fig = equilibria_figure(res)
    ax = drawn.axes(fig)[0]
    assert ax.get_legend() is None and len(fig.legends) == 1
    fig.canvas.draw()
    legend_box = fig.legends[0].get_window_extent()
    assert not legend_box.overlaps(ax.get_window_extent())  # outside the axes: over no curve
    assert _inside_figure(fig, fig.legends[0]) and _inside_figure(fig, ax.title)
    texts = [t.get_text() for t in fig.legends[0].get_texts()]
    assert len(texts) == len(res.states)
    for text, state in zip(texts, res.states):
        curve = drawn.labelled(ax, text)
        _, x = drawn.xy(curve)  # drawn as (y, x): x down
        assert ("rises above the base" in text) == bool(x.min() < 0)
        assert state.total_angle_deg < 180 or "rises above the base" in text
    assert any("rises above the base" in t for t in texts)  # the 213 degree state
    # the clamp is a block at the base as wide as the actuator, not a line across the figure
    (clamp,) = ax.patches
    box = Bbox(clamp.get_bbox().get_points())
    assert box.x0 == pytest.approx(-8.0) and box.x1 == pytest.approx(8.0)


def test_fit_figure_one_quantity_a_panel_and_units_in_the_legend():
    preds = [Prediction("a", "total_angle", "deg", 90.0, 91.0, 0.5, True), Prediction("b", "tip_x", "mm", 120.0, 118.0, 1.0, True),
             Prediction("b", "tip_y", "mm", 50.0, 51.0, 1.0, True)]
    label = "fitted: " + parameters_text(("E", "rho"), (0.5356, 11.46), ("MPa", "deg"))
    fig = measured_vs_predicted([Series(label, preds)])
    axes = [ax for ax in drawn.axes(fig) if ax.axison]
    assert [ax.get_xlabel() for ax in axes] == [f"measured {name} ({unit})" for name, q, unit in PANELS if q[0] in ("total_angle", "tip_x", "tip_y")]
    tip_x, tip_y = axes[1], axes[2]
    assert drawn.errorbars(tip_x)[label].tolist() == [[120.0, -2.0]] and drawn.errorbars(tip_y)[label].tolist() == [[50.0, 1.0]]
    assert [t.get_text() for t in fig.legends[0].get_texts()] == ["fitted: E = 0.5356 MPa, rho = 11.46 deg"]


def test_fit_cli_legend_has_units(tmp_path, monkeypatch, capsys):
    from pathlib import Path

    from esba.cli import EXIT_OK, main

    saved = drawn.record_saved(monkeypatch)
    csv = Path(__file__).resolve().parents[2] / "examples" / "measurements" / "paper_exp.csv"
    assert main(["fit", str(csv), "--plot", str(tmp_path / "fit.png")]) == EXIT_OK
    (fig,) = saved.values()
    texts = [t.get_text() for t in fig.legends[0].get_texts()]
    assert texts[0] == "start: E = 0.54 MPa, rho = 10 deg"
    assert texts[1].startswith("fitted: E = ") and " MPa, rho = " in texts[1] and "deg" in texts[1]
    xlabels = [ax.get_xlabel() for ax in drawn.axes(fig) if ax.axison]
    assert "measured tip x (down the unbent axis) (mm)" in xlabels and "measured tip y (horizontal) (mm)" in xlabels


def test_the_payload_arrow_and_its_label_lie_inside_the_axes():
    """An annotation does not scale the axes: the arrow's tail (where its label is) is kept inside."""
    from matplotlib.text import Annotation

    from esba.figures.scenes import solve_figure
    from esba.statics.equilibrium import solve

    result = solve(Scene(pressure=0.2, payloads=(Payload(0.5, 90.0),)))
    ax = drawn.axes(solve_figure(result))[0]
    (label,) = [a for a in ax.texts if isinstance(a, Annotation) and a.get_text() == "0.5 N"]
    y, x = label.xy
    (y0, y1), (x0, x1) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
    assert y0 <= y <= y1 and x0 <= x <= x1

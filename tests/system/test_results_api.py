"""The Python API in a notebook: every major result has a short repr, ``summary()`` (the text the
command line prints for it), ``plot(ax=None)`` returning the axes, and a rich display in Jupyter;
the façade holds what a notebook needs; a covariance ellipse has named fields."""

from __future__ import annotations

import html
import re
from pathlib import Path

import numpy as np
import pytest

import esba
from esba.cli import main
from esba.figures.scenes import new_figure
from esba.infra.report import MAX_REPR, Report
from esba.model.scene import MAIN_JOB, Payload, Scene

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

#: Times in a text (they differ from run to run).
_TIME = re.compile(r"\d+(\.\d+)? s\b")


def _masked(text: str) -> str:
    return _TIME.sub("T s", text).strip()


@pytest.fixture(scope="module")
def results() -> dict[str, Report]:
    """One of each major result, small and quick."""
    from esba.analysis.folds import Plane
    from esba.analysis.maps import stability_map
    from esba.analysis.path_analysis import analyse
    from esba.analysis.sensitivity import sensitivities
    from esba.analysis.stiffness import secant_stiffness
    from esba.calibration.sigmas import parse_sigma
    from esba.calibration.uncertainty import propagate, resolve_sigmas
    from esba.design.optimise import DesignProblem, optimise_ipopt
    from esba.calibration.fit import fit
    from esba.calibration.measurements import load_measurements
    from esba.calibration.sensing import Measured, Pose, estimate_load
    from esba.paths.continuation import PathProblem, trace
    from esba.statics.batch import BatchOptions
    from esba.statics.equilibria import EquilibriaOptions, equilibria
    from esba.statics.equilibrium import solve
    from esba.studies.sweep import sweep

    loaded = Scene(pressure=0.17, payloads=(Payload(2.0, 90.0),))
    start = solve(Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),)))
    unloaded = Scene(pressure=0.15, payloads=(Payload(1.0, 60.0),))
    theta = solve(unloaded).theta_deg
    return {
        "Equilibrium": solve(MAIN_JOB),
        "Equilibria": equilibria(loaded, EquilibriaOptions()),
        "Branch": trace(PathProblem.from_scene(start.scene, "pressure"), start.theta, 0.0, to=0.3),
        "PathAnalysis": analyse(Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),)), "pressure", 0.3),
        "StabilityMap": stability_map(Plane.from_scene(Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),)), "pressure", "payload"),
                                      (0.1, 0.25), (1.0, 3.0), resolution=21, history_lines=0),
        "LoadEstimate": estimate_load(Pose(0.15, (Measured("theta", tuple(theta), 0.05),)), ("force", "angle"),
                                      Scene(pressure=0.15, payloads=(Payload(0.5, 90.0),))),
        "SweepResult": sweep(Scene(pressure=0.1), E=[0.5, 0.6], options=BatchOptions(compile="never")),
        "FitResult": fit(load_measurements(EXAMPLES / "measurements" / "paper_exp.csv"), ["E", "rho"]),
        "SecantStiffness": secant_stiffness(MAIN_JOB.replace(payloads=()), (0.5, 1.0)),
        "DesignResult": optimise_ipopt(DesignProblem()),
        "Sensitivities": sensitivities(solve(MAIN_JOB)),
        "Propagation": propagate(solve(MAIN_JOB), resolve_sigmas(MAIN_JOB, [parse_sigma("E=10%"), parse_sigma("d=±0.1")])),
    }


NAMES = ("Equilibrium", "Equilibria", "Branch", "PathAnalysis", "StabilityMap", "LoadEstimate", "SweepResult", "FitResult", "SecantStiffness",
         "DesignResult", "Sensitivities", "Propagation")


@pytest.mark.parametrize("name", NAMES)
def test_short_repr(results, name):
    r = results[name]
    text = repr(r)
    assert type(r).__name__ == name and isinstance(r, Report)
    assert text.startswith(f"<{name}: ") and text.endswith(">") and "\n" not in text and len(text) <= MAX_REPR, text


@pytest.mark.parametrize("name", NAMES)
def test_summary_and_notebook_display(results, name):
    r = results[name]
    summary = r.summary()
    assert isinstance(summary, str) and summary.count("\n") >= 1 and "nan" not in summary.lower().split()
    shown = r._repr_html_()
    assert shown.startswith(f"<p><b>{name}</b>: ") and f"<pre>{html.escape(summary)}</pre>" in shown


@pytest.mark.parametrize("name", NAMES)
def test_plot_into_given_axes_and_a_new_figure(results, name):
    import matplotlib.pyplot as plt

    r = results[name]
    ax = new_figure().add_subplot()
    assert r.plot(ax) is ax
    assert ax.has_data() and (ax.get_title() or ax.get_xlabel())
    fresh = r.plot()
    try:
        assert fresh is not ax and fresh.has_data() and fresh.figure in [plt.figure(n) for n in plt.get_fignums()]
    finally:
        plt.close("all")


def test_summary_is_what_the_command_prints(results, capsys):
    """The same formatter renders both: a solve, every equilibrium, a fit, the stiffness."""
    cases = [
        (["solve", "--no-plot"], results["Equilibrium"]),
        (["equilibria", "--pressure", "0.17", "--payload", "2", "--no-plot"], results["Equilibria"]),
        (["fit", str(EXAMPLES / "measurements" / "paper_exp.csv")], results["FitResult"]),
        (["stiffness", "--payload", "0.5", "--payload", "1"], results["SecantStiffness"]),
        (["design"], results["DesignResult"]),
    ]
    for argv, result in cases:
        main(argv)
        printed = capsys.readouterr().out
        assert _masked(printed) == _masked(result.summary()), argv


def test_equilibrium_repr_is_short_and_says_the_answer(results):
    r = results["Equilibrium"]
    assert repr(r) == (f"<Equilibrium: stable, P = {r.pressure:.5g} MPa, total angle {r.total_angle_deg:.3f} deg, "
                       f"tip ({r.tip_mm[0]:.2f}, {r.tip_mm[1]:.2f}) mm, n = 3>")
    assert len(repr(r)) < 120


def test_facade_has_what_a_notebook_needs():
    from esba.calibration.sensing import Measured, Pose
    from esba.calibration.sigmas import parse_sigma

    assert esba.Pose is Pose and esba.Measured is Measured and esba.parse_sigma is parse_sigma
    assert {"Pose", "Measured", "parse_sigma", "ellipse", "Ellipse", "stability_map", "Plane"} <= set(esba.__all__)
    assert esba.parse_sigma("E=10%").name == "E"


def test_ellipse_has_named_fields_and_is_still_a_pair():
    e = esba.ellipse(np.diag([4.0, 1.0]))
    assert isinstance(e, tuple) and isinstance(e, esba.Ellipse) and len(e) == 2
    axes, angle = e
    assert axes is e.semi_axes and angle == e.angle == e[1] == 0.0 and e.angle_deg == 0.0
    assert e.semi_axes.tolist() == pytest.approx([4.8955, 2.4477], abs=1e-4)
    assert "semi_axes" in repr(e) and len(repr(e)) < 80

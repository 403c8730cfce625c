"""The paper's EXP and FEM values against esba (esba.calibration.experiments) and docs/experiments.md."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from esba.calibration.experiments import COLUMNS, PAPER, UNLOADED, compare_with_paper, paper_data
from esba.cli import EXIT_FAILED, EXIT_OK, main
from esba.pages.experiments import DOC_COMMAND, PAGE, render
from tests.figures import drawn

DOC_PATH = Path(__file__).resolve().parents[2] / "docs" / "experiments.md"


@pytest.fixture(scope="module")
def comparison():
    return PAGE.compute()  # the paper's comparison and the page's 3-D section (esba.calibration.cases3d)


def test_the_data_are_the_papers_tables():
    exp, fem = paper_data("EXP"), paper_data("FEM")
    assert [r.label for r in exp.rows] == [label for label, _, _ in PAPER]
    assert [r.label for r in fem.rows] == [label for label, _, v in PAPER if "FEM" in v]  # no prototype in FEM
    assert exp.rows[1].scene.pressure == 0.124 and fem.rows[1].scene.pressure == 0.121
    vertical = next(r for r in exp.rows if r.label == "2 N vertical")
    assert vertical.values == {"total_angle": 53.2, "tip_x": 119.2, "tip_y": 50.8}  # Table 3's theta_TOL, not its copied first row
    proto = exp.rows[-1]
    assert proto.scene.actuator.r2 == 1.5305 and proto.scene.actuator.d == 0.0 and proto.own == {"r2", "d"}
    # the assumed sd of a stiffness is the effect of 1 mm on the displacement: K^2 / (1000 F)
    k05 = next(r for r in exp.rows if r.label == "K at 0.5 N")
    assert k05.sds["stiffness"] == pytest.approx(39.3**2 / 500.0, abs=0.005)
    with pytest.raises(ValueError, match="allowed are EXP, FEM"):
        paper_data("ANA")


def test_the_model_at_the_papers_modulus(comparison):
    by = {c.name: {(p.row, p.quantity): p for p in c.nominal} for c in comparison.columns}
    # esba's Table 2 numbers (docs/validation.md) and the design page's prototype stiffness
    assert by["EXP"][("2 N horizontal", "total_angle")].predicted == pytest.approx(25.322, abs=1e-3)
    assert by["EXP"][("2 N horizontal", "tip_y")].predicted == pytest.approx(10.217, abs=1e-3)
    assert by["EXP"][("K at 2 N", "stiffness")].predicted == pytest.approx(26.411, abs=1e-3)
    assert by["EXP"][("free bend", "total_angle")].error == pytest.approx(179.351 - 176.8, abs=1e-3)
    assert comparison.model_pressure_90 == pytest.approx(0.1238739, abs=1e-7)
    assert all(p.ok for c in comparison.columns for p in c.nominal)


def test_the_fits(comparison):
    exp, fem = comparison.columns
    assert exp.fit_e.ok and exp.fit_both.ok and fem.fit_e.ok
    lo, hi = exp.fit_e.interval[0]
    assert lo < 0.54 < hi  # the paper's tensile-test modulus is consistent with its own experiments
    assert exp.fit_both.identifiable and 0.0 < exp.fit_both.value("rho") < 30.0
    # the FEM column wants rho < 0 (at 0 the model stops depending on it): reported, not hidden
    assert not fem.fit_both.identifiable and any("rho" in w for w in fem.fit_both.warnings)


def test_cross_validation_both_ways(comparison):
    for col in comparison.columns:
        unloaded, loaded = col.folds
        assert set(unloaded.train) == set(UNLOADED) and set(loaded.test) == set(UNLOADED)
        assert unloaded.fit.ok and loaded.fit.ok
        # E and rho cannot be told apart from unloaded bends: the exact trade-off
        assert not unloaded.both.identifiable and unloaded.both.ratio < 1e-12
        assert unloaded.both.direction["E"] / unloaded.both.direction["rho"] == pytest.approx(comparison.tradeoff, rel=1e-6)
        for fold in col.folds:
            assert all(p.ok and math.isfinite(p.sd) and p.sd > 0 for p in fold.predictions)
            for p in fold.predictions:
                assert fold.band(p) > fold.z * p.sd  # the prediction band adds the training scatter
    # the FEM column's loaded rows cannot see rho at all (every one is at the 90 degree pressure)
    assert comparison.columns[1].folds[1].both.ratio < 1e-20


def test_modulus_tolerance_first_order_agrees_with_monte_carlo(comparison):
    assert comparison.modulus_agreement.agree, comparison.modulus_agreement.verdict
    assert comparison.modulus_monte_carlo.counts["ok"] == 10_000


def test_committed_page_is_fresh_and_names_its_command(comparison):
    text = DOC_PATH.read_text(encoding="utf-8")
    assert DOC_COMMAND in text and "figures/experiments.png" in text
    assert PAGE.check(DOC_PATH, data=comparison).ok, f"docs/experiments.md is stale: run `{DOC_COMMAND}`"
    assert render(comparison) == text


def test_cli_writes_and_checks_the_page(tmp_path, capsys, comparison, monkeypatch):
    import esba.pages.experiments as ep

    monkeypatch.setattr(ep, "compare_with_paper", lambda *a, **k: comparison)  # the comparison is deterministic; run it once
    saved = drawn.record_saved(monkeypatch)
    page = tmp_path / "docs" / "experiments.md"
    page.parent.mkdir()  # an output's folder must exist (esba.infra.outputs): esba creates only figures/ beside the page
    assert main(["experiments", "--write-doc", str(page), "--json"]) == EXIT_OK
    d = json.loads(capsys.readouterr().out, parse_constant=lambda c: pytest.fail(f"{c} in JSON"))
    assert [c["name"] for c in d["columns"]] == list(COLUMNS) and d["page"] == str(page)
    figure = tmp_path / "docs" / "figures" / "experiments.png"
    assert page.exists() and figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the figure: per panel, each column's measured values against the model at 0.54 MPa and fitted
    axes = saved[figure.resolve()].axes
    assert [ax.get_xlabel() for ax in axes] == ["measured total angle (deg)", "measured tip x (down the unbent axis) (mm)", "measured tip y (horizontal) (mm)",
                                                 "measured secant stiffness (N/m)"]
    for ax, quantities in zip(axes, (("total_angle",), ("tip_x",), ("tip_y",), ("stiffness",))):
        series = drawn.errorbars(ax)
        assert len(series) == 4
        for col in comparison.columns:
            for label, preds in ((f"{col.name}, E = 0.54 MPa", col.nominal), (next(k for k in series if k.startswith(f"{col.name}, fitted")), col.fitted)):
                shown = [[p.measured, p.predicted - p.measured] for p in preds if p.quantity in quantities and p.ok and math.isfinite(p.predicted)]
                np.testing.assert_allclose(series[label], shown)
    # the FEM column cannot determine rho: the legend says so instead of a value on its bound
    (box,) = saved[figure.resolve()].legends  # below the panels
    legend = [t.get_text() for t in box.get_texts()]
    fem = next(c for c in comparison.columns if c.name == "FEM")
    if not np.all(np.isfinite(fem.fit_both.std_error)):
        assert any(t.startswith("FEM, fitted (") and "rho not identifiable" in t for t in legend), legend
    assert not any("rho = 0.0°" in t for t in legend)
    assert main(["experiments", "--check", str(page)]) == EXIT_OK
    capsys.readouterr()
    monkeypatch.chdir(tmp_path)  # outside a checkout the page is ./docs/experiments.md, where the README's --write-doc docs/experiments.md wrote it
    assert main(["experiments", "--check"]) == EXIT_OK
    assert capsys.readouterr().out.strip() == f"{Path.cwd() / 'docs' / 'experiments.md'} is up to date"
    page.write_text("stale\n", encoding="utf-8")
    assert main(["experiments", "--check", str(page)]) == EXIT_FAILED
    assert "is stale" in capsys.readouterr().err


def test_cli_refuses_a_bad_page_path(capsys, tmp_path):
    assert main(["experiments", "--write-doc", str(tmp_path / "page.txt")]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and "expected a file ending in .md" in err

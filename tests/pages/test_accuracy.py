"""docs/accuracy-vs-time.md (esba.pages.accuracy) from a smoke run of its benchmarks."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from esba.cli import main
from esba.pages.accuracy import CASE_LABELS, PAGE, AccuracySettings
from tests.figures import drawn
from tests.tolerances import BATCH_THETA_ATOL


@pytest.mark.slow
@pytest.mark.ci
def test_bench_accuracy_quick_writes_the_page(tmp_path, capsys, monkeypatch):
    """A smoke run of `esba bench accuracy --quick`: the page and figure are written, every
    section is there, the figure shows the errors, the batch answers agree with IPOPT, and a second
    run checks the page, times aside (the timings themselves are not tested)."""
    saved = drawn.record_saved(monkeypatch)
    doc, fig = tmp_path / "acc.md", tmp_path / "acc.png"
    assert main(["bench", "accuracy", "--quick", "--out", str(doc), "--figure", str(fig), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    text = doc.read_text()
    for heading in ("## The reference", "## IPOPT tolerance", "## The cost of each effect", "## The first script", "## Many solves"):
        assert heading in text
    assert "esba bench accuracy --quick" in text and "](acc.png)" in text
    # written outside a checkout, the page links no sweep figure that is not beside it, and names the command that draws it
    assert "](figures/sweep-" not in text
    assert f"(figures/sweep-fig12.png is not beside this page: `esba sweep --fig12 {tmp_path.as_posix()}/figures/sweep-fig12.png` draws it.)" in text
    assert data["batch"]["counts"]["not_ok"] == 0
    assert data["batch"]["max_theta_difference_vs_ipopt"] < BATCH_THETA_ATOL
    assert all(ref["order"] == pytest.approx(2.0, abs=0.1) for ref in data["reference"].values())
    # the figure: (a) the true error and the n-vs-(n+1) gap against n, per case; (b) the error against the solve time
    ax_n, ax_t = drawn.axes(saved[fig.resolve()])
    assert ax_n.get_xlabel() == "segments n" and ax_n.get_ylabel() == "tip position error (mm)"
    for case in data["reference"]:
        rows = [r for r in data["rows"] if r["case"] == case]
        true = drawn.labelled(ax_n, f"{CASE_LABELS[case]}: true error")
        np.testing.assert_array_equal(drawn.xy(true)[0], [r["n"] for r in rows])
        np.testing.assert_array_equal(drawn.xy(true)[1], [r["error_mm"] for r in rows])
        np.testing.assert_array_equal(drawn.xy(drawn.labelled(ax_t, CASE_LABELS[case]))[0], [1e3 * r["solve_s"] for r in rows])
    assert len(drawn.lines(ax_n)) == 2 * len(data["reference"]) + 2  # two curves a case, the 1 mm and 0.1 mm lines
    # the time and n axes read as plain numbers (not 2×10⁰, 3×10⁰, ...)
    saved[fig.resolve()].canvas.draw()
    for ax in (ax_n, ax_t):
        labels = [t.get_text() for t in ax.xaxis.get_ticklabels(which="both") if t.get_text()]
        assert labels and all(float(text) > 0 for text in labels), labels
    # the page is what the benchmarks give, times aside
    settings = dataclasses.replace(AccuracySettings(quick=True, repeat=1), command="esba bench accuracy --quick", figure=fig)
    check = PAGE.check(doc, settings)
    assert check.ok, check.describe()

"""The page ``docs/experiments.md`` and its figure, rendered from :func:`esba.calibration.experiments.compare_with_paper`.

Presentation only: every number comes from the comparison; nothing here computes a model.
``esba experiments --write-doc docs/experiments.md`` writes the page and
``docs/figures/experiments.png``; the page holds no times, so ``esba experiments --check [FILE]`` and
``esba docs --check experiments`` can say whether the committed one is stale.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import numpy as np

from esba.calibration.experiments import (
    MC_SAMPLES,
    MC_SEED,
    MODULUS_TOLERANCE,
    SD_ANGLE,
    SD_DISPLACEMENT,
    SD_TIP,
    Column,
    Fold,
    PaperComparison,
    compare_with_paper,
)
from esba.calibration.fit import FitResult, Prediction
from esba.figures.fit import Series, measured_vs_predicted
from esba.infra.roundoff import ROUNDOFF_RATIO, floored

from .page import TIMES, Page, Progress, Rendered, Times
from .registry import ENTRIES

__all__ = ["PAGE", "ExperimentsPage", "DOC_COMMAND", "FIGURE_NAME", "render", "figure"]

#: The command that writes it.
DOC_COMMAND = ENTRIES["experiments"].command
#: The figure, in ``figures/`` beside the page.
FIGURE_NAME = "experiments.png"

_Q = {"total_angle": ("total angle", "deg"), "tip_x": ("tip x", "mm"), "tip_y": ("tip y", "mm"), "stiffness": ("secant stiffness", "N/m")}


def _f(v: float, digits: int = 3) -> str:
    return "–" if v is None or not math.isfinite(v) else f"{v:.{digits}f}"


def _g(v: float, digits: int = 4) -> str:
    return "–" if v is None or not math.isfinite(v) else f"{v:.{digits}g}"


def _kind(q: str) -> str:
    return "tip" if q in ("tip_x", "tip_y") else q


def _rms(preds: Sequence[Prediction], kind: str) -> tuple[float, float, int]:
    e = np.array([p.error for p in preds if _kind(p.quantity) == kind and p.ok])
    return (float(np.sqrt(np.mean(e**2))), float(np.max(np.abs(e))), len(e)) if len(e) else (math.nan, math.nan, 0)


def _estimate(r: FitResult, name: str) -> str:
    j = r.free.index(name)
    se, (lo, hi) = r.std_error[j], r.interval[j]
    unit = r.units[j]
    if not math.isfinite(se):
        return f"{r.estimate[j]:.4g} {unit} (not determined)"
    return f"{r.estimate[j]:.4f} ± {se:.4f} {unit}, 95 % [{lo:.4f}, {hi:.4f}]"


def _comparison(comparison: PaperComparison) -> list[str]:
    exp, fem = comparison.columns
    by = {c.name: {(p.row, p.quantity): p for p in c.nominal} for c in comparison.columns}
    lines = [
        "| measurement | quantity | EXP | FEM | esba, E = 0.54 MPa | esba − EXP | esba − FEM |",
        "|---|---|---:|---:|---:|---:|---:|",
        f"| pressure for a 90° unloaded bend | pressure (MPa) | {exp.pressure_90:.3f} | {fem.pressure_90:.3f} | {comparison.model_pressure_90:.5f} | "
        f"{comparison.model_pressure_90 - exp.pressure_90:+.5f} | {comparison.model_pressure_90 - fem.pressure_90:+.5f} |",
    ]
    for row in exp.data.rows:
        for q in ("total_angle", "tip_x", "tip_y", "stiffness"):
            if q not in row.values:
                continue
            pe = by["EXP"].get((row.label, q))
            pf = by["FEM"].get((row.label, q))
            name, unit = _Q[q]
            if row.label == "90 deg pressure":  # each column at its own pressure: two model values
                lines.append(f"| bent 90° at {exp.pressure_90:g} MPa (EXP) | {name} ({unit}) | {pe.measured:g} | – | {_f(pe.predicted, 2)} | "
                             f"{pe.error:+.2f} | – |")
                lines.append(f"| bent 90° at {fem.pressure_90:g} MPa (FEM) | {name} ({unit}) | – | {pf.measured:g} | {_f(pf.predicted, 2)} | "
                             f"– | {pf.error:+.2f} |")
                continue
            lines.append(
                f"| {row.label} | {name} ({unit}) | {pe.measured:g} | {'–' if pf is None else f'{pf.measured:g}'} | "
                f"{_f(pe.predicted, 2)} | {pe.error:+.2f} | {'–' if pf is None else f'{pf.error:+.2f}'} |"
            )
    return lines


def _fold_table(fold: Fold) -> list[str]:
    lines = [
        "| held out | quantity | measured | predicted | error | sd from E | inside ±1.96 sd | 95 % prediction band | inside |",
        "|---|---|---:|---:|---:|---:|---|---:|---|",
    ]
    for p in fold.predictions:
        name, unit = _Q[p.quantity]
        lines.append(
            f"| {p.row} | {name} ({unit}) | {p.measured:g} | {_f(p.predicted, 2)} | {p.error:+.2f} | {_f(p.sd, 3)} | "
            f"{'yes' if fold.inside_parameter_band(p) else 'no'} | ±{_f(fold.band(p), 2)} | {'yes' if fold.inside_prediction_band(p) else 'no'} |"
        )
    return lines


def _fold_block(col: Column, fold: Fold, title: str) -> list[str]:
    f = fold.fit
    n_in = sum(fold.inside_parameter_band(p) for p in fold.predictions)
    n_band = sum(fold.inside_prediction_band(p) for p in fold.predictions)
    m = len(fold.predictions)
    both = fold.both
    lines = [
        f"### {col.name}: {title}",
        "",
        f"Trained on {', '.join(fold.train)} ({len(f.residuals)} values): **E = {_estimate(f, 'E')}** "
        f"(rho held at 10°; residual variance s² = {_g(f.residual_variance, 3)} on {f.dof} degree{'s' if f.dof != 1 else ''} of freedom).",
        "",
        "E and rho together from these rows (at the paper's values): " + (
            f"identifiable (Fisher ratio {floored(both.ratio, '.2g', ROUNDOFF_RATIO)})." if both.identifiable
            else "**not identifiable**: " + "; ".join(w.removeprefix("not identifiable: ") for w in both.warnings) + "."
        ),
        "",
        *_fold_table(fold),
        "",
        f"{n_in} of {m} held-out errors fall inside ±1.96 sd of the uncertainty propagated from the fitted E alone; "
        f"{n_band} of {m} inside the 95 % prediction band that adds the training fit's own scatter "
        f"(Student's t on {f.dof} degree{'s' if f.dof != 1 else ''} of freedom).",
        "",
    ]
    return lines


def render(comparison: PaperComparison, figure_path: str = f"figures/{FIGURE_NAME}") -> str:
    """The Markdown of the page."""
    exp, fem = comparison.columns
    L: list[str] = []
    L += [
        "# How far to trust the model: the paper's experiments and FEM against esba",
        "",
        f"<!-- Written by `{DOC_COMMAND}` (esba/calibration/experiments.py computes, esba/pages/experiments.py writes); do not edit by hand. -->",
        "<!-- `esba experiments --check` exits 1 when this page is stale. -->",
        "",
        f"Written by the command `{DOC_COMMAND}` (n = {exp.data.base.segments}, variant `{exp.data.base.variant}`), which also draws "
        f"`docs/{figure_path}`. Every number below comes from that run; the page holds no times.",
        "",
        "## The data",
        "",
        "The paper (Sections 4.4 and 5) reports for the Table 1 actuator (L = 135 mm, r1 = 8 mm, r2 = 3 mm, d = 4 mm, rho = 10°) "
        "experimental values (EXP) and finite-element values (FEM), and compares them with its model at E = 0.54 MPa from a tensile "
        "test. Here they are two measurement sets (`esba.calibration.experiments.paper_data`, the same rows as `examples/measurements/paper_exp.csv` and "
        "`examples/measurements/paper_fem.toml`); the FEM column is treated as a second actuator. Rows at \"the 90° pressure\" start, as the "
        "paper's tests do, from the pressure that bends each actuator (the model, or the prototype) unloaded to 90°; the 90° pressure "
        "measurement itself is the row \"the actuator bent 90° at 0.124 MPa (EXP) or 0.121 MPa (FEM)\". The 2 N horizontal row and the "
        "stiffness at 2 N come from the same test (K = 1000 F / Δy with the tip's y moving from the unloaded 90° state).",
        "",
        f"The paper states no measurement uncertainties. The sets assume {SD_ANGLE:g}° on an angle (a camera and AutoCAD), "
        f"{SD_TIP:g} mm on a tip coordinate (the trakSTAR probe reads to 0.1 mm; its placement on the tip is coarser) and, for a "
        f"stiffness K = 1000 F / δ, the effect of {SD_DISPLACEMENT:g} mm on the displacement δ: K² / (1000 F). Every fit scales its "
        "Fisher matrix by the residual variance s², so the intervals do not rest on these guesses, only on their ratios.",
        "",
        "## The model with E = 0.54 MPa against the paper's values",
        "",
        *_comparison(comparison),
        "",
    ]
    rows = []
    for col in comparison.columns:
        parts = []
        for kind, unit in (("total_angle", "deg"), ("tip", "mm"), ("stiffness", "N/m")):
            rms, worst, k = _rms(col.nominal, kind)
            parts.append(f"{kind.replace('_', ' ')}: RMS {_f(rms, 2)} {unit}, largest {_f(worst, 2)} {unit} ({k} values)")
        rows.append(f"- {col.name}: " + "; ".join(parts) + ".")
    L += ["Errors of esba's model (E = 0.54 MPa, rho = 10°) by kind:", "", *rows, ""]
    L += [
        "## E, and E with rho, fitted to all of each column",
        "",
        "Weighted least squares with exact derivatives (`esba fit`: one IPOPT problem over the parameters and every row's "
        "segment angles with dU/dθ = 0 as constraints; standard errors from the Gauss-Newton matrix of the implicit-function-theorem "
        "sensitivities, scaled by s²; intervals with Student's t). Every fitted state was checked to be a stable minimum, the one the "
        "load path reaches.",
        "",
        "| column | free | E | rho | corr(E, rho) | s² (dof) | fitted states | notes |",
        "|---|---|---|---|---:|---|---|---|",
    ]
    for col in comparison.columns:
        for r in (col.fit_e, col.fit_both):
            rho = _estimate(r, "rho") if "rho" in r.free else "10° (held)"
            corr = f"{r.correlation[0, 1]:+.3f}" if len(r.free) > 1 and math.isfinite(r.correlation[0, 1]) else "–"
            states = "stable, on the load path" if r.ok else f"**{r.status}**: {r.message}"
            notes = "; ".join(r.warnings) or "–"
            L.append(f"| {col.name} | {', '.join(r.free)} | {_estimate(r, 'E')} | {rho} | {corr} | {_g(r.residual_variance, 3)} ({r.dof}) | {states} | {notes} |")
    L += [
        "",
        f"The EXP column alone puts E at {exp.fit_e.value('E'):.4f} MPa with rho held at 10° (the paper's tensile test: 0.54 MPa, "
        f"{'inside' if exp.fit_e.interval[0][0] <= 0.54 <= exp.fit_e.interval[0][1] else 'outside'} the 95 % interval), and with rho free "
        f"at {exp.fit_both.value('E'):.4f} MPa and rho = {exp.fit_both.value('rho'):.2f}° (correlation {exp.fit_both.correlation[0, 1]:+.2f}: "
        "a softer rubber and a steeper fibre angle bend the actuator alike). The free bends fix the combination (r1 − 4 r2 tan² rho) / E, "
        "the payload rows at the 90° pressure fix E alone (rho drops out there, below). The FEM column's best fit with rho free "
        + ("drives rho to its bound of 0°, where the model stops depending on it: its free bend is larger than any rho ≥ 0 gives with "
           "the E its payload rows need." if any(w.startswith("rho ended on its bound") for w in fem.fit_both.warnings)
           else f"puts rho at {fem.fit_both.value('rho'):.2f}°."),
        "",
        f"![the model's error against each measured value, with error bars]({figure_path})",
        "",
        "The figure sets every measured value against the model's error there, predicted minus measured: hollow grey at E = 0.54 MPa, "
        "filled and coloured with E and rho fitted to the column (vertical bars: 95 % of the uncertainty propagated from the fit's "
        "covariance; horizontal bars: the assumed measurement sd; a parameter the column cannot determine is named so in the legend).",
        "",
        "## Cross-validation",
        "",
        "E is fitted on one group of rows and the other group is predicted, both ways: the unloaded rows (the free bend and the 90° "
        "pressure) against the payload cases and the stiffnesses. Each held-out error is set against the first-order uncertainty "
        "propagated from the fitted E (`esba.calibration.fit.predict`: the implicit-function-theorem Jacobian of each prediction times the "
        "variance of E), and against the 95 % prediction band that adds the training fit's own scatter (s² times the measurement's sd²).",
        "",
    ]
    for col in comparison.columns:
        L += _fold_block(col, col.folds[0], "fit on the unloaded rows, predict the loaded ones")
        L += _fold_block(col, col.folds[1], "fit on the loaded rows, predict the unloaded ones")
    inside = sum(f.inside_parameter_band(p) for c in comparison.columns for f in c.folds for p in f.predictions)
    band = sum(f.inside_prediction_band(p) for c in comparison.columns for f in c.folds for p in f.predictions)
    total = sum(len(f.predictions) for c in comparison.columns for f in c.folds)
    split = "; ".join(f"{c.name} {c.folds[0].fit.value('E'):.4f} MPa from the unloaded rows against {c.folds[1].fit.value('E'):.4f} MPa "
                      f"from the loaded ones" for c in comparison.columns)
    L += [
        f"Over both columns and both directions, {inside} of {total} held-out errors fall inside the uncertainty propagated from the "
        f"fitted E, and {band} of {total} inside the prediction bands. The two groups of rows want different moduli ({split}). "
        + ("The parameter's own uncertainty is far too small to explain the held-out errors: what limits the predictions is the model "
           "itself, not the knowledge of E, and a modulus fitted to one kind of test mispredicts the other by more than its interval "
           "says." if inside < total / 2 else
           "The held-out errors are mostly within the propagated uncertainty: one modulus serves both kinds of test."),
        "",
    ]
    fo, ag = comparison.modulus_first_order, comparison.modulus_agreement
    axes, angle = fo.ellipse()
    L += [
        "## What E known to ±20 % means",
        "",
        f"The main job (Table 2's scene: 90° unloaded, 2 N horizontal at the tip, n = {exp.data.base.segments}) with "
        f"`--sigma {MODULUS_TOLERANCE}` (uniform: sd = 0.2 × 0.54 / √3 = {fo.sigmas[0].sigma:.4f} MPa), to first order "
        f"(`esba.calibration.uncertainty.propagate`) and by Monte Carlo on the batch path ({MC_SAMPLES} samples, seed {MC_SEED}):",
        "",
        "| output | nominal | sd, first order | sd, Monte Carlo | ratio | Monte Carlo mean − nominal |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for r in ag.rows:
        L.append(
            f"| {r['output'].replace('_', ' ')} ({r['unit']}) | {r['nominal']:.3f} | {r['std_first_order']:.3f} | {r['std_monte_carlo']:.3f} | "
            f"{r['std_ratio']:.3f} | {r['mean_monte_carlo'] - r['nominal']:+.3f} |"
        )
    L += [
        "",
        f"Verdict: {ag.verdict}. With one uncertain parameter the tip's 95 % ellipse (first order) is a segment "
        f"{2 * axes[0]:.1f} mm long, {math.degrees(angle):.1f}° from x (along the tip's arc, nearly horizontal): a ±20 % modulus moves "
        f"the tip sideways by about ±{1.96 * fo.std_tip_mm[1]:.1f} mm and the total angle by ±{1.96 * fo.std_total_angle_deg:.1f}° "
        f"(95 %), against the model's largest errors with E = 0.54 MPa of {_rms(exp.nominal, 'tip')[1]:.1f} mm and "
        f"{_rms(exp.nominal, 'total_angle')[1]:.1f}° on the EXP column"
        + (": the modulus must be known far better than ±20 % before the model's own error is what is left."
           if 1.96 * fo.std_tip_mm[1] > _rms(exp.nominal, "tip")[1] else "."),
        "",
        "## What the paper's measurements can determine",
        "",
        "- **Unloaded bends at given pressures cannot separate E and rho.** Without payload the equilibrium is the uniform bend at which "
        "the rubber's moment (proportional to E) balances the pressure's net moment, P π r1² (r1 − 4 r2 tan² rho) in the paper's variant; "
        "E and rho enter only through (r1 − 4 r2 tan² rho) / E. The Fisher matrix of the unloaded rows is singular to round-off "
        f"(the first folds above) and its undetermined direction, dE/E = {exp.folds[0].both.direction.get('E', math.nan):+.4f} per "
        f"drho/rho = {exp.folds[0].both.direction.get('rho', math.nan):+.4f}, is that combination's: d ln(r1 − 4 r2 tan² rho) / d ln rho = "
        f"{comparison.tradeoff:+.4f} at rho = 10°. `esba fit` says so.",
        "- **At a target angle rho drops out altogether.** When the pressure is the one that bends the unloaded actuator to 90°, the "
        "pressure follows rho so that the net moment is the same: every loaded state at the 90° pressure is independent of rho "
        "(`esba solve --sensitivities` gives d/drho = 0 there). The FEM column's loaded rows cannot determine rho at all (Fisher ratio "
        f"{floored(fem.folds[1].both.ratio, '.1g', ROUNDOFF_RATIO)}); the EXP column's can only through the optimised prototype, tested at a given pressure (ratio "
        f"{floored(exp.folds[1].both.ratio, '.1g', ROUNDOFF_RATIO)}).",
        f"- **All rows together determine both** (EXP: Fisher ratio at the paper's values {_g(comparison.identifiability_all['EXP'], 2)}; FEM "
        f"{_g(comparison.identifiability_all['FEM'], 2)}), through the combination of free bends (E against rho) and payload rows (E alone).",
        "",
        "## A copy error in the paper",
        "",
        "Table 3 (2 N vertical payload) repeats in its first row the EXP and FEM angles of Table 2's horizontal case (28.8°, 32.4°), "
        "while its θ_TOL row gives the vertical case's 53.2° and 50.2°; the vertical values are used here. See "
        "[derivations.md](derivations.md#the-papers-tables).",
        "",
    ]
    if comparison.spatial is not None:
        from .spatial_sections import render_experiments3d

        L += render_experiments3d(comparison.spatial)
    return "\n".join(L)


def fitted_label(fit) -> str:
    """The fitted parameters for a legend: each value, or "not identifiable" for a parameter the data
    do not determine (no finite standard error: a value on its bound means nothing).

    >>> from types import SimpleNamespace
    >>> fitted_label(SimpleNamespace(free=("E", "rho"), estimate=[0.561, 3e-5], std_error=[0.006, float("nan")]))
    'E = 0.561 MPa, rho not identifiable'
    """
    out = []
    for n, v, se in zip(fit.free, fit.estimate, fit.std_error):
        if not math.isfinite(float(se)):
            out.append(f"{n} not identifiable")
        else:
            out.append(f"{n} = {v:.3f} MPa" if n == "E" else f"{n} = {v:.1f}°")
    return ", ".join(out)


def figure(comparison: PaperComparison):
    """Measured against predicted for both columns, at E = 0.54 MPa and fitted."""
    series = []
    styles = {"EXP": ("o", "C0"), "FEM": ("^", "C1")}
    for col in comparison.columns:
        sds = {(r.label, q): sd for r in col.data.rows for q, sd in r.sds.items()}
        marker, color = styles[col.name]
        series.append(Series(f"{col.name}, E = 0.54 MPa", col.nominal, sds, marker, "0.55"))
        series.append(Series(f"{col.name}, fitted ({fitted_label(col.fit_both)})", col.fitted, sds, marker, color, face=color))
    return measured_vs_predicted(series, title="The paper's EXP and FEM values against esba (n = 3)")


class ExperimentsPage(Page):
    """``docs/experiments.md`` and ``figures/experiments.png`` beside it."""

    name = "experiments"

    def compute(self, settings: None = None, progress: Progress | None = None) -> PaperComparison:
        from dataclasses import replace

        from esba.calibration.cases3d import experiments3d_cases

        return replace(compare_with_paper(), spatial=experiments3d_cases())

    def render(self, data: PaperComparison, settings: None, path: Path, times: Times = TIMES) -> Rendered:
        return Rendered(render(data), {path.parent / "figures" / FIGURE_NAME: lambda: figure(data)})


PAGE = ExperimentsPage()

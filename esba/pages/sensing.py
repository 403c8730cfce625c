"""The page ``docs/sensing.md`` and its two figures, rendered from :func:`esba.calibration.sensing_cases.sensing_cases`.

Presentation only: every number comes from the cases; nothing here computes a model. ``esba docs
--write sensing`` writes it (about a minute), ``esba docs --check sensing`` checks it; the page
holds no times.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from esba.calibration.sensing_cases import (
    BLIND_DIRECTIONS,
    BLIND_PRESSURES,
    CHECK_REPLICATES,
    ELLIPSE_DIRECTIONS,
    ELLIPSE_PRESSURES,
    SD_DEG,
    SEED,
    SensingCases,
    sensing_cases,
)
from esba.figures.sensing import ARROW_MM_PER_N, blind_figure, ellipse_figure

from .page import TIMES, Page, Progress, Rendered, Times
from .registry import ENTRIES

__all__ = ["PAGE", "SensingPage", "render", "BLIND_FIGURE", "ELLIPSE_FIGURE"]

BLIND_FIGURE = "sensing-blind.png"
ELLIPSE_FIGURE = "sensing-ellipses.png"


def _g(v, digits: int = 3) -> str:
    return "not determined" if v is None or not math.isfinite(v) else f"{v:.{digits}g}"


def _span(values: list[float]) -> str:
    """"4.5" or "4.5 to 6.4": one number when both ends round alike."""
    lo, hi = f"{min(values):.1f}", f"{max(values):.1f}"
    return lo if lo == hi else f"{lo} to {hi}"


def _ranges(values: list[float]) -> str:
    """Consecutive runs of a regular grid as 'a to b' pieces."""
    if not values:
        return "none"
    step = min((b - a for a, b in zip(values, values[1:])), default=0.0)
    runs, start, prev = [], values[0], values[0]
    for v in values[1:]:
        if v - prev > step * 1.5:
            runs.append((start, prev))
            start = v
        prev = v
    runs.append((start, prev))
    return ", ".join(f"{a:g}" if a == b else f"{a:g} to {b:g}" for a, b in runs)


def render(data: SensingCases) -> str:
    b = data.blind
    lines = [
        "# The actuator as a force sensor",
        "",
        f"Written by `{ENTRIES['sensing'].command}` from `esba/calibration/sensing_cases.py`; every number below is computed there "
        "(no times: `esba docs --check sensing` compares it with a fresh run). The method is `esba estimate` "
        "(`esba/calibration/sensing.py`): weighted least squares over the load, the equilibrium followed by Newton on the "
        "generated gradient and Hessian, the covariance from the Fisher matrix of the implicit-function Jacobian, the "
        "identifiability rule of `esba fit`, and starts all round plus every other stable state of each load found.",
        "",
        "The actuator is Table 1's, n = 3, at the pressure that bends it unloaded to 90°; loads are at the tip, Ω from the "
        "vertical (0 pulls down, 90 is horizontal, against the bending direction).",
        "",
        "## How well each kind of measurement determines a tip load",
        "",
        "Standard errors of the load's magnitude F and direction Ω, per 0.1° of noise on each angle or 0.1 mm on each "
        "coordinate (first order; they grow in proportion to the noise while first order holds, see the check below):",
        "",
        "| load | measured | std error of F (N) | std error of Ω (deg) |",
        "|---|---|---:|---:|",
    ]
    for m in data.by_measurement:
        lines.append(f"| {m.force:g} N at Ω = {m.direction:g}° | {m.kind} (± 0.1 {m.unit}) | {_g(m.se_force)} | {_g(m.se_direction)} |")
    lines += ["", "What the data cannot see (the rule of `esba fit`, in the words `esba estimate` prints):", ""]
    lines += [f"- {m.kind}, {m.force:g} N at Ω = {m.direction:g}°: {u}" for m in data.by_measurement for u in m.undetermined]
    seg = {m.direction: m for m in data.by_measurement if m.kind == "segment angles"}
    tip = {m.direction: m for m in data.by_measurement if m.kind == "tip position"}
    ratios = [tip[d].se_force / seg[d].se_force for d in seg if d in tip and tip[d].se_force and seg[d].se_force]
    lines += [
        "",
        "The segment angles determine a tip load best: three numbers for two unknowns. The total angle alone is one number "
        "for two unknowns: only a combination of magnitude and direction. The tip position is two numbers for two unknowns, "
        f"{_span(ratios)} times less precise in F per 0.1 mm than the angles per 0.1°. A marker at L/2 sees only the proximal half, "
        "where a tip load's moment changes little with its direction: it is nearly blind.",
        "",
        "**First order holds for small noise only.** Repeated estimates from noisy segment angles (1 N horizontal, "
        f"{CHECK_REPLICATES} replicates each, seed {SEED}, each started at the true load):",
        "",
        "| noise (deg) | estimates | predicted std error of F (N) | observed std of F (N) | mean error of F (N) | predicted std error of Ω (deg) | observed std of Ω (deg) | 95 % intervals that cover 1 N |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for c in data.first_order:
        lines.append(f"| {c.sd_deg:g} | {c.replicates} | {c.predicted_se_force:.3g} | {c.observed_sd_force:.3g} | {c.bias_force:+.3g} | "
                     f"{c.predicted_se_direction:.3g} | {c.observed_sd_direction:.3g} | {100 * c.coverage:.0f} % |")
    lines += [
        "",
        "At 0.1° the first-order errors are the observed ones. Past about 1° the estimate of F is biased upward (the "
        "shape responds less than linearly to the load) and the first-order error no longer describes the spread: take "
        "the intervals as rough there.",
        "",
        "## Where the actuator is blind",
        "",
        f"The standard error of a 1 N tip load's magnitude from the segment angles at ± {SD_DEG:g}°, at "
        f"{len(BLIND_PRESSURES)} pressures from {BLIND_PRESSURES[0]:g} to {BLIND_PRESSURES[-1]:g} MPa and {len(BLIND_DIRECTIONS)} directions "
        f"every {BLIND_DIRECTIONS[1] - BLIND_DIRECTIONS[0]:g}°. Blind (the error exceeds the load itself, or the load is not "
        f"determined): **{int(b.blind.sum())} of {b.blind.size} cells**.",
        "",
        f"![the blind region](figures/{BLIND_FIGURE})",
        "",
        "| pressure (MPa) | blind directions (deg) | largest std error of F (N) |",
        "|---:|---|---:|",
    ]
    for i, p in enumerate(b.pressures):
        blind_dirs = [d for j, d in enumerate(b.directions) if b.blind[i, j]]
        if blind_dirs:
            worst = np.nanmax(b.se_force[i]) if np.any(np.isfinite(b.se_force[i])) else math.nan
            lines.append(f"| {p:g} | {_ranges(blind_dirs)} | {_g(worst)} |")
    failed = int(np.sum(~np.isfinite(b.se_force)))
    if failed:
        lines += ["", f"{failed} cells have no number (the load is not determined there, or the load history reaches no equilibrium)."]
    blind_p = [p for i, p in enumerate(b.pressures) if np.any(b.blind[i])]
    lines += [
        "",
        f"The blind cells lie at low pressure (up to {max(blind_p, default=0.0):g} MPa here), where the load turns the hardly bent actuator along its own direction: "
        "the actuator hangs like a pendulum and its segment angles hardly change with the load's magnitude. As a sensor, "
        "the actuator needs some bend of its own (pressure) to read a load, and it reads loads across its bend better than "
        "loads along its axis.",
        "",
        "## Error ellipses over the workspace",
        "",
        f"1 N tip loads in {len(ELLIPSE_DIRECTIONS)} directions at {', '.join(f'{p:g}' for p in ELLIPSE_PRESSURES)} MPa, each state "
        f"with its load as an arrow and the load's 95 % ellipse at the arrow's head ({ARROW_MM_PER_N:g} mm per N), from the segment "
        f"angles at ± {SD_DEG:g}°:",
        "",
        f"![error ellipses](figures/{ELLIPSE_FIGURE})",
        "",
        "## A worked example: the paper's Table 3",
        "",
        "The 2 N vertical payload (Ω = 0) at the 90° pressure, read back as a load with F and Ω free (started at 1 N "
        "horizontal, not at the answer; standard deviations as on `docs/experiments.md`, 1° and 1 mm):",
        "",
        "| read from | measured | F (N) | Ω (deg) | 95 % interval of F (N) | 95 % interval of Ω (deg) | unique |",
        "|---|---|---:|---:|---|---|---|",
    ]
    for c in data.table3:
        e = c.estimate
        (flo, fhi), (olo, ohi) = e.interval[0], e.interval[1]
        lines.append(f"| {c.source} | {c.measured} | {e.estimate[0]:.2f} ± {e.std_error[0]:.2f} | {e.estimate[1]:.1f} ± {e.std_error[1]:.1f} | "
                     f"[{flo:.2f}, {fhi:.2f}] | [{olo:.1f}, {ohi:.1f}] | {'yes' if e.unique else 'no'} |")
    lines += [
        "",
        "The EXP and FEM shapes both read back as a load whose interval holds the true 2 N, but at 1° and 1 mm the interval "
        "is wide: the total angle and the tip carry little about the direction. The same load read from segment angles "
        "at 0.1° comes back to a few per cent. To weigh an object with this actuator, measure each segment's angle.",
        "",
        "## What a designer takes from this",
        "",
        "- Measure the segment angles (bend sensors per segment), not only the tip or one marker.",
        "- Read loads with the actuator bent: at low pressure it is blind to loads along its axis.",
        "- Trust the first-order intervals below about 1° of angle noise; above, expect a bias toward larger loads.",
        "- When `esba estimate` says \"not unique\", the listed loads explain the shape equally well: the shape alone "
        "cannot tell them apart, and another pose (another pressure, `--poses`) can.",
        "",
    ]
    if data.spatial is not None:
        from .spatial_sections import render_sensing3d

        lines += render_sensing3d(data.spatial)
    return "\n".join(lines)


class SensingPage(Page):
    """``docs/sensing.md`` and its figures in ``figures/`` beside it."""

    name = "sensing"

    def compute(self, settings: None = None, progress: Progress | None = None) -> SensingCases:
        from dataclasses import replace

        from esba.calibration.cases3d import sensing3d_cases

        return replace(sensing_cases(), spatial=sensing3d_cases())

    def render(self, data: SensingCases, settings: None, path: Path, times: Times = TIMES) -> Rendered:
        return Rendered(render(data), {path.parent / "figures" / BLIND_FIGURE: lambda: blind_figure(data.blind),
                                       path.parent / "figures" / ELLIPSE_FIGURE: lambda: ellipse_figure(data.ellipses, SD_DEG)})


PAGE = SensingPage()

"""The page ``docs/validation.md``: the Table 2 comparison of :mod:`esba.calibration.validation` (written by
``esba validate``; ``esba validate --check`` and ``esba docs --check validation`` fail when the committed
page is stale)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from esba.calibration.validation import TOLERANCE_DEG, TOLERANCE_MM, Table2Case, table2
from esba.model.scene import MAIN_JOB

from .page import TIMES, Page, Progress, Rendered, Times, figure_link

__all__ = ["PAGE", "ValidationPage", "Table2Cases", "render_page"]


def _table(cases: Sequence[Table2Case]) -> list[str]:
    out = [
        "| n | quantity | Table 2 | esba | esba − paper | tolerance | verdict |",
        "|---|---|---:|---:|---:|---:|---|",
    ]
    for case in cases:
        for c in case.comparisons:
            name = {"theta_TOL": "θ_TOL (deg)", "x": "tip x (mm)", "y": "tip y (mm)"}.get(c.quantity)
            if name is None:
                name = f"θ_{c.quantity.split('_')[1]} (deg)"
            out.append(
                f"| {c.n} | {name} | {c.paper:.1f} | {c.esba:.3f} | {c.difference:+.3f} | ±{c.tolerance:g} | {'pass' if c.passed else '**FAIL**'} |"
            )
    return out


def render_page(cases: Sequence[Table2Case], printed: Sequence[Table2Case] = (), page_dir: Path | None = None) -> str:
    """The Markdown of ``docs/validation.md`` (deterministic: no times, numbers to 3 decimals); with
    ``page_dir`` (the page's folder) a figure that is not in ``figures/`` there is named, not linked."""
    a = MAIN_JOB.actuator
    p90 = cases[0].result.pressure if cases else float("nan")
    all_pass = all(c.passed for c in cases)
    lines = [
        "# Validation against the paper's Table 2",
        "",
        "<!-- Written by `esba validate` (esba/calibration/validation.py, esba/pages/validation.py); do not edit by hand. -->",
        "<!-- `esba validate --check` exits 1 when this page is stale. -->",
        "",
        "Written by the command `esba validate`; `pytest tests/statics/test_equilibrium.py -k table2` asserts the",
        "same comparison.",
        "",
        "**Scene** (Section 4.4.2 of the paper): the Table 1 actuator, L = "
        f"{a.L:g} mm, r1 = {a.r1:g} mm, r2 = {a.r2:g} mm, d = {a.d:g} mm, ρ = {a.rho_deg:g}°, "
        f"E = {a.E:g} MPa (Section 4.2), no gravity (Section 4.1); inflated to a 90° unloaded bend, then a "
        "2 N payload at the tip, horizontal and against the bend (Ω = 90°).",
        "",
        f"**Pressure**: the model's own 90° pressure, unrounded, P = {p90:.7f} MPa (closed form: U is "
        "linear in P and the unloaded equilibrium is uniform, θ_i = 90°/n, so the same for every n). "
        "The paper quotes 0.123 MPa.",
        "",
        "**Solve**: `esba.statics.equilibrium.solve` (IPOPT on the generated exact gradient and Hessian, payload "
        "ramped from the unloaded state in steps), model variant `paper`.",
        "",
        f"**Tolerances**: ±{TOLERANCE_DEG:g}° on each segment angle and on the total angle, ±{TOLERANCE_MM:g} mm "
        "on each tip coordinate: Table 2 prints one decimal.",
        "",
        f"**Verdict**: {'every number within tolerance, every equilibrium stable' if all_pass else 'SOME NUMBERS OUTSIDE TOLERANCE'}.",
        "",
        *_table(cases),
        "",
        "| n | P (MPa) | stability | smallest Hessian eigenvalue (N mm/rad²) | max abs dU/dθ (N mm/rad) |",
        "|---|---:|---|---:|---:|",
    ]
    for case in cases:
        r = case.result
        grad = "< 1e-9" if r.gradient_norm < 1e-9 else f"{r.gradient_norm:.1e}"
        lines.append(f"| {case.n} | {r.pressure:.7f} | {r.stability} | {r.eigenvalues[0]:.3f} | {grad} |")
    if printed:
        pp = ", ".join(f"{c.result.pressure:.5f} MPa (n = {c.n})" for c in printed)
        lines += [
            "",
            "## For comparison: the `printed` variant",
            "",
            "Every equation exactly as printed (Eq. 13 with the factor (L + r1 θ_i), Eq. 16 on the chamber "
            f"circumference). Its 90° pressure depends on n, {pp}, none of them the paper's 0.123 MPa, and it "
            "does not reproduce Table 2; this is why the `paper` variant is the default (see `derive/effects.py`, `VARIANTS`). "
            "At n = 1 the two agree exactly: the variants' radial factors coincide for one segment, and the air "
            "and fibre terms are both P times a multiple of θ_TOL, so at each variant's own 90° pressure the net "
            "pressure moment is the same.",
            "",
            *_table(printed),
        ]
    lines += ["", *_figures_section(page_dir)]
    lines.append("")
    return "\n".join(lines)


#: The paper-style figures of the experiments of Section 4, shown on this page (``esba figures``).
PAGE_FIGURES = (
    ("fig7b", "Fig. 7b: the unloaded bending angle against pressure, 0 to 0.2 MPa, for fibre angles 5, 10, 15 and 20°."),
    ("fig8c", "Fig. 8c: the shapes for n = 1 to 4 under the 2 N horizontal tip payload of Table 2 (the red arrow), with the unloaded 90° shape and the measured and FEM tips."),
    ("fig10", "Fig. 10: the horizontal tip payload, 0 to 2 N, against the tip position, n = 3, with the paper's secants."),
    ("fig11", "Fig. 11: the secant stiffness against the payload (the paper's 0.5, 1 and 2 N and a fine curve), and the tangent stiffness at 0 N."),
)


def _figures_section(page_dir: Path | None = None) -> list[str]:
    out = [
        "## Figures",
        "",
        "The paper's figures of these experiments, drawn from the same model (Table 1 actuator, `paper` variant). "
        "Each is written into `docs/figures/` by the command beside it (`esba figures` writes them all; see "
        "`esba/figures/paper.py` for the data behind each).",
        "",
    ]
    for name, caption in PAGE_FIGURES:
        out += [f"- `esba figures --only {name}`: {caption}", "",
                "  " + figure_link(page_dir, f"figures/{name}.png", name, f"esba figures --only {name} --out {{dir}}"), ""]
    return out[:-1]


@dataclass(frozen=True, eq=False)
class Table2Cases:
    """The page's data: Table 2 against the ``paper`` variant, and the ``printed`` one beside it."""

    paper: tuple[Table2Case, ...]
    printed: tuple[Table2Case, ...]


class ValidationPage(Page):
    """``docs/validation.md``: :func:`esba.calibration.validation.table2` for n = 1..4, both variants."""

    name = "validation"

    def compute(self, settings: None = None, progress: Progress | None = None) -> Table2Cases:
        cases = table2("paper")
        return Table2Cases(tuple(cases), tuple(table2("printed", segments=[c.n for c in cases])))

    def render(self, data: Table2Cases, settings: None, path: Path, times: Times = TIMES) -> Rendered:
        return Rendered(render_page(data.paper, data.printed, path.parent))


PAGE = ValidationPage()

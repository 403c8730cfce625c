"""The page ``docs/accuracy-vs-time.md`` and its figure, rendered from the benchmarks of
:mod:`esba.bench.accuracy` (``esba bench accuracy`` and ``esba docs --write accuracy-vs-time`` write
it; ``esba docs --check accuracy-vs-time`` reruns the benchmarks once each and compares, times
aside: every time on the page is written through :class:`esba.pages.page.Times`)."""

from __future__ import annotations

import dataclasses
import platform
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from esba.bench.accuracy import ACCURACY_NS, REFERENCE_N, AccuracyBenchmark

from .page import TIMES, Page, Progress, Rendered, Times, figure_link

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = ["PAGE", "AccuracyPage", "AccuracySettings", "AccuracyRuns", "figure", "render_page", "CASE_LABELS", "FIGURE_NAME"]

#: The figure's file name (in ``figures/`` beside the page unless told otherwise).
FIGURE_NAME = "accuracy-vs-time.png"

CASE_LABELS = {
    "table2": "Table 2: 2 N horizontal at the tip",
    "vertical": "2 N vertical at the tip",
    "midlength": "2 N horizontal at mid-length",
}

#: The sweep figures the page shows, written by the ``esba sweep`` commands it names.
SWEEP_FIGURES = {"fig12": "docs/figures/sweep-fig12.png", "pressure": "docs/figures/sweep-pressure-payload.png"}


def figure(accuracy: AccuracyBenchmark) -> "Figure":
    """Tip error against n (true and n-vs-(n+1)) and against solve time."""
    from esba.figures.scenes import new_figure

    fig = new_figure(11.0, 4.6)
    ax_n, ax_t = fig.subplots(1, 2)
    for k, case in enumerate(accuracy.reference):
        rows = accuracy.by_case(case)
        ns = [r.n for r in rows]
        c = f"C{k}"
        ax_n.loglog(ns, [r.error_mm for r in rows], "o-", color=c, label=f"{CASE_LABELS[case]}: true error")
        ax_n.loglog(ns, [r.next_mm for r in rows], "s--", color=c, mfc="none", label="  n vs n+1 (the paper's criterion)")
        ax_t.loglog([r.solve_s * 1e3 for r in rows], [r.error_mm for r in rows], "o-", color=c, label=CASE_LABELS[case])
        for r in rows:
            if case == "table2":
                ax_t.annotate(f"{r.n}", (r.solve_s * 1e3, r.error_mm), textcoords="offset points", xytext=(4, 3), fontsize=7)
    for ax in (ax_n, ax_t):
        for mm, label in ((1.0, "1 mm"), (0.1, "0.1 mm")):
            ax.axhline(mm, color="0.5", lw=0.8, ls=":")
            ax.annotate(label, (1.0, mm), xycoords=("axes fraction", "data"), xytext=(-40, 3), textcoords="offset points", fontsize=8, color="0.4")
        ax.grid(True, which="both", color="0.92", lw=0.5)
        ax.set_ylabel("tip position error (mm)")
    plain_log_ticks(ax_n.xaxis)
    plain_log_ticks(ax_t.xaxis)
    ax_n.set_xlabel("segments n")
    ax_n.set_title("(a) error against n")
    ax_n.legend(fontsize=7)
    ax_t.set_xlabel("solve time per equilibrium (ms, esba.statics.equilibrium.solve)")
    ax_t.set_title("(b) error against solve time (labels: n)")
    ax_t.legend(fontsize=7)
    ref = accuracy.reference[next(iter(accuracy.reference))]
    fig.suptitle(f"Accuracy against time (reference: {ref['method']}; esba bench accuracy)", fontsize=10)
    return fig


def plain_log_ticks(axis) -> None:
    """Label a logarithmic axis with plain numbers (``2``, ``3``, ``10``, not ``2×10⁰``); its
    minor ticks too when it spans less than two decades (else only the powers of ten)."""
    from matplotlib.ticker import FuncFormatter

    lo, hi = sorted(axis.get_view_interval())
    plain = FuncFormatter(lambda v, _pos: f"{v:g}")
    axis.set_major_formatter(plain)
    short = lo > 0 and hi / lo < 100.0
    axis.set_minor_formatter(plain if short else FuncFormatter(lambda v, _pos: ""))


def _fmt_s(s: float, t: Times = TIMES) -> str:
    if s < 1e-3:
        text = f"{s * 1e6:.0f} µs"
    elif s < 1.0:
        text = f"{s * 1e3:.1f} ms"
    else:
        text = f"{s:.1f} s"
    return t.word(text)


def _batch3d_lines(b3: dict | None, t: Times, planar_us: float | None = None) -> list[str]:
    """The 3-D batch beside the planar one (:func:`esba.bench.accuracy.batch3d_benchmark`);
    ``planar_us``: the planar compiled batch's µs per equilibrium in the same run."""
    if not b3:
        return []
    gap = b3["max_q_difference_vs_solve3d"]
    met = b3["us"] <= b3["target_us"]
    ratio = []
    if planar_us:
        ratio = [f"  That is {t(b3['us'] / planar_us, '.1f')}x the planar batch's {t(planar_us, '.1f')} µs in the same run; the targets'"
                 f" ratio is {b3['target_us'] / 20.0:.0f}x (60 µs against 20 µs): where the planar batch meets its 20 µs, the 3-D batch"
                 f" {t.word('would meet its 60 µs' if b3['us'] / planar_us <= b3['target_us'] / 20.0 else 'would still miss its 60 µs')}, if the ratio holds there."]
    return [
        f"- **3-D scenes** (`esba.export.batch3d`: the compiled 3-D export, `esba export c --3d`, every element checked from the",
        "  model: its gradient and 3n x 3n Hessian, the model's own function compiled over the batch, and the Hessian positive definite",
        f"  by a Cholesky factorisation): {b3['size']} equilibria at n = {b3['segments']}, Table 1 with its section,",
        "  pressures 0-0.2 MPa x tip payloads 0-2 N horizontal and 30 deg out of the plane, warm (median of 3 runs):",
        f"  {t(b3['us'], '.0f')} µs per equilibrium, every element included ({t(b3['solve_us'], '.0f')} µs the C solve,",
        f"  {t(b3['check_us'], '.0f')} µs the check); target 60 µs or less at n = 3: {t.word('met' if met else 'NOT met')}."
        f" Answered: {', '.join(f'{k} {v}' for k, v in sorted(b3['counts'].items()))}; {b3['ok']} verified.",
        *ratio,
        f"  The load history took {b3['newton_iterations']:.1f} Newton iterations per equilibrium on average ({b3['steps']:.1f} load steps).",
        f"  Largest difference from solve3d on {b3['samples']} sampled elements: {'< 1e-12' if gap is not None and gap < 1e-12 else (f'{gap:.1g}' if gap is not None else 'none compared')} rad.",
    ]


def _batch_cost(b: dict, t: Times) -> list[str]:
    """Where the compiled batch's time per equilibrium goes: natural continuation, its finer retry,
    and the elements it hands to pseudo-arclength continuation of their load history."""
    if "compiled_us" not in b:
        return []
    retried = b["counts"].get("newton-retry", 0)
    handed = b["counts"].get("continuation", 0)
    line = (
        f"- Where the {t(b['compiled_us'], '.1f')} µs go: natural continuation {t(b['compiled_fast_path_us'], '.1f')} µs and its finer "
        f"retry {t(b.get('compiled_retry_us', 0.0), '.1f')} µs per equilibrium of the batch ({retried} elements retried, "
        f"{100 * retried / b['size']:.2g} %: in this grid (pressures 0-0.2 MPa, horizontal tip payloads 0-2 N) they sit "
        "at the edge of the bistable range of [paths.md](paths.md), where the 8-step ramp passes close to the cusp "
        "and is refused by the acceptance rule, and the 64-step ramp, compiled as the first, is accepted)"
    )
    if handed:
        line += (
            f"; the {handed} elements ({100 * handed / b['size']:.2g} %) whose finer ramp is refused too take "
            f"{t(1e3 * b['compiled_fallback_s'] / handed, '.1f')} ms each in pseudo-arclength continuation of their load history "
            f"(`esba.statics.equilibrium.load_history`), {t(1e6 * b['compiled_fallback_s'] / b['size'], '.1f')} µs per equilibrium "
            "of the batch: it goes round the fold, takes any jump and notes it"
        )
    return [line + "."]


def answered(counts: dict[str, int]) -> str:
    """A batch's :meth:`esba.statics.batch.BatchResult.counts` in words.

    >>> answered({"newton": 9, "ipopt": 1, "ok": 10, "not_ok": 0})
    'newton 9, ipopt 1 (10 ok, 0 not ok)'
    """
    methods = ", ".join(f"{m} {c}" for m, c in counts.items() if m not in ("ok", "not_ok"))
    return f"{methods} ({counts.get('ok', 0)} ok, {counts.get('not_ok', 0)} not ok)"


def render_page(runs: "AccuracyRuns", command: str, figure_rel: str, t: Times = TIMES, page_dir: Path | None = None) -> str:
    """The Markdown of ``docs/accuracy-vs-time.md``; with ``page_dir`` (the page's folder) a sweep
    figure that is not in ``figures/`` there is named with the command that draws it, not linked."""
    accuracy, tolerance, effects, naive, batch = runs.accuracy, runs.tolerance, runs.effects, runs.naive, runs.batch
    lines = [
        "# What accuracy costs in time",
        "",
        f"Every number on this page is printed by `{command}`, which also writes this page and",
        f"[the figure]({figure_rel}). Machine: {t.word(f'{platform.machine()}, {platform.python_implementation()} {platform.python_version()}')}"
        ", 2 cores shared with other jobs: read times as orders of magnitude and",
        "compare ratios within the page (they come from one run).",
        "",
        f"![accuracy against time]({figure_rel})",
        "",
        "## The reference",
        "",
    ]
    for case, ref in accuracy.reference.items():
        lines.append(
            f"- {CASE_LABELS[case]}: tip ({ref['tip'][0]:.4f}, {ref['tip'][1]:.4f}) mm, total angle "
            f"{ref['total_angle_deg']:.4f} deg; {ref['method']}; the n = {ref['n_max']} solution is "
            f"{ref['n_max_error_mm']:.2g} mm from it."
        )
    nmax = accuracy.reference_n
    worst = max(ref["n_max_error_mm"] for ref in accuracy.reference.values())
    lines += [
        "",
        f"Why Richardson extrapolation rather than n = {nmax} alone: the chain of constant-curvature",
        "segments converges to the continuum as a clean power of 1/n (the observed orders above), so",
        "extrapolating from three successive halvings removes the leading error term. The distance of",
        f"the n = {nmax} solution from the reference (at most {worst:.2g} mm) is what using n = {nmax}",
        f"directly would have added to every error below; it is {'well below' if worst < 0.01 else 'not far below'} the 0.1 mm this page resolves.",
        "",
        "## Tip error against n, and what each n costs",
        "",
        "Error = distance of the tip to the reference; n vs n+1 = distance between the tips of the",
        "n and n+1 segment models (the paper's criterion, Section 4.4.2). Generate = derive and write",
        "the model (cold, SymPy, done once per n and then cached; the n = 1 row also pays for importing",
        "SymPy once); load = build its CasADi Functions from the freshly written file (warm; later loads",
        "read CasADi's serialised Functions from the model cache, see performance.md); solve = one equilibrium",
        "with `esba.statics.equilibrium.solve` (the load path followed, the end state certified a minimiser; median);",
        "Hessian condition = largest / smallest eigenvalue of the Hessian at the equilibrium.",
        "",
    ]
    for case in accuracy.reference:
        lines += [
            f"### {CASE_LABELS[case]}",
            "",
            "| n | tip x, y (mm) | error (mm) | n vs n+1 (mm) | angle error (deg) | n vs n+1 angle (deg) | generate | load | solve | Hessian condition |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]
        for r in accuracy.by_case(case):
            c = accuracy.costs[r.n]
            flag = "" if r.ok else " (not ok)"
            lines.append(
                f"| {r.n} | {r.tip[0]:.3f}, {r.tip[1]:.3f}{flag} | {r.error_mm:.3g} | {r.next_mm:.3g} | "
                f"{r.angle_error_deg:+.3g} | {r.next_angle_deg:+.3g} | {_fmt_s(c.generate_s, t)} | {_fmt_s(c.load_s, t)} | {_fmt_s(r.solve_s, t)} | {r.condition:.3g} |"
            )
        lines.append("")
        for mm in (1.0, 0.1):
            r = accuracy.first_n_below(case, mm)
            if r is None:
                lines.append(f"- {mm:g} mm: not reached by n = {accuracy.by_case(case)[-1].n}.")
            else:
                c = accuracy.costs[r.n]
                crit = next((q for q in accuracy.by_case(case) if q.next_mm < mm), None)
                crit_txt = f"the n-vs-(n+1) criterion would stop at n = {crit.n}" if crit else "the n-vs-(n+1) criterion never falls below it"
                lines.append(
                    f"- {mm:g} mm: reached at n = {r.n} (error {r.error_mm:.3g} mm): generate {_fmt_s(c.generate_s, t)} once, "
                    f"load {_fmt_s(c.load_s, t)}, solve {_fmt_s(r.solve_s, t)}; {crit_txt}."
                )
        lines.append("")
    n_big = max(accuracy.costs)
    c = accuracy.costs[n_big]
    big = [n for n in sorted(accuracy.costs) if n >= 8]
    if len(big) >= 2:
        slope = np.polyfit(np.log(big), np.log([accuracy.costs[n].instructions["hessian"] for n in big]), 1)[0]
        tslope = np.polyfit(np.log(big), np.log([accuracy.costs[n].generate_s for n in big]), 1)[0]
        growth = f"The Hessian's size grows as n^{slope:.2f} and the cold generation time as n^{t(tslope, '.2f')} (fits over n >= 8); "
    else:
        growth = ""
    ratios = [r.error_mm / r.next_mm for r in accuracy.rows if r.n == max(q.n for q in accuracy.rows) and r.next_mm > 0]
    lines += [
        f"{growth}n = {n_big}: {c.instructions['energy']} / {c.instructions['gradient']} / {c.instructions['hessian']} "
        f"SX instructions for U / gradient / Hessian, generated cold in {_fmt_s(c.generate_s, t)}.",
        "",
        "The paper's n-vs-(n+1) criterion underestimates the true error, and more so as n grows: for an",
        "error falling as C/n^2 the gap between n and n+1 is about 2C/n^3, so the error is about n/2",
        f"gaps. At n = {max(q.n for q in accuracy.rows)} the true error is {min(ratios):.1f} to {max(ratios):.1f} times the gap. Stopping when the",
        "gap falls below a tolerance therefore leaves an error well above that tolerance (see where the",
        "criterion would stop, above).",
        "",
        "## IPOPT tolerance against time and error",
        "",
        f"Table 2 case at n = {tolerance[0].get('n', 16) if tolerance else 16}; polishing off so that the tolerance alone decides;",
        "error against the tightest solve (tol = 1e-12 with Newton polishing) of the same n.",
        "",
        "| tol | solve | IPOPT iterations | max abs dU/dtheta (N mm/rad) | tip error (mm) | angle error (deg) |",
        "|---|---|---|---|---|---|",
    ]
    for r in tolerance:
        lines.append(
            f"| {r['tol']:.0e} | {_fmt_s(r['solve_s'], t)} | {r['iterations']} | {r['gradient_norm']:.2g} | {r['tip_error_mm']:.2g} | {r['angle_error_deg']:+.2g} |"
        )
    if tolerance:
        ts = [r["solve_s"] for r in tolerance]
        lines += [
            "",
            f"From tol = {tolerance[0]['tol']:.0e} to {tolerance[-1]['tol']:.0e} the solve time changes by a factor of "
            f"{t(max(ts) / min(ts), '.1f')} at most (IPOPT's per-solve overhead dominates at this size), while the error falls from "
            f"{tolerance[0]['tip_error_mm']:.2g} mm to {tolerance[-1]['tip_error_mm']:.2g} mm: a tight tolerance is nearly free, and",
            "esba's default (1e-10, then Newton polishing) costs nothing worth saving.",
        ]
    lines += [
        "",
        "## The cost of each effect",
        "",
        f"n = {effects[0].get('n', 16) if effects else 16}; every scene at the Table 2 case's pressure (the 90 degree pressure of the",
        "base model), so the change in the tip is the effect's alone.",
        "",
        "| scene | effects | SX instructions U / grad / Hessian | generate | solve | tip x, y (mm) | tip change (mm) | angle change (deg) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in effects:
        i = r["instructions"]
        lines.append(
            f"| {r['effect']} | `{r['effects']}` | {i['energy']} / {i['gradient']} / {i['hessian']} | {_fmt_s(r['generate_s'], t)} | "
            f"{_fmt_s(r['solve_s'], t)} | {r['tip_mm'][0]:.2f}, {r['tip_mm'][1]:.2f} | {r['tip_change_mm']:.2f} | {r['angle_change_deg']:+.2f} |"
        )
    lines += [
        "",
        "## The first script against esba",
        "",
        "Naive: `scipy.optimize.minimize(U, zeros(n), method=\"BFGS\")` with finite-difference",
        "gradients, on the same generated energy at the same pressure. esba: `esba.statics.equilibrium.solve`",
        "(the load ramp as one compiled Newton continuation on the exact gradient and Hessian, a path",
        "trace where it meets a fold, the certificate of the end state (IPOPT's when needed), the stability",
        "check), and the same without continuation (one IPOPT solve from the unloaded state).",
        "",
        "| n | naive | U evaluations | naive says converged | naive tip error (mm) | esba solve | naive / esba | esba, one IPOPT solve | naive / that |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in naive:
        lines.append(
            f"| {r['n']} | {_fmt_s(r['naive_s'], t)} | {r['naive_evaluations']} | {'yes' if r['naive_success'] else 'no'} | "
            f"{r['naive_tip_error_mm']:.2g} | {_fmt_s(r['esba_s'], t)} | "
            f"{t(r['ratio'], '.1f')}x | {_fmt_s(r['esba_single_s'], t)} | {t(r['ratio_single'], '.1f')}x |"
        )
    wrong = [r for r in naive if r["naive_tip_error_mm"] > 0.01]
    lines += [
        "",
        "One solve at a time, the naive script is not far behind at small n: a few dozen energy",
        "evaluations cost little more than esba's fixed costs per call (the certificate, the multistability",
        "check, the stability verdict). What the naive script lacks is shown by its error column"
        + (
            ": " + ", ".join(f"at n = {r['n']} it stops {r['naive_tip_error_mm']:.2g} mm from the equilibrium" + ("" if r["naive_success"] else " (and says so)") for r in wrong)
            if wrong
            else ""
        )
        + "; it checks no stability and follows no load path. For many solves the batch path below is",
        "the answer to speed.",
    ]
    b = batch
    lines += [
        "",
        "## Many solves: the batch path",
        "",
        f"{b['size']} equilibria, n = {b['segments']}: Table 1, pressures 0-0.2 MPa x horizontal tip payloads 0-2 N",
        "(`esba bench batch` runs this benchmark alone; warm = median of 3 runs). Each element follows the load path with Newton steps",
        "in one CasADi graph mapped over the batch, is verified (stationarity, domain, Hessian",
        "eigenvalues), retried with a denser path or solved by IPOPT when that fails.",
        "",
        "| path | µs per equilibrium |",
        "|---|---|",
    ]
    if "compiled_us" in b:
        lines += [
            f"| batch, compiled C, warm (cached library) | {t(b['compiled_us'], '.1f')} |",
            f"| batch, compiled C, first call (compiles in {t(b['compiled_first_compile_s'], '.1f')} s) | {t(b['compiled_first_us'], '.1f')} |",
        ]
    lines += [
        f"| batch, CasADi interpreter | {t(b['interpreted_us'], '.1f')} |",
        f"| esba.statics.equilibrium.solve (IPOPT), one by one | {t(b['ipopt_us'], '.0f')} |",
        f"| naive SciPy BFGS, one by one | {t(b['naive_us'], '.0f')} |",
        "",
        "- Target: 20 µs or less per equilibrium for n = 3 on 10 000: "
        + (f"{t.word('met' if b.get('compiled_us', 1e9) <= 20 else 'NOT met')} ({t(b.get('compiled_us', float('nan')), '.1f')} µs compiled, warm)." if "compiled_us" in b else "no C compiler here: interpreted only."),
        *_batch_cost(b, t),
        f"- Speed-up: {t(b['speedup_vs_naive'], '.0f')}x the naive script, {t(b['speedup_vs_ipopt'], '.0f')}x IPOPT one by one.",
        f"- How the elements were answered: {answered(b['counts'])}; backend: {b['backend'].split(', cached')[0]}.",
        f"- Largest difference from IPOPT on {50} sampled elements: {b['max_theta_difference_vs_ipopt']:.2g} rad.",
        *_batch3d_lines(runs.batch3d, t, b.get("compiled_us")),
        "",
        "## Sweeps on the batch path",
        "",
        "Figures drawn by `esba sweep` (each solved as one batch; every point is ok, or a row that",
        "says why not):",
        "",
        f"- `esba sweep --fig12 {SWEEP_FIGURES['fig12']}`: the paper's Fig. 12, bending angle against",
        "  r2 for d = 0, 2, 4, 6 mm and against d for r2 = 2, 4, 6 mm, at rho = 10 deg and P = 0.2 MPa.",
        "  The angle grows with both and faster with r2 (the paper's conclusion), and without bound as",
        "  the chamber wall r1 - r2 - d thins: the model has no wall-thickness limit.",
        "",
        "  " + figure_link(page_dir, Path(SWEEP_FIGURES["fig12"]).relative_to("docs").as_posix(), "Fig. 12", "esba sweep --fig12 {file}"),
        "",
        f"- `esba sweep --pressure 0:0.2:41 --payload 0,0.5,1,2 --plot {SWEEP_FIGURES['pressure']}`: total angle",
        "  against pressure for horizontal tip payloads (Table 1). Each curve is the branch traced through",
        "  its first grid point (stable solid, unstable dashed, folds circled); the dots are the grid",
        "  points, each solved along its own load history (inflate, then load). The 2 N curve is an S:",
        "  between its two folds the actuator is bistable, and the grid points switch branch where that",
        "  history starts to reach the upper state (`docs/paths.md` has the folds and the hysteresis).",
        "",
        "  " + figure_link(page_dir, Path(SWEEP_FIGURES["pressure"]).relative_to("docs").as_posix(), "pressure sweep",
                           "esba sweep --pressure 0:0.2:41 --payload 0,0.5,1,2 --plot {file}"),
        "",
    ]
    return "\n".join(lines)


@dataclass(frozen=True, eq=False)
class AccuracyRuns:
    """The page's data: the five benchmarks of :mod:`esba.bench.accuracy`."""

    accuracy: AccuracyBenchmark
    tolerance: list[dict]
    effects: list[dict]
    naive: list[dict]
    batch: dict
    batch3d: dict | None = None


@dataclass(frozen=True)
class AccuracySettings:
    """What ``esba bench accuracy`` takes (``quick``: n <= 4, reference n = 16, a batch of 1000), the
    command the page names, and where its figure goes (None: ``figures/`` beside the page)."""

    quick: bool = False
    max_n: int = 128
    reference_n: int = REFERENCE_N
    fixed_n: int = 16
    repeat: int = 5
    command: str = "esba bench accuracy"
    figure: Path | None = None

    @property
    def plan(self) -> tuple[tuple[int, ...], int, int, tuple[int, ...], int]:
        """(segment counts, reference n, n of the tolerance and effect benchmarks, n of the naive one, batch size)."""
        if self.quick:
            return (1, 2, 3, 4), 16, 4, (3,), 1000
        return tuple(n for n in ACCURACY_NS if n <= self.max_n), self.reference_n, self.fixed_n, (3, 8, 16), 10_000


class AccuracyPage(Page):
    """``docs/accuracy-vs-time.md`` and its figure."""

    name = "accuracy-vs-time"

    def settings(self) -> AccuracySettings:
        return AccuracySettings()

    def check_settings(self) -> AccuracySettings:
        return dataclasses.replace(self.settings(), repeat=1)

    def compute(self, settings: AccuracySettings | None = None, progress: Progress | None = None) -> AccuracyRuns:
        from esba.bench import accuracy as acc

        settings = self.settings() if settings is None else settings
        say = progress or (lambda msg: None)
        ns, ref_n, fixed_n, naive_ns, size = settings.plan
        accuracy = acc.accuracy_benchmark(ns, ref_n, repeat=settings.repeat, progress=say)
        say(f"tolerance benchmark (n = {fixed_n})")
        tolerance = acc.tolerance_benchmark(fixed_n, repeat=settings.repeat)
        say(f"effect benchmark (n = {fixed_n})")
        effects = acc.effect_benchmark(fixed_n, repeat=settings.repeat)
        for rows in (tolerance, effects):
            for r in rows:
                r["n"] = fixed_n
        say("naive BFGS against esba")
        naive = acc.naive_benchmark(naive_ns, repeat=settings.repeat)
        say(f"batch of {size}")
        batch = acc.batch_benchmark(size)
        say("3-D batch")
        batch3d = acc.batch3d_benchmark(200 if settings.quick else 2000)
        return AccuracyRuns(accuracy, tolerance, effects, naive, batch, batch3d)

    def figure_path(self, settings: AccuracySettings, path: Path) -> Path:
        return path.parent / "figures" / FIGURE_NAME if settings.figure is None else Path(settings.figure)

    def render(self, data: AccuracyRuns, settings: AccuracySettings, path: Path, times: Times = TIMES) -> Rendered:
        fig_path = self.figure_path(settings, path)
        try:
            rel = fig_path.resolve().relative_to(path.resolve().parent).as_posix()
        except ValueError:
            rel = fig_path.resolve().as_posix()
        return Rendered(render_page(data, settings.command, rel, times, path.parent), {fig_path: lambda: figure(data.accuracy)})


PAGE = AccuracyPage()

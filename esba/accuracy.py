"""What accuracy costs in time: the benchmarks behind ``docs/accuracy-vs-time.md``.

Every number of that page is printed by ``esba bench accuracy`` (which writes the page and its
figure), and the batch numbers also by ``esba bench batch``. The studies:

* :func:`accuracy_study`: the tip position and total angle of three scenes (the paper's Table 2
  case, a vertical tip payload, a horizontal payload at mid-length) for n = 1 ... 128 against a
  converged reference, beside the paper's n-vs-(n+1) criterion, with the time to generate each
  model (cold), to load it (warm) and to solve one equilibrium (median).
* :func:`tolerance_study`: IPOPT's tolerance against time and error at a fixed n.
* :func:`effect_study`: the cost of each effect (model size, generation and solve time) and the
  change it makes in the answer.
* :func:`naive_study` and :func:`batch_study`: the first script a researcher writes (SciPy BFGS
  with numeric gradients on the same energy) against esba's IPOPT solve and the batch path.

Timings are medians on a shared machine: compare the ratios within one run.

Examples
--------
>>> sorted(CASES), ACCURACY_NS[-1], REFERENCE_N
(['midlength', 'table2', 'vertical'], 128, 256)
>>> CASES["midlength"].payloads[0].at
0.5
"""

from __future__ import annotations

import math
import platform
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from .bench import median_time
from .equilibrium import SolverOptions, solve
from . import cache
from .model import _exec_model, _usable_cached, cache_dir
from .outputs import default_page, figures_dir
from .scene import Payload, Scene

__all__ = [
    "ACCURACY_NS",
    "REFERENCE_N",
    "CASES",
    "ModelCost",
    "AccuracyStudy",
    "model_cost",
    "accuracy_study",
    "tolerance_study",
    "effect_study",
    "naive_study",
    "batch_study",
    "write_page",
    "DOC_PATH",
    "FIGURE_PATH",
]

#: Segment counts of the accuracy study (issue 5).
ACCURACY_NS: tuple[int, ...] = (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 64, 128)
#: The finest model solved; the reference is extrapolated from it and n / 2, n / 4.
REFERENCE_N = 256

#: The scenes of the study: Table 1 at its 90 degree pressure with a 2 N tip payload,
#: horizontal (Table 2), vertical (Table 3), and horizontal at mid-length.
CASES: dict[str, Scene] = {
    "table2": Scene(target_angle_deg=90.0, payloads=(Payload(2.0, 90.0, 1.0),)),
    "vertical": Scene(target_angle_deg=90.0, payloads=(Payload(2.0, 0.0, 1.0),)),
    "midlength": Scene(target_angle_deg=90.0, payloads=(Payload(2.0, 90.0, 0.5),)),
}
CASE_LABELS = {
    "table2": "Table 2: 2 N horizontal at the tip",
    "vertical": "2 N vertical at the tip",
    "midlength": "2 N horizontal at mid-length",
}

#: The sweep figures the page shows, written by the ``esba sweep`` commands it names.
SWEEP_FIGURES = {"fig12": "docs/figures/sweep-fig12.png", "pressure": "docs/figures/sweep-pressure-payload.png"}

ROOT = Path(__file__).resolve().parent.parent
DOC_PATH = ROOT / "docs" / "accuracy-vs-time.md"
FIGURE_PATH = ROOT / "docs" / "figures" / "accuracy-vs-time.png"


# ---------------------------------------------------------------------------------------------
# model costs


@dataclass(frozen=True)
class ModelCost:
    """What one model costs before any solve.

    Attributes
    ----------
    generate_s : float
        Cold: derive and write the model file (SymPy), s.
    load_s : float
        Warm: build the CasADi Functions from the file, median, s.
    instructions : dict
        SX instructions of energy, gradient and Hessian.
    """

    n: int
    effects: str
    generate_s: float
    load_s: float
    instructions: dict


def model_cost(n: int, effects: str, variant: str = "paper", repeat: int = 3) -> ModelCost:
    """Generate the model into a fresh folder (cold), then time building its Functions (warm).

    The fresh file is copied into the model cache when that has none, so the solves that
    follow do not generate it a second time (the emission is deterministic: same bytes).
    """
    from derive.effects import EffectSet
    from derive.emit import write_model

    eff = EffectSet.parse(effects)
    with tempfile.TemporaryDirectory(prefix="esba-bench-") as tmp:
        t0 = time.perf_counter()
        path, entry = write_model(n, eff, variant, Path(tmp), manifest=False)
        generate_s = time.perf_counter() - t0
        load_s = median_time(lambda: _exec_model(path), repeat)
        cached = cache_dir() / path.name
        if not _usable_cached(cached, n, eff, variant):
            cache.install(cache.usable_root(cached.parent) / path.name, path)
    instr = {k: int(v) for k, v in entry["instructions"].items() if k in ("energy", "gradient", "hessian")}
    return ModelCost(n, eff.spec(), generate_s, load_s, instr)


def _solve_time(scene: Scene, repeat: int, options: SolverOptions | None = None) -> tuple[float, object]:
    result = solve(scene, options)  # warm-up: builds and caches the IPOPT solver
    return median_time(lambda: solve(scene, options), repeat), result


# ---------------------------------------------------------------------------------------------
# accuracy against n


@dataclass(frozen=True)
class AccuracyRow:
    case: str
    n: int
    tip: tuple[float, float]
    total_angle_deg: float
    error_mm: float
    angle_error_deg: float
    next_mm: float
    next_angle_deg: float
    solve_s: float
    ok: bool
    condition: float


@dataclass(frozen=True)
class AccuracyStudy:
    """Errors against n for each case, the reference used and the model costs.

    Attributes
    ----------
    reference : dict
        Per case: ``tip`` and ``total_angle_deg`` of the reference, ``n_max`` (the finest n),
        ``order`` (observed convergence order of the tip from n_max/4, n_max/2, n_max),
        ``n_max_error_mm`` (how far the n_max solution is from the reference), ``method``.
    """

    rows: list[AccuracyRow]
    reference: dict
    costs: dict[int, ModelCost]
    reference_n: int

    def by_case(self, case: str) -> list[AccuracyRow]:
        return [r for r in self.rows if r.case == case]

    def first_n_below(self, case: str, mm: float) -> AccuracyRow | None:
        """The smallest n whose tip error (against the reference) is below ``mm``, and stays so."""
        rows = self.by_case(case)
        for k, r in enumerate(rows):
            if all(q.error_mm < mm for q in rows[k:]):
                return r
        return None


def _tip_and_angle(scene: Scene) -> tuple[np.ndarray, float, bool, float]:
    r = solve(scene)
    ev = np.asarray(r.eigenvalues, dtype=float)
    return np.asarray(r.tip[:2], dtype=float), r.total_angle_deg, r.ok, float(ev[-1] / ev[0])


def accuracy_study(
    ns: Sequence[int] = ACCURACY_NS,
    reference_n: int = REFERENCE_N,
    cases: Sequence[str] = tuple(CASES),
    repeat: int = 5,
    progress: Callable[[str], None] | None = None,
) -> AccuracyStudy:
    """Tip and angle errors against n, the n-vs-(n+1) gaps, and what each n costs.

    The reference is the Richardson extrapolation of the solutions at reference_n / 4,
    reference_n / 2 and reference_n with the observed order (the discretisation error of a
    piecewise-constant-curvature chain falls as a power of 1/n); ``reference`` records the order
    and how far the reference_n solution itself is from it.
    """
    say = progress or (lambda _msg: None)
    effects = CASES["table2"].effects.spec()
    need = sorted(set(ns) | {n + 1 for n in ns} | {reference_n // 4, reference_n // 2, reference_n})
    costs: dict[int, ModelCost] = {}
    for n in sorted(set(ns) | {reference_n}):
        say(f"model n = {n}: generating (cold) and loading (warm)")
        costs[n] = model_cost(n, effects, repeat=3 if n <= 64 else 1)
    sol: dict[tuple[str, int], tuple[np.ndarray, float, bool, float]] = {}
    for case in cases:
        for n in need:
            sol[(case, n)] = _tip_and_angle(CASES[case].replace(segments=n))
        say(f"case {case}: solved n = {', '.join(map(str, need))}")
    reference = {}
    for case in cases:
        t1, a1, _, _ = sol[(case, reference_n // 4)]
        t2, a2, _, _ = sol[(case, reference_n // 2)]
        t3, a3, _, _ = sol[(case, reference_n)]
        gap12, gap23 = float(np.linalg.norm(t2 - t1)), float(np.linalg.norm(t3 - t2))
        order = math.log2(gap12 / gap23) if gap23 > 0 and gap12 > 0 else float("nan")
        factor = 1.0 / (2.0**order - 1.0) if math.isfinite(order) and order > 0.5 else 0.0
        tip_ref = t3 + factor * (t3 - t2)
        angle_ref = a3 + factor * (a3 - a2)
        reference[case] = {
            "tip": [float(v) for v in tip_ref],
            "total_angle_deg": float(angle_ref),
            "n_max": reference_n,
            "order": order,
            "n_max_error_mm": float(np.linalg.norm(t3 - tip_ref)),
            "method": f"Richardson from n = {reference_n // 4}, {reference_n // 2}, {reference_n} (observed order {order:.2f})" if factor else f"n = {reference_n}",
        }
    rows = []
    for case in cases:
        tip_ref = np.array(reference[case]["tip"])
        angle_ref = reference[case]["total_angle_deg"]
        for n in ns:
            say(f"case {case}: timing n = {n}")
            solve_s, _ = _solve_time(CASES[case].replace(segments=n), repeat if n <= 32 else max(1, min(repeat, 3)))
            tip, angle, ok, cond = sol[(case, n)]
            tip1, angle1, _, _ = sol[(case, n + 1)]
            rows.append(
                AccuracyRow(
                    case=case,
                    n=n,
                    tip=(float(tip[0]), float(tip[1])),
                    total_angle_deg=angle,
                    error_mm=float(np.linalg.norm(tip - tip_ref)),
                    angle_error_deg=float(angle - angle_ref),
                    next_mm=float(np.linalg.norm(tip1 - tip)),
                    next_angle_deg=float(angle1 - angle),
                    solve_s=solve_s,
                    ok=ok,
                    condition=cond,
                )
            )
    return AccuracyStudy(rows, reference, costs, reference_n)


# ---------------------------------------------------------------------------------------------
# tolerance, effects, naive, batch


def tolerance_study(
    n: int = 16, tolerances: Sequence[float] = (1e-2, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12), repeat: int = 7, case: str = "table2"
) -> list[dict]:
    """IPOPT's ``tol`` against solve time, iterations and the tip error at a fixed n.

    Polishing is off (it would take every tolerance to round-off) and the stationarity check is
    loosened, so each row shows what IPOPT alone returns; the error is against the tightest
    solve (tol = 1e-12 with polishing) of the same n.
    """
    scene = CASES[case].replace(segments=n)
    tight = solve(scene, SolverOptions(tol=1e-12, polish=True))
    rows = []
    for tol in tolerances:
        opts = SolverOptions(tol=tol, polish=False, stationarity_tol=1e6)
        t, r = _solve_time(scene, repeat, opts)
        rows.append(
            {
                "tol": tol,
                "solve_s": t,
                "iterations": r.iterations,
                "gradient_norm": r.gradient_norm,
                "tip_error_mm": float(np.linalg.norm(np.asarray(r.tip[:2]) - np.asarray(tight.tip[:2]))),
                "angle_error_deg": r.total_angle_deg - tight.total_angle_deg,
                "ok": r.ok,
            }
        )
    return rows


def effect_study(n: int = 16, repeat: int = 5) -> list[dict]:
    """Each effect's cost (model size, generation, solve) and the change it makes in the answer.

    All scenes hold the pressure of the Table 2 case (the 90 degree pressure of the base model),
    so a change in the tip is the effect's alone.
    """
    base = CASES["table2"].replace(segments=n)
    pressure = solve(base).pressure
    variants = [
        ("base: air, axial, radial, fibres, 2 N horizontal tip payload", base),
        ("+ gravity (M = 35 g, g = 9.81 m/s^2)", base.replace(gravity=True)),
        ("- fibres", base.replace(fibres=False)),
        ("+ second payload, 1 N vertical at mid-length", base.replace(payloads=base.payloads + (Payload(1.0, 0.0, 0.5),))),
        ("- payload (unloaded)", base.replace(payloads=())),
    ]
    rows = []
    ref = None
    for label, scene in variants:
        scene = scene.replace(pressure=pressure)
        cost = model_cost(n, scene.effects.spec())
        t, r = _solve_time(scene, repeat)
        tip = np.asarray(r.tip[:2])
        if ref is None:
            ref = (tip, r.total_angle_deg)
        rows.append(
            {
                "effect": label,
                "effects": scene.effects.spec(),
                "instructions": cost.instructions,
                "generate_s": cost.generate_s,
                "solve_s": t,
                "tip_mm": [float(v) for v in tip],
                "tip_change_mm": float(np.linalg.norm(tip - ref[0])),
                "angle_change_deg": r.total_angle_deg - ref[1],
                "ok": r.ok,
            }
        )
    return rows


def naive_solve(model, pv: np.ndarray, n: int, theta0: np.ndarray | None = None):
    """What a first script does: SciPy BFGS from theta = 0 (or ``theta0``) with finite-difference gradients."""
    from scipy.optimize import minimize

    return minimize(lambda th: model.energy(th, pv), np.zeros(n) if theta0 is None else theta0, method="BFGS")


def naive_study(ns: Sequence[int] = (3, 8, 16), repeat: int = 5, case: str = "table2") -> list[dict]:
    """SciPy BFGS with numeric gradients on the same generated energy against esba's solve.

    Both solve the same scene at the same pressure; the naive error is the tip distance to
    esba's answer. esba's time is :func:`esba.equilibrium.solve` with its load continuation,
    and without it (one IPOPT solve from the unloaded state).
    """
    rows = []
    for n in ns:
        scene = CASES[case].replace(segments=n)
        t_esba, r = _solve_time(scene, repeat)
        t_single, _ = _solve_time(scene, repeat, SolverOptions(continuation=False))
        model = scene.model()
        pv = model.param_vector(scene.parameters(r.pressure))
        naive_solve(model, pv, n)  # warm-up (SciPy's first call imports and sets up)
        t_naive = median_time(lambda: naive_solve(model, pv, n), repeat)
        res = naive_solve(model, pv, n)
        tip = model.tip(res.x, scene.actuator.L)
        rows.append(
            {
                "n": n,
                "naive_s": t_naive,
                "naive_evaluations": int(res.nfev),
                "naive_success": bool(res.success),
                "naive_tip_error_mm": float(np.linalg.norm(tip[:2] - r.tip[:2])),
                "esba_s": t_esba,
                "esba_single_s": t_single,
                "ratio": t_naive / t_esba,
                "ratio_single": t_naive / t_single,
            }
        )
    return rows


def batch_grid(size: int = 10_000, segments: int = 3) -> tuple[object, dict]:
    """The benchmark batch: Table 1, pressures 0-0.2 MPa x horizontal tip payloads 0-2 N."""
    k = int(round(math.sqrt(size)))
    P, F = np.meshgrid(np.linspace(0.0, 0.2, k), np.linspace(0.0, 2.0, size // k))
    scene = Scene(pressure=0.1, payloads=(Payload(1.0, 90.0),), segments=segments)
    values = scene.parameters(0.1)
    model = scene.model()
    vals = {p: values[p] for p in model.parameters}
    vals["P"], vals["F1"] = P.ravel(), F.ravel()
    return model, vals


def batch_study(size: int = 10_000, segments: int = 3, naive_repeat: int = 5, ipopt_samples: int = 50) -> dict:
    """µs per equilibrium of the batch path (compiled, interpreted) against IPOPT and naive BFGS."""
    from .batch import BatchOptions, compiler, solve_arrays

    model, vals = batch_grid(size, segments)
    size = len(vals["P"])
    out: dict = {"size": size, "segments": segments, "compiler": compiler()}

    def scene_of(i: int) -> Scene:  # for the IPOPT fallback of elements the Newton path cannot solve
        return Scene(pressure=float(vals["P"][i]), payloads=(Payload(float(vals["F1"][i]), 90.0),), segments=segments)

    if compiler() is not None:
        with tempfile.TemporaryDirectory(prefix="esba-bench-cc-") as tmp:  # a cold first call: compiles
            first = solve_arrays(model, vals, options=BatchOptions(compile="always", cache=tmp), scene_of=scene_of)
        warm = [solve_arrays(model, vals, options=BatchOptions(compile="always"), scene_of=scene_of) for _ in range(3)]
        best = sorted(warm, key=lambda r: r.timings["total"])[1]
        out["compiled_first_us"] = first.per_equilibrium_us()
        out["compiled_first_compile_s"] = first.timings["compile"]
        out["compiled_us"] = best.per_equilibrium_us()
        out["compiled_fast_path_us"] = 1e6 * best.timings["fast"] / size
        out["counts"] = best.counts()
        out["backend"] = best.backend
        result = best
    interp = solve_arrays(model, vals, options=BatchOptions(compile="never"), scene_of=scene_of)
    out["interpreted_us"] = interp.per_equilibrium_us()
    if compiler() is None:
        out["counts"] = interp.counts()
        out["backend"] = interp.backend
        result = interp
    # IPOPT (esba.equilibrium.solve) and naive BFGS on a sample of the same batch
    rng = np.random.default_rng(0)
    ipopt_samples = min(ipopt_samples, size)
    out["ipopt_samples"] = ipopt_samples
    sample = rng.choice(size, ipopt_samples, replace=False)
    scenes = [Scene(pressure=float(vals["P"][i]), payloads=(Payload(float(vals["F1"][i]), 90.0),), segments=segments) for i in sample]
    solve(scenes[0])
    t0 = time.perf_counter()
    refs = [solve(s) for s in scenes]
    out["ipopt_us"] = 1e6 * (time.perf_counter() - t0) / len(scenes)
    agree = [float(np.max(np.abs(r.theta - result.theta[i]))) for r, i in zip(refs, sample) if r.ok and result.ok[i]]
    out["max_theta_difference_vs_ipopt"] = max(agree) if agree else None
    if not agree:
        out["max_theta_difference_vs_ipopt_reason"] = "no sampled element was solved ok by both"
    pv = [model.param_vector({**{k: (v if np.ndim(v) == 0 else v[i]) for k, v in vals.items()}}) for i in sample[:naive_repeat]]
    naive_solve(model, pv[0], segments)  # warm-up (SciPy's first call imports and sets up)
    t0 = time.perf_counter()
    for p in pv:
        naive_solve(model, p, segments)
    out["naive_us"] = 1e6 * (time.perf_counter() - t0) / len(pv)
    best_us = out.get("compiled_us", out["interpreted_us"])
    out["speedup_vs_naive"] = out["naive_us"] / best_us
    out["speedup_vs_ipopt"] = out["ipopt_us"] / best_us
    return out


# ---------------------------------------------------------------------------------------------
# the page and its figure


def figure(study: AccuracyStudy):
    """Tip error against n (true and n-vs-(n+1)) and against solve time."""
    from .plots import new_figure

    fig = new_figure(11.0, 4.6)
    ax_n, ax_t = fig.subplots(1, 2)
    for k, case in enumerate(study.reference):
        rows = study.by_case(case)
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
    ax_n.set_xlabel("segments n")
    ax_n.set_title("(a) error against n")
    ax_n.legend(fontsize=7)
    ax_t.set_xlabel("solve time per equilibrium (ms, IPOPT with load continuation)")
    ax_t.set_title("(b) error against solve time (labels: n)")
    ax_t.legend(fontsize=7)
    ref = study.reference[next(iter(study.reference))]
    fig.suptitle(f"Accuracy against time (reference: {ref['method']}; esba bench accuracy)", fontsize=10)
    return fig


def _fmt_s(s: float) -> str:
    if s < 1e-3:
        return f"{s * 1e6:.0f} µs"
    if s < 1.0:
        return f"{s * 1e3:.1f} ms"
    return f"{s:.1f} s"


def render_page(study: AccuracyStudy, tolerance: list[dict], effects: list[dict], naive: list[dict], batch: dict, command: str, figure_rel: str) -> str:
    """The Markdown of ``docs/accuracy-vs-time.md``."""
    lines = [
        "# What accuracy costs in time",
        "",
        f"Every number on this page is printed by `{command}`, which also writes this page and",
        f"[the figure]({figure_rel}). Machine: {platform.machine()}, {platform.python_implementation()} "
        f"{platform.python_version()}, 2 cores shared with other jobs: read times as orders of magnitude and",
        "compare ratios within the page (they come from one run).",
        "",
        f"![accuracy against time]({figure_rel})",
        "",
        "## The reference",
        "",
    ]
    for case, ref in study.reference.items():
        lines.append(
            f"- {CASE_LABELS[case]}: tip ({ref['tip'][0]:.4f}, {ref['tip'][1]:.4f}) mm, total angle "
            f"{ref['total_angle_deg']:.4f} deg; {ref['method']}; the n = {ref['n_max']} solution is "
            f"{ref['n_max_error_mm']:.2g} mm from it."
        )
    nmax = study.reference_n
    worst = max(ref["n_max_error_mm"] for ref in study.reference.values())
    lines += [
        "",
        f"Why Richardson extrapolation rather than n = {nmax} alone: the chain of constant-curvature",
        "segments converges to the continuum as a clean power of 1/n (the observed orders above), so",
        "extrapolating from three successive halvings removes the leading error term. The distance of",
        f"the n = {nmax} solution from the reference (at most {worst:.2g} mm) is what using n = {nmax}",
        f"directly would have added to every error below; it is {'well below' if worst < 0.01 else 'not far below'} the 0.1 mm the study resolves.",
        "",
        "## Tip error against n, and what each n costs",
        "",
        "Error = distance of the tip to the reference; n vs n+1 = distance between the tips of the",
        "n and n+1 segment models (the paper's criterion, Section 4.4.2). Generate = derive and write",
        "the model (cold, SymPy, done once per n and then cached; the n = 1 row also pays for importing",
        "SymPy once); load = build its CasADi Functions from the file (warm); solve = one equilibrium",
        "with IPOPT along the load path (median);",
        "Hessian condition = largest / smallest eigenvalue of the Hessian at the equilibrium.",
        "",
    ]
    for case in study.reference:
        lines += [
            f"### {CASE_LABELS[case]}",
            "",
            "| n | tip x, y (mm) | error (mm) | n vs n+1 (mm) | angle error (deg) | n vs n+1 angle (deg) | generate | load | solve | Hessian condition |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]
        for r in study.by_case(case):
            c = study.costs[r.n]
            flag = "" if r.ok else " (not ok)"
            lines.append(
                f"| {r.n} | {r.tip[0]:.3f}, {r.tip[1]:.3f}{flag} | {r.error_mm:.3g} | {r.next_mm:.3g} | "
                f"{r.angle_error_deg:+.3g} | {r.next_angle_deg:+.3g} | {_fmt_s(c.generate_s)} | {_fmt_s(c.load_s)} | {_fmt_s(r.solve_s)} | {r.condition:.3g} |"
            )
        lines.append("")
        for mm in (1.0, 0.1):
            r = study.first_n_below(case, mm)
            if r is None:
                lines.append(f"- {mm:g} mm: not reached by n = {study.by_case(case)[-1].n}.")
            else:
                c = study.costs[r.n]
                crit = next((q for q in study.by_case(case) if q.next_mm < mm), None)
                crit_txt = f"the n-vs-(n+1) criterion would stop at n = {crit.n}" if crit else "the n-vs-(n+1) criterion never falls below it"
                lines.append(
                    f"- {mm:g} mm: reached at n = {r.n} (error {r.error_mm:.3g} mm): generate {_fmt_s(c.generate_s)} once, "
                    f"load {_fmt_s(c.load_s)}, solve {_fmt_s(r.solve_s)}; {crit_txt}."
                )
        lines.append("")
    n_big = max(study.costs)
    c = study.costs[n_big]
    big = [n for n in sorted(study.costs) if n >= 8]
    if len(big) >= 2:
        slope = np.polyfit(np.log(big), np.log([study.costs[n].instructions["hessian"] for n in big]), 1)[0]
        tslope = np.polyfit(np.log(big), np.log([study.costs[n].generate_s for n in big]), 1)[0]
        growth = f"The Hessian's size grows as n^{slope:.2f} and the cold generation time as n^{tslope:.2f} (fits over n >= 8); "
    else:
        growth = ""
    ratios = [r.error_mm / r.next_mm for r in study.rows if r.n == max(q.n for q in study.rows) and r.next_mm > 0]
    lines += [
        f"{growth}n = {n_big}: {c.instructions['energy']} / {c.instructions['gradient']} / {c.instructions['hessian']} "
        f"SX instructions for U / gradient / Hessian, generated cold in {_fmt_s(c.generate_s)}.",
        "",
        "The paper's n-vs-(n+1) criterion underestimates the true error, and more so as n grows: for an",
        "error falling as C/n^2 the gap between n and n+1 is about 2C/n^3, so the error is about n/2",
        f"gaps. At n = {max(q.n for q in study.rows)} the true error is {min(ratios):.1f} to {max(ratios):.1f} times the gap. Stopping when the",
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
            f"| {r['tol']:.0e} | {_fmt_s(r['solve_s'])} | {r['iterations']} | {r['gradient_norm']:.2g} | {r['tip_error_mm']:.2g} | {r['angle_error_deg']:+.2g} |"
        )
    if tolerance:
        ts = [r["solve_s"] for r in tolerance]
        lines += [
            "",
            f"From tol = {tolerance[0]['tol']:.0e} to {tolerance[-1]['tol']:.0e} the solve time changes by a factor of "
            f"{max(ts) / min(ts):.1f} at most (IPOPT's per-solve overhead dominates at this size), while the error falls from "
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
            f"| {r['effect']} | `{r['effects']}` | {i['energy']} / {i['gradient']} / {i['hessian']} | {_fmt_s(r['generate_s'])} | "
            f"{_fmt_s(r['solve_s'])} | {r['tip_mm'][0]:.2f}, {r['tip_mm'][1]:.2f} | {r['tip_change_mm']:.2f} | {r['angle_change_deg']:+.2f} |"
        )
    lines += [
        "",
        "## The first script against esba",
        "",
        "Naive: `scipy.optimize.minimize(U, zeros(n), method=\"BFGS\")` with finite-difference",
        "gradients, on the same generated energy at the same pressure. esba: `esba.equilibrium.solve`",
        "(IPOPT, exact gradient and Hessian, load continuation, polish, stability check), and the",
        "same without continuation (one IPOPT solve).",
        "",
        "| n | naive | U evaluations | naive says converged | naive tip error (mm) | esba solve | naive / esba | esba, one IPOPT solve | naive / that |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in naive:
        lines.append(
            f"| {r['n']} | {_fmt_s(r['naive_s'])} | {r['naive_evaluations']} | {'yes' if r['naive_success'] else 'no'} | "
            f"{r['naive_tip_error_mm']:.2g} | {_fmt_s(r['esba_s'])} | "
            f"{r['ratio']:.1f}x | {_fmt_s(r['esba_single_s'])} | {r['ratio_single']:.1f}x |"
        )
    wrong = [r for r in naive if r["naive_tip_error_mm"] > 0.01]
    lines += [
        "",
        "One solve at a time, the naive script is not far behind at small n: IPOPT's set-up per call",
        "and esba's load continuation (several IPOPT solves, then the stability check) cost more than",
        "a few dozen energy evaluations. What the naive script lacks is shown by its error column"
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
        "(`esba bench batch` runs this study alone; warm = median of 3 runs). Each element follows the load path with Newton steps",
        "in one CasADi graph mapped over the batch, is verified (stationarity, domain, Hessian",
        "eigenvalues), retried with a denser path or solved by IPOPT when that fails.",
        "",
        "| path | µs per equilibrium |",
        "|---|---|",
    ]
    if "compiled_us" in b:
        lines += [
            f"| batch, compiled C, warm (cached library) | {b['compiled_us']:.1f} |",
            f"| batch, compiled C, first call (compiles in {b['compiled_first_compile_s']:.1f} s) | {b['compiled_first_us']:.1f} |",
        ]
    lines += [
        f"| batch, CasADi interpreter | {b['interpreted_us']:.1f} |",
        f"| esba.equilibrium.solve (IPOPT), one by one | {b['ipopt_us']:.0f} |",
        f"| naive SciPy BFGS, one by one | {b['naive_us']:.0f} |",
        "",
        "- Target: 20 µs or less per equilibrium for n = 3 on 10 000: "
        + (f"{'met' if b.get('compiled_us', 1e9) <= 20 else 'NOT met'} ({b.get('compiled_us', float('nan')):.1f} µs compiled, warm)." if "compiled_us" in b else "no C compiler here: interpreted only."),
        f"- Speed-up: {b['speedup_vs_naive']:.0f}x the naive script, {b['speedup_vs_ipopt']:.0f}x IPOPT one by one.",
        f"- How the elements were answered: {b['counts']}; backend: {b['backend'].split(', cached')[0]}.",
        f"- Largest difference from IPOPT on {50} sampled elements: {b['max_theta_difference_vs_ipopt']:.2g} rad.",
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
        f"  ![Fig. 12]({Path(SWEEP_FIGURES['fig12']).relative_to('docs').as_posix()})",
        "",
        f"- `esba sweep --pressure 0:0.2:41 --payload 0,0.5,1,2 --plot {SWEEP_FIGURES['pressure']}`: total angle",
        "  against pressure for horizontal tip payloads (Table 1). Each curve is the branch traced through",
        "  its first grid point (stable solid, unstable dashed, folds circled); the dots are the grid",
        "  points, each solved along its own load history (inflate, then load). The 2 N curve is an S:",
        "  between its two folds the actuator is bistable, and the grid points switch branch where that",
        "  history starts to reach the upper state (`docs/paths.md` has the folds and the hysteresis).",
        "",
        f"  ![pressure sweep]({Path(SWEEP_FIGURES['pressure']).relative_to('docs').as_posix()})",
        "",
    ]
    return "\n".join(lines)


def write_page(study, tolerance, effects, naive, batch, command: str = "esba bench accuracy", doc: Path | None = None, fig_path: Path | None = None) -> tuple[Path, Path]:
    """Write the page and the figure; return their paths."""
    from .plots import save_figure

    doc = default_page("accuracy-vs-time.md") if doc is None else Path(doc)
    fig_path = figures_dir() / "accuracy-vs-time.png" if fig_path is None else Path(fig_path)
    save_figure(figure(study), fig_path)
    try:
        rel = fig_path.resolve().relative_to(doc.resolve().parent).as_posix()
    except ValueError:
        rel = fig_path.resolve().as_posix()
    doc.write_text(render_page(study, tolerance, effects, naive, batch, command, rel), encoding="utf-8")
    return doc, fig_path

"""Benchmarks: tables of medians over repeated runs, printed by ``esba bench ...``.

Speed targets are met here, not in timed tests. Every comparison runs side by side in one
process, so the ratios hold on a noisy shared machine even when absolute times do not.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

#: Segment counts of the generation benchmark.
GENERATION_NS = (1, 2, 4, 8, 16, 32, 64, 100)
#: The naive SymPy route (expanded POE, sympy.diff) is timed up to this n only: it grows ~n^3.3.
NAIVE_MAX_N = 16
BENCH_EFFECTS = "air,axial,radial,fibres,payload"


def median_time(fn: Callable[[], object], repeat: int) -> float:
    """Median wall time of ``repeat`` calls of ``fn``, in seconds."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def per_call(fn: Callable[[], object], calls: int = 200, repeat: int = 5) -> float:
    """Median over ``repeat`` batches of the mean time of one call, in seconds."""
    return statistics.median(median_time(lambda: [fn() for _ in range(calls)], 1) / calls for _ in range(repeat))


@dataclass(frozen=True)
class GenerationRow:
    n: int
    derive_s: float
    emit_s: float
    total_s: float
    assignments: int
    instructions: dict
    ad_hessian_instructions: int
    naive_s: float | None
    call_us: dict


def _naive_generation(n: int) -> float:
    """The first thing one writes: the POE tip position expanded, then sympy.diff twice."""
    import sympy as sp

    from esba.derive import energy
    from esba.derive import symbols as S
    from esba.derive.effects import EffectSet

    t0 = time.perf_counter()
    th = S.theta(n)
    eff = EffectSet.parse(BENCH_EFFECTS)
    sep = energy.separable(eff.names(), n, "paper")
    U = sum((e.subs(S.t, th[i]) for e in sep.values() for i in range(n)), sp.Integer(0))
    x = y = sp.Integer(0)
    for i in range(n):
        phi = sum(th[:i], sp.Integer(0))
        l = S.L / (n * th[i])
        cx, cy = l * sp.sin(th[i]), l * (1 - sp.cos(th[i]))
        x += sp.cos(phi) * cx - sp.sin(phi) * cy
        y += sp.sin(phi) * cx + sp.cos(phi) * cy
    F, Om, _ = S.payload(1)
    U += y * F * sp.sin(Om) + (S.L - x) * F * sp.cos(Om)
    grad = [sp.diff(U, t) for t in th]
    hess = [[sp.diff(grad[i], th[j]) for j in range(i, n)] for i in range(n)]
    sp.cse([U, *grad, *[h for row in hess for h in row]])
    return time.perf_counter() - t0


def generation(ns: Sequence[int] = GENERATION_NS, repeat: int = 3, naive: bool = True, progress=None) -> list[GenerationRow]:
    """Generation time and size against n, and the per-call time of the generated Functions."""
    import casadi as ca

    from esba.derive.effects import EffectSet
    from esba.derive.emit import _exec_source, generate_source

    eff = EffectSet.parse(BENCH_EFFECTS)
    values = {"L": 135.0, "r1": 8.0, "r2": 3.0, "d": 4.0, "rho": 0.1745, "E": 0.54, "P": 0.12, "F1": 2.0, "Omega1": 1.5708, "s1": 1.0}
    rows = []
    for n in ns:
        runs = []
        for _ in range(repeat if n <= 32 else max(1, min(repeat, 2))):
            t0 = time.perf_counter()
            text, entry = generate_source(n, eff, "paper")
            runs.append((time.perf_counter() - t0, entry))
        total, entry = sorted(runs, key=lambda r: r[0])[len(runs) // 2]
        funs = _exec_source(text)
        th_sym = ca.SX.sym("th", n)
        p = [values[k] for k in eff.parameters()]
        U = funs["energy"](th_sym, *p)[0]
        ad_hessian = ca.Function("H", [th_sym], [ca.hessian(U, th_sym)[0]])
        theta = np.linspace(0.05, 0.6, n)
        calls = {name: per_call(lambda f=funs[name]: f(theta, *p), calls=100 if n < 64 else 20) * 1e6 for name in ("energy", "gradient", "hessian")}
        naive_s = median_time(lambda: _naive_generation(n), 1) if naive and n <= NAIVE_MAX_N else None
        rows.append(
            GenerationRow(
                n=n,
                derive_s=entry["_timing"]["derive_s"],
                emit_s=entry["_timing"]["emit_s"],
                total_s=total,
                assignments=entry["_assignments"],
                instructions=entry["instructions"],
                ad_hessian_instructions=ad_hessian.n_instructions(),
                naive_s=naive_s,
                call_us=calls,
            )
        )
        if progress:
            progress(n)
    return rows


def growth(ns: Sequence[int], times: Sequence[float], n_min: int = 16) -> tuple[float | None, str]:
    """Least-squares slope of log(time) against log(n) for n >= n_min, or None and why not.

    >>> growth([1, 2, 4], [0.1, 0.2, 0.4])
    (None, 'needs at least two n >= 16 (got 0): run with --max-n 32 or more')
    """
    pts = [(np.log(n), np.log(t)) for n, t in zip(ns, times) if n >= n_min and t > 0]
    if len(pts) < 2:
        return None, f"needs at least two n >= {n_min} (got {len(pts)}): run with --max-n {2 * n_min} or more"
    x, y = np.array(pts).T
    return float(np.polyfit(x, y, 1)[0]), ""


def growth_exponent(ns: Sequence[int], times: Sequence[float], n_min: int = 16) -> float | None:
    """The exponent of :func:`growth` (None when there are too few points)."""
    return growth(ns, times, n_min)[0]

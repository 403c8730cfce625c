"""Benchmark of path following: the 2 N pressure path 0 -> 0.3 MPa, traced, against the old IPOPT ramp.

For n = 3 and n = 32, side by side in one run: the path trace (:func:`esba.paths.continuation.trace`: its points
per second and its evaluations of g, H and dg/dlambda), IPOPT warm-started at each lambda value of
the traced path in turn (the load ramp esba used before path following: one IPOPT solve per value),
the naive SciPy script (BFGS with numeric gradients, warm-started at each value) where it finishes
in reasonable time, and the compiled limit: the trace's evaluations times one evaluation of the
same generated g, H and dg/dlambda compiled to C (no Python, no linear algebra).

``esba bench path`` prints the table and writes the ``path`` section of ``docs/performance.md``
(:mod:`esba.pages.performance` renders both).
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import casadi as ca
import numpy as np

from esba.model.scene import Payload, Scene
from esba.paths.continuation import PathProblem, trace
from esba.paths.problem import ghl_function
from esba.solvers.minimise import minimise
from esba.statics.equilibrium import solve

from .accuracy import naive_solve
from .timing import median_time

__all__ = ["PathBenchRow", "path_benchmark", "PATH_NS"]

#: Segment counts of the benchmark.
PATH_NS = (3, 32)
#: The naive BFGS is timed up to this n (it takes minutes beyond).
NAIVE_MAX_N = 8


@dataclass(frozen=True)
class PathBenchRow:
    n: int
    points: int
    folds: int
    evaluations: int
    trace_s: float
    ipopt_s: float
    naive_s: float | None
    compiled_eval_us: float | None

    @property
    def points_per_s(self) -> float:
        return self.points / self.trace_s

    @property
    def floor_s(self) -> float | None:
        return None if self.compiled_eval_us is None else self.evaluations * self.compiled_eval_us * 1e-6


def _compiled_eval_us(problem: PathProblem, theta: np.ndarray, calls: int = 2000) -> float | None:
    """One evaluation of the generated g, H, dg/dlambda compiled to C, microseconds (mapped, so that
    the Python call is paid once for ``calls`` evaluations)."""
    from esba.statics.batch import compile_library, compiler

    cc = compiler()
    if cc is None:
        return None
    fun = ghl_function(problem.model).map("esba_bench_ghl", "serial", calls, [], [])
    with tempfile.TemporaryDirectory(prefix="esba-bench-path-") as tmp:
        lib = Path(tmp) / "esba_bench_ghl.so"
        compile_library([fun], lib, cc)
        compiled = ca.external(fun.name(), str(lib))
        th = np.repeat(theta.reshape(-1, 1), calls, axis=1)
        p = np.repeat(problem.params(0.1).reshape(-1, 1), calls, axis=1)
        dp = np.repeat(problem.dp.reshape(-1, 1), calls, axis=1)
        compiled(th, p, dp)
        return 1e6 * median_time(lambda: compiled(th, p, dp), 5) / calls


def path_benchmark(ns: Sequence[int] = PATH_NS, repeat: int = 5, naive_max_n: int = NAIVE_MAX_N, progress=None) -> list[PathBenchRow]:
    """Time the 2 N horizontal-payload pressure path 0 -> 0.3 MPa for each n (medians of ``repeat``)."""
    rows = []
    for n in ns:
        scene = Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),), segments=int(n))
        start = solve(scene)
        problem = PathProblem.from_scene(scene, "pressure")
        branch = trace(problem, start.theta, 0.0, to=0.3)
        t_trace = median_time(lambda: trace(problem, start.theta, 0.0, to=0.3), repeat)
        model = problem.model

        def ipopt_ramp() -> None:
            theta = start.theta
            for lam in branch.lam:
                lbx = np.full(model.n, problem.lower_bound(lam) * (1 - 1e-6))
                theta = minimise(model, theta, problem.params(lam), lbx, warm=True).theta

        ipopt_ramp()
        t_ipopt = median_time(ipopt_ramp, repeat)
        t_naive = None
        if n <= naive_max_n:

            def naive_ramp() -> None:
                theta = start.theta
                for lam in branch.lam:
                    theta = naive_solve(model, problem.params(lam), model.n, theta).x

            naive_ramp()
            t_naive = median_time(naive_ramp, max(1, repeat // 2))
        rows.append(
            PathBenchRow(
                n=int(n),
                points=len(branch),
                folds=len(branch.folds),
                evaluations=branch.evaluations,
                trace_s=t_trace,
                ipopt_s=t_ipopt,
                naive_s=t_naive,
                compiled_eval_us=_compiled_eval_us(problem, start.theta),
            )
        )
        if progress is not None:
            progress(n)
    return rows

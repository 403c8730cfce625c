"""Benchmark of path following: the 2 N pressure path 0 -> 0.3 MPa, traced, against the old IPOPT ramp.

For n = 3 and n = 100, side by side in one run: the path trace (:func:`esba.paths.continuation.trace`:
microseconds per point and its fold values), IPOPT warm-started at each lambda value of the traced
path in turn (the load ramp esba used before path following: one IPOPT solve per value), the naive
SciPy script (BFGS with numeric gradients, warm-started at each value) where it finishes in
reasonable time, and the compiled limit: one Newton step of the bordered system (the corrector's
kernel, :func:`esba.solvers.newton.bordered_function`) compiled to C and mapped over many calls, so
that it is timed without Python.

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
from esba.solvers.minimise import minimise
from esba.solvers.newton import bordered_function
from esba.statics.equilibrium import solve

from .accuracy import naive_solve
from .timing import median_time

__all__ = ["PathBenchRow", "path_benchmark", "PATH_NS"]

#: Segment counts of the benchmark.
PATH_NS = (3, 100)
#: The naive BFGS is timed up to this n (it takes minutes beyond).
NAIVE_MAX_N = 8


@dataclass(frozen=True)
class PathBenchRow:
    n: int
    points: int
    folds: tuple[float, ...]
    evaluations: int
    trace_s: float
    ipopt_s: float
    naive_s: float | None
    newton_step_us: float | None

    @property
    def points_per_s(self) -> float:
        return self.points / self.trace_s

    @property
    def point_us(self) -> float:
        return 1e6 * self.trace_s / self.points


def _newton_step_us(problem: PathProblem, theta: np.ndarray, calls: int = 2000) -> float | None:
    """One Newton step of the bordered system compiled to C, microseconds (mapped, so that the call
    from Python is paid once for ``calls`` steps)."""
    from esba.solvers.native import compile_library, compiler

    cc = compiler()
    if cc is None:
        return None
    n = problem.n
    fun = bordered_function(problem.model, 1)
    mapped = fun.map("esba_bench_step", "serial", calls, [], [])
    with tempfile.TemporaryDirectory(prefix="esba-bench-path-") as tmp:
        lib = Path(tmp) / "esba_bench_step.so"
        compile_library([mapped], lib, cc, "-O1" if n <= 128 else "-O0")
        compiled = ca.external(mapped.name(), str(lib))
        c = np.zeros(n + 1)
        c[-1] = 1.0
        z = np.concatenate([theta, [0.1], c, [0.1, 1e-9], problem.p0, problem.dp])
        zs = np.repeat(z.reshape(-1, 1), calls, axis=1)
        compiled(zs)
        return 1e6 * median_time(lambda: compiled(zs), 5) / calls


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
                folds=tuple(f.lam for f in branch.folds),
                evaluations=branch.evaluations,
                trace_s=t_trace,
                ipopt_s=t_ipopt,
                naive_s=t_naive,
                newton_step_us=_newton_step_us(problem, start.theta),
            )
        )
        if progress is not None:
            progress(n)
    return rows

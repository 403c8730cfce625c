"""Benchmark of everyday single-scene calls: esba, the naive SciPy script and the compiled limit.

Side by side in one run, medians over repeats (``esba bench solve``, which writes the ``solve``
section of ``docs/performance.md``):

* ``solve()`` of the Table 2 scene (Table 1 at its 90 degree pressure, 2 N horizontal tip payload)
  for n = 3, 16, 64, 100, 128: esba (warm process); the naive script (SciPy BFGS from theta = 0
  with numeric gradients on the same generated energy, one start); and the compiled limit: the
  generated gradient and Hessian in the same Newton load ramp as esba's fast path
  (:mod:`esba.solvers.newton`: 4 load steps), generated to C and compiled, one call, no IPOPT, no Python;
* the pressure for 90 degrees plus the three secant stiffnesses (0.5, 1, 2 N) of ``esba stiffness``,
  against the naive script (the pressure by bisection on BFGS solves, then a BFGS solve per payload);
* the design, IPOPT on the paper's problem and the paper's PSO (30 particles x 50 iterations); the
  naive PSO (1500 naive stiffness evaluations) is estimated from one measured naive evaluation;
* loading a model ready to call (n = 100): executing the generated Python file against esba's
  cached form;
* the command line's wall time (``esba solve --no-plot``, ``esba --help``) in a fresh interpreter.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable, Sequence

import casadi as ca
import numpy as np

from esba.analysis.stiffness import PAPER_FORCES, secant_stiffness
from esba.model.scene import MAIN_JOB, Payload, Scene
from esba.solvers.newton import natural_function
from esba.statics.equilibrium import pressure_for_angle, solve

from .accuracy import naive_solve
from .timing import growth_exponent, median_time

__all__ = ["SOLVE_NS", "solve_benchmark", "solve_table", "solve_section"]

#: Segment counts of the solve rows (the growth is fitted from 16 to 128).
SOLVE_NS = (3, 16, 64, 100, 128)
#: The naive BFGS is timed up to this n (one run beyond 16: it may take seconds).
NAIVE_MAX_N = 128


def _compiled_ramp(scene: Scene, tmp: str) -> Callable[[], object] | None:
    """The compiled limit of one solve: esba's fast-path ramp (unloaded state -> full load), in C."""
    from esba.statics.batch import compile_library, compiler

    cc = compiler()
    if cc is None:
        return None
    model = scene.model()
    fun = natural_function(model)
    lib = Path(tmp) / f"esba_bench_ramp_{model.n}.so"
    compile_library([fun], lib, cc)
    compiled = ca.external(fun.name(), str(lib))
    p = pressure_for_angle(scene)
    p0 = model.param_vector(scene.parameters(p, load_factor=0.0))
    dp = model.param_vector(scene.parameters(p)) - p0
    theta0 = np.full(model.n, math.radians(scene.target_angle_deg) / model.n)
    return lambda: compiled(theta0, p0, dp, 1.0)


def _naive_stiffness(scene: Scene, forces: Sequence[float] = PAPER_FORCES) -> list[float]:
    """What a first script does: bisect the pressure for 90 degrees on BFGS solves of the unloaded
    actuator, then one BFGS solve per payload from theta = 0 (no continuation)."""
    from scipy.optimize import brentq

    unloaded = scene.replace(payloads=(Payload(0.0, 90.0),))
    model = unloaded.model()
    n = scene.segments

    def angle(p: float) -> float:
        return float(np.sum(naive_solve(model, model.param_vector(unloaded.parameters(p)), n).x)) - math.pi / 2

    p = brentq(angle, 0.0, 0.3, xtol=1e-7)
    base = naive_solve(model, model.param_vector(unloaded.parameters(p)), n).x
    y0 = model.tip(base, scene.actuator.L)[1]
    out = []
    for f in forces:
        loaded = unloaded.replace(payloads=(Payload(f, 90.0),))
        x = naive_solve(model, model.param_vector(loaded.parameters(p)), n).x
        out.append(1000.0 * f / (y0 - model.tip(x, scene.actuator.L)[1]))
    return out


def _wall(args: Sequence[str], repeat: int) -> float:
    """Median wall time of ``python -m esba ARGS`` in a fresh interpreter, as after ``pip install``:
    bytecode cached (``PYTHONDONTWRITEBYTECODE`` is dropped and a first run writes it)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    subprocess.run([sys.executable, "-m", "esba", *args], capture_output=True, env=env, cwd=tempfile.gettempdir(), check=False)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "esba", *args], capture_output=True, env=env, cwd=tempfile.gettempdir(), check=False)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def solve_benchmark(ns: Sequence[int] = SOLVE_NS, repeat: int = 11, progress=None) -> dict:
    """Every row of the benchmark (see the module): a dict of rows and the fitted growth."""
    say = progress or (lambda msg: None)
    rows = []
    with tempfile.TemporaryDirectory(prefix="esba-bench-solve-") as tmp:
        for n in ns:
            scene = MAIN_JOB.replace(segments=int(n))
            r = solve(scene)
            esba_s = median_time(lambda: solve(scene), repeat)
            naive_s, naive_result = None, None
            if n <= NAIVE_MAX_N:
                model, pv = r.model, r.model.param_vector(r.parameters)
                res = naive_solve(model, pv, n)
                error = float(np.linalg.norm(model.tip(res.x, scene.actuator.L)[:2] - r.tip[:2]))
                naive_result = {"converged": bool(res.success), "tip_error_mm": error, "iterations": int(res.nit)}
                naive_s = median_time(lambda: naive_solve(model, pv, n), max(1, repeat // 4) if n > 16 else repeat)
            compiled = _compiled_ramp(scene, tmp)
            compiled_s = median_time(compiled, repeat * 10) if compiled is not None else None
            rows.append({"call": f"solve(), Table 2 scene, n = {n}", "n": n, "esba_s": esba_s, "naive_s": naive_s, "compiled_s": compiled_s, "ok": r.ok,
                         "naive_result": naive_result})
            say(f"solve n = {n}")
    scene = Scene(segments=3)

    def stiffness():
        pressure_for_angle(scene)
        return secant_stiffness(scene)

    stiffness()
    st_s = median_time(stiffness, repeat)
    naive_k = _naive_stiffness(scene)
    st_naive = median_time(lambda: _naive_stiffness(scene), 3)
    esba_k = secant_stiffness(scene).stiffness_n_per_m
    error = max(abs(a - b) / abs(b) for a, b in zip(naive_k, esba_k))
    rows.append({"call": "pressure for 90 deg + 3 secant stiffnesses", "n": 3, "esba_s": st_s, "naive_s": st_naive, "compiled_s": None, "ok": True,
                 "naive_k": naive_k, "naive_result": {"converged": error < 1e-3, "stiffness_rel_error": error}})
    say("stiffness")
    try:
        from esba.design.optimise import DesignProblem, optimise_ipopt, optimise_pso
        from esba.solvers.pso import PSOOptions

        problem = DesignProblem()
        optimise_ipopt(problem)
        ipopt_s = median_time(lambda: optimise_ipopt(problem), max(3, repeat // 2))
        pso_s = median_time(lambda: optimise_pso(problem, pso_options=PSOOptions(particles=30, iterations=50, seed=0)), 3)
        rows.append({"call": "design, IPOPT (paper's problem)", "n": 3, "esba_s": ipopt_s, "naive_s": None, "compiled_s": None, "ok": True})
        one = median_time(lambda: _naive_stiffness(scene, (2.0,)), 3)
        rows.append({"call": "design, PSO 30 x 50", "n": 3, "esba_s": pso_s, "naive_s": 1500 * one, "compiled_s": None, "ok": True, "naive_estimated": True})
        say("design")
    except ImportError:  # pragma: no cover - design is part of esba
        pass
    rows.append(_model_load_row(100, repeat))
    say("model load")
    rows.append({"call": "esba solve --no-plot (wall)", "n": 3, "esba_s": _wall(["solve", "--no-plot"], max(3, repeat // 2)), "naive_s": None, "compiled_s": None, "ok": True})
    rows.append({"call": "esba --help (wall)", "n": 0, "esba_s": _wall(["--help"], max(3, repeat // 2)), "naive_s": None, "compiled_s": None, "ok": True})
    say("command line")
    solve_rows = [r for r in rows if r["call"].startswith("solve()") and 16 <= r["n"] <= 128]
    growth = growth_exponent([r["n"] for r in solve_rows], [r["esba_s"] for r in solve_rows]) if len(solve_rows) >= 2 else None
    return {"rows": rows, "growth_16_128": growth}


def _model_load_row(n: int, repeat: int) -> dict:
    """Making a model ready to call: executing its generated Python file, against esba's load_model."""
    from esba.model.generated import _exec_model, _load, load_model

    model = load_model(n)
    exec_s = median_time(lambda: _exec_model(model.path), max(3, repeat // 3))

    times = []
    for _ in range(max(3, repeat // 3)):
        _load.cache_clear()  # freeing the previous copy is not part of loading: outside the clock
        t0 = time.perf_counter()
        load_model(n)
        times.append(time.perf_counter() - t0)
    esba_s = float(np.median(times))
    return {"call": f"a model ready to call, n = {n}", "n": n, "esba_s": esba_s, "naive_s": exec_s, "compiled_s": None, "ok": True, "naive_label": "exec of the model file"}


def _ms(v: float | None) -> str:
    if v is None:
        return "-"
    return f"{1e3 * v:.3f}" if v < 0.01 else f"{1e3 * v:.1f}"


def solve_table(data: dict) -> str:
    """The benchmark as a fixed-width table (milliseconds; ratios = other / esba, same run)."""
    head = f"{'call':<46} {'esba ms':>9} {'naive ms':>10} {'naive/esba':>10} {'compiled ms':>11} {'esba/compiled':>13}"
    lines = [head, "-" * len(head)]
    wrong = []
    for r in data["rows"]:
        naive = _ms(r["naive_s"]) + ("*" if r.get("naive_estimated") else "")
        ratio = "-" if r["naive_s"] is None else f"{r['naive_s'] / r['esba_s']:.0f}x"
        result = r.get("naive_result")
        if result is not None and not result["converged"]:
            naive, ratio = naive + "!", "wrong"
            if "tip_error_mm" in result:
                wrong.append(f"n = {r['n']}: BFGS stops after {result['iterations']} iterations, its tip {result['tip_error_mm']:.1f} mm from esba's")
            else:
                wrong.append(f"{r['call']}: the naive stiffnesses are {100 * result['stiffness_rel_error']:.1f} % off")
        comp_ratio = "-" if r["compiled_s"] is None else f"{r['esba_s'] / r['compiled_s']:.1f}x"
        lines.append(f"{r['call']:<46} {_ms(r['esba_s']):>9} {naive:>10} {ratio:>10} {_ms(r['compiled_s']):>11} {comp_ratio:>13}")
    if data.get("growth_16_128") is not None:
        lines.append(f"\nsolve() time grows as n^{data['growth_16_128']:.2f} from n = 16 to 128 (target: no worse than n^1.5)")
    lines += [
        "naive: SciPy BFGS with numeric gradients on the same generated energy (one start from theta = 0);",
        "  for the model row: executing the generated Python file; * estimated: 1500 naive stiffness evaluations",
        "compiled: esba's fast-path Newton ramp (4 load steps, O(n) structured solves) generated to C, one call",
    ]
    if wrong:
        lines.append("! the naive script returns a wrong answer (no ratio: its time is not that of a solve): " + "; ".join(wrong))
    return "\n".join(lines)


def solve_section(data: dict) -> str:
    """The ``solve`` section of docs/performance.md."""
    import platform

    rows = {r["call"]: r for r in data["rows"]}
    first = next(iter(rows.values()))
    return "\n".join(
        [
            "## Single-scene calls",
            "",
            "What a researcher's everyday calls cost in a warm process, side by side with the first script one",
            "writes (SciPy BFGS with numeric gradients on the same generated energy) and with the compiled limit",
            "of the same generated model (its gradient and Hessian in the same Newton load ramp, compiled to C,",
            "without IPOPT and without Python). Medians over repeated runs on a shared 2-core machine: the",
            "ratios come from one run and hold better than the absolute times.",
            "",
            f"Machine: {platform.machine()}, Python {platform.python_version()}, CasADi {ca.__version__}.",
            "",
            "```",
            solve_table(data),
            "```",
            "",
            "Where the time of `solve()` goes: the load ramp is one call of a CasADi Function (`esba/solvers/newton.py`:",
            "a natural-parameter continuation whose Newton steps are solved in O(n) from the Hessian's structure,",
            "`esba/model/structured.py`), accepted only when every Hessian it met was positive definite and every",
            "step contracted (else the adaptive path trace of `esba/paths/continuation.py` takes over); IPOPT then certifies",
            "the state from there (zero iterations when it is already converged); the result's energy terms,",
            "gradient, Hessian and kinematics come from one more call, its eigenvalues and centre-line from",
            "NumPy with one BLAS thread (`esba/infra/threads.py`).",
            f"At n = {first['n']} the compiled ramp alone takes {_ms(first['compiled_s'])} ms of esba's {_ms(first['esba_s'])} ms.",
        ]
    )

"""Benchmark of everyday single-scene calls: esba, the naive SciPy script and the compiled limit.

Side by side in one run, medians over repeats (``esba bench solve``, which writes the ``solve``
section of ``docs/performance.md`` with :mod:`esba.pages.performance`):

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
* the command line's wall time (``esba solve --no-plot``, ``esba --help``) in a fresh interpreter;
* the default ``solve()`` in the bistable window (P = 0.17 MPa under the 2 N horizontal tip payload,
  n = 3) and ``equilibria()`` at n = 3 and 10 for both scenes, with the targets of issue 31;
* the multistability check of ``solve()`` (:func:`esba.statics.equilibria.check_multistability`) and
  the full search of every equilibrium (:func:`esba.statics.equilibria.equilibria`: the load history,
  the completeness check, the barriers) for n = 3, 16, 100, for the Table 2 scene and in the bistable
  window (P = 0.17 MPa under the 2 N horizontal tip payload), against ``solve()`` without the check.
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

__all__ = ["SOLVE_NS", "MULTISTABILITY_NS", "EQUILIBRIA_NS", "TARGETS", "solve_benchmark", "multistability_rows", "warm"]

#: Segment counts of the solve rows (the growth is fitted from 16 to 128).
SOLVE_NS = (3, 16, 64, 100, 128)
#: Segment counts of the multistability rows.
MULTISTABILITY_NS = (3, 16, 100)
#: The naive BFGS is timed up to this n (one run beyond 16: it may take seconds).
NAIVE_MAX_N = 128
#: Segment counts of the equilibria() rows of the main table.
EQUILIBRIA_NS = (3, 10)
#: The bistable window: P = 0.17 MPa under the 2 N horizontal tip payload.
WINDOW = Scene(pressure=0.17, payloads=(Payload(2.0, 90.0),))
WINDOW_LABEL = "P = 0.17 MPa, 2 N"
#: The targets of issue 31 (seconds, on a quiet machine, where the naive script takes
#: :data:`QUIET_NAIVE_S` at n = 3): the call of a row of the main table, and its target.
TARGETS = (
    ("solve(), Table 2 scene, n = 3", 1e-3),
    (f"solve(), {WINDOW_LABEL} (multistable), n = 3", 1.5e-3),
    ("equilibria(), Table 2 scene, n = 3", 20e-3),
    (f"equilibria(), {WINDOW_LABEL}, n = 3", 20e-3),
    ("equilibria(), Table 2 scene, n = 10", 200e-3),
    (f"equilibria(), {WINDOW_LABEL}, n = 10", 200e-3),
)
#: The naive script's time at n = 3 on a quiet machine when the targets were set (issue 31).
QUIET_NAIVE_S = 4.53e-3


def warm(fn: Callable[[], object], calls: int) -> None:
    """Call ``fn`` ``calls`` times: a warm process, whose kernels have been compiled (or loaded from
    the cache) once they have run :data:`esba.solvers.native.HOT_RUNS` times."""
    for _ in range(calls):
        fn()


def _warm_calls(n: int) -> int:
    """Calls of solve() that make its kernels hot (compiled up to SOLVE_COMPILE_MAX_N segments)."""
    from esba.solvers.native import HOT_RUNS
    from esba.solvers.newton import SOLVE_COMPILE_MAX_N

    return HOT_RUNS + 10 if n <= SOLVE_COMPILE_MAX_N else 1


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
            warm(lambda: solve(scene), _warm_calls(n))
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
        rows.append(_window_row(repeat))
        say("solve, multistable")
        rows += _equilibria_rows(repeat)
        say("equilibria")
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
    multistability = multistability_rows(repeat=repeat, progress=say)
    solve_rows = [r for r in rows if r["call"].startswith("solve()") and 16 <= r["n"] <= 128]
    growth = growth_exponent([r["n"] for r in solve_rows], [r["esba_s"] for r in solve_rows]) if len(solve_rows) >= 2 else None
    naive3 = next((r["naive_s"] for r in rows if r["call"] == "solve(), Table 2 scene, n = 3"), None)
    load = None if naive3 is None else naive3 / QUIET_NAIVE_S
    by_call = {r["call"]: r for r in rows}
    targets = [{"call": call, "target_s": target, "esba_s": by_call[call]["esba_s"], "load": load} for call, target in TARGETS if call in by_call]
    return {"rows": rows, "growth_16_128": growth, "multistability": multistability, "targets": targets}


def _window_row(repeat: int) -> dict:
    """The default solve() in the bistable window (n = 3, the check finds the other stable state), and
    the naive script on the same scene."""
    r = solve(WINDOW)
    warm(lambda: solve(WINDOW), _warm_calls(3))
    esba_s = median_time(lambda: solve(WINDOW), repeat)
    model, pv = r.model, r.model.param_vector(r.parameters)
    res = naive_solve(model, pv, 3)
    error = float(np.linalg.norm(model.tip(res.x, WINDOW.actuator.L)[:2] - r.tip[:2]))
    naive_s = median_time(lambda: naive_solve(model, pv, 3), repeat)
    return {"call": f"solve(), {WINDOW_LABEL} (multistable), n = 3", "n": 3, "esba_s": esba_s, "naive_s": naive_s, "compiled_s": None, "ok": r.ok and bool(r.multistable),
            "naive_result": {"converged": bool(res.success) and error < 1e-3, "tip_error_mm": error, "iterations": int(res.nit)}}


def _equilibria_rows(repeat: int) -> list[dict]:
    """equilibria() of the Table 2 scene and of the bistable window at EQUILIBRIA_NS (warm: its
    kernels compiled once they have run HOT_RUNS times)."""
    from esba.statics.equilibria import equilibria

    out = []
    for label, base in (("Table 2 scene", MAIN_JOB), (WINDOW_LABEL, WINDOW)):
        for n in EQUILIBRIA_NS:
            scene = base.replace(segments=int(n))
            res = equilibria(scene)
            warm(lambda: equilibria(scene), 3)
            esba_s = median_time(lambda: equilibria(scene), max(3, repeat // 2))
            out.append({"call": f"equilibria(), {label}, n = {n}", "n": int(n), "esba_s": esba_s, "naive_s": None, "compiled_s": None, "ok": bool(res.complete),
                        "states": len(res.states)})
    return out


def multistability_rows(ns: Sequence[int] = MULTISTABILITY_NS, repeat: int = 11, progress=None) -> list[dict]:
    """Per scene and n: ``solve()`` without the check, its multistability check alone, and
    ``equilibria()`` (medians, s), for the Table 2 scene (one stable state; solve() on its fast path)
    and in the bistable window (P = 0.17 MPa under the 2 N horizontal tip payload)."""
    from esba.statics.equilibria import AUTO_MAX_SEGMENTS, check_multistability, equilibria
    from esba.statics.equilibrium import SolverOptions

    say = progress or (lambda msg: None)
    out = []
    never = SolverOptions(multistability="never")
    scenes = (("Table 2 scene", MAIN_JOB), (WINDOW_LABEL, WINDOW))
    for (label, base), n in ((sc, n) for sc in scenes for n in ns):
        scene = base.replace(segments=int(n))
        r = solve(scene, never)
        warm(lambda: solve(scene, never), _warm_calls(n))
        model = r.model

        def check():
            return check_multistability(scene, model, r.pressure, r.theta, "inflate-then-load", "")

        found = check()
        full = equilibria(scene)
        if _warm_calls(n) > 1:  # the check's and the search's kernels hot, as solve()'s are
            warm(check, _warm_calls(n) // 10)
            warm(lambda: equilibria(scene), 3)
        out.append(
            {
                "scene": label,
                "n": int(n),
                "solve_s": median_time(lambda: solve(scene, never), repeat),
                "check_s": median_time(check, repeat),
                "equilibria_s": median_time(lambda: equilibria(scene), max(1, repeat // 4)),
                "stable_found": len(found.stable),
                "states": len(full.states),
                "complete": full.complete,
                "by_default": int(n) <= AUTO_MAX_SEGMENTS,
            }
        )
        say(f"multistability, {label}, n = {n}")
    return out


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

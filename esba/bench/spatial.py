"""``esba bench 3d``: what the 3-D model costs against the planar one, in the same run.

Generation of the 3-D model (n = 3, 10, 30), a full 3-D solve at n = 3 (load history + IPOPT
certificate) against the planar ``solve`` of the same scene and a naive SciPy BFGS on the 3-D
energy, a warm 3-D solve at n = 30 (90 unknowns; :func:`esba.statics.spatial.warm3d`), and the cost per point of following the
3-D equilibria in the pressure at n = 3 (:func:`esba.statics.spatial.follow3d`: natural continuation,
one call of a compiled four-step Newton Function a point, checked) beside the arclength tracer's
(:class:`esba.statics.spatial_paths.SpatialPathProblem` on the planar engine's
:func:`esba.paths.continuation.trace`: pseudo-arclength steps, stability by the Hessian's pivots,
folds and branch points watched) over the same pressures. The compiled limit of the same generated
3-D model is one call of the 3-D C export's equilibrium (:mod:`esba.export.spatial`: its load ramp of
Newton steps on the model's gradient and Hessian, built ``-O2`` as a shared library), on the same
scene, with its largest difference from esba's state; where no C compiler is found it says so.
"""

from __future__ import annotations

import os
import time
from typing import Callable

import numpy as np

from .timing import median_time, per_call

__all__ = ["spatial_benchmark", "GENERATION_NS_3D"]

GENERATION_NS_3D = (3, 10, 30)
#: The sideways and torsional stiffnesses of the benchmark scene (N*mm^2): stiff enough that the
#: Table 2 state is stable in 3-D.
SECTION = {"EI_side": 4e5, "GJ": 1e6, "Beta1": 0.0}
#: The arclength tracer's step (scaled arclength; the pressure span is its scale): about 60 points.
ARC_DS = 0.025


def spatial_benchmark(repeat: int = 3, progress: Callable[[str], None] | None = None) -> dict:
    from scipy.optimize import minimize

    from esba.derive.effects3d import Effects3D
    from esba.derive.emit3d import generate_source3d
    from esba.model.scene import MAIN_JOB
    from esba.model.spatial import load_model3d
    from esba.statics.equilibrium import solve
    from esba.paths.continuation import PathOptions
    from esba.paths.continuation import trace as arclength_trace
    from esba.statics.spatial import follow3d, solve3d, warm3d
    from esba.statics.spatial_paths import SpatialPathProblem

    say = progress or (lambda msg: None)
    gen = []
    for n in GENERATION_NS_3D:
        t0 = time.perf_counter()
        _, entry = generate_source3d(n, Effects3D.parse("air,axial,radial,fibres,payload"))
        gen.append({"n": n, "seconds": time.perf_counter() - t0, "assignments": entry["_assignments"], "hessian": entry["instructions"]["hessian"]})
        say(f"generation n = {n}")
    planar = solve(MAIN_JOB)
    values = {**MAIN_JOB.parameters(planar.pressure), **SECTION}
    m3 = load_model3d(3)
    solve3d(m3, values)  # builds the IPOPT solver once
    t3 = median_time(lambda: solve3d(m3, values), repeat)
    tp = median_time(lambda: solve(MAIN_JOB), repeat)
    lb = np.concatenate([np.full(3, -0.7), np.full(6, -np.inf)])
    naive_q = None

    def naive():
        nonlocal naive_q
        res = minimize(lambda q: m3.energy(q, values), np.zeros(9), method="L-BFGS-B", bounds=[(b if np.isfinite(b) else None, None) for b in lb])
        naive_q = res.x

    tn = median_time(naive, repeat)
    naive_err = float(np.abs(naive_q[:3] - planar.theta).max())
    compiled = _compiled3d(values, solve3d(m3, values).q, repeat)
    say("solve n = 3")
    m30 = load_model3d(30)
    q30 = solve3d(m30, values, certify=False).q
    warm3d(m30, values, q30 + 1e-6)  # builds the Newton kernel once
    tw = median_time(lambda: warm3d(m30, values, q30 + 1e-6), max(repeat, 5))
    say("warm n = 30")
    vals = {**MAIN_JOB.parameters(0.16), **SECTION}
    q = solve3d(m3, vals, certify=False).q
    pressures = np.linspace(0.16, 0.173, 41)[1:]

    follow3d(m3, vals, "P", pressures, q)  # builds the Newton kernel once

    def trace():
        follow3d(m3, vals, "P", pressures, q)

    tt = median_time(trace, repeat)
    problem = SpatialPathProblem.from_values(m3, vals, "pressure")
    options = PathOptions(ds=ARC_DS, ds_max=ARC_DS)
    arc = {}

    def arclength():
        arc["branch"] = arclength_trace(problem, q, float(vals["P"]), to=float(pressures[-1]), options=options)

    problem.compile_kernels()  # as a long trace would (they are compiled after HOT_RUNS runs)
    arclength()
    ta = median_time(arclength, repeat)
    branch = arc["branch"]
    say("continuation n = 3")
    return {
        "generation": gen,
        "solve3d_ms": t3 * 1e3, "planar_ms": tp * 1e3, "naive_ms": tn * 1e3, "naive_error": naive_err,
        **compiled,
        "warm30_ms": tw * 1e3,
        "point_us": tt / len(pressures) * 1e6, "points": len(pressures),
        "arc_point_us": ta / len(branch) * 1e6, "arc_points": len(branch), "arc_stopped": branch.stopped,
        "load_average": _load_average(), "cpus": os.cpu_count() or 0,
    }


def _compiled3d(values: dict, q: np.ndarray, repeat: int) -> dict:
    """The compiled limit: the 3-D C export's equilibrium at n = 3 on ``values`` (ms a call, the
    largest difference from esba's state ``q`` in rad, its status), or why there is none."""
    import tempfile
    from pathlib import Path

    from esba.export import build
    from esba.export.binding3d import Library3D, loads3d
    from esba.export.spatial import ExportSpec3D, export_c3d

    cc = build.compiler()
    if cc is None:
        return {"compiled_ms": None, "compiled_note": "no C compiler ($CC, gcc, cc) was found"}
    spec = ExportSpec3D(3)
    with tempfile.TemporaryDirectory(prefix="esba-bench-3d-") as tmp:
        export = export_c3d(spec, Path(tmp) / "n3")
        lib = Library3D(build.compile_shared(export.source, out=Path(tmp) / "n3.so", cc=cc, opt="-O2"), spec)
        params = {"M": 0.0, **values}
        payload = (values["F1"], values["Omega1"], values.get("Beta1", 0.0), values["s1"])
        loads = loads3d(values["P"], [payload], g=0.0)  # the 3-D model of the benchmark has no gravity
        result = lib.equilibrium(params, loads)
        seconds = per_call(lambda: lib.equilibrium(params, loads), calls=200, repeat=max(repeat, 5))
    return {"compiled_ms": seconds * 1e3, "compiled_error": float(np.abs(result.q - q).max()), "compiled_status": result.status_name}


def _load_average() -> float | None:
    """The machine's 1-minute load average at the end of the run (None where the OS has none)."""
    try:
        return float(os.getloadavg()[0])
    except (AttributeError, OSError):
        return None

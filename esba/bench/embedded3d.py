"""The 3-D export in ``esba bench embedded`` (its section of ``docs/embedded.md``).

For n = 3 and 8: microseconds per 3-D equilibrium in C (the export built ``-O2`` as a shared
library; each scene solved ``repeat`` times by one call of ``{name}_equilibrium_batch``, timed
around the call on record arrays in the C layout (no Python per element), median over scenes), the same scenes by Python's 3-D solve
(:func:`esba.statics.spatial.solve3d`, certified by IPOPT as it always is), the largest difference
of their states, the object's code size (``size``, host ``-O2``), the work memory, and the sizes for
a Cortex-M4 (``arm-none-eabi-gcc ... -Os``) in double and single precision where that compiler is
installed (else it says so). It returns data; :mod:`esba.pages.embedded` renders it.
"""

from __future__ import annotations

import math
import statistics
import tempfile
import time
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from esba.export import build
from esba.export.binding3d import STATUS3D, Library3D, loads3d
from esba.export.spatial import ExportSpec3D, export_c3d
from esba.model.spatial import load_model3d
from esba.statics.spatial import solve3d

from . import cortexm4

__all__ = ["EMBEDDED3D_NS", "SCENES3D", "embedded3d_benchmark"]

#: Segment counts of the 3-D rows.
EMBEDDED3D_NS = (3, 8)
#: 3-D equilibria timed: (pressure MPa, payload N, in-plane direction deg, out-of-plane deg, point),
#: Table 1 with its section (esba.model.section).
SCENES3D = ((0.12, 1.0, 90.0, 30.0, 1.0), (0.05, 0.5, 90.0, -45.0, 1.0), (0.2, 2.0, 45.0, 10.0, 0.8), (0.12, 1.0, 0.0, 60.0, 0.6))
TABLE1 = {"L": 135.0, "r1": 8.0, "r2": 3.0, "d": 4.0, "rho": math.radians(10.0), "E": 0.54, "M": 0.035}


def _m4_times(exports: dict, n: int, workdir: Path, arm: str, qemu: str, precisions: Sequence[str], params: dict, cc: str) -> dict:
    """Instructions and estimated cycles per 3-D equilibrium on a Cortex-M4 (:mod:`esba.bench.cortexm4`)
    for :data:`SCENES3D`, each run's status and state against the host's build of the same precision."""
    scenes = [{"pressure": p, "payload[0].force": f, "payload[0].angle": math.radians(om), "payload[0].out_of_plane": math.radians(be),
               "payload[0].at": s} for p, f, om, be, s in SCENES3D]
    out = {}
    for prec in precisions:
        chosen = scenes if prec == "float" else scenes[:1]  # double: ~40x the instructions (software floating point)
        sub = workdir / f"m4-n{n}-{prec}"
        sub.mkdir(exist_ok=True)
        e = exports[prec]
        counts, results = cortexm4.m4_equilibrium_counts(e.folder, e.spec.name, n, chosen, "q", 3 * n, sub, arm, qemu)
        lib = Library3D(build.compile_shared(e.source, out=sub / "host.so", cc=cc, opt="-O2"), e.spec)
        host = lib.batch_records(lib.as_records("params", [params] * len(chosen)),
                                 lib.as_records("loads", [loads3d(p, [(f, math.radians(om), math.radians(be), s)]) for p, f, om, be, s in SCENES3D[: len(chosen)]]))
        out[prec] = cortexm4.summary(counts, results, [(int(r["status"]), np.asarray(r["q"], dtype=float)) for r in host])
    return out


def embedded3d_benchmark(ns: Sequence[int] = EMBEDDED3D_NS, repeat: int = 11, progress: Callable[[str], None] | None = None, m4_time: bool = True) -> dict:
    say = progress or (lambda _msg: None)
    cc = build.compiler()
    if cc is None:
        raise build.BuildError("esba bench embedded needs a C compiler ($CC, gcc, cc): none was found")
    arm = build.arm_compiler()
    qemu = cortexm4.qemu_arm() if m4_time else None
    rows = []
    with tempfile.TemporaryDirectory(prefix="esba-bench-embedded3d-") as tmp:
        work = Path(tmp)
        for n in ns:
            spec = ExportSpec3D(n)
            export = export_c3d(spec, work / f"n{n}")
            say(f"3-D n = {n}: exported; compiling")
            lib = Library3D(build.compile_shared(export.source, out=work / f"n{n}.so", cc=cc, opt="-O2"), spec)
            section = spec.section_values()
            params = {**TABLE1, **section}
            model = load_model3d(n)
            c_us, py_us, gaps, statuses = [], [], [], []
            for p, f, om, be, s in SCENES3D:
                loads = lib.as_records("loads", [loads3d(p, [(f, math.radians(om), math.radians(be), s)])])
                one = lib.as_records("params", [params])
                lib.batch_records(one, loads)  # warm
                many_params, many_loads = np.repeat(one, repeat), np.repeat(loads, repeat)
                t0 = time.perf_counter()
                results = lib.batch_records(many_params, many_loads)
                c_us.append(1e6 * (time.perf_counter() - t0) / repeat)
                r = results[0]
                statuses.append(STATUS3D[r["status"]] if 0 <= r["status"] < len(STATUS3D) else f"unknown({r['status']})")
                values = {**params, "P": p, "F1": f, "Omega1": math.radians(om), "Beta1": math.radians(be), "s1": s}
                values = {k: values[k] for k in model.parameters}
                solve3d(model, values)
                times = []
                for _ in range(max(3, repeat // 3)):
                    t0 = time.perf_counter()
                    py = solve3d(model, values)
                    times.append(time.perf_counter() - t0)
                py_us.append(1e6 * statistics.median(times))
                gaps.append(float(np.abs(py.q - r["q"]).max()))
            obj = work / f"n{n}.o"
            build.run_compiler(cc, ["-std=c99", "-O2", "-c", str(export.source), "-o", str(obj)])
            size = build.object_size(obj)
            arm_sizes, m4_time = {}, None
            if arm is not None:
                exports = {"double": export, "float": export_c3d(ExportSpec3D(n, precision="float"), work / f"n{n}-float")}
                for prec, e in exports.items():
                    o = work / f"n{n}-{prec}-m4.o"
                    build.run_compiler(arm, ["-std=c99", *build.CORTEX_M4, "-c", str(e.source), "-o", str(o)])
                    arm_sizes[prec] = build.object_size(o, tool="arm-none-eabi-size")
                if qemu is not None:
                    say(f"3-D n = {n}: the Cortex-M4's instructions (qemu-arm)")
                    m4_time = _m4_times(exports, n, work, arm, qemu, ("float", "double") if n == ns[0] else ("float",), params, cc)
            rows.append({
                "n": n, "name": spec.name, "c_us": statistics.median(c_us), "python_us": statistics.median(py_us),
                "speedup": statistics.median(py_us) / statistics.median(c_us), "max_q_difference": max(gaps), "statuses": statuses,
                "text": size["text"], "data": size["data"], "bss": size["bss"], "work_bytes": lib.work_bytes, "cortex_m4": arm_sizes,
                "cortex_m4_time": m4_time,
                "section": section,
            })
            say(f"3-D n = {n}: {rows[-1]['c_us']:.0f} us per equilibrium in C")
    return {"rows": rows, "scenes": [list(s) for s in SCENES3D], "repeat": repeat, "arm": arm is not None}

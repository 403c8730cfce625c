"""Benchmark of the exported C (``esba bench embedded``, which writes ``docs/embedded.md``).

For n = 3, 8 and 16, in one run:

* microseconds per equilibrium and per inverse (the pressure for a total angle under payloads) in
  C, timed inside a compiled driver (``clock_gettime`` around each call, median over repeats), and
  the same calls in Python (:func:`esba.statics.equilibrium.solve`, and
  :func:`esba.analysis.stiffness.pressure_for_target`, what ``esba pressure --total-angle`` runs),
  median over repeats, and their ratio; with the largest difference of the answers, so that the
  two are seen to do the same work;
* code size (``size`` of the object, host ``-O2``) and stack use (``-fstack-usage``: the deepest
  chain of frames from each entry point, by ``-fcallgraph-info``), the work memory the caller
  provides (``sizeof``), and the same sizes for a Cortex-M4 (``arm-none-eabi-gcc -mcpu=cortex-m4
  -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16 -Os``) in double and single precision where that
  compiler is installed (else it says so);
* the Cortex-M4's instructions per equilibrium and the time they take, estimated from its
  technical reference manual, where ``qemu-arm`` can run the M4 build (:mod:`esba.bench.cortexm4`:
  single precision on every equilibrium scene, double on the first; ``m4_time=False`` skips it);
* the accuracy of the single-precision build (``--float``) against double on random scenes;
* what the demo, built by ``make`` from the export alone, prints for the README's example.

It returns data; :mod:`esba.pages.embedded` renders the page.
"""

from __future__ import annotations

import math
import platform
import statistics
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Callable, Sequence

import casadi as ca
import numpy as np

from esba.analysis.stiffness import pressure_for_target
from esba.export import build
from esba.export.ccode import ExportSpec
from esba.export.writer import export_c
from esba.model.scene import Payload, Scene
from esba.statics.equilibrium import solve

from . import cortexm4
from .timing import median_time

__all__ = ["EMBEDDED_NS", "EQUILIBRIUM_SCENES", "INVERSE_SCENES", "DRIVER", "embedded_benchmark", "random_scenes", "run_driver"]

#: Segment counts of the benchmark.
EMBEDDED_NS = (3, 8, 16)
#: Equilibria timed: (pressure MPa, payload N, its direction deg from the vertical, its point).
#: The last snaps on its load path (a compressive payload on a nearly straight actuator).
EQUILIBRIUM_SCENES = ((0.12, 2.0, 90.0, 1.0), (0.05, 0.5, 90.0, 1.0), (0.2, 2.0, 90.0, 1.0), (0.12, 1.0, 0.0, 0.6), (0.15, 3.0, 150.0, 1.0), (0.005, 5.0, 180.0, 0.9))
#: Inverses timed: (total angle deg, payload N, direction deg, point).
INVERSE_SCENES = ((90.0, 2.0, 90.0, 1.0), (45.0, 0.5, 90.0, 1.0), (135.0, 1.0, 0.0, 0.6), (60.0, 1.5, 45.0, 0.8))
#: Random scenes of the float-vs-double comparison, per n.
ACCURACY_SCENES = 100
#: The largest pressure the inverse may use (as pressure_for_target's default), MPa.
MAX_PRESSURE = 10.0

#: The timing driver: reads the repeat count, then lines "e P F angle_deg at" (an equilibrium) or
#: "i target_deg F angle_deg at" (an inverse); prints per line the median time of the calls (ns),
#: the status, the pressure, the total angle, the tip, the snaps (count, load factor, total angles
#: before and after) and theta (rad, 17 digits).
DRIVER = r"""#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "{{NAME}}.h"

#define PI 3.14159265358979323846
#define MAX_REPEAT 1001

static double now_ns(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e9 + (double)t.tv_nsec;
}

static int by_value(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(void) {
    static {{NAME}}_work work;
    static double times[MAX_REPEAT];
    {{NAME}}_params params;
    {{NAME}}_loads loads;
    {{NAME}}_result r;
    char kind;
    double v, f, angle, at;
    int repeat, i, k, status = 0;
    {{NAME}}_default_params(&params);
    if (scanf("%d", &repeat) != 1 || repeat < 1 || repeat > MAX_REPEAT) return 2;
    printf("work_bytes %lu\n", {{NAME}}_work_bytes());
    while (scanf(" %c %lf %lf %lf %lf", &kind, &v, &f, &angle, &at) == 5) {
        {{NAME}}_default_loads(&loads);
        loads.payload[0].force = ({{NAME}}_real)f;
        loads.payload[0].angle = ({{NAME}}_real)(angle * PI / 180.0);
        loads.payload[0].at = ({{NAME}}_real)at;
        for (i = 0; i < repeat; ++i) {
            double t0 = now_ns();
            if (kind == 'e') {
                loads.pressure = ({{NAME}}_real)v;
                status = {{NAME}}_equilibrium({{N}}, &params, &loads, NULL, &r, &work);
            } else {
                status = {{NAME}}_pressure_for_angle({{N}}, &params, &loads, ({{NAME}}_real)(v * PI / 180.0), ({{NAME}}_real){{MAX_PRESSURE}}, NULL, &r, &work);
            }
            times[i] = now_ns() - t0;
        }
        qsort(times, (size_t)repeat, sizeof(double), by_value);
        printf("%c %.1f %d %.17g %.17g %.17g %.17g %d %.17g %.17g %.17g", kind, times[repeat / 2], status, (double)r.pressure, (double)r.total_angle,
               (double)r.tip[0], (double)r.tip[1], r.snaps, (double)r.snap_at, (double)r.snap_from, (double)r.snap_to);
        for (k = 0; k < {{N}}; ++k) printf(" %.17g", (double)r.theta[k]);
        printf("\n");
    }
    return 0;
}
"""


def random_scenes(count: int, seed: int) -> list[tuple[str, float, float, float, float]]:
    """Driver lines: equilibria (a third near a compressive snap) and inverses, reproducibly."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        if i % 3 == 0:
            out.append(("e", rng.uniform(0.001, 0.02), rng.uniform(2.5, 8.0), rng.uniform(176.0, 184.0), rng.uniform(0.7, 1.0)))
        elif i % 3 == 1:
            out.append(("e", rng.uniform(0.0, 0.3), rng.uniform(0.0, 4.0), rng.uniform(0.0, 180.0), rng.uniform(0.3, 1.0)))
        else:
            out.append(("i", rng.uniform(-30.0, 250.0), rng.uniform(0.0, 3.0), rng.uniform(0.0, 180.0), rng.uniform(0.3, 1.0)))
    return out


def _build_driver(export, cc: str, workdir: Path) -> Path:
    spec = export.spec
    driver = workdir / f"bench_{spec.name}_{spec.precision}.c"
    text = DRIVER.replace("{{NAME}}", spec.name).replace("{{N}}", str(spec.n)).replace("{{MAX_PRESSURE}}", repr(MAX_PRESSURE))
    driver.write_text(text, encoding="utf-8")
    exe = workdir / f"bench_{spec.name}_{spec.precision}"
    build.run_compiler(cc, ["-std=c99", "-O2", f"-I{export.folder}", str(driver), str(export.source), "-o", str(exe), "-lm"])
    return exe


def run_driver(exe: Path, lines: Sequence[tuple], repeat: int) -> tuple[int, list[dict]]:
    """Run a driver on ``lines``: (its work bytes, one dict per line)."""
    text = f"{repeat}\n" + "".join(f"{k} {v!r} {f!r} {a!r} {s!r}\n" for k, v, f, a, s in lines)
    proc = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True)
    out = proc.stdout.strip().splitlines()
    work = int(out[0].split()[1])
    rows = []
    for line in out[1:]:
        w = line.split()
        rows.append({"kind": w[0], "ns": float(w[1]), "status": int(w[2]), "pressure": float(w[3]), "total_angle": float(w[4]),
                     "tip": [float(w[5]), float(w[6])], "snaps": int(w[7]), "snap_at": float(w[8]), "snap_from": float(w[9]), "snap_to": float(w[10]),
                     "theta": np.array([float(x) for x in w[11:]])})
    return work, rows


def _python_calls(n: int, repeat: int) -> tuple[list[dict], list[dict]]:
    eq, inv = [], []
    for p, f, a, s in EQUILIBRIUM_SCENES:
        scene = Scene(pressure=p, payloads=(Payload(f, a, s),), segments=n)
        r = solve(scene)  # warm: the model loaded, its Functions built
        eq.append({"s": median_time(lambda: solve(scene), repeat), "theta": r.theta, "ok": r.ok, "snapped": bool(r.jumps)})
    for t, f, a, s in INVERSE_SCENES:
        scene = Scene(payloads=(Payload(f, a, s),), segments=n)
        r = pressure_for_target(scene, total_angle_deg=t)
        inv.append({"s": median_time(lambda: pressure_for_target(scene, total_angle_deg=t), repeat), "pressure": r.pressure, "ok": r.ok,
                    "theta": r.equilibrium.theta})
    return eq, inv


def _sizes(export, workdir: Path, cc: str | None, flags: Sequence[str], tool: str) -> dict:
    """Object size and stack use of an export's source built with ``cc flags`` (None: no compiler)."""
    if cc is None:
        return {}
    sub = workdir / f"{export.spec.precision}-{Path(cc).name}"
    sub.mkdir(exist_ok=True)
    stack = build.stack_use(export.source, cc, flags, sub)
    obj = sub / (export.source.stem + ".o")
    name = export.spec.name
    return {
        "size": build.object_size(obj, tool),
        "stack_equilibrium": stack.deepest.get(f"{name}_equilibrium"),
        "stack_inverse": stack.deepest.get(f"{name}_pressure_for_angle"),
        "largest_frame": max(stack.frames.values()),
        "dynamic_frames": list(stack.dynamic),
    }


def _make_demo(export) -> dict:
    """Build the demo with ``make`` in the export's folder and run the README's example and the inverse's."""
    subprocess.run(["make", "-s", "demo"], cwd=export.folder, check=True, capture_output=True, text=True)
    out = subprocess.run(["./demo"], cwd=export.folder, input=export.example_input + "\n", capture_output=True, text=True, check=True).stdout.strip()
    inverse_input = "90 2 90"
    inverse = subprocess.run(["./demo", "-i"], cwd=export.folder, input=inverse_input + "\n", capture_output=True, text=True, check=True).stdout.strip()
    return {"input": export.example_input, "output": out, "expected": export.example_output, "inverse_input": inverse_input, "inverse_output": inverse}


def _accuracy(double_exe: Path, float_exe: Path, n: int) -> dict:
    lines = random_scenes(ACCURACY_SCENES, seed=19 + n)
    _, d = run_driver(double_exe, lines, 1)
    _, f = run_driver(float_exe, lines, 1)
    same = [a["status"] == b["status"] for a, b in zip(d, f)]
    both_ok = [i for i, (a, b) in enumerate(zip(d, f)) if a["status"] in (0, 2) and a["status"] == b["status"]]
    eq_ok = [i for i in both_ok if lines[i][0] == "e"]
    inv_ok = [i for i in both_ok if lines[i][0] == "i"]

    def worst(idx, key):
        return max((float(np.max(np.abs(np.asarray(d[i][key]) - np.asarray(f[i][key])))) for i in idx), default=None)

    return {
        "scenes": len(lines),
        "status_agree": int(sum(same)),
        "status_differ": [{"line": lines[i], "double": d[i]["status"], "float": f[i]["status"]} for i, s in enumerate(same) if not s],
        "compared_equilibria": len(eq_ok),
        "compared_inverses": len(inv_ok),
        "theta_rad": worst(eq_ok, "theta"),
        "tip_mm": worst(eq_ok, "tip"),
        "inverse_pressure_mpa": worst(inv_ok, "pressure"),
        "inverse_theta_rad": worst(inv_ok, "theta"),
    }


def _m4_times(exports: dict, exes: dict, n: int, workdir: Path, arm: str, qemu: str, precisions: Sequence[str]) -> dict:
    """Instructions and estimated cycles per equilibrium on a Cortex-M4 (:mod:`esba.bench.cortexm4`)
    for the equilibrium scenes, with each run's status and angles against the host's build of the
    same precision."""
    out = {}
    for prec in precisions:
        chosen = EQUILIBRIUM_SCENES if prec == "float" else EQUILIBRIUM_SCENES[:1]  # double: ~40x the instructions (software floating point)
        scenes = [{"pressure": p, "payload[0].force": f, "payload[0].angle": math.radians(a), "payload[0].at": s} for p, f, a, s in chosen]
        sub = workdir / f"m4-n{n}-{prec}"
        sub.mkdir(exist_ok=True)
        counts, results = cortexm4.m4_equilibrium_counts(exports[prec].folder, exports[prec].spec.name, n, scenes, "theta", n, sub, arm, qemu)
        _, host = run_driver(exes[prec], [("e", *sc) for sc in chosen], 1)
        out[prec] = cortexm4.summary(counts, results, [(r["status"], r["theta"]) for r in host])
    return out


def embedded_benchmark(ns: Sequence[int] = EMBEDDED_NS, repeat: int = 11, progress: Callable[[str], None] | None = None, m4_time: bool = True) -> dict:
    """Run the benchmark (see the module); returns the data :mod:`esba.pages.embedded` renders.
    ``m4_time``: also count the Cortex-M4's instructions per equilibrium under qemu-arm where it and
    arm-none-eabi-gcc are installed (:mod:`esba.bench.cortexm4`; minutes).

    Raises
    ------
    esba.export.build.BuildError
        when there is no host C compiler (the benchmark times compiled C).
    """
    say = progress or (lambda _msg: None)
    cc = build.compiler()
    if cc is None:
        raise build.BuildError("esba bench embedded needs a C compiler ($CC, gcc, cc): none was found")
    arm = build.arm_compiler()
    qemu = cortexm4.qemu_arm() if m4_time else None
    rows = []
    t_start = time.perf_counter()
    demo = None
    with tempfile.TemporaryDirectory(prefix="esba-bench-embedded-") as tmp:
        work = Path(tmp)
        for n in ns:
            t0 = time.perf_counter()
            exports = {prec: export_c(ExportSpec(n, precision=prec), work / f"n{n}-{prec}") for prec in ("double", "float")}
            export_s = time.perf_counter() - t0
            say(f"n = {n}: exported ({export_s:.1f} s); compiling")
            exes = {prec: _build_driver(e, cc, work) for prec, e in exports.items()}
            lines = [("e", *s) for s in EQUILIBRIUM_SCENES] + [("i", *s) for s in INVERSE_SCENES]
            work_bytes, c_rows = run_driver(exes["double"], lines, repeat)
            fwork_bytes, _ = run_driver(exes["float"], lines[:1], 1)
            say(f"n = {n}: C timed; timing Python")
            py_eq, py_inv = _python_calls(n, max(3, repeat // 2))
            c_eq, c_inv = c_rows[: len(EQUILIBRIUM_SCENES)], c_rows[len(EQUILIBRIUM_SCENES):]
            say(f"n = {n}: sizes")
            host = _sizes(exports["double"], work, cc, ["-O2"], "size")
            m4 = {prec: _sizes(exports[prec], work, arm, list(build.CORTEX_M4), "arm-none-eabi-size") for prec in ("double", "float")} if arm else {}
            m4_time = None
            if arm and qemu:
                say(f"n = {n}: the Cortex-M4's instructions (qemu-arm)")
                m4_time = _m4_times(exports, exes, n, work, arm, qemu, ("float", "double") if n == ns[0] else ("float",))
            say(f"n = {n}: float against double")
            accuracy = _accuracy(exes["double"], exes["float"], n)
            if demo is None:
                demo = _make_demo(exports["double"])
            rows.append({
                "n": n,
                "export_s": export_s,
                "work_bytes": work_bytes,
                "work_bytes_float": fwork_bytes,
                "c_equilibrium_us": [r["ns"] / 1e3 for r in c_eq],
                "c_inverse_us": [r["ns"] / 1e3 for r in c_inv],
                "py_equilibrium_us": [r["s"] * 1e6 for r in py_eq],
                "py_inverse_us": [r["s"] * 1e6 for r in py_inv],
                "c_equilibrium_status": [r["status"] for r in c_eq],
                "c_inverse_status": [r["status"] for r in c_inv],
                "c_equilibrium_snaps": [{"snaps": r["snaps"], "at": r["snap_at"], "from_deg": math.degrees(r["snap_from"]), "to_deg": math.degrees(r["snap_to"]),
                                         "total_deg": math.degrees(r["total_angle"])} for r in c_eq],
                "c_inverse_pressure": [r["pressure"] for r in c_inv],
                "py_equilibrium_ok": [r["ok"] for r in py_eq],
                "py_equilibrium_snapped": [r["snapped"] for r in py_eq],
                "py_inverse_ok": [r["ok"] for r in py_inv],
                "equilibrium_theta_difference_rad": max(float(np.max(np.abs(c["theta"] - p["theta"]))) for c, p in zip(c_eq, py_eq)),
                "inverse_pressure_difference_mpa": max(abs(c["pressure"] - p["pressure"]) for c, p in zip(c_inv, py_inv)),
                "host": host,
                "cortex_m4": m4,
                "cortex_m4_time": m4_time,
                "accuracy": accuracy,
            })
    say("the 3-D export")
    from .embedded3d import embedded3d_benchmark

    spatial = embedded3d_benchmark(repeat=repeat, progress=say, m4_time=m4_time)
    for r in rows:
        for kind in ("equilibrium", "inverse"):
            c, p = statistics.median(r[f"c_{kind}_us"]), statistics.median(r[f"py_{kind}_us"])
            r[f"c_{kind}_median_us"], r[f"py_{kind}_median_us"], r[f"{kind}_speedup"] = c, p, p / c
    return {
        "rows": rows,
        "demo": demo,
        "repeat": repeat,
        "equilibrium_scenes": [list(s) for s in EQUILIBRIUM_SCENES],
        "inverse_scenes": [list(s) for s in INVERSE_SCENES],
        "max_pressure": MAX_PRESSURE,
        "compiler": subprocess.run([cc, "--version"], capture_output=True, text=True).stdout.splitlines()[0],
        "arm_compiler": subprocess.run([arm, "--version"], capture_output=True, text=True).stdout.splitlines()[0] if arm else None,
        "arm_install": build.ARM_INSTALL,
        "m4_time": m4_time,
        "qemu": subprocess.run([qemu, "--version"], capture_output=True, text=True).stdout.splitlines()[0] if qemu else None,
        "qemu_install": cortexm4.QEMU_INSTALL,
        "m4_clock_hz": cortexm4.CLOCK_HZ,
        "machine": f"{platform.machine()}, Python {platform.python_version()}, CasADi {ca.__version__}",
        "time_s": time.perf_counter() - t_start,
        "accuracy_scenes": ACCURACY_SCENES,
        "spatial": spatial,
    }


def embedded_table(data: dict) -> str:
    """The benchmark as a plain-text table."""
    head = f"{'n':>3} {'C eq us':>8} {'Py eq us':>9} {'x':>6} {'C inv us':>9} {'Py inv us':>10} {'x':>6} {'text B':>8} {'stack B':>8} {'work B':>8} {'M4 f32 text':>12} {'M4 stack':>9}"
    lines = [head, "-" * len(head)]
    for r in data["rows"]:
        m4 = r["cortex_m4"].get("float", {})
        lines.append(
            f"{r['n']:>3} {r['c_equilibrium_median_us']:8.1f} {r['py_equilibrium_median_us']:9.0f} {r['equilibrium_speedup']:6.0f} "
            f"{r['c_inverse_median_us']:9.1f} {r['py_inverse_median_us']:10.0f} {r['inverse_speedup']:6.0f} {r['host']['size']['text']:8d} "
            f"{r['host']['stack_equilibrium']:8d} {r['work_bytes']:8d} "
            f"{(str(m4['size']['text']) if m4 else '-'):>12} {(str(m4['stack_equilibrium']) if m4 else '-'):>9}"
        )
    for r in data["rows"]:
        a = r["accuracy"]
        lines.append(f"n = {r['n']}: float vs double on {a['scenes']} scenes: statuses agree {a['status_agree']}/{a['scenes']}, "
                     f"max |d theta| {a['theta_rad']:.2g} rad, tip {a['tip_mm']:.2g} mm, inverse pressure {a['inverse_pressure_mpa']:.2g} MPa")
    if data["arm_compiler"] is None:
        lines.append(f"arm-none-eabi-gcc is not installed: no Cortex-M4 sizes ({data['arm_install']})")
    for label, rs in (("", data["rows"]), ("3-D ", data.get("spatial", {}).get("rows", []))):
        for r in rs:
            for prec, m in (r.get("cortex_m4_time") or {}).items():
                lines.append(f"{label}n = {r['n']}: Cortex-M4 {prec}: {m['instructions_median']:,.0f} instructions per equilibrium, "
                             f"{m['us_min_median'] / 1e3:.2f} to {m['us_max_median'] / 1e3:.2f} ms at {data['m4_clock_hz'] / 1e6:g} MHz (estimated; "
                             f"statuses as the host's: {'yes' if m['statuses_as_host'] else 'NO'})")
    for r in data.get("spatial", {}).get("rows", []):
        lines.append(f"3-D n = {r['n']}: {r['c_us']:.1f} us per equilibrium in C, {r['python_us']:.0f} us in Python ({r['speedup']:.0f}x), "
                     f"text {r['text']} B, work {r['work_bytes']} B, max |d q| {r['max_q_difference']:.2g} rad")
    lines.append(f"demo: {data['demo']['output']}")
    return "\n".join(lines)

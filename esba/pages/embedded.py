"""``docs/embedded.md``: the page of ``esba bench embedded`` (presentation only; the measurements
are :func:`esba.bench.embedded.embedded_benchmark`).

Every number on the page comes from the benchmark's data; the control loop is C that a test
compiles against an export of n = 3 (``tests/export``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from esba.export.binding import STATUS
from esba.export.writer import STATUS_TABLE, flag_table
from esba.infra import outputs
from esba.infra.roundoff import RELATIVE_FLOOR, floored

__all__ = ["CONTROL_LOOP", "embedded_page", "write_page"]

#: A minimal control loop on an export of n = 3 (``esba export c --segments 3 --out ctrl``).
CONTROL_LOOP = r"""#include <stddef.h>

#include "esba_n3_air_axial_radial_fibres_payload1_paper.h"

#define ESBA(x) esba_n3_air_axial_radial_fibres_payload1_paper_##x
#define N 3

/* The board's own I/O: not part of the export. */
extern double read_pressure_sensor(void);  /* MPa */
extern double read_payload_estimate(void); /* N, pushing horizontally on the tip */
extern double commanded_angle(void);       /* rad, the total bend wanted */
extern void set_pressure(double mpa);      /* the valve's set point */
extern void report_snap(double from_rad, double to_rad);

void control_step(void) {
    static ESBA(work) work; /* scratch memory of the calls: no malloc */
    static ESBA(state) now; /* the last equilibrium and its loads: the warm start */
    static int known = 0;
    ESBA(params) a;
    ESBA(loads) loads;
    ESBA(result) r;
    int k, status;

    ESBA(default_params)(&a); /* or the parameters esba fit calibrated */
    ESBA(default_loads)(&loads);
    loads.pressure = (ESBA(real))read_pressure_sensor();
    loads.payload[0].force = (ESBA(real))read_payload_estimate();
    loads.payload[0].angle = (ESBA(real))1.5707963; /* horizontal, from the vertical */

    /* Where the actuator is: the loads moved from the last cycle's to these. */
    status = ESBA(equilibrium)(N, &a, &loads, known ? &now : NULL, &r, &work);
    if (status == ESBA_OK || status == ESBA_SNAPPED) {
        if (status == ESBA_SNAPPED) report_snap(r.snap_from, r.snap_to);
        for (k = 0; k < N; ++k) now.theta[k] = r.theta[k];
        now.loads = loads;
        known = 1;
    } else {
        known = 0; /* start the next cycle from the straight state */
    }

    /* The pressure that holds the commanded bend under this payload, at most 0.3 MPa. */
    status = ESBA(pressure_for_angle)(N, &a, &loads, (ESBA(real))commanded_angle(), (ESBA(real))0.3, known ? &now : NULL, &r, &work);
    /* unreachable: the nearest bend that holds; never a state outside the model's domain (a bend
     * through the clamp); ESBA_FLAG_MULTISTABLE: held from here, but inflating from zero ends elsewhere */
    if ((status == ESBA_OK || status == ESBA_UNREACHABLE) && !(r.flags & ESBA_FLAGS_OUTSIDE_MODEL))
        set_pressure(r.pressure);
    /* anything else: keep the valve where it is */
}
"""


def _us(v: float) -> str:
    return f"{v:,.1f}" if v < 100 else f"{v:,.0f}"


def _status_list(codes) -> str:
    return ", ".join(STATUS[c] for c in codes)


def _ms(us: float) -> str:
    return f"{us / 1e3:,.2f}" if us < 1e4 else f"{us / 1e3:,.1f}" if us < 1e5 else f"{us / 1e3:,.0f}"


def _m4_time_rows(label: str, n: int, t: dict | None) -> list[str]:
    """Rows of the Cortex-M4 time table for one n (both precisions where counted)."""
    out = []
    for prec in ("float", "double"):
        if not t or prec not in t:
            continue
        m = t[prec]
        scenes = len(m["instructions"])
        same = "yes" if m["statuses_as_host"] else "**no**"
        out.append(f"| {label} | {n} | {prec} | {scenes} | {m['instructions_median']:,.0f} | {_ms(m['us_min_median'])} to {_ms(m['us_max_median'])} | "
                   f"{same} | {floored(m['state_difference_from_host'], '.1e', RELATIVE_FLOOR)} |")
    return out


def _double_ratio(data: dict[str, Any]) -> str:
    """How many times the float build's instructions the double build takes on the first scene."""
    out = []
    for label, rows in (("planar", data["rows"]), ("3-D", (data.get("spatial") or {}).get("rows", []))):
        t = rows[0].get("cortex_m4_time") if rows else None
        if t and "double" in t and "float" in t:
            out.append(f"{t['double']['instructions'][0] / t['float']['instructions'][0]:.0f}x ({label}, n = {rows[0]['n']})")
    return ": " + " and ".join(out) + " the float build's instructions on the first scene" if out else ""


def _m4_time_section(data: dict[str, Any], command: str) -> list[str]:
    """How long an equilibrium takes on a Cortex-M4, estimated from the instructions it executes."""
    lines = ["", "### Time per equilibrium on a Cortex-M4 (estimated)", ""]
    if not data.get("m4_time", True):
        return lines + [f"Not counted in this run (`--no-m4-time`); `{command.replace(' --no-m4-time', '')}` counts them."]
    if data.get("arm_compiler") is None or data.get("qemu") is None:
        missing = " and ".join(x for x, have in (("`arm-none-eabi-gcc`", data.get("arm_compiler")), ("`qemu-arm`", data.get("qemu"))) if not have)
        return lines + [f"{missing} {'was' if ' and ' not in missing else 'were'} not installed when this page was written, so the M4's",
                        f"instructions were not counted (Debian or Ubuntu: `{data['arm_install']}`, `{data['qemu_install']}`)."]
    spatial = (data.get("spatial") or {}).get("rows", [])
    mhz = data["m4_clock_hz"] / 1e6
    lines += [
        "A time on a Cortex-M4 needs the chip. What a machine without one can give exactly is the stream",
        "of instructions the chip executes, and from it an estimate of the cycles (`esba.bench.cortexm4`):",
        "",
        "- the export and a small driver are built for the M4 as `make cortex-m4` builds the model, linked as",
        f"  a Linux program, and run by `qemu-arm` ({data['qemu']}; `{data['qemu_install']}`), which logs",
        "  every block of instructions it translates and executes. The driver calls a marker function",
        "  before and after each equilibrium, so each is counted alone; objdump decodes the instructions;",
        "- each executed instruction gets its cycles from the Cortex-M4's technical reference manual (ARM DDI",
        "  0439B, Table 3-1, and the FPU's Table 7-1) as a range: a load 1 to 2, a taken branch 2 to 4 (a",
        "  pipeline refill of 1 to 3), `IT` 0 to 1, a division 2 to 12, `VLDR`/`VSTR` 2, `VMLA`/`VFMA` 3,",
        "  `VDIV`/`VSQRT` 14; whether a branch was taken is read from the next block executed;",
        f"- microseconds are those cycles at {mhz:g} MHz (an STM32F405/407's clock).",
        "",
        "This assumes memory without wait states (code and data in zero-wait-state RAM, or flash behind an",
        "accelerator that hides its wait states, as the STM32F4's ART does for most code); a part fetching",
        "from slow flash without a cache takes longer. qemu runs the M4's instructions on its `max` core",
        "(its `cortex-m4` aborts in user mode on an assertion in qemu 7.2); qemu's own timing is not used.",
        "The M4 run computes the host's equilibrium: the same statuses, and states within the last bits of",
        "the precision (newlib's libm is not glibc's). The double build runs every operation in software",
        f"(the FPU has single precision only){_double_ratio(data)}, so it is counted on the",
        "first scene only. The scenes are the timing table's (planar) and the 3-D section's below.",
        "",
        f"| model | n | precision | scenes | instructions per equilibrium (median) | ms at {mhz:g} MHz (median, fewest to most cycles) | statuses as the host's | largest state difference from the host (rad) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in data["rows"]:
        lines += _m4_time_rows("planar", r["n"], r.get("cortex_m4_time"))
    for r in spatial:
        lines += _m4_time_rows("3-D", r["n"], r.get("cortex_m4_time"))
    planar = data["rows"][0].get("cortex_m4_time") or {}
    if "float" in planar:
        f = planar["float"]
        host = data["rows"][0]["c_equilibrium_median_us"]
        lines += ["", f"At n = {data['rows'][0]['n']} in single precision an equilibrium takes about {_ms(f['us_min_median'])} to {_ms(f['us_max_median'])} ms on the M4,",
                  f"{f['us_min_median'] / host:,.0f} to {f['us_max_median'] / host:,.0f} times the host's double build ({_us(host)} µs): {1e6 / f['us_max_median']:,.0f} to",
                  f"{1e6 / f['us_min_median']:,.0f} equilibria a second from the straight state, enough for a pressure loop of a few hundred Hz,",
                  "not for one at kHz. A warm start from the last cycle's state (the control loop below) takes fewer",
                  "Newton iterations (tests/export/test_equilibrium.py checks it); its time on the M4 is not counted here."]
    return lines


def _spatial_section(sp: dict | None) -> list[str]:
    """The 3-D export's rows (:func:`esba.bench.embedded3d.embedded3d_benchmark`)."""
    if not sp:
        return []
    rows = sp["rows"]
    scenes = "; ".join(f"{p:g} MPa, {f:g} N at {a:g} deg in the plane and {b:g} deg out of it, at = {s:g}" for p, f, a, b, s in sp["scenes"])
    sec = rows[0]["section"]
    lines = [
        "## The 3-D model in C (`esba export c --3d`)",
        "",
        "The spatial model (docs/3d.md) exported with the same contract: the section's EI_side and GJ and",
        "every load (a payload's direction in space and its point, moments, gravity's direction) at run time,",
        "`ESBA_SNAPPED` at a fold in the plane and `ESBA_BUCKLED` where the stable branch ends with a sideways",
        "critical mode. Its Hessian is dense (3n x 3n, an LDL^T solve of O(n^3)): it costs more than the",
        f"planar export. Scenes: Table 1 with its section (EI_side = {sec['EI_side']:.4g}, GJ = {sec['GJ']:.4g} N mm^2); {scenes}.",
        f"C: each scene {sp['repeat']} times in one `..._equilibrium_batch` call (host `-O2`), median over the scenes;",
        "Python: `esba.statics.spatial.solve3d` (its load history and IPOPT's certificate), median.",
        "",
        "| n | C, µs per equilibrium | Python, µs | speed-up | largest difference of q, rad | statuses | text, bytes (host -O2) | work, bytes |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        gap = r["max_q_difference"]
        lines.append(f"| {r['n']} | {r['c_us']:.0f} | {r['python_us']:.0f} | {r['speedup']:.0f}x | {'< 1e-12' if gap < 1e-12 else f'{gap:.1g}'} | "
                     f"{', '.join(sorted(set(r['statuses'])))} | {r['text']:,} | {r['work_bytes']:,} |")
    lines.append("")
    if sp["arm"]:
        lines.append("Cortex-M4 (`-Os`), text bytes: " + "; ".join(
            f"n = {r['n']}: double {r['cortex_m4']['double']['text']:,}, float {r['cortex_m4']['float']['text']:,}" for r in rows) + ".")
    else:
        lines.append("Cortex-M4: `arm-none-eabi-gcc` is not installed on the machine that wrote this page (`apt-get install gcc-arm-none-eabi`): no sizes.")
    lines.append("")
    return lines


def embedded_page(data: dict[str, Any], command: str) -> str:
    """The Markdown of ``docs/embedded.md`` from :func:`esba.bench.embedded.embedded_benchmark`."""
    rows = data["rows"]
    demo = data["demo"]
    first = rows[0]
    eq_scenes = "; ".join(f"{p:g} MPa, {f:g} N at {a:g} deg, at = {s:g}" for p, f, a, s in data["equilibrium_scenes"])
    inv_scenes = "; ".join(f"{t:g} deg under {f:g} N at {a:g} deg, at = {s:g}" for t, f, a, s in data["inverse_scenes"])
    lines = [
        "# The model in C, for the controller on the bench",
        "",
        f"Written by `{command}`; rerun it to refresh. Every number on this page comes from that command",
        f"(it took {data['time_s']:.0f} s on this machine: {data['machine']}; {data['compiler']}).",
        "",
        "`esba export c` writes a model as C99 that depends on nothing but libm: no Python, no CasADi,",
        "no `malloc`, no global mutable state (re-entrant: every call works in the caller's memory), every",
        "loop bounded. The actuator's parameters (L, r1, r2, d, rho, E, M) are a struct passed at run time,",
        "so an actuator calibrated with `esba fit` needs no new export.",
        "",
        "    esba export c --segments 3 --out ctrl          # double precision",
        "    esba export c --segments 3 --float --out ctrl  # single precision, for an FPU without doubles",
        "    cd ctrl && make && echo '0.12 2 90' | ./demo",
        "",
        "The folder holds the header and the source (named after the model, e.g.",
        "`esba_n3_air_axial_radial_fibres_payload1_paper.h`), a `Makefile` (`make`, `make check` with",
        "`-std=c99 -Wall -Wextra -Werror -pedantic`, `make cortex-m4`), a README (the API, the units, the",
        "status codes) and `demo.c`. The source has two parts: the model's functions (energy, gradient, the",
        "Hessian's diagonal and first row, the tip and its Jacobian) written by CasADi's code generator, and",
        "esba's solver, filled in from a template: the load history with the folds, the pressure for a total",
        "angle, Newton, the tip's tangent stiffness. Every linear solve uses the chain structure of the",
        "Hessian (diagonal plus c[max(j, k)]): O(n), and the signs of its pivots say whether a state is stable.",
        "",
        "## The demo",
        "",
        "Built by `make` from the export alone (n = 3, double), for the Table 1 actuator at 0.12 MPa under a",
        "2 N horizontal tip payload, and (`-i`) the pressure that bends it to 90 deg under the same payload",
        "(a result's flags follow its status: `multistable` when the load history at that pressure, inflated",
        "and then loaded, reaches another state, as `esba pressure` notes too):",
        "",
        f"    $ echo '{demo['input']}' | ./demo",
        f"    {demo['output']}",
        f"    $ echo '{demo['inverse_input']}' | ./demo -i",
        f"    {demo['inverse_output']}",
        "",
        ("esba's Python solver gives the same line for the first (the export's README quotes it)."
         if demo["output"] == demo["expected"] else
         f"esba's Python solver gives `{demo['expected']}` for the first: THEY DIFFER."),
        "",
        "## Time per call: C against Python",
        "",
        f"Medians over {data['repeat']} calls of each scene in C (a driver compiled with `-O2`, `clock_gettime`",
        "around each call), and in Python in the same run (`esba.statics.equilibrium.solve`, and for the",
        "inverse `esba.analysis.stiffness.pressure_for_target`, what `esba pressure --total-angle` runs);",
        "the table gives the median over the scenes. Equilibria from the straight state along the load",
        f"history: {eq_scenes} (the last snaps at a fold on its way). Inverses, the pressure for a total angle",
        f"under a payload (at most {data['max_pressure']:g} MPa): {inv_scenes}.",
        "",
        "| n | equilibrium, C (us) | Python (us) | C faster by | inverse, C (us) | Python (us) | C faster by | same answers |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['n']} | {_us(r['c_equilibrium_median_us'])} | {_us(r['py_equilibrium_median_us'])} | {r['equilibrium_speedup']:.0f}x | "
            f"{_us(r['c_inverse_median_us'])} | {_us(r['py_inverse_median_us'])} | {r['inverse_speedup']:.0f}x | "
            f"angles within {r['equilibrium_theta_difference_rad']:.1g} rad, pressures within {r['inverse_pressure_difference_mpa']:.1g} MPa |"
        )
    lines += [
        "",
        "Per scene (C statuses; Python's `ok` for the same calls):",
        "",
        "| n | equilibria, C (us) | C status | inverses, C (us) | C status | Python ok |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['n']} | {', '.join(_us(v) for v in r['c_equilibrium_us'])} | {_status_list(r['c_equilibrium_status'])} | "
            f"{', '.join(_us(v) for v in r['c_inverse_us'])} | {_status_list(r['c_inverse_status'])} | "
            f"{sum(r['py_equilibrium_ok'])}/{len(r['py_equilibrium_ok'])} equilibria, {sum(r['py_inverse_ok'])}/{len(r['py_inverse_ok'])} inverses |"
        )
    lines += [
        "",
        "## Code size and stack",
        "",
        "`size` of the object (bytes of code and constants; no data, no bss: nothing global is written),",
        "the deepest chain of stack frames from `..._equilibrium` and from `..._pressure_for_angle`",
        "(`-fstack-usage` for each frame, `-fcallgraph-info=su` for the calls; libm's own frames not",
        "counted), and the work memory the caller provides (`sizeof(..._work)`: CasADi's work vector and",
        "the solver's arrays; declare it static or in a task's memory, not necessarily on the stack).",
        "",
        "| n | host x86-64 -O2, double: text | stack, equilibrium | stack, inverse | largest frame | work (double) | work (float) |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        h = r["host"]
        lines.append(
            f"| {r['n']} | {h['size']['text']:,} | {h['stack_equilibrium']:,} | {h['stack_inverse']:,} | {h['largest_frame']:,} | "
            f"{r['work_bytes']:,} | {r['work_bytes_float']:,} |"
        )
    lines += ["", "### Cortex-M4", ""]
    if data["arm_compiler"] is None:
        lines += [
            "`arm-none-eabi-gcc` was not installed when this page was written, so there are no Cortex-M4 sizes.",
            f"Install it (Debian or Ubuntu: `{data['arm_install']}`) and rerun `{command}`.",
        ]
    else:
        lines += [
            f"`arm-none-eabi-gcc -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16 -Os` ({data['arm_compiler']};",
            f"Debian or Ubuntu: `{data['arm_install']}`). The M4's FPU does single precision only: the",
            "`--float` export keeps every operation on it; the double export runs on the software library.",
            "",
            "| n | precision | text | stack, equilibrium | stack, inverse | largest frame |",
            "|---|---|---|---|---|---|",
        ]
        for r in rows:
            for prec in ("float", "double"):
                m = r["cortex_m4"][prec]
                lines.append(f"| {r['n']} | {prec} | {m['size']['text']:,} | {m['stack_equilibrium']:,} | {m['stack_inverse']:,} | {m['largest_frame']:,} |")
        lines += _m4_time_section(data, command)
    lines += [
        "",
        "## Single precision against double",
        "",
        f"The `--float` export against the double one on {data['accuracy_scenes']} random scenes per n (a third near",
        "a compressive snap, a third general equilibria, a third inverses under a random payload), compared",
        "where both converge with the same status:",
        "",
        "| n | statuses agree | equilibria compared | max angle difference (rad) | (deg) | max tip difference (mm) | inverses compared | max pressure difference (MPa) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        a = r["accuracy"]
        theta = a["theta_rad"] if a["theta_rad"] is not None else math.nan
        lines.append(
            f"| {r['n']} | {a['status_agree']}/{a['scenes']} | {a['compared_equilibria']} | {theta:.1e} | {math.degrees(theta):.1e} | "
            f"{a['tip_mm']:.1e} | {a['compared_inverses']} | {a['inverse_pressure_mpa']:.1e} |"
        )
    differ = [(r["n"], d) for r in rows for d in r["accuracy"]["status_differ"]]
    if differ:
        lines += ["", "Where the statuses differ, the scene is close to a fold or a branch point, where single precision cannot tell the sides apart:", ""]
        for n, d in differ:
            k, v, f, ang, s = d["line"]
            what = f"P = {v:.4g} MPa" if k == "e" else f"target {v:.4g} deg"
            lines.append(f"- n = {n}: {what}, {f:.3g} N at {ang:.4g} deg, at = {s:.3g}: double {STATUS[d['double']]}, float {STATUS[d['float']]}")
    snap = first["c_equilibrium_snaps"][-1]
    p, f, ang, s = data["equilibrium_scenes"][-1]
    lines += [
        "",
        "## What happens at a fold",
        "",
        "A quasi-static load keeps the actuator on a stable branch of equilibria until the branch ends at a",
        "fold, where the stable state meets an unstable one and both vanish; the actuator snaps to another",
        "stable state. `..._equilibrium` follows the branch with load steps that must keep every Hessian",
        "positive definite and the corrector close to the predictor; at the end of the branch the steps",
        "shrink to nothing while the Hessian turns singular. It then kicks the state along the critical",
        "mode, towards the side where the energy falls past the fold, minimises the energy just past it, and",
        "goes on from the state it lands in to the full load. It returns that state with `ESBA_SNAPPED` and",
        "says where it snapped (`snap_ramp`, `snap_at`: the ramp and its load factor) and from which total",
        "angle to which (`snap_from`, `snap_to`). In the benchmark's last scene (n = "
        f"{first['n']}, {p:g} MPa, {f:g} N at {ang:g} deg, at = {s:g}) it snapped {snap['snaps']} time(s), the first at "
        f"{100 * snap['at']:.2f} % of the payload, from {snap['from_deg']:.2f} to {snap['to_deg']:.2f} deg, and ended at {snap['total_deg']:.2f} deg.",
        "",
        "`..._pressure_for_angle` follows the branch in the total angle instead (the angle and the pressure",
        "as unknowns, a bordered Newton step with two O(n) solves), through its folds: a target whose state",
        "is unstable (between two folds), needs a pressure below 0 or above the limit given is",
        "`ESBA_UNREACHABLE`, with the nearest state that holds (the fold's, or the limit's). A controller",
        "that keeps commanding such a target keeps the actuator at the edge of the stable range. A target",
        "held by a stable state past a snap is answered, flagged `ESBA_FLAG_MULTISTABLE` (as is a nearest",
        "state that holds) when the load history at its pressure (what `..._equilibrium` does from the",
        "straight state) reaches another state: the actuator holds it only when it gets there another way.",
        "",
        *_spatial_section(data.get("spatial")),
        "## A minimal control loop",
        "",
        "Each cycle reads the pressure and a payload estimate, updates where the actuator is from where it",
        "was (a warm start: the loads move from the last cycle's to these), then asks for the pressure that",
        "holds the commanded bend under that payload:",
        "",
        "```c",
        CONTROL_LOOP.rstrip("\n"),
        "```",
        "",
        "## Status codes",
        "",
        STATUS_TABLE.rstrip("\n"),
        "",
        "## Flags",
        "",
        "Beside its status, a result carries `flags`: where its state lies outside the model's range, by the",
        "rule and thresholds of esba's Python results (`esba.model.validity`), and the inverse's note.",
        "",
        flag_table().rstrip("\n"),
        "",
    ]
    return "\n".join(lines)


def write_page(path: str | Path, data: dict[str, Any], command: str) -> Path:
    """Write ``docs/embedded.md`` (or ``path``)."""
    return outputs.write_text(path, embedded_page(data, command))

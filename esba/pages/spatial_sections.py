"""The 3-D sections of ``docs/sensing.md`` and ``docs/experiments.md``, rendered from
:mod:`esba.calibration.cases3d` (presentation only: every number comes from the cases)."""

from __future__ import annotations

import math

from esba.calibration.cases3d import (
    EXPERIMENTS,
    FREE_SETS,
    LOAD,
    MEASUREMENTS,
    TARGET_DEG,
    Experiments3DCases,
    Sensing3DCases,
)

__all__ = ["render_sensing3d", "render_experiments3d"]

EXPERIMENT_POS = "tip position (± 0.1 mm)"

#: Below this ratio of the smallest to the largest Fisher eigenvalue the number is round-off (printed as a bound).
ROUNDOFF_RATIO = 1e-12


def _cond(c: float) -> str:
    return "∞" if not math.isfinite(c) else ("> 1e6" if c > 1e6 else f"{c:.3g}")


def _floor(v: float, floor: float) -> str:
    return f"< {floor:g}" if v < floor else f"{v:.2g}"


def render_sensing3d(d: Sensing3DCases) -> list[str]:
    F, om, be = LOAD
    sec = ", ".join(f"{k} = {v:g}" for k, v in d.section.items())
    lines = [
        "## The load in space: a 3-D tracker (`esba estimate --3d`)",
        "",
        "Computed by `esba/calibration/cases3d.py` (`sensing3d_cases`) with the 3-D estimate of `esba/calibration/sensing3d.py` "
        "on the 3-D model (`docs/3d.md`): the payload as a force in space (F, Ω in the bending plane, β out of it toward +z; "
        "or its components in the base frame), its point, and a tip moment, read from what a 3-D tracker gives: the tip's "
        "position and orientation (the paper's trakSTAR), markers along the length, or the 3n joint angles.",
        "",
        f"The actuator is Table 1's, n = 3, at the pressure that bends it unloaded to {TARGET_DEG:g}° ({d.pressure:.4f} MPa), with "
        f"the section stiffnesses {sec} N mm² (the paper gives neither; one of `docs/3d.md`'s pairs). The load is "
        f"{F:g} N at Ω = {om:g}°, β = {be:g}° at the tip. Each table cell is computed from the singular values of the "
        "whitened sensitivity of the measured values to the unknowns (relative unknowns: 1 N, 30°, 0.3 L, 100 N mm), at the "
        "state the load history reaches: its rank, its condition number, and the verdict of the identifiability rule of "
        "`esba fit` (a Fisher eigenvalue below 1e-6 of the largest: not separated).",
        "",
        "| measured | unknowns | rank | condition | identifiable | std error of F (N) | of Ω (deg) | of β (deg) |",
        "|---|---|---:|---:|---|---:|---:|---:|",
    ]
    for c in d.cells:
        se = [("—" if not math.isfinite(v) else f"{v:.3g}") for v in c.std_error[:3]]
        lines.append(f"| {c.measured} | {c.free} | {c.rank} of {c.unknowns} | {_cond(c.condition)} | {'yes' if c.identifiable else 'no'} | "
                     f"{se[0]} | {se[1]} | {se[2]} |")
    by = {(c.measured, c.free): c for c in d.cells}
    pose = MEASUREMENTS[2][0]
    pm = by[(pose, FREE_SETS[2][0])]
    pp = by[(pose, FREE_SETS[1][0])]
    tip = by[(MEASUREMENTS[0][0], FREE_SETS[0][0])]
    ang = by[(MEASUREMENTS[4][0], FREE_SETS[2][0])]
    lines += [
        "",
        "**The identifiability rule for the tip pose alone**, as computed above:",
        "",
        f"- A force in space: {'separated' if by[(pose, FREE_SETS[0][0])].identifiable else 'not separated'} (rank "
        f"{by[(pose, FREE_SETS[0][0])].rank} of 3). The tip position alone also gives it "
        f"({'rank 3' if tip.identifiable else 'not'}), with the direction in the plane poorly: ± {tip.std_error[1]:.3g}° on Ω.",
        f"- A force and its point along the length (magnitude against point): {'separated' if pp.identifiable else 'not separated'} "
        f"by the tip pose (rank {pp.rank} of 4, condition {_cond(pp.condition)}); the tip position alone cannot "
        f"(rank {by[(MEASUREMENTS[0][0], FREE_SETS[1][0])].rank} of 4).",
        f"- A force and a tip moment: {'separated' if pm.identifiable else 'not separated'} by the tip pose "
        f"(rank {pm.rank} of 6 above the rule's bound). In its words:",
        "",
    ]
    lines += [f"  > {w}" for w in pm.words] + [""]
    if not pm.identifiable:
        lines += ["Six numbers for six unknowns are not enough here: a chain of n = 3 segments maps a tip force and a tip moment onto "
                  "joint torques that the tip's pose sees almost alike."]
    lines += [
        f"The 3n joint angles {'separate them' if ang.identifiable else 'do not separate them either'} (rank {ang.rank} of 6, "
        f"condition {_cond(ang.condition)}).",
        "",
        f"**A worked example.** The tip pose of that load (noise-free values, read with the stated deviations) read back "
        f"by `estimate_load3d` from a start of 0.5 N horizontal in the plane and six more directions: F = {d.example_estimate[0]:.4f} ± "
        f"{d.example_std_error[0]:.2g} N, Ω = {d.example_estimate[1]:.2f} ± {d.example_std_error[1]:.2g}°, β = {d.example_estimate[2]:.2f} ± "
        f"{d.example_std_error[2]:.2g}°; force vector ({', '.join(f'{v:.3f}' for v in d.example_force)}) N; largest error against the "
        f"true load {_floor(d.example_error, 1e-8)}.",
        "",
        "**The joint region** is the force vector's 95 % ellipsoid (`force_covariance`): the measured pose is nearly linear in the "
        "force's components, while (F, Ω, β) are its polar coordinates, whose joint ellipse the map bends. Each interval of F, Ω "
        "and β covers at its rate, and so does the force vector's region (`tests/calibration/test_sensing3d.py`, 240 random loads "
        "with a slow test, 30 in CI).",
        "",
        f"**In the plane it is the planar estimate.** Segment angles of an in-plane load (1 N at Ω = 60°, ± 0.5°) read by "
        f"the planar estimate and by the 3-D one with ψ = τ = 0 measured: estimates differ by {_floor(d.planar_difference, 1e-10)}, "
        f"standard errors by {_floor(d.planar_se_difference, 1e-10)} (relative), and |β| is {_floor(d.planar_beta, 1e-10)}: at an in-plane "
        "state the out-of-plane unknown is uncoupled from the in-plane ones.",
        "",
        "From the command line: `esba estimate --pressure P --tip X,Y,Z --sigma-tip SD --tip-rotation R11,...,R33 --sigma-rotation DEG "
        "--section EI_side=... --section GJ=...` (or `--marker AT:X,Y,Z`, `--angles`, `--poses FILE.csv` in the format of "
        "`esba/calibration/poses3d.py`; `--free force,angle,out[,at][,moment]`).",
        "",
    ]
    return lines


def render_experiments3d(d: Experiments3DCases) -> list[str]:
    sec = ", ".join(f"{k} = {v:g}" for k, v in d.section.items())
    lines = [
        "## Which measurements determine the sideways and torsional stiffness (`esba fit` with 3-D poses)",
        "",
        "The paper's experiments are all in the bending plane, and its model has no sideways bending stiffness EI_side and no "
        "torsional stiffness GJ (`docs/3d.md`). `esba fit` fits them from 3-D poses under known loads (a CSV with "
        "`tip_z_mm`, `tip_R11` ... `tip_R33`, `psi1_deg`, ...: `esba/calibration/poses3d.py`). Which experiments would "
        "determine them is computed here (`esba/calibration/cases3d.py`, `experiments3d_cases`) from the Fisher information "
        "of each candidate experiment about (EI_side, GJ) in relative changes, at the model's prediction with "
        f"{sec} N mm² (the values assumed on `docs/sensing.md`), a {d.load_n:g} N tip payload:",
        "",
        "| experiment | measured | rank | relative std error of EI_side | of GJ | smallest / largest eigenvalue |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for c in d.cells:
        if c.rank == 2:
            a, b = (f"{100 * v:.2g} %" for v in c.relative_se)
        elif c.rank == 1 and c.alone[0] is not None:
            a, b = f"{100 * c.alone[0]:.2g} % (GJ held)", "not determined"
        elif c.rank == 1:
            a = b = "one combination only"
        else:
            a = b = "not determined"
        lines.append(f"| {c.experiment} | {c.measured} | {c.rank} | {a} | {b} | {_floor(c.ratio, ROUNDOFF_RATIO)} |")
    inplane = [c for c in d.cells if c.experiment == EXPERIMENTS[0][0]]
    straight = [c for c in d.cells if c.experiment == EXPERIMENTS[1][0]]
    bent = [c for c in d.cells if c.experiment in (EXPERIMENTS[2][0], EXPERIMENTS[3][0])]
    pos = [c.ratio for c in bent if c.measured.startswith("tip position")]
    pose = [c.ratio for c in bent if c.measured == "tip pose"]
    lines += ["", "What the table says:", ""]
    if all(c.rank == 0 for c in inplane):
        lines.append("- A load in the bending plane leaves the actuator in its plane, where neither stiffness acts: such rows (every row "
                     "of the paper's experiments) carry no information about them (rank 0).")
    if all(c.rank == 1 and c.alone[0] is not None for c in straight):
        lines.append("- The straight actuator under a sideways tip load bends sideways without twisting: it measures EI_side alone "
                     "(rank 1, the combination it determines is EI_side's), GJ not at all.")
    if all(c.rank == 2 for c in bent if c.measured != EXPERIMENT_POS) and max(pos) < min(pose):
        lines.append("- Bent, the same sideways load also twists the actuator (the load's arm about the base's axis): with the tip's "
                     "orientation measured both are determined, the two stiffnesses' effects told apart far better (Fisher eigenvalue "
                     f"ratio {min(pose):.2g} to {max(pose):.2g} with the tip pose) than from the tip position alone ({min(pos):.2g} to {max(pos):.2g}).")
    lines += ["- So: measure the tip pose (a trakSTAR sensor) under sideways loads, with the actuator straight and bent.", ""]
    lines += [
        f"A fit from the two sideways experiments on the bent actuator (bent 45° and 90°, noise-free tip poses at ± 0.1 mm and "
        f"± 0.2°, started at three times the values) returns EI_side = {d.fit_estimate[0]:.6g} ± {d.fit_std_error[0]:.2g} and "
        f"GJ = {d.fit_estimate[1]:.6g} ± {d.fit_std_error[1]:.2g} N mm² ({d.fit_rows} rows; the standard errors are those of the "
        "stated deviations). `tests/calibration/test_fit3d.py` checks that noise-free data give the stiffnesses back to 1e-8 and "
        "that the intervals from noisy data cover.",
        "",
    ]
    return lines

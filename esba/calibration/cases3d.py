"""The computed 3-D sections of ``docs/sensing.md`` and ``docs/experiments.md``: what a 3-D tracker
tells about a load in space, and which experiments determine the section's stiffnesses.

Data only (no Markdown): :mod:`esba.pages.sensing` and :mod:`esba.pages.experiments` render it.
The actuator is Table 1's, n = 3. The paper gives neither EI_side nor GJ; the pages assume
:data:`SECTION` (one of docs/3d.md's pairs, under which the Table 2 push stays in its plane up to
4 N). With the eccentric section's defaults (:mod:`esba.model.section`: the fibres slack, GJ about
2e3 N mm^2) a 1 N tip load at these directions is near or past the sideways flip, where no load is
read from the shape.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from esba.model.scene import Payload, Scene

__all__ = ["Sensing3DCases", "Experiments3DCases", "sensing3d_cases", "experiments3d_cases", "MEASUREMENTS", "FREE_SETS",
           "LOAD", "TARGET_DEG", "SPATIAL_LOAD_N", "EXPERIMENTS"]

#: The section stiffnesses the pages assume (N*mm^2).
SECTION = {"EI_side": 4e5, "GJ": 1e5}
#: The unloaded bend that sets the pressure (deg).
TARGET_DEG = 90.0
#: The tip load of the sensing section: F (N), Omega (deg), Beta (deg).
LOAD = (1.0, 60.0, 20.0)
#: What a 3-D tracker measures, with the standard deviations the section assumes: (name, kinds (kind, at, sd)).
MEASUREMENTS = (
    ("tip position (± 0.5 mm)", (("tip", None, 0.5),)),
    ("tip orientation (± 0.5°)", (("rotation", None, 0.5),)),
    ("tip pose: position and orientation (a trakSTAR sensor)", (("tip", None, 0.5), ("rotation", None, 0.5))),
    ("markers at L/2 and L (± 0.5 mm)", (("marker", 0.5, 0.5), ("marker", 1.0, 0.5))),
    ("the 3n joint angles (± 0.5°)", (("angles", None, 0.5),)),
)
#: The unknowns: (name, free).
FREE_SETS = (
    ("force (F, Ω, β)", ("force", "angle", "out")),
    ("force and its point", ("force", "angle", "out", "at")),
    ("force and a tip moment", ("force", "angle", "out", "moment")),
)
#: The payload of the experiments section (N).
SPATIAL_LOAD_N = 0.5
#: Candidate experiments: (name, target angle deg (0: unpressurised), Omega deg, Beta deg).
EXPERIMENTS = (
    ("in-plane tip load (Ω = 90°), bent 90°", 90.0, 90.0, 0.0),
    ("sideways tip load (β = 90°), straight (P = 0)", 0.0, 90.0, 90.0),
    ("sideways tip load (β = 90°), bent 45°", 45.0, 90.0, 90.0),
    ("sideways tip load (β = 90°), bent 90°", 90.0, 90.0, 90.0),
    ("tip load 45° out of the plane, bent 90°", 90.0, 90.0, 45.0),
)
#: What is measured in each experiment: (name, kinds).
EXPERIMENT_MEASUREMENTS = (
    ("tip position (± 0.1 mm)", (("tip", None, 0.1),)),
    ("tip orientation (± 0.2°)", (("rotation", None, 0.2),)),
    ("tip pose", (("tip", None, 0.1), ("rotation", None, 0.2))),
)


@dataclass(frozen=True)
class IdentCell:
    measured: str
    free: str
    rank: int
    unknowns: int
    condition: float
    identifiable: bool
    std_error: tuple
    words: tuple


@dataclass(frozen=True)
class Sensing3DCases:
    section: dict
    pressure: float
    cells: tuple
    example_truth: tuple
    example_estimate: tuple
    example_std_error: tuple
    example_interval: tuple
    example_force: tuple
    example_error: float
    planar_difference: float
    planar_se_difference: float
    planar_beta: float


def _scene(target: float, load=LOAD) -> Scene:
    F, om, be = load
    return Scene(target_angle_deg=target, payloads=(Payload(F, om, 1.0, be),))


def sensing3d_cases() -> Sensing3DCases:
    """The identifiability table, a worked trakSTAR example, and the in-plane reduction."""
    from esba.calibration.sensing import Measured, Pose, SensingOptions, estimate_load
    from esba.calibration.sensing3d import Pose3D, estimate_load3d, identifiability3d, predict3d
    from esba.calibration.spatial_ls import Measured3D
    from esba.statics.equilibrium import solve
    from esba.statics.spatial import check_section, scene_values3d

    scene = _scene(TARGET_DEG)
    section = check_section(SECTION, scene)
    pressure = scene_values3d(scene, section)[1]["P"]
    scene = scene.replace(pressure=pressure)
    cells = []
    for mname, kinds in MEASUREMENTS:
        for fname, free in FREE_SETS:
            a = identifiability3d(scene, kinds, free, section)
            cells.append(IdentCell(mname, fname, a.rank, len(a.labels), a.condition, a.identifiable,
                                   tuple(float(v) for v in a.std_error), a.words))
    # the worked example: the tip pose of the load, noise-free, read back from a far start
    kinds = MEASUREMENTS[2][1]
    _, preds = predict3d(scene, section, pressure, [(k, a) for k, a, _ in kinds])
    pose = Pose3D(pressure, tuple(Measured3D(k, tuple(v), sd, a) for (k, a, sd), v in zip(kinds, preds)))
    start = scene.replace(payloads=(Payload(0.5, 90.0),))
    r = estimate_load3d([pose], ("force", "angle", "out"), start, section)
    err = float(np.abs(r.estimate - np.array(LOAD)).max())
    # in the plane: segment angles of an in-plane load, planar and 3-D estimates from the same start
    planar_scene = Scene(pressure=pressure, payloads=(Payload(1.0, 60.0),))
    eq = solve(planar_scene)
    th = tuple(float(v) for v in np.degrees(eq.theta))
    base = Scene(pressure=pressure, payloads=(Payload(0.5, 90.0),))  # both start here, and only here
    r2 = estimate_load(Pose(pressure, (Measured("theta", th, 0.5),)), ("F1", "Omega1"), base, SensingOptions(starts=0, branches=False, tol=1e-14))
    r3 = estimate_load3d([Pose3D(pressure, (Measured3D("angles", th + (0.0,) * 6, 0.5),))], ("force", "angle", "out"), base, section, starts=0)
    diff = float(np.abs(r3.estimate[:2] - r2.estimate).max())
    sed = float(np.abs(r3.std_error[:2] / r2.std_error - 1).max())
    return Sensing3DCases(section, float(pressure), tuple(cells), LOAD, tuple(map(float, r.estimate)), tuple(map(float, r.std_error)),
                          tuple((float(a), float(b)) for a, b in r.interval), tuple(map(float, r.force)), err, diff, sed,
                          float(abs(r3.estimate[2])))


@dataclass(frozen=True)
class ExperimentCell:
    experiment: str
    measured: str
    rank: int
    relative_se: tuple  # of EI_side, GJ: relative standard errors, None where not determined (both), else floats
    ratio: float  # smallest / largest eigenvalue of the relative Fisher matrix
    best: tuple  # the best-determined combination (relative changes of EI_side, GJ), largest entry 1
    alone: tuple  # rank 1 along one stiffness: its relative standard error (the other not determined)


@dataclass(frozen=True)
class Experiments3DCases:
    section: dict
    load_n: float
    cells: tuple
    fit_truth: dict
    fit_estimate: tuple
    fit_std_error: tuple
    fit_rows: int


def experiments3d_cases() -> Experiments3DCases:
    """The Fisher information of candidate experiments about (EI_side, GJ), and a synthetic fit."""
    from esba.calibration.fit3d import experiment_information, fit_section
    from esba.calibration.sensing3d import Pose3D, predict3d
    from esba.calibration.spatial_ls import Measured3D
    from esba.model.closed_form import pressure_for_angle
    from esba.statics.spatial import check_section

    base = Scene()
    section = check_section(SECTION, base)
    cells = []
    pressures = {}
    for name, target, om, be in EXPERIMENTS:
        pressure = 0.0 if target == 0.0 else float(pressure_for_angle(Scene(target_angle_deg=target, payloads=())))
        pressures[name] = pressure
        for mname, kinds in EXPERIMENT_MEASUREMENTS:
            info = experiment_information(base, section, pressure, (SPATIAL_LOAD_N, om, be, 1.0), kinds, name)
            w = info.eigenvalues
            ratio = float(w[-1] / w[0]) if w[0] > 0 else 0.0
            top = np.linalg.eigh(info.fisher)[1][:, -1]
            top = top / top[np.argmax(np.abs(top))]
            alone = tuple(float(1.0 / math.sqrt(info.fisher[j, j])) if info.rank == 1 and abs(top[1 - j]) < 1e-6 else None for j in range(2))
            cells.append(ExperimentCell(name, mname, info.rank, tuple(info.relative_se), ratio, tuple(float(v) for v in top), alone))
    # a fit from the two sideways experiments on the bent actuator, noise-free tip poses
    rows = []
    for name, _, om, be in EXPERIMENTS[2:4]:
        P = pressures[name]
        sc = Scene(pressure=P, payloads=(Payload(SPATIAL_LOAD_N, om, 1.0, be),))
        _, (tip, rot) = predict3d(sc, section, P, [("tip", None), ("rotation", None)])
        rows.append((Pose3D(P, (Measured3D("tip", tuple(tip), 0.1), Measured3D("rotation", tuple(rot), 0.2)), label=name),
                     (SPATIAL_LOAD_N, om, be, 1.0)))
    start = {k: 3.0 * v for k, v in section.items()}
    r = fit_section(rows, base, start=start)
    return Experiments3DCases(section, SPATIAL_LOAD_N, tuple(cells), section, tuple(map(float, r.estimate)), tuple(map(float, r.std_error)), len(rows))


#: The synthetic 3-D measurement file of ``examples/measurements/trakstar_3d.csv``: (label, target angle deg, Omega, Beta).
EXAMPLE_ROWS = (("straight sideways", 0.0, 90.0, 90.0), ("bent 45 sideways", 45.0, 90.0, 90.0),
                ("bent 90 sideways", 90.0, 90.0, 90.0), ("bent 90 45 deg out", 90.0, 90.0, 45.0))
EXAMPLE_SEED = 2026


def example_fit_file() -> str:
    """The text of ``examples/measurements/trakstar_3d.csv``: tip poses (a trakSTAR's position and
    rotation matrix) of the Table 1 actuator with :data:`SECTION` under known sideways loads, with
    Gaussian noise of the stated deviations (seed :data:`EXAMPLE_SEED`), to 4 decimals as a tracker prints them."""
    from esba.calibration.sensing3d import predict3d
    from esba.model.closed_form import pressure_for_angle

    rng = np.random.default_rng(EXAMPLE_SEED)
    rot_names = ",".join(f"tip_R{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))
    lines = ["# Synthetic 3-D poses (not measured): the Table 1 actuator with EI_side = 4e5 and GJ = 1e5 N mm^2 under known",
             "# sideways tip loads, tip position and rotation matrix as a trakSTAR sensor gives them, with Gaussian noise of the",
             "# stated deviations. Made by `python -m esba.calibration.cases3d FILE` (esba/calibration/cases3d.py).",
             "# Fit EI_side and GJ with:  esba fit examples/measurements/trakstar_3d.csv",
             f"label,pressure_mpa,payload_n,payload_angle_deg,payload_out_of_plane_deg,tip_x_mm,tip_y_mm,tip_z_mm,tip_sd_mm,{rot_names},rotation_sd_deg"]
    for label, target, om, be in EXAMPLE_ROWS:
        P = 0.0 if target == 0.0 else round(float(pressure_for_angle(Scene(target_angle_deg=target, payloads=()))), 4)
        sc = Scene(pressure=P, payloads=(Payload(SPATIAL_LOAD_N, om, 1.0, be),))
        _, (tip, rot) = predict3d(sc, SECTION, P, [("tip", None), ("rotation", None)])
        tip = tip + rng.normal(0.0, 0.1, 3)
        w = rng.normal(0.0, math.radians(0.2), 3)
        W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        th = float(np.linalg.norm(w))
        E = np.eye(3) + math.sin(th) / th * W + (1 - math.cos(th)) / th**2 * W @ W
        rot = rot.reshape(3, 3) @ E
        lines.append(f"{label},{P:g},{SPATIAL_LOAD_N:g},{om:g},{be:g}," + ",".join(f"{v:.4f}" for v in tip) + ",0.1,"
                     + ",".join(f"{v:.4f}" for v in rot.ravel()) + ",0.2")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":  # pragma: no cover - writes the example file
    import sys

    from esba.infra import outputs

    outputs.check_file(sys.argv[1], "FILE", (".csv",)) if len(sys.argv) == 2 else sys.exit("usage: python -m esba.calibration.cases3d FILE.csv")
    with open(sys.argv[1], "w", encoding="utf-8") as fh:
        fh.write(example_fit_file())

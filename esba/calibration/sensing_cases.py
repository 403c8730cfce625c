"""The cases of ``docs/sensing.md``: how well the Table 1 actuator measures a tip load by its shape.

Data only (:mod:`esba.pages.sensing` renders it):

* :func:`by_measurement`: the standard errors of a tip load's magnitude and direction from each kind
  of measurement (segment angles, total angle, tip, a marker at L/2), per 0.1 deg or 0.1 mm of
  noise, at the 90 deg pressure (first order: the Fisher matrix of :func:`esba.calibration.sensing.information`;
  they scale with the noise as long as first order holds);
* :func:`first_order_check`: whether it holds, by repeated estimates from noisy segment angles
  (fixed seed) at three noise levels;
* :func:`blind_map`: over pressures and load directions, where a 1 N tip load's error from the
  segment angles at 1 deg noise exceeds the load itself;
* :func:`ellipses`: the 95 % ellipses of the force vector over the workspace (for the figure);
* :func:`table3_example`: the paper's Table 3 (the 2 N vertical payload at the 90 deg pressure)
  read back as a load, from the EXP and FEM total angle and tip, and from the model's own segment angles.

``sensing_cases()`` runs all of them (about a minute).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from esba.calibration.experiments import PAPER, SD_ANGLE, SD_TIP
from esba.calibration.sensing import LoadEstimate, Measured, Pose, SensingOptions, estimate_load, information
from esba.model.scene import Payload, Scene
from esba.statics.equilibrium import EquilibriumError, solve

__all__ = ["KINDS", "ByMeasurement", "by_measurement", "FirstOrderCheck", "first_order_check", "BlindMap", "blind_map",
           "Ellipse", "ellipses", "Table3Case", "table3_example", "SensingCases", "sensing_cases",
           "BLIND_PRESSURES", "BLIND_DIRECTIONS", "SD_DEG", "ELLIPSE_PRESSURES", "ELLIPSE_DIRECTIONS", "CHECK_NOISE", "CHECK_REPLICATES", "SEED"]

#: The actuator of every case: Table 1, n = 3, at the pressure that bends it unloaded to 90 deg.
TARGET_DEG = 90.0
#: The kinds of measurement compared, with their unit noise (0.1 deg or 0.1 mm).
KINDS = (("segment angles", Measured("theta", (0.0, 0.0, 0.0), 0.1)),
         ("total angle", Measured("total_angle", (0.0,), 0.1)),
         ("tip position", Measured("tip", (0.0, 0.0), 0.1)),
         ("marker at L/2", Measured("marker", (0.0, 0.0), 0.1, 0.5)))
#: The loads compared: 1 N at the tip, pulling down (0 deg) and horizontal (90 deg).
LOADS = ((1.0, 0.0), (1.0, 90.0))
#: The blind map: pressures (MPa) and directions (deg), 1 N at the tip, segment angles at SD_DEG.
BLIND_PRESSURES = tuple(float(p) for p in np.round(np.linspace(0.01, 0.21, 21), 4))
BLIND_DIRECTIONS = tuple(float(d) for d in np.arange(-180.0, 180.0, 10.0))
SD_DEG = 1.0
#: The ellipses of the figure.
ELLIPSE_PRESSURES = (0.06, 0.12, 0.18)
ELLIPSE_DIRECTIONS = tuple(float(d) for d in np.arange(-180.0, 180.0, 45.0))
#: The first-order check: noise levels (deg), replicates, seed.
CHECK_NOISE = (0.1, 1.0, 3.0)
CHECK_REPLICATES = 100
SEED = 20261202


def _scene(force: float, direction: float, pressure: float | None = None) -> Scene:
    drive = {"pressure": pressure} if pressure is not None else {"target_angle_deg": TARGET_DEG}
    return Scene(payloads=(Payload(force, direction),), **drive)


@dataclass(frozen=True)
class ByMeasurement:
    """Standard errors (N, deg) of (F, Omega) per unit noise for each kind and load; None where undetermined."""

    kind: str
    unit: str
    force: float
    direction: float
    se_force: float | None
    se_direction: float | None
    undetermined: tuple[str, ...]


def by_measurement() -> list[ByMeasurement]:
    out = []
    for force, direction in LOADS:
        scene = _scene(force, direction)
        for label, kind in KINDS:
            info = information(scene, [kind])
            se = [None if not math.isfinite(v) else float(v) for v in info.std_error]
            out.append(ByMeasurement(label, kind.unit, force, direction, se[0], se[1], info.undetermined))
    return out


@dataclass(frozen=True)
class FirstOrderCheck:
    """Repeated estimates from noisy segment angles against the first-order standard error."""

    sd_deg: float
    replicates: int
    predicted_se_force: float
    observed_sd_force: float
    bias_force: float
    predicted_se_direction: float
    observed_sd_direction: float
    coverage: float


def first_order_check(noise: tuple[float, ...] = CHECK_NOISE, replicates: int = CHECK_REPLICATES, seed: int = SEED) -> list[FirstOrderCheck]:
    """1 N horizontal at the tip, 90 deg pressure: ``replicates`` estimates per noise level (each
    started from the true load: the check is of first order, not of the starts)."""
    scene = _scene(1.0, 90.0)
    truth = np.asarray(solve(scene).theta_deg)
    rng = np.random.default_rng(seed)
    out = []
    for sd in noise:
        est, inside = [], 0
        predicted = information(scene, [Measured("theta", (0.0, 0.0, 0.0), sd)])
        for _ in range(replicates):
            noisy = tuple(float(v) for v in truth + rng.normal(0.0, sd, truth.size))
            pose = Pose(None, (Measured("theta", noisy, sd),), target_angle_deg=TARGET_DEG)
            r = estimate_load(pose, ("F1", "Omega1"), scene, SensingOptions(starts=0, branches=False))
            if r.status == "failed":
                continue
            est.append(r.estimate)
            lo, hi = r.interval[0]
            inside += int(lo <= 1.0 <= hi)
        e = np.array(est)
        out.append(FirstOrderCheck(sd, len(e), float(predicted.std_error[0]), float(np.std(e[:, 0], ddof=1)), float(np.mean(e[:, 0]) - 1.0),
                                   float(predicted.std_error[1]), float(np.std(e[:, 1], ddof=1)), inside / max(len(e), 1)))
    return out


@dataclass(frozen=True)
class BlindMap:
    """Standard error of a 1 N tip load's magnitude (N) from the segment angles at ``sd_deg``, per
    pressure (rows) and direction (columns); NaN where undetermined or the history fails."""

    pressures: tuple[float, ...]
    directions: tuple[float, ...]
    sd_deg: float
    se_force: np.ndarray
    se_direction: np.ndarray

    @property
    def blind(self) -> np.ndarray:
        """Cells where the error exceeds the load itself (1 N), or the load is not determined."""
        return ~(self.se_force <= 1.0)


def blind_map(pressures=BLIND_PRESSURES, directions=BLIND_DIRECTIONS, sd_deg: float = SD_DEG) -> BlindMap:
    se_f = np.full((len(pressures), len(directions)), np.nan)
    se_o = np.full_like(se_f, np.nan)
    kind = Measured("theta", (0.0, 0.0, 0.0), sd_deg)
    for i, p in enumerate(pressures):
        for j, d in enumerate(directions):
            try:
                info = information(_scene(1.0, d, p), [kind])
            except EquilibriumError:  # the load history reaches no equilibrium: a blank cell, said so on the page
                continue
            se_f[i, j], se_o[i, j] = info.std_error[0], info.std_error[1]
    return BlindMap(tuple(pressures), tuple(directions), sd_deg, se_f, se_o)


@dataclass(frozen=True)
class Ellipse:
    """One load's state and the covariance of its force vector (x, y in N) from the segment angles."""

    pressure: float
    direction: float
    tip: np.ndarray
    shape_mm: np.ndarray
    force_covariance: np.ndarray


def ellipses(pressures=ELLIPSE_PRESSURES, directions=ELLIPSE_DIRECTIONS, sd_deg: float = SD_DEG) -> list[Ellipse]:
    out = []
    kind = Measured("theta", (0.0, 0.0, 0.0), sd_deg)
    for p in pressures:
        for d in directions:
            scene = _scene(1.0, d, p)
            r = solve(scene)
            if not r.ok:
                continue
            info = information(scene, [kind], theta=np.asarray(r.theta))
            out.append(Ellipse(p, d, np.asarray(r.tip[:2]), np.asarray(r.centreline[:, :2]), info.force_covariance))
    return out


@dataclass(frozen=True, eq=False)
class Table3Case:
    """One reading of the paper's 2 N vertical payload."""

    source: str
    measured: str
    estimate: LoadEstimate


def table3_example() -> list[Table3Case]:
    """EXP and FEM (total angle and tip at 1 deg / 1 mm), and the model's own segment angles at 0.1 deg."""
    label, scene_cols, values = next(row for row in PAPER if row[0] == "2 N vertical")
    base = _scene(scene_cols["payload_n"], scene_cols["payload_angle_deg"])
    start = base.replace(payloads=(Payload(1.0, 90.0),))  # not the answer: the starts find it
    out = []
    for column in ("EXP", "FEM"):
        v = values[column]
        pose = Pose(None, (Measured("total_angle", (v["total_angle"],), SD_ANGLE), Measured("tip", (v["tip_x"], v["tip_y"]), SD_TIP)),
                    label=column, target_angle_deg=TARGET_DEG)
        out.append(Table3Case(f"the paper's {column}", f"total angle {v['total_angle']} deg ± {SD_ANGLE:g}, tip ({v['tip_x']}, {v['tip_y']}) mm ± {SD_TIP:g}",
                              estimate_load(pose, ("F1", "Omega1"), start)))
    theta = tuple(round(float(t), 2) for t in solve(base).theta_deg)
    pose = Pose(None, (Measured("theta", theta, 0.1),), label="model", target_angle_deg=TARGET_DEG)
    out.append(Table3Case("the model's own segment angles", f"theta ({', '.join(f'{t:.2f}' for t in theta)}) deg ± 0.1",
                          estimate_load(pose, ("F1", "Omega1"), start)))
    return out


@dataclass(frozen=True, eq=False)
class SensingCases:
    by_measurement: list[ByMeasurement]
    first_order: list[FirstOrderCheck]
    blind: BlindMap
    ellipses: list[Ellipse]
    table3: list[Table3Case]
    spatial: Any = None  # the 3-D section's cases (esba.calibration.cases3d.Sensing3DCases), when computed


def sensing_cases() -> SensingCases:
    """Every case of the page."""
    return SensingCases(by_measurement(), first_order_check(), blind_map(), ellipses(), table3_example())

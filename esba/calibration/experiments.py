"""How far to trust the model: the paper's experiments and FEM results against esba, fitted and cross-validated.

The paper (Sections 4.4 and 5) reports, for the Table 1 actuator, experimental (EXP) and finite
element (FEM) values next to its model with E = 0.54 MPa from a tensile test. They are here as
two measurement sets (:func:`paper_data`), the FEM column treated as a second "measured"
actuator. The comparison (:func:`compare_with_paper`):

* every measured value against esba's model with E = 0.54 MPa (:func:`esba.calibration.fit.predict`);
* E, and E with rho, fitted to all of each column (:func:`esba.calibration.fit.fit`);
* cross-validation both ways: E fitted on the unloaded measurements (the free bend and the 90
  degree pressure) and the payload cases and stiffnesses predicted, then the other way round,
  with each held-out error set against the first-order uncertainty propagated from the fitted
  E (and against the prediction band that adds the training fit's residual scatter); for E and
  rho together each fold's Fisher matrix shows what its rows cannot separate;
* what E known to +-20 % means for the main job (Table 2's scene), to first order and by Monte
  Carlo on the batch path (:mod:`esba.calibration.uncertainty`).

The paper states no measurement uncertainties. The sets carry assumed ones, stated with the
data: 1 deg on an angle (a camera and AutoCAD), 1 mm on a tip coordinate (the trakSTAR probe is
good to 0.1 mm, its placement on the tip less so), and for a stiffness K = 1000 F / delta the
effect of 1 mm on the displacement delta, K^2 / (1000 F). Every fit scales its Fisher matrix by
the residual variance, so only their ratios matter for the intervals.

The page ``docs/experiments.md`` is written from the comparison by :mod:`esba.pages.experiments`.

Examples
--------
>>> exp = paper_data("EXP")
>>> len(exp.rows), exp.count(), [r.label for r in exp.rows][:2]
(8, 12, ['free bend', '90 deg pressure'])
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

from esba.model.scene import MAIN_JOB, Scene
from esba.statics.equilibrium import pressure_for_angle, solve

from .fit import FitResult, Identifiability, Prediction, fit, identifiability, predict
from .measurements import MeasurementSet, measurements_from_rows
from .uncertainty import (
    Agreement,
    MonteCarloOptions,
    Propagation,
    compare,
    monte_carlo,
    parse_sigma,
    propagate,
    resolve_sigmas,
)

__all__ = ["COLUMNS", "PAPER", "UNLOADED", "paper_data", "Fold", "Column", "PaperComparison", "compare_with_paper", "PAPER_PRESSURE_90"]

#: The two columns of the paper's results.
COLUMNS = ("EXP", "FEM")

#: Assumed standard deviations (the paper gives none): angle (deg), tip coordinate (mm), and the
#: displacement behind a secant stiffness (mm).
SD_ANGLE, SD_TIP, SD_DISPLACEMENT = 1.0, 1.0, 1.0

#: The pressure each column needed for a 90 degree unloaded bend, MPa (Section 4.4.2; the
#: paper's model: 0.123).
PAPER_PRESSURE_90 = {"EXP": 0.124, "FEM": 0.121}

#: The paper's values: (label, scene columns, {column: {quantity: value}}). Units: deg, mm, N/m.
PAPER: tuple[tuple[str, dict, dict], ...] = (
    ("free bend", {"pressure_mpa": 0.2}, {"EXP": {"total_angle": 176.8}, "FEM": {"total_angle": 183.1}}),
    ("90 deg pressure", {}, {"EXP": {"total_angle": 90.0}, "FEM": {"total_angle": 90.0}}),  # at each column's pressure
    ("2 N horizontal", {"target_angle_deg": 90.0, "payload_n": 2.0, "payload_angle_deg": 90.0},
     {"EXP": {"total_angle": 28.8, "tip_x": 133.5, "tip_y": 8.1}, "FEM": {"total_angle": 32.4, "tip_x": 125.6, "tip_y": 15.3}}),
    ("2 N vertical", {"target_angle_deg": 90.0, "payload_n": 2.0, "payload_angle_deg": 0.0},
     {"EXP": {"total_angle": 53.2, "tip_x": 119.2, "tip_y": 50.8}, "FEM": {"total_angle": 50.2, "tip_x": 122.6, "tip_y": 47.3}}),
    ("K at 0.5 N", {"target_angle_deg": 90.0, "payload_n": 0.5, "payload_angle_deg": 90.0}, {"EXP": {"stiffness": 39.3}, "FEM": {"stiffness": 43.5}}),
    ("K at 1 N", {"target_angle_deg": 90.0, "payload_n": 1.0, "payload_angle_deg": 90.0}, {"EXP": {"stiffness": 29.1}, "FEM": {"stiffness": 33.7}}),
    ("K at 2 N", {"target_angle_deg": 90.0, "payload_n": 2.0, "payload_angle_deg": 90.0}, {"EXP": {"stiffness": 25.7}, "FEM": {"stiffness": 28.3}}),
    ("optimised prototype", {"pressure_mpa": 0.2317, "payload_n": 2.0, "payload_angle_deg": 90.0, "r2_mm": 1.5305, "d_mm": 0.0},
     {"EXP": {"stiffness": 46.62}}),
)

#: The rows without payload (the first fold of the cross-validation).
UNLOADED = ("free bend", "90 deg pressure")

_COLUMN_NAMES = {"total_angle": "total_angle_deg", "tip_x": "tip_x_mm", "tip_y": "tip_y_mm", "stiffness": "stiffness_n_per_m"}
_SD_NAMES = {"total_angle": "total_angle_sd_deg", "tip_x": "tip_x_sd_mm", "tip_y": "tip_y_sd_mm", "stiffness": "stiffness_sd_n_per_m"}


def _sd(quantity: str, value: float, force: float | None) -> float:
    if quantity == "total_angle":
        return SD_ANGLE
    if quantity in ("tip_x", "tip_y"):
        return SD_TIP
    return round(value**2 * SD_DISPLACEMENT / (1000.0 * force), 2)  # dK = K^2 d(delta) / (1000 F)


def paper_rows(column: str) -> list[tuple[str, dict]]:
    """The rows of one column as measurement-file rows (what the files in ``examples/measurements/`` hold)."""
    if column not in COLUMNS:
        raise ValueError(f"column={column!r}: allowed are {', '.join(COLUMNS)}")
    rows = []
    for label, scene, values in PAPER:
        if column not in values:
            continue
        row: dict[str, Any] = {"label": label, **scene}
        if label == "90 deg pressure":
            row["pressure_mpa"] = PAPER_PRESSURE_90[column]
        for q, v in values[column].items():
            row[_COLUMN_NAMES[q]] = v
            row[_SD_NAMES[q]] = _sd(q, v, scene.get("payload_n"))
        rows.append((label, row))
    return rows


def paper_data(column: str, base: Scene | None = None) -> MeasurementSet:
    """The paper's EXP or FEM column as a measurement set (Table 1 actuator, n = 3 by default)."""
    return measurements_from_rows(f"the paper's {column} column", paper_rows(column), Scene() if base is None else base)


# ---------------------------------------------------------------------------------------------
# the comparison


@dataclass(frozen=True, eq=False)
class Fold:
    """One direction of the cross-validation.

    Attributes
    ----------
    train, test : tuple of str
        Row labels.
    fit : FitResult
        E fitted on ``train``.
    both : Identifiability
        Whether ``train`` could determine E and rho together (at the paper's values).
    predictions : tuple of Prediction
        The held-out values at the fitted E, with the first-order sd propagated from its variance.
    z : float
        The two-sided ``level`` quantile of the normal distribution.
    t : float
        Student's t quantile on the training fit's degrees of freedom (prediction band).
    """

    train: tuple[str, ...]
    test: tuple[str, ...]
    fit: FitResult
    both: Identifiability
    predictions: tuple[Prediction, ...]
    z: float
    t: float

    def band(self, p: Prediction) -> float:
        """Half-width of the 95 % prediction band of a held-out value: t sqrt(sd_param^2 + s^2 sd_meas^2)."""
        sd_meas = next((r.sds.get(p.quantity) for r in self.fit.data.rows if r.label == p.row), None)
        s2 = self.fit.residual_variance
        extra = s2 * sd_meas**2 if (sd_meas is not None and math.isfinite(s2)) else 0.0
        return self.t * math.sqrt(p.sd**2 + extra)

    def inside_parameter_band(self, p: Prediction) -> bool:
        """|error| within z times the propagated sd (the parameter's uncertainty alone)."""
        return abs(p.error) <= self.z * p.sd

    def inside_prediction_band(self, p: Prediction) -> bool:
        """|error| within the prediction band (the parameter's uncertainty and the training scatter)."""
        return abs(p.error) <= self.band(p)


@dataclass(frozen=True, eq=False)
class Column:
    """The comparison of one column (EXP or FEM)."""

    name: str
    data: MeasurementSet
    nominal: tuple[Prediction, ...]
    pressure_90: float
    fit_e: FitResult
    fit_both: FitResult
    folds: tuple[Fold, ...]
    fitted: tuple[Prediction, ...]


@dataclass(frozen=True, eq=False)
class PaperComparison:
    """Everything ``docs/experiments.md`` reports.

    ``identifiability_all``: column -> Fisher ratio of E and rho from all its rows at the paper's
    values; ``tradeoff``: d ln(r1 - 4 r2 tan^2 rho) / d ln rho at the paper's values, the relative
    change of E that a relative change of rho needs to leave an unloaded bend as it is.
    """

    columns: tuple[Column, ...]
    model_pressure_90: float
    modulus_first_order: Propagation
    modulus_monte_carlo: Any
    modulus_agreement: Agreement
    level: float
    identifiability_all: dict
    tradeoff: float
    spatial: Any = None  # the 3-D section's cases (esba.calibration.cases3d.Experiments3DCases), when computed


def _fold(data: MeasurementSet, train: tuple[str, ...], level: float) -> Fold:
    test = tuple(r.label for r in data.rows if r.label not in train)
    tr = data.subset(train)
    f = fit(tr, ("E",))
    both = identifiability(tr, ("E", "rho"))
    preds = predict(data.subset(test), f.params(), f.covariance)
    z = float(stats.norm.ppf(0.5 + level / 2))
    t = float(stats.t.ppf(0.5 + level / 2, f.dof)) if f.dof > 0 else math.nan
    return Fold(train, test, f, both, preds, z, t)


#: The main job's modulus tolerance of the comparison: E known to +-20 % (uniform).
MODULUS_TOLERANCE = "E=±20%"
#: Monte Carlo samples and seed of the comparison.
MC_SAMPLES, MC_SEED = 10_000, 0


def compare_with_paper(segments: int = 3, level: float = 0.95) -> PaperComparison:
    """Run every comparison of ``docs/experiments.md`` (about half a minute)."""
    base = Scene(segments=segments)
    columns = []
    for name in COLUMNS:
        data = paper_data(name, base)
        unloaded = tuple(r.label for r in data.rows if r.label in UNLOADED)
        loaded = tuple(r.label for r in data.rows if r.label not in UNLOADED)
        f_e = fit(data, ("E",))
        f_both = fit(data, ("E", "rho"))
        cov = f_both.covariance if np.all(np.isfinite(f_both.covariance)) else None
        columns.append(Column(
            name=name, data=data, nominal=predict(data), pressure_90=PAPER_PRESSURE_90[name], fit_e=f_e, fit_both=f_both,
            folds=(_fold(data, unloaded, level), _fold(data, loaded, level)), fitted=predict(data, f_both.params(), cov),
        ))
    job = MAIN_JOB.replace(segments=segments)
    sig = resolve_sigmas(job, [parse_sigma(MODULUS_TOLERANCE)])
    first = propagate(solve(job), sig)
    mc = monte_carlo(job, sig, MonteCarloOptions(samples=MC_SAMPLES, seed=MC_SEED))
    ident = {c.name: identifiability(c.data, ("E", "rho")).ratio for c in columns}
    a = base.actuator
    rho, tan = math.radians(a.rho_deg), math.tan(math.radians(a.rho_deg))
    tradeoff = -8.0 * a.r2 * tan * (1.0 + tan**2) * rho / (a.r1 - 4.0 * a.r2 * tan**2)
    return PaperComparison(tuple(columns), pressure_for_angle(base, 90.0), first, mc, compare(first, mc), level, ident, tradeoff)

"""``esba fit`` in 3-D: the section stiffnesses the paper does not give, from 3-D poses under known loads.

The paper's experiments are planar; its model has no sideways bending stiffness EI_side and no
torsional stiffness GJ (docs/3d.md). With a 3-D tracker (tip position and orientation, markers,
joint angles; the file format of :mod:`esba.calibration.poses3d`, each row a pressure, a known
payload and what was measured) this fits EI_side and GJ (N mm^2) by the weighted least squares of
:mod:`esba.calibration.spatial_ls`: estimates, standard errors, intervals at ``level``,
correlation, the residual chi-square, and the identifiability rule of
:func:`esba.calibration.fit.identifiability_rule` on the Fisher matrix (relative changes).
The stated standard deviations are taken as they are (no rescaling by the residuals).

:func:`experiment_information` says before any measurement what a candidate experiment would
determine: the Fisher matrix of (EI_side, GJ) in relative changes at the model's prediction, its
rank and the standard errors it would give. In-plane loads leave the actuator in its plane, where
neither stiffness acts: such rows carry no information about them (computed, docs/experiments.md).

>>> from esba.model.scene import Scene, Payload
>>> from esba.calibration.spatial_ls import Measured3D
>>> from esba.calibration.sensing3d import Pose3D, predict3d
>>> truth = {"EI_side": 3e4, "GJ": 1.5e4}
>>> rows = []
>>> for P, beta in ((0.0, 90.0), (0.15, 90.0), (0.15, 45.0)):
...     scene = Scene(pressure=P, payloads=(Payload(0.3, 90.0, 1.0, beta),))
...     q, (tip, rot) = predict3d(scene, truth, P, [("tip", None), ("rotation", None)])
...     pose = Pose3D(P, (Measured3D("tip", tuple(tip), 0.1), Measured3D("rotation", tuple(rot), 0.2)))
...     rows.append((pose, (0.3, 90.0, beta, 1.0)))
>>> r = fit_section(rows, Scene(), start={"EI_side": 1e4, "GJ": 1e4})
>>> r.ok, [round(float(v)) for v in r.estimate]
(True, [30000, 15000])
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
from scipy import stats

from esba.calibration.fit import fisher_correlation, identifiability_rule
from esba.calibration.sensing3d import Pose3D
from esba.calibration.spatial_ls import Problem, Row, SpatialLSError
from esba.infra.report import Report
from esba.infra.threads import single_threaded
from esba.model.scene import Payload, Scene, SceneError

__all__ = ["fit_section", "FitResult3D", "experiment_information", "ExperimentInformation", "FREE3D", "Fit3DError"]

Fit3DError = SpatialLSError
#: What the 3-D fit fits (N*mm^2).
FREE3D = ("EI_side", "GJ")
MISFIT_P = 1e-3


def _check_free(free: Sequence[str]) -> tuple[str, ...]:
    if isinstance(free, str):
        free = [s.strip() for s in free.split(",")]
    out = tuple(str(f).strip() for f in free)
    if not out:
        raise Fit3DError(f"free: name one or both of {', '.join(FREE3D)}")
    for f in out:
        if f not in FREE3D:
            raise Fit3DError(f"free {f!r}: the 3-D fit fits the section's {', '.join(FREE3D)} (N*mm^2); fit the in-plane parameters with a planar file")
    if len(set(out)) != len(out):
        raise Fit3DError(f"free {','.join(out)}: a name given twice")
    return out


def _scene_row(base: Scene, pose: Pose3D, payload, where: str) -> Scene:
    try:
        sc = pose.scene(base)
        loads = () if payload is None else (Payload(payload[0], payload[1], payload[3], payload[2]),)
        return sc.replace(payloads=loads)
    except SceneError as exc:
        raise Fit3DError(f"{where}: {exc}") from None


def _problem(rows, base: Scene, free: tuple[str, ...], start: dict):
    from esba.derive.effects3d import Effects3D
    from esba.model.spatial import load_model3d
    from esba.statics.spatial import scene_values3d

    payloads = max((0 if p is None else 1) for _, p in rows)
    model = None
    out = []
    for k, (pose, payload) in enumerate(rows):
        where = pose.label or f"row {k + 1}"
        sc = _scene_row(base, pose, payload, where)
        effects, values = scene_values3d(sc, start, sc.down())
        if payloads and payload is None:  # a row without payload in a file with payloads: the same model, F = 0
            values.update(F1=0.0, Omega1=0.0, Beta1=0.0, s1=1.0)
            effects = Effects3D.from_planar(sc.replace(payloads=(Payload(0.0),)).effects)
        if model is None:
            model = load_model3d(base.segments, effects, base.variant)
        for m in pose.measured:
            m.check_segments(base.segments)
        out.append(Row(values, pose.measured, where))
    scale = np.array([start[f] for f in free])
    return Problem(model, out, free, np.ones(len(free)), scale, 1e-6 * scale, None)


@dataclass(repr=False)
class FitResult3D(Report):
    free: tuple[str, ...]
    start: np.ndarray
    estimate: np.ndarray
    std_error: np.ndarray
    interval: np.ndarray
    covariance: np.ndarray
    correlation: np.ndarray
    level: float
    chi2: float
    dof: int
    p_value: float
    identifiable: bool
    residuals: list
    status: str
    message: str
    iterations: int
    warnings: list = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def headline(self) -> str:
        return f"{self.status}: " + ", ".join(f"{n} = {v:.4g} N*mm^2" for n, v in zip(self.free, self.estimate))

    def summary(self) -> str:
        return fit3d_table(self.to_dict())

    def to_dict(self) -> dict:
        def num(v):
            return float(v) if math.isfinite(float(v)) else None

        return {
            "model": "3d", "status": self.status, "message": self.message, "level": self.level,
            "parameters": {n: {"estimate": num(self.estimate[j]), "start": num(self.start[j]), "std_error": num(self.std_error[j]),
                               "interval": [num(self.interval[j, 0]), num(self.interval[j, 1])], "unit": "N*mm^2"}
                           for j, n in enumerate(self.free)},
            "covariance": [[num(c) for c in row] for row in self.covariance],
            "correlation": [[num(c) for c in row] for row in self.correlation],
            "chi2": num(self.chi2), "dof": self.dof, "p_value": num(self.p_value), "identifiable": self.identifiable,
            "residuals": self.residuals, "iterations": self.iterations, "warnings": list(self.warnings),
        }


def fit3d_table(d: dict) -> str:
    def f(v, fmt=".5g"):
        return "-" if v is None else format(v, fmt)

    lines = [f"3-D fit: {d['status']}" + (f" ({d['message']})" if d["message"] else "")]
    lines.append(f"{'parameter':<9} {'start':>10} {'estimate':>11} {'std error':>10} {int(round(100 * d['level'])):>3} % interval (N*mm^2)")
    for n, p in d["parameters"].items():
        lines.append(f"{n:<9} {f(p['start'], '.4g'):>10} {f(p['estimate']):>11} {f(p['std_error'], '.3g'):>10} [{f(p['interval'][0])}, {f(p['interval'][1])}]")
    lines.append(f"chi2 = {f(d['chi2'], '.4g')} with {d['dof']} degrees of freedom" + (f", p = {d['p_value']:.3g}" if d["p_value"] is not None else ""))
    lines += [f"warning: {w}" for w in d["warnings"]]
    return "\n".join(lines)


def _check_rows(rows) -> list:
    out = []
    for k, item in enumerate(rows if isinstance(rows, (list, tuple)) else []):
        if hasattr(item, "pose") and hasattr(item, "payload"):
            item = (item.pose, item.payload)
        if not (isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], Pose3D)):
            raise Fit3DError(f"rows[{k}]: expected (Pose3D, payload (F, Omega deg, Beta deg, at) or None)")
        out.append(item)
    if not out:
        raise Fit3DError("rows: expected one or more (Pose3D, payload) rows")
    return out


@single_threaded
def fit_section(rows, base: Scene | None = None, free: Sequence[str] = FREE3D, start: dict | None = None, *, level: float = 0.95,
                max_iter: int = 100) -> FitResult3D:
    """Fit ``free`` (of EI_side, GJ) to ``rows`` ((Pose3D, payload) each) on ``base``'s actuator.

    ``start``: the starting stiffnesses (default: the eccentric section's, :mod:`esba.model.section`).
    """
    from esba.statics.spatial import SpatialError, check_section

    rows = _check_rows(rows)
    base = Scene() if base is None else base
    free = _check_free(free)
    if not 0.0 < float(level) < 1.0:
        raise Fit3DError(f"level={level!r}: expected a confidence level between 0 and 1")
    try:
        start = check_section(start, base)
    except SpatialError as exc:
        raise Fit3DError(str(exc)) from None
    prob = _problem(rows, base, free, start)
    z0 = np.array([start[f] for f in free])
    try:
        z, qs, r, J, it, conv = prob.solve(z0, max_iter=max_iter)
    except RuntimeError as exc:
        raise Fit3DError(f"at the start stiffnesses: {exc}") from None
    k, m = len(free), prob.m
    F = J.T @ J
    ident, _, unknown, words, _ = identifiability_rule(F, m, free, prob.scale, z, [], 1e-6, 1e-12, ["N*mm^2"] * k)
    cov = np.full((k, k), np.nan)
    se = np.full(k, np.nan)
    known = ~unknown
    if np.any(known):
        c = np.linalg.inv(F[np.ix_(known, known)])
        cov[np.ix_(known, known)] = 0.5 * (c + c.T)
        se[known] = np.sqrt(np.maximum(np.diag(c), 0.0))
    zq = float(stats.norm.ppf(0.5 + level / 2))
    interval = np.column_stack([z - zq * se, z + zq * se])
    chi2 = float(r @ r)
    dof = max(m - k, 0)
    p_value = float(stats.chi2.sf(chi2, dof)) if dof > 0 else math.nan
    residuals, i0 = [], 0
    for row in prob.rows:
        for mm in row.measured:
            c = mm.count()
            for name, v in zip(mm.quantities(prob.model.n), r[i0:i0 + c]):
                residuals.append({"row": row.label, "quantity": name, "weighted": float(v)})
            i0 += c
    status, message = "ok", ""
    if not conv:
        status, message = "failed", f"the Levenberg-Marquardt iteration did not converge in {max_iter} iterations"
    elif dof > 0 and p_value < MISFIT_P:
        status, message = "misfit", f"the model does not reproduce the data within the stated deviations (chi2 = {chi2:.4g}, {dof} dof, p = {p_value:.2g})"
    return FitResult3D(free, z0, z, se, interval, cov, fisher_correlation(F, prob.scale), float(level), chi2, dof, p_value, bool(ident),
                       residuals, status, message, it, list(words))


@dataclass
class ExperimentInformation:
    """What one candidate experiment would tell about (EI_side, GJ): Fisher matrix in relative changes,
    its eigenvalues (largest first), rank (eigenvalues above 1e-6 of the largest, and above 1e-12
    per measured value) and the relative standard errors it would give (None where undetermined)."""

    label: str
    fisher: np.ndarray
    eigenvalues: np.ndarray
    rank: int
    relative_se: list


@single_threaded
def experiment_information(base: Scene, section: dict, pressure: float, payload: tuple[float, float, float, float] | None,
                           kinds: Sequence[tuple[str, float | None, float]], label: str = "") -> ExperimentInformation:
    """The Fisher information about (EI_side, GJ) of measuring ``kinds`` ((kind, at, sd) each) at
    ``pressure`` under ``payload`` (F, Omega deg, Beta deg, at), at the model's prediction with ``section``."""
    from esba.calibration.sensing3d import predict3d
    from esba.calibration.spatial_ls import Measured3D

    scene = _scene_row(base, Pose3D(pressure, (Measured3D("tip", (0.0, 0.0, 0.0), 1.0),)), payload, label or "experiment")
    q, preds = predict3d(scene, section, pressure, [(k, a) for k, a, _ in kinds])
    pose = Pose3D(pressure, tuple(Measured3D(k, tuple(v), sd, a) for (k, a, sd), v in zip(kinds, preds)))
    prob = _problem([(pose, payload)], base, FREE3D, dict(section))
    z = np.array([section[f] for f in FREE3D])
    _, J, _, _ = prob.evaluate(z, [q])
    Js = J * prob.scale[None, :]
    Frel = Js.T @ Js
    w = np.linalg.eigvalsh(Frel)[::-1]
    floor = 1e-12 * max(prob.m, 1)
    rank = int(np.sum((w > 1e-6 * w[0]) & (w > floor))) if w[0] > 0 else 0
    se: list = [None, None]
    if rank == 2:
        c = np.linalg.inv(Frel)
        se = [float(math.sqrt(c[0, 0])), float(math.sqrt(c[1, 1]))]
    return ExperimentInformation(label, Frel, w, rank, se)

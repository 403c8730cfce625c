"""Uncertainty of a 3-D equilibrium: first-order propagation, checked by Monte Carlo, as in the plane.

The planar machinery (:mod:`esba.calibration.uncertainty`) on the 3-D model (:mod:`esba.statics.spatial`):

- **Uncertain parameters**: the planar scene's (``--sigma E=10%``, an ``[uncertainty]`` table), and
  the 3-D ones: each payload's angle out of the bending plane ``Beta1``, ... (deg) and the
  section's stiffnesses ``EI_side``, ``GJ`` (N mm^2), resolved by
  :func:`esba.calibration.sigmas.resolve_sigmas` with the section. The section is held at its given
  (or the nominal scene's eccentric-section) values unless it has a sigma of its own, as the 3-D
  sweep holds it.
- **First order** (:func:`propagate3d`): Cov(y) = S diag(sigma^2) S^T with the 3-D sensitivities
  S of :mod:`esba.analysis.sensitivity3d`, for y = the tip (x, y, z), the total in-plane angle,
  the total sideways bend sum(psi) and the total twist sum(tau). No numbers near a fold or a
  sideways buckling point; ``beyond_linear_range`` when 3 sigma reaches one, by the planar rules.
- **Monte Carlo** (:func:`monte_carlo3d`): the planar Monte Carlo's samples, drawn up front from one
  seeded generator (:func:`esba.calibration.uncertainty.draw_samples`), each solved on its own along
  its load history (:func:`esba.statics.spatial.solve3d`: inflate, then raise the loads, and past a
  sideways branch point down to the stable state below, as the nominal solve; no warm
  start from another sample), in chunks through :func:`esba.calibration.uncertainty.run_samples`.
  A sample's answer depends on its parameters alone, so any chunking, any order and any runner
  (in this process or on Dask, :mod:`esba.studies.monte_carlo`) give the same numbers, bit for bit.
  :func:`esba.calibration.uncertainty.compare` sets the two side by side.

For a scene whose loads lie in the bending plane (and no sigma of a Beta) the in-plane numbers are
the planar ones: the first-order deviations of the tip's x, y and the total angle to 1e-10,
the samples' to the solvers' tolerance; y_z, sideways and twist are 0.

>>> from esba.model.scene import Payload, Scene
>>> from esba.calibration.sigmas import parse_sigma, resolve_sigmas
>>> from esba.statics.spatial import check_section, solve_scene3d
>>> scene = Scene(pressure=0.12, payloads=(Payload(0.6, 90.0, 1.0, 20.0),))
>>> section = check_section({"EI_side": 4e5, "GJ": 1e5}, scene)
>>> sig = resolve_sigmas(scene, [parse_sigma("GJ=20%"), parse_sigma("Beta1=±5")], section)
>>> u = propagate3d(scene, section, solve_scene3d(scene, section), sig)
>>> u.status, round(u.std("tip_z"), 3), round(u.std("twist"), 3)
('ok', 0.105, 0.104)
>>> mc = monte_carlo3d(scene, sig, MonteCarloOptions(samples=40, chunk=16), section=section)
>>> mc.counts["ok"], round(mc.std("tip_z"), 3)
(40, 0.108)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, ClassVar, Mapping, Sequence

import numpy as np

from esba.analysis.sensitivity import SensitivityOptions
from esba.analysis.sensitivity3d import OUTPUTS3D, sensitivities3d, with_parameters3d
from esba.infra import jsonsafe
from esba.model.scene import Scene, SceneError

from .sigmas import Sigma, UncertaintyError, _checked_sigmas
from .uncertainty import (
    SAMPLE_INVALID,
    SAMPLE_NOT_OK,
    SAMPLE_OK,
    MonteCarlo,
    MonteCarloOptions,
    Propagation,
    check_monte_carlo,
    linear_range,
    run_samples,
    variance_shares,
)

__all__ = ["OUTPUTS3D", "Propagation3D", "propagate3d", "solve_samples3d", "MonteCarlo3D", "monte_carlo3d", "uncertainty3d_rows"]

_INDEX = {o: i for i, (o, _) in enumerate(OUTPUTS3D)}


def _std(cov: np.ndarray, output: str) -> float:
    i = _INDEX[output]
    s = math.sqrt(max(float(cov[i, i]), 0.0))
    return math.degrees(s) if i >= 3 else s


@dataclass(frozen=True, eq=False, repr=False)
class Propagation3D(Propagation):
    """First-order uncertainty of a 3-D equilibrium: a :class:`esba.calibration.uncertainty.Propagation`
    (its in-plane fields: ``cov_theta``, the tip's x-y covariance ``cov_tip``, ``var_total``) with
    the 3-D outputs.

    Attributes
    ----------
    cov_q : ndarray, shape (3n, 3n)
        Covariance of (theta, psi, tau), rad^2.
    cov_out : ndarray, shape (6, 6)
        Covariance of :data:`esba.analysis.sensitivity3d.OUTPUTS3D` (mm and rad).
    nominal_out : ndarray, shape (6,)
        The solved outputs, mm and deg.
    """

    cov_q: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    cov_out: np.ndarray = field(default_factory=lambda: np.full((6, 6), np.nan))
    nominal_out: np.ndarray = field(default_factory=lambda: np.full(6, np.nan))

    outputs: ClassVar[tuple[tuple[str, str], ...]] = OUTPUTS3D

    def nominal(self, output: str) -> float:
        return float(self.nominal_out[_INDEX[output]])

    def std(self, output: str) -> float:
        """Standard deviation of an output of :data:`OUTPUTS3D` (mm or deg)."""
        return _std(self.cov_out, output)

    def headline(self) -> str:
        if not self.has_numbers:
            return f"{self.status}: {self.message}"
        return (f"{self.status}: std tip {self.std('tip_x'):.4g}, {self.std('tip_y'):.4g}, {self.std('tip_z'):.4g} mm, total angle "
                f"{self.std('total_angle'):.4g}, sideways {self.std('sideways'):.4g}, twist {self.std('twist'):.4g} deg (first order)")

    def summary(self) -> str:
        return "\n".join(f"{k:>12}: {v}" for k, v in uncertainty3d_rows({"uncertainty": self.to_dict()}))

    def to_dict(self) -> dict:
        num = self.has_numbers
        n = self.cov_q.shape[0] // 3
        axes, angle = self.ellipse() if num else (None, None)
        sd_q = [math.degrees(math.sqrt(max(v, 0.0))) for v in np.diag(self.cov_q)] if num else None
        return jsonsafe.clean({
            "model": "3d",
            "status": self.status,
            "message": self.message,
            "sigmas": [s.to_dict() for s in self.sigmas],
            "nominal": {o: self.nominal(o) for o, _ in OUTPUTS3D},
            "std": {o: (self.std(o) if num else None) for o, _ in OUTPUTS3D},
            "std_tip_mm": [self.std(o) for o in ("tip_x", "tip_y", "tip_z")] if num else None,
            "std_total_angle_deg": self.std("total_angle") if num else None,
            "cov_tip_mm2": self.cov_out[:3, :3].tolist() if num else None,
            "std_theta_deg": sd_q[:n] if num else None,
            "std_psi_deg": sd_q[n:2 * n] if num else None,
            "std_tau_deg": sd_q[2 * n:] if num else None,
            "tip_ellipse_95": {"semi_axes_mm": axes, "angle_deg": math.degrees(angle), "plane": "x-y (the bending plane)"} if num else None,
            "variance_shares": self.shares if num else None,
        })


def propagate3d(scene: Scene, section: Mapping[str, float], result, sigmas: Sequence[Sigma], options: SensitivityOptions | None = None,
                *, gravity_direction=None) -> Propagation3D:
    """First-order uncertainty of the tip, the joint angles and the total angles of a 3-D equilibrium.

    Parameters
    ----------
    scene : Scene
    section : dict
        Both stiffnesses (:func:`esba.statics.spatial.check_section` with the scene).
    result : Equilibrium3D
        The solve of ``scene`` (:func:`esba.statics.spatial.solve_scene3d`).
    sigmas : sequence of Sigma
        From :func:`esba.calibration.sigmas.resolve_sigmas` with ``section``.
    """
    sigmas = _checked_sigmas(scene, sigmas, three_d=True)
    names = [s.name for s in sigmas]
    sens = sensitivities3d(scene, section, result, names, options, gravity_direction=gravity_direction)
    n = scene.segments
    tip = np.asarray(result.tip, dtype=float)
    nominal = np.array([*tip, *(math.degrees(float(np.sum(b))) for b in (result.theta, result.psi, result.tau))])
    if sens.status in ("near_fold", "not_stable"):
        return _empty(sigmas, sens.status, sens.message, n, nominal)
    sd = np.array([s.sigma for s in sigmas])
    with np.errstate(over="ignore", invalid="ignore"):
        Sq = sens.dq * sd[None, :]
        So = sens.dout * sd[None, :]  # each column: one parameter's 1-sigma effect
        cov_q, cov_out = Sq @ Sq.T, So @ So.T
    if not (np.all(np.isfinite(cov_q)) and np.all(np.isfinite(cov_out))):
        given = ", ".join(s.given for s in sigmas)
        return _empty(sigmas, "overflow", f"the first-order covariance of {given} overflows (not a finite number): the sigmas are far beyond the model's range", n, nominal)
    shares = variance_shares(So, names, OUTPUTS3D)
    status, message = linear_range(sigmas, sens.fold_distance, "the fold or buckling point")
    return Propagation3D(sigmas=sigmas, status=status, message=message, cov_theta=cov_q[:n, :n], cov_tip=cov_out[:2, :2], var_total=float(cov_out[3, 3]),
                         shares=shares, nominal_tip=tip[:2].copy(), nominal_total_deg=float(nominal[3]), cov_q=cov_q, cov_out=cov_out, nominal_out=nominal)


def _empty(sigmas, status: str, message: str, n: int, nominal: np.ndarray) -> Propagation3D:
    return Propagation3D(sigmas, status, message, np.full((n, n), np.nan), np.full((2, 2), np.nan), math.nan, {}, nominal[:2].copy(), float(nominal[3]),
                         np.full((3 * n, 3 * n), np.nan), np.full((6, 6), np.nan), nominal)


def solve_samples3d(base: Scene, section: Mapping[str, float], gravity_direction, names: Sequence[str], values: np.ndarray) -> dict[str, np.ndarray]:
    """Solve one chunk of samples in 3-D, each on its own along its load history: a pure function of its arguments.

    Returns ``code`` (k,) (``SAMPLE_OK``, ``SAMPLE_INVALID``, ``SAMPLE_NOT_OK``), ``q`` (k, 3n) rad,
    ``tip`` (k, 3) mm and ``pressure`` (k,) MPa; NaN where not ok (the pressure also where not stable).
    """
    from esba.model.spatial import load_model3d
    from esba.statics.spatial import scene_values3d, solve3d

    names = tuple(names)
    values = np.asarray(values, dtype=float).reshape(len(names), -1)
    k, n = values.shape[1], base.segments
    code = np.full(k, SAMPLE_INVALID)
    q = np.full((k, 3 * n), np.nan)
    tip = np.full((k, 3), np.nan)
    pressure = np.full(k, np.nan)
    for i in range(k):
        try:
            scene, sec = with_parameters3d(base, section, dict(zip(names, values[:, i])))
        except SceneError:
            continue
        effects, vals = scene_values3d(scene, sec, gravity_direction)
        eq = solve3d(load_model3d(n, effects, scene.variant), vals, certify=False, descend=True)
        pressure[i] = vals["P"]
        code[i] = SAMPLE_OK if eq.ok else SAMPLE_NOT_OK
        if eq.ok:
            q[i], tip[i] = eq.q, eq.tip
    return {"code": code, "q": q, "tip": tip, "pressure": pressure}


@dataclass(frozen=True, eq=False)
class MonteCarlo3D(MonteCarlo):
    """Monte Carlo of a 3-D equilibrium's uncertainty: a :class:`esba.calibration.uncertainty.MonteCarlo`
    whose ``tip`` has three columns, with every sample's state ``q`` (N, 3n) (rad, NaN where not ok)
    and the section it was solved with."""

    q: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    section: dict = field(default_factory=dict)

    outputs: ClassVar[tuple[tuple[str, str], ...]] = OUTPUTS3D

    def values(self, output: str) -> np.ndarray:
        """The solved samples of an output of :data:`OUTPUTS3D` (mm or deg)."""
        ok = self.ok
        i = _INDEX[output]
        if i < 3:
            return self.tip[ok, i]
        n = self.q.shape[1] // 3
        return np.degrees(np.sum(self.q[ok, (i - 3) * n:(i - 2) * n], axis=1))

    @property
    def cov_tip(self) -> np.ndarray:
        """Covariance of the tip (x, y, z) over the solved samples, mm^2."""
        t = self.tip[self.ok]
        return np.cov(t.T) if len(t) > 2 else np.full((3, 3), np.nan)

    def to_dict(self) -> dict:
        out = super().to_dict()
        out.update(model="3d", section_nmm2=dict(self.section))
        return jsonsafe.clean(out)


def monte_carlo3d(
    scene: Scene,
    sigmas: Sequence[Sigma],
    options: MonteCarloOptions | None = None,
    *,
    section: Mapping[str, float] | None = None,
    gravity_direction=None,
    chunks: Sequence[int] | None = None,
    execute: Callable | None = None,
    solved: dict[str, np.ndarray] | None = None,
    on_chunk: Callable[[int, dict[str, np.ndarray]], None] | None = None,
    progress: bool = False,
) -> MonteCarlo3D:
    """Sample the uncertain parameters (3-D ones included) and solve every sample in 3-D.

    ``section``: the section's stiffnesses (those not given: the eccentric section's of ``scene``,
    held for every sample). ``chunks``, ``execute``, ``solved`` (``code``, ``q``, ``tip`` of the first
    k samples), ``on_chunk`` and ``progress`` as for :func:`esba.calibration.uncertainty.monte_carlo`.
    ``options.batch`` must be None: the 3-D samples are not solved on the planar batch path.
    """
    from esba.statics.spatial import SpatialError, check_direction, check_section

    options, sigmas = check_monte_carlo(scene, sigmas, options, three_d=True)
    if options.batch is not None:
        raise UncertaintyError("batch: a 3-D Monte Carlo solves each sample along its own load history (esba.statics.spatial.solve3d); give batch=None")
    try:
        section = check_section(section, scene)
        down = tuple(float(x) for x in check_direction("gravity direction", scene.down(gravity_direction)))
    except SpatialError as exc:
        raise UncertaintyError(str(exc)) from None
    names = tuple(s.name for s in sigmas)
    values, merged = run_samples(scene, sigmas, options, solve_samples3d, lambda v: (scene, section, down, names, v), ("code", "q", "tip"),
                                 chunks=chunks, execute=execute, solved=solved, on_chunk=on_chunk, progress=progress)
    n = scene.segments
    theta = merged["q"][:, :n]
    return MonteCarlo3D(sigmas, options, values, merged["code"], theta, merged["tip"], np.sum(theta, axis=1),
                        "3-D load history in Python (esba.statics.spatial.solve3d)", merged["q"], dict(section))


def uncertainty3d_rows(d: dict) -> list[tuple[str, str]]:
    """The text rows of ``d["uncertainty"]`` (:meth:`Propagation3D.to_dict`), ``d["monte_carlo"]``
    (:meth:`MonteCarlo3D.to_dict`) and ``d["agreement"]`` when given."""
    u = d["uncertainty"]
    given = ", ".join(f"{s['name']} {s['sigma']:.4g} {s['unit']}" + (" (uniform)" if s["distribution"] == "uniform" else "") for s in u["sigmas"])
    rows = [("sigmas", given)]

    def line(std: dict) -> str:
        def num(v):
            return "-" if v is None else f"{v:.4g}"
        return (f"std tip x, y, z {num(std['tip_x'])}, {num(std['tip_y'])}, {num(std['tip_z'])} mm; total angle {num(std['total_angle'])}, "
                f"sideways {num(std['sideways'])}, twist {num(std['twist'])} deg")

    first = u["std_total_angle_deg"] is not None
    if first:
        rows.append(("first order", line(u["std"])))
        if u["status"] != "ok":
            rows.append(("NOT LINEAR", u["message"]))
    else:
        rows.append(("uncertainty", f"{u['status']}: {u['message']}"))
    mc = d.get("monte_carlo")
    if mc:
        c = mc["counts"]
        rows.append(("Monte Carlo", f"{c['samples']} samples (seed {mc['seed']}): {c['ok']} solved, {c['invalid']} outside the scene's rules, "
                                    f"{c['not_ok']} without a stable equilibrium; {line(mc['std'])}"))
        st = mc.get("study")
        if st:
            where = f"; samples in {st['out']}" + (f" (resumed at sample {st['resumed_from_sample']})" if st.get("resumed_from_sample") else "") if st.get("out") else ""
            rows.append(("solved", f"{st['runner']} in {st['seconds']:.1f} s{where}"))
        rows.append(("agreement", d["agreement"]["verdict"] if first else
                     f"none to judge: first order gives no answer ({u['status']}, above); the Monte Carlo is the estimate"))
    return rows


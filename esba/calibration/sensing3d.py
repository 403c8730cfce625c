"""The payload in 3-D from what a 3-D tracker measures: a force in space, and a moment where identifiable.

The 3-D counterpart of :mod:`esba.calibration.sensing`, on the spatial model (:mod:`esba.model.spatial`,
docs/3d.md). A tracker such as the paper's trakSTAR gives the tip's position and orientation;
markers along the length give points; a shape sensor gives the 3n joint angles. Each pose is a
pressure (or the unloaded target angle that sets it) and what was measured there
(:class:`esba.calibration.spatial_ls.Measured3D`, each with its standard deviation).

**Unknowns** (``free``), of the k-th payload: ``F{k}`` (N), ``Omega{k}`` (deg, in the bending plane as
in Eq. 14), ``Beta{k}`` (deg, out of the plane toward +z; the scene file's ``out_of_plane_deg``) and
``s{k}`` (its point, fraction of L); and a point moment at the tip ``mx1``, ``my1``, ``mz1`` (N mm,
body components at the tip as the 3-D model defines them, docs/3d.md). Words: ``force`` = F1,
``angle`` = Omega1, ``out`` = Beta1, ``at`` = s1, ``moment`` = mx1, my1, mz1. The force is also
reported as a vector in the base frame, f = F (cos B cos Omega, -cos B sin Omega, sin B), with its
covariance (first order).

**The estimate** is the weighted least squares of :mod:`esba.calibration.spatial_ls` over the poses
(poses share the load: an object held at several pressures). It runs from the scene's payload and
from ``starts`` more loads (directions spread over the sphere, the scene's magnitude), each from the
state the load history reaches; every distinct load whose residual sum lies within the ``level``
quantile of chi-square (k unknowns) of the best one is listed: the estimate is unique when there is one.

**Intervals** ``estimate +- z_level std_error`` from (J^T J)^-1, J the Jacobian of the whitened
residuals: the stated standard deviations taken as they are; the residual chi-square and its
p-value say whether they fit (status ``misfit`` below p = 1e-3). The joint confidence region is
the force vector's ellipsoid (``force``, ``force_covariance``): the poses are nearly linear in the
force's components, while (F, Omega, Beta) are its polar coordinates, whose joint ellipse the
curvature of that map bends (each of their intervals covers at its rate; their joint ellipse
does not, at a tracker's noise; ``tests/calibration/test_sensing3d.py`` counts the intervals and the force vector's region).

**Identifiability** (:func:`identifiability3d`): the rule of
:func:`esba.calibration.fit.identifiability_rule` on the Fisher matrix, and the singular values
of the whitened sensitivity (its rank and condition number) with the combination of unknowns
the data determine worst: computed at the state, not asserted.

For loads in the bending plane measured in the plane (psi = tau = 0, tip z = 0, ...), the 3-D
estimate is the planar one of :mod:`esba.calibration.sensing` (``tests/calibration/test_sensing3d.py``
checks it to 1e-10).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np
from scipy import stats

from esba.calibration.fit import fisher_correlation, identifiability_rule
from esba.calibration.spatial_ls import Measured3D, Problem, Row, SpatialLSError
from esba.infra import checks
from esba.infra.report import Report
from esba.infra.threads import single_threaded
from esba.model.scene import Scene, SceneError

__all__ = ["Pose3D", "Measured3D", "LoadEstimate3D", "Identifiability3D", "estimate_load3d", "identifiability3d", "free_names3d",
           "predict3d", "Sensing3DError", "force_vector"]

Sensing3DError = SpatialLSError

#: The words of ``free``.
ALIASES = {"force": ("F1",), "angle": ("Omega1",), "out": ("Beta1",), "at": ("s1",), "moment": ("mx1", "my1", "mz1")}
#: Unit, factor to the model's unit and scale (a typical size, for the identifiability rule) of each kind of unknown.
_KINDS = {"F": ("N", 1.0, 1.0), "Omega": ("deg", math.pi / 180, 30.0), "Beta": ("deg", math.pi / 180, 30.0), "s": ("1", 1.0, 0.3),
          "mx": ("N*mm", 1.0, 100.0), "my": ("N*mm", 1.0, 100.0), "mz": ("N*mm", 1.0, 100.0)}
MISFIT_P = 1e-3
MAX_PRESSURE = 10.0


def _kind(name: str) -> str:
    return name.rstrip("0123456789")


@dataclass(frozen=True)
class Pose3D:
    """One pose: the pressure (MPa; or ``target_angle_deg``) and what a 3-D tracker measured there."""

    pressure: float | None
    measured: tuple[Measured3D, ...]
    load: str = "load"
    label: str = ""
    target_angle_deg: float | None = None

    def __post_init__(self) -> None:
        where = self.label or "pose"
        if (self.pressure is None) == (self.target_angle_deg is None):
            raise Sensing3DError(f"{where}: give one of its pressure (MPa) and the unloaded target angle that sets it")
        if self.pressure is not None:
            p = checks.finite(f"{where}: pressure", self.pressure, Sensing3DError)
            if not 0.0 <= p <= MAX_PRESSURE:
                raise Sensing3DError(f"{where}: pressure={p:g} MPa: expected a pressure from 0 to {MAX_PRESSURE:g} MPa")
        else:
            t = checks.finite(f"{where}: target_angle_deg", self.target_angle_deg, Sensing3DError)
            if not 0.0 < t <= 720.0:
                raise Sensing3DError(f"{where}: target_angle_deg={t:g}: expected an angle with 0 < angle <= 720 deg")
        measured = tuple(self.measured) if isinstance(self.measured, (tuple, list)) else (self.measured,)
        if not measured or not all(isinstance(m, Measured3D) for m in measured):
            raise Sensing3DError(f"{where}: measured={self.measured!r:.60}: expected one or more Measured3D")
        object.__setattr__(self, "measured", measured)

    def scene(self, base: Scene) -> Scene:
        return base.replace(pressure=self.pressure) if self.pressure is not None else base.replace(target_angle_deg=self.target_angle_deg)

    def count(self) -> int:
        return sum(m.count() for m in self.measured)


def free_names3d(base: Scene, free: Sequence[str]) -> tuple[str, ...]:
    """The unknowns by name (words expanded), checked against the scene's payloads."""
    if isinstance(free, str):
        free = [s.strip() for s in free.split(",")]
    out: list[str] = []
    for raw in free:
        name = str(raw).strip()
        names = ALIASES.get(name.lower(), (name,))
        for nm in names:
            kind, num = _kind(nm), nm[len(_kind(nm)):]
            if kind not in _KINDS or not num.isdigit() or int(num) < 1:
                raise Sensing3DError(f"free {name!r}: allowed are force, angle, out, at, moment or F1, Omega1, Beta1, s1, mx1, my1, mz1 "
                                     "(F2, ... for a second payload)")
            k = int(num)
            if kind in ("mx", "my", "mz"):
                if k != 1:
                    raise Sensing3DError(f"free {nm!r}: one tip moment (mx1, my1, mz1) is estimated")
            elif k > len(base.payloads):
                raise Sensing3DError(f"free {nm!r}: the scene has {len(base.payloads)} payload(s); give the scene a payload {k} to estimate "
                                     "(its values start the search)")
            if nm in out:
                raise Sensing3DError(f"free {nm!r}: named twice")
            out.append(nm)
    if not out:
        raise Sensing3DError("free: name at least one unknown (force, angle, out, at, moment)")
    return tuple(out)


def _setup(base: Scene, free: tuple[str, ...], section) -> tuple[Any, Any, dict]:
    from esba.model.spatial import load_model3d
    from esba.statics.spatial import scene_values3d

    effects, values = scene_values3d(base.replace(pressure=base.pressure if base.pressure is not None else 0.0), section, base.down())
    if any(_kind(f) in ("mx", "my", "mz") for f in free):
        from dataclasses import replace as dc_replace

        effects = dc_replace(effects, moments=1)
        values.update(mx1=0.0, my1=0.0, mz1=0.0, sm1=1.0)
    model = load_model3d(base.segments, effects, base.variant)
    return model, effects, values


def _rows(poses: Sequence[Pose3D], base: Scene, values: dict, section) -> list[Row]:
    from esba.statics.spatial import scene_values3d

    rows = []
    for k, pose in enumerate(poses):
        try:
            sc = pose.scene(base)
        except SceneError as exc:
            raise Sensing3DError(f"{pose.label or f'pose {k + 1}'}: {exc}") from None
        _, v = scene_values3d(sc, section, sc.down())
        row_values = dict(values)
        row_values.update({key: v[key] for key in ("P",) if key in v})
        for m in pose.measured:
            m.check_segments(base.segments)
        rows.append(Row(row_values, pose.measured, pose.label or f"pose {k + 1}"))
    return rows


def _problem(model, rows, free: tuple[str, ...]) -> Problem:
    units = [_KINDS[_kind(f)] for f in free]
    lower = [0.0 if _kind(f) == "F" else (-90.0 if _kind(f) == "Beta" else (1e-3 if _kind(f) == "s" else -np.inf)) for f in free]
    upper = [90.0 if _kind(f) == "Beta" else (1.0 if _kind(f) == "s" else np.inf) for f in free]
    return Problem(model, rows, free, [u[1] for u in units], [u[2] for u in units], lower, upper)


def _z0(base: Scene, free: tuple[str, ...]) -> np.ndarray:
    out = []
    for f in free:
        kind, k = _kind(f), int(f[len(_kind(f)):])
        if kind in ("mx", "my", "mz"):
            out.append(0.0)
            continue
        p = base.payloads[k - 1]
        out.append({"F": p.force, "Omega": p.angle_deg, "Beta": p.out_of_plane_deg, "s": p.at}[kind])
    return np.array(out, dtype=float)


def force_vector(F: float, omega_deg: float, beta_deg: float) -> np.ndarray:
    """The payload as a vector in the base frame (N): F (cos B cos Omega, -cos B sin Omega, sin B)."""
    o, b = math.radians(omega_deg), math.radians(beta_deg)
    return F * np.array([math.cos(b) * math.cos(o), -math.cos(b) * math.sin(o), math.sin(b)])


@dataclass(repr=False)
class Identifiability3D(Report):
    """What a set of 3-D measurements can tell about the unknowns at one state.

    ``singular`` are the singular values of the whitened sensitivity in *relative* unknowns
    (each unknown divided by its typical size: 1 N, 30 deg, 0.3 L, 100 N mm), largest first;
    ``rank`` counts those above ``tol`` times the largest; ``worst`` is the combination the data
    determine worst (the last right singular vector, relative changes); ``words`` the rule's findings.
    """

    labels: tuple[str, ...]
    measured: tuple[str, ...]
    singular: np.ndarray
    rank: int
    condition: float
    worst: dict
    words: tuple[str, ...]
    std_error: np.ndarray
    tol: float = 1e-6

    @property
    def identifiable(self) -> bool:
        return self.rank == len(self.labels) and not self.words

    def headline(self) -> str:
        return f"{', '.join(self.measured)} -> {', '.join(self.labels)}: rank {self.rank} of {len(self.labels)}, condition {self.condition:.3g}"

    def summary(self) -> str:
        return "\n".join([self.headline(), *self.words])

    def to_dict(self) -> dict:
        return {"labels": list(self.labels), "measured": list(self.measured), "singular_values": self.singular.tolist(), "rank": self.rank,
                "condition": self.condition if math.isfinite(self.condition) else None,
                "worst_combination": self.worst, "undetermined": list(self.words),
                "std_error": [float(v) if math.isfinite(v) else None for v in self.std_error], "identifiable": self.identifiable}


def _ident(J: np.ndarray, labels, scale, z, units, measured_words, count, tol=1e-6, floor=1e-12) -> Identifiability3D:
    Js = J * scale[None, :]
    s, V = np.linalg.svd(Js, full_matrices=False)[1:]
    s_full = np.zeros(len(labels))
    s_full[: len(s)] = s
    rank = int(np.sum(s_full * s_full >= tol * s_full[0] ** 2)) if s_full[0] > 0 else 0  # as the rule: Fisher eigenvalues (s^2) against tol
    cond = float(s_full[0] / s_full[-1]) if s_full[-1] > 0 else math.inf
    if len(s) < len(labels):
        _, _, Vt = np.linalg.svd(Js, full_matrices=True)
        v = Vt[-1]
    else:
        v = V[-1]
    v = v / v[np.argmax(np.abs(v))]
    worst = {lab: float(round(x, 12)) for lab, x in zip(labels, v)}
    F = J.T @ J
    _, _, unknown, warnings, _ = identifiability_rule(F, count, tuple(labels), scale, z, [], tol, floor, units)
    se = np.full(len(labels), np.nan)
    known = ~unknown
    if np.any(known):
        cov = np.linalg.inv(F[np.ix_(known, known)])
        se[known] = np.sqrt(np.maximum(np.diag(cov), 0.0))
    return Identifiability3D(tuple(labels), tuple(measured_words), s_full, rank, cond, worst, tuple(warnings), se, tol)


def _words(poses: Sequence[Pose3D]) -> tuple[str, ...]:
    names = {"tip": "tip position", "rotation": "tip orientation", "marker": "markers", "angles": "joint angles"}
    return tuple(dict.fromkeys(names[m.kind] for p in poses for m in p.measured))


@dataclass(repr=False)
class LoadEstimate3D(Report):
    """The 3-D load estimate: unknowns, standard errors, intervals, the force vector, identifiability, uniqueness."""

    labels: tuple[str, ...]
    units: tuple[str, ...]
    estimate: np.ndarray
    std_error: np.ndarray
    interval: np.ndarray
    covariance: np.ndarray
    correlation: np.ndarray
    level: float
    force: np.ndarray
    force_covariance: np.ndarray
    chi2: float
    dof: int
    p_value: float
    identifiability: Identifiability3D
    candidates: list
    states: list
    status: str
    message: str
    iterations: int
    starts: int
    poses: tuple = ()
    warnings: list = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def unique(self) -> bool:
        return len(self.candidates) <= 1

    @property
    def identifiable(self) -> bool:
        return self.identifiability.identifiable

    def value(self, label: str) -> float:
        return float(self.estimate[self.labels.index(label)])

    def headline(self) -> str:
        parts = ", ".join(f"{lab} = {v:.4g} {u}" for lab, v, u in zip(self.labels, self.estimate, self.units))
        return f"{self.status}: {parts}" + ("" if self.unique else f" ({len(self.candidates)} loads fit)")

    def summary(self) -> str:
        return estimate3d_table(self.to_dict())

    def to_dict(self) -> dict:
        def num(v):
            return float(v) if math.isfinite(float(v)) else None

        params = {}
        for j, (lab, u) in enumerate(zip(self.labels, self.units)):
            params[lab] = {"estimate": num(self.estimate[j]), "std_error": num(self.std_error[j]), "unit": u,
                           "interval": [num(self.interval[j, 0]), num(self.interval[j, 1])]}
        return {
            "model": "3d", "status": self.status, "message": self.message, "level": self.level, "unknowns": params,
            "covariance": [[num(c) for c in row] for row in self.covariance],
            "correlation": [[num(c) for c in row] for row in self.correlation],
            "force_vector_n": [num(v) for v in self.force], "force_covariance": [[num(c) for c in row] for row in self.force_covariance],
            "chi2": num(self.chi2), "dof": self.dof, "p_value": num(self.p_value), "unique": self.unique,
            "candidates": self.candidates, "identifiability": self.identifiability.to_dict(),
            "states": [{"label": s["label"], "q_deg": [float(v) for v in np.degrees(s["q"])], "tip_mm": [float(v) for v in s["tip"]],
                        "stable": s["stable"]} for s in self.states],
            "iterations": self.iterations, "starts": self.starts, "warnings": list(self.warnings),
        }


def estimate3d_table(d: dict) -> str:
    lines = [f"3-D load estimate: {d['status']}" + (f" ({d['message']})" if d["message"] else "")]
    lines.append(f"{'unknown':<8} {'estimate':>11} {'std error':>10} {int(round(100 * d['level'])):>3} % interval")
    for lab, p in d["unknowns"].items():
        def f(v, fmt=".5g"):
            return "-" if v is None else format(v, fmt)

        lines.append(f"{lab:<8} {f(p['estimate']):>11} {f(p['std_error'], '.3g'):>10} [{f(p['interval'][0])}, {f(p['interval'][1])}] {p['unit']}")
    fv = d["force_vector_n"]
    if all(v is not None for v in fv):
        var = [d["force_covariance"][i][i] for i in range(3)]
        parts = [f"{c} = {v:.4g}" + (f" +- {math.sqrt(max(w, 0.0)):.2g}" if w is not None else " (not determined)") for c, v, w in zip("xyz", fv, var)]
        lines.append("force vector (base frame, N): " + ", ".join(parts))
    lines.append(f"chi2 = {d['chi2']:.4g} with {d['dof']} degrees of freedom" + (f", p = {d['p_value']:.3g}" if d["p_value"] is not None else ""))
    ident = d["identifiability"]
    cond = "inf" if ident["condition"] is None else f"{ident['condition']:.3g}"
    lines.append(f"identifiability: rank {ident['rank']} of {len(ident['labels'])}, condition number {cond} (relative unknowns)")
    lines += [f"  {w}" for w in ident["undetermined"]]
    if not d["unique"]:
        lines.append(f"{len(d['candidates'])} loads explain the data equally well within the noise:")
        for c in d["candidates"]:
            lines.append("  " + ", ".join(f"{k} = {v:.4g}" for k, v in c["values"].items()) + f" (chi2 {c['chi2']:.4g})")
    return "\n".join(lines)


def _directions(count: int) -> list[tuple[float, float]]:
    """(Omega, Beta) in deg of ``count`` directions spread over the sphere (a Fibonacci lattice)."""
    out = []
    golden = math.pi * (3 - math.sqrt(5))
    for i in range(count):
        zc = 1 - 2 * (i + 0.5) / count
        out.append((math.degrees(golden * i) % 360.0, math.degrees(math.asin(zc))))
    return out


def _check_poses(poses) -> tuple[Pose3D, ...]:
    if isinstance(poses, Pose3D):
        poses = (poses,)
    poses = tuple(poses) if isinstance(poses, (list, tuple)) else None
    if not poses or not all(isinstance(p, Pose3D) for p in poses):
        raise Sensing3DError("poses: expected one or more Pose3D")
    if len({p.load for p in poses}) != 1:
        raise Sensing3DError(f"poses: {len({p.load for p in poses})} loads named; the 3-D estimate takes one load at a time (its poses share it)")
    return poses


@single_threaded
def estimate_load3d(poses: Sequence[Pose3D] | Pose3D, free: Sequence[str] = ("force", "angle", "out"), base: Scene | None = None,
                    section: dict | None = None, *, level: float = 0.95, starts: int = 6, max_iter: int = 100) -> LoadEstimate3D:
    """The load (``free``) that explains the 3-D ``poses`` on the actuator of ``base`` with the section
    stiffnesses ``section`` (EI_side, GJ; the scene's section where not given).

    >>> from esba.model.scene import Scene, Payload
    >>> from esba.statics.spatial import solve_scene3d
    >>> truth = Scene(pressure=0.15, payloads=(Payload(1.0, 60.0, 1.0, 20.0),))
    >>> eq = solve_scene3d(truth, {"EI_side": 4e5, "GJ": 1e5})
    >>> pose = Pose3D(0.15, (Measured3D("tip", tuple(eq.tip), 0.1), Measured3D("rotation", tuple(eq.tip_rotation.ravel()), 0.2)))
    >>> r = estimate_load3d([pose], base=Scene(pressure=0.15, payloads=(Payload(0.5, 90.0),)), section={"EI_side": 4e5, "GJ": 1e5})
    >>> r.ok, [round(float(v), 6) for v in r.estimate]
    (True, [1.0, 60.0, 20.0])
    """
    from esba.statics.spatial import SpatialError, check_section

    poses = _check_poses(poses)
    base = Scene() if base is None else base
    if not isinstance(base, Scene):
        raise Sensing3DError(f"base={base!r:.60}: expected a Scene")
    if not 0.0 < float(level) < 1.0:
        raise Sensing3DError(f"level={level!r}: expected a confidence level between 0 and 1")
    if not isinstance(starts, int) or not 0 <= starts <= 200:
        raise Sensing3DError(f"starts={starts!r}: expected a whole number from 0 to 200")
    free = free_names3d(base, free)
    try:
        section = check_section(section, base)
    except SpatialError as exc:
        raise Sensing3DError(str(exc)) from None
    model, _, values = _setup(base, free, section)
    rows = _rows(poses, base, values, section)
    prob = _problem(model, rows, free)
    m = prob.m
    k = len(free)
    z_base = _z0(base, free)
    tries = [("scene", z_base)]
    if any(_kind(f) in ("Omega", "Beta") for f in free):
        for om, be in _directions(starts):
            z = z_base.copy()
            for j, f in enumerate(free):
                if f == "Omega1":
                    z[j] = om
                elif f == "Beta1":
                    z[j] = be
            tries.append((f"direction {om:.0f}, {be:.0f} deg", z))
    runs = []
    iterations = 0
    for why, z0 in tries:
        try:
            z, qs, r, J, it, conv = prob.solve(z0, max_iter=max_iter)
        except RuntimeError:
            continue
        iterations += it
        runs.append((float(r @ r), z, qs, r, J, conv, why))
    if not runs:
        p0 = base.payloads[0] if base.payloads else None
        start = f"{p0.force:g} N at Omega = {p0.angle_deg:g} deg" if p0 is not None else "no payload"
        raise Sensing3DError(f"no start load reaches a stable equilibrium along the load history with EI_side = {section['EI_side']:.4g} and "
                             f"GJ = {section['GJ']:.4g} N*mm^2 (the scene's payload, {start}, and {len(tries) - 1} more directions): "
                             "start from a smaller payload (--payload) or give the section (--section EI_side=... --section GJ=...)")
    for run in runs:  # directions in (-180, 180]
        run[1][:] = _wrap_angles(run[1], free)
    runs.sort(key=lambda t: round(t[0], 9))  # ties keep the order of the starts
    chi2, z, qs, r, J, conv, _ = runs[0]
    scale = prob.scale
    units = tuple(_KINDS[_kind(f)][0] for f in free)
    ident = _ident(J, free, scale, z, units, _words(poses), m)
    F = J.T @ J
    cov = np.full((k, k), np.nan)
    se = np.full(k, np.nan)
    if ident.rank == k:
        cov = np.linalg.inv(F)
        cov = 0.5 * (cov + cov.T)
        se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    else:
        se = ident.std_error
    zq = float(stats.norm.ppf(0.5 + level / 2))
    interval = np.column_stack([z - zq * se, z + zq * se])
    corr = fisher_correlation(F, scale)
    dof = max(m - k, 0)
    p_value = float(stats.chi2.sf(chi2, dof)) if dof > 0 else math.nan
    # the force vector and its covariance (first order in F1, Omega1, Beta1)
    vals = {"F1": None, "Omega1": None, "Beta1": None}
    p1 = base.payloads[0] if base.payloads else None
    for key, attr in (("F1", "force"), ("Omega1", "angle_deg"), ("Beta1", "out_of_plane_deg")):
        vals[key] = float(z[free.index(key)]) if key in free else (getattr(p1, attr) if p1 is not None else math.nan)
    force = force_vector(vals["F1"], vals["Omega1"], vals["Beta1"]) if p1 is not None else np.full(3, math.nan)
    fcov = np.full((3, 3), math.nan)
    if p1 is not None and np.all(np.isfinite(cov)):
        G = np.zeros((3, k))
        for j, f in enumerate(free):
            if f in vals:
                e = {"F1": 1e-6, "Omega1": 1e-5, "Beta1": 1e-5}[f]
                hi, lo = dict(vals), dict(vals)
                hi[f] += e
                lo[f] -= e
                G[:, j] = (force_vector(hi["F1"], hi["Omega1"], hi["Beta1"]) - force_vector(lo["F1"], lo["Omega1"], lo["Beta1"])) / (2 * e)
        fcov = G @ cov @ G.T
    # every distinct load within the chi-square quantile of the best; loads are compared as force
    # vectors (Omega means nothing at beta = +-90 deg, the poles of the polar coordinates) and by their other unknowns
    limit = chi2 + float(stats.chi2.ppf(level, k))
    polar = [j for j, f in enumerate(free) if f in ("F1", "Omega1", "Beta1")]
    rest = [j for j in range(k) if j not in polar]
    f_tol = np.maximum(3 * np.sqrt(np.abs(np.nan_to_num(np.diag(fcov), nan=0.0))), 1e-6)
    z_tol = np.maximum(3 * np.nan_to_num(se, nan=0.0), 1e-6 * scale)

    def vector(zc: np.ndarray) -> np.ndarray:
        v = dict(vals)
        v.update({free[j]: float(zc[j]) for j in polar})
        return force_vector(v["F1"], v["Omega1"], v["Beta1"]) if p1 is not None else np.zeros(3)

    def same(a: np.ndarray, b: np.ndarray) -> bool:
        if polar and np.any(np.abs(vector(a) - vector(b)) > f_tol):
            return False
        return bool(np.all(np.abs(_wrap(a - b, free))[rest] <= z_tol[rest]))

    candidates = []
    for c2, zc, *_rest in runs:
        if c2 > limit or any(same(zc, c["z"]) for c in candidates):
            continue
        candidates.append({"z": zc, "values": {f: float(v) for f, v in zip(free, zc)}, "chi2": float(c2)})
    for c in candidates:
        del c["z"]
    states = []
    stable = True
    near = []
    for i, q in enumerate(qs):
        vals_i = prob.values(i, z)
        w = np.linalg.eigvalsh(model.hessian(q, vals_i))
        w0 = float(w[0])
        stable = stable and w0 > 0
        if 0 < w0 < 1e-6 * float(w[-1]):
            near.append(rows[i].label)
        states.append({"label": rows[i].label, "q": q, "tip": model.tip(q, vals_i["L"]), "stable": w0 > 0})
    warnings = []
    status, message = "ok", ""
    if not conv:
        status, message = "failed", f"the Levenberg-Marquardt iteration did not converge in {max_iter} iterations"
    elif not stable:
        status, message = "unstable", "a pose's state is not stable: the actuator cannot hold that shape"
    elif dof > 0 and p_value < MISFIT_P:
        status, message = "misfit", (f"no load reproduces the data within the stated deviations (chi2 = {chi2:.4g} with {dof} degrees "
                                     f"of freedom, p = {p_value:.2g} < {MISFIT_P:g})")
    if near:
        warnings.append(f"{', '.join(near)}: the state is near a fold or branch point (smallest Hessian eigenvalue below 1e-6 of the largest): "
                        "the shape hardly determines the load there, and the intervals are not to be trusted")
    if ident.words:
        warnings += list(ident.words)
    if len(candidates) > 1:
        warnings.append(f"not unique: {len(candidates)} loads explain the data equally well within the noise")
    return LoadEstimate3D(free, units, z, se, interval, cov, corr, float(level), force, fcov, chi2, dof, p_value, ident, candidates, states,
                          status, message, iterations, len(tries), poses, warnings)


def _wrap_angles(z: np.ndarray, free) -> np.ndarray:
    out = np.array(z, dtype=float)
    for j, f in enumerate(free):
        if _kind(f) == "Omega":
            out[j] = 180.0 - (180.0 - out[j]) % 360.0
    return out


def _wrap(dz: np.ndarray, free) -> np.ndarray:
    out = np.array(dz, dtype=float)
    for j, f in enumerate(free):
        if _kind(f) == "Omega":
            out[j] = (out[j] + 180.0) % 360.0 - 180.0
    return out


def predict3d(base: Scene, section: dict | None, pressure: float, kinds: Sequence[tuple[str, float | None]], q=None) -> tuple[np.ndarray, list[np.ndarray]]:
    """(q, predicted values per kind) of ``base`` at ``pressure`` for the kinds (``(kind, at)``): the tip
    position, the rotation (9, row-major), markers, joint angles (deg). Solved along its history unless ``q``."""
    from esba.calibration.spatial_ls import measure_function
    from esba.model.spatial import load_model3d
    from esba.statics.spatial import check_section, scene_values3d, solve_scene3d

    scene = base.replace(pressure=pressure)
    section = check_section(section, scene)
    effects, values = scene_values3d(scene, section, scene.down())
    model = load_model3d(scene.segments, effects, scene.variant)
    if q is None:
        eq = solve_scene3d(scene, section, gravity_direction=scene.down())
        q = eq.q
    y = np.asarray(measure_function(model, tuple(kinds))(q, values["L"])[0]).ravel()
    out, i = [], 0
    for kind, _ in kinds:
        c = {"tip": 3, "rotation": 9, "marker": 3, "angles": model.size}[kind]
        out.append(y[i:i + c])
        i += c
    return np.asarray(q), out


@single_threaded
def identifiability3d(scene: Scene, kinds: Sequence[tuple[str, float | None, float]], free: Sequence[str] = ("force", "angle", "out"),
                      section: dict | None = None) -> Identifiability3D:
    """What the measurements ``kinds`` ((kind, at, sd) each) would tell about ``scene``'s load
    (unknowns ``free``) at the state its load history reaches: the rank and condition of the whitened
    sensitivity, its worst-determined combination, the standard errors and the rule's words."""
    from esba.statics.spatial import check_section

    free = free_names3d(scene, free)
    section = check_section(section, scene)
    model, _, values = _setup(scene, free, section)
    pressure = values["P"] if scene.pressure is None else scene.pressure
    if scene.pressure is None:
        from esba.statics.spatial import scene_values3d

        pressure = scene_values3d(scene, section)[1]["P"]
    q, preds = predict3d(scene, section, pressure, [(k, a) for k, a, _ in kinds])
    measured = tuple(Measured3D(k, tuple(v), sd, a) for (k, a, sd), v in zip(kinds, preds))
    pose = Pose3D(pressure, measured)
    rows = _rows([pose], scene.replace(pressure=pressure), values, section)
    prob = _problem(model, rows, free)
    z = _z0(scene, free)
    _, J, _, _ = prob.evaluate(z, [q])
    return _ident(J, free, prob.scale, z, tuple(_KINDS[_kind(f)][0] for f in free), _words([pose]), prob.m)

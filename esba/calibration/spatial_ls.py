"""Weighted least squares on the 3-D model's equilibria: the engine behind the 3-D load estimate
(:mod:`esba.calibration.sensing3d`) and the 3-D stiffness fit (:mod:`esba.calibration.fit3d`).

Each *row* is a set of the 3-D model's parameter values (a pressure, loads, section) and what a 3-D
tracker measured there (:class:`Measured3D`). Unknowns ``z`` are some of the model's parameters,
shared by every row (a load seen at several pressures; the section's stiffnesses seen under
several loads). The problem is

    minimise 1/2 sum_rows sum_i ((y_i(q(z)) - m_i) / sd_i)^2,   with   dU/dq (q(z), z) = 0,

solved by Levenberg-Marquardt in z. Each row's state q is an equilibrium of the generated 3-D
model, followed from the last accepted one with the first-order predictor q + dq/dz dz (implicit
function theorem: dq/dz = -H^-1 d(grad U)/dz, CasADi AD of the generated gradient) and the damped
Newton method of :func:`esba.statics.spatial.newton3d`; a step whose Newton does not converge or
whose state is not stable (the 3n x 3n Hessian positive definite) is refused and shortened.

What is measured, and its residual (all whitened by the stated standard deviation):

=========  ================================  ===========================================
kind       values                            residual
=========  ================================  ===========================================
tip        tip position x, y, z (mm)         y - m
rotation   tip rotation R (9, row-major:     1/2 vee(R_m^T R - R^T R_m) (rad): the rotation
           columns are the tip frame's       vector from the measured to the predicted frame
           axes in the base frame)           to first order; sd in degrees, each axis
marker     point at fraction ``at`` of L:    y - m
           x, y, z (mm)
angles     the 3n joint angles theta_1..n,   y - m
           psi_1..n, tau_1..n (deg)
=========  ================================  ===========================================

The Jacobian J of the whitened residuals in z gives the Fisher matrix J^T J and the covariance
(J^T J)^-1 (the stated deviations taken as they are, as :mod:`esba.calibration.sensing` does).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import casadi as ca
import numpy as np

from esba.infra import checks
from esba.infra.errors import InputError
from esba.model.spatial import Model3D
from esba.statics.spatial import newton3d, solve3d

__all__ = ["Measured3D", "KINDS3D", "SpatialLSError", "chain_points", "measure_function", "rotation_residual_map", "Row", "Problem"]


class SpatialLSError(InputError):
    """A bad 3-D measurement (one line naming it)."""


#: Each kind: (number of values or None for 3n, unit).
KINDS3D = {"tip": (3, "mm"), "rotation": (9, "deg"), "marker": (3, "mm"), "angles": (None, "deg")}

#: How far a measured rotation matrix may be from orthonormal (largest entry of R^T R - I): a tracker's
#: matrix printed to 4 decimals passes; it is then replaced by the nearest rotation (polar decomposition).
ORTHONORMAL_TOL = 1e-3


def _quote(value, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


@dataclass(frozen=True)
class Measured3D:
    """One quantity a 3-D tracker measured, with the standard deviation of each value.

    ``kind``: ``tip`` (x, y, z mm), ``rotation`` (the tip's 3 x 3 rotation, 9 numbers row by row,
    sd in deg about each axis), ``marker`` (x, y, z mm of the point at fraction ``at`` of L) or
    ``angles`` (the 3n joint angles theta..., psi..., tau..., deg).

    >>> Measured3D("rotation", (1, 0, 0, 0, 1, 0, 0, 0, 2), 0.5)
    Traceback (most recent call last):
    ...
    esba.calibration.spatial_ls.SpatialLSError: rotation: not a rotation matrix (largest entry of R^T R - I is 3, above 0.001)
    """

    kind: str
    values: tuple[float, ...]
    sd: float
    at: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.kind, str) or self.kind not in KINDS3D:
            raise SpatialLSError(f"measured kind {_quote(self.kind)}: allowed in 3-D are {', '.join(KINDS3D)}")
        count, unit = KINDS3D[self.kind]
        raw = self.values if isinstance(self.values, (tuple, list, np.ndarray)) else (self.values,)
        values = tuple(checks.finite(self.kind, v, SpatialLSError) for v in np.asarray(raw, dtype=object).ravel())
        if count is not None and len(values) != count:
            what = {"tip": "x, y, z in mm", "marker": "x, y, z in mm", "rotation": "a 3 x 3 rotation matrix, row by row"}[self.kind]
            raise SpatialLSError(f"{self.kind}={_quote(self.values)}: expected {count} values ({what})")
        if not values:
            raise SpatialLSError(f"{self.kind}: expected at least one value")
        limit = 1e4 if unit == "deg" else 1e5
        if any(abs(v) > limit for v in values):
            raise SpatialLSError(f"{self.kind}={_quote(self.values)}: expected |value| <= {limit:g} {unit}")
        object.__setattr__(self, "values", values)
        sd = checks.finite(f"{self.kind} sd", self.sd, SpatialLSError)
        if not 1e-9 <= sd <= 1e4:
            raise SpatialLSError(f"{self.kind} sd={sd:g} {unit}: expected a standard deviation with 1e-9 <= sd <= 1e4 {unit}")
        object.__setattr__(self, "sd", sd)
        if self.kind == "rotation":
            R = np.array(values).reshape(3, 3)
            err = float(np.abs(R.T @ R - np.eye(3)).max())
            if err > ORTHONORMAL_TOL:
                raise SpatialLSError(f"rotation: not a rotation matrix (largest entry of R^T R - I is {err:.3g}, above {ORTHONORMAL_TOL:g})")
            if np.linalg.det(R) < 0:
                raise SpatialLSError("rotation: a reflection (determinant -1), not a rotation matrix")
            U, _, Vt = np.linalg.svd(R)
            object.__setattr__(self, "values", tuple(float(v) for v in (U @ Vt).ravel()))
        if self.kind == "marker":
            at = checks.finite("marker at", self.at, SpatialLSError) if self.at is not None else math.nan
            if not 0.0 < at <= 1.0:
                raise SpatialLSError(f"marker at={self.at!r}: expected a fraction of the length with 0 < at <= 1")
            object.__setattr__(self, "at", at)
        elif self.at is not None:
            raise SpatialLSError(f"{self.kind}: only a marker has a point (at={self.at!r})")

    @property
    def unit(self) -> str:
        return KINDS3D[self.kind][1]

    def count(self) -> int:
        """Number of residuals (3 for a rotation)."""
        return 3 if self.kind == "rotation" else len(self.values)

    def check_segments(self, n: int) -> None:
        if self.kind == "angles" and len(self.values) != 3 * n:
            raise SpatialLSError(f"angles: {len(self.values)} values for n = {n} segments: expected 3n = {3 * n} (theta_1..n, psi_1..n, tau_1..n in deg)")

    def quantities(self, n: int) -> list[str]:
        if self.kind == "angles":
            return [f"{c}{i}" for c in ("theta", "psi", "tau") for i in range(1, n + 1)]
        if self.kind == "rotation":
            return ["rot_x", "rot_y", "rot_z"]
        head = "tip" if self.kind == "tip" else f"marker{self.at:g}"
        return [f"{head}_{c}" for c in "xyz"]


# ---------------------------------------------------------------------------------------------
# predictions, symbolic


def _exp_sx(joint, length, sigma: float):
    """exp(sigma hat(Xi)) of one joint (theta, psi, tau) as (R, t), CasADi SX (as :func:`esba.model.spatial.segment_pose`)."""
    th, ps, ta = joint[0] * sigma, joint[1] * sigma, joint[2] * sigma
    w = ca.vertcat(ta, ps, th)
    r2 = ca.dot(w, w)
    small = r2 < 1e-6
    rs = ca.sqrt(ca.if_else(small, 1.0, r2))
    f1 = ca.if_else(small, 1 - r2 / 6 + r2 * r2 / 120, ca.sin(rs) / rs)
    f2 = ca.if_else(small, 0.5 - r2 / 24 + r2 * r2 / 720, (1 - ca.cos(rs)) / (rs * rs))
    f3 = ca.if_else(small, 1.0 / 6 - r2 / 120 + r2 * r2 / 5040, (rs - ca.sin(rs)) / (rs * rs * rs))
    W = ca.skew(w)
    I3 = ca.SX.eye(3)
    R = I3 + f1 * W + f2 * (W @ W)
    t = (I3 + f2 * W + f3 * (W @ W)) @ ca.vertcat(sigma * length, 0, 0)
    return R, t


def chain_points(n: int, q, L, fractions: Sequence[float]):
    """Positions (SX 3-vectors) of the points at ``fractions`` of L along the layer's mid-line."""
    joints = [(q[j], q[n + j], q[2 * n + j]) for j in range(n)]
    out = []
    for a in fractions:
        x = a * n
        j = min(int(math.floor(x)), n - 1)
        sigma = x - j
        R, t = ca.SX.eye(3), ca.SX.zeros(3)
        for k in range(j):
            Rk, tk = _exp_sx(joints[k], L / n, 1.0)
            t = t + R @ tk
            R = R @ Rk
        if sigma > 0:
            Rk, tk = _exp_sx(joints[j], L / n, sigma)
            t = t + R @ tk
        out.append(t)
    return out


def measure_function(model: Model3D, layout: tuple) -> ca.Function:
    """(q, L) -> (y, dy/dq) for ``layout``, a tuple of (kind, at): the tip position, the tip rotation
    (9 entries, row-major), marker positions, the joint angles (deg)."""
    key = ("measure3d", layout)
    found = model.registry.get(key)
    if found is None:
        q = ca.SX.sym("q", model.size)
        L = ca.SX.sym("L")
        tip, R, _ = model.functions["kinematics"](q, L)
        parts = []
        for kind, at in layout:
            if kind == "tip":
                parts.append(tip)
            elif kind == "rotation":
                parts.append(ca.reshape(R.T, 9, 1))  # row-major
            elif kind == "marker":
                parts.append(chain_points(model.n, q, L, [at])[0])
            else:
                parts.append(q * (180.0 / math.pi))
        y = ca.vertcat(*parts)
        found = ca.Function("esba3d_measure", [q, L], [y, ca.jacobian(y, q)])
        model.registry[key] = found
    return found


def rotation_residual_map(Rm: np.ndarray) -> np.ndarray:
    """A (3 x 9): the residual 1/2 vee(Rm^T R - R^T Rm) as a linear map of R's entries (row-major)."""
    A = np.zeros((3, 9))
    for k in range(9):
        E = np.zeros(9)
        E[k] = 1.0
        M = Rm.T @ E.reshape(3, 3)
        S = 0.5 * (M - M.T)
        A[:, k] = (S[2, 1], S[0, 2], S[1, 0])
    return A


def sensitivity_function(model: Model3D) -> ca.Function:
    """(q, p) -> (grad U, Hessian, d grad U / d p) of the 3-D model (CasADi AD), built once per model."""
    found = model.registry.get("sens3d")
    if found is None:
        q = ca.SX.sym("q", model.size)
        ps = ca.SX.sym("p", len(model.parameters))
        args = ca.vertsplit(ps) if len(model.parameters) else []
        g = model.functions["gradient"](q, *args)
        found = ca.Function("esba3d_sens", [q, ps], [g, model.functions["hessian"](q, *args), ca.jacobian(g, ps)], {"cse": True})
        model.registry["sens3d"] = found
    return found


# ---------------------------------------------------------------------------------------------
# rows and the problem


@dataclass
class Row:
    """One row: the model's parameter values (radians) and what was measured there."""

    values: dict
    measured: tuple[Measured3D, ...]
    label: str = ""

    def layout(self) -> tuple:
        return tuple((m.kind, m.at) for m in self.measured)


class Problem:
    """The least-squares problem of rows sharing the unknowns ``names`` (model parameters);
    ``factors`` turn an unknown's value into the model's unit (deg -> rad, ...)."""

    def __init__(self, model: Model3D, rows: Sequence[Row], names: Sequence[str], factors: Sequence[float], scales: Sequence[float],
                 lower: Sequence[float] | None = None, upper: Sequence[float] | None = None):
        self.model = model
        self.rows = list(rows)
        self.names = tuple(names)
        self.factors = np.asarray(factors, dtype=float)
        self.scale = np.asarray(scales, dtype=float)
        self.lower = np.full(len(names), -np.inf) if lower is None else np.asarray(lower, dtype=float)
        self.upper = np.full(len(names), np.inf) if upper is None else np.asarray(upper, dtype=float)
        self.index = [model.parameters.index(nm) for nm in self.names]
        self.sens = sensitivity_function(model)
        self.meas = [measure_function(model, r.layout()) for r in self.rows]
        self.p0 = [model.param_vector(r.values) for r in self.rows]
        self.m = sum(sum(mm.count() for mm in r.measured) for r in self.rows)
        # the residual maps: residual = A y - b, whitened
        self.maps = []
        for r in self.rows:
            blocks, offs = [], []
            for mm in r.measured:
                c = len(mm.values)
                if mm.kind == "rotation":
                    A = rotation_residual_map(np.array(mm.values).reshape(3, 3)) / math.radians(mm.sd)
                    b = np.zeros(3)
                else:
                    A = np.eye(c) / mm.sd
                    b = np.array(mm.values) / mm.sd
                blocks.append((A, b))
                offs.append(c)
            rows_ = sum(A.shape[0] for A, _ in blocks)
            cols = sum(offs)
            Abig, bbig = np.zeros((rows_, cols)), np.zeros(rows_)
            i = j = 0
            for A, b in blocks:
                Abig[i:i + A.shape[0], j:j + A.shape[1]] = A
                bbig[i:i + A.shape[0]] = b
                i += A.shape[0]
                j += A.shape[1]
            self.maps.append((Abig, bbig))

    def values(self, i: int, z: np.ndarray) -> dict:
        out = dict(self.rows[i].values)
        for nm, v, f in zip(self.names, z, self.factors):
            out[nm] = float(v) * float(f)
        return out

    def params(self, i: int, z: np.ndarray) -> np.ndarray:
        p = self.p0[i].copy()
        p[self.index] = np.asarray(z, dtype=float) * self.factors
        return p

    def start_states(self, z: np.ndarray) -> list[np.ndarray] | None:
        """Each row's state along the load history at z (inflate, then load), None where one fails."""
        out = []
        for i in range(len(self.rows)):
            eq = solve3d(self.model, self.values(i, z), certify=False)
            if not (eq.converged and eq.stable):
                return None
            out.append(eq.q)
        return out

    def evaluate(self, z: np.ndarray, qs: Sequence[np.ndarray]):
        """(whitened residuals, their Jacobian in z, each row's dq/dz, smallest Hessian eigenvalue of each row)."""
        rs, Js, dqs, eig = [], [], [], []
        for i, q in enumerate(qs):
            p = self.params(i, z)
            _, H, dgdp = self.sens(q, p)
            H, dgdp = np.asarray(H), np.asarray(dgdp)
            dqdz = -np.linalg.solve(H, dgdp[:, self.index] * self.factors[None, :])
            y, dy = self.meas[i](q, self.rows[i].values["L"])
            A, b = self.maps[i]
            rs.append(A @ np.asarray(y).ravel() - b)
            Js.append(A @ np.asarray(dy) @ dqdz)
            dqs.append(dqdz)
            eig.append(float(np.linalg.eigvalsh(H)[0]))
        return np.concatenate(rs), np.vstack(Js), dqs, eig

    def follow(self, z_old: np.ndarray, z_new: np.ndarray, qs, dqs) -> list[np.ndarray] | None:
        """The states at z_new from those at z_old (predictor, then damped Newton); None if one fails or is unstable."""
        out = []
        for i, (q, dq) in enumerate(zip(qs, dqs)):
            vals = self.values(i, z_new)
            qn, ok, _ = newton3d(self.model, vals, q + dq @ (z_new - z_old))
            if not ok or not np.all(np.isfinite(qn)):
                return None
            if np.linalg.eigvalsh(self.model.hessian(qn, vals))[0] <= 0:
                return None
            out.append(qn)
        return out

    def solve(self, z0: np.ndarray, qs: list[np.ndarray] | None = None, *, max_iter: int = 100, xtol: float = 1e-13):
        """Levenberg-Marquardt from z0: (z, states, r, J, iterations, converged)."""
        z = np.clip(np.asarray(z0, dtype=float), self.lower, self.upper)
        if qs is None:
            qs = self.start_states(z)
            if qs is None:
                raise RuntimeError("the load history does not reach a stable equilibrium at the start")
        r, J, dqs, _ = self.evaluate(z, qs)
        cost = float(r @ r)
        lam = 1e-3
        D = self.scale
        for it in range(1, max_iter + 1):
            Js = J * D[None, :]
            A = Js.T @ Js
            g = Js.T @ r
            step = None
            for _ in range(30):
                try:
                    dx = -np.linalg.solve(A + lam * np.diag(np.maximum(np.diag(A), 1e-12 * max(1.0, np.trace(A)))), g)
                except np.linalg.LinAlgError:
                    lam *= 10
                    continue
                z_new = np.clip(z + D * dx, self.lower, self.upper)
                if np.all(z_new == z) or np.abs(dx).max() <= xtol:
                    return z, qs, r, J, it, True
                q_new = self.follow(z, z_new, qs, dqs)
                if q_new is not None:
                    r_new, J_new, dq_new, _ = self.evaluate(z_new, q_new)
                    c_new = float(r_new @ r_new)
                    if c_new <= cost * (1 + 1e-14) + 1e-300:
                        step = (z_new, q_new, r_new, J_new, dq_new, c_new)
                        break
                lam *= 10
            if step is None:
                return z, qs, r, J, it, bool(np.abs(g).max() <= 1e-9 * max(1.0, cost))
            small = np.abs((step[0] - z) / D).max() <= xtol * max(1.0, np.abs(step[0] / D).max())
            z, qs, r, J, dqs, cost = step
            lam = max(lam / 10, 1e-12)
            if small:
                return z, qs, r, J, it, True
        return z, qs, r, J, max_iter, False

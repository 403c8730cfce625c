"""The actuator's surfaces along whole segments, and the closest point of each segment to an obstacle.

The model bends the inextensible layer: segment i is a circular arc of length L/n turning by
theta_i (Eq. 1-2), starting at the joint point P_i with heading phi_i = theta_1 + ... + theta_{i-1}.
Its point at the fraction sigma in [0, 1] of the segment is

    p_i(sigma) = P_i + (L/n) sigma R(phi_i) [sinc(sigma theta_i), versinc(sigma theta_i)],

heading phi_i + sigma theta_i (the same smooth forms as ``derive.smooth``: exact at theta_i = 0). The
surface at offset o is q = p - o nu, with nu = (-sin phi, cos phi) the normal towards the inside
of the bend: o = 0 is the layer (``inner``), o = 2 r1 the dorsal surface (``outer``). Along a segment

    q'(sigma) = (L/n + o theta_i) t,    q''(sigma) = (L/n + o theta_i) theta_i nu,

with t = (cos phi, sin phi). The gap of an obstacle along a segment, d(sigma) = distance(q(sigma)),
has at most one interior local minimum (a line or a circle against an arc of less than a turn);
:func:`closest_points` finds it exactly (a grid, then Newton on d' = 0). With the joints, those
are all the points where the body can first touch a convex obstacle.

Examples
--------
>>> import numpy as np
>>> from esba.model.contact.obstacles import Cylinder
>>> th = np.full(3, np.pi / 6)
>>> q = surface_points(th, 135.0, 0.0, np.array([[0.0, 0.5, 1.0]] * 3))
>>> [round(float(v), 4) for v in q[2, 2]]   # the tip of the layer (chain_tip gives the same)
[85.9437, 85.9437]
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from .obstacles import Obstacle

__all__ = ["surface_points", "surface_derivatives", "closest_points", "offset_of", "symbolic_surface", "GRID"]

#: Grid points per segment on which the interior minimum of a gap is first bracketed.
GRID = 17

#: Where the series branch of sinc hands over to sin(u)/u (``derive.smooth.SINC_SWITCH``).
SINC_SWITCH = 0.1


def offset_of(side: str, r1: float) -> float:
    """The offset of a surface from the layer, mm: 0 for ``inner``, 2 r1 for ``outer``."""
    return 0.0 if side == "inner" else 2.0 * float(r1)


def _frames(theta: np.ndarray, L: float) -> tuple[np.ndarray, np.ndarray]:
    """Joint points P_i (n, 2) and headings phi_i (n,) at the start of each segment."""
    n = theta.size
    phi = np.concatenate([[0.0], np.cumsum(theta)[:-1]])
    sinc = np.sinc(theta / np.pi)
    versinc = 0.5 * theta * np.sinc(theta / (2.0 * np.pi)) ** 2
    seg = L / n
    dx = seg * (np.cos(phi) * sinc - np.sin(phi) * versinc)
    dy = seg * (np.sin(phi) * sinc + np.cos(phi) * versinc)
    starts = np.column_stack([np.concatenate([[0.0], np.cumsum(dx)[:-1]]), np.concatenate([[0.0], np.cumsum(dy)[:-1]])])
    return starts, phi


def _along(theta: np.ndarray, L: float, offset: float, sigma: np.ndarray, starts: np.ndarray, phi0: np.ndarray, derivatives: bool):
    n = theta.size
    u = sigma * theta[:, None]
    cx = (L / n) * sigma * np.sinc(u / np.pi)
    cy = (L / n) * sigma * 0.5 * u * np.sinc(u / (2.0 * np.pi)) ** 2
    c, s = np.cos(phi0)[:, None], np.sin(phi0)[:, None]
    head = phi0[:, None] + u
    sh, ch = np.sin(head), np.cos(head)
    q = np.stack([starts[:, :1] + c * cx - s * cy + offset * sh, starts[:, 1:] + s * cx + c * cy - offset * ch], axis=-1)
    if not derivatives:
        return q
    speed = (L / n + offset * theta)[:, None, None]
    t = np.stack([ch, sh], axis=-1)
    nu = np.stack([-sh, ch], axis=-1)
    return q, speed * t, speed * theta[:, None, None] * nu


def _along_rows(theta: np.ndarray, n: int, L: float, offset: float, sigma: np.ndarray, starts: np.ndarray, phi0: np.ndarray):
    """q, q', q'' at one fraction per row for the segments given (their angles, starts and headings), each (k, 2)."""
    u = sigma * theta
    cx = (L / n) * sigma * np.sinc(u / np.pi)
    cy = (L / n) * sigma * 0.5 * u * np.sinc(u / (2.0 * np.pi)) ** 2
    c, s = np.cos(phi0), np.sin(phi0)
    head = phi0 + u
    sh, ch = np.sin(head), np.cos(head)
    q = np.column_stack([starts[:, 0] + c * cx - s * cy + offset * sh, starts[:, 1] + s * cx + c * cy - offset * ch])
    speed = (L / n + offset * theta)[:, None]
    return q, speed * np.column_stack([ch, sh]), speed * theta[:, None] * np.column_stack([-sh, ch])


def surface_points(theta: Any, L: float, offset: float, sigma: np.ndarray) -> np.ndarray:
    """Points of the surface at ``offset`` at fractions ``sigma`` (n, m) of each segment, shape (n, m, 2)."""
    theta = np.asarray(theta, dtype=float).ravel()
    starts, phi0 = _frames(theta, L)
    return _along(theta, L, offset, np.asarray(sigma, dtype=float), starts, phi0, False)


def surface_derivatives(theta: Any, L: float, offset: float, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q' and q'' (each (n, m, 2)) along each segment at fractions ``sigma`` (n, m)."""
    theta = np.asarray(theta, dtype=float).ravel()
    starts, phi0 = _frames(theta, L)
    return _along(theta, L, offset, np.asarray(sigma, dtype=float), starts, phi0, True)


def closest_points(theta: Any, L: float, offset: float, obstacle: Obstacle, newton_steps: int = 12) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per segment: the fraction of its interior local minimum of the gap, whether it has one, and the gap there.

    Returns ``sigma`` (n,), ``interior`` (n, bool) and ``gap`` (n,). A segment without an interior
    minimum (its gap is least at a joint) gets the end where its gap is least (then its point is
    that joint's: a contact that slides off the end of a segment keeps its constraint continuous)
    and ``interior`` False.
    """
    theta = np.asarray(theta, dtype=float).ravel()
    n = theta.size
    starts, phi0 = _frames(theta, L)
    grid = np.broadcast_to(np.linspace(0.0, 1.0, GRID), (n, GRID))
    d = obstacle.distance(_along(theta, L, offset, grid, starts, phi0, False))
    inner = d[:, 1:-1]
    is_min = (inner <= d[:, :-2]) & (inner <= d[:, 2:])
    masked = np.where(is_min, inner, np.inf)
    j = np.argmin(masked, axis=1) + 1
    found = np.isfinite(masked[np.arange(n), j - 1])
    h = 1.0 / (GRID - 1)
    lo, hi = (j - 1) * h, (j + 1) * h
    sigma = j * h
    if not found.all():  # a minimum inside the first or last grid interval shows as a slope into the segment at its end
        ends = np.tile([0.0, 1.0], (n, 1))
        q, q1, _ = _along(theta, L, offset, ends, starts, phi0, True)
        _, g, _ = obstacle.derivatives(q)
        slope = np.einsum("ijk,ijk->ij", g, q1)
        first = ~found & (slope[:, 0] < 0) & (d[:, 0] <= d[:, -1])
        last = ~found & ~first & (slope[:, 1] > 0)
        lo, hi, sigma = np.where(first, 0.0, lo), np.where(first, h, hi), np.where(first, 0.5 * h, sigma)
        lo, hi, sigma = np.where(last, 1.0 - h, lo), np.where(last, 1.0, hi), np.where(last, 1.0 - 0.5 * h, sigma)
        found = found | first | last
    ends_gap = np.where(d[:, 0] < d[:, -1], d[:, 0], d[:, -1])
    if not found.any():  # every segment's gap is least at an end: no Newton
        return np.where(d[:, 0] < d[:, -1], 0.0, 1.0), found, ends_gap
    rows = np.flatnonzero(found)  # Newton on the segments with an interior candidate only
    th, st, ph = theta[rows], starts[rows], phi0[rows]
    sg, lo_r, hi_r = sigma[rows], lo[rows], hi[rows]
    for _ in range(newton_steps):
        q, q1, q2 = _along_rows(th, n, L, offset, sg, st, ph)
        _, g, hess = obstacle.derivatives(q)
        d1 = np.einsum("ij,ij->i", g, q1)
        d2 = np.einsum("ij,ijk,ik->i", q1, hess, q1) + np.einsum("ij,ij->i", g, q2)
        step = np.where(d2 > 0, d1 / np.where(d2 > 0, d2, 1.0), 0.0)
        new = np.clip(sg - step, lo_r, hi_r)
        done = float(np.max(np.abs(new - sg))) <= 1e-15
        sg = new
        if done:
            break
    q, q1, _ = _along_rows(th, n, L, offset, sg, st, ph)
    dist, g, _ = obstacle.derivatives(q)
    d1 = np.einsum("ij,ij->i", g, q1)
    scale = np.abs(L / n + offset * th)
    ok = (sg > 1e-9) & (sg < 1.0 - 1e-9) & (np.abs(d1) <= 1e-9 * np.maximum(scale, 1.0))
    interior = np.zeros(n, dtype=bool)
    interior[rows] = ok
    sigma = np.where(d[:, 0] < d[:, -1], 0.0, 1.0)
    sigma[rows[ok]] = sg[ok]
    gap = ends_gap.copy()
    gap[rows[ok]] = dist[ok]
    return sigma, interior, gap


# ---------------------------------------------------------------------------------------------
# the same surface on CasADi symbols


def _sinc(u: Any) -> Any:
    """sin(u)/u with a series branch at 0, as ``derive.smooth.sinc`` (both branches finite, exact derivatives)."""
    u2 = u * u
    series = 1 - u2 / 6 * (1 - u2 / 20 * (1 - u2 / 42 * (1 - u2 / 72)))
    w = u + ca.if_else(u2 < SINC_SWITCH**2, 1, 0)
    return ca.if_else(ca.fabs(u) < SINC_SWITCH, series, ca.sin(w) / w)


def _versinc(u: Any) -> Any:
    return u / 2 * _sinc(u / 2) ** 2


def symbolic_surface(theta: Any, L: Any, offset: Any, sigma: Any) -> tuple[list, list]:
    """The surface at ``offset`` on CasADi symbols: the joint points 1..n and the points at
    ``sigma[i]`` of each segment, as lists of 2-vectors (x, y)."""
    n = theta.shape[0]
    x = y = 0
    phi = 0
    joints, inside = [], []
    seg = L / n
    for i in range(n):
        t, sg = theta[i], sigma[i]
        u = sg * t
        cx, cy = seg * sg * _sinc(u), seg * sg * _versinc(u)
        head = phi + u
        inside.append((x + ca.cos(phi) * cx - ca.sin(phi) * cy + offset * ca.sin(head), y + ca.sin(phi) * cx + ca.cos(phi) * cy - offset * ca.cos(head)))
        cx, cy = seg * _sinc(t), seg * _versinc(t)
        x, y = x + ca.cos(phi) * cx - ca.sin(phi) * cy, y + ca.sin(phi) * cx + ca.cos(phi) * cy
        phi = phi + t
        joints.append((x + offset * ca.sin(phi), y - offset * ca.cos(phi)))
    return joints, inside

"""Kinematics of the virtual rigid robot: twists, the hat map, exponentials, the POE map (Eq. 1-2).

The base frame S sits at the base of the inextensible layer, x vertical downward, y horizontal
(Section 3.1). Joint i of the virtual robot turns about z through q_i = (0, l_i, 0) with
l_i = L/(n theta_i) (Eq. 1), so every segment of the actuator is a circular arc of length L/n.

Two forms of the same map live here:

* the paper's: the product of 4x4 matrix exponentials of the twists (Eq. 2), used to *prove*
  (symbolically, small n) that it equals the chain of tangent circular arcs;
* the chain form used to generate code: the position of a point is a *chain sum*
  ``Q = sum_k R(phi_k) v_k(theta_k)`` with cumulative angles ``phi_k = theta_1 + ... +
  theta_{k-1}`` and a local vector ``v_k`` per segment. Its derivatives follow the screw-theory
  Jacobian (column j is the local derivative plus the rotation of everything beyond joint j):

      dQ/dtheta_j            = R(phi_j) v_j'  +  J S_j,            S_j = sum_{k>j} R(phi_k) v_k
      d2Q/dtheta_j^2         = R(phi_j) v_j'' -  S_j
      d2Q/dtheta_j dtheta_k  = J dQ/dtheta_k                       (j < k)

  with J the rotation by +90 degrees. Every entry is O(1) given the cumulative quantities, so
  the gradient costs O(n) and the Hessian O(n^2) (``chain_sum_derivatives``; checked against
  brute-force SymPy differentiation of the POE map in the tests).
"""

from __future__ import annotations

import sympy as sp

from . import symbols as S
from .smooth import sinc, versinc

# ----------------------------------------------------------------------------------------------
# Screw theory (Section 3.1 and Appendix a)


def twist(omega: sp.Matrix, q: sp.Matrix) -> sp.Matrix:
    """Twist of a revolute joint with unit axis ``omega`` through point ``q``: [-omega x q; omega]."""
    return sp.Matrix.vstack(-omega.cross(q), omega)


def skew(w: sp.Matrix) -> sp.Matrix:
    """The hat map of a 3-vector: ``skew(w) @ v == w x v``.

    (The paper's Appendix (a) prints -omega_1 in row 1, column 2; the correct entry is -omega_3:
    see ``paper.hat_omega_printed`` and the audit.)
    """
    return sp.Matrix([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def hat(xi: sp.Matrix) -> sp.Matrix:
    """The 4x4 matrix of a twist ``xi = [v; omega]`` (Appendix a)."""
    out = sp.zeros(4, 4)
    out[:3, :3] = skew(xi[3:, 0])
    out[:3, 3] = xi[:3, 0]
    return out


def exp_twist(xi: sp.Matrix, angle: sp.Expr) -> sp.Matrix:
    """``exp(hat(xi) * angle)`` for a unit-axis rotational twist, by Rodrigues' formula.

    ``e^{xi^ th} = [[e^{w^ th}, (I - e^{w^ th})(w x v) + w w^T v th], [0, 1]]``
    (Murray, Li, Sastry, Prop. 2.8). ``test_kinematics`` checks it against SymPy's
    general matrix exponential.
    """
    v, w = xi[:3, 0], xi[3:, 0]
    wh = skew(w)
    rot = sp.eye(3) + sp.sin(angle) * wh + (1 - sp.cos(angle)) * wh * wh
    p = (sp.eye(3) - rot) * w.cross(v) + w * (w.T * v)[0] * angle
    out = sp.eye(4)
    out[:3, :3] = rot
    out[:3, 3] = p
    return out


def joint_radius(theta_i: sp.Expr, n: int | sp.Expr) -> sp.Expr:
    """Eq. (1): the bending radius l_i = L/(n theta_i) of a segment of arc length L/n."""
    return S.L / (n * theta_i)


def segment_twist(theta_i: sp.Expr, n: int | sp.Expr) -> sp.Matrix:
    """The twist of joint i: axis z through q_i = (0, l_i, 0), i.e. [l_i, 0, 0, 0, 0, 1]."""
    return twist(sp.Matrix([0, 0, 1]), sp.Matrix([0, joint_radius(theta_i, n), 0]))


def poe(thetas: list[sp.Expr], n: int | None = None, last_fraction: sp.Expr = 1) -> sp.Matrix:
    """Eq. (2): g_st(theta) = e^{xi_1 theta_1} ... e^{xi_m theta_m} g_st(0), g_st(0) = I.

    ``n`` is the segment count that fixes each twist (default ``len(thetas)``); the last joint
    turns by ``last_fraction * theta_m`` about its own twist, which gives the pose at a point
    inside segment m (``1/2``: its mid-point, as Eq. 15 places it).
    """
    n = len(thetas) if n is None else n
    g = sp.eye(4)
    for i, th in enumerate(thetas):
        frac = last_fraction if i == len(thetas) - 1 else 1
        g = g * exp_twist(segment_twist(th, n), frac * th)
    return g


def arc_chain(thetas: list[sp.Expr], n: int | None = None, last_fraction: sp.Expr = 1) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
    """The end point and heading of tangent circular arcs of length L/n, built geometrically.

    Arc k starts where arc k-1 ends, tangent to it, and turns by theta_k with radius l_k.
    """
    n = len(thetas) if n is None else n
    x = y = phi = sp.Integer(0)
    for i, th in enumerate(thetas):
        frac = last_fraction if i == len(thetas) - 1 else 1
        l = joint_radius(th, n)
        # an arc of radius l turned by frac*th, in the frame of its start
        cx, cy = l * sp.sin(frac * th), l * (1 - sp.cos(frac * th))
        x, y = x + sp.cos(phi) * cx - sp.sin(phi) * cy, y + sp.sin(phi) * cx + sp.cos(phi) * cy
        phi = phi + frac * th
    return x, y, phi


# ----------------------------------------------------------------------------------------------
# The chain form used for code generation


def chord(t: sp.Expr, sigma: sp.Expr, n: int | sp.Expr) -> sp.Matrix:
    """Chord of the first fraction ``sigma`` of a segment bent by ``t``, in the segment's frame.

    ``l (sin(sigma t), 1 - cos(sigma t))`` with ``l = L/(n t)``, written as
    ``(L/n) sigma (sinc(sigma t), versinc(sigma t))``: smooth and exact at t = 0, where it is the
    straight chord ``(sigma L/n, 0)``.
    """
    u = sigma * t
    return (S.L / n) * sigma * sp.Matrix([sinc(u), versinc(u)])


def rot(phi: sp.Expr) -> sp.Matrix:
    """Rotation of the plane by ``phi`` about z."""
    return sp.Matrix([[sp.cos(phi), -sp.sin(phi)], [sp.sin(phi), sp.cos(phi)]])


#: Rotation by +90 degrees: d/dphi R(phi) = J R(phi).
J = sp.Matrix([[0, -1], [1, 0]])


Vec = tuple  # a plane vector (x, y) of SymPy expressions


def chain_sum_derivatives(
    cos_phi: list[sp.Expr],
    sin_phi: list[sp.Expr],
    v: list[Vec],
    dv: list[Vec],
    ddv: list[Vec],
    assign,
    tag: str,
) -> tuple[Vec, list[Vec], list[Vec], list[Vec]]:
    """Value and derivatives of ``Q = sum_k R(phi_k) v_k(theta_k)`` in the screw-theory form.

    Plane vectors are tuples ``(x, y)`` (SymPy's Matrix arithmetic is far slower on 2-vectors).

    Parameters
    ----------
    cos_phi, sin_phi : list
        cos and sin of the cumulative angle phi_k before segment k (k = 1..n).
    v, dv, ddv : list of (x, y)
        the local vector of each segment and its first and second derivative in theta_k.
    assign : callable(name, expr) -> Symbol
        records an intermediate quantity in the straight-line program and returns its symbol.
    tag : str
        a prefix for the names of the intermediates.

    Returns
    -------
    Q : (x, y)
    D : list, D[j] = dQ/dtheta_j
    DD : list, DD[j] = d2Q/dtheta_j^2
    S : list, S[j] = sum_{k>j} R(phi_k) v_k (the part beyond joint j)
    """
    n = len(v)

    def rotate(k: int, a: Vec) -> Vec:
        c, s = cos_phi[k], sin_phi[k]
        return (c * a[0] - s * a[1], s * a[0] + c * a[1])

    def vec(name: str, a: Vec) -> Vec:
        return (assign(f"{name}_x", a[0]), assign(f"{name}_y", a[1]))

    rotated = [vec(f"{tag}_r{k + 1}", rotate(k, v[k])) for k in range(n)]
    S_: list[Vec] = [(sp.Integer(0), sp.Integer(0))] * n
    acc: Vec = (sp.Integer(0), sp.Integer(0))
    for j in range(n - 1, -1, -1):
        S_[j] = acc
        summed = (acc[0] + rotated[j][0], acc[1] + rotated[j][1])
        acc = vec(f"{tag}_tail{j + 1}", summed) if j > 0 else summed
    Q = vec(f"{tag}_Q", acc)
    D = []
    DD = []
    for j in range(n):
        rd, rdd = rotate(j, dv[j]), rotate(j, ddv[j])
        # J S = (-S_y, S_x): the rotation of everything beyond joint j
        D.append(vec(f"{tag}_D{j + 1}", (rd[0] - S_[j][1], rd[1] + S_[j][0])))
        DD.append((rdd[0] - S_[j][0], rdd[1] - S_[j][1]))
    return Q, D, DD, S_


def fraction_in_segment(s: sp.Expr, k: int, n: int) -> sp.Expr:
    """How much of segment k (1-based) lies before the point at fraction ``s`` of L: in [0, 1].

    ``sigma_k = min(max(n s - (k - 1), 0), 1)``: 1 for segments wholly before the point, the
    local fraction for the segment that holds it, 0 beyond. Then the point is the chain sum
    ``sum_k R(phi_k) chord(theta_k, sigma_k)``.
    """
    return sp.Min(sp.Max(n * s - (k - 1), 0), 1)

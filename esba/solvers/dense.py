"""Dense LDL^T of a small symmetric SX matrix, unrolled (the 3-D model's 3n x 3n Hessian).

The planar chain's Hessian has an O(n) structure (:mod:`esba.model.structured`); the spatial
model's has none that pays at small n, so its Newton kernels factor it densely: O(N^3) operations
written out, without pivoting. The pivots d have the signs of the matrix's eigenvalues (Sylvester's
law of inertia) wherever the factorisation exists, so they give the Morse index without an
eigendecomposition.

Examples
--------
>>> import casadi as ca, numpy as np
>>> h = ca.SX.sym("h", 2, 2)
>>> L, d = ldl_sx(h, 2)
>>> f = ca.Function("f", [h], [ca.vertcat(*d), ldl_solve_sx(L, d, ca.DM([1.0, 2.0]), 2)])
>>> [np.asarray(o).ravel().round(6).tolist() for o in f(ca.DM([[4.0, 2.0], [2.0, 3.0]]))]
[[4.0, 2.0], [-0.125, 0.75]]
"""

from __future__ import annotations

import casadi as ca

__all__ = ["ldl_sx", "ldl_solve_sx"]


def ldl_sx(h, N: int):
    """LDL^T of a symmetric N x N SX matrix without pivoting, unrolled: (L as nested lists, pivots d)."""
    L = [[None] * N for _ in range(N)]
    d = [None] * N
    for j in range(N):
        dj = h[j, j]
        for k in range(j):
            dj = dj - L[j][k] * L[j][k] * d[k]
        d[j] = dj
        for i in range(j + 1, N):
            v = h[i, j]
            for k in range(j):
                v = v - L[i][k] * L[j][k] * d[k]
            L[i][j] = v / dj
    return L, d


def ldl_solve_sx(L, d, b, N: int):
    """x with L diag(d) L^T x = b, for the factors of :func:`ldl_sx` (an SX column)."""
    y = [None] * N
    for i in range(N):
        v = b[i]
        for k in range(i):
            v = v - L[i][k] * y[k]
        y[i] = v
    x = [None] * N
    for i in reversed(range(N)):
        v = y[i] / d[i]
        for k in range(i + 1, N):
            v = v - L[k][i] * x[k]
        x[i] = v
    return ca.vertcat(*x)

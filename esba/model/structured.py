"""O(n) linear algebra for the Hessian of the chain: diagonal plus a "max" structure.

The Hessian of U has off-diagonal entries that depend on the later joint only,
H[j, k] = c[max(j, k)] for j != k (the elastic terms are separable, the air and fibre terms are
linear in the total angle, and the payload and gravity potentials follow the screw-theory
Jacobian, whose mixed second derivatives d2Q/dtheta_j dtheta_k = J dQ/dtheta_k depend on k
alone, see ``derive/kinematics.py``). So H = diag(e) + C with C[j, k] = c[max(j, k)], c[0] = 0,
c[k] = H[0, k] and e[k] = H[k, k] - c[k].

Eliminating the unknowns from the last to the first keeps that structure: removing unknown k
subtracts the same number from every remaining entry of C. The pivots of that elimination,

    p[k] = e[k] + c[k] - S[k],   s[k] = (c[k] - S[k])^2 / p[k],   S[k-1] = S[k] + s[k]  (S[n-1] = 0),

are those of an LDL^T factorisation (with the unknowns in reverse order), so by Sylvester's law of
inertia the number of negative pivots is the Morse index; and H x = b is solved in O(n) by the
same sweep and a back substitution. :func:`pivots` and :func:`solve` work on NumPy arrays,
:func:`pivots_sx` and :func:`solve_sx` build the same sweeps as CasADi expressions, so that a
compiled Newton step costs O(n) and never forms a dense factorisation.

Examples
--------
>>> h = np.array([[4.0, 1.0, 2.0], [1.0, 5.0, 2.0], [2.0, 2.0, 6.0]])
>>> bool(np.allclose(solve(h, np.array([1.0, 2.0, 3.0])), np.linalg.solve(h, [1.0, 2.0, 3.0])))
True
>>> int(np.sum(pivots(h) < 0)), int(np.sum(np.linalg.eigvalsh(h) < 0))
(0, 0)
"""

from __future__ import annotations

import casadi as ca
import numpy as np

__all__ = ["generators", "pivots", "solve", "inertia", "pivots_sx", "solve_sx", "matvec_sx", "check_structure"]


def generators(h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(e, c) of H = diag(e) + C, C[j, k] = c[max(j, k)]: c[0] = 0, c[k] = H[0, k], e = diag(H) - c."""
    h = np.asarray(h, dtype=float)
    c = np.concatenate([[0.0], h[0, 1:]])
    return np.diag(h) - c, c


def check_structure(h: np.ndarray, rtol: float = 1e-12) -> bool:
    """True when every off-diagonal entry of H equals c[max(j, k)] (to ``rtol`` of the largest entry)."""
    h = np.asarray(h, dtype=float)
    n = h.shape[0]
    _, c = generators(h)
    j, k = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    model = c[np.maximum(j, k)]
    off = j != k
    scale = max(float(np.max(np.abs(h))), 1e-300)
    return bool(np.all(np.abs(h[off] - model[off]) <= rtol * scale))


def _sweep(e, c, n: int, zero, divide):
    """The elimination from the last unknown to the first: pivots p[k] and the couplings c[k] - S[k]."""
    p = [zero] * n
    a = [zero] * n  # a[k] = c[k] - S[k]: unknown k's coupling to every earlier unknown, at its turn
    shift = zero
    for k in range(n - 1, -1, -1):
        a[k] = c[k] - shift
        p[k] = e[k] + a[k]
        shift = shift + divide(a[k] * a[k], p[k])
    return p, a


def pivots(h: np.ndarray) -> np.ndarray:
    """The n pivots of the structured elimination (their signs are the eigenvalues' signs)."""
    e, c = generators(h)
    p, _ = _sweep(e, c, len(e), 0.0, lambda x, y: x / y)
    return np.array(p, dtype=float)


def inertia(h: np.ndarray) -> tuple[int, float]:
    """(Morse index, smallest pivot relative to the largest magnitude) in O(n)."""
    p = pivots(h)
    return int(np.sum(p < 0)), float(np.min(p) / max(float(np.max(np.abs(p))), 1e-300))


def _solve(e, c, b, n: int, zero, divide):
    p, a = _sweep(e, c, n, zero, divide)
    # forward: eliminating unknown k shifts every earlier right-hand side by a[k] beta[k] / p[k]
    beta = [zero] * n
    shift = zero
    for k in range(n - 1, -1, -1):
        beta[k] = b[k] - shift
        shift = shift + divide(a[k] * beta[k], p[k])
    # back: x[k] = (beta[k] - a[k] * sum_{j<k} x[j]) / p[k]
    x = [zero] * n
    total = zero
    for k in range(n):
        x[k] = divide(beta[k] - a[k] * total, p[k])
        total = total + x[k]
    return x


def solve(h: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with H x = b, in O(n) from the structure (no check that H has it: see :func:`check_structure`)."""
    e, c = generators(h)
    b = np.asarray(b, dtype=float).ravel()
    return np.array(_solve(e, c, b, len(e), 0.0, lambda x, y: x / y), dtype=float)


def _sx_generators(h):
    n = h.shape[0]
    c = [ca.SX(0.0)] + [h[0, k] for k in range(1, n)]
    e = [h[k, k] - c[k] for k in range(n)]
    return e, c, n


def pivots_sx(h) -> ca.SX:
    """:func:`pivots` as CasADi SX expressions of the entries of an SX matrix ``h`` (row 0 and the diagonal)."""
    e, c, n = _sx_generators(h)
    p, _ = _sweep(e, c, n, ca.SX(0.0), lambda x, y: x / y)
    return ca.vertcat(*p)


def solve_sx(h, b) -> ca.SX:
    """:func:`solve` as CasADi SX expressions (uses row 0 and the diagonal of ``h`` only)."""
    e, c, n = _sx_generators(h)
    bs = [b[k] for k in range(n)]
    return ca.vertcat(*_solve(e, c, bs, n, ca.SX(0.0), lambda x, y: x / y))


def matvec_sx(h, v) -> ca.SX:
    """H v in O(n) from the structure (row 0 and the diagonal of ``h``), as CasADi expressions:
    (C v)_j = c[j] (v_0 + ... + v_j) + c[j+1] v_{j+1} + ... + c[n-1] v_{n-1}."""
    e, c, n = _sx_generators(h)
    vs = [v[k] for k in range(n)]
    below = [ca.SX(0.0)] * n  # v_0 + ... + v_j
    total = ca.SX(0.0)
    for j in range(n):
        total = total + vs[j]
        below[j] = total
    above = [ca.SX(0.0)] * (n + 1)  # c[j] v_j + ... + c[n-1] v_{n-1}
    for j in range(n - 1, -1, -1):
        above[j] = above[j + 1] + c[j] * vs[j]
    return ca.vertcat(*[e[j] * vs[j] + c[j] * below[j] + above[j + 1] for j in range(n)])

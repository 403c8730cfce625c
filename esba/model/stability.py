"""Stability of an equilibrium from the eigenvalues of the Hessian of U.

An equilibrium (dU/dtheta = 0) is a strict minimum of the total potential energy, i.e. *stable*,
when every eigenvalue of the Hessian is positive; its *Morse index* is the number of negative
eigenvalues (0 for a minimum, 1 on the unstable branch between two stable states of a bistable
actuator, ...). Eigenvalues within ``critical_tol`` times the largest magnitude of zero are treated
as zero: the equilibrium is then *critical* (a fold or a branch point), neither verdict.

Examples
--------
>>> stability_verdict([2.0, 5.0]), stability_verdict([-1.0, 5.0]), stability_verdict([1e-14, 5.0])
('stable', 'unstable', 'critical')
>>> int(morse_index([-3.0, -1e-14, 2.0]))
1
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

__all__ = ["STABILITY", "CRITICAL_TOL", "stability_verdict", "stability_verdicts", "morse_index", "morse_indices"]

#: The stability verdicts, from the smallest eigenvalue of the Hessian relative to the largest.
STABILITY = ("stable", "critical", "unstable")

#: Default relative threshold below which an eigenvalue counts as zero.
CRITICAL_TOL = 1e-9


def _scale(eig: np.ndarray) -> np.ndarray:
    return np.maximum(np.max(np.abs(eig), axis=-1), 1e-300)


def stability_verdicts(eigenvalues: np.ndarray, critical_tol: float = CRITICAL_TOL) -> np.ndarray:
    """``stable``, ``critical`` or ``unstable`` for every row of an (m, n) array of eigenvalues.

    The smallest eigenvalue is compared with ``critical_tol`` times the largest magnitude; a row
    with a non-finite eigenvalue is ``unknown``.

    >>> stability_verdicts(np.array([[2.0, 5.0], [np.nan, 1.0]])).tolist()
    ['stable', 'unknown']
    """
    eig = np.asarray(eigenvalues, dtype=float)
    out = np.full(len(eig), "unknown", dtype=object)
    finite = np.all(np.isfinite(eig), axis=1)
    safe = np.where(finite[:, None], eig, 0.0)
    scale = _scale(safe)
    low = np.min(safe, axis=1)
    out[finite] = "critical"
    out[finite & (low > critical_tol * scale)] = "stable"
    out[finite & (low < -critical_tol * scale)] = "unstable"
    return out.astype(str)


def stability_verdict(eigenvalues: Sequence[float], critical_tol: float = CRITICAL_TOL) -> str:
    """:func:`stability_verdicts` of one set of eigenvalues."""
    return str(stability_verdicts(np.asarray(eigenvalues, dtype=float)[None, :], critical_tol)[0])


def morse_indices(eigenvalues: np.ndarray, critical_tol: float = CRITICAL_TOL) -> np.ndarray:
    """The number of negative eigenvalues (below ``-critical_tol`` times the largest magnitude) per row.

    >>> morse_indices(np.array([[1.0, 2.0], [-1.0, 2.0]])).tolist()
    [0, 1]
    """
    eig = np.asarray(eigenvalues, dtype=float)
    return np.sum(eig < -critical_tol * _scale(eig)[:, None], axis=1)


def morse_index(eigenvalues: Sequence[float], critical_tol: float = CRITICAL_TOL) -> int:
    """:func:`morse_indices` of one set of eigenvalues."""
    return int(morse_indices(np.asarray(eigenvalues, dtype=float)[None, :], critical_tol)[0])

"""The tip's 6 x 6 tangent stiffness and compliance of a 3-D equilibrium (``esba stiffness --3d``,
``esba solve --3d --json``), from :func:`esba.statics.spatial.tip_compliance`.

Coordinates, in this order, in the base frame: the tip's position x, y, z (mm; x down, y the
bending direction, z the layer's normal) and its rotation about x, y, z (rad); the loads conjugate
to them: a tip force (N) and a tip moment (N mm), dead loads added at the tip. So the stiffness
K = C^-1 has the blocks [[N/mm, N/rad], [N (N mm/mm), N mm/rad]] and the compliance C the blocks
[[mm/N, mm/(N mm)], [rad/N, rad/(N mm)]].

A state that is not stable (its 3n x 3n Hessian not positive definite) has no stiffness in this
sense (K would not be positive definite: the tip would not come back); a tip with fewer than six
independent motions (n = 1: three degrees of freedom) has a compliance but no inverse of it.

>>> from esba.model.scene import MAIN_JOB
>>> from esba.model.spatial import load_model3d
>>> from esba.statics.spatial import scene_values3d, solve_scene3d
>>> section = {"EI_side": 4e5, "GJ": 1e6}
>>> effects, values = scene_values3d(MAIN_JOB, section)
>>> model = load_model3d(MAIN_JOB.segments, effects, MAIN_JOB.variant)
>>> t = tip_stiffness3d(model, values, solve_scene3d(MAIN_JOB, section))
>>> t.stable, t.stiffness.shape
(True, (6, 6))
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

#: The order of the coordinates of the 6 x 6 matrices (base frame).
COORDINATES3D = ("x", "y", "z", "rot_x", "rot_y", "rot_z")

#: What the rows and columns of the two matrices are, and their units (for the JSON and the table).
ORDER3D = ("rows and columns: the tip's position x, y, z (mm) and its rotation about x, y, z (rad), in the base frame "
           "(x down, y the bending direction, z the layer's normal); loads conjugate to them: tip force (N), tip moment (N mm)")
UNITS3D = {"stiffness": "[[N/mm, N/rad], [N, N mm/rad]] (translation, rotation blocks)",
           "compliance": "[[mm/N, mm/(N mm)], [rad/N, rad/(N mm)]] (translation, rotation blocks)"}

#: Below this the smallest eigenvalue of the unit-free (correlation) form of C counts as zero.
SINGULAR = 1e-10


@dataclass(frozen=True, eq=False)
class TipStiffness3D:
    """The tip's 6 x 6 tangent stiffness at one 3-D equilibrium (loads held as dead loads).

    Attributes
    ----------
    stable : bool
        Whether the state is stable (its Hessian positive definite); without it, no matrices.
    min_eigenvalue : float
        The Hessian's smallest eigenvalue (N mm per rad^2).
    compliance, stiffness : ndarray or None
        C = J H^-1 J^T and K = C^-1 (:data:`COORDINATES3D`); K is None when C is singular.
    reason : str
        Why a matrix is missing ('' when both are there).
    """

    stable: bool
    min_eigenvalue: float
    compliance: np.ndarray | None
    stiffness: np.ndarray | None
    reason: str = ""

    def to_dict(self) -> dict:
        """JSON-ready: the matrices (null when missing, with ``reason``), their order and units."""
        return {
            "stable": self.stable,
            "min_eigenvalue": self.min_eigenvalue,
            "coordinates": list(COORDINATES3D),
            "order": ORDER3D,
            "units": dict(UNITS3D),
            "tip_stiffness": None if self.stiffness is None else self.stiffness.tolist(),
            "tip_compliance": None if self.compliance is None else self.compliance.tolist(),
            "reason": self.reason,
        }


def tip_stiffness3d(model, values: Mapping[str, float], result) -> TipStiffness3D:
    """The tip's 6 x 6 stiffness and compliance at the 3-D equilibrium ``result`` of ``model``
    (:class:`esba.statics.spatial.Equilibrium3D`) with parameter ``values``."""
    from esba.statics.spatial import tip_compliance

    lowest = float(np.linalg.eigvalsh(model.hessian(result.q, values))[0])
    if lowest <= 0:
        return TipStiffness3D(False, lowest, None, None,
                              f"the state is not stable (the Hessian's smallest eigenvalue is {lowest:.3g}): its stiffness "
                              "would not be positive definite, so none is given")
    C, _ = tip_compliance(model, values, result.q)
    d = np.sqrt(np.clip(np.diag(C), 0.0, None))
    if np.any(d == 0) or np.linalg.eigvalsh(C / np.outer(d, d))[0] <= SINGULAR:
        return TipStiffness3D(True, lowest, C, None,
                              f"the compliance is singular: the tip has fewer than six independent motions here (n = {model.n}, "
                              f"{model.size} degrees of freedom), so it has no 6 x 6 stiffness")
    K = np.linalg.inv(C)
    return TipStiffness3D(True, lowest, C, 0.5 * (K + K.T))


def stiffness3d_table(d: dict) -> str:
    """``esba stiffness --3d``'s table, from its JSON."""
    rows = [f"{'scene':>10}: {d['scene']}", f"{'model':>10}: {d['model']}",
            f"{'section':>10}: EI_side {d['section_nmm2']['EI_side']:.6g} N mm^2, GJ {d['section_nmm2']['GJ']:.6g} N mm^2 ({d['section_from']})",
            f"{'tip':>10}: " + "  ".join(f"{v:.4f}" for v in d["tip_mm"]) + " mm",
            f"{'state':>10}: " + ("stable" if d["stable"] else "NOT STABLE") + f" (the Hessian's smallest eigenvalue {d['min_eigenvalue']:.4g})"]
    rows += [f"{'note':>10}: {n}" for n in d["notes"]]
    rows.append(f"{'order':>10}: {d['order']}")
    for key, name in (("tip_stiffness", "stiffness"), ("tip_compliance", "compliance")):
        if d[key] is None:
            continue
        rows.append(f"{name:>10}: units {d['units'][name]}")
        rows += [" " * 12 + "  ".join(f"{v:>11.4g}" for v in row) for row in d[key]]
    if d["reason"]:
        rows.append(f"{'NOTE' if d['stable'] else 'NOT STABLE':>10}: {d['reason']}")
    return "\n".join(rows)


__all__ = ["COORDINATES3D", "TipStiffness3D", "stiffness3d_table", "tip_stiffness3d"]

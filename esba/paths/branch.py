"""The result of a path trace: a :class:`Branch` of equilibria and its :class:`SpecialPoint` s.

Per point: lambda, theta, tip, arclength, the Hessian's eigenvalues and Morse index (the number of
negative eigenvalues), and what the point is (start, regular, fold, branch point, user value,
event, end); per branch: the located special points and why the trace stopped. ``to_dict()`` for
JSON (no NaN: null with the reason), :func:`branches_csv` and :func:`write_branches` for files.
Labels follow AUTO-07p: LP (limit point, a fold), BP (branch point), UZ (user value), EP (end).
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from esba.infra import outputs
from esba.infra.report import Report
from esba.model.stability import CRITICAL_TOL

from .problem import PathError

__all__ = ["SpecialPoint", "Branch", "STOPS", "LABELS", "branches_csv", "write_branches"]

#: AUTO-07p's labels of the special points.
LABELS = {"fold": "LP", "branch point": "BP", "user": "UZ", "end": "EP"}


# ---------------------------------------------------------------------------------------------
# points, special points, branches


@dataclass(frozen=True, eq=False)
class SpecialPoint:
    """A located fold, branch point, user point or end point of a branch.

    Attributes
    ----------
    kind : str
        ``fold`` (limit point: lambda turns back and one eigenvalue crosses zero), ``branch point``
        (an eigenvalue crosses zero, lambda goes on), ``user`` (a requested value of lambda) or
        ``event`` (a total-angle or user event).
    lam : float
        Lambda at the point, in the parameter's unit.
    theta : ndarray
        Segment angles, rad.
    tip : ndarray
        Tip x, y (mm) and orientation (rad).
    eigenvalue : float
        The critical eigenvalue (the one that crosses zero), N mm/rad^2; nan for user points.
    eigenvector : ndarray
        Its unit eigenvector (the critical mode); empty for user points.
    morse_before, morse_after : int
        Morse index on either side, in the direction of the trace.
    status : str
        ``converged`` (located to the tolerance) or ``guess`` (only bracketed: the better end).
    bracket : (float, float)
        Lambda at the two trace points around it.
    method : str
        How it was located.
    index : int
        Its row in the branch's arrays.
    orthogonality : float
        |phi . dg/dlambda| / |dg/dlambda| at the point (phi its critical vector): 0 at a branch point,
        where dg/dlambda is orthogonal to the null vector (Moore's extended system), not at a fold;
        nan for user points. :data:`esba.paths.locate.BRANCH_ORTHOGONALITY` separates the two.
    bifurcation : str
        For a branch point, its type from the third derivative of U along the null vector,
        c = d3U[phi, phi, phi] (:func:`esba.paths.locate.classify_branch_point`): ``transcritical``
        (c != 0: the crossing branch passes through with lambda changing, so one side carries more
        load than the branch point and the other less) or ``pitchfork`` (c = 0: the crossing branch
        leaves tangent to lambda = const, both sides alike to first order); empty for other points.
    cubic : float
        That c, N mm/rad^3 (nan when not a branch point).
    """

    kind: str
    lam: float
    theta: np.ndarray
    tip: np.ndarray
    eigenvalue: float
    eigenvector: np.ndarray
    morse_before: int
    morse_after: int
    status: str
    bracket: tuple[float, float]
    method: str
    index: int = -1
    arclength: float = math.nan
    orthogonality: float = math.nan
    bifurcation: str = ""
    cubic: float = math.nan

    @property
    def label(self) -> str:
        """AUTO-07p's label: LP (fold), BP (branch point), UZ (user value), EP (end)."""
        return LABELS.get(self.kind, "UZ")

    @property
    def total_angle_deg(self) -> float:
        """Total bending angle at the point, degrees."""
        return math.degrees(float(np.sum(self.theta)))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (degrees and mm)."""
        return {
            "kind": self.kind,
            "label": self.label,
            "lambda": self.lam,
            "theta_deg": np.degrees(self.theta).tolist(),
            "total_angle_deg": self.total_angle_deg,
            "tip_mm": [float(self.tip[0]), float(self.tip[1])],
            "eigenvalue": None if not math.isfinite(self.eigenvalue) else self.eigenvalue,
            "eigenvector": [float(v) for v in self.eigenvector],
            "morse_before": self.morse_before,
            "morse_after": self.morse_after,
            "status": self.status,
            "bracket": list(self.bracket),
            "method": self.method,
            "index": self.index,
            "orthogonality": None if not math.isfinite(self.orthogonality) else self.orthogonality,
            "bifurcation": self.bifurcation or None,
            "cubic": None if not math.isfinite(self.cubic) else self.cubic,
        }


#: Why a trace stops: the codes of :attr:`Branch.stopped`.
STOPS = ("bound", "max_steps", "event", "loop", "corrector", "domain", "instability", "start", "refused")


def special_counts(points: Sequence[SpecialPoint]) -> str:
    """How many special points of each kind, in words: ``"2 folds, 1 branch point"`` (empty for none)."""
    counts = {k: sum(1 for s in points if s.kind == k) for k in dict.fromkeys(s.kind for s in points)}
    return ", ".join(f"{n} {k}{'s' if n != 1 else ''}" for k, n in counts.items())


def branch_lines(b: dict[str, Any]) -> list[str]:
    """A branch's :meth:`Branch.to_dict` as text: its label, points and why it stopped, then a row per
    special point (the lines ``esba path`` prints for each branch)."""
    unit = b["unit"].split(" ")[0]
    unit = "" if unit == "1" else f" {unit}"
    lines = [f"{b['label'] or 'branch'}: {b['points']} points; {b['stop_reason']}"]
    if b["special_points"]:
        lines.append(f"  {'':2} {'point':<13} {b['parameter'] + unit:>16} {'angle deg':>10} {'tip x, y mm':>17}  {'Morse':>5}  status")
    for sp in b["special_points"]:
        tip = f"{sp['tip_mm'][0]:7.2f}, {sp['tip_mm'][1]:7.2f}"
        kind = f"; {sp['bifurcation']}" if sp.get("bifurcation") else ""
        lines.append(
            f"  {sp['label']:2} {sp['kind']:<13} {sp['lambda']:16.9g} {sp['total_angle_deg']:10.3f} {tip:>17}  "
            f"{sp['morse_before']} -> {sp['morse_after']}  {sp['status']}{kind}"
        )
    return lines


@dataclass(frozen=True, eq=False, repr=False)
class Branch(Report):
    """A traced branch: one row per point, in the order traced.

    Attributes
    ----------
    name, unit : str
        The parameter lambda and its unit.
    lam : ndarray, shape (m,)
        Lambda per point.
    theta : ndarray, shape (m, n)
        Segment angles, rad.
    tip : ndarray, shape (m, 3)
        Tip x, y (mm) and orientation (rad), computed on first use (``tips``).
    arclength : ndarray, shape (m,)
        Scaled arclength from the start.
    eigenvalues : ndarray, shape (m, n)
        Hessian eigenvalues, ascending, N mm/rad^2: computed when first asked for (``spectrum``),
        since the trace itself needs only the Hessian's LDL^T pivots.
    min_pivot : ndarray, shape (m,)
        The Hessian's smallest LDL^T pivot relative to the largest magnitude (its sign is the smallest
        eigenvalue's: Sylvester's law of inertia).
    morse : ndarray of int, shape (m,)
        Morse index (number of negative eigenvalues, counted as negative pivots).
    kind : ndarray of str, shape (m,)
        ``start``, ``regular``, ``fold``, ``branch point``, ``user``, ``event`` or ``end``.
    special : tuple of SpecialPoint
        The located special points (also rows of the arrays, see ``index``).
    stopped : str
        Why the trace stopped, one of :data:`STOPS`.
    stop_reason : str
        The same in words.
    iterations : ndarray of int
        Corrector iterations per point.
    residuals : tuple of tuple of float
        The corrector's max |g| before each iteration, per point (its convergence history).
    evaluations : int
        Evaluations of g, H and dg/dlambda the trace made (correctors, tangents, locating).
    beyond : (float, ndarray) or None
        When the trace stopped at the end of a stable branch: (lambda, theta) of the step past
        it, on the unstable side (which way a snap-through starts).
    """

    name: str
    unit: str
    lam: np.ndarray
    theta: np.ndarray
    tips: Callable[[], np.ndarray] = field(repr=False)
    arclength: np.ndarray
    spectrum: Callable[[], np.ndarray] = field(repr=False)
    min_pivot: np.ndarray
    morse: np.ndarray
    kind: np.ndarray
    special: tuple[SpecialPoint, ...]
    stopped: str
    stop_reason: str
    iterations: np.ndarray
    residuals: tuple[tuple[float, ...], ...] = field(repr=False, default=())
    critical_tol: float = CRITICAL_TOL
    label: str = ""
    beyond: tuple[float, np.ndarray] | None = field(repr=False, default=None)
    evaluations: int = 0

    _plotter = "esba.figures.results:draw_branch"

    def __len__(self) -> int:
        return len(self.lam)

    def headline(self) -> str:
        """One line: the parameter's range, the points, the special points and why the trace stopped."""
        if not len(self):
            return f"{self.label or 'branch'} in {self.name}: no point; {self.stopped}"
        unit = self.unit.split(" ")[0]
        unit = "" if unit == "1" else f" {unit}"
        kinds = special_counts(self.special)
        return (f"{self.label + ', ' if self.label else ''}{self.name} {self.lam[0]:.4g} to {self.lam[-1]:.4g}{unit}, {len(self)} points"
                f"{'; ' + kinds if kinds else ''}; stopped: {self.stopped}")

    def summary(self) -> str:
        """The branch and its special points, as ``esba path`` prints each branch."""
        return "\n".join(branch_lines(self.to_dict(points=False)))

    @cached_property
    def tip(self) -> np.ndarray:
        """Tip x, y (mm) and orientation (rad) per point, shape (m, 3) (computed on first use)."""
        return np.asarray(self.tips(), dtype=float).reshape(len(self), 3)

    @cached_property
    def eigenvalues(self) -> np.ndarray:
        """Hessian eigenvalues per point, ascending, shape (m, n), N mm/rad^2 (computed on first use)."""
        return np.asarray(self.spectrum(), dtype=float).reshape(len(self), self.theta.shape[1])

    @property
    def stable(self) -> np.ndarray:
        """Per point: a strict minimum (Morse index 0 and no pivot within the critical band)."""
        return (self.morse == 0) & (self.min_pivot > self.critical_tol)

    @property
    def total_angle_deg(self) -> np.ndarray:
        """Total bending angle per point, degrees."""
        return np.degrees(np.sum(self.theta, axis=1))

    @property
    def folds(self) -> tuple[SpecialPoint, ...]:
        """The folds, in the order traced."""
        return tuple(s for s in self.special if s.kind == "fold")

    @property
    def branch_points(self) -> tuple[SpecialPoint, ...]:
        """The branch points, in the order traced."""
        return tuple(s for s in self.special if s.kind == "branch point")

    @property
    def end(self) -> tuple[float, np.ndarray]:
        """(lambda, theta) of the last point."""
        return float(self.lam[-1]), self.theta[-1]

    def to_dict(self, points: bool = True) -> dict[str, Any]:
        """JSON-ready form (degrees and mm); ``points=False`` leaves out the per-point arrays."""
        out: dict[str, Any] = {
            "label": self.label,
            "parameter": self.name,
            "unit": self.unit,
            "points": len(self),
            "stopped": self.stopped,
            "stop_reason": self.stop_reason,
            "lambda_range": [float(np.min(self.lam)), float(np.max(self.lam))] if len(self) else None,
            "special_points": [s.to_dict() for s in self.special],
        }
        if points:
            out.update(
                {
                    "lambda": self.lam.tolist(),
                    "theta_deg": np.degrees(self.theta).tolist(),
                    "total_angle_deg": self.total_angle_deg.tolist(),
                    "tip_mm": self.tip[:, :2].tolist(),
                    "tip_angle_deg": np.degrees(self.tip[:, 2]).tolist(),
                    "arclength": self.arclength.tolist(),
                    "min_eigenvalue": self.eigenvalues[:, 0].tolist(),
                    "eigenvalues": self.eigenvalues.tolist(),
                    "morse_index": self.morse.astype(int).tolist(),
                    "stable": self.stable.tolist(),
                    "kind": self.kind.tolist(),
                    "corrector_iterations": self.iterations.astype(int).tolist(),
                }
            )
        return out

    def csv_rows(self) -> list[dict[str, Any]]:
        """One dict per point: the CSV's columns."""
        rows = []
        for i in range(len(self)):
            row = {
                "branch": self.label,
                "point": i,
                "kind": str(self.kind[i]),
                "arclength": float(self.arclength[i]),
                f"{self.name} ({self.unit.split(' ')[0]})": float(self.lam[i]),
                "total_angle_deg": float(self.total_angle_deg[i]),
                "tip_x_mm": float(self.tip[i, 0]),
                "tip_y_mm": float(self.tip[i, 1]),
                "tip_angle_deg": math.degrees(float(self.tip[i, 2])),
                "min_eigenvalue": float(self.eigenvalues[i, 0]),
                "morse_index": int(self.morse[i]),
                "stable": bool(self.stable[i]),
            }
            for j, t in enumerate(self.theta[i], start=1):
                row[f"theta{j}_deg"] = math.degrees(float(t))
            for j, e in enumerate(self.eigenvalues[i], start=1):
                row[f"eigenvalue{j}"] = float(e)
            rows.append(row)
        return rows


def branches_csv(branches: Sequence[Branch]) -> str:
    """Every point of every branch as CSV text (one header; a ``branch`` column names the branch)."""
    rows = [r for b in branches for r in b.csv_rows()]
    buf = io.StringIO()
    if rows:
        fields = list(rows[0])
    else:  # no point at all: the header alone, so that the file still says what it would hold
        fields = ["branch", "point", "kind", "arclength", "lambda", "total_angle_deg", "tip_x_mm", "tip_y_mm", "tip_angle_deg", "min_eigenvalue", "morse_index", "stable"]
    writer = csv.DictWriter(buf, fieldnames=fields, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return buf.getvalue()


def write_branches(branches: Sequence[Branch], path: str | Path, extra: Mapping[str, Any] | None = None) -> Path:
    """Write branches to ``path``: CSV for ``.csv``, JSON for ``.json`` (with ``extra`` keys)."""
    path = Path(path)
    if path.suffix.lower() == ".csv":
        outputs.write_text(path, branches_csv(branches))  # WriteFailed naming the file on a full disk
    elif path.suffix.lower() == ".json":
        data = dict(extra or {})
        data["branches"] = [b.to_dict() for b in branches]
        outputs.write_text(path, json.dumps(data, indent=1, sort_keys=True, allow_nan=False) + "\n")
    else:
        raise PathError(f"{str(path)!r}: expected a file name ending in .csv or .json")
    return path

"""Quasi-static load histories: the stable state an actuator follows as a load changes slowly.

A slow load change keeps the actuator on a *stable* branch of equilibria (:mod:`esba.paths.continuation`) until
that branch ends:

* at a **fold** the stable state meets an unstable one and both vanish: the actuator *snaps* to
  another stable state. It moves off along the critical eigenvector, towards the unstable branch
  (the side where the energy falls once the fold is passed), and the state it lands in is found
  by a minimisation (IPOPT, :mod:`esba.solvers.minimise`) started just past the fold along that mode;
* at a **branch point** the state goes on along the crossing branch when that branch is stable
  in the direction of loading (a supercritical bifurcation, such as the buckling of a straight
  actuator that bends to the side its eccentric chamber prefers); when neither side is, it snaps
  as at a fold.

:func:`follow` is one ramp (from a state at lambda0 to a target value), :func:`history` several
in a row (loading up and down: the hysteresis loop of a bistable range). Every jump is a
:class:`Jump` with the special point's lambda and the states before and after; every branch
point crossed without a jump is reported too.

Examples
--------
>>> import numpy as np
>>> from esba.paths.continuation import PathProblem
>>> from esba.model.scene import Scene, Payload
>>> column = Scene(pressure=0.0, payloads=(Payload(1.0, 180.0),), segments=2)
>>> up = follow(PathProblem.from_scene(column, "payload"), np.zeros(2), 1.0, 5.0)
>>> up.reached, len(up.jumps), [round(b.lam, 4) for b in up.branch_points]
(True, 0, [3.3303])
>>> round(float(np.degrees(up.theta).sum()), 2)   # it buckled to the side that stays stable
-41.45
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from esba.infra import checks
from esba.infra.threads import single_threaded
from esba.model.generated import near_domain_bound
from esba.model.stability import morse_index
from esba.solvers.minimise import minimise

from .continuation import DEFAULT_PATH_OPTIONS, Branch, Natural, PathError, PathOptions, PathProblem, SpecialPoint, crossing_start, natural_branch, trace
from .corrector import Corrector
from .problem import is_path_problem

__all__ = ["Jump", "Ramp", "follow", "history"]

#: How many snaps and branch switches one ramp may take before it is reported as stuck.
MAX_EVENTS = 50


@dataclass(frozen=True, eq=False)
class Jump:
    """A snap-through: the stable branch ended at a special point and the state jumped.

    Attributes
    ----------
    kind : str
        ``fold`` or ``branch point``: where the stable branch ended.
    parameter, unit : str
        The ramp's parameter and its unit.
    lam : float
        Lambda at the special point (located, see :class:`esba.paths.continuation.SpecialPoint`).
    lam_after : float
        Lambda at which the landing state was found (just past the point, in the ramp's direction).
    theta_before, theta_after : ndarray
        Segment angles at the special point and after the jump, rad.
    tip_before, tip_after : ndarray
        Tip x, y (mm) and orientation (rad) before and after.
    point : SpecialPoint
        The special point itself.
    """

    kind: str
    parameter: str
    unit: str
    lam: float
    lam_after: float
    theta_before: np.ndarray
    theta_after: np.ndarray
    tip_before: np.ndarray
    tip_after: np.ndarray
    point: SpecialPoint = field(repr=False)

    @property
    def distance_mm(self) -> float:
        """How far the tip jumps, mm."""
        return float(np.hypot(*(self.tip_after[:2] - self.tip_before[:2])))

    def describe(self, value: str | None = None) -> str:
        """One sentence: where it jumps and from which state to which."""
        unit = self.unit.split(" ")[0]
        where = value if value is not None else f"{self.parameter} = {self.lam:.6g}" + ("" if unit == "1" else f" {unit}")
        a, b = math.degrees(float(np.sum(self.theta_before))), math.degrees(float(np.sum(self.theta_after)))
        return (
            f"the quasi-static path jumps (snap-through) at a {self.kind} at {where}: total angle {a:.2f} -> {b:.2f} deg, "
            f"tip ({self.tip_before[0]:.2f}, {self.tip_before[1]:.2f}) -> ({self.tip_after[0]:.2f}, {self.tip_after[1]:.2f}) mm"
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (degrees and mm)."""
        return {
            "kind": self.kind,
            "parameter": self.parameter,
            "unit": self.unit,
            "lambda": self.lam,
            "lambda_after": self.lam_after,
            "theta_before_deg": np.degrees(self.theta_before).tolist(),
            "theta_after_deg": np.degrees(self.theta_after).tolist(),
            "total_angle_before_deg": math.degrees(float(np.sum(self.theta_before))),
            "total_angle_after_deg": math.degrees(float(np.sum(self.theta_after))),
            "tip_before_mm": [float(v) for v in self.tip_before[:2]],
            "tip_after_mm": [float(v) for v in self.tip_after[:2]],
            "distance_mm": self.distance_mm,
            "status": self.point.status,
        }


@dataclass(frozen=True, eq=False)
class Ramp:
    """One quasi-static ramp of a parameter: what the stable state did on the way.

    Attributes
    ----------
    problem : PathProblem
    start, target : float
        Lambda at the start and the value aimed at.
    lam : float
        Lambda reached (``target`` when :attr:`reached`).
    theta : ndarray
        The state reached, rad.
    reached : bool
        The ramp got to ``target`` on a stable state.
    jumps : tuple of Jump
        The snaps on the way, in order.
    branch_points : tuple of SpecialPoint
        Branch points where the state went on along a crossing branch without a jump.
    pieces : tuple of Branch
        The traced stable pieces, in order (a jump connects the end of one to the start of the next).
    message : str
        Why the target was not reached (empty when it was).
    ipopt_iterations : int
        IPOPT's iterations finding where the snaps landed.
    algorithm : str
        ``Natural`` when natural continuation was accepted for the whole ramp, else ``PALC``.
    """

    problem: PathProblem = field(repr=False)
    start: float
    target: float
    lam: float
    theta: np.ndarray
    reached: bool
    jumps: tuple[Jump, ...]
    branch_points: tuple[SpecialPoint, ...]
    pieces: tuple[Branch, ...] = field(repr=False)
    message: str = ""
    ipopt_iterations: int = 0
    algorithm: str = "PALC"

    @property
    def points(self) -> int:
        """Points traced over every piece."""
        return sum(len(p) for p in self.pieces)

    @property
    def corrector_iterations(self) -> int:
        """Newton corrector iterations over every piece."""
        return int(sum(int(p.iterations.sum()) for p in self.pieces))


def _minimum(problem: PathProblem, theta0: np.ndarray, lam: float, tol: float) -> tuple[np.ndarray | None, int]:
    """IPOPT from theta0 at lambda: the stable state it lands in (None if it fails), and its iterations."""
    own = getattr(problem, "minimum", None)
    if own is not None:  # a problem of another model (the 3-D one) minimises its own energy
        return own(theta0, lam, tol)
    p = problem.params(lam)
    lbx = np.full(problem.n, problem.lower_bound(lam) * (1.0 - 1e-6))
    m = minimise(problem.model, theta0, p, lbx, tol=tol)
    if not m.success or near_domain_bound(m.theta, lbx):
        return None, m.iterations
    g, h, _ = problem.ghl(m.theta, lam)
    eig = np.linalg.eigvalsh(h)
    if float(np.max(np.abs(g))) > 1e-7 or morse_index(eig) != 0 or eig[0] <= 0:
        return None, m.iterations
    return m.theta, m.iterations


#: How far past a fold (in typical sizes of the parameter) the landing state of a snap is sought.
SNAP_PAST = 1e-7
#: The first perturbation along the critical mode, radians of total bend (times 1/sqrt(n) per segment).
SNAP_KICK = 0.05


def _snap(problem: PathProblem, piece: Branch, sp: SpecialPoint, direction: float, tol: float):
    """Where the state lands after the stable branch ends at ``sp``: (lam_after, theta_after, iterations) or None.

    Just past the point (``SNAP_PAST`` typical sizes of lambda, in the ramp's direction) there is no
    equilibrium near it: IPOPT from it, moved along the critical mode, finds where the state goes.
    At a fold the mode is oriented towards the unstable side (the trace's next point: past a fold the
    energy falls that way). At a branch point with no stable way on both orientations are tried and
    the landing state nearer to the branch point is taken (the smaller snap).
    """
    v = sp.eigenvector / np.linalg.norm(sp.eigenvector)
    signs = [1.0, -1.0]
    if piece.beyond is not None:  # towards the unstable side: where the trace went on
        toward = float(v @ (piece.beyond[1] - sp.theta))
        if toward != 0.0:
            first = math.copysign(1.0, toward)
            signs = [first] if sp.kind == "fold" else [first, -first]
    lam_j = sp.lam + direction * max(SNAP_PAST * problem.scale, 1e-12 * (1.0 + abs(sp.lam)))
    iterations = 0
    candidates = []
    for sign in signs:
        eps = SNAP_KICK / math.sqrt(problem.n)
        for _ in range(3):  # the kick grows to 16 times the first: IPOPT must leave the fold's neighbourhood
            theta, it = _minimum(problem, sp.theta + sign * eps * v, lam_j, tol)
            iterations += it
            if theta is not None and float(np.linalg.norm(theta - sp.theta)) > eps:
                candidates.append(theta)
                break
            eps *= 4.0
    if not candidates:
        return None
    nearest = min(candidates, key=lambda t: float(np.linalg.norm(t - sp.theta)))
    return lam_j, nearest, iterations


def _switch(problem: PathProblem, piece: Branch, sp: SpecialPoint, direction: float, options: PathOptions, lo: float, hi: float):
    """At a branch point: the first stable point of a crossing branch that goes on in the ramp's direction, or None."""
    i = sp.index
    traced = None
    if 0 < i < len(piece):
        traced = np.concatenate([piece.theta[i] - piece.theta[i - 1], [piece.lam[i] - piece.lam[i - 1]]])
    corr = Corrector.for_trace(problem, lo, hi, options)
    for sign in (1.0, -1.0):
        try:
            start = crossing_start(corr, sp, sign, traced)
        except (PathError, np.linalg.LinAlgError):
            return None
        if start is None or start.morse != 0 or (start.lam - sp.lam) * direction <= 0 or start.eig[0] <= 0:
            continue
        return start
    return None


@single_threaded
def follow(
    problem: PathProblem,
    theta0: Sequence[float],
    lam0: float,
    to: float,
    options: PathOptions | None = None,
    *,
    ipopt_tol: float = 1e-10,
    natural: Natural | None = None,
) -> Ramp:
    """Ramp lambda from ``lam0`` to ``to`` quasi-statically from the stable state near ``theta0``.

    With ``natural`` (a :class:`esba.paths.continuation.Natural`), the ramp is first tried by
    natural-parameter continuation (compiled, O(n)), kept when the one acceptance rule accepts it
    (``theta0`` must then be the equilibrium at ``lam0``). Otherwise, and always without it, the
    stable branch is traced by pseudo-arclength continuation (:func:`esba.paths.continuation.trace`)
    until it reaches ``to``; where it ends at a fold the state snaps (see the module), where it ends
    at a branch point it goes on along a stable crossing branch or snaps; then the trace goes on
    from the new state.

    Returns
    -------
    Ramp
        Check :attr:`Ramp.reached`.
    """
    opts = DEFAULT_PATH_OPTIONS if options is None else options
    if not isinstance(opts, PathOptions):
        raise PathError(f"options={checks.quote(options)}: expected a PathOptions")
    theta = _start(problem, theta0)
    lam = checks.finite("lam0", lam0, PathError)
    to = checks.finite("to", to, PathError)
    if natural is not None:
        if not isinstance(natural, Natural):
            raise PathError(f"natural={natural!r}: expected a Natural() or None")
        if not isinstance(problem, PathProblem):
            raise PathError("natural: Natural() continuation is the planar model's (a PathProblem); leave natural=None")
        fast = natural_branch(problem, theta, lam, to, natural, "stable")
        if fast.stopped == "bound":
            return Ramp(problem, float(lam0), to, to, fast.theta[-1].copy(), True, (), (), (fast,), "", 0, "Natural")
    direction = 1.0 if to >= lam else -1.0
    lo, hi = min(lam, to), max(lam, to)
    jumps: list[Jump] = []
    branch_points: list[SpecialPoint] = []
    pieces: list[Branch] = []
    iterations = 0
    message = ""
    tangent = None
    for _ in range(MAX_EVENTS + 1):
        piece = trace(problem, theta, lam, to=to, options=opts, stop_on_instability=True, tangent=tangent, label="stable")
        tangent = None
        if len(piece):
            pieces.append(piece)
        if piece.stopped == "bound" and len(piece) and piece.lam[-1] == to:
            lam, theta = piece.end
            break
        if piece.stopped == "start" and len(piece) == 0:
            message = piece.stop_reason
            break
        if len(piece) and piece.stopped == "start":  # the start itself is singular (on a branch point)
            message = piece.stop_reason
            break
        if len(piece) and piece.morse[0] != 0:
            # the start is not stable: it falls to the nearest stable state first
            found, it = _minimum(problem, piece.theta[0] + 1e-3 * np.ones(problem.n), piece.lam[0], ipopt_tol)
            iterations += it
            if found is None:
                message = f"the start at {problem.describe(piece.lam[0])} is not stable and no stable state was found near it"
                break
            theta = found
            continue
        if piece.stopped != "instability":
            lam, theta = piece.end if len(piece) else (lam, theta)
            message = piece.stop_reason
            break
        sp = piece.special[-1]
        if sp.kind == "branch point":
            start = _switch(problem, piece, sp, direction, opts, lo, hi)
            if start is not None:
                branch_points.append(sp)
                theta, lam = start.theta, float(start.lam)
                continue
        landed = _snap(problem, piece, sp, direction, ipopt_tol)
        if landed is None:
            lam, theta = sp.lam, sp.theta
            message = f"the stable branch ends at a {sp.kind} at {problem.describe(sp.lam)} and no stable state was found after it"
            break
        lam_j, theta_j, it = landed
        iterations += it
        jumps.append(
            Jump(
                kind=sp.kind,
                parameter=problem.name,
                unit=problem.unit,
                lam=sp.lam,
                lam_after=lam_j,
                theta_before=sp.theta,
                theta_after=theta_j,
                tip_before=sp.tip,
                tip_after=problem.tip(theta_j, lam_j),
                point=sp,
            )
        )
        theta, lam = theta_j, lam_j
        if (to - lam) * direction <= 0:  # the snap happened within the last sliver before the target
            found, it = _minimum(problem, theta, to, ipopt_tol)
            iterations += it
            if found is not None:
                theta, lam = found, to
            break
    else:
        message = f"more than {MAX_EVENTS} snaps and branch switches on one ramp: stopped at {problem.describe(lam)}"
    reached = not message and lam == to
    return Ramp(
        problem=problem,
        start=float(lam0),
        target=to,
        lam=lam,
        theta=np.asarray(theta, dtype=float),
        reached=reached,
        jumps=tuple(jumps),
        branch_points=tuple(branch_points),
        pieces=tuple(pieces),
        message=message,
        ipopt_iterations=iterations,
    )


#: The most ramps of a load history (:func:`history`).
MAX_RAMPS = 1000


def _start(problem: Any, theta0: Any) -> np.ndarray:
    """The start angles as an array of the problem's n finite angles, else a :class:`PathError`."""
    if not is_path_problem(problem):
        raise PathError(f"problem={checks.quote(problem)}: expected a PathProblem")
    try:
        theta = np.asarray(theta0, dtype=float).ravel()
    except (TypeError, ValueError, OverflowError):
        raise PathError(f"theta0={checks.quote(theta0)}: expected {problem.n} finite angles (rad)") from None
    if theta.shape != (problem.n,) or not np.all(np.isfinite(theta)):
        raise PathError(f"theta0 has shape {theta.shape}: expected {problem.n} finite angles (rad)")
    return theta


def history(problem: PathProblem, theta0: Sequence[float], lam0: float, values: Sequence[float], options: PathOptions | None = None) -> list[Ramp]:
    """Ramps from ``lam0`` to each value in turn (e.g. up to ``to`` and back down): a load history.

    Each ramp starts from the state the previous one reached; the list stops at the first ramp
    that does not reach its value.
    """
    theta, lam = _start(problem, theta0), checks.finite("lam0", lam0, PathError)
    if isinstance(values, (str, bytes)) or not isinstance(values, (list, tuple, np.ndarray)):
        raise PathError(f"values={checks.quote(values)}: expected a list of parameter values to ramp to in turn")
    if not 1 <= len(values) <= MAX_RAMPS:
        raise PathError(f"values: {len(values)} given; expected 1 to {MAX_RAMPS} values (each is a ramp of up to max_steps steps)")
    values = [checks.finite("values", v, PathError) for v in values]
    ramps: list[Ramp] = []
    for value in values:
        r = follow(problem, theta, lam, float(value), options)
        ramps.append(r)
        if not r.reached:
            break
        theta, lam = r.theta, r.lam
    return ramps

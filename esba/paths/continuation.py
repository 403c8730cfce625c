"""Equilibrium paths: pseudo-arclength continuation with folds, branch points and stability.

An equilibrium of the actuator is a root of the generated gradient, g(theta, lambda) = dU/dtheta = 0,
and as one scene parameter lambda changes (the pressure, a payload's magnitude, direction or point,
a design parameter, or a homotopy such as the load factor of :func:`esba.statics.equilibrium.solve`) the
roots form curves in (theta, lambda): *branches*. A branch can turn back in lambda (a *fold*, or
limit point: two equilibria meet and vanish, and a load ramp snaps) or cross another branch (a
*branch point*, such as the buckling of a straight actuator under a compressive tip load).

This module follows a branch the way structural mechanics does (Riks in Abaqus, AUTO-07p,
BifurcationKit), with the model's exact derivatives:

* **the problem** (:class:`PathProblem`): the generated gradient g and Hessian H, and dg/dlambda
  by CasADi's forward AD of the generated gradient along the parameter direction; the parameter
  vector is affine in lambda, p(lambda) = p0 + lambda dp, which covers one scene parameter
  (:meth:`PathProblem.from_scene`) and homotopies between two parameter sets
  (:meth:`PathProblem.homotopy`);
* **the settings** (:class:`PathOptions`): one frozen, validated dataclass (step lengths, corrector
  targets, turning limit, how special points are located);
* **the trace** (:func:`trace`): tangent predictor, Newton corrector on the bordered system
  (:mod:`esba.paths.corrector`)
  [[H, dg/dlambda], [t^T]] with the arclength ds^2 = w |dtheta|^2 + (dlambda / sigma)^2 (w = n, so
  that a step means about the same change of the total angle whatever n is; sigma a typical size of
  lambda), adaptive step (grown or shrunk towards ``target_iterations`` corrector iterations,
  rejected and halved on a failed corrector, a sharp turn, a chord far steeper than the turn (a landing on another branch),
  two eigenvalue crossings in one step, or a change of stability that is neither a turn of lambda
  (a fold) nor a branch point by the extended system: the step left the branch),
  stops exactly at the parameter bounds, at a step count, a total-angle or user event, at the
  model's domain boundary, or on returning to the start;
* **stability** at every point: the Hessian's eigenvalues, the Morse index (the number of negative
  ones) and stable / unstable (:mod:`esba.model.stability`);
* **special points**, located precisely, not bracketed (:mod:`esba.paths.locate`): a fold through the
  extended system g = 0, H v = 0, v0 . v = 1 (Newton with third derivatives by AD), or by eigenvalue
  bisection (Brent's method on the crossing eigenvalue along the arclength) (``locate``); branch
  points through Moore's extended system (regular there, where the fold system is not), else by
  bisection. A stability change is a branch point only where dg/dlambda is orthogonal to the null
  vector (:data:`esba.paths.locate.BRANCH_ORTHOGONALITY`); a branch point is classified transcritical
  or pitchfork from d3U along the null vector (:func:`esba.paths.locate.classify_branch_point`). Each has its type, lambda, theta, tip, the critical eigenvector, and a status
  (``converged`` / ``guess``). A step in which lambda runs against both end tangents (two folds
  inside one step, near a cusp) is halved until they are resolved;
* **branch switching** (:func:`bifurcating_branches`): at a branch point the directions of the
  crossing branches solve the algebraic bifurcation equation built from the second derivatives of
  v . g; both sides of the new branch are traced, each with its own stability and folds (the
  eccentric chamber makes U not even in theta, so they need not mirror each other).

The result of a trace is a :class:`Branch`: arrays of lambda, theta, tip, arclength, eigenvalues
and Morse index per point, the special points, and why it stopped; ``to_dict()``, CSV and JSON.

Examples
--------
A straight actuator (P = 0) pushed along its axis: the straight state buckles at a branch point.

>>> from esba.model.scene import Scene, Payload
>>> column = Scene(pressure=0.0, payloads=(Payload(1.0, 180.0),), segments=2)
>>> b = trace(PathProblem.from_scene(column, "payload"), [0.0, 0.0], 1.0, to=12.0)
>>> b.stop_reason
'reached payload1 = 12 N'
>>> bp = b.special[0]
>>> bp.kind, bp.morse_before, bp.morse_after, round(bp.lam, 4)
('branch point', 0, 1, 3.3303)
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Any, Callable, Sequence

import numpy as np

from esba.infra import checks
from esba.infra.threads import single_threaded
from esba.model.stability import CRITICAL_TOL
from esba.model.structured import pivots as structured_pivots
from esba.solvers.newton import ACCEPTANCE, FINAL, NEWTON, STEPS, Acceptance, run_natural

from .branch import Branch, SpecialPoint, branches_csv, write_branches
from .corrector import Corrector, Point
from .locate import BRANCH_ORTHOGONALITY, locate_crossing, locate_value, special_from
from .problem import PARAMETERS, PathError, PathProblem, is_path_problem

_log = logging.getLogger("esba.paths.continuation")

__all__ = [
    "Natural",
    "PALC",
    "continuation",
    "PathError",
    "PathOptions",
    "PathProblem",
    "SpecialPoint",
    "Branch",
    "trace",
    "bifurcating_branches",
    "bifurcation_tangents",
    "crossing_start",
    "side_of",
    "SIDES",
    "PARAMETERS",
    "LOCATE_METHODS",
    "branches_csv",
    "write_branches",
]


#: How a fold is located: Newton on the extended system, or Brent's method on the eigenvalue.
LOCATE_METHODS = ("extended", "bisection")

#: A trace may run to at most this many typical sizes of its parameter (beyond, the metric's
#: squares overflow and nothing of the model's physics is left).
MAX_SPAN = 1e6


def _check_pos(name: str, value: Any) -> float:
    v = checks.finite(name, value, PathError)
    if v <= 0:
        raise PathError(f"{name}={value!r}: expected a finite number > 0")
    return v


@dataclass(frozen=True)
class PathOptions:
    """Settings of the continuation, validated on creation (BifurcationKit's ``ContinuationPar``).

    Step lengths are in the scaled arclength ds^2 = w |dtheta|^2 + (dlambda / sigma)^2: about radians
    of total bending angle, or fractions of sigma in the parameter.

    Parameters
    ----------
    ds : float or None
        First step; default the smaller of 0.05 and ``ds_max``.
    ds_min, ds_max : float
        Smallest and largest step; a step that must be halved below ``ds_min`` ends the trace.
    max_steps : int
        Steps before the trace stops (``max_steps`` points after the start).
    target_iterations : int
        Corrector iterations aimed at: the step grows when fewer are needed, shrinks when more.
    max_iterations : int
        Corrector iterations before a step is rejected and halved.
    tol : float
        Largest max |dU/dtheta_i| of a converged point, N mm/rad.
    max_turn_deg : float
        Largest angle between successive tangents, degrees; a sharper turn halves the step.
    locate : str
        How folds are located: ``"extended"`` (Newton on g = 0, H v = 0, v0 . v = 1) or
        ``"bisection"`` (Brent's method on the crossing eigenvalue). Branch points by Moore's
        extended system, else the latter.
    detect : bool
        Detect and locate folds and branch points.
    critical_tol : float
        Eigenvalues within this fraction of the largest magnitude count as zero (Morse index).
    theta_weight : float or None
        w in the arclength; default n (the segment count).
    scale : float or None
        sigma, a typical size of lambda in its unit; default the span of the trace, else the
        parameter's own typical size.
    stop_total_angle_deg : float or None
        Stop where the total bending angle crosses this value (located like a special point).

    Examples
    --------
    >>> PathOptions().locate, PathOptions(ds_max=0.01).ds
    ('extended', 0.01)
    >>> PathOptions(ds_min=1.0, ds=0.1)
    Traceback (most recent call last):
    ...
    esba.paths.problem.PathError: ds_min=1.0, ds=0.1, ds_max=0.25: expected 0 < ds_min <= ds <= ds_max
    """

    ds: float | None = None
    ds_min: float = 1e-7
    ds_max: float = 0.25
    max_steps: int = 2000
    target_iterations: int = 3
    max_iterations: int = 12
    tol: float = 1e-10
    max_turn_deg: float = 25.0
    locate: str = "extended"
    detect: bool = True
    critical_tol: float = CRITICAL_TOL
    theta_weight: float | None = None
    scale: float | None = None
    stop_total_angle_deg: float | None = None

    def __post_init__(self) -> None:
        for name in ("ds_min", "ds_max", "tol", "max_turn_deg", "critical_tol"):
            _check_pos(name, getattr(self, name))
        if self.ds is None:
            object.__setattr__(self, "ds", min(0.05, float(self.ds_max)))
        _check_pos("ds", self.ds)
        if not self.ds_min <= self.ds <= self.ds_max:
            raise PathError(f"ds_min={self.ds_min!r}, ds={self.ds!r}, ds_max={self.ds_max!r}: expected 0 < ds_min <= ds <= ds_max")
        checks.whole("max_steps", self.max_steps, 1, PathError)
        if self.max_steps > 1_000_000:
            raise PathError(f"max_steps={self.max_steps!r}: expected at most 1000000 (each step stores a point)")
        checks.whole("target_iterations", self.target_iterations, 1, PathError)
        checks.whole("max_iterations", self.max_iterations, 2, PathError)
        if self.target_iterations >= self.max_iterations:
            raise PathError(f"target_iterations={self.target_iterations!r}: expected fewer than max_iterations={self.max_iterations!r}")
        if self.locate not in LOCATE_METHODS:
            raise PathError(f"locate={self.locate!r}: allowed are {', '.join(LOCATE_METHODS)}")
        if not isinstance(self.detect, bool):
            raise PathError(f"detect={self.detect!r}: expected True or False")
        if self.max_turn_deg >= 180.0:
            raise PathError(f"max_turn_deg={self.max_turn_deg!r}: expected a number > 0 and < 180")
        if self.critical_tol >= 1.0:
            raise PathError(f"critical_tol={self.critical_tol!r}: expected a number > 0 and < 1")
        for name in ("theta_weight", "scale"):
            if getattr(self, name) is not None:
                _check_pos(name, getattr(self, name))
        if self.stop_total_angle_deg is not None:
            checks.finite("stop_total_angle_deg", self.stop_total_angle_deg, PathError)


DEFAULT_PATH_OPTIONS = PathOptions()


# ---------------------------------------------------------------------------------------------
# the trace


def _lam_delta(problem: PathProblem, d: float) -> float:
    if problem.period is None:
        return d
    p = problem.period
    return (d + 0.5 * p) % p - 0.5 * p


def _interval(problem: PathProblem, lam0: float, to: float | None, bounds) -> tuple[float, float]:
    """The interval of lambda a trace stays in, checked against the parameter's range and size."""
    dom_lo, dom_hi = problem.domain
    unit = problem.unit_short
    limit = MAX_SPAN * problem.scale
    if not problem.in_range(lam0):
        raise PathError(f"{problem.describe(lam0)}: outside the parameter's range, {dom_lo:g} to {dom_hi:g}{unit}")
    if to is not None:
        to = checks.finite("to", to, PathError)
        if not problem.in_range(to):
            raise PathError(f"to={to:g}: outside the range of {problem.name}, {dom_lo:g} to {dom_hi:g}{unit}")
        if abs(to - lam0) > limit:
            raise PathError(f"to={to:g}: more than {limit:g}{unit} from the start ({MAX_SPAN:g} typical sizes of {problem.name})")
        if bounds is None:
            return min(lam0, to), max(lam0, to)
    if bounds is not None:
        if not isinstance(bounds, (tuple, list)) or len(bounds) != 2:
            raise PathError(f"bounds={bounds!r}: expected (low, high)")
        lo, hi = (checks.finite("bounds", v, PathError) for v in bounds)
        if not lo <= lam0 <= hi:
            raise PathError(f"bounds=({lo:g}, {hi:g}): the start {lam0:g} must lie inside")
        if to is not None and to not in (lo, hi):
            raise PathError(f"bounds=({lo:g}, {hi:g}) with to={to:g}: to must be one end of the bounds")
        lo, hi = max(lo, dom_lo, lam0 - limit), min(hi, dom_hi, lam0 + limit)
        return lo, hi
    return max(dom_lo, lam0 - limit), min(dom_hi, lam0 + limit)


def _check_vector(name: str, value, size: int) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float).ravel()
    except (TypeError, ValueError):
        raise PathError(f"{name}: expected {size} finite numbers") from None
    if v.shape != (size,) or not np.all(np.isfinite(v)):
        raise PathError(f"{name} has shape {v.shape}: expected {size} finite numbers")
    return v


#: Memory a traced point holds, bytes, about POINT_BYTES[0] + POINT_BYTES[1] * n (measured: a
#: million steps at n = 3 took 1.25 GB for the main branch and one loading ramp; 20 000 at n = 16, 45 MB).
POINT_BYTES = (500, 40)
#: Traces of one ``esba path`` run that may each take max_steps: the main branch, the loading ramps up and down.
PATH_TRACES = 3


def path_bytes(max_steps: int, n: int, traces: int = PATH_TRACES) -> int:
    """About the most memory (bytes) ``traces`` traces of ``max_steps`` steps at n segments hold.

    >>> round(path_bytes(1_000_000, 3) / 2**30, 2)
    1.73
    """
    return int(max_steps) * int(traces) * (POINT_BYTES[0] + POINT_BYTES[1] * int(n))


#: After this many seconds a trace says how long the rest of its interval may take, when that is
#: more than :data:`FORECAST_AT_LEAST` seconds (as a sweep's size is checked up front; a path's step
#: count is not known until it runs).
FORECAST_AFTER = 2.0
FORECAST_AT_LEAST = 60.0


class _Forecast:
    """Says once, on the ``esba`` logger, how long the rest of a trace may take: the parameter
    distance left to its end (``to``, else the end of its interval it heads for) at the pace it
    has come nearer that end so far (distance per second, over :data:`FORECAST_AFTER` seconds or
    more). ``max_steps`` is a cap, not a forecast: a trace that reaches its end in a few hundred
    steps does not take the time of two thousand. The pace is taken from the end of the first step
    on: the first pays one-off costs (a model's kernels compiled to C on first use) that the rest do
    not. A trace that has not come nearer its end yet (it turned back at a fold) says nothing until
    it has. ``clock`` is the time source (seconds)."""

    def __init__(self, goal: float, label: str, clock: Callable[[], float] | None = None) -> None:
        self.goal, self.label = float(goal), label
        self.clock = time.perf_counter if clock is None else clock
        self.t0: float | None = None
        self.s0 = 0
        self.left0 = math.inf
        self.done = False

    def remaining_s(self, lam: float, now: float) -> float | None:
        """Seconds the rest may take from ``lam`` at ``now`` (None: no pace yet)."""
        if self.t0 is None or now <= self.t0:
            return None
        left = abs(self.goal - lam)
        covered = self.left0 - left
        if not covered > 0:
            return None
        return left * (now - self.t0) / covered

    def tick(self, steps: int, lam: float) -> None:
        if self.done or steps == 0:
            return
        now = self.clock()
        if self.t0 is None:
            self.t0, self.s0, self.left0 = now, steps, abs(self.goal - lam)
            return
        elapsed = now - self.t0
        if elapsed < FORECAST_AFTER or steps <= self.s0:
            return
        rest = self.remaining_s(lam, now)
        if rest is None:
            return
        self.done = True
        if rest >= FORECAST_AT_LEAST:
            minutes = f"{rest / 60:.0f} min" if rest < 3600 else f"{rest / 3600:.1f} h"
            _log.warning(
                "%s: %d steps in %.0f s, %.3g of the parameter's %.3g to go covered; at that pace it may take another %s "
                "(a larger --ds-max speeds it; Ctrl-C stops it)",
                self.label or "the branch", steps - self.s0, elapsed, self.left0 - abs(self.goal - lam), self.left0, minutes,
            )


@single_threaded
def trace(
    problem: PathProblem,
    theta0: Sequence[float],
    lam0: float,
    *,
    to: float | None = None,
    bounds: tuple[float, float] | None = None,
    options: PathOptions | None = None,
    direction: float | None = None,
    tangent: Sequence[float] | None = None,
    milestones: Sequence[float] = (),
    stop_on_instability: bool = False,
    event: Callable[[float, np.ndarray], float] | None = None,
    label: str = "",
) -> Branch:
    """Follow the branch through (theta0, lam0) of ``problem``.

    Parameters
    ----------
    problem : PathProblem
    theta0 : sequence of float
        A point on (or near) the branch at ``lam0``, rad; it is corrected at fixed lambda first.
    lam0 : float
        Lambda at the start, in the parameter's unit.
    to : float, optional
        Trace towards this value and stop exactly on it; the branch may turn back at folds on the
        way, and then stops exactly at the other end of the interval (``bounds``, default
        [lam0, to]) if it gets there.
    bounds : (low, high), optional
        The interval of lambda to stay in (instead of [lam0, to]; with ``to``, one of its ends);
        always cut to the parameter's range.
    options : PathOptions, optional
    direction : float, optional
        +1 or -1: the sign of d lambda of the first step (default: towards ``to``, else +1).
    tangent : sequence of float, optional
        The first tangent (theta, lambda) instead (used to leave a branch point).
    milestones : sequence of float
        Values of lambda at which points are located exactly (user points), wherever the
        branch crosses them.
    stop_on_instability : bool
        Stop at the first special point where the Morse index rises from 0 (the end of a stable
        branch for a load ramp).
    event : callable, optional
        ``event(lam, theta) -> float``: the trace stops where it changes sign (located).
    label : str
        A name for the branch (in its JSON and CSV).

    Returns
    -------
    Branch
    """
    opts = DEFAULT_PATH_OPTIONS if options is None else options
    if not isinstance(opts, PathOptions):
        raise PathError(f"options={options!r}: expected a PathOptions")
    if not is_path_problem(problem):
        raise PathError(f"problem={problem!r}: expected a PathProblem")
    lam0 = checks.finite("lam0", lam0, PathError)
    theta0 = _check_vector("theta0", theta0, problem.n)
    lo, hi = _interval(problem, lam0, to, bounds)
    marks = sorted(checks.finite("milestones", m, PathError) for m in milestones)
    if direction is not None:
        direction = checks.finite("direction", direction, PathError)
        if direction == 0:
            raise PathError("direction=0: expected +1 or -1 (the sign of the first step in lambda)")
    if event is not None and not callable(event):
        raise PathError(f"event={event!r}: expected a function event(lam, theta) -> float")
    corr = Corrector.for_trace(problem, lo, hi, opts)
    first = corr.at_lambda(theta0, lam0)
    if first is None:
        return _branch(corr, [], [], "start", f"no equilibrium found near the start at {problem.describe(lam0)}", label)
    if tangent is not None:
        t = _check_vector("tangent", tangent, problem.n + 1)
        if corr.norm(t) == 0.0:
            raise PathError("tangent: expected a nonzero (theta, lambda) direction")
        first.tangent = t / corr.norm(t)
    else:
        sign = direction if direction is not None else (1.0 if to is None or to >= lam0 else -1.0)
        first.tangent = corr.tangent(first, None, math.copysign(1.0, sign))
        if first.tangent is None:
            return _branch(corr, [first], [], "start", f"the start at {problem.describe(lam0)} is singular: give a tangent", label)
    if to is not None and to == lam0:
        return _branch(corr, [first], [], "bound", f"reached {problem.describe(to)}", label)

    points: list[Point] = [first]
    kinds: list[str] = ["start"]
    specials: list[tuple[int, SpecialPoint]] = []
    arclength = [0.0]
    ds = opts.ds
    travelled = 0.0
    stopped, reason = "max_steps", f"stopped after max_steps = {opts.max_steps} steps"
    max_turn = math.radians(opts.max_turn_deg)
    total_event = None if opts.stop_total_angle_deg is None else math.radians(opts.stop_total_angle_deg)
    events = [(event, "the user event")]
    if total_event is not None:
        events.append((lambda lam, th: float(np.sum(th)) - total_event, f"the total angle of {float(opts.stop_total_angle_deg):g} deg"))
    beyond = None
    steps = 0
    clock = _Forecast(to if to is not None else (hi if first.tangent[-1] >= 0 else lo), label)
    while steps < opts.max_steps:
        a = points[-1]
        clock.tick(steps, a.lam)
        # a trace that starts on an end of its interval and heads out of it stops there
        outward = (a.lam <= lo and a.tangent[-1] < 0) or (a.lam >= hi and a.tangent[-1] > 0)
        if outward and steps == 0 and (lo < hi):
            stopped, reason = "bound", f"the branch leaves the interval {lo:g} to {hi:g} at its start, {problem.describe(a.lam)}"
            break
        b = corr.on_segment(a, ds)
        reject = b is None
        if not reject:
            b.tangent = corr.tangent(b, a.tangent)
            reject = b.tangent is None
        if not reject:
            turn = math.acos(max(-1.0, min(1.0, corr.dot(a.tangent, b.tangent))))
            sharp = turn > max_turn
            double = abs(b.morse - a.morse) > 1
            # lambda ran against both end tangents: it turned back at least twice inside the step
            dlam = b.lam - a.lam
            hidden = a.tangent[-1] * b.tangent[-1] > 0 and dlam * a.tangent[-1] < 0
            hidden = hidden or (opts.detect and b.morse == a.morse and _dips(corr, a, b, ds))
            # the corrector did not contract as Newton does near its root: the predictor was far from
            # this branch, or the step landed on another one
            res = b.residuals
            slack = len(res) >= 3 and res[1] > 1e3 * opts.tol and res[2] > CORRECTOR_CONTRACTION * res[1]
            # the corrector moved far from the predictor: on a smooth arc the chord from a to b leaves
            # a's tangent by about half the turn between the two tangents (exactly half on a circle);
            # a chord much steeper than that landed on a neighbouring branch running alongside
            chord = math.atan2(corr.norm(b.x - a.x - ds * a.tangent), ds)
            elsewhere = chord > max(CHORD_FACTOR * 0.5 * turn, CHORD_FLOOR)
            reject = (sharp or double or hidden or slack or elsewhere) and ds > opts.ds_min * 1.0000001
        found = []
        if not reject:
            found = _events_on_segment(corr, a, b, ds, lo, hi, marks, events, opts)
            # a fold or branch point that cannot be located on the segment: the step is not one branch
            unlocated = any(sp is not None and sp.status == "guess" for _, _, _, sp in found)
            reject = unlocated and ds > opts.ds_min * 1.0000001
        if reject:
            if ds <= opts.ds_min * 1.0000001:
                stopped, reason = _why_stuck(corr, a, ds)
                break
            ds = max(opts.ds_min, ds / 2.0)
            continue
        steps += 1
        s_b = ds
        stop_here = None
        for s_pt, kind, pt, sp in found:
            if pt is not a and pt is not b:
                if pt.tangent is None:
                    pt.tangent = corr.tangent(pt, a.tangent) if pt.tangent is None else pt.tangent
                if pt.tangent is None:
                    pt.tangent = a.tangent
                points.append(pt)
                kinds.append(kind)
                arclength.append(travelled + s_pt)
            elif pt is b:
                points.append(b)
                kinds.append(kind)
                arclength.append(travelled + s_b)
            if sp is not None:
                specials.append((len(points) - 1, sp))
            if kind == "end":
                if to is not None and pt.lam != to:
                    why = f"turned back and reached {problem.describe(pt.lam)} without reaching {to:g}{problem.unit_short}"
                else:
                    why = f"reached {problem.describe(pt.lam)}"
                stop_here = ("bound", why)
                break
            if kind == "event":
                stop_here = ("event", f"stopped at {sp.method.split(' (')[0]} at {problem.describe(pt.lam)}")
                break
            if stop_on_instability and kind in ("fold", "branch point") and sp.morse_before == 0 and sp.morse_after > 0:
                stop_here = ("instability", f"the stable branch ends at a {kind} at {problem.describe(pt.lam)}")
                break
        if stop_here is not None:
            stopped, reason = stop_here
            # keep the crossing step's far end for what happens next (the unstable side of a fold)
            beyond = (float(b.lam), b.theta.copy())
            break
        if points[-1] is not b:
            points.append(b)
            kinds.append("regular")
            arclength.append(travelled + s_b)
        travelled += s_b
        # step control: towards target_iterations corrector iterations
        factor = 2.0 ** ((opts.target_iterations - max(b.iterations, 1)) / 2.0)
        ds = min(opts.ds_max, max(opts.ds_min, ds * min(2.0, max(0.5, factor))))
        # back at the start: a closed branch
        if steps >= 3 and travelled > 2.0 * opts.ds_max and abs(_lam_delta(problem, b.lam - first.lam)) < 0.5 * s_b * corr.sigma:
            d = np.concatenate([b.theta - first.theta, [_lam_delta(problem, b.lam - first.lam)]])
            if corr.norm(d) < 0.5 * s_b and corr.dot(b.tangent, first.tangent) > 0:
                stopped, reason = "loop", f"returned to the start (a closed branch) after {steps} steps"
                break
    return _branch(corr, points, specials, stopped, reason, label, kinds, arclength, beyond)


#: A step whose corrector's second residual is more than this fraction of its first is rejected (a
#: Newton iteration from a predictor inside its region of convergence contracts far faster).
CORRECTOR_CONTRACTION = 0.25

#: A step is rejected when the angle between its chord and the tangent it started along is more
#: than CHORD_FACTOR times half the turn between the tangents at its ends (the angle on a smooth
#: arc) and more than CHORD_FLOOR (radians: below it a nearly straight step is not judged): it landed
#: on another branch. Halving a step on a smooth arc brings the two angles together, so the rule
#: cannot stall a trace.
CHORD_FACTOR = 3.0
CHORD_FLOOR = math.radians(2.0)

#: The smallest eigenvalue is watched for a hidden sign change (two crossings inside one step) when it
#: is below this fraction of the largest at both ends of the step.
WATCH = 0.05
#: ... and the spectra that watch needs are computed when H's smallest pivot (in magnitude) is below
#: this fraction of the largest at both ends.
WATCH_PIVOT = 0.25


def _dips(corr: Corrector, a: Point, b: Point, ds: float) -> bool:
    """The eigenvalue nearest zero keeps its sign at both ends but the cubic Hermite interpolant of it
    (values and slopes along the arclength) crosses zero inside the step: two folds hide in it.

    The eigenvalue, its eigenvector and its slope come from inverse iteration in O(n)
    (:meth:`Corrector.critical_mode`), asked for only where H's smallest pivot is within
    :data:`WATCH_PIVOT` of its largest at both ends (near singular)."""
    if a.small_pivot > WATCH_PIVOT or b.small_pivot > WATCH_PIVOT:
        return False
    v_a, mu_a, slope_a = corr.critical_mode(a, a.tangent[:-1] if np.any(a.tangent[:-1]) else np.ones(corr.n), a.tangent)
    _, mu_b, slope_b = corr.critical_mode(b, v_a, b.tangent)
    scale = max(a.pivot_scale, b.pivot_scale, 1e-300)
    if mu_a * mu_b <= 0 or max(abs(mu_a), abs(mu_b)) > WATCH * scale:
        return False
    da, db = slope_a * ds, slope_b * ds
    u = np.linspace(0.0, 1.0, 33)[1:-1]
    h00, h10, h01, h11 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u, -2 * u**3 + 3 * u**2, u**3 - u**2
    cubic = h00 * mu_a + h10 * da + h01 * mu_b + h11 * db
    return bool(np.any(np.sign(cubic) != np.sign(mu_a)))


def _events_on_segment(corr: Corrector, a: Point, b: Point, s_b: float, lo: float, hi: float, marks, events, opts: PathOptions) -> list:
    """Everything that happens between a and b, located and sorted by arclength:
    (s, kind, point, special point or None)."""
    found: list[tuple[float, str, Point, SpecialPoint | None]] = []
    value = "at the requested value (Newton at fixed lambda)"
    for bound in (lo, hi):
        crossed = (a.lam - bound) * (b.lam - bound) < 0 or (b.lam == bound and a.lam != bound)
        if math.isfinite(bound) and crossed:
            pt = locate_value(corr, a, b, s_b, lambda p, v=bound: p.lam - v)
            if pt is not None:
                pt = corr.at_lambda(pt.theta, bound) or pt  # exactly on the bound
                sp = special_from(corr, "user", pt, None, a, b, "converged", value) if bound in marks else None
                found.append((corr.arclength_of(a, pt), "end", pt, sp))
    for m in marks:
        if m in (lo, hi):
            continue
        if (a.lam - m) * (b.lam - m) < 0 or (b.lam == m and a.lam != m):
            pt = locate_value(corr, a, b, s_b, lambda p, v=m: p.lam - v)
            if pt is not None:
                pt = corr.at_lambda(pt.theta, m) or pt
                found.append((corr.arclength_of(a, pt), "user", pt, special_from(corr, "user", pt, None, a, b, "converged", value)))
    turned = np.sign(b.tangent[-1]) != np.sign(a.tangent[-1]) and a.tangent[-1] != 0
    if opts.detect and (b.morse != a.morse or turned):
        idx = min(a.morse, b.morse, corr.n - 1)  # the eigenvalue (ascending) that crosses zero
        if turned and a.morse == b.morse and opts.locate != "extended":
            corr.spectrum(b)
            idx = int(np.argmin(np.abs(b.eig)))
        kind = "fold" if turned else "branch point"
        pt, status, method, vector = locate_crossing(corr, a, b, s_b, turned, idx, opts.locate)
        sp = special_from(corr, kind, pt, idx, a, b, status, method, vector)
        if kind == "branch point" and not sp.orthogonality <= BRANCH_ORTHOGONALITY:
            # the stability changed without lambda turning back, but dg/dlambda is not orthogonal to the
            # null vector: the zero eigenvalue is a fold's, not a branch point's, so the step did not
            # stay on one branch (it jumped across a fold to a neighbouring one): unlocated, it is rejected
            why = f"a fold (phi . dg/dlambda / |dg/dlambda| = {sp.orthogonality:.2g}) where lambda did not turn: the step left the branch"
            sp = replace(sp, kind="fold", status="guess", method=why, bifurcation="", cubic=math.nan)
            kind = "fold"
        found.append((corr.arclength_of(a, pt), kind, pt, sp))
        ended = any(k == "end" for _, k, _, _ in found)
        for bound in (lo, hi):
            if turned and not ended and math.isfinite(bound) and (a.lam - bound) * (pt.lam - bound) < 0:
                # the step went past the bound to a fold beyond it and came back: the branch ends at the
                # bound, before the fold (both ends of the step lie inside the interval)
                end = locate_value(corr, a, pt, corr.arclength_of(a, pt), lambda p, v=bound: p.lam - v)
                if end is not None:
                    end = corr.at_lambda(end.theta, bound) or end
                    sp = special_from(corr, "user", end, None, a, b, "converged", value) if bound in marks else None
                    found.append((corr.arclength_of(a, end), "end", end, sp))
    for f_ev, name in events:
        if f_ev is None:
            continue
        fa, fb = f_ev(a.lam, a.theta), f_ev(b.lam, b.theta)
        if fa * fb < 0 or (fb == 0 and fa != 0):
            pt = locate_value(corr, a, b, s_b, lambda p, fe=f_ev: fe(p.lam, p.theta))
            if pt is not None:
                sp = special_from(corr, "event", pt, None, a, b, "converged", f"{name} (Brent's method on the arclength)")
                found.append((corr.arclength_of(a, pt), "event", pt, sp))
    found.sort(key=lambda item: item[0])
    return found


def _why_stuck(corr: Corrector, a: Point, ds: float) -> tuple[str, str]:
    """Why no step of ds_min can be taken from ``a``."""
    prob = corr.prob
    x = a.x + ds * a.tangent
    lam = float(x[-1])
    low = prob.lower_bound(a.lam)
    if not prob.defined(x[:-1], lam) or np.any(a.theta - low < 1e-3 * max(1.0, abs(low))):
        return "domain", f"the branch reaches the model's domain boundary (Eq. 10: the chamber closes) at {prob.describe(a.lam)}"
    return "corrector", f"the corrector fails even at ds_min = {corr.opts.ds_min:g} after {prob.describe(a.lam)}"


def _branch(
    corr: Corrector,
    points: list[Point],
    specials: list[tuple[int, SpecialPoint]],
    stopped: str,
    reason: str,
    label: str,
    kinds: list[str] | None = None,
    arclength: list[float] | None = None,
    beyond: tuple[float, np.ndarray] | None = None,
) -> Branch:
    prob, n = corr.prob, corr.n
    m = len(points)
    kinds = kinds if kinds is not None else (["start"] + ["regular"] * (m - 1))[:m]
    arclength = arclength if arclength is not None else [0.0] * m
    special = tuple(replace(sp, index=i, arclength=float(arclength[i])) for i, sp in specials)
    lam = np.array([pt.lam for pt in points], dtype=float)
    theta = np.array([pt.theta for pt in points], dtype=float).reshape(m, n)
    known = {i: pt.eig for i, pt in enumerate(points) if pt.eig is not None}
    return Branch(
        name=prob.name,
        unit=prob.unit,
        lam=lam,
        theta=theta,
        tips=(lambda: prob.tips(theta, lam)) if m else (lambda: np.zeros((0, 3))),
        arclength=np.array(arclength, dtype=float),
        spectrum=_spectrum_of(prob, theta, lam, known),
        min_pivot=np.array([pt.min_pivot for pt in points], dtype=float),
        morse=np.array([pt.morse for pt in points], dtype=int),
        kind=np.array(kinds, dtype=object).astype(str) if m else np.array([], dtype=str),
        special=special,
        stopped=stopped,
        stop_reason=reason,
        iterations=np.array([pt.iterations for pt in points], dtype=int),
        residuals=tuple(pt.residuals for pt in points),
        critical_tol=corr.opts.critical_tol,
        label=label,
        beyond=beyond,
        evaluations=corr.evaluations,
    )


def _spectrum_of(problem: PathProblem, theta: np.ndarray, lam: np.ndarray, known: dict):
    """The branch's eigenvalues, computed when first asked for: the Hessians of every point in mapped
    calls, then one stacked ``eigvalsh`` (the trace itself needs only the pivots)."""

    def spectrum() -> np.ndarray:
        m, n = theta.shape
        out = np.empty((m, n))
        todo = [i for i in range(m) if i not in known]
        for i, eig in known.items():
            out[i] = eig
        if todo:
            out[todo] = np.linalg.eigvalsh(problem.hessians(theta[todo], lam[todo]))
        return out

    return spectrum


# ---------------------------------------------------------------------------------------------
# the engine: one entry, the algorithm a value


#: Upper bound of Natural's counts (each step is unrolled into the compiled graph).
MAX_NATURAL_STEPS = 1_000
#: A natural ramp refused with every Hessian it met positive definite is run once more with this
#: many times its steps (no fold on the way, only steps too long for its Newton iterations: a
#: strongly bent branch under a load ramp); 16 steps are a C call of tens of microseconds, where
#: the pseudo-arclength trace that follows a refusal takes a millisecond.
FINER = 4


@dataclass(frozen=True)
class Natural:
    """Natural-parameter continuation: lambda in ``steps`` equal steps, each a tangent predictor and
    ``newton`` Newton corrections (``final`` more at the end), O(n) per step and one compiled call
    per ramp (:func:`esba.solvers.newton.natural_function`). It cannot pass a fold: the branch it
    returns is accepted by :class:`esba.solvers.newton.Acceptance` (stationary, positive definite
    all the way, every step contracting) or ``stopped == "refused"`` with the reason. A ramp refused
    while positive definite all the way is run once more with :data:`FINER` times the steps.

    >>> Natural().steps
    4
    >>> Natural(steps=0)
    Traceback (most recent call last):
    ...
    esba.paths.problem.PathError: steps=0: expected a whole number from 1 to 1000 (each step is unrolled into the compiled graph)
    """

    steps: int = STEPS
    newton: int = NEWTON
    final: int = FINAL
    acceptance: Acceptance = ACCEPTANCE

    def __post_init__(self) -> None:
        why = "each step is unrolled into the compiled graph"
        checks.whole("steps", self.steps, 1, PathError, MAX_NATURAL_STEPS, why)
        checks.whole("newton", self.newton, 1, PathError, MAX_NATURAL_STEPS, why)
        checks.whole("final", self.final, 0, PathError, MAX_NATURAL_STEPS, why)
        if not isinstance(self.acceptance, Acceptance):
            raise PathError(f"acceptance={self.acceptance!r}: expected an esba.solvers.newton.Acceptance")


@dataclass(frozen=True)
class PALC:
    """Pseudo-arclength continuation (:func:`trace`): adaptive steps along the branch's tangent in the
    arclength metric, through folds (located) and branch points (located, and switchable)."""

    options: PathOptions = field(default_factory=PathOptions)

    def __post_init__(self) -> None:
        if not isinstance(self.options, PathOptions):
            raise PathError(f"options={self.options!r}: expected a PathOptions")


@single_threaded
def continuation(
    problem: PathProblem,
    theta0: Sequence[float],
    lam0: float,
    *,
    to: float | None = None,
    algorithm: Natural | PALC | None = None,
    label: str = "",
    **kwargs: Any,
) -> Branch:
    """Continue the branch of ``problem`` through (theta0, lam0) with ``algorithm``; one result type.

    The engine's one entry (in the manner of BifurcationKit's ``continuation(prob, alg, opts)``):
    :class:`Natural` (compiled, O(n), cannot pass a fold: a :class:`Branch` that is accepted or
    ``"refused"``) or :class:`PALC` (the default; :func:`trace`, whose keywords ``kwargs`` are).

    Examples
    --------
    >>> from esba.model.scene import Scene, Payload
    >>> from esba.statics.equilibrium import solve
    >>> unloaded = solve(Scene(pressure=0.1)).theta   # the equilibrium at lambda = 0 (no payload)
    >>> problem = PathProblem.from_scene(Scene(pressure=0.1, payloads=(Payload(1.0),)), "payload")
    >>> nat = continuation(problem, unloaded, 0.0, to=1.0, algorithm=Natural())
    >>> nat.stopped, len(nat), round(float(nat.total_angle_deg[-1]), 2)
    ('bound', 5, 36.63)
    >>> palc = continuation(problem, unloaded, 0.0, to=1.0)
    >>> palc.stopped, round(float(palc.total_angle_deg[-1]), 2)
    ('bound', 36.63)
    """
    algorithm = PALC() if algorithm is None else algorithm
    if isinstance(algorithm, PALC):
        return trace(problem, theta0, lam0, to=to, options=algorithm.options, label=label, **kwargs)
    if not isinstance(algorithm, Natural):
        raise PathError(f"algorithm={algorithm!r}: expected Natural() or PALC()")
    if kwargs:
        raise PathError(f"Natural continuation takes no {', '.join(sorted(kwargs))}: those are PALC's (trace's)")
    if to is None:
        raise PathError("Natural continuation needs to=: the value lambda is ramped to")
    if not isinstance(problem, PathProblem):  # its compiled O(n) graph stands on the planar chain's structure
        raise PathError(f"problem={problem!r}: Natural() continuation is the planar model's (a PathProblem); use PALC()")
    lam0 = checks.finite("lam0", lam0, PathError)
    theta0 = _check_vector("theta0", theta0, problem.n)
    _interval(problem, lam0, to, None)
    return natural_branch(problem, theta0, lam0, float(to), algorithm, label)


@lru_cache(maxsize=64)
def _natural_kinds(m: int) -> np.ndarray:
    out = np.array(["start"] + ["regular"] * (m - 2) + ["end"], dtype=str)
    out.flags.writeable = False
    return out


def natural_branch(problem: PathProblem, theta0: np.ndarray, lam0: float, to: float, alg: Natural, label: str = "") -> Branch:
    """:func:`continuation` with :class:`Natural` on checked inputs (``theta0`` the equilibrium at ``lam0``)."""
    model = problem.model
    run = run_natural(model, theta0, problem.params(lam0), problem.dp, to - lam0, alg.steps, alg.newton, alg.final)
    finite = bool(np.all(np.isfinite(run.theta)) and np.all(np.isfinite(run.states)))
    if alg.steps < MAX_NATURAL_STEPS and finite and alg.acceptance.why_not(run.gradient_norm, run.min_pivot, run.contraction, True, run.jump) and run.min_pivot > alg.acceptance.critical_tol:
        # refused with every Hessian it met positive definite: its steps were too long for Newton to
        # contract, or a corrector went farther than its predictor; FINER times the steps, same rule
        alg = replace(alg, steps=min(alg.steps * FINER, MAX_NATURAL_STEPS))
        run = run_natural(model, theta0, problem.params(lam0), problem.dp, to - lam0, alg.steps, alg.newton, alg.final)
    lam = lam0 + (to - lam0) * np.arange(alg.steps + 1) / alg.steps
    theta = np.vstack([theta0[None, :], run.states])
    theta[-1] = run.theta
    finite = bool(np.all(np.isfinite(theta)))
    why = alg.acceptance.why_not(run.gradient_norm, run.min_pivot, run.contraction, finite, run.jump)
    m = len(lam)
    if why or not finite:
        # a refused ramp: the Morse index of each point from its Hessian's pivots (what is finite)
        morse = np.zeros(m, dtype=int)
        rel = np.full(m, np.nan)
        if finite:
            for i, h in enumerate(problem.hessians(theta, lam)):
                piv = structured_pivots(h)
                scale = max(float(np.max(np.abs(piv))), 1e-300)
                morse[i], rel[i] = int(np.sum(piv < -alg.acceptance.critical_tol * scale)), float(np.min(piv)) / scale
        stopped, reason = "refused", f"natural continuation refused: it {why}"
    else:
        morse, rel = np.zeros(m, dtype=int), np.full(m, run.min_pivot)
        stopped, reason = "bound", f"reached {problem.describe(to)}"
    iterations = np.full(m, alg.newton, dtype=int)
    iterations[0] = 0
    iterations[-1] += alg.final
    return Branch(
        name=problem.name,
        unit=problem.unit,
        lam=lam,
        theta=theta,
        tips=(lambda: problem.tips(theta, lam)) if finite else (lambda: np.full((m, 3), np.nan)),
        arclength=np.abs(lam - lam0) / max(abs(to - lam0), 1e-300),
        spectrum=_spectrum_of(problem, theta, lam, {}),
        min_pivot=rel,
        morse=morse,
        kind=_natural_kinds(m),
        special=(),
        stopped=stopped,
        stop_reason=reason,
        iterations=iterations,
        critical_tol=alg.acceptance.critical_tol,
        label=label,
        evaluations=alg.steps * (alg.newton + 1) + alg.final + 1,
    )


# ---------------------------------------------------------------------------------------------
# branch switching


def bifurcation_tangents(problem: PathProblem, point: SpecialPoint, branch_tangent: np.ndarray, w: float, sigma: float) -> np.ndarray:
    """The tangent (theta, lambda) of the branch crossing the traced one at a branch point.

    Both tangents lie in the plane of t_a = (psi, 1), psi = -H^+ dg/dlambda orthogonal to the null
    vector phi, and t_b = (phi, 0), and solve the algebraic bifurcation equation
    phi . D2g[t, t] = a alpha^2 + 2 b alpha beta + c beta^2 = 0 for t = alpha t_a + beta t_b, with
    the second derivatives from d(H phi)/d(theta, lambda) and d2(phi . g)/dlambda2 (AD). Of its two
    roots the one farther from ``branch_tangent`` (the traced branch's) is returned, unit in the metric
    w |dtheta|^2 + (dlambda / sigma)^2.
    """
    n = problem.n
    phi = point.eigenvector / np.linalg.norm(point.eigenvector)
    _, h, gl = problem.ghl(point.theta, point.lam)
    _, hv_t, hv_l, vgll = problem.fold_terms(point.theta, point.lam, phi)
    m = np.zeros((n + 1, n + 1))
    m[:n, :n] = 0.5 * (hv_t + hv_t.T)
    m[:n, n] = hv_l
    m[n, :n] = hv_l
    m[n, n] = vgll
    psi = np.linalg.lstsq(h, -gl, rcond=1e-10)[0]
    psi = psi - (psi @ phi) * phi
    t_a = np.concatenate([psi, [1.0]])
    t_b = np.concatenate([phi, [0.0]])
    a, b, c = t_a @ m @ t_a, t_a @ m @ t_b, t_b @ m @ t_b
    disc = b * b - a * c
    scale = max(abs(a), abs(b), abs(c), 1e-300)
    if disc < -1e-12 * scale**2:
        raise PathError(f"branch point at {problem.describe(point.lam)}: no real crossing direction (b^2 - ac = {disc:.3g})")
    root = math.sqrt(max(disc, 0.0))
    if abs(a) >= abs(c) and abs(a) > 1e-12 * scale:
        pairs = [((-b + root) / a, 1.0), ((-b - root) / a, 1.0)]  # (alpha, beta)
    elif abs(c) > 1e-12 * scale:
        pairs = [(1.0, (-b + root) / c), (1.0, (-b - root) / c)]
    else:  # a = c = 0: the two branches are t_a and t_b themselves
        pairs = [(1.0, 0.0), (0.0, 1.0)]

    def unit(t: np.ndarray) -> np.ndarray:
        return t / math.sqrt(w * float(t[:n] @ t[:n]) + float(t[n]) ** 2 / sigma**2)

    candidates = [unit(al * t_a + be * t_b) for al, be in pairs]
    traced = unit(np.asarray(branch_tangent, dtype=float))

    def alignment(t: np.ndarray) -> float:
        return abs(w * float(t[:n] @ traced[:n]) + float(t[n] * traced[n]) / sigma**2)

    return min(candidates, key=alignment)


def _branch_tangent(problem: PathProblem, point: SpecialPoint, given: np.ndarray | None) -> np.ndarray:
    """The traced branch's tangent at a branch point: given, or along lambda with
    dtheta/dlambda = -H^+ dg/dlambda (the pseudo-inverse: H is singular there)."""
    if given is not None:
        return np.asarray(given, dtype=float)
    _, h, gl = problem.ghl(point.theta, point.lam)
    z = np.linalg.lstsq(h, -gl, rcond=1e-10)[0]
    return np.concatenate([z, [1.0]])


def crossing_start(corr: Corrector, point: SpecialPoint, sign: float, traced_tangent: np.ndarray | None = None) -> Point | None:
    """The first point of the crossing branch off a branch point on side ``sign`` (+1 or -1), with its
    tangent and spectrum; None when the corrector cannot land on the new branch.

    The step is halved until the point lands on the new branch, not back on the traced one: its
    offset from the branch point lies nearer the new branch's tangent line than half its distance
    from the traced one's. (That holds whichever of the two crosses the other: leaving the straight
    column for a bent branch, and leaving a bent branch for the straight column, whose tangent has
    no component along the null vector.)
    """
    traced = _branch_tangent(corr.prob, point, traced_tangent)
    direction = sign * bifurcation_tangents(corr.prob, point, traced, corr.w, corr.sigma)
    anchor = corr.point(point.theta.copy(), point.lam)
    anchor.tangent = direction

    def off_line(d: np.ndarray, t: np.ndarray) -> float:
        t = t / corr.norm(t)
        return corr.norm(d - corr.dot(d, t) * t)

    ds = corr.opts.ds
    while ds >= corr.opts.ds_min:
        start = corr.on_segment(anchor, ds)
        if start is not None:
            d = start.x - anchor.x
            if off_line(d, direction) < 0.5 * off_line(d, traced):
                start.tangent = corr.tangent(start, anchor.tangent)
                if start.tangent is not None:
                    corr.spectrum(start)
                    return start
        ds /= 2.0
    return None


@single_threaded
def bifurcating_branches(
    problem: PathProblem,
    point: SpecialPoint,
    branch_tangent: np.ndarray | None = None,
    *,
    to: float | None = None,
    bounds: tuple[float, float] | None = None,
    options: PathOptions | None = None,
    label: str = "",
) -> list[Branch]:
    """Trace the branch that crosses at a branch point, on both sides (two :class:`Branch`), each
    labelled by the way it bends (:func:`side_of`): ``label + "away from chamber"`` or
    ``label + "towards chamber"`` (the total angle rising or falling from the branch point's).

    Parameters
    ----------
    problem : PathProblem
    point : SpecialPoint
        A branch point of a trace of ``problem`` (``kind == "branch point"``).
    branch_tangent : ndarray, optional
        The traced branch's tangent there (theta, lambda); default: along lambda with
        dtheta/dlambda = -H^+ dg/dlambda.
    to, bounds, options, label :
        As for :func:`trace`; each side is traced until it stops.
    """
    if not isinstance(point, SpecialPoint) or point.kind != "branch point":
        raise PathError(f"bifurcating_branches needs a branch point, got {getattr(point, 'kind', point)!r}")
    opts = DEFAULT_PATH_OPTIONS if options is None else options
    if bounds is None:
        bounds = (min(point.lam, to), max(point.lam, to)) if to is not None else problem.domain
    lo, hi = max(bounds[0], problem.domain[0]), min(bounds[1], problem.domain[1])
    corr = Corrector.for_trace(problem, lo, hi, opts)
    starts = [crossing_start(corr, point, sign, branch_tangent) for sign in (1.0, -1.0)]
    sides = [None if st is None else side_of(st.theta, point.theta) for st in starts]
    if sides[0] is not None and sides[0] == sides[1]:  # both bend the same way (a mode of zero total angle)
        sides = [f"{sides[0]}, mode +", f"{sides[1]}, mode -"]
    out = []
    for start, side, sign in zip(starts, sides, ("+", "-")):
        if start is None:
            name = f"{label}mode {sign}" if label else f"bifurcating mode {sign}"
            out.append(_branch(corr, [], [], "start", f"no point found off the branch point along the mode's {sign} side", name))
            continue
        name = f"{label}{side}" if label else f"bifurcating {side}"
        side_bounds = (min(lo, start.lam), max(hi, start.lam))
        out.append(trace(problem, start.theta, start.lam, bounds=side_bounds, options=opts, tangent=start.tangent, label=name))
    return out


#: The two sides of a crossing branch, named by the way they bend: theta > 0 bends the actuator away
#: from its chamber (the chamber lies on the convex side: inflating bends it away), theta < 0 towards it.
SIDES = ("away from chamber", "towards chamber")


def side_of(theta: np.ndarray, at: np.ndarray) -> str:
    """Which way a crossing branch leaving the branch point ``at`` through ``theta`` bends: its total
    angle grows (``"away from chamber"``) or falls (``"towards chamber"``)."""
    return SIDES[0] if float(np.sum(theta) - np.sum(at)) > 0 else SIDES[1]

"""Load histories: the order in which pressure and loads are applied, and the state they reach.

A quasi-static history starts from the straight, unloaded actuator (theta = 0 at P = 0, no payload
or weight) and moves the pressure and the loads (payload forces and weight, together) to their
full values through a list of *steps*. A step is a pair (pressure fraction, load fraction), each
from 0 to 1, the last always (1, 1); between two steps both change linearly. Each leg is one ramp of
:func:`esba.paths.loading.follow` (pseudo-arclength continuation on the stable branch, snapping where
it ends at a fold). Where an actuator is multistable, the history decides which stable state it is
in (:mod:`esba.statics.equilibria`).

==================== ============================ ===============================================
name                 steps                        what it means
==================== ============================ ===============================================
``inflate-then-load`` (1, 0), (1, 1)              inflate to P unloaded, then raise the payloads
                                                  and weight at P (``solve``'s default)
``load-then-inflate`` (0, 1), (1, 1)              hang the payloads (and weight) on the straight
                                                  actuator at P = 0, then inflate under them
``together``          (1, 1)                      raise pressure and loads in proportion
==================== ============================ ===============================================

Any other list of steps is a history of its own, e.g. ``((0.5, 0), (0.5, 1), (1, 1))``: half the
pressure, then the loads, then the rest of the pressure.

Examples
--------
>>> history_steps("load-then-inflate")
((0.0, 1.0), (1.0, 1.0))
>>> describe_history(((0.5, 0.0), (0.5, 1.0), (1.0, 1.0)))
'steps (P, loads) = (0, 0) -> (0.5, 0) -> (0.5, 1) -> (1, 1)'
>>> history_steps([(1, 0.5)])
Traceback (most recent call last):
...
esba.statics.history.HistoryError: history=[(1, 0.5)]: the last step must be (1, 1) (the full pressure and loads)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from esba.infra.errors import InputError
from esba.model.closed_form import load_parameter
from esba.model.generated import Model
from esba.paths.continuation import Natural, PathOptions, PathProblem, SpecialPoint
from esba.paths.loading import Jump, Ramp, follow

__all__ = [
    "HISTORIES",
    "DEFAULT_HISTORY",
    "MAX_STEPS",
    "HistoryError",
    "LoadHistory",
    "history_steps",
    "history_name",
    "describe_history",
    "load_history",
]

#: The named histories and their steps (pressure fraction, load fraction).
HISTORIES: dict[str, tuple[tuple[float, float], ...]] = {
    "inflate-then-load": ((1.0, 0.0), (1.0, 1.0)),
    "load-then-inflate": ((0.0, 1.0), (1.0, 1.0)),
    "together": ((1.0, 1.0),),
}
#: ``solve``'s history unless told otherwise (the one esba has always used).
DEFAULT_HISTORY = "inflate-then-load"
#: Most steps a history may have (each is a path trace).
MAX_STEPS = 100


class HistoryError(InputError):
    """A history that is not allowed: the message names the value and what is allowed."""


def history_steps(value: Any) -> tuple[tuple[float, float], ...]:
    """The steps of a history: a name of :data:`HISTORIES` or a sequence of (pressure, load) fractions."""
    if isinstance(value, str):
        if value not in HISTORIES:
            raise HistoryError(f"history={value!r}: allowed are {', '.join(HISTORIES)} or a list of (pressure, load) fraction steps ending at (1, 1)")
        return HISTORIES[value]
    try:
        steps = tuple((float(p), float(q)) for p, q in value)
    except (TypeError, ValueError):
        raise HistoryError(f"history={value!r}: expected a name ({', '.join(HISTORIES)}) or a list of (pressure, load) fraction pairs") from None
    if not 1 <= len(steps) <= MAX_STEPS:
        raise HistoryError(f"history has {len(steps)} steps: expected 1 to {MAX_STEPS}")
    for p, q in steps:
        if not (math.isfinite(p) and math.isfinite(q) and 0.0 <= p <= 1.0 and 0.0 <= q <= 1.0):
            raise HistoryError(f"history step ({p:g}, {q:g}): each fraction must be from 0 to 1")
    if steps[-1] != (1.0, 1.0):
        raise HistoryError(f"history={value!r}: the last step must be (1, 1) (the full pressure and loads)")
    return steps


def history_name(value: Any) -> str:
    """The name of a history if it has one, else its steps written out."""
    steps = history_steps(value)
    for name, known in HISTORIES.items():
        if steps == known:
            return name
    return describe_history(steps)


def describe_history(value: Any) -> str:
    """The steps of a history as text, from the unloaded straight state."""
    steps = ((0.0, 0.0),) + history_steps(value)
    return "steps (P, loads) = " + " -> ".join(f"({p:g}, {q:g})" for p, q in steps)


def _settings(options: Any) -> tuple[PathOptions, float, bool]:
    """(path options, IPOPT tolerance, fast) of a ``SolverOptions`` (or the defaults for None)."""
    if options is None:
        return PathOptions(), 1e-10, True
    return options.path, options.tol, options.fast


def _load_value(model: Model, pv_full: np.ndarray, pressure: float, name: str, lam: float) -> str:
    """Where on a ramp of the default history lambda lies, in the scene's terms (its payloads' forces and
    weight, from the full load's parameter vector)."""
    if name == "pressure":
        return f"P = {lam:.6g} MPa (unloaded)"
    names = model.parameters
    forces = [pv_full[i] for i, k in enumerate(names) if k.startswith("F") and k[1:].isdigit()]
    parts = [f"payload {k} = {f * lam:.6g} N" for k, f in enumerate(forces, start=1)]
    if "g" in names:
        parts.append(f"weight {100 * lam:.4g} %")
    return f"{100 * lam:.6g} % of the loads ({', '.join(parts)}) at P = {pressure:.6g} MPa"


def _step_value(pressure: float, leg: tuple[tuple[float, float], tuple[float, float]], lam: float) -> str:
    """Where on a leg of a general history lambda lies: the pressure and the fraction of the loads."""
    (p0, q0), (p1, q1) = leg
    p, q = p0 + lam * (p1 - p0), q0 + lam * (q1 - q0)
    return f"P = {p * pressure:.6g} MPa with {100 * q:.4g} % of the loads"


@dataclass(frozen=True, eq=False)
class LoadHistory:
    """What the quasi-static load history did.

    Attributes
    ----------
    theta : ndarray
        The state reached, rad.
    ramps : tuple of (str, Ramp)
        Each ramp (``pressure``, ``load``, or ``step k`` of a general history) and what it did
        (:class:`esba.paths.loading.Ramp`).
    message : str
        Why the history did not reach the full load (empty when it did).
    history : str
        The history's name, or its steps written out.
    legs : tuple
        For a general history, each ramp's ((P, loads) from, (P, loads) to) fractions; empty for
        the default history (whose ramps are named).
    """

    theta: np.ndarray
    ramps: tuple[tuple[str, Ramp], ...]
    message: str = ""
    history: str = DEFAULT_HISTORY
    legs: tuple[tuple[tuple[float, float], tuple[float, float]], ...] = ()

    @property
    def jumps(self) -> tuple[Jump, ...]:
        return tuple(j for _, r in self.ramps for j in r.jumps)

    @property
    def branch_points(self) -> tuple[SpecialPoint, ...]:
        return tuple(sp for _, r in self.ramps for sp in r.branch_points)

    def where(self, k: int, model: Model, pv_full: np.ndarray, pressure: float, lam: float) -> str:
        """Where on ramp ``k`` lambda lies, in the scene's terms."""
        name, _ = self.ramps[k]
        if self.legs:
            return _step_value(pressure, self.legs[k], lam)
        return _load_value(model, pv_full, pressure, name, lam)

    def notes(self, model: Model, pv_full: np.ndarray, pressure: float) -> list[str]:
        """One sentence per buckling and per snap-through on the way, in the scene's terms."""
        out = []
        for k, (_, r) in enumerate(self.ramps):
            for sp in r.branch_points:
                out.append(
                    f"the straight-through branch loses stability at a {sp.bifurcation + ' ' if sp.bifurcation else ''}branch point at {self.where(k, model, pv_full, pressure, sp.lam)}: "
                    f"the state goes on along the stable crossing branch (buckling)"
                )
            for j in r.jumps:
                out.append(j.describe(self.where(k, model, pv_full, pressure, j.lam)))
        return out

    @property
    def iterations(self) -> int:
        return sum(r.corrector_iterations + r.ipopt_iterations for _, r in self.ramps)

    @property
    def points(self) -> int:
        return sum(r.points + len(r.jumps) for _, r in self.ramps)


def _unloaded(model: Model, pv_full: np.ndarray) -> np.ndarray:
    """The parameter vector with every load (payload forces, g) at 0."""
    out = np.array(pv_full, dtype=float)
    out[[i for i, k in enumerate(model.parameters) if load_parameter(k)]] = 0.0
    return out


def load_history(
    model: Model,
    pressure: float,
    pv_full: np.ndarray,
    unloaded: np.ndarray | None = None,
    options: Any = None,
    steps: Any = None,
) -> LoadHistory:
    """The state an actuator reaches along a load history, on the continuation engine.

    ``steps`` is the history (a name of :data:`HISTORIES` or a list of steps; default: the
    ``history`` of ``options``, else :data:`DEFAULT_HISTORY`). ``options`` is a
    :class:`esba.statics.equilibrium.SolverOptions` (its ``path``, ``tol`` and ``fast``).

    The default history: from the unloaded state at ``pressure`` (``unloaded`` when it is known,
    e.g. exact for a target angle; else the pressure is raised from 0 at theta = 0), the payloads
    and weight are raised together from 0 to ``pv_full``. Each ramp is
    :func:`esba.paths.loading.follow`: natural continuation first when ``options.fast`` (compiled,
    O(n), accepted by the one rule), else and otherwise pseudo-arclength continuation through its
    folds and branch points, snapping where the stable branch ends. The batch
    (:mod:`esba.statics.batch`) hands its refused elements here.

    Any other history starts at theta = 0, P = 0, no loads, and follows its steps in the same way
    (``unloaded`` is then not used).
    """
    if steps is None:
        steps = getattr(options, "history", DEFAULT_HISTORY) if options is not None else DEFAULT_HISTORY
    steps = history_steps(steps)
    if steps == HISTORIES[DEFAULT_HISTORY]:
        return _inflate_then_load(model, pressure, pv_full, unloaded, options)
    path, tol, fast = _settings(options)
    natural = Natural() if fast else None
    names = model.parameters
    pv_unloaded = _unloaded(model, pv_full)
    i = names.index("P")
    dp = np.zeros(len(names))
    dp[i] = pressure  # U is linear in P
    dload = pv_full - pv_unloaded  # and in the loads

    def params(p: float, q: float) -> np.ndarray:
        out = pv_unloaded + q * dload + (p - 1.0) * dp
        return out

    theta = np.zeros(model.n)
    ramps: list[tuple[str, Ramp]] = []
    legs = []
    here = (0.0, 0.0)
    name = history_name(steps)
    for k, step in enumerate(steps, start=1):
        if step == here:
            continue
        problem = PathProblem.homotopy(model, params(*here), params(*step), name=f"step {k}", what=f"pressure and loads from {here} to {step} of their values")
        r = follow(problem, theta, 0.0, 1.0, path, ipopt_tol=tol, natural=natural)
        ramps.append((f"step {k}", r))
        legs.append((here, step))
        theta = r.theta
        if not r.reached:
            where = _step_value(pressure, (here, step), r.lam)
            return LoadHistory(theta, tuple(ramps), f"step {k} of the history ({name}) stopped at {where}: {r.message}", name, tuple(legs))
        here = step
    return LoadHistory(theta, tuple(ramps), "", name, tuple(legs))


def _inflate_then_load(model: Model, pressure: float, pv_full: np.ndarray, unloaded: np.ndarray | None, options: Any) -> LoadHistory:
    """The default history: inflate (unless the unloaded state is known), then load."""
    path, tol, fast = _settings(options)
    n = model.n
    natural = Natural() if fast else None
    names = model.parameters
    pv_unloaded = _unloaded(model, pv_full)
    ramps: list[tuple[str, Ramp]] = []
    if unloaded is not None:
        theta = np.asarray(unloaded, dtype=float)
    else:
        i = names.index("P")
        p_zero = pv_unloaded.copy()
        p_zero[i] = 0.0
        dp = np.zeros(len(names))
        dp[i] = 1.0  # U is linear in P
        problem = PathProblem(model, p_zero, dp, "pressure", "MPa", (0.0, math.inf), 0.1, what="pressure")
        r = follow(problem, np.zeros(n), 0.0, pressure, path, ipopt_tol=tol, natural=natural)
        ramps.append(("pressure", r))
        theta = r.theta
        if not r.reached:
            where = _load_value(model, pv_full, pressure, "pressure", r.lam)
            return LoadHistory(theta, tuple(ramps), f"the pressure ramp from P = 0 stopped at {where}: {r.message}")
    if np.any(pv_full != pv_unloaded):  # payloads of 0 N and no weight leave nothing to ramp
        problem = PathProblem.homotopy(model, pv_unloaded, pv_full, name="load", what="payloads and weight")
        r = follow(problem, theta, 0.0, 1.0, path, ipopt_tol=tol, natural=natural)
        ramps.append(("load", r))
        theta = r.theta
        if not r.reached:
            where = _load_value(model, pv_full, pressure, "load", r.lam)
            return LoadHistory(theta, tuple(ramps), f"the load ramp from the unloaded state stopped at {where}: {r.message}")
    return LoadHistory(theta, tuple(ramps))


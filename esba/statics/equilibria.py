"""Every equilibrium of a scene: deflated Newton on the generated gradient and Hessian.

An actuator under load can have several equilibria at one pressure: two stable states and the
unstable one between them in a bistable window, a detached branch that no load history from the
unloaded state reaches. :func:`equilibria` finds them all in the model's domain by *deflation*
(Farrell, Birkisson and Funke, "Deflation techniques for finding distinct solutions of nonlinear
partial differential equations", SIAM J. Sci. Comput. 37(4), 2015; the ``defcon`` package): once an
equilibrium theta* is found, Newton's method is run again on the deflated residual

    G(theta) = M(theta) dU/dtheta,   M(theta) = prod_k (1 / |theta - theta*_k|^p + sigma)

which has the same zeros as dU/dtheta except the ones found (the shift sigma keeps M bounded away
from them, so Newton is not pulled to infinity). With the exact Hessian H the Jacobian of G is
M H + g (grad M)^T, a rank-one update of H, so the deflated Newton step is the ordinary one,
delta = -H^-1 g, scaled (Sherman-Morrison):

    delta_G = delta / (1 - (grad log M) . delta).

Each ordinary step is the O(n) structured solve of :func:`esba.solvers.newton.newton_correction`
(evaluated for every start at once), so a round costs O(n) per start and iteration plus O(n) per
start and equilibrium found.

The search (:class:`EquilibriaOptions`):

* **the domain**: every segment angle above the model's lower bound (Eq. 10: the chamber closes),
  the total bend from n times that bound up to ``max_bend_deg`` (360 deg: beyond a full turn the
  actuator passes through itself, :mod:`esba.model.validity`). Each Newton step changes the total
  bend by at most ``max_step_deg`` and stays inside the lower bound; an equilibrium that Newton
  reaches beyond ``max_bend_deg`` is counted (``outside``), not listed.
* **the starts**: the load-history state (inflate, then load; ``solve`` passes the state its own
  history reached and deflates it from the first round instead), the straight state theta = 0, the exact
  unloaded state when the scene gives a target angle, ``theta_starts`` given by the caller, and
  ``starts`` constant-curvature shapes whose total bends span the domain evenly.
* **rounds**: every start runs ``max_iter`` deflated Newton steps against all equilibria found so
  far (a CasADi graph of ``max_iter`` calls of one step Function around the kernel; a start that
  has converged stops moving), each start one C call once the kernel is hot (:func:`round_kernel`),
  else all starts in one call of CasADi's interpreter; what converges is new (distinct starts that
  reach the same equilibrium count once, the first start in order keeps it). The rounds go on until
  one finds nothing new (beyond :data:`ROUND_ROOTS` equilibria found, in NumPy, one kernel call a
  step).
* **the completeness check**: a second search from fresh starts (constant curvature half-way
  between the first starts, and shapes curved more towards the base or towards the tip over the
  same total bends), deflated by everything found. ``complete`` says whether it found nothing new
  (what it found is kept and reported).
* **each equilibrium** gets its energy, tip, Hessian eigenvalues, Morse index (number of negative
  eigenvalues) and stability. For every index-1 saddle, steepest descent on the energy from each
  side of its unstable mode (saddle-free Newton steps with an energy line search) finds the stable
  states it connects: the saddle and the energy barriers between them (:class:`Barrier`).

Examples
--------
>>> from esba.model.scene import Scene, Payload
>>> res = equilibria(Scene(pressure=0.17, payloads=(Payload(force=2, angle_deg=90),)))
>>> [(round(s.total_angle_deg, 2), s.morse_index) for s in res.states]
[(212.84, 0), (83.9, 0), (138.84, 1)]
>>> res.complete, res.multistable
(True, True)
>>> b = res.barriers[0]
>>> round(b.from_a, 2), round(b.from_b, 2)
(8.09, 3.42)
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from esba.infra import checks
from esba.infra.errors import InputError
from esba.infra.report import Report
from esba.infra.threads import single_threaded
from esba.model import resolution
from esba.model.closed_form import pressure_for_angle
from esba.model.generated import Model
from esba.model.scene import Scene, SceneError
from esba.model.stability import CRITICAL_TOL, stability_verdict
from esba.model.validity import assess
from esba.solvers.native import HOT_RUNS, Kernel, packed
from esba.solvers.newton import SOLVE_COMPILE_MAX_N, correction_kernel, newton_correction
from esba.solvers.newton import state as compiled_state

from .history import load_history

__all__ = ["EquilibriaOptions", "EquilibriaOptionsError", "Equilibria", "State", "Barrier", "equilibria", "search", "state_of", "round_kernel"]


class EquilibriaOptionsError(InputError):
    """A search option that is not allowed: the message names the option, the value and what is allowed."""


@dataclass(frozen=True)
class EquilibriaOptions:
    """Settings of :func:`equilibria`, validated on creation.

    Parameters
    ----------
    max_bend_deg : float
        Largest total bend searched, deg (> 0, at most 720); 360 by default (a full turn).
    starts : int
        Constant-curvature starts spread over the domain's total bends (2 to 1000).
    max_iter : int
        Newton iterations of one run (1 to 1000).
    max_rounds : int
        Deflation rounds of a search (1 to 100): each runs every start once.
    max_step_deg : float
        Largest change of the total bend in one Newton step, deg (> 0).
    power, shift : float
        The deflation operator's power p (> 0) and shift sigma (> 0).
    tol : float
        Largest |dU/dtheta_i| (N mm/rad) of an equilibrium (> 0).
    distinct : float
        Two equilibria closer than this (largest segment-angle difference, rad) are one (> 0).
    history : bool
        Start from the state the default load history reaches too (a path trace: about the cost
        of a solve).
    check : bool
        Run the completeness check (a second search from fresh starts).
    connect : bool
        Find which stable states each index-1 saddle connects, and the barriers.
    critical_tol : float
        An eigenvalue within ``critical_tol`` times the largest (in magnitude) of 0 counts as 0.

    Examples
    --------
    >>> EquilibriaOptions().starts
    25
    >>> EquilibriaOptions(starts=1)
    Traceback (most recent call last):
    ...
    esba.statics.equilibria.EquilibriaOptionsError: starts=1: expected a whole number from 2 to 1000 (each start is a Newton run per round)
    """

    max_bend_deg: float = 360.0
    starts: int = 25
    max_iter: int = 60
    max_rounds: int = 12
    max_step_deg: float = 45.0
    power: float = 2.0
    shift: float = 1.0
    tol: float = 1e-8
    distinct: float = 1e-5
    history: bool = True
    check: bool = True
    connect: bool = True
    critical_tol: float = CRITICAL_TOL

    def __post_init__(self) -> None:
        E = EquilibriaOptionsError
        checks.whole("starts", self.starts, 2, E, 1000, "each start is a Newton run per round")
        checks.whole("max_iter", self.max_iter, 1, E, 1000, "Newton converges in tens of iterations or not at all")
        checks.whole("max_rounds", self.max_rounds, 1, E, 100, "each round finds at least one equilibrium or ends the search")
        for name, high in (("max_bend_deg", 720.0), ("max_step_deg", None), ("power", None), ("shift", None), ("tol", 1.0), ("distinct", 1.0), ("critical_tol", 1.0)):
            value = checks.finite(name, getattr(self, name), E)
            if value <= 0 or (high is not None and value > high):
                raise E(f"{name}={value!r}: expected a number > 0" + (f" and at most {high:g}" if high is not None else ""))
        for name in ("history", "check", "connect"):
            if not isinstance(getattr(self, name), bool):
                raise E(f"{name}={getattr(self, name)!r}: expected True or False")


DEFAULT_OPTIONS = EquilibriaOptions()


# ---------------------------------------------------------------------------------------------
# the result


@dataclass(frozen=True, eq=False)
class State:
    """One equilibrium of a scene.

    Attributes
    ----------
    theta : ndarray
        Segment angles, rad.
    tip : ndarray
        Tip position [x, y], mm.
    tip_angle : float
        Tip orientation, rad.
    energy : float
        Total potential energy U, N mm.
    eigenvalues : ndarray
        Hessian eigenvalues, ascending, N mm/rad^2.
    morse_index : int
        Number of negative eigenvalues (0: a minimum).
    stability : str
        ``stable``, ``critical`` or ``unstable`` (:func:`esba.model.stability.stability_verdict`).
    gradient_norm : float
        max |dU/dtheta_i| at theta, N mm/rad.
    found : str
        Which search and start found it first.
    validity : tuple of Finding
        Where the state leaves the model's domain, by the rule ``solve`` applies
        (:func:`esba.model.validity.assess`): a strain past 1, a bend past a turn, the tip behind
        the base, a load far outside the paper's. Empty: inside.
    """

    theta: np.ndarray
    tip: np.ndarray
    tip_angle: float
    energy: float
    eigenvalues: np.ndarray
    morse_index: int
    stability: str
    gradient_norm: float
    found: str = ""
    validity: tuple = ()

    @property
    def in_domain(self) -> bool:
        """Inside the model's domain (no :attr:`validity` finding)."""
        return not self.validity

    @property
    def total_angle_deg(self) -> float:
        """Total bend, Eq. (17), deg."""
        return math.degrees(float(np.sum(self.theta)))

    @property
    def theta_deg(self) -> list[float]:
        return [math.degrees(float(t)) for t in self.theta]

    @property
    def min_eigenvalue(self) -> float:
        """Smallest Hessian eigenvalue, N mm/rad^2."""
        return float(self.eigenvalues[0])

    @property
    def stable(self) -> bool:
        return self.stability == "stable"

    def to_dict(self) -> dict[str, Any]:
        return {
            "theta_deg": self.theta_deg,
            "total_angle_deg": self.total_angle_deg,
            "tip_mm": [float(self.tip[0]), float(self.tip[1])],
            "tip_angle_deg": math.degrees(self.tip_angle),
            "energy_nmm": self.energy,
            "morse_index": self.morse_index,
            "min_eigenvalue": self.min_eigenvalue,
            "stable": self.stable,
            "stability": self.stability,
            "gradient_norm": self.gradient_norm,
            "found": self.found,
            "in_domain": self.in_domain,
            "validity": [f.to_dict() for f in self.validity],
        }


@dataclass(frozen=True)
class Barrier:
    """Two stable states joined through an index-1 saddle.

    ``a`` and ``b`` index :attr:`Equilibria.states` (a < b: ``a`` has the lower energy or comes
    first), ``saddle`` too; ``from_a`` and ``from_b`` are the energies to climb from each to the
    saddle, N mm.
    """

    a: int
    b: int
    saddle: int
    from_a: float
    from_b: float

    def to_dict(self) -> dict[str, Any]:
        return {"a": self.a, "b": self.b, "saddle": self.saddle, "barrier_from_a_nmm": self.from_a, "barrier_from_b_nmm": self.from_b}


@dataclass(frozen=True, eq=False, repr=False)
class Equilibria(Report):
    """Every equilibrium :func:`equilibria` found in the scene's domain.

    Attributes
    ----------
    scene : Scene
    pressure : float
        MPa.
    states : tuple of State
        Sorted by energy, least first.
    barriers : tuple of Barrier
        For each pair of stable states joined by an index-1 saddle, the lowest such saddle.
    domain : dict
        What was searched: ``lower_bound_deg`` (each segment), ``total_bend_deg`` ([low, high]).
    complete : bool or None
        The completeness check found nothing new (None: not run).
    check_found : int
        Equilibria the completeness check found that the first search had not.
    starts, rounds, runs, iterations : int
        Starts of the first search; deflation rounds and Newton runs of both searches; Newton iterations.
    outside : int
        Equilibria Newton converged to beyond the domain searched (not listed); the listed states
        outside the model's domain say so themselves (:attr:`State.validity`), and
        :attr:`outside_domain` counts both.
    time_s : float
        Wall time, s.
    """

    scene: Scene = field(repr=False)
    pressure: float
    states: tuple[State, ...]
    barriers: tuple[Barrier, ...]
    domain: dict[str, Any]
    complete: bool | None
    check_found: int
    starts: int
    rounds: int
    runs: int
    iterations: int
    outside: int
    time_s: float
    history_state: int | None = None

    _plotter = "esba.figures.results:draw_equilibria"

    def headline(self) -> str:
        """One line: how many equilibria, how many stable, at which pressure."""
        return (f"{len(self.states)} equilibri{'um' if len(self.states) == 1 else 'a'} at P = {self.pressure:.5g} MPa, {len(self.stable)} stable"
                + (" (multistable)" if len(self.stable) > 1 else "") + f", n = {self.scene.segments}")

    def summary(self) -> str:
        """The text ``esba equilibria`` prints for this scene (without its figure)."""
        from .text import equilibria_table

        return equilibria_table({**self.to_dict(), "scene": self.scene.describe()})

    @property
    def stable(self) -> tuple[State, ...]:
        """The stable states, least energy first."""
        return tuple(s for s in self.states if s.stable)

    @property
    def multistable(self) -> bool:
        return len(self.stable) > 1

    @property
    def outside_domain(self) -> int:
        """Equilibria outside the model's domain: the listed ones that leave it (the rule of
        ``solve``, :func:`esba.model.validity.assess`) and those beyond the search, not listed."""
        return self.outside + sum(1 for s in self.states if not s.in_domain)

    @property
    def least_energy(self) -> State | None:
        """The stable state of least energy (None when none is stable)."""
        stable = self.stable
        return stable[0] if stable else None

    def index(self, theta: Sequence[float], distinct: float = DEFAULT_OPTIONS.distinct * 100) -> int | None:
        """The index in :attr:`states` of the state at ``theta`` (None when none is that close)."""
        theta = np.asarray(theta, dtype=float)
        for k, s in enumerate(self.states):
            if s.theta.shape == theta.shape and float(np.max(np.abs(s.theta - theta))) <= distinct:
                return k
        return None

    def describe_domain(self) -> str:
        lo, hi = self.domain["total_bend_deg"]
        return f"each segment above {self.domain['lower_bound_deg']:.2f} deg (Eq. 10), total bend {lo:.1f} to {hi:.1f} deg"

    def to_dict(self) -> dict[str, Any]:
        least = self.least_energy
        return {
            "pressure_mpa": self.pressure,
            "segments": self.scene.segments,
            "variant": self.scene.variant,
            "payloads": [{"force_n": p.force, "angle_deg": p.angle_deg, "at": p.at} for p in self.scene.payloads],
            "gravity": self.scene.gravity,
            "domain": dict(self.domain, text=self.describe_domain()),
            "states": [s.to_dict() for s in self.states],
            "stable": [k for k, s in enumerate(self.states) if s.stable],
            "least_energy_stable": None if least is None else self.states.index(least),
            "history_state": self.history_state,
            "multistable": self.multistable,
            "barriers": [b.to_dict() for b in self.barriers],
            "complete": self.complete,
            "check_found": self.check_found,
            "starts": self.starts,
            "rounds": self.rounds,
            "newton_runs": self.runs,
            "newton_iterations": self.iterations,
            "outside_domain": self.outside_domain,
            "not_listed": self.outside,
            "time_s": self.time_s,
        }


# ---------------------------------------------------------------------------------------------
# the search


@dataclass
class _Found:
    thetas: list[np.ndarray]
    labels: list[str]
    rounds: int = 0
    runs: int = 0
    iterations: int = 0


def _deflated_newton(kernel, pv: np.ndarray, starts: np.ndarray, roots: np.ndarray, lb: float, hi_total: float, opts: EquilibriaOptions) -> tuple[np.ndarray, np.ndarray, int]:
    """Deflated Newton from every row of ``starts`` at once, deflated by the rows of ``roots``.

    Returns (thetas, converged mask, iterations); ``converged`` rows are equilibria (|g| <= tol),
    which may lie beyond ``hi_total`` (the caller counts them as outside)."""
    x = np.array(starts, dtype=float)
    m, n = x.shape
    active = np.ones(m, dtype=bool)
    done = np.zeros(m, dtype=bool)
    step_cap = math.radians(opts.max_step_deg) / math.sqrt(n)  # a constant-curvature change of max_step_deg
    p, sigma = opts.power, opts.shift
    iterations = 0
    for _ in range(opts.max_iter):
        idx = np.flatnonzero(active)
        if not len(idx):
            break
        g, newton, _ = kernel(x[idx].T, pv)
        g = np.asarray(g).reshape(n, -1).T
        delta = -np.asarray(newton).reshape(n, -1).T
        iterations += len(idx)
        gnorm = np.max(np.abs(g), axis=1)
        finite = np.all(np.isfinite(delta), axis=1) & np.isfinite(gnorm)
        conv = finite & (gnorm <= opts.tol)
        done[idx[conv]] = True
        active[idx[conv | ~finite]] = False
        keep = finite & ~conv
        idx, delta, xs = idx[keep], delta[keep], x[idx[keep]]
        if not len(idx):
            break
        if len(roots):
            e = xs[:, None, :] - roots[None, :, :]  # (m, k, n)
            d2 = np.maximum(np.sum(e * e, axis=2), 1e-300)
            w = -p * d2 ** (-p / 2 - 1) / (d2 ** (-p / 2) + sigma)  # d log(d^-p + sigma) / d(d^2) * 2
            grad_log_m = np.sum(w[:, :, None] * e, axis=1)
            denom = 1.0 - np.sum(grad_log_m * delta, axis=1)
            ok = np.abs(denom) > 1e-12
            delta = delta / np.where(ok, denom, 1.0)[:, None]
            active[idx[~ok]] = False
        # a step of at most step_cap (2-norm), and at most 90 % of the way to the lower bound
        norm = np.linalg.norm(delta, axis=1)
        scale = np.minimum(1.0, step_cap / np.maximum(norm, 1e-300))
        room = xs - lb
        with np.errstate(divide="ignore", invalid="ignore"):
            frac = np.where(delta < 0, 0.9 * room / -delta, np.inf)
        scale = np.minimum(scale, np.min(frac, axis=1))
        xs = xs + scale[:, None] * delta
        total = np.sum(xs, axis=1)
        left = (total > hi_total + 2 * math.pi) | ~np.all(np.isfinite(xs), axis=1)
        x[idx] = xs
        active[idx[left]] = False
    return x, done, iterations


#: Found equilibria one compiled round deflates (more: the rounds go on in NumPy, one kernel call per iteration).
ROUND_ROOTS = 16


def _round_function(model: Model, opts: EquilibriaOptions, sx: bool = False) -> "ca.Function":
    """One deflation round from one start: (start n, roots n x K, mask 1 x K, p, lb) -> (theta, |g|,
    iterations), ``opts.max_iter`` deflated Newton steps around the O(n) kernel (as
    :func:`_deflated_newton`; a converged start stops moving); a CasADi graph of ``max_iter`` calls
    of one step Function, so that its C code (and gcc's time) is that of one step. ``sx``: the step
    with the kernel inlined, scalar by scalar (what C runs fastest); else a graph of matrix
    operations around a call of the kernel (what CasADi's interpreter runs fastest)."""
    import casadi as ca

    def build():
        n, npar = model.n, len(model.parameters)
        kernel = newton_correction(model)
        sym = ca.SX.sym if sx else ca.MX.sym
        x = sym("theta", n)
        count = sym("iterations")
        roots = sym("roots", n, ROUND_ROOTS)
        mask = sym("mask", 1, ROUND_ROOTS)
        pv = sym("p", npar)
        low = sym("lb")
        cap = math.radians(opts.max_step_deg) / math.sqrt(n)
        p, sigma = opts.power, opts.shift
        g, step, _ = kernel(x, pv)
        gnorm = ca.mmax(ca.fabs(g))
        delta = -step
        e = ca.repmat(x, 1, ROUND_ROOTS) - roots
        d2 = ca.fmax(ca.sum1(e * e), 1e-300)
        w = mask * (-p * d2 ** (-p / 2 - 1)) / (d2 ** (-p / 2) + sigma)
        denom = 1 - ca.dot(ca.mtimes(e, w.T), delta)
        delta = delta / ca.if_else(ca.fabs(denom) > 1e-12, denom, 1.0)
        scale = ca.fmin(1.0, cap / ca.fmax(ca.norm_2(delta), 1e-300))
        frac = ca.if_else(delta < 0, 0.9 * (x - low) / ca.fmax(-delta, 1e-300), 1e300)
        scale = ca.fmin(scale, ca.mmin(frac))
        moving = gnorm > opts.tol
        one = ca.Function("esba_deflation_step", [x, count, roots, mask, pv, low], [ca.if_else(moving, x + scale * delta, x), count + moving])
        x0 = ca.MX.sym("theta", n)
        roots_mx = ca.MX.sym("roots", n, ROUND_ROOTS)
        mask_mx = ca.MX.sym("mask", 1, ROUND_ROOTS)
        pv_mx = ca.MX.sym("p", npar)
        low_mx = ca.MX.sym("lb")
        xs, active = x0, ca.MX(0)
        for _ in range(opts.max_iter):
            xs, active = one(xs, active, roots_mx, mask_mx, pv_mx, low_mx)
        g_end, _, _ = kernel(xs, pv_mx)
        return ca.Function("esba_deflation_round", [x0, roots_mx, mask_mx, pv_mx, low_mx], [xs, ca.mmax(ca.fabs(g_end)), active])

    return model.derived("deflation_round", build, settings=(*_round_settings(opts), sx), persist=False)


def _round_settings(opts: EquilibriaOptions) -> tuple:
    return (opts.max_iter, opts.max_step_deg, opts.power, opts.shift, opts.tol, ROUND_ROOTS)


def round_kernel(model: Model, opts: EquilibriaOptions) -> Kernel:
    """:func:`_round_function` with its inputs and outputs packed, compiled to C when a compiler is
    found (:class:`esba.solvers.native.Kernel`, cached on disk), as the kernels of a solve are
    (:func:`esba.solvers.newton.correction_kernel`): a start's round is then one C call of
    microseconds, where CasADi's interpreter takes hundreds."""
    mode = "auto" if model.n <= SOLVE_COMPILE_MAX_N else "never"
    return model.derived("deflation_round_kernel", lambda: Kernel(packed(_round_function(model, opts, sx=True)), mode, model.n, HOT_RUNS), settings=_round_settings(opts), persist=False)


def _compiled_round(model: Model, pv, starts: np.ndarray, roots: np.ndarray, lb: float, opts: EquilibriaOptions) -> tuple[np.ndarray, np.ndarray, int]:
    """:func:`_deflated_newton` with up to :data:`ROUND_ROOTS` roots: each start one call of
    :func:`round_kernel` (C), or every start in one call of the interpreted graph mapped over them."""
    m, n = starts.shape
    padded = np.zeros((n, ROUND_ROOTS))
    mask = np.zeros((1, ROUND_ROOTS))
    padded[:, : len(roots)] = np.asarray(roots).T if len(roots) else 0.0
    mask[0, : len(roots)] = 1.0
    kernel = round_kernel(model, opts)
    if not kernel.compiled:
        kernel.count(m)
    if kernel.compiled:
        z = np.concatenate([np.zeros(n), padded.ravel(order="F"), mask.ravel(), np.asarray(pv, dtype=float).ravel(), [lb]])
        out = np.empty((m, n + 2))
        for k in range(m):
            z[:n] = starts[k]
            out[k] = kernel.run(z)
        x, gnorm, active = out[:, :n], out[:, n], out[:, n + 1]
    else:
        fun = model.derived("deflation_round_map", lambda: _round_function(model, opts).map(m, "serial"), settings=(*_round_settings(opts), m), persist=False)
        x, gnorm, active = fun(starts.T, padded, mask, pv, lb)
        x = np.asarray(x).reshape(n, m).T
        gnorm = np.asarray(gnorm).ravel()
    done = np.isfinite(gnorm) & (gnorm <= opts.tol) & np.all(np.isfinite(x), axis=1)
    return x, done, int(np.sum(np.asarray(active)))


def _known(theta: np.ndarray, thetas: list[np.ndarray], distinct: float) -> bool:
    return any(float(np.max(np.abs(theta - t))) <= distinct for t in thetas)


def _rounds(model, kernel, pv, starts, found: _Found, label: str, lb: float, hi_total: float, opts: EquilibriaOptions) -> int:
    """Deflation rounds from ``starts`` until one finds nothing new; returns the number found."""
    new_total = 0
    for r in range(opts.max_rounds):
        roots = np.array(found.thetas) if found.thetas else np.zeros((0, starts.shape[1]))
        if len(roots) <= ROUND_ROOTS:
            x, done, its = _compiled_round(model, pv, starts, roots, lb, opts)
        else:
            x, done, its = _deflated_newton(kernel, pv, starts, roots, lb, hi_total, opts)
        found.rounds += 1
        found.runs += len(starts)
        found.iterations += its
        new = 0
        for k in np.flatnonzero(done):
            theta = x[k]
            if _known(theta, found.thetas, opts.distinct):
                continue
            found.thetas.append(theta.copy())
            found.labels.append(f"{label}, start {k}, round {r + 1}")
            new += 1
        new_total += new
        if not new:
            break
    return new_total


def _first_starts(n: int, lb: float, hi_total: float, count: int, extra: Sequence[np.ndarray]) -> np.ndarray:
    """The method's own starts: the extra states given, theta = 0, and constant curvature over the domain."""
    totals = np.linspace(0.95 * n * lb, hi_total, count)
    rows = [np.asarray(e, dtype=float) for e in extra] + [np.zeros(n)] + [np.full(n, t / n) for t in totals]
    return np.array(rows)


def _fresh_starts(n: int, lb: float, hi_total: float, count: int) -> np.ndarray:
    """The completeness check's starts: constant curvature half-way between the first ones, and
    curvature growing towards the tip or towards the base over the same total bends."""
    totals = np.linspace(0.95 * n * lb, hi_total, count)
    mids = 0.5 * (totals[1:] + totals[:-1])
    ramp = np.arange(1, n + 1, dtype=float)
    ramp = ramp / ramp.sum()
    rows = [np.full(n, t / n) for t in mids]
    if n > 1:
        for t in totals:
            for w in (ramp, ramp[::-1]):
                row = t * w
                if np.all(row > lb):
                    rows.append(row)
    return np.array(rows)


def _polish(model: Model, pv, theta: np.ndarray, steps: int = 3) -> np.ndarray:
    """A few plain Newton steps (the search stops at ``tol``; this takes it to round-off)."""
    kernel = correction_kernel(model)
    n = len(theta)
    z = np.concatenate([theta, np.asarray(pv, dtype=float).ravel()])
    for _ in range(steps):
        step = kernel.run(z)[n : 2 * n]
        if not np.all(np.isfinite(step)):
            break
        z[:n] -= step
    return z[:n].copy()


def _state(model: Model, pv: np.ndarray, theta: np.ndarray, critical_tol: float, found: str, scene: Scene, pressure: float) -> State:
    st = compiled_state(model, theta, pv)
    return state_of(theta, st["tip"], st["energy"], np.sort(np.linalg.eigvalsh(st["hessian"])), float(np.max(np.abs(st["gradient"]))), critical_tol, found,
                    assess(scene, theta, pressure, np.asarray(st["tip"], dtype=float)))


def state_of(theta: np.ndarray, tip: np.ndarray, energy: float, eigenvalues: np.ndarray, gradient_norm: float, critical_tol: float, found: str,
             validity: tuple = ()) -> State:
    """A :class:`State` from what is known at an equilibrium (its tip pose, energy, ascending Hessian
    eigenvalues and max |dU/dtheta|, and where it leaves the model's domain): its stability and Morse index."""
    eig = np.asarray(eigenvalues, dtype=float)
    verdict = stability_verdict(eig, critical_tol)
    scale = max(float(np.max(np.abs(eig))), 1e-300)
    index = int(np.sum(eig < -critical_tol * scale))
    tip = np.asarray(tip, dtype=float)
    return State(np.asarray(theta, dtype=float), tip[:2].copy(), float(tip[2]), float(energy), eig, index, verdict, float(gradient_norm), found, tuple(validity))


def _descend(model: Model, pv: np.ndarray, theta: np.ndarray, lb: float, tol: float, max_iter: int = 300) -> np.ndarray | None:
    """Steepest descent on U to a minimum: saddle-free Newton steps (|H|^-1 g) with an Armijo line search."""
    x = theta.copy()
    for _ in range(max_iter):
        st = compiled_state(model, x, pv)
        g, h, u = st["gradient"], st["hessian"], st["energy"]
        lam, vec = np.linalg.eigh(h)
        big = max(float(np.max(np.abs(lam))), 1e-300)
        if lam[0] > 0 and float(np.max(np.abs(g))) <= 1e-4:
            # in the minimum's basin: plain Newton to round-off (an energy line search cannot
            # resolve the last digits of the gradient)
            for _ in range(6):
                x = x - np.linalg.solve(model.hessian(x, pv), model.gradient(x, pv))
            return x if float(np.max(np.abs(model.gradient(x, pv)))) <= max(tol, 1e-9) and np.all(x > lb) else None
        d = -vec @ ((vec.T @ g) / np.maximum(np.abs(lam), 1e-6 * big))
        norm = float(np.linalg.norm(d))
        cap = 0.2 / math.sqrt(len(x))
        if norm > cap:
            d *= cap / norm
        t = 1.0
        slope = float(g @ d)
        while t > 1e-12:
            y = x + t * d
            if np.all(y > lb) and model.energy(y, pv) <= u + 1e-4 * t * slope:
                break
            t *= 0.5
        else:
            return None
        x = y
    return None


def _connections(model, pv, states: list[State], lb: float, opts: EquilibriaOptions) -> tuple[Barrier, ...]:
    """For each index-1 saddle, the stable states down each side of its unstable mode; the lowest
    saddle for each joined pair."""
    stable = [k for k, s in enumerate(states) if s.stable]
    best: dict[tuple[int, int], Barrier] = {}
    for k, s in enumerate(states):
        if s.morse_index != 1:
            continue
        h = model.hessian(s.theta, pv)
        _, vec = np.linalg.eigh(h)
        v = vec[:, 0]
        ends = []
        for sign in (1.0, -1.0):
            x = _descend(model, pv, s.theta + sign * 1e-3 * v / max(float(np.max(np.abs(v))), 1e-300), lb, opts.tol)
            hit = None
            if x is not None:
                for j in stable:
                    if float(np.max(np.abs(states[j].theta - x))) <= 1e-4:
                        hit = j
                        break
            ends.append(hit)
        a, b = ends
        if a is None or b is None or a == b:
            continue
        a, b = min(a, b), max(a, b)
        bar = Barrier(a, b, k, s.energy - states[a].energy, s.energy - states[b].energy)
        if (a, b) not in best or s.energy < states[best[(a, b)].saddle].energy:
            best[(a, b)] = bar
    return tuple(best[key] for key in sorted(best))


def _domain(scene: Scene, model: Model, full: dict[str, float], opts: EquilibriaOptions) -> tuple[float, float, float]:
    lb = float(model.lower_bounds(full)[0])
    return lb, model.n * lb, math.radians(opts.max_bend_deg)


def search(
    scene: Scene,
    pressure: float,
    options: EquilibriaOptions,
    theta_starts: Sequence[np.ndarray] = (),
    model: Model | None = None,
    reached: np.ndarray | None = None,
    known_equilibrium: bool = False,
    known_state: State | None = None,
) -> Equilibria:
    """The search of :func:`equilibria` at a given pressure, from the method's starts, ``theta_starts``
    and ``reached``, the state a load history reached (:func:`equilibria` traces the default one,
    ``solve`` passes the state its history reached); ``history_state`` indexes it. With
    ``known_equilibrium`` (``reached`` is a certified equilibrium) it is deflated from the first
    round instead of being a start, and ``known_state``, its :class:`State` when the caller has it
    (a solve's certified result), is not evaluated again."""
    t0 = time.perf_counter()
    model = scene.model() if model is None else model
    n = model.n
    full = scene.parameters(pressure)
    pv = model.param_vector(full)
    lb, lo_total, hi_total = _domain(scene, model, full, options)
    kernel = newton_correction(model)
    known = reached is not None and known_equilibrium
    extra = ([] if reached is None or known else [np.asarray(reached, dtype=float).ravel()]) + [np.asarray(t, dtype=float).ravel() for t in theta_starts]
    starts = _first_starts(n, lb, hi_total, options.starts, extra)
    found = _Found([], [])
    if known:  # deflate it from the start (not a start itself): the search looks for the others
        found.thetas.append(np.asarray(reached, dtype=float).ravel().copy())
        found.labels.append("the load history's state")
    _rounds(model, kernel, pv, starts, found, "first search", lb, hi_total, options)
    check_found = 0
    complete: bool | None = None
    if options.check:
        before = len(found.thetas)
        _rounds(model, kernel, pv, _fresh_starts(n, lb, hi_total, options.starts), found, "completeness check", lb, hi_total, options)
        check_found = sum(1 for t in found.thetas[before:] if float(np.sum(t)) <= hi_total + 1e-9)  # new, in the domain
        complete = check_found == 0
    states = []
    outside = 0
    for k, (theta, label) in enumerate(zip(found.thetas, found.labels)):
        if k == 0 and known and known_state is not None:
            states.append(known_state)
            continue
        theta = _polish(model, pv, theta)
        total = float(np.sum(theta))
        if total > hi_total + 1e-9 or np.any(theta <= lb):
            outside += 1
            continue
        states.append(_state(model, pv, theta, options.critical_tol, label, scene, pressure))
    # by energy to 1e-6 N mm, then by total bend: two states whose energies differ by round-off
    # (a symmetric pair) come in the same order on every machine
    states.sort(key=lambda s: (round(s.energy, 6), round(s.total_angle_deg, 6)))
    # polishing may merge two that the search told apart only at its tolerance
    unique: list[State] = []
    for s in states:
        if not _known(s.theta, [u.theta for u in unique], options.distinct):
            unique.append(s)
    barriers = _connections(model, pv, unique, lb, options) if options.connect else ()
    res = Equilibria(
        scene=scene,
        pressure=pressure,
        states=tuple(unique),
        barriers=barriers,
        domain={"lower_bound_deg": math.degrees(lb), "total_bend_deg": [math.degrees(lo_total), math.degrees(hi_total)]},
        complete=complete,
        check_found=check_found,
        starts=len(starts),
        rounds=found.rounds,
        runs=found.runs,
        iterations=found.iterations,
        outside=outside,
        time_s=time.perf_counter() - t0,
    )
    return res if reached is None else _with_history(res, res.index(reached))


@single_threaded
def equilibria(scene: Scene, options: EquilibriaOptions | None = None, theta_starts: Sequence[Sequence[float]] | None = None) -> Equilibria:
    """Every equilibrium of ``scene`` in the model's domain, by deflated Newton (see the module).

    Parameters
    ----------
    scene : Scene
        The scene (its pressure, or the pressure of its target angle).
    options : EquilibriaOptions, optional
        The search's settings.
    theta_starts : sequence of arrays, optional
        More start states (rad), besides the method's own.

    Returns
    -------
    Equilibria
        The states sorted by energy, the barriers, the domain searched and whether the
        completeness check found anything new. ``history_state`` indexes the state that the
        default load history (inflate, then load) reaches, when ``options.history``.
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"scene={scene!r}: expected an esba.model.scene.Scene")
    options = DEFAULT_OPTIONS if options is None else options
    if not isinstance(options, EquilibriaOptions):
        raise EquilibriaOptionsError(f"options={options!r}: expected an EquilibriaOptions")
    model = scene.model()
    n = model.n
    extra = []
    for k, t in enumerate(theta_starts or ()):
        try:
            arr = np.asarray(t, dtype=float).ravel()
        except (TypeError, ValueError):
            raise EquilibriaOptionsError(f"theta_starts[{k}]={t!r}: expected {n} finite angles (rad)") from None
        if arr.shape != (n,) or not np.all(np.isfinite(arr)):
            raise EquilibriaOptionsError(f"theta_starts[{k}] has shape {arr.shape}: expected {n} finite angles (rad)")
        extra.append(arr)
    t0 = time.perf_counter()
    if scene.pressure is not None:
        pressure, unloaded = scene.pressure, None
    else:
        pressure = pressure_for_angle(scene)
        unloaded = np.full(n, math.radians(scene.target_angle_deg) / n)
    resolution.check_resolvable(scene, pressure, options.tol)  # scales the search cannot resolve: refused, as solve() does
    full = scene.parameters(pressure)
    pv = model.param_vector(full)
    reached = None
    if options.history:
        h = load_history(model, pressure, pv, unloaded)
        if not h.message:
            reached = h.theta
    starts = ([] if unloaded is None else [unloaded]) + extra
    res = search(scene, pressure, options, starts, model, reached)
    return _with_time(res, time.perf_counter() - t0)


def _with_history(res: Equilibria, index: int | None) -> Equilibria:
    return Equilibria(**{**res.__dict__, "history_state": index})


def _with_time(res: Equilibria, seconds: float) -> Equilibria:
    return Equilibria(**{**res.__dict__, "time_s": seconds})


# ---------------------------------------------------------------------------------------------
# the check that solve() makes

#: The search ``solve`` makes by default: fewer starts and iterations than :func:`equilibria`, no
#: completeness check, no barriers, no history of its own (the state it reached is deflated from
#: the first round); each start's round is one C call of microseconds once hot (docs/performance.md).
SOLVE_CHECK = EquilibriaOptions(starts=9, max_iter=15, history=False, check=False, connect=False)
#: ``multistability="auto"`` checks up to this many segments: beyond it the search costs
#: several solves (docs/performance.md, the solve benchmark's "multistability check" rows).
AUTO_MAX_SEGMENTS = 8
#: The values of ``SolverOptions.multistability``.
MULTISTABILITY = ("auto", "always", "never")


@dataclass(frozen=True, eq=False)
class Multistability:
    """What ``solve`` found about the other stable states of its scene.

    Attributes
    ----------
    looked : bool
        The search ran.
    stable : tuple of State
        Every stable state found (least energy first), the one reached among them.
    reached : int or None
        Index in ``stable`` of the state the history reached (None: not among them).
    message : str
        One line: whether the scene is multistable, which state the history reached and why,
        and the others; or why the search did not run.
    search_time_s : float
    """

    looked: bool
    stable: tuple[State, ...] = ()
    reached: int | None = None
    message: str = ""
    search_time_s: float = 0.0

    @property
    def multistable(self) -> bool | None:
        """True or False when looked, None when not."""
        return len(self.stable) > 1 if self.looked else None

    @property
    def others(self) -> tuple[State, ...]:
        """The stable states other than the one reached."""
        return tuple(s for k, s in enumerate(self.stable) if k != self.reached)

    def to_dict(self) -> dict[str, Any]:
        return {
            "looked": self.looked,
            "multistable": self.multistable,
            "message": self.message,
            "warning": self.message if self.multistable else "",
            "stable_states": [s.to_dict() for s in self.stable],
            "reached": self.reached,
            "other_stable_states": [
                {"theta_deg": s.theta_deg, "total_angle_deg": s.total_angle_deg, "energy_nmm": s.energy, "tip_mm": [float(s.tip[0]), float(s.tip[1])]}
                for s in self.others
            ],
            "search_time_s": self.search_time_s,
        }


def not_looked(why: str) -> Multistability:
    """A :class:`Multistability` that says why the search did not run."""
    return Multistability(False, message=f"not checked for other stable states: {why}")


def check_multistability(scene: Scene, model: Model, pressure: float, reached: np.ndarray, history: str, why: str, known_state: State | None = None) -> Multistability:
    """The :data:`SOLVE_CHECK` search around a solve's result, and the one line that says what it found.

    ``history`` names the load history, ``why`` says why it reached ``reached`` (it followed one
    branch, it snapped at a fold); ``known_state`` is its :class:`State` when the caller has it.
    """
    res = search(scene, pressure, SOLVE_CHECK, (), model, reached, known_equilibrium=True, known_state=known_state)
    stable = res.stable
    k = None
    for j, s in enumerate(stable):
        if float(np.max(np.abs(s.theta - reached))) <= 1e-4:
            k = j
    if len(stable) <= 1:
        message = f"one stable state in the search ({res.describe_domain()})"
        return Multistability(True, stable, k, message, res.time_s)
    here = stable[k] if k is not None else None
    if here is None:
        head = f"multistable: {len(stable)} stable states, and the load history ({history}) reached none of them"
    else:
        least = "the least energy" if k == 0 else f"not the least energy ({stable[0].energy:.4g} N mm)"
        head = (
            f"multistable: {len(stable)} stable states; the load history ({history}) reached {here.total_angle_deg:.2f} deg "
            f"(U = {here.energy:.4g} N mm, {least}) because {why}"
        )
    others = "; ".join(f"{s.total_angle_deg:.2f} deg (U = {s.energy:.4g} N mm)" for j, s in enumerate(stable) if j != k)
    return Multistability(True, stable, k, f"{head}; other stable states: {others}", res.time_s)

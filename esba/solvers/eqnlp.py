"""Equilibrium-constrained NLPs: the one builder the design optimisation and the fit share.

Both :mod:`esba.design.nlp` (the stiffest chamber) and :mod:`esba.calibration.fit` (parameters from
measurements) solve full-space problems: the unknowns are some parameters *and* the segment
angles of every equilibrium state involved, and each state is held to equilibrium by equality
constraints on the generated gradient,

    dU/dtheta(theta_k; parameters) = 0        (n constraints per state k),

with the model's domain (Eq. 10: the square root and its denominator) as inequalities where a
state may approach it. IPOPT gets CasADi's dict ``{"x", "f", "g", "p"}``; CasADi differentiates
the generated gradient once more, so the Hessian of the Lagrangian is exact. ``p`` carries data
that changes between solves of the same structure (a fit's measured values), so one solver
serves many data sets.

:class:`EquilibriumNLP` collects named variable blocks (with bounds), NLP parameters, named
constraints (with units and whether their multipliers are worth reporting) and equilibrium
states; :meth:`EquilibriumNLP.build` returns a :class:`BuiltNLP` with the IPOPT solver, the
layout, and helpers to start, read and report a solution (:class:`ActiveConstraint`).
:func:`model_gradient` evaluates a generated model's gradient on symbolic parameters. (The closed-form pressure of a uniform unloaded bend, for states whose pressure is set by a target
angle, is :func:`esba.model.closed_form.unloaded_pressure`.)

Examples
--------
The unloaded Table 1 actuator bent to 90 degrees: find the pressure as a variable.

>>> import math
>>> from esba.model.generated import load_model
>>> m = load_model(3, "air,axial,radial,fibres")
>>> b = EquilibriumNLP("example")
>>> theta = b.variable("theta", 3)
>>> P = b.variable("P", lb=0.0)
>>> values = dict(L=135.0, r1=8.0, r2=3.0, d=4.0, rho=math.radians(10.0), E=0.54, P=P)
>>> b.equilibrium(model_gradient(m, theta, values), "unloaded")
>>> b.constraint(theta[0] + theta[1] + theta[2] - math.pi / 2, "angle", "total angle 90 deg", "rad", 0.0, 0.0)
>>> nlp = b.build(P)
>>> sol = nlp.solve(nlp.x0(theta=[0.5, 0.5, 0.5], P=0.1))
>>> sol.success, round(float(sol["P"][0]), 7)
(True, 0.1238739)
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import casadi as ca
import numpy as np

from esba.model.generated import Model

__all__ = [
    "Constraint",
    "ActiveConstraint",
    "EquilibriumNLP",
    "BuiltNLP",
    "NLPSolution",
    "model_gradient",
    "DOMAIN_MARGIN",
]

#: Relative margin of the domain inequalities of Eq. (10) (as ratios that must stay >= margin).
DOMAIN_MARGIN = 1e-6

#: IPOPT settings every equilibrium-constrained NLP gets (silent; no timing printout).
_BASE_OPTIONS = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes"}


@dataclass(frozen=True)
class Constraint:
    """One row block of g: ``lb <= expr <= ub``, named so that a result can say which holds.

    Attributes
    ----------
    name : str
        Short identifier (``equilibrium_loaded[2]``, ``wall``, ...).
    description : str
        The constraint in words.
    unit : str
        Unit of the expression.
    lb, ub : float
        Bounds (equal for an equality).
    shown : bool
        An inequality shown, with its multiplier, when it is active.
    """

    name: str
    description: str
    unit: str
    lb: float
    ub: float
    shown: bool = False


@dataclass(frozen=True)
class ActiveConstraint:
    """One constraint or bound that holds at a solution.

    Attributes
    ----------
    name : str
        The constraint's or bound's name (e.g. ``d_min`` for d >= 0, ``wall``, ``min_stiffness``,
        ``max_pressure``, ``domain_sqrt[i]``, ``domain_denominator[i]``).
    description : str
        The constraint in words.
    value : float
        The constrained quantity at the solution (in ``unit``).
    bound : float
        Its bound (in ``unit``).
    unit : str
    multiplier : float or None
        IPOPT's multiplier (CasADi's sign convention: > 0 at an upper bound, < 0 at a lower one),
        for the NLP as scaled; None where no multiplier exists (a swarm's result).
    sensitivity : float or None
        d(objective*) / d(bound), in the objective's unit per ``unit``: what moving the bound by
        one unit would change the optimum by (first order). None without a multiplier.
    """

    name: str
    description: str
    value: float
    bound: float
    unit: str
    multiplier: float | None
    sensitivity: float | None

    def to_dict(self) -> dict:
        """JSON-ready form."""
        return dataclasses.asdict(self)


def model_gradient(model: Model, theta: Any, values: Mapping[str, Any]) -> Any:
    """dU/dtheta of a generated model at symbolic (or numeric) angles and parameters.

    Parameters
    ----------
    model : Model
        The generated model.
    theta : casadi.SX
        The n segment angles (rad).
    values : mapping
        Every name in ``model.parameters`` to a number or a CasADi expression (radians for
        ``rho`` and ``Omega_k``).
    """
    missing = [k for k in model.parameters if k not in values]
    if missing:
        raise KeyError(f"model {model.path.name} needs parameters {missing}")
    return model["gradient"](theta, *[values[k] for k in model.parameters])


@dataclass(frozen=True, eq=False)
class NLPSolution:
    """IPOPT's answer: the variables by name, g, the multipliers and the solver's statistics."""

    x: np.ndarray
    f: float
    g: np.ndarray
    lam_g: np.ndarray
    lam_x: np.ndarray
    success: bool
    status: str
    iterations: int
    slices: Mapping[str, slice]

    def __getitem__(self, name: str) -> np.ndarray:
        """The values of the variable block ``name``."""
        return self.x[self.slices[name]]


class EquilibriumNLP:
    """Builder of one equilibrium-constrained NLP; :meth:`build` makes the IPOPT solver.

    Parameters
    ----------
    name : str
        Name of the CasADi solver (``esba_design``, ``esba_fit``, ...).
    """

    def __init__(self, name: str):
        self.name = name
        self._blocks: list[tuple[str, Any, np.ndarray, np.ndarray]] = []
        self._params: list[tuple[str, Any]] = []
        self._g: list[Any] = []
        self._constraints: list[Constraint] = []
        self._bound_names: dict[tuple[str, str], tuple[str, str, str]] = {}

    def variable(
        self,
        name: str,
        size: int = 1,
        lb: float | Sequence[float] = -math.inf,
        ub: float | Sequence[float] = math.inf,
        *,
        lower: tuple[str, str, str] | None = None,
        upper: tuple[str, str, str] | None = None,
    ) -> Any:
        """A block of ``size`` variables (a CasADi SX column) with bounds.

        ``lower`` / ``upper`` name a scalar variable's bounds, shown when active: (name, description,
        unit), e.g. ``("d_min", "d >= 0 mm", "mm")``.
        """
        if any(b[0] == name for b in self._blocks):
            raise ValueError(f"variable {name!r} is defined twice")
        sym = ca.SX.sym(name, size)
        self._blocks.append((name, sym, np.broadcast_to(np.asarray(lb, dtype=float), (size,)).copy(),
                             np.broadcast_to(np.asarray(ub, dtype=float), (size,)).copy()))
        if lower is not None:
            self._bound_names[(name, "lower")] = lower
        if upper is not None:
            self._bound_names[(name, "upper")] = upper
        return sym

    def parameter(self, name: str, size: int = 1) -> Any:
        """A block of NLP parameters (CasADi's ``p``): data given at each solve."""
        sym = ca.SX.sym(name, size)
        self._params.append((name, sym))
        return sym

    def constraint(self, expr: Any, name: str, description: str, unit: str, lb: float, ub: float, shown: bool = False) -> None:
        """Add ``lb <= expr <= ub`` (a scalar expression)."""
        self._g.append(expr)
        self._constraints.append(Constraint(name, description, unit, float(lb), float(ub), shown))

    def equilibrium(self, gradient: Any, label: str) -> None:
        """Hold a state to equilibrium: every entry of its gradient (N mm/rad) equal to 0."""
        for i in range(gradient.shape[0]):
            self.constraint(gradient[i], f"equilibrium_{label}[{i}]", f"dU/dtheta_{i + 1} = 0 ({label})", "N mm/rad", 0.0, 0.0)

    def domain(self, theta: Any, L: Any, r1: Any, r2: Any, d: Any, label: str, margin: float = DOMAIN_MARGIN) -> None:
        """Keep a state inside the model's domain, Eq. (10), as ratios >= ``margin``.

        L r2^2 + n r1^3 theta_i >= 0 (the square root) and L + n (r1 + d) theta_i > 0 (its
        denominator), each divided by its value at theta_i = 0.
        """
        n = theta.shape[0]
        for i in range(n):
            th = theta[i]
            self.constraint(1.0 + n * r1**3 * th / (L * r2**2), f"domain_sqrt[{i}]",
                            f"Eq. (10) square root of segment {i + 1} ({label}) >= 0", "1", margin, math.inf, True)
            self.constraint(1.0 + n * (r1 + d) * th / L, f"domain_denominator[{i}]",
                            f"Eq. (10) denominator of segment {i + 1} ({label}) > 0", "1", margin, math.inf, True)

    def build(self, objective: Any, solver_options: Mapping[str, Any] | None = None) -> BuiltNLP:
        """The NLP ``{"x", "f", "g", "p"}`` with its IPOPT solver (``solver_options`` add to silent defaults)."""
        t0 = time.perf_counter()
        slices, k = {}, 0
        for name, sym, _, _ in self._blocks:
            slices[name] = slice(k, k + sym.shape[0])
            k += sym.shape[0]
        x = ca.vertcat(*[b[1] for b in self._blocks])
        p = ca.vertcat(*[s for _, s in self._params]) if self._params else ca.SX(0, 1)
        nlp = {"x": x, "f": objective, "g": ca.vertcat(*self._g), "p": p}
        opts = dict(_BASE_OPTIONS)
        opts.update(solver_options or {})
        solver = ca.nlpsol(self.name, "ipopt", nlp, opts)
        return BuiltNLP(
            nlp=nlp,
            solver=solver,
            slices=slices,
            lbx=np.concatenate([b[2] for b in self._blocks]),
            ubx=np.concatenate([b[3] for b in self._blocks]),
            lbg=np.array([c.lb for c in self._constraints]),
            ubg=np.array([c.ub for c in self._constraints]),
            constraints=tuple(self._constraints),
            bound_names=dict(self._bound_names),
            parameters=tuple((name, s.shape[0]) for name, s in self._params),
            build_time=time.perf_counter() - t0,
        )


@dataclass(frozen=True, eq=False)
class BuiltNLP:
    """An equilibrium-constrained NLP ready to solve (see :class:`EquilibriumNLP`).

    Attributes
    ----------
    nlp : dict
        CasADi's ``{"x", "f", "g", "p"}``.
    solver : casadi.Function
        IPOPT (``casadi.nlpsol``).
    slices : dict
        Each variable block's slice of x.
    lbx, ubx, lbg, ubg : ndarray
        Bounds of x and g.
    constraints : tuple of Constraint
        One per row of g.
    bound_names : dict
        (variable, "lower" | "upper") -> (name, description, unit) for the bounds shown when active.
    parameters : tuple of (str, int)
        The blocks of p, in order.
    build_time : float
        Seconds to build the solver.
    """

    nlp: dict
    solver: Any
    slices: Mapping[str, slice]
    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray
    constraints: tuple[Constraint, ...]
    bound_names: Mapping[tuple[str, str], tuple[str, str, str]]
    parameters: tuple[tuple[str, int], ...]
    build_time: float

    def x0(self, **values: Any) -> np.ndarray:
        """A start vector from values by block name (blocks not given start at 0)."""
        z = np.zeros(self.lbx.size)
        for name, value in values.items():
            z[self.slices[name]] = value
        return z

    def p(self, **values: Any) -> np.ndarray:
        """The parameter vector from values by block name (every block needed)."""
        parts = []
        for name, size in self.parameters:
            if name not in values:
                raise KeyError(f"NLP parameter {name!r} missing")
            parts.append(np.broadcast_to(np.asarray(values[name], dtype=float), (size,)))
        return np.concatenate(parts) if parts else np.zeros(0)

    def solve(self, x0: np.ndarray, p: np.ndarray | None = None) -> NLPSolution:
        """Run IPOPT from ``x0`` (with parameters ``p``)."""
        args = {"x0": x0, "lbx": self.lbx, "ubx": self.ubx, "lbg": self.lbg, "ubg": self.ubg}
        if p is not None and len(p):
            args["p"] = p
        sol = self.solver(**args)
        stats = self.solver.stats()
        return NLPSolution(
            x=np.asarray(sol["x"], dtype=float).ravel(),
            f=float(sol["f"]),
            g=np.asarray(sol["g"], dtype=float).ravel(),
            lam_g=np.asarray(sol["lam_g"], dtype=float).ravel(),
            lam_x=np.asarray(sol["lam_x"], dtype=float).ravel(),
            success=bool(stats.get("success", False)),
            status=str(stats.get("return_status", "unknown")),
            iterations=int(stats.get("iter_count", 0)),
            slices=self.slices,
        )

    def active(self, z: np.ndarray, g: np.ndarray, lam_g: np.ndarray, lam_x: np.ndarray, tol: float, factor: float) -> tuple[ActiveConstraint, ...]:
        """The inequalities shown and the named bounds, at their bound, with multipliers.

        ``factor`` turns a multiplier into d(objective*)/d(bound) (for an objective minimised as
        sign * J / scale it is -sign * scale). A bound is active within ``tol`` times max(1, |bound|).
        """
        out = []

        def near(value, bound):
            return math.isfinite(bound) and abs(value - bound) <= tol * max(1.0, abs(bound))

        for c, value, lam in zip(self.constraints, g, lam_g):
            if not c.shown:
                continue
            for bound in (c.lb, c.ub):
                if near(value, bound):
                    out.append(ActiveConstraint(c.name, c.description, float(value), float(bound), c.unit, float(lam), float(factor * lam)))
        for var, s in self.slices.items():
            if s.stop - s.start != 1:
                continue
            value, lam = float(z[s][0]), float(lam_x[s][0])
            for kind, bound in (("lower", self.lbx[s][0]), ("upper", self.ubx[s][0])):
                if near(value, bound) and (var, kind) in self.bound_names:
                    name, desc, unit = self.bound_names[(var, kind)]
                    out.append(ActiveConstraint(name, desc, value, float(bound), unit, lam, float(factor * lam)))
        return tuple(out)

"""The design cases of ``docs/design.md``: every optimisation the page shows, run and returned as data.

:func:`design_cases` runs, for one segment count:

* the paper's problem (the stiffest chamber) and five constrained ones (a pressure budget, the
  largest free angle and the lowest pressure under a stiffness floor, minimum walls), each by IPOPT
  and by PSO from one run (:func:`esba.design.optimise.compare`);
* a request no design meets (a stiffness just above the best one) and a harder one (the lowest
  pressure for 30 N/m);
* the pressure/stiffness trade-off: the lowest 90 degree pressure for each stiffness floor (IPOPT);
* the designs along d = 0 (pressure, stiffness, free angle, and each energy term's curvature at the
  90 degree start) and the Table 1 design;
* the optimum against n = 1..6 (IPOPT).

:mod:`esba.pages.design` renders them; nothing here formats text.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from esba.solvers.pso import PSOOptions

from .optimise import (
    DEFAULT_DESIGN_OPTIONS,
    Comparison,
    DesignOptions,
    DesignProblem,
    DesignResult,
    Evaluation,
    compare,
    evaluate,
    free_angle,
    optimise_ipopt,
    term_curvatures,
)

__all__ = ["DesignCases", "design_cases", "MIN_STIFFNESS", "MAX_PRESSURE", "WALLS", "TRADE_OFF_STIFFNESS", "LINE_R2", "SEGMENTS"]

#: The stiffness floor (N/m), pressure budget (MPa) and minimum walls (mm) of the constrained cases.
MIN_STIFFNESS = 40.0
MAX_PRESSURE = 0.2
WALLS = (6.6, 5.8)
#: The stiffness floors of the trade-off, N/m (those below the best stiffness are solved).
TRADE_OFF_STIFFNESS = (20.0, 25.0, 30.0, 35.0, 40.0, 42.5, 44.0, 45.0)
#: The chamber radii along d = 0, mm (the optimum's r2 is added between 1 and 2).
LINE_R2 = (0.3, 0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0)
#: The segment counts of the optimum against n.
SEGMENTS = (1, 2, 3, 4, 5, 6)


@dataclass(frozen=True, eq=False)
class DesignCases:
    """What :func:`design_cases` ran.

    Attributes
    ----------
    segments : int
    options : DesignOptions
    pso_options : PSOOptions
    base : DesignProblem
        The paper's problem at ``segments``.
    runs : dict of str to Comparison
        IPOPT and PSO on each problem: ``paper``, ``max_pressure``, ``angle``, ``pressure``,
        ``wall_stiffness``, ``wall_angle``.
    infeasible, hard : Comparison
        A stiffness no design reaches; the lowest pressure for 30 N/m.
    trade_off : list of DesignResult
        The lowest 90 degree pressure for each floor of :data:`TRADE_OFF_STIFFNESS` below the best stiffness.
    line_r2 : ndarray
        The chamber radii along d = 0, mm.
    line : Evaluation
        Their 90 degree pressures and stiffnesses.
    line_angle : ndarray
        Their free bending angles at :data:`MAX_PRESSURE`, deg.
    line_terms : list of dict
        Each energy term's curvature at the 90 degree start, per segment (N mm/rad^2).
    table1 : Evaluation
        The Table 1 design.
    by_segments : list of DesignResult
        The optimum for each n of :data:`SEGMENTS`.
    """

    segments: int
    options: DesignOptions
    pso_options: PSOOptions
    base: DesignProblem
    runs: dict[str, Comparison]
    infeasible: Comparison
    hard: Comparison
    trade_off: list[DesignResult]
    line_r2: np.ndarray
    line: Evaluation
    line_angle: np.ndarray
    line_terms: list[dict[str, float]]
    table1: Evaluation
    by_segments: list[DesignResult]

    @property
    def best(self) -> DesignResult:
        """IPOPT's optimum of the paper's problem."""
        return self.runs["paper"].ipopt

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form of the optimisations (each :meth:`Comparison.to_dict` or :meth:`DesignResult.to_dict`)."""
        data: dict[str, Any] = {k: v.to_dict() for k, v in self.runs.items()}
        data["infeasible"] = self.infeasible.to_dict()
        data["hard"] = self.hard.to_dict()
        data["trade_off"] = [r.to_dict() for r in self.trade_off]
        data["by_segments"] = [r.to_dict() for r in self.by_segments]
        return data


def design_cases(
    segments: int = 3,
    options: DesignOptions | None = None,
    pso_options: PSOOptions | None = None,
    progress: Callable[[str], None] | None = None,
) -> DesignCases:
    """Run every design case of ``docs/design.md`` (a minute or two); ``progress`` hears of each group."""
    say = progress or (lambda msg: None)
    options = DEFAULT_DESIGN_OPTIONS if options is None else options
    pso_options = PSOOptions() if pso_options is None else pso_options
    base = DesignProblem(segments=segments)
    km, pm = MIN_STIFFNESS, MAX_PRESSURE
    say("IPOPT and PSO on every problem")
    runs = {
        "paper": compare(base, options, pso_options),
        "max_pressure": compare(base.replace(max_pressure=pm), options, pso_options),
        "angle": compare(base.replace(objective="angle", max_pressure=pm, min_stiffness=km), options, pso_options),
        "pressure": compare(base.replace(objective="pressure", min_stiffness=km), options, pso_options),
        "wall_stiffness": compare(base.replace(min_wall=WALLS[0]), options, pso_options),
        "wall_angle": compare(base.replace(objective="angle", max_pressure=pm, min_stiffness=km, min_wall=WALLS[1]), options, pso_options),
    }
    best = runs["paper"].ipopt
    say("an infeasible request")
    k_infeasible = 5.0 * math.ceil((best.stiffness_n_per_m + 1.0) / 5.0)
    infeasible = compare(base.replace(objective="pressure", min_stiffness=k_infeasible), options, pso_options)
    say("the pressure/stiffness trade-off")
    trade = [
        optimise_ipopt(base.replace(objective="pressure", min_stiffness=k), options) for k in TRADE_OFF_STIFFNESS if k < best.stiffness_n_per_m
    ]
    say("along d = 0 and at the Table 1 design")
    r2_line = np.array([*LINE_R2[:3], best.r2_mm, *LINE_R2[3:]])
    line = evaluate(base, r2_line, np.zeros_like(r2_line), options)
    line_angle = free_angle(base, r2_line, np.zeros_like(r2_line), pm, options)
    line_terms = [term_curvatures(base, float(v), 0.0) for v in r2_line]
    say("a harder case")
    hard = compare(base.replace(objective="pressure", min_stiffness=30.0), options, pso_options)
    table1 = evaluate(base, [base.actuator.r2], [base.actuator.d], options)
    say("the optimum against n")
    by_n = [optimise_ipopt(DesignProblem(segments=k), options) for k in SEGMENTS]
    return DesignCases(segments, options, pso_options, base, runs, infeasible, hard, trade, r2_line, line, line_angle, line_terms, table1, by_n)

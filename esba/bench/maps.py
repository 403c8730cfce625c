"""Benchmark of stability maps: tracing the fold curves against the brute-force grid they replace.

For each map of ``docs/maps.md`` (:data:`esba.analysis.map_cases.MAP_CASES`), in one run: the
time to find and trace its fold curves (:func:`esba.analysis.folds.fold_curves`: the seeding path
traces, the continuation of the extended system, the cusps and fold/branch-point meetings
located), its points per second, and the brute-force grid a map would otherwise be drawn from: the
stable states counted by a multistart Newton descent (:func:`esba.analysis.maps.stable_states`)
at each cell of a K x K grid, with how many of those cells the map's regions agree with.

``esba bench maps`` prints the table and writes the ``maps`` section of ``docs/performance.md``
(:mod:`esba.pages.performance` renders both).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from esba.analysis.folds import Plane, fold_curves
from esba.analysis.map_cases import MAP_CASES
from esba.analysis.maps import check_grid, stability_map

from .timing import median_time

__all__ = ["MapBenchRow", "maps_benchmark", "BRUTE_K"]

#: Cells per side of the brute-force grid.
BRUTE_K = 20


@dataclass(frozen=True)
class MapBenchRow:
    name: str
    curves: int
    points: int
    special: int
    trace_s: float
    brute_k: int
    brute_s: float
    agree: int
    near: int

    @property
    def points_per_s(self) -> float:
        return self.points / self.trace_s

    @property
    def cell_ms(self) -> float:
        return 1e3 * self.brute_s / self.brute_k**2

    @property
    def speedup(self) -> float:
        return self.brute_s / self.trace_s


def maps_benchmark(repeat: int = 3, k: int = BRUTE_K, progress: Callable[[str], None] | None = None) -> list[MapBenchRow]:
    """One row per map: fold-curve tracing (median of ``repeat``) against a k x k brute-force grid (once)."""
    say = progress or (lambda msg: None)
    rows = []
    for case in MAP_CASES:
        plane = Plane.from_scene(case.scene, case.x, case.y)
        curves = fold_curves(plane, case.xrange, case.yrange)  # warm: kernels built, models loaded
        trace_s = median_time(lambda: fold_curves(plane, case.xrange, case.yrange), repeat)
        smap = stability_map(plane, case.xrange, case.yrange, resolution=11, history_lines=0)
        grid = check_grid(smap, k)
        agree = sum(1 for c in grid.cells if c[2] == c[3])
        rows.append(
            MapBenchRow(
                case.name, len(curves), int(sum(len(c) for c in curves)), int(sum(len(c.special) for c in curves)),
                trace_s, k, grid.seconds, agree, int(np.sum([c[4] < grid.near for c in grid.cells])),
            )
        )
        say(case.name)
    return rows

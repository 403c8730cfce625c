"""The stability maps of ``docs/maps.md`` (the Table 1 actuator): this module computes, :mod:`esba.pages.maps` renders.

* (pressure, horizontal tip payload): the bistable window and the cusp where it opens;
* (payload direction Omega, payload magnitude) at the 90 degree pressure: the cusp and the branch
  point near 122.2 degrees;
* (pressure, Omega) under 2 N;

each with its grid check against brute force (:func:`esba.analysis.maps.check_grid`) and the
folds of ``docs/paths.md`` read off its curves (:func:`esba.analysis.folds.folds_at`). The design
plane (r2, d) is :func:`esba.design.envelope.design_plane`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from esba.model.scene import MAIN_JOB, Payload, Scene

from .folds import Plane, folds_at
from .maps import GridCheck, StabilityMap, check_grid, stability_map

__all__ = ["MapCase", "MAP_CASES", "MapCaseResult", "map_cases", "PATHS_PAYLOADS"]

#: Payloads (N) at which docs/paths.md gives the folds of the pressure path.
PATHS_PAYLOADS = (2.0, 2.5, 3.0)


@dataclass(frozen=True)
class MapCase:
    """One map: its name, scene, parameters and ranges, and a title."""

    name: str
    scene: Scene
    x: str
    xrange: tuple[float, float]
    y: str
    yrange: tuple[float, float]
    title: str
    command: str
    check: int = 8  # cells per side of its grid check


_LOADED_AT_ZERO = Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),))

MAP_CASES = (
    MapCase("pressure-payload", _LOADED_AT_ZERO, "pressure", (0.0, 0.3), "payload", (0.0, 4.0),
            "pressure and horizontal tip payload", "esba map --x pressure:0:0.3 --y payload:0:4 --pressure 0"),
    MapCase("omega-payload", MAIN_JOB, "omega", (110.0, 135.0), "payload", (0.0, 4.0),
            "payload direction and magnitude at the 90 deg pressure", "esba map --x omega:110:135 --y payload:0:4 --target-angle 90"),
    # the bistable band is a few kPa wide: a narrower pressure range and a finer check grid, so that cells fall in it
    MapCase("pressure-omega", _LOADED_AT_ZERO, "pressure", (0.05, 0.25), "omega", (60.0, 180.0),
            "pressure and payload direction under 2 N", "esba map --x pressure:0.05:0.25 --y omega:60:180 --pressure 0", 12),
)


@dataclass(frozen=True, eq=False)
class MapCaseResult:
    """A computed map case: the map, its grid check, and the folds along lines of docs/paths.md."""

    case: MapCase
    map: StabilityMap
    check: GridCheck
    lines: dict[str, Any]


def map_cases(progress: Callable[[str], None] | None = None) -> list[MapCaseResult]:
    """Compute every map of :data:`MAP_CASES` with its grid check (half a minute)."""
    say = progress or (lambda msg: None)
    out = []
    for case in MAP_CASES:
        say(f"map of {case.title}")
        plane = Plane.from_scene(case.scene, case.x, case.y)
        smap = stability_map(plane, case.xrange, case.yrange)
        say(f"  check on a {case.check} x {case.check} grid")
        grid = check_grid(smap, case.check)
        box = (case.xrange, case.yrange)
        lines: dict[str, Any] = {}
        if case.name == "pressure-payload":
            lines = {f: folds_at(plane, smap.curves, box, y=f) for f in PATHS_PAYLOADS}
        elif case.name == "omega-payload":
            lines = {2.0: folds_at(plane, smap.curves, box, y=2.0)}
        elif case.name == "pressure-omega":
            lines = {90.0: folds_at(plane, smap.curves, box, y=90.0)}
        out.append(MapCaseResult(case, smap, grid, lines))
    return out

"""The 3-D maps of ``docs/maps.md`` (the Table 1 actuator in space): this module computes,
:mod:`esba.pages.maps` renders.

* the gripper map: over (pressure, the payload's direction around the actuator) under a 0.5 N tip
  payload, with the eccentric section's stiffnesses (:func:`esba.model.section.section_stiffness`),
  where the finger stays in its plane, flips sideways or snaps, checked cell by cell against
  brute force (:func:`esba.analysis.maps3d.check_grid3d`);
* the pressure paths under horizontal tip payloads in 3-D: their folds, which for a section stiff
  out of the plane are the planar ones (to round-off), and, with the eccentric section, the branch
  points at which the in-plane state flips sideways first;
* the curves of those branch points in (pressure, payload), and the fold curve into which a payload
  tilted out of the plane unfolds them (:func:`esba.analysis.maps3d.curves3d`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from esba.model.scene import Payload, Scene

from .maps3d import Curves3D, GridCheck3D, Plane3D, StabilityMap3D, check_grid3d, curves3d, path_points, principal, stability_map3d

__all__ = ["GRIPPER", "STIFF_SECTION", "PATH_PAYLOADS", "Map3DCases", "map3d_cases", "CURVES_COMMAND", "TILTED_COMMAND", "CURVES_TILT"]

#: The gripper map: the scene, its ranges, raster and check grid.
GRIPPER_SCENE = Scene(pressure=0.0, payloads=(Payload(0.5, 90.0),))
GRIPPER = {"x": ("pressure", (0.05, 0.25)), "y": ("around", (0.0, 40.0)), "resolution": 13, "check": 4}
GRIPPER_COMMAND = "esba map --3d --x pressure:0.05:0.25 --y around:0:40 --payload 0.5 --pressure 0 --resolution 13 --history-lines 1 --check-grid 4"
#: A section stiff out of the plane (docs/3d.md: the finger stays in its plane to 4 N).
STIFF_SECTION = {"EI_side": 4e5, "GJ": 1e5}
#: Payloads (N) of the pressure paths (those of docs/maps.md's first map, and lighter ones).
PATH_PAYLOADS = (0.5, 1.0, 2.0, 2.5, 3.0)
PATH_RANGE = (0.05, 0.3)
#: The fold and branch-point curves: the horizontal payload in the plane (eccentric section), and
#: tilted out of the plane by CURVES_TILT degrees; the boxes and the commands that print them.
CURVES_BOX = ((0.05, 0.3), (0.2, 3.0))
CURVES_TILT = 15.0
TILTED_BOX = ((0.05, 0.3), (0.0, 3.0))
CURVES_COMMAND = "esba map --3d --x pressure:0.05:0.3 --y payload:0.2:3 --pressure 0 --payload 1 --fold-curves"
TILTED_COMMAND = "esba map --3d --x pressure:0.05:0.3 --y payload:0:3 --pressure 0 --payload 1 --payload-out-of-plane 15 --fold-curves"


@dataclass(frozen=True, eq=False)
class Map3DCases:
    """The gripper map and its check; the pressure paths' critical points, per payload, with the stiff
    section and with the eccentric one: {payload: [(direction, pressure, kind), ...]}."""

    gripper: StabilityMap3D
    check: GridCheck3D
    stiff: dict[float, list[tuple[str, float, str]]]
    eccentric: dict[float, list[tuple[str, float, str]]]
    section: dict[str, float]
    curves: Curves3D | None = None  # in the plane, eccentric section (CURVES_BOX)
    tilted: Curves3D | None = None  # tilted by CURVES_TILT (TILTED_BOX)


def _paths(plane: Plane3D) -> dict[float, list[tuple[str, float, str]]]:
    out: dict[float, list[tuple[str, float, str]]] = {}
    for f in PATH_PAYLOADS:
        found, _ = path_points(plane, PATH_RANGE, (f, f + 1.0), lines=1, axes=("x",))
        rows = [(p.direction, p.x, p.kind) for p in found]
        for direction, start in (("rising", PATH_RANGE[0]), ("falling", PATH_RANGE[1])):
            if not any(r[0] == direction for r in rows) and principal(plane, plane.values(start, f), f).critical <= f:
                rows.append((direction, start, "unstable at the start"))
        out[f] = sorted(rows, key=lambda t: t[1])
    return out


def map3d_cases(progress: Callable[[str], None] | None = None) -> Map3DCases:
    """Compute the 3-D cases of docs/maps.md (tens of seconds)."""
    say = progress or (lambda msg: None)
    say("3-D: the gripper map")
    (xn, xr), (yn, yr) = GRIPPER["x"], GRIPPER["y"]
    plane = Plane3D.from_scene(GRIPPER_SCENE, xn, yn)
    smap = stability_map3d(plane, xr, yr, resolution=GRIPPER["resolution"], lines=1)
    say(f"  check on a {GRIPPER['check']} x {GRIPPER['check']} grid")
    check = check_grid3d(smap, GRIPPER["check"])
    say("3-D: pressure paths")
    loaded = Scene(pressure=0.0, payloads=(Payload(1.0, 90.0),))
    stiff = _paths(Plane3D.from_scene(loaded, "pressure", "payload", STIFF_SECTION))
    ecc_plane = Plane3D.from_scene(loaded, "pressure", "payload")
    say("3-D: fold and branch-point curves")
    curves = curves3d(ecc_plane, *CURVES_BOX)
    tilted_scene = Scene(pressure=0.0, payloads=(Payload(1.0, 90.0, out_of_plane_deg=CURVES_TILT),))
    tilted = curves3d(Plane3D.from_scene(tilted_scene, "pressure", "payload"), *TILTED_BOX)
    return Map3DCases(smap, check, stiff, _paths(ecc_plane), dict(ecc_plane.section), curves, tilted)

"""``esba map --3d``: the 3-D stability map of two parameters (in plane, flips sideways, snaps; docs/maps.md)."""

from __future__ import annotations

import argparse
import json
import math
import sys

from esba.infra import outputs

from .arguments import UsageError, one_of, scene_from_args, with_json
from .results import EXIT_FAILED, EXIT_OK, print_result

#: Where ``esba map --3d`` writes its points and figure unless told otherwise (the current folder).
DEFAULT_MAP3D_OUT = "esba-map3d.csv"
DEFAULT_MAP3D_FIGURE = "esba-map3d.png"
#: The parameters of a 3-D map (``esba.analysis.maps3d.AXES3D``, written out so that building the
#: parser does not import CasADi; a test checks they agree).
MAP3D_PARAMETERS = ("pressure", "payload", "omega", "beta", "around", "at")
#: Defaults of the 3-D map where the planar map's would take too long.
DEFAULT_RESOLUTION_3D = 21
DEFAULT_LINES_3D = 5


def _csv(d: dict) -> str:
    nx, ny = d["x"]["parameter"], d["y"]["parameter"]
    rows = ["source,kind," + f"{nx},{ny},along,direction,total_angle_deg,twist_deg"]
    for p in d["path_points"]:
        rows.append(f"path,{p['kind']},{p[nx]!r},{p[ny]!r},{p['along']},{p['direction']},{p['total_angle_deg']!r},{p['twist_deg']!r}")
    for b in d["boundaries"]:
        rows.append(f"boundary,{b['kind']},{b[nx]!r},{b[ny]!r},{b['along']},,{b['total_angle_deg']!r},{b['twist_deg']!r}")
    for key, source in (("fold_curves", "fold curve"), ("branch_point_curves", "branch-point curve")):
        for c in d.get("curves", {}).get(key, []):
            kind = "fold" if key == "fold_curves" else "branch point"
            for p in c.get("curve", []):
                rows.append(f"{source} {c['index']},{kind},{p[nx]!r},{p[ny]!r},,,{p['total_angle_deg']!r},{p['twist_deg']!r}")
            for p in c["special_points"]:
                rows.append(f"{source} {c['index']},{p['kind']},{p[nx]!r},{p[ny]!r},,,{p['total_angle_deg']!r},{p['twist_deg']!r}")
    return "\n".join(rows) + "\n"


def cmd_map3d(args: argparse.Namespace) -> int:
    """The 3-D map (``args`` from ``esba map``'s parser; ``--x``/``--y`` already parsed)."""
    from .scenes import _section_arg

    for flag, v in (("--x", args.x), ("--y", args.y)):
        if v is None:
            raise UsageError(f"the following arguments are required: {flag} PARAM:FROM:TO")
        if v[0] not in MAP3D_PARAMETERS:
            raise UsageError(f"{flag} {v[0]}:{v[1]:g}:{v[2]:g}: with --3d the parameter is one of {', '.join(MAP3D_PARAMETERS)} (the scene's one payload)")
    one_of(args, ("out", "no_out"), ("plot", "no_plot"))
    with_json(args, "points")
    if args.max_twist is not None and not (math.isfinite(args.max_twist) and 0 < args.max_twist < 180):
        raise UsageError(f"--max-twist {args.max_twist:g}: expected an angle in (0, 180) degrees")
    out = None if args.no_out else outputs.check_file(DEFAULT_MAP3D_OUT if args.out is None else args.out, "--out", (".csv", ".json"))
    plot = None if args.no_plot else outputs.figure_file(DEFAULT_MAP3D_FIGURE if args.plot is None else args.plot, "--plot", DEFAULT_MAP3D_FIGURE)
    section = _section_arg(args.section)
    scene = scene_from_args(args)
    (xname, x0, x1), (yname, y0, y1) = args.x, args.y
    from esba.analysis.maps3d import DEFAULT_MAX_TWIST_DEG, Map3DError, Plane3D, check_grid3d, map3d_table, stability_map3d
    from esba.statics.spatial import SpatialError

    try:
        plane = Plane3D.from_scene(scene, xname, yname, section, DEFAULT_MAX_TWIST_DEG if args.max_twist is None else args.max_twist)
        plane.check_range("--x", xname, x0, x1)
        plane.check_range("--y", yname, y0, y1)
        if args.fold_curves:
            from esba.analysis.maps3d import curves_plane

            curves_plane(plane, (x0, x1), (y0, y1))
    except (Map3DError, SpatialError) as exc:
        raise UsageError(str(exc)) from None
    say = (lambda msg: None) if args.json else (lambda msg: print(f"  {msg}", file=sys.stderr))
    try:
        smap = stability_map3d(plane, (x0, x1), (y0, y1), resolution=args.resolution or DEFAULT_RESOLUTION_3D,
                               lines=DEFAULT_LINES_3D if args.history_lines is None else args.history_lines, progress=say,
                               curves=args.fold_curves)
        checked = check_grid3d(smap, args.check_grid) if args.check_grid else None
    except Map3DError as exc:
        raise UsageError(str(exc)) from None
    except RuntimeError as exc:
        print(f"esba: failed: {exc}", file=sys.stderr)
        return EXIT_FAILED
    data = smap.to_dict(raster=bool(args.json and args.points))
    data["scene"] = plane.describe()
    if checked is not None:
        data["check_grid"] = checked.to_dict()
    if out:
        full = smap.to_dict(raster=True)
        text = json.dumps(full, indent=1, allow_nan=False) if str(out).endswith(".json") else _csv(full)
        data["out"] = str(outputs.write_text(out, text).resolve())
    if plot:
        from esba.figures.maps3d import map3d_figure, save_figure

        data["figure"] = str(save_figure(map3d_figure(smap, plane.describe()), plot).resolve())
    print_result(args, data, map3d_table)
    if checked is not None and not checked.agrees:
        print(f"esba: the 3-D map disagrees with brute force in {checked.mismatches} cells away from a boundary "
              f"(the multistart missed the principal state in {checked.missed})", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def add_map3d_flags(p: argparse.ArgumentParser) -> None:
    """The flags ``esba map`` takes for its 3-D map."""
    from .arguments import float_arg

    p.add_argument("--3d", dest="three_d", action="store_true",
                   help="the 3-D map: over two of pressure, payload, omega, beta, around, at, where the finger stays in its plane, "
                        "flips sideways (branch point, sideways fold, twist beyond --max-twist) or snaps (fold) as its payload is raised (docs/maps.md)")
    p.add_argument("--section", action="append", metavar="NAME=VALUE", help="with --3d: section stiffness EI_side=..., GJ=... (N*mm^2; default the eccentric section's)")
    p.add_argument("--fold-curves", action="store_true",
                   help="with --3d: also continue the fold curves in the two parameters and, for a payload in the bending plane, the "
                        "curves of the branch points where the in-plane state flips sideways (not with around)")
    p.add_argument("--max-twist", type=float_arg, metavar="DEG", help="with --3d: the twist bound |sum tau| beyond which the finger counts as flipped (default 10)")

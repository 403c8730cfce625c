"""``esba map``: the stability map of two parameters (fold curves, cusps, regions by stable states)."""

from __future__ import annotations

import argparse
import math
import sys

from esba.infra import outputs

from .arguments import UsageError, add_scene_flags, count_arg, float_arg, one_of, scene_from_args, with_json, write_page
from .map3d import MAP3D_PARAMETERS
from .results import EXIT_FAILED, EXIT_OK, print_result

#: Where ``esba map`` writes its fold curves and figure unless told otherwise (the current folder).
DEFAULT_MAP_OUT = "esba-map.csv"
DEFAULT_MAP_FIGURE = "esba-map.png"

#: The parameters of a map (``esba.paths.problem.PARAMETERS``, written out so that building the
#: parser does not import CasADi; a test checks they agree). A payload's take its number (payload2).
_MAP_PARAMETERS = ("pressure", "payload", "omega", "at", "load", "r2", "d", "rho", "E", "L", "r1", "M")


#: Parameters only the 3-D map (``--3d``) has: the payload's angle out of the plane, and its direction around the actuator.
_MAP3D_ONLY = tuple(name for name in MAP3D_PARAMETERS if name not in _MAP_PARAMETERS)


def axis_arg(flag: str):
    """An argparse type: ``PARAM:FROM:TO`` with FROM < TO, finite."""

    def parse(text: str) -> tuple[str, float, float]:
        parts = text.split(":")
        allowed = (f"PARAM:FROM:TO with PARAM one of {', '.join(_MAP_PARAMETERS)} (a payload's with its number, e.g. omega2), "
                   f"with --3d one of {', '.join(MAP3D_PARAMETERS)}, and FROM < TO")
        if len(parts) != 3:
            raise argparse.ArgumentTypeError(f"{flag}={text!r}: expected {allowed}")
        name = parts[0].strip()
        base = name.rstrip("0123456789")
        if name not in _MAP_PARAMETERS and name not in _MAP3D_ONLY and not (base in ("payload", "omega", "at") and base != name):
            raise argparse.ArgumentTypeError(f"{flag}={text!r}: unknown parameter {name!r}; expected {allowed}")
        try:  # the number rule of every other flag (float_arg): no 1_10, no other scripts' digits, no subnormals
            lo, hi = float_arg(parts[1]), float_arg(parts[2])
        except argparse.ArgumentTypeError as exc:
            raise argparse.ArgumentTypeError(f"{flag}={text!r}: FROM and TO must be numbers ({exc}); expected {allowed}") from None
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise argparse.ArgumentTypeError(f"{flag}={text!r}: expected finite FROM < TO")
        return name, lo, hi

    return parse


def _map_write_doc(args: argparse.Namespace) -> int:
    """``esba map --write-doc FILE``: the maps of docs/maps.md (no other map flags)."""
    from esba.pages.maps import PAGE, MapsSettings

    write_page(args, "map", PAGE, MapsSettings, (("--x", args.x), ("--y", args.y), ("--out", args.out), ("--plot", args.plot),
                                                ("--check-grid", args.check_grid), ("SCENE.toml", args.scene),
                                                ("--3d", args.three_d or None), ("--section", args.section), ("--max-twist", args.max_twist),
                                                ("--fold-curves", args.fold_curves or None)))
    return EXIT_OK


def _cmd_map(args: argparse.Namespace) -> int:
    from esba.analysis.maps import map_table
    if args.write_doc:
        return _map_write_doc(args)
    if args.three_d:
        from .map3d import cmd_map3d

        return cmd_map3d(args)
    for flag, v in (("--section", args.section), ("--max-twist", args.max_twist)):
        if v is not None:
            raise UsageError(f"{flag} is for the 3-D map: give --3d")
    if args.fold_curves:
        raise UsageError("--fold-curves is for the 3-D map: give --3d (the planar map always traces its fold curves)")
    for flag, v in (("--x", args.x), ("--y", args.y)):
        if v is not None and v[0] in _MAP3D_ONLY:
            raise UsageError(f"{flag} {v[0]}:{v[1]:g}:{v[2]:g}: {v[0]} is a parameter of the 3-D map only: give --3d")
    for flag, v in (("--x", args.x), ("--y", args.y)):
        if v is None:
            raise UsageError(f"the following arguments are required: {flag} PARAM:FROM:TO")
    one_of(args, ("out", "no_out"), ("plot", "no_plot"))
    with_json(args, "points")
    out = None if args.no_out else outputs.check_file(DEFAULT_MAP_OUT if args.out is None else args.out, "--out", (".csv", ".json"))
    plot = None if args.no_plot else outputs.figure_file(DEFAULT_MAP_FIGURE if args.plot is None else args.plot, "--plot", DEFAULT_MAP_FIGURE)
    (xname, x0, x1), (yname, y0, y1) = args.x, args.y
    scene = scene_from_args(args)
    from esba.analysis.folds import Plane, check_box, write_fold_curves
    from esba.analysis.maps import check_grid, stability_map
    from esba.paths.problem import PathError
    from esba.statics.equilibrium import EquilibriumError

    try:
        plane = Plane.from_scene(scene, xname, yname)
        for name, lo, hi, prob in ((xname, x0, x1, plane.px), (yname, y0, y1, plane.py)):
            if not (prob.in_range(lo) and prob.in_range(hi)):
                raise UsageError(f"--{'x' if prob is plane.px else 'y'} {name}:{lo:g}:{hi:g}: outside the parameter's range {prob.domain[0]:.7g}..{prob.domain[1]:.7g}{prob.unit_short}")
        check_box(plane, ((x0, x1), (y0, y1)))
        say = (lambda msg: None) if args.json else (lambda msg: print(f"  {msg}", file=sys.stderr))
        smap = stability_map(plane, (x0, x1), (y0, y1), resolution=args.resolution or 201, history_lines=21 if args.history_lines is None else args.history_lines, progress=say)
        checked = check_grid(smap, args.check_grid) if args.check_grid else None
    except PathError as exc:
        raise UsageError(str(exc)) from None
    except EquilibriumError as exc:
        print(f"esba: failed: {exc}", file=sys.stderr)
        return EXIT_FAILED
    data = smap.to_dict(points=bool(args.json and args.points))
    data["scene"] = scene.describe()
    if checked is not None:
        data["check_grid"] = checked.to_dict()
    if out:
        extra = {k: v for k, v in smap.to_dict(points=False).items() if k != "fold_curves"}
        extra["scene"] = data["scene"]
        if checked is not None:
            extra["check_grid"] = data["check_grid"]
        data["out"] = str(write_fold_curves(smap.curves, out, extra).resolve())
    if plot:
        from esba.figures.maps import map_figure, save_figure

        data["figure"] = str(save_figure(map_figure(smap), plot).resolve())
    print_result(args, data, map_table)
    if checked is not None and not checked.agrees:
        print(f"esba: the map disagrees with brute force in {checked.mismatches} cells away from a fold curve", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def add_map(sub) -> None:
    p = sub.add_parser(
        "map",
        help="stability map of two parameters: fold curves, cusps, regions by number of stable states, jump lines (CSV/JSON, figure)",
    )
    add_scene_flags(p)
    p.add_argument("--x", type=axis_arg("--x"), metavar="PARAM:FROM:TO", help="the horizontal parameter and its range (e.g. omega:110:135; units as esba path)")
    p.add_argument("--y", type=axis_arg("--y"), metavar="PARAM:FROM:TO", help="the vertical parameter and its range (e.g. payload:0:4)")
    p.add_argument("--check-grid", type=count_arg("--check-grid", 1, 40, "K x K brute-force counts"), metavar="K", help="also count the stable states by brute force at the centres of a K x K grid and compare (exit 1 on a disagreement away from a fold curve)")
    p.add_argument("--resolution", type=count_arg("--resolution", 11, 1001, "raster of the regions"), default=None, metavar="N", help="the regions' raster, N x N (default 201; 21 with --3d)")
    p.add_argument("--history-lines", type=count_arg("--history-lines", 0, 201, "quasi-static histories"), default=None, metavar="N", help="values of y at which the history in x is followed up and down for the jump lines (default 21; 0: none); "
                   "with --3d: lines each way along which paths in x and in y find the folds and branch points (default 5)")
    p.add_argument("--out", metavar="FILE", help=f"the fold curves as CSV or JSON (default {DEFAULT_MAP_OUT})")
    p.add_argument("--no-out", action="store_true", help="write no fold-curve file")
    p.add_argument("--plot", metavar="FILE", help=f"the figure (default {DEFAULT_MAP_FIGURE})")
    p.add_argument("--no-plot", action="store_true", help="write no figure")
    p.add_argument("--points", action="store_true", help="with --json: print every point of the fold curves")
    p.add_argument("--write-doc", metavar="FILE", help="compute the maps of docs/maps.md (Table 1: three stability maps, the design plane, the 3-D gripper map and pressure paths; a few minutes) and write the page and its figures")
    from .map3d import add_map3d_flags

    add_map3d_flags(p)
    p.set_defaults(func=_cmd_map)

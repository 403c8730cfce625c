"""``esba path``: branches, special points, hysteresis."""

from __future__ import annotations

import argparse
import math
import sys

from esba.infra import outputs

from .arguments import (
    UsageError,
    add_scene_flags,
    count_arg,
    float_arg,
    one_of,
    scene_from_args,
    with_json,
    write_page,
)
from .results import EXIT_FAILED, EXIT_OK, print_result, warn_findings

#: Where ``esba path`` writes its branches and figure unless told otherwise (the current folder).
DEFAULT_PATH_OUT = "esba-path.csv"


DEFAULT_PATH_FIGURE = "esba-path.png"


#: The parameters of ``esba path --param`` (``esba.paths.problem.PARAMETERS``, written out so that
#: building the parser does not import CasADi; a test checks they agree).
_PATH_PARAMETERS = ("pressure", "payload", "omega", "at", "load", "r2", "d", "rho", "E", "L", "r1", "M")
#: The parameters only a 3-D path has (``esba path --3d``: esba.statics.spatial_paths.PARAMETERS_3D).
_PATH_PARAMETERS_3D_ONLY = ("beta",)


def _path_write_doc(args: argparse.Namespace) -> int:
    """``esba path --write-doc FILE``: every path case of docs/paths.md (no other path flags)."""
    from esba.pages.paths import PAGE, PathsSettings

    write_page(args, "path", PAGE, PathsSettings, (("--to", args.to), ("--from", args.start), ("--out", args.out), ("--plot", args.plot),
                                                  ("SCENE.toml", args.scene)))
    return EXIT_OK


#: Above this much memory for the branches' points, a path says so before it starts.
NOTE_BYTES = 256 * 1024**2


def _check_path_size(max_steps: int, n: int) -> None:
    """Bound a path up front as a sweep is bounded: refuse ``--max-steps`` whose branches could not
    fit in the batch path's memory limit; say what a large one may take."""
    from esba.paths.continuation import path_bytes
    from esba.statics.batch_options import MAX_BATCH_BYTES

    need = path_bytes(max_steps, n)
    if need > MAX_BATCH_BYTES:
        most = MAX_BATCH_BYTES // path_bytes(1, n)
        raise UsageError(
            f"--max-steps {max_steps} at n = {n}: the branches could hold about {need / 1024**3:.1f} GiB of points "
            f"(limit {MAX_BATCH_BYTES / 1024**3:g} GiB): at most {most} steps at this n"
        )
    if need > NOTE_BYTES:
        print(
            f"esba: note: --max-steps {max_steps} at n = {n}: up to {need / 1024**3:.1f} GiB of points and minutes of work "
            "if every branch takes them all (a smaller --max-steps bounds it; Ctrl-C stops it)",
            file=sys.stderr,
        )


def _cmd_path(args: argparse.Namespace) -> int:

    from esba.analysis.path_analysis import path_table
    if args.write_doc:
        return _path_write_doc(args)
    if args.to is None:
        raise UsageError("the following arguments are required: --to")
    if not math.isfinite(args.to):
        raise UsageError(f"--to {args.to!r}: expected the finite value of --param to trace to")
    one_of(args, ("out", "no_out"), ("plot", "no_plot"))
    with_json(args, "points")
    out = None if args.no_out else outputs.check_file(DEFAULT_PATH_OUT if args.out is None else args.out, "--out", (".csv", ".json"))
    plot = None if args.no_plot else outputs.figure_file(DEFAULT_PATH_FIGURE if args.plot is None else args.plot, "--plot", DEFAULT_PATH_FIGURE)
    from esba.analysis.path_analysis import analyse
    from esba.paths.continuation import PathOptions, write_branches
    from esba.paths.problem import PathError
    from esba.statics.equilibrium import EquilibriumError

    scene = scene_from_args(args)
    if args.three_d or scene.needs_3d:
        from .path3d import cmd_path3d

        _check_path_size(args.max_steps, 3 * scene.segments)  # 3n unknowns a point
        return cmd_path3d(args, scene, out, plot)
    from .arguments import planar_only_flags

    planar_only_flags(args, scene, "esba path")
    if args.param in _PATH_PARAMETERS_3D_ONLY:
        raise UsageError(f"--param {args.param}: the direction out of the bending plane needs the 3-D model: give --3d")
    if scene.obstacles:
        return _contact_path(args, scene, out, plot)
    param = args.param
    if args.payload_index != 1:
        if param not in ("payload", "omega", "at"):
            raise UsageError(f"--payload-index {args.payload_index}: only means something with --param payload, omega or at")
        param = f"{param}{args.payload_index}"
    _check_path_size(args.max_steps, scene.segments)
    try:
        options = PathOptions(locate=args.locate, max_steps=args.max_steps, ds_max=args.ds_max, ds=min(0.05, args.ds_max))
        result = analyse(scene, param, args.to, start=args.start, options=options, switch=not args.no_switch, loading=not args.no_loading)
    except PathError as exc:
        raise UsageError(str(exc)) from None
    except EquilibriumError as exc:
        print(f"esba: failed: {exc}", file=sys.stderr)
        return EXIT_FAILED
    data = result.to_dict(points=bool(args.json and args.points))
    if out:
        extra = {k: v for k, v in result.to_dict(points=False).items() if k != "branches"}
        data["out"] = str(write_branches(result.branches, out, extra).resolve())
    if plot:
        from esba.figures.paths import path_figure, save_figure

        data["figure"] = str(save_figure(path_figure(result, args.y), plot).resolve())
    print_result(args, data, path_table)
    warn_findings(data["validity"])
    reached = result.main.stopped == "loop" or (len(result.main) and result.main.lam[-1] == args.to)
    if not reached:
        print(f"esba: the branch did not reach --to {args.to:g}: {result.main.stop_reason}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


#: Points of a path with contact (``esba path`` on a scene with obstacles).
CONTACT_PATH_POINTS = 31


def _contact_path(args: argparse.Namespace, scene, out, plot) -> int:
    """``esba path`` on a scene with obstacles: the pressure from --from (default 0) to --to in 31
    steps, each a contact equilibrium warm-started from the previous one, with the contact events
    located (esba.statics.contact.sweeps.contact_path)."""
    import numpy as np

    from esba.statics.contact.sweeps import contact_path

    from .contact import _path_table as contact_table
    from .contact import write_path_file

    if args.param != "pressure":
        raise UsageError(f"--param {args.param}: a scene with obstacles follows the pressure only (--param pressure); a prescribed tip is esba.statics.contact.sweeps.displacement_path")
    start = 0.0 if args.start is None else args.start
    path = contact_path(scene, np.linspace(start, args.to, CONTACT_PATH_POINTS), "pressure")
    data = path.to_dict(shapes=bool(args.json and args.points))
    data["scene"] = scene.describe()
    if out:
        data["out"] = write_path_file(out, path, "pressure_mpa,total_force_n,contacts,tip_x_mm,tip_y_mm,total_angle_deg,ok",
                                      [f"{p.pressure:.10g},{f:.10g},{len(p.contacts)},{p.tip[0]:.10g},{p.tip[1]:.10g},{p.total_angle_deg:.10g},{p.ok}"
                                       for p, f in zip(path.points, path.forces)])
    if plot:
        from esba.figures.contact import grasp_figure
        from esba.figures.scenes import save_figure

        data["figure"] = str(save_figure(grasp_figure(path), plot).resolve())
    print_result(args, data, lambda d: contact_table(f"path with contact: {d['scene']}", d) + (f"\nbranch file: wrote {d['out']}" if d.get("out") else ""))
    bad = [p for p in path.points if not p.ok]
    if bad:
        print(f"esba: warning: {len(bad)} of {len(path.points)} points are not certified equilibria (first: P = {bad[0].pressure:g} MPa: {bad[0].message or bad[0].status})", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def add_path(sub) -> None:
    p = sub.add_parser(
        "path",
        help="trace the equilibria as one parameter changes: folds, branch points, stability, hysteresis (CSV/JSON, figure)",
    )
    add_scene_flags(p)
    p.add_argument("--param", choices=_PATH_PARAMETERS + _PATH_PARAMETERS_3D_ONLY, default="pressure",
                   help="the parameter to follow (default pressure; payload, omega, beta and at are payload 1's: use --payload-index for another; beta, the direction out of the plane, needs --3d)")
    p.add_argument("--payload-index", type=count_arg("--payload-index", 1, 16, "a model carries at most 16 payloads"), default=1, metavar="K", help="which payload --param payload/omega/at means (default 1)")
    p.add_argument("--to", type=float_arg, metavar="VALUE", help="trace to this value (MPa, N, deg, mm, ... as the parameter; required)")
    p.add_argument("--from", dest="start", type=float_arg, metavar="VALUE", help="start here (default: the scene's own value)")
    p.add_argument("--locate", choices=("extended", "bisection"), default="extended", help="how folds are located (default: the extended system)")
    p.add_argument("--max-steps", type=count_arg("--max-steps", 1, 1_000_000, "each step stores a point"), default=2000, metavar="N", help="steps per branch (default 2000, at most 1000000)")
    p.add_argument("--ds-max", type=float_arg, default=0.1, metavar="DS", help="largest step in the scaled arclength (default 0.1)")
    p.add_argument("--no-switch", action="store_true", help="do not trace the branches crossing at branch points")
    p.add_argument("--no-loading", action="store_true", help="do not follow quasi-static loading up and down (the hysteresis)")
    p.add_argument("--y", choices=("total-angle", "tip-x", "tip-y"), default="total-angle", help="what the figure shows against the parameter")
    p.add_argument("--out", metavar="FILE", help=f"the branches as CSV or JSON (default {DEFAULT_PATH_OUT})")
    p.add_argument("--no-out", action="store_true", help="write no branch file")
    p.add_argument("--plot", metavar="FILE", help=f"the figure (default {DEFAULT_PATH_FIGURE})")
    p.add_argument("--no-plot", action="store_true", help="write no figure")
    p.add_argument("--points", action="store_true", help="with --json: print every point, not only the special ones")
    p.add_argument("--write-doc", metavar="FILE", help="run the path cases of docs/paths.md (Table 1: bistable ranges, buckling for n = 1..8) and write the page and its figures (several seconds)")
    p.add_argument("--3d", dest="three_d", action="store_true", help="trace the 3-D model (chosen by itself when a payload points out of the plane; --param pressure, payload, omega, beta, at or load; docs/3d.md)")
    p.add_argument("--section", action="append", metavar="NAME=VALUE", help="with --3d: section stiffness EI_side=..., GJ=... (N*mm^2; repeatable; default the eccentric section's)")
    p.add_argument("--gravity-direction", metavar="X,Y,Z", help="with --3d and --gravity: the direction of gravity in the base frame (overrides the scene file's gravity_direction; default 1,0,0: down, the paper's)")
    p.set_defaults(func=_cmd_path)

"""``esba path --3d`` and ``esba equilibria --3d``: the 3-D model's branches and equilibria (docs/3d.md)."""

from __future__ import annotations

import argparse
import sys

from .arguments import UsageError
from .results import EXIT_FAILED, EXIT_OK, print_result


def gravity_direction_arg(args: argparse.Namespace, scene) -> tuple[float, float, float]:
    """``--gravity-direction X,Y,Z`` checked (one line naming it), (1, 0, 0) when not given."""
    if getattr(args, "gravity_direction", None) is None:
        return (1.0, 0.0, 0.0)
    from esba.statics.spatial import SpatialError, check_direction

    try:
        parts = [float(v) for v in args.gravity_direction.split(",")]
    except ValueError:
        raise UsageError(f"--gravity-direction {args.gravity_direction!r}: expected X,Y,Z, three numbers of the base frame") from None
    try:
        down = tuple(float(v) for v in check_direction("--gravity-direction", parts))
    except SpatialError as exc:
        raise UsageError(str(exc)) from None
    if not scene.gravity:
        raise UsageError("--gravity-direction turns the weight: give --gravity (or gravity = true in the scene file)")
    return down  # type: ignore[return-value]


def planar_only_flags(args: argparse.Namespace, scene, command: str) -> None:
    """Without --3d (and no payload out of the plane): the 3-D flags are refused (one line)."""
    for flag, given in (("--section", getattr(args, "section", None)), ("--gravity-direction", getattr(args, "gravity_direction", None))):
        if given is not None:
            raise UsageError(f"{flag} is for the 3-D model: give --3d ({command} --3d)")


def cmd_path3d(args: argparse.Namespace, scene, out, plot) -> int:
    """``esba path --3d``: the branch in --param of the 3-D model, its folds and branch points, the
    sideways branches crossing there, and the quasi-static ramps with their jumps."""
    from esba.analysis.path3d import analyse3d, path3d_table
    from esba.analysis.path3d import write_branches3d
    from esba.paths.continuation import PathOptions
    from esba.paths.problem import PathError

    from .scenes import _section_arg

    if scene.obstacles:
        raise UsageError("--3d: a scene with obstacles has no 3-D path command yet; esba solve --3d solves it, esba.statics.contact.spatial_path.contact_path3d follows the pressure")
    if args.locate != "extended":
        raise UsageError(f"--locate {args.locate}: with --3d folds and branch points are located by their extended systems only (--locate extended)")
    section = _section_arg(args.section)
    down = gravity_direction_arg(args, scene)
    param = args.param
    if args.payload_index != 1:
        if param not in ("payload", "omega", "at", "beta"):
            raise UsageError(f"--payload-index {args.payload_index}: only means something with --param payload, omega, beta or at")
        param = f"{param}{args.payload_index}"
    if args.y != "total-angle":
        raise UsageError(f"--y {args.y}: with --3d the figure shows the in-plane bend, the sideways bend and the twist (leave --y out)")
    try:
        options = PathOptions(max_steps=args.max_steps, ds_max=args.ds_max, ds=min(0.05, args.ds_max))
        result = analyse3d(scene, param, args.to, start=args.start, options=options, section=section, gravity_direction=down,
                           switch=not args.no_switch, loading=not args.no_loading)
    except PathError as exc:
        raise UsageError(str(exc)) from None
    except RuntimeError as exc:
        print(f"esba: failed: {exc}", file=sys.stderr)
        return EXIT_FAILED
    data = result.to_dict(points=bool(args.json and args.points))
    if out:
        data["out"] = str(write_branches3d(result, out).resolve())
    if plot:
        from esba.figures.path3d import path3d_figure
        from esba.figures.scenes import save_figure

        data["figure"] = str(save_figure(path3d_figure(result), plot).resolve())
    print_result(args, data, path3d_table)
    main = result.main
    for b in result.branches:
        if b.stopped in ("domain", "corrector"):
            print(f"esba: warning: {b.label or 'branch'}: {b.stop_reason}", file=sys.stderr)
    reached = main.stopped == "loop" or (len(main) and main.lam[-1] == args.to)
    if not reached:
        print(f"esba: the branch did not reach --to {args.to:g}: {main.stop_reason}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def cmd_equilibria3d(args: argparse.Namespace, scene) -> int:
    """``esba equilibria --3d``: every 3-D equilibrium the search finds, certified and classified."""
    from esba.statics.spatial import SpatialError
    from esba.statics.spatial_search import search3d, search3d_table

    from .scenes import _section_arg

    section = _section_arg(args.section)
    down = gravity_direction_arg(args, scene)
    try:
        result = search3d(scene, section, gravity_direction=down, starts=args.starts, check=not args.no_check)
    except SpatialError as exc:
        raise UsageError(str(exc)) from None
    data = result.to_dict()
    print_result(args, data, search3d_table)
    if result.complete is False:
        print(f"esba: warning: the completeness check found {result.check_found} equilibria the first search had not: raise --starts", file=sys.stderr)
    if not data["states"]:
        print("esba: failed: no equilibrium found", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


__all__ = ["cmd_path3d", "cmd_equilibria3d", "gravity_direction_arg", "planar_only_flags"]

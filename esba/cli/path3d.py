"""``esba path --3d`` and ``esba equilibria --3d``: the 3-D model's branches and equilibria (docs/3d.md)."""

from __future__ import annotations

import argparse
import sys

from .arguments import UsageError, gravity_direction_arg
from .results import EXIT_FAILED, EXIT_OK, print_result


def cmd_path3d(args: argparse.Namespace, scene, out, plot) -> int:
    """``esba path --3d``: the branch in --param of the 3-D model, its folds and branch points, the
    sideways branches crossing there, and the quasi-static ramps with their jumps."""
    from esba.analysis.path3d import analyse3d, path3d_table
    from esba.analysis.path3d import write_branches3d
    from esba.paths.continuation import PathOptions
    from esba.paths.problem import PathError

    from .scenes import _section_arg

    if scene.obstacles:
        return _contact_path3d(args, scene, out, plot)
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


#: Points of a 3-D path with contact (``esba path --3d`` on a scene with obstacles).
CONTACT_PATH_POINTS_3D = 31


def _contact_path3d_table(d: dict) -> str:
    lines = [f"3-D path with contact: {d['scene']}",
             f"  {'P MPa':>8} {'force N':>9} {'contacts (s, force N)':<46} {'tip x, y, z mm':>26} {'KKT: stat.':>10} {'compl.':>8} {'min eig':>9}  status"]
    for p in d["points"]:
        where = "; ".join(f"{c['where']} s={c['s']:.3f} {c['force_n']:.3f}" for c in p["contacts"]) or "none"
        kkt = p["kkt"]
        eig = min(kkt["reduced_eigenvalues"]) if kkt["reduced_eigenvalues"] else float("nan")
        force = sum(c["force_n"] for c in p["contacts"])
        tip = ",".join(f"{v:>8.2f}" for v in p["tip_mm"])
        lines.append(f"  {p['pressure_mpa']:>8.4f} {force:>9.4f} {where[:46]:<46} {tip:>26} {kkt['stationarity_nmm']:>10.1e} "
                     f"{kkt['complementarity_nmm']:>8.1e} {eig:>9.4g}  {'ok' if p['ok'] else p['message'] or p['status']}")
    lines += [f"event: {e['description']}" for e in d["events"]] or ["event: none"]
    for key, what in (("out", "branch file"), ("figure", "figure")):
        if d.get(key):
            lines.append(f"{what}: wrote {d[key]}")
    return "\n".join(lines)


def _contact_path3d(args: argparse.Namespace, scene, out, plot) -> int:
    """``esba path --3d`` on a scene with obstacles: the pressure from --from (default 0) to --to in 31
    points, each a 3-D contact equilibrium warm-started from the previous one, with the touches, lift-offs
    and slides located and where the contact branch is lost (esba.statics.contact.spatial_path)."""
    import numpy as np

    from esba.model.scene import SceneError, check_pressure
    from esba.statics.contact.spatial_path import contact_path3d

    from .contact import _finish, write_path_file
    from .scenes import _section_arg

    if args.param != "pressure":
        raise UsageError(f"--param {args.param}: a scene with obstacles follows the pressure only (--param pressure)")
    try:
        start = 0.0 if args.start is None else check_pressure(args.start, "--from")
        to = check_pressure(args.to, "--to")
    except SceneError as exc:
        raise UsageError(str(exc)) from None
    section = _section_arg(args.section)
    down = gravity_direction_arg(args, scene)
    path = contact_path3d(scene, np.linspace(start, to, CONTACT_PATH_POINTS_3D), section, gravity_direction=down)
    data = path.to_dict(shapes=bool(args.json and args.points))
    data["scene"] = scene.describe()
    if out:
        data["out"] = write_path_file(out, path, "pressure_mpa,total_force_n,contacts,tip_x_mm,tip_y_mm,tip_z_mm,ok",
                                      [f"{p.pressure:.10g},{f:.10g},{len(p.contacts)},{p.tip[0]:.10g},{p.tip[1]:.10g},{p.tip[2]:.10g},{p.ok}"
                                       for p, f in zip(path.points, path.forces())])
    good = [p for p in path.points if p.ok]
    if plot and good:
        from esba.figures.contact3d import contact3d_figure
        from esba.figures.scenes import save_figure

        data["figure"] = str(save_figure(contact3d_figure(good[-1]), plot).resolve())
    return _finish(args, path, data, _contact_path3d_table)


def cmd_equilibria3d(args: argparse.Namespace, scene) -> int:
    """``esba equilibria --3d``: every 3-D equilibrium the search finds, certified and classified; with
    obstacles, the contact equilibria reached from each (:func:`esba.cli.contact3d.cmd_equilibria_contact3d`)."""
    from esba.statics.spatial import SpatialError
    from esba.statics.spatial_search import search3d, search3d_table

    from .scenes import _section_arg

    section = _section_arg(args.section)
    down = gravity_direction_arg(args, scene)
    if scene.obstacles:
        if args.no_check:
            raise UsageError("--no-check tunes the free search's completeness check; with obstacles the free 3-D search runs without it")
        from .contact3d import cmd_equilibria_contact3d

        try:
            return cmd_equilibria_contact3d(args, scene, section, down)
        except SpatialError as exc:
            raise UsageError(str(exc)) from None
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


__all__ = ["cmd_path3d", "cmd_equilibria3d"]

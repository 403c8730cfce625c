"""``esba equilibria``: every equilibrium of a scene (deflated Newton), its stability, the barriers."""

from __future__ import annotations

import argparse
import sys

from .arguments import UsageError, add_scene_flags, count_arg, float_arg, scene_figure, scene_from_args
from .results import EXIT_FAILED, EXIT_OK, print_result

#: Where ``esba equilibria`` writes its figure unless told otherwise.
DEFAULT_EQUILIBRIA_FIGURE = "esba-equilibria.png"


def _cmd_equilibria(args: argparse.Namespace) -> int:
    from esba.statics.equilibria import EquilibriaOptions, EquilibriaOptionsError, equilibria
    from esba.statics.text import equilibria_table

    scene = scene_from_args(args)
    if args.three_d or scene.needs_3d:
        from .path3d import cmd_equilibria3d

        if args.plot is not None or args.max_bend is not None:
            raise UsageError("--plot and --max-bend are not used with --3d (the 3-D search has no figure yet; its domain: docs/3d.md)")
        return cmd_equilibria3d(args, scene)
    from .arguments import planar_only_flags

    planar_only_flags(args, scene, "esba equilibria")
    figure = scene_figure(args, DEFAULT_EQUILIBRIA_FIGURE)
    if scene.obstacles:
        return _contact_equilibria(args, scene, figure)
    try:
        extra = {} if args.starts is None else {"starts": args.starts}
        if args.max_bend is not None:
            extra["max_bend_deg"] = args.max_bend
        options = EquilibriaOptions(check=not args.no_check, **extra)
    except EquilibriaOptionsError as exc:
        raise UsageError(str(exc).replace("max_bend_deg=", "--max-bend ").replace("starts=", "--starts ")) from None
    res = equilibria(scene, options)
    data = res.to_dict()
    data["scene"] = scene.describe()
    if figure is not None:
        from esba.figures.equilibria import equilibria_figure, save_figure

        data["figure"] = str(save_figure(equilibria_figure(res), figure).resolve())
    print_result(args, data, equilibria_table)
    for k, s in enumerate(res.states, start=1):
        for f in s.validity:
            print(f"esba: warning: state #{k} ({s.total_angle_deg:.2f} deg): {f.message}", file=sys.stderr)
    if res.complete is False:
        print(f"esba: warning: the completeness check found {res.check_found} equilibria the first search had not: raise --starts", file=sys.stderr)
    if not res.states:
        beyond = f" ({res.outside} beyond it: --max-bend widens it, up to 720 deg)" if res.outside else ""
        print(f"esba: no equilibrium found in the domain searched, {res.describe_domain()}{beyond}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _contact_table(d: dict) -> str:
    lines = [f"scene: {d['scene']}", f"pressure: {d['pressure_mpa']:.7f} MPa",
             f"method: {d['method']} ({d['free_equilibria']} free equilibria, {d['dropped']} dropped: they lie through an obstacle or failed)",
             f"  {'#':>2}  {'stability':<9} {'total deg':>10} {'tip x, y mm':>17} {'energy N mm':>12}  contacts (where, force N)"]
    for k, s in enumerate(d["states"], start=1):
        where = "; ".join(f"{c['where']} {c['force_n']:.4f}" for c in s["contacts"]) or "none"
        lines.append(f"  {k:>2}  {s['kkt']['stability']:<9} {s['total_angle_deg']:>10.3f} {s['tip_mm'][0]:>8.2f},{s['tip_mm'][1]:>8.2f} {s['energy_nmm']:>12.4f}  {where}")
    if d.get("figure"):
        lines.append(f"figure: wrote {d['figure']}")
    return "\n".join(lines)


def _contact_equilibria(args: argparse.Namespace, scene, figure) -> int:
    """``esba equilibria`` on a scene with obstacles: esba.statics.contact.multistart."""
    from esba.statics.contact.multistart import contact_equilibria

    if args.starts is not None or args.max_bend is not None or args.no_check:
        raise UsageError("--starts, --max-bend and --no-check tune the free search; with obstacles the search is the free one's defaults")
    res = contact_equilibria(scene)
    data = res.to_dict()
    data["scene"] = scene.describe()
    if figure is not None and res.states:
        from esba.figures.contact import contact_states_figure
        from esba.figures.scenes import save_figure

        data["figure"] = str(save_figure(contact_states_figure(res.states), figure).resolve())
    print_result(args, data, _contact_table)
    if not res.states:
        print("esba: no contact equilibrium found from the free equilibria", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def add_equilibria(sub) -> None:
    p = sub.add_parser(
        "equilibria",
        help="every equilibrium of a scene (deflated Newton): stability, Morse index, energy, barriers (table, JSON, figure)",
    )
    add_scene_flags(p)
    p.add_argument("--starts", type=count_arg("--starts", 2, 1000, "each start is a Newton run per round"), metavar="K", help="constant-curvature starts over the domain (default 25)")
    p.add_argument("--max-bend", type=float_arg, metavar="DEG", help="largest total bend searched (default 360: a full turn)")
    p.add_argument("--no-check", action="store_true", help="skip the completeness check (a second search from fresh starts)")
    p.add_argument("--plot", metavar="FILE", help=f"the figure of every equilibrium (default {DEFAULT_EQUILIBRIA_FIGURE} when no scene file is given)")
    p.add_argument("--no-plot", action="store_true", help="write no figure")
    p.add_argument("--3d", dest="three_d", action="store_true", help="search the 3-D model's equilibria: sideways and twisted states too (chosen by itself when a payload points out of the plane; docs/3d.md)")
    p.add_argument("--section", action="append", metavar="NAME=VALUE", help="with --3d: section stiffness EI_side=..., GJ=... (N*mm^2; repeatable; default the eccentric section's)")
    p.add_argument("--gravity-direction", metavar="X,Y,Z", help="with --3d and --gravity: the direction of gravity in the base frame (overrides the scene file's gravity_direction; default 1,0,0: down, the paper's)")
    p.set_defaults(func=_cmd_equilibria)

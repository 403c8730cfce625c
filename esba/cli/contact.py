"""``esba blocked`` and ``esba grasp``: contact along a pressure ramp (the blocked force, a finger closing on a cylinder)."""

from __future__ import annotations

import argparse
import sys

from esba.derive.effects import VARIANTS

from .arguments import UsageError, float_arg, load_scene_file, scene_changes, scene_figure, segments_arg
from .results import EXIT_FAILED, EXIT_OK, print_result

#: Where the commands write their figure unless told otherwise.
DEFAULT_BLOCKED_FIGURE = "esba-blocked.png"
DEFAULT_GRASP_FIGURE = "esba-grasp.png"
#: The pressures of both commands unless told otherwise.
DEFAULT_PRESSURES = "0:0.3:31"


def _values_arg(text: str) -> list[float]:
    from esba.studies.sweep import SweepError, parse_values

    try:
        return parse_values(text)
    except SweepError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _point_arg(text: str) -> tuple[float, float]:
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"{text!r}: expected X,Y in mm (two numbers separated by a comma)")
    return float_arg(parts[0]), float_arg(parts[1])


def _base(args: argparse.Namespace):
    from esba.model.scene import Scene, SceneError

    try:
        scene = load_scene_file(args.scene, Scene(segments=3, pressure=0.0))
        changes = scene_changes(args, skip=("pressure", "target_angle"))
        return scene.replace(**changes) if changes else scene
    except SceneError as exc:
        raise UsageError(str(exc)) from None


def _options(args: argparse.Namespace):
    from esba.statics.contact import ContactOptions

    return ContactOptions(certify=args.certify)


def _path_table(title: str, d: dict, extra: str = "") -> str:
    lines = [title]
    lines.append(f"  {'P MPa':>8} {'force N':>9} {'contacts (s, force N)':<44} {'tip x, y mm':>17} {'KKT: stat.':>10} {'compl.':>8} {'min eig':>9}  status")
    for p in d["points"]:
        where = "; ".join(f"{c['where']} s={c['s']:.3f} {c['force_n']:.3f}" for c in p["contacts"]) or "none"
        kkt = p["kkt"]
        eig = min(kkt["reduced_eigenvalues"]) if kkt["reduced_eigenvalues"] else float("nan")
        force = sum(c["force_n"] for c in p["contacts"])
        lines.append(
            f"  {p['pressure_mpa']:>8.4f} {force:>9.4f} {where[:44]:<44} {p['tip_mm'][0]:>8.2f},{p['tip_mm'][1]:>8.2f} "
            f"{kkt['stationarity_nmm']:>10.1e} {kkt['complementarity_nmm']:>8.1e} {eig:>9.4g}  {'ok' if p['ok'] else p['message'] or p['status']}"
        )
    for e in d["events"]:
        lines.append(f"event: {e['description']} ({e['obstacle']}) at P = {e['parameter']:.6f} MPa ({e['status']})")
    if extra:
        lines.append(extra)
    if d.get("figure"):
        lines.append(f"figure: wrote {d['figure']}")
    return "\n".join(lines)


def write_path_file(out, path, header: str, rows: list[str]) -> str:
    """A contact path's file (``esba path`` with obstacles, planar or 3-D): JSON (every point with its
    shape, every event) or CSV (``header`` and ``rows``); returns its absolute path."""
    from esba.infra import jsonsafe
    from esba.infra.outputs import write_text

    if str(out).endswith(".json"):
        write_text(out, jsonsafe.dumps(path.to_dict(shapes=True), indent=2, sort_keys=True) + "\n")
    else:
        write_text(out, "\n".join([header, *rows]) + "\n")
    return str(out.resolve())


def _finish(args: argparse.Namespace, path, data: dict, table) -> int:
    print_result(args, data, table)
    bad = [p for p in path.points if not p.ok]
    if bad:
        print(f"esba: warning: {len(bad)} of {len(path.points)} points are not certified equilibria (first: P = {bad[0].pressure:g} MPa: {bad[0].message or bad[0].status})", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _cmd_blocked(args: argparse.Namespace) -> int:
    from esba.statics.contact.sweeps import blocked_force

    figure = scene_figure(args, DEFAULT_BLOCKED_FIGURE)
    base = _base(args)
    path = blocked_force(base, args.pressure, _options(args))
    data = path.to_dict(shapes=True)
    data["scene"] = base.replace(payloads=(), gravity=False).describe()
    data["probe"] = "frictionless half-plane y >= 0 through the tip at rest (face looking towards -y, the bending side)"
    if figure is not None:
        from esba.figures.contact import blocked_figure
        from esba.figures.scenes import save_figure

        data["figure"] = str(save_figure(blocked_figure(path), figure).resolve())
    return _finish(args, path, data, lambda d: _path_table(f"blocked force: {d['scene']}\nprobe: {d['probe']}", d))


def _cmd_grasp(args: argparse.Namespace) -> int:
    from esba.model.contact.obstacles import ObstacleError
    from esba.model.scene import SceneError
    from esba.statics.contact.sweeps import grasp

    figure = scene_figure(args, DEFAULT_GRASP_FIGURE)
    base = _base(args)
    try:
        path = grasp(base, args.at, args.radius, args.pressure, _options(args))
    except (ObstacleError, SceneError) as exc:
        raise UsageError(str(exc).replace("cylinder.radius=", "--radius ").replace("cylinder.centre", "--at")) from None
    data = path.to_dict(shapes=True)
    data["scene"] = base.describe()
    data["contact_length_mm"] = [p.contact_length() for p in path.points]
    if figure is not None:
        from esba.figures.contact import grasp_figure
        from esba.figures.scenes import save_figure

        data["figure"] = str(save_figure(grasp_figure(path), figure).resolve())
    first = data["first_touch"]
    extra = "first touch: " + (f"P = {first:.6f} MPa" if first is not None else "none in the pressures given")
    extra += "\ncontact length within 0.1 mm (mm): " + ", ".join(f"{v:.1f}" for v in data["contact_length_mm"])
    return _finish(args, path, data, lambda d: _path_table(f"grasp: {d['scene']}", d, extra))


def _common(p: argparse.ArgumentParser, figure: str) -> None:
    p.add_argument("scene", nargs="?", default=None, metavar="SCENE.toml", help="the actuator (default: Table 1, n = 3); its pressure is replaced by --pressure")
    p.add_argument("--pressure", type=_values_arg, default=DEFAULT_PRESSURES, metavar="VALUES", help=f"pressures, MPa (start:stop:count or v1,v2,...; default {DEFAULT_PRESSURES})")
    p.add_argument("--segments", "-n", type=segments_arg, help="segment count n, 1 to 256")
    p.add_argument("--no-fibres", action="store_true", help="leave out the fibre restraint (Eq. 18)")
    p.add_argument("--variant", choices=VARIANTS, default=None, help="model variant")
    p.add_argument("--json", action="store_true", help="print JSON (every point with its shape, contacts and KKT numbers)")
    p.add_argument("--certify", action="store_true", help="also run IPOPT from each active-set Newton result and report how far it moved it")
    p.add_argument("--plot", metavar="FILE|DIR", help=f"the figure (default {figure} when no scene file is given)")
    p.add_argument("--no-plot", action="store_true", help="write no figure")


def add_blocked(sub) -> None:
    p = sub.add_parser("blocked", help="the blocked-force curve: a frictionless flat probe at the tip, pressure rising (table, JSON, figure)")
    _common(p, DEFAULT_BLOCKED_FIGURE)
    p.set_defaults(func=_cmd_blocked)


def add_grasp(sub) -> None:
    p = sub.add_parser("grasp", help="a finger closing on a cylinder: contact force and length against pressure, first touch (table, JSON, figure)")
    _common(p, DEFAULT_GRASP_FIGURE)
    p.add_argument("--radius", type=float_arg, default=15.0, metavar="MM", help="the cylinder's radius, mm (default 15)")
    p.add_argument("--at", type=_point_arg, default=(70.0, 45.0), metavar="X,Y", help="its centre, mm: x down the unbent actuator, y towards the bend (default 70,45)")
    p.set_defaults(func=_cmd_grasp)

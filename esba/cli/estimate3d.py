"""``esba estimate`` and ``esba fit`` in 3-D: the flags and files of a 3-D tracker (docs/sensing.md, docs/experiments.md)."""

from __future__ import annotations

import argparse
import sys

from .arguments import UsageError, float_arg, refuse
from .results import EXIT_FAILED, EXIT_OK, print_result

#: The estimate's flags that only the 3-D estimate takes (any of them picks it).
FLAGS_3D = ("tip_rotation", "sigma_rotation", "angles", "sigma_angles", "section")


def numbers(flag: str, counts: tuple[int, ...] | None = None, what: str = ""):
    def parse(text: str) -> tuple[float, ...]:
        parts = text.split(",")
        if any(not p.strip() for p in parts):
            raise argparse.ArgumentTypeError(f"{text!r}: expected numbers separated by commas, none empty")
        values = tuple(float_arg(p.strip()) for p in parts)
        if counts is not None and len(values) not in counts:
            raise argparse.ArgumentTypeError(f"{text[:60]!r}: expected {' or '.join(map(str, counts))} numbers ({what})")
        return values

    return parse


def marker(text: str) -> tuple[float, ...]:
    """(at, x, y) or, in 3-D, (at, x, y, z)."""
    at, sep, xy = text.partition(":")
    if not sep:
        raise argparse.ArgumentTypeError(f"{text!r}: expected AT:X,Y or AT:X,Y,Z (a fraction of L, then the marker's position in mm), e.g. 0.5:60.2,10.3")
    return (float_arg(at.strip()), *numbers("--marker", (2, 3), "x,y or x,y,z in mm")(xy))


def wants_3d(args: argparse.Namespace) -> bool:
    """Does the command line ask for the 3-D estimate (--3d, a 3-D flag, a tip or marker with z, a 3-D pose file)?"""
    if getattr(args, "three_d", False) or any(getattr(args, d, None) for d in FLAGS_3D):
        return True
    if args.tip is not None and len(args.tip) == 3 or any(len(m) == 4 for m in (args.marker or [])):
        return True
    if args.poses is not None:
        from esba.calibration.poses3d import is_3d

        return is_3d(args.poses)
    return False


def section_arg(items) -> dict[str, float]:
    from esba.statics.spatial import SpatialError, check_section

    section: dict[str, str] = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        if not sep:
            raise UsageError(f"--section {item!r}: expected NAME=VALUE, e.g. EI_side=4e5 (N*mm^2)")
        section[name.strip()] = value.strip()
    try:
        return check_section(section, complete=False)
    except SpatialError as exc:
        raise UsageError(f"--section: {exc}") from None


def _planar_only(scene, where: str) -> None:
    if getattr(scene, "obstacles", ()):
        raise UsageError(f"{where}: the scene has obstacles (contact), which only the planar model carries; drop them for the 3-D model")


def _flag_poses(args: argparse.Namespace, scene):
    from esba.calibration.sensing3d import Pose3D
    from esba.calibration.spatial_ls import Measured3D as _Measured3D
    from esba.calibration.spatial_ls import SpatialLSError

    flags = {"tip": "--tip", "rotation": "--tip-rotation", "angles": "--angles", "marker": "--marker"}

    def Measured3D(kind, values, sd, at=None):  # noqa: N802 - the error names the flag
        try:
            return _Measured3D(kind, values, sd, at)
        except SpatialLSError as exc:
            raise UsageError(f"{flags[kind]}: {exc}") from None

    measured = []
    if args.tip is not None:
        if len(args.tip) != 3:
            raise UsageError(f"--tip {','.join(f'{v:g}' for v in args.tip)}: the 3-D estimate takes the tip as X,Y,Z (mm)")
        if args.sigma_tip is None:
            raise UsageError("--tip needs its standard deviation: --sigma-tip SD")
        measured.append(Measured3D("tip", args.tip, args.sigma_tip))
    elif args.sigma_tip is not None:
        raise UsageError("--sigma-tip is not used without --tip")
    for dest, sd_dest, flag, sd_flag, kind in (("tip_rotation", "sigma_rotation", "--tip-rotation", "--sigma-rotation", "rotation"),
                                                ("angles", "sigma_angles", "--angles", "--sigma-angles", "angles")):
        value, sd = getattr(args, dest), getattr(args, sd_dest)
        if value is None:
            if sd is not None:
                raise UsageError(f"{sd_flag} is not used without {flag}")
            continue
        if sd is None:
            raise UsageError(f"{flag} needs its standard deviation: {sd_flag} SD")
        if kind == "angles" and len(value) != 3 * scene.segments:
            raise UsageError(f"--angles: {len(value)} angles for n = {scene.segments} segments: expected 3n = {3 * scene.segments} "
                             "(theta_1..n, psi_1..n, tau_1..n in deg)")
        measured.append(Measured3D(kind, value, sd))
    if args.marker:
        if args.sigma_marker is None:
            raise UsageError("--marker needs its standard deviation: --sigma-marker SD")
        for at, *xyz in args.marker:
            if len(xyz) != 3:
                raise UsageError(f"--marker {at:g}:{','.join(f'{v:g}' for v in xyz)}: the 3-D estimate takes a marker as AT:X,Y,Z")
            measured.append(Measured3D("marker", tuple(xyz), args.sigma_marker, at))
    elif args.sigma_marker is not None:
        raise UsageError("--sigma-marker is not used without --marker")
    if not measured:
        raise UsageError("nothing measured in 3-D: give --tip X,Y,Z, --tip-rotation, --marker AT:X,Y,Z or --angles (each with its --sigma-...), "
                         "or --poses FILE.csv")
    return [Pose3D(scene.pressure, tuple(measured), label="flags", target_angle_deg=scene.target_angle_deg if scene.pressure is None else None)]


def run_estimate3d(args: argparse.Namespace, scene) -> int:
    """``esba estimate`` with a 3-D measurement."""
    from esba.calibration.measurements import MeasurementError
    from esba.calibration.poses3d import load_poses3d
    from esba.calibration.sensing3d import Sensing3DError, estimate3d_table, estimate_load3d
    from esba.model.scene import SceneError

    refuse(args, ["theta", "sigma_theta", "total_angle", "sigma_total_angle"], "in 3-D (give the joint angles as --angles THETAS,PSIS,TAUS)")
    refuse(args, ["sigma", "fit", "frozen"], "in 3-D (the actuator's uncertainty is carried by the planar estimate only)")
    _planar_only(scene, "esba estimate in 3-D")
    section = section_arg(args.section)
    free = args.free if args.free_given else ["force", "angle", "out"]
    try:
        if args.poses is not None:
            poses = load_poses3d(args.poses, scene.segments)
            loads = list(dict.fromkeys(p.load for p in poses))
        else:
            poses = _flag_poses(args, scene)
            loads = [poses[0].load]
        results = []
        for load in loads:
            group = [p for p in poses if p.load == load]
            results.append((load, estimate_load3d(group, free, scene, section, level=args.level, starts=min(args.starts, 50))))
    except (Sensing3DError, MeasurementError, SceneError) as exc:
        raise UsageError(str(exc)) from None
    if len(results) == 1:
        print_result(args, results[0][1].to_dict(), estimate3d_table)
    else:
        print_result(args, {"loads": {ld: r.to_dict() for ld, r in results}},
                     lambda d: "\n\n".join(f"load {ld}:\n" + estimate3d_table(v) for ld, v in d["loads"].items()))
    code = EXIT_OK
    for ld, r in results:
        for w in r.warnings:
            print(f"esba: warning: {w}", file=sys.stderr)
        if not r.ok:
            print(f"esba: estimate {r.status}" + (f" ({ld})" if len(results) > 1 else "") + f": {r.message}", file=sys.stderr)
            code = EXIT_FAILED
    return code


def run_fit3d(args: argparse.Namespace, base) -> int:
    """``esba fit FILE`` for a 3-D pose file with known payloads: EI_side and GJ."""
    from esba.calibration.fit3d import Fit3DError, fit3d_table, fit_section
    from esba.calibration.measurements import MeasurementError
    from esba.calibration.poses3d import load_rows3d
    from esba.model.scene import SceneError

    if args.plot:
        raise UsageError("--plot is not used with a 3-D file (the 3-D fit draws no figure yet)")
    free = args.free if args.free_given else ["EI_side", "GJ"]
    _planar_only(base, f"{args.measurements}")
    try:
        rows = load_rows3d(args.measurements, base.segments)
        if all(r.payload is None for r in rows):
            raise UsageError(f"{args.measurements}: no row states its payload (payload_n): without a known load the stiffnesses are not measured; "
                             "a file of unknown loads is for `esba estimate --poses`")
        start = section_arg(args.section) if getattr(args, "section", None) else None
        result = fit_section(rows, base, free, start, level=args.level)
    except (Fit3DError, MeasurementError, SceneError) as exc:
        raise UsageError(str(exc)) from None
    print_result(args, result.to_dict(), fit3d_table)
    for w in result.warnings:
        print(f"esba: warning: {w}", file=sys.stderr)
    if not result.ok:
        print(f"esba: fit {result.status}: {result.message}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK

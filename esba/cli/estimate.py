"""``esba estimate``: the payload from the measured shape, with its uncertainty (the actuator as a force sensor)."""

from __future__ import annotations

import argparse
import json
import math
import sys

from .arguments import UsageError, add_scene_flags, count_arg, float_arg, refuse, scene_from_args
from .estimate3d import marker as marker3
from .estimate3d import numbers as numbers3
from .results import EXIT_FAILED, EXIT_OK, print_result


def _numbers(flag: str, count: int | None = None):
    def parse(text: str) -> tuple[float, ...]:
        parts = text.split(",")
        if any(not p.strip() for p in parts):
            raise argparse.ArgumentTypeError(f"{text!r}: expected numbers separated by commas, none empty")
        values = tuple(float_arg(p.strip()) for p in parts)
        if count is not None and len(values) != count:
            raise argparse.ArgumentTypeError(f"{text!r}: expected {count} numbers ({'x,y in mm' if count == 2 else 'one value'})")
        return values

    return parse


def _sd(text: str) -> float:
    v = float_arg(text)
    if not 1e-9 <= v <= 1e4:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a standard deviation with 1e-9 <= sd <= 1e4")
    return v


def _free(text: str) -> list[str]:
    names = [s.strip() for s in text.split(",")]
    if not names or any(not n for n in names):
        raise argparse.ArgumentTypeError(f"{text!r}: expected names such as force,angle or force,angle,at")
    return names


def _level(text: str) -> float:
    v = float_arg(text)
    if not 0.0 < v < 1.0:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a confidence level between 0 and 1 (0.95 for 95 %)")
    return v


def _flag_poses(args: argparse.Namespace, scene):
    from esba.calibration.sensing import Measured, Pose

    measured = []
    pairs = (("theta", "sigma_theta", "--theta", "--sigma-theta"), ("total_angle", "sigma_total_angle", "--total-angle", "--sigma-total-angle"),
             ("tip", "sigma_tip", "--tip", "--sigma-tip"))
    for dest, sd_dest, flag, sd_flag in pairs:
        value, sd = getattr(args, dest), getattr(args, sd_dest)
        if value is None:
            if sd is not None:
                raise UsageError(f"{sd_flag} is not used without {flag}")
            continue
        if sd is None:
            raise UsageError(f"{flag} needs its standard deviation: {sd_flag} SD")
        if dest == "theta" and len(value) != scene.segments:
            raise UsageError(f"--theta {','.join(f'{v:g}' for v in value)}: {len(value)} angles for {scene.segments} segments (set -n or give one per segment)")
        measured.append(Measured(dest, value, sd))
    if args.marker:
        if args.sigma_marker is None:
            raise UsageError("--marker needs its standard deviation: --sigma-marker SD")
        for at, x, y in args.marker:
            measured.append(Measured("marker", (x, y), args.sigma_marker, at))
    elif args.sigma_marker is not None:
        raise UsageError("--sigma-marker is not used without --marker")
    if not measured:
        raise UsageError("nothing measured: give --theta, --total-angle, --tip or --marker (each with its --sigma-...), or --poses FILE.csv")
    return [Pose(scene.pressure, tuple(measured), label="flags", target_angle_deg=scene.target_angle_deg if scene.pressure is None else None)]


def _scene_sets_drive(path: str | None) -> bool:
    """Does the scene file set the pressure or the target angle itself (the scene's default of 90 deg is no measurement)?"""
    if path is None:
        return False
    from esba.infra.inputs import load_toml
    from esba.model.scene import SceneError

    loads = load_toml(path, "scene file", SceneError).get("loads", {})
    return isinstance(loads, dict) and ("pressure" in loads or "target_angle_deg" in loads)


def _fit_file(path: str, scene):
    """Actuator values and their covariance from ``esba fit --json`` output."""
    from esba.calibration.sensing import ACTUATOR

    from esba.infra.inputs import read_text

    text = read_text(path, "--fit", UsageError)  # the guards of a scene file: a regular file, bounded, UTF-8
    try:
        data = json.loads(text)
    except (json.JSONDecodeError, RecursionError) as exc:
        raise UsageError(f"--fit {path!r}: not the JSON of `esba fit --json`: {str(exc)[:80]}") from None
    params = data.get("parameters") if isinstance(data, dict) else None
    cov = data.get("covariance") if isinstance(data, dict) else None
    if not isinstance(params, dict) or not params or not isinstance(cov, list):
        raise UsageError(f"--fit {path!r}: expected the JSON of `esba fit --json` (parameters and covariance)")
    names = list(params)
    for n in names:
        if n not in ACTUATOR:
            raise UsageError(f"--fit {path!r}: parameter {n[:20]!r} is not an actuator parameter ({', '.join(ACTUATOR)})")
    values = {}
    for n in names:
        v = params[n].get("estimate") if isinstance(params[n], dict) else None
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
            raise UsageError(f"--fit {path!r}: parameter {n}: no finite estimate")
        values[n] = float(v)
    try:
        matrix = [[float(c) if c is not None else math.nan for c in row] for row in cov]
    except (TypeError, ValueError):
        raise UsageError(f"--fit {path!r}: covariance: expected a matrix of numbers") from None
    if len(matrix) != len(names) or any(len(r) != len(names) for r in matrix):
        raise UsageError(f"--fit {path!r}: covariance: expected {len(names)} x {len(names)}")
    if any(not math.isfinite(c) for r in matrix for c in r):
        raise UsageError(f"--fit {path!r}: the fit left some parameter undetermined (its covariance is null): refit with fewer free parameters")
    from esba.analysis.sensitivity import with_parameters
    from esba.model.scene import SceneError

    try:
        scene = with_parameters(scene, values)
    except SceneError as exc:
        raise UsageError(f"--fit {path!r}: {exc}") from None
    return scene, tuple(names), matrix


def _cmd_estimate(args: argparse.Namespace) -> int:
    from esba.calibration.sensing import estimate_table
    from esba.calibration.measurements import MeasurementError
    from esba.calibration.poses import load_poses
    from esba.calibration.sensing import SensingError, SensingOptions, estimate_load
    from esba.calibration.sigmas import UncertaintyError, parse_sigma, resolve_sigmas
    from esba.model.scene import SceneError

    scene = scene_from_args(args)
    args.free_given = args.free is not None
    from .estimate3d import run_estimate3d, wants_3d

    if wants_3d(args):  # a 3-D tracker's measurements: the 3-D model (docs/sensing.md)
        if args.poses is not None:
            refuse(args, ["tip", "marker", "tip_rotation", "angles", "sigma_tip", "sigma_marker", "sigma_rotation", "sigma_angles"],
                   "with --poses (the file holds the measurements)")
            if args.pressure is not None or args.target_angle is not None:
                raise UsageError("--pressure and --target-angle are not used with --poses (each row has its own pressure)")
        elif args.pressure is None and args.target_angle is None and not _scene_sets_drive(args.scene):
            raise UsageError("give the pressure the shape was measured at: --pressure P (MPa) or --target-angle DEG")
        return run_estimate3d(args, scene)
    if args.free is None:
        args.free = ["force", "angle"]
    if args.tip is not None and len(args.tip) != 2:
        raise UsageError("--tip with three numbers (x, y, z) is for the 3-D estimate: give --3d")
    if args.poses is not None:
        refuse(args, ["theta", "total_angle", "tip", "marker", "sigma_theta", "sigma_total_angle", "sigma_tip", "sigma_marker"],
               "with --poses (the file holds the measurements)")
        if args.pressure is not None or args.target_angle is not None:
            raise UsageError("--pressure and --target-angle are not used with --poses (each row has its own pressure)")
    elif args.pressure is None and args.target_angle is None and not _scene_sets_drive(args.scene):
        raise UsageError("give the pressure the shape was measured at: --pressure P (MPa) or --target-angle DEG"
                         + (f" (the scene file {args.scene} sets neither)" if args.scene else ""))
    carried, cov = (), None
    try:
        if args.fit is not None:
            if args.sigma:
                raise UsageError("--fit and --sigma: give the actuator's uncertainty in one place")
            scene, carried, cov = _fit_file(args.fit, scene)
            if args.frozen:
                carried, cov = (), None
        elif args.frozen:
            raise UsageError("--frozen takes the values of --fit FIT.json without its covariance: give --fit")
        elif args.sigma:
            sigmas = resolve_sigmas(scene, [parse_sigma(s) for s in args.sigma])
            from esba.calibration.sensing import ACTUATOR

            for s in sigmas:
                if s.name not in ACTUATOR:
                    raise UsageError(f"--sigma {s.given}: {s.name} is not an actuator parameter; allowed are {', '.join(ACTUATOR)}")
                if not s.sigma <= abs(s.nominal):
                    raise UsageError(f"--sigma {s.given[:40]}: {s.name}'s standard deviation {s.sigma:.3g} exceeds its value {s.nominal:.4g}: "
                                     "expected one smaller than the value (first order)")
            carried = tuple(s.name for s in sigmas)
            cov = [[s.sigma * s.sigma if i == j else 0.0 for j in range(len(sigmas))] for i, s in enumerate(sigmas)]
        poses = load_poses(args.poses, scene.segments) if args.poses is not None else _flag_poses(args, scene)
        options = SensingOptions(level=args.level, starts=args.starts)
        result = estimate_load(poses, args.free, scene, options, carried=carried, carried_covariance=cov,
                               progress=None if args.json else "esba estimate")  # a bar with its forecast, on a terminal
    except (SensingError, MeasurementError, SceneError, UncertaintyError) as exc:
        raise UsageError(str(exc)) from None
    print_result(args, result.to_dict(), estimate_table)
    for w in result.warnings:
        print(f"esba: warning: {w}", file=sys.stderr)
    if not result.ok:
        print(f"esba: estimate {result.status}: {result.message}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def add_estimate(sub) -> None:
    p = sub.add_parser("estimate", help="the payload from the measured shape: estimate, intervals, what the data cannot see, every load that fits")
    add_scene_flags(p)
    m = p.add_argument_group("what was measured (each with its standard deviation), or --poses")
    m.add_argument("--theta", type=_numbers("--theta"), metavar="DEG,DEG,...", help="every segment angle, deg")
    m.add_argument("--sigma-theta", type=_sd, metavar="SD", help="standard deviation of each segment angle, deg")
    m.add_argument("--total-angle", type=_numbers("--total-angle", 1), metavar="DEG", help="the total bending angle, deg")
    m.add_argument("--sigma-total-angle", type=_sd, metavar="SD", help="its standard deviation, deg")
    m.add_argument("--tip", type=numbers3("--tip", (2, 3), "x,y or x,y,z in mm"), metavar="X,Y[,Z]",
                   help="the tip position, mm (x down the base's axis, y horizontal; z out of the bending plane: the 3-D estimate)")
    m.add_argument("--sigma-tip", type=_sd, metavar="SD", help="standard deviation of each tip coordinate, mm")
    m.add_argument("--marker", type=marker3, action="append", metavar="AT:X,Y[,Z]", help="a marker at fraction AT of L seen at x,y (or x,y,z: 3-D) mm (repeatable)")
    m.add_argument("--sigma-marker", type=_sd, metavar="SD", help="standard deviation of each marker coordinate, mm")
    m.add_argument("--tip-rotation", type=numbers3("--tip-rotation", (9,), "the tip's 3 x 3 rotation matrix, row by row"), metavar="R11,...,R33",
                   help="3-D: the tip's orientation as a rotation matrix, row by row (a trakSTAR's matrix output)")
    m.add_argument("--sigma-rotation", type=_sd, metavar="DEG", help="3-D: standard deviation of the tip's orientation about each axis, deg")
    m.add_argument("--angles", type=numbers3("--angles"), metavar="DEG,...", help="3-D: the 3n joint angles theta_1..n, psi_1..n, tau_1..n, deg")
    m.add_argument("--sigma-angles", type=_sd, metavar="SD", help="3-D: standard deviation of each joint angle, deg")
    m.add_argument("--poses", metavar="FILE.csv", help="a CSV of poses, one a row (see esba.calibration.poses): several loads, or one load at several pressures")
    p.add_argument("--free", type=_free, default=None, metavar="NAMES",
                   help="the unknowns: force, angle, at (of the payload), or F1, Omega1, s1, F2, ... (default force,angle); "
                        "3-D also out (Beta1) and moment (mx1, my1, mz1 at the tip) (default force,angle,out)")
    p.add_argument("--3d", dest="three_d", action="store_true", help="estimate with the 3-D model (chosen by itself by a 3-D flag or pose file; docs/sensing.md)")
    p.add_argument("--section", action="append", metavar="NAME=VALUE", help="3-D: section stiffness EI_side=..., GJ=... (N*mm^2; default the eccentric section's)")
    p.add_argument("--sigma", action="append", metavar="NAME=SIGMA", help="an actuator parameter's uncertainty carried into the load's (E=5%%, rho=±1; repeatable)")
    p.add_argument("--fit", metavar="FIT.json", help="actuator values and covariance from `esba fit --json` (carried into the load's uncertainty)")
    p.add_argument("--frozen", action="store_true", help="with --fit: the actuator frozen at the fit's values, its covariance not carried")
    p.add_argument("--level", type=_level, default=0.95, help="confidence level of the intervals (default 0.95)")
    p.add_argument("--starts", type=count_arg("--starts", 0, 200), default=12, help="start loads besides the scene's payload (default 12)")
    p.set_defaults(func=_cmd_estimate)

"""Argument types and the scene flags shared by ``esba`` commands.

Every type rejects a bad value with one line naming the flag, the value and what is allowed
(:class:`UsageError`, exit code 2), when the flags are parsed, before any computation.
"""

from __future__ import annotations

import argparse
import re
import sys
from typing import Callable, Sequence

from esba.derive.effects import DEFAULT_VARIANT, VARIANTS
from esba.infra import checks, outputs
from esba.infra.errors import InputError


class UsageError(InputError):
    """Bad input from the command line: reported in one line with exit code 2."""


#: A token that starts like a negative number (``-3.95,6.25``, ``-.5``, ``-1:2:5``) is a value,
#: never a flag: no esba flag starts with a digit. argparse's own rule takes only one plain number
#: (``-3.95``), so a list that starts negative would be "expected one argument".
NEGATIVE_VALUE = re.compile(r"^-\.?\d")


class Parser(argparse.ArgumentParser):
    """An argparse parser whose errors are :class:`UsageError` (one line, exit code 2), and whose
    flags take values that start with a minus sign (:data:`NEGATIVE_VALUE`)::

        >>> p = Parser(prog="x")
        >>> _ = p.add_argument("--theta")
        >>> p.parse_args(["--theta", "-3.95,6.25,20.24"]).theta
        '-3.95,6.25,20.24'
    """

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_VALUE  # argparse's hook (all supported Pythons)

    def error(self, message: str) -> None:  # one line, exit 2 (argparse prints usage too)
        raise UsageError(message)


_WHOLE = re.compile(r"\s*\d+\s*", re.ASCII)  # ASCII digits only: int() also reads other scripts' digits


def segments_arg(text: str) -> int:
    """An argparse type: the segment count n, 1 to :data:`esba.infra.checks.MAX_SEGMENTS`."""
    if not _WHOLE.fullmatch(text):
        raise argparse.ArgumentTypeError(f"segments={text!r}: expected a whole number from 1 to {checks.MAX_SEGMENTS}")
    try:
        return checks.segments(int(text))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def count_arg(name: str, low: int, high: int, why: str = "") -> Callable[[str], int]:
    """An argparse type: a whole number from ``low`` to ``high`` (``why`` explains the bound)."""

    def parse(text: str) -> int:
        value = int(text) if _WHOLE.fullmatch(text) else None
        if value is None or not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{name}={text}: expected a whole number from {low} to {high}" + (f" ({why})" if why else ""))
        return value

    return parse


def given_flags(args: argparse.Namespace, *dests: str) -> list[str]:
    """The flags among ``dests`` that were given (not None, not False), as the user spells them."""
    return ["--" + d.replace("_", "-") for d in dests if getattr(args, d, None) not in (None, False)]


def refuse(args: argparse.Namespace, dests: Sequence[str], why: str) -> None:
    """A usage error when any of ``dests`` was given: they would be silently ignored."""
    given = given_flags(args, *dests)
    if given:
        raise UsageError(f"{', '.join(given)} {'is' if len(given) == 1 else 'are'} not used {why}")


def one_of(args: argparse.Namespace, *pairs: tuple[str, str]) -> None:
    """A usage error when both flags of a pair were given (``--out`` and ``--no-out``): the
    command cannot do both, and silently obeying one would surprise."""
    for a, b in pairs:
        if len(given_flags(args, a, b)) == 2:
            raise UsageError(f"--{a.replace('_', '-')} and --{b.replace('_', '-')}: give one of the two")


def with_json(args: argparse.Namespace, *dests: str) -> None:
    """A usage error when a flag that only shapes the JSON output is given without ``--json``."""
    given = given_flags(args, *dests)
    if given and not getattr(args, "json", False):
        raise UsageError(f"{', '.join(given)} only shapes the JSON output: give {'it' if len(given) == 1 else 'them'} with --json")


def float_arg(text: str) -> float:
    """A number as people write it; Python's ``float()`` would also read ``0_1`` as 1."""
    try:
        return checks.number("value", text)
    except ValueError as exc:
        if "smallest normal" in str(exc):  # a subnormal number: said as such
            raise argparse.ArgumentTypeError(str(exc).removeprefix("value ")) from None
        raise argparse.ArgumentTypeError(f"{checks.quote(text)} is not a number (expected decimal digits such as 0.1 or 2e-3)") from None


def vector_arg(text: str) -> tuple[float, float, float]:
    """Three numbers written X,Y,Z."""
    parts = text.split(",")
    if len(parts) != 3:
        raise argparse.ArgumentTypeError(f"{checks.quote(text)}: expected three numbers X,Y,Z")
    return tuple(float_arg(v.strip()) for v in parts)  # type: ignore[return-value]


#: The actuator's parameters as flags, named as in a scene file's ``[actuator]`` table:
#: :data:`esba.model.scene.ACTUATOR_RULES` (field -> unit, meaning), written out here so that
#: building the parser imports nothing of the model (a test checks they agree). One definition
#: for every command: :func:`add_actuator_flags`.
ACTUATOR_FLAGS: dict[str, tuple[str, str]] = {
    "L": ("mm", "length of the inextensible layer"),
    "r1": ("mm", "external radius"),
    "r2": ("mm", "chamber radius"),
    "d": ("mm", "eccentric distance of the chamber"),
    "rho_deg": ("deg", "fibre winding angle rho"),
    "E": ("MPa", "Young's modulus of the rubber"),
    "M": ("kg", "mass (used only with gravity)"),
}


#: Other spellings of an actuator flag: ``--rho`` (as ``esba section``, ``--sigma rho=...`` and ``--param rho`` name it).
ACTUATOR_ALIASES: dict[str, tuple[str, ...]] = {"rho_deg": ("--rho",)}


def actuator_flag(name: str) -> str:
    """The flag of actuator field ``name``: ``--E``, ``--rho-deg``."""
    return "--" + name.replace("_", "-")


def add_actuator_flags(p: argparse.ArgumentParser, names: Sequence[str] = tuple(ACTUATOR_FLAGS), values: Callable[[str], list[float]] | None = None,
                       note: str = "") -> None:
    """The actuator flags ``names`` (``--L``, ``--r1``, ``--r2``, ``--d``, ``--rho-deg``, ``--E``, ``--M``): one
    number each, overriding the scene file's ``[actuator]`` value, or with ``values`` (a sweep) a list
    or range each. A bad value is refused by the scene's own rules when the scene is built
    (:func:`scene_from_args`), before any computation."""
    group = p.add_argument_group("actuator", "the actuator's parameters, as in a scene file's [actuator] table (they override it)" + note)
    for name in names:
        unit, what = ACTUATOR_FLAGS[name]
        flags = (actuator_flag(name), *ACTUATOR_ALIASES.get(name, ()))
        if values is None:
            group.add_argument(*flags, dest=name, type=float_arg, metavar=unit.upper(), help=f"{what}, {unit}")
        else:
            group.add_argument(*flags, dest=name, type=values, metavar="VALUES", help=f"{what}, {unit} (VALUES: start:stop:count or v1,v2,...)")


def actuator_changes(args: argparse.Namespace, names: Sequence[str] = tuple(ACTUATOR_FLAGS)) -> dict[str, float]:
    """The actuator fields that flags set (field -> value), for :meth:`esba.model.scene.Scene.replace`,
    each checked on its own by the scene's rule (a usage error naming the flag); the chamber's fit
    (r2 + d < r1) is checked when the scene is built."""
    from esba.model.scene import SceneError, check_actuator_field

    try:
        return {name: check_actuator_field(name, getattr(args, name), actuator_flag(name)) for name in names if getattr(args, name, None) is not None}
    except SceneError as exc:
        raise UsageError(str(exc)) from None


def add_scene_flags(p: argparse.ArgumentParser, payloads: bool = True) -> None:
    p.add_argument("scene", nargs="?", default=None, metavar="SCENE.toml", help="scene file (default: the main job, Table 1 with a 2 N horizontal tip payload, n = 3)")
    p.add_argument("--segments", "-n", type=segments_arg, help="segment count n, 1 to 256")
    drive = p.add_mutually_exclusive_group()
    drive.add_argument("--pressure", type=float_arg, help="pressure, MPa")
    drive.add_argument("--target-angle", type=float_arg, metavar="DEG", help="use the pressure that bends the unloaded actuator to DEG")
    if payloads:
        p.add_argument("--payload", type=float_arg, action="append", metavar="N", help="payload magnitude in N (repeatable; replaces the scene's payloads)")
        p.add_argument("--payload-angle", type=float_arg, action="append", metavar="DEG", help="direction Omega of the k-th payload from the vertical (90 = horizontal; one value applies to all)")
        p.add_argument("--payload-at", type=float_arg, action="append", metavar="FRACTION", help="point of the k-th payload as a fraction of L (1 = tip; one value applies to all)")
        p.add_argument("--payload-out-of-plane", type=float_arg, action="append", metavar="DEG",
                       help="angle Beta of the k-th payload out of the bending plane, -90..90 (needs the 3-D model: solve --3d; one value applies to all)")
        p.add_argument("--no-payload", action="store_true", help="no payloads (and no payload terms)")
        p.add_argument("--moment", type=vector_arg, action="append", metavar="MX,MY,MZ",
                       help="a point moment in N mm, axes of the straight actuator (x along it, y the bending direction, z the "
                            "layer's normal); repeatable; replaces the scene's moments; needs the 3-D model (solve --3d)")
        p.add_argument("--moment-at", type=float_arg, action="append", metavar="FRACTION", help="point of the k-th moment as a fraction of L (1 = tip; one value applies to all)")
        p.add_argument("--moment-arm", type=vector_arg, action="append", metavar="AX,AY,AZ",
                       help="make the k-th moment a couple of dead forces on a rigid arm along this direction of the section "
                            "(perpendicular to the moment; docs/3d.md; one value applies to all)")
    p.add_argument("--gravity", action="store_true", default=None, help="include the actuator's weight (Eq. 15)")
    p.add_argument("--no-fibres", action="store_true", help="leave out the fibre restraint (Eq. 18)")
    p.add_argument("--variant", choices=VARIANTS, default=None, help=f"model variant (default: the scene's, else {DEFAULT_VARIANT})")
    p.add_argument("--json", action="store_true", help="print JSON")
    add_actuator_flags(p)


def _per_payload(flag: str, values: list | None, count: int, what: str = "payload", add: str = "--payload N") -> list | None:
    if values is None:
        return None
    if count == 0:
        raise UsageError(f"{flag} given but there is no {what}: add {add}")
    if len(values) == 1:
        return values * count
    if len(values) != count:
        raise UsageError(f"{flag} given {len(values)} times for {count} {what}s: give it once (for all) or once per {what}")
    return values


def scene_changes(args: argparse.Namespace, skip: tuple[str, ...] = ()) -> dict:
    """The scene fields that the common flags override (flags a command lacks count as unset).

    ``skip`` names flags that mean something else to the command (a sweep's --pressure is a grid).
    """
    flags = {"segments": "segments", "pressure": "pressure", "target_angle": "target_angle_deg", "variant": "variant"}
    changes = {
        field: getattr(args, flag) for flag, field in flags.items() if flag not in skip and getattr(args, flag, None) is not None
    }
    changes.update(actuator_changes(args, [name for name in ACTUATOR_FLAGS if name not in skip]))
    if getattr(args, "gravity", False):
        changes["gravity"] = True
    if getattr(args, "no_fibres", False):
        changes["fibres"] = False
    return changes


def load_scene_file(path: str | None, default):
    """The scene file ``path`` (an empty name is an error, not the default), else ``default``."""
    from esba.model.scene import SceneError, load_scene

    if path is None:
        return default
    if not path.strip():
        raise SceneError(f"scene file {path!r}: expected the path of a TOML scene file (or no argument for the default scene)")
    return load_scene(path)


def scene_from_args(args: argparse.Namespace, payloads: bool = True):
    """The scene file (or the main job) with the flags applied; bad values are usage errors."""
    from esba.model.scene import MAIN_JOB, Moment, Payload, SceneError

    try:
        scene = load_scene_file(args.scene, MAIN_JOB)
        changes = scene_changes(args)
        if payloads:
            if args.no_payload and (args.payload or args.payload_angle or args.payload_at or args.payload_out_of_plane):
                raise UsageError("--no-payload cannot be combined with --payload, --payload-angle, --payload-at or --payload-out-of-plane")
            current = list(scene.payloads)
            if args.no_payload:
                current = []
            elif args.payload is not None:
                current = [Payload(f) for f in args.payload]
            angles = _per_payload("--payload-angle", args.payload_angle, len(current))
            ats = _per_payload("--payload-at", args.payload_at, len(current))
            betas = _per_payload("--payload-out-of-plane", args.payload_out_of_plane, len(current))
            if args.no_payload or args.payload is not None or angles or ats or betas:
                current = [
                    Payload(p.force, angles[k] if angles else p.angle_deg, ats[k] if ats else p.at, betas[k] if betas else p.out_of_plane_deg)
                    for k, p in enumerate(current)
                ]
                changes["payloads"] = tuple(current)
            moments = list(scene.moments) if args.moment is None else [Moment(m) for m in args.moment]
            ats = _per_payload("--moment-at", args.moment_at, len(moments), "moment", "--moment MX,MY,MZ")
            arms = _per_payload("--moment-arm", args.moment_arm, len(moments), "moment", "--moment MX,MY,MZ")
            if args.moment is not None or ats or arms:
                changes["moments"] = tuple(Moment(m.moment, ats[k] if ats else m.at, arms[k] if arms else m.arm)
                                           for k, m in enumerate(moments))
        return scene.replace(**changes) if changes else scene
    except SceneError as exc:
        raise UsageError(str(exc)) from None


def gravity_direction_arg(args: argparse.Namespace, scene) -> tuple[float, float, float]:
    """``--gravity-direction X,Y,Z`` checked (one line naming it); when not given, the scene's
    (its file's ``gravity_direction``, default (1, 0, 0): down)."""
    if getattr(args, "gravity_direction", None) is None:
        return scene.down()
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


def output_file_arg(*suffixes: str) -> Callable[[str], str]:
    """An argparse type for a file to write (:func:`esba.infra.outputs.check_file`), checked when the flags are
    parsed, before any computation."""

    def check(text: str) -> str:
        try:
            outputs.check_file(text, "file", suffixes)
        except outputs.OutputError as exc:
            raise argparse.ArgumentTypeError(str(exc).removeprefix("file ")) from None
        return text

    return check


def scene_figure(args: argparse.Namespace, default: str) -> str | None:
    """The figure a scene command writes: ``--plot`` (a file or a folder), else ``default`` when no
    scene file is given, none with ``--no-plot`` (which cannot be combined with ``--plot``)."""
    if args.no_plot and args.plot is not None:
        raise UsageError("--plot and --no-plot: give one of the two")
    plot = args.plot
    if plot is None and args.scene is None and not args.no_plot:
        plot = default
    return outputs.figure_file(plot, "--plot", default) if plot is not None and not args.no_plot else None


def write_page(args: argparse.Namespace, command: str, page, settings_type, ignored: Sequence[tuple[str, object]]) -> None:
    """``esba COMMAND --write-doc FILE``: write the docs page ``page`` (its own cases of the Table 1
    actuator, so none of the flags ``ignored`` (flag, value) may be given with it), its progress on
    stderr unless ``--json``, then the file written."""
    from .results import print_result

    given = [flag for flag, v in ignored if v is not None] + [actuator_flag(name) for name in actuator_changes(args)]
    if given:
        raise UsageError(f"--write-doc runs its own cases of the Table 1 actuator: give no {', '.join(given)} with it")
    outputs.check_file(args.write_doc, "--write-doc", (".md",))

    def say(msg):
        if not args.json:
            print(f"  {msg}", file=sys.stderr)

    written = page.write(args.write_doc, settings_type(f"esba {command} --write-doc {args.write_doc}"), progress=say).path
    print_result(args, {"page": str(written.resolve())}, lambda d: f"wrote {d['page']}")


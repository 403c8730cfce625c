"""``esba section``: the actuator's cross-section (area, centroid, second moments, torsion constant,
shear centre) and the composite's stiffnesses, from :mod:`esba.model.section`."""

from __future__ import annotations

import argparse
import dataclasses

from .arguments import UsageError, count_arg, float_arg, load_scene_file
from .results import EXIT_OK, print_result, warn_findings

#: The finest mesh level the command takes (each level doubles the mesh both ways; level 4 takes
#: seconds and resolves J to about 1e-8).
MAX_CLI_MESH = 4


def _flag(field: str) -> str:
    """The flag of a parameter of :func:`esba.model.section.section_stiffness`, for the messages."""
    from esba.model.section import SECTION_FLAGS

    return "--rho (or the scene's rho_deg)" if field == "rho_deg" else SECTION_FLAGS.get(field) or field


def _section_data(args: argparse.Namespace) -> dict:
    from esba.model.scene import MAIN_JOB, SceneError
    from esba.model.section import SectionError, section_stiffness

    try:
        a = load_scene_file(args.scene, MAIN_JOB).actuator
        changes = {k: getattr(args, k) for k in ("r1", "r2", "d", "E", "rho_deg") if getattr(args, k) is not None}
        a = dataclasses.replace(a, **changes) if changes else a  # validated again: one line naming the field
    except SceneError as exc:
        raise UsageError(str(exc)) from None
    options = {
        "E_layer": args.E_layer,
        "layer_width": args.layer_width,
        "layer_thickness": args.layer_thickness,
        "layer_depth": args.layer_depth,
        "nu": args.nu,
        "fibres": args.fibres,
        "fibre_efficiency": args.fibre_efficiency,
        "E_fibre": args.E_fibre,
        "fibre_diameter": args.fibre_diameter,
        "fibres_per_helix": args.fibres_per_helix,
        "mesh": args.mesh,
    }
    options = {k: v for k, v in options.items() if v is not None}
    try:
        k = section_stiffness(a.r1, a.r2, a.d, a.E, rho_deg=a.rho_deg, **options)
    except SectionError as exc:  # named as the flag that gave it (the scene's fields are checked above)
        field, _, rest = str(exc).partition("=")
        raise UsageError(f"{_flag(field)}={rest}" if rest else str(exc)) from None
    p = k.section
    return {
        "inputs": {"r1": a.r1, "r2": a.r2, "d": a.d, "E": a.E, **{name: v for name, v in k.parameters if name != "mesh"}},
        "section": {
            "area": p.area,
            "centroid": list(p.centroid),
            "I_yy": p.I_yy,
            "I_zz": p.I_zz,
            "I_yz": p.I_yz,
            "torsion_constant": p.torsion_constant,
            "torsion_upper": p.torsion_upper,
            "torsion_error": p.torsion_error,
            "shear_centre": list(p.shear_centre),
            "mesh": p.mesh,
        },
        "stiffness": {
            "EI_bend": k.EI_bend,
            "EI_side": k.EI_side,
            "GJ": k.GJ,
            "GJ_silicone": k.GJ_silicone,
            "GJ_layer": k.GJ_layer,
            "GJ_fibres": k.GJ_fibres,
            "EA": k.EA,
            "neutral_axis": list(k.neutral_axis),
        },
    }


def _point(p) -> str:
    return f"({p[0]:.4f}, {p[1]:.4f})"


def _table(d: dict) -> str:
    i, s, k = d["inputs"], d["section"], d["stiffness"]
    rows = [
        f"section r1={i['r1']:g} r2={i['r2']:g} d={i['d']:g} mm, E={i['E']:g} MPa, rho={i['rho_deg']:g} deg "
        "(y toward the bending side from the inextensible line, z = x × y)",
        "silicone (the chamber a hole)",
        f"  area A                  {s['area']:12.4f} mm²",
        f"  centroid (y, z)         {_point(s['centroid'])} mm",
        f"  I_yy = ∫z² dA           {s['I_yy']:12.3f} mm⁴   (sideways bend)",
        f"  I_zz = ∫y² dA           {s['I_zz']:12.3f} mm⁴   (in-plane bend)",
        f"  I_yz                    {s['I_yz']:12.3f} mm⁴",
        f"  torsion constant J      {s['torsion_constant']:12.3f} mm⁴   (Prandtl; warping bound {s['torsion_upper']:.3f}, gap {s['torsion_error']:.1e}, mesh {s['mesh']})",
        f"  shear centre (y, z)     {_point(s['shear_centre'])} mm",
        "composite (silicone + layer + fibres)",
        f"  EI_bend                 {k['EI_bend']:12.2f} N·mm²  (about the neutral axis y = {k['neutral_axis'][0]:.4f} mm)",
        f"  EI_side                 {k['EI_side']:12.2f} N·mm²",
        f"  GJ                      {k['GJ']:12.2f} N·mm²  (silicone {k['GJ_silicone']:.2f} + layer {k['GJ_layer']:.2f} + fibres {k['GJ_fibres']:.2f})",
        f"  EA                      {k['EA']:12.2f} N",
        f"parameters: layer {i['layer_width']:g} x {i['layer_thickness']:g} mm at depth {i['layer_depth']:g} mm, E_layer={i['E_layer']:g} MPa, "
        f"nu_layer={i['nu_layer']:g}, nu={i['nu']:g}; fibres {i['fibres']} (efficiency {i['fibre_efficiency']:g}, "
        f"E_fibre={i['E_fibre']:g} MPa, {i['fibres_per_helix']} x {i['fibre_diameter']:g} mm per helix)",
    ]
    return "\n".join(rows)


#: The relative gap between J's two bounds above which the command warns (a wall too thin for the mesh).
WARN_TORSION_ERROR = 1e-3


def _cmd_section(args: argparse.Namespace) -> int:
    data = _section_data(args)
    print_result(args, data, _table)
    s = data["section"]
    if s["torsion_error"] > WARN_TORSION_ERROR:
        finer = f"; a finer --mesh (up to {MAX_CLI_MESH}) narrows it" if s["mesh"] < MAX_CLI_MESH else ""
        warn_findings([{"message": f"the torsion constant's bounds differ by {s['torsion_error']:.1e} of J on mesh {s['mesh']} (a thin wall){finer}"}])
    return EXIT_OK


def add_section(sub) -> None:
    p = sub.add_parser("section", help="the cross-section: area, centroid, second moments, torsion constant, shear centre, stiffnesses")
    p.add_argument("scene", nargs="?", default=None, metavar="SCENE.toml", help="scene file whose actuator is used (default: Table 1)")
    p.add_argument("--r1", type=float_arg, metavar="MM", help="external radius (default: the scene's)")
    p.add_argument("--r2", type=float_arg, metavar="MM", help="chamber radius (default: the scene's)")
    p.add_argument("--d", type=float_arg, metavar="MM", help="eccentric distance of the chamber (default: the scene's)")
    p.add_argument("--E", type=float_arg, metavar="MPA", help="silicone's Young's modulus (default: the scene's)")
    p.add_argument("--rho", dest="rho_deg", type=float_arg, metavar="DEG", help="fibre angle from the hoop direction, degrees (default: the scene's)")
    p.add_argument("--E-layer", dest="E_layer", type=float_arg, metavar="MPA", help="inextensible layer's modulus (default 6500, Section 4.2)")
    p.add_argument("--layer-width", type=float_arg, metavar="MM", help="layer width across z (default r1; not in the paper)")
    p.add_argument("--layer-thickness", type=float_arg, metavar="MM", help="layer thickness (default 0.3; not in the paper)")
    p.add_argument("--layer-depth", type=float_arg, metavar="MM", help="layer mid-plane below the inextensible line (default 0, the paper's)")
    p.add_argument("--nu", type=float_arg, help="silicone's Poisson's ratio, 0 to 0.5 (default 0.5: G = E/3)")
    p.add_argument("--fibres", choices=("slack", "taut", "none"), help="the fibres' state: slack (default, unpressurised), taut (pressurised), none")
    p.add_argument("--fibre-efficiency", type=float_arg, metavar="X", help="factor on the fibres' torsional stiffness (default 1; 0: none)")
    p.add_argument("--E-fibre", dest="E_fibre", type=float_arg, metavar="MPA", help="Kevlar's modulus, for --fibres taut (default 31067, Section 4.2)")
    p.add_argument("--fibre-diameter", type=float_arg, metavar="MM", help="fibre diameter, for --fibres taut (default 0.2; not in the paper)")
    p.add_argument("--fibres-per-helix", type=count_arg("--fibres-per-helix", 1, 1000), metavar="N", help="fibres per helix, for --fibres taut (default 1)")
    p.add_argument("--mesh", type=count_arg("--mesh", 0, MAX_CLI_MESH, "each level doubles the mesh"), help=f"mesh level 0 to {MAX_CLI_MESH} (default 2)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_section)

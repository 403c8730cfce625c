"""``esba solve --3d`` on a scene with obstacles: the 3-D contact solve (esba.statics.contact.spatial),
its contacts and KKT numbers, and optionally its figure (``--plot``)."""

from __future__ import annotations

import argparse
import sys

from esba.statics.text import gaps_text

from .results import EXIT_FAILED, EXIT_OK, print_result

__all__ = ["cmd_solve_contact3d", "cmd_equilibria_contact3d"]


def _table(d: dict) -> str:
    k = d["kkt"]
    rows = [
        ("scene", d["scene"]),
        ("model", d["model"]),
        ("section", f"EI_side {d['section_nmm2']['EI_side']:.6g} N mm^2, GJ {d['section_nmm2']['GJ']:.6g} N mm^2"),
        ("theta deg", "  ".join(f"{v:.4f}" for v in d["theta_deg"])),
        ("psi deg", "  ".join(f"{v:.4f}" for v in d["psi_deg"])),
        ("tau deg", "  ".join(f"{v:.4f}" for v in d["tau_deg"])),
        ("tip mm", "  ".join(f"{v:.4f}" for v in d["tip_mm"])),
        ("obstacles", "; ".join(f"#{i + 1} {o['kind']}, touching " + ("the body (tube)" if o["touches"] == "tube" else f"the {o['touches']} line")
                                for i, o in enumerate(d["obstacles"]))),
        ("contacts", "; ".join(
            f"{c['where']} (s = {c['s']:.4f}) {c['force_n']:.4f} N = ({c['force_vector_n'][0]:.4f}, {c['force_vector_n'][1]:.4f}, {c['force_vector_n'][2]:.4f}) N "
            f"at ({c['point_mm'][0]:.2f}, {c['point_mm'][1]:.2f}, {c['point_mm'][2]:.2f}) mm, {c['kind']} #{c['obstacle'] + 1}" for c in d["contacts"]) or "none"),
        ("gaps", gaps_text(d["gaps_elsewhere_mm"])),
        ("KKT", f"stationarity {k['stationarity_nmm']:.1e} N mm/rad, least gap {k['min_gap_mm']:.1e} mm, least force {k['min_force_n']:.1e} N, "
                f"complementarity {k['complementarity_nmm']:.1e} N mm; reduced Hessian on {k['active']} active: {k['stability']} "
                f"(least eigenvalue {min(k['reduced_eigenvalues'], default=float('nan')):.4g} N mm/rad^2)"),
        ("solver", f"{d['status']}; {d['iterations']} IPOPT iterations, {d['outer_passes']} passes, {d['halvings']} halved steps, {d['solve_time_s']:.3f} s"),
    ]
    if d.get("message"):
        rows.append(("NOT OK", d["message"]))
    if d.get("figure"):
        rows.append(("figure", f"wrote {d['figure']}"))
    return "\n".join(f"{a:>12}: {b}" for a, b in rows)


def cmd_solve_contact3d(args: argparse.Namespace, scene, section: dict, down, figure) -> int:
    """The 3-D solve of a scene with obstacles; ``figure`` a checked path or None."""
    from esba.statics.contact.spatial import solve_contact3d

    result = solve_contact3d(scene, section, gravity_direction=down)
    data = result.to_dict()
    data["scene"] = scene.describe()
    data["section_nmm2"] = {name: result.values[name] for name in ("EI_side", "GJ")}
    if figure is not None:
        from esba.figures.contact3d import contact3d_figure
        from esba.figures.scenes import save_figure

        data["figure"] = str(save_figure(contact3d_figure(result), figure))
    print_result(args, data, _table)
    if not result.ok:
        print(f"esba: solve not ok: {result.message or result.status}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _equilibria_table(d: dict) -> str:
    lines = [f"scene: {d['scene']}", f"pressure: {d['pressure_mpa']:.7f} MPa; section EI_side {d['section_nmm2'].get('EI_side', float('nan')):.6g}, "
             f"GJ {d['section_nmm2'].get('GJ', float('nan')):.6g} N mm^2",
             f"method: {d['method']} ({d['free_equilibria']} free equilibria, {d['dropped']} dropped: no contact equilibrium reached from them)",
             f"  {'#':>2}  {'stability':<9} {'bend':>8} {'side':>7} {'twist':>8} {'tip x, y, z mm':>26} {'energy N mm':>12}  contacts (where, force N)"]
    for k, s in enumerate(d["states"], start=1):
        bend, side, twist = sum(s["theta_deg"]), sum(s["psi_deg"]), sum(s["tau_deg"])
        tip = ",".join(f"{v:>8.2f}" for v in s["tip_mm"])
        where = "; ".join(f"{c['where']} {c['force_n']:.4f}" for c in s["contacts"]) or "none"
        lines.append(f"  {k:>2}  {s['kkt']['stability']:<9} {bend:>8.2f} {side:>7.2f} {twist:>8.2f} {tip:>26} {s['energy_nmm']:>12.4f}  {where}")
    lines.append("  (bend, side, twist: the sums of theta, psi and tau in degrees)")
    return "\n".join(lines)


def cmd_equilibria_contact3d(args: argparse.Namespace, scene, section: dict, down) -> int:
    """``esba equilibria --3d`` on a scene with obstacles: esba.statics.contact.multistart.contact_equilibria3d."""
    from esba.statics.contact.multistart import contact_equilibria3d

    result = contact_equilibria3d(scene, section, gravity_direction=down, starts=args.starts)
    data = result.to_dict()
    data["scene"] = scene.describe()
    print_result(args, data, _equilibria_table)
    if not result.states:
        print("esba: failed: no contact equilibrium found from the free 3-D equilibria", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK

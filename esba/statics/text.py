"""The text ``esba solve`` and ``esba equilibria`` print: a computation returns data (``to_dict``),
these functions render it, and :meth:`esba.statics.equilibrium.Equilibrium.summary` and
:meth:`esba.statics.equilibria.Equilibria.summary` print the same text in Python.

They read only the plain dicts of the results (with the scene's one-line description added under
``scene``), so any floor may render with them.
"""

from __future__ import annotations

__all__ = ["solve_table", "equilibria_table", "sensitivity_rows", "uncertainty_rows", "gaps_text"]


def _fmt(values, digits: int = 3) -> str:
    return ", ".join(f"{v:.{digits}f}" for v in values)


def gaps_text(gaps) -> str:
    """Each obstacle's least gap over the points not in contact (``gaps_elsewhere_mm``; None: all in contact)."""
    return "; ".join(f"#{i + 1} {'-' if g is None else format(g, '.4f') + ' mm'}" for i, g in enumerate(gaps)) + " (least elsewhere)"


def _solver_row(d: dict) -> str:
    """What the solve did: the free solve's path points and IPOPT iterations, or the contact solve's steps."""
    c = d.get("contact")
    if not c:
        return f"{d['certificate'] or 'IPOPT ' + d['status']}; {d['steps']} path points and solves, {d['iterations']} iterations in all, {d['solve_time_s']:.3f} s"
    return (f"contact solve {d['status']}: {c['newton_steps']} load steps by active-set Newton, {c['ipopt_steps']} by IPOPT "
            f"({d['iterations']} IPOPT iterations in {c['outer_passes']} passes), {c['halvings']} halved, {d['solve_time_s']:.3f} s")


def solve_table(d: dict) -> str:
    """The text of ``esba solve`` for a solve's :meth:`~esba.statics.equilibrium.Equilibrium.to_dict` (with ``scene``,
    and the ``sensitivities``, ``uncertainty``, ``monte_carlo`` and ``figure`` the command adds)."""
    terms = ", ".join(f"{k} {v:.3f}" for k, v in d["energy_terms_nmm"].items())
    loads = "; ".join(f"{p['force_n']:g} N at {p['angle_deg']:g} deg, s = {p['at']:g}" for p in d["payloads"]) or "none"
    rows = [
        ("scene", d["scene"]),
        ("effects", ", ".join(d["effects"])),
        ("payloads", loads),
        ("pressure", f"{d['pressure_mpa']:.7f} MPa ({d['pressure_from']})"),
        ("theta", f"({_fmt(d['theta_deg'], 2)}) deg"),
        ("total angle", f"{d['total_angle_deg']:.3f} deg"),
        ("tip x, y", f"{d['tip_mm'][0]:.3f}, {d['tip_mm'][1]:.3f} mm (orientation {d['tip_angle_deg']:.2f} deg)"),
        ("energy", f"{d['energy_nmm']:.4f} N mm ({terms})"),
        ("stability", f"{d['stability']} ({'reduced Hessian eigenvalues (on the constrained set)' if d.get('contact') else 'Hessian eigenvalues'} "
                      f"{_fmt(d['eigenvalues'], 3)} N mm/rad^2)"),
        ("solver", _solver_row(d)),
    ]
    if d.get("message"):
        rows.append(("NOT OK", d["message"]))
    if d.get("contact"):  # a scene with obstacles: its contacts and KKT numbers
        c, k = d["contact"], d["contact"]["kkt"]
        rows.append(("contacts", "; ".join(f"{x['where']} (s = {x['s']:.4f}) {x['force_n']:.4f} N along ({x['direction'][0]:.3f}, {x['direction'][1]:.3f}), {x['kind']} #{x['obstacle'] + 1}"
                                           for x in c["contacts"]) or "none"))
        rows.append(("gaps", gaps_text(c["gaps_elsewhere_mm"])))
        rows.append(("KKT", f"stationarity {k['stationarity_nmm']:.1e} N mm/rad, least gap {k['min_gap_mm']:.1e} mm, least force {k['min_force_n']:.1e} N, "
                            f"complementarity {k['complementarity_nmm']:.1e} N mm; reduced Hessian on {k['active']} active: {k['stability']}"))
    if d.get("history"):
        rows.append(("history", d["history"]))
    if d.get("multistability"):
        rows.append(("other states", d["multistability"]["message"]))
    for note in d.get("notes", []):
        rows.append(("note", note))
    if d.get("sensitivities"):
        rows += sensitivity_rows(d)
    if d.get("uncertainty"):
        rows += uncertainty_rows(d)
    if d.get("figure"):
        rows.append(("figure", f"wrote {d['figure']}"))
    return "\n".join(f"{k:>12}: {v}" for k, v in rows)


def sensitivity_rows(d: dict) -> list[tuple[str, str]]:
    """The rows of ``d["sensitivities"]`` (:meth:`esba.analysis.sensitivity.Sensitivities.to_dict`)."""
    s = d["sensitivities"]
    if s["status"] != "ok":
        return [("sensitivity", s["message"])]
    rows = [("sensitivity", "per unit of each parameter, the others held (implicit function theorem, exact AD); fold: linear estimate of the change that reaches it")]
    if s.get("held_fixed"):
        rows.append(("held fixed", s["held_fixed"]["meaning"]))
    if s.get("round_off"):
        rows.append(("round-off", s["round_off"]))
    rows.append(("", f"{'parameter':<14} {'value':>10} {'unit':<6} {'d angle (deg)':>14} {'d tip x (mm)':>13} {'d tip y (mm)':>13} {'fold':>10}"))
    for name, r in s["parameters"].items():
        fold = "-" if r["fold_distance"] is None else f"{r['fold_distance']:+.3g}"
        rows.append(("", f"{name:<14} {r['value']:>10.5g} {r['unit']:<6} {r['dtotal_angle_deg_per_unit']:>14.5g} "
                         f"{r['dtip_mm_per_unit'][0]:>13.5g} {r['dtip_mm_per_unit'][1]:>13.5g} {fold:>10}"))
    return rows


def uncertainty_rows(d: dict) -> list[tuple[str, str]]:
    """The rows of ``d["uncertainty"]`` (:meth:`esba.calibration.uncertainty.Propagation.to_dict`), and of
    ``d["monte_carlo"]`` and ``d["agreement"]`` when given."""
    u = d["uncertainty"]
    given = ", ".join(f"{s['name']} {s['sigma']:.4g} {s['unit']}" + (" (uniform)" if s["distribution"] == "uniform" else "") for s in u["sigmas"])
    rows = [("sigmas", given)]
    first = u["std_total_angle_deg"] is not None
    if not first:  # first order refuses (near a fold): the Monte Carlo, when run, is still reported below
        rows.append(("uncertainty", f"{u['status']}: {u['message']}"))
    else:
        e = u["tip_ellipse_95"]
        rows.append(("first order", f"std total angle {u['std_total_angle_deg']:.4g} deg; std tip x, y {u['std_tip_mm'][0]:.4g}, {u['std_tip_mm'][1]:.4g} mm; "
                                    f"95 % tip ellipse: semi-axes {e['semi_axes_mm'][0]:.3g} and {e['semi_axes_mm'][1]:.3g} mm, the major at {e['angle_deg']:.1f} deg from x"))
        if u["status"] != "ok":
            rows.append(("NOT LINEAR", u["message"]))
    mc = d.get("monte_carlo")
    if mc:
        c = mc["counts"]
        std = mc["std"]

        def num(v):
            return "-" if v is None else f"{v:.4g}"

        rows.append(("Monte Carlo", f"{c['samples']} samples (seed {mc['seed']}, {mc['backend']}): {c['ok']} solved, {c['invalid']} outside the scene's rules, "
                                    f"{c['not_ok']} without a stable equilibrium; std total angle {num(std['total_angle'])} deg, tip x, y "
                                    f"{num(std['tip_x'])}, {num(std['tip_y'])} mm"))
        st = mc.get("study")
        if st:
            where = f"; samples in {st['out']}" + (f" (resumed at sample {st['resumed_from_sample']})" if st.get("resumed_from_sample") else "") if st.get("out") else ""
            rows.append(("solved", f"{st['runner']} in {st['seconds']:.1f} s{where}"))
        if first:
            rows.append(("agreement", d["agreement"]["verdict"]))
        else:
            rows.append(("agreement", f"none to judge: first order gives no answer ({u['status']}, above); the Monte Carlo is the estimate"))
    return rows


def equilibria_table(d: dict) -> str:
    """The text of ``esba equilibria`` for :meth:`~esba.statics.equilibria.Equilibria.to_dict` (with ``scene``)."""

    lines = [
        f"scene: {d['scene']}",
        f"pressure: {d['pressure_mpa']:.7f} MPa",
        f"domain searched: {d['domain']['text']}",
        f"  {'#':>2}  {'stability':<9} {'Morse':>5} {'total deg':>10} {'tip x, y mm':>17} {'energy N mm':>12} {'min eigenvalue':>15}  theta deg",
    ]
    for k, s in enumerate(d["states"], start=1):
        tip = f"{s['tip_mm'][0]:7.2f}, {s['tip_mm'][1]:7.2f}"
        theta = ", ".join(f"{t:.2f}" for t in s["theta_deg"][:8]) + (", ..." if len(s["theta_deg"]) > 8 else "")
        lines.append(f"  {k:>2}  {s['stability']:<9} {s['morse_index']:>5} {s['total_angle_deg']:>10.3f} {tip:>17} {s['energy_nmm']:>12.4f} {s['min_eigenvalue']:>15.4g}  ({theta})"
                     + ("" if s["in_domain"] else "  OUTSIDE the model's domain"))
    stable = d["stable"]
    if d["least_energy_stable"] is not None:
        least = d["least_energy_stable"] + 1
        lines.append(f"stable: {len(stable)} ({'multistable' if d['multistable'] else 'one stable state'}); least energy: #{least}")
    else:
        lines.append("stable: none in the domain")
    if d["history_state"] is not None:
        lines.append(f"the load history (inflate, then load) reaches #{d['history_state'] + 1}")
    for b in d["barriers"]:
        lines.append(
            f"barrier: #{b['a'] + 1} <-> #{b['b'] + 1} through the saddle #{b['saddle'] + 1}: "
            f"{b['barrier_from_a_nmm']:.4f} N mm from #{b['a'] + 1}, {b['barrier_from_b_nmm']:.4f} N mm from #{b['b'] + 1}"
        )
    if d["complete"] is None:
        lines.append("completeness: not checked (--no-check)")
    else:
        lines.append("completeness: " + ("a second search from fresh starts found nothing new" if d["complete"] else f"the second search from fresh starts found {d['check_found']} more (listed above): the search may be incomplete"))
    listed = d["outside_domain"] - d["not_listed"]
    if listed:
        lines.append(f"outside the model's domain: {listed} of the states listed (the warnings say how, as solve's do)")
    if d["not_listed"]:
        lines.append(f"beyond the domain searched: {d['not_listed']} equilibria, not listed")
    lines.append(f"search: {d['starts']} starts, {d['rounds']} deflation rounds, {d['newton_runs']} Newton runs, {d['newton_iterations']} iterations, {d['time_s']:.3f} s")
    if d.get("figure"):
        lines.append(f"figure: wrote {d['figure']}")
    return "\n".join(lines)

"""The page ``docs/paths.md`` and its figures, rendered from :func:`esba.analysis.path_cases.path_cases`
(``esba path --write-doc docs/paths.md`` writes them; ``esba docs --check paths`` says whether the
committed page is stale).

Presentation only: every number comes from the path cases; nothing here traces a path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from esba.analysis.path_cases import COLUMN_NS, FOLD_NS, WINDOW_TO, PathCases, path_cases
from esba.figures.paths import path_figure
from esba.infra.roundoff import RELATIVE_FLOOR, floored
from esba.paths.continuation import SIDES

from .page import TIMES, Page, Progress, Rendered, Times

__all__ = ["PAGE", "PathsPage", "PathsSettings", "render_page", "FIGURES"]

#: The page's figures, in ``figures/`` beside it.
FIGURES = {"pressure": "path-pressure-2N.png", "direction": "path-omega-2N.png", "column": "path-column-n4.png"}


def _fold_row(label: str, folds: list[float]) -> str:
    """A table row: the label, the fold pressures (MPa) and the width between two folds (kPa)."""
    width = f"{1000 * abs(folds[0] - folds[1]):.2f}" if len(folds) == 2 else "-"
    return f"| {label} | {_fmt_folds(folds)} | {width} |"


def _fmt_folds(folds: list[float], digits: int = 5) -> str:
    return ", ".join(f"{f:.{digits}f}" for f in folds) if folds else "none"


def _side_rows(data: PathCases) -> list[tuple[dict, dict | None, dict | None]]:
    rows = []
    for row in data.buckling:
        sides = {s["direction"]: s for s in row["sides"]}
        rows.append((row, sides.get(SIDES[0]), sides.get(SIDES[1])))
    return rows


def _column_summary(data: PathCases) -> list[str]:
    """What the buckling table says, in words computed from it: the branch points' types and which
    side carries load and is stable."""
    kinds = sorted({row.get("bifurcation") for row in data.buckling if row.get("bifurcation")})
    if not kinds:
        return ["No branch point was found on these traces."]
    out = [f"The branch point is classified from the third derivative of U along the null vector phi, c = d3U[phi, phi, phi]"
           " (transcritical when c is not zero: the crossing branch passes through with the load changing; pitchfork"
           f" when it is: both sides leave at constant load). Here every one is **{' / '.join(kinds)}**"
           + (" (the eccentric chamber makes U not even in theta)." if kinds == ["transcritical"] else ".")]
    for name, other in ((SIDES[0], SIDES[1]), (SIDES[1], SIDES[0])):
        idx = 1 if name == SIDES[0] else 2
        rows = [r[idx] for r in _side_rows(data) if r[idx] is not None]
        if rows and all(s["load_after"] == "falls" and not s["stable_at_first"] for s in rows):
            folded = all(s["folds_n"] for s in rows)
            out.append(
                f"Bending {name.replace('chamber', 'the chamber')} sheds load and is unstable"
                + (", and turns stable again only at a fold far from the straight state; between that fold and the"
                   " buckling load the straight actuator and the bent one are both stable." if folded else ".")
            )
        elif rows and all(s["load_after"] == "rises" and s["stable_at_first"] for s in rows):
            out.append(f"Bending {name.replace('chamber', 'the chamber')} carries more load and is stable: the actuator buckles smoothly that way.")
    return [" ".join(out)]


def _designer_column(data: PathCases) -> str:
    """The designer's sentence about buckling: which way it bends, from the table."""
    rows = _side_rows(data)
    stable = [name for name, idx in ((SIDES[0], 1), (SIDES[1], 2)) if rows and all(r[idx] is not None and r[idx]["stable_at_first"] and r[idx]["load_after"] == "rises" for r in rows)]
    if len(stable) != 1:
        return "with no one side stable at every n (the table above)."
    other = SIDES[1] if stable[0] == SIDES[0] else SIDES[0]
    return (f"bending {stable[0].replace('chamber', 'its chamber')}; bent {other.replace('chamber', 'the chamber')} it is stable only"
            " beyond the fold, so a small disturbance that way near the buckling load can make it snap to a large bend.")


def _window_section(data: PathCases) -> list[str]:
    """The snapping window of the payload magnitude near 122.2 degrees, each direction's behaviour computed."""
    crossing = _window_crossing(data)
    lines = [
        f"## Payload magnitude near {np.mean([w['omega_deg'] for w in data.window]):.1f} degrees: a narrow window that snaps",
        "",
        f"With the pressure held at its 90 degree value and the payload's magnitude raised from 0 to {WINDOW_TO:g} N",
        f"(`esba path --param payload --target-angle 90 --payload-angle OMEGA --from 0 --to {WINDOW_TO:g}`, default steps),",
        f"two branches almost cross {crossing}, and hundredths of a degree decide the path:",
        "",
        "| Omega (deg) | folds, N (total angle, deg) | loading 0 -> 6 N | unloading 6 -> 0 N | angle at 6 N (deg) |",
        "|---|---|---|---|---|",
    ]

    def jumps(js: list) -> str:
        return "; ".join(f"snaps at the {k} {lam:.6f} N by {dist:.1f} mm ({a:.1f} -> {b:.1f} deg)" for k, lam, dist, a, b in js) or "no jump"

    for w in data.window:
        folds = ", ".join(f"{lam:.6f} ({ang:.1f})" for lam, ang in w["folds"]) or "none"
        if w["branch_points"]:
            folds += "; branch points " + ", ".join(f"{lam:.6f}" for lam in w["branch_points"])
        lines.append(f"| {w['omega_deg']:g} | {folds} | {jumps(w['jumps_up'])} | {jumps(w['jumps_down'])} | {w['end_angle_deg']:.1f} |")
    lines.append("")
    for w in data.window:
        o = f"{w['omega_deg']:g} deg"
        if w["folds"] and w["jumps_up"]:
            _, _, _, before, after = w["jumps_up"][0]
            way = "further away from the chamber" if after > before else "back towards the chamber"
            back = f"; unloading snaps back at {w['jumps_down'][0][1]:.6f} N" if w["jumps_down"] else "; unloading does not snap back"
            lines.append(
                f"- At {o} the stable branch bends on until the fold at **{w['folds'][0][0]:.6f} N**, where loading snaps"
                f" to the far branch, bending {way}{back}."
            )
        elif not w["folds"] and not w["jumps_up"]:
            way = "back towards the chamber" if w["end_angle_deg"] < 90 else "on away from the chamber"
            lines.append(f"- At {o} the path is monotonic: no fold, no snap; the actuator bends {way} ({w['end_angle_deg']:.1f} deg at {WINDOW_TO:g} N).")
    lines += [
        "",
        "Inside the window a neighbouring branch passes close to the path's first fold, and a long step of the",
        "continuation can land on it. The trace rejects such a step: a change of stability is a",
        "branch point only when the extended system says so (dg/dlambda orthogonal to the null vector, as at a",
        "branch point, not at a fold), and a step whose stability changes while lambda does not turn back and",
        "that test fails has left the branch; it is halved until the fold is resolved."
        + (" Every special point of these paths is a fold; none is a branch point." if not any(w["branch_points"] for w in data.window) else ""),
        "",
    ]
    return lines


def _window_crossing(data: PathCases) -> str:
    """Where the branches of the window cross over: between the last direction whose path bends back
    towards the chamber and the first whose path folds (from the cases, not a fixed number)."""
    back = [w["omega_deg"] for w in data.window if not w["folds"] and w["end_angle_deg"] < 90]
    folded = [w["omega_deg"] for w in data.window if w["folds"]]
    if back and folded and max(back) < min(folded):
        return f"between Omega = {max(back):g} and {min(folded):g} deg"
    return "in this range of Omega"


def render_page(data: PathCases, command: str) -> str:
    """The Markdown of ``docs/paths.md``; its figures (:data:`FIGURES`) are in ``figures/`` beside it."""
    fig_rel = Path("figures")
    rel = FIGURES
    p = data.pressure
    up, down = p.main.folds[0].lam, p.main.folds[1].lam
    h = p.hysteresis or {"width": float("nan")}
    d = data.direction
    d_folds = sorted(f.lam for f in d.main.folds)
    dh = d.hysteresis or {"width": float("nan")}
    jumps_p = [j for r in p.loading for j in r.jumps]
    loads = [r["traced_n"] for r in data.buckling if r["traced_n"] is not None]
    column_text = f"{min(loads):.2f} to {max(loads):.2f} N (n = {COLUMN_NS[-1]} to 1)" if loads else "a load the traces did not find"
    n3 = next(r["folds_mpa"] for r in data.by_segments if r["n"] == 3)
    nmax = data.by_segments[-1]["folds_mpa"]
    fold_gap = 1000 * max(abs(a - b) for a, b in zip(n3, nmax)) if len(n3) == len(nmax) == 2 else float("nan")
    jumps_d = [j for r in d.loading for j in r.jumps]
    lines = [
        "# Equilibrium paths: where the actuator snaps and where it buckles",
        "",
        f"<!-- Written by `{command}`; rerun it to refresh. -->",
        "",
        "The Table 1 actuator (E = 0.54 MPa, n = 3 unless said otherwise, variant `paper`) is *multistable*",
        "in the paper's own operating range. This page follows its equilibria as one parameter changes",
        "(`esba path`, pseudo-arclength continuation on the generated exact derivatives, see `esba/paths/continuation.py`):",
        "a **fold** (limit point, LP) is where a stable and an unstable equilibrium meet and vanish, so that a",
        "slowly changing load makes the actuator *snap*; a **branch point** (BP) is where two branches cross,",
        "as when a straight actuator buckles. Every special point is located to a relative 1e-8 in the",
        "parameter (folds by the extended system g = 0, H v = 0, v0 . v = 1; branch points by Moore's",
        "extended system), and the Morse index (the number of negative Hessian eigenvalues) changes by one at",
        "each. In the figures, stable branches are solid and unstable ones dashed; the thick translucent",
        "lines are quasi-static loading up and down, the arrows its jumps.",
        "",
        "## Pressure under the 2 N horizontal tip payload",
        "",
        "Inflating the actuator under Table 2's load, the stable branch bends on until the fold at",
        f"**P = {up:.5f} MPa**, where it snaps by {jumps_p[0].distance_mm:.0f} mm"
        f" (total angle {math.degrees(np.sum(jumps_p[0].theta_before)):.1f} -> {math.degrees(np.sum(jumps_p[0].theta_after)):.1f} deg)",
        f"to the far branch. Deflating from there it holds on until the other fold at **P = {down:.5f} MPa**"
        f" and snaps back by {jumps_p[-1].distance_mm:.0f} mm.",
        f"The hysteresis loop is **{1000 * h['width']:.2f} kPa** wide; between the folds two stable states",
        "exist, and which one the actuator is in depends on its history. esba's `solve` inflates first and",
        "then applies the payload"
        + (
            f": that history reaches the upper state for pressures above {data.history_mpa:.4f} MPa (bisection on `solve`)."
            if data.history_mpa is not None
            else "."
        ),
        "That is `solve`'s default history; `--history load-then-inflate` (or `together`, or a list of steps)",
        "chooses another, and `solve` names the other stable state when there is one. Every equilibrium of",
        "the window, the saddle between the two stable states and the energy barriers are on",
        "[equilibria.md](equilibria.md).",
        "",
        f"![pressure path under 2 N]({fig_rel / rel['pressure']})",
        "",
        "`esba path --param pressure --from 0 --to 0.3 --payload 2` draws this figure.",
        "",
        "### The bistable range opens with the payload",
        "",
        "The folds of the pressure path (0 to 0.4 MPa) for horizontal tip payloads of 0.5 to 3 N:",
        "",
        "| payload (N) | folds (MPa) | bistable range (kPa) |",
        "|---|---|---|",
    ]
    lines += [_fold_row(f"{row['payload_n']:g}", row["folds_mpa"]) for row in data.by_payload]
    lines += [
        "",
        "Below the smallest payload with two folds the pressure path is monotonic: no snap-through, one",
        "stable state per pressure."
        + (f" The two folds are born together (a cusp) at a payload of **{data.cusp_n:.3f} N** (bisection to 1e-3 N)." if data.cusp_n else ""),
        "",
        "### How many segments the folds need",
        "",
        "The fold pressures under 2 N against the segment count n:",
        "",
        "| n | folds (MPa) | hysteresis (kPa) |",
        "|---|---|---|",
    ]
    lines += [_fold_row(str(row["n"]), row["folds_mpa"]) for row in data.by_segments]
    lines += [
        "",
        "## Payload direction at the 90 degree pressure",
        "",
        "With the pressure held at its 90 degree value and a 2 N tip payload turned from 90 to 150 degrees",
        f"(Omega from the vertical), the branch folds at **{d_folds[1]:.3f} deg** (turning up, the actuator",
        f"snaps by {jumps_d[0].distance_mm:.0f} mm) and at **{d_folds[0]:.3f} deg** (turning back, it snaps back):",
        f"a hysteresis of **{dh['width']:.2f} deg**.",
        "",
        "![direction path](" + str(fig_rel / rel["direction"]) + ")",
        "",
        "`esba path --param omega --to 150` draws this figure.",
        "",
    ]
    lines += _window_section(data)
    lines += [
        "## The straight actuator pushed along its axis",
        "",
        "At P = 0 the straight state is an equilibrium under any compressive tip load (Omega = 180 deg). It",
        "loses stability at a branch point where the Hessian at theta = 0 turns singular; the closed form",
        "is F = k0 / lambda_max(-X''), with k0 the elastic stiffness of a segment at theta = 0 (Eq. 8 and",
        "Eq. 13) and X'' the Hessian of the tip's x (`esba.analysis.path_analysis.column_buckling_load`).",
        "The two sides of the crossing branch are named by the way they bend: the chamber lies on the convex",
        "side of a theta > 0 bend (inflating bends the actuator away from its chamber), so theta > 0 bends",
        "*away from* the chamber and theta < 0 *towards* it. The trace finds (a relative difference below",
        f"{RELATIVE_FLOOR:.0e}, a few units in the last place of a double, is round-off and printed as \"< {RELATIVE_FLOOR:.0e}\"):",
        "",
        "| n | closed form (N) | traced (N) | relative difference | type | bending away from the chamber (theta > 0) | bending towards it (theta < 0) |",
        "|---|---|---|---|---|---|---|",
    ]
    for row in data.buckling:
        diff = "-" if row["traced_n"] is None else floored(abs(row["traced_n"] / row["closed_form_n"] - 1), ".1e", RELATIVE_FLOOR)
        traced = "-" if row["traced_n"] is None else f"{row['traced_n']:.6f}"
        sides = {s["direction"]: s for s in row["sides"]}

        def describe(s: dict | None) -> str:
            if s is None:
                return "-"
            text = f"load {s['load_after']}, {'stable' if s['stable_at_first'] else 'unstable'}"
            if s["folds_n"]:
                text += f"; fold at {s['folds_n'][0]:.4f} N ({s['fold_angles_deg'][0]:.1f} deg)"
            return text

        kind = row.get("bifurcation") or "-"
        lines.append(
            f"| {row['n']} | {row['closed_form_n']:.6f} | {traced} | {diff} | {kind} | {describe(sides.get(SIDES[0]))} | "
            f"{describe(sides.get(SIDES[1]))} |"
        )
    lines += ["", *_column_summary(data), ""]
    lines += [
        f"![column path, n = 4]({fig_rel / rel['column']})",
        "",
        "`esba path --param payload --pressure 0 --payload 1 --payload-angle 180 -n 4 --to 6.4` draws this figure.",
        "",
        "## What a designer should take from this",
        "",
        f"- Under a 2 N side load the Table 1 actuator has a bistable window of {1000 * h['width']:.1f} kPa",
        f"  ({down:.4f} to {up:.4f} MPa): commanding a pressure in that window does not determine the shape;",
        "  the history does. A controller that ramps the pressure through it sees the tip jump by",
        f"  {min(j.distance_mm for j in jumps_p):.0f} mm or more. Larger payloads widen the window (the table above)"
        + (f"; below about {data.cusp_n:.2f} N there is none." if data.cusp_n else "."),
        f"- A 2 N side load turned past {d_folds[1]:.1f} degrees from the vertical flips the actuator the same way, and it",
        f"  flips back only below {d_folds[0]:.1f} degrees: tasks with the load in that direction are where a snap is to",
        "  be expected.",
        f"- A straight, unpressurised actuator pushed along its axis buckles at {column_text},",
        f"  {_designer_column(data)}",
        f"- Near a payload direction where two branches almost cross ({_window_crossing(data)}, at the 90 degree",
        "  pressure), a change of the direction by hundredths of a degree decides whether loading snaps and",
        "  which way the actuator ends up bending (the window above).",
        f"- The folds converge fast in n: n = 3, as in the paper, places them within {fold_gap:.2f} kPa of n = {FOLD_NS[-1]}.",
        "",
    ]
    return "\n".join(lines)


@dataclass(frozen=True)
class PathsSettings:
    """The page's one setting: the command it names as its writer."""

    command: str


class PathsPage(Page):
    """``docs/paths.md`` and its three figures in ``figures/`` beside it."""

    name = "paths"

    def settings(self) -> PathsSettings:
        return PathsSettings(self.command)

    def compute(self, settings: PathsSettings | None = None, progress: Progress | None = None) -> PathCases:
        return path_cases(progress)

    def render(self, data: PathCases, settings: PathsSettings, path: Path, times: Times = TIMES) -> Rendered:
        shown = {"pressure": data.pressure, "direction": data.direction, "column": data.column}
        figures = {path.parent / "figures" / FIGURES[k]: (lambda a=a: path_figure(a)) for k, a in shown.items()}
        return Rendered(render_page(data, settings.command), figures)


PAGE = PathsPage()

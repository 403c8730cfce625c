"""The page ``docs/equilibria.md`` and its figures, rendered from
:func:`esba.analysis.equilibria_cases.equilibria_cases` (``esba docs --write equilibria`` writes them;
``esba docs --check equilibria`` says whether the committed page is stale).

Presentation only: every number comes from the cases; nothing here solves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from esba.analysis.equilibria_cases import OMEGA_DEG, PAYLOAD_RANGE_N, EquilibriaCases, equilibria_cases
from esba.figures.equilibria import equilibria_figure
from esba.statics.equilibria import Equilibria

from .page import TIMES, Page, Progress, Rendered, Times

__all__ = ["PAGE", "EquilibriaPage", "EquilibriaSettings", "render_page", "FIGURES"]

#: The page's figures, in ``figures/`` beside it.
FIGURES = {"window": "equilibria-window.png", "direction": "equilibria-omega121.png"}


def _f(value: float, digits: int) -> str:
    """``value`` to ``digits`` decimals, without a minus sign on a value that rounds to zero."""
    text = f"{value:.{digits}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text


def _states_table(res: Equilibria) -> list[str]:
    lines = ["| # | stability | Morse index | total bend (deg) | tip x, y (mm) | energy (N mm) | smallest eigenvalue (N mm/rad^2) |", "|---|---|---|---|---|---|---|"]
    for k, s in enumerate(res.states, start=1):
        lines.append(
            f"| {k} | {s.stability} | {s.morse_index} | {_f(s.total_angle_deg, 2)} | {_f(s.tip[0], 2)}, {_f(s.tip[1], 2)} | {_f(s.energy, 4)} | {s.min_eigenvalue:.3f} |"
        )
    return lines


def _barriers(res: Equilibria) -> str:
    if not res.barriers:
        return "no saddle joins two stable states"
    parts = []
    for b in res.barriers:
        sa, sb = res.states[b.a], res.states[b.b]
        parts.append(
            f"#{b.a + 1} ({_f(sa.total_angle_deg, 1)} deg) and #{b.b + 1} ({_f(sb.total_angle_deg, 1)} deg) are joined through the saddle #{b.saddle + 1}: "
            f"**{b.from_a:.3f} N mm** to climb from #{b.a + 1}, **{b.from_b:.3f} N mm** from #{b.b + 1}"
        )
    return "; ".join(parts)


def render_page(data: EquilibriaCases, command: str) -> str:
    """The Markdown of ``docs/equilibria.md``; its figures (:data:`FIGURES`) are in ``figures/`` beside it."""
    fig = Path("figures")
    at17 = next(res for res, _ in data.window if abs(res.pressure - 0.17) < 1e-12)
    lines = [
        "# Every equilibrium: the bistable window and the detached branch",
        "",
        f"<!-- Written by `{command}`; rerun it to refresh. -->",
        "",
        "Where the Table 1 actuator is multistable ([paths.md](paths.md)), a pressure and a load do not fix its",
        "shape. This page lists *every* equilibrium of such scenes, found by deflated Newton on the generated",
        "gradient and Hessian (`esba equilibria`, `esba.equilibria(scene)`, `esba/statics/equilibria.py`;",
        "Farrell, Birkisson and Funke, SIAM J. Sci. Comput. 2015): each equilibrium found is removed from the",
        "residual by a deflation operator and Newton is run again from the same starts until nothing new",
        "appears; a second search from fresh starts checks that nothing was missed. The Morse index is the",
        "number of negative Hessian eigenvalues (0: stable; 1: a saddle between two stable states); a",
        "*barrier* is the energy to climb from a stable state to the saddle that joins it to the other (the",
        "stable states each side of the saddle's unstable mode, found by steepest descent). n = 3, variant",
        "`paper`, unless said otherwise.",
        "",
        "## The bistable window under the 2 N horizontal tip payload",
        "",
        f"At P = 0.17 MPa (`esba equilibria --pressure 0.17 --payload 2`; searched: {at17.describe_domain()}):",
        "",
    ]
    lines += _states_table(at17)
    lines += [
        "",
        f"{_barriers(at17)}. The completeness check "
        + ("found nothing new." if at17.complete else f"found {at17.check_found} more."),
        "",
        f"![every equilibrium at 0.17 MPa under 2 N]({fig / FIGURES['window']})",
        "",
        "Across the window: the stable states, the saddle, the barriers, and the state each load history of",
        "`solve` reaches (`esba solve --pressure P --payload 2 --history NAME`):",
        "",
        "| P (MPa) | stable: total bend (deg), energy (N mm) | saddle (deg, N mm) | barriers (N mm) | inflate-then-load | load-then-inflate | together |",
        "|---|---|---|---|---|---|---|",
    ]
    for res, reached in data.window:
        stable = "; ".join(f"{s.total_angle_deg:.2f}, {s.energy:.4f}" for s in res.stable)
        saddles = "; ".join(f"{s.total_angle_deg:.2f}, {s.energy:.4f}" for s in res.states if s.morse_index == 1) or "-"
        bars = "; ".join(f"{b.from_a:.3f} / {b.from_b:.3f}" for b in res.barriers) or "-"
        cells = " | ".join(f"{reached[k]:.2f}" for k in ("inflate-then-load", "load-then-inflate", "together"))
        lines.append(f"| {res.pressure:g} | {stable} | {saddles} | {bars} | {cells} |")
    lines += [
        "",
        "Barriers are given from the least-energy stable state / from the other.",
    ]
    for name in ("inflate-then-load", "load-then-inflate", "together"):
        far, near = [], []
        for res, reached in data.window:
            stable = sorted(res.stable, key=lambda s: s.total_angle_deg)
            if len(stable) == 2:
                (far if abs(reached[name] - stable[1].total_angle_deg) < abs(reached[name] - stable[0].total_angle_deg) else near).append(res)
        less = [r for r in far if min(r.stable, key=lambda s: s.energy).total_angle_deg < max(s.total_angle_deg for s in r.stable)]
        parts = []
        if far:
            parts.append("the far, strongly bent state at " + ", ".join(f"{r.pressure:g}" for r in far) + " MPa")
        if near:
            parts.append(("the near one" if far else "the near state") + " at " + ", ".join(f"{r.pressure:g}" for r in near) + " MPa")
        text = f"`{name}` reaches " + " and ".join(parts)
        if less:
            text += " (at " + ", ".join(f"{r.pressure:g}" for r in less) + " MPa the far state is the one of higher energy)"
        lines.append(f"- {text}.")
    lines += [
        "",
        "### The same equilibria as n grows",
        "",
        "At 0.17 MPa under 2 N:",
        "",
        "| n | equilibria | stable: total bend (deg), energy (N mm) | saddle (deg, N mm) | barriers (N mm) | complete |",
        "|---|---|---|---|---|---|",
    ]
    for res in data.by_n:
        stable = "; ".join(f"{s.total_angle_deg:.2f}, {s.energy:.4f}" for s in res.stable)
        saddles = "; ".join(f"{s.total_angle_deg:.2f}, {s.energy:.4f}" for s in res.states if s.morse_index == 1) or "-"
        bars = "; ".join(f"{b.from_a:.3f} / {b.from_b:.3f}" for b in res.barriers) or "-"
        lines.append(f"| {res.scene.segments} | {len(res.states)} | {stable} | {saddles} | {bars} | {'yes' if res.complete else 'no'} |")
    d = data.direction
    c = data.curled
    curled_k = max(range(len(d.states)), key=lambda k: d.states[k].total_angle_deg if d.states[k].stable else -math.inf)
    reached = d.history_state
    folds = ", ".join(f"{lam:.3f} N ({ang:.1f} deg)" for lam, ang in c["folds"]) or "none"
    lines += [
        "",
        f"## The detached branch: a 2 N payload at Omega = {OMEGA_DEG:g} deg",
        "",
        f"At the 90 degree pressure ({d.pressure:.5f} MPa) with the 2 N tip payload turned to {OMEGA_DEG:g} deg from the vertical",
        f"(`esba equilibria --target-angle 90 --payload 2 --payload-angle {OMEGA_DEG:g}`):",
        "",
    ]
    lines += _states_table(d)
    lines += [
        "",
        f"{_barriers(d)}. The load history (inflate, then load) reaches #{reached + 1 if reached is not None else '-'}.",
        f"The strongly curled state #{curled_k + 1} ({c['total_angle_deg']:.1f} deg) is on a branch that no path from the",
        f"unloaded state reaches: traced in the payload from 2 N both ways (within {PAYLOAD_RANGE_N[0]:g} to {PAYLOAD_RANGE_N[1]:g} N), it",
        f"exists only from {c['min_n']:.3f} N up (folds: {folds}), where it turns back as the unstable branch of the",
        "saddle; it never reaches F = 0, so continuation from the unloaded actuator never sees it.",
        "",
        f"![every equilibrium at Omega = {OMEGA_DEG:g} deg]({fig / FIGURES['direction']})",
        "",
    ]
    col = data.column
    lines += [
        "## The straight column under a 3 N push",
        "",
        "At P = 0 under a 3 N compressive tip load (`esba equilibria --pressure 0 --payload 3 --payload-angle 180`),",
        "between the fold of the bent branch and the buckling load ([paths.md](paths.md)):",
        "",
    ]
    lines += _states_table(col)
    lines += [
        "",
        f"{_barriers(col)}.",
        "",
        "## What a designer should take from this",
        "",
        f"- In the bistable window there are exactly {len(at17.stable)} stable states and one saddle between them"
        f" ({len(at17.states)} equilibria in all), and the same for every n from {data.by_n[0].scene.segments} to {data.by_n[-1].scene.segments}.",
        "  `solve` says so (`esba: warning: multistable: ...`), names the other state, and returns the one its",
        "  history reaches: choose the history that matches how the actuator is operated (`--history`).",
        f"- The barriers are a few N mm ({min(min(b.from_a, b.from_b) for b in at17.barriers):.2f} N mm from the shallower well at 0.17 MPa):",
        "  a small disturbance (a touch, a pressure ripple) near a fold can tip the actuator over.",
        f"- A 2 N payload turned to about {OMEGA_DEG:g} deg has a strongly curled stable state that loading from rest",
        "  never reaches; once the actuator is there (after a snap at the direction fold, [paths.md](paths.md)), it",
        f"  stays as long as the payload stays above {c['min_n']:.2f} N.",
        "",
    ]
    return "\n".join(lines)


@dataclass(frozen=True)
class EquilibriaSettings:
    """The page's one setting: the command it names as its writer."""

    command: str


class EquilibriaPage(Page):
    """``docs/equilibria.md`` and its two figures in ``figures/`` beside it."""

    name = "equilibria"

    def settings(self) -> EquilibriaSettings:
        return EquilibriaSettings(self.command)

    def compute(self, settings: EquilibriaSettings | None = None, progress: Progress | None = None) -> EquilibriaCases:
        return equilibria_cases(progress)

    def render(self, data: EquilibriaCases, settings: EquilibriaSettings, path: Path, times: Times = TIMES) -> Rendered:
        at17 = next(res for res, _ in data.window if abs(res.pressure - 0.17) < 1e-12)
        shown = {"window": at17, "direction": data.direction}
        figures = {path.parent / "figures" / FIGURES[k]: (lambda r=r: equilibria_figure(r)) for k, r in shown.items()}
        return Rendered(render_page(data, settings.command), figures)


PAGE = EquilibriaPage()

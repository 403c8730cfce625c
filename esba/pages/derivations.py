"""The page ``docs/derivations.md``: the audit of the paper's printed equations (:mod:`derive.audit`),
rendered by :mod:`derive.audit_page` (``esba audit`` writes it; ``esba audit --check`` and
``esba docs --check derivations`` fail when the committed page is stale).

The derivation lives in ``derive/`` and knows nothing of the runtime, so its renderer does too;
this module wraps it in the page protocol. SymPy is imported when the page is computed, not before.
The one part of the page that comes from the runtime, the section's assumed parameters and their
defaults (:func:`esba.model.section.assumed_parameters`), is rendered here and appended after the
derivation's own Markdown (the 3-D model's section of the page points to it).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .page import TIMES, Page, Progress, Rendered, Times

__all__ = ["PAGE", "DerivationsPage", "Audit", "render_section"]


@dataclass(frozen=True, eq=False)
class Audit:
    """The page's data: every audit entry (:func:`derive.audit.entries`) and the checks of the paper's tables."""

    entries: tuple[Any, ...]
    table_checks: tuple[Any, ...]
    section: tuple[dict[str, Any], ...] = ()

    def verdicts(self) -> dict[str, str]:
        """Each equation's verdict, by key (``"Eq. 13"``, ...)."""
        return {e.key: e.verdict for e in self.entries}


class DerivationsPage(Page):
    """``docs/derivations.md``: every equation as printed against the derivation, with its verdict."""

    name = "derivations"

    def compute(self, settings: None = None, progress: Progress | None = None) -> Audit:
        from esba.derive import audit  # SymPy: only for this page
        from esba.model.section import assumed_parameters

        return Audit(tuple(audit.entries()), tuple(audit.table_checks()), tuple(assumed_parameters()))

    def render(self, data: Audit, settings: None, path: Path, times: Times = TIMES) -> Rendered:
        from esba.derive import audit_page

        return Rendered(audit_page.render_entries(data.entries, data.table_checks) + "\n" + render_section(data.section))


def _value(v: Any) -> str:
    return f'"{v}"' if isinstance(v, str) else f"{v:g}"


def render_section(rows) -> str:
    """The section's assumed parameters (:func:`esba.model.section.assumed_parameters`) as Markdown."""
    from esba.model.section import SECTION_OUTPUTS

    out = [
        "## The section's assumed parameters (3-D)",
        "",
        "Computed by `esba.model.section.assumed_parameters` from `SECTION_PARAMETERS` and `section_stiffness`'s "
        f"defaults (`esba/model/section/stiffness.py`; `esba audit` writes this table). The 3-D model takes the section's "
        f"{' and '.join(SECTION_OUTPUTS)}; when they are not given (`--section`), `esba section` computes them from Table 1's "
        "actuator and these inputs, which the paper gives only in part. \"Moves\" is computed: the outputs that change "
        "when the parameter changes by 10 % (layer_depth by 0.1 mm; the fibres' state to each other one), at Table 1's "
        "section; EI_bend is reported by `esba section` only (the planar terms keep the paper's Eq. 8).",
        "",
        "| parameter | `esba section` flag | default | unit | source | moves |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        flag = f"`{r['flag']}`" if r["flag"] else "none (the API's keyword)"
        moves = ", ".join(r["moves"]) or "none of them"
        if r["when"]:
            moves += f" (with {r['when']} only)"
        out.append(f"| `{r['name']}` | {flag} | {_value(r['default'])} | {r['unit'] or '1'} | {r['source']} | {moves} |")
    out += [
        "",
        f"`esba fit` (3-D rows with known loads) fits {' and '.join(SECTION_OUTPUTS)} themselves (`--free EI_side,GJ`), not "
        "these inputs: a measurement determines the section's stiffnesses, and many combinations of the inputs give the same "
        "pair.",
        "",
    ]
    return "\n".join(out)


PAGE = DerivationsPage()

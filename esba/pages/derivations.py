"""The page ``docs/derivations.md``: the audit of the paper's printed equations (:mod:`derive.audit`),
rendered by :mod:`derive.audit_page` (``esba audit`` writes it; ``esba audit --check`` and
``esba docs --check derivations`` fail when the committed page is stale).

The derivation lives in ``derive/`` and knows nothing of the runtime, so its renderer does too;
this module wraps it in the page protocol. SymPy is imported when the page is computed, not before.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .page import TIMES, Page, Progress, Rendered, Times

__all__ = ["PAGE", "DerivationsPage", "Audit"]


@dataclass(frozen=True, eq=False)
class Audit:
    """The page's data: every audit entry (:func:`derive.audit.entries`) and the checks of the paper's tables."""

    entries: tuple[Any, ...]
    table_checks: tuple[Any, ...]

    def verdicts(self) -> dict[str, str]:
        """Each equation's verdict, by key (``"Eq. 13"``, ...)."""
        return {e.key: e.verdict for e in self.entries}


class DerivationsPage(Page):
    """``docs/derivations.md``: every equation as printed against the derivation, with its verdict."""

    name = "derivations"

    def compute(self, settings: None = None, progress: Progress | None = None) -> Audit:
        from esba.derive import audit  # SymPy: only for this page

        return Audit(tuple(audit.entries()), tuple(audit.table_checks()))

    def render(self, data: Audit, settings: None, path: Path, times: Times = TIMES) -> Rendered:
        from esba.derive import audit_page

        return Rendered(audit_page.render_entries(data.entries, data.table_checks))


PAGE = DerivationsPage()

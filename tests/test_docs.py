"""The docs: every figure in docs/figures is shown on a page beside the command that writes it."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


#: Every figure in docs/figures and the command that writes it.
WRITERS = {
    "fig7b": "esba figures --only fig7b",
    "fig8c": "esba figures --only fig8c",
    "fig10": "esba figures --only fig10",
    "fig11": "esba figures --only fig11",
    "fig13a": "esba figures --only fig13a",
    "fig13b": "esba figures --only fig13a fig13b",
    "fig14": "esba figures --only fig13a fig13b fig14",
    "sweep-fig12": "esba sweep --fig12 docs/figures/sweep-fig12.png",
    "sweep-pressure-payload": "--plot docs/figures/sweep-pressure-payload.png",
    "accuracy-vs-time": "esba bench accuracy",
}


@pytest.mark.parametrize("figure", sorted(p.stem for p in (ROOT / "docs" / "figures").glob("*.png")))
def test_every_figure_is_shown_on_a_page_beside_its_command(figure):
    assert figure in WRITERS, f"docs/figures/{figure}.png: add it to a page and to WRITERS"
    pages = [p for p in (ROOT / "docs").glob("*.md") if f"](figures/{figure}.png)" in p.read_text(encoding="utf-8")]
    assert pages, f"docs/figures/{figure}.png is shown on no page"
    assert any(WRITERS[figure] in p.read_text(encoding="utf-8") for p in pages), f"{figure}: the page does not name `{WRITERS[figure]}`"

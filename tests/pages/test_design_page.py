"""docs/design.md (esba.pages.design) written outside a checkout: it links only the figures beside it."""

from __future__ import annotations

import re

import pytest

from esba.pages.design import PAGE

FIGURES = ("fig13a", "fig13b", "fig14")


@pytest.mark.slow
@pytest.mark.ci
def test_design_page_links_only_figures_that_are_beside_it(tmp_path):
    data = PAGE.compute()
    alone = tmp_path / "alone" / "design.md"
    alone.parent.mkdir()
    text = PAGE.render(data, PAGE.settings(), alone).text
    assert not re.search(r"!\[[^\]]*\]\(figures/", text)
    for name in FIGURES:
        assert f"(figures/{name}.png is not beside this page: `esba figures --only {name} --out {alone.parent.as_posix()}/figures` draws it.)" in text
    (alone.parent / "figures").mkdir()
    for name in FIGURES:
        (alone.parent / "figures" / f"{name}.png").write_bytes(b"\\x89PNG")
    text = PAGE.render(data, PAGE.settings(), alone).text
    assert [m for m in re.findall(r"\]\((figures/[^)]+)\)", text)] == ["figures/fig13b.png", "figures/fig13a.png", "figures/fig14.png"]
    assert "is not beside this page" not in text

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


def test_validation_page_outside_a_checkout_links_only_figures_beside_it(capsys, tmp_path, monkeypatch):
    """``esba validate`` in an empty folder writes ./docs/validation.md: it names the command for each of
    the paper's figures instead of linking a figure that is not there; with ``esba figures`` run there
    first, it links them."""
    from esba.cli import main

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("esba.infra.outputs.checkout_root", lambda cwd=None: None)
    assert main(["validate", "--json"]) == 0
    text = (tmp_path / "docs" / "validation.md").read_text(encoding="utf-8")
    assert not re.search(r"!\[[^\]]*\]\(figures/", text)
    assert f"(figures/fig7b.png is not beside this page: `esba figures --only fig7b --out {tmp_path.as_posix()}/docs/figures` draws it.)" in text
    (tmp_path / "docs" / "figures").mkdir()
    for name in ("fig7b", "fig8c", "fig10", "fig11"):
        (tmp_path / "docs" / "figures" / f"{name}.png").write_bytes(b"\x89PNG")
    assert main(["validate", "--json"]) == 0
    capsys.readouterr()
    text = (tmp_path / "docs" / "validation.md").read_text(encoding="utf-8")
    assert "is not beside this page" not in text and "![fig7b](figures/fig7b.png)" in text

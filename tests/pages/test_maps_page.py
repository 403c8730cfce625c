"""docs/maps.md: the page renders what the map cases computed, names its command, and is in the registry."""

from __future__ import annotations

from pathlib import Path

import pytest

from esba.pages.page import MASK, matches
from esba.pages.registry import ENTRIES, page

DOCS = Path(__file__).resolve().parents[2] / "docs"


def test_maps_is_a_registered_page():
    entry = ENTRIES["maps"]
    assert entry.file == "maps.md" and entry.command == "esba map --write-doc docs/maps.md"
    assert page("maps").name == "maps"


@pytest.mark.slow
def test_committed_page_matches_a_fresh_computation(tmp_path):
    p = page("maps")
    data = p.compute()
    rendered = p.render(data, p.settings(), DOCS / "maps.md", MASK)
    assert matches(rendered.text, (DOCS / "maps.md").read_text())
    # what the page says it found: the cusp near 1.645 N and every grid check agreeing
    text = (DOCS / "maps.md").read_text()
    assert "F = 1.6452" in text and text.count("the map agrees in **") == 4  # three planar maps and the 3-D gripper map
    for r in data.maps:
        assert r.check.mismatches == 0 and r.check.near_mismatches == 0
    assert data.spatial.check.agrees and data.spatial.check.near_mismatches == 0
    assert data.design.optimum[0].status == "optimal" and data.design.optimum[0].unconstrained["clearance"]["snaps_inside"]

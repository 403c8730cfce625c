"""docs/derivations.md as a page (esba.pages.derivations): written, checked, and what ``esba audit`` writes."""

from __future__ import annotations

from esba.derive import audit, audit_page
from esba.pages.derivations import PAGE


def test_write_and_check_page(tmp_path):
    out = tmp_path / "derivations.md"
    assert PAGE.check(out).status == "missing"
    written = PAGE.write(out)
    assert written.path == out and written.data.verdicts()["Eq. 13"] == audit.DIFFERS
    assert out.read_text(encoding="utf-8") == audit_page.render()
    assert PAGE.check(out).ok
    out.write_text(out.read_text() + "\nedited by hand\n")
    check = PAGE.check(out)
    assert check.status == "stale" and "edited by hand" not in check.detail


def test_the_page_renders_what_the_audit_found():
    data = PAGE.compute()
    assert [e.key for e in data.entries] == [e.key for e in audit.entries()]
    assert PAGE.render(data, None, PAGE.default_path()).text == audit_page.render()

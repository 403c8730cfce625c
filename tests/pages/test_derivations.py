"""docs/derivations.md as a page (esba.pages.derivations): written, checked, and what ``esba audit`` writes."""

from __future__ import annotations

from esba.derive import audit, audit_page
from esba.model.section import SECTION_PARAMETERS, assumed_parameters
from esba.pages.derivations import PAGE, render_section


def test_write_and_check_page(tmp_path):
    out = tmp_path / "derivations.md"
    assert PAGE.check(out).status == "missing"
    written = PAGE.write(out)
    assert written.path == out and written.data.verdicts()["Eq. 13"] == audit.DIFFERS
    assert out.read_text(encoding="utf-8") == audit_page.render() + "\n" + render_section(assumed_parameters())
    assert PAGE.check(out).ok
    out.write_text(out.read_text() + "\nedited by hand\n")
    check = PAGE.check(out)
    assert check.status == "stale" and "edited by hand" not in check.detail


def test_the_page_renders_what_the_audit_found():
    data = PAGE.compute()
    assert [e.key for e in data.entries] == [e.key for e in audit.entries()]
    assert PAGE.render(data, None, PAGE.default_path()).text == audit_page.render() + "\n" + render_section(data.section)


def test_the_page_names_every_assumed_section_parameter_with_its_default_and_flag():
    from esba.cli import build_parser

    text = PAGE.render(PAGE.compute(), None, PAGE.default_path()).text
    table = text[text.index("## The section's assumed parameters (3-D)"):]
    section_help = build_parser()._subparsers._group_actions[0].choices["section"].format_help()
    for row in assumed_parameters():
        assert f"| `{row['name']}` |" in table
        if row["flag"]:
            assert f"`{row['flag']}`" in table and row["flag"] in section_help
    assert set(SECTION_PARAMETERS) == {r["name"] for r in assumed_parameters()}
    assert "| `layer_width` | `--layer-width` | 8 | mm |" in table and "| `layer_thickness` | `--layer-thickness` | 0.3 | mm |" in table
    assert "`esba fit`" in table and "fits EI_side and GJ themselves" in table
    assert "asks for both" not in text and "at the end of this page" in text

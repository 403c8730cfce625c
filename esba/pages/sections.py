"""Docs pages made of sections, each written by its own command.

``docs/performance.md`` gathers several benchmarks (generation, path following, single solves);
each command rewrites only its own section, delimited by HTML comments that name the section and
the command, and leaves the others as they are.

Examples
--------
>>> import tempfile, pathlib
>>> page = pathlib.Path(tempfile.mkdtemp()) / "p.md"
>>> _ = write_section(page, "a", "## A\\n\\none", "esba a", title="# Page")
>>> _ = write_section(page, "b", "## B\\n\\ntwo", "esba b", title="# Page")
>>> _ = write_section(page, "a", "## A\\n\\nthree", "esba a", title="# Page")
>>> text = page.read_text()
>>> text.index("three") < text.index("two"), "one" in text
(True, False)
>>> _ = page.write_text("# Old page\\n\\nold numbers\\n\\n" + text)
>>> "old numbers" in write_section(page, "b", "## B\\n\\nfour", "esba b", title="# Page").read_text()
False
"""

from __future__ import annotations

import re
from pathlib import Path

from esba.infra.outputs import write_text

__all__ = ["write_section", "read_sections", "section_block", "page_head", "join_sections"]


def _markers(key: str) -> tuple[str, str]:
    return f"<!-- section {key} -->", f"<!-- end of section {key} -->"


def page_head(title: str) -> str:
    """The head of a page made of sections: its title and how it is written."""
    return f"{title}\n\nEach section below is written by the command it names; rerun that command to refresh it.\n\n"


def section_block(key: str, body: str, command: str) -> str:
    """Section ``key`` as it stands in the page: between its markers, naming the command that wrote it."""
    start, end = _markers(key)
    return f"{start}\n<!-- Written by `{command}`; rerun it to refresh. -->\n\n{body.rstrip()}\n\n{end}\n"


def join_sections(title: str, blocks: list[str]) -> str:
    """A whole page from its title and its section blocks, in order."""
    return page_head(title).rstrip("\n") + "\n\n" + "\n".join(b.rstrip("\n") + "\n" for b in blocks)


def read_sections(text: str) -> tuple[str, list[tuple[str, str]]]:
    """The page's head (before the first section) and its sections as (key, block) in order."""
    pattern = re.compile(r"<!-- section (\S+) -->\n.*?<!-- end of section \1 -->\n?", re.S)
    sections = [(m.group(1), m.group(0)) for m in pattern.finditer(text)]
    first = pattern.search(text)
    head = text[: first.start()] if first else text
    return head, sections


def write_section(path: str | Path, key: str, body: str, command: str, title: str) -> Path:
    """Replace (or append) section ``key`` of the page at ``path``; create the page with ``title``.

    The section records the command that wrote it; other sections are kept verbatim and in order.
    """
    path = Path(path)
    text = path.read_text(encoding="utf-8") if path.exists() else ""
    _, sections = read_sections(text)
    # the page is made of sections only: its head is always the title (text left before the
    # first section, e.g. from an older page format, would keep numbers no command refreshes)
    block = section_block(key, body, command)
    keys = [k for k, _ in sections]
    if key in keys:
        sections[keys.index(key)] = (key, block)
    else:
        sections.append((key, block))
    out = join_sections(title, [b for _, b in sections])
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text(path, out)
    return path

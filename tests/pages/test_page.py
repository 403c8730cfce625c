"""The page protocol (esba.pages.page) and its registry (esba.pages.registry): write, check times
aside, missing and stale pages, the figures a page draws; every registered page follows it."""

from __future__ import annotations

import importlib
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from esba.figures.scenes import new_figure
from esba.pages.page import MASK, MISSING, STALE, TIMES, UP_TO_DATE, Page, Rendered, Times, first_difference, matches
from esba.pages.registry import ENTRIES, PageError, check_names, page

ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Run:
    """A toy computation: an answer (content) and how long it took (a time)."""

    answer: float
    seconds: float
    fast: bool


class ToyPage(Page):
    """A page with content, a time, a phrase chosen by the time, lines that appear only when fast,
    and a figure of the answer."""

    name = "validation"  # borrows a registry entry for its file name

    def compute(self, settings, progress=None):
        return settings

    def render(self, data: Run, settings, path: Path, times: Times = TIMES) -> Rendered:
        lines = [
            "# Toy",
            "",
            f"| answer | time (s) |\n|---|---|\n| {data.answer:.3f} | {times(data.seconds, '8.3f')} |",
            "",
            f"It was {times.word('fast' if data.fast else 'slow')}.",
            *times.lines(["", "And fast enough to say so."] if data.fast else []),
            "",
            "![answer](figures/toy.png)",
            "",
        ]

        def draw():
            fig = new_figure(2.0, 2.0)
            fig.add_subplot().plot([0.0, 1.0], [0.0, data.answer], label="answer")
            return fig

        return Rendered("\n".join(lines), {path.parent / "figures" / "toy.png": draw})


TOY = ToyPage()


def test_write_then_check(tmp_path):
    path = tmp_path / "toy.md"
    assert TOY.check(path, settings=Run(1.0, 0.1, True)).status == MISSING
    written = TOY.write(path, settings=Run(1.0, 0.1, True))
    assert written.path == path and written.figures == (tmp_path / "figures" / "toy.png",)
    assert path.read_text().startswith("# Toy\n\n| answer | time (s) |")
    assert TOY.check(path, settings=Run(1.0, 0.1, True)).status == UP_TO_DATE


@pytest.mark.parametrize("other", [Run(1.0, 123.456, True), Run(1.0, 0.001, False), Run(1.0, 7.0, False)])
def test_times_are_set_aside(tmp_path, other):
    """Another run with other times (another width, another phrase, without the optional lines) is up to date."""
    path = tmp_path / "toy.md"
    TOY.write(path, settings=Run(1.0, 0.1, True))
    assert TOY.check(path, settings=other).ok


def test_content_is_not_set_aside(tmp_path):
    path = tmp_path / "toy.md"
    TOY.write(path, settings=Run(1.0, 0.1, True))
    check = TOY.check(path, settings=Run(1.001, 0.1, True))
    assert check.status == STALE and check.detail == "line 5 differs; a fresh page has: '| 1.001 | … |'"
    assert "toy.md is stale (line 5 differs" in check.describe()


def test_a_missing_figure_makes_the_page_stale(tmp_path):
    path = tmp_path / "toy.md"
    TOY.write(path, settings=Run(1.0, 0.1, True))
    (tmp_path / "figures" / "toy.png").unlink()
    check = TOY.check(path, settings=Run(1.0, 0.1, True))
    assert check.status == STALE and "toy.png is missing" in check.detail


def test_a_check_draws_no_figure(tmp_path, monkeypatch):
    path = tmp_path / "toy.md"
    TOY.write(path, settings=Run(1.0, 0.1, True))
    monkeypatch.setitem(globals(), "new_figure", lambda *a, **k: pytest.fail("a check drew a figure"))
    assert TOY.check(path, settings=Run(1.0, 0.1, True)).ok


def test_templates_match_only_what_they_say():
    t = "\n".join(["a " + MASK(1.0) + " b", *MASK.lines(["x"]), "end"])
    assert matches(t, "a 12 b\n\nend") and matches(t, "a   3.14159 b\nline one\nline two\nend")
    assert not matches(t, "a 12 c\n\nend") and not matches(t, "a 12 b\n\nend\n")
    assert first_difference(t, "a 12 b\n\nend") == (0, "")
    assert first_difference("one\ntwo\nthree", "one\ntwo\nfour") == (3, "three")
    assert first_difference("one\ntwo", "one\nTWO") == (2, "two")
    # a page with no times is compared byte for byte
    assert matches("x = 1.5 (s)", "x = 1.5 (s)") and not matches("x = 1.5 (s)", "x = 1.50 (s)")


# ---------------------------------------------------------------------------------------------
# the registry


def test_registry_lists_each_page_once_with_its_module():
    files = [e.file for e in ENTRIES.values()]
    assert len(set(files)) == len(files)
    for name, entry in ENTRIES.items():
        p = page(name)
        assert isinstance(p, Page) and p.name == name and p.file == entry.file and p.command == entry.command
        assert importlib.import_module(entry.module).PAGE is p


def _commands(command: str) -> list[str]:
    """``esba bench generation|solve|path --markdown F`` -> one command a section (without what follows)."""
    m = re.fullmatch(r"(.*?)(\S+\|\S+)(.*)", command)
    return [command] if m is None else [m[1] + alt for alt in m[2].split("|")]


@pytest.mark.parametrize("name", list(ENTRIES))
def test_every_committed_page_exists_and_names_its_command(name):
    entry = ENTRIES[name]
    text = (ROOT / "docs" / entry.file).read_text(encoding="utf-8")
    for command in _commands(entry.command):
        assert command in text, command


def test_names_are_checked():
    assert check_names(None) == list(ENTRIES) and check_names([]) == list(ENTRIES)
    with pytest.raises(PageError, match="unknown page 'docs': allowed are derivations, validation"):
        check_names(["validation", "docs"])


def test_the_registry_imports_no_numerics():
    script = "import sys; import esba.pages.registry; print(sorted(m for m in ('numpy', 'casadi', 'sympy', 'matplotlib') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


# (every computed page against a fresh computation, as `esba docs --check` finds it, and the
# benchmark pages' structure: tests/pages/test_committed_pages.py)

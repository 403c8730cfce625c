"""The page protocol: every docs page is computed, rendered, written and checked the same way.

A :class:`Page` is four steps:

* **compute** (``settings`` -> data): run what the page shows (a computation of the layers below:
  :mod:`esba.design.cases`, :mod:`esba.analysis.path_cases`, the benchmarks of :mod:`esba.bench`,
  ...). Nothing in a page module computes a model: it asks.
* **render** (data -> :class:`Rendered`): the Markdown, and the figures the page shows that it
  draws itself, each with the file it goes to (as a function that draws it: a check draws none).
* **write**: the figures, then the page (:func:`esba.infra.outputs.write_text`: a write that fails
  leaves no half-written page).
* **check**: the page on disk against a fresh computation, *times aside*: the renderer writes every
  number that depends on the machine and the moment (a time, a rate, a ratio of times, the
  machine line, a word chosen by comparing times) through a :class:`Times` formatter. To check,
  the page is rendered with :data:`MASK`, which writes a wildcard in each such place, and the file
  must match the result with anything in the wildcards and exactly the rest. A page with no
  times must equal the fresh rendering byte for byte. A figure's pixels are not compared (they
  depend on the fonts and the matplotlib version); that every figure the page draws is there is.

:mod:`esba.pages.registry` lists every page; ``esba docs --check`` and ``esba docs --write`` run them,
and each page's own command (``esba validate``, ``esba audit``, ``esba path --write-doc``, ...)
calls the same :class:`Page`.

Examples
--------
>>> t = "| n | time (s) |\\n| 3 | " + MASK(0.123, ".3f") + " |"
>>> matches(t, "| n | time (s) |\\n| 3 | 0.456 |"), matches(t, "| n | time (s) |\\n| 4 | 0.456 |")
(True, False)
>>> first_difference(t, "| n | time (s) |\\n| 4 | 0.456 |")
(2, '| 3 | … |')
>>> TIMES(0.123, ".2f"), TIMES.word("met")
('0.12', 'met')
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Mapping

from esba.infra.outputs import default_page, write_text

from .registry import ENTRIES, Entry

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = [
    "Page",
    "Rendered",
    "Written",
    "Check",
    "Times",
    "TIMES",
    "MASK",
    "UP_TO_DATE",
    "STALE",
    "MISSING",
    "matches",
    "first_difference",
    "figure_link",
]

#: A time (or a phrase chosen by times) on one line, in a template.
_INLINE = "\ue000"
#: Lines chosen by times (any number of them, none included), a line of its own in a template.
_BLOCK = "\ue001"

#: What a check finds.
UP_TO_DATE, STALE, MISSING = "up to date", "stale", "missing"


class Times:
    """How a page writes what depends on the machine and the moment: as it is.

    ``times(value, spec)`` formats a time, a rate or a ratio of times as ``format(value, spec)``;
    ``times.word(text)`` is a phrase chosen by comparing times (``"met"``, ``"NOT met"``);
    ``times.lines(lines)`` is a list of lines whose number depends on times (possibly none): a
    check matches any number of lines there.
    """

    masked = False

    def __call__(self, value: Any, spec: str = "") -> str:
        return format(value, spec)

    def word(self, text: str) -> str:
        return text

    def lines(self, lines: list[str]) -> list[str]:
        return list(lines)


class _Masked(Times):
    """The same places as wildcards: a template for a check."""

    masked = True

    def __call__(self, value: Any, spec: str = "") -> str:
        return _INLINE

    def word(self, text: str) -> str:
        return _INLINE

    def lines(self, lines: list[str]) -> list[str]:
        return [_BLOCK]


#: Times as they are (for writing a page).
TIMES = Times()
#: Times as wildcards (for checking a page).
MASK = _Masked()


def _line_matches(pattern: str, line: str) -> bool:
    """One line against one template line: a wildcard matches any run of characters (with the
    spaces around it: a column's padding depends on the time's width), the rest matches exactly.
    Glob matching by two pointers (linear in practice, never exponential)."""
    p = re.sub(f" *[{_INLINE}{_BLOCK}] *", _INLINE, pattern)
    i = j = 0
    star, mark = -1, 0
    while j < len(line):
        if i < len(p) and p[i] != _INLINE and p[i] == line[j]:
            i, j = i + 1, j + 1
        elif i < len(p) and p[i] == _INLINE:
            star, mark, i = i, j, i + 1
        elif star >= 0:
            i, mark = star + 1, mark + 1
            j = mark
        else:
            return False
    while i < len(p) and p[i] == _INLINE:
        i += 1
    return i == len(p)


def _lines_match(template: list[str], lines: list[str]) -> bool:
    """Lines against template lines, where a template line that is only :data:`_BLOCK` matches
    any number of lines (the same glob matching, a line for a character)."""
    i = j = 0
    star, mark = -1, 0
    while j < len(lines):
        if i < len(template) and template[i] != _BLOCK and _line_matches(template[i], lines[j]):
            i, j = i + 1, j + 1
        elif i < len(template) and template[i] == _BLOCK:
            star, mark, i = i, j, i + 1
        elif star >= 0:
            i, mark = star + 1, mark + 1
            j = mark
        else:
            return False
    while i < len(template) and template[i] == _BLOCK:
        i += 1
    return i == len(template)


def matches(template: str, text: str) -> bool:
    """True when ``text`` is ``template`` with anything in its wildcards (times) and exactly the rest."""
    return _lines_match(template.split("\n"), text.split("\n"))


def first_difference(template: str, text: str) -> tuple[int, str]:
    """The first line of ``template`` that ``text`` does not follow: (line number, that line, its
    wildcards shown as ``…``); (0, "") when ``text`` matches."""
    if matches(template, text):
        return 0, ""
    tlines, lines = template.split("\n"), text.split("\n")

    def follows(k: int) -> bool:  # the first k lines of the template match the start of the text
        return _lines_match(tlines[:k] + [_BLOCK], lines)

    low, high = 0, len(tlines)  # follows(low) holds; the whole does not
    while high - low > 1:
        mid = (low + high) // 2
        if follows(mid):
            low = mid
        else:
            high = mid
    shown = tlines[high - 1] if follows(high - 1) else tlines[low]
    return high, shown.replace(_INLINE, "…").replace(_BLOCK, "…")


def figure_link(page_dir: Path | None, rel: str, alt: str, command: str) -> str:
    """The Markdown image of the figure ``rel`` (relative to the page), when it is there beside the
    page (or ``page_dir`` is None: not known); else a line that says which command draws it there,
    so that a page written outside a checkout never links a figure that is not there.

    >>> figure_link(Path("/nowhere"), "figures/f.png", "F", "esba figures --only f --out {dir}")
    '(figures/f.png is not beside this page: `esba figures --only f --out /nowhere/figures` draws it.)'
    """
    if page_dir is None or (page_dir / rel).is_file():
        return f"![{alt}]({rel})"
    return f"({rel} is not beside this page: `{command.format(dir=(page_dir / rel).parent.as_posix(), file=(page_dir / rel).as_posix())}` draws it.)"


@dataclass(frozen=True, eq=False)
class Rendered:
    """A rendered page: its Markdown, and the figures it draws, by the file each goes to (a
    function that draws the figure, called only when the page is written)."""

    text: str
    figures: Mapping[Path, Callable[[], "Figure"]] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class Written:
    """What :meth:`Page.write` wrote, and the data it computed (for the command's own output)."""

    path: Path
    figures: tuple[Path, ...]
    data: Any


@dataclass(frozen=True)
class Check:
    """What :meth:`Page.check` found: ``status`` is ``"up to date"``, ``"stale"`` or ``"missing"``;
    ``detail`` says where a stale page first differs."""

    page: str
    path: Path
    status: str
    detail: str = ""

    @property
    def ok(self) -> bool:
        return self.status == UP_TO_DATE

    def describe(self) -> str:
        return f"{self.page}: {self.path} is {self.status}" + (f" ({self.detail})" if self.detail else "")

    def to_dict(self) -> dict[str, Any]:
        return {"page": self.page, "path": str(self.path), "status": self.status, "detail": self.detail}


Progress = Callable[[str], None]


class Page:
    """One docs page. A subclass sets :attr:`name` (its entry in :mod:`esba.pages.registry`, which
    holds its file, command and whether it is slow) and defines :meth:`compute` and :meth:`render`;
    :meth:`write` and :meth:`check` are the same for all.

    Settings are whatever the page's command takes (a frozen dataclass, or None for a page that
    takes none); :meth:`settings` gives the ones the committed page was written with.
    """

    #: The page's name in the registry (``esba docs --check NAME``).
    name: str = ""

    @property
    def entry(self) -> Entry:
        return ENTRIES[self.name]

    @property
    def file(self) -> str:
        """Its file in ``docs/``."""
        return self.entry.file

    @property
    def command(self) -> str:
        """The command that writes it, as the committed page names it."""
        return self.entry.command

    def settings(self) -> Any:
        """The settings of the committed page (default: None, the page takes none)."""
        return None

    def check_settings(self) -> Any:
        """The settings a check computes with: :meth:`settings`, save what only changes times
        (a benchmark's repeats), since a check sets times aside."""
        return self.settings()

    def compute(self, settings: Any, progress: Progress | None = None) -> Any:  # pragma: no cover - abstract
        raise NotImplementedError

    def render(self, data: Any, settings: Any, path: Path, times: Times = TIMES) -> Rendered:  # pragma: no cover - abstract
        raise NotImplementedError

    def default_path(self) -> Path:
        """Where the page goes by default (:func:`esba.infra.outputs.default_page`)."""
        return default_page(self.file)

    def write(self, path: str | Path | None = None, settings: Any = None, data: Any = None, progress: Progress | None = None) -> Written:
        """Compute (unless ``data`` is given), render, and write the figures and the page."""
        path = self.default_path() if path is None else Path(path)
        settings = self.settings() if settings is None else settings
        data = self.compute(settings, progress) if data is None else data
        rendered = self.render(data, settings, path)
        figures = []
        if rendered.figures:
            from esba.figures.scenes import save_figure

            for file, draw in rendered.figures.items():
                figures.append(save_figure(draw(), file))
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text(path, rendered.text)
        return Written(path, tuple(figures), data)

    def check(self, path: str | Path | None = None, settings: Any = None, data: Any = None, progress: Progress | None = None) -> Check:
        """The page at ``path`` (default :meth:`default_path`) against a fresh computation, times aside."""
        path = self.default_path() if path is None else Path(path)
        if not path.is_file():
            return Check(self.name, path, MISSING)
        settings = self.check_settings() if settings is None else settings
        data = self.compute(settings, progress) if data is None else data
        rendered = self.render(data, settings, path, MASK)
        return self.compare(path, rendered)

    def compare(self, path: Path, rendered: Rendered) -> Check:
        """The page at ``path`` against a template rendered with :data:`MASK`."""
        line, expected = first_difference(rendered.text, path.read_text(encoding="utf-8"))
        if line:
            return Check(self.name, path, STALE, f"line {line} differs; a fresh page has: {expected[:120]!r}")
        missing = [f for f in rendered.figures if not Path(f).is_file()]
        if missing:
            return Check(self.name, path, STALE, "its figure " + ", ".join(str(f) for f in missing) + " is missing")
        return Check(self.name, path, UP_TO_DATE)

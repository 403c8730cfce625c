"""How a result shows itself in Python and in a notebook: :class:`Report`.

A result class (an equilibrium, a branch, a map, a load estimate, ...) takes :class:`Report` as a
base and says two things: :meth:`Report.headline` (one line) and :meth:`Report.summary` (the text
the command line prints for it). It then has a short ``repr`` (``<Equilibrium: ...>``), a rich
display in Jupyter (``_repr_html_``: the summary as preformatted text under its headline) and
``plot(ax=None)``, which draws it with the function its class names in ``_plotter``
(``"esba.figures.results:draw_equilibrium"``). That function is imported by name when ``plot`` is
called, as the façade ``esba`` imports its names: a result in a lower floor knows the name of
its drawing, never its module, so no import runs back up the floors.

Examples
--------
>>> class Answer(Report):
...     def headline(self):
...         return "42, after 7.5 million years"
...     def summary(self):
...         return "answer: 42\\nquestion: unknown"
>>> Answer()
<Answer: 42, after 7.5 million years>
>>> print(Answer()._repr_html_())
<p><b>Answer</b>: 42, after 7.5 million years</p><pre>answer: 42
question: unknown</pre>
"""

from __future__ import annotations

import html
import importlib
from typing import Any, ClassVar

__all__ = ["Report", "MAX_REPR"]

#: The longest ``repr`` of a result, characters (a headline longer than this is cut with "...").
MAX_REPR = 200


class Report:
    """A mixin: short repr, :meth:`summary`, :meth:`plot` and a notebook display (see the module).

    A dataclass that takes it is declared with ``repr=False``, so that the dataclass does not
    write a ``__repr__`` of every field over this one.
    """

    #: ``"module:function"`` that draws the result into matplotlib axes: ``function(result, ax, **options)``.
    _plotter: ClassVar[str] = ""

    def headline(self) -> str:  # pragma: no cover - each result says its own
        """One line: what the result is."""
        raise NotImplementedError

    def summary(self) -> str:  # pragma: no cover - each result says its own
        """Several lines: the text ``esba`` prints for this result."""
        raise NotImplementedError

    def __repr__(self) -> str:
        text = f"<{type(self).__name__}: {self.headline()}>"
        return text if len(text) <= MAX_REPR else text[: MAX_REPR - 4] + "...>"

    def _repr_html_(self) -> str:
        return f"<p><b>{html.escape(type(self).__name__)}</b>: {html.escape(self.headline())}</p><pre>{html.escape(self.summary())}</pre>"

    def plot(self, ax: Any = None, **options: Any) -> Any:
        """Draw the result into ``ax`` (a new figure when None, shown inline in a notebook); return the axes."""
        module, _, name = self._plotter.partition(":")
        if not module:
            raise NotImplementedError(f"{type(self).__name__} has no plot")
        draw = getattr(importlib.import_module(module), name)
        if ax is None:
            import matplotlib.pyplot as plt  # a figure pyplot knows, so that a notebook shows it

            _, ax = plt.subplots(figsize=(6.0, 5.0), layout="constrained")
        draw(self, ax, **options)
        return ax

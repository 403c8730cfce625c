"""Ctrl-C that surfaces as another exception, turned back into :class:`KeyboardInterrupt`.

Python raises :class:`KeyboardInterrupt` between bytecodes. When SIGINT lands while CasADi's
wrappers convert a result to NumPy (``np.asarray`` of a ``DM`` calls ``DM.__array__``), the C layer
reports the interrupt as ``SystemError: <function DM.__array__ ...> returned a result with an
exception set``, the KeyboardInterrupt as its cause or context. :func:`caused_by_interrupt` finds
such an interrupt in an exception's chain; :func:`interrupts_raised` re-raises it as what it is,
so that the study stops as on any Ctrl-C (the resume hint, exit 130).

Examples
--------
>>> try:
...     try:
...         raise KeyboardInterrupt
...     except KeyboardInterrupt as exc:
...         raise SystemError("returned a result with an exception set") from exc
... except SystemError as err:
...     caused_by_interrupt(err)
True
>>> caused_by_interrupt(ValueError("bad"))
False
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

__all__ = ["caused_by_interrupt", "interrupts_raised"]


def caused_by_interrupt(exc: BaseException) -> bool:
    """Whether a :class:`KeyboardInterrupt` is ``exc`` or in its chain of causes and contexts."""
    todo, seen = [exc], set()
    while todo:
        e = todo.pop()
        if e is None or id(e) in seen:
            continue
        if isinstance(e, KeyboardInterrupt):
            return True
        seen.add(id(e))
        todo += [e.__cause__, e.__context__]
    return False


@contextmanager
def interrupts_raised() -> Iterator[None]:
    """Inside the block, an exception caused by Ctrl-C is raised as :class:`KeyboardInterrupt`."""
    try:
        yield
    except Exception as exc:
        if caused_by_interrupt(exc):
            raise KeyboardInterrupt from exc
        raise

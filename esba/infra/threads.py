"""Thread settings of esba's small dense linear algebra: one BLAS thread.

esba's matrices are small (n x n with n the segment count, rarely above 128): a solve or an
eigenvalue decomposition takes microseconds on one core, while OpenBLAS, left to its default,
spreads it over every core and on a busy machine waits for them (measured on 2 shared cores at
n = 100: ``numpy.linalg.solve`` 2 ms with two threads, 55 us with one). So esba's entry points
(:func:`esba.statics.equilibrium.solve`, the path traces, the batch verification, the stiffness) run with
one BLAS thread, set with threadpoolctl for the duration of the call and restored after it: the
user's own NumPy work keeps the user's setting.

Examples
--------
>>> @single_threaded
... def f():
...     return 1
>>> f()
1
"""

from __future__ import annotations

import functools
import threading
from contextlib import contextmanager
from typing import Callable, Iterator, TypeVar

__all__ = ["single_threaded", "blas_one_thread"]

_CONTROLLER = None
_STATE = threading.local()  # depth of nested esba entry points in this thread: only the outermost sets the limit
T = TypeVar("T")


def _controller():
    global _CONTROLLER
    if _CONTROLLER is None:
        from threadpoolctl import ThreadpoolController

        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER


@contextmanager
def blas_one_thread() -> Iterator[None]:
    """One BLAS thread inside the ``with`` block (about 7 us to enter and leave; nothing when nested)."""
    depth = getattr(_STATE, "depth", 0)
    _STATE.depth = depth + 1
    try:
        if depth:
            yield
        else:
            with _controller().limit(limits=1, user_api="blas"):
                yield
    finally:
        _STATE.depth = depth


def single_threaded(fn: Callable[..., T]) -> Callable[..., T]:
    """Run ``fn`` with one BLAS thread (see the module)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with blas_one_thread():
            return fn(*args, **kwargs)

    return wrapper

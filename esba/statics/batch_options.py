"""The settings of the batch path (:mod:`esba.statics.batch`): one frozen, validated :class:`BatchOptions`,
and the bounds that keep a batch's memory and graph finite (:func:`check_size`).

Examples
--------
>>> BatchOptions(chunk=0)
Traceback (most recent call last):
...
esba.statics.batch_options.BatchOptionsError: chunk=0: expected a whole number from 1 to 100000
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass

from esba.infra import checks
from esba.infra.errors import InputError

from .equilibrium import DEFAULT_OPTIONS

__all__ = ["BatchOptions", "BatchOptionsError", "DEFAULT_BATCH_OPTIONS", "batch_bytes", "check_size", "TAIL_CHUNK", "AUTO_COMPILE_MAX_N", "MAX_BATCH_BYTES"]


_COMPILE_MODES = ("auto", "always", "never")

#: The rest of a batch after its full chunks runs in blocks of this size (padding < TAIL_CHUNK).
TAIL_CHUNK = 64

#: ``compile="auto"`` compiles only up to this n: beyond it gcc takes tens of seconds (n = 64:
#: about 30 s) for a gain of 2x or less over the interpreter (MEASUREMENTS.md).
AUTO_COMPILE_MAX_N = 32


#: The most memory a batch may take for its results (every element keeps its angles, gradient
#: and Hessian until it is verified): beyond it a batch is refused, not left to exhaust the machine.
MAX_BATCH_BYTES = 2 * 1024**3

#: Upper bounds of BatchOptions counts (each multiplies the size of the mapped graph or its calls).
MAX_CHUNK = 100_000
MAX_STEPS = 1_000


class BatchOptionsError(InputError):
    """A batch option that is not allowed: the message names the option, the value and what is allowed."""


def batch_bytes(size: int, n: int) -> int:
    """Estimated memory (bytes) of a batch of ``size`` equilibria of an n-segment model.

    Per element: the outputs of the mapped Function (angles, gradient, n x n Hessian, tip,
    pressure), the parameters, eigenvalues and the verdict strings of the result.

    >>> batch_bytes(10_000, 3)   # 680 bytes each
    6800000
    """
    return int(size) * (8 * (n * n + 4 * n + 24) + 40 * 8)


def check_size(size: int, n: int, what: str = "batch", error: type[Exception] = ValueError) -> int:
    """``size`` when a batch that large fits in :data:`MAX_BATCH_BYTES`, else ``error`` naming both."""
    need = batch_bytes(size, n)
    if need > MAX_BATCH_BYTES:
        most = MAX_BATCH_BYTES // batch_bytes(1, n)
        raise error(
            f"{what} of {size} equilibria at n = {n} would take about {need / 1024**3:.1f} GiB (limit "
            f"{MAX_BATCH_BYTES / 1024**3:g} GiB): at most {most} at this n; split it into smaller runs"
        )
    return size


def _whole(name: str, value, low: int, high: int | None = None, why: str = "") -> int:
    return checks.whole(name, value, low, BatchOptionsError, high, why)


@dataclass(frozen=True)
class BatchOptions:
    """Settings of the batch solver, validated on creation.

    Parameters
    ----------
    compile : str
        ``"auto"``: compile to C when a compiler is found and it pays (the library is already
        cached, or the batch has at least ``compile_min`` elements and n <= ``AUTO_COMPILE_MAX_N``),
        else interpreted, and the result says why; ``"always"`` (an error without a compiler);
        ``"never"`` (CasADi's interpreter).
    compile_min : int
        Smallest batch that ``"auto"`` compiles for (compiling n = 3 takes about 1 s).
    chunk : int
        Elements per call of the mapped Function (the progress bar moves per chunk).
    pressure_steps, load_steps : int
        Continuation steps of the pressure ramp (when the pressure is given) and of the payload
        and weight ramp.
    newton_steps : int
        Newton iterations per continuation step.
    final_steps : int
        Newton iterations at the full load after the ramp.
    max_step : float
        Largest Newton step of one segment angle, times n (rad): the step is scaled down to
        ``max_step / n``.
    retry : bool
        Solve the elements that fail again with a denser continuation (4x the steps, 3 Newton
        iterations each, 8 final, downhill).
    fallback : bool
        Solve the elements that still fail with :func:`esba.statics.equilibrium.solve` (needs scenes).
    stationarity_tol : float
        Largest accepted max |dU/dtheta_i|, N mm/rad (as :class:`esba.statics.equilibrium.SolverOptions`).
    critical_tol : float
        Relative eigenvalue threshold of the stability verdict (as ``SolverOptions``).
    downhill : bool
        Reverse Newton steps that climb (where the Hessian is indefinite), so that an element does
        not settle on a saddle between two stable branches. About a third slower; the retry uses it.
    unstable_tol : float
        An element whose Hessian, at any Newton iterate of its load ramp, has a negative LDL^T
        pivot below ``-unstable_tol`` times the largest (Sylvester's law of inertia: a negative
        eigenvalue) has left the stable branch it started on: a snap-through at a fold or a
        buckling at a branch point. It is passed on to :func:`esba.statics.equilibrium.solve`, whose path
        trace locates the special point and notes the jump, so that a jump is never taken silently.
        So is an element a load step of which did not contract (its second Newton correction more
        than a quarter of its first, Deuflhard's test, as :mod:`esba.solvers.newton`): a step that slid to
        another branch without meeting an indefinite Hessian. The unloaded pressure ramp is not
        checked: its uniform path is unique and stable.
    progress : bool
        Show a tqdm progress bar on stderr.
    cache : str or None
        Folder of the compiled libraries (default: ``compiled/`` in esba's cache, beside
        :func:`esba.model.generated.cache_dir`, i.e. under :func:`esba.infra.cache.root`).

    Examples
    --------
    >>> BatchOptions().load_steps
    8
    >>> BatchOptions(compile="yes")
    Traceback (most recent call last):
    ...
    esba.statics.batch_options.BatchOptionsError: compile='yes': allowed are auto, always, never
    """

    compile: str = "auto"
    compile_min: int = 500
    chunk: int = 1000
    pressure_steps: int = 1
    load_steps: int = 8
    newton_steps: int = 2
    final_steps: int = 4
    max_step: float = 1.5
    retry: bool = True
    fallback: bool = True
    stationarity_tol: float = DEFAULT_OPTIONS.stationarity_tol
    critical_tol: float = DEFAULT_OPTIONS.critical_tol
    unstable_tol: float = DEFAULT_OPTIONS.critical_tol
    downhill: bool = False
    progress: bool = False
    cache: str | None = None

    def __post_init__(self) -> None:
        if self.compile not in _COMPILE_MODES:
            raise BatchOptionsError(f"compile={self.compile!r}: allowed are {', '.join(_COMPILE_MODES)}")
        _whole("chunk", self.chunk, 1, MAX_CHUNK)
        _whole("compile_min", self.compile_min, 1)
        for name in ("pressure_steps", "load_steps", "newton_steps"):
            _whole(name, getattr(self, name), 1, MAX_STEPS, "each step is unrolled into the mapped graph")
        _whole("final_steps", self.final_steps, 0, MAX_STEPS, "each step is unrolled into the mapped graph")
        for name in ("max_step", "stationarity_tol", "critical_tol", "unstable_tol"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise BatchOptionsError(f"{name}={v!r}: expected a finite number > 0")
        if self.cache is not None and not isinstance(self.cache, (str, os.PathLike)):
            raise BatchOptionsError(f"cache={self.cache!r}: expected a folder path or None")
        for name in ("retry", "fallback", "progress", "downhill"):
            if not isinstance(getattr(self, name), bool):
                raise BatchOptionsError(f"{name}={getattr(self, name)!r}: expected True or False")

    def denser(self) -> BatchOptions:
        """The retry's settings: four times the continuation steps, 3 Newton iterations each, downhill.

        Its chunk is at most 64: retries are few.
        """
        return dataclasses.replace(
            self,
            chunk=min(self.chunk, 64),
            pressure_steps=4 * self.pressure_steps,
            load_steps=4 * self.load_steps,
            newton_steps=max(3, self.newton_steps),
            final_steps=max(8, self.final_steps),
            downhill=True,
        )

    def newton_iterations(self, angle_mode: bool, loaded: bool) -> int:
        """Newton iterations of one element on the fast path."""
        k = 0 if angle_mode else self.pressure_steps * self.newton_steps
        return k + (self.load_steps * self.newton_steps if loaded else 0) + self.final_steps


DEFAULT_BATCH_OPTIONS = BatchOptions()


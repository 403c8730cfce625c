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
        Steps of the natural continuation of the pressure (when the pressure is given; for a target
        angle the unloaded state is exact) and of the payloads and weight.
    newton_steps : int
        Newton iterations per continuation step (at least 2 measure the contraction).
    final_steps : int
        Newton iterations at the end of each ramp.
    retry : bool
        Solve the elements whose ramp is refused again with a finer one (8x the steps, 3 Newton
        iterations each, 8 at the end), compiled as the first.
    fallback : bool
        Hand the elements whose finer ramp is refused too to the load history's pseudo-arclength
        continuation (:func:`esba.statics.equilibrium.load_history`, O(n) compiled kernels): it
        goes round folds, locates them, takes the snap and finds the stable state after it, and the
        element is flagged as having snapped.
    stationarity_tol : float
        Largest accepted max |dU/dtheta_i|, N mm/rad (as :class:`esba.statics.equilibrium.SolverOptions`).
    critical_tol : float
        Relative eigenvalue threshold of the stability verdict, and the smallest relative pivot the
        acceptance rule takes as positive definite (:class:`esba.solvers.newton.Acceptance`: every
        Hessian met on the ramp positive definite, every step contracting, no corrector moving the
        state farther than its predictor: otherwise a fold or branch point may lie on the ramp, and
        the element is handed on so that a jump is never taken silently).
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
    pressure_steps: int = 2
    load_steps: int = 8
    newton_steps: int = 2
    final_steps: int = 4
    retry: bool = True
    fallback: bool = True
    stationarity_tol: float = DEFAULT_OPTIONS.stationarity_tol
    critical_tol: float = DEFAULT_OPTIONS.critical_tol
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
        for name in ("stationarity_tol", "critical_tol"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise BatchOptionsError(f"{name}={v!r}: expected a finite number > 0")
        if self.cache is not None and not isinstance(self.cache, (str, os.PathLike)):
            raise BatchOptionsError(f"cache={self.cache!r}: expected a folder path or None")
        for name in ("retry", "fallback", "progress"):
            if not isinstance(getattr(self, name), bool):
                raise BatchOptionsError(f"{name}={getattr(self, name)!r}: expected True or False")

    def denser(self) -> BatchOptions:
        """The retry's settings: 8 times the continuation steps, 3 Newton iterations each, 8 at the end.

        Its chunk is at most 64: retries are few.
        """
        return dataclasses.replace(
            self,
            chunk=min(self.chunk, 64),
            pressure_steps=min(MAX_STEPS, 8 * self.pressure_steps),
            load_steps=min(MAX_STEPS, 8 * self.load_steps),
            newton_steps=max(3, self.newton_steps),
            final_steps=max(8, self.final_steps),
        )


DEFAULT_BATCH_OPTIONS = BatchOptions()


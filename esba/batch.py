"""Equilibria for many scenes at once: Newton continuation mapped over a batch, compiled to C.

:func:`esba.equilibrium.solve` pays IPOPT's set-up and CasADi's per-call overhead (25-40 us a
call) on every solve: a few ms each. A sweep of thousands of pressures, payloads or designs of
one model is instead solved here as one CasADi ``Function`` mapped over the batch:

1. **Fast path.** Each element follows the same physical load path as :func:`solve`: from the
   unloaded state (exact for a target angle: theta_i = Theta / n with the closed-form pressure of
   :func:`esba.equilibrium.pressure_for_angle`; else a pressure ramp from theta = 0), then the
   payloads and weight ramp in ``load_steps`` steps, with ``newton_steps`` Newton iterations on
   the generated gradient and Hessian at each step and ``final_steps`` more at the full load.
   Each Newton step is limited to ``max_step / n`` rad per segment and kept inside the model's
   domain (the bounds of :meth:`esba.model.Model.lower_bounds`). The whole path is one graph of
   fixed size, mapped over a chunk of the batch and, when a C compiler is found, generated to C
   by CasADi and compiled once (the shared library is cached, keyed by the hash of the model file,
   the options and this module, with a checksum that is verified before the library is loaded:
   a damaged one is reported and rebuilt, see :mod:`esba.cache`).
2. **Verification.** Every element is checked the way :func:`solve` checks its answers, from the
   gradient and Hessian evaluated at the final angles: finite, ``max |dU/dtheta| <=
   stationarity_tol``, not on the domain boundary, and a stability verdict from the Hessian's
   eigenvalues (:func:`esba.equilibrium.stability_verdict`).
3. **Retry, then IPOPT.** Elements that fail are retried with a denser continuation (``retry``),
   and those that still fail are solved one by one with :func:`esba.equilibrium.solve` when a
   scene is available (``fallback``). Every element ends with ``success``, ``stability``,
   ``ok`` and a ``message`` saying why it is not ok; no element is dropped and none is a silent NaN.

Examples
--------
>>> from esba.scene import Scene, Payload
>>> scenes = [Scene(pressure=p, payloads=(Payload(2.0),)) for p in (0.05, 0.1, 0.15)]
>>> r = solve_scenes(scenes, BatchOptions(compile="never"))
>>> bool(r.ok.all()), r.total_angle_deg.round(2).tolist()
(True, [-13.78, 9.92, 48.92])
>>> from esba.equilibrium import solve
>>> bool(np.allclose(solve(scenes[1]).theta, r.theta[1], atol=1e-8))
True
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import math
import os
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Mapping, Sequence

import casadi as ca
import numpy as np

from . import cache, checks
from .equilibrium import DEFAULT_OPTIONS, EquilibriumError, solve, stability_verdicts
from .model import Model, domain_lower_bound, near_domain_bound
from .ramp import CONTRACTION
from .ramp import TINY as CONTRACTION_TINY
from .scene import Scene, SceneError
from .threads import single_threaded

__all__ = [
    "BatchOptions",
    "BatchOptionsError",
    "BatchResult",
    "solve_arrays",
    "solve_scenes",
    "compiler",
    "compile_library",
    "batch_bytes",
    "check_size",
    "decide_backend",
    "prepare",
    "METHODS",
]

#: How an element's answer was found: the fast path, its denser retry, IPOPT, or not at all.
METHODS = ("newton", "newton-retry", "ipopt", "none")

#: Up to this n the Newton step solves H dx = -g symbolically (SX, O(n^3) instructions);
#: above it, with CasADi's QR linear solver inside the graph.
SX_SOLVE_MAX_N = 8

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


class BatchOptionsError(ValueError):
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
        Solve the elements that still fail with :func:`esba.equilibrium.solve` (needs scenes).
    stationarity_tol : float
        Largest accepted max |dU/dtheta_i|, N mm/rad (as :class:`esba.equilibrium.SolverOptions`).
    critical_tol : float
        Relative eigenvalue threshold of the stability verdict (as ``SolverOptions``).
    downhill : bool
        Reverse Newton steps that climb (where the Hessian is indefinite), so that an element does
        not settle on a saddle between two stable branches. About a third slower; the retry uses it.
    unstable_tol : float
        An element whose Hessian, at any Newton iterate of its load ramp, has a negative LDL^T
        pivot below ``-unstable_tol`` times the largest (Sylvester's law of inertia: a negative
        eigenvalue) has left the stable branch it started on: a snap-through at a fold or a
        buckling at a branch point. It is passed on to :func:`esba.equilibrium.solve`, whose path
        trace locates the special point and notes the jump, so that a jump is never taken silently.
        So is an element a load step of which did not contract (its second Newton correction more
        than a quarter of its first, Deuflhard's test, as :mod:`esba.ramp`): a step that slid to
        another branch without meeting an indefinite Hessian. The unloaded pressure ramp is not
        checked: its uniform path is unique and stable.
    progress : bool
        Show a tqdm progress bar on stderr.
    cache : str or None
        Folder of the compiled libraries (default: ``compiled/`` in esba's cache, beside
        :func:`esba.model.cache_dir`, i.e. under :func:`esba.cache.root`).

    Examples
    --------
    >>> BatchOptions().load_steps
    8
    >>> BatchOptions(compile="yes")
    Traceback (most recent call last):
    ...
    esba.batch.BatchOptionsError: compile='yes': allowed are auto, always, never
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


# ---------------------------------------------------------------------------------------------
# the result


@dataclass(frozen=True, eq=False)
class BatchResult:
    """Equilibria of a batch: one row per element, in the order given.

    Attributes
    ----------
    pressure : ndarray, shape (N,)
        MPa (given, or from the target angle in closed form).
    theta : ndarray, shape (N, n)
        Segment angles, rad (the last iterate when the element is not ok).
    tip : ndarray, shape (N, 3)
        Tip x, y (mm) and orientation (rad).
    gradient_norm : ndarray, shape (N,)
        max |dU/dtheta_i| at theta, N mm/rad.
    eig_min, eig_max : ndarray, shape (N,)
        Smallest and largest Hessian eigenvalue, N mm/rad^2.
    stability : ndarray of str, shape (N,)
        ``stable``, ``critical``, ``unstable`` (or ``unknown`` when the Hessian is not finite).
    success : ndarray of bool, shape (N,)
        Finite, stationary and inside the domain.
    method : ndarray of str, shape (N,)
        One of :data:`METHODS`.
    messages : tuple of str
        Why each element is not ok (empty when it is).
    notes : tuple of tuple of str
        What happened on the way (a jump or a buckling on the load path, noted by the path
        solver that answered the element), per element.
    backend : str
        How the fast path ran: compiled (with the compiler and the cached library) or
        interpreted, and why.
    timings : dict
        Wall times in s: ``build``, ``compile``, ``fast``, ``retry``, ``fallback``, ``total``.
    """

    pressure: np.ndarray
    theta: np.ndarray
    tip: np.ndarray
    gradient_norm: np.ndarray
    eig_min: np.ndarray
    eig_max: np.ndarray
    stability: np.ndarray
    success: np.ndarray
    method: np.ndarray
    messages: tuple[str, ...]
    backend: str
    timings: dict = field(default_factory=dict)
    notes: tuple[tuple[str, ...], ...] = ()

    def __len__(self) -> int:
        return len(self.pressure)

    @property
    def ok(self) -> np.ndarray:
        """Converged and stable, per element."""
        return self.success & (self.stability == "stable")

    @property
    def total_angle(self) -> np.ndarray:
        """Total bending angle theta_TOL (Eq. 17), rad."""
        return np.sum(self.theta, axis=1)

    @property
    def total_angle_deg(self) -> np.ndarray:
        """Total bending angle, degrees."""
        return np.degrees(self.total_angle)

    @property
    def theta_deg(self) -> np.ndarray:
        """Segment angles, degrees."""
        return np.degrees(self.theta)

    def counts(self) -> dict[str, int]:
        """How many elements each method answered, and how many are ok / not ok."""
        out = {m: int(np.sum(self.method == m)) for m in METHODS}
        out["ok"] = int(np.sum(self.ok))
        out["not_ok"] = len(self) - out["ok"]
        return out

    def per_equilibrium_us(self) -> float:
        """Total wall time divided by the batch size, microseconds (compilation included)."""
        return 1e6 * self.timings.get("total", float("nan")) / max(1, len(self))


def _concat(parts: Sequence[tuple[np.ndarray, BatchResult]], size: int) -> BatchResult:
    """Merge group results back into the original order."""
    if len(parts) == 1 and np.array_equal(parts[0][0], np.arange(size)):
        return parts[0][1]
    n = parts[0][1].theta.shape[1]
    out = {
        "pressure": np.empty(size),
        "theta": np.empty((size, n)),
        "tip": np.empty((size, 3)),
        "gradient_norm": np.empty(size),
        "eig_min": np.empty(size),
        "eig_max": np.empty(size),
        "stability": np.empty(size, dtype=object),
        "success": np.zeros(size, dtype=bool),
        "method": np.empty(size, dtype=object),
    }
    messages = [""] * size
    notes: list[tuple[str, ...]] = [()] * size
    timings: dict[str, float] = {}
    backends = []
    for idx, r in parts:
        for k in out:
            out[k][idx] = getattr(r, k)
        for j, i in enumerate(idx):
            messages[i] = r.messages[j]
            notes[i] = r.notes[j]
        for k, v in r.timings.items():
            timings[k] = timings.get(k, 0.0) + v
        if r.backend not in backends:
            backends.append(r.backend)
    out["stability"] = out["stability"].astype(str)
    out["method"] = out["method"].astype(str)
    return BatchResult(messages=tuple(messages), notes=tuple(notes), backend="; ".join(backends), timings=timings, **out)


# ---------------------------------------------------------------------------------------------
# the graph


def _indices(model: Model) -> dict[str, list[int]]:
    names = model.parameters
    return {
        "P": [names.index("P")] if "P" in names else [],
        "loads": [i for i, p in enumerate(names) if (p.startswith("F") and p[1:].isdigit()) or p == "g"],
        "geometry": [names.index(k) for k in ("L", "r1", "r2", "d")],
    }


def _lower_bound_sym(p, idx: dict, n: int):
    """Eq. (10)'s domain (:func:`esba.model.domain_lower_bound`) on symbolic parameters."""
    L, r1, r2, d = (p[i] for i in idx["geometry"])
    return domain_lower_bound(n, L, r1, r2, d, maximum=ca.fmax)


def _scaled(p, idx: dict, pressure_factor, load_factor, pressure=None):
    parts = ca.vertsplit(p)
    for i in idx["P"]:
        parts[i] = (parts[i] if pressure is None else pressure) * pressure_factor
    for i in idx["loads"]:
        parts[i] = parts[i] * load_factor
    return ca.vertcat(*parts)


_PIVOTS: dict[int, ca.Function] = {}


def _pivot_function(n: int) -> ca.Function:
    """H -> the smallest LDL^T pivot of H divided by the largest magnitude (SX, cached per n).

    By Sylvester's law of inertia the pivots have the signs of the eigenvalues: the result is < 0
    exactly when H has a negative eigenvalue.
    """
    fun = _PIVOTS.get(n)
    if fun is None:
        h = ca.SX.sym("H", n, n)
        d, _, _ = ca.ldl(0.5 * (h + h.T), False)
        fun = ca.Function("esba_min_pivot", [h], [ca.mmin(d) / (ca.mmax(ca.fabs(d)) + 1e-300)], ["H"], ["min_pivot"], {"cse": True})
        _PIVOTS[n] = fun
    return fun


def _newton_step(model: Model, max_step: float, downhill: bool = False) -> ca.Function:
    """theta -> theta + s dx with H dx = -g, s = min(1, (max_step/n) / max|dx|), kept in the domain;
    also the relative smallest LDL^T pivot of H at theta (< 0: H is indefinite there).

    With ``downhill`` a step that climbs (g . dx > 0, H indefinite along it) is reversed, so the
    iteration does not settle on a saddle between two stable branches.
    """
    n, npar = model.n, len(model.parameters)
    idx = _indices(model)
    sym = ca.SX if n <= SX_SOLVE_MAX_N else ca.MX
    th = sym.sym("theta", n)
    p = sym.sym("p", npar)
    args = ca.vertsplit(p)
    g = model["gradient"](th, *args)
    h = model["hessian"](th, *args)
    dx = -ca.solve(h, g) if sym is ca.SX else -ca.solve(h, g, "qr")
    if downhill:
        dx = dx * (1.0 - 2.0 * (ca.dot(g, dx) > 0))
    scale = ca.fmin(1.0, (max_step / n) / (ca.mmax(ca.fabs(dx)) + 1e-300))
    new = ca.fmax(th + scale * dx, _lower_bound_sym(p, idx, n))
    opts = {"cse": True} if sym is ca.SX else {}
    pivot = _pivot_function(n)(h)
    return ca.Function("esba_newton_step", [th, p], [new, pivot], ["theta", "p"], ["theta_new", "min_pivot"], opts)


def _element_function(model: Model, options: BatchOptions, angle_mode: bool) -> ca.Function:
    """One element's load path: (p, target) -> theta, P, grad, hess, tip, and the smallest relative
    LDL^T pivot of the Hessian over the Newton iterates of the load ramp (< 0: it left the stable branch)."""
    n, npar = model.n, len(model.parameters)
    idx = _indices(model)
    step = _newton_step(model, options.max_step, options.downhill)
    free_step = _newton_step(model, 1e6, options.downhill)  # the unloaded problem is nearly quadratic: no limit
    th = ca.SX.sym("theta", n)
    ps = ca.SX.sym("p", npar)
    gh = ca.Function(
        "esba_grad_hess", [th, ps], [model["gradient"](th, *ca.vertsplit(ps)), model["hessian"](th, *ca.vertsplit(ps))], {"cse": True}
    )
    p = ca.MX.sym("p", npar)
    target = ca.MX.sym("target")
    loaded = bool(idx["loads"])
    if angle_mode:
        # closed form of pressure_for_angle: the uniform shape, U linear in P
        x = ca.repmat(target / n, n, 1)
        g0 = gh(x, _scaled(p, idx, 0.0, 0.0))[0]
        g1 = gh(x, _scaled(p, idx, 1.0, 0.0, pressure=1.0))[0] - g0
        pressure = -ca.dot(g0, g1) / ca.dot(g1, g1)
        p_full = _scaled(p, idx, 1.0, 1.0, pressure=pressure)
    else:
        pressure = p[idx["P"][0]] if idx["P"] else ca.MX(0.0)
        p_full = p
        x = ca.MX.zeros(n)
        for k in range(1, options.pressure_steps + 1):
            pk = _scaled(p_full, idx, k / options.pressure_steps, 0.0)
            for _ in range(options.newton_steps):
                x = free_step(x, pk)[0]
    pivot = ca.MX(1.0)
    # continuity of the load ramp: each step's second Newton correction against its first (Deuflhard's
    # contraction, as esba.ramp): a step that slid to another branch without meeting an indefinite
    # Hessian does not contract. With one Newton step per load step it cannot be measured: infinite.
    contraction = ca.MX(0.0) if options.newton_steps >= 2 or not loaded else ca.MX(math.inf)
    if loaded:
        for k in range(1, options.load_steps + 1):
            pk = _scaled(p_full, idx, 1.0, k / options.load_steps)
            sizes = []
            for _ in range(options.newton_steps):
                before = x
                x, piv = step(x, pk)
                pivot = ca.fmin(pivot, piv)
                sizes.append(ca.mmax(ca.fabs(x - before)))
            if len(sizes) >= 2:
                contraction = ca.fmax(contraction, ca.if_else(sizes[0] > CONTRACTION_TINY, sizes[1] / (sizes[0] + 1e-300), 0.0))
    for _ in range(options.final_steps):
        x, piv = step(x, p_full)
        pivot = ca.fmin(pivot, piv)
    g, h = gh(x, p_full)
    tip = model["kinematics"](x, p[idx["geometry"][0]])[0]
    return ca.Function(
        "esba_batch_element",
        [p, target],
        [x, pressure, g, ca.vec(h), tip, pivot, contraction],
        ["p", "target"],
        ["theta", "P", "grad", "hess", "tip", "min_pivot", "contraction"],
    )


# ---------------------------------------------------------------------------------------------
# compiling


def compiler() -> str | None:
    """The C compiler used for the fast path (``$CC``, else ``gcc``, else ``cc``), or None."""
    for name in (os.environ.get("CC"), "gcc", "cc"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def _compiled_dir(options: BatchOptions) -> Path:
    if options.cache is not None:
        return Path(options.cache)
    return cache.root() / "compiled"


_log = logging.getLogger("esba.batch")


def _usable_library(lib: Path) -> bool:
    """True when the compiled library is there and intact; a damaged one is reported and removed.

    Loading a truncated shared library can kill the process (a bus error), so it is checked
    against the checksum recorded when it was built, before ``casadi.external`` loads it.
    """
    if not lib.exists():
        return False
    why = cache.damage(lib)
    if why is None:
        return True
    _log.warning("compiled batch solver %s is damaged (%s): building it again", lib, why)
    cache.discard(lib)
    return False


def _key(model: Model, options: BatchOptions, angle_mode: bool) -> str:
    h = hashlib.sha256()
    h.update(model.path.read_bytes())
    h.update(Path(__file__).read_bytes())
    settings = (options.chunk, TAIL_CHUNK, options.pressure_steps, options.load_steps, options.newton_steps, options.final_steps, options.max_step, options.downhill, angle_mode, ca.__version__)  # unstable_tol is checked in Python
    h.update(repr(settings).encode())
    return h.hexdigest()[:20]


_FUNCTIONS: dict[tuple, ca.Function] = {}


def _backend(model: Model, options: BatchOptions, angle_mode: bool, size: int, key: str | None = None) -> tuple[bool, Path, str | None, str]:
    """Whether the fast path of a batch of ``size`` elements runs compiled: (compiled, the cached
    library's path, the compiler, a description of the backend and why)."""
    key = _key(model, options, angle_mode) if key is None else key
    lib = _compiled_dir(options) / f"esba_batch_{key}.so"
    cc = compiler() if options.compile != "never" else None
    have_lib = cc is not None and _usable_library(lib)
    if options.compile == "always" and cc is None:
        raise BatchOptionsError("compile='always' but no C compiler was found ($CC, gcc, cc): install gcc or use compile='auto'")
    why = ""
    if options.compile == "never":
        why = "compile='never'"
    elif cc is None:
        why = "no C compiler found ($CC, gcc, cc)"
    elif options.compile == "auto" and not have_lib:
        if model.n > AUTO_COMPILE_MAX_N:
            why = f"compile='auto' and n = {model.n} > {AUTO_COMPILE_MAX_N} (compiling would take longer than it saves)"
        elif size < options.compile_min:
            why = f"compile='auto' and {size} elements < compile_min = {options.compile_min}"
    if not why:
        return True, lib, cc, f"compiled C ({Path(cc).name} -O2), cached {lib}"
    return False, lib, cc, f"interpreted (CasADi virtual machine, 2 threads): {why}"


def decide_backend(model: Model, options: BatchOptions | None, angle_mode: bool, size: int) -> tuple[BatchOptions, str]:
    """Decide once, for a whole study of ``size`` elements, whether the fast path runs compiled.

    A study split into chunks (:mod:`esba.distributed`) must run every chunk on the same backend:
    compiled C and CasADi's interpreter agree only to round-off, and ``compile="auto"`` would
    decide per chunk from the chunk's size. Returns ``options`` with ``compile`` set to
    ``"always"`` or ``"never"`` (the same decision ``"auto"`` makes for one batch of ``size``) and
    the backend's description.

    Examples
    --------
    >>> from esba.model import load_model
    >>> fixed, why = decide_backend(load_model(3), BatchOptions(compile="never"), False, 10_000)
    >>> fixed.compile, why
    ('never', "interpreted (CasADi virtual machine, 2 threads): compile='never'")
    """
    options = DEFAULT_BATCH_OPTIONS if options is None else options
    if not isinstance(options, BatchOptions):
        raise BatchOptionsError(f"options={options!r}: expected a BatchOptions")
    compiled, _, _, description = _backend(model, options, angle_mode, size)
    return dataclasses.replace(options, compile="always" if compiled else "never"), description


def prepare(model: Model, options: BatchOptions, angle_mode: bool) -> tuple[float, float]:
    """Build (and with ``compile="always"`` compile, unless cached) the fast path's Functions now.

    Run once before a study's chunks go to worker processes that share this machine's cache, so
    that they load one compiled library instead of each compiling it. Returns the seconds spent
    building the graph and compiling it (0 for what was already built or cached).
    """
    _, _, build_s, compile_s = _mapped(model, options, angle_mode, options.compile_min)
    return build_s, compile_s


def _mapped(model: Model, options: BatchOptions, angle_mode: bool, size: int) -> tuple[tuple[ca.Function, ca.Function], str, float, float]:
    """The element Function mapped over ``options.chunk`` and over ``TAIL_CHUNK`` elements
    (for the rest of a batch), compiled when it pays.

    Returns the two Functions, a backend description, the build time and the compile time (s).
    """
    key = _key(model, options, angle_mode)
    compiled, lib, cc, backend = _backend(model, options, angle_mode, size, key)
    cached = _FUNCTIONS.get((key, compiled, str(lib)))
    if cached is not None:
        return cached, backend, 0.0, 0.0
    t0 = time.perf_counter()
    element = _element_function(model, options, angle_mode)
    build_s = time.perf_counter() - t0
    compile_s = 0.0
    small = min(options.chunk, TAIL_CHUNK)
    if not compiled:
        funs = (element.map(options.chunk, "thread", 2), element.map(small, "thread", 2))
    else:
        mapped = (
            element.map(f"esba_batch_{key}", "serial", options.chunk, [], []),
            element.map(f"esba_batch_{key}_tail", "serial", small, [], []),
        )
        if not _usable_library(lib):
            cache.usable_root(lib.parent)
            t1 = time.perf_counter()
            compile_library(mapped, lib, cc)
            compile_s = time.perf_counter() - t1
        funs = tuple(ca.external(f.name(), str(lib)) for f in mapped)
    _FUNCTIONS[(key, compiled, str(lib))] = funs
    return funs, backend, build_s, compile_s


def compile_library(funs: Sequence[ca.Function], lib: Path, cc: str) -> None:
    """Generate C for ``funs`` and compile them into the shared library ``lib`` (atomically)."""
    lib.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="esba-cg-") as tmp:
        name = lib.stem
        cg = ca.CodeGenerator(f"{name}.c", {"with_header": False})
        for fun in funs:
            cg.add(fun)
        cg.generate(tmp + os.sep)
        src = Path(tmp) / f"{name}.c"
        out = Path(tmp) / lib.name
        proc = subprocess.run([cc, "-O2", "-shared", "-fPIC", str(src), "-o", str(out), "-lm"], capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"compiling the batch solver failed ({cc}): {proc.stderr.strip()[:2000]}")
        cache.install(lib, out)


# ---------------------------------------------------------------------------------------------
# solving arrays of parameters


def _lower_bounds(model: Model, pv: np.ndarray) -> np.ndarray:
    """:meth:`Model.lower_bounds` for every column of ``pv``."""
    L, r1, r2, d = (pv[i] for i in _indices(model)["geometry"])
    return domain_lower_bound(model.n, L, r1, r2, d)


def _run(model: Model, pv: np.ndarray, targets: np.ndarray, angle_mode: bool, options: BatchOptions, bar, size_hint: int = 0) -> dict:
    (fun_big, fun_small), backend, build_s, compile_s = _mapped(model, options, angle_mode, max(pv.shape[1], size_hint))
    n, size = model.n, pv.shape[1]
    outs = {k: [] for k in ("theta", "P", "grad", "hess", "tip", "min_pivot", "contraction")}
    t0 = time.perf_counter()
    full = size - size % options.chunk
    small = min(options.chunk, TAIL_CHUNK)
    blocks = [(start, options.chunk, fun_big) for start in range(0, full, options.chunk)]
    blocks += [(start, small, fun_small) for start in range(full, size, small)]
    for start, chunk, fun in blocks:
        stop = min(size, start + chunk)
        block = pv[:, start:stop]
        tgt = targets[start:stop]
        if stop - start < chunk:  # pad the last block with copies of its last element
            pad = chunk - (stop - start)
            block = np.hstack([block, np.repeat(block[:, -1:], pad, axis=1)])
            tgt = np.concatenate([tgt, np.repeat(tgt[-1:], pad)])
        res = fun(block, tgt.reshape(1, -1))
        for k, v in zip(outs, res):
            outs[k].append(np.asarray(v)[:, : stop - start])
        if bar is not None:
            bar.update(stop - start)
    data = {k: np.hstack(v) for k, v in outs.items()}
    return {
        "theta": data["theta"].T.reshape(size, n),
        "P": data["P"].ravel(),
        "grad": data["grad"].T.reshape(size, n),
        "hess": data["hess"].T.reshape(size, n, n),
        "tip": data["tip"].T.reshape(size, 3),
        "min_pivot": data["min_pivot"].ravel(),
        "contraction": data["contraction"].ravel(),
        "backend": backend,
        "build": build_s,
        "compile": compile_s,
        "fast": time.perf_counter() - t0,
    }


def _verify(model: Model, pv: np.ndarray, run: dict, angle_mode: bool, options: BatchOptions):
    """success, stability, gradient norm, eigenvalues and messages of a fast-path run."""
    with np.errstate(invalid="ignore", over="ignore"):
        theta, grad, hess, P = run["theta"], run["grad"], run["hess"], run["P"]
        finite = np.all(np.isfinite(theta), axis=1) & np.all(np.isfinite(grad), axis=1) & np.all(np.isfinite(hess), axis=(1, 2))
        gnorm = np.where(finite, np.max(np.abs(np.where(np.isfinite(grad), grad, np.inf)), axis=1), np.inf)
        eig = np.full((len(P), model.n), np.nan)
        if finite.any():
            sym = 0.5 * (hess[finite] + np.swapaxes(hess[finite], 1, 2))
            eig[finite] = np.linalg.eigvalsh(sym)
        stability = stability_verdicts(eig, options.critical_tol)
        lb = _lower_bounds(model, pv)
        near = near_domain_bound(theta, lb[:, None], axis=1)
        pressure_ok = np.isfinite(P) & (P >= 0)
        stationary = gnorm <= options.stationarity_tol
        left = ~(run["min_pivot"] >= -options.unstable_tol)
        slid = ~(run["contraction"] <= CONTRACTION)
        success = finite & stationary & ~near & pressure_ok & ~left & ~slid
    messages = [""] * len(P)
    for i in np.flatnonzero(~(success & (stability == "stable"))):
        if not pressure_ok[i]:
            messages[i] = (
                f"target angle: would need a negative pressure ({P[i]:.4g} MPa)" if np.isfinite(P[i]) else "target angle: outside the model's domain for this actuator"
            )
        elif not finite[i]:
            messages[i] = "the Newton path left the model's domain (non-finite values)"
        elif near[i]:
            messages[i] = "the solve stopped on the model's domain boundary (Eq. 10): not an equilibrium"
        elif left[i]:
            messages[i] = (
                f"the Hessian lost positive definiteness on the load ramp (smallest relative LDL^T pivot "
                f"{run['min_pivot'][i]:.3g}): the stable branch ended at a fold or a branch point, for the path solver to locate"
            )
        elif slid[i]:
            messages[i] = (
                f"a load step's Newton iteration did not contract (ratio {run['contraction'][i]:.3g} > {CONTRACTION:g}; "
                "infinite with one Newton step per load step): the step may have left its branch, for the path solver to decide"
            )
        elif not stationary[i]:
            messages[i] = f"max |dU/dtheta| = {gnorm[i]:.3g} N mm/rad > stationarity_tol = {options.stationarity_tol:g}"
        else:
            messages[i] = f"the equilibrium is {stability[i]}: smallest Hessian eigenvalue {eig[i, 0]:.3g} N mm/rad^2 (largest {eig[i, -1]:.3g})"
    return success, stability, gnorm, eig, messages, pressure_ok


@single_threaded
def solve_arrays(
    model: Model,
    values: Mapping[str, float | Sequence[float] | np.ndarray],
    *,
    target_angle: float | Sequence[float] | np.ndarray | None = None,
    options: BatchOptions | None = None,
    scene_of: Callable[[int], Scene] | None = None,
) -> BatchResult:
    """Equilibria of one model for a batch of parameter values.

    Parameters
    ----------
    model : Model
        The generated model (all elements share it).
    values : mapping
        Every name in ``model.parameters`` (radians for ``rho`` and ``Omega_k``), each a scalar
        or an array; arrays broadcast to the batch size. ``P`` is ignored with ``target_angle``.
    target_angle : float or array, optional
        The unloaded total angle (rad) whose closed-form pressure each element uses, as a scene's
        ``target_angle_deg``; without it the pressure ``P`` is given.
    options : BatchOptions, optional
    scene_of : callable, optional
        ``scene_of(i)`` returns the :class:`Scene` of element i, for the IPOPT fallback; without
        it elements the fast path and its retry cannot solve are reported not ok.

    Returns
    -------
    BatchResult

    Examples
    --------
    >>> import math
    >>> from esba.model import load_model
    >>> m = load_model(3)
    >>> v = dict(L=135.0, r1=8.0, r2=3.0, d=4.0, rho=math.radians(10), E=0.54, P=0.0,
    ...          F1=[0.0, 2.0], Omega1=math.pi / 2, s1=1.0)
    >>> r = solve_arrays(m, v, target_angle=math.pi / 2, options=BatchOptions(compile="never"))
    >>> r.theta_deg[1].round(2).tolist(), r.method.tolist()
    ([-3.29, 7.17, 21.44], ['newton', 'newton'])
    """
    options = DEFAULT_BATCH_OPTIONS if options is None else options
    if not isinstance(options, BatchOptions):
        raise BatchOptionsError(f"options={options!r}: expected a BatchOptions")
    t_start = time.perf_counter()
    missing = [k for k in model.parameters if k not in values]
    if missing:
        raise KeyError(f"model {model.path.name} needs parameters {missing}")
    arrays = [np.atleast_1d(np.asarray(values[k], dtype=float)) for k in model.parameters]
    angle_mode = target_angle is not None
    if angle_mode:
        arrays.append(np.atleast_1d(np.asarray(target_angle, dtype=float)))
    try:
        arrays = list(np.broadcast_arrays(*arrays))
    except ValueError:
        shapes = {k: np.shape(values[k]) for k in model.parameters}
        raise BatchOptionsError(f"parameter arrays of different lengths: {shapes}") from None
    if any(a.ndim != 1 for a in arrays):
        raise BatchOptionsError("every parameter must be a scalar or a 1-D array")
    size = check_size(len(arrays[0]), model.n, "a batch", BatchOptionsError)
    targets = arrays.pop() if angle_mode else np.zeros(size)
    pv = np.vstack(arrays) if arrays else np.zeros((0, size))

    bar = None
    if options.progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=size, unit="eq", desc=f"esba batch n={model.n}", leave=False)
    try:
        run = _run(model, pv, targets, angle_mode, options, bar)
        success, stability, gnorm, eig, messages, pressure_ok = _verify(model, pv, run, angle_mode, options)
        method = np.where(success & (stability == "stable"), "newton", "none").astype(object)
        theta, tip, P = run["theta"], run["tip"], run["P"]
        notes: list[tuple[str, ...]] = [()] * len(P)
        timings = {"build": run["build"], "compile": run["compile"], "fast": run["fast"], "retry": 0.0, "fallback": 0.0}

        # retry the failures (that have a pressure) with a denser continuation
        redo = np.where(~(success & (stability == "stable")) & pressure_ok)[0]
        if options.retry and len(redo):
            dense = options.denser()
            if bar is not None:
                bar.reset(total=len(redo))
                bar.set_description("esba batch retry")
            r2 = _run(model, pv[:, redo], targets[redo], angle_mode, dense, bar, size_hint=size)  # compiled when the fast path is
            s2, st2, g2, e2, m2, _ = _verify(model, pv[:, redo], r2, angle_mode, dense)
            good = s2 & (st2 == "stable")
            for j, i in enumerate(redo):
                if good[j] or not np.all(np.isfinite(theta[i])):
                    theta[i], tip[i], gnorm[i], eig[i], success[i], stability[i], messages[i] = (
                        r2["theta"][j], r2["tip"][j], g2[j], e2[j], s2[j], st2[j], m2[j]
                    )
                    method[i] = "newton-retry" if good[j] else "none"
            timings["retry"] = r2["fast"]
            timings["build"] += r2["build"]
            timings["compile"] += r2["compile"]

        # IPOPT along the load path for what is left
        redo = np.where(~(success & (stability == "stable")) & pressure_ok)[0]
        if len(redo):
            t1 = time.perf_counter()
            if bar is not None:
                bar.reset(total=len(redo))
                bar.set_description("esba batch IPOPT fallback")
            for i in redo:
                if not options.fallback or scene_of is None:
                    why = "fallback=False" if not options.fallback else "no scene given"
                    messages[i] = f"fast path: {messages[i]}; IPOPT fallback not run ({why})"
                    continue
                try:
                    eq = solve(scene_of(int(i)))
                except (EquilibriumError, SceneError) as exc:  # SceneError: scales the solver cannot resolve
                    messages[i] = str(exc)
                    continue
                ev = np.asarray(eq.eigenvalues, dtype=float)
                theta[i], tip[i], P[i] = eq.theta, eq.tip, eq.pressure
                gnorm[i], eig[i], success[i], stability[i] = eq.gradient_norm, ev, eq.success, eq.stability
                messages[i] = eq.message
                notes[i] = tuple(getattr(eq, "notes", ()))
                method[i] = "ipopt"
                if bar is not None:
                    bar.update(1)
            timings["fallback"] = time.perf_counter() - t1
    finally:
        if bar is not None:
            bar.close()
    timings["total"] = time.perf_counter() - t_start
    with np.errstate(invalid="ignore"):
        eig_min = eig[:, 0].copy()
        eig_max = eig[:, -1].copy()
    return BatchResult(
        pressure=P,
        theta=theta,
        tip=tip,
        gradient_norm=gnorm,
        eig_min=eig_min,
        eig_max=eig_max,
        stability=np.asarray(stability).astype(str),
        success=np.asarray(success, dtype=bool),
        method=method.astype(str),
        messages=tuple(messages),
        backend=run["backend"],
        timings=timings,
        notes=tuple(notes),
    )


# ---------------------------------------------------------------------------------------------
# solving scenes


def solve_scenes(scenes: Sequence[Scene], options: BatchOptions | None = None) -> BatchResult:
    """Equilibria of many scenes: grouped by model and by how the pressure is set, then batched.

    All scenes must have the same segment count (the result's ``theta`` is one array); their
    effects may differ (each group gets its own model). The answers agree with
    :func:`esba.equilibrium.solve` on each scene, which is also the fallback for elements the
    Newton path cannot solve.

    Raises
    ------
    BatchOptionsError
        for an empty batch or mixed segment counts.
    """
    scenes = list(scenes)
    if not scenes:
        raise BatchOptionsError("scenes: the batch is empty")
    if not all(isinstance(s, Scene) for s in scenes):
        raise BatchOptionsError("scenes: expected a sequence of Scene")
    counts = sorted({s.segments for s in scenes})
    if len(counts) > 1:
        raise BatchOptionsError(f"scenes have segment counts {counts}: a batch needs one (solve one batch per n)")
    groups: dict[tuple, list[int]] = {}
    for i, s in enumerate(scenes):
        groups.setdefault((s.effects, s.variant, s.pressure is None), []).append(i)
    parts = []
    for (effects, variant, angle_mode), idx in groups.items():
        model = scenes[idx[0]].model()
        rows = [scenes[i].parameters(0.0 if angle_mode else scenes[i].pressure) for i in idx]
        values = {k: np.array([r[k] for r in rows]) for k in model.parameters}
        target = np.radians([scenes[i].target_angle_deg for i in idx]) if angle_mode else None
        r = solve_arrays(model, values, target_angle=target, options=options, scene_of=lambda j, idx=idx: scenes[idx[j]])
        parts.append((np.asarray(idx), r))
    return _concat(parts, len(scenes))

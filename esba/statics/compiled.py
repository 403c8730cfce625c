"""The batch path's function (:mod:`esba.statics.batch`): the graph of one element's Newton continuation,
mapped over a chunk, generated to C and compiled once (the shared library cached and checked
before it is loaded), or run by CasADi's interpreter; :func:`decide_backend` decides which, once
for a whole study.

The cached library is keyed by the model file, the options that shape the graph and this
module's source: a change to the graph builds a new library.
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
from pathlib import Path
from typing import Sequence

import casadi as ca

from esba.infra import cache
from esba.model.generated import Model, domain_lower_bound
from esba.solvers.newton import TINY as CONTRACTION_TINY

from .batch_options import (
    AUTO_COMPILE_MAX_N,
    DEFAULT_BATCH_OPTIONS,
    TAIL_CHUNK,
    BatchOptions,
    BatchOptionsError,
)

__all__ = ["compiler", "compile_library", "decide_backend", "prepare", "mapped_functions", "parameter_indices"]

#: Up to this n the Newton step solves H dx = -g symbolically (SX, O(n^3) instructions);
#: above it, with CasADi's QR linear solver inside the graph.
SX_SOLVE_MAX_N = 8


# ---------------------------------------------------------------------------------------------
# the graph


def parameter_indices(model: Model) -> dict[str, list[int]]:
    names = model.parameters
    return {
        "P": [names.index("P")] if "P" in names else [],
        "loads": [i for i, p in enumerate(names) if (p.startswith("F") and p[1:].isdigit()) or p == "g"],
        "geometry": [names.index(k) for k in ("L", "r1", "r2", "d")],
    }


def _lower_bound_sym(p, idx: dict, n: int):
    """Eq. (10)'s domain (:func:`esba.model.generated.domain_lower_bound`) on symbolic parameters."""
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
    idx = parameter_indices(model)
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
    idx = parameter_indices(model)
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
    # contraction, as esba.solvers.newton): a step that slid to another branch without meeting an indefinite
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


_log = logging.getLogger("esba.statics.batch")


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

    A study split into chunks (:mod:`esba.studies.distributed`) must run every chunk on the same backend:
    compiled C and CasADi's interpreter agree only to round-off, and ``compile="auto"`` would
    decide per chunk from the chunk's size. Returns ``options`` with ``compile`` set to
    ``"always"`` or ``"never"`` (the same decision ``"auto"`` makes for one batch of ``size``) and
    the backend's description.

    Examples
    --------
    >>> from esba.model.generated import load_model
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
    _, _, build_s, compile_s = mapped_functions(model, options, angle_mode, options.compile_min)
    return build_s, compile_s


def mapped_functions(model: Model, options: BatchOptions, angle_mode: bool, size: int) -> tuple[tuple[ca.Function, ca.Function], str, float, float]:
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



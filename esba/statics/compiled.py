"""The batch path's function (:mod:`esba.statics.batch`): the graph of one element's load history on the
continuation engine's natural continuation (O(n) per Newton step), mapped over a chunk, generated
to C and compiled once (the shared library cached and checked before it is loaded), or run by
CasADi's interpreter; :func:`decide_backend` decides which, once for a whole study.

The cached library is keyed by the model file, the options that shape the graph and this
module's source: a change to the graph builds a new library.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import time
from pathlib import Path

import casadi as ca

from esba.infra import cache
from esba.model import closed_form, structured
from esba.model.closed_form import load_parameter, unloaded_pressure
from esba.model.generated import Model
from esba.solvers import newton
from esba.solvers.native import compile_library, compiler
from esba.solvers.newton import natural_expression, newton_correction, newton_parts

from .batch_options import (
    AUTO_COMPILE_MAX_N,
    DEFAULT_BATCH_OPTIONS,
    TAIL_CHUNK,
    BatchOptions,
    BatchOptionsError,
)

__all__ = ["compiler", "compile_library", "decide_backend", "prepare", "mapped_functions", "parameter_indices"]

# ---------------------------------------------------------------------------------------------
# the graph: one element's load history on the engine's natural continuation


def parameter_indices(model: Model) -> dict[str, list[int]]:
    names = model.parameters
    return {
        "P": [names.index("P")] if "P" in names else [],
        "loads": [i for i, p in enumerate(names) if load_parameter(p)],
        "geometry": [names.index(k) for k in ("L", "r1", "r2", "d")],
    }


def _with(p, idx: dict, pressure=None, load_factor=1.0):
    """The parameter vector ``p`` with the pressure replaced and the loads scaled (MX)."""
    parts = ca.vertsplit(p)
    for i in idx["P"]:
        parts[i] = parts[i] if pressure is None else pressure
    for i in idx["loads"]:
        parts[i] = parts[i] * load_factor
    return ca.vertcat(*parts)


def _element_function(model: Model, options: BatchOptions, angle_mode: bool) -> ca.Function:
    """One element's load history: (p, target) -> theta, P, grad, hess, tip, and the one acceptance
    rule's measures over both ramps (smallest relative pivot, worst contraction, worst jump), and the
    unloaded state (where a refused element's continuation starts).

    The unloaded state is exact for a target angle (theta_i = Theta / n at the closed-form pressure,
    :func:`esba.model.closed_form.unloaded_pressure`), else natural continuation of the pressure from
    theta = 0; then natural continuation of the loads from 0 to 1 (:func:`esba.solvers.newton.natural_expression`,
    O(n) per Newton step), the same engine and the same acceptance as :func:`esba.statics.equilibrium.solve`.
    """
    n, npar = model.n, len(model.parameters)
    idx = parameter_indices(model)
    parts, correction = newton_parts(model), newton_correction(model)
    th = ca.SX.sym("theta", n)
    ps = ca.SX.sym("p", npar)
    gh = ca.Function("esba_grad_hess", [th, ps], [model["gradient"](th, *ca.vertsplit(ps)), model["hessian"](th, *ca.vertsplit(ps))], {"cse": True})
    p = ca.MX.sym("p", npar)
    target = ca.MX.sym("target")
    loaded = bool(idx["loads"])
    one = ca.MX(1.0)
    zero = ca.MX(0.0)
    if angle_mode:
        pressure = unloaded_pressure(model, target, dict(zip(model.parameters, ca.vertsplit(p))))
        theta_u = ca.repmat(target / n, n, 1)
        low, worst, jump = one, zero, zero
    else:
        pressure = p[idx["P"][0]] if idx["P"] else zero
        p_zero = _with(p, idx, pressure=0.0, load_factor=0.0)
        dp = ca.DM.zeros(npar)
        if idx["P"]:
            dp[idx["P"][0]] = 1.0
        theta_u, _, low, worst, _, jump = natural_expression(parts, ca.MX.zeros(n), p_zero, dp, pressure, options.pressure_steps, options.newton_steps, 1, correction)
    p_full = _with(p, idx, pressure=pressure)
    theta = theta_u
    if loaded:
        p_unloaded = _with(p, idx, pressure=pressure, load_factor=0.0)
        theta, _, low2, worst2, _, jump2 = natural_expression(parts, theta_u, p_unloaded, p_full - p_unloaded, 1.0, options.load_steps, options.newton_steps, options.final_steps, correction)
        low, worst, jump = ca.fmin(low, low2), ca.fmax(worst, worst2), ca.fmax(jump, jump2)
    g, h = gh(theta, p_full)
    tip = model["kinematics"](theta, p[idx["geometry"][0]])[0]
    return ca.Function(
        "esba_batch_element",
        [p, target],
        [theta, pressure, g, ca.vec(h), tip, low, worst, jump, theta_u],
        ["p", "target"],
        ["theta", "P", "grad", "hess", "tip", "min_pivot", "contraction", "jump", "theta_unloaded"],
    )


# ---------------------------------------------------------------------------------------------
# compiling


def _compiled_dir(options: BatchOptions) -> Path:
    if options.cache is not None:
        return Path(options.cache)
    return cache.root() / "compiled"


_log = logging.getLogger("esba.statics.compiled")


def _usable_library(lib: Path) -> bool:
    """True when the compiled library is there and intact; a damaged one is reported and removed.

    Loading a truncated shared library can kill the process (a bus error), so it is checked
    against the checksum recorded when it was built, and loaded by a child process first
    (:func:`esba.infra.cache.library_damage`), before ``casadi.external`` loads it.
    """
    if not lib.exists():
        return False
    why = cache.library_damage(lib)
    if why is None:
        return True
    _log.warning("compiled batch solver %s is damaged (%s): building it again", lib, why)
    cache.discard(lib)
    return False


def _key(model: Model, options: BatchOptions, angle_mode: bool) -> str:
    h = hashlib.sha256()
    h.update(model.path.read_bytes())
    h.update(Path(__file__).read_bytes())
    settings = (options.chunk, TAIL_CHUNK, options.pressure_steps, options.load_steps, options.newton_steps, options.final_steps, angle_mode, ca.__version__)
    for path in (newton.__file__, structured.__file__, closed_form.__file__):  # the graph's builders
        h.update(Path(path).read_bytes())
    h.update(repr(settings).encode())
    return h.hexdigest()[:20]


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
    timings = {"build": 0.0, "compile": 0.0}

    def build() -> tuple[ca.Function, ca.Function]:
        t0 = time.perf_counter()
        element = _element_function(model, options, angle_mode)
        timings["build"] = time.perf_counter() - t0
        small = min(options.chunk, TAIL_CHUNK)
        if not compiled:
            return element.map(options.chunk, "thread", 2), element.map(small, "thread", 2)
        mapped = (
            element.map(f"esba_batch_{key}", "serial", options.chunk, [], []),
            element.map(f"esba_batch_{key}_tail", "serial", small, [], []),
        )
        if not _usable_library(lib):
            cache.usable_root(lib.parent)
            t1 = time.perf_counter()
            compile_library(mapped, lib, cc)
            timings["compile"] = time.perf_counter() - t1
        return tuple(ca.external(f.name(), str(lib)) for f in mapped)

    funs = model.derived("batch", build, settings=(key, compiled, str(lib)), persist=False)
    build_s, compile_s = timings["build"], timings["compile"]
    return funs, backend, build_s, compile_s

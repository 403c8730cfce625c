"""CasADi Functions generated to C, compiled once, and called at the cost of a C call.

A kernel of the continuation engine (:mod:`esba.solvers.newton`) is a CasADi Function with one
packed input vector and one packed output vector. Called through CasADi from Python it costs
tens of microseconds of conversions and the virtual machine's evaluation; generated to C by
CasADi's code generator, compiled with the system's C compiler, and called through ``ctypes``
with preallocated buffers, it costs a C call: that is what brings a path trace near the
compiled limit. :class:`Kernel` does either, with the same answers to round-off:

* compiled when a C compiler is found (``$CC``, else ``gcc``, else ``cc``) and the library is in
  the cache or worth building (:func:`worth_compiling`); the library is kept in esba's cache
  (:mod:`esba.infra.cache`: atomic, a checksum checked before it is loaded, a damaged one rebuilt),
  keyed by the Function's serialisation, so a changed kernel builds a new library;
* else interpreted by CasADi.

:func:`compiler` and :func:`compile_library` are also the batch's (:mod:`esba.statics.compiled`).

Examples
--------
>>> import casadi as ca, numpy as np
>>> z = ca.SX.sym("z", 2)
>>> k = Kernel(ca.Function("k", [z], [ca.vertcat(z[0] * z[1], z[0] + z[1])]), compile="never")
>>> k(np.array([2.0, 3.0])).tolist(), k.compiled
([6.0, 5.0], False)
"""

from __future__ import annotations

import ctypes
import hashlib
import logging
import os
import shutil
import subprocess
import tempfile
import threading
from pathlib import Path
from typing import Sequence

import casadi as ca
import numpy as np

from esba.infra import cache
from esba.infra.errors import InputError

__all__ = ["Kernel", "packed", "HOT_RUNS", "compiler", "compile_library", "worth_compiling", "COMPILE_MODES", "AUTO_COMPILE_MAX_N"]

_log = logging.getLogger("esba.solvers.native")

#: How a kernel runs: compiled when it pays (``auto``), always (an error without a compiler), never.
COMPILE_MODES = ("auto", "always", "never")

#: ``auto`` compiles a model's kernels up to this segment count (unless the library is already in
#: the cache): at n = 100 gcc takes about 3 s at -O0 for a corrector step 2.6x faster than CasADi's
#: interpreter (MEASUREMENTS.md: compile time grows with the generated code).
AUTO_COMPILE_MAX_N = 128
#: The ``after`` of the kernels of a solve and of the search for equilibria (:class:`Kernel`): the
#: runs of an interpreted kernel after which it is compiled (about a hundred solves, or a search of
#: every equilibrium at n = 3; a first run then costs no compiler time).
HOT_RUNS = 200
#: Up to this n kernels are compiled with -O1 (well under a second at n = 3, 13 s at n = 100 for a
#: corrector step 2.6x faster than -O0's); above it with -O0 (3.4 s at n = 100).
O1_MAX_N = 128


def compiler() -> str | None:
    """The C compiler (``$CC``, else ``gcc``, else ``cc``), or None."""
    for name in (os.environ.get("CC"), "gcc", "cc"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def compile_library(funs: Sequence[ca.Function], lib: Path, cc: str, optimise: str = "-O2") -> None:
    """Generate C for ``funs`` and compile them into the shared library ``lib`` (installed atomically
    in the cache with its checksum)."""
    lib.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="esba-cg-") as tmp:
        name = lib.stem
        cg = ca.CodeGenerator(f"{name}.c", {"with_header": False})
        for fun in funs:
            cg.add(fun)
        cg.generate(tmp + os.sep)
        src = Path(tmp) / f"{name}.c"
        out = Path(tmp) / lib.name
        proc = subprocess.run([cc, optimise, "-shared", "-fPIC", str(src), "-o", str(out), "-lm"], capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"compiling {name} failed ({cc}): {proc.stderr.strip()[:2000]}")
        cache.install(lib, out)


def _usable(lib: Path) -> bool:
    """The library is there and exactly what was built (a damaged one is reported and removed)."""
    if not lib.exists():
        return False
    why = cache.library_damage(lib)  # the checksum, then a child process loads it (no bus error here)
    if why is None:
        return True
    _log.warning("compiled kernel %s is damaged (%s): building it again", lib, why)
    cache.discard(lib)
    return False


def worth_compiling(n: int, cached: bool, mode: str = "auto") -> bool:
    """Whether a kernel of an n-segment model runs compiled under ``mode`` (a compiler is found)."""
    if mode == "never" or compiler() is None:
        return False
    return mode == "always" or cached or n <= AUTO_COMPILE_MAX_N


class Kernel:
    """One packed-input, packed-output CasADi Function, compiled to C and called by ctypes when it pays.

    Parameters
    ----------
    fun : casadi.Function
        One input vector, one output vector.
    compile : str
        ``auto`` (compiled when :func:`worth_compiling` says so), ``always`` or ``never``.
    n : int
        The model's segment count (what ``auto`` decides by).
    after : int
        With ``auto``: run interpreted, and at the ``after``-th run in this process load the
        library from the cache, or compile it (0: at once). A kernel that a process calls a few
        times (one ``esba solve``, a test) costs no compiler time and no library check (a child
        process per library); one it calls often (a loop of solves, a search) is compiled once and
        cached for every later process. Which runs are compiled is decided by the count of runs,
        never by time: the same calls give the same numbers.
    """

    def __init__(self, fun: ca.Function, compile: str = "auto", n: int = 0, after: int = 0):
        if compile not in COMPILE_MODES:
            raise InputError(f"compile={compile!r}: allowed are {', '.join(COMPILE_MODES)}")
        if fun.n_in() != 1 or fun.n_out() != 1:
            raise InputError(f"kernel {fun.name()}: expected one input and one output")
        self.fun = fun
        self.size_in = fun.nnz_in(0)
        self.size_out = fun.nnz_out(0)
        self.compiled = False
        self._local = threading.local()
        self._n = n
        self._after = 0  # > 0: compile at this run (counted in _runs), unless the cache had it
        self._runs = 0
        self._lock = threading.Lock()
        if compile != "never":
            self._try_compile(compile, n, after)

    def _try_compile(self, mode: str, n: int, after: int = 0) -> None:
        if mode == "auto" and after > 0:
            self._after = after  # compiled (or loaded from the cache) once it has run ``after`` times here
            return
        cc = compiler()
        if cc is None:
            if mode == "always":
                raise InputError("compile='always' but no C compiler was found ($CC, gcc, cc): install gcc or use compile='auto'")
            return
        level = b"O1" if n <= O1_MAX_N else b"O0"
        key = hashlib.sha256(self.fun.serialize().encode() + ca.__version__.encode() + b"native-1" + level).hexdigest()[:20]
        lib = cache.root() / "compiled" / f"esba_kernel_{key}.so"
        have = _usable(lib)
        if not worth_compiling(n, have, mode):
            return
        name = f"esba_kernel_{key}"
        named = _renamed(self.fun, name)
        if not have:
            try:
                cache.usable_root(lib.parent)
                compile_library([named], lib, cc, "-O1" if n <= O1_MAX_N else "-O0")
            except (OSError, RuntimeError, cache.CacheError) as exc:
                _log.warning("cannot compile kernel %s (%s): CasADi's interpreter runs it", self.fun.name(), exc)
                return
        try:
            self._lib = ctypes.CDLL(str(lib))
            self._c = getattr(self._lib, name)
        except (OSError, AttributeError) as exc:
            _log.warning("cannot load kernel %s (%s): CasADi's interpreter runs it", lib, exc)
            return
        self._c.restype = ctypes.c_int
        self._c.argtypes = [ctypes.c_void_p] * 4 + [ctypes.c_int]
        self._sizes = (named.sz_arg(), named.sz_res(), named.sz_iw(), named.sz_w())
        self.compiled = True

    def count(self, runs: int = 1) -> None:
        """Count ``runs`` more interpreted runs (:meth:`run` counts its own; a caller that ran the
        same Function another way, e.g. mapped over many inputs, counts them here); at the
        ``after``-th, compile (a one-off cost, then cached)."""
        with self._lock:
            if not self._after:
                return
            self._runs += runs
            if self._runs >= self._after:
                self._after = 0
                self._try_compile("auto", self._n)

    def _buffers(self):
        b = getattr(self._local, "b", None)
        if b is None:
            sz_arg, sz_res, sz_iw, sz_w = self._sizes
            z = np.zeros(self.size_in)
            out = np.zeros(self.size_out)
            args = (ctypes.c_void_p * sz_arg)()
            args[0] = z.ctypes.data
            res = (ctypes.c_void_p * sz_res)()
            res[0] = out.ctypes.data
            iw = np.zeros(max(sz_iw, 1), dtype=np.int64)
            w = np.zeros(max(sz_w, 1))
            b = self._local.b = (z, out, args, res, iw, w, iw.ctypes.data, w.ctypes.data)
        return b

    def __call__(self, z: np.ndarray) -> np.ndarray:
        """The output vector for the input vector ``z`` (a new array)."""
        return self.run(z).copy()

    def run(self, z: np.ndarray) -> np.ndarray:
        """The output vector for ``z``, in a buffer the next call overwrites (copy what you keep)."""
        if not self.compiled and self._after:
            self.count()
        if not self.compiled:
            with np.errstate(all="ignore"):
                return np.asarray(self.fun(z), dtype=float).ravel()
        zb, out, args, res, _, _, iw, w = self._buffers()
        zb[:] = z
        if self._c(args, res, iw, w, 0) != 0:
            out[:] = np.nan
        return out


def packed(fun: ca.Function, name: str | None = None) -> ca.Function:
    """``fun`` with its inputs packed into one vector and its outputs into another (each input and
    output column-major, densified, in order): what a :class:`Kernel` takes."""
    ins = [ca.MX.sym(fun.name_in(i), fun.sparsity_in(i)) for i in range(fun.n_in())]
    z = ca.vertcat(*[ca.vec(a) for a in ins])
    outs = fun(*ins)
    outs = outs if isinstance(outs, (list, tuple)) else [outs]
    return ca.Function(name or f"{fun.name()}_packed", [z], [ca.vertcat(*[ca.vec(ca.densify(o)) for o in outs])])


def _renamed(fun: ca.Function, name: str) -> ca.Function:
    """``fun`` under another name (the symbol the library exports)."""
    z = ca.MX.sym("z", fun.nnz_in(0))
    return ca.Function(name, [z], [fun(z)], ["z"], ["out"])

"""The batch for 3-D scenes: many equilibria of one spatial model in one call of the compiled 3-D
export (:mod:`esba.export.spatial`, ``{name}_equilibrium_batch``), each checked in Python.

It lives here, not in :mod:`esba.statics` beside the planar batch, because it runs the exported C
solver (the load history with its snaps and sideways buckling), and :mod:`esba.statics` is below
:mod:`esba.export`. The shared library is compiled once (host ``-O2``) and kept in the cache,
keyed by the SHA-256 of its source; a library whose checksum does not match is built again. The
scenes go in and the results come out as NumPy record arrays in the C structures' layout
(:meth:`~esba.export.binding3d.Library3D.batch_records`): no Python work per element.

Every element is then verified from the model itself: its gradient and 3n x 3n Hessian at the
C's state, from the model's own CasADi Function (:meth:`esba.model.spatial.Model3D.state_function`)
mapped over chunks of the batch and compiled once (:class:`esba.solvers.native.Kernel`, cached
like the library); the element is verified when they are finite, ``max |dU/dq| <= GRAD_TOL`` and
the Hessian is positive definite (its Cholesky factorisation exists: the test of its smallest
eigenvalue > 0 without computing it). Its ``status`` is the C's (``ok``, ``snapped``,
``buckled``, ...) and ``ok`` says that the status is one of an equilibrium reached and the check
passed; an element that fails the check keeps its status with ``verified`` False, none is dropped.

For example (it compiles the export and the check the first time, about half a minute)::

    r = solve_batch3d(3, {"P": np.array([0.1, 0.15]), "F1": 1.0, "Omega1": np.pi / 2, "Beta1": 0.3, "s1": 1.0})
    r.status, r.ok  # ['ok', 'ok'], [True, True]; tests/export/test_spatial.py checks it against solve3d
"""

from __future__ import annotations

import hashlib
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import casadi as ca
import numpy as np

from esba.infra import cache
from esba.solvers.native import Kernel, packed

from .binding3d import Library3D
from .build import BuildError, compile_shared, compiler
from .spatial import ACTUATOR3D, STATUS3D, ExportSpec3D, render_source3d

__all__ = ["Batch3DResult", "solve_batch3d", "library3d", "check_kernel", "GRAD_TOL", "CHECK_CHUNK"]

#: Largest |dU/dq| (N mm/rad) of a verified element: esba's acceptance of an equilibrium.
GRAD_TOL = 1e-7
#: Elements per call of the compiled check (the tail of a batch is padded).
CHECK_CHUNK = 256
_TABLE1 = {"L": 135.0, "r1": 8.0, "r2": 3.0, "d": 4.0, "rho": math.radians(10.0), "E": 0.54, "M": 0.035}
_STATUS_NAMES = np.array([*STATUS3D, "unknown"])
_libraries: dict = {}
_checks: dict = {}


@dataclass
class Batch3DResult:
    q: np.ndarray  # (count, 3n)
    status: np.ndarray  # status names
    verified: np.ndarray  # the Python check passed
    gradient_norm: np.ndarray  # max |dU/dq| at q, from the model
    stable: np.ndarray  # the model's Hessian at q is positive definite
    snaps: np.ndarray
    iterations: np.ndarray  # Newton iterations of the C's load history
    steps: np.ndarray  # its accepted load steps
    timings: dict = field(default_factory=dict)

    @property
    def ok(self) -> np.ndarray:
        return np.isin(self.status, ("ok", "snapped", "buckled")) & self.verified

    def counts(self) -> dict[str, int]:
        names, k = np.unique(self.status, return_counts=True)
        return {str(a): int(b) for a, b in zip(names, k)}

    def per_equilibrium_us(self) -> float:
        return 1e6 * self.timings["total"] / max(1, len(self.status))


def library3d(spec: ExportSpec3D) -> Library3D:
    """The compiled export of ``spec`` (host ``-O2``), built once and kept in the cache."""
    if spec in _libraries:
        return _libraries[spec]
    cc = compiler()
    if cc is None:
        raise BuildError("the 3-D batch needs a C compiler ($CC, gcc, cc): none was found")
    header, source = render_source3d(spec, "esba.export.batch3d")
    key = hashlib.sha256((header + source).encode()).hexdigest()[:20]
    folder = cache.usable_root(cache.root() / "export" / f"batch3d_{spec.name}_{spec.precision}_{key}")
    so = folder / f"{spec.name}.so"
    if so.exists():
        data, why = cache.read_verified(so)
        if why is not None:
            cache.discard(so)
    if not so.exists():
        (folder / f"{spec.name}.h").write_text(header, encoding="utf-8")
        (folder / f"{spec.name}.c").write_text(source, encoding="utf-8")
        built = compile_shared(folder / f"{spec.name}.c", out=folder / "build.so", cc=cc, opt="-O2")
        cache.write_bytes(so, Path(built).read_bytes())
    lib = Library3D(so, spec)
    _libraries[spec] = lib
    return lib


def check_kernel(spec: ExportSpec3D) -> Kernel:
    """The model's gradient and Hessian over CHECK_CHUNK states: (q_1..q_C, p_1..p_C) packed ->
    (g_1..g_C, H_1..H_C (each column-major)), compiled once and cached (:class:`Kernel`)."""
    if spec in _checks:
        return _checks[spec]
    model = spec.model()
    q = ca.SX.sym("q", model.size)
    p = ca.SX.sym("p", len(model.parameters))
    _, g, h = model.state_function()(q, p)
    one = ca.Function(f"esba3d_check_{spec.name}", [q, p], [g, h], {"cse": True})
    kernel = Kernel(packed(one.map(CHECK_CHUNK), f"esba3d_check_{spec.name}_{CHECK_CHUNK}"), compile="always", n=spec.n)
    _checks[spec] = kernel
    return kernel


def _check(spec: ExportSpec3D, q: np.ndarray, pm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """max |dU/dq| and positive definiteness of the model's Hessian at each row of q (parameters pm)."""
    kernel = check_kernel(spec)
    count, m = q.shape
    c = CHECK_CHUNK
    g = np.empty((count, m))
    h = np.empty((count, m, m))
    for a in range(0, count, c):
        b = min(count, a + c)
        qs, ps = q[a:b], pm[a:b]
        if b - a < c:  # pad the tail with its first element
            qs = np.concatenate([qs, np.repeat(qs[:1], c - (b - a), axis=0)])
            ps = np.concatenate([ps, np.repeat(ps[:1], c - (b - a), axis=0)])
        out = kernel.run(np.concatenate([qs.ravel(), ps.ravel()]))
        g[a:b] = out[: c * m].reshape(c, m)[: b - a]
        h[a:b] = out[c * m:].reshape(c, m, m)[: b - a].transpose(0, 2, 1)
    with np.errstate(invalid="ignore"):
        finite = np.isfinite(g).all(axis=1) & np.isfinite(h).all(axis=(1, 2))
        gn = np.where(finite, np.abs(np.where(finite[:, None], g, 0.0)).max(axis=1, initial=0.0), np.inf)
    stable = np.zeros(count, dtype=bool)
    sym = 0.5 * (h[finite] + h[finite].transpose(0, 2, 1))
    if len(sym):
        try:
            np.linalg.cholesky(sym)
            stable[finite] = True
        except np.linalg.LinAlgError:  # one is not positive definite: find which, by their eigenvalues
            stable[finite] = np.linalg.eigvalsh(sym)[:, 0] > 0
    return gn, stable


def solve_batch3d(n: int, values: Mapping[str, object], effects: str | None = None) -> Batch3DResult:
    """The 3-D equilibria of a batch: ``values`` maps the model's parameters (Table 1 and its
    section by default) to scalars or arrays of one length (the batch)."""
    t0 = time.perf_counter()
    spec = ExportSpec3D(n) if effects is None else ExportSpec3D(n, effects)
    lib = library3d(spec)
    model = spec.model()
    base = {**_TABLE1, **spec.section_values(), "P": 0.0}
    merged = {**base, **values}
    sizes = {np.size(v) for v in merged.values() if np.ndim(v) > 0}
    if len(sizes) > 1:
        raise ValueError(f"solve_batch3d: the arrays have different lengths {sorted(sizes)}")
    count = sizes.pop() if sizes else 1
    cols = {k: np.broadcast_to(np.asarray(v, dtype=float), (count,)) for k, v in merged.items()}
    check_kernel(spec)
    t1 = time.perf_counter()
    params = lib.records("params", count)
    for k in ACTUATOR3D:
        params[k] = cols[k]
    loads = lib.records("loads", count)
    loads["pressure"] = cols["P"]
    loads["g"] = cols["g"] if "g" in cols else 9.81
    loads["down"][:, 0] = 1.0
    for k in range(spec.payloads):
        payload = loads["payload"][:, k]
        payload["force"] = cols[f"F{k + 1}"]
        payload["angle"] = cols[f"Omega{k + 1}"]
        payload["out_of_plane"] = cols[f"Beta{k + 1}"] if f"Beta{k + 1}" in cols else 0.0
        payload["at"] = cols[f"s{k + 1}"] if f"s{k + 1}" in cols else 1.0
    if spec.moments:
        loads["moment"]["at"] = 1.0
    t2 = time.perf_counter()
    results = lib.batch_records(params, loads)
    t3 = time.perf_counter()
    q = np.array(results["q"], dtype=float)
    code = results["status"]
    status = _STATUS_NAMES[np.where((code >= 0) & (code < len(STATUS3D)), code, len(STATUS3D))]
    # the check, from the model
    zero = np.zeros(count)
    pm = np.stack([cols[p] if p in cols else zero for p in model.parameters], axis=1)
    gn, stable = _check(spec, q, pm)
    verified = np.isfinite(gn) & (gn <= GRAD_TOL) & stable
    t4 = time.perf_counter()
    return Batch3DResult(q, status, verified, gn, stable, results["snaps"] + results["sideways"], np.array(results["iterations"]), np.array(results["steps"]),
                         {"setup": t1 - t0, "pack": t2 - t1, "solve": t3 - t2, "check": t4 - t3, "total": t4 - t0})

"""The batch for 3-D scenes: many equilibria of one spatial model in one call of the compiled 3-D
export (:mod:`esba.export.spatial`, ``{name}_equilibrium_batch``), each checked in Python.

It lives here, not in :mod:`esba.statics` beside the planar batch, because it runs the exported C
solver (the load history with its snaps and sideways buckling), and :mod:`esba.statics` is below
:mod:`esba.export`. The shared library is compiled once (host ``-O2``) and kept in the cache,
keyed by the SHA-256 of its source; a library whose checksum does not match is built again.

Every element is then verified from the model itself, in one mapped CasADi call over the batch:
finite, ``max |dU/dq| <= GRAD_TOL`` and the 3n x 3n Hessian's smallest eigenvalue > 0. Its
``status`` is the C's (``ok``, ``snapped``, ``buckled``, ...) and ``ok`` says that the status is
one of an equilibrium reached and the check passed; an element that fails the check keeps its
status with ``verified`` False, none is dropped.

For example (it compiles the export the first time, about half a minute)::

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

import numpy as np

from esba.infra import cache

from .binding3d import Library3D
from .build import BuildError, compile_shared, compiler
from .spatial import STATUS3D, ExportSpec3D, render_source3d

__all__ = ["Batch3DResult", "solve_batch3d", "library3d", "GRAD_TOL"]

#: Largest |dU/dq| (N mm/rad) of a verified element: esba's acceptance of an equilibrium.
GRAD_TOL = 1e-7
_TABLE1 = {"L": 135.0, "r1": 8.0, "r2": 3.0, "d": 4.0, "rho": math.radians(10.0), "E": 0.54, "M": 0.035}
_libraries: dict = {}


@dataclass
class Batch3DResult:
    q: np.ndarray  # (count, 3n)
    status: np.ndarray  # status names
    verified: np.ndarray  # the Python check passed
    gradient_norm: np.ndarray
    min_eigenvalue: np.ndarray
    snaps: np.ndarray
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
    t1 = time.perf_counter()
    params = [{k: cols[k][i] for k in ("L", "r1", "r2", "d", "rho", "E", "M", "EI_side", "GJ")} for i in range(count)]
    loads = []
    for i in range(count):
        payloads = [(cols[f"F{k}"][i], cols[f"Omega{k}"][i], cols.get(f"Beta{k}", np.zeros(count))[i], cols.get(f"s{k}", np.ones(count))[i])
                    for k in range(1, spec.payloads + 1)]
        loads.append({"pressure": cols["P"][i], "payloads": payloads})
    t2 = time.perf_counter()
    results = lib.batch(params, loads)
    t3 = time.perf_counter()
    q = np.array([r.q for r in results])
    status = np.array([STATUS3D[r.status] if 0 <= r.status < len(STATUS3D) else "unknown" for r in results])
    # the check, from the model: one mapped call over the batch
    pmat = np.array([[cols[p][i] if p in cols else 0.0 for p in model.parameters] for i in range(count)]).T
    fun = model.state_function().map(count)
    _, g, h = fun(q.T, pmat)
    g = np.asarray(g).T
    H = np.asarray(h).reshape(model.size, count, model.size).transpose(1, 0, 2)
    eig = np.linalg.eigvalsh(0.5 * (H + H.transpose(0, 2, 1)))[:, 0]
    gn = np.abs(g).max(axis=1)
    verified = np.isfinite(gn) & (gn <= GRAD_TOL) & (eig > 0)
    t4 = time.perf_counter()
    return Batch3DResult(q, status, verified, gn, eig, np.array([r.snaps + r.sideways for r in results]),
                         {"setup": t1 - t0, "pack": t2 - t1, "solve": t3 - t2, "check": t4 - t3, "total": t4 - t0})

"""Call a compiled 3-D export from Python (ctypes): the tests, ``esba bench embedded`` and the
3-D batch (:mod:`esba.statics.batch3d`) use it.

The structures mirror ``templates/model3d.h`` for the export's n, payload and moment counts and
precision.

Examples
--------
>>> from esba.export.spatial import ExportSpec3D
>>> sorted(structures3d(ExportSpec3D(3)))
['loads', 'moment', 'params', 'payload', 'result', 'state', 'stiffness']
"""

from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from .ccode import FLAGS
from .spatial import ACTUATOR3D, STATUS3D, ExportSpec3D

__all__ = ["Library3D", "CResult3D", "CStiffness3D", "structures3d", "loads3d", "STATUS3D"]

_RESULT_REALS = ("total_angle", "total_side", "total_twist")


def structures3d(spec: ExportSpec3D) -> dict[str, type]:
    real = ctypes.c_double if spec.precision == "double" else ctypes.c_float
    m, k, km = 3 * spec.n, spec.payloads, spec.moments

    class Params(ctypes.Structure):
        _fields_ = [(name, real) for name in ACTUATOR3D]

    class Payload(ctypes.Structure):
        _fields_ = [("force", real), ("angle", real), ("out_of_plane", real), ("at", real)]

    class Moment(ctypes.Structure):
        _fields_ = [("m", real * 3), ("at", real)]

    class Loads(ctypes.Structure):
        _fields_ = ([("pressure", real)] + ([("payload", Payload * k)] if k else []) + ([("moment", Moment * km)] if km else [])
                    + [("g", real), ("down", real * 3)])

    class State(ctypes.Structure):
        _fields_ = [("q", real * m), ("loads", Loads)]

    class Result(ctypes.Structure):
        _fields_ = [
            ("q", real * m), ("total_angle", real), ("total_side", real), ("total_twist", real), ("tip", real * 3), ("rotation", real * 9),
            ("pressure", real), ("energy", real), ("gradient_norm", real), ("min_pivot", real), ("status", ctypes.c_int), ("iterations", ctypes.c_int),
            ("steps", ctypes.c_int), ("snaps", ctypes.c_int), ("sideways", ctypes.c_int), ("snap_ramp", ctypes.c_int), ("snap_at", real),
            ("snap_from", real), ("snap_to", real), ("snap_side", real), ("flags", ctypes.c_int),
        ]

    class Stiffness(ctypes.Structure):
        _fields_ = [("compliance", real * 36), ("stiffness", real * 36), ("min_pivot", real)]

    return {"params": Params, "payload": Payload, "moment": Moment, "loads": Loads, "state": State, "result": Result, "stiffness": Stiffness}


def loads3d(pressure: float, payloads: Sequence[tuple[float, float, float, float]] = (), moments: Sequence[tuple[float, float, float, float]] = (),
            g: float = 9.81, down: Sequence[float] = (1.0, 0.0, 0.0)) -> dict:
    """C loads: the pressure (MPa), payloads (force N, angle rad, out_of_plane rad, at), moments
    (mx, my, mz N mm, at), g (m/s^2) and gravity's direction."""
    return {"pressure": float(pressure), "payloads": [tuple(map(float, p)) for p in payloads], "moments": [tuple(map(float, m)) for m in moments],
            "g": float(g), "down": tuple(map(float, down))}


@dataclass(frozen=True, eq=False)
class CResult3D:
    status: int
    q: np.ndarray
    total_angle: float
    total_side: float
    total_twist: float
    tip: np.ndarray
    rotation: np.ndarray
    pressure: float
    energy: float
    gradient_norm: float
    min_pivot: float
    iterations: int
    steps: int
    snaps: int
    sideways: int
    snap_ramp: int
    snap_at: float
    snap_from: float
    snap_to: float
    snap_side: float
    flags: int = 0

    @property
    def status_name(self) -> str:
        return STATUS3D[self.status] if 0 <= self.status < len(STATUS3D) else f"unknown({self.status})"

    @property
    def flag_names(self) -> tuple[str, ...]:
        return tuple(name for i, name in enumerate(FLAGS) if self.flags & (1 << i))

    def values(self) -> list[float]:
        return [*self.q, self.total_angle, self.total_side, self.total_twist, *self.tip, *self.rotation.ravel(), self.pressure, self.energy,
                self.gradient_norm, self.min_pivot, self.snap_at, self.snap_from, self.snap_to, self.snap_side]


@dataclass(frozen=True, eq=False)
class CStiffness3D:
    status: int
    compliance: np.ndarray
    stiffness: np.ndarray
    min_pivot: float


def result_of(r) -> CResult3D:
    return CResult3D(
        status=int(r.status), q=np.array(list(r.q), dtype=float), total_angle=float(r.total_angle), total_side=float(r.total_side),
        total_twist=float(r.total_twist), tip=np.array(list(r.tip), dtype=float), rotation=np.array(list(r.rotation), dtype=float).reshape(3, 3),
        pressure=float(r.pressure), energy=float(r.energy), gradient_norm=float(r.gradient_norm), min_pivot=float(r.min_pivot),
        iterations=int(r.iterations), steps=int(r.steps), snaps=int(r.snaps), sideways=int(r.sideways), snap_ramp=int(r.snap_ramp),
        snap_at=float(r.snap_at), snap_from=float(r.snap_from), snap_to=float(r.snap_to), snap_side=float(r.snap_side), flags=int(r.flags),
    )


class Library3D:
    """A compiled 3-D export (a shared library of its source)."""

    def __init__(self, path: str | Path, spec: ExportSpec3D):
        self.spec = spec
        self.path = Path(path).resolve()
        self.lib = ctypes.CDLL(str(self.path))
        self.types = structures3d(spec)
        self.real = ctypes.c_double if spec.precision == "double" else ctypes.c_float
        name = spec.name
        fn = getattr(self.lib, f"{name}_work_bytes")
        fn.restype = ctypes.c_ulong
        self.work_bytes = int(fn())
        self._work = ctypes.create_string_buffer(self.work_bytes + 64)
        t, ptr, real = self.types, ctypes.POINTER, self.real
        c_int, vp = ctypes.c_int, ctypes.c_void_p
        sig = {
            "equilibrium": [c_int, ptr(t["params"]), ptr(t["loads"]), ptr(t["state"]), ptr(t["result"]), vp],
            "equilibrium_batch": [c_int, c_int, ptr(t["params"]), ptr(t["loads"]), ptr(t["result"]), vp],
            "pressure_for_angle": [c_int, ptr(t["params"]), ptr(t["loads"]), real, real, ptr(t["state"]), ptr(t["result"]), vp],
            "newton": [c_int, ptr(t["params"]), ptr(t["loads"]), ptr(real), ptr(t["result"]), vp],
            "stiffness": [c_int, ptr(t["params"]), ptr(t["loads"]), ptr(real), ptr(t["stiffness"]), vp],
            "energy": [c_int, ptr(t["params"]), ptr(t["loads"]), ptr(real), ptr(real), ptr(real), vp],
            "gradient": [c_int, ptr(t["params"]), ptr(t["loads"]), ptr(real), ptr(real), vp],
            "hessian": [c_int, ptr(t["params"]), ptr(t["loads"]), ptr(real), ptr(real), vp],
            "tip": [c_int, ptr(t["params"]), ptr(real), ptr(real), ptr(real), ptr(real), vp],
        }
        self.fn = {}
        for key, args in sig.items():
            f = getattr(self.lib, f"{name}_{key}")
            f.argtypes = args
            f.restype = c_int
            self.fn[key] = f

    # -- structures -------------------------------------------------------------------------

    def params(self, values: Mapping[str, float]):
        return self.types["params"](**{k: float(values[k]) for k in ACTUATOR3D})

    def fill_loads(self, c, loads: Mapping) -> object:
        c.pressure = loads["pressure"]
        c.g = loads.get("g", 9.81)
        for i, v in enumerate(loads.get("down", (1.0, 0.0, 0.0))):
            c.down[i] = v
        payloads = list(loads.get("payloads", ()))
        if len(payloads) > self.spec.payloads:
            raise ValueError(f"{len(payloads)} payloads for an export with {self.spec.payloads}")
        for i in range(self.spec.payloads):
            c.payload[i].force, c.payload[i].angle, c.payload[i].out_of_plane, c.payload[i].at = payloads[i] if i < len(payloads) else (0.0, math.pi / 2, 0.0, 1.0)
        moments = list(loads.get("moments", ()))
        if len(moments) > self.spec.moments:
            raise ValueError(f"{len(moments)} moments for an export with {self.spec.moments}")
        for i in range(self.spec.moments):
            mx, my, mz, at = moments[i] if i < len(moments) else (0.0, 0.0, 0.0, 1.0)
            c.moment[i].m[0], c.moment[i].m[1], c.moment[i].m[2], c.moment[i].at = mx, my, mz, at
        return c

    def loads(self, loads: Mapping):
        return self.fill_loads(self.types["loads"](), loads)

    def state(self, q: Sequence[float], loads: Mapping):
        s = self.types["state"]()
        for i, v in enumerate(q):
            s.q[i] = float(v)
        s.loads = self.loads(loads)
        return s

    def _vector(self, values: Sequence[float] | None, size: int):
        arr = (self.real * size)()
        if values is not None:
            for i, v in enumerate(values):
                arr[i] = float(v)
        return arr

    # -- calls ------------------------------------------------------------------------------

    def equilibrium(self, params: Mapping[str, float], loads: Mapping, start=None, n: int | None = None) -> CResult3D:
        r = self.types["result"]()
        st = self.state(*start) if start is not None else None
        self.fn["equilibrium"](self.spec.n if n is None else n, self.params(params), self.loads(loads), None if st is None else ctypes.byref(st),
                               ctypes.byref(r), self._work)
        return result_of(r)

    def batch(self, params: Sequence[Mapping[str, float]], loads: Sequence[Mapping]) -> list[CResult3D]:
        count = len(loads)
        P = (self.types["params"] * count)(*[self.params(p) for p in params])
        L = (self.types["loads"] * count)()
        for i, lo in enumerate(loads):
            self.fill_loads(L[i], lo)
        R = (self.types["result"] * count)()
        self.fn["equilibrium_batch"](self.spec.n, count, P, L, R, self._work)
        return [result_of(r) for r in R]

    def records(self, kind: str, count: int) -> np.ndarray:
        """``count`` zeroed C structures of ``kind`` (``params``, ``loads``, ``result``) as a NumPy
        record array (the C layout), for :meth:`batch_records`."""
        return np.zeros(count, dtype=np.dtype(self.types[kind]))

    def as_records(self, kind: str, values: Sequence[Mapping]) -> np.ndarray:
        """Parameter (``params``) or load (``loads``, as for :meth:`loads`) mappings as a record array."""
        make = self.params if kind == "params" else self.loads
        out = self.records(kind, len(values))
        for i, v in enumerate(values):
            out[i] = np.frombuffer(bytes(make(v)), dtype=out.dtype)[0]
        return out

    def batch_records(self, params: np.ndarray, loads: np.ndarray) -> np.ndarray:
        """``{name}_equilibrium_batch`` on record arrays of :meth:`records` (one C call, no Python
        per element): the results as a record array of the result structure."""
        count = len(loads)
        if len(params) != count or params.dtype != np.dtype(self.types["params"]) or loads.dtype != np.dtype(self.types["loads"]):
            raise ValueError(f"batch_records: {len(params)} params and {count} loads of this export's record types expected")
        params, loads = np.ascontiguousarray(params), np.ascontiguousarray(loads)
        out = self.records("result", count)
        t, ptr = self.types, ctypes.POINTER
        self.fn["equilibrium_batch"](self.spec.n, count, params.ctypes.data_as(ptr(t["params"])), loads.ctypes.data_as(ptr(t["loads"])),
                                     out.ctypes.data_as(ptr(t["result"])), self._work)
        return out

    def pressure_for_angle(self, params, loads, total_angle: float, max_pressure: float = 10.0, start=None) -> CResult3D:
        r = self.types["result"]()
        st = self.state(*start) if start is not None else None
        self.fn["pressure_for_angle"](self.spec.n, self.params(params), self.loads(loads), total_angle, max_pressure,
                                      None if st is None else ctypes.byref(st), ctypes.byref(r), self._work)
        return result_of(r)

    def newton(self, params, loads, q0) -> CResult3D:
        r = self.types["result"]()
        self.fn["newton"](self.spec.n, self.params(params), self.loads(loads), self._vector(q0, 3 * self.spec.n), ctypes.byref(r), self._work)
        return result_of(r)

    def stiffness(self, params, loads, q) -> CStiffness3D:
        s = self.types["stiffness"]()
        status = self.fn["stiffness"](self.spec.n, self.params(params), self.loads(loads), self._vector(q, 3 * self.spec.n), ctypes.byref(s), self._work)
        return CStiffness3D(int(status), np.array(list(s.compliance)).reshape(6, 6), np.array(list(s.stiffness)).reshape(6, 6), float(s.min_pivot))

    def energy(self, params, loads, q) -> tuple[int, float, np.ndarray]:
        u = (self.real * 1)()
        terms = (self.real * 32)()
        status = self.fn["energy"](self.spec.n, self.params(params), self.loads(loads), self._vector(q, 3 * self.spec.n), u, terms, self._work)
        return int(status), float(u[0]), np.array(list(terms))

    def gradient(self, params, loads, q) -> tuple[int, np.ndarray]:
        m = 3 * self.spec.n
        out = (self.real * m)()
        status = self.fn["gradient"](self.spec.n, self.params(params), self.loads(loads), self._vector(q, m), out, self._work)
        return int(status), np.array(list(out))

    def hessian(self, params, loads, q) -> tuple[int, np.ndarray]:
        m = 3 * self.spec.n
        out = (self.real * (m * m))()
        status = self.fn["hessian"](self.spec.n, self.params(params), self.loads(loads), self._vector(q, m), out, self._work)
        return int(status), np.array(list(out)).reshape(m, m)

    def tip(self, params, q) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
        n, m = self.spec.n, 3 * self.spec.n
        tip, rot, points = (self.real * 3)(), (self.real * 9)(), (self.real * (3 * (n + 1)))()
        status = self.fn["tip"](n, self.params(params), self._vector(q, m), tip, rot, points, self._work)
        return int(status), np.array(list(tip)), np.array(list(rot)).reshape(3, 3), np.array(list(points)).reshape(n + 1, 3).T

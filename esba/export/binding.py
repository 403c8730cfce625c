"""Call a compiled export from Python (ctypes): what the tests and ``esba bench embedded`` use.

The structures mirror ``templates/model.h`` for the export's n, payload count and precision; the
work memory is a buffer of ``{name}_work_bytes()`` bytes, as a C caller would declare it.

Examples
--------
>>> from esba.export.ccode import ExportSpec
>>> lib_types = structures(ExportSpec(3))
>>> sorted(lib_types)
['loads', 'params', 'payload', 'result', 'state', 'stiffness']
"""

from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from .ccode import ACTUATOR, FLAGS, ExportSpec

__all__ = ["STATUS", "FLAGS", "CResult", "CStiffness", "Library", "structures", "params_of", "loads_of"]

#: The status codes of the exported C, by number (``templates/model.h``).
STATUS = ("ok", "unstable", "snapped", "unreachable", "not_converged", "out_of_domain", "bad_input", "bad_parameters", "bad_size")


def structures(spec: ExportSpec) -> dict[str, type]:
    """ctypes mirrors of the export's structs."""
    real = ctypes.c_double if spec.precision == "double" else ctypes.c_float
    n, k = spec.n, spec.payloads

    class Params(ctypes.Structure):
        _fields_ = [(name, real) for name in ACTUATOR]

    class Payload(ctypes.Structure):
        _fields_ = [("force", real), ("angle", real), ("at", real)]

    class Loads(ctypes.Structure):
        _fields_ = [("pressure", real)] + ([("payload", Payload * k)] if k else []) + [("g", real)]

    class State(ctypes.Structure):
        _fields_ = [("theta", real * n), ("loads", Loads)]

    class Result(ctypes.Structure):
        _fields_ = [
            ("theta", real * n), ("total_angle", real), ("tip", real * 3), ("pressure", real), ("energy", real),
            ("gradient_norm", real), ("min_pivot", real), ("iterations", ctypes.c_int), ("steps", ctypes.c_int),
            ("snaps", ctypes.c_int), ("snap_ramp", ctypes.c_int), ("snap_at", real), ("snap_from", real), ("snap_to", real),
            ("flags", ctypes.c_int),
        ]

    class Stiffness(ctypes.Structure):
        _fields_ = [("compliance", real * 4), ("stiffness", real * 4), ("horizontal", real), ("vertical", real), ("min_pivot", real)]

    return {"params": Params, "payload": Payload, "loads": Loads, "state": State, "result": Result, "stiffness": Stiffness}


def params_of(values: Mapping[str, float]) -> dict[str, float]:
    """The C params from esba's parameter values (``Scene.parameters``, radians; M default 0.035)."""
    return {name: float(values.get(name, 0.035 if name == "M" else math.nan)) for name in ACTUATOR}


def loads_of(pressure: float, payloads: Sequence[tuple[float, float, float]] = (), g: float = 9.81) -> dict:
    """C loads: the pressure (MPa), payloads as (force N, angle rad, at), g (m/s^2)."""
    return {"pressure": float(pressure), "payloads": [tuple(map(float, p)) for p in payloads], "g": float(g)}


@dataclass(frozen=True, eq=False)
class CResult:
    """What ``equilibrium``, ``pressure_for_angle`` and ``newton`` returned."""

    status: int
    theta: np.ndarray
    total_angle: float
    tip: np.ndarray
    pressure: float
    energy: float
    gradient_norm: float
    min_pivot: float
    iterations: int
    steps: int
    snaps: int
    snap_ramp: int
    snap_at: float
    snap_from: float
    snap_to: float
    flags: int = 0

    @property
    def status_name(self) -> str:
        return STATUS[self.status] if 0 <= self.status < len(STATUS) else f"unknown({self.status})"

    @property
    def flag_names(self) -> tuple[str, ...]:
        """The names of the flags set (:data:`esba.export.ccode.FLAGS`), lowest bit first."""
        return tuple(name for i, name in enumerate(FLAGS) if self.flags & (1 << i))

    def values(self) -> list[float]:
        """Every real number of the result (for checks that nothing is NaN)."""
        return [*self.theta, self.total_angle, *self.tip, self.pressure, self.energy, self.gradient_norm, self.min_pivot, self.snap_at, self.snap_from, self.snap_to]


@dataclass(frozen=True, eq=False)
class CStiffness:
    status: int
    compliance: np.ndarray  # m/N
    stiffness: np.ndarray  # N/m
    horizontal: float
    vertical: float
    min_pivot: float


class Library:
    """A compiled export (a shared library built by :func:`esba.export.build.compile_shared`)."""

    def __init__(self, path: str | Path, spec: ExportSpec):
        self.spec = spec
        self.path = Path(path).resolve()
        self.lib = ctypes.CDLL(str(self.path))
        self.types = structures(spec)
        self.real = ctypes.c_double if spec.precision == "double" else ctypes.c_float
        name = spec.name
        fn = getattr(self.lib, f"{name}_work_bytes")
        fn.restype = ctypes.c_ulong
        self.work_bytes = int(fn())
        self._work = ctypes.create_string_buffer(self.work_bytes + 64)
        t = self.types
        ptr = ctypes.POINTER
        self._eq = getattr(self.lib, f"{name}_equilibrium")
        self._eq.argtypes = [ctypes.c_int, ptr(t["params"]), ptr(t["loads"]), ptr(t["state"]), ptr(t["result"]), ctypes.c_void_p]
        self._inv = getattr(self.lib, f"{name}_pressure_for_angle")
        self._inv.argtypes = [ctypes.c_int, ptr(t["params"]), ptr(t["loads"]), self.real, self.real, ptr(t["state"]), ptr(t["result"]), ctypes.c_void_p]
        self._newton = getattr(self.lib, f"{name}_newton")
        self._newton.argtypes = [ctypes.c_int, ptr(t["params"]), ptr(t["loads"]), ptr(self.real), ptr(t["result"]), ctypes.c_void_p]
        self._stiff = getattr(self.lib, f"{name}_stiffness")
        self._stiff.argtypes = [ctypes.c_int, ptr(t["params"]), ptr(t["loads"]), ptr(self.real), ptr(t["stiffness"]), ctypes.c_void_p]
        self._energy = getattr(self.lib, f"{name}_energy")
        self._energy.argtypes = [ctypes.c_int, ptr(t["params"]), ptr(t["loads"]), ptr(self.real), ptr(self.real), ptr(self.real), ctypes.c_void_p]
        self._gradient = getattr(self.lib, f"{name}_gradient")
        self._gradient.argtypes = [ctypes.c_int, ptr(t["params"]), ptr(t["loads"]), ptr(self.real), ptr(self.real), ctypes.c_void_p]
        self._hessian = getattr(self.lib, f"{name}_hessian")
        self._hessian.argtypes = self._gradient.argtypes
        self._tip = getattr(self.lib, f"{name}_tip")
        self._tip.argtypes = [ctypes.c_int, ptr(t["params"]), ptr(self.real), ptr(self.real), ptr(self.real), ctypes.c_void_p]
        for f in (self._eq, self._inv, self._newton, self._stiff, self._energy, self._gradient, self._hessian, self._tip):
            f.restype = ctypes.c_int

    # -- structures -------------------------------------------------------------------------

    def params(self, values: Mapping[str, float]):
        return self.types["params"](**{k: float(values[k]) for k in ACTUATOR})

    def loads(self, loads: Mapping) -> object:
        c = self.types["loads"]()
        c.pressure = loads["pressure"]
        c.g = loads.get("g", 9.81)
        payloads = list(loads.get("payloads", ()))
        if len(payloads) > self.spec.payloads:
            raise ValueError(f"{len(payloads)} payloads for an export with {self.spec.payloads}")
        for i in range(self.spec.payloads):
            force, angle, at = payloads[i] if i < len(payloads) else (0.0, math.pi / 2, 1.0)
            c.payload[i].force, c.payload[i].angle, c.payload[i].at = force, angle, at
        return c

    def state(self, theta: Sequence[float], loads: Mapping):
        s = self.types["state"]()
        for i, v in enumerate(theta):
            s.theta[i] = float(v)
        s.loads = self.loads(loads)
        return s

    def _vector(self, values: Sequence[float] | None, size: int):
        arr = (self.real * size)()
        if values is not None:
            for i, v in enumerate(values):
                arr[i] = float(v)
        return arr

    @staticmethod
    def _result(status: int, r) -> CResult:
        return CResult(
            status=int(status), theta=np.array(list(r.theta), dtype=float), total_angle=float(r.total_angle), tip=np.array(list(r.tip), dtype=float),
            pressure=float(r.pressure), energy=float(r.energy), gradient_norm=float(r.gradient_norm), min_pivot=float(r.min_pivot),
            iterations=int(r.iterations), steps=int(r.steps), snaps=int(r.snaps), snap_ramp=int(r.snap_ramp), snap_at=float(r.snap_at),
            snap_from=float(r.snap_from), snap_to=float(r.snap_to), flags=int(r.flags),
        )

    # -- calls ------------------------------------------------------------------------------

    def equilibrium(self, params: Mapping[str, float], loads: Mapping, start: tuple[Sequence[float], Mapping] | None = None, n: int | None = None) -> CResult:
        """``{name}_equilibrium``; ``start`` = (theta, its loads) or None (the straight state)."""
        r = self.types["result"]()
        st = self.state(*start) if start is not None else None
        status = self._eq(self.spec.n if n is None else n, self.params(params), self.loads(loads), None if st is None else ctypes.byref(st), ctypes.byref(r), self._work)
        return self._result(status, r)

    def pressure_for_angle(self, params: Mapping[str, float], loads: Mapping, total_angle: float, max_pressure: float = 10.0,
                           start: tuple[Sequence[float], Mapping] | None = None, n: int | None = None) -> CResult:
        """``{name}_pressure_for_angle`` (the loads' pressure is ignored)."""
        r = self.types["result"]()
        st = self.state(*start) if start is not None else None
        status = self._inv(self.spec.n if n is None else n, self.params(params), self.loads(loads), total_angle, max_pressure,
                           None if st is None else ctypes.byref(st), ctypes.byref(r), self._work)
        return self._result(status, r)

    def newton(self, params: Mapping[str, float], loads: Mapping, theta0: Sequence[float]) -> CResult:
        r = self.types["result"]()
        status = self._newton(self.spec.n, self.params(params), self.loads(loads), self._vector(theta0, self.spec.n), ctypes.byref(r), self._work)
        return self._result(status, r)

    def stiffness(self, params: Mapping[str, float], loads: Mapping, theta: Sequence[float]) -> CStiffness:
        s = self.types["stiffness"]()
        status = self._stiff(self.spec.n, self.params(params), self.loads(loads), self._vector(theta, self.spec.n), ctypes.byref(s), self._work)
        return CStiffness(int(status), np.array(list(s.compliance)).reshape(2, 2), np.array(list(s.stiffness)).reshape(2, 2), float(s.horizontal),
                          float(s.vertical), float(s.min_pivot))

    def energy(self, params, loads, theta) -> tuple[int, float, np.ndarray]:
        u = (self.real * 1)()
        terms = (self.real * 32)()
        status = self._energy(self.spec.n, self.params(params), self.loads(loads), self._vector(theta, self.spec.n), u, terms, self._work)
        return int(status), float(u[0]), np.array(list(terms))

    def gradient(self, params, loads, theta) -> tuple[int, np.ndarray]:
        out = (self.real * self.spec.n)()
        status = self._gradient(self.spec.n, self.params(params), self.loads(loads), self._vector(theta, self.spec.n), out, self._work)
        return int(status), np.array(list(out))

    def hessian(self, params, loads, theta) -> tuple[int, np.ndarray]:
        n = self.spec.n
        out = (self.real * (n * n))()
        status = self._hessian(n, self.params(params), self.loads(loads), self._vector(theta, n), out, self._work)
        return int(status), np.array(list(out)).reshape(n, n)

    def tip(self, params, theta) -> tuple[int, np.ndarray, np.ndarray]:
        n = self.spec.n
        tip = (self.real * 3)()
        points = (self.real * (2 * (n + 1)))()
        status = self._tip(n, self.params(params), self._vector(theta, n), tip, points, self._work)
        return int(status), np.array(list(tip)), np.array(list(points)).reshape(n + 1, 2).T

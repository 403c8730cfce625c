"""Exports compiled once per test session: the system's C compiler builds each (n, effects,
precision) as a shared library, called through :mod:`esba.export.binding`."""

from __future__ import annotations

import math

import numpy as np
import pytest

from esba.export.binding import Library
from esba.export.build import compile_shared, compiler
from esba.export.ccode import ExportSpec
from esba.export.writer import export_c

#: Table 1 (esba's Scene defaults) as the C params, rho in radians.
TABLE1 = {"L": 135.0, "r1": 8.0, "r2": 3.0, "d": 4.0, "rho": math.radians(10.0), "E": 0.54, "M": 0.035}


@pytest.fixture(scope="session")
def cc():
    found = compiler()
    if found is None:
        pytest.skip("no C compiler ($CC, gcc, cc): the exported C cannot be built here")
    return found


@pytest.fixture(scope="session")
def exports(tmp_path_factory, cc):
    """build(n, precision="double", effects=..., library=True) -> (Export, Library or None), each
    exported and compiled once."""
    built: dict = {}
    libraries: dict = {}

    def build(n: int, precision: str = "double", effects: str | None = None, library: bool = True):
        key = (n, precision, effects)
        if key not in built:
            spec = ExportSpec(n, precision=precision) if effects is None else ExportSpec(n, effects, precision=precision)
            built[key] = export_c(spec, tmp_path_factory.mktemp(f"export-n{n}-{precision}"))
        if library and key not in libraries:
            export = built[key]
            # -O1: the same IEEE results as the Makefile's -O2 (no fast-math), in half the compile time
            libraries[key] = Library(compile_shared(export.source, cc=cc, opt="-O1"), export.spec)
        return built[key], libraries.get(key)

    return build


def random_equilibria(count: int, seed: int) -> list[tuple[float, float, float, float]]:
    """(pressure MPa, payload N, direction deg, point) scenes: a third with a compressive payload on a
    nearly straight actuator (many of them snap on their load path), the rest anywhere in the
    paper's range."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        if i % 3 == 0:
            out.append((rng.uniform(0.001, 0.02), rng.uniform(2.5, 8.0), rng.uniform(176.0, 184.0), rng.uniform(0.7, 1.0)))
        else:
            out.append((rng.uniform(0.0, 0.3), rng.uniform(0.0, 4.0), rng.uniform(0.0, 180.0), rng.uniform(0.3, 1.0)))
    return out


def random_targets(count: int, seed: int) -> list[tuple[float, float, float, float]]:
    """(total angle deg, payload N, direction deg, point): targets from below the reachable range
    (a payload bends it backwards at P = 0) to past a fold and on the far branch."""
    rng = np.random.default_rng(seed)
    return [(rng.uniform(-40.0, 300.0), rng.uniform(0.0, 4.0), rng.uniform(0.0, 180.0), rng.uniform(0.3, 1.0)) for _ in range(count)]

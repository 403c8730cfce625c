"""Bad input to the exported C gets its status code and finite outputs, never NaN."""

from __future__ import annotations

import ctypes
import math

import numpy as np
import pytest

from esba.export.binding import STATUS, loads_of

from .conftest import TABLE1

NAN, INF = math.nan, math.inf
GOOD = loads_of(0.12, [(1.0, math.pi / 2, 1.0)])


def _finite(result) -> bool:
    return all(math.isfinite(v) for v in result.values())


@pytest.mark.parametrize(
    "loads, status",
    [
        (loads_of(-0.01, [(1.0, 1.0, 1.0)]), "bad_input"),  # a negative pressure
        (loads_of(NAN, [(1.0, 1.0, 1.0)]), "bad_input"),
        (loads_of(INF, [(1.0, 1.0, 1.0)]), "bad_input"),
        (loads_of(0.1, [(-1.0, 1.0, 1.0)]), "bad_input"),  # a negative force
        (loads_of(0.1, [(NAN, 1.0, 1.0)]), "bad_input"),
        (loads_of(0.1, [(1.0, NAN, 1.0)]), "bad_input"),
        (loads_of(0.1, [(1.0, 1.0, 0.0)]), "bad_input"),  # at outside (0, 1]
        (loads_of(0.1, [(1.0, 1.0, 1.5)]), "bad_input"),
    ],
    ids=["negative-pressure", "nan-pressure", "inf-pressure", "negative-force", "nan-force", "nan-angle", "at-0", "at-1.5"],
)
def test_bad_loads(exports, loads, status):
    _, lib = exports(3)
    for r in (lib.equilibrium(TABLE1, loads), lib.newton(TABLE1, loads, [0.1, 0.1, 0.1])):
        assert r.status_name == status and _finite(r) and np.all(r.theta == 0)
    if loads["pressure"] == 0.1:  # the inverse ignores the loads' pressure, not the payloads
        assert lib.pressure_for_angle(TABLE1, loads, 1.0).status_name == status
    assert lib.stiffness(TABLE1, loads, [0.1, 0.1, 0.1]).status == STATUS.index(status)
    assert lib.gradient(TABLE1, loads, [0.1, 0.1, 0.1])[0] == STATUS.index(status)


@pytest.mark.parametrize(
    "change",
    [{"L": 0.0}, {"r1": NAN}, {"r2": -1.0}, {"d": 5.0}, {"rho": math.pi / 2}, {"E": 0.0}, {"M": -0.1}, {"E": INF}],
    ids=["L=0", "r1=nan", "r2<0", "r2+d>=r1", "rho=90deg", "E=0", "M<0", "E=inf"],
)
def test_bad_parameters(exports, change):
    _, lib = exports(3)
    params = dict(TABLE1, **change)
    r = lib.equilibrium(params, GOOD)
    assert r.status_name == "bad_parameters" and _finite(r)
    assert lib.pressure_for_angle(params, GOOD, 1.0).status_name == "bad_parameters"
    assert lib.tip(params, [0.1, 0.1, 0.1])[0] == STATUS.index("bad_parameters")


@pytest.mark.parametrize("n", [0, 2, 4, 8, -1, 1 << 20])
def test_n_outside_the_export(exports, n):
    _, lib = exports(3)
    assert lib.equilibrium(TABLE1, GOOD, n=n).status_name == "bad_size"
    assert lib.pressure_for_angle(TABLE1, GOOD, 1.0, n=n).status_name == "bad_size"


def test_bad_targets_and_states(exports):
    _, lib = exports(3)
    for target, pmax in ((NAN, 10.0), (INF, 10.0), (1.0, 0.0), (1.0, -1.0), (1.0, NAN)):
        r = lib.pressure_for_angle(TABLE1, GOOD, target, pmax)
        assert r.status_name == "bad_input" and _finite(r)
    # a warm start with NaN, or outside Eq. (10)'s domain (theta_i below the chamber's closing angle)
    assert lib.equilibrium(TABLE1, GOOD, start=([NAN, 0.0, 0.0], GOOD)).status_name == "bad_input"
    assert lib.equilibrium(TABLE1, GOOD, start=([-2.0, 0.0, 0.0], GOOD)).status_name == "out_of_domain"
    assert lib.newton(TABLE1, GOOD, [-2.0, 0.0, 0.0]).status_name == "out_of_domain"
    assert lib.stiffness(TABLE1, GOOD, [-2.0, 0.0, 0.0]).status == STATUS.index("out_of_domain")
    assert lib.energy(TABLE1, GOOD, [-2.0, 0.0, 0.0])[0] == STATUS.index("out_of_domain")


def test_null_pointers(exports):
    _, lib = exports(3)
    r = lib.types["result"]()
    params, loads = lib.params(TABLE1), lib.loads(GOOD)
    assert lib._eq(3, None, ctypes.byref(loads), None, ctypes.byref(r), lib._work) == STATUS.index("bad_input")
    assert lib._eq(3, ctypes.byref(params), None, None, ctypes.byref(r), lib._work) == STATUS.index("bad_input")
    assert lib._eq(3, ctypes.byref(params), ctypes.byref(loads), None, None, lib._work) == STATUS.index("bad_input")
    assert lib._eq(3, ctypes.byref(params), ctypes.byref(loads), None, ctypes.byref(r), None) == STATUS.index("bad_input")
    assert lib._newton(3, ctypes.byref(params), ctypes.byref(loads), None, ctypes.byref(r), lib._work) == STATUS.index("bad_input")


def test_targets_past_the_reachable_range(exports):
    """Below what P = 0 gives under the payload, above what max_pressure gives: the nearest state
    that holds, never NaN."""
    _, lib = exports(3)
    loads = loads_of(0.0, [(2.0, math.pi / 2, 1.0)])
    low = lib.pressure_for_angle(TABLE1, loads, math.radians(-80.0))
    assert low.status_name == "unreachable" and low.pressure == 0.0
    at_zero = lib.equilibrium(TABLE1, loads)
    assert abs(low.total_angle - at_zero.total_angle) < 1e-12  # the P = 0 state: the payload bends it backwards
    high = lib.pressure_for_angle(TABLE1, loads, math.radians(90.0), 0.1)
    assert high.status_name == "unreachable" and abs(high.pressure - 0.1) < 1e-6 and high.total_angle < math.radians(90.0)
    # the model has no contact: 5000 deg (14 turns) is held at 2.84 MPa (so says esba pressure too), not at 1 MPa
    far = lib.pressure_for_angle(TABLE1, loads, math.radians(5000.0), 1.0)
    assert far.status_name == "unreachable" and _finite(far) and abs(far.pressure - 1.0) < 1e-6


def test_huge_loads_are_answered_with_a_status(exports):
    _, lib = exports(3)
    for loads in (loads_of(1e6, [(0.0, 0.0, 1.0)]), loads_of(0.1, [(1e9, math.pi, 1.0)]), loads_of(1e300, [(1e300, 1.0, 1.0)])):
        r = lib.equilibrium(TABLE1, loads)
        assert _finite(r)
        assert r.status_name in ("not_converged", "out_of_domain")
    # a 1 MN push up the axis closes the chambers: the state stops at Eq. (10)'s edge, inside it
    r = lib.equilibrium(TABLE1, loads_of(0.0, [(1e6, math.pi, 1.0)]))
    lowest = max(-135.0 * 3.0**2 / (3 * 8.0**3), -135.0 / (3 * (8.0 + 4.0)))
    assert r.status_name == "out_of_domain" and _finite(r) and np.all(r.theta > lowest) and np.min(r.theta) < 0.999 * lowest

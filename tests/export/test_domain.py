"""One rule of the model's domain in Python and in the exported C, and the C's notes where Python
notes something: the flags of a result (esba.model.validity's checks, with its thresholds read when
the export was written), the inverse's multistable note (pressure_for_target's on_load_path), and
an answer at the cusp of the pressure/payload map (docs/maps.md), where the ramp passes a nearly
singular Hessian."""

from __future__ import annotations

import math

import numpy as np
import pytest

from esba.analysis.stiffness import pressure_for_target
from esba.export.binding import loads_of, params_of
from esba.export.ccode import FLAGS
from esba.model import validity
from esba.model.scene import Payload, Scene
from esba.statics.equilibrium import solve
from tests.tolerances import EXPORT_THETA_ATOL

from .conftest import TABLE1

#: The flags that are esba.model.validity's checks (the rest are the C's notes).
CHECKS = FLAGS[:6]


def _python_flags(scene: Scene, theta, pressure: float, tip) -> set[str]:
    return {f.check for f in validity.assess(scene, theta, pressure, tip)}


def test_the_flags_are_validitys_checks():
    """Every check esba.model.validity makes has a flag of the same name (and a state that makes it)."""
    scene = Scene(pressure=5.0, payloads=(Payload(20.0, 0.0),))
    found = {f.check for f in validity.assess(scene, [9.0, 9.0, 0.5], 5.0, [-1.0, 0.0])}
    assert found == set(CHECKS) - {"radial_strain"}  # passing -1 needs a chamber wider than half the actuator
    wide = Scene().replace(r2=5.0, d=1.0)
    assert {f.check for f in validity.assess_angles(wide, [-2.1, 1.0, 1.0], 0.0)} == {"radial_strain"}


def test_the_c_rule_is_validitys_rule_on_random_states(exports, cc, tmp_path):
    """The C's range check (static in the export's source, reached through a wrapper that includes
    it) against validity.assess on random states of two actuators, Table 1 and one whose chamber is
    wider than half of it (the only way past -1 of radial strain), with random tips, pressures and
    payloads on both sides of every threshold."""
    import ctypes

    from esba.export.build import compile_shared

    export, lib = exports(3)
    name = export.spec.name
    wrapper = tmp_path / "range_flags.c"
    wrapper.write_text(
        f'#include "{export.source}"\n'
        f"int esba_test_range_flags(const {name}_params *a, const {name}_loads *l, const {name}_real *theta, {name}_real tip_x, {name}_real p) {{\n"
        "    return range_flags(a, l, theta, tip_x, p);\n}\n"
    )
    check = ctypes.CDLL(str(compile_shared(wrapper, cc=cc, opt="-O1")))
    check.esba_test_range_flags.restype = ctypes.c_int
    rng = np.random.default_rng(44)
    seen: set[str] = set()
    for i in range(400):
        scene = Scene() if i % 2 else Scene().replace(r2=7.0, d=0.5)
        a = scene.actuator
        low = max(-a.L * a.r2**2 / (3 * a.r1**3), -a.L / (3 * (a.r1 + a.d)))
        theta = rng.uniform(0.999 * low, 4.0, 3) if i % 3 else rng.uniform(-0.5, 2.6, 3)
        tip_x, pressure, force = rng.uniform(-20.0, 100.0), rng.uniform(0.0, 2.0), rng.uniform(0.0, 15.0)
        payloads = (Payload(force, 90.0),)
        want = {f.check for f in validity.assess(scene.replace(payloads=payloads), theta, pressure, [tip_x, 0.0])}
        params = lib.params(params_of(scene.parameters(0.0)))
        loads = lib.loads(loads_of(pressure, [(force, math.pi / 2, 1.0)]))
        got = check.esba_test_range_flags(ctypes.byref(params), ctypes.byref(loads), lib._vector(theta, 3), lib.real(tip_x), lib.real(pressure))
        assert {n for k, n in enumerate(FLAGS) if got & (1 << k)} == want, (i, theta, tip_x, pressure, force)
        seen |= want
    assert seen == set(CHECKS)


def _random_scenes(count: int, seed: int):
    """(pressure, force, direction deg, at): the paper's range and well past it (bends past a turn,
    tips behind the base, pressures past 1 MPa and payloads past 10 N)."""
    rng = np.random.default_rng(seed)
    out = [(0.17, 2.0, 90.0, 1.0), (0.5, 0.0, 90.0, 1.0), (1.2, 0.5, 90.0, 1.0), (0.1, 12.0, 0.0, 1.0)]
    for i in range(count - len(out)):
        if i % 2:
            out.append((rng.uniform(0.0, 0.25), rng.uniform(0.0, 4.0), rng.uniform(0.0, 180.0), rng.uniform(0.3, 1.0)))
        else:
            out.append((rng.uniform(0.15, 0.6), rng.uniform(0.0, 3.0), rng.uniform(0.0, 180.0), rng.uniform(0.5, 1.0)))
    return out


@pytest.mark.parametrize("n, count, seed", [(3, 30, 41), pytest.param(8, 40, 42, marks=[pytest.mark.slow, pytest.mark.ci])])
def test_c_and_python_flag_the_same_states(exports, n, count, seed):
    """On random scenes, in and outside the model's range: the C's flags are validity's findings of
    the state the C returns, and where C and Python's solve() reach the same state, they are solve()'s."""
    _, lib = exports(n)
    outside = compared = 0
    for p, f, a, s in _random_scenes(count, seed):
        scene = Scene(pressure=p, payloads=(Payload(f, a, s),), segments=n)
        c = lib.equilibrium(params_of(scene.parameters(p)), loads_of(p, [(f, math.radians(a), s)]))
        if c.status_name not in ("ok", "snapped", "unstable", "not_converged"):
            continue
        assert set(c.flag_names) == _python_flags(scene, c.theta, p, c.tip), (p, f, a, s, c.flag_names)
        py = solve(scene)
        if py.ok and np.max(np.abs(py.theta - c.theta)) < EXPORT_THETA_ATOL:
            assert set(c.flag_names) == {x.check for x in py.validity}, (p, f, a, s)
            compared += 1
        outside += bool(c.flags)
    assert compared >= count // 2 and outside >= count // 4, (compared, outside)


def test_the_issues_states_are_flagged(exports):
    """0.17 MPa under 2 N horizontal: 212.84 deg with the tip 26 mm behind the base (solve() warns);
    0.5 MPa: 687 deg, almost two turns. Neither is plain "ok" any more."""
    _, lib = exports(3)
    c = lib.equilibrium(TABLE1, loads_of(0.17, [(2.0, math.pi / 2, 1.0)]))
    assert c.status_name == "ok" and math.degrees(c.total_angle) == pytest.approx(212.84, abs=0.01) and c.tip[0] < -26
    assert c.flag_names == ("tip_behind_base",)
    c = lib.equilibrium(TABLE1, loads_of(0.5, [(0.0, math.pi / 2, 1.0)]))
    assert math.degrees(c.total_angle) > 680 and c.flag_names == ("axial_strain", "total_bend", "tip_behind_base")


def test_the_inverse_says_when_its_answer_is_off_the_load_history(exports):
    """200 deg under 2 N horizontal: 0.1657 MPa, past the snap; inflating first reaches about 78 deg
    there. The answer is flagged multistable (and its tip, behind the base), as Python notes."""
    _, lib = exports(3)
    loads = loads_of(0.0, [(2.0, math.pi / 2, 1.0)])
    c = lib.pressure_for_angle(TABLE1, loads, math.radians(200.0))
    assert c.status_name == "ok" and c.pressure == pytest.approx(0.1657168, abs=1e-7)
    assert "multistable" in c.flag_names
    reached = lib.equilibrium(TABLE1, loads_of(c.pressure, [(2.0, math.pi / 2, 1.0)]))
    assert 70 < math.degrees(reached.total_angle) < 85 and "multistable" not in reached.flag_names
    py = pressure_for_target(Scene(payloads=(Payload(2.0),)), total_angle_deg=200.0)
    assert not py.on_load_path and "multistable" in py.message
    on_path = lib.pressure_for_angle(TABLE1, loads, math.radians(45.0))
    assert on_path.status_name == "ok" and on_path.flags == 0


def test_the_multistable_note_agrees_with_python_on_random_targets(exports):
    rng = np.random.default_rng(43)
    _, lib = exports(3)
    agreed = flagged = unreachable = 0
    for _ in range(16):
        target, f = rng.uniform(20.0, 260.0), rng.uniform(0.5, 3.0)
        scene = Scene(payloads=(Payload(f),))
        c = lib.pressure_for_angle(TABLE1, loads_of(0.0, [(f, math.pi / 2, 1.0)]), math.radians(target))
        if c.status_name == "unreachable":  # the nearest state that holds: flagged by the same rule
            history = lib.equilibrium(TABLE1, loads_of(c.pressure, [(f, math.pi / 2, 1.0)]))
            same = history.status_name in ("ok", "snapped") and np.max(np.abs(history.theta - c.theta)) <= 1e-6
            assert ("multistable" in c.flag_names) == (not same), (target, f, c.pressure)
            unreachable += 1
        if c.status_name != "ok":
            continue
        py = pressure_for_target(scene, total_angle_deg=target)
        if not py.ok or abs(py.pressure - c.pressure) > 1e-7:
            continue
        assert ("multistable" in c.flag_names) == (not py.on_load_path), (target, f, c.pressure)
        agreed += 1
        flagged += "multistable" in c.flag_names
    assert agreed >= 6 and 0 < flagged < agreed and unreachable >= 1, (agreed, flagged, unreachable)


@pytest.mark.parametrize("force", [1.65, 1.7])
@pytest.mark.parametrize("dp", [-1e-9, 0.0, 1e-9])
def test_the_ramp_answers_at_the_cusp(exports, force, dp):
    """docs/maps.md: the pressure/payload cusp at P = 0.1685804535 MPa, F = 1.645 N. Raising the
    payload at that pressure passes a Hessian singular to 1e-8: the C used to stop there
    (not_converged, gradient 0.9 N mm). It now answers solve()'s state (153.404 deg at 1.65 N), a
    stable equilibrium; where the payload path crosses the tip of the fold curve it reports the
    small snap (under a degree, at the cusp's 145 deg) that solve()'s path trace does not resolve."""
    _, lib = exports(3)
    p = 0.1685804535 + dp
    c = lib.equilibrium(TABLE1, loads_of(p, [(force, math.pi / 2, 1.0)]))
    assert c.status_name in ("ok", "snapped"), c.status_name
    assert c.gradient_norm <= 1e-9 and c.min_pivot > 0
    if c.status_name == "snapped":
        assert 144.5 < math.degrees(c.snap_from) < math.degrees(c.snap_to) < 146.0
    py = solve(Scene(pressure=p, payloads=(Payload(force),)))
    assert np.max(np.abs(py.theta - c.theta)) < 1e-8
    if force == 1.65 and dp == 0.0:
        assert py.ok and math.degrees(c.total_angle) == pytest.approx(153.404, abs=1e-3)

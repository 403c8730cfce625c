"""The batch solver: same answers as esba.statics.equilibrium.solve, every element accounted for.

Speed is measured by ``esba bench batch``, not here.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from esba.model.generated import load_model
from esba.model.scene import Actuator, Payload, Scene
from esba.statics.batch import (
    BatchOptions,
    BatchOptionsError,
    compiler,
    solve_arrays,
    solve_scenes,
)
from esba.statics.equilibrium import solve
from tests.tolerances import BATCH_THETA_ATOL, EQUILIBRIUM_GRAD_ATOL

INTERPRETED = BatchOptions(compile="never")


def _scenes() -> list[Scene]:
    """Pressures and target angles, payloads in several directions and places, other geometries."""
    out = []
    for p in (0.0, 0.03, 0.12, 0.2):
        for f, om in ((0.0, 90.0), (1.0, 90.0), (2.0, 0.0), (1.5, 225.0)):
            out.append(Scene(pressure=p, payloads=(Payload(f, om),)))
    out.append(Scene(target_angle_deg=90.0, payloads=(Payload(2.0, 90.0),)))
    out.append(Scene(target_angle_deg=45.0, payloads=(Payload(1.0, 300.0, at=0.5),)))
    out.append(Scene(actuator=Actuator(r2=1.0, d=0.0, rho_deg=40.0), pressure=0.2, payloads=(Payload(0.5, 60.0),)))
    out.append(Scene(actuator=Actuator(r2=6.0, d=1.5, rho_deg=0.0), pressure=0.05, payloads=(Payload(1.0, 90.0),)))
    return out


def _compare(scenes, result):
    for i, s in enumerate(scenes):
        ref = solve(s)
        assert ref.ok == bool(result.ok[i]), (i, s.describe(), ref.message, result.messages[i])
        if ref.ok:
            np.testing.assert_allclose(result.theta[i], ref.theta, atol=BATCH_THETA_ATOL, err_msg=s.describe())
            np.testing.assert_allclose(result.tip[i], ref.tip, atol=1e3 * BATCH_THETA_ATOL)
            assert result.pressure[i] == pytest.approx(ref.pressure, rel=1e-12)
            assert result.notes[i] == tuple(ref.notes), "a jump solve() notes must be noted by the batch too"


def test_batch_agrees_with_ipopt_solve():
    scenes = _scenes()
    r = solve_scenes(scenes, INTERPRETED)
    assert r.ok.all(), [m for m in r.messages if m]
    assert (r.gradient_norm <= EQUILIBRIUM_GRAD_ATOL).all()
    assert set(r.method) <= {"newton", "newton-retry"}
    _compare(scenes, r)


def test_retry_and_continuation_agree_too():
    # a deliberately starved fast path: one load step, one Newton iteration, nothing after
    starved = BatchOptions(compile="never", load_steps=1, newton_steps=1, final_steps=0)
    scenes = _scenes()[4:12]
    r = solve_scenes(scenes, starved)
    assert "newton-retry" in set(r.method)
    _compare(scenes, r)
    r = solve_scenes(scenes, BatchOptions(compile="never", load_steps=1, newton_steps=1, final_steps=0, retry=False))
    assert "continuation" in set(r.method)
    _compare(scenes, r)


def test_unsolved_elements_say_why_and_are_never_silent():
    starved = BatchOptions(compile="never", load_steps=1, newton_steps=1, final_steps=0, retry=False, fallback=False)
    r = solve_scenes(_scenes(), starved)
    assert not r.ok.all()
    for i in range(len(r)):
        if r.ok[i]:
            assert r.messages[i] == "" and np.all(np.isfinite(r.theta[i]))
        else:
            assert "pseudo-arclength continuation not run (fallback=False)" in r.messages[i]
            assert r.method[i] == "none"
    # arrays of parameters need no scenes: pseudo-arclength continuation answers what natural cannot
    m = load_model(3)
    v = dict(L=135.0, r1=8.0, r2=3.0, d=4.0, rho=math.radians(10), E=0.54, P=0.2, F1=[0.0, 3.0], Omega1=math.pi / 2, s1=1.0)
    r = solve_arrays(m, v, options=BatchOptions(compile="never", load_steps=1, newton_steps=1, final_steps=0, retry=False))
    assert r.ok.all() and r.method[1] == "continuation"
    np.testing.assert_allclose(r.theta[1], solve(Scene(pressure=0.2, payloads=(Payload(3.0),))).theta, atol=BATCH_THETA_ATOL)


def test_mixed_effects_keep_their_order():
    scenes = [
        Scene(pressure=0.1),
        Scene(pressure=0.1, payloads=(Payload(1.0),)),
        Scene(pressure=0.1, gravity=True),
        Scene(target_angle_deg=60.0, payloads=(Payload(1.0),)),
        Scene(pressure=0.1, payloads=(Payload(1.0), Payload(0.5, 0.0, at=0.5))),
    ]
    r = solve_scenes(scenes, INTERPRETED)
    assert r.ok.all()
    _compare(scenes, r)


@pytest.mark.skipif(compiler() is None, reason="no C compiler ($CC, gcc, cc) on this machine")
def test_compiled_equals_interpreted():
    scenes = _scenes()[:8]
    a = solve_scenes(scenes, BatchOptions(compile="always", chunk=4))
    b = solve_scenes(scenes, BatchOptions(compile="never", chunk=4))
    assert a.backend.startswith("compiled C") and b.backend.startswith("interpreted")
    np.testing.assert_allclose(a.theta, b.theta, atol=1e-12)


def test_auto_does_not_compile_small_batches():
    r = solve_scenes(_scenes()[:2], BatchOptions(compile="auto", compile_min=10_000))
    if compiler() is None:
        assert "no C compiler" in r.backend
    elif not r.backend.startswith("compiled"):  # unless this library is already cached
        assert "compile_min" in r.backend


def test_progress_bar_and_counts(capsys):
    r = solve_scenes(_scenes()[:3], BatchOptions(compile="never", progress=True))
    assert r.counts()["ok"] == 3 and r.counts()["not_ok"] == 0
    assert r.per_equilibrium_us() > 0
    assert capsys.readouterr().out == ""  # the bar goes to stderr, nothing to stdout


def test_a_snap_through_is_never_taken_silently():
    """A straight actuator pushed along its axis (10 N at 180 deg, P = 1e-3 MPa) snaps sideways at ~3 N.

    Natural continuation meets a Hessian that is not positive definite on its load ramp and hands the
    element on; pseudo-arclength continuation follows the snap and notes it, as solve() does.
    """
    scenes = [Scene(pressure=1e-3, payloads=(Payload(f, 180.0),)) for f in (1.0, 10.0)]
    r = solve_scenes(scenes, INTERPRETED)
    assert r.method.tolist() == ["newton", "continuation"]
    assert r.ok.all() and r.snapped.tolist() == [False, True]
    assert r.notes[0] == () and r.notes[1] == tuple(solve(scenes[1]).notes) and any("jump" in note for note in r.notes[1])
    _compare(scenes, r)


def test_bad_batches_are_refused():
    with pytest.raises(BatchOptionsError, match="empty"):
        solve_scenes([])
    with pytest.raises(BatchOptionsError, match="segment counts"):
        solve_scenes([Scene(segments=2), Scene(segments=3)])
    with pytest.raises(BatchOptionsError, match="chunk=0"):
        BatchOptions(chunk=0)
    with pytest.raises(BatchOptionsError, match="critical_tol"):
        BatchOptions(critical_tol=-1.0)
    m = load_model(3)
    with pytest.raises(BatchOptionsError, match="missing parameter"):  # esba's own error, not a KeyError
        solve_arrays(m, {"L": 135.0})


def test_a_snap_the_retry_would_cross_with_positive_pivots_is_handed_on():
    """Found in review: 10 N at 170 deg on P = 0.03 MPa snaps at 24.5 % of the load. The denser retry
    used to cross that fold with every Hessian positive definite; the acceptance rule refuses it
    (its load steps do not contract there, or its corrector goes farther than its predictor), so the
    element goes on to pseudo-arclength continuation, which notes the jump."""
    scene = Scene(pressure=0.03, payloads=(Payload(10.0, 170.0),))
    r = solve_scenes([scene], INTERPRETED)
    ref = solve(scene)
    assert ref.jumps and r.method.tolist() == ["continuation"] and r.snapped.tolist() == [True]
    assert r.notes[0] == tuple(ref.notes) and any("snap-through" in note for note in r.notes[0])
    np.testing.assert_allclose(r.theta[0], ref.theta, atol=BATCH_THETA_ATOL)


def test_every_element_that_took_the_harder_way_gives_solves_answer():
    """The bench's grid near the cusp (0.168-0.170 MPa, 1.64-2 N horizontal) and points inside the
    bistable window, where the load history snaps (inflate, then load: 2 N at 0.170-0.173 MPa jumps
    to the curled state), and a buckling-like snap (10 N at 170 deg on 0.03 MPa). Natural
    continuation is refused near the fold; the finer ramp or pseudo-arclength continuation answers,
    compiled engine or not, and each agrees with solve(), snaps and notes included."""
    scenes = [Scene(pressure=p, payloads=(Payload(f, 90.0),)) for p in (0.1685, 0.169, 0.1695, 0.171, 0.1725) for f in (1.64, 1.8, 2.0)]
    scenes.append(Scene(pressure=0.03, payloads=(Payload(10.0, 170.0),)))
    r = solve_scenes(scenes, INTERPRETED)
    harder = [i for i in range(len(scenes)) if r.method[i] != "newton"]
    assert {"continuation"} <= set(r.method[harder]) and r.snapped.any()
    for i in harder:
        ref = solve(scenes[i])
        assert r.ok[i] and ref.ok
        np.testing.assert_allclose(r.theta[i], ref.theta, atol=BATCH_THETA_ATOL)
        assert r.snapped[i] == bool(ref.jumps)
        assert r.notes[i] == tuple(ref.notes)

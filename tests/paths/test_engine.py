"""The continuation engine: one entry, the algorithm a value (Natural, PALC), one result type, one
acceptance rule; and the load history that solve() and the batch stand on."""

from __future__ import annotations

import numpy as np
import pytest

from esba.model.scene import Payload, Scene
from esba.paths.branch import Branch
from esba.paths.continuation import PALC, Natural, PathError, PathOptions, continuation
from esba.paths.loading import follow
from esba.paths.problem import PathProblem
from esba.solvers.newton import Acceptance
from esba.statics.equilibrium import SolverOptions, solve


@pytest.fixture(scope="module")
def payload_problem():
    unloaded = solve(Scene(pressure=0.1)).theta
    return PathProblem.from_scene(Scene(pressure=0.1, payloads=(Payload(2.0),)), "payload"), unloaded


def test_natural_and_palc_return_the_same_type_and_end(payload_problem):
    problem, unloaded = payload_problem
    nat = continuation(problem, unloaded, 0.0, to=2.0, algorithm=Natural())
    palc = continuation(problem, unloaded, 0.0, to=2.0, algorithm=PALC())
    assert isinstance(nat, Branch) and isinstance(palc, Branch)
    assert nat.stopped == palc.stopped == "bound"
    assert nat.lam[-1] == palc.lam[-1] == 2.0
    np.testing.assert_allclose(nat.theta[-1], palc.theta[-1], atol=1e-9)
    assert len(nat) == Natural().steps + 1 and (nat.morse == 0).all() and nat.stable.all()
    # the eigenvalues of either, computed when asked for, are the Hessian's
    g, h, _ = problem.ghl(nat.theta[-1], 2.0)
    np.testing.assert_allclose(nat.eigenvalues[-1], np.linalg.eigvalsh(h), rtol=1e-10)


def test_natural_is_refused_where_it_would_pass_a_fold():
    """The 2 N horizontal tip payload: the pressure path folds at 0.17354 MPa. Natural continuation
    from P = 0 to 0.2 MPa cannot pass it and is refused; PALC goes round it."""
    scene = Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),))
    problem = PathProblem.from_scene(scene, "pressure")
    start = solve(scene).theta
    nat = continuation(problem, start, 0.0, to=0.2, algorithm=Natural())
    assert nat.stopped == "refused" and "natural continuation refused" in nat.stop_reason
    palc = continuation(problem, start, 0.0, to=0.2)
    assert [sp.kind for sp in palc.special][:1] == ["fold"]


def test_a_natural_step_over_a_fold_onto_another_stable_branch_is_refused():
    """Found with the C export: 4.95 N pushing up the axis at 0.866 L on P = 0.0058 MPa. A natural step
    used to land on the far stable branch with every pivot positive and a contracting Newton iteration,
    so the snap went unreported; its corrector moves the state 24 times as far as its predictor."""
    scene = Scene(pressure=0.0058, payloads=(Payload(4.95, 180.0, 0.866),))
    fast, reference = solve(scene), solve(scene, SolverOptions(fast=False))
    assert len(reference.jumps) == 1 and len(fast.jumps) == 1
    np.testing.assert_allclose(fast.theta, reference.theta, atol=1e-9)
    assert fast.jumps[0].lam == pytest.approx(reference.jumps[0].lam, rel=1e-10)


def test_follow_keeps_an_accepted_natural_ramp(payload_problem):
    problem, unloaded = payload_problem
    r = follow(problem, unloaded, 0.0, 2.0, natural=Natural())
    assert r.reached and r.algorithm == "Natural" and len(r.pieces) == 1
    slow = follow(problem, unloaded, 0.0, 2.0)
    assert slow.algorithm == "PALC"
    np.testing.assert_allclose(r.theta, slow.theta, atol=1e-9)


def test_bad_algorithms_and_settings_are_refused(payload_problem):
    problem, unloaded = payload_problem
    with pytest.raises(PathError, match="algorithm="):
        continuation(problem, unloaded, 0.0, to=1.0, algorithm="natural")
    with pytest.raises(PathError, match="needs to="):
        continuation(problem, unloaded, 0.0, algorithm=Natural())
    with pytest.raises(PathError, match="steps=0"):
        Natural(steps=0)
    with pytest.raises(PathError, match="options="):
        PALC(options="fast")
    with pytest.raises(PathError, match="takes no"):
        continuation(problem, unloaded, 0.0, to=1.0, algorithm=Natural(), milestones=[0.5])
    with pytest.raises(Exception, match="jump="):
        Acceptance(jump=0.0)


def test_palc_accepts_its_options(payload_problem):
    problem, unloaded = payload_problem
    coarse = continuation(problem, unloaded, 0.0, to=2.0, algorithm=PALC(PathOptions(ds_max=0.5, ds=0.5)))
    fine = continuation(problem, unloaded, 0.0, to=2.0, algorithm=PALC(PathOptions(ds_max=0.01)))
    assert len(fine) > len(coarse)
    np.testing.assert_allclose(fine.theta[-1], coarse.theta[-1], atol=1e-9)


def test_the_forecast_of_a_long_trace_leaves_out_the_first_step(caplog):
    """The first step pays one-off costs (kernels compiled on first use): the pace is taken after it."""
    from esba.paths import continuation

    clock = iter([100.0, 103.0])  # step 1 ends at 100 s (a compile); 30 more steps take 3 s
    forecast = continuation._Forecast(1.0, "the branch", clock=lambda: next(clock))
    with caplog.at_level("WARNING", logger=continuation._log.name):
        forecast.tick(1, 0.0)  # one step in at lambda = 0 (its first step took 100 s)
        forecast.tick(31, 0.04)  # 0.04 of 1 in 3 s: 0.96 left takes 72 s
    (record,) = caplog.records
    assert "30 steps in 3 s" in record.getMessage() and "another 1 min" in record.getMessage()


def test_the_forecast_is_the_distance_left_at_the_pace_so_far_not_max_steps(caplog):
    """A trace that covers its range in k equal steps (a fake clock, one second a step) forecasts
    the time of the steps it has left, proportional to the parameter distance left, whatever its
    max_steps; on main it forecast (max_steps - steps) steps at that pace ("another 37 min" for a
    run of 7 s)."""
    from esba.paths import continuation

    k, lo, hi = 400, 0.0, 0.3
    for done in (50, 100, 200, 300):
        now = [0.0]
        forecast = continuation._Forecast(hi, "pressure", clock=lambda: now[0])
        forecast.tick(1, lo + (hi - lo) / k)  # the pace is taken from the end of the first step
        now[0] = done - 1.0
        lam = lo + (hi - lo) * done / k
        rest = forecast.remaining_s(lam, now[0])
        assert rest == pytest.approx(k - done, rel=1e-9)  # the steps left, one second each
        assert rest == pytest.approx((hi - lam) / ((hi - lo) / k), rel=1e-9)  # proportional to the distance left
    # a trace heading down to its end, and one that has turned back at a fold, say nothing alarming
    now = [0.0]
    down = continuation._Forecast(-1.0, "down", clock=lambda: now[0])
    down.tick(1, 0.0)
    assert down.remaining_s(-0.5, 10.0) == pytest.approx(10.0)
    assert down.remaining_s(0.1, 10.0) is None
    # no warning when the rest is short, however large max_steps is
    now = [0.0]
    short = continuation._Forecast(hi, "pressure", clock=lambda: now[0])
    with caplog.at_level("WARNING", logger=continuation._log.name):
        short.tick(1, 0.0)
        now[0] = 7.0
        short.tick(200, 0.2)
    assert not caplog.records and short.done

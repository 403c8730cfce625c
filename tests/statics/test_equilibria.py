"""Every equilibrium of a scene (esba.statics.equilibria) and solve()'s multistability check.

The search is checked against what it must find: the bistable window under Table 2's load (the two
stable states and the saddle, whose energies an independent SymPy evaluation confirms and which
lies on the traced pressure branch between its folds), a brute-force multistart Newton over 20
random scenes, the straight column between its fold and its buckling load, and larger n.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from esba.model.scene import Payload, Scene
from esba.paths.continuation import PathOptions, PathProblem, trace
from esba.paths.loading import follow
from esba.solvers.newton import newton_correction
from esba.statics.equilibria import EquilibriaOptions, EquilibriaOptionsError, equilibria
from esba.statics.equilibrium import SolverOptions, SolverOptionsError, solve
from esba.statics.history import HISTORIES, describe_history, history_steps
from tests import reference
from tests.tolerances import EQUILIBRIUM_GRAD_ATOL, KERNEL_ATOL, KERNEL_RTOL

#: Table 2's load: the 2 N horizontal tip payload.
TWO_N = (Payload(force=2.0, angle_deg=90.0),)
#: Two equilibria closer than this (rad, largest segment difference) are the same one: both are
#: stationary to ~1e-10 N mm/rad on Hessians of O(10-1000) N mm/rad^2, so they agree to ~1e-9 rad.
SAME_STATE = 1e-6


def _summary(res):
    return [(s.morse_index, s.stable) for s in res.states]


@pytest.fixture(scope="module")
def window():
    """P = 0.17 MPa under 2 N, n = 3: inside the bistable window (folds at 0.1636 and 0.1735 MPa)."""
    return equilibria(Scene(pressure=0.17, payloads=TWO_N))


def test_bistable_window_has_exactly_two_stable_states_and_the_saddle(window):
    res = window
    assert [s.morse_index for s in res.states] == [0, 0, 1]
    assert [round(s.total_angle_deg, 2) for s in res.stable] == [212.84, 83.90]
    assert res.multistable and res.complete is True and res.check_found == 0
    assert res.least_energy is res.states[0]
    assert res.history_state == 0  # inflate then load reaches the far, least-energy state at 0.17 MPa
    saddle = res.states[2]
    assert saddle.stability == "unstable" and saddle.min_eigenvalue < 0
    b = res.barriers[0]
    assert (b.a, b.b, b.saddle) == (0, 1, 2)
    assert b.from_a == pytest.approx(saddle.energy - res.states[0].energy) and b.from_a > 0
    assert b.from_b == pytest.approx(saddle.energy - res.states[1].energy) and b.from_b > 0


def test_energies_match_an_independent_evaluation(window):
    scene = window.scene
    values = scene.parameters(window.pressure)
    for s in window.states:
        u, g, _ = reference.evaluate(scene.segments, scene.effects, scene.variant, values, s.theta)
        assert s.energy == pytest.approx(u, rel=KERNEL_RTOL, abs=KERNEL_ATOL)
        assert max(abs(v) for v in g) <= EQUILIBRIUM_GRAD_ATOL


def test_the_saddle_lies_on_the_traced_branch_between_the_folds(window):
    scene = Scene(pressure=0.10, payloads=TWO_N)
    problem = PathProblem.from_scene(scene, "pressure")
    start = solve(scene, SolverOptions(multistability="never")).theta
    branch = trace(problem, start, 0.10, to=0.30, options=PathOptions(ds_max=0.1), milestones=[0.17])
    folds = sorted(f.lam for f in branch.folds)
    assert len(folds) == 2 and folds[0] < 0.17 < folds[1]
    at = [sp for sp in branch.special if sp.kind == "user" and abs(sp.lam - 0.17) < 1e-12]
    assert len(at) == 3  # the branch crosses P = 0.17 three times: stable, saddle, stable
    on_branch = sorted(at, key=lambda sp: sp.arclength)
    saddle = window.states[2]
    assert float(np.max(np.abs(on_branch[1].theta - saddle.theta))) <= 1e-6  # the middle crossing, between the folds
    for sp, s in zip((on_branch[0], on_branch[2]), sorted(window.stable, key=lambda s: s.total_angle_deg)):
        assert float(np.max(np.abs(sp.theta - s.theta))) <= 1e-6


def _brute_force(scene: Scene, points: int = 11, iterations: int = 100) -> list[np.ndarray]:
    """Plain Newton (steps capped at 0.5 rad) from a points^n grid of starts over each segment's
    range; the distinct converged states in the search's domain (segments above the model's lower
    bound, total bend at most 360 deg)."""
    model = scene.model()
    n = model.n
    full = scene.parameters(scene.pressure)
    pv = model.param_vector(full)
    lb = float(model.lower_bounds(full)[0])
    kernel = newton_correction(model)
    axis = np.linspace(0.95 * lb, 2.8, points)
    x = np.array(np.meshgrid(*[axis] * n, indexing="ij")).reshape(n, -1).T
    for _ in range(iterations):
        _, step, _ = kernel(x.T, pv)
        d = -np.asarray(step).T
        norm = np.linalg.norm(d, axis=1, keepdims=True)
        x = x + d * np.minimum(1.0, 0.5 / np.maximum(norm, 1e-300))
        x[~np.all(np.isfinite(x), axis=1) | np.any(x < lb, axis=1)] = np.nan
    g = np.asarray(kernel(np.nan_to_num(x).T, pv)[0]).T
    ok = np.all(np.isfinite(x), axis=1) & (np.max(np.abs(g), axis=1) <= 1e-8) & (x.sum(axis=1) <= 2 * math.pi) & np.all(x > lb, axis=1)
    roots: list[np.ndarray] = []
    for r in x[ok]:
        if not any(float(np.max(np.abs(r - q))) <= SAME_STATE for q in roots):
            roots.append(r)
    return roots


def test_deflation_finds_every_equilibrium_a_brute_force_multistart_finds():
    rng = np.random.default_rng(17)
    multiple = 0
    for _ in range(20):
        pressure, force, angle = rng.uniform(0.0, 0.25), rng.uniform(0.0, 4.0), rng.uniform(0.0, 180.0)
        scene = Scene(pressure=pressure, payloads=(Payload(force, angle),))
        roots = _brute_force(scene)
        res = equilibria(scene, EquilibriaOptions(connect=False))
        assert roots, "the brute force found no equilibrium: the test checks nothing"
        for r in roots:
            assert res.index(r, SAME_STATE) is not None, f"P={pressure:.4f} F={force:.3f} Omega={angle:.1f}: missed {np.degrees(r)}"
        model = scene.model()
        pv = model.param_vector(scene.parameters(pressure))
        for s in res.states:  # every state found is an equilibrium
            assert float(np.max(np.abs(model.gradient(s.theta, pv)))) <= EQUILIBRIUM_GRAD_ATOL
        multiple += len(res.states) > 1
    assert multiple >= 3  # the random scenes include multistable ones


@pytest.mark.parametrize("n", [3, 8])
def test_straight_column_between_its_fold_and_its_buckling_load(n):
    # n = 3: the bent branch towards the chamber folds at 2.65 N, the straight column buckles at 3.24 N
    # (docs/paths.md); n = 8: 2.61 and 3.17 N. 3 N lies between for both.
    res = equilibria(Scene(pressure=0.0, payloads=(Payload(3.0, 180.0),), segments=n))
    assert len(res.states) == 3 and len(res.stable) == 2
    straight = [s for s in res.stable if float(np.max(np.abs(s.theta))) < 1e-9]
    bent = [s for s in res.stable if s not in straight]
    assert len(straight) == 1 and len(bent) == 1 and bent[0].total_angle_deg > 45.0
    saddle = next(s for s in res.states if not s.stable)
    assert saddle.morse_index == 1
    assert 0.0 < saddle.total_angle_deg < bent[0].total_angle_deg  # between the two, on the towards-the-chamber side
    assert res.barriers and {res.barriers[0].a, res.barriers[0].b} == {res.states.index(straight[0]), res.states.index(bent[0])}


@pytest.mark.parametrize("n", [8, pytest.param(32, marks=[pytest.mark.slow, pytest.mark.ci])])
def test_more_segments_find_the_same_bistable_window(window, n):
    res = equilibria(Scene(pressure=0.17, payloads=TWO_N, segments=n), EquilibriaOptions(connect=False))
    assert _summary(res) == _summary(window)
    assert res.complete is True
    for a, b in zip(res.states, window.states):  # the same states, converging in n (docs/paths.md: the folds within 0.75 kPa)
        assert abs(a.total_angle_deg - b.total_angle_deg) < 5.0


def _independent_history(scene: Scene, history: str) -> np.ndarray:
    """The state a history reaches, traced with the path problems of the scene's own parameters
    (not the homotopies of esba.statics.history)."""
    pressure = scene.pressure
    force = scene.payloads[0].force
    if history == "inflate-then-load":
        legs = [("pressure", scene.replace(pressure=0.0, payloads=(Payload(0.0, 90.0),)), 0.0, pressure), ("payload", scene.replace(payloads=(Payload(0.0, 90.0),)), 0.0, force)]
    elif history == "load-then-inflate":
        legs = [("payload", scene.replace(pressure=0.0, payloads=(Payload(0.0, 90.0),)), 0.0, force), ("pressure", scene.replace(pressure=0.0), 0.0, pressure)]
    else:
        raise AssertionError(history)
    theta = np.zeros(scene.segments)
    for name, at, lam0, to in legs:
        r = follow(PathProblem.from_scene(at, name), theta, lam0, to)
        assert r.reached
        theta = r.theta
    return theta


@pytest.mark.parametrize("history", ["inflate-then-load", "load-then-inflate", "together"])
def test_solve_in_the_window_returns_the_state_its_history_reaches_and_names_the_other(history):
    scene = Scene(pressure=0.1686, payloads=TWO_N)
    r = solve(scene, SolverOptions(history=history))
    assert r.ok and r.history == history
    m = r.multistability
    assert m.looked and r.multistable is True and len(m.stable) == 2
    other = r.other_stable_states
    assert len(other) == 1 and float(np.max(np.abs(other[0].theta - r.theta))) > 0.1
    assert m.stable[m.reached].energy == pytest.approx(r.energy, rel=1e-12)
    assert f"{other[0].total_angle_deg:.2f} deg" in m.message and history in m.message
    d = r.to_dict()
    assert d["multistable"] is True and d["multistability"]["warning"] == m.message
    assert d["multistability"]["other_stable_states"][0]["total_angle_deg"] == pytest.approx(other[0].total_angle_deg)
    if history != "together":
        assert float(np.max(np.abs(r.theta - _independent_history(scene, history)))) <= 1e-6
    # inflate then load returns the far state, of higher energy (-84.95 against -85.13 N mm); the others the near one
    if history == "inflate-then-load":
        assert r.total_angle_deg > 180 and r.energy == pytest.approx(-84.95, abs=0.005) and other[0].energy == pytest.approx(-85.13, abs=0.005)
        assert "not the least energy" in m.message
    else:
        assert r.total_angle_deg < 90 and r.energy == pytest.approx(-85.13, abs=0.005)


def test_solve_outside_the_window_is_not_multistable_and_large_n_says_it_did_not_look():
    r = solve(Scene(pressure=0.12, payloads=TWO_N))
    assert r.multistable is False and r.other_stable_states == ()
    big = solve(Scene(pressure=0.12, payloads=TWO_N, segments=17))
    assert big.multistable is None and "not checked" in big.multistability.message and "n = 17" in big.multistability.message
    never = solve(Scene(pressure=0.17, payloads=TWO_N), SolverOptions(multistability="never"))
    assert never.multistable is None


def test_a_list_of_steps_is_a_history_of_its_own():
    scene = Scene(pressure=0.1686, payloads=TWO_N)
    steps = ((0.5, 0.0), (0.5, 1.0), (1.0, 1.0))
    r = solve(scene, SolverOptions(history=steps))
    assert r.ok and r.history == describe_history(steps)
    # the same steps as a named history give the named history's state
    same = solve(scene, SolverOptions(history=HISTORIES["load-then-inflate"]))
    assert same.history == "load-then-inflate"


def test_bad_options_name_the_value():
    with pytest.raises(SolverOptionsError, match="history='sideways'"):
        SolverOptions(history="sideways")
    with pytest.raises(SolverOptionsError, match="multistability='sometimes'"):
        SolverOptions(multistability="sometimes")
    with pytest.raises(EquilibriaOptionsError, match="max_bend_deg"):
        EquilibriaOptions(max_bend_deg=float("nan"))
    with pytest.raises(EquilibriaOptionsError, match=r"theta_starts\[0\]"):
        equilibria(Scene(pressure=0.1), theta_starts=[[0.1, 0.2]])
    assert history_steps("together") == ((1.0, 1.0),)


def test_the_numpy_rounds_find_what_the_compiled_rounds_find(window, monkeypatch):
    # beyond ROUND_ROOTS equilibria found, the rounds go on in NumPy (one kernel call per iteration)
    from esba.statics import equilibria as module

    monkeypatch.setattr(module, "ROUND_ROOTS", 0)
    res = equilibria(window.scene, EquilibriaOptions(connect=False))
    assert _summary(res) == _summary(window) and res.complete is True
    for a, b in zip(res.states, window.states):
        assert float(np.max(np.abs(a.theta - b.theta))) <= SAME_STATE


@pytest.mark.parametrize("n", [3, 8])
def test_solve_finds_the_other_state_up_to_the_auto_limit(n):
    for pressure in (0.165, 0.17, 0.173):
        r = solve(Scene(pressure=pressure, payloads=TWO_N, segments=n))
        assert r.multistable is True and len(r.other_stable_states) == 1, (n, pressure, r.multistability.message)


def test_solve_check_agrees_with_the_full_search_on_random_scenes():
    rng = np.random.default_rng(5)
    for _ in range(15):
        pressure, force, angle = rng.uniform(0.0, 0.25), rng.uniform(0.0, 4.0), rng.uniform(0.0, 180.0)
        scene = Scene(pressure=pressure, payloads=(Payload(force, angle),))
        r = solve(scene)
        full = equilibria(scene, EquilibriaOptions(connect=False))
        assert len(r.multistability.stable) == len(full.stable), (pressure, force, angle)
        assert full.index(r.theta, SAME_STATE) is not None  # the state solve() reached is among them


def test_the_detached_curled_branch_at_omega_121():
    # the 2 N tip payload turned to 121 deg at the 90 degree pressure (docs/paths.md: the direction folds
    # at 118.9 and 122.8 deg): two stable states; loading from rest reaches the near one, and the branch
    # through the strongly curled one folds at a payload above 0, never reaching the unloaded actuator
    res = equilibria(Scene(target_angle_deg=90.0, payloads=(Payload(2.0, 121.0),)))
    assert [s.morse_index for s in res.states] == [0, 0, 1]
    curled = max(res.stable, key=lambda s: s.total_angle_deg)
    assert curled.total_angle_deg > 150.0 and res.states[res.history_state] is not curled
    problem = PathProblem.from_scene(Scene(pressure=res.pressure, payloads=(Payload(2.0, 121.0),)), "payload")
    down = trace(problem, curled.theta, 2.0, bounds=(0.0, 8.0), direction=-1.0, options=PathOptions(ds_max=0.1))
    assert len(down.folds) == 1 and 1.5 < down.folds[0].lam < 2.0
    assert float(down.lam.min()) > 1.5  # the branch turns back at the fold: F = 0 is never reached
    r = solve(res.scene)
    assert r.multistable is True and float(np.max(np.abs(r.other_stable_states[0].theta - curled.theta))) <= 1e-6


# ---------------------------------------------------------------------------------------------
# the work the default solve does (issue 31: its multistability check should cost almost nothing)


def test_the_solve_check_deflates_the_reached_state_and_does_not_start_from_it_or_evaluate_it_again(monkeypatch):
    """The check's search runs SOLVE_CHECK.starts + 1 starts (theta = 0 and the constant-curvature
    shapes) per round; the state the solve reached is deflated from the first round, not a start
    as well (a start on a deflated root goes nowhere), and its State comes from the solve's result
    (no second evaluation). On main it ran one start more and evaluated the reached state again."""
    from esba.statics import equilibria as module

    evaluated = []
    real = module._state
    monkeypatch.setattr(module, "_state", lambda *a, **k: evaluated.append(a[2]) or real(*a, **k))
    runs = []
    real_rounds = module._rounds
    monkeypatch.setattr(module, "_rounds", lambda model, kernel, pv, starts, *a, **k: runs.append(len(starts)) or real_rounds(model, kernel, pv, starts, *a, **k))
    one = solve(Scene(pressure=0.1, payloads=TWO_N))  # one stable state
    assert one.multistable is False
    assert runs == [module.SOLVE_CHECK.starts + 1] and evaluated == []
    evaluated.clear(), runs.clear()
    two = solve(Scene(pressure=0.17, payloads=TWO_N))  # the bistable window: the near state and the saddle
    assert two.multistable is True and runs == [module.SOLVE_CHECK.starts + 1]
    assert len(evaluated) == 2 and all(float(np.max(np.abs(t - two.theta))) > 1e-3 for t in evaluated)
    assert np.array_equal(two.multistability.stable[two.multistability.reached].theta, two.theta)


def test_the_round_graph_calls_one_step_function_per_newton_iteration():
    """A deflation round is max_iter calls of one step Function (its C code, and gcc's time, are one
    step's), not max_iter inlined copies of the step's operations (main: about 40 nodes a step, so
    the round of equilibria()'s 60 steps took gcc 20 s at n = 3)."""
    import dataclasses

    from esba.statics import equilibria as module

    model = Scene(pressure=0.1).model()
    for sx in (False, True):  # the interpreter's graph and the compiled one
        size = {k: module._round_function(model, dataclasses.replace(module.SOLVE_CHECK, max_iter=k), sx).n_instructions() for k in (15, 60)}
        assert size[60] - size[15] <= 2 * 45  # at most two instructions a step


def test_the_multistable_scenes_load_ramp_is_natural_continuation_not_a_trace():
    """At 0.17 MPa under 2 N the load ramp stays on one stable branch, strongly bent: 4 natural steps
    are refused (a corrector went 1.28 times as far as its predictor), 16 are accepted by the same
    rule. The solve takes that finer ramp (a C call) instead of the adaptive trace (on main: 16
    pseudo-arclength points, a millisecond), and reaches the same state."""
    from esba.statics.history import load_history

    scene = Scene(pressure=0.17, payloads=TWO_N)
    model = scene.model()
    pv = model.param_vector(scene.parameters(0.17))
    h = load_history(model, 0.17, pv, None, SolverOptions())
    assert [r.algorithm for _, r in h.ramps] == ["Natural", "Natural"] and not h.message
    traced = load_history(model, 0.17, pv, None, SolverOptions(fast=False))
    assert float(np.max(np.abs(h.theta - traced.theta))) <= SAME_STATE
    r = solve(scene)
    assert r.ok and r.steps <= 1 + 5 + 17 and math.isclose(r.total_angle_deg, 212.8414878, abs_tol=1e-6)

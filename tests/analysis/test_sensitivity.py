"""Parameter sensitivities (esba.analysis.sensitivity): every parameter kind against central differences of
solves at n = 1, 3, 8, the payload point's closed form, folds, and the command line."""

from __future__ import annotations

import json

import numpy as np
import pytest

from esba.analysis.sensitivity import (
    SensitivityError,
    SensitivityOptions,
    parameter_names,
    scene_parameters,
    sensitivities,
    with_parameters,
)
from esba.cli import EXIT_OK, main
from esba.model.scene import MAIN_JOB, Payload, Scene, SceneError
from esba.statics.equilibrium import evaluate, solve
from tests.tolerances import (
    SENS_FD_FLOOR_MM,
    SENS_FD_FLOOR_RAD,
    SENS_FD_RTOL,
    SENS_FD_STEP,
    SENS_S_RTOL,
)

#: Two scenes that between them have every kind of parameter: a target angle (the pressure in
#: closed form) with a tip payload; a pressure with two payloads, one at s = 0.5 (a segment end
#: for n = 8, inside a segment for n = 1, 3) and one at the tip, and gravity (M, g).
SCENES = {
    "target": lambda n: MAIN_JOB.replace(segments=n),
    "pressure+gravity": lambda n: Scene(
        pressure=0.15, payloads=(Payload(1.0, 30.0, 0.5), Payload(0.5, 120.0, 1.0)), gravity=True, segments=n
    ),
}
KINDS = {"L", "r1", "r2", "d", "rho", "E", "M", "g", "P", "target_angle", "F", "Omega", "s"}


def _kind(name: str) -> str:
    return name if name in ("r1", "r2") else name.rstrip("0123456789")


def _difference(scene: Scene, name: str, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Central difference of solves; one-sided (second order) for a payload point at a segment end
    or the tip, where the angles are only once continuously differentiable in s."""
    value = next(p.value for p in scene_parameters(scene) if p.name == name)

    def at(v):
        r = solve(with_parameters(scene, {name: v}))
        assert r.ok, r.message
        return r.theta, r.tip[:2]

    if _kind(name) == "s" and abs(scene.segments * value - round(scene.segments * value)) < 1e-9:
        (t0, x0), (t1, x1), (t2, x2) = at(value), at(value - h), at(value - 2 * h)
        return (3 * t0 - 4 * t1 + t2) / (2 * h), (3 * x0 - 4 * x1 + x2) / (2 * h)
    (ta, xa), (tb, xb) = at(value + h), at(value - h)
    return (ta - tb) / (2 * h), (xa - xb) / (2 * h)


def test_the_scenes_cover_every_parameter_kind():
    kinds = {_kind(name) for make in SCENES.values() for name in parameter_names(make(3))}
    assert kinds == KINDS


@pytest.mark.parametrize("n", [1, 3, 8])
@pytest.mark.parametrize("which", list(SCENES))
def test_sensitivities_match_central_differences_of_solves(which, n):
    scene = SCENES[which](n)
    r = solve(scene)
    s = sensitivities(r)
    assert s.ok and s.names == parameter_names(scene)
    for j, p in enumerate(s.parameters):
        h = SENS_FD_STEP * max(1.0, abs(p.value))
        dtheta, dtip = _difference(scene, p.name, h)
        scale = max(float(np.max(np.abs(dtheta))), SENS_FD_FLOOR_RAD)
        np.testing.assert_allclose(s.dtheta[:, j], dtheta, rtol=0, atol=SENS_FD_RTOL * scale, err_msg=p.name)
        tscale = max(float(np.max(np.abs(dtip))), SENS_FD_FLOOR_MM)
        np.testing.assert_allclose(s.dtip[:, j], dtip, rtol=0, atol=SENS_FD_RTOL * tscale, err_msg=p.name)
        assert s.dtotal[j] == pytest.approx(float(np.sum(dtheta)), abs=SENS_FD_RTOL * scale * n)


@pytest.mark.parametrize("n, at", [(3, 0.5), (3, 1.0 / 3.0), (3, 2.0 / 3.0), (3, 1.0), (8, 0.25), (1, 1.0), (2, 0.7)])
def test_payload_point_column_against_differences_of_the_generated_gradient(n, at):
    """The closed form of d(dU/dtheta)/ds, at fixed angles, inside segments, at segment ends and the tip."""
    from esba.analysis.sensitivity import _functions

    scene = Scene(pressure=0.15, payloads=(Payload(1.5, 60.0, at),), segments=n)
    r = solve(scene)
    model, names = r.model, parameter_names(scene)
    p = np.array([q.value for q in scene_parameters(scene)])
    out = _functions(model, names, ())(r.theta, p, [], np.ones(n))
    column = np.asarray(out[2])[:, names.index("s1")].ravel()
    h = 1e-6

    def grad(s):
        return model.gradient(r.theta, model.param_vector(with_parameters(scene, {"s1": s}).parameters(0.15)))

    if abs(n * at - round(n * at)) < 1e-9:  # a segment end or the tip: once differentiable, from below
        fd = (3 * grad(at) - 4 * grad(at - h) + grad(at - 2 * h)) / (2 * h)
    else:
        fd = (grad(at + h) - grad(at - h)) / (2 * h)
    assert np.all(np.isfinite(column))
    np.testing.assert_allclose(column, fd, rtol=0, atol=SENS_S_RTOL * max(1.0, float(np.max(np.abs(fd)))))


def test_the_fibre_angle_drops_out_at_a_target_angle():
    """At a target angle the pressure follows rho so that the net pressure moment is fixed: the
    loaded state does not depend on rho at all (it does at a given pressure)."""
    s = sensitivities(solve(MAIN_JOB))
    assert np.max(np.abs(s.dtheta[:, s.index("rho")])) < 1e-12
    s = sensitivities(solve(MAIN_JOB.replace(pressure=0.1238739)))
    assert s.total_angle("rho") < -0.5  # deg per deg: more fibre angle, less bend


def test_subset_of_parameters_keeps_the_order_given():
    s = sensitivities(solve(MAIN_JOB), ["E", "r2"])
    full = sensitivities(solve(MAIN_JOB))
    assert s.names == ("E", "r2")
    np.testing.assert_array_equal(s.dtheta[:, 0], full.dtheta[:, full.index("E")])


def test_near_a_fold_says_so_instead_of_numbers():
    """A nearly straight actuator pushed along its axis just below its buckling load (about 2.9 N)."""
    r = solve(Scene(pressure=1e-3, payloads=(Payload(2.9, 180.0),)))
    assert r.ok
    s = sensitivities(r, options=SensitivityOptions(fold_tol=0.02))
    assert s.status == "near_fold" and not s.ok
    assert "fold" in s.message and "nearly singular" in s.message
    d = s.to_dict()
    json.dumps(d, allow_nan=False)
    assert all(v["dtheta_deg_per_unit"] is None and v["dtotal_angle_deg_per_unit"] is None for v in d["parameters"].values())


def test_just_short_of_a_fold_the_default_options_say_so():
    """0.02 % below the fold at 2.90414 N the eigenvalue ratio is still 0.006 (it falls like a square
    root), but the fold is a first-order 3e-3 deg of payload direction away: near_fold, no numbers."""
    r = solve(Scene(pressure=1e-3, payloads=(Payload(2.904143590 * (1 - 2e-4), 180.0),)))
    assert r.ok and not r.jumps
    s = sensitivities(r)
    assert s.eigenvalue_ratio > SensitivityOptions().fold_tol  # the ratio alone would let it through
    assert s.status == "near_fold" and "fold_distance_tol" in s.message


def test_fold_distance_estimates_the_buckling_load():
    """The linear estimate of where the smallest eigenvalue reaches 0 is about twice the true
    distance (the eigenvalue falls like a square root): compare half of it with the load at
    which the solve snaps."""
    base = 2.8
    s = sensitivities(solve(Scene(pressure=1e-3, payloads=(Payload(base, 180.0),))))
    estimate = s.fold_distance[s.index("F1")]
    assert estimate > 0  # more force brings the fold nearer
    lo, hi = base, 3.2
    for _ in range(12):  # bisect on the snap that solve() notes
        mid = 0.5 * (lo + hi)
        r = solve(Scene(pressure=1e-3, payloads=(Payload(mid, 180.0),)))
        lo, hi = (lo, mid) if r.notes else (mid, hi)
    true = 0.5 * (lo + hi) - base
    assert 0.5 * estimate == pytest.approx(true, rel=0.25)


def test_not_a_stable_equilibrium_gives_no_numbers():
    column = Scene(pressure=0.0, payloads=(Payload(20.0, 180.0),))
    s = sensitivities(evaluate(column, [0.0, 0.0, 0.0]))
    assert s.status == "not_stable" and "not a converged stable equilibrium" in s.message
    json.dumps(s.to_dict(), allow_nan=False)


def test_with_parameters_names_bad_input():
    with pytest.raises(SensitivityError, match="'P' is not a parameter of this scene .*target_angle"):
        with_parameters(MAIN_JOB, {"P": 0.1})
    with pytest.raises(SensitivityError, match="'F2' is not a parameter"):
        with_parameters(MAIN_JOB, {"F2": 1.0})
    with pytest.raises(SceneError, match="r2 \\+ d < r1"):
        with_parameters(MAIN_JOB, {"r2": 5.0})
    with pytest.raises(SceneError, match="E=nan"):
        with_parameters(MAIN_JOB, {"E": float("nan")})
    with pytest.raises(SensitivityError, match="fold_tol"):
        SensitivityOptions(fold_tol=0.0)


def test_cli_sensitivities(capsys):
    assert main(["solve", "--no-plot", "--sensitivities", "--json"]) == EXIT_OK
    d = json.loads(capsys.readouterr().out, parse_constant=lambda c: pytest.fail(f"{c} in JSON"))
    s = d["sensitivities"]
    assert s["status"] == "ok" and set(s["parameters"]) == set(parameter_names(MAIN_JOB))
    e = s["parameters"]["E"]
    assert e["unit"] == "MPa" and len(e["dtheta_deg_per_unit"]) == 3
    assert e["dtotal_angle_deg_per_unit"] == pytest.approx(sum(e["dtheta_deg_per_unit"]))
    assert main(["solve", "--no-plot", "--sensitivities"]) == EXIT_OK
    out = capsys.readouterr().out
    assert "sensitivity" in out and "target_angle" in out and "Omega1" in out


def test_the_output_says_what_is_held_fixed(capsys):
    """Issue 21: the default solve holds the 90 deg target angle (the pressure moves with E, dtheta/dE =
    +101.8 deg/MPa); at the same pressure held fixed dtheta/dE = -66.7 deg/MPa. The text and the JSON
    say which."""
    held = sensitivities(solve(MAIN_JOB)).held
    assert held["parameter"] == "target_angle" and held["value"] == 90.0 and "pressure moves" in held["meaning"]
    assert sensitivities(solve(MAIN_JOB.replace(pressure=0.1238739))).held["parameter"] == "P"
    for args, name, d_e in ((["solve"], "target_angle", 101.76), (["solve", "--pressure", "0.1238739"], "P", -66.74)):
        assert main([*args, "--no-plot", "--sensitivities", "--json"]) == EXIT_OK
        s = json.loads(capsys.readouterr().out)["sensitivities"]
        assert s["held_fixed"]["parameter"] == name
        assert s["parameters"]["E"]["dtotal_angle_deg_per_unit"] == pytest.approx(d_e, abs=0.01)
        assert main([*args, "--no-plot", "--sensitivities"]) == EXIT_OK
        out = capsys.readouterr().out
        assert "held fixed: " + s["held_fixed"]["meaning"] in out


def test_round_off_of_an_exact_zero_is_zero(capsys):
    """d/d rho at a held target angle is exactly 0 in the model; the arithmetic leaves about 1e-16, which
    the rule (ROUND_OFF) sets to 0, in the numbers and in the text."""
    s = sensitivities(solve(MAIN_JOB))
    j = s.index("rho")
    assert s.total_angle("rho") == 0.0 and np.all(s.dtheta[:, j] == 0.0) and np.all(s.dtip[:, j] == 0.0)
    assert np.all(s.dtheta[:, s.index("E")] != 0.0)  # the others are untouched
    assert sensitivities(solve(MAIN_JOB), ["rho"]).total_angle("rho") == 0.0  # whatever subset is asked for
    assert main(["solve", "--no-plot", "--sensitivities"]) == EXIT_OK
    row = next(line for line in capsys.readouterr().out.splitlines() if line.strip().startswith(": rho"))
    assert row.split()[4:7] == ["0", "0", "0"] and "e-1" not in row

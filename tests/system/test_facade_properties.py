"""The façade's arguments, by hypothesis: any argument of the wrong type, NaN, infinite or out of
range is refused with an :class:`esba.EsbaError` naming the argument, before any long
computation, and never with another exception (issue 30: ``esba.sweep(options='fast')`` raised a
bare TypeError, ``esba.tangent_stiffness(None)`` an AttributeError, ``EffectSet(air='yes')`` was
accepted, ``pressure_for_angle(Scene(), 3601)`` answered where a Scene refuses 3601, 120 MPa and
2000 N came back as ok=False after the solver gave up).

Each public callable of ``esba/__init__.py``'s façade has a valid call; hypothesis picks one
argument, replaces it with a bad value (generic: wrong types, NaN, infinities; or one out of
the argument's range) and checks the refusal.
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import esba
from esba import EsbaError

ROOT = Path(__file__).resolve().parents[2]


@lru_cache(maxsize=1)
def _result():
    return esba.solve(esba.Scene(pressure=0.1, payloads=(esba.Payload(1.0),)))


def _scene():
    return esba.Scene(pressure=0.1, payloads=(esba.Payload(1.0),))


def _sigmas():
    from esba.calibration.sigmas import parse_sigma, resolve_sigmas

    return resolve_sigmas(_scene(), [parse_sigma("E=5%")])


@lru_cache(maxsize=1)
def _measurements():
    return esba.load_measurements(ROOT / "examples" / "measurements" / "paper_exp.csv")


def _poses():
    from esba.calibration.sensing import Measured, Pose

    return Pose(0.1, (Measured("total_angle", (40.0,), 0.5),))


#: Façade callables: name -> (function of the keyword arguments, the valid arguments (a function,
#: so that the valid values are made per call), {argument: out-of-range values}, {argument: the
#: words a refusal of it may use instead of its name}).
CASES = {
    "Actuator": (lambda **k: esba.Actuator(**k), lambda: {"L": 135.0, "r1": 8.0, "r2": 3.0, "d": 4.0, "rho_deg": 10.0, "E": 0.54, "M": 0.035},
                 {"L": [-1.0, 0.0], "r1": [-8.0, 0.0], "r2": [-3.0, 9.0], "d": [-1.0, 8.0], "E": [-0.5, 0.0], "M": [-1.0], "rho_deg": [-1.0, 361.0]}, {}),
    "Payload": (lambda **k: esba.Payload(**k), lambda: {"force": 1.0, "angle_deg": 90.0, "at": 1.0},
                {"force": [-1.0, 2000.0, 1e300], "at": [0.0, 1.5, -1.0]}, {}),
    "Scene": (lambda **k: esba.Scene(**k), lambda: {"pressure": 0.1, "segments": 3, "gravity": False, "fibres": True, "variant": "paper"},
              {"pressure": [-0.1, 120.0, 1e300], "segments": [0, -1, 10_000]}, {}),
    "Scene(target)": (lambda **k: esba.Scene(**k), lambda: {"target_angle_deg": 90.0}, {"target_angle_deg": [0.0, -10.0, 3601.0, 1e300]}, {}),
    "EffectSet": (lambda **k: esba.EffectSet(**k), lambda: {"air": True, "axial": True, "radial": True, "fibres": True, "payloads": 1, "gravity": False},
                  {"payloads": [-1, 17]}, {}),
    "load_model": (lambda **k: esba.load_model(**k), lambda: {"n": 3, "effects": "air,axial,radial,fibres,payload", "variant": "paper"},
                   {"n": [0, -3, 100_000]}, {"n": ["segments"], "effects": ["effect"]}),
    "load_scene": (lambda **k: esba.load_scene(**k), lambda: {"path": "examples/no-such-scene.toml"}, {}, {"path": ["scene file"]}),
    "load_measurements": (lambda **k: esba.load_measurements(**k), lambda: {"path": "no-such.csv"}, {}, {"path": ["measurement file"]}),
    "pressure_for_angle": (lambda **k: esba.pressure_for_angle(**k), lambda: {"scene": esba.Scene(), "angle_deg": 90.0},
                           {"angle_deg": [0.0, -1.0, 3601.0]}, {"angle_deg": ["target_angle_deg"]}),
    "solve": (lambda **k: esba.solve(**k), lambda: {"scene": _scene(), "options": None}, {}, {}),
    "SolverOptions": (lambda **k: esba.SolverOptions(**k), lambda: {"tol": 1e-10, "max_iter": 200, "stationarity_tol": 1e-7},
                      {"tol": [0.0, -1.0], "max_iter": [0, -5]}, {}),
    "equilibria": (lambda **k: esba.equilibria(**k), lambda: {"scene": _scene(), "options": None}, {}, {}),
    "EquilibriaOptions": (lambda **k: esba.EquilibriaOptions(**k), lambda: {"max_bend_deg": 360.0, "starts": 25, "history": True},
                          {"max_bend_deg": [0.0, 721.0], "starts": [1, 1001]}, {}),
    "secant_stiffness": (lambda **k: esba.secant_stiffness(**k), lambda: {"scene": _scene(), "forces": [0.5, 1.0], "angle_deg": 90.0},
                         {"forces": [[-1.0], [2000.0]]}, {}),
    "tangent_stiffness": (lambda **k: esba.tangent_stiffness(**k), lambda: {"result": _result()}, {}, {}),
    "pressure_for_target": (lambda **k: esba.pressure_for_target(**k), lambda: {"scene": _scene(), "total_angle_deg": 60.0},
                            {"total_angle_deg": [3601.0, -3601.0]}, {}),
    "sensitivities": (lambda **k: esba.sensitivities(**k), lambda: {"result": _result(), "parameters": ["E"]}, {}, {"parameters": ["parameter"]}),
    "propagate": (lambda **k: esba.propagate(**k), lambda: {"result": _result(), "sigmas": _sigmas()}, {}, {}),
    "sweep": (lambda **k: esba.sweep(**k), lambda: {"base": None, "pressure": [0.1], "options": None},
              {"pressure": [[-0.1], [120.0]]}, {}),
    "plan_sweep": (lambda **k: esba.plan_sweep(**k), lambda: {"base": None, "pressure": [0.1], "payload": [1.0]},
                   {"pressure": [[-0.1], [120.0]], "payload": [[-1.0], [2000.0]]}, {}),
    "solve_scenes": (lambda **k: esba.solve_scenes(**k), lambda: {"scenes": [_scene()], "options": None}, {}, {}),
    "BatchOptions": (lambda **k: esba.BatchOptions(**k), lambda: {"chunk": 1000, "retry": True}, {"chunk": [0, -1]}, {}),
    "estimate_load": (lambda **k: esba.estimate_load(**k), lambda: {"poses": _poses(), "free": ["F1"], "base": _scene(), "options": None}, {}, {}),
    "fit": (lambda **k: esba.fit(**k), lambda: {"data": _measurements(), "free": ["E"], "options": None}, {}, {}),
    "DesignProblem": (lambda **k: esba.DesignProblem(**k), lambda: {"objective": "stiffness", "segments": 3, "payload_n": 2.0},
                      {"segments": [0, -1], "payload_n": [-1.0, 1e300]}, {"payload_n": ["payload"]}),
    "Measured": (lambda **k: esba.Measured(**k), lambda: {"kind": "total_angle", "values": (40.0,), "sd": 0.5},
                 {"sd": [-1.0, 0.0, 1e5], "values": [(1e6,)]}, {"values": ["total_angle"], "sd": ["standard deviation"]}),
    "Pose": (lambda **k: esba.Pose(**k), lambda: {"pressure": 0.1, "measured": (esba.Measured("total_angle", (40.0,), 0.5),)},
             {"pressure": [-0.1, 120.0]}, {}),
    "parse_sigma": (lambda **k: esba.parse_sigma(**k), lambda: {"text": "E=5%"}, {"text": ["E=-1", "E=0", "E"]}, {"text": ["--sigma"]}),
    "optimise": (lambda **k: esba.optimise(**k), lambda: {"problem": esba.DesignProblem(), "method": "ipopt", "options": None}, {}, {}),
}

#: Values of the wrong type, or not finite: refused for every argument.
GENERIC = [math.nan, math.inf, -math.inf, "x", b"1", object(), {"a": 1}, [math.nan], 1j]
#: Arguments that may be None (their default).
OPTIONAL_NONE = {"options", "base", "effects", "problem", "parameters", "angle_deg", "pressure", "target_angle_deg"}
#: Cases whose valid call names a file that is missing on purpose: only refusals are checked.
NO_VALID_CALL = {"load_scene", "load_measurements"}

PAIRS = sorted((name, arg) for name, (_, valid, _, _) in CASES.items() for arg in valid())


@st.composite
def bad_call(draw):
    name, arg = draw(st.sampled_from(PAIRS))
    _, _, ranges, _ = CASES[name]
    value = draw(st.sampled_from(GENERIC + list(ranges.get(arg, []))))
    return name, arg, value


def _refused(name: str, arg: str, value) -> None:
    call, valid, _, words = CASES[name]
    kwargs = valid()
    kwargs[arg] = value
    with pytest.raises(EsbaError) as info:
        call(**kwargs)
    message = str(info.value)
    names = [arg, *words.get(arg, [])]
    assert any(n in message for n in names), f"{name}({arg}={value!r}): {message!r} names none of {names}"
    assert "\n" not in message.strip()


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(bad_call())
def test_every_facade_argument_that_is_bad_is_refused_by_name(case):
    name, arg, value = case
    if value is None and arg in OPTIONAL_NONE:
        return
    _refused(name, arg, value)


@pytest.mark.parametrize("name,arg,value", [(n, a, v) for n, (_, _, ranges, _) in CASES.items() for a, vs in ranges.items() for v in vs])
def test_every_out_of_range_value_is_refused(name, arg, value):
    """Every out-of-range value of the table at least once (hypothesis samples the rest)."""
    _refused(name, arg, value)


def test_the_facade_cases_cover_every_public_callable():
    covered = {n.split("(")[0] for n in CASES}
    # errors are classes to catch; the rest take objects that only esba builds (a model, a branch,
    # a path problem: PathProblem.from_scene checks its own arguments, tests/paths)
    skipped = {"EsbaError", "InputError", "RunError", "EquilibriumError", "EffectError", "SceneError",
               "Model", "Equilibrium", "Branch", "PathProblem", "PathOptions", "trace", "history",
               # a result type, and a map's plane and map, built from path problems (tests/analysis)
               "Ellipse", "Plane", "stability_map", "ellipse"}
    assert set(esba.__all__) - skipped <= covered, sorted(set(esba.__all__) - skipped - covered)


@pytest.mark.parametrize("name", sorted(set(CASES) - NO_VALID_CALL - {"solve", "equilibria", "secant_stiffness", "sweep", "solve_scenes",
                                                                           "estimate_load", "optimise", "pressure_for_target", "propagate", "sensitivities", "fit"}))
def test_the_valid_calls_are_valid(name):
    """The table's valid calls run (the cheap ones), so that each refusal is of the one bad argument."""
    call, valid, _, _ = CASES[name]
    call(**valid())

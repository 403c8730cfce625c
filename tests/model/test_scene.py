"""Scenes: defaults, validation messages, freezing, the effect set they imply, TOML files."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest

from esba.model.scene import (
    MAIN_JOB,
    Actuator,
    Payload,
    Scene,
    SceneError,
    load_scene,
    scene_from_dict,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_defaults_are_table_1():
    a = Actuator()
    assert (a.L, a.r1, a.r2, a.d, a.rho_deg, a.E, a.M) == (135.0, 8.0, 3.0, 4.0, 10.0, 0.54, 0.035)
    s = Scene()
    assert s.pressure is None and s.target_angle_deg == 90.0
    assert s.payloads == () and not s.gravity and s.fibres and s.segments == 3 and s.variant == "paper"


def test_main_job_is_table_2_case():
    assert MAIN_JOB.payloads == (Payload(2.0, 90.0, 1.0),)
    assert MAIN_JOB.target_angle_deg == 90.0 and MAIN_JOB.segments == 3


@pytest.mark.parametrize(
    "obj",
    [Actuator(), Payload(1.0), Scene()],
    ids=["actuator", "payload", "scene"],
)
def test_frozen(obj):
    name = dataclasses.fields(obj)[0].name
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(obj, name, 1.0)


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: Actuator(L=0), "actuator.L=0: expected a number > 0"),
        (lambda: Actuator(r1=-8), "actuator.r1=-8: expected a number > 0"),
        (lambda: Actuator(L=float("nan")), "actuator.L=nan: expected a finite number"),
        (lambda: Actuator(E=float("inf")), "actuator.E=inf: expected a finite number"),
        (lambda: Actuator(L="135"), "actuator.L='135': expected a finite number"),
        (lambda: Actuator(L=True), "actuator.L=True: expected a finite number"),
        (lambda: Actuator(d=-1), "actuator.d=-1: expected a number >= 0"),
        (lambda: Actuator(M=-0.1), "actuator.M=-0.1: expected a number >= 0"),
        (lambda: Actuator(r2=4), "actuator.r2=4 with d=4, r1=8: the chamber must lie inside the actuator, r2 + d < r1"),
        (lambda: Actuator(rho_deg=90), "actuator.rho_deg=90: expected 0 <= rho_deg < 90"),
        (lambda: Actuator(rho_deg=-5), "actuator.rho_deg=-5: expected 0 <= rho_deg < 90"),
        (lambda: Payload(-1.0), "payload.force=-1: expected a magnitude >= 0 N"),
        (lambda: Payload(1.0, at=0.0), "payload.at=0: expected a fraction of the length with 0 < at <= 1"),
        (lambda: Payload(1.0, at=1.01), "payload.at=1.01: expected a fraction"),
        (lambda: Payload(1.0, angle_deg=float("inf")), "payload.angle_deg=inf: expected a finite number"),
        (lambda: Scene(segments=0), "segments=0: expected a whole number from 1 to 256"),
        (lambda: Scene(segments=2.5), "segments=2.5: expected a whole number from 1 to 256"),
        (lambda: Scene(segments="3"), "segments='3': expected a whole number from 1 to 256"),
        (lambda: Scene(variant="exact"), "variant='exact': allowed are paper, printed"),
        (lambda: Scene(pressure=-0.1), "pressure=-0.1: expected a pressure >= 0 MPa"),
        (lambda: Scene(pressure=0.1, target_angle_deg=90.0), "give one of the two, not both"),
        (lambda: Scene(target_angle_deg=0.0), "target_angle_deg=0: expected an angle > 0 degrees"),
        (lambda: Scene(target_angle_deg=1e6), "target_angle_deg=1e+06: expected an angle <= 3600 degrees"),
        (lambda: Scene(gravity="yes"), "gravity='yes': expected true or false"),
        (lambda: Scene(fibres=1), "fibres=1: expected true or false"),
        (lambda: Scene(g=0.0), "g=0: expected a number > 0"),
        (lambda: Scene(payloads=(1.0,)), "payloads=(1.0,): expected a list of Payload"),
        (lambda: Scene(payloads=tuple(Payload(1.0) for _ in range(17))), "payloads: 17 given; payloads=17: expected an integer from 0 to 16"),
        (lambda: Scene(actuator={"L": 1}), "actuator={'L': 1}: expected an Actuator"),
        (lambda: MAIN_JOB.replace(Length=3), "unknown scene field(s) Length: allowed are"),
    ],
)
def test_validation_messages(make, message):
    with pytest.raises(SceneError) as info:
        make()
    assert message in str(info.value)
    assert "\n" not in str(info.value)


def test_whole_float_segments_accepted():
    assert Scene(segments=4.0).segments == 4


@pytest.mark.parametrize(
    "payloads, gravity, fibres, spec",
    [
        ((), False, True, "air,axial,radial,fibres"),
        ((Payload(0.0),), False, True, "air,axial,radial,fibres,payload"),
        ((Payload(1.0), Payload(2.0, 0.0, 0.5)), False, True, "air,axial,radial,fibres,payload:2"),
        ((), True, True, "air,axial,radial,fibres,gravity"),
        ((Payload(1.0),), True, False, "air,axial,radial,payload,gravity"),
    ],
)
def test_scene_decides_effects(payloads, gravity, fibres, spec):
    s = Scene(payloads=payloads, gravity=gravity, fibres=fibres)
    assert s.effects.spec() == spec
    assert s.model().effects == s.effects


def test_parameters_in_radians_and_scaled():
    s = Scene(payloads=(Payload(2.0, 90.0, 0.5),), g=9.81)
    v = s.parameters(0.12, load_factor=0.25)
    assert v["P"] == 0.12 and v["rho"] == pytest.approx(math.radians(10.0))
    assert v["F1"] == pytest.approx(0.5) and v["Omega1"] == pytest.approx(math.pi / 2) and v["s1"] == 0.5
    assert v["g"] == pytest.approx(9.81 * 0.25)
    m = s.model()
    assert len(m.param_vector(v)) == len(m.parameters)


def test_replace_switches_pressure_setting():
    s = MAIN_JOB.replace(pressure=0.1)
    assert s.pressure == 0.1 and s.target_angle_deg is None
    s2 = s.replace(target_angle_deg=45.0)
    assert s2.pressure is None and s2.target_angle_deg == 45.0
    assert MAIN_JOB.replace(r2=2.0).actuator.r2 == 2.0
    assert MAIN_JOB.unloaded().payloads == () and MAIN_JOB.unloaded().target_angle_deg == 90.0


def test_describe_mentions_everything():
    text = MAIN_JOB.replace(gravity=True, fibres=False).describe()
    for piece in ("L=135", "unloaded angle 90 deg", "2 N at 90 deg", "n=3", "gravity", "no fibres"):
        assert piece in text


# ---------------------------------------------------------------------------------------------
# TOML


def test_example_table2_is_main_job():
    assert load_scene(EXAMPLES / "table2.toml") == MAIN_JOB


@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.toml")), ids=lambda p: p.name)
def test_examples_load(path):
    assert isinstance(load_scene(path), Scene)


def test_toml_fields(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text(
        'segments = 2\nvariant = "printed"\ngravity = true\nfibres = false\n'
        "[actuator]\nL = 100\nrho_deg = 15\n[loads]\npressure = 0.1\ng = 9.8\n"
        "[[payloads]]\nforce = 1\nangle_deg = 0\nat = 0.5\n[[payloads]]\nforce = 0.5\n"
    )
    s = load_scene(f)
    assert s.segments == 2 and s.variant == "printed" and s.gravity and not s.fibres
    assert s.actuator.L == 100.0 and s.actuator.rho_deg == 15.0 and s.actuator.r1 == 8.0
    assert s.pressure == 0.1 and s.target_angle_deg is None and s.g == 9.8
    assert s.payloads == (Payload(1.0, 0.0, 0.5), Payload(0.5, 90.0, 1.0))


@pytest.mark.parametrize(
    "text, message",
    [
        ("segments = 3\n[actuator\nL = 1\n", "is not valid TOML: Expected ']' at the end of a table declaration (at line 2"),
        ("segments = \n", "is not valid TOML"),
        ("segmnts = 3\n", "scene: unknown key(s) segmnts; allowed are actuator, fibres, gravity, loads, moments, obstacles, payloads, segments, uncertainty, variant"),
        ("[actuator]\nR1 = 8\n", "[actuator]: unknown key(s) R1; allowed are E, L, M, d, r1, r2, rho_deg"),
        ("[loads]\npresure = 0.1\n", "[loads]: unknown key(s) presure; allowed are g, gravity_direction, pressure, target_angle_deg"),
        ("gravity = true\n[loads]\ngravity_direction = [0, 0]\n", "[loads] gravity_direction=[0, 0]: expected three finite numbers [x, y, z]"),
        ("gravity = true\n[loads]\ngravity_direction = [0, nan, 1]\n", "[loads] gravity_direction=[0, nan, 1]: expected three finite numbers [x, y, z]"),
        ("gravity = true\n[loads]\ngravity_direction = [0, 0, 0]\n", "[loads] gravity_direction=[0, 0, 0]: a zero vector has no direction"),
        ("gravity = true\n[loads]\ngravity_direction = 'down'\n", "[loads] gravity_direction='down': expected three finite numbers [x, y, z]"),
        ("[loads]\ngravity_direction = [0, 0, 1]\n", "[loads] gravity_direction=[0, 0, 1]: turns the weight, and the scene has none: add gravity = true"),
        ("[[payloads]]\nangle_deg = 0\n", "[[payloads]] #1: missing key force (N)"),
        ("[[moments]]\nat = 0.5\n", "[[moments]] #1: missing key moment ([mx, my, mz], N mm)"),
        ("[[moments]]\nmoment = [1, 2]\n", "[[moments]] #1: moment.moment=[1, 2]: expected three numbers [x, y, z]"),
        ("[[moments]]\nmoment = [1, 0, nan]\n", "[[moments]] #1: moment.moment"),
        ("[[moments]]\nmoment = [0, 0, 5]\nat = 0\n", "[[moments]] #1: moment.at=0: expected a fraction of the length with 0 < at <= 1 (1 = tip)"),
        ("[[moments]]\nmoment = [0, 0, 5]\narm = [0, 0, 0]\n", "[[moments]] #1: moment.arm=[0, 0, 0]: a zero vector has no direction"),
        ("[[moments]]\nmoment = [0, 0, 5]\narm = [0, 1, 1]\n", "[[moments]] #1: moment.arm=[0, 1, 1]: expected a direction perpendicular to moment=[0, 0, 5]"),
        ("[[moments]]\nmoment = [0, 0, 5]\nkind = 'couple'\n", "[[moments]] #1: unknown key(s) kind; allowed are arm, at, moment"),
        ("[[moments]]\nmoment = [0, 0, 1e9]\n", "[[moments]] #1: moment.moment=[0, 0, 1e+09]: its size 1e+09 N mm is more than 100000 N mm"),
        ("[[payloads]]\nforce = 1\nwhere = 1\n", "[[payloads]] #1: unknown key(s) where"),
        ("payloads = 3\n", "payloads=3: expected an array of tables [[payloads]]"),
        ("actuator = 3\n", "[actuator]: expected a table, got 3"),
        ("[actuator]\nr2 = 6\n", "actuator.r2=6 with d=4, r1=8: the chamber must lie inside the actuator"),
        ("[[payloads]]\nforce = 'x'\n", "payload.force='x': expected a finite number"),
        ("segments = 0\n", "segments=0: expected a whole number from 1 to 256"),
        ("[loads]\npressure = 0.1\ntarget_angle_deg = 90\n", "give one of the two, not both"),
    ],
)
def test_toml_errors(tmp_path, text, message):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(SceneError) as info:
        load_scene(f)
    assert str(f) in str(info.value)
    assert message in str(info.value)


def test_missing_file(tmp_path):
    with pytest.raises(SceneError, match="does not exist"):
        load_scene(tmp_path / "nope.toml")


def test_not_utf8(tmp_path):
    f = tmp_path / "bin.toml"
    f.write_bytes(b"\xff\xfe\x00")
    with pytest.raises(SceneError, match="cannot be read"):
        load_scene(f)


def test_scene_from_dict_defaults():
    assert scene_from_dict({}) == Scene()


def test_gravity_direction_in_a_scene_file_is_a_unit_vector_and_any_but_down_needs_the_3d_model(tmp_path):
    f = tmp_path / "sideways.toml"
    f.write_text("gravity = true\n[loads]\ngravity_direction = [0, 0, 2]\n")
    scene = load_scene(f)
    assert scene.gravity_direction == (0.0, 0.0, 1.0) and scene.needs_3d and scene.down() == (0.0, 0.0, 1.0)
    assert scene.down((0, 1, 0)) == (0.0, 1.0, 0.0)  # a flag or an API keyword overrides the file
    assert "gravity along [0, 0, 1]" in scene.describe()
    with pytest.raises(SceneError, match=r"gravity_direction=\[0, 0, 1\]: the planar model's weight acts along \+x"):
        scene.model()
    in_plane = scene.replace(gravity_direction=(0.0, 1.0, 0.0))  # in the bending plane, still not the planar model's +x
    assert in_plane.needs_3d
    down = scene.replace(gravity_direction=(3.0, 0.0, 0.0))
    assert down.gravity_direction == (1.0, 0.0, 0.0) and not down.needs_3d and ", gravity;" not in down.describe()
    assert not scene.replace(gravity=False).needs_3d  # without gravity the direction is unused
    f.write_text("gravity = true\n[loads]\ngravity_direction = [1, 0, 0]\n")
    assert load_scene(f) == Scene(gravity=True)

"""The section (esba.model.section): closed forms, the finite elements against a series solution,
their convergence, the shear centre against the flexural centre, the composite and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from esba.model import section as sec
from esba.model.section.fe import annulus_mesh
from esba.model.section import SectionError, exact_properties, finite_elements, section_properties, section_stiffness, series_torsion
from tests.tolerances import KERNEL_RTOL

#: Table 1's section, mm
R1, R2, D = 8.0, 3.0, 4.0
#: two exact evaluations of a closed form (round-off only)
EXACT_RTOL = KERNEL_RTOL
#: the isoparametric P2 mesh at level 2 against a closed form: geometry and quadrature errors
#: of O(h^4), about 1e-7 here
FE_RTOL = 1e-6


def flexural_centre(r1: float, r2: float, d: float, level: int) -> float:
    """y of the flexural centre for nu = 0 (where Trefftz's centre and Timoshenko's agree), by finite
    elements independent of the warping function: a shear force V_z = 1 gives shear stresses
    tau = ∇psi, ∇²psi = -z/I_yy, d psi/dn = 0; their moment about the centroid is y_s - y_c."""
    from scipy.sparse.linalg import spsolve
    from skfem import Basis, BilinearForm, ElementTriP2, LinearForm
    from skfem.helpers import dot, grad

    mesh, _, _ = annulus_mesh(r1, r2, d, level)
    basis = Basis(mesh, ElementTriP2(), intorder=4)
    ex = exact_properties(r1, r2, d)
    K = BilinearForm(lambda u, v, w: dot(grad(u), grad(v))).assemble(basis).tocsr()
    b = LinearForm(lambda v, w: w.x[1] / ex["I_yy"] * v).assemble(basis)
    keep = np.arange(1, K.shape[0])
    psi = np.zeros(K.shape[0])
    psi[keep] = spsolve(K[keep][:, keep].tocsc(), b[keep])
    moment = LinearForm(lambda v, w: (w.x[0] - ex["y_c"]) * v.grad[1] - w.x[1] * v.grad[0]).assemble(basis) @ psi
    return ex["y_c"] + float(moment)


# --- closed forms -------------------------------------------------------------------------------


def test_concentric_closed_forms():
    p = exact_properties(R1, R2, 0.0)
    ring = math.pi * (R1**4 - R2**4) / 4
    assert p["area"] == pytest.approx(math.pi * (R1**2 - R2**2), rel=EXACT_RTOL)
    assert p["y_c"] == pytest.approx(-R1, rel=EXACT_RTOL) and p["z_c"] == 0.0
    assert p["I_yy"] == pytest.approx(ring, rel=EXACT_RTOL) and p["I_zz"] == pytest.approx(ring, rel=EXACT_RTOL)


@pytest.mark.parametrize("d", [0.0, 1.0, 2.0, 4.0, 4.9])
def test_finite_element_area_and_second_moments_match_the_closed_forms(d):
    ex, fe = exact_properties(R1, R2, d), finite_elements(R1, R2, d)
    assert fe.area == pytest.approx(ex["area"], rel=FE_RTOL)
    assert fe.centroid[0] == pytest.approx(ex["y_c"], rel=FE_RTOL) and abs(fe.centroid[1]) < 1e-12 * R1
    assert fe.I_yy == pytest.approx(ex["I_yy"], rel=FE_RTOL)
    assert fe.I_zz == pytest.approx(ex["I_zz"], rel=FE_RTOL)
    assert abs(fe.I_yz) < 1e-12 * ex["I_yy"]


def test_the_section_scales_with_r1():
    small, large = finite_elements(1.0, R2 / R1, D / R1), finite_elements(R1, R2, D)
    assert large.J_lower == pytest.approx(small.J_lower * R1**4, rel=EXACT_RTOL)
    assert large.shear_centre[0] == pytest.approx(small.shear_centre[0] * R1, rel=EXACT_RTOL)
    huge = finite_elements(1e6, 3.75e5, 5e5)
    assert huge.J_upper == pytest.approx(large.J_upper * (1e6 / R1) ** 4, rel=EXACT_RTOL)


def test_the_api_uses_the_closed_forms():
    p, ex = section_properties(R1, R2, D), exact_properties(R1, R2, D)
    assert (p.area, p.centroid, p.I_yy, p.I_zz, p.I_yz) == (ex["area"], (ex["y_c"], 0.0), ex["I_yy"], ex["I_zz"], 0.0)
    # the centroid moves away from the chamber: d r2²/(r1² - r2²) above the disc's centre
    assert p.centroid[0] == pytest.approx(-R1 + D * R2**2 / (R1**2 - R2**2), rel=EXACT_RTOL)


# --- torsion ------------------------------------------------------------------------------------


def test_concentric_torsion_constant_is_the_polar_moment():
    polar = math.pi * (R1**4 - R2**4) / 2
    fe = finite_elements(R1, R2, 0.0, mesh=3)
    assert fe.J_lower == pytest.approx(polar, rel=1e-7)
    assert fe.J_upper == pytest.approx(polar, rel=1e-7)
    # the chamber's constant: phi = (r1² - r²)/2 there
    assert fe.hole_constant == pytest.approx((R1**2 - R2**2) / 2, rel=1e-7)


def test_series_reproduces_the_concentric_annulus_and_converges():
    with pytest.raises(sec.SeriesError, match="did not fit"):  # too few terms for the 0.5 mm wall: said, not returned
        series_torsion(R1, 1.0, 6.5, terms=20)
    J0, C0 = series_torsion(R1, R2, 0.0, terms=4)
    assert J0 == pytest.approx(math.pi * (R1**4 - R2**4) / 2, rel=EXACT_RTOL)
    assert C0 == pytest.approx((R1**2 - R2**2) / 2, rel=EXACT_RTOL)
    assert series_torsion(R1, R2, D, terms=60)[0] == pytest.approx(series_torsion(R1, R2, D)[0], rel=1e-13)
    assert series_torsion(R1, 1.0, 6.5, terms=120)[0] == pytest.approx(series_torsion(R1, 1.0, 6.5)[0], rel=1e-13)


@pytest.mark.parametrize("r2, d", [(3.0, 4.0), (2.0, 5.0), (5.0, 2.5), (1.0, 6.5)])
def test_the_two_energies_bracket_the_series_solution(r2, d):
    """The complementary energy bounds J from below, the potential energy from above; on these
    eccentric sections the discretisation error is far above the curved boundary's O(h^4)
    geometric error, so the bracket holds and its width bounds the error."""
    J_ref, C_ref = series_torsion(R1, r2, d)
    fe = finite_elements(R1, r2, d)
    assert fe.J_lower < J_ref < fe.J_upper
    assert fe.J_upper - fe.J_lower < 3e-4 * J_ref  # the thinnest wall, 0.5 mm, is the worst
    assert fe.hole_constant == pytest.approx(C_ref, rel=1e-4)


def test_torsion_constant_converges_at_the_order_of_p2():
    J_ref, _ = series_torsion(R1, R2, D)
    errors = [J_ref - finite_elements(R1, R2, D, mesh=k).J_lower for k in range(4)]
    assert all(e > 0 for e in errors)  # a lower bound on every mesh
    orders = [math.log2(a / b) for a, b in zip(errors, errors[1:])]
    # the energy error of P2 is O(h^4); the first mesh is coarse for the 1 mm wall
    assert min(orders[1:]) > 3.5, orders
    assert errors[-1] / J_ref < 1e-6


def test_default_mesh_is_within_its_stated_accuracy():
    J_ref, _ = series_torsion(R1, R2, D)
    p = section_properties(R1, R2, D)
    assert p.mesh == sec.DEFAULT_MESH
    assert abs(p.torsion_constant - J_ref) <= p.torsion_upper - p.torsion_constant < 1e-5 * J_ref


# --- shear centre -------------------------------------------------------------------------------


def test_shear_centre_of_the_concentric_annulus_is_its_centre():
    ys, zs = section_properties(R1, R2, 0.0).shear_centre
    assert ys == pytest.approx(-R1, rel=1e-12) and zs == 0.0


@pytest.mark.parametrize("d", [2.0, 4.0])
def test_shear_centre_is_on_the_axis_and_at_the_flexural_centre(d):
    fe = finite_elements(R1, R2, d)
    assert abs(fe.shear_centre[1]) < 1e-12 * R1
    assert section_properties(R1, R2, d).shear_centre[1] == 0.0
    assert fe.shear_centre[0] == pytest.approx(flexural_centre(R1, R2, d, fe.mesh), abs=1e-6)
    # the thick wall is on the layer's side: the centre of twist lies between the centroid and the layer
    assert exact_properties(R1, R2, d)["y_c"] < fe.shear_centre[0] < 0.0


# --- the composite ------------------------------------------------------------------------------


def test_a_layer_of_silicone_leaves_the_silicone_section():
    E = 0.54
    p, k = section_properties(R1, R2, D), section_stiffness(R1, R2, D, E, E_layer=E, rho_deg=0.0)
    assert k.EI_bend == pytest.approx(E * p.I_zz, rel=EXACT_RTOL)
    assert k.EI_side == pytest.approx(E * p.I_yy, rel=EXACT_RTOL)
    assert k.neutral_axis[0] == pytest.approx(p.centroid[0], rel=EXACT_RTOL)
    assert k.GJ_silicone == pytest.approx(E / 3 * p.torsion_constant, rel=EXACT_RTOL)
    assert k.GJ_fibres == 0.0 and k.GJ == pytest.approx(k.GJ_silicone + k.GJ_layer, rel=EXACT_RTOL)


def test_a_stiff_thin_layer_bends_the_silicone_about_the_paper_line():
    """Eq. 8: the silicone bent about y = 0 has E pi (5 r1⁴ - 4 r2² (r1 + d)² - r2⁴)/4."""
    E = 0.54
    eq8 = E * math.pi * (5 * R1**4 - 4 * R2**2 * (R1 + D) ** 2 - R2**4) / 4
    k = section_stiffness(R1, R2, D, E, E_layer=1e9, layer_thickness=1e-2)  # E_layer A_layer = 8e7 N: inextensible
    own = (1e9 - E) * R1 * 1e-2**3 / 12
    assert abs(k.neutral_axis[0]) < 1e-5  # E A y_c / (E_layer A_layer)
    assert k.EI_bend - own == pytest.approx(eq8, rel=1e-5)


def test_the_torsion_parts():
    E = 0.54
    k = section_stiffness(R1, R2, D, E)
    assert k.GJ == pytest.approx(k.GJ_silicone + k.GJ_layer + k.GJ_fibres, rel=EXACT_RTOL)
    w, t = R1, sec.LAYER_THICKNESS
    G_layer = sec.LAYER_E / (2 * (1 + sec.LAYER_NU))
    assert k.GJ_layer == pytest.approx((G_layer - E / 3) * sec.rectangle_torsion_factor(w / t) * w * t**3, rel=EXACT_RTOL)
    # the fibres: zero for hoop windings, linear in the efficiency, growing toward the locking angle
    assert section_stiffness(R1, R2, D, E, rho_deg=0.0).GJ_fibres == 0.0
    assert section_stiffness(R1, R2, D, E, fibre_efficiency=0.5).GJ_fibres == pytest.approx(k.GJ_fibres / 2, rel=EXACT_RTOL)
    f = [section_stiffness(R1, R2, D, E, rho_deg=r).GJ_fibres for r in (5, 10, 15, 20, 25, 30, 34)]
    assert all(a < b for a, b in zip(f, f[1:]))
    # the locking angle: refused with slack fibres, taken without them or with taut ones
    assert section_stiffness(R1, R2, D, E, rho_deg=sec.MAGIC_ANGLE_DEG, fibre_efficiency=0.0).GJ_fibres == 0.0
    assert section_stiffness(R1, R2, D, E, rho_deg=sec.MAGIC_ANGLE_DEG, fibres="none").GJ_fibres == 0.0
    assert section_stiffness(R1, R2, D, E, rho_deg=sec.MAGIC_ANGLE_DEG, fibres="taut").GJ_fibres > 0
    assert math.tan(math.radians(sec.MAGIC_ANGLE_DEG)) ** 2 == pytest.approx(0.5, rel=EXACT_RTOL)


def test_taut_fibres_resist_by_their_stretch():
    """Both helices taut: a twist gamma = r1 kappa stretches one and shortens the other by
    gamma sin rho cos rho; per length each fibre holds 1/sin rho of fibre."""
    rho, df, n = 10.0, 0.2, 2
    k = section_stiffness(R1, R2, D, 0.54, fibres="taut", rho_deg=rho, fibre_diameter=df, fibres_per_helix=n)
    s, c = math.sin(math.radians(rho)), math.cos(math.radians(rho))
    energy = 2 * n * 0.5 * sec.FIBRE_E * math.pi * df**2 / 4 * (R1 * s * c) ** 2 / s  # per unit length and unit kappa²
    assert k.GJ_fibres == pytest.approx(2 * energy, rel=EXACT_RTOL)
    assert k.GJ_fibres > 10 * k.GJ_silicone  # pressurised, the Kevlar dominates the twist
    # independent of the silicone: the same for another E
    assert section_stiffness(R1, R2, D, 5.0, fibres="taut", rho_deg=rho, fibre_diameter=df, fibres_per_helix=n).GJ_fibres == k.GJ_fibres


def test_the_parameter_table_is_the_signature():
    import inspect

    keyword = {n: q.default for n, q in inspect.signature(section_stiffness).parameters.items() if q.kind is q.KEYWORD_ONLY}
    assert set(keyword) - {"rho_deg", "mesh"} == set(sec.SECTION_PARAMETERS)
    assert all(keyword[n] == default for n, (default, _, _) in sec.SECTION_PARAMETERS.items())
    k = section_stiffness(R1, R2, D, 0.54)
    assert {n for n, _ in k.parameters} == set(keyword) and k.parameter("layer_width") == R1


def test_rectangle_torsion_factor():
    assert sec.rectangle_torsion_factor(1.0) == pytest.approx(0.140577, abs=1e-6)  # the square, 0.1406 a⁴
    assert sec.rectangle_torsion_factor(2.0) == pytest.approx(0.228682, abs=1e-6)
    assert sec.rectangle_torsion_factor(1e4) == pytest.approx(1 / 3, rel=1e-4)


# --- bad input ----------------------------------------------------------------------------------

nan, inf = float("nan"), float("inf")
BAD = [
    ((8.0, 8.0, 0.0), {}, "r2=8 with d=0, r1=8: the chamber must lie inside the actuator, r2 + d < r1"),
    ((8.0, 9.0, 0.0), {}, "r2=9 with d=0, r1=8"),
    ((8.0, 3.0, 5.0), {}, "r2=3 with d=5, r1=8: the chamber must lie inside the actuator"),
    ((8.0, 3.0, nan), {}, "d=nan: expected a finite number"),
    ((nan, 3.0, 1.0), {}, "r1=nan: expected a finite number"),
    ((8.0, -3.0, 1.0), {}, "r2=-3: expected a number > 0"),
    ((8.0, 3.0, -1.0), {}, "d=-1: expected a number >= 0"),
    ((8.0, 0.0, 1.0), {}, "r2=0: expected a number > 0"),
    ((inf, 3.0, 1.0), {}, "r1=inf: expected a finite number"),
    (("8", 3.0, 1.0), {}, "r1='8': expected a finite number"),
    ((8.0, 3.0, 1.0), {"mesh": 9}, "mesh=9: expected a whole number from 0 to 5"),
    ((8.0, 3.0, 1.0), {"mesh": 1.5}, "mesh=1.5: expected a whole number"),
    ((8.0, 3.0, 4.99999999999), {}, "the wall r1 - r2 - d is thinner than 1e-6 r1"),
    ((8.0, 1e-300, 1.0), {}, "r2=1e-300 with r1=8: a chamber smaller than 1e-6 r1"),
    ((1e80, 3e79, 4e79), {}, "r1=1e+80: expected a radius from 1e-06 to 1e+06 mm"),
    ((1e-9, 3e-10, 4e-10), {}, "r1=1e-09: expected a radius from 1e-06 to 1e+06 mm"),
]


@pytest.mark.parametrize("args, kw, needle", BAD, ids=[str(a) + str(k) for a, k, _ in BAD])
def test_bad_sections_are_refused_in_one_line(args, kw, needle):
    with pytest.raises(SectionError) as info:
        section_properties(*args, **kw)
    assert needle in str(info.value) and "\n" not in str(info.value)
    assert isinstance(info.value, ValueError)


BAD_STIFFNESS = [
    ({"E": nan}, "E=nan: expected a finite number"),
    ({"E": -1.0}, "E=-1: expected a number > 0"),
    ({"E_layer": 0.1}, "E_layer=0.1 below E=0.54"),
    ({"E_layer": 1e308}, "E_layer=1e+308: expected a modulus up to 1e+09 MPa"),
    ({"layer_width": 0.0}, "layer_width=0: expected a number > 0"),
    ({"layer_width": 16.0}, "layer_width=16: expected a layer narrower than the actuator's diameter"),
    ({"layer_thickness": nan}, "layer_thickness=nan"),
    ({"layer_depth": -0.1}, "layer_depth=-0.1: expected a depth >= 0"),
    ({"layer_depth": 8.9}, "the layer reaches the chamber"),
    ({"nu": 0.6}, "nu=0.6: expected a Poisson's ratio from 0 to 0.5"),
    ({"nu_layer": -1.0}, "nu_layer=-1"),
    ({"rho_deg": 35.26}, "rho_deg=35.26: within 1 deg of 35.26, where the slack fibres lock the twist"),
    ({"fibres": "tight"}, "fibres='tight': allowed are slack, taut, none"),
    ({"fibres": "taut", "fibre_diameter": 0.0}, "fibre_diameter=0: expected a number > 0"),
    ({"fibres": "taut", "fibres_per_helix": 0}, "fibres_per_helix=0: expected a whole number from 1 to 1000"),
    ({"fibres": "taut", "E_fibre": nan}, "E_fibre=nan: expected a finite number"),
    ({"rho_deg": 90.0}, "rho_deg=90: expected a fibre angle from the hoop direction, 0 <= rho_deg < 90 degrees"),
    ({"rho_deg": -1.0}, "rho_deg=-1"),
    ({"fibre_efficiency": -0.5}, "fibre_efficiency=-0.5: expected a number >= 0"),
    ({"fibre_efficiency": inf}, "fibre_efficiency=inf: expected a finite number"),
]


@pytest.mark.parametrize("kw, needle", BAD_STIFFNESS, ids=[str(k) for k, _ in BAD_STIFFNESS])
def test_bad_stiffness_parameters_are_refused_in_one_line(kw, needle):
    args = {"r1": R1, "r2": R2, "d": D, "E": 0.54, **kw}
    with pytest.raises(SectionError) as info:
        section_stiffness(**args)
    assert needle in str(info.value) and "\n" not in str(info.value)

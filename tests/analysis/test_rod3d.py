"""The rod benchmarks of issue 26 on esba's spatial machinery (the ``rod`` variant): B1, B2, B5."""

from __future__ import annotations

import numpy as np
import pytest

from esba.analysis.rod3d import PRANDTL, elastica, elastica_reference, lateral_torsional_load, richardson
from esba.model.spatial import load_model3d
from esba.statics.spatial import newton3d

#: Mattiasson (1981), Int. J. Numer. Meth. Eng. 17, Table 1: v/L, u/L and the tip angle (rad) of
#: the elastica under a perpendicular tip dead load, at alpha = P L^2 / EI.
MATTIASSON = {
    1.0: (0.30172, 0.05643, 0.46135),
    2.0: (0.49346, 0.16064, 0.78175),
    5.0: (0.71379, 0.38763, 1.21537),
    10.0: (0.81061, 0.55500, 1.43029),
}


@pytest.mark.parametrize("alpha", sorted(MATTIASSON))
def test_b1_reference_quadrature_is_mattiassons_table(alpha):
    ref = elastica_reference(alpha)
    assert (ref["v"], ref["u"], ref["phi0"]) == pytest.approx(MATTIASSON[alpha], abs=6e-6)


@pytest.mark.slow
@pytest.mark.ci
@pytest.mark.parametrize("alpha", [1.0, 10.0])
def test_b1_elastica_extrapolated_in_n_is_within_1e_4_of_the_table(alpha):
    """n = 8 and 16, Richardson (4 f(16) - f(8)) / 3: every quantity within 1e-4 of Mattiasson's."""
    f8, f16 = elastica(8, alpha), elastica(16, alpha)
    for k, want in zip(("v", "u", "phi0"), MATTIASSON[alpha]):
        assert abs(richardson(f8[k], f16[k]) - want) < 1e-4, k
        assert abs(f16[k] - want) > abs(richardson(f8[k], f16[k]) - want)  # the extrapolation helps


def test_b2_an_end_moment_of_2_pi_EI_over_L_rolls_the_rod_into_a_full_circle():
    """Continuation in the moment from 0 to 2 pi EI / L: the tip returns to the base, turned 360 deg."""
    model = load_model3d(4, "rod,moment")
    vals = dict(L=1.0, EI=1.0, EI_side=1.0, GJ=1.0, kappa0=0.0, mx1=0.0, my1=0.0, mz1=0.0, sm1=1.0)
    q = np.zeros(model.size)
    for lam in np.linspace(0.0, 1.0, 21)[1:]:
        vals["mz1"] = lam * 2 * np.pi
        q, ok, _ = newton3d(model, vals, q)
        assert ok, lam
    tip, rot, _ = model.pose(q, 1.0)
    assert np.abs(tip).max() < 1e-12 and np.abs(rot - np.eye(3)).max() < 1e-12
    assert np.sum(q[:4]) == pytest.approx(2 * np.pi, abs=1e-12) and np.abs(q[4:]).max() < 1e-14


@pytest.mark.slow
@pytest.mark.ci
def test_b5_prandtl_lateral_torsional_buckling_is_a_branch_point_within_half_a_percent():
    b8, b16 = lateral_torsional_load(8), lateral_torsional_load(16)
    assert abs(b16.load / PRANDTL - 1) < 5e-3
    assert abs(richardson(b8.load, b16.load) / PRANDTL - 1) < 5e-4
    n = 16
    assert np.abs(b16.mode[:n]).max() < 1e-8  # the buckling mode is sideways bend and twist
    assert np.abs(b16.mode[n:2 * n]).max() > 0.05 and np.abs(b16.mode[2 * n:]).max() > 0.05


def test_b5_at_n_3_already_brackets_the_branch_point():
    """A fast check: at n = 3 the Hessian turns singular 8 % above Prandtl's load (the 1/n^2 error)."""
    b = lateral_torsional_load(3)
    assert 1.0 < b.load / PRANDTL < 1.1


@pytest.mark.slow
@pytest.mark.ci
def test_b3_bathe_bolourchi_tip_positions_lie_within_the_references_spread():
    """At P = 300 and 600 the extrapolated tip (n = 8, 16) is nearer to a published tip than the
    published tips are to each other; at 450 (one reference) within 0.25 % of the tip's distance."""
    from esba.analysis.rod3d import BATHE_REFERENCES, bathe_bolourchi

    t8, t16 = bathe_bolourchi(8), bathe_bolourchi(16)
    for P, refs in BATHE_REFERENCES.items():
        tip = richardson(t8[P], t16[P])
        pts = np.array(list(refs.values()))
        nearest = np.linalg.norm(pts - tip, axis=1).min()
        if len(pts) > 1:
            spread = max(np.linalg.norm(a - b) for a in pts for b in pts)
            assert nearest < spread, (P, tip, nearest, spread)
        else:
            assert nearest < 2.5e-3 * np.linalg.norm(pts[0]), (P, tip, nearest)


@pytest.mark.slow
@pytest.mark.ci
@pytest.mark.parametrize("GJ", [3.0, 1000.0])
def test_b6_twist_buckling_under_an_end_couple_matches_the_closed_form(GJ):
    """Greenhill's problem on a cantilever: the couple of dead forces on a tip arm buckles the twisted
    rod at T_cr = (pi / 2L) EI GJ / (GJ - EI) (GJ = 3: a 45 deg pre-twist; GJ = 1000: nearly pi EI / 2L),
    a branch point whose mode bends the rod out of its axis; n = 8, 16 extrapolated to 1e-4."""
    from esba.analysis.rod3d import greenhill_reference, twist_buckling_couple

    T, phi0, M = greenhill_reference(1.0, GJ)
    b8, b16 = twist_buckling_couple(8, GJ=GJ), twist_buckling_couple(16, GJ=GJ)
    assert abs(b16.load / M - 1) < 5e-3
    assert abs(richardson(b8.load, b16.load) / M - 1) < 1e-4
    n = 16
    assert np.sum(b16.q[2 * n:]) == pytest.approx(phi0, rel=5e-3)  # the pre-buckling twist
    assert np.abs(b16.q[:2 * n]).max() < 1e-10  # straight before it buckles
    assert np.abs(b16.mode[:2 * n]).max() > 0.05  # the mode bends


def test_b6_an_end_couple_never_buckles_a_rod_whose_twist_is_softer_than_its_bending():
    """GJ <= EI (rubber's round rod: GJ = 2/3 EI): the twist tends to 90 deg and the state stays stable."""
    from esba.analysis.rod3d import greenhill_reference, twist_buckling_couple

    assert greenhill_reference(1.0, 2.0 / 3.0) is None
    assert twist_buckling_couple(3, GJ=2.0 / 3.0, top=40.0) is None

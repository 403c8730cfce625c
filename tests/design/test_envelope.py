"""Designs that do not snap: the fold constraint of an operating envelope, the map-based optimum, PSO."""

from __future__ import annotations

import math

import numpy as np
import pytest

from esba.analysis.folds import Plane, fold_curves, folds_at
from esba.analysis.maps import stable_states
from esba.design.envelope import Envelope, fold_clearance, optimise_envelope
from esba.design.problem import DesignError, DesignProblem
from esba.model.scene import Actuator, Payload, Scene
from tests.tolerances import ENVELOPE_PSO_MM, ENVELOPE_PSO_REL, LOCATE_RTOL

#: the paper's optimum (Section 5)
PAPER = (1.5305, 0.0)
#: an envelope in which the paper's optimum snaps: its cusp (0.2916 MPa, 2.231 N) lies inside
ENVELOPE = Envelope(0.3, 2.5, margin=0.05)


def test_the_papers_optimum_snaps_inside_the_envelope():
    c = fold_clearance(DesignProblem(), ENVELOPE, *PAPER)
    assert c.inside and not c.clear and c.nearest["kind"] == "cusp"
    P, F = c.nearest["pressure_mpa"], c.nearest["payload_n"]
    assert P <= ENVELOPE.max_pressure and F <= ENVELOPE.max_payload
    # brute force: above the cusp's payload, at its pressure, the design has two stable states; below it one
    plane = Plane.from_scene(Scene(Actuator(r2=PAPER[0], d=PAPER[1]), pressure=0.0, payloads=(Payload(2.0, 90.0),)), "pressure", "payload")
    assert len(stable_states(plane, P, F + 0.05)) == 2
    assert len(stable_states(plane, P, F - 0.05)) == 1


def test_the_fold_constraint_is_the_nearest_fold():
    # a design clear of the envelope: its fold payload is the fold curve's lowest payload at pressures up to the bound
    c = fold_clearance(DesignProblem(), ENVELOPE, 0.8, 0.0)
    assert c.clear and not c.inside
    assert c.value == pytest.approx(c.fold_payload / ENVELOPE.max_payload - 1.05, rel=1e-12)
    plane = Plane.from_scene(Scene(Actuator(r2=0.8, d=0.0), pressure=0.0, payloads=(Payload(2.5, 90.0),)), "pressure", "payload")
    box = ((0.0, ENVELOPE.pressure_bound), (0.0, 2 * ENVELOPE.payload_bound))
    curves = fold_curves(plane, *box)
    lowest = min(float(np.min(cv.ys[cv.stable & (cv.xs <= ENVELOPE.pressure_bound)])) for cv in curves)
    assert c.fold_payload <= lowest + 1e-12
    assert c.nearest["kind"] == "fold of the payload path at the pressure bound"
    assert min(folds_at(plane, curves, box, x=ENVELOPE.pressure_bound)) == pytest.approx(c.fold_payload, rel=LOCATE_RTOL)


@pytest.mark.slow
@pytest.mark.ci  # about 22 s alone: CI checks the envelope optimum against PSO
def test_the_stiffest_design_clear_of_folds_against_pso():
    m, p = optimise_envelope(DesignProblem(), ENVELOPE, method="both")
    # without the constraint IPOPT finds the paper's optimum, which snaps inside
    u = m.unconstrained
    assert u["r2_mm"] == pytest.approx(PAPER[0], abs=1e-3) and u["clearance"]["snaps_inside"]
    assert m.status == "optimal" and m.clearance.clear and "fold clearance" in m.active and "d >= 0" in m.active
    assert m.stiffness_n_per_m < u["stiffness_n_per_m"]
    # PSO on the same constraint lands on the same design, no stiffer (the map's is the constrained optimum)
    assert p.status == "optimal" and p.clearance.clear
    assert abs(p.r2_mm - m.r2_mm) <= ENVELOPE_PSO_MM and abs(p.d_mm - m.d_mm) <= ENVELOPE_PSO_MM
    assert p.stiffness_n_per_m <= m.stiffness_n_per_m * (1 + 1e-9)
    assert p.stiffness_n_per_m == pytest.approx(m.stiffness_n_per_m, rel=ENVELOPE_PSO_REL)


def test_the_map_method_lands_on_the_fold_boundary():
    m = optimise_envelope(DesignProblem(), ENVELOPE, method="map")
    assert m.status == "optimal" and "fold clearance" in m.active
    assert abs(m.clearance.value) < 1e-9
    # a step into larger r2 (stiffer) crosses the constraint: the design is where the fold enters the margin
    beyond = fold_clearance(DesignProblem(), ENVELOPE, m.r2_mm + 0.01, m.d_mm)
    assert not beyond.clear


@pytest.mark.parametrize(
    "kwargs, words",
    [({"max_pressure": 0.0, "max_payload": 1.0}, "max_pressure=0"), ({"max_pressure": 0.3, "max_payload": 1.0, "margin": -0.1}, "margin"),
     ({"max_pressure": 0.3, "max_payload": 1.0, "at": 1.5}, "at=1.5"), ({"max_pressure": 0.3, "max_payload": math.nan}, "max_payload")],
)
def test_bad_envelopes(kwargs, words):
    with pytest.raises(DesignError, match=words):
        Envelope(**kwargs)

"""An independent cross-check of the spatial rod against Exudyn's geometrically exact beam
(``ObjectBeamGeometricallyExact``, 2-node, constant strain per element): the same stiffnesses, a
tip load out of every plane. Exudyn's element and esba's segment are the same discretisation (a
piecewise-constant strain), so at equal n the tips agree to the penalty Exudyn puts on
stretching and shear (1e6 EI/L^2 here: ~1e-6 L). Skipped, with a message, without Exudyn."""

from __future__ import annotations

import numpy as np
import pytest

from esba.model.spatial import load_model3d
from esba.statics.spatial import newton3d

exu = pytest.importorskip("exudyn", reason="Exudyn is not installed (pip install exudyn): the cross-check is skipped")


def _exudyn_tip(nel: int, L: float, EI: float, EI_side: float, GJ: float, force, R: float | None = None, penalty: float = 1e6, steps: int = 60) -> np.ndarray:
    from exudyn.itemInterface import (CoordinateConstraint, Force, MarkerNodeCoordinate, MarkerNodeRigid, NodePointGround,
                                      NodeRigidBodyRotVecLG, ObjectBeamGeometricallyExact)

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    sec = exu.BeamSection()
    penalty = penalty * max(EI, EI_side, GJ) / L**2  # axial and shear stiffness: practically inextensible, unshearable
    # esba's z bend (theta) is Exudyn's EI_z, its y bend (psi) EI_y
    sec.stiffnessMatrix = np.diag([penalty, penalty, penalty, GJ, EI_side, EI])
    sec.inertia = np.eye(3)
    sec.massPerLength = 1.0
    nodes = []
    for k in range(nel + 1):
        s = L * k / nel
        # straight along x, or a circular arc of radius R in the x-y plane bending toward +y (a rest curvature)
        pose = [s, 0, 0, 0, 0, 0] if R is None else [R * np.sin(s / R), R * (1 - np.cos(s / R)), 0, 0, 0, s / R]
        nodes.append(mbs.AddNode(NodeRigidBodyRotVecLG(referenceCoordinates=pose)))
    for k in range(nel):
        mbs.AddObject(ObjectBeamGeometricallyExact(nodeNumbers=[nodes[k], nodes[k + 1]], length=L / nel, sectionData=sec))
    ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround(referenceCoordinates=[0, 0, 0])), coordinate=0))
    for i in range(6):
        mbs.AddObject(CoordinateConstraint(markerNumbers=[ground, mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[0], coordinate=i))]))
    mbs.AddLoad(Force(markerNumber=mbs.AddMarker(MarkerNodeRigid(nodeNumber=nodes[-1])), loadVector=list(force)))
    mbs.Assemble()
    settings = exu.SimulationSettings()
    settings.staticSolver.numberOfLoadSteps = steps
    settings.staticSolver.newton.relativeTolerance = 1e-8
    settings.staticSolver.newton.absoluteTolerance = 1e-10
    settings.staticSolver.verboseMode = 0
    settings.solution.file.write = False  # Exudyn writes solution/ into the current folder otherwise
    settings.solution.sensors.writePeriod = 1e9
    assert exu.SolveStatic(mbs, settings)
    return np.array(mbs.GetNodeOutput(nodes[-1], exu.OutputVariableType.Position))


def _esba_tip(n: int, L: float, EI: float, EI_side: float, GJ: float, force) -> np.ndarray:
    model = load_model3d(n, "rod,payload")
    f = np.asarray(force, dtype=float)
    F = float(np.linalg.norm(f))
    beta = float(np.arcsin(f[2] / F))
    omega = float(np.arctan2(-f[1], f[0]))  # f = F (cos B cos Omega, -cos B sin Omega, sin B)
    vals = dict(L=L, EI=EI, EI_side=EI_side, GJ=GJ, kappa0=0.0, F1=0.0, Omega1=omega, Beta1=beta, s1=1.0)
    q = np.zeros(model.size)
    for lam in np.linspace(0.0, 1.0, 11)[1:]:
        vals["F1"] = lam * F
        q, ok, _ = newton3d(model, vals, q)
        assert ok
    return model.tip(q, L)


@pytest.mark.parametrize("force, stiff", [
    ((0.0, 0.3, 0.6), (1.0, 0.5, 0.7)),   # a sideways tip load: bend in two planes and twist
    ((0.0, 1.0, 0.0), (1.0, 1.0, 1.0)),   # the elastica at alpha = 1 (B1)
])
def test_a_rod_under_a_tip_load_agrees_with_exudyn_at_equal_n(force, stiff):
    n = 3
    ours = _esba_tip(n, 1.0, *stiff, force)
    theirs = _exudyn_tip(n, 1.0, *stiff, force)
    assert np.abs(ours - theirs).max() < 5e-6, (ours, theirs)
    assert np.abs(ours - [1.0, 0.0, 0.0]).max() > 0.05  # a large deflection, not the linear regime


@pytest.mark.slow
@pytest.mark.ci
def test_the_sideways_loaded_rod_agrees_with_exudyn_at_n_8_and_16():
    for n in (8, 16):
        ours = _esba_tip(n, 1.0, 1.0, 0.5, 0.7, (0.0, 0.3, 0.6))
        theirs = _exudyn_tip(n, 1.0, 1.0, 0.5, 0.7, (0.0, 0.3, 0.6))
        assert np.abs(ours - theirs).max() < 5e-6, (n, ours, theirs)


@pytest.mark.slow
@pytest.mark.ci
def test_b3_bathe_bolourchi_at_300_agrees_with_exudyn_at_8_segments():
    """B3 at P = 300 (about 15 s in Exudyn): esba's n = 8 tip against Exudyn's 8 elements with the
    same EI, EI_side = EI and GJ; Exudyn's axial and shear penalty (1e5 EI/L^2 here, for its solver
    to converge) lets the tip move by about 2e-3 mm more than the inextensible rod does."""
    from esba.analysis.rod3d import BATHE, bathe_bolourchi

    L = BATHE["R"] * np.pi / 4
    ours = bathe_bolourchi(8, loads=(300.0,))[300.0]  # (x toward the centre, y along the tangent, z)
    theirs = _exudyn_tip(8, L, BATHE["EI"], BATHE["EI"], BATHE["GJ"], (0.0, 0.0, 300.0), R=BATHE["R"], penalty=1e5, steps=10)
    assert np.abs(ours - theirs[[1, 0, 2]]).max() < 5e-3, (ours, theirs)

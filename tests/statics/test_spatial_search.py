"""``esba equilibria --3d``'s search (esba.statics.spatial_search): the planar equilibria and the sideways ones."""

from __future__ import annotations

import numpy as np
import pytest

from esba.model.scene import MAIN_JOB, Payload, Scene
from esba.statics.equilibria import EquilibriaOptions, equilibria
from esba.statics.spatial import SpatialError
from esba.statics.spatial_search import search3d

STIFF = {"EI_side": 4e5, "GJ": 1e6}


def test_for_in_plane_loads_the_3d_search_finds_the_planar_equilibria():
    scene = Scene(pressure=0.17, payloads=(Payload(force=2, angle_deg=90),))
    planar = equilibria(scene, EquilibriaOptions(check=False)).states
    res = search3d(scene, STIFF, starts=2, check=False)
    assert len(planar) == 3
    for st in planar:
        match = [s for s in res.states if s.in_plane and np.abs(s.q[:3] - st.theta).max() < 1e-10]
        assert len(match) == 1, st.theta
        assert match[0].morse_index == st.morse_index and match[0].certified
    assert all(s.in_plane for s in res.states)  # stiff sideways: no state leaves the plane


@pytest.mark.slow  # the CLI test (tests/cli/test_cli_path3d.py) and docs/3d.md's check find the same three states in CI
def test_the_paper_actuator_under_2_n_flips_sideways_and_the_in_plane_state_is_unstable():
    res = search3d(MAIN_JOB, starts=2, check=False)
    planar = [s for s in res.states if s.in_plane]
    flipped = [s for s in res.states if not s.in_plane]
    assert len(planar) == 1 and planar[0].morse_index == 1 and not planar[0].stable
    assert len(flipped) == 2 and all(s.stable and s.certified for s in flipped)
    a, b = flipped
    assert abs(a.energy - b.energy) < 1e-9 and abs(a.tip[2] + b.tip[2]) < 1e-7 and abs(a.tip[2]) > 10  # mirror images
    assert a.energy < planar[0].energy
    d = res.to_dict()
    assert d["states"][0]["stable"] and d["states"][-1]["stability"] == "unstable (index 1)"


@pytest.mark.slow
def test_the_completeness_check_of_the_3d_search_finds_nothing_new():
    res = search3d(MAIN_JOB)
    assert res.complete and len(res.states) == 3


def test_bad_starts_are_refused_in_one_line():
    with pytest.raises(SpatialError, match="starts=1: expected a whole number from 2 to 1000"):
        search3d(MAIN_JOB, starts=1)

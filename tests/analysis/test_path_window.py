"""The snapping window of the payload magnitude near 122.2 degrees (issue 21).

``esba path --param payload --target-angle 90 --payload-angle OMEGA --from 0 --to 6`` with the default
steps: two branches almost cross near 122.18 deg, and a step could land on the neighbouring one. Inside
the window the path folds and loading snaps; on each side of it the path is monotonic.
"""

from __future__ import annotations

import pytest

from esba.analysis.path_analysis import analyse
from esba.model.scene import Payload, Scene
from esba.paths.continuation import PathOptions
from esba.paths.locate import BRANCH_ORTHOGONALITY

#: ``esba path``'s default steps.
CLI_STEPS = PathOptions(ds_max=0.1, ds=0.05)


def window(omega: float, steps: PathOptions = CLI_STEPS):
    return analyse(Scene(payloads=(Payload(2.0, omega),)), "payload", 6.0, start=0.0, options=steps, switch=False)


def test_122_19_folds_at_1_794243_and_snaps_on_loading():
    run = window(122.19)
    main = run.main
    assert main.stopped == "bound" and main.lam[-1] == 6.0
    assert main.branch_points == ()  # no false branch point at 1.834173 N
    first, second = main.folds
    assert first.lam == pytest.approx(1.794243, abs=1e-6) and first.status == "converged"
    assert (first.morse_before, first.morse_after) == (0, 1) and first.orthogonality > 1e3 * BRANCH_ORTHOGONALITY
    up, down = run.loading
    assert [(j.kind, j.lam) for j in up.jumps] == [("fold", first.lam)]  # the snap on loading
    assert [j.kind for j in down.jumps] == ["fold"] and down.jumps[0].lam == pytest.approx(second.lam, rel=1e-9)
    assert bool(main.stable[-1])  # the branch ends on the stable far state, not an unstable one
    # the same as with small steps, where no step can reach the neighbouring branch
    fine = window(122.19, PathOptions(ds_max=0.03, ds=0.03)).main
    assert [f.lam for f in fine.folds] == pytest.approx([f.lam for f in main.folds], rel=1e-9)


def test_122_179_is_a_fold_not_a_branch_point():
    main = window(122.179).main
    assert main.branch_points == ()
    assert [round(f.lam, 6) for f in main.folds] == [1.808891, 1.777049]
    assert all(f.status == "converged" for f in main.folds)


@pytest.mark.parametrize("omega, bends", [(122.17, "towards"), (122.28, "away")])
def test_either_side_of_the_window_is_monotonic(omega, bends):
    """122.17: the path bends back towards the chamber (the total angle falls below its 90 deg start);
    122.28: past the cusp where the two folds meet, it bends on away from it. Neither folds nor snaps."""
    run = window(omega)
    assert run.main.special == () and all(not r.jumps for r in run.loading)
    assert bool(run.main.stable.all())
    end = float(run.main.total_angle_deg[-1])
    assert (end < 0.0) if bends == "towards" else (end > 200.0)


@pytest.mark.parametrize("guard", ["branch point test", "chord test"])
def test_either_guard_alone_keeps_the_trace_on_its_branch(monkeypatch, guard):
    """Two guards reject the step that lands on the neighbouring branch: the extended system's verdict
    on a change of stability (dg/dlambda not orthogonal to the null vector: a fold, where lambda did
    not turn) and the chord far steeper than the turn between the tangents. Each alone suffices."""
    import esba.paths.continuation as continuation

    if guard == "branch point test":  # switch off the other one
        monkeypatch.setattr(continuation, "CHORD_FLOOR", 10.0)
    else:
        monkeypatch.setattr(continuation, "BRANCH_ORTHOGONALITY", float("inf"))
    for omega, fold in ((122.19, 1.794243), (122.179, 1.808891)):
        main = window(omega).main
        assert main.branch_points == () and round(main.folds[0].lam, 6) == fold

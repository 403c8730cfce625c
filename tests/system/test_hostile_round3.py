"""Hostile input, third round (issue 30, the Python half): list flags that start with a minus
sign, numbers in map axes, contradictory flags, files the estimate reads, output paths that loop,
a full disk under a map, the façade's arguments, states outside the model's domain, periodic
directions in maps, estimates that explain nothing, and the cost of a pose set in its rows.

Each case fails on the main branch before the round; the command-line cases run in a temporary
current folder (the ``places`` fixture of test_hostile.py).
"""

from __future__ import annotations

import argparse
import os
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from esba.cli import EXIT_FAILED, EXIT_OK, EXIT_USAGE, build_parser, main

from .test_hostile import one_line_error, places, strict_json  # noqa: F401  (a fixture)


# ---------------------------------------------------------------------------------------------
# list-valued flags take a leading negative number


@lru_cache(maxsize=1)
def _parser():
    return build_parser()


def _flags(parser=None, prefix=()):
    """Every (command words, option string, action) of the command line that takes one value, in
    subcommands of subcommands too (``bench accuracy``, ``export c``)."""
    parser = build_parser() if parser is None else parser
    for sub in (a for a in parser._actions if isinstance(a, argparse._SubParsersAction)):
        for command, p in sub.choices.items():
            words = (*prefix, command)
            for action in p._actions:
                if action.option_strings and action.nargs is None and not isinstance(action, (argparse._StoreConstAction, argparse._HelpAction, argparse._VersionAction)):
                    yield " ".join(words), action.option_strings[-1], action
            yield from _flags(p, words)


@pytest.mark.parametrize("command,flag", [(c, f) for c, f, _ in _flags()])
def test_every_flag_takes_a_value_that_starts_with_a_minus(command, flag):
    """argparse took ``-3.95,6.25`` for a flag ("expected one argument"): now the flag's own type
    judges it (accepts it, or refuses it naming the flag's rule)."""
    parser = _parser()
    for value in ("-3.95,6.25,20.24", "-1", "-.5,2", "-1:2:5"):
        try:
            parser.parse_args([*command.split(), flag, value])
        except Exception as exc:  # noqa: BLE001 - the message is what is checked
            assert "expected one argument" not in str(exc), (command, flag, value, exc)


LIST_FLAGS = [
    (["estimate", "--pressure", "0.15", "--theta", "-3.95,6.25,20.24"], "theta", [-3.95, 6.25, 20.24]),
    (["estimate", "--pressure", "0.15", "--tip", "-10,50"], "tip", [-10.0, 50.0]),
    (["estimate", "--pressure", "0.15", "--total-angle", "-20"], "total_angle", [-20.0]),
    (["estimate", "--pressure", "0.15", "--marker", "0.5:-10,3"], "marker", [(0.5, -10.0, 3.0)]),
    (["sweep", "--payload-angle", "-90,0,90"], "payload_angle", [-90.0, 0.0, 90.0]),
    (["sweep", "--payload", "-1:1:3"], "payload", [-1.0, 0.0, 1.0]),
    (["sweep", "--pressure", "-0.1,0.1"], "pressure", [-0.1, 0.1]),
    (["sweep", "--r2", "-1,3"], "r2", [-1.0, 3.0]),
    (["sweep", "--d", "-1,3"], "d", [-1.0, 3.0]),
]


@pytest.mark.parametrize("argv,dest,expected", LIST_FLAGS, ids=[" ".join(a[-2:]) for a, _, _ in LIST_FLAGS])
def test_list_flags_parse_a_leading_negative_number(argv, dest, expected):
    args = build_parser().parse_args(argv)
    assert list(getattr(args, dest)) == expected


def test_estimate_with_negative_angles_runs(capsys):
    """The angles ``solve`` prints (negative ones included) go back into ``estimate``."""
    got = main(["estimate", "--pressure", "0.15", "--theta", "-3.95,6.25,20.24", "--sigma-theta", "0.5", "--json"])
    out, err = capsys.readouterr()
    assert "expected one argument" not in err
    assert got in (EXIT_OK, EXIT_FAILED), err
    strict_json(out)


# ---------------------------------------------------------------------------------------------
# the map's axes read numbers by the rule of every other flag; contradictory flags are refused

ROUND3_CLI = [
    (["map", "--x", "omega:1_10:120", "--y", "payload:0:4"], "--x='omega:1_10:120': FROM and TO must be numbers"),
    (["map", "--x", "omega:\u0661\u0660:120", "--y", "payload:0:4"], "FROM and TO must be numbers"),
    (["map", "--x", "omega:100:120", "--y", "payload:1e-320:4"], "below the smallest normal double"),
    (["map", "--x", "omega:100:120", "--y", "payload:0:4", "--out", "m.csv", "--no-out"], "--out and --no-out: give one of the two"),
    (["map", "--x", "omega:100:120", "--y", "payload:0:4", "--plot", "m.png", "--no-plot"], "--plot and --no-plot: give one of the two"),
    (["map", "--x", "omega:100:120", "--y", "payload:0:4", "--points"], "--points only shapes the JSON output: give it with --json"),
    (["path", "--param", "pressure", "--to", "0.2", "--points"], "--points only shapes the JSON output: give it with --json"),
]


@pytest.mark.parametrize("argv,needle", ROUND3_CLI, ids=[" ".join(a[1:]) for a, _ in ROUND3_CLI])
def test_cli_round3_refused(capsys, places, argv, needle):
    line = one_line_error(capsys, argv, places)
    assert needle in line, line


# ---------------------------------------------------------------------------------------------
# output paths: a symlink that loops, a full disk under a map


@pytest.mark.parametrize("argv", [
    ["map", "--x", "omega:100:130", "--y", "payload:0:4", "--out", "loop.csv"],
    ["path", "--param", "pressure", "--to", "0.1", "--out", "loop.csv"],
    ["solve", "--plot", "loop.csv"],
    ["export", "c", "-n", "3", "--out", "loop.csv"],
    ["solve", "--plot", "d/sub/x.png"],
], ids=["map --out", "path --out", "solve --plot", "export c --out", "a loop further up"])
def test_an_output_that_is_a_symlink_loop_is_refused_up_front(capsys, places, argv):
    tmp = Path(places["tmp"])
    (tmp / "loop.csv").symlink_to("loop.csv")
    (tmp / "d").mkdir()
    (tmp / "d" / "sub").symlink_to("../loop.csv")
    line = one_line_error(capsys, argv, places)
    assert "a symlink that loops" in line and argv[-1] in line, line


def test_check_folder_and_check_file_refuse_a_loop(tmp_path):
    from esba.infra import outputs

    (tmp_path / "loop").symlink_to("loop")
    for check in (outputs.check_folder, outputs.check_file):
        with pytest.raises(outputs.OutputError, match="a symlink that loops"):
            check(tmp_path / "loop", "--out")


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (a device whose writes fail: disk full)")
@pytest.mark.parametrize("name", ["m.csv", "m.json"])
def test_a_full_disk_under_a_map_names_the_file(capsys, places, name):
    (Path(places["tmp"]) / name).symlink_to("/dev/full")
    argv = ["map", "--x", "omega:100:130", "--y", "payload:0:4", "--out", name, "--no-plot", "--resolution", "11", "--history-lines", "0", "--json"]
    got = main(argv)
    out, err = capsys.readouterr()
    assert got == EXIT_FAILED, err
    assert err.strip().splitlines()[-1] == f"esba: error: {name}: cannot write (No space left on device)", err


# ---------------------------------------------------------------------------------------------
# every file the estimate reads goes through the guards of a scene file


@pytest.mark.skipif(not hasattr(os, "mkfifo") or not os.path.exists("/dev/zero"), reason="needs FIFOs and /dev/zero")
@pytest.mark.parametrize("kind", ["fifo", "zero", "folder", "big", "binary"])
@pytest.mark.parametrize("flag", ["--fit", "--poses"])
def test_the_estimates_files_are_guarded_like_a_scene_file(capsys, places, kind, flag):
    """``--fit FIFO`` waited forever, ``--fit`` a symlink to /dev/zero said "out of memory"."""
    tmp = Path(places["tmp"])
    name = "f.json" if flag == "--fit" else "f.csv"
    path = tmp / name
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "zero":
        path.symlink_to("/dev/zero")
    elif kind == "folder":
        path.mkdir()
    elif kind == "big":
        with open(path, "wb") as fh:
            fh.truncate(17 * 2**20)
    else:
        path.write_bytes(b"\xff\xfe\x00garbage")
    argv = ["estimate", flag, name] if flag == "--poses" else ["estimate", "--pressure", "0.15", "--total-angle", "90", "--sigma-total-angle", "1", flag, name]
    line = one_line_error(capsys, argv, places)
    assert repr(name) in line, line
    assert {"fifo": "FIFO", "zero": "character device", "folder": "folder", "big": "MiB", "binary": "not UTF-8"}[kind] in line, line


# ---------------------------------------------------------------------------------------------
# an estimate that explains nothing is not "ok"


def test_an_estimate_that_explains_nothing_is_a_misfit_exit_1(capsys):
    """No load bends three segments to 300, -300 and 300 deg: it said "load estimate: ok"."""
    got = main(["estimate", "--pressure", "0.15", "--theta", "300,-300,300", "--sigma-theta", "0.05", "--starts", "2"])
    out, err = capsys.readouterr()
    assert got == EXIT_FAILED, err
    assert out.startswith("load estimate: misfit: no load explains the data: chi-square "), out
    misfit = [line for line in err.splitlines() if line.startswith("esba: estimate misfit: ")]
    assert len(misfit) == 1 and "p = " in misfit[0], err


def test_a_good_estimate_stays_ok(capsys):
    got = main(["estimate", "--pressure", "0.15", "--theta", "11.88,21.31,33.05", "--sigma-theta", "0.05", "--starts", "2", "--json"])
    out, err = capsys.readouterr()
    assert got == EXIT_OK, err
    assert strict_json(out)["status"] == "ok"


# ---------------------------------------------------------------------------------------------
# one rule of the model's domain: equilibria judges its states as solve does


def test_equilibria_judges_the_domain_as_solve_does(capsys):
    """``solve --pressure 0.17 --payload 2`` warns that the tip is 26 mm behind the base;
    ``equilibria`` listed the same state as stable with ``outside_domain: 0``."""
    from esba.model.scene import Payload, Scene
    from esba.statics.equilibria import EquilibriaOptions, equilibria
    from esba.statics.equilibrium import solve

    scene = Scene(pressure=0.17, payloads=(Payload(2.0, 90.0),))
    solved = solve(scene)
    res = equilibria(scene, EquilibriaOptions(check=False, connect=False))
    same = res.states[res.index(solved.theta)]
    assert [f.check for f in same.validity] == [f.check for f in solved.validity] == ["tip_behind_base"]
    assert not same.in_domain and res.outside_domain >= 1
    assert all(s.in_domain for s in res.states if s is not same)
    assert main(["equilibria", "--pressure", "0.17", "--payload", "2", "--no-plot", "--no-check", "--json"]) == EXIT_OK
    out, err = capsys.readouterr()
    d = strict_json(out)
    assert d["outside_domain"] == 1 and [s["in_domain"] for s in d["states"]].count(False) == 1
    assert "esba: warning: state #1 (212.84 deg): the tip is 26.18 mm behind the base" in err


# ---------------------------------------------------------------------------------------------
# a periodic axis (a payload direction) past one turn


@pytest.fixture(scope="module")
def omega_plane():
    from esba.analysis.folds import Plane
    from esba.model.scene import Payload, Scene

    return Plane.from_scene(Scene(payloads=(Payload(2.0, 90.0),)), "omega", "payload")


def test_a_map_past_one_turn_finds_every_window(omega_plane):
    """``--x omega:0:720`` found the bistable window at 77.7-144.2 deg and missed the one at
    437.7-504.2 deg."""
    from esba.analysis.maps import stability_map

    one = stability_map(omega_plane, (0.0, 360.0), (0.0, 4.0), resolution=41, history_lines=0)
    two = stability_map(omega_plane, (0.0, 720.0), (0.0, 4.0), resolution=41, history_lines=0)
    assert len(one.curves) >= 1 and len(two.curves) == 2 * len(one.curves)
    lo = min(float(c.xs.min()) for c in one.curves)
    assert sorted(round(float(c.xs.min()) - lo, 6) for c in two.curves) == sorted([0.0, 360.0] * len(one.curves))
    # the counts one period on are the counts of the first period
    assert np.array_equal(two.count([100.0, 460.0, 300.0, 660.0], [3.0] * 4), [2, 2, 1, 1])
    assert two.to_dict()["stable_states"] == one.to_dict()["stable_states"]
    assert two.to_dict()["stable_states"]["max"] == 2


def test_a_map_of_a_hundred_turns_costs_one_turn(omega_plane, monkeypatch):
    """``--x omega:-36000:36000`` said "stable states: 1 to 1"; its work is that of one period:
    the fold curves are traced once and copied (the number of traces does not grow with the turns)."""
    from esba.analysis import folds, maps

    traced = []
    real = folds.trace_fold_curve

    def counted(*args, **kwargs):
        traced.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(folds, "trace_fold_curve", counted)
    one = maps.stability_map(omega_plane, (-36000.0, -35640.0), (0.0, 4.0), resolution=41, history_lines=0)
    once = len(traced)
    many = maps.stability_map(omega_plane, (-36000.0, 36000.0), (0.0, 4.0), resolution=41, history_lines=0)
    assert len(traced) == 2 * once  # one period each
    assert len(many.curves) == 200 * len(one.curves)
    st = many.to_dict()["stable_states"]
    assert (st["min"], st["max"]) == (1, 2) and st["fraction_multistable"] > 0.01


def test_a_map_past_too_many_turns_is_refused(capsys, places):
    line = one_line_error(capsys, ["map", "--x", "omega:0:400000", "--y", "payload:0:4"], places)
    assert "1111 periods of 360 deg; expected at most 1000" in line


def test_an_envelopes_directions_are_periodic():
    """A design's envelope over directions: 450 deg and -270 deg are 90 deg, checked once."""
    from esba.design.envelope import Envelope

    assert Envelope(max_pressure=0.2, max_payload=2.0, directions_deg=(90.0, 450.0, -270.0, 0.0)).directions_deg == (90.0, 0.0)


# ---------------------------------------------------------------------------------------------
# the load estimate's work grows linearly in the poses


class _Work:
    """Counts the estimate's work: equilibrium solves (load histories), equilibria searches, pose
    evaluations (a pose's model function) and Levenberg-Marquardt runs with the size of each."""

    def __init__(self, monkeypatch):
        from collections import Counter

        from esba.calibration import sensing

        self.counts = Counter()
        self.sizes: list[int] = []
        for name in ("history_state", "call"):
            real = getattr(sensing._PoseModel, name)

            def wrapped(pm, *a, _real=real, _name=name, **k):
                self.counts[_name] += 1
                return _real(pm, *a, **k)

            monkeypatch.setattr(sensing._PoseModel, name, wrapped)
        other, lm = sensing._other_states, sensing._levenberg_marquardt

        def counted_other(*a, **k):
            self.counts["other_states"] += 1
            return other(*a, **k)

        def counted_lm(prob, *a, **k):
            self.counts["lm"] += 1
            self.sizes.append(prob.size)
            return lm(prob, *a, **k)

        monkeypatch.setattr(sensing, "_other_states", counted_other)
        monkeypatch.setattr(sensing, "_levenberg_marquardt", counted_lm)

    def run(self, poses, base):
        from esba.calibration.sensing import SensingOptions, estimate_load

        self.counts.clear()
        self.sizes.clear()
        estimate_load(poses, ("F1",), base, SensingOptions(starts=2))
        return dict(self.counts), max(self.sizes)


def _poses(rows: int, load: str | None):
    from esba.calibration.sensing import Measured, Pose

    return [Pose(0.1699 + 0.0002 * i / rows, (Measured("total_angle", (83.90 + 0.1 * (i % 3),), 0.05),), label=f"row {i + 1}",
                 **({"load": load} if load else {"load": f"object {i + 1}"})) for i in range(rows)]


@pytest.mark.parametrize("one_load", [True, False], ids=["one load", "a load per row"])
def test_the_estimates_work_is_linear_in_the_poses(monkeypatch, one_load):
    """``esba estimate --poses`` grew faster than linearly: with one load that misfits, 10 rows
    took 4 s and 80 rows 195 s (each pose's other stable state rerun the whole set); with separate
    loads, 20 rows took 16 s and 100 rows 208 s (one dense least-squares problem over every load).
    Twice the poses now cost at most about twice the work, in the bistable window (other states)."""
    from esba.model.scene import Payload, Scene

    work = _Work(monkeypatch)
    base = Scene(payloads=(Payload(2.0, 90.0),))
    small, small_size = work.run(_poses(3, "cup" if one_load else None), base)
    large, large_size = work.run(_poses(6, "cup" if one_load else None), base)
    for what in ("history_state", "call", "other_states"):
        assert large[what] <= 2.2 * small[what], (what, small, large)
    assert large_size == small_size == 1  # one unknown a problem: separate loads are estimated one at a time
    if one_load:
        assert large["lm"] == small["lm"]  # the runs do not multiply with the poses


def test_stiffness_results_are_strict_json():
    """``to_dict()`` held ``inf``: a direction along which the tip does not move (a straight
    actuator loaded along its axis) has no finite stiffness; null now, with the reason beside it."""
    import json

    from esba import Payload, Scene, secant_stiffness, solve, tangent_stiffness

    for d in (secant_stiffness(Scene(pressure=0.0), angle_deg=0.0).to_dict(),
              tangent_stiffness(solve(Scene(pressure=0.0, payloads=(Payload(1.0, 0.0),)))).to_dict()):
        json.dumps(d, allow_nan=False)
    d = secant_stiffness(Scene(pressure=0.0), angle_deg=0.0).to_dict()
    assert d["stiffness_n_per_m"] == [None, None, None] and "does not move the tip" in d["stiffness_n_per_m_reason"]
    t = tangent_stiffness(solve(Scene(pressure=0.0))).to_dict()
    assert t["vertical_n_per_m"] is None and "does not move along this direction" in t["vertical_n_per_m_reason"]

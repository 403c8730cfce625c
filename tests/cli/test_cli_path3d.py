"""``esba path --3d`` and ``esba equilibria --3d``: answers, files and one-line refusals (exit code 2)."""

from __future__ import annotations

import json

import pytest

from esba.cli import EXIT_OK, EXIT_USAGE, main


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_path_3d_reports_the_sideways_branch_point_and_writes_csv_and_figure(capsys, tmp_path):
    out, fig = tmp_path / "p.csv", tmp_path / "p.png"
    code, text, err = run(capsys, "path", "--3d", "--param", "payload", "--from", "0", "--to", "2", "--no-loading", "--out", str(out), "--plot", str(fig), "--json")
    assert code == EXIT_OK, err
    d = json.loads(text)
    (bp,) = d["branches"][0]["special_points"]
    assert bp["kind"] == "branch point" and bp["mode"] == "sideways" and bp["bifurcation"] == "pitchfork"
    assert sorted(b["label"] for b in d["branches"][1:]) == ["BP1 sideways +z", "BP1 sideways -z"]
    header = out.read_text().splitlines()[0]
    assert "tip_z_mm" in header and "tau3_deg" in header
    assert fig.stat().st_size > 0


@pytest.mark.parametrize(
    "args, message",
    [
        (["path", "--3d", "--param", "r2", "--to", "3"], "parameter='r2': a 3-D path follows pressure"),
        (["path", "--param", "beta", "--to", "3"], "--param beta: the direction out of the bending plane needs the 3-D model"),
        (["path", "--section", "GJ=1", "--to", "3"], "--section is for the 3-D model: give --3d"),
        (["path", "--3d", "--to", "3", "--section", "EI=3"], "section parameter 'EI': unknown"),
        (["path", "--3d", "--to", "3", "--locate", "bisection"], "--locate bisection: with --3d"),
        (["path", "--3d", "--to", "3", "--y", "tip-x"], "--y tip-x: with --3d"),
        (["path", "--3d", "--to", "3", "--gravity-direction", "0,0,0"], "a zero vector has no direction"),
        (["path", "--3d", "--param", "beta", "--to", "120"], "to=120.0: outside the range of beta1, -90 to 90 deg"),
        (["equilibria", "--gravity-direction", "1,0,0"], "--gravity-direction is for the 3-D model"),
        (["equilibria", "--3d", "--plot", "x.png"], "--plot and --max-bend are not used with --3d"),
    ],
)
def test_bad_3d_path_and_equilibria_input_is_one_line_and_exit_2(capsys, args, message):
    code, out, err = run(capsys, *args, "--no-out", "--no-plot") if args[0] == "path" else run(capsys, *args)
    assert code == EXIT_USAGE, err
    assert message in err and len(err.strip().splitlines()) == 1


def test_equilibria_3d_lists_the_flipped_states(capsys):
    code, text, err = run(capsys, "equilibria", "--3d", "--starts", "2", "--no-check", "--json")
    assert code == EXIT_OK, err
    d = json.loads(text)
    assert [s["stable"] for s in d["states"]] == [True, True, False] and d["multistable"]
    assert d["states"][2]["in_plane"] and not d["states"][0]["in_plane"]

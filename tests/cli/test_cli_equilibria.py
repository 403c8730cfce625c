"""The command line: esba equilibria, and esba solve's --history and multistability warning."""

from __future__ import annotations

import json

import pytest

from esba.cli import EXIT_OK, EXIT_USAGE, main
from esba.cli.equilibria import DEFAULT_EQUILIBRIA_FIGURE
from tests.figures import drawn


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_equilibria_lists_the_bistable_window_with_json(capsys):
    code, out, err = run(capsys, "equilibria", "--pressure", "0.17", "--payload", "2", "--json", "--no-plot")
    assert code == EXIT_OK, err
    d = json.loads(out)
    assert [s["morse_index"] for s in d["states"]] == [0, 0, 1]
    assert [round(s["total_angle_deg"], 2) for s in d["states"][:2]] == [212.84, 83.90]
    assert d["stable"] == [0, 1] and d["least_energy_stable"] == 0 and d["history_state"] == 0 and d["complete"] is True
    assert d["barriers"][0]["saddle"] == 2 and "total bend" in d["domain"]["text"]


def test_equilibria_table_and_figure(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    saved = drawn.record_saved(monkeypatch)
    code, out, err = run(capsys, "equilibria", "--pressure", "0.17", "--payload", "2")
    assert code == EXIT_OK, err
    assert "barrier: #1 <-> #2 through the saddle #3" in out and "found nothing new" in out
    fig = saved[(tmp_path / DEFAULT_EQUILIBRIA_FIGURE).resolve()]
    ax = drawn.axes(fig)[0]
    shapes = {line.get_label()[:2]: line for line in drawn.starting(ax, "#")}
    assert set(shapes) == {"#1", "#2", "#3"}
    assert shapes["#1"].get_linestyle() == "-" and shapes["#2"].get_linestyle() == "-" and shapes["#3"].get_linestyle() == "--"
    assert "U = -92.86 N mm" in shapes["#1"].get_label()


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["equilibria", "--starts", "1"], "--starts=1"),
        (["equilibria", "--max-bend", "-3", "--no-plot"], "--max-bend"),
        (["solve", "--history", "sideways", "--no-plot"], "history='sideways'"),
        (["solve", "--history", "1:0.5", "--no-plot"], "the last step must be (1, 1)"),
        (["solve", "--history", "1:x,1:1", "--no-plot"], "--history"),
        (["solve", "--history", "together", "--no-continuation", "--no-plot"], "--no-continuation"),
    ],
)
def test_bad_flags_exit_2_with_one_line(capsys, argv, needle):
    code, _, err = run(capsys, *argv)
    assert code == EXIT_USAGE
    assert needle in err and len(err.strip().splitlines()) == 1


def test_solve_warns_in_one_line_when_multistable(capsys):
    code, out, err = run(capsys, "solve", "--pressure", "0.1686", "--payload", "2", "--no-plot", "--history", "load-then-inflate")
    assert code == EXIT_OK, err
    warnings = [line for line in err.splitlines() if "multistable" in line]
    assert len(warnings) == 1 and warnings[0].startswith("esba: warning: multistable: 2 stable states")
    assert "history: load-then-inflate" in out and "209.36 deg" in warnings[0]
    code, out, err = run(capsys, "solve", "--pressure", "0.1686", "--payload", "2", "--no-plot", "--history", "0:1,1:1", "--json")
    d = json.loads(out)
    assert d["history"] == "load-then-inflate" and d["multistable"] is True and d["multistability"]["warning"]

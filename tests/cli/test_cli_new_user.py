"""What a new user tripped on (issue 31): each case failed on the commit before its fix."""

from __future__ import annotations

import pytest

from esba.cli import EXIT_OK, main


def test_resume_of_a_finished_study_starts_no_cluster(capsys, tmp_path, monkeypatch):
    """`esba sweep --resume --workers 2` on a file that holds every row solved 0 chunks on a Dask
    cluster it started for them (10 s); now it reads the rows back in this process."""
    out = tmp_path / "s.csv"
    grid = ["sweep", "--pressure", "0:0.2:4", "--no-compile", "--no-progress", "--out", str(out)]
    assert main(grid) == EXIT_OK
    before = out.read_bytes()
    capsys.readouterr()

    def no_cluster(*args, **kwargs):
        raise AssertionError("a cluster was started for a study with nothing left to solve")

    monkeypatch.setattr("esba.studies.distributed._connect", no_cluster)
    assert main([*grid, "--resume", "--workers", "2"]) == EXIT_OK
    assert "already holds every row of this study (4): nothing solved, nothing written" in capsys.readouterr().out
    assert out.read_bytes() == before


def test_design_reports_the_starts_it_ran_as_they_are(capsys):
    """`esba design --objective angle --min-stiffness 40` said "5 starts" where --starts is 4: the
    stiffest design, found first to see whether the floor can be met, is the fifth; say so."""
    assert main(["design", "--objective", "angle", "--min-stiffness", "40", "--max-pressure", "0.2"]) == EXIT_OK
    out = capsys.readouterr().out
    assert "5 starts (4 of --starts and the stiffest design, found first for K >= 40 N/m)" in out
    assert main(["design", "--objective", "stiffness", "--starts", "3"]) == EXIT_OK
    out = capsys.readouterr().out
    assert "3 starts;" in out


def test_sweep_warnings_are_worded_alike_in_memory_and_streamed(capsys, tmp_path):
    """A sweep whose rows stream to its file (on Dask, or --resume) warned "N point(s) outside the
    model's range: see the validity column", where the same sweep in memory named each check with an
    example: the same lines now, also for rows read back from the file."""
    grid = ["sweep", "--pressure", "0:3:4", "--no-compile", "--no-progress"]
    assert main([*grid, "--out", str(tmp_path / "a.csv")]) == EXIT_OK
    in_memory = capsys.readouterr().err
    assert in_memory.count("esba: warning: ") == 4 and "e.g. total bend" in in_memory
    assert main([*grid, "--out", str(tmp_path / "b.csv"), "--resume"]) == EXIT_OK
    assert capsys.readouterr().err == in_memory
    assert main([*grid, "--out", str(tmp_path / "b.csv"), "--resume"]) == EXIT_OK  # every row read back
    assert capsys.readouterr().err == in_memory


def test_a_users_own_derive_and_generated_modules_do_not_break_esba(tmp_path):
    """esba installed top-level packages `derive` and `generated`: a user's derive.py in the working
    folder broke `esba solve` and `from esba import solve` ('derive' is not a package). They install
    as esba.derive and esba.generated now; the user's modules are theirs."""
    import subprocess
    import sys

    (tmp_path / "derive.py").write_text("raise ImportError('the user derive.py was imported')\n")
    (tmp_path / "generated.py").write_text("raise ImportError('the user generated.py was imported')\n")
    run = subprocess.run([sys.executable, "-m", "esba", "solve", "--no-plot", "--json"], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    code = "import derive, generated"
    mine = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert "the user derive.py was imported" in mine.stderr  # the name is the user's
    api = subprocess.run([sys.executable, "-c", "from esba import solve, Scene; print(solve(Scene()).ok)"], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert api.returncode == 0 and api.stdout.strip() == "True", api.stderr

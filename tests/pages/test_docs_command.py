"""``esba docs``: check the docs pages against a fresh computation, write them, list them; bad input."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from esba.cli import EXIT_FAILED, EXIT_OK, EXIT_USAGE, main
from esba.pages.registry import ENTRIES

ROOT = Path(__file__).resolve().parents[2]


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(["docs", *args])
    out, err = capsys.readouterr()
    return code, out, err


def test_the_committed_pages_are_fresh(capsys):
    """The JSON of a check of the checkout's pages (every computed page is checked, one by one, in
    tests/pages/test_committed_pages.py; the benchmarks by `esba docs --check NAME`, minutes)."""
    code, out, err = run(capsys, "--check", "validation", "--json")
    assert code == EXIT_OK, err
    data = json.loads(out)
    assert data["ok"] and [c["page"] for c in data["checks"]] == ["validation"]
    assert all(Path(c["path"]) == ROOT / "docs" / ENTRIES[c["page"]].file for c in data["checks"])


def test_write_then_check_outside_a_checkout(capsys, tmp_path, monkeypatch):
    """Outside a checkout the pages go to docs/ in the current folder (esba.infra.outputs), where
    the README's commands write them; checking makes nothing, writing makes the folder."""
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, "--check", "validation")
    assert code == EXIT_FAILED and "validation  missing" in out and str(tmp_path / "docs" / "validation.md") in out
    assert err == "esba: validation is missing: run `esba docs --write validation` and commit the pages\n"
    assert not (tmp_path / "docs").exists()
    # its figures beside it (as `esba figures` there writes them): the page is the checkout's, and links them
    (tmp_path / "docs" / "figures").mkdir(parents=True)
    for figure in (ROOT / "docs" / "figures").glob("fig*.png"):
        shutil.copy(figure, tmp_path / "docs" / "figures" / figure.name)
    assert run(capsys, "--write", "validation")[0] == EXIT_OK
    assert (tmp_path / "docs" / "validation.md").read_text() == (ROOT / "docs" / "validation.md").read_text()
    assert run(capsys, "--check", "validation")[0] == EXIT_OK


def test_the_same_page_for_every_command_that_writes_or_checks_it(capsys, tmp_path, monkeypatch):
    """`esba experiments --write-doc docs/experiments.md` (the README's command) and `esba
    experiments --check` agree on the file outside a checkout too; a page checked under another
    name is written again by the command with that name."""
    monkeypatch.chdir(tmp_path)
    assert main(["validate"]) == EXIT_OK
    assert (tmp_path / "docs" / "validation.md").is_file()
    capsys.readouterr()
    assert main(["validate", "--check"]) == EXIT_OK
    other = tmp_path / "other.md"
    other.write_text("stale\n")
    capsys.readouterr()
    assert main(["validate", "--check", str(other)]) == EXIT_FAILED
    assert f"run `esba validate --out {other}`" in capsys.readouterr().err


def test_a_stale_page_is_named(capsys, tmp_path):
    for name in ("derivations.md", "validation.md"):
        shutil.copy(ROOT / "docs" / name, tmp_path / name)
    page = tmp_path / "validation.md"
    page.write_text(page.read_text().replace("| 3 | θ_TOL (deg) | 25.2 |", "| 3 | θ_TOL (deg) | 25.3 |"))
    code, out, err = run(capsys, "--check", "derivations", "validation", "--dir", str(tmp_path))
    assert code == EXIT_FAILED
    lines = out.splitlines()
    assert lines[0].startswith("derivations  up to date") and lines[1].startswith(f"validation   stale       {page}: line ")
    assert "a fresh page has: '| 3 | θ_TOL (deg) | 25.2 |" in lines[1]
    assert err == "esba: validation is stale: run `esba docs --write validation` and commit the pages\n"


def test_list(capsys):
    code, out, _ = run(capsys)
    assert code == EXIT_OK
    assert [line.split()[0] for line in out.splitlines()[:-1]] == list(ENTRIES)
    assert sum("[benchmark: minutes]" in line for line in out.splitlines()) == sum(e.slow for e in ENTRIES.values())


def test_help_names_every_page_and_the_slow_ones(capsys):
    with pytest.raises(SystemExit):
        main(["docs", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for name in ENTRIES:
        assert name in text
    assert "Slow: accuracy-vs-time, performance, scaling" in text


@pytest.mark.parametrize(
    "args, message",
    [
        (["--check", "derivation"], "unknown page 'derivation': allowed are derivations, validation, design, paths, experiments, sensing, accuracy-vs-time, performance, scaling"),
        (["--write", "paths", "nope"], "unknown page 'nope': allowed are"),
        (["--check", "--write"], "argument --write: not allowed with argument --check"),
        (["--check", "validation", "--dir", "/no/such/folder"], "--dir '/no/such/folder': not a folder"),
        (["--write", "validation", "--dir", "/no/such/folder"], "--dir '/no/such/folder': the folder '/no/such/folder' does not exist"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(capsys, tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, *args)
    assert code == EXIT_USAGE and out == ""
    assert err.count("\n") == 1 and err.startswith("esba: error: ") and message in err, err
    assert list(tmp_path.iterdir()) == []  # nothing computed, nothing written

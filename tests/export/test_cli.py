"""``esba export c`` and ``esba bench embedded`` from the command line, and the page it writes."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from esba.cli import EXIT_OK, EXIT_USAGE, main
from esba.export.build import STRICT, run_compiler

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "embedded.md"


def test_export_writes_the_folder(tmp_path, capsys):
    out = tmp_path / "ctrl"
    assert main(["export", "c", "--segments", "2", "--float", "--out", str(out), "--json"]) == EXIT_OK
    data = json.loads(capsys.readouterr().out)
    name = "esba_n2_air_axial_radial_fibres_payload1_paper"
    assert data["name"] == name and data["precision"] == "float"
    assert sorted(p.name for p in out.iterdir()) == sorted([f"{name}.h", f"{name}.c", "Makefile", "README.md", "demo.c", "esba-export.json"])
    assert "esba export c --segments 2 --float --out" in (out / f"{name}.h").read_text()
    assert "typedef float " in (out / f"{name}.h").read_text()
    assert data["example"]["output"] in (out / "README.md").read_text()


def _names(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_files_esba_did_not_write_are_not_replaced_without_force(tmp_path, capsys):
    """A Makefile of the user's in --out: refused in one line naming it (exit 2), nothing written;
    --force replaces it; an export into its own folder again needs no --force; a file of the export
    changed since is the user's again."""
    out = tmp_path / "ctrl"
    out.mkdir()
    (out / "Makefile").write_text("all:\n\techo mine\n")
    (out / "notes.txt").write_text("kept\n")
    argv = ["export", "c", "--segments", "2", "--out", str(out)]
    assert main(argv) == EXIT_USAGE
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "would replace Makefile," in err and "--force" in err
    assert _names(out) == ["Makefile", "notes.txt"] and "mine" in (out / "Makefile").read_text()
    assert main([*argv, "--force"]) == EXIT_OK
    assert "DO NOT MODIFY BY HAND" in (out / "Makefile").read_text() and (out / "notes.txt").read_text() == "kept\n"
    assert main(argv) == EXIT_OK  # its own files, unchanged since
    (out / "demo.c").write_text((out / "demo.c").read_text() + "/* my change */\n")
    (out / "README.md").unlink()
    assert main(argv) == EXIT_USAGE
    err = capsys.readouterr().err
    assert "would replace demo.c," in err and "README" not in err


def test_a_manifest_that_is_not_esbas_is_not_replaced(tmp_path, capsys):
    out = tmp_path / "ctrl"
    out.mkdir()
    (out / "esba-export.json").write_text('{"mine": true}')
    assert main(["export", "c", "--segments", "2", "--out", str(out)]) == EXIT_USAGE
    assert "would replace esba-export.json" in capsys.readouterr().err


def test_a_failed_export_leaves_no_folder(tmp_path, capsys, monkeypatch):
    """An unusable model cache (a file) fails in one line, exit 2, and leaves no empty --out folder."""
    (tmp_path / "cache").write_text("")
    monkeypatch.setenv("ESBA_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "x"
    assert main(["export", "c", "--segments", "5", "--out", str(out)]) == EXIT_USAGE
    assert "ESBA_CACHE_DIR" in capsys.readouterr().err
    assert not out.exists()


def test_export_help_imports_no_numerics():
    script = (
        "import sys, contextlib, io\n"
        "from esba.cli import main\n"
        "for argv in (['export', '--help'], ['export', 'c', '--help'], ['bench', 'embedded', '--help']):\n"
        "    with contextlib.redirect_stdout(io.StringIO()):\n"
        "        try:\n"
        "            main(argv)\n"
        "        except SystemExit:\n"
        "            pass\n"
        "print(sorted(m for m in ('casadi', 'numpy', 'sympy', 'scipy') if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out


def test_bench_parser_agrees_with_the_benchmark():
    from esba.bench.embedded import EMBEDDED_NS
    from esba.cli import bench

    assert bench._EMBEDDED_NS == EMBEDDED_NS


def test_the_control_loop_of_the_page_compiles(exports, cc, tmp_path):
    """The page's control loop is C against an export of n = 3, strict C99; the page shows the
    loop as the page module has it (the page is not stale)."""
    from esba.pages.embedded import CONTROL_LOOP

    export, _ = exports(3, library=False)
    source = tmp_path / "control.c"
    source.write_text(CONTROL_LOOP)
    run_compiler(cc, [*STRICT, f"-I{export.folder}", "-c", str(source), "-o", str(tmp_path / "control.o")])
    page = PAGE.read_text()
    block = re.search(r"```c\n(.*?)```", page, flags=re.S).group(1)
    assert block == CONTROL_LOOP


def test_the_page_names_its_command_and_the_readme_the_export():
    page = PAGE.read_text()
    assert re.search(r"Written by `esba bench embedded[^`]*`; rerun it to refresh", page)
    assert "apt-get install gcc-arm-none-eabi" in page and "What happens at a fold" in page
    readme = (ROOT / "README.md").read_text()
    assert "esba export c --segments" in readme and "docs/embedded.md" in readme and "`esba bench embedded`" in readme


@pytest.mark.slow
@pytest.mark.ci
def test_bench_embedded_runs_and_writes_its_page(tmp_path, capsys):
    page = tmp_path / "embedded.md"
    # the M4's instruction counts take minutes under qemu; tests/export/test_cortexm4.py checks them
    assert main(["bench", "embedded", "--segments", "3", "--repeat", "3", "--no-m4-time", "--out", str(page), "--json"]) == EXIT_OK
    data = json.loads(capsys.readouterr().out)
    row = data["rows"][0]
    assert row["n"] == 3 and row["equilibrium_speedup"] > 1 and row["inverse_speedup"] > 1
    assert row["equilibrium_theta_difference_rad"] < 1e-9 and row["inverse_pressure_difference_mpa"] < 1e-8
    assert data["demo"]["output"] == data["demo"]["expected"]
    text = page.read_text()
    assert "Written by `esba bench embedded --segments 3 --repeat 3 --no-m4-time --out" in text
    assert "Not counted in this run (`--no-m4-time`)" in text
    assert f"| 3 | {row['host']['size']['text']:,} |" in text


@pytest.mark.slow
@pytest.mark.ci
def test_the_wheel_ships_the_templates(tmp_path):
    """A non-editable install must find the C templates: they are package data."""
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-w", str(tmp_path), str(ROOT)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-2000:]
    import zipfile

    wheel = next(tmp_path.glob("esba-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    for template in ("model.h", "solver.c", "inverse.c", "demo.c", "Makefile"):
        assert f"esba/export/templates/{template}" in names

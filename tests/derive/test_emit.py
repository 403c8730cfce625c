"""generated/ is reproducible, fresh, deterministic, and the runtime needs no SymPy to use it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from esba.derive import emit
from esba.derive.effects import EffectSet, model_filename
from esba.derive.provenance import GENERATED_DIR, source_hash
from esba.cli import main

ROOT = Path(__file__).resolve().parents[2]


def test_committed_models_are_fresh(tmp_path):
    """Regenerate every committed model into a temporary folder: the bytes must match.

    On failure: run `esba generate --refresh` and commit generated/.
    """
    emit.refresh(tmp_path)
    committed = json.loads((GENERATED_DIR / "manifest.json").read_text())
    fresh = json.loads((tmp_path / "manifest.json").read_text())
    assert sorted(committed["models"]) == sorted(fresh["models"]), "the manifest lists other models"
    stale = [
        name
        for name in fresh["models"]
        if (GENERATED_DIR / name).read_bytes() != (tmp_path / name).read_bytes()
    ]
    assert not stale, f"stale models (run `esba generate --refresh`): {stale}"
    for name, entry in committed["models"].items():
        assert entry == fresh["models"][name]
        assert entry["source_sha256"] == source_hash()


def test_manifest_records_provenance():
    data = json.loads((GENERATED_DIR / "manifest.json").read_text())
    assert {"sympy", "casadi", "format", "models"} <= set(data)
    assert len(data["models"]) == len(emit.COMMITTED)
    for n, eff, var in emit.COMMITTED:
        entry = data["models"][model_filename(n, EffectSet.parse(eff), var)]
        assert entry["segments"] == n and entry["variant"] == var
        assert EffectSet.parse(entry["effects"]) == EffectSet.parse(eff)
        assert set(entry["instructions"]) == {"energy", "gradient", "hessian", "kinematics", "centreline"}


def test_every_model_file_says_do_not_edit():
    for path in GENERATED_DIR.glob("m_n*.py"):
        head = path.read_text()[:400]
        assert "DO NOT MODIFY BY HAND" in head and "esba generate" in head


def _generate_in_subprocess(folder: Path, seed: str) -> bytes:
    code = (
        "import sys; from esba.derive.emit import write_model; "
        "write_model(4, 'air,axial,radial,fibres,payload:2,gravity', 'printed', sys.argv[1], manifest=False)"
    )
    env = dict(os.environ, PYTHONHASHSEED=seed)
    subprocess.run([sys.executable, "-c", code, str(folder)], check=True, env=env, cwd=ROOT)
    (path,) = folder.glob("m_n*.py")
    return path.read_bytes()


def test_emission_is_deterministic_across_hash_seeds(tmp_path):
    a = _generate_in_subprocess(tmp_path / "a", "1")
    b = _generate_in_subprocess(tmp_path / "b", "4242")
    assert a == b


def test_runtime_imports_and_solves_without_sympy():
    code = (
        "import sys, esba; m = esba.load_model(3); "
        "m.gradient([0.1, 0.2, 0.3], dict(L=135, r1=8, r2=3, d=4, rho=0.17, E=0.54, P=0.1, F1=1, Omega1=1.57, s1=1)); "
        "assert 'sympy' not in sys.modules, 'sympy was imported'"
    )
    subprocess.run([sys.executable, "-c", code], check=True, cwd=ROOT)


def test_missing_model_is_generated_on_demand_by_two_processes_at_once(tmp_path):
    """Two processes ask for the same missing model at the same time: both get a whole, valid file."""
    code = (
        "import esba; m = esba.load_model(2, 'air,axial,payload:3', 'printed'); "
        "print(m.path); assert m.parameters[-1] == 's3'"
    )
    env = dict(os.environ, ESBA_CACHE_DIR=str(tmp_path))
    procs = [subprocess.Popen([sys.executable, "-c", code], env=env, cwd=ROOT, stdout=subprocess.PIPE, text=True) for _ in range(2)]
    outs = [p.communicate(timeout=300) for p in procs]
    assert all(p.returncode == 0 for p in procs)
    paths = {out.strip() for out, _ in outs}
    assert len(paths) == 1
    path = Path(paths.pop())
    assert path.is_relative_to(tmp_path) and path.exists()
    assert not [p for p in path.parent.iterdir() if p.name.startswith(".")], "a temporary file was left behind"


def test_generate_cli_writes_a_model(tmp_path, capsys):
    assert main(["generate", "--segments", "2", "--effects", "axial,gravity", "--out", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert Path(out["file"]).exists() and out["effects"] == "axial,gravity"
    text = Path(out["file"]).read_text()
    assert "M = ca.SX.sym('M')" in text and "F1" not in text and "P = " not in text


@pytest.mark.parametrize(
    "argv,needle",
    [
        (["generate", "--segments", "0"], "segments=0: expected a whole number from 1 to 256"),
        (["generate", "--segments", "-3"], "expected a whole number from 1 to 256"),
        (["generate", "--segments", "2.5"], "segments='2.5': expected a whole number from 1 to 256"),
        (["generate", "--segments", "abc"], "segments='abc'"),
        (["generate", "--segments", "3", "--effects", "air,wind"], "unknown effect 'wind': allowed are air, axial, radial, fibres, payload, gravity"),
        (["generate", "--segments", "3", "--effects", ""], "the effect set is empty"),
        (["generate", "--segments", "3", "--effects", "payload:0"], "payload count must be at least 1"),
        (["generate", "--segments", "3", "--variant", "bogus"], "invalid choice: 'bogus' (choose from 'paper', 'printed')"),
        (["generate"], "generate needs --segments N"),
    ],
)
def test_generate_rejects_bad_input(argv, needle, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, "the error must be one line"
    assert err.startswith("esba: error:") and needle in err


def test_generation_sources_cover_what_emission_imports():
    """Every derive module that the emitter imports is hashed into the provenance."""
    code = (
        "import sys; import esba.derive.emit; "
        "print(' '.join(sorted(m.split('.')[2] + '.py' for m in sys.modules if m.startswith('esba.derive.'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, cwd=ROOT, capture_output=True, text=True).stdout.split()
    from esba.derive.provenance import GENERATION_SOURCES

    assert out and set(out) <= set(GENERATION_SOURCES)


def test_written_files_are_readable_by_others(tmp_path):
    """A model file and its manifest get the mode of a new file of the user's (0644 under umask
    022), not mkstemp's 0600: a shared generated/ or --out folder is readable by the group."""
    old = os.umask(0o022)
    try:
        path, _ = emit.write_model(1, EffectSet.parse("air,axial"), "paper", tmp_path)
    finally:
        os.umask(old)
    for written in (path, tmp_path / emit.MANIFEST):
        assert written.stat().st_mode & 0o777 == 0o644, written

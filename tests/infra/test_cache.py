"""The cache mechanism (esba.infra.cache): atomic writes with a checksum record, checked before use."""

from __future__ import annotations

import pytest

from esba.infra import cache


def test_write_records_checksum_and_mode(tmp_path):
    p = cache.write_text(tmp_path / "sub" / "m.py", "x = 1\n")
    assert cache.damage(p) is None
    assert p.stat().st_mode & 0o777 == 0o644
    assert cache.record_path(p).stat().st_mode & 0o777 == 0o644
    assert sorted(q.name for q in p.parent.iterdir()) == ["m.py", "m.py.sha256"]  # no temporary files left


@pytest.mark.parametrize(
    "spoil, reason",
    [
        (lambda p: p.write_text("x = "), "truncated or changed: 4 bytes, 6 expected"),
        (lambda p: p.write_text("y = 2\n"), "changed since it was written (sha256 differs)"),
        (lambda p: cache.record_path(p).unlink(), "no checksum recorded"),
        (lambda p: cache.record_path(p).write_text("[]"), "its checksum record is unreadable"),
        (lambda p: (p.unlink(), p.mkdir()), "a folder is in its place"),
        (lambda p: p.unlink(), "missing"),
    ],
)
def test_damage_names_the_reason(tmp_path, spoil, reason):
    p = cache.write_text(tmp_path / "m.py", "x = 1\n")
    spoil(p)
    assert cache.damage(p).startswith(reason)
    cache.discard(p)
    assert not p.exists() and not cache.record_path(p).exists()


def test_install_copies_a_file(tmp_path):
    src = tmp_path / "lib.so"
    src.write_bytes(b"\x7fELF" + bytes(100))
    dst = cache.install(tmp_path / "cache" / "lib.so", src)
    assert dst.read_bytes() == src.read_bytes() and cache.damage(dst) is None


def test_usable_root(tmp_path, monkeypatch):
    monkeypatch.setenv("ESBA_CACHE_DIR", str(tmp_path / "c"))
    assert cache.root() == tmp_path / "c"
    assert cache.usable_root() == tmp_path / "c" and (tmp_path / "c").is_dir()
    (tmp_path / "f").write_text("")
    monkeypatch.setenv("ESBA_CACHE_DIR", str(tmp_path / "f"))
    with pytest.raises(cache.CacheError, match=r"ESBA_CACHE_DIR='.*f': '.*f' is a file, expected a folder"):
        cache.usable_root(cache.root() / "models")
    monkeypatch.delenv("ESBA_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.root() == tmp_path / "xdg" / "esba"


def test_model_format_constant_agrees_with_the_generator():
    from esba.derive.emit import FORMAT_VERSION
    from esba.model.generated import MODEL_FORMAT

    assert MODEL_FORMAT == FORMAT_VERSION


def test_committed_models_pass_the_file_check():
    from esba.derive.effects import EffectSet, model_filename
    from esba.derive.emit import COMMITTED
    from esba.derive.provenance import GENERATED_DIR
    from esba.model.generated import model_file_problem

    for n, effects, variant in COMMITTED:
        eff = EffectSet.parse(effects)
        assert model_file_problem(GENERATED_DIR / model_filename(n, eff, variant), n, eff, variant) is None


class _Lines(list):
    """A logging handler that keeps the messages."""

    level = 0

    def handle(self, record):
        self.append(record.getMessage())

    def createLock(self):  # pragma: no cover - logging protocol
        pass


@pytest.mark.parametrize("how", ["truncated", "garbage", "folder", "no-checksum"])
def test_load_model_regenerates_a_damaged_cached_file(tmp_path, monkeypatch, how):
    import logging

    from esba.model import generated as model

    monkeypatch.setenv("ESBA_CACHE_DIR", str(tmp_path))
    model._load.cache_clear()
    lines = _Lines()
    logging.getLogger("esba.model.generated").addHandler(lines)
    try:
        path = model.load_model(1, "air,axial").path
        data = path.read_bytes()
        model._load.cache_clear()
        if how == "truncated":
            path.write_bytes(data[:100])
        elif how == "garbage":
            path.write_bytes(bytes(range(256)) * 4)
        elif how == "folder":
            path.unlink()
            path.mkdir()
        else:
            cache.record_path(path).unlink()
        again = model.load_model(1, "air,axial")
    finally:
        logging.getLogger("esba.model.generated").removeHandler(lines)
        model._load.cache_clear()
    assert again.path == path and path.read_bytes() == data and cache.damage(path) is None
    assert again.energy([0.1], {"L": 135.0, "r1": 8.0, "r2": 3.0, "d": 4.0, "E": 0.54, "P": 0.1}) == pytest.approx(
        model.load_model(1, "air,axial").energy([0.1], {"L": 135.0, "r1": 8.0, "r2": 3.0, "d": 4.0, "E": 0.54, "P": 0.1})
    )
    damaged = [m for m in lines if "is damaged" in m]
    assert len(damaged) == 1 and str(path) in damaged[0]


SO_SCRIPT = """
import sys
from esba.statics import batch
from esba.model.scene import Scene
from esba.model.generated import load_model
m = load_model(3)
v = {**Scene(pressure=0.1).parameters(0.1), "F1": 0.0, "Omega1": 1.5707963, "s1": 1.0}
r = batch.solve_arrays(m, {**v, "P": [0.05, 0.1]}, options=batch.BatchOptions(compile="always", cache=sys.argv[1]))
print(int(r.ok.sum()))
"""


@pytest.mark.skipif(__import__("esba.statics.batch", fromlist=["compiler"]).compiler() is None, reason="needs a C compiler")
def test_truncated_compiled_library_is_rebuilt_not_loaded(tmp_path):
    """Loading a truncated shared library killed the process (a bus error): it is checked first."""
    import subprocess
    import sys

    run = [sys.executable, "-c", SO_SCRIPT, str(tmp_path)]
    first = subprocess.run(run, capture_output=True, text=True)
    assert first.returncode == 0 and first.stdout.strip() == "2", first.stderr
    (lib,) = tmp_path.glob("*.so")
    lib.write_bytes(lib.read_bytes()[:2048])
    again = subprocess.run(run, capture_output=True, text=True)
    assert again.returncode == 0 and again.stdout.strip() == "2", again.stderr
    assert f"compiled batch solver {lib} is damaged (truncated" in again.stderr  # logging's last resort prints warnings
    assert cache.damage(lib) is None and lib.stat().st_mode & 0o777 == 0o644

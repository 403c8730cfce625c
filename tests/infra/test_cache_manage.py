"""esba cache: what the model cache holds by kind, clearing and pruning it, and its bound."""

from __future__ import annotations

import json
import os

import pytest

from esba.cli import EXIT_OK, EXIT_USAGE, main
from esba.infra import cache


@pytest.fixture
def private_cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("ESBA_CACHE_DIR", str(folder))
    monkeypatch.delenv("ESBA_CACHE_MAX", raising=False)
    return folder


def _fill(folder, kind, name, size, age):
    path = cache.write_bytes(folder / kind / name, b"x" * size)
    os.utime(path, (1_000_000 + age, 1_000_000 + age))
    return path


def test_usage_by_kind_and_prune_least_recently_used_first(private_cache):
    old = _fill(private_cache, "functions", "old.casadi", 4000, 0)
    mid = _fill(private_cache, "models", "h/m.py", 3000, 10)
    new = _fill(private_cache, "compiled", "k.so", 2000, 20)
    (private_cache / "notes.txt").write_text("the user's own file")
    u = cache.usage()
    assert u["kinds"]["functions"]["files"] == 1 and u["kinds"]["models"]["files"] == 1 and u["kinds"]["compiled"]["files"] == 1
    assert u["kinds"]["functions"]["bytes"] == 4000 + cache.record_path(old).stat().st_size
    assert u["kinds"]["other"]["files"] == 1
    assert cache.read_verified(old)[1] is None  # a read marks it used: now the newest
    removed = cache.prune(7000)
    assert [f.path for f in removed] == [mid]
    assert old.exists() and new.exists() and not mid.exists() and not cache.record_path(mid).exists()
    assert not (private_cache / "models").exists()  # its empty folders went with it
    cache.clear()
    assert not old.exists() and not new.exists()
    assert (private_cache / "notes.txt").read_text() == "the user's own file"  # only esba's own folders


def test_the_cache_stays_within_its_bound(private_cache, monkeypatch):
    monkeypatch.setenv("ESBA_CACHE_MAX", "10K")
    for i in range(8):
        _fill(private_cache, "functions", f"f{i}.casadi", 3000, i)
    u = cache.usage()
    assert u["bytes"] <= 10 * 1024
    assert (private_cache / "functions" / "f7.casadi").exists()  # the one just written stays


def test_esba_cache_command(private_cache, capsys):
    _fill(private_cache, "functions", "a.casadi", 5000, 0)
    assert main(["cache", "--json"]) == EXIT_OK
    d = json.loads(capsys.readouterr().out)
    assert d["folder"] == str(private_cache) and d["kinds"]["functions"]["files"] == 1 and d["limit_bytes"] == cache.DEFAULT_LIMIT
    assert main(["cache", "prune", "--to", "1K", "--json"]) == EXIT_OK
    d = json.loads(capsys.readouterr().out)
    assert d["removed"]["files"] == 1 and d["files"] == 0
    _fill(private_cache, "export", "x.c", 10, 0)
    assert main(["cache", "clear"]) == EXIT_OK
    assert "removed 1 files" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv, env, says",
    [
        (["cache", "prune", "--to", "lots"], {}, "--to 'lots': expected a size in bytes"),
        (["cache", "--to", "1M"], {}, "--to '1M': goes with `esba cache prune` only"),
        (["cache"], {"ESBA_CACHE_MAX": "-5"}, "ESBA_CACHE_MAX '-5': expected a size in bytes"),
        (["cache", "prune"], {"ESBA_CACHE_MAX": "0"}, "give --to SIZE"),
    ],
)
def test_bad_cache_input_is_one_line(private_cache, capsys, monkeypatch, argv, env, says):
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    assert main(argv) == EXIT_USAGE
    err = capsys.readouterr().err
    assert says in err and err.count("\n") == 1


def test_a_file_in_place_of_the_cache_folder(tmp_path, monkeypatch, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    monkeypatch.setenv("ESBA_CACHE_DIR", str(f))
    assert main(["cache"]) == EXIT_USAGE
    assert "a file, expected a folder" in capsys.readouterr().err

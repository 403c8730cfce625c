"""Built CasADi Functions kept in the cache: read back identical, rebuilt when damaged or
when what built them changed, and a cache that cannot be written costs only the speed."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from esba.infra import fncache
from esba.model.generated import _load, load_model


@pytest.fixture
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("ESBA_CACHE_DIR", str(tmp_path))
    _load.cache_clear()
    yield tmp_path
    _load.cache_clear()


def _square():
    x = ca.SX.sym("x")
    return {"f": ca.Function("f", [x], [x**2]), "g": ca.Function("g", [x], [ca.sin(x)])}


def test_read_back_without_building(private_cache):
    calls = []

    def build():
        calls.append(1)
        return _square()

    a = fncache.cached("t", ["k"], build)
    b = fncache.cached("t", ["k"], build)
    assert calls == [1] and set(b) == {"f", "g"}
    assert float(b["g"](0.5)) == pytest.approx(float(a["g"](0.5)), abs=0)
    fncache.cached("t", ["other key"], build)
    assert calls == [1, 1]  # another key is another file


@pytest.mark.parametrize("damage", ["truncate", "garbage", "folder"])
def test_a_damaged_file_is_rebuilt_not_deserialised(private_cache, damage, caplog):
    fncache.cached("t", ["k"], _square)
    (path,) = (private_cache / "functions").glob("t_*.casadi")
    if damage == "truncate":
        path.write_bytes(path.read_bytes()[:50])
    elif damage == "garbage":
        path.write_bytes(b"\x00garbage" * 10)
    else:
        path.unlink()
        path.mkdir()
    again = fncache.cached("t", ["k"], _square)
    assert float(again["f"](3.0)) == 9.0
    assert "damaged" in caplog.text or "cannot be read" in caplog.text


def test_an_unwritable_cache_only_costs_speed(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("ESBA_CACHE_DIR", str(blocker))
    out = fncache.cached("t", ["k"], _square)
    assert float(out["f"](2.0)) == 4.0


def test_a_model_read_back_is_the_model(private_cache):
    m = load_model(3)
    _load.cache_clear()
    again = load_model(3)  # from the serialised Functions this time
    assert any((private_cache / "functions").glob("m_n003_*.casadi"))
    theta = np.array([0.1, -0.2, 0.3])
    p = m.param_vector(dict(L=135.0, r1=8.0, r2=3.0, d=4.0, rho=0.17, E=0.54, P=0.1, F1=1.0, Omega1=1.5, s1=1.0))
    np.testing.assert_array_equal(again.hessian(theta, p), m.hessian(theta, p))
    np.testing.assert_array_equal(again.gradient(theta, p), m.gradient(theta, p))
    assert again.key == m.key and len(m.key) == 64

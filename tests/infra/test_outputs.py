"""Where commands write (esba.infra.outputs), the checks of output paths, and JSON without NaN."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

from esba.infra import jsonsafe, outputs
from esba.infra.outputs import OutputError

ROOT = Path(__file__).resolve().parents[2]


def test_checkout_detected_only_from_inside(tmp_path, monkeypatch):
    assert outputs.is_checkout()  # the tests run from a checkout
    monkeypatch.chdir(ROOT / "docs")
    assert outputs.checkout_root() == ROOT
    assert outputs.default_page("validation.md") == ROOT / "docs" / "validation.md"
    assert outputs.figures_dir() == ROOT / "docs" / "figures"
    monkeypatch.chdir(tmp_path)
    assert outputs.checkout_root() is None
    assert outputs.default_page("validation.md") == tmp_path / "docs" / "validation.md"
    assert outputs.figures_dir() == tmp_path / "docs" / "figures"
    assert not (tmp_path / "docs").exists()  # looking up where a page is makes nothing
    assert outputs.default_page("validation.md", create=True).parent.is_dir()


def test_pages_of_a_clone_with_a_non_editable_install(tmp_path, monkeypatch):
    """One rule for where pages are: the docs/ of the esba checkout that holds the current folder,
    whichever esba runs (`pip install .` in the clone leaves the package in site-packages)."""
    clone = tmp_path / "clone"
    for d in ("esba", "derive", "generated", "docs/figures"):
        (clone / d).mkdir(parents=True)
    (clone / "pyproject.toml").write_text('[project]\nname = "esba"\n')
    monkeypatch.setattr(outputs, "PACKAGE_ROOT", tmp_path / "site-packages")
    monkeypatch.chdir(clone / "docs" / "figures")
    assert outputs.checkout_root() is None  # not this esba's own checkout: its generated/ is not ours
    assert outputs.enclosing_checkout() == clone
    assert outputs.default_page("validation.md") == clone / "docs" / "validation.md"
    other = tmp_path / "other"
    for d in ("esba", "derive", "generated", "docs"):
        (other / d).mkdir(parents=True)
    (other / "pyproject.toml").write_text('[project]\nname = "something-else"\n')
    monkeypatch.chdir(other)
    assert outputs.enclosing_checkout() is None


def test_an_installed_package_is_not_a_checkout(tmp_path):
    site = tmp_path / "site-packages"
    for d in ("esba", "derive", "generated"):
        (site / d).mkdir(parents=True)
    assert not outputs.is_checkout(site)


def test_check_file(tmp_path):
    ok = tmp_path / "a.csv"
    assert outputs.check_file(ok, "--out", (".csv",)) == ok
    assert not ok.exists()  # checking writes nothing (the probe file is removed)
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "folder.csv").mkdir()
    with pytest.raises(OutputError, match="is a folder, expected a file"):
        outputs.check_file(tmp_path / "folder.csv", "--out")
    with pytest.raises(OutputError, match="expected a file ending in .csv"):
        outputs.check_file(tmp_path / "a.txt", "--out", (".csv",))
    with pytest.raises(OutputError, match="''"):
        outputs.check_file("", "--out")


def test_check_folder_creates_one_level(tmp_path):
    assert outputs.check_folder(tmp_path / "new", "--out").is_dir()
    with pytest.raises(OutputError, match="does not exist"):
        outputs.check_folder(tmp_path / "a" / "b", "--out")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders; the /proc cases in test_hostile cover it")
def test_read_only_folder(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        with pytest.raises(OutputError, match="cannot write into"):
            outputs.check_file(ro / "x.png", "--plot")
    finally:
        ro.chmod(0o700)


def test_figure_file_suffixes(tmp_path):
    assert ".png" in outputs.figure_suffixes() and ".pdf" in outputs.figure_suffixes()
    assert outputs.figure_file(tmp_path / "a.PDF", "--plot", "x.png").name == "a.PDF"
    assert outputs.figure_file(tmp_path / "a", "--plot", "x.png").name == "a.png"
    assert outputs.figure_file(tmp_path, "--plot", "x.png") == tmp_path / "x.png"


def test_jsonsafe_replaces_non_finite_numbers():
    data = {
        "a": math.nan,
        "b": [1.0, math.inf],
        "c": {"d": np.float64("nan"), "e": np.array([1.0, np.nan])},
        "f": np.int64(3),
        "g": None,
        "g_reason": "given",
        "h": [[1.0, -math.inf]],
    }
    text = jsonsafe.dumps(data, sort_keys=True)
    back = json.loads(text, parse_constant=lambda name: pytest.fail(name))
    assert back["a"] is None and back["a_reason"] == "not a number"
    assert back["b"] == [1.0, None] and back["b_reason"] == "element 1 is infinite"
    assert back["c"] == {"d": None, "d_reason": "not a number", "e": [1.0, None], "e_reason": "element 1 is not a number"}
    assert back["f"] == 3 and back["g"] is None and back["g_reason"] == "given"
    assert back["h"] == [[1.0, None]] and back["h_reason"] == "element 0.1 is infinite"

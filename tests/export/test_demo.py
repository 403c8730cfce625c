"""The export's folder on its own: its Makefile builds the demo, which reproduces the example line
its README documents (computed by esba's Python solver when the export was written)."""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest

from esba.analysis.stiffness import pressure_for_target
from esba.model.scene import Payload, Scene


def _documented(readme: str) -> tuple[str, str]:
    m = re.search(r"^    \$ echo '([^']*)' \| \./demo\n    (.+)$", readme, flags=re.M)
    assert m, "the README documents no example line"
    return m.group(1), m.group(2)


def _make(folder, *targets):
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    return subprocess.run(["make", *targets], cwd=folder, capture_output=True, text=True)


def _demo(folder, text: str, *flags):
    return subprocess.run(["./demo", *flags], cwd=folder, input=text, capture_output=True, text=True)


def test_the_demo_built_by_make_alone_prints_the_documented_line(exports, tmp_path):
    export, _ = exports(3, library=False)
    folder = tmp_path / "alone"
    shutil.copytree(export.folder, folder)  # nothing but the export's own files
    build = _make(folder)
    assert build.returncode == 0, build.stderr
    assert _make(folder, "check").returncode == 0  # every warning an error
    line_in, line_out = _documented((folder / "README.md").read_text())
    assert line_in == export.example_input and line_out == export.example_output
    run = _demo(folder, f"# a comment\n\n{line_in}\n")
    assert run.returncode == 0 and run.stdout.strip() == line_out


def test_the_float_demo_agrees_with_the_documented_line_to_its_precision(exports, tmp_path):
    export, _ = exports(3, "float", library=False)
    assert _make(export.folder).returncode == 0
    line_in, line_out = _documented((export.folder / "README.md").read_text())
    got = _demo(export.folder, line_in + "\n").stdout.split()
    want = line_out.split()
    assert [w for w in got if not _number(w)] == [w for w in want if not _number(w)]
    for g, w in zip(got, want):
        if _number(w):
            assert abs(float(g) - float(w)) <= 2e-3  # 4 decimals of degrees, 3 of mm: the last one may move


def _number(word: str) -> bool:
    return re.fullmatch(r"-?\d+\.\d+", word) is not None


def test_the_inverse_demo_and_bad_lines(exports):
    export, _ = exports(3, library=False)
    assert _make(export.folder).returncode == 0
    run = _demo(export.folder, "90 2 90\n", "-i")
    words = run.stdout.split()
    assert run.returncode == 0 and words[0] == "pressure_mpa" and words[words.index("status") + 1] == "ok"
    py = pressure_for_target(Scene(payloads=(Payload(2.0, 90.0),)), total_angle_deg=90.0)
    assert abs(float(words[1]) - py.pressure) < 1e-7  # printed to 7 decimals
    # at 0.1716 MPa inflating first curls the actuator past the load: both say the scene is multistable
    assert not py.on_load_path and words[-2:] == ["flags", "multistable"]
    bad = _demo(export.folder, "0.1 2\n-0.1 2 90\n0.1 two 90\n")
    assert bad.returncode == 1
    assert "line 1: expected" in bad.stderr and "line 3: expected" in bad.stderr
    assert bad.stdout.strip().endswith("status bad_input") and "nan" not in bad.stdout.lower()

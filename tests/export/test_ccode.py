"""The exported C as C: strict C99 without a warning, libm only, nothing global written, no
allocation, every loop bounded; single precision really single; the generated part cached."""

from __future__ import annotations

import re
import subprocess

import pytest

from esba.export.build import STRICT, check_strict, object_size, run_compiler
from esba.export.ccode import ExportError, ExportSpec, casadi_code, render_source

#: What an export may call: libm, and the few functions GCC may call from any code, freestanding or
#: not, for loops it turns into them (memset, memcpy, memmove; GCC's documented requirement).
LIBM = {"sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "exp", "log", "log1p", "expm1", "sqrt", "cbrt", "pow",
        "fabs", "fmin", "fmax", "floor", "ceil", "erf", "fmod", "copysign", "hypot", "sincos"}
ALLOWED = LIBM | {f + "f" for f in LIBM} | {"memset", "memcpy", "memmove"}


def _undefined(obj) -> set[str]:
    out = subprocess.run(["nm", "-u", str(obj)], capture_output=True, text=True, check=True).stdout
    return {line.split()[-1] for line in out.splitlines() if line.strip()}


@pytest.mark.parametrize(
    "n, effects, precision",
    [(3, None, "double"), (3, None, "float"), (1, None, "double"), (2, "air,axial,radial,fibres,payload:2,gravity", "double"),
     (2, "air,axial,radial", "float"), (2, "axial,radial,payload", "double")],
    ids=["n3", "n3-float", "n1", "n2-two-payloads-gravity", "n2-no-payload-float", "n2-no-pressure"],
)
def test_strict_c99_without_a_warning_libm_only_nothing_global(exports, cc, tmp_path, n, effects, precision):
    export, _ = exports(n, precision, effects, library=False)
    extra = ["-Wdouble-promotion"] if precision == "float" else []  # nothing computed in double
    assert check_strict(export.folder / "demo.c", cc, extra) == ""
    obj = tmp_path / "model.o"
    proc = run_compiler(cc, [*STRICT, *extra, "-O2", "-c", str(export.source), "-o", str(obj)])  # -Werror: a warning fails
    assert proc.stderr.strip() == ""
    size = object_size(obj)
    assert size["data"] == 0 and size["bss"] == 0  # no global or static variable: re-entrant
    assert _undefined(obj) <= ALLOWED, _undefined(obj) - ALLOWED


def test_no_allocation_no_unbounded_loop_in_the_source(exports):
    export, _ = exports(3, library=False)
    text = export.source.read_text()
    code = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    assert not re.search(r"\b(malloc|calloc|realloc|free|alloca)\s*\(", code)
    assert not re.search(r"\bwhile\s*\(|\bgoto\b|for\s*\(\s*;\s*;", code)  # every loop is a for with a bound
    header = export.header.read_text()
    assert "DO NOT MODIFY BY HAND" in header and "DO NOT MODIFY BY HAND" in text


def test_single_precision_calls_float_libm_only(exports, tmp_path, cc):
    export, _ = exports(3, "float", library=False)
    obj = tmp_path / "f.o"
    run_compiler(cc, ["-std=c99", "-O2", "-c", str(export.source), "-o", str(obj)])
    calls = _undefined(obj) - {"memset", "memcpy", "memmove"}
    assert calls and all(name.endswith("f") for name in calls), calls


def test_the_generated_part_is_cached(exports, monkeypatch):
    export, _ = exports(3, library=False)
    spec = ExportSpec(3)

    def generate_again(*args, **kwargs):
        raise AssertionError("the generated part was generated again, not read back from the cache")

    monkeypatch.setattr("esba.export.ccode.model_functions", generate_again)
    code, sizes = casadi_code(spec)
    assert code in export.source.read_text()
    assert set(sizes) == {"arg", "res", "iw", "w"} and min(sizes.values()) >= 1
    header, source = render_source(spec, "esba export c --segments 3 --out DIR")
    assert header.startswith("/* esba_n3_air_axial_radial_fibres_payload1_paper.h")


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"n": 0}, "segments=0: expected a whole number from 1 to 256"),
        ({"n": 257}, "segments=257"),
        ({"n": 3, "effects": "air,bogus"}, "unknown effect 'bogus'"),
        ({"n": 3, "variant": "typo"}, "unknown variant 'typo'"),
        ({"n": 3, "precision": "half"}, "precision='half': allowed are double, float"),
    ],
)
def test_export_spec_refuses_what_is_not_allowed(kwargs, message):
    with pytest.raises(ExportError, match=re.escape(message)):
        ExportSpec(**kwargs)

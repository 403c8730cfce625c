"""Hostile input to the export's demo program, built with AddressSanitizer and
UndefinedBehaviorSanitizer (every finding fatal): long lines, empty input, binary garbage, NaN, inf
and huge numbers, a folder as standard input, a full disk as standard output, many lines.

The demo must read every line whole or refuse it naming the line, answer each line it reads with a
status (never NaN), and exit 1 with a message when a line is refused, standard input cannot be read
or standard output cannot be written. One build of the demo (a few seconds) serves the module.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess

import pytest

from esba.export.binding import STATUS

#: The sanitizers, every finding fatal; float-cast-overflow is not in gcc's "undefined".
SANITIZE = ("-fsanitize=address,undefined,float-cast-overflow", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer")
#: What the demo answers the README's example with (Table 1 at 0.12 MPa, 2 N horizontal).
EXAMPLE = "0.12 2 90"
ENV = dict(os.environ, ASAN_OPTIONS="detect_leaks=1:abort_on_error=0:exitcode=99", UBSAN_OPTIONS="halt_on_error=1:exitcode=98")


@pytest.fixture(scope="module")
def demo(exports, tmp_path_factory):
    """The demo of n = 3 in double and in float, built with the sanitizers: {precision: (path, example line)}."""
    gcc = shutil.which("gcc")
    if gcc is None:
        pytest.skip("needs gcc (its AddressSanitizer and UndefinedBehaviorSanitizer)")
    built = {}
    for precision in ("double", "float"):
        export, _ = exports(3, precision, library=False)
        out = tmp_path_factory.mktemp(f"sanitized-{precision}") / "demo"
        proc = subprocess.run(
            [gcc, "-std=c99", "-g", "-O1", *SANITIZE, "-o", str(out), "demo.c", export.source.name, "-lm"],
            cwd=export.folder, capture_output=True, text=True,
        )
        if proc.returncode != 0 and re.search(r"cannot find .*(asan|ubsan)|unrecognized .*sanitize", proc.stderr):
            pytest.skip(f"gcc has no sanitizer runtime here: {proc.stderr.strip().splitlines()[-1]}")
        assert proc.returncode == 0, proc.stderr
        built[precision] = (out, export.example_output)
    return built


def run(program, data: bytes = b"", *args, stdin=None, stdout=subprocess.PIPE):
    proc = subprocess.run([str(program), *args], input=None if stdin is not None else data, stdin=stdin, stdout=stdout,
                          stderr=subprocess.PIPE, env=ENV, timeout=120)
    err = proc.stderr.decode(errors="replace")
    assert "Sanitizer" not in err and "runtime error" not in err, err[-3000:]
    assert proc.returncode in (0, 1, 2), (proc.returncode, err[-3000:])
    out = proc.stdout.decode(errors="replace") if proc.stdout is not None else ""
    assert "nan" not in out.lower() and "inf" not in out.lower(), out[-2000:]
    for line in out.splitlines():
        assert re.search(r" status [a-z_]+( flags [a-z_,]+)?$", line), line
    return proc.returncode, out, err


@pytest.mark.parametrize("precision", ["double", "float"])
def test_a_long_line_is_read_whole(demo, precision):
    """1015 spaces before the example: the same answer as the example, one line, not two."""
    program, example = demo[precision]
    code, out, err = run(program, b" " * 1015 + EXAMPLE.encode() + b"\n")
    assert code == 0 and err == "" and len(out.splitlines()) == 1
    if precision == "double":
        assert out.strip() == example


def test_a_line_past_the_limit_is_refused_naming_it(demo):
    program, example = demo["double"]
    data = b" " * 5000 + EXAMPLE.encode() + b"\n" + EXAMPLE.encode() + b"\n" + b"1" * 200_000  # the last one has no newline
    code, out, err = run(program, data)
    assert code == 1 and out.strip() == example  # line 2 alone is answered
    assert err.splitlines() == ["line 1: longer than 4096 bytes: refused", "line 3: longer than 4096 bytes: refused"]
    code, out, err = run(program, b" " * 4087 + EXAMPLE.encode() + b"\n")  # 4096 bytes exactly: read
    assert code == 0 and out.strip() == example


@pytest.mark.parametrize("data", [b"", b"\n", b"# only a comment\n\n   \n", b"\r\n"], ids=["empty", "newline", "comments", "crlf"])
def test_nothing_to_answer(demo, data):
    code, out, err = run(demo["double"][0], data)
    assert (code, out, err) == (0, "", "")


@pytest.mark.parametrize("precision", ["double", "float"])
def test_binary_garbage(demo, precision):
    garbage = bytes((i * 131 + 7 * (i >> 5)) % 256 for i in range(40_000))  # every byte, NULs among them
    code, out, err = run(demo[precision][0], garbage)
    assert code == 1 and "holds a NUL byte" in err
    code, out, err = run(demo[precision][0], garbage.replace(b"\0", b"x"), "-i")
    assert code == 1 and "expected" in err


@pytest.mark.parametrize("precision", ["double", "float"])
def test_nan_inf_and_huge_numbers_get_a_status(demo, precision):
    refused = ["nan 2 90", "inf 2 90", "-inf 2 90", "0.1 1e999 90", "0.1 nan(123) 90", "0.1 2 90 nan", "0.1 2 90 inf", "-1e-30 0 0"]
    # answered with some status (float turns what it cannot hold into an infinity: bad input)
    extreme = ["1e308 2 90", "0.1 2 1e308", "0.1 1e39 90", "0.1 2 90 1e-320", "1e-320 1e-320 1e-320", "0x1p-3 2 90", "-0 -0 -0"]
    code, out, err = run(demo[precision][0], ("\n".join(refused + extreme) + "\n").encode())
    assert code == 0 and err == ""
    statuses = [line.split(" status ")[1].split()[0] for line in out.splitlines()]
    assert statuses[: len(refused)] == ["bad_input"] * len(refused)
    assert len(statuses) == len(refused) + len(extreme) and set(statuses) <= set(STATUS)
    code, out, err = run(demo[precision][0], b"nan 2 90\n1e999 2 90\n-1e999 2 90\n", "-i")
    assert code == 0 and [line.split(" status ")[1] for line in out.splitlines()] == ["bad_input"] * 3


def test_a_folder_as_standard_input(demo, tmp_path):
    folder = os.open(tmp_path, os.O_RDONLY)  # what the shell opens for ./demo < .
    try:
        code, out, err = run(demo["double"][0], stdin=folder)
    finally:
        os.close(folder)
    assert code == 1 and out == "" and "cannot read standard input" in err and len(err.splitlines()) == 1


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (a device whose writes fail: disk full)")
@pytest.mark.parametrize("lines", [1, 3000])
def test_a_full_disk_as_standard_output(demo, lines):
    with open("/dev/full", "wb") as full:
        code, _, err = run(demo["double"][0], (EXAMPLE + "\n").encode() * lines, stdout=full)
    assert code == 1 and "cannot write standard output (No space left on device)" in err and len(err.splitlines()) == 1


def test_many_lines_and_many_numbers(demo):
    program, example = demo["double"]
    code, out, err = run(program, (EXAMPLE + "\n").encode() * 3000)
    assert code == 0 and err == "" and out.splitlines() == [example] * 3000
    wide = " ".join(["0.1"] * 64) + "\n" + " ".join(["0.1"] * 65) + "\n" + ",".join(["0.1"] * 3) + "\n"
    code, out, err = run(program, wide.encode())
    assert code == 1 and err.splitlines()[0].startswith("line 1: expected") and err.splitlines()[1].startswith("line 2: expected")
    assert len(out.splitlines()) == 1  # the comma-separated line


def test_bad_arguments(demo):
    code, out, err = run(demo["double"][0], b"", "-x")
    assert code == 2 and "usage:" in err
    code, out, err = run(demo["double"][0], b"", "-i", "extra")
    assert code == 2 and "usage:" in err

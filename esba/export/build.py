"""Compile and measure an export with the system's compilers: the strict warning check, a shared
library for :mod:`esba.export.binding`, object sizes (``size``) and stack use (``-fstack-usage``,
``-fcallgraph-info``), for the host and for a Cortex-M4 (``arm-none-eabi-gcc``, where installed).

Examples
--------
>>> STRICT
('-std=c99', '-Wall', '-Wextra', '-Werror', '-pedantic')
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from esba.infra.errors import RunError

__all__ = [
    "STRICT",
    "CORTEX_M4",
    "ARM_INSTALL",
    "BuildError",
    "compiler",
    "arm_compiler",
    "run_compiler",
    "check_strict",
    "compile_shared",
    "object_size",
    "StackUse",
    "stack_use",
]

#: The warnings an export compiles under without a message (the issue's flags).
STRICT = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic")
#: The Cortex-M4 build of the benchmark: hard float on the single-precision FPU, optimised for size.
CORTEX_M4 = ("-mcpu=cortex-m4", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv4-sp-d16", "-Os")
#: How to install the Cortex-M compiler on Debian or Ubuntu.
ARM_INSTALL = "apt-get install gcc-arm-none-eabi"


class BuildError(RunError):
    """A compiler that failed on an export: the message holds its first lines."""


def compiler() -> str | None:
    """The host's C compiler: ``$CC``, else ``gcc``, else ``cc`` (None when there is none)."""
    for name in (os.environ.get("CC"), "gcc", "cc"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def arm_compiler() -> str | None:
    """``arm-none-eabi-gcc`` when it is installed (Debian: ``gcc-arm-none-eabi``)."""
    return shutil.which("arm-none-eabi-gcc")


def run_compiler(cc: str, args: Sequence[str], cwd: str | Path | None = None) -> subprocess.CompletedProcess:
    """Run ``cc args``; :class:`BuildError` with its first 40 lines of messages when it fails."""
    proc = subprocess.run([cc, *args], capture_output=True, text=True, cwd=cwd)
    if proc.returncode != 0:
        lines = (proc.stderr or proc.stdout).strip().splitlines()
        raise BuildError(f"{Path(cc).name} {' '.join(args)} failed:\n" + "\n".join(lines[:40]))
    return proc


def check_strict(source: str | Path, cc: str | None = None, extra: Sequence[str] = ()) -> str:
    """Compile ``source`` with :data:`STRICT` (and ``extra``) to nothing; returns the compiler's
    messages (empty: no warning), raises :class:`BuildError` on any."""
    cc = cc or compiler()
    if cc is None:
        raise BuildError("no C compiler found ($CC, gcc, cc)")
    source = Path(source)
    proc = run_compiler(cc, [*STRICT, *extra, "-c", source.name, "-o", os.devnull], cwd=source.parent)
    return proc.stderr.strip()


def compile_shared(source: str | Path, out: str | Path | None = None, cc: str | None = None, opt: str = "-O2") -> Path:
    """A shared library of the export's source (for :class:`esba.export.binding.Library`)."""
    cc = cc or compiler()
    if cc is None:
        raise BuildError("no C compiler found ($CC, gcc, cc)")
    source = Path(source)
    out = source.with_suffix(".so") if out is None else Path(out)
    run_compiler(cc, ["-std=c99", opt, "-shared", "-fPIC", str(source), "-o", str(out), "-lm"])
    return out


def object_size(obj: str | Path, tool: str = "size") -> dict[str, int]:
    """``size`` of an object file: text, data and bss bytes (Berkeley format)."""
    proc = subprocess.run([tool, str(obj)], capture_output=True, text=True, check=True)
    fields = proc.stdout.strip().splitlines()[-1].split()
    return {"text": int(fields[0]), "data": int(fields[1]), "bss": int(fields[2])}


@dataclass(frozen=True)
class StackUse:
    """Stack use of an object's functions (bytes): each frame (``-fstack-usage``) and the deepest
    chain of calls from each function (``-fcallgraph-info``; libm calls count as 0)."""

    frames: dict[str, int]
    deepest: dict[str, int]
    dynamic: tuple[str, ...]  # functions whose frame is not static (none expected)


def _parse_su(text: str) -> tuple[dict[str, int], list[str]]:
    frames, dynamic = {}, []
    for line in text.splitlines():
        parts = line.split("\t")
        if len(parts) < 3:
            continue
        name = parts[0].rsplit(":", 1)[-1]
        frames[name] = int(parts[1])
        if parts[2].strip() != "static":
            dynamic.append(name)
    return frames, dynamic


def _parse_ci(text: str) -> dict[str, list[str]]:
    """Call edges of a ``-fcallgraph-info`` file (VCG): caller -> callees, by function name."""
    titles: dict[str, str] = {}
    for m in re.finditer(r'node:\s*\{\s*title:\s*"([^"]+)"\s*label:\s*"([^"\\]+)', text):
        titles[m.group(1)] = m.group(2).split("\\n")[0]
    edges: dict[str, list[str]] = {}
    for m in re.finditer(r'edge:\s*\{\s*sourcename:\s*"([^"]+)"\s*targetname:\s*"([^"]+)"', text):
        src = titles.get(m.group(1), m.group(1)).split(":")[-1]
        dst = titles.get(m.group(2), m.group(2)).split(":")[-1]
        edges.setdefault(src, []).append(dst)
    return edges


def stack_use(source: str | Path, cc: str, flags: Sequence[str], workdir: str | Path) -> StackUse:
    """Compile ``source`` with ``flags -fstack-usage -fcallgraph-info=su`` in ``workdir`` and read both."""
    workdir = Path(workdir)
    obj = workdir / (Path(source).stem + ".o")
    run_compiler(cc, ["-std=c99", *flags, "-fstack-usage", "-fcallgraph-info=su", "-c", str(Path(source).resolve()), "-o", str(obj)], cwd=workdir)
    frames, dynamic = _parse_su(obj.with_suffix(".su").read_text(encoding="utf-8"))
    ci = obj.with_suffix(".ci")
    edges = _parse_ci(ci.read_text(encoding="utf-8")) if ci.exists() else {}
    deepest: dict[str, int] = {}

    def depth(name: str, seen: frozenset) -> int:
        if name in deepest:
            return deepest[name]
        if name in seen:  # recursion would be unbounded: there is none, but do not loop
            return frames.get(name, 0)
        below = [depth(c, seen | {name}) for c in edges.get(name, []) if c != name]
        value = frames.get(name, 0) + (max(below) if below else 0)
        deepest[name] = value
        return value

    for name in frames:
        depth(name, frozenset())
    return StackUse(frames=frames, deepest=deepest, dynamic=tuple(dynamic))

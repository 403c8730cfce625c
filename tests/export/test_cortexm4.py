"""The Cortex-M4 instruction counts of ``esba bench embedded`` (esba.bench.cortexm4): the cycle
table, the counting of a qemu log, and (where arm-none-eabi-gcc and qemu-arm are installed) a real
count checked against qemu's single-step count and the host's equilibrium."""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest

from esba.bench import cortexm4
from esba.bench.cortexm4 import CLOCK_HZ, count_blocks, instruction_cycles
from esba.export import build


@pytest.mark.parametrize("mnemonic, operands, taken, cycles", [
    ("movs", "r2, #0", False, (1, 1)),
    ("orrsne.w", "r3, r3, r2", False, (1, 1)),   # flag-setting and conditional (objdump's order)
    ("addseq", "r0, r1", False, (1, 1)),
    ("lsls", "r3, r3, #1", False, (1, 1)),      # not "ls" + "ls"
    ("bics", "r3, r2", False, (1, 1)),          # not "bi" + "cs"
    ("teq", "r1, r2", False, (1, 1)),
    ("ldr.w", "r3, [r4, #8]", False, (1, 2)),
    ("ldrd", "r2, r3, [r0]", False, (2, 3)),
    ("udiv", "r0, r1, r2", False, (2, 12)),
    ("mla", "r0, r1, r2, r3", False, (2, 2)),
    ("bne.n", "80a4", False, (1, 1)),           # a conditional branch not taken
    ("bne.n", "80a4", True, (2, 4)),            # taken: a pipeline refill of 1 to 3
    ("bl", "102e2", True, (2, 4)),
    ("bx", "lr", True, (2, 4)),
    ("cbz", "r0, 8100", False, (1, 1)),
    ("tbb", "[pc, r3]", True, (3, 5)),
    ("push", "{r4, r5, r6, lr}", False, (5, 5)),
    ("stmdb", "sp!, {r4, r5, r6, r7, r8, lr}", False, (7, 7)),
    ("pop", "{r4, r5, pc}", True, (5, 7)),
    ("ldmia.w", "sp!, {r4, r5, r6, r7, r8, pc}", True, (8, 10)),
    ("vpush", "{s16-s19}", False, (5, 5)),
    ("vpop", "{d8-d9}", False, (5, 5)),         # two double registers: four words
    ("it", "eq", False, (0, 1)),
    ("itte", "ne", False, (0, 1)),
    ("iteet", "gt", False, (0, 1)),             # every IT form, not a list of some
    ("vadd.f32", "s0, s1, s2", False, (1, 1)),
    ("vmlane.f32", "s0, s1, s2", False, (3, 3)),
    ("vfma.f32", "s0, s1, s2", False, (3, 3)),
    ("vdiv.f32", "s0, s1, s2", False, (14, 14)),
    ("vsqrt.f32", "s0, s1", False, (14, 14)),
    ("vldr", "s14, [r4, #312]", False, (2, 2)),
    ("vldr", "d7, [r4]", False, (3, 3)),
    ("vmov", "r0, r1, d0", False, (2, 2)),
])
def test_cycles_of_an_instruction(mnemonic, operands, taken, cycles):
    assert instruction_cycles(mnemonic, operands, taken) == cycles


@pytest.mark.parametrize("mnemonic", ["vadd.f64", "vdiv.f64", "frobnicate", "wfi"])
def test_an_instruction_the_table_does_not_know_is_none(mnemonic):
    """Double-precision VFP does not exist on the M4's FPU; an unknown mnemonic is reported, not guessed."""
    assert instruction_cycles(mnemonic, "d0, d1, d2", False) is None


def _log(blocks: dict[int, list[int]], executed: list[tuple[int, str]]) -> list[str]:
    """A qemu -d in_asm,exec,nochain log: each block translated once (its instructions' sizes), then
    executed in the order given (pc, symbol)."""
    lines, translated = [], set()
    for pc, sym in executed:
        if pc not in translated:
            translated.add(pc)
            lines += ["----------------", f"IN: {sym}"]
            at = pc
            for size in blocks[pc]:
                code = "0000 0000 " if size == 4 else "0000      "
                lines.append(f"0x{at:08x}:  {code} whatever")
                at += size
            lines.append("")
        lines.append(f"Trace 0: 0x7f0000000000 [00800480/{pc:08x}/00000000/00000200] {sym}")
    return lines


def test_count_blocks_counts_each_stretch_between_markers_and_taken_branches():
    decoded = {
        0x100: (2, "bx", "lr"),                         # the marker
        0x200: (2, "movs", "r0, #1"), 0x202: (4, "bl", "300"),
        0x206: (2, "adds", "r0, #1"), 0x208: (4, "bl", "100"),
        0x300: (2, "cmp", "r0, #3"), 0x302: (2, "bne.n", "300"), 0x304: (2, "bx", "lr"),
    }
    blocks = {0x100: [2], 0x200: [2, 4], 0x206: [2, 4], 0x300: [2, 2], 0x304: [2]}
    # marker, main (call), loop taken once then falls through, return, main (call marker), marker
    executed = [(0x100, "mark"), (0x200, "main"), (0x300, "f"), (0x300, "f"), (0x304, "f"), (0x206, "main"), (0x100, "mark")]
    (one,) = count_blocks(_log(blocks, executed), "mark", decoded)
    assert one.instructions == 2 + 2 + 2 + 1 + 2
    # movs 1, bl taken 2..4, cmp 1, bne taken 2..4, cmp 1, bne not taken 1, bx taken 2..4, adds 1, bl taken 2..4
    assert (one.cycles_min, one.cycles_max) == (1 + 2 + 1 + 2 + 1 + 1 + 2 + 1 + 2, 1 + 4 + 1 + 4 + 1 + 1 + 4 + 1 + 4)
    assert one.unknown == ()
    assert one.us_min == pytest.approx(1e6 * one.cycles_min / CLOCK_HZ)


def test_count_blocks_refuses_a_log_without_translations():
    with pytest.raises(ValueError, match="before it was translated"):
        count_blocks(["Trace 0: 0x7f00 [00800480/00000100/00000000/00000200] mark",
                      "Trace 0: 0x7f00 [00800480/00000200/00000000/00000200] main"], "mark", {})


@pytest.fixture(scope="module")
def tools():
    arm, qemu = build.arm_compiler(), cortexm4.qemu_arm()
    if arm is None:
        pytest.skip(f"arm-none-eabi-gcc is not installed ({build.ARM_INSTALL}): no Cortex-M4 build to count")
    if qemu is None:
        pytest.skip(f"qemu-arm is not installed ({cortexm4.QEMU_INSTALL}): the Cortex-M4 build cannot be run here")
    return arm, qemu


SCENES = ((0.12, 2.0, 90.0, 1.0), (0.005, 5.0, 180.0, 0.9))  # the README's scene; one that snaps


def _singlestep_count(elf, qemu) -> list[int]:
    """qemu's own count, one instruction per block (-singlestep): the instructions between markers."""
    proc = subprocess.run([qemu, "-cpu", "max", "-singlestep", "-d", "exec,nochain", str(elf)], capture_output=True, text=True, check=True)
    counts, inside = [], None
    for line in proc.stderr.splitlines():
        if not line.startswith("Trace"):
            continue
        if line.rstrip().endswith(" esba_m4_mark"):
            if inside is None:
                inside = 0
            else:
                counts.append(inside)
                inside = None
        elif inside is not None:
            inside += 1
    return counts


@pytest.mark.parametrize("precision", ["float", "double"])
def test_m4_counts_match_qemus_single_step_and_the_host(precision, tools, exports, tmp_path):
    from esba.bench.embedded import run_driver

    arm, qemu = tools
    export, _ = exports(3, precision=precision, library=False)
    scenes = [{"pressure": p, "payload[0].force": f, "payload[0].angle": math.radians(a), "payload[0].at": s} for p, f, a, s in SCENES]
    chosen = scenes if precision == "float" else scenes[:1]
    counts, results = cortexm4.m4_equilibrium_counts(export.folder, export.spec.name, 3, chosen, "theta", 3, tmp_path, arm, qemu)
    assert len(counts) == len(results) == len(chosen)
    # the blocks expanded by objdump's decoding count exactly what qemu executes one by one
    elf = next(tmp_path.glob("count_*.elf"))
    assert [c.instructions for c in counts] == _singlestep_count(elf, qemu)
    for c in counts:
        assert c.unknown == ()
        assert 0 < c.instructions and 0 < c.cycles_min < c.cycles_max  # IT costs 0 at the fewest: no tighter rule holds
    # the M4 computes the host's equilibrium: the same status, the state to the precision's last bits
    from esba.bench.embedded import _build_driver

    exe = _build_driver(export, build.compiler(), tmp_path)
    _, host = run_driver(exe, [("e", *sc) for sc in SCENES[: len(chosen)]], 1)
    tol = 1e-5 if precision == "float" else 1e-12
    for (status, theta), h in zip(results, host):
        assert status == h["status"]
        assert np.max(np.abs(np.asarray(theta) - h["theta"])) < tol
    if precision == "float":
        assert [s for s, _ in results] == [0, 2]  # ok; snapped (the second scene snaps on its load path)
    data = cortexm4.summary(counts, results, [(h["status"], h["theta"]) for h in host])
    assert data["statuses_as_host"] and data["unknown_mnemonics"] == []
    assert data["us_min_median"] == pytest.approx(np.median([1e6 * c.cycles_min / CLOCK_HZ for c in counts]))

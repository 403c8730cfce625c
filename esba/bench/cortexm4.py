"""Cycles per equilibrium on a Cortex-M4, estimated from an emulated run (``esba bench embedded``).

A time on a Cortex-M4 needs the chip. What can be had without one, and what this module gives, is
the exact stream of instructions the chip would execute and an estimate of its cycles:

1. the export and a small driver are built for the M4 exactly as ``make cortex-m4`` builds the
   model (``arm-none-eabi-gcc -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16 -Os``),
   linked as a Linux program (its own ``_start``, output by the ``write`` system call);
2. ``qemu-arm`` (Debian's ``qemu-user``) runs it and logs every block of instructions it translates
   (``-d in_asm``) and every block it executes (``-d exec,nochain``: no chaining, so that no
   execution goes unlogged). The driver calls a marker function before and after each equilibrium,
   so each equilibrium's blocks are counted alone;
3. each executed instruction is given its cycles from the Cortex-M4's technical reference manual
   (ARM DDI 0439B, Table 3-1, and the FPU's Table 7-1) as a range: a load 1 to 2 cycles (2, or 1
   when it pipelines with its neighbour), a taken branch 1 + P with a pipeline refill P of 1 to 3,
   a division 2 to 12, ``IT`` 0 to 1, ``VDIV``/``VSQRT`` 14, and so on
   (:data:`CYCLES`). Whether a branch was taken is read from the next executed block.

The range assumes memory without wait states (code and data in zero-wait-state RAM, or flash
behind an accelerator that hides its wait states, as the STM32F4's ART does for most code); a part
that fetches from slow flash without a cache is slower. Microseconds are the cycles at
:data:`CLOCK_HZ`. The driver prints each result's status and state as the bits of its doubles, so
the run is seen to compute the same equilibrium as the host.

qemu 7.2's ``-cpu cortex-m4`` aborts in user mode on an assertion in its page table; the program is
therefore run as ``-cpu max``, an A-profile core that executes the same Thumb-2 and VFPv4
instructions. The instructions counted are those of the M4 build; qemu's timing is not used.
"""

from __future__ import annotations

import re
import shutil
import statistics
import struct
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from esba.export import build

__all__ = ["CLOCK_HZ", "CYCLES", "QEMU_INSTALL", "M4Count", "qemu_arm", "instruction_cycles", "disassemble", "count_blocks", "m4_equilibrium_counts", "summary"]

#: The clock the microseconds are given at: an STM32F405/407's 168 MHz.
CLOCK_HZ = 168e6
#: How to get qemu-arm on Debian or Ubuntu.
QEMU_INSTALL = "apt-get install qemu-user"

_CONDITIONS = ("eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le", "al")

#: Cycles (fewest, most) of one instruction by mnemonic (without condition, width or data type
#: suffix), from the Cortex-M4 TRM (DDI 0439B) Table 3-1 and its FPU's Table 7-1, memory without
#: wait states. Branches, loads of several registers and the FPU's multiple loads are costed by
#: :func:`instruction_cycles` (they depend on whether the branch is taken and on the registers).
CYCLES: dict[str, tuple[int, int]] = {
    **{m: (1, 1) for m in (
        "mov", "movw", "movt", "mvn", "add", "addw", "adc", "sub", "subw", "sbc", "rsb", "neg", "and", "orr", "orn", "eor", "bic",
        "lsl", "lsr", "asr", "ror", "rrx", "cmp", "cmn", "tst", "teq", "adr", "sxtb", "sxth", "uxtb", "uxth", "sxtab", "sxtah", "uxtab",
        "uxtah", "ubfx", "sbfx", "bfi", "bfc", "clz", "rbit", "rev", "rev16", "revsh", "nop", "usat", "ssat", "mul", "umull", "smull",
        "umlal", "smlal", "uadd8", "usub8", "sel", "qadd", "qsub")},
    "mla": (2, 2), "mls": (2, 2),
    "sdiv": (2, 12), "udiv": (2, 12),
    **{m: (1, 2) for m in ("ldr", "ldrb", "ldrh", "ldrsb", "ldrsh", "ldrex", "str", "strb", "strh", "strex")},
    "ldrd": (2, 3), "strd": (2, 3),
    "it": (0, 1),
    # FPv4-SP: single precision only
    **{m: (1, 1) for m in ("vadd", "vsub", "vmul", "vnmul", "vabs", "vneg", "vcmp", "vcmpe", "vcvt", "vcvtr", "vmov", "vmrs", "vmsr",
                           "vcvta", "vcvtn", "vcvtp", "vcvtm", "vmaxnm", "vminnm", "vsel")},
    **{m: (3, 3) for m in ("vmla", "vmls", "vnmla", "vnmls", "vfma", "vfms", "vfnma", "vfnms")},
    "vdiv": (14, 14), "vsqrt": (14, 14), "vldr": (2, 2), "vstr": (2, 2),
}
_BRANCHES = {"b", "bl", "bx", "blx", "cbz", "cbnz", "tbb", "tbh"}
_MULTIPLE = {"ldm", "ldmia", "ldmdb", "stm", "stmia", "stmdb", "push", "pop", "vldm", "vldmia", "vldmdb", "vstm", "vstmia", "vstmdb", "vpush", "vpop"}
#: Pipeline refill of a taken branch (P in the TRM): 1 to 3 cycles.
_REFILL = (1, 3)


#: IT and its forms (ITT, ITE, ..., up to four instructions): 0 cycles when folded, else 1.
_IT = re.compile(r"it[te]{0,3}")


def _base(mnemonic: str) -> str:
    """The mnemonic without its width (``.w``) or data type (``.f32``) suffix, flag-setting ``s`` and
    condition; every form of IT as ``it``."""
    m = mnemonic.lower().split(".")[0]
    if _IT.fullmatch(m):
        return "it"
    known = CYCLES.keys() | _BRANCHES | _MULTIPLE
    if m in known:
        return m
    for cut in (m[:-2] if m[-2:] in _CONDITIONS else None, m[:-1] if m.endswith("s") else None):
        if cut and cut in known:
            return cut
    if m.endswith("s") and m[-3:-1] in _CONDITIONS and m[:-3] in known:  # e.g. addeqs (pre-UAL)
        return m[:-3]
    if m[-2:] in _CONDITIONS and m[:-2].endswith("s") and m[:-3] in known:  # e.g. movseq
        return m[:-3]
    return m


def _registers(operands: str) -> int:
    """Registers in a list ``{r4, r5, lr}`` or ``{s16-s19}`` / ``{d8, d9}`` in units of 32-bit transfers."""
    inside = operands[operands.find("{") + 1: operands.rfind("}")]
    count = 0
    for item in (x.strip() for x in inside.split(",") if x.strip()):
        width = 2 if item.startswith("d") else 1
        if "-" in item:
            a, b = item.split("-")
            count += width * (int(b.strip()[1:]) - int(a.strip()[1:]) + 1)
        else:
            count += width
    return count


def instruction_cycles(mnemonic: str, operands: str, taken: bool) -> tuple[int, int] | None:
    """Cycles (fewest, most) of one executed instruction; ``taken``: whether control left it for
    somewhere else than the next instruction. None for a mnemonic the table does not know."""
    m = _base(mnemonic)
    if m in _BRANCHES:
        if m in ("tbb", "tbh"):
            return (2 + _REFILL[0], 2 + _REFILL[1])
        return (1 + _REFILL[0], 1 + _REFILL[1]) if taken else (1, 1)
    if m in _MULTIPLE:
        n = _registers(operands)
        writes_pc = bool(re.search(r"\bpc\b", operands)) and m in ("pop", "ldm", "ldmia", "ldmdb")
        return (1 + n + _REFILL[0], 1 + n + _REFILL[1]) if writes_pc and taken else (1 + n, 1 + n)
    if m not in CYCLES:
        return None
    lo, hi = CYCLES[m]
    if m in ("vldr", "vstr") and re.match(r"\s*d\d", operands):  # a double register: two transfers
        return (3, 3)
    if m == "vmov" and re.search(r"\bd\d", operands) and re.search(r"\br\d", operands):  # two core registers to or from a double one
        return (2, 2)
    if taken and m in ("ldr", "mov", "add") and re.match(r"\s*pc\b", operands):  # a load or move into pc branches
        return (lo + _REFILL[0], hi + _REFILL[1])
    if mnemonic.lower().split(".")[0].startswith("v") and (".f64" in mnemonic.lower()):
        return None  # FPv4-SP has no double precision: such an instruction would not run on an M4
    return lo, hi


@dataclass(frozen=True)
class M4Count:
    """One stretch of execution: instructions executed and the estimated cycles (fewest, most)."""

    instructions: int
    cycles_min: int
    cycles_max: int
    unknown: tuple[str, ...] = ()  # mnemonics the cycle table does not know (counted as 1 cycle)

    @property
    def us_min(self) -> float:
        return 1e6 * self.cycles_min / CLOCK_HZ

    @property
    def us_max(self) -> float:
        return 1e6 * self.cycles_max / CLOCK_HZ


_IN = re.compile(r"^0x([0-9a-f]+):\s+((?:[0-9a-f]{4} )+)")
_TRACE = re.compile(r"^Trace \d+: 0x[0-9a-f]+ \[[0-9a-f]+/([0-9a-f]+)/[0-9a-f]+/[0-9a-f]+\] ?(.*)$")
_OBJDUMP = re.compile(r"^\s*([0-9a-f]+):\t([0-9a-f]{4}(?: [0-9a-f]{4})?) *\t(\S+)\t?([^@;]*)")

Decoded = dict[int, tuple[int, str, str]]  # pc -> (bytes, mnemonic, operands)


def disassemble(elf: str | Path, objdump: str = "arm-none-eabi-objdump") -> Decoded:
    """Every instruction of ``elf``'s code by ``objdump -d``: pc -> (bytes, mnemonic, operands).

    objdump decodes the M4's Thumb-2 in its IT blocks correctly; qemu's own disassembler
    (capstone) loses track in some and prints ``.byte``, so qemu's log gives only where each block
    starts and ends."""
    proc = subprocess.run([objdump, "-d", str(elf)], capture_output=True, text=True, check=True)
    out: Decoded = {}
    for line in proc.stdout.splitlines():
        m = _OBJDUMP.match(line)
        if m and not m.group(3).startswith("."):
            out[int(m.group(1), 16)] = (2 * len(m.group(2).split()), m.group(3), m.group(4).strip())
    return out


def count_blocks(log_lines, marker: str, decoded: Decoded) -> list[M4Count]:
    """Count a qemu ``-d in_asm,exec,nochain`` log of the program ``decoded`` describes
    (:func:`disassemble`): one :class:`M4Count` for each stretch between two executions of the
    function ``marker`` (its first and second, third and fourth, ...)."""
    extent: dict[int, int] = {}  # block start -> its end (from the translation's listing)
    listing: list[tuple[int, int]] | None = None
    cache: dict[int, tuple[int, int, int, tuple, tuple]] = {}  # start -> (instructions, lo, hi of all but the last, last, unknown)
    stretches: list[M4Count] = []
    counting = False
    pending = None  # the last executed block's last instruction: its cost waits on the next pc
    ins = lo = hi = 0
    unknown: set[str] = set()

    def body(start: int) -> list[tuple[int, int, str, str]]:
        if start not in extent:
            raise ValueError(f"qemu log: the block at 0x{start:x} ran before it was translated (was -d in_asm given?)")
        out, pc = [], start
        while pc < extent[start]:
            if pc not in decoded:
                raise ValueError(f"qemu log: no instruction at 0x{pc:x} in the program's disassembly")
            size, mn, ops = decoded[pc]
            out.append((pc, size, mn, ops))
            pc += size
        return out

    for line in log_lines:
        if line.startswith("IN:"):
            listing = []
            continue
        if listing is not None:
            m = _IN.match(line)
            if m:
                listing.append((int(m.group(1), 16), 2 * len(m.group(2).split())))
                continue
            if listing:
                start = listing[0][0]
                extent[start] = listing[-1][0] + listing[-1][1]
                cache.pop(start, None)
            listing = None
        m = _TRACE.match(line)
        if not m:
            continue
        pc = int(m.group(1), 16)
        if counting and pending is not None:
            p, size, mn, ops = pending
            c = instruction_cycles(mn, ops, taken=pc != p + size)
            if c is None:
                unknown.add(mn)
                c = (1, 1)
            lo, hi, pending = lo + c[0], hi + c[1], None
        if m.group(2).strip() == marker:
            if counting:
                stretches.append(M4Count(ins, lo, hi, tuple(sorted(unknown))))
                counting = False
            else:
                counting, ins, lo, hi, pending, unknown = True, 0, 0, 0, None, set()
            continue
        if not counting:
            continue
        if pc not in cache:
            instructions = body(pc)
            blo = bhi = 0
            strange = []
            for _, _, mn, ops in instructions[:-1]:
                c = instruction_cycles(mn, ops, taken=False)
                if c is None:
                    strange.append(mn)
                    c = (1, 1)
                blo, bhi = blo + c[0], bhi + c[1]
            cache[pc] = (len(instructions), blo, bhi, instructions[-1], tuple(strange))
        n, blo, bhi, last, strange = cache[pc]
        unknown.update(strange)
        ins, lo, hi, pending = ins + n, lo + blo, hi + bhi, last
    return stretches


def qemu_arm() -> str | None:
    """``qemu-arm`` on the PATH, or None."""
    return shutil.which("qemu-arm")


_DRIVER = r"""/* Counting driver of esba bench embedded (esba.bench.cortexm4): each scene's equilibrium between two
 * calls of the marker, its status and state printed as the bits of doubles, by the write system call. */
#include "{{NAME}}.h"

static long sys3(long nr, long a, long b, long c) {
    register long r0 __asm__("r0") = a;
    register long r1 __asm__("r1") = b;
    register long r2 __asm__("r2") = c;
    register long r7 __asm__("r7") = nr;
    __asm__ volatile("svc 0" : "+r"(r0) : "r"(r1), "r"(r2), "r"(r7) : "memory");
    return r0;
}
static void put(const char *s, int len) { sys3(4, 1, (long)s, len); }
static void put_bits(double x) {
    union { double d; unsigned long long u; } v;
    char b[17];
    int i;
    v.d = x;
    for (i = 15; i >= 0; --i) { b[i] = "0123456789abcdef"[v.u & 15u]; v.u >>= 4; }
    b[16] = ' ';
    put(b, 17);
}
void esba_m4_mark(void) __attribute__((noinline));
void esba_m4_mark(void) { __asm__ volatile(""); }

static {{NAME}}_work work;
int main(void) {
    {{NAME}}_params params;
    {{NAME}}_loads loads;
    {{NAME}}_result r;
    int status, k;
    char c;
    {{NAME}}_default_params(&params);
{{SCENES}}
    return 0;
}
void _start(void) __attribute__((naked, noreturn));
void _start(void) { __asm__ volatile("bl main\n mov r7, #248\n svc 0\n"); }
"""

_SCENE = r"""    {{NAME}}_default_loads(&loads);
{{SET}}
    esba_m4_mark();
    status = {{NAME}}_equilibrium({{N}}, &params, &loads, 0, &r, &work);
    esba_m4_mark();
    c = (char)('0' + status);
    put(&c, 1);
    put(" ", 1);
    for (k = 0; k < {{SIZE}}; ++k) put_bits((double)r.{{STATE}}[k]);
    put("\n", 1);
"""


def m4_equilibrium_counts(folder: str | Path, name: str, n: int, scenes: Sequence[dict[str, float]], state: str, size: int,
                          workdir: str | Path, arm_cc: str, qemu: str) -> tuple[list[M4Count], list[tuple[int, list[float]]]]:
    """Build the export in ``folder`` (header ``name.h``, source ``name.c``) for the M4 with a driver
    that solves ``scenes`` (each a mapping of C fields of ``loads`` to values, for example
    ``{"pressure": 0.12, "payload[0].force": 2.0}``), run it under ``qemu``, and count each
    equilibrium: (counts, [(status, state) per scene]) where state is ``r.<state>[0..size)``."""
    folder, workdir = Path(folder), Path(workdir)
    body = []
    for scene in scenes:
        sets = "\n".join(f"    loads.{field} = ({name}_real){value!r};" for field, value in scene.items())
        body.append(_SCENE.replace("{{SET}}", sets))
    text = _DRIVER.replace("{{SCENES}}", "".join(body)).replace("{{NAME}}", name).replace("{{N}}", str(n)).replace("{{STATE}}", state).replace("{{SIZE}}", str(size))
    driver = workdir / f"count_{name}.c"
    driver.write_text(text, encoding="utf-8")
    elf = workdir / f"count_{name}.elf"
    build.run_compiler(arm_cc, ["-std=c99", *build.CORTEX_M4, "-nostartfiles", "--specs=nosys.specs", f"-I{folder}", str(driver),
                                str(folder / f"{name}.c"), "-o", str(elf), "-lm"])
    decoded = disassemble(elf, str(Path(arm_cc).with_name("arm-none-eabi-objdump")))
    proc = subprocess.Popen([qemu, "-cpu", "max", "-d", "in_asm,exec,nochain", str(elf)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, errors="replace")
    assert proc.stderr is not None and proc.stdout is not None
    counts = count_blocks(proc.stderr, "esba_m4_mark", decoded)
    out = proc.stdout.read()
    if proc.wait() != 0:
        raise build.BuildError(f"{qemu} -cpu max {elf.name} exited {proc.returncode}")
    results = []
    for line in out.strip().splitlines():
        words = line.split()
        values = [struct.unpack(">d", bytes.fromhex(w))[0] for w in words[1:]]  # the bits of each double
        results.append((int(words[0]), values))
    if len(results) != len(scenes) or len(counts) != len(scenes):
        raise build.BuildError(f"{elf.name} under qemu: {len(results)} results and {len(counts)} counted stretches for {len(scenes)} scenes")
    return counts, results


def summary(counts: Sequence[M4Count], results: Sequence[tuple[int, list[float]]], host: Sequence[tuple[int, Sequence[float]]]) -> dict:
    """The per-scene counts as data: instructions, cycles and microseconds (fewest, most) at
    :data:`CLOCK_HZ` with their medians over the scenes, the statuses, whether they are the host's,
    and the largest difference of the state from the host's (``host``: (status, state) per scene)."""
    import numpy as np

    unknown = sorted({m for c in counts for m in c.unknown})
    return {
        "instructions": [c.instructions for c in counts],
        "cycles_min": [c.cycles_min for c in counts],
        "cycles_max": [c.cycles_max for c in counts],
        "us_min": [c.us_min for c in counts],
        "us_max": [c.us_max for c in counts],
        "instructions_median": statistics.median(c.instructions for c in counts),
        "us_min_median": statistics.median(c.us_min for c in counts),
        "us_max_median": statistics.median(c.us_max for c in counts),
        "statuses": [s for s, _ in results],
        "statuses_as_host": all(s == h for (s, _), (h, _) in zip(results, host)),
        "state_difference_from_host": max(float(np.max(np.abs(np.asarray(q) - np.asarray(h)))) for (_, q), (_, h) in zip(results, host)),
        "unknown_mnemonics": unknown,
    }

"""``docs/performance.md``: the benchmarks' page, one section per ``esba bench`` command.

Each section is written by the command it names (:mod:`esba.pages.sections`); this module renders
the generation benchmark (:func:`esba.bench.timing.generation`) as its section.
"""

from __future__ import annotations

from esba.bench.timing import GenerationRow, growth

from .sections import write_section

__all__ = ["generation_table", "write_generation_page", "PERFORMANCE_TITLE"]


def generation_table(rows: list[GenerationRow]) -> str:
    """The generation benchmark as a plain-text table, with its growth exponent and a legend."""
    head = (
        f"{'n':>4} {'derive s':>9} {'emit s':>7} {'total s':>8} {'naive s':>8} {'ratio':>6} "
        f"{'U instr':>8} {'grad instr':>10} {'hess instr':>10} {'AD hess':>8} "
        f"{'U us':>7} {'grad us':>8} {'hess us':>8}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        naive = f"{r.naive_s:8.2f}" if r.naive_s is not None else f"{'-':>8}"
        ratio = f"{r.naive_s / r.total_s:6.1f}" if r.naive_s is not None else f"{'-':>6}"
        lines.append(
            f"{r.n:>4} {r.derive_s:9.2f} {r.emit_s:7.2f} {r.total_s:8.2f} {naive} {ratio} "
            f"{r.instructions['energy']:>8} {r.instructions['gradient']:>10} {r.instructions['hessian']:>10} "
            f"{r.ad_hessian_instructions:>8} {r.call_us['energy']:7.1f} {r.call_us['gradient']:8.1f} {r.call_us['hessian']:8.1f}"
        )
    k, why = growth([r.n for r in rows], [r.total_s for r in rows])
    rate = f"generation time grows as n^{k:.2f} for n >= 16" if k is not None else f"growth exponent not computed: {why}"
    lines += [
        "",
        f"{rate} (target: at most n^2, and n = 100 within 30 s)",
        "naive: expanded POE tip + sympy.diff + cse, the same effects (ratio = naive / esba, same run)",
        "AD hess: instructions of CasADi's own AD Hessian of the generated energy (the yardstick)",
        "us: median per-call time of the generated Functions from Python (interpreted SX)",
    ]
    return "\n".join(lines)


#: The title of the benchmarks' page.
PERFORMANCE_TITLE = "# Performance"


def write_generation_page(path, rows: list[GenerationRow], command: str):
    """Write the generation benchmark as the ``generation`` section of a Markdown page (``docs/performance.md``)."""
    import platform

    import casadi
    import sympy

    body = "\n".join(
        [
            "## Generating the models",
            "",
            "What the symbolic route costs against the segment count n, for the default effects",
            "(air, axial, radial, fibres, one payload), variant `paper`: derivation (SymPy), emission",
            "(CasADi source, built once to count instructions), the size of each generated Function,",
            "and the per-call time of U, gradient and Hessian from Python. Times are medians over",
            "repeated runs on a shared 2-core machine: read them as orders of magnitude; the ratios",
            "come from the same run and hold better than the absolute times.",
            "",
            f"Machine: {platform.machine()}, Python {platform.python_version()}, SymPy {sympy.__version__}, CasADi {casadi.__version__}.",
            "",
            "```",
            generation_table(rows),
            "```",
            "",
            "How the chain form keeps the cost down (see `derive/program.py`): the cumulative angles",
            "are symbols of their own, the separable terms are differentiated once per template, and",
            "the payload and gravity potentials use the screw-theory Jacobian, whose off-diagonal",
            "Hessian entries depend on the later joint only. The straight-line program has O(n)",
            "assignments and O(n^2) references in the Hessian. The medians hide a one-off cost per",
            "process: the SymPy integrations of the energy terms (a second or two, paid by the first",
            "model a process generates).",
        ]
    )
    return write_section(path, "generation", body, command, PERFORMANCE_TITLE)

"""``esba bench``: the benchmarks, each printing a table of medians and writing its docs section."""

from __future__ import annotations

import argparse
import dataclasses
import sys

from esba.infra import outputs

from .arguments import (
    Parser,
    UsageError,
    count_arg,
    output_file_arg,
    refuse,
    segments_arg,
)
from .cluster import chunk_arg, scheduler_arg, timeout_arg, workers_arg
from .results import EXIT_OK, print_result


def _cmd_bench_generation(args: argparse.Namespace) -> int:
    from esba.bench import timing as bench
    from esba.pages.performance import PAGE, GenerationSettings, generation_table

    page = outputs.check_file(args.markdown, "--markdown", (".md",)) if args.markdown else None
    command = f"esba bench generation --max-n {args.max_n} --repeat {args.repeat}{' --no-naive' if args.no_naive else ''} --markdown {args.markdown}"
    settings = GenerationSettings(args.max_n, args.repeat, not args.no_naive, command)

    def progress(n):
        print(f"  n = {n} done", file=sys.stderr)

    rows = PAGE.compute_section("generation", settings, None if args.json else progress)
    exponent, why = bench.growth([r.n for r in rows], [r.total_s for r in rows])
    data = {"rows": [r.__dict__ for r in rows], "growth_exponent": exponent}
    if exponent is None:
        data["growth_exponent_reason"] = why
    print_result(args, data, lambda d: generation_table(rows))
    if page is not None:
        path = PAGE.write_section(page, "generation", rows, settings)
        print(f"esba: wrote {path}", file=sys.stderr)
    return EXIT_OK


def _cmd_bench_accuracy(args: argparse.Namespace) -> int:
    from esba.bench import accuracy as acc
    from esba.pages.accuracy import PAGE, AccuracySettings

    if args.quick:
        refuse(args, ["max_n", "reference_n", "fixed_n"], "with --quick (it fixes n <= 4, reference n = 16)")
    if args.no_write:
        refuse(args, ["out", "figure"], "with --no-write")
    max_n = 128 if args.max_n is None else args.max_n
    reference_n = acc.REFERENCE_N if args.reference_n is None else args.reference_n
    fixed_n = 16 if args.fixed_n is None else args.fixed_n
    settings = AccuracySettings(args.quick, max_n, reference_n, fixed_n, args.repeat)
    _, ref_n, _, _, _ = settings.plan
    if ref_n < 4 or ref_n % 4:
        raise UsageError(f"--reference-n {ref_n}: expected a multiple of 4 (the reference extrapolates from n/4, n/2, n)")
    doc = fig = None
    if not args.no_write:
        doc = outputs.check_file(outputs.default_page("accuracy-vs-time.md", create=True) if args.out is None else args.out, "--out", (".md",))
        fig = outputs.figures_dir(create=True) / "accuracy-vs-time.png" if args.figure is None else args.figure
        if args.figure is None:
            outputs.check_folder(fig.parent, "--figure")
        fig = outputs.figure_file(fig, "--figure", "accuracy-vs-time.png")
    command = "esba bench accuracy" + (" --quick" if args.quick else "")
    if not args.quick and (max_n, reference_n, fixed_n, args.repeat) != (128, 256, 16, 5):
        command += f" --max-n {max_n} --reference-n {reference_n} --fixed-n {fixed_n} --repeat {args.repeat}"
    settings = dataclasses.replace(settings, command=command, figure=fig)

    def say(msg):
        if not args.json:
            print(f"  {msg}", file=sys.stderr)

    runs = PAGE.compute(settings, say)
    accuracy, batch = runs.accuracy, runs.batch
    data = {
        "reference": accuracy.reference,
        "rows": [r.__dict__ for r in accuracy.rows],
        "costs": {n: c.__dict__ for n, c in accuracy.costs.items()},
        "reach": {
            case: {f"{mm:g} mm": (None if (r := accuracy.first_n_below(case, mm)) is None else r.n) for mm in (1.0, 0.1)} for case in accuracy.reference
        },
        "tolerance": runs.tolerance,
        "effects": runs.effects,
        "naive": runs.naive,
        "batch": batch,
    }
    if doc is not None:
        PAGE.write(doc, settings, data=runs)
        data["page"], data["figure"] = str(doc), str(fig)

    def table(d: dict) -> str:
        lines = [f"{'case':>10} {'n':>4} {'error mm':>9} {'n vs n+1':>9} {'solve ms':>9}"]
        for r in accuracy.rows:
            lines.append(f"{r.case:>10} {r.n:>4} {r.error_mm:9.3g} {r.next_mm:9.3g} {1e3 * r.solve_s:9.2f}")
        lines += [f"{case}: tip error below " + ", ".join(f"{mm} from n = {n}" if n is not None else f"{mm} at no n tried" for mm, n in reach.items())
                  for case, reach in d["reach"].items()]
        lines.append(f"batch: {batch.get('compiled_us', batch['interpreted_us']):.1f} us per equilibrium; naive {batch['naive_us']:.0f} us; IPOPT {batch['ipopt_us']:.0f} us")
        if "page" in d:
            lines.append(f"wrote {d['page']} and {d['figure']}")
        return "\n".join(lines)

    print_result(args, data, table)
    return EXIT_OK


def _bench_progress(args: argparse.Namespace, form: str):
    """A progress line per finished part on stderr (none with --json)."""

    def progress(what):
        if not args.json:
            print(form.format(what), file=sys.stderr)

    return progress


def _cmd_bench_solve(args: argparse.Namespace) -> int:
    from esba.pages.performance import PAGE, SolveSettings, solve_table

    if args.markdown:
        outputs.check_file(args.markdown, "--markdown", (".md",))
    settings = SolveSettings(args.repeat, f"esba bench solve --repeat {args.repeat} --markdown {args.markdown}")
    data = PAGE.compute_section("solve", settings, _bench_progress(args, "  {} done"))
    print_result(args, data, solve_table)
    if args.markdown:
        print(f"wrote {PAGE.write_section(args.markdown, 'solve', data, settings)}", file=sys.stderr)
    return EXIT_OK


def _cmd_bench_maps(args: argparse.Namespace) -> int:
    from esba.pages.performance import PAGE, MapsSettings, maps_table

    if args.markdown:
        outputs.check_file(args.markdown, "--markdown", (".md",))
    settings = MapsSettings(args.repeat, args.k, f"esba bench maps --repeat {args.repeat} --markdown {args.markdown}")
    rows = PAGE.compute_section("maps", settings, _bench_progress(args, "  {} done"))
    data = {"rows": [dict(r.__dict__, points_per_s=r.points_per_s, cell_ms=r.cell_ms, speedup=r.speedup) for r in rows]}
    print_result(args, data, lambda d: maps_table(rows))
    if args.markdown:
        print(f"wrote {PAGE.write_section(args.markdown, 'maps', rows, settings)}", file=sys.stderr)
    return EXIT_OK


def _cmd_bench_contact(args: argparse.Namespace) -> int:
    from esba.pages.performance import PAGE, ContactSettings, contact_table

    if args.markdown:
        outputs.check_file(args.markdown, "--markdown", (".md",))
    settings = ContactSettings(args.repeat, f"esba bench contact --repeat {args.repeat} --markdown {args.markdown}")
    data = PAGE.compute_section("contact", settings, _bench_progress(args, "  {} done"))
    out = dict(data, rows=[r.__dict__ for r in data["rows"]])
    print_result(args, out, lambda d: contact_table(data))
    if args.markdown:
        print(f"wrote {PAGE.write_section(args.markdown, 'contact', data, settings)}", file=sys.stderr)
    return EXIT_OK


def _cmd_bench_3d(args: argparse.Namespace) -> int:
    from esba.pages.performance import PAGE, SpatialSettings, spatial_table

    if args.markdown:
        outputs.check_file(args.markdown, "--markdown", (".md",))
    settings = SpatialSettings(args.repeat, f"esba bench 3d --repeat {args.repeat} --markdown {args.markdown}")
    data = PAGE.compute_section("3d", settings, _bench_progress(args, "  {} done"))
    print_result(args, data, spatial_table)
    if args.markdown:
        print(f"wrote {PAGE.write_section(args.markdown, '3d', data, settings)}", file=sys.stderr)
    return EXIT_OK


def _cmd_bench_path(args: argparse.Namespace) -> int:
    from esba.pages.performance import PAGE, PathSettings, path_table

    if args.markdown:
        outputs.check_file(args.markdown, "--markdown", (".md",))
    settings = PathSettings(args.repeat, f"esba bench path --repeat {args.repeat} --markdown {args.markdown}")
    rows = PAGE.compute_section("path", settings, _bench_progress(args, "  n = {} done"))
    data = {"rows": [dict(r.__dict__, folds=list(r.folds), points_per_s=r.points_per_s, point_us=r.point_us) for r in rows]}
    print_result(args, data, lambda d: path_table(rows))
    if args.markdown:
        print(f"wrote {PAGE.write_section(args.markdown, 'path', rows, settings)}", file=sys.stderr)
    return EXIT_OK


def _cmd_bench_batch(args: argparse.Namespace) -> int:
    from esba.bench import accuracy as acc
    from esba.pages.accuracy import answered
    from esba.statics.batch import check_size

    check_size(args.size, args.segments, "--size", UsageError)
    data = acc.batch_benchmark(args.size, args.segments)

    def table(d: dict) -> str:
        rows = [("batch size", f"{d['size']} equilibria, n = {d['segments']} (pressures 0-0.2 MPa x horizontal tip payloads 0-2 N)")]
        if "compiled_us" in d:
            rows += [
                ("compiled, warm", f"{d['compiled_us']:.1f} us per equilibrium (fast path alone {d['compiled_fast_path_us']:.1f} us)"),
                ("compiled, first", f"{d['compiled_first_us']:.1f} us per equilibrium (compiling took {d['compiled_first_compile_s']:.1f} s)"),
            ]
        diff = d["max_theta_difference_vs_ipopt"]
        rows += [
            ("interpreted", f"{d['interpreted_us']:.1f} us per equilibrium"),
            ("IPOPT solve", f"{d['ipopt_us']:.0f} us per equilibrium (esba.statics.equilibrium.solve, one by one, on {d['ipopt_samples']} of them)"),
            ("naive BFGS", f"{d['naive_us']:.0f} us per equilibrium (SciPy, numeric gradients)"),
            ("speed-up", f"{d['speedup_vs_naive']:.0f}x naive, {d['speedup_vs_ipopt']:.0f}x IPOPT"),
            ("answered by", answered(d["counts"])),
            ("vs IPOPT", "no sample solved ok by both" if diff is None else f"largest angle difference {diff:.2g} rad on a sample"),
            ("backend", d["backend"]),
        ]
        return "\n".join(f"{k:>16}: {v}" for k, v in rows)

    print_result(args, data, table)
    return EXIT_OK


#: ``--repeat``'s bound: medians of more runs change nothing but the wait.
_MAX_REPEAT = 100


#: ``--size``'s bound before the memory check (esba.statics.batch.check_size) refines it per n.
_MAX_SIZE = 10_000_000


def _cmd_bench_scaling(args: argparse.Namespace) -> int:
    from esba.bench import scaling as bench_scaling
    from esba.pages.scaling import PAGE, ScalingSettings, summary
    from esba.studies.distributed import DistributedError, require_dask

    if args.scheduler is not None and args.workers is not None:
        raise UsageError("--workers N lists local cluster sizes and --scheduler ADDRESS measures an existing cluster: give one of the two")
    if args.connect_timeout is not None and args.scheduler is None:
        raise UsageError("--connect-timeout is the wait for --scheduler ADDRESS: it is not used without it")
    try:
        require_dask("esba bench scaling")
    except DistributedError as exc:
        raise UsageError(str(exc)) from None
    from esba.statics.batch import check_size

    check_size(args.points, args.segments, f"--points {args.points} at n = {args.segments}", UsageError)

    def say(msg: str) -> None:
        if not args.json:
            print(f"  {msg}", file=sys.stderr)

    command = "esba bench scaling"
    defaults = bench_scaling.DEFAULTS
    for flag, value, default in (("--points", args.points, defaults["points"]), ("--segments", args.segments, defaults["segments"]),
                                 ("--repeat", args.repeat, defaults["repeat"]), ("--chunk", args.chunk, defaults["chunk"])):
        if value != default:
            command += f" {flag} {value}"
    if args.workers:
        command += "".join(f" --workers {w}" for w in args.workers)
    if args.scheduler:
        command += f" --scheduler {args.scheduler}"
    command += f" --markdown {args.markdown}"
    workers = tuple(args.workers) if args.workers else defaults["workers"]
    settings = ScalingSettings(args.points, args.segments, args.repeat, args.chunk, workers, args.scheduler, args.connect_timeout or 10.0, command)
    try:
        data = PAGE.compute(settings, say)
    except DistributedError as exc:
        raise UsageError(str(exc)) from None
    if args.markdown:
        data["page"] = str(PAGE.write(args.markdown, settings, data=data).path)

    print_result(args, data, summary)
    return EXIT_OK


#: The segment counts of ``esba bench embedded`` (``esba.bench.embedded.EMBEDDED_NS``, written out so that
#: building the parser does not import CasADi; a test checks they agree).
_EMBEDDED_NS = (3, 8, 16)


def _cmd_bench_embedded(args: argparse.Namespace) -> int:
    if args.no_write:
        refuse(args, ["out"], "with --no-write")
    page = None
    if not args.no_write:
        page = outputs.check_file(outputs.default_page("embedded.md", create=True) if args.out is None else args.out, "--out", (".md",))
    ns = tuple(sorted(set(args.segments))) if args.segments else _EMBEDDED_NS
    from esba.bench import embedded as bench_embedded

    data = bench_embedded.embedded_benchmark(ns, repeat=args.repeat, progress=_bench_progress(args, "  {}"), m4_time=not args.no_m4_time)
    if page is not None:
        from esba.pages.embedded import write_page

        command = "esba bench embedded"
        if ns != _EMBEDDED_NS:
            command += "".join(f" --segments {n}" for n in ns)
        if args.repeat != 11:
            command += f" --repeat {args.repeat}"
        if args.no_m4_time:
            command += " --no-m4-time"
        if args.out is not None:
            command += f" --out {args.out}"
        data["page"] = str(write_page(page, data, command))
    print_result(args, data, lambda d: bench_embedded.embedded_table(d) + (f"\nwrote {d['page']}" if "page" in d else ""))
    return EXIT_OK


def add_bench(sub) -> None:
    p = sub.add_parser("bench", help="benchmarks: tables of medians over repeated runs")
    bsub = p.add_subparsers(dest="bench", parser_class=Parser, required=True)
    g = bsub.add_parser("generation", help="generation time and size against n; per-call time of U, gradient, Hessian (minutes)")
    g.add_argument("--max-n", type=segments_arg, default=100, help="largest n (default 100)")
    g.add_argument("--repeat", type=count_arg("repeat", 1, _MAX_REPEAT), default=3, help="runs per n, median reported (default 3, at most 100)")
    g.add_argument("--no-naive", action="store_true", help="skip the naive SymPy route")
    g.add_argument("--markdown", metavar="FILE", help="also write the table as a docs page (docs/performance.md)")
    g.add_argument("--json", action="store_true", help="print JSON")
    g.set_defaults(func=_cmd_bench_generation)

    a = bsub.add_parser("accuracy", help="tip error against n, tolerance, effects, naive vs esba, batch (about 4 minutes); writes the accuracy page")
    a.add_argument("--max-n", type=segments_arg, default=None, help="largest n of the benchmark (default 128)")
    a.add_argument("--reference-n", type=segments_arg, default=None, help="finest n; the reference extrapolates from n/4, n/2, n (default 256)")
    a.add_argument("--fixed-n", type=segments_arg, default=None, help="n of the tolerance and effect benchmarks (default 16)")
    a.add_argument("--repeat", type=count_arg("repeat", 1, _MAX_REPEAT), default=5, help="solves per timing, median reported (default 5, at most 100)")
    a.add_argument("--quick", action="store_true", help="a small smoke run (n <= 4, reference n = 16, batch of 1000)")
    a.add_argument("--out", default=None, metavar="FILE", help="page to write (default docs/accuracy-vs-time.md in a checkout, else ./accuracy-vs-time.md)")
    a.add_argument("--figure", default=None, metavar="FILE", help="figure to write (default figures/accuracy-vs-time.png beside the page)")
    a.add_argument("--no-write", action="store_true", help="print only; write no page or figure")
    a.add_argument("--json", action="store_true", help="print JSON")
    a.set_defaults(func=_cmd_bench_accuracy)
    so = bsub.add_parser("solve", help="single-scene calls (solve for n = 3..128, stiffness, design, model load, CLI) against naive SciPy and the compiled limit")
    so.add_argument("--repeat", type=segments_arg, default=11, help="runs per timing, median reported (default 11)")
    so.add_argument("--markdown", metavar="FILE", help="also write the solve section of a docs page (docs/performance.md)")
    so.add_argument("--json", action="store_true", help="print JSON")
    so.set_defaults(func=_cmd_bench_solve)
    pa = bsub.add_parser("path", help="time to trace the 2 N pressure path 0 -> 0.3 MPa (n = 3, 32) against the IPOPT ramp and naive BFGS (about 15 s)")
    pa.add_argument("--repeat", type=segments_arg, default=5, help="runs per timing, median reported (default 5)")
    pa.add_argument("--markdown", metavar="FILE", help="also write the path section of a docs page (docs/performance.md)")
    pa.add_argument("--json", action="store_true", help="print JSON")
    pa.set_defaults(func=_cmd_bench_path)
    s3 = bsub.add_parser("3d", help="the 3-D model against the planar one: generation (n = 3, 10, 30), solve, warm n = 30, continuation per point (docs/performance.md)")
    s3.add_argument("--repeat", type=segments_arg, default=3, help="runs per timing, median reported (default 3)")
    s3.add_argument("--markdown", metavar="FILE", help="also write the 3d section of a docs page (docs/performance.md)")
    s3.add_argument("--json", action="store_true", help="print JSON")
    s3.set_defaults(func=_cmd_bench_3d)
    mp = bsub.add_parser("maps", help="time to trace the fold curves of each map of docs/maps.md against the brute-force grid of stable-state counts")
    mp.add_argument("--repeat", type=segments_arg, default=3, help="runs per timing of the fold curves, median reported (default 3)")
    mp.add_argument("--k", type=count_arg("--k", 2, 100, "k x k brute-force cells"), default=20, help="cells per side of the brute-force grid (default 20)")
    mp.add_argument("--markdown", metavar="FILE", help="also write the maps section of a docs page (docs/performance.md)")
    mp.add_argument("--json", action="store_true", help="print JSON")
    mp.set_defaults(func=_cmd_bench_maps)
    co = bsub.add_parser("contact", help="a contact solve (n = 3) against a free solve, naive SciPy and the compiled limit; the blocked-force curve (n = 8, 31 pressures)")
    co.add_argument("--repeat", type=segments_arg, default=7, help="runs per timing, median reported (default 7)")
    co.add_argument("--markdown", metavar="FILE", help="also write the contact section of a docs page (docs/performance.md)")
    co.add_argument("--json", action="store_true", help="print JSON")
    co.set_defaults(func=_cmd_bench_contact)
    sc = bsub.add_parser("scaling", help="equilibria per second of a sweep in this process and on Dask (1, 2 workers), chunk sizes, overhead per chunk (docs/scaling.md)")
    sc.add_argument("--points", type=count_arg("points", 20, 200_000, "the rows are compared in memory"), default=12_000, help="grid size, 20 to 200000 (default 12000)")
    sc.add_argument("--segments", "-n", type=segments_arg, default=16, help="segment count (default 16)")
    sc.add_argument("--repeat", type=count_arg("repeat", 1, 50), default=3, help="runs per timing, median reported (default 3)")
    sc.add_argument("--chunk", type=chunk_arg, default=1000, metavar="K", help="points per chunk of the worker-count rows (default 1000)")
    sc.add_argument("--workers", type=workers_arg, action="append", metavar="N", help="local cluster sizes to measure (repeatable; default 1 and 2)")
    sc.add_argument("--scheduler", type=scheduler_arg, metavar="ADDRESS", help="measure the existing Dask cluster at ADDRESS instead (e.g. one started by dask-jobqueue)")
    sc.add_argument("--connect-timeout", type=timeout_arg, default=None, metavar="S", help="seconds to wait for --scheduler (default 10)")
    sc.add_argument("--markdown", type=output_file_arg(".md"), metavar="FILE", help="also write the page (docs/scaling.md)")
    sc.add_argument("--json", action="store_true", help="print JSON")
    sc.set_defaults(func=_cmd_bench_scaling)
    em = bsub.add_parser("embedded", help="the exported C (esba export c) at n = 3, 8, 16: us per equilibrium and inverse against Python, code size, stack, Cortex-M4, float vs double (docs/embedded.md; a few minutes)")
    em.add_argument("--segments", "-n", type=count_arg("segments", 1, 64, "each n is exported and compiled"), action="append", metavar="N", help="segment counts (repeatable; default 3, 8 and 16)")
    em.add_argument("--repeat", type=count_arg("repeat", 1, _MAX_REPEAT), default=11, help="calls per timing, median reported (default 11, at most 100)")
    em.add_argument("--out", default=None, metavar="FILE.md", help="page to write (default docs/embedded.md in a checkout, else ./embedded.md)")
    em.add_argument("--no-m4-time", action="store_true",
                    help="skip the Cortex-M4's instruction counts under qemu-arm (minutes; without qemu-arm or arm-none-eabi-gcc they are skipped anyway)")
    em.add_argument("--no-write", action="store_true", help="print only; write no page")
    em.add_argument("--json", action="store_true", help="print JSON")
    em.set_defaults(func=_cmd_bench_embedded)
    b = bsub.add_parser("batch", help="us per equilibrium of the batch path against IPOPT and naive BFGS")
    b.add_argument("--size", type=count_arg("size", 1, _MAX_SIZE), default=10_000, help="batch size (default 10000; bounded by the memory it takes)")
    b.add_argument("--segments", "-n", type=segments_arg, default=3, help="segment count (default 3)")
    b.add_argument("--json", action="store_true", help="print JSON")
    b.set_defaults(func=_cmd_bench_batch)

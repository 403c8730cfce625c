"""``esba sweep``: grids on the batch path, in this process or chunk by chunk on Dask."""

from __future__ import annotations

import argparse
import os
import sys

from esba.derive.effects import VARIANTS
from esba.infra import outputs

from .arguments import (
    ACTUATOR_FLAGS,
    UsageError,
    add_actuator_flags,
    float_arg,
    load_scene_file,
    refuse,
    scene_changes,
    segments_arg,
)
from .cluster import add_cluster_flags, chunk_arg, on_cluster, rows_held, study_stopped
from .results import EXIT_FAILED, EXIT_OK, print_result


def _values_arg(text: str) -> list[float]:
    from esba.studies.sweep import SweepError, parse_values

    try:
        return parse_values(text)
    except SweepError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _actuator_axes(args: argparse.Namespace) -> dict[str, list[float]]:
    """The actuator flags given, as sweep axes (field -> values)."""
    return {name: getattr(args, name) for name in ACTUATOR_FLAGS if getattr(args, name, None) is not None}


def _cmd_sweep(args: argparse.Namespace) -> int:
    from esba.studies.sweep import sweep_table
    from esba.figures.scenes import save_figure
    from esba.figures.sweeps import fig12, sweep_figure
    from esba.model.scene import Scene
    from esba.statics.batch import BatchOptions
    from esba.studies.sweep import sweep

    from .sweep3d import run_sweep3d, wants_3d

    if wants_3d(args):  # the 3-D model: esba.studies.sweep3d
        return run_sweep3d(args)
    if args.fig12 is not None:
        refuse(args, ["pressure", "payload", "payload_angle", *ACTUATOR_FLAGS, "target_angle", "out", "plot"],
               "with --fig12 (it draws its own grid: r2 and d at P = 0.2 MPa, no payload)")
        figure = outputs.figure_file(args.fig12, "--fig12", "sweep-fig12.png")
        out = None
    else:
        if args.pressure is not None:
            refuse(args, ["target_angle"], "with --pressure (it sets the pressure of designs swept without --pressure)")
        out = outputs.check_file(args.out, "--out", (".csv", ".json")) if args.out is not None else None
        figure = outputs.figure_file(args.plot, "--plot", "esba-sweep.png") if args.plot is not None else None
    base = load_scene_file(args.scene, None) or Scene()
    changes = scene_changes(args, skip=("pressure", *ACTUATOR_FLAGS))  # these are the grid's axes
    base = base.replace(**changes) if changes else base
    options = BatchOptions(compile="never" if args.no_compile else "auto", progress=not (args.json or args.no_progress))
    if on_cluster(args) or args.resume:
        return _sweep_in_chunks(args, base, options, out, figure)
    refuse(args, ["chunk"], "without --workers, --scheduler or --resume (a sweep in this process is one batch)")
    if args.fig12 is not None:
        fig, sweeps = fig12(base.replace(pressure=0.2, payloads=()), options=options)
        path = save_figure(fig, figure)
        curves = [s for group in sweeps.values() for s in group]
        bad = sum(int((s.status == "not ok").sum()) for s in curves)
        data = {"figure": str(path), "curves": len(curves), "points": sum(len(s.status) for s in curves), "not_ok": bad}
        print_result(args, data, lambda d: f"wrote {d['figure']}: {d['curves']} curves, {d['points']} points, {d['not_ok']} not ok")
        return EXIT_OK if bad == 0 else EXIT_FAILED
    if out is not None and str(out).lower().endswith(".csv"):  # a study file: refused now when another run writes it
        from esba.studies.chunks import StudyError, StudyFile

        try:
            StudyFile(out, "sweep", {}, [], 0).check_free()
        except StudyError as exc:
            raise UsageError(str(exc)) from None
    result = sweep(base, pressure=args.pressure, payload=args.payload, payload_angle=args.payload_angle, options=options, **_actuator_axes(args))
    if figure is not None:
        drawn = sweep_figure(result)  # refuses a figure with too many curves before anything is written
    data = result.to_dict()
    if out is not None:
        data["out"] = str(result.write(out))
    if figure is not None:
        data["figure"] = str(save_figure(drawn, figure))
    print_result(args, data, sweep_table)
    _warn_sweep(result.tally())
    if data["counts"]["not ok"]:
        print(f"esba: {data['counts']['not ok']} point(s) not ok: see their status and message", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _warn_sweep(tally) -> None:
    """One ``esba: warning:`` line per kind of finding of a sweep's points
    (:class:`esba.model.validity.Tally`): the same words in this process and on Dask, rows in
    memory or streamed to a file."""
    for line in tally.lines():
        print(f"esba: warning: {line}", file=sys.stderr)


def _sweep_in_chunks(args: argparse.Namespace, base, options, out: str | None, figure) -> int:
    """``esba sweep`` chunk by chunk (--workers, --scheduler, --resume): esba.studies.sweep_runner."""
    from esba.figures.scenes import save_figure
    from esba.figures.sweeps import sweep_figure
    from esba.model.scene import SceneError
    from esba.studies.chunks import StudyError, StudyStopped
    from esba.studies.distributed import DistributedError, open_runner
    from esba.studies.sweep import SweepError, plan_sweep
    from esba.studies.sweep import sweep_table
    from esba.studies.sweep_runner import DEFAULT_CHUNK, check_study, sweep_study

    if args.fig12 is not None:
        raise UsageError("--fig12 draws its own small grid in this process: give it without --workers, --scheduler or --resume")
    out = None if out is None else str(out)
    streamed = out is not None and out.lower().endswith(".csv")
    if args.resume and not streamed:
        raise UsageError(f"--resume continues a study from the CSV file it streams to: give --out FILE.csv (given: {out!r})")
    if args.plot is not None and streamed:
        raise UsageError("--plot needs every row in memory, and with --out FILE.csv on --workers, --scheduler or --resume the rows stream to the file: plot in a run without them")
    try:
        plan = plan_sweep(base, pressure=args.pressure, payload=args.payload, payload_angle=args.payload_angle, **_actuator_axes(args))
        check_study(plan, args.chunk or DEFAULT_CHUNK, streamed)  # before a cluster starts
    except (SweepError, SceneError, StudyError) as exc:
        raise UsageError(str(exc)) from None
    workers, scheduler = args.workers, args.scheduler
    if args.resume and rows_held(out) >= plan.size:  # nothing left to solve: no cluster to start for it
        workers = scheduler = None
    try:
        with open_runner(workers, scheduler, args.connect_timeout) as runner:
            study = sweep_study(plan, options, runner=runner, chunk=args.chunk or DEFAULT_CHUNK, out=out if streamed else None, resume=args.resume, progress=options.progress)
    except (DistributedError, StudyError) as exc:
        raise UsageError(str(exc)) from None
    except KeyboardInterrupt:
        where = f": the rows solved so far are in {out}; rerun with --resume to go on" if streamed and os.path.exists(out) else ""
        print(f"esba: interrupted{where}", file=sys.stderr)
        return 130
    except StudyStopped as exc:  # the scheduler lost, a chunk's workers dying, a full disk: exit 1
        return study_stopped(exc, out if streamed else None)
    # streamed rows stay in the file (a study may not fit in memory); a small grid's table reads them back
    data = study.to_dict(rows=not streamed or (plan.size <= 60 and not args.json))
    if streamed:
        data["out"] = out
    elif out is not None:
        data["out"] = str(study.result.write(out))
    if args.plot is not None:
        try:
            data["figure"] = str(save_figure(sweep_figure(study.result), figure))
        except SweepError as exc:
            raise UsageError(str(exc)) from None
    print_result(args, data, sweep_table)
    _warn_sweep(study.tally)
    if data["counts"]["not ok"]:
        print(f"esba: {data['counts']['not ok']} point(s) not ok: see their status and message", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def add_sweep(sub) -> None:
    p = sub.add_parser("sweep", help="solve a grid over pressure, payload and any actuator parameter (L, r1, r2, d, rho, E, M) as one batch; CSV/JSON out; Fig. 12")
    p.add_argument("scene", nargs="?", default=None, metavar="SCENE.toml", help="base scene (default: Table 1 at its 90 degree pressure, no payload, n = 3)")
    values = "VALUES: start:stop:count or v1,v2,..."
    p.add_argument("--pressure", type=_values_arg, metavar="VALUES", help=f"pressures, MPa ({values}; default: the base scene's)")
    p.add_argument("--payload", type=_values_arg, metavar="VALUES", help="tip payload magnitudes, N (one payload, horizontal unless --payload-angle)")
    p.add_argument("--payload-angle", type=_values_arg, metavar="VALUES", help="payload directions Omega from the vertical, degrees")
    p.add_argument("--segments", "-n", type=segments_arg, help="segment count n, 1 to 256")
    p.add_argument("--target-angle", type=float_arg, metavar="DEG", help="without --pressure: each design at the pressure that bends it unloaded to DEG")
    p.add_argument("--gravity", action="store_true", help="include the actuator's weight (Eq. 15)")
    p.add_argument("--no-fibres", action="store_true", help="leave out the fibre restraint (Eq. 18)")
    p.add_argument("--variant", choices=VARIANTS, default=None, help="model variant")
    p.add_argument("--out", metavar="FILE", help="write every point to FILE.csv (the study's metadata in FILE.study.json beside it) or FILE.json (no file is written by default)")
    p.add_argument("--plot", metavar="FILE|DIR", help="total angle against the first swept axis, one curve per other value (a folder gets esba-sweep.png)")
    p.add_argument("--fig12", metavar="FILE|DIR", help="write the paper's Fig. 12 (angle vs r2 for d = 0, 2, 4, 6; vs d for r2 = 2, 4, 6; P = 0.2 MPa)")
    p.add_argument("--no-compile", action="store_true", help="use CasADi's interpreter, not compiled C")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print JSON (every row)")
    add_actuator_flags(p, values=_values_arg, note="; each a sweep axis")
    p.add_argument("--3d", dest="three_d", action="store_true", help="sweep the 3-D model (chosen by itself by the flags below; esba/studies/sweep3d.py)")
    p.add_argument("--payload-out-of-plane", type=_values_arg, metavar="VALUES", help="3-D: the payload's angle out of the bending plane, degrees (-90..90)")
    p.add_argument("--EI-side", dest="EI_side", type=_values_arg, metavar="VALUES", help="3-D: the section's sideways bending stiffness, N*mm^2 (a sweep axis)")
    p.add_argument("--GJ", dest="GJ", type=_values_arg, metavar="VALUES", help="3-D: the section's torsional stiffness, N*mm^2 (a sweep axis)")
    p.add_argument("--section", action="append", metavar="NAME=VALUE", help="3-D: a fixed section stiffness EI_side=..., GJ=... (N*mm^2; default the eccentric section's)")
    add_cluster_flags(p, "the grid")
    p.add_argument("--chunk", type=chunk_arg, default=None, metavar="K", help="points per chunk with --workers, --scheduler or --resume (default 1000)")
    p.add_argument("--resume", action="store_true", help="stream the rows chunk by chunk to --out FILE.csv and continue the study that file holds (a new one if there is none)")
    p.set_defaults(func=_cmd_sweep)

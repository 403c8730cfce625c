"""``esba sweep --3d``: a grid of 3-D scenes (esba.studies.sweep3d), in this process or on Dask."""

from __future__ import annotations

import argparse
import sys

from .arguments import ACTUATOR_FLAGS, UsageError, load_scene_file, refuse, scene_changes
from .cluster import on_cluster, rows_held, study_stopped
from .results import EXIT_FAILED, EXIT_OK, print_result

#: The sweep's flags that only the 3-D sweep takes (any of them picks it).
FLAGS_3D = ("payload_out_of_plane", "EI_side", "GJ", "section")


def wants_3d(args: argparse.Namespace) -> bool:
    return bool(getattr(args, "three_d", False) or any(getattr(args, d, None) is not None for d in FLAGS_3D))


def _table(d: dict) -> str:
    lines = [f"3-D sweep: {d['points']} points ({', '.join(f'{k} {v}' for k, v in sorted(d['counts'].items()))}) {d['runner']}"]
    if d.get("out"):
        lines.append(f"wrote {d['out']} (and its .study.json)" + (f", resumed after its first {d['resumed_from_row']} rows" if d.get("resumed_from_row") else ""))
    for r in d.get("rows", [])[:60]:
        axes = ", ".join(f"{k} = {r[k]:g}" for k in d["axes"])
        if r["status"] == "infeasible":
            lines.append(f"{axes}: infeasible")
            continue
        lines.append(f"{axes}: {r['status']}, total angle {r['total_angle_deg']:.2f} deg, twist {r['total_twist_deg']:.2f} deg, "
                     f"tip ({r['tip_x_mm']:.2f}, {r['tip_y_mm']:.2f}, {r['tip_z_mm']:.2f}) mm")
    return "\n".join(lines)


def run_sweep3d(args: argparse.Namespace) -> int:
    from esba.infra import outputs
    from esba.model.scene import Scene, SceneError
    from esba.studies.chunks import StudyError, StudyStopped
    from esba.studies.distributed import DistributedError, open_runner
    from esba.studies.sweep3d import Sweep3DError, plan_sweep3d, row_fields3d, sweep3d_study

    from .estimate3d import section_arg

    refuse(args, ["fig12", "plot", "target_angle"], "with a 3-D sweep (--3d: give the pressure as --pressure; no figure yet)")
    refuse(args, ["no_compile"], "with a 3-D sweep (each point is solved alone, by Newton's method in Python)")
    out = outputs.check_file(args.out, "--out", (".csv",)) if args.out is not None else None
    if args.resume and out is None:
        raise UsageError("--resume continues a 3-D study from the CSV file it streams to: give --out FILE.csv")
    base = load_scene_file(args.scene, None) or Scene()
    changes = scene_changes(args, skip=("pressure", *ACTUATOR_FLAGS))
    try:
        base = base.replace(**changes) if changes else base
        if args.pressure is None:
            if base.pressure is None:
                raise UsageError("a 3-D sweep needs the pressure: --pressure VALUES (or a scene file that sets it)")
        axes = {"pressure": args.pressure, "payload": args.payload, "payload_angle": args.payload_angle,
                "payload_out_of_plane": args.payload_out_of_plane, "EI_side": args.EI_side, "GJ": args.GJ}
        axes.update({name: getattr(args, name) for name in ACTUATOR_FLAGS if getattr(args, name, None) is not None})
        plan = plan_sweep3d(base, section_arg(args.section), **{k: v for k, v in axes.items() if v is not None})
    except (Sweep3DError, SceneError) as exc:
        raise UsageError(str(exc)) from None
    cluster = on_cluster(args) and not (args.resume and rows_held(None if out is None else str(out)) >= plan.size)  # nothing left: no cluster
    try:
        with open_runner(args.workers if cluster else None, args.scheduler if cluster else None, args.connect_timeout) as runner:
            study = sweep3d_study(plan, runner=runner, chunk=args.chunk or 8, out=out, resume=args.resume)
    except (DistributedError, StudyError, Sweep3DError) as exc:
        raise UsageError(str(exc)) from None
    except KeyboardInterrupt:
        where = f": the rows solved so far are in {out}; rerun with --resume to go on" if out is not None and out.exists() else ""
        print(f"esba: interrupted{where}", file=sys.stderr)
        return 130
    except StudyStopped as exc:
        return study_stopped(exc, str(out) if out is not None else None)
    axes = row_fields3d(plan.base.segments, plan)[: len(plan.axes)]  # the axes' columns
    data = {"model": "3d", "points": plan.size, "counts": study.counts, "runner": study.runner, "axes": axes,
            "section": plan.section, "out": str(study.out) if study.out is not None else None, "hash": study.hash,
            "resumed_from_row": study.resumed_from}
    if out is None:
        data["rows"] = study.rows
    print_result(args, data, _table)
    bad = study.counts.get("not ok", 0)
    if bad:
        print(f"esba: {bad} point(s) not ok: see their status and message", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK

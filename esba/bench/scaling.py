"""How a sweep scales on Dask: the measurements behind ``docs/scaling.md`` (``esba bench scaling``).

One sweep grid (n = 16 by default: pressures x tip payloads) is solved

- in this process: once as :func:`esba.studies.sweep.sweep` (one batch) and chunk by chunk
  (:func:`esba.studies.sweep_runner.sweep_study` with the serial runner);
- on local Dask clusters of 1 and 2 worker processes (or on an existing cluster, ``scheduler``);

each ``repeat`` times, the median wall time giving the throughput in equilibria per second. Every
run's rows are checked against the in-process sweep's (element for element). The study is timed
warm: the batch library compiled once beforehand (that time is reported), each cluster started
(reported), its workers given one chunk first (reported: loading the model and the library) and
the study run once untimed.
Then the chunk size is varied, in this process and on the largest cluster, and the overhead of one
chunk is measured directly: the round trip of a chunk through the scheduler against the same
chunk solved in this process. The page is written by :mod:`esba.pages.scaling`.
"""

from __future__ import annotations

import os
import platform
import statistics
import time
from typing import Any, Callable, Sequence

import numpy as np

from esba.model.scene import Payload, Scene
from esba.statics.batch import BatchOptions, check_size, decide_backend, prepare
from esba.statics.batch_options import TAIL_CHUNK
from esba.studies.distributed import (
    WINDOW_PER_WORKER,
    ModelKey,
    SerialRunner,
    open_runner,
    run_task,
)
from esba.studies.sweep import (
    SweepError,
    SweepPlan,
    check_points,
    plan_sweep,
    solve_points,
    sweep,
)
from esba.studies.sweep_runner import sweep_study

__all__ = ["scaling_benchmark", "study_plan", "DEFAULTS"]

#: The defaults of ``esba bench scaling``.
DEFAULTS = {"points": 12_000, "segments": 16, "repeat": 3, "chunk": 1000, "chunk_sizes": (128, 1000, 4000), "workers": (1, 2), "round_trips": 21, "round_trip_points": 64}

#: Tip payloads of the grid (the pressure axis takes the rest of the points).
PAYLOADS = 20


def study_plan(points: int, segments: int) -> SweepPlan:
    """The benchmark's grid: ``points // 20`` pressures from 0 to 0.2 MPa times 20 horizontal tip
    payloads from 0 to 2 N, on the Table 1 actuator with ``segments`` segments."""
    base = Scene(segments=segments, payloads=(Payload(1.0, 90.0),))
    return plan_sweep(base, pressure=list(np.linspace(0.0, 0.2, max(1, points // PAYLOADS))), payload=list(np.linspace(0.0, 2.0, PAYLOADS)))


def _timed(fn: Callable[[], Any], repeat: int) -> tuple[list[float], Any]:
    times, last = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        last = fn()
        times.append(time.perf_counter() - t0)
    return times, last


def _on_cluster(runner, plan: SweepPlan, options: BatchOptions, chunk: int, repeat: int) -> tuple[list[float], list[float], Any]:
    """Wall times of the study on ``runner``, and the time its workers spent solving chunks (Dask's task stream)."""
    from distributed import get_task_stream

    times, busy, last = [], [], None
    for _ in range(repeat):
        with get_task_stream(runner.client) as stream:
            t0 = time.perf_counter()
            last = sweep_study(plan, options, runner=runner, chunk=chunk)
            times.append(time.perf_counter() - t0)
        busy.append(sum(ss["stop"] - ss["start"] for task in stream.data for ss in task["startstops"] if ss["action"] == "compute"))
    return times, busy, last


def _row(where: str, workers: int, chunk: int | None, chunks: int, times: list[float], points: int, identical: bool, busy: list[float] | None = None) -> dict[str, Any]:
    median = statistics.median(times)
    return {
        "where": where,
        "workers": workers,
        "chunk": chunk,
        "chunks": chunks,
        "times_s": times,
        "median_s": median,
        "per_second": points / median,
        "identical": identical,
        # the workers' time in chunks, per equilibrium (in this process: the wall time): more than
        # with one worker when the workers slow each other down (shared cores)
        "busy_us": 1e6 * (statistics.median(busy) if busy else median) / points,
    }


def scaling_benchmark(
    points: int = DEFAULTS["points"],
    segments: int = DEFAULTS["segments"],
    repeat: int = DEFAULTS["repeat"],
    chunk: int = DEFAULTS["chunk"],
    chunk_sizes: Sequence[int] = DEFAULTS["chunk_sizes"],
    workers: Sequence[int] = DEFAULTS["workers"],
    scheduler: str | None = None,
    timeout: float = 10.0,
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Throughput of one sweep grid in this process and on Dask clusters; see the module.

    Returns a JSON-ready dict: ``setup`` (grid, backend, machine, versions, compile time, load
    averages), ``rows`` (one per place and worker count at ``chunk``), ``clusters`` (start-up and
    first-chunk times), ``chunks`` (throughput against the chunk size) and ``overhead`` (the
    round trip of one chunk).
    """
    say = progress or (lambda msg: None)
    plan = study_plan(points, segments)
    check_points(plan)  # every row is kept to compare the runs
    check_size(plan.size, segments, f"a study of {plan.size} points at n = {segments}", SweepError)
    if scheduler is not None:  # an address that answers nothing is refused before the in-process runs
        with open_runner(scheduler=scheduler, timeout=timeout):
            pass
    load_before = os.getloadavg()
    size = plan.size
    model = plan.base.model()
    options, backend = decide_backend(model, BatchOptions(compile="always" if _has_compiler() else "never"), plan.angle_mode, size)
    build_s, compile_s = prepare(model, options, plan.angle_mode)
    key = ModelKey.of(plan.base)

    say(f"in this process: {size} points, n = {segments}")
    sweep(plan.base, options=options, **plan.axes)  # warm: first calls of NumPy's and CasADi's kernels, untimed
    sweep_times, reference = _timed(lambda: sweep(plan.base, options=options, **plan.axes), repeat)
    ref_rows = reference.rows()
    rows = [_row("in this process, one batch (esba sweep)", 0, None, 1, sweep_times, size, True)]
    growth = _growth(plan, segments, options, repeat, sweep_times)
    serial: dict[int, dict[str, Any]] = {}
    for c in sorted(set(chunk_sizes) | {chunk}):
        times, study = _timed(lambda c=c: sweep_study(plan, options, runner=SerialRunner(), chunk=c), repeat)
        serial[c] = _row("in this process, chunk by chunk", 0, c, study.chunks, times, size, study.result.rows() == ref_rows)
    rows.append(serial[chunk])

    # the same chunk solved here, for the round-trip overhead
    small = min(DEFAULTS["round_trip_points"], size)
    here_times, _ = _timed(lambda: run_task(key, solve_points, plan, 0, small, options), DEFAULTS["round_trips"])

    clusters, by_chunk, overhead = [], {}, None
    counts = list(workers) if scheduler is None else [None]
    for w in counts:
        label = f"{w} worker{'s' if w != 1 else ''}" if w is not None else "the cluster"
        say(f"Dask: {label}")
        t0 = time.perf_counter()
        with open_runner(workers=w, scheduler=scheduler, timeout=timeout) as runner:
            start_s = time.perf_counter() - t0
            t1 = time.perf_counter()
            runner.client.run(run_task, key, solve_points, plan, 0, 1, options)  # every worker: model, library
            warm_s = time.perf_counter() - t1
            sweep_study(plan, options, runner=runner, chunk=chunk)  # warm, untimed: every worker meets the retry's library too
            n_workers = runner.workers
            clusters.append({"workers": n_workers, "where": runner.description, "start_s": start_s, "first_chunk_s": warm_s})
            times, busy, study = _on_cluster(runner, plan, options, chunk, repeat)
            rows.append(_row(runner.description, n_workers, chunk, study.chunks, times, size, study.result.rows() == ref_rows, busy))
            if w == min(counts, key=lambda v: v or 0) or scheduler is not None:
                trips = []
                for _ in range(DEFAULTS["round_trips"]):
                    t1 = time.perf_counter()
                    runner.client.submit(run_task, key, solve_points, plan, 0, small, options, pure=False).result()
                    trips.append(time.perf_counter() - t1)
                overhead = {
                    "workers": n_workers,
                    "points": small,
                    "round_trip_s": statistics.median(trips),
                    "in_process_s": statistics.median(here_times),
                }
                overhead["overhead_s"] = overhead["round_trip_s"] - overhead["in_process_s"]
            if w == max(counts, key=lambda v: v or 0):
                for c in sorted(set(chunk_sizes) | {chunk}):
                    if c == chunk:
                        by_chunk[c] = rows[-1]
                        continue
                    times, busy, study = _on_cluster(runner, plan, options, c, repeat)
                    by_chunk[c] = _row(runner.description, n_workers, c, study.chunks, times, size, study.result.rows() == ref_rows, busy)
    import casadi
    import distributed

    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        cores = os.cpu_count() or 1
    setup = {
        "points": size,
        "segments": segments,
        "grid": f"{len(plan.axes['pressure'])} pressures 0-0.2 MPa x {PAYLOADS} horizontal tip payloads 0-2 N",
        "repeat": repeat,
        "chunk": chunk,
        "backend": backend.split(", cached")[0],
        "compile": options.compile,
        "build_s": build_s,
        "compile_s": compile_s,
        "cores": cores,
        "load_before": list(load_before),
        "load_after": list(os.getloadavg()),
        "python": platform.python_version(),
        "casadi": casadi.__version__,
        "dask": distributed.__version__,
        "scheduler": scheduler,
        "methods": {m: int(np.sum(reference.method == m)) for m in sorted(set(reference.method.tolist()))},
        "batch_block": options.chunk,
        "tail_block": TAIL_CHUNK,
        "window_per_worker": WINDOW_PER_WORKER,
    }
    chunks = [
        {"chunk": c, "chunks": serial[c]["chunks"], "in_process_per_second": serial[c]["per_second"],
         "cluster_per_second": by_chunk[c]["per_second"] if c in by_chunk else None,
         "cluster_workers": by_chunk[c]["workers"] if c in by_chunk else None,
         "identical": serial[c]["identical"] and (by_chunk[c]["identical"] if c in by_chunk else True)}
        for c in sorted(serial)
    ]
    return {"setup": setup, "rows": rows, "clusters": clusters, "chunks": chunks, "overhead": overhead, "growth": growth}


def _growth(plan: SweepPlan, segments: int, options: BatchOptions, repeat: int, full_times: list[float]) -> list[dict[str, Any]]:
    """The in-process sweep (one batch) at a quarter of the grid and at the whole grid: the median
    wall time and the time per equilibrium at each size. Linear growth keeps the time per
    equilibrium the same; a cost that grows with N per point (a property recomputed over the whole
    batch at every point made it O(N^2) once) shows as a larger time per equilibrium at the larger size."""
    quarter = study_plan(max(PAYLOADS, plan.size // 4), segments)
    times, _ = _timed(lambda: sweep(quarter.base, options=options, **quarter.axes), repeat)
    return [
        {"points": quarter.size, "median_s": statistics.median(times), "per_point_us": 1e6 * statistics.median(times) / quarter.size},
        {"points": plan.size, "median_s": statistics.median(full_times), "per_point_us": 1e6 * statistics.median(full_times) / plan.size},
    ]


def _has_compiler() -> bool:
    from esba.statics.batch import compiler

    return compiler() is not None


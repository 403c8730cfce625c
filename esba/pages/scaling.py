"""``docs/scaling.md``: the page of ``esba bench scaling`` (presentation only; the measurements are
:func:`esba.bench.scaling.scaling_benchmark`). ``esba docs --check scaling`` reruns the benchmark
(one repeat) and compares, times aside: every time, rate and ratio of times, the load averages
and the versions are written through :class:`esba.pages.page.Times`.

Examples
--------
>>> data = {"setup": {"points": 10, "segments": 3, "grid": "g", "repeat": 1, "chunk": 5, "backend": "b",
...   "compile": "never", "build_s": 0.1, "compile_s": 0.0, "cores": 2, "load_before": [1.0, 1.0, 1.0], "load_after": [1.0, 1.0, 1.0],
...   "python": "3", "casadi": "3", "dask": "1", "scheduler": None, "methods": {"newton": 10},
...   "batch_block": 1000, "tail_block": 64, "window_per_worker": 4},
...   "rows": [{"where": "in this process, one batch (esba sweep)", "workers": 0, "chunk": None, "chunks": 1,
...             "times_s": [0.1], "median_s": 0.1, "per_second": 100.0, "identical": True, "busy_us": 1e4}],
...   "clusters": [], "chunks": [], "overhead": None}
>>> "100 equilibria/s" in scaling_page(data, "esba bench scaling")
True
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .page import TIMES, Page, Progress, Rendered, Times

__all__ = ["PAGE", "ScalingPage", "ScalingSettings", "scaling_page", "summary", "SLURM_EXAMPLE"]

#: How to run the same study on a SLURM cluster (documented, not run here).
SLURM_EXAMPLE = '''\
```python
# slurm_cluster.py: start Dask workers as SLURM jobs and keep them while the study runs
from dask_jobqueue import SLURMCluster   # pip install dask-jobqueue

cluster = SLURMCluster(
    cores=8, processes=8,                # 8 worker processes of one thread each per job (CasADi's IPOPT is not thread-safe)
    memory="16GB", walltime="04:00:00",
    queue="compute", account="my-project",
    job_script_prologue=[                # the same esba on every node, and one model/library cache for all
        "source ~/esba-venv/bin/activate",
        "export ESBA_CACHE_DIR=$HOME/.cache/esba",
    ],
)
cluster.scale(jobs=10)                   # 10 jobs x 8 = 80 workers
print(cluster.scheduler_address)         # e.g. tcp://10.1.2.3:40123
input("the cluster runs until you press Enter")
```

With the cluster up, from the login node (or any node that reaches the scheduler), the same commands:

```sh
esba bench scaling --scheduler tcp://10.1.2.3:40123 --markdown scaling-slurm.md   # this page, for that cluster
esba sweep --r2 0.5:7.5:40 --d 0:7.5:40 --pressure 0:0.3:40 -n 16 \\
    --scheduler tcp://10.1.2.3:40123 --out study.csv --resume                     # run again after any interruption
```

Each worker checks that its esba (code and derivation) is the client's before it solves anything,
and loads the model itself. The client compiles the batch library into its `ESBA_CACHE_DIR`
before the study starts; workers that share that folder (a shared home) load it, others compile it
once each. Without dask-jobqueue, any Dask cluster does: `dask scheduler` on one node,
`dask worker tcp://HOST:8786 --nthreads 1 --nworkers 8` on the others.
'''


def _rate(v: float | None, t: Times = TIMES) -> str:
    return "-" if v is None else t(v, ",.0f")


def _methods(counts: dict[str, int]) -> str:
    """How many points each method answered, in words: ``newton 10, ipopt 2``."""
    return ", ".join(f"{m} {c:,}" for m, c in counts.items())


def scaling_page(data: dict[str, Any], command: str, t: Times = TIMES) -> str:
    """The Markdown of ``docs/scaling.md`` from :func:`esba.bench.scaling.scaling_benchmark`."""
    st = data["setup"]
    rows = data["rows"]
    base = rows[0]["per_second"]
    lines = [
        "# Sweeps and Monte Carlo on Dask: scaling",
        "",
        f"Written by `{command}`; rerun it to refresh. Every number on this page comes from that command.",
        "",
        f"The study: a sweep grid of {st['points']:,} equilibria at n = {st['segments']} ({st['grid']}), each along its load",
        f"path on the batch path ({st['backend']}; answered by {_methods(st['methods'])}). Each time is the median of {t(st['repeat'])}",
        f"runs. The machine: {t(st['cores'])} cores shared with other work (load average {t(st['load_before'][0], '.2f')} before the",
        f"benchmark, {t(st['load_after'][0], '.2f')} after), Python {t(st['python'])}, CasADi {t(st['casadi'])}, Dask {t(st['dask'])}.",
        t.word(f"Before any timing the batch path's graph was built ({st['build_s']:.1f} s) and compiled to C ({st['compile_s']:.1f} s), once: "
               "the library is cached and every worker loads it." if st["compile_s"] > 0 else
               f"Before any timing the batch path's graph was built ({st['build_s']:.1f} s){' and its compiled library found in the cache' if st['compile'] == 'always' else ''}."),
        "",
        "## Throughput against the worker count",
        "",
        f"Chunks of {st['chunk']} points (the batch path's block). Identical: every row equal to the in-process sweep's, element for element.",
        "",
        "| where | workers | chunks | wall time (s) | equilibria/s | vs. in process | solving time per equilibrium (µs) | identical |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['where']} | {r['workers'] or '-'} | {r['chunks']} | {t(r['median_s'], '.2f')} | {_rate(r['per_second'], t)} equilibria/s | "
            f"{t(r['per_second'] / base, '.2f')}x | {t(r['busy_us'], '.0f')} | {'yes' if r['identical'] else '**no**'} |"
        )
    lines += [
        "",
        "Solving time per equilibrium: the time the workers spent in chunks (Dask's task stream, summed over workers;",
        "in this process, the wall time) over the points. Where it grows with the worker count, the workers slowed",
        "each other down: they share the cores.",
    ]
    growth = data.get("growth") or []
    if len(growth) == 2:
        small, large = growth
        lines += [
            "",
            "## In this process against the grid's size",
            "",
            "One batch (`esba sweep`) of a quarter of the grid and of the whole grid: a sweep in this process grows",
            "linearly with its points when the time per equilibrium stays the same.",
            "",
            "| points | wall time (s) | time per equilibrium (µs) |",
            "|---|---|---|",
            *[f"| {g['points']:,} | {t(g['median_s'], '.2f')} | {t(g['per_point_us'], '.0f')} |" for g in growth],
            "",
            f"{large['points'] / small['points']:.0f}x the points took {t(large['median_s'] / small['median_s'], '.2f')}x the time"
            f" ({t(large['per_point_us'] / small['per_point_us'], '.2f')}x the time per equilibrium).",
        ]
    dask_rows = [r for r in rows if r["workers"]]
    if dask_rows:
        most = max(dask_rows, key=lambda r: r["workers"])
        one = next((r for r in dask_rows if r["workers"] == 1), None)
        if one is not None and most["workers"] > 1:
            lines += [
                "",
                f"{most['workers']} workers solve {t(most['per_second'] / one['per_second'], '.2f')}x as many equilibria per second as 1 worker, and "
                f"{t(most['per_second'] / base, '.2f')}x as many as one batch in this process; the ideal on {t(st['cores'])} cores is "
                f"{t(min(most['workers'], st['cores']))}x, and these cores also run the client, the scheduler and other work.",
            ]
    if data["clusters"]:
        lines += [
            "",
            "## Starting a cluster",
            "",
            "| cluster | start (s) | first chunk on every worker (s) |",
            "|---|---|---|",
        ]
        for c in data["clusters"]:
            lines.append(f"| {c['where']} | {t(c['start_s'], '.2f')} | {t(c['first_chunk_s'], '.2f')} |")
        lines += [
            "",
            "Starting a local cluster spawns its worker processes; the first chunk a worker solves imports esba and",
            "loads the model (`esba.model.generated.load_model`, once per process) and the compiled library. A study pays these",
            "once per cluster and once per worker; the throughput above leaves them out.",
        ]
    if data["chunks"]:
        cl = next((c["cluster_workers"] for c in data["chunks"] if c["cluster_workers"]), None)
        lines += [
            "",
            "## What the chunk size does",
            "",
            f"| points per chunk | chunks | in this process (equilibria/s) | {cl} workers (equilibria/s) | identical |" if cl else
            "| points per chunk | chunks | in this process (equilibria/s) | - | identical |",
            "|---|---|---|---|---|",
        ]
        for c in data["chunks"]:
            lines.append(f"| {c['chunk']} | {c['chunks']} | {_rate(c['in_process_per_second'], t)} | {_rate(c['cluster_per_second'], t)} | {'yes' if c['identical'] else '**no**'} |")
        serial = [c["in_process_per_second"] for c in data["chunks"]]
        verdict: list[str] = []
        if serial and min(serial) > base:
            verdict = ["", f"In this process every chunk size here ({min(serial) / base:.2f}x to {max(serial) / base:.2f}x) beats one batch of the whole grid."]
        elif serial and max(serial) < base:
            verdict = ["", "In this process one batch of the whole grid beats every chunk size here."]
        lines += t.lines(verdict)
        lines += [
            "",
            f"A chunk is one task: its points go to the batch path as calls of the mapped Function on {st['batch_block']} points and,",
            f"for the rest, on {st['tail_block']} (the last one padded), then through the retry and the IPOPT fallback for the few that",
            "need them. Small chunks pay the task's round trip and the batch path's per-call costs more often; large",
            "chunks leave workers idle at the end of the study and hold more rows in memory. The answers do not depend",
            "on the chunk size.",
        ]
    ov = data.get("overhead")
    if ov:
        share = ov["overhead_s"] / max(ov["in_process_s"], 1e-12)
        lines += [
            "",
            "## The overhead of one chunk",
            "",
            f"A chunk of {ov['points']} points sent through the scheduler to a warm worker and back: {t(1e3 * ov['round_trip_s'], '.1f')} ms",
            f"(median); the same chunk solved in this process: {t(1e3 * ov['in_process_s'], '.1f')} ms. The difference,",
            f"**{t(1e3 * ov['overhead_s'], '.1f')} ms per chunk**, is what Dask adds (scheduling, serialising the task and its",
            f"result, the transfer; {t(100 * share, '.0f')} % of this chunk's solve time). While a worker solves one chunk the next ones",
            f"are already queued (up to {st['window_per_worker']} per worker), so in a running study much of this latency overlaps the solving.",
        ]
    lines += [
        "",
        "## Running it on a SLURM cluster (dask-jobqueue)",
        "",
        "The same commands take `--scheduler ADDRESS` instead of `--workers N`. An example, not run here:",
        "",
        SLURM_EXAMPLE.rstrip(),
        "",
        "## Files and resuming",
        "",
        "With `--out FILE.csv`, rows stream to the file in grid order as soon as a chunk and every chunk before it",
        "are solved; the study's settings and hash are in `FILE.study.json` beside it (the CSV is plain: `pandas.read_csv(FILE)`). `--resume` checks",
        "that the file is the same study (grid, scene, batch settings, esba code), keeps its complete rows, drops a",
        "row cut short, and solves the rest: the finished file is the uninterrupted one. A worker that dies has its",
        "chunks run again by Dask; each chunk's rows are written once.",
    ]
    return "\n".join(lines) + "\n"


def summary(data: dict[str, Any]) -> str:
    """The table ``esba bench scaling`` prints."""
    st = data["setup"]
    lines = [f"{st['points']} equilibria, n = {st['segments']}; {st['backend']}; load {st['load_before'][0]:.2f} -> {st['load_after'][0]:.2f}",
             f"{'where':<62} {'chunk':>6} {'median s':>9} {'eq/s':>9}  identical"]
    for r in data["rows"]:
        lines.append(f"{r['where']:<62} {r['chunk'] or '-':>6} {r['median_s']:9.2f} {r['per_second']:9.0f}  {r['identical']}")
    for c in data["chunks"]:
        lines.append(f"chunk {c['chunk']:>6}: in process {_rate(c['in_process_per_second']):>9} eq/s; cluster {_rate(c['cluster_per_second']):>9} eq/s")
    for g in data.get("growth") or []:
        lines.append(f"in this process, {g['points']:>7} points: {g['median_s']:.2f} s, {g['per_point_us']:.0f} us per equilibrium")
    if data["overhead"]:
        lines.append(f"overhead per chunk: {1e3 * data['overhead']['overhead_s']:.1f} ms")
    if data.get("page"):
        lines.append(f"wrote {data['page']}")
    return "\n".join(lines)


@dataclass(frozen=True)
class ScalingSettings:
    """What ``esba bench scaling`` takes (see :data:`esba.bench.scaling.DEFAULTS`), and the command the page names."""

    points: int = 12_000
    segments: int = 16
    repeat: int = 3
    chunk: int = 1000
    workers: tuple[int, ...] = (1, 2)
    scheduler: str | None = None
    timeout: float = 10.0
    command: str = "esba bench scaling --markdown docs/scaling.md"


class ScalingPage(Page):
    """``docs/scaling.md`` (the benchmark needs the ``dask`` extra)."""

    name = "scaling"

    def settings(self) -> ScalingSettings:
        return ScalingSettings()

    def check_settings(self) -> ScalingSettings:
        return dataclasses.replace(self.settings(), repeat=1)

    def compute(self, settings: ScalingSettings | None = None, progress: Progress | None = None) -> dict[str, Any]:
        from esba.bench.scaling import scaling_benchmark

        s = self.settings() if settings is None else settings
        return scaling_benchmark(points=s.points, segments=s.segments, repeat=s.repeat, chunk=s.chunk, workers=s.workers,
                                 scheduler=s.scheduler, timeout=s.timeout, progress=progress)

    def render(self, data: dict[str, Any], settings: ScalingSettings, path: Path, times: Times = TIMES) -> Rendered:
        return Rendered(scaling_page(data, settings.command, times))


PAGE = ScalingPage()

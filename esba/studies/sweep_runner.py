"""A sweep grid solved chunk by chunk: in this process or on Dask workers, kept in memory or
streamed to a CSV file, and resumed from that file after an interruption.

:func:`sweep_study` splits a :class:`esba.studies.sweep.SweepPlan` into chunks of ``chunk`` points
(default: one call of the batch path's mapped Function, :attr:`esba.statics.batch.BatchOptions.chunk`)
and solves each with :func:`esba.studies.sweep.solve_points` on a runner of :mod:`esba.studies.distributed`. The
backend of the batch path (compiled C or CasADi's interpreter) is decided once for the whole
grid, as :func:`esba.studies.sweep.sweep` decides it, so the rows are the in-process sweep's, element
for element, in the same order.

- Without ``out`` the chunks' arrays are gathered into a :class:`esba.studies.sweep.SweepResult`.
- With ``out`` (a ``.csv`` file) each chunk's rows are appended as soon as it and the chunks
  before it are solved (:class:`esba.studies.chunks.StudyFile`); nothing of the grid is held in memory but
  a few chunks. With ``resume`` a study continues from the rows its file holds, once the file's
  metadata shows the same study (grid, scene, batch settings, esba code) and keeps its backend.

Examples
--------
>>> from esba.model.scene import Scene
>>> from esba.studies.sweep import plan_sweep, sweep
>>> plan = plan_sweep(Scene(pressure=0.1), r2=[2.0, 3.0, 5.0], d=[2.0, 4.0])
>>> s = sweep_study(plan, BatchOptions(compile="never"), chunk=4)
>>> s.chunks, s.counts, s.result.rows() == sweep(Scene(pressure=0.1), r2=[2.0, 3.0, 5.0], d=[2.0, 4.0], options=BatchOptions(compile="never")).rows()
(2, {'ok': 5, 'not ok': 0, 'infeasible': 1}, True)
"""

from __future__ import annotations

import csv
import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from esba.statics.batch import (
    BatchOptions,
    BatchOptionsError,
    check_size,
    decide_backend,
    prepare,
)
from esba.model.validity import Tally
from esba.statics.batch_options import DEFAULT_BATCH_OPTIONS

from .chunks import MAX_CHUNK, StudyError, StudyFile, checked_rows, chunk_bounds, run_chunks
from .distributed import ModelKey, SerialRunner
from .sweep import (
    AXES,
    SweepError,
    SweepPlan,
    SweepResult,
    check_points,
    check_resolvable,
    parse_row,
    point_rows,
    resumed_row_problem,
    row_fields,
    solve_points,
    study_identity,
)

__all__ = ["SweepStudy", "sweep_study", "check_study", "read_rows", "DEFAULT_CHUNK", "MAX_CHUNK"]

#: Points per chunk unless told: one call of the batch path's mapped Function.
DEFAULT_CHUNK = DEFAULT_BATCH_OPTIONS.chunk


@dataclass(frozen=True, eq=False)
class SweepStudy:
    """What a chunked sweep did.

    Attributes
    ----------
    plan : SweepPlan
    counts : dict
        Points ok, not ok and infeasible (over the whole grid, resumed rows included).
    backend : str
        How the batch path ran, decided once for the grid (or by the study being resumed).
    runner : str
        Where the chunks ran.
    workers : int
        Worker processes when the study started.
    chunk : int
        Points per chunk.
    chunks : int
        Chunks solved by this run.
    resumed_from : int
        Rows the file already held (0 for a new study).
    seconds : float
        Wall time of this run.
    out : Path or None
        The CSV file the rows were streamed to.
    hash : str or None
        The study's hash (in the file's metadata, beside it).
    result : SweepResult or None
        Every point, when the rows were gathered in memory (no ``out``).
    tally : Tally
        Rows outside the range the paper's model describes (a non-empty ``validity`` column), by check.
    """

    plan: SweepPlan
    counts: dict
    backend: str
    runner: str
    workers: int
    chunk: int
    chunks: int
    resumed_from: int
    seconds: float
    out: Path | None = None
    hash: str | None = None
    result: SweepResult | None = None
    tally: Tally = dataclasses.field(default_factory=Tally)

    @property
    def outside(self) -> int:
        """Rows outside the range the paper's model describes."""
        return self.tally.points

    def rows(self) -> list[dict[str, Any]]:
        """Every row, from memory or read back from the file (exactly the values written)."""
        if self.result is not None:
            return self.result.rows()
        assert self.out is not None
        return read_rows(self.out)

    def describe(self) -> dict[str, Any]:
        """How the study ran (JSON-ready)."""
        return {
            "runner": self.runner,
            "workers": self.workers,
            "chunk": self.chunk,
            "chunks_solved": self.chunks,
            "resumed_from_row": self.resumed_from,
            "rows": self.plan.size,
            "seconds": self.seconds,
            "out": str(self.out) if self.out is not None else None,
            "hash": self.hash,
        }

    def to_dict(self, rows: bool = True) -> dict[str, Any]:
        """JSON-ready: as :meth:`esba.studies.sweep.SweepResult.to_dict` (rows read back from the file when
        they were streamed), plus ``study``: how it ran."""
        if self.result is not None:
            data = self.result.to_dict()
            if not rows:
                data.pop("rows")
        else:
            base = self.plan.base
            data = {
                "base": base.describe(),
                "segments": base.segments,
                "axes": {k: {"values": v, "unit": AXES[k]} for k, v in self.plan.axes.items()},
                "counts": dict(self.counts),
                "outside_model_range": self.outside,
                "backend": self.backend,
                "timings_s": {},
            }
            if rows:
                data["rows"] = self.rows()
        data["study"] = self.describe()
        return data


def read_rows(path: str | Path) -> list[dict[str, Any]]:
    """The rows of a sweep's study file (:func:`esba.studies.sweep.parse_row`: numbers exact, empty cells None)."""
    with open(path, encoding="utf-8", newline="") as fh:
        return [parse_row(r) for r in csv.DictReader(fh)]


def _identity(plan: SweepPlan, options: BatchOptions) -> dict[str, Any]:
    return study_identity(plan, options)


def check_study(plan: SweepPlan, chunk: int, streamed: bool) -> None:
    """Refuse, before any cluster starts or any point is solved, a study that would not fit: every
    row gathered in memory (not ``streamed``) is bounded like :func:`esba.studies.sweep.sweep`, a chunk by
    the batch path's memory, and the grid's scales must be ones the solver resolves."""
    if not streamed:  # every row is gathered here
        check_points(plan)
        check_size(plan.size, plan.base.segments, "the sweep", SweepError)
    check_size(min(chunk, plan.size), plan.base.segments, "a chunk of the sweep", StudyError)
    check_resolvable(plan)


def sweep_study(
    plan: SweepPlan,
    options: BatchOptions | None = None,
    *,
    runner=None,
    chunk: int = DEFAULT_CHUNK,
    out: str | Path | None = None,
    resume: bool = False,
    progress: bool = False,
) -> SweepStudy:
    """Solve a sweep grid chunk by chunk on ``runner`` (default: in this process).

    Parameters
    ----------
    plan : SweepPlan
        From :func:`esba.studies.sweep.plan_sweep`.
    options : BatchOptions, optional
        As for :func:`esba.studies.sweep.sweep` (``compile="auto"`` is decided once for the grid;
        ``progress`` is replaced by this function's bar over chunks).
    runner : SerialRunner or DaskRunner, optional
        From :func:`esba.studies.distributed.open_runner`.
    chunk : int
        Points per chunk.
    out : str or Path, optional
        A ``.csv`` file to stream the rows to (else they are gathered in memory).
    resume : bool
        Continue the study in ``out`` from the rows it holds (a new study when the file does not
        exist or is empty).
    progress : bool
        A tqdm bar on stderr over the points of completed chunks.

    Raises
    ------
    StudyError
        for a file that cannot be written, or resumed as this study.
    """
    options = DEFAULT_BATCH_OPTIONS if options is None else options
    if not isinstance(options, BatchOptions):
        raise BatchOptionsError(f"options={options!r}: expected a BatchOptions")
    if isinstance(chunk, bool) or not isinstance(chunk, int) or not 1 <= chunk <= MAX_CHUNK:
        raise StudyError(f"chunk={chunk!r}: expected a whole number of points from 1 to {MAX_CHUNK}")
    if resume and out is None:
        raise StudyError("resume=True needs the study's file: give out=FILE.csv")
    check_study(plan, chunk, streamed=out is not None)
    runner = SerialRunner() if runner is None else runner
    t0 = time.perf_counter()
    model = plan.base.model()
    counts = {"ok": 0, "not ok": 0, "infeasible": 0}
    tally = Tally()
    file = start = None
    if out is not None:
        file = StudyFile(out, "sweep", _identity(plan, options), row_fields(plan.base.segments), plan.size)

        def count(row: dict[str, str]) -> None:  # each row the file holds, once checked
            counts[row["status"]] = counts.get(row["status"], 0) + 1
            tally.add(row.get("validity") or "")

        if resume and file.path.exists() and file.path.stat().st_size > 0:
            start = file.resume(checked_rows(out, lambda i, row: resumed_row_problem(plan, i, row), count))
            decided = file.settings.get("compile")
            if decided not in ("always", "never"):
                file.close()
                raise StudyError(f"--resume {file.path}: its metadata has no backend decision (compile={decided!r})")
            fixed, backend = dataclasses.replace(options, compile=decided), str(file.settings.get("backend", ""))
    try:
        if start is None:
            fixed, backend = decide_backend(model, options, plan.angle_mode, plan.size)
            if file is not None:
                file.start({"compile": fixed.compile, "backend": backend})
        fixed = dataclasses.replace(fixed, progress=False)
        if fixed.compile == "always":
            prepare(model, fixed, plan.angle_mode)  # one compilation here, not one per worker
        bounds = chunk_bounds(start or 0, plan.size, chunk)
        parts: list[dict[str, Any]] = []

        def keep(a: int, b: int, part: dict[str, Any]) -> None:
            if file is None:
                parts.append(part)
                return
            rows = point_rows(plan.columns(a, b), part)
            file.append(rows)
            for r in rows:
                counts[r["status"]] = counts.get(r["status"], 0) + 1
            for found in part.get("validity", ()):
                tally.add(found)

        workers = runner.workers
        run_chunks(runner, ModelKey.of(plan.base), solve_points, bounds, lambda a, b: (plan, a, b, fixed), keep, "esba sweep" if progress else None)
    finally:
        if file is not None:
            file.close()
    result = None
    if file is None:
        result = SweepResult.from_parts(plan, parts, backend, _identity(plan, options), {"compile": fixed.compile, "backend": backend})
        counts = result.counts()
        tally = result.tally()
    return SweepStudy(
        plan=plan,
        counts=counts,
        backend=backend,
        runner=runner.description,
        workers=workers,
        chunk=chunk,
        chunks=len(bounds),
        resumed_from=start or 0,
        seconds=time.perf_counter() - t0,
        out=file.path if file is not None else None,
        hash=file.hash if file is not None else None,
        result=result,
        tally=tally,
    )

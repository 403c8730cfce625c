"""The Monte Carlo's samples in a CSV file, written chunk by chunk and resumed after an interruption.

:func:`monte_carlo_study` runs :func:`esba.calibration.uncertainty.monte_carlo` (in this process or on Dask
workers) and appends each chunk's samples to a :class:`esba.studies.chunks.StudyFile` as soon as it and
the chunks before it are solved: one row per sample with the sample's parameter values (in the
scene file's units), its outcome (``ok``; ``invalid``: outside the scene's rules, not solved;
``not ok``: no stable equilibrium), the pressure (MPa), the segment angles and the total angle
(rad) and the tip (mm); empty cells where a sample has no equilibrium. Numbers are written in
Python's shortest round-trip form, so a resumed study reads back exactly the values it wrote and
ends with the same statistics as an uninterrupted one.

A study is resumed only by the same scene, sigmas, samples, seed, batch settings and esba code
(the hash in the file's metadata), and only when the samples in the file are the ones drawn again from
the seed (a NumPy whose generator draws other numbers is refused).

A 3-D Monte Carlo (``three_d=True``: :func:`esba.calibration.uncertainty3d.monte_carlo3d`) is one
such file too, of kind ``monte-carlo-3d``: its rows also hold psi and tau of every joint and the
tip's z, and its identity the section and gravity's direction; it resumes by the same rules.

Examples
--------
>>> import tempfile, pathlib
>>> from esba.model.scene import MAIN_JOB
>>> from esba.calibration.uncertainty import MonteCarloOptions, parse_sigma, resolve_sigmas
>>> sig = resolve_sigmas(MAIN_JOB, [parse_sigma("E=5%")])
>>> out = pathlib.Path(tempfile.mkdtemp()) / "mc.csv"
>>> opts = MonteCarloOptions(samples=20, chunk=8)
>>> mc, info = monte_carlo_study(MAIN_JOB, sig, opts, out=out)
>>> mc.counts["ok"], info["resumed_from_sample"], len(out.read_text().splitlines())  # column names and 20 rows
(20, 0, 21)
>>> again, info = monte_carlo_study(MAIN_JOB, sig, opts, out=out, resume=True)
>>> info["resumed_from_sample"], bool((again.tip == mc.tip).all())
(20, True)
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from esba.calibration import uncertainty, uncertainty3d
from esba.calibration.uncertainty import (
    SAMPLE_INVALID,
    SAMPLE_NOT_OK,
    SAMPLE_OK,
    MonteCarlo,
    MonteCarloOptions,
    Sigma,
    _batch_options,
    draw_samples,
)
from esba.calibration.uncertainty3d import MonteCarlo3D
from esba.infra import checks
from esba.model.scene import Scene
from esba.statics.batch import BatchOptions

from .chunks import StudyError, StudyFile, run_chunks
from .distributed import ModelKey, SerialRunner, code_digest

__all__ = ["monte_carlo", "monte_carlo3d", "monte_carlo_study", "sample_fields", "OUTCOMES"]


def monte_carlo(scene: Scene, sigmas: Sequence[Sigma], options: MonteCarloOptions | None = None, *, runner=None, **kwargs: Any) -> MonteCarlo:
    """:func:`esba.calibration.uncertainty.monte_carlo` with its chunks run on ``runner``
    (:func:`esba.studies.distributed.open_runner`: a local Dask cluster or an existing one; default:
    in this process, one after the other). The same samples and the same result either way.
    ``kwargs`` are those of :func:`esba.calibration.uncertainty.monte_carlo` (``chunks``, ``solved``,
    ``on_chunk``, ``progress``)."""
    return uncertainty.monte_carlo(scene, sigmas, options, **kwargs) if runner is None else uncertainty.monte_carlo(scene, sigmas, options, execute=_on(runner), **kwargs)


def monte_carlo3d(scene: Scene, sigmas: Sequence[Sigma], options: MonteCarloOptions | None = None, *, runner=None, **kwargs: Any) -> MonteCarlo3D:
    """:func:`esba.calibration.uncertainty3d.monte_carlo3d` with its chunks run on ``runner`` (as
    :func:`monte_carlo`); ``kwargs`` are that function's (``section``, ``gravity_direction``, ``chunks``, ...)."""
    return uncertainty3d.monte_carlo3d(scene, sigmas, options, **kwargs) if runner is None else uncertainty3d.monte_carlo3d(scene, sigmas, options, execute=_on(runner), **kwargs)


def _on(runner):
    """The ``execute`` of :func:`esba.calibration.uncertainty.run_samples` that runs the chunks on ``runner``."""

    def execute(scene_, fn, bounds, args_of, on_result, progress):
        run_chunks(runner, ModelKey.of(scene_), fn, bounds, args_of, on_result, progress)

    return execute

#: A sample's outcome in the file, by code.
OUTCOMES = {SAMPLE_OK: "ok", SAMPLE_INVALID: "invalid", SAMPLE_NOT_OK: "not ok"}


def _angles(n: int, three_d: bool) -> list[str]:
    return [f"{c}{k + 1}_rad" for c in (("theta", "psi", "tau") if three_d else ("theta",)) for k in range(n)]


def _results(n: int, three_d: bool) -> list[str]:
    """The result cells of a sample row (after its outcome and pressure)."""
    return [*_angles(n, three_d), "total_angle_rad", "tip_x_mm", "tip_y_mm", *(["tip_z_mm"] if three_d else [])]


def sample_fields(names: Sequence[str], n: int, three_d: bool = False) -> list[str]:
    """The columns of a sample file for the parameters ``names`` and n segments (with ``three_d``:
    also psi, tau and the tip's z)."""
    return ["sample", *names, "outcome", "pressure_mpa", *_results(n, three_d)]


def _cell(v: float) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


def _rows(start: int, names: Sequence[str], values: np.ndarray, part: dict[str, np.ndarray], n: int, three_d: bool) -> list[dict[str, Any]]:
    rows = []
    angles = part["q"] if three_d else part["theta"]
    total = part["total_angle"] if "total_angle" in part else np.sum(angles[:, :n], axis=1)  # as the Monte Carlo sums them
    for j in range(len(part["code"])):
        row: dict[str, Any] = {"sample": start + j}
        row.update({name: float(values[i, start + j]) for i, name in enumerate(names)})
        row["outcome"] = OUTCOMES[int(part["code"][j])]
        row["pressure_mpa"] = _cell(part["pressure"][j])
        row.update({c: _cell(v) for c, v in zip(_angles(n, three_d), angles[j])})
        row["total_angle_rad"] = _cell(total[j])
        row.update({f"tip_{c}_mm": _cell(v) for c, v in zip("xyz", part["tip"][j])})
        rows.append(row)
    return rows


def _number(text: str) -> float:
    """A result cell: '' (no value: NaN in the arrays) or a finite decimal number (a cell that
    reads 'nan' or 'inf' was not written by the study: ValueError)."""
    if text == "":
        return math.nan
    value = checks.number("cell", text, subnormal=True)  # as written: any double
    if not math.isfinite(value):
        raise ValueError(text)
    return value


def sample_row_problem(n: int, row: dict[str, Any], three_d: bool = False) -> str:
    """Why a resumed sample row cannot be a solved sample, or ``""``: an ``ok`` sample has finite
    angles, tip and total angle, and the total is the sum of the angles.

    >>> sample_row_problem(1, {"outcome": "ok", "theta1_rad": "0.5", "total_angle_rad": "0.7", "tip_x_mm": "1", "tip_y_mm": "2"})
    'is ok but its total_angle_rad=0.7 is not the sum of its angles (0.5)'
    """
    if row.get("outcome") not in OUTCOMES.values():
        return f"has outcome={checks.quote(row.get('outcome'), 30)}; a Monte Carlo writes {', '.join(OUTCOMES.values())}"
    cells = _results(n, three_d)
    try:
        values = {c: _number(row.get(c, "")) for c in cells}
    except ValueError:
        return "has a cell that is not a finite number (as written, an empty cell is no value)"
    if row.get("outcome") != OUTCOMES[SAMPLE_OK]:
        return ""
    empty = [c for c in cells if math.isnan(values[c])]
    if empty:
        return f"is ok but has no {empty[0]}"
    total = sum(values[f"theta{k + 1}_rad"] for k in range(n))
    if abs(total - values["total_angle_rad"]) > 1e-9 * max(1.0, abs(total)):
        return f"is ok but its total_angle_rad={row['total_angle_rad']} is not the sum of its angles ({total:.12g})"
    return ""


def monte_carlo_study(
    scene: Scene,
    sigmas: Sequence[Sigma],
    options: MonteCarloOptions | None = None,
    *,
    runner=None,
    out: str | Path,
    resume: bool = False,
    progress: bool = False,
    three_d: bool = False,
    section: dict | None = None,
    gravity_direction=None,
) -> tuple[MonteCarlo, dict[str, Any]]:
    """:func:`esba.calibration.uncertainty.monte_carlo` with every sample streamed to ``out`` (CSV), resumable.

    With ``three_d`` it is :func:`esba.calibration.uncertainty3d.monte_carlo3d` (``section`` and
    ``gravity_direction`` are its), its rows also with psi, tau and the tip's z, its file of kind
    ``monte-carlo-3d``.

    Returns the Monte Carlo (all samples, the resumed ones read back from the file) and how the
    study ran: ``runner``, ``workers``, ``resumed_from_sample``, ``seconds``, ``out``, ``hash``.

    Raises
    ------
    StudyError
        for a file that cannot be written, or resumed as this study.
    """
    options = MonteCarloOptions() if options is None else options
    runner = SerialRunner() if runner is None else runner
    t0 = time.perf_counter()
    names = [s.name for s in sigmas]
    identity = {
        "scene": dataclasses.asdict(scene),
        "sigmas": [s.to_dict() for s in sigmas],
        "samples": options.samples,
        "seed": options.seed,
        "batch": None if options.batch is None else {k: v for k, v in dataclasses.asdict(options.batch).items() if k not in ("progress", "cache")},
        "esba": code_digest(),
    }
    if three_d:
        from esba.statics.spatial import SpatialError, check_direction, check_section

        try:
            section = check_section(section, scene)
            gravity_direction = tuple(float(x) for x in check_direction("gravity direction", scene.down(gravity_direction)))
        except SpatialError as exc:
            raise StudyError(str(exc)) from None
        identity.update(model="3d", section=section, gravity_direction=list(gravity_direction))
    n = scene.segments
    file = StudyFile(out, "monte-carlo-3d" if three_d else "monte-carlo", identity, sample_fields(names, n, three_d), options.samples)
    solved = None
    values = draw_samples(sigmas, options.samples, options.seed)
    if resume and file.path.exists() and file.path.stat().st_size > 0:
        rows: list[dict[str, str]] = []
        count = file.resume(rows.append)
        bad = next(((i, p) for i, p in ((i, sample_row_problem(n, r, three_d)) for i, r in enumerate(rows)) if p), None)
        if bad is not None:  # checked before the rows are read into arrays
            file.close()
            raise StudyError(f"--resume {file.path}: sample row {bad[0] + 1} {bad[1]}; it is not kept: remove the file to start anew")
        try:
            drawn = np.array([[float(r[name]) for name in names] for r in rows]).reshape(count, len(names)).T
            same = all(int(r["sample"]) == i for i, r in enumerate(rows)) and np.array_equal(drawn, values[:, :count])
            codes = {v: k for k, v in OUTCOMES.items()}
            angles = _angles(n, three_d)
            tips = [f"tip_{c}_mm" for c in ("xyz" if three_d else "xy")]
            solved = {
                "code": np.array([codes[r["outcome"]] for r in rows], dtype=int),
                "q" if three_d else "theta": np.array([[_number(r[c]) for c in angles] for r in rows]).reshape(count, len(angles)),
                "tip": np.array([[_number(r[c]) for c in tips] for r in rows]).reshape(count, len(tips)),
            }
            if not three_d:
                solved["total_angle"] = np.array([_number(r["total_angle_rad"]) for r in rows])
        except (KeyError, ValueError):
            file.close()
            raise StudyError(f"--resume {file.path}: a row's sample number, parameter values or outcome cannot be read; remove the file to start anew") from None
        if not same:
            file.close()
            raise StudyError(f"--resume {file.path}: its samples are not the ones drawn again from seed {options.seed} (another NumPy?); remove the file to start anew")
        if not three_d:
            decided = file.settings.get("compile")
            if decided not in ("always", "never"):
                file.close()
                raise StudyError(f"--resume {file.path}: its metadata has no backend decision (compile={decided!r})")
            batch = options.batch if options.batch is not None else BatchOptions()
            options = dataclasses.replace(options, batch=dataclasses.replace(batch, compile=decided))
    elif three_d:
        file.start({})
    else:
        batch = _batch_options(options, scene)
        options = dataclasses.replace(options, batch=batch)
        file.start({"compile": batch.compile})
    done = 0 if solved is None else len(solved["code"])
    try:

        def write(start: int, part: dict[str, np.ndarray]) -> None:
            file.append(_rows(start, names, values, part, n, three_d))

        workers = runner.workers
        if three_d:
            mc = monte_carlo3d(scene, sigmas, options, runner=runner, section=section, gravity_direction=gravity_direction, solved=solved,
                               on_chunk=write, progress=progress)
        else:
            mc = monte_carlo(scene, sigmas, options, runner=runner, solved=solved, on_chunk=write, progress=progress)
    finally:
        file.close()
    info = {
        "runner": runner.description,
        "workers": workers,
        "resumed_from_sample": done,
        "seconds": time.perf_counter() - t0,
        "out": str(file.path),
        "hash": file.hash,
    }
    return mc, info

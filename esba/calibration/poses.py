"""Pose files: measured shapes for the load estimate (:mod:`esba.calibration.sensing`), one pose a row.

A CSV file (``#`` lines are comments) with a header and one row per pose. Columns (every
measured column may be left empty in a row where it was not measured):

==========================  ===================================================================
``label``                   how the output names the row (default: its line)
``load``                    rows with the same name hold one load (a known object lifted at
                            several pressures); without the column, each row is its own load
``pressure_mpa``            the pressure (or ``target_angle_deg``: the unloaded bend that sets it)
``theta1_deg`` ... ``thetaN_deg``, ``theta_sd_deg``     every segment angle and their deviation
``total_angle_deg``, ``total_angle_sd_deg``
``tip_x_mm``, ``tip_y_mm``, ``tip_sd_mm``
``marker_at``, ``marker_x_mm``, ``marker_y_mm``, ``marker_sd_mm``   a marker at a fraction of L
==========================  ===================================================================

A measured value needs its standard deviation (the estimate's intervals rest on it).

>>> import tempfile, pathlib
>>> f = pathlib.Path(tempfile.mkdtemp()) / "lift.csv"
>>> _ = f.write_text("load,pressure_mpa,total_angle_deg,total_angle_sd_deg\\ncup,0.10,60.1,0.5\\ncup,0.15,101.2,0.5\\n")
>>> poses = load_poses(f, segments=3)
>>> [(p.load, p.pressure, p.measured[0].kind) for p in poses]
[('cup', 0.1, 'total_angle'), ('cup', 0.15, 'total_angle')]
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from esba.calibration.measurements import MeasurementError, _csv_rows, _number, _read
from esba.calibration.sensing import Measured, Pose, SensingError

__all__ = ["load_poses", "COLUMNS", "MAX_POSES"]

#: The most rows a pose file may hold.
MAX_POSES = 2000

COLUMNS = ("label", "load", "pressure_mpa", "target_angle_deg", "theta_sd_deg", "total_angle_deg", "total_angle_sd_deg",
           "tip_x_mm", "tip_y_mm", "tip_sd_mm", "marker_at", "marker_x_mm", "marker_y_mm", "marker_sd_mm")

_THETA = re.compile(r"^theta([1-9][0-9]*)_deg$")


def _column(where: str, name: str) -> None:
    """A pose file's column name, or one line naming it and what is allowed."""
    if name not in COLUMNS and not _THETA.match(name):
        raise MeasurementError(f"{where}: unknown column {name[:40]!r}; allowed are {', '.join(COLUMNS)} and theta1_deg ... thetaN_deg")


def _sd(where: str, row: dict, name: str, measured: str) -> float:
    sd = _number(where, name, row.get(name))
    if sd is None:
        raise MeasurementError(f"{where}: {measured} is given without {name} (its standard deviation)")
    return sd


def _pose(where: str, row: dict[str, Any], segments: int, default_label: str) -> Pose:
    measured: list[Measured] = []
    thetas = {int(m.group(1)): k for k in row if (m := _THETA.match(k))}
    values = {i: _number(where, k, row[k]) for i, k in thetas.items()}
    given = {i: v for i, v in values.items() if v is not None}
    try:
        if given:
            missing = [f"theta{i}_deg" for i in range(1, segments + 1) if i not in given]
            if missing or len(given) != segments:
                raise MeasurementError(f"{where}: segment angles need all of theta1_deg to theta{segments}_deg "
                                       f"(the scene has {segments} segments); missing or extra: {', '.join(missing) or 'extra columns'}")
            measured.append(Measured("theta", tuple(given[i] for i in range(1, segments + 1)), _sd(where, row, "theta_sd_deg", "theta")))
        total = _number(where, "total_angle_deg", row.get("total_angle_deg"))
        if total is not None:
            measured.append(Measured("total_angle", (total,), _sd(where, row, "total_angle_sd_deg", "total_angle_deg")))
        for head, kind in (("tip", "tip"), ("marker", "marker")):
            x = _number(where, f"{head}_x_mm", row.get(f"{head}_x_mm"))
            y = _number(where, f"{head}_y_mm", row.get(f"{head}_y_mm"))
            if (x is None) != (y is None):
                raise MeasurementError(f"{where}: {head}_x_mm and {head}_y_mm go together; one of them is empty")
            if x is None:
                if kind == "marker" and _number(where, "marker_at", row.get("marker_at")) is not None:
                    raise MeasurementError(f"{where}: marker_at is given without marker_x_mm and marker_y_mm")
                continue
            at = None
            if kind == "marker":
                at = _number(where, "marker_at", row.get("marker_at"))
                if at is None:
                    raise MeasurementError(f"{where}: a marker needs marker_at (its fraction of L)")
            measured.append(Measured(kind, (x, y), _sd(where, row, f"{head}_sd_mm", f"{head}_x_mm"), at))
        if not measured:
            raise MeasurementError(f"{where}: nothing measured (give theta1_deg..., total_angle_deg, tip_x_mm/tip_y_mm or a marker)")
        pressure = _number(where, "pressure_mpa", row.get("pressure_mpa"))
        target = _number(where, "target_angle_deg", row.get("target_angle_deg"))
        if (pressure is None) == (target is None):
            raise MeasurementError(f"{where}: give one of pressure_mpa and target_angle_deg")
        if pressure is not None and not 0.0 <= pressure <= 10.0:
            raise MeasurementError(f"{where}, pressure_mpa={pressure:g}: expected a pressure from 0 to 10 MPa")
        if target is not None and not 0.0 < target <= 720.0:
            raise MeasurementError(f"{where}, target_angle_deg={target:g}: expected an angle with 0 < angle <= 720 deg")
        label = (row.get("label") or "").strip() or default_label
        load = (row.get("load") or "").strip() or label
        return Pose(pressure, tuple(measured), load=load, label=label, target_angle_deg=target)
    except SensingError as exc:
        raise MeasurementError(f"{where}: {exc}") from None


def load_poses(path: str | Path, segments: int = 3) -> list[Pose]:
    """Read and validate a pose file (see the module docstring); errors name the file, the line and the column."""
    path = Path(path)
    source = str(path)
    if path.suffix.lower() != ".csv":
        raise MeasurementError(f"pose file {source!r}: expected a .csv file")
    rows = _csv_rows(source, _read(path), _column)
    if not rows:
        raise MeasurementError(f"{source}: no rows below the header")
    if len(rows) > MAX_POSES:
        raise MeasurementError(f"{source}: {len(rows)} rows; at most {MAX_POSES}")
    return [_pose(f"{source} {where}", row, segments, where) for where, row in rows]

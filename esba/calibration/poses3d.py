"""3-D pose files: what a 3-D tracker measured, one pose a row, for ``esba estimate`` and ``esba fit`` in 3-D.

The planar pose file (:mod:`esba.calibration.poses`) and measurement file
(:mod:`esba.calibration.measurements`) extended by the columns of space; a file with any of the
3-D columns below is read by this module (``esba estimate --poses`` and ``esba fit`` pick it by
its header), every other file as before. A CSV file (``#`` lines are comments), a header and one
row per pose; a measured column may be left empty where it was not measured:

===========================================  ==============================================================
``label``, ``load``                          as in a planar pose file (rows with one ``load`` share it)
``pressure_mpa`` (or ``target_angle_deg``)   the pressure (or the unloaded bend that sets it)
``payload_n``, ``payload_angle_deg``,        the known payload of the row (``esba fit`` only: the
``payload_out_of_plane_deg``, ``payload_at``  estimate finds it): magnitude, Omega, Beta, point
``tip_x_mm``, ``tip_y_mm``, ``tip_z_mm``,    the tip position (x down the base's axis, y horizontal,
``tip_sd_mm``                                z out of the bending plane) and its deviation
``tip_R11`` ... ``tip_R33``,                 the tip's rotation matrix row by row (its columns are the
``rotation_sd_deg``                          tip frame's axes in the base frame; orthonormal to 1e-3,
                                             then the nearest rotation)
``marker_at``, ``marker_x_mm``,              a marker at a fraction of L
``marker_y_mm``, ``marker_z_mm``,
``marker_sd_mm``
``theta1_deg`` ... ``thetaN_deg``,           the 3n joint angles (all of them) and their deviation
``psi1_deg`` ..., ``tau1_deg`` ...,
``angles_sd_deg``
===========================================  ==============================================================

The 3-D columns: ``tip_z_mm``, ``tip_R..``, ``rotation_sd_deg``, ``marker_z_mm``, ``psi..``,
``tau..``, ``angles_sd_deg``, ``payload_out_of_plane_deg``.

>>> import tempfile, pathlib
>>> f = pathlib.Path(tempfile.mkdtemp()) / "trak.csv"
>>> _ = f.write_text("pressure_mpa,tip_x_mm,tip_y_mm,tip_z_mm,tip_sd_mm\\n0.15,100.5,60.2,8.1,0.1\\n")
>>> is_3d(f), [(p.pressure, p.measured[0].kind) for p in load_poses3d(f, 3)]
(True, [(0.15, 'tip')])
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from esba.calibration.measurements import MeasurementError, _csv_rows, _number, _read
from esba.calibration.sensing3d import Pose3D
from esba.calibration.spatial_ls import Measured3D, SpatialLSError

__all__ = ["load_poses3d", "is_3d", "COLUMNS3D", "Row3D"]

MAX_ROWS = 2000
_R = tuple(f"tip_R{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))
COLUMNS3D = ("label", "load", "pressure_mpa", "target_angle_deg", "payload_n", "payload_angle_deg", "payload_out_of_plane_deg", "payload_at",
             "tip_x_mm", "tip_y_mm", "tip_z_mm", "tip_sd_mm", *_R, "rotation_sd_deg",
             "marker_at", "marker_x_mm", "marker_y_mm", "marker_z_mm", "marker_sd_mm", "angles_sd_deg")
#: The columns that make a file a 3-D one.
ONLY_3D = ("tip_z_mm", *_R, "rotation_sd_deg", "marker_z_mm", "angles_sd_deg", "payload_out_of_plane_deg")
_ANGLE = re.compile(r"^(theta|psi|tau)([1-9][0-9]*)_deg$")


def is_3d(path: str | Path) -> bool:
    """Does the CSV file's header name a 3-D column? (False for unreadable files: their reader says why.)"""
    try:
        text = _read(Path(path))
    except MeasurementError:
        return False
    for line in text.splitlines():
        if line.strip() and not line.lstrip().startswith("#"):
            names = {h.strip() for h in line.split(",")}
            return bool(names & set(ONLY_3D)) or any((m := _ANGLE.match(h)) and m.group(1) in ("psi", "tau") for h in names)
    return False


def _column(where: str, name: str) -> None:
    if name not in COLUMNS3D and not _ANGLE.match(name):
        raise MeasurementError(f"{where}: unknown column {name[:40]!r} in a 3-D pose file; allowed are {', '.join(COLUMNS3D)}, "
                               "theta1_deg..., psi1_deg..., tau1_deg...")


def _sd(where: str, row: dict, name: str, measured: str) -> float:
    sd = _number(where, name, row.get(name))
    if sd is None:
        raise MeasurementError(f"{where}: {measured} is given without {name} (its standard deviation)")
    return sd


def _triple(where: str, row: dict, head: str) -> tuple[float, float, float] | None:
    vals = [_number(where, f"{head}_{c}_mm", row.get(f"{head}_{c}_mm")) for c in "xyz"]
    given = [v is not None for v in vals]
    if any(given) and not all(given):
        missing = [f"{head}_{c}_mm" for c, g in zip("xyz", given) if not g]
        raise MeasurementError(f"{where}: {head}_x_mm, {head}_y_mm and {head}_z_mm go together; {', '.join(missing)} empty")
    return tuple(vals) if all(given) else None


@dataclass(frozen=True)
class Row3D:
    """One row: its pose and, for a fit, its known payload (force, Omega deg, Beta deg, at) or None."""

    pose: Pose3D
    payload: tuple[float, float, float, float] | None


def _row(where: str, row: dict[str, Any], segments: int, default_label: str) -> Row3D:
    measured: list[Measured3D] = []
    try:
        angles = {(m.group(1), int(m.group(2))): _number(where, k, row[k]) for k in row if (m := _ANGLE.match(k))}
        given = {key: v for key, v in angles.items() if v is not None}
        if given:
            want = [(c, i) for c in ("theta", "psi", "tau") for i in range(1, segments + 1)]
            missing = [f"{c}{i}_deg" for c, i in want if (c, i) not in given]
            extra = [f"{c}{i}_deg" for c, i in given if i > segments]
            if missing or extra:
                raise MeasurementError(f"{where}: the joint angles need all of theta, psi and tau 1 to {segments} (the scene has {segments} "
                                       f"segments); missing: {', '.join(missing) or 'none'}; extra: {', '.join(extra) or 'none'}")
            measured.append(Measured3D("angles", tuple(given[k] for k in want), _sd(where, row, "angles_sd_deg", "theta1_deg...")))
        tip = _triple(where, row, "tip")
        if tip is not None:
            measured.append(Measured3D("tip", tip, _sd(where, row, "tip_sd_mm", "tip_x_mm")))
        R = [_number(where, k, row.get(k)) for k in _R]
        if any(v is not None for v in R):
            if not all(v is not None for v in R):
                empty = ", ".join(k for k, v in zip(_R, R) if v is None)
                raise MeasurementError(f"{where}: the tip rotation needs all nine of tip_R11 ... tip_R33; {empty} empty")
            measured.append(Measured3D("rotation", tuple(R), _sd(where, row, "rotation_sd_deg", "tip_R11...")))
        marker = _triple(where, row, "marker")
        at = _number(where, "marker_at", row.get("marker_at"))
        if marker is not None:
            if at is None:
                raise MeasurementError(f"{where}: a marker needs marker_at (its fraction of L)")
            measured.append(Measured3D("marker", marker, _sd(where, row, "marker_sd_mm", "marker_x_mm"), at))
        elif at is not None:
            raise MeasurementError(f"{where}: marker_at is given without marker_x_mm, marker_y_mm and marker_z_mm")
        if not measured:
            raise MeasurementError(f"{where}: nothing measured (give the tip's x, y, z, its rotation tip_R11..., a marker or the joint angles)")
        pressure = _number(where, "pressure_mpa", row.get("pressure_mpa"))
        target = _number(where, "target_angle_deg", row.get("target_angle_deg"))
        label = (row.get("label") or "").strip() or default_label
        load = (row.get("load") or "").strip() or label
        pose = Pose3D(pressure, tuple(measured), load=load, label=label, target_angle_deg=target)
        force = _number(where, "payload_n", row.get("payload_n"))
        payload = None
        others = {k: _number(where, k, row.get(k)) for k in ("payload_angle_deg", "payload_out_of_plane_deg", "payload_at")}
        if force is not None:
            payload = (force, 90.0 if others["payload_angle_deg"] is None else others["payload_angle_deg"],
                       0.0 if others["payload_out_of_plane_deg"] is None else others["payload_out_of_plane_deg"],
                       1.0 if others["payload_at"] is None else others["payload_at"])
        elif any(v is not None for v in others.values()):
            raise MeasurementError(f"{where}: {', '.join(k for k, v in others.items() if v is not None)} given without payload_n")
        return Row3D(pose, payload)
    except SpatialLSError as exc:
        raise MeasurementError(f"{where}: {exc}") from None


def load_rows3d(path: str | Path, segments: int = 3) -> list[Row3D]:
    """Read and validate a 3-D pose file; errors name the file, the line and the column."""
    path = Path(path)
    source = str(path)
    if path.suffix.lower() != ".csv":
        raise MeasurementError(f"3-D pose file {source!r}: expected a .csv file")
    rows = _csv_rows(source, _read(path), _column)
    if not rows:
        raise MeasurementError(f"{source}: no rows below the header")
    if len(rows) > MAX_ROWS:
        raise MeasurementError(f"{source}: {len(rows)} rows; at most {MAX_ROWS}")
    return [_row(f"{source} {where}", row, segments, where) for where, row in rows]


def load_poses3d(path: str | Path, segments: int = 3) -> list[Pose3D]:
    """The poses of a 3-D pose file for the load estimate: its rows may not state the payload (it is the unknown)."""
    rows = load_rows3d(path, segments)
    for r in rows:
        if r.payload is not None:
            raise MeasurementError(f"{path} row {r.pose.label}: payload_n is given, but the estimate finds the payload; "
                                   "a file with known payloads is for `esba fit`")
    return [r.pose for r in rows]

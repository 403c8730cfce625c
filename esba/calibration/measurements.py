"""Measurement files: what was done to an actuator and what was measured, validated row by row.

A measurement file is CSV or TOML; every row is one scene and what was measured in it. Column
(or key) names carry their unit, so a file states its units; a name without its unit, or with one
esba does not know, is refused with the units it accepts.

======================  ===============================  =====================================
column                  meaning                          units accepted
======================  ===============================  =====================================
label                   a name for the row (optional)
pressure_<u>            the pressure applied             ``mpa``, ``kpa``, ``bar``
target_angle_deg        ... or: the pressure that bends  ``deg``
                        the unloaded actuator this far
payload_n, payload2_n   tip or point payloads            ``n`` (N)
payload_angle_deg       its direction Omega (default 90) ``deg``
payload_at              its point, fraction of L (def. 1)
L_mm r1_mm r2_mm d_mm   this row's actuator, when it     ``mm``, ``deg``, ``mpa``, ``kg``
rho_deg E_mpa M_kg      differs from the file's
total_angle_deg         measured total bending angle     ``deg``
tip_x_mm, tip_y_mm      measured tip position            ``mm`` (x down, y horizontal)
stiffness_n_per_m       measured secant stiffness        ``n_per_m`` (N/m)
<quantity>_sd_<u>       standard deviation of a          as the quantity
                        measured value (optional)
======================  ===============================  =====================================

Each row gives exactly one of a pressure or a target angle, and at least one measured value.
The stiffness is the paper's secant stiffness (Section 4.4.3): from the unloaded state at the
row's pressure, K = 1000 F / delta with delta the tip's displacement along the row's one payload.
Empty CSV cells mean "not given"; NaN, infinities and text where a number belongs are refused.

A TOML file has the same keys, one ``[[measurement]]`` table per row, and may carry the actuator
and model as a scene table (``[scene]``, the keys of a scene file: ``segments``, ``variant``,
``[scene.actuator]``, ...); a CSV file takes them from ``esba fit --scene``, else Table 1 with n = 3.

    # TOML                                   # CSV
    [scene]                                  label,pressure_mpa,total_angle_deg,total_angle_sd_deg
    segments = 3                             free bend,0.2,176.8,1.0
    [[measurement]]
    label = "free bend"
    pressure_mpa = 0.2
    total_angle_deg = 176.8
    total_angle_sd_deg = 1.0

Every message names the file, the line (CSV) or the table (TOML), the field, the value and what
is allowed (:class:`MeasurementError`).

Examples
--------
>>> import pathlib, tempfile
>>> path = pathlib.Path(tempfile.mkdtemp()) / "m.csv"
>>> _ = path.write_text("label,pressure_mpa,total_angle_deg\\nfree bend,0.2,176.8\\n")
>>> data = load_measurements(path)
>>> data.rows[0].scene.pressure, data.rows[0].values
(0.2, {'total_angle': 176.8})
>>> _ = path.write_text("label,pressure,total_angle_deg\\nfree bend,0.2,176.8\\n")
>>> load_measurements(path)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
esba.calibration.measurements.MeasurementError: ...m.csv line 1: column 'pressure' states no unit: write pressure_mpa, pressure_kpa or pressure_bar
"""

from __future__ import annotations

import collections
import csv
import dataclasses
import io
import math
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

from esba.infra import checks, inputs
from esba.infra.errors import InputError
from esba.model.scene import MAX_TARGET_ANGLE_DEG, Payload, Scene, SceneError, scene_from_dict

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["MeasurementError", "Measurement", "MeasurementSet", "load_measurements", "measurements_from_rows", "QUANTITIES", "MAX_ROWS"]

#: What can be measured, in the unit esba works in.
QUANTITIES: dict[str, str] = {"total_angle": "deg", "tip_x": "mm", "tip_y": "mm", "stiffness": "N/m"}

#: The smallest standard deviation of a measured value, in esba's unit of it (deg, mm, N/m).
MIN_SD = 1e-6

#: The largest angle a row may state (a target, or a measured total angle), degrees: ten turns.
#: A bend past one turn is fitted with a warning (the actuator would pass through itself);
#: one past ten is no measurement of a bending actuator (1e6 deg is a typo).
MAX_ANGLE_DEG = MAX_TARGET_ANGLE_DEG  # the bound of a scene's target angle, 3600
_TURN = "ten turns; past one the model already warns that the actuator passes through itself"

#: The most rows a file may have (each row adds its equilibria to the fit's NLP).
MAX_ROWS = 500

#: Each quantity of a column: its accepted units and the factor to esba's unit.
_UNITS: dict[str, dict[str, float]] = {
    "pressure": {"mpa": 1.0, "kpa": 1e-3, "bar": 0.1},
    "target_angle": {"deg": 1.0},
    "total_angle": {"deg": 1.0},
    "tip_x": {"mm": 1.0},
    "tip_y": {"mm": 1.0},
    "stiffness": {"n_per_m": 1.0},
    "L": {"mm": 1.0},
    "r1": {"mm": 1.0},
    "r2": {"mm": 1.0},
    "d": {"mm": 1.0},
    "rho": {"deg": 1.0},
    "E": {"mpa": 1.0},
    "M": {"kg": 1.0},
}
_ESBA_UNIT = {"pressure": "MPa", "target_angle": "deg", **QUANTITIES}
_ACTUATOR = {"L": "L", "r1": "r1", "r2": "r2", "d": "d", "rho": "rho_deg", "E": "E", "M": "M"}
_PAYLOAD_FIELDS = {"n": "force", "angle_deg": "angle_deg", "at": "at"}


class MeasurementError(InputError):
    """A measurement file or row that is not allowed: the message names the file, the row, the field and what is allowed."""


@dataclass(frozen=True)
class Measurement:
    """One row: a scene and what was measured in it.

    Attributes
    ----------
    label : str
    where : str
        File and line (or table) of the row, for messages.
    scene : Scene
        The row's scene: the file's actuator and model, the row's pressure or target angle, its
        payloads and any actuator values of its own.
    values : dict
        Measured quantity -> value, in :data:`QUANTITIES` units.
    sds : dict
        Measured quantity -> standard deviation, where given.
    own : frozenset of str
        Actuator parameters the row sets itself (a fit cannot free them for this row).
    """

    label: str
    where: str
    scene: Scene
    values: dict
    sds: dict
    own: frozenset = field(default_factory=frozenset)


@dataclass(frozen=True)
class MeasurementSet:
    """The rows of a file and the scene they share.

    Attributes
    ----------
    source : str
        The file (or a description).
    base : Scene
        The actuator and model settings of the rows.
    rows : tuple of Measurement
    """

    source: str
    base: Scene
    rows: tuple[Measurement, ...]

    def __len__(self) -> int:
        return len(self.rows)

    def count(self) -> int:
        """Number of measured values."""
        return sum(len(r.values) for r in self.rows)

    def subset(self, labels: Any) -> MeasurementSet:
        """The rows whose label is in ``labels``, in the file's order."""
        labels = set(labels)
        missing = labels - {r.label for r in self.rows}
        if missing:
            raise MeasurementError(f"{self.source}: no row labelled {', '.join(sorted(map(repr, missing)))}")
        return dataclasses.replace(self, rows=tuple(r for r in self.rows if r.label in labels))


def _either(options: list[str]) -> str:
    """'a', 'a or b', 'a, b or c'."""
    return options[0] if len(options) == 1 else ", ".join(options[:-1]) + " or " + options[-1]


def _column(where: str, name: str) -> tuple[str, str | None, str | None]:
    """(kind, detail, unit) of a column name; kind is 'label', 'payload', 'sd', 'value' or 'actuator'."""
    if name == "label":
        return "label", None, None
    m = re.fullmatch(r"payload(\d*)_(n|angle_deg|at)", name)
    if m:
        k = int(m.group(1)) if m.group(1) else 1
        if k < 1:
            raise MeasurementError(f"{where}: column {checks.quote(name)}: payloads are numbered from 1 (payload_n, payload2_n, ...)")
        return "payload", f"{k}:{m.group(2)}", None
    if re.fullmatch(r"payload\d*(_.*)?", name):
        raise MeasurementError(f"{where}: column {checks.quote(name)}: a payload's columns are payload_n (N), payload_angle_deg and payload_at")
    for quantity in sorted(_UNITS, key=len, reverse=True):
        for sd in ("_sd", ""):
            prefix = quantity + sd
            if name == prefix:
                raise MeasurementError(f"{where}: column {checks.quote(name)} states no unit: write {_either([f'{prefix}_{u}' for u in _UNITS[quantity]])}")
            if name.startswith(prefix + "_"):
                unit = name[len(prefix) + 1:]
                if unit not in _UNITS[quantity]:
                    allowed = ", ".join(f"{prefix}_{u}" for u in _UNITS[quantity])
                    raise MeasurementError(f"{where}: column {checks.quote(name)}: unit {checks.quote(unit)} is not accepted for {quantity}; write {allowed}")
                if sd:
                    if quantity not in QUANTITIES:
                        raise MeasurementError(f"{where}: column {checks.quote(name)}: only measured quantities ({', '.join(QUANTITIES)}) take a standard deviation")
                    return "sd", quantity, unit
                kind = "actuator" if quantity in _ACTUATOR else "value"
                return kind, quantity, unit
    allowed = "label, pressure_mpa, target_angle_deg, payload_n, payload_angle_deg, payload_at, " + ", ".join(
        f"{q}_{next(iter(u))}" for q, u in _UNITS.items() if q not in ("pressure", "target_angle")
    ) + ", and <quantity>_sd_<unit>"
    raise MeasurementError(f"{where}: unknown column {checks.quote(name)}; allowed are {allowed}")


def _raw(raw: Any) -> str:
    """A cell as the file gives it, for a message (cut when long)."""
    text = raw.strip() if isinstance(raw, str) else repr(raw)
    return text if len(text) <= 30 else text[:30] + "..."


def _number(where: str, name: str, raw: Any) -> float | None:
    """A finite number, or None for an empty cell."""
    if raw is None:
        return None
    if isinstance(raw, bool):
        raise MeasurementError(f"{where}, {name}={checks.quote(raw)}: expected a number")
    if isinstance(raw, str):
        text = raw.strip()
        if text == "":
            return None
        try:
            value = checks.number(name, text)  # decimal ASCII digits: float() also takes 1_0 and other scripts' digits
        except ValueError:
            raise MeasurementError(f"{where}, {name}={checks.quote(text)}: expected a number") from None
    elif isinstance(raw, (int, float)):
        value = float(raw)
    else:
        raise MeasurementError(f"{where}, {name}={checks.quote(raw)}: expected a number")
    if not math.isfinite(value):
        raise MeasurementError(f"{where}, {name}={checks.quote(value)}: expected a finite number (leave the cell empty when it was not measured)")
    return value


def _row(where: str, row: Mapping[str, Any], base: Scene, columns: Mapping[str, tuple], default_label: str) -> Measurement:
    label = str(row.get("label") or "").strip() or default_label
    drive: dict[str, float] = {}
    payloads: dict[int, dict[str, float]] = {}
    actuator: dict[str, float] = {}
    values: dict[str, float] = {}
    sds: dict[str, float] = {}
    given: dict[tuple[str, str], tuple[str, float]] = {}  # (kind, quantity) -> (column, value in esba's unit)
    for name, raw in row.items():
        kind, detail, unit = columns[name]
        if kind == "label":
            continue
        value = _number(where, name, raw)
        if value is None:
            continue
        if kind != "payload":  # one quantity in two units (pressure_mpa and pressure_kpa): they must agree
            key, converted = (kind, detail), value * _UNITS[detail][unit]
            if key in given:
                other, before = given[key]
                if not math.isclose(before, converted, rel_tol=1e-9, abs_tol=0.0):
                    raise MeasurementError(
                        f"{where}: {other}={_raw(row[other])} and {name}={_raw(raw)} disagree "
                        f"({before:.6g} vs {converted:.6g} {_ESBA_UNIT.get(detail, '')}); give the {detail.replace('_', ' ')} once"
                    )
            given[key] = (name, converted)
        if kind == "payload":
            k, what = detail.split(":")
            payloads.setdefault(int(k), {})[_PAYLOAD_FIELDS[what]] = value
            continue
        value *= _UNITS[detail][unit]
        if detail in ("pressure", "target_angle"):
            if detail == "target_angle" and not 0.0 < value <= MAX_ANGLE_DEG:
                raise MeasurementError(f"{where}, {name}={value:g}: expected a target angle > 0 and <= {MAX_ANGLE_DEG:g} deg ({_TURN})")
            drive[detail] = value
        elif kind == "actuator":
            actuator[_ACTUATOR[detail]] = value
        elif kind == "sd":
            if value <= 0:
                raise MeasurementError(f"{where}, {name}={value:g}: a standard deviation must be > 0")
            if value < MIN_SD:  # its weight 1/sd^2 would swamp the fit (and overflow near 1e-154)
                raise MeasurementError(
                    f"{where}, {name}={value:g}: expected a standard deviation >= {MIN_SD:g} {QUANTITIES[detail]} (finer than any measurement)"
                )
            sds[detail] = value
        else:
            if detail == "total_angle" and abs(value) > MAX_ANGLE_DEG:
                raise MeasurementError(f"{where}, {name}={value:g}: expected a measured angle from -{MAX_ANGLE_DEG:g} to {MAX_ANGLE_DEG:g} deg ({_TURN})")
            values[detail] = value
    if len(drive) != 1:
        given = ", ".join(drive) or "neither"
        raise MeasurementError(f"{where}: give exactly one of pressure_<unit> or target_angle_deg (given: {given})")
    if not values:
        raise MeasurementError(f"{where}: nothing measured: give at least one of " + ", ".join(f"{q}_{next(iter(_UNITS[q]))}" for q in QUANTITIES))
    for q in sds:
        if q not in values:
            raise MeasurementError(f"{where}: {q}_sd given without {q}")
    missing = [k for k in sorted(payloads) if "force" not in payloads[k]]
    if missing:
        k = missing[0]
        raise MeasurementError(f"{where}: payload {k} has a direction or point but no force (payload{'' if k == 1 else k}_n, N)")
    if sorted(payloads) != list(range(1, len(payloads) + 1)):
        raise MeasurementError(f"{where}: payloads must be numbered 1, 2, ... without gaps (got {sorted(payloads)})")
    try:
        act = dataclasses.replace(base.actuator, **actuator) if actuator else base.actuator
        pl = tuple(Payload(**payloads[k]) for k in sorted(payloads))
        scene = dataclasses.replace(
            base, actuator=act, payloads=pl,
            pressure=drive.get("pressure"), target_angle_deg=drive.get("target_angle"),
        )
    except SceneError as exc:
        raise MeasurementError(f"{where}: {exc}") from None
    if "stiffness" in values:
        if len(pl) != 1 or pl[0].force <= 0:
            raise MeasurementError(f"{where}: a stiffness needs exactly one payload with a force > 0 (the secant stiffness along it)")
    inverse = {v: k for k, v in _ACTUATOR.items()}
    return Measurement(label, where, scene, values, sds, frozenset(inverse[k] for k in actuator))


def measurements_from_rows(source: str, rows: list[tuple[str, Mapping[str, Any]]], base: Scene | None = None) -> MeasurementSet:
    """Validate rows given as (where, {column: value}) (what both file readers produce).

    >>> m = measurements_from_rows("example", [("row 1", {"target_angle_deg": 90, "payload_n": 2, "tip_y_mm": 8.1})])
    >>> m.rows[0].scene.payloads[0].force, m.rows[0].values
    (2.0, {'tip_y': 8.1})
    """
    base = Scene() if base is None else base
    if not isinstance(base, Scene):
        raise MeasurementError(f"{source}: base={checks.quote(base)}: expected a Scene")
    if not rows:
        raise MeasurementError(f"{source}: no measurements (no data rows)")
    if len(rows) > MAX_ROWS:
        raise MeasurementError(f"{source}: {len(rows)} rows; at most {MAX_ROWS} are allowed (split the file)")
    columns: dict[str, tuple] = {}
    out = []
    labels: set[str] = set()
    for where, row in rows:
        for name in row:
            if name not in columns:
                columns[name] = _column(f"{source}", str(name))
        m = _row(f"{source} {where}", row, base, columns, where)
        if m.label in labels:
            raise MeasurementError(f"{source} {where}: label {checks.quote(m.label)} is used twice (labels name rows in the report)")
        labels.add(m.label)
        out.append(m)
    return MeasurementSet(source, base, tuple(out))


def _read(path: Path) -> str:
    """The file's text: a regular file of bounded size, BOM or not (:func:`esba.infra.inputs.read_text`)."""
    return inputs.read_text(path, "measurement file", MeasurementError)


def _csv_rows(source: str, text: str, check_column: Callable[[str, str], Any] | None = None) -> list[tuple[str, dict]]:
    """The rows of a CSV text as (where, {column: cell}); every column name is checked by
    ``check_column(where, name)`` (default: a measurement file's columns) before any row is read."""
    check_column = _column if check_column is None else check_column
    lines = [(k, line) for k, line in enumerate(text.splitlines(), start=1) if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise MeasurementError(f"{source}: the file is empty (expected a header row of column names)")
    reader = csv.reader(io.StringIO("\n".join(line for _, line in lines)))
    try:
        table = list(reader)
    except csv.Error as exc:
        raise MeasurementError(f"{source}: not valid CSV: {exc}") from None
    header = [h.strip() for h in table[0]]
    if any(not h for h in header):
        raise MeasurementError(f"{source} line {lines[0][0]}: an empty column name in the header")
    seen = collections.Counter(header)  # header.count per column was quadratic: 300k columns took over a minute
    dup = sorted(h for h, n in seen.items() if n > 1)
    if dup:
        raise MeasurementError(f"{source} line {lines[0][0]}: column(s) {', '.join(dup)} appear twice")
    for h in header:  # an unknown name is said before any row's cell count
        check_column(f"{source} line {lines[0][0]}", h)
    rows = []
    for (lineno, _), cells in zip(lines[1:], table[1:]):
        if len(cells) != len(header):
            raise MeasurementError(f"{source} line {lineno}: {len(cells)} cells for {len(header)} columns")
        rows.append((f"line {lineno}", dict(zip(header, cells))))
    return rows


def load_measurements(path: str | Path, base: Scene | None = None) -> MeasurementSet:
    """Read and validate a measurement file (``.csv`` or ``.toml``).

    Parameters
    ----------
    path : path
    base : Scene, optional
        The actuator and model of the rows (a TOML file's ``[scene]`` table takes precedence
        over Table 1, ``base`` over both).

    Raises
    ------
    MeasurementError
        naming the file, the row and the field.
    """
    if isinstance(path, bytes) or not isinstance(path, (str, Path)) or not str(path).strip():
        raise MeasurementError(f"measurement file {checks.quote(path)}: expected the path of a .csv or .toml file")
    path = Path(path)
    source = str(path)
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".toml"):
        raise MeasurementError(f"measurement file {source!r}: expected a .csv or .toml file")
    text = _read(path)
    if suffix == ".csv":
        return measurements_from_rows(source, _csv_rows(source, text), base)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise MeasurementError(f"{source}: not valid TOML: {str(exc).splitlines()[0]}") from None
    except RecursionError:
        raise MeasurementError(f"{source}: not valid TOML: nested too deeply (arrays or tables inside each other)") from None
    unknown = sorted(set(data) - {"scene", "measurement"})
    if unknown:
        raise MeasurementError(f"{source}: unknown table(s) {checks.some(unknown)}; allowed are [scene] and [[measurement]]")
    if base is None:
        try:
            base = scene_from_dict(data.get("scene", {}))
        except SceneError as exc:
            raise MeasurementError(f"{source} [scene]: {exc}") from None
    rows = data.get("measurement", [])
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise MeasurementError(f"{source}: measurement must be an array of tables [[measurement]]")
    return measurements_from_rows(source, [(f"[[measurement]] #{k}", r) for k, r in enumerate(rows, start=1)], base)


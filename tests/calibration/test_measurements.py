"""Measurement files (esba.calibration.measurements): CSV and TOML, units in the names, and every bad file refused
in one line that names the file, the row, the field and what is allowed (also through `esba fit`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from esba.calibration.experiments import paper_data
from esba.calibration.measurements import (
    MAX_ROWS,
    MeasurementError,
    load_measurements,
    measurements_from_rows,
)
from esba.cli import EXIT_USAGE, main
from esba.model.scene import Scene

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "measurements"


def _csv(tmp_path, text: str, name: str = "m.csv") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("column, name", [("EXP", "paper_exp.csv"), ("FEM", "paper_fem.toml")])
def test_example_files_hold_the_papers_values(column, name):
    """The example files (CSV and TOML) read to the same rows as esba.calibration.experiments.paper_data."""
    a, b = load_measurements(EXAMPLES / name), paper_data(column)
    assert a.base == b.base
    assert [(r.label, r.scene, r.values, r.sds, r.own) for r in a.rows] == [(r.label, r.scene, r.values, r.sds, r.own) for r in b.rows]


def test_a_csv_row_becomes_a_scene(tmp_path):
    path = _csv(tmp_path, "# comment\nlabel,pressure_kpa,payload_n,payload_angle_deg,payload_at,payload2_n,r2_mm,tip_y_mm,tip_y_sd_mm\n"
                          "a,150,1.5,45,0.5,0.5,2.5,20.0,0.5\n\n")
    (row,) = load_measurements(path).rows
    s = row.scene
    assert s.pressure == pytest.approx(0.15) and s.target_angle_deg is None
    assert [(p.force, p.angle_deg, p.at) for p in s.payloads] == [(1.5, 45.0, 0.5), (0.5, 90.0, 1.0)]
    assert s.actuator.r2 == 2.5 and row.own == frozenset({"r2"})
    assert row.values == {"tip_y": 20.0} and row.sds == {"tip_y": 0.5}
    assert row.where.endswith("line 3") and row.label == "a"


def test_the_base_scene_and_defaults(tmp_path):
    path = _csv(tmp_path, "target_angle_deg,total_angle_deg\n90,90\n")
    data = load_measurements(path, Scene(segments=5, variant="printed"))
    assert data.rows[0].scene.segments == 5 and data.rows[0].scene.variant == "printed"
    assert data.rows[0].label == "line 2"
    assert data.count() == 1 and len(data) == 1
    with pytest.raises(MeasurementError, match="no row labelled 'x'"):
        data.subset(["x"])


@pytest.mark.parametrize(
    "text, needle",
    [
        ("", "the file is empty"),
        ("# only a comment\n", "the file is empty"),
        ("label,pressure_mpa,total_angle_deg\n", "no measurements"),
        ("pressure,total_angle_deg\n0.1,30\n", "column 'pressure' states no unit: write pressure_mpa, pressure_kpa or pressure_bar"),
        ("pressure_psi,total_angle_deg\n0.1,30\n", "unit 'psi' is not accepted for pressure; write pressure_mpa, pressure_kpa, pressure_bar"),
        ("pressure_mpa,tip_x_cm\n0.1,3\n", "unit 'cm' is not accepted for tip_x; write tip_x_mm"),
        ("pressure_mpa,total_angle\n0.1,30\n", "column 'total_angle' states no unit: write total_angle_deg"),
        ("pressure_mpa,total_angle_sd\n0.1,1\n", "column 'total_angle_sd' states no unit: write total_angle_sd_deg"),
        ("pressure_mpa,angle_deg\n0.1,30\n", "unknown column 'angle_deg'; allowed are label, pressure_mpa"),
        ("pressure_mpa,E_sd_mpa,total_angle_deg\n0.1,1,30\n", "only measured quantities"),
        ("pressure_mpa,payload_force\n0.1,2\n", "a payload's columns are payload_n"),
        ("pressure_mpa,payload0_n,total_angle_deg\n0.1,1,30\n", "payloads are numbered from 1"),
        ("pressure_mpa,total_angle_deg\n0.1,nan\n", "total_angle_deg=nan: expected a finite number"),
        ("pressure_mpa,total_angle_deg\n0.1,inf\n", "total_angle_deg=inf: expected a finite number"),
        ("pressure_mpa,total_angle_deg\nabc,30\n", "line 2, pressure_mpa='abc': expected a number"),
        ("pressure_mpa,total_angle_deg\n0.1\n", "line 2: 1 cells for 2 columns"),
        ("pressure_mpa,pressure_mpa\n0.1,0.1\n", "column(s) pressure_mpa appear twice"),
        ("pressure_mpa,,total_angle_deg\n0.1,,30\n", "an empty column name"),
        ("pressure_mpa,target_angle_deg,total_angle_deg\n0.1,90,30\n", "give exactly one of pressure_<unit> or target_angle_deg (given: pressure, target_angle)"),
        ("payload_n,total_angle_deg\n1,30\n", "(given: neither)"),
        ("pressure_mpa,payload_n\n0.1,1\n", "nothing measured"),
        ("pressure_mpa,tip_x_sd_mm,total_angle_deg\n0.1,1,30\n", "tip_x_sd given without tip_x"),
        ("pressure_mpa,total_angle_deg,total_angle_sd_deg\n0.1,30,0\n", "a standard deviation must be > 0"),
        ("pressure_mpa,stiffness_n_per_m\n0.1,30\n", "a stiffness needs exactly one payload"),
        ("pressure_mpa,payload_n,payload2_n,stiffness_n_per_m\n0.1,1,1,30\n", "a stiffness needs exactly one payload"),
        ("pressure_mpa,payload_angle_deg,total_angle_deg\n0.1,30,30\n", "payload 1 has a direction or point but no force"),
        ("pressure_mpa,payload_n,payload3_n,total_angle_deg\n0.1,1,1,30\n", "without gaps"),
        ("pressure_mpa,r2_mm,total_angle_deg\n0.1,5,30\n", "line 2: actuator.r2=5 with d=4, r1=8: the chamber must lie inside"),
        ("pressure_mpa,total_angle_deg\n-0.1,30\n", "pressure=-0.1: expected a pressure >= 0 MPa"),
        ("label,pressure_mpa,total_angle_deg\na,0.1,30\na,0.2,60\n", "label 'a' is used twice"),
    ],
)
def test_bad_csv_files_name_the_problem(tmp_path, text, needle):
    path = _csv(tmp_path, text)
    with pytest.raises(MeasurementError) as info:
        load_measurements(path)
    message = str(info.value)
    assert needle in message and str(path) in message and "\n" not in message


@pytest.mark.parametrize(
    "header, needle",
    [
        (",".join(f"c{i}" for i in range(200_000)), "line 1: unknown column 'c0'; allowed are"),
        (",".join(["tip_y_mm"] * 200_000), "line 1: column(s) tip_y_mm appear twice"),
    ],
    ids=["unknown", "repeated"],
)
def test_a_header_of_200k_columns_is_refused_by_its_names(tmp_path, header, needle):
    # the header is judged before any row's cell count (the row here has one cell), and in one pass:
    # a per-column header.count took minutes for such a file
    path = _csv(tmp_path, header + "\n1\n")
    with pytest.raises(MeasurementError) as info:
        load_measurements(path)
    message = str(info.value)
    assert needle in message and str(path) in message and "\n" not in message


@pytest.mark.parametrize(
    "text, needle",
    [
        ("[[measurement]]\npressure_mpa = 0.1\ntotal_angle_deg = 'x'\n", "total_angle_deg='x': expected a number"),
        ("[[measurement]]\npressure_mpa = true\ntotal_angle_deg = 3\n", "pressure_mpa=True: expected a number"),
        ("[[measurement]]\npressure_mpa = 0.1\ntotal_angle_deg = nan\n", "[[measurement]] #1, total_angle_deg=nan"),
        ("[[measurement]\n", "not valid TOML"),
        ("[data]\nx = 1\n", "unknown table(s) data; allowed are [scene] and [[measurement]]"),
        ("measurement = 3\n", "must be an array of tables"),
        ("[scene]\nsegments = 0\n[[measurement]]\npressure_mpa = 0.1\ntotal_angle_deg = 3\n", "[scene]: segments=0"),
        ("[scene]\n", "no measurements"),
    ],
)
def test_bad_toml_files_name_the_problem(tmp_path, text, needle):
    path = _csv(tmp_path, text, "m.toml")
    with pytest.raises(MeasurementError) as info:
        load_measurements(path)
    assert needle in str(info.value) and str(path) in str(info.value)


def test_files_that_are_not_measurement_files(tmp_path):
    with pytest.raises(MeasurementError, match="does not exist"):
        load_measurements(tmp_path / "missing.csv")
    with pytest.raises(MeasurementError, match="expected a .csv or .toml file"):
        load_measurements(_csv(tmp_path, "x", "m.txt"))
    (tmp_path / "dir.csv").mkdir()
    with pytest.raises(MeasurementError, match="is a folder"):
        load_measurements(tmp_path / "dir.csv")
    (tmp_path / "bin.csv").write_bytes(b"\xff\xfe\x00bad")
    with pytest.raises(MeasurementError, match="cannot be read"):
        load_measurements(tmp_path / "bin.csv")


def test_too_many_rows_are_refused():
    rows = [(f"row {k}", {"pressure_mpa": 0.1, "total_angle_deg": 30.0}) for k in range(MAX_ROWS + 1)]
    with pytest.raises(MeasurementError, match=f"at most {MAX_ROWS}"):
        measurements_from_rows("big", rows)


@pytest.mark.parametrize(
    "text, needle",
    [
        ("pressure,total_angle_deg\n0.1,30\n", "states no unit"),
        ("pressure_mpa,total_angle_deg\n0.1,nan\n", "expected a finite number"),
        ("pressure_mpa,payload_n\n0.1,1\n", "nothing measured"),
        # a row that cannot be solved: at rho = 45 deg the fibres outpull the pressure, so no pressure bends it to 90 deg
        ("target_angle_deg,rho_deg,payload_n,total_angle_deg\n90,45,1,30\n", "the row cannot be solved at the starting parameters"),
    ],
)
def test_cli_fit_refuses_bad_files_in_one_line(tmp_path, capsys, text, needle):
    path = _csv(tmp_path, text)
    assert main(["fit", str(path), "--free", "E"]) == EXIT_USAGE
    out, err = capsys.readouterr()
    assert out == "" and err.startswith("esba: error:") and err.count("\n") == 1 and needle in err and str(path) in err

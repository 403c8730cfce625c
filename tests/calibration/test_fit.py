"""Calibration (esba.calibration.fit): synthetic data with known parameters and seeded noise, interval coverage,
identifiability, the implicit-function-theorem Jacobian, the checks of every fitted state, and
`esba fit`."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from esba.calibration.fit import (
    DEFAULT_SD,
    FitError,
    FitOptions,
    _rows_at,
    fit,
    identifiability,
    predict,
)
from esba.calibration.measurements import (
    QUANTITIES,
    MeasurementSet,
    measurements_from_rows,
)
from esba.cli import EXIT_OK, EXIT_USAGE, main
from esba.model.scene import Scene
from tests.figures import drawn
from tests.tolerances import FIT_EXACT_REL, FIT_JACOBIAN_RTOL

#: The parameters the synthetic data are made with (the fit starts from Table 1's 0.54 MPa, 10 deg).
TRUTH = {"E": 0.6, "rho": 12.0}

#: A synthetic experiment: free bends at given pressures (E against rho), payloads at the 90 degree
#: pressure (E alone), a stiffness, and a payload at a given pressure. Values are filled in later.
LAYOUT = [
    ("bend 0.10", {"pressure_mpa": 0.10}, ("total_angle",)),
    ("bend 0.15", {"pressure_mpa": 0.15}, ("total_angle",)),
    ("bend 0.20", {"pressure_mpa": 0.20}, ("total_angle",)),
    ("2 N horizontal", {"target_angle_deg": 90.0, "payload_n": 2.0, "payload_angle_deg": 90.0}, ("total_angle", "tip_x", "tip_y")),
    ("2 N vertical", {"target_angle_deg": 90.0, "payload_n": 2.0, "payload_angle_deg": 0.0}, ("total_angle", "tip_x", "tip_y")),
    ("K at 1 N", {"target_angle_deg": 90.0, "payload_n": 1.0, "payload_angle_deg": 90.0}, ("stiffness",)),
    ("1 N at 0.15 MPa", {"pressure_mpa": 0.15, "payload_n": 1.0, "payload_angle_deg": 60.0}, ("total_angle", "tip_x", "tip_y")),
]
UNIT = {"total_angle": "total_angle_deg", "tip_x": "tip_x_mm", "tip_y": "tip_y_mm", "stiffness": "stiffness_n_per_m"}
SD_UNIT = {"total_angle": "total_angle_sd_deg", "tip_x": "tip_x_sd_mm", "tip_y": "tip_y_sd_mm", "stiffness": "stiffness_sd_n_per_m"}
SD = {"total_angle": 0.5, "tip_x": 0.5, "tip_y": 0.5, "stiffness": 0.5}


def _dataset(values: dict[tuple[str, str], float], layout=LAYOUT, base: Scene | None = None) -> MeasurementSet:
    rows = []
    for label, scene, quantities in layout:
        row = {"label": label, **scene}
        for q in quantities:
            row[UNIT[q]] = values[(label, q)]
            row[SD_UNIT[q]] = SD[q]
        rows.append((label, row))
    return measurements_from_rows("synthetic", rows, base)


@pytest.fixture(scope="module")
def clean():
    """The model's own values at the truth: a layout with placeholders, predicted at TRUTH."""
    template = _dataset({(label, q): 1.0 for label, _, qs in LAYOUT for q in qs})
    preds = predict(template, TRUTH)
    assert all(p.ok for p in preds)
    return {(p.row, p.quantity): p.predicted for p in preds}


def _noisy(clean: dict, seed: int) -> MeasurementSet:
    rng = np.random.default_rng(seed)
    keys = list(clean)
    noise = rng.standard_normal(len(keys))
    return _dataset({k: clean[k] + SD[k[1]] * e for k, e in zip(keys, noise)})


def test_exact_data_recover_the_truth(clean):
    r = fit(_dataset(clean))
    assert r.ok and r.identifiable, (r.message, r.warnings)
    assert r.value("E") == pytest.approx(TRUTH["E"], rel=FIT_EXACT_REL)
    assert r.value("rho") == pytest.approx(TRUTH["rho"], rel=FIT_EXACT_REL)
    assert max(abs(x["residual"]) for x in r.residuals) < 1e-6
    assert all(s["stable"] and s["on_load_path"] for s in r.rows)


def test_noisy_data_recover_the_truth_within_the_intervals(clean):
    r = fit(_noisy(clean, seed=0))
    assert r.ok and r.identifiable
    for name in TRUTH:
        lo, hi = r.interval[r.free.index(name)]
        assert lo <= TRUTH[name] <= hi, (name, lo, hi)
    assert r.dof == sum(len(q) for _, _, q in LAYOUT) - 2
    # the stated sds are the true ones: the residual variance is about 1
    assert 0.2 < r.residual_variance < 3.0
    assert -1.0 < r.correlation[0, 1] < 0.0  # a softer rubber and a steeper fibre angle bend it alike
    json.dumps(r.to_dict(), allow_nan=False)


@pytest.mark.slow
@pytest.mark.ci
def test_95_percent_intervals_cover_the_truth_90_to_99_percent_of_the_time(clean):
    """50 seeds x 2 parameters: the 95 % intervals (Gauss-Newton covariance scaled by s^2, Student's t)
    must cover the truth in 90 to 99 of the 100 cases."""
    covered, total = 0, 0
    for seed in range(50):
        r = fit(_noisy(clean, seed))
        assert r.ok and r.identifiable, (seed, r.message, r.warnings)
        for name, truth in TRUTH.items():
            lo, hi = r.interval[r.free.index(name)]
            covered += lo <= truth <= hi
            total += 1
    print(f"{covered} of {total} intervals cover the truth")
    assert 90 <= covered <= 99, f"{covered} of {total} intervals cover the truth"


def test_the_jacobian_is_the_derivative_of_the_predictions(clean):
    """The implicit-function-theorem Jacobian of every prediction against central differences of solves."""
    data = _dataset(clean)
    free = ("E", "rho")
    p = np.array([TRUTH["E"], TRUTH["rho"]])
    jac = np.vstack([dy for _, _, _, dy, _ in _rows_at(data, free, p, None)])
    h = 1e-5 * p
    cols = []
    for j in range(2):
        up, down = p.copy(), p.copy()
        up[j] += h[j]
        down[j] -= h[j]
        a = np.array([x.predicted for x in predict(data, dict(zip(free, up)))])
        b = np.array([x.predicted for x in predict(data, dict(zip(free, down)))])
        cols.append((a - b) / (2 * h[j]))
    np.testing.assert_allclose(jac, np.column_stack(cols), rtol=FIT_JACOBIAN_RTOL, atol=FIT_JACOBIAN_RTOL * np.max(np.abs(jac)))


def test_the_fit_is_stationary_in_the_jacobians_metric(clean):
    """At the NLP's optimum the weighted residuals are orthogonal to the columns of J (Gauss-Newton's
    first-order condition): the full-space NLP and the sensitivities agree."""
    data = _noisy(clean, seed=3)
    r = fit(data)
    jac = np.vstack([dy for _, _, _, dy, _ in _rows_at(data, r.free, r.estimate, None)])
    sd = np.array([x["sd"] for x in r.residuals])
    res = np.array([x["residual"] for x in r.residuals]) / sd
    g = (jac / sd[:, None]).T @ res
    assert np.all(np.abs(g * np.abs(r.estimate)) < 1e-6 * np.sum(res**2))


def test_predictions_carry_the_propagated_sd(clean):
    data = _dataset(clean)
    cov = np.array([[1e-4, -2e-3], [-2e-3, 0.25]])
    preds = predict(data, TRUTH, cov)
    jac = np.vstack([dy for _, _, _, dy, _ in _rows_at(data, ("E", "rho"), np.array([0.6, 12.0]), None)])
    np.testing.assert_allclose([p.sd for p in preds], np.sqrt(np.einsum("ij,jk,ik->i", jac, cov, jac)), rtol=1e-12)


def test_identifiability_warning_fires_on_pressure_only_data_and_not_on_the_full_set(clean):
    bends = _dataset(clean, LAYOUT[:3])
    r = fit(bends)
    assert not r.identifiable
    (warning,) = [w for w in r.warnings if w.startswith("not identifiable")]
    assert "do not separate E and rho" in warning
    assert all(not math.isfinite(v) for v in r.std_error)
    ident = identifiability(bends)
    assert not ident.identifiable and ident.ratio < 1e-12
    # the undetermined direction is the combination (r1 - 4 r2 tan^2 rho) / E of the unloaded bend
    rho, t = math.radians(10.0), math.tan(math.radians(10.0))
    expected = -8 * 3.0 * t * (1 + t * t) * rho / (8.0 - 4 * 3.0 * t * t)
    assert ident.direction["E"] / ident.direction["rho"] == pytest.approx(expected, rel=1e-6)
    full = fit(_dataset(clean))
    assert full.identifiable and not [w for w in full.warnings if w.startswith("not identifiable")]
    assert identifiability(_dataset(clean)).identifiable
    json.dumps(r.to_dict(), allow_nan=False)


def test_rho_drops_out_of_loaded_rows_at_a_target_angle(clean):
    loaded = _dataset(clean, LAYOUT[3:6])
    ident = identifiability(loaded)
    assert not ident.identifiable and "do not depend on rho" in ident.warnings[0]
    assert fit(loaded, ["E"]).identifiable
    # alone, rho has a Fisher matrix of ratio 1: the absolute floor still finds it undetermined
    alone = fit(loaded, ["rho"])
    assert not alone.identifiable and not np.isfinite(alone.std_error[0])
    assert any("do not depend on rho" in w for w in alone.warnings)


def test_a_parameter_without_effect_is_named_even_beside_another(clean):
    """Unloaded rows at P = 0: neither E nor rho changes a prediction; both are named."""
    rows = [("straight", {"pressure_mpa": 0.0, "total_angle_deg": 0.5}), ("again", {"pressure_mpa": 0.0, "total_angle_deg": -0.5})]
    r = fit(measurements_from_rows("zero pressure", rows), ["E", "rho"])
    assert not r.identifiable
    assert any("do not depend on E" in w for w in r.warnings) and any("do not depend on rho" in w for w in r.warnings)


def test_a_straight_row_with_tip_coordinates_fits():
    """theta = 0 exactly in a row (P = 0, no payload): CasADi's reverse-mode derivatives of the tip
    through the smooth sinc forms stay finite there, so IPOPT starts (it stopped on
    Invalid_Number_Detected)."""
    truth = {"E": 0.6}
    template = measurements_from_rows("tips", [
        ("straight", {"pressure_mpa": 0.0, "tip_x_mm": 135.0, "tip_y_mm": 0.0}),
        ("bent", {"pressure_mpa": 0.15, "tip_x_mm": 1.0, "tip_y_mm": 1.0}),
    ])
    values = {(p.row, p.quantity): p.predicted for p in predict(template, truth)}
    data = measurements_from_rows("tips", [
        ("straight", {"pressure_mpa": 0.0, "tip_x_mm": values[("straight", "tip_x")], "tip_y_mm": values[("straight", "tip_y")]}),
        ("bent", {"pressure_mpa": 0.15, "tip_x_mm": values[("bent", "tip_x")], "tip_y_mm": values[("bent", "tip_y")]}),
    ])
    r = fit(data, ["E"])
    assert r.ok and r.value("E") == pytest.approx(0.6, rel=FIT_EXACT_REL)


def test_a_fitted_state_outside_the_models_range_is_a_warning():
    """A bend of 500 degrees is fitted (the model can), but it passes a full turn and an outer-fibre
    strain of 1: the fit says so, as solve would."""
    r = fit(measurements_from_rows("far", [("far", {"pressure_mpa": 0.3, "total_angle_deg": 500.0}),
                                           ("near", {"pressure_mpa": 0.1, "total_angle_deg": 60.0})]), ["E"])
    far = next(row for row in r.rows if row["row"] == "far")
    assert any("full turn" in v for v in far["validity"])
    assert any(w.startswith("row 'far' is outside the model's range") and "full turn" in w for w in r.warnings)
    assert not next(row for row in r.rows if row["row"] == "near")["validity"]


def test_a_geometric_parameter_can_be_fitted(clean):
    """r2 free (with E): the domain of Eq. 10 and the wall r1 - r2 - d enter the NLP symbolically."""
    truth = {"E": 0.6, "r2": 3.2}
    template = _dataset({(label, q): 1.0 for label, _, qs in LAYOUT for q in qs})
    values = {(p.row, p.quantity): p.predicted for p in predict(template, truth)}
    r = fit(_dataset(values), ["E", "r2"])
    assert r.ok and r.value("r2") == pytest.approx(3.2, rel=FIT_EXACT_REL) and r.value("E") == pytest.approx(0.6, rel=FIT_EXACT_REL)


def test_default_sds_when_none_are_given(clean):
    rows = [(label, {"label": label, **scene, **{UNIT[q]: clean[(label, q)] for q in qs}}) for label, scene, qs in LAYOUT]
    r = fit(measurements_from_rows("no sds", rows), ["E"])
    assert all(not x["sd_given"] and x["sd"] == DEFAULT_SD[x["quantity"]] for x in r.residuals)
    assert {x["unit"] for x in r.residuals} <= set(QUANTITIES.values())


@pytest.mark.parametrize(
    "free, message",
    [
        ([], "none given"),
        (["P"], "free parameter 'P': allowed are L, r1, r2, d, rho, E, M"),
        (["E", "E"], "E given twice"),
        (["M"], "the mass only acts with gravity"),
    ],
)
def test_bad_free_parameters(clean, free, message):
    with pytest.raises(FitError, match=message):
        fit(_dataset(clean), free)


def test_a_parameter_every_row_sets_cannot_be_freed():
    data = measurements_from_rows("own", [("a", {"pressure_mpa": 0.1, "r2_mm": 2.0, "total_angle_deg": 40.0})])
    with pytest.raises(FitError, match="every row sets its own r2"):
        fit(data, ["r2"])


@pytest.mark.parametrize("kwargs", [{"level": 95}, {"tol": 0.0}, {"max_iter": 0}, {"linear_solver": "ma27"}, {"identifiability_tol": 1.5}])
def test_bad_fit_options(kwargs):
    with pytest.raises(FitError):
        FitOptions(**kwargs)


def test_cli_fit_table_json_and_plot(tmp_path, capsys, clean, monkeypatch):
    saved = drawn.record_saved(monkeypatch)
    path = tmp_path / "synthetic.csv"
    cols = ["label", "pressure_mpa", "target_angle_deg", "payload_n", "payload_angle_deg"] + [UNIT[q] for q in QUANTITIES] + [SD_UNIT[q] for q in QUANTITIES]
    lines = [",".join(cols)]
    for label, scene, qs in LAYOUT:
        row = {"label": label, **scene, **{UNIT[q]: clean[(label, q)] for q in qs}, **{SD_UNIT[q]: SD[q] for q in qs}}
        lines.append(",".join(str(row.get(c, "")) for c in cols))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    fig = tmp_path / "mvp.png"
    assert main(["fit", str(path), "--plot", str(fig)]) == EXIT_OK
    out = capsys.readouterr().out
    assert "E " in out and "rho" in out and "95 % interval" in out and "correlation: E-rho" in out
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the figure: a panel per kind of value, the measured values (x) against the start and the fit (y)
    axes = saved[fig.resolve()].axes
    assert [ax.get_xlabel() for ax in axes] == ["measured total angle (deg)", "measured tip x (down the unbent axis) (mm)", "measured tip y (horizontal) (mm)",
                                                 "measured secant stiffness (N/m)"]
    for ax, quantities in zip(axes, (("total_angle",), ("tip_x",), ("tip_y",), ("stiffness",))):
        series = drawn.errorbars(ax)
        assert [k.split(":")[0] for k in series] == ["start", "fitted"]
        measured = sorted(v for (_, q), v in clean.items() if q in quantities)
        fitted = next(v for k, v in series.items() if k.startswith("fitted"))
        assert sorted(fitted[:, 0]) == pytest.approx(measured)
        assert fitted[:, 1] == pytest.approx(0.0, abs=FIT_EXACT_REL * np.abs(fitted[:, 0]).max())  # clean data: the fit predicts them
    assert [ax.get_ylabel() for ax in axes] == ["predicted - measured (deg)", "predicted - measured (mm)", "predicted - measured (mm)", "predicted - measured (N/m)"]
    assert main(["fit", str(path), "--free", "E", "--level", "0.9", "--json"]) == EXIT_OK
    d = json.loads(capsys.readouterr().out, parse_constant=lambda c: pytest.fail(f"{c} in JSON"))
    assert list(d["parameters"]) == ["E"] and "interval_90" in d["parameters"]["E"] and d["status"] == "ok"
    assert main(["fit", str(path), "--free", "E,Q"]) == EXIT_USAGE
    assert "free parameter 'Q'" in capsys.readouterr().err
    assert main(["fit", str(path), "--level", "95"]) == EXIT_USAGE
    assert "0.95 for 95 %" in capsys.readouterr().err


def test_cli_fit_warns_when_not_identifiable(tmp_path, capsys, clean):
    path = tmp_path / "bends.csv"
    path.write_text("label,pressure_mpa,total_angle_deg\n" + "".join(f"{label},{s['pressure_mpa']},{clean[(label, 'total_angle')]}\n"
                                                                    for label, s, _ in LAYOUT[:3]), encoding="utf-8")
    assert main(["fit", str(path)]) == EXIT_OK
    out, err = capsys.readouterr()
    assert "WARNING: not identifiable" in out and err.startswith("esba: warning: not identifiable")


@pytest.mark.parametrize("plot, needle", [("out.xyz", "expected a file ending in .png, .pdf, .svg"), (".", "expected a file ending in")])
def test_cli_fit_refuses_a_bad_figure_path_before_fitting(tmp_path, capsys, plot, needle):
    path = tmp_path / "m.csv"
    path.write_text("pressure_mpa,total_angle_deg\n0.1,40\n", encoding="utf-8")
    assert main(["fit", str(path), "--free", "E", "--plot", plot]) == EXIT_USAGE
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and needle in err
    (tmp_path / "dir.png").mkdir()
    assert main(["fit", str(path), "--free", "E", "--plot", str(tmp_path / "dir.png")]) == EXIT_USAGE
    assert "is a folder" in capsys.readouterr().err


def test_cli_fit_refuses_a_scene_given_twice(tmp_path, capsys):
    """A TOML file with its own [scene] and --scene: the actuator would silently be --scene's."""
    data = tmp_path / "m.toml"
    data.write_text("[scene]\nsegments = 4\n\n[[measurement]]\npressure_mpa = 0.1\ntotal_angle_deg = 40\n", encoding="utf-8")
    scene = tmp_path / "s.toml"
    scene.write_text("segments = 3\n", encoding="utf-8")
    assert main(["fit", str(data), "--free", "E", "--scene", str(scene)]) == EXIT_USAGE
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and "has a [scene] table of its own" in err


def test_a_row_whose_load_path_snaps_says_so():
    """An axial push past the fold of a slightly inflated actuator: the row's state is the one after
    the snap, and the fit says that it compared the row with it."""
    rows = [("snap", {"pressure_mpa": 0.001, "payload_n": 3.0, "payload_angle_deg": 180.0, "total_angle_deg": 95.0}),
            ("no snap", {"pressure_mpa": 0.1, "payload_n": 1.0, "payload_angle_deg": 90.0, "total_angle_deg": 40.0})]
    r = fit(measurements_from_rows("snaps", rows), ["E"])
    snap = next(row for row in r.rows if row["row"] == "snap")
    assert len(snap["snaps"]) == 1 and "snap-through" in snap["snaps"][0]
    assert not next(row for row in r.rows if row["row"] == "no snap")["snaps"]
    assert any(w.startswith("row 'snap': at the fitted parameters the quasi-static path jumps") for w in r.warnings)

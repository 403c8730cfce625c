"""The paper-style figures (``esba figures``): the data behind each makes sense, each figure shows
that data (its lines against the computation, its labels, its line count), the PNGs are written.

The data checks are the paper's own statements (Section 4.4): the unloaded bending angle grows
with pressure, faster as the pressure grows, and less for a larger fibre angle (Fig. 7b); more
segments move the loaded tip less and less (Table 2, Fig. 8c); the tip moves back against a
growing horizontal payload (Fig. 10), and the secant stiffness falls as the payload grows
(Fig. 11).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from esba.analysis.stiffness import PAPER_FORCES
from esba.cli import main
from esba.figures import paper as figures
from esba.statics.equilibrium import solve
from tests.figures import drawn
from tests.tolerances import TABLE2_ANGLE_DEG, TABLE2_TIP_MM

CORE = ["fig7b", "fig8c", "fig10", "fig11"]
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: solver accuracy on angles (IPOPT + Newton polish stop near |dU/dtheta| ~ 1e-8), degrees
SOLVE_ANGLE_DEG = 1e-6


# ---------------------------------------------------------------------------------------------
# the data


@pytest.fixture(scope="module")
def curves():
    return figures.pressure_angle_curves(points=21)


def test_fig7b_angle_grows_with_pressure_and_faster_at_higher_pressure(curves):
    for c in curves:
        assert c.pressure_mpa[0] == 0.0 and c.angle_deg[0] == 0.0
        assert c.pressure_mpa[-1] == pytest.approx(figures.FIG7B_MAX_PRESSURE, rel=1e-9)
        assert np.all(np.diff(c.pressure_mpa) > 0)
        # equal angle steps need ever smaller pressure steps: the angle grows faster with pressure
        assert np.all(np.diff(c.pressure_mpa, 2) < 0)


def test_fig7b_angle_falls_with_fibre_angle(curves):
    assert [c.rho_deg for c in curves] == list(figures.FIBRE_ANGLES_DEG)
    for p in (0.05, 0.1, 0.15, 0.2):
        angles = [np.interp(p, c.pressure_mpa, c.angle_deg) for c in curves]
        assert np.all(np.diff(angles) < 0), (p, angles)


def test_fig7b_inversion_agrees_with_forward_solves(curves):
    """The closed-form inversion and IPOPT solves at the same pressures give the same angle."""
    c = curves[1]
    for k in (5, 10, 15):
        r = solve(c.check.scene.replace(pressure=float(c.pressure_mpa[k]))).check()
        assert r.total_angle_deg == pytest.approx(c.angle_deg[k], abs=SOLVE_ANGLE_DEG)


def test_fig8c_shapes_converge_with_segments():
    data = figures.payload_shapes()
    assert data.unloaded.total_angle_deg == pytest.approx(90.0, abs=SOLVE_ANGLE_DEG)
    assert [r.scene.segments for r in data.loaded] == [1, 2, 3, 4]
    for r in data.loaded:
        assert r.ok and r.pressure == data.pressure
        assert r.total_angle_deg < 90.0
    tips = np.array([r.tip_mm for r in data.loaded])
    steps = np.linalg.norm(np.diff(tips, axis=0), axis=1)
    assert np.all(np.diff(steps) < 0), steps  # n -> n + 1 changes the tip less and less
    # the n = 3 shape is Table 2's
    assert data.loaded[2].total_angle_deg == pytest.approx(25.2, abs=TABLE2_ANGLE_DEG)
    assert tips[2] == pytest.approx([133.2, 10.2], abs=TABLE2_TIP_MM)


@pytest.fixture(scope="module")
def sweep():
    return figures.horizontal_payload_sweep(np.arange(1, 41) * 0.05)


def test_fig10_tip_moves_back_monotonically(sweep):
    tips = np.array([sweep.initial.tip_mm] + [r.tip_mm for r in sweep.loaded])
    assert np.all(np.diff(tips[:, 1]) < 0)  # y falls as the payload grows
    assert np.all(np.diff(tips[:, 0]) > 0)  # and the tip swings down
    assert tips[0] == pytest.approx([270.0 / math.pi] * 2, abs=1e-6)  # the 90 deg arc: x = y = 2L/pi


def test_fig11_secant_stiffness_falls_with_payload(sweep):
    paper = figures.horizontal_payload_sweep(PAPER_FORCES)
    assert np.all(np.diff(paper.stiffness_n_per_m) < 0)  # "increase of payload ... reduction in stiffness"
    f = np.array(sweep.forces)
    k = np.array(sweep.stiffness_n_per_m)
    assert np.all(np.diff(k[f <= 1.9]) < 0)
    # near 2 N the curve is flat: it has a shallow minimum (about 1.95 N) and rises by < 0.1 %
    assert k.max() == k[0] and k[-1] <= 1.001 * k.min()
    # below the smallest payload it tends to the tangent stiffness of the unloaded state
    assert k[0] < sweep.tangent.along(90.0) < 1.05 * k[0]


# ---------------------------------------------------------------------------------------------
# the files and the command


# ---------------------------------------------------------------------------------------------
# what each figure shows


def test_fig7b_shows_each_curve(curves):
    fig = figures.draw_7b(curves)
    (ax,) = drawn.axes(fig)
    assert ax.get_xlabel() == "input pressure P (MPa)" and ax.get_ylabel() == "bending angle θ (deg)"
    for c in curves:
        x, y = drawn.xy(drawn.labelled(ax, f"ρ = {c.rho_deg:g}°"))
        np.testing.assert_array_equal(x, c.pressure_mpa)
        np.testing.assert_array_equal(y, c.angle_deg)
    # the four curves, the 90 degree line and the 90 degree state of Table 1
    assert len(drawn.lines(ax)) == len(curves) + 2
    p90 = figures.pressure_for_angle(figures._zero_payload(figures.Scene(segments=1)), 90.0)
    assert [[p90, 90.0]] in [drawn.points(ln) for ln in drawn.lines(ax)]
    assert drawn.legend(ax) == [f"ρ = {r:g}°" for r in figures.FIBRE_ANGLES_DEG]


def test_fig8c_shows_each_shape_and_the_measured_tips():
    data = figures.payload_shapes()
    fig = figures.draw_8c(data)
    (ax,) = drawn.axes(fig)
    assert ax.get_xlabel() == "y (mm)" and ax.get_ylabel() == "x (mm), downwards"
    shapes = drawn.starting(ax, "n = ")
    assert len(shapes) == 4
    for line, r in zip(shapes, data.loaded):
        assert drawn.xy(line)[0] == pytest.approx(r.centreline[:, 1]) and drawn.xy(line)[1] == pytest.approx(r.centreline[:, 0])
        assert line.get_label().startswith(f"n = {r.scene.segments}: θ = {r.total_angle_deg:.1f}°")
    (free,) = drawn.starting(ax, "no payload")
    assert drawn.xy(free)[1] == pytest.approx(data.unloaded.centreline[:, 0])
    exp = drawn.labelled(ax, "experiment tip (Table 2)")
    assert drawn.points(exp) == [[figures.TABLE2_EXP_TIP_MM[1], figures.TABLE2_EXP_TIP_MM[0]]]
    # a shape and its segment ends per n, the unloaded shape, the two measured tips; the clamp a block
    assert len(drawn.lines(ax)) == 2 * 4 + 1 + 2
    assert len(ax.patches) == 1
    assert len(drawn.legend(ax)) == 4 + 1 + 2


def test_fig10_shows_the_traced_branch_and_the_secants():
    b = figures.payload_branch()
    fig = figures.draw_10(b)
    ax_y, ax_x = drawn.axes(fig)
    assert ax_y.get_xlabel() == "tip y, horizontal (mm)" and ax_y.get_ylabel() == "horizontal tip payload F (N)"
    assert ax_x.get_xlabel() == "tip x, vertical, downwards (mm)"
    assert b.stable.all()  # one run of the branch on each panel
    x, y = drawn.xy(drawn.labelled(ax_y, "esba, n = 3: traced branch (all stable)"))
    np.testing.assert_array_equal(x, b.tip[:, 1])
    np.testing.assert_array_equal(y, b.lam)
    x, y = drawn.xy(drawn.labelled(ax_x, "esba, n = 3 (traced)"))
    np.testing.assert_array_equal(x, b.tip[:, 0])
    # a dashed secant from the unloaded tip to the tip at each of the paper's payloads
    secants = [ln for ln in drawn.lines(ax_y) if ln.get_linestyle() == "--"]
    assert [drawn.xy(ln)[1][-1] for ln in secants] == list(PAPER_FORCES)
    for ln, f in zip(secants, PAPER_FORCES):
        tip = next(p.tip for p in b.special if p.kind == "user" and p.lam == f)
        assert drawn.xy(ln)[0] == pytest.approx([b.tip[0, 1], tip[1]])


def test_fig11_shows_the_secant_stiffness(sweep):
    paper = figures.horizontal_payload_sweep(PAPER_FORCES)
    fig = figures.draw_11(sweep, paper)
    (ax,) = drawn.axes(fig)
    assert ax.get_xlabel() == "horizontal tip payload F (N)" and ax.get_ylabel() == "stiffness K (N/m)"
    x, y = drawn.xy(drawn.labelled(ax, "secant K = ΔF/Δy, esba n = 3"))
    np.testing.assert_array_equal(x, sweep.forces)
    np.testing.assert_array_equal(y, sweep.stiffness_n_per_m)
    x, y = drawn.xy(drawn.labelled(ax, "the paper's payloads 0.5, 1, 2 N"))
    np.testing.assert_array_equal(x, PAPER_FORCES)
    np.testing.assert_array_equal(y, paper.stiffness_n_per_m)
    (tangent,) = drawn.starting(ax, "tangent stiffness at 0 N")
    assert drawn.points(tangent) == [[0.0, pytest.approx(sweep.tangent.along(90.0))]]
    assert len(drawn.lines(ax)) == 3 + (1 if int(np.argmin(sweep.stiffness_n_per_m)) < len(sweep.forces) - 1 else 0)


# ---------------------------------------------------------------------------------------------
# the files and the command


def test_write_all_writes_every_figure(tmp_path):
    written = figures.write_all(tmp_path, CORE)
    assert list(written) == CORE
    for name, path in written.items():
        assert path == tmp_path / f"{name}.png"
        assert path.read_bytes()[:8] == PNG_SIGNATURE, name


def test_cli_writes_the_chosen_figures(tmp_path, capsys):
    assert main(["figures", "--out", str(tmp_path), "--only", "fig7b", "--only", "fig7b", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert list(data["figures"]) == ["fig7b"]
    assert (tmp_path / "fig7b.png").read_bytes()[:8] == PNG_SIGNATURE
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig7b.png"]


def test_cli_bad_name_is_a_one_line_usage_error(tmp_path, capsys):
    assert main(["figures", "--out", str(tmp_path / "new"), "--only", "fig7b", "fig9"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err
    assert err.startswith("esba: error: --only: unknown figure 'fig9': allowed are fig7b, fig8c, fig10, fig11")
    assert not (tmp_path / "new").exists()  # nothing drawn before the names are checked


def test_registry_core_names():
    assert list(figures.registry())[:4] == CORE


def test_design_figures_registered_only_when_their_module_exists(tmp_path, monkeypatch):
    monkeypatch.setattr(figures, "_DESIGN_MODULE", "esba_no_such_design_figures")
    assert list(figures.registry()) == CORE
    (tmp_path / "fake_design_figures.py").write_text(
        "from esba.figures.scenes import new_figure\n"
        "def draw_13a():\n"
        "    fig = new_figure(2.0, 2.0)\n"
        "    fig.add_subplot().plot([0.0, 1.0], [1.0, 2.0], label='fake')\n"
        "    return fig\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(figures, "_DESIGN_MODULE", "fake_design_figures")
    reg = figures.registry()
    assert list(reg) == CORE + ["fig13a", "fig13b", "fig14"]
    assert drawn.points(drawn.labelled(reg["fig13a"]().axes[0], "fake")) == [[0.0, 1.0], [1.0, 2.0]]  # imported when drawn
    assert figures.write_all(tmp_path / "out", ["fig13a"]) == {"fig13a": tmp_path / "out" / "fig13a.png"}
    assert (tmp_path / "out" / "fig13a.png").read_bytes()[:8] == PNG_SIGNATURE


def test_the_top_contour_of_a_steep_field_lies_where_the_field_has_its_value():
    """Fig. 13a's field grows steeply past its top level (720 deg): the contour lines are drawn on
    the field's own values there, not on values clipped just above the top level (which put the
    720 deg line between a value and its clipped neighbour: jagged)."""
    from matplotlib.contour import ContourSet
    from matplotlib.tri import LinearTriInterpolator

    from esba.figures.design import _contour, triangle_grid
    from esba.figures.scenes import new_figure

    grid = triangle_grid(8.0, 30)
    field = 20.0 * np.exp(0.8 * grid[:, 0]) + 5.0 * grid[:, 1]  # steep in r2, like the bending angle at 0.2 MPa
    field[np.argmax(field)] = np.inf  # a design off every scale
    levels = np.arange(0.0, 721.0, 45.0)
    fig = new_figure()
    ax = fig.add_subplot()
    tri = _contour(fig, ax, grid, field, levels, "deg", "viridis", extend="max")
    (lines,) = [c for c in ax.collections if isinstance(c, ContourSet) and not c.filled]
    top = lines.get_paths()[list(lines.levels).index(720.0)].vertices
    assert len(top) > 5
    finite = np.where(np.isfinite(field), field, 1e9)
    on_line = LinearTriInterpolator(tri, finite)(top[:, 0], top[:, 1])
    np.testing.assert_allclose(on_line.compressed(), 720.0, rtol=1e-9)


def test_the_loading_band_goes_on_through_a_branch_point_it_passes():
    """n = 4 column, 1 -> 6.4 N and back (docs/paths.md's figure): unloading comes back along the buckled
    branch to the branch point and goes on straight; its band is drawn through the branch point, from
    its last point on the buckled branch to the first on the straight one."""
    from esba.analysis.path_analysis import analyse
    from esba.figures.paths import LOADING_BANDS, path_figure
    from esba.model.scene import Payload, Scene
    from esba.paths.continuation import PathOptions

    run = analyse(Scene(pressure=0.0, payloads=(Payload(1.0, 180.0),), segments=4), "payload", 6.4, options=PathOptions(ds_max=0.1))
    down = run.loading[1]
    (bp,) = down.branch_points
    assert down.jumps == ()
    ax = drawn.axes(path_figure(run))[0]
    _, down_colour, down_width = LOADING_BANDS[1]
    bands = [ln for ln in drawn.lines(ax) if ln.get_linewidth() == down_width and ln.get_color() == down_colour]
    x = np.concatenate([drawn.xy(ln)[0] for ln in bands])
    assert x.min() == 1.0 and x.max() == 6.4
    # no stretch of the ramp left undrawn: every gap between drawn x values lies inside one band
    spans = sorted((float(min(drawn.xy(ln)[0])), float(max(drawn.xy(ln)[0]))) for ln in bands)
    reach = spans[0][1]
    for lo, hi in spans[1:]:
        assert lo <= reach + 1e-12, (lo, reach)
        reach = max(reach, hi)
    assert any(bp.lam in drawn.xy(ln)[0] for ln in bands)

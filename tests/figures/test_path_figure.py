"""The path figure (esba.figures.paths) of ``esba path``: its title, axis labels and loading bands."""

from __future__ import annotations

from matplotlib.colors import to_rgba

from esba.cli import main
from esba.figures.paths import LOADING_BANDS
from tests.figures import drawn


def _figure(capsys, monkeypatch, tmp_path, *argv):
    saved = drawn.record_saved(monkeypatch)
    fig = tmp_path / "p.png"
    assert main(["path", *argv, "--plot", str(fig), "--no-out"]) == 0
    capsys.readouterr()
    (ax,) = saved[fig.resolve()].axes
    return ax


def test_a_pressure_path_is_titled_by_its_range_and_its_start(capsys, monkeypatch, tmp_path):
    """The scene's drive (a 90 degree target angle) is not what a pressure path from 0 shows."""
    ax = _figure(capsys, monkeypatch, tmp_path, "--param", "pressure", "--from", "0", "--to", "0.3", "--payload", "2")
    title = ax.get_title()
    assert title.startswith("pressure from 0 to 0.3 MPa (esba path --param pressure)\nat the start: ")
    assert "P=0 MPa" in title and "unloaded angle" not in title
    assert ax.get_xlabel() == "pressure (MPa)"


def test_payload_paths_are_labelled_in_words(capsys, monkeypatch, tmp_path):
    ax = _figure(capsys, monkeypatch, tmp_path, "--param", "omega", "--from", "90", "--to", "100")
    assert ax.get_xlabel() == "payload direction from the vertical (deg)"
    assert ax.get_title().startswith("payload direction from the vertical from 90 to 100 deg")
    ax = _figure(capsys, monkeypatch, tmp_path, "--param", "payload", "--pressure", "0.05", "--payload", "0.5", "--to", "1")
    assert ax.get_xlabel() == "payload magnitude (N)"


def test_the_loading_bands_are_the_colours_of_their_legend_entries(capsys, monkeypatch, tmp_path):
    """Opaque bands of two widths, the narrower (loading down) over the wider: where both follow the
    same branch each keeps its own colour, the one its legend entry shows (translucent bands blended)."""
    ax = _figure(capsys, monkeypatch, tmp_path, "--param", "pressure", "--from", "0", "--to", "0.3", "--payload", "2")
    legend = {t.get_text(): h for t, h in zip(ax.get_legend().get_texts(), ax.get_legend().legend_handles)}
    for (name, color, width), other in zip(LOADING_BANDS, reversed(LOADING_BANDS)):
        bands = [ln for ln in drawn.lines(ax) if ln.get_linewidth() == width]
        assert bands and all(to_rgba(ln.get_color(), ln.get_alpha()) == to_rgba(color) for ln in bands), name
        assert to_rgba(legend[name].get_color(), legend[name].get_alpha()) == to_rgba(color)
    up = [ln for ln in drawn.lines(ax) if ln.get_linewidth() == LOADING_BANDS[0][2]]
    down = [ln for ln in drawn.lines(ax) if ln.get_linewidth() == LOADING_BANDS[1][2]]
    assert LOADING_BANDS[1][2] < LOADING_BANDS[0][2] and min(ln.get_zorder() for ln in down) > max(ln.get_zorder() for ln in up)
    branch = [ln for ln in drawn.lines(ax) if ln.get_linewidth() == 1.8]
    assert min(ln.get_zorder() for ln in branch) > max(ln.get_zorder() for ln in down)  # the branch drawn over both

"""The README and docs: the annotated scene file, the examples, the figures on pages, packaging."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from esba.model.scene import load_scene

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text(encoding="utf-8")

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def test_readme_scene_example_is_the_annotated_file_and_names_every_key():
    block = re.search(r"```toml\n(.*?)```", README, flags=re.S).group(1)
    text = (ROOT / "examples" / "annotated.toml").read_text(encoding="utf-8")
    assert block == text
    scene = load_scene(ROOT / "examples" / "annotated.toml")
    assert scene.segments == 3 and scene.target_angle_deg == 90.0 and scene.payloads[0].force == 2.0
    import dataclasses

    from esba.model.scene import _LOAD_KEYS, _PAYLOAD_KEYS, _TOP_KEYS, Actuator

    keys = _TOP_KEYS | _LOAD_KEYS | _PAYLOAD_KEYS | {f.name for f in dataclasses.fields(Actuator)}
    for key in keys:
        assert re.search(rf"^#? ?\[*{key}\]*\s*(=|#|$)", text, flags=re.M), f"{key} is not annotated"


def test_readme_glossary_names_every_parameter():
    glossary = README[README.index("## Glossary"):README.index("### Scene files")]
    for name in ("L", "r1", "r2", "d", "ρ", "E", "M", "P", "F", "Ω", "at", "n", "variant"):
        assert re.search(rf"^\| {re.escape(name)} ", glossary, flags=re.M), name


def test_readme_sweep_example_stays_in_the_design_space():
    from esba.studies.sweep import parse_values

    m = re.search(r"esba sweep --r2 (\S+) --d (\S+)", README)
    r2, d = parse_values(m.group(1)), parse_values(m.group(2))
    assert max(r2) + max(d) < 8.0


def test_readme_says_where_each_command_writes_and_what_takes_minutes():
    where = README[README.index("## Where each command writes"):]
    for command in ("solve", "sweep", "design", "validate", "audit", "figures", "bench accuracy", "bench generation", "generate"):
        assert f"| `esba {command}" in where, command
    howlong = README[README.index("### How long commands take"):]
    howlong = howlong[: howlong.index("\n#")]
    for command in ("bench accuracy", "bench generation", "bench solve", "bench scaling", "generate --refresh"):
        assert f"`esba {command}`" in howlong or f"`{command}`" in howlong, f"the README does not say how long `esba {command}` takes"


#: Every figure in docs/figures and the command that writes it.
WRITERS = {
    "fig7b": "esba figures --only fig7b",
    "fig8c": "esba figures --only fig8c",
    "fig10": "esba figures --only fig10",
    "fig11": "esba figures --only fig11",
    "fig13a": "esba figures --only fig13a",
    "fig13b": "esba figures --only fig13a fig13b",
    "fig14": "esba figures --only fig13a fig13b fig14",
    "sweep-fig12": "esba sweep --fig12 docs/figures/sweep-fig12.png",
    "sweep-pressure-payload": "--plot docs/figures/sweep-pressure-payload.png",
    "accuracy-vs-time": "esba bench accuracy",
    "experiments": "esba experiments --write-doc",
    "path-pressure-2N": "esba path --write-doc",
    "path-omega-2N": "esba path --write-doc",
    "path-column-n4": "esba path --write-doc",
    "equilibria-window": "esba docs --write equilibria",
    "equilibria-omega121": "esba docs --write equilibria",
    "sensing-blind": "esba docs --write sensing",
    "sensing-ellipses": "esba docs --write sensing",
    "map-pressure-payload": "esba map --write-doc",
    "map-omega-payload": "esba map --write-doc",
    "map-pressure-omega": "esba map --write-doc",
    "map-design-plane": "esba map --write-doc",
    "map-3d-gripper": "esba map --write-doc",
    "contact-blocked": "esba docs --write contact",
    "contact-tester": "esba docs --write contact",
    "contact-grasp": "esba docs --write contact",
    "contact3d-tilted-cylinder": "esba docs --write contact",
}


@pytest.mark.parametrize("figure", sorted(p.stem for p in (ROOT / "docs" / "figures").glob("*.png")))
def test_every_figure_is_shown_on_a_page_beside_its_command(figure):
    assert figure in WRITERS, f"docs/figures/{figure}.png: add it to a page and to WRITERS"
    pages = [p for p in (ROOT / "docs").glob("*.md") if f"](figures/{figure}.png)" in p.read_text(encoding="utf-8")]
    assert pages, f"docs/figures/{figure}.png is shown on no page"
    assert any(WRITERS[figure] in p.read_text(encoding="utf-8") for p in pages), f"{figure}: the page does not name `{WRITERS[figure]}`"


def test_gitignore_lists_what_the_readme_commands_write():
    ignored = (ROOT / ".gitignore").read_text().split()
    assert "esba-solve.png" in ignored and "sweep.csv" in ignored and "sweep.study.json" in ignored


def test_license_is_an_spdx_string():
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert data["project"]["license"] == "MIT"  # a table is deprecated by setuptools >= 77
    assert any(r.startswith("setuptools>=77") for r in data["build-system"]["requires"])


def test_cli_bounds_agree_with_the_library():
    from esba.cli import scenes
    from esba.statics import equilibrium

    assert scenes._MAX_ITER == equilibrium.MAX_ITER_LIMIT


def test_every_package_of_the_source_is_installed():
    """A subpackage missing from pyproject's list would work in a checkout and fail after `pip install .`."""
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())
    listed = set(data["tool"]["setuptools"]["packages"])
    # derive/ installs as esba.derive (pyproject's package-dir): the repository keeps it at its top
    found = {".".join(("esba",) * (top == "derive") + p.parent.relative_to(ROOT).parts) for top in ("esba", "derive") for p in (ROOT / top).rglob("__init__.py")}
    assert found <= listed, f"add {sorted(found - listed)} to [tool.setuptools] packages"


def test_architecture_page_draws_the_floors_of_the_layer_test_and_is_linked():
    from tests.system.test_layers import FLOORS

    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    assert "(docs/architecture.md)" in README
    drawn = {}
    for floor, names in re.findall(r"^ +(\d+) +([a-z]+(?: +[a-z]+)?) {2,}", text, flags=re.M):
        for name in names.split():
            drawn[name] = int(floor)
    assert drawn == FLOORS
    for name in FLOORS:  # a row of the package table each
        assert f"\n| `{name}` |" in text, name
    covered = set()
    for a, b in re.findall(r"^\| Eq\. (\d+)(?:-(\d+))? \|", text, flags=re.M):
        covered |= set(range(int(a), int(b or a) + 1))
    assert covered == set(range(1, 20)), sorted(set(range(1, 20)) - covered)  # every equation of the paper has a row


@pytest.mark.parametrize("number", range(len(re.findall(r"```python\n", README))))
def test_each_readme_python_snippet_runs_on_its_own(number, tmp_path):
    """A reader copies one snippet: it runs alone, in a fresh interpreter, with its own imports and names."""
    import subprocess
    import sys

    code = re.findall(r"```python\n(.*?)```", README, flags=re.S)[number]
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"README snippet {number + 1}:\n{proc.stderr[-1500:]}"
    assert proc.stdout.strip()

"""Every command of the README's "Set-up" and "Using it", run as a new user runs it: esba installed
from this checkout without ``-e`` (so nothing of the checkout is found), each command in an empty
folder after the section's two preparing lines (``esba example --all``, ``mkdir -p docs``).

Commands that take long (benchmarks, Dask studies, the Monte Carlo, pages that run many cases) are
slow tests; the cheap ones also run in CI (``ci``).
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text(encoding="utf-8")

#: Substrings of the commands that take more than a few seconds: slow, not in CI.
EXPENSIVE = ("bench ", "--monte-carlo", "--workers", "generate --segments 12", "path --write-doc", "docs --write", "design --method both",
             "esba figures", "esba audit", "experiments --write-doc", "esba map", "--envelope", "esba estimate")


def _section(title: str) -> str:
    start = README.index(f"\n## {title}\n")
    end = README.find("\n## ", start + 1)
    return README[start:end]


def readme_commands() -> tuple[list[str], list[str]]:
    """The preparing lines of "Using it" and every esba command of "Set-up" and "Using it" (comments
    dropped; ``pip install . && esba solve`` gives ``esba solve``), except those marked to run in a checkout."""
    prepare, commands = [], []
    for title in ("Set-up", "Using it"):
        for line in _section(title).splitlines():
            if not line.startswith("    "):
                continue
            command, _, comment = line.strip().partition(" # ")
            command = command.split("&& ")[-1].strip()
            if comment.strip().startswith("in a checkout"):
                continue
            if command in ("esba example --all", "mkdir -p docs"):
                prepare.append(command)
            elif command.startswith("esba "):
                commands.append(command)
    return prepare, commands


PREPARE, COMMANDS = readme_commands()


def _param(command: str):
    marks = [pytest.mark.slow] + ([] if any(e in command for e in EXPENSIVE) else [pytest.mark.ci])
    return pytest.param(command, marks=marks, id=command[5:60])


def test_the_readme_has_its_commands():
    assert PREPARE == ["esba example --all", "mkdir -p docs"]
    assert not any("#" in c for c in COMMANDS)
    assert "esba solve" in COMMANDS and "esba fit examples/measurements/paper_exp.csv" in COMMANDS and len(COMMANDS) > 25


@pytest.fixture(scope="session")
def installed(tmp_path_factory) -> Path:
    """esba installed from this checkout, not editable, into a folder of its own (its dependencies:
    this environment's)."""
    target = tmp_path_factory.mktemp("site")
    proc = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-compile", "--target", str(target), str(ROOT)],
                          capture_output=True, text=True, timeout=600)
    if proc.returncode != 0:
        pytest.fail(f"pip install --target of the checkout failed: {proc.stderr.strip().splitlines()[-1:]}")
    assert (target / "esba" / "examples" / "table2.toml").is_file()
    return target


def _run(command: str, site: Path, cwd: Path) -> subprocess.CompletedProcess:
    if command.startswith("mkdir "):
        (cwd / command.split()[-1]).mkdir(parents=True, exist_ok=True)
        return subprocess.CompletedProcess(command, 0, "", "")
    env = dict(os.environ, PYTHONPATH=str(site), MPLBACKEND="Agg")
    argv = [sys.executable, "-m", "esba", *shlex.split(command)[1:]]
    return subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=1800)


@pytest.mark.parametrize("command", [_param(c) for c in COMMANDS])
def test_readme_command_works_in_an_empty_folder(installed, tmp_path, command):
    where = tmp_path / "user"
    where.mkdir()
    for line in PREPARE:
        assert _run(line, installed, where).returncode == 0, line
    probe = subprocess.run([sys.executable, "-c", "import esba, sys; print(esba.__file__)"], env=dict(os.environ, PYTHONPATH=str(installed)),
                           cwd=where, capture_output=True, text=True)
    assert Path(probe.stdout.strip()).is_relative_to(installed)  # the installed esba, not the checkout
    proc = _run(command, installed, where)
    assert proc.returncode == 0, f"{command}: exit {proc.returncode}\n{proc.stderr[-2000:]}"
    assert "Traceback" not in proc.stderr
    assert not re.search(r"\{'", proc.stdout), "a Python dict printed as it is"

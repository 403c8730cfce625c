"""The slow-test policy of tests/conftest.py selects by marker, whatever the folders are called."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

CONFTEST = Path(__file__).resolve().parents[1] / "conftest.py"

TESTS = '''
import pytest

def test_fast():
    pass

@pytest.mark.slow
def test_slow():
    pass

@pytest.mark.slow
@pytest.mark.ci
def test_slow_ci():
    pass
'''


@pytest.mark.parametrize("folder", ["ci", "slow", "plain"])
@pytest.mark.parametrize("ci, expected", [("true", "2 passed, 1 skipped"), ("", "1 passed, 2 skipped")])
def test_ci_subset_does_not_depend_on_folder_names(tmp_path, folder, ci, expected):
    tests = tmp_path / folder / "tests"
    tests.mkdir(parents=True)
    shutil.copy(CONFTEST, tests / "conftest.py")
    (tests / "test_policy.py").write_text(TESTS)
    env = {**os.environ, "CI": ci}
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-o", "addopts=", str(tests)],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert expected in proc.stdout, proc.stdout

"""Brent's method (esba.solvers.roots): SciPy's algorithm without importing scipy.optimize."""

from __future__ import annotations

import math
import subprocess
import sys

import pytest
from scipy.optimize import brentq as scipy_brentq

from esba.solvers.roots import brentq

CASES = [
    (lambda x: x**3 - 2 * x - 5, 2.0, 3.0),
    (lambda x: math.cos(x) - x, 0.0, 1.0),
    (lambda x: math.exp(x) - 10.0, -5.0, 5.0),
    (lambda x: math.atan(50 * (x - 0.3)), -1.0, 2.0),
    (lambda x: (x - 1e-3) ** 3, -1.0, 1.0),
    (lambda x: x - 7.0, 7.0, 9.0),  # a root at an end
]


@pytest.mark.parametrize("case", range(len(CASES)))
@pytest.mark.parametrize("xtol", [2e-12, 1e-15])
def test_brentq_is_scipys_algorithm(case, xtol):
    f, a, b = CASES[case]
    ours = brentq(f, a, b, xtol=xtol, rtol=1e-15, maxiter=200)
    assert ours == scipy_brentq(f, a, b, xtol=xtol, rtol=1e-15, maxiter=200)  # the same steps, to the bit
    assert abs(ours - scipy_brentq(f, a, b, xtol=1e-300, rtol=8.9e-16, maxiter=500)) <= xtol + 1e-15 * abs(ours) + 1e-300


def test_brentq_refuses_what_scipy_refuses():
    with pytest.raises(ValueError, match="opposite signs"):
        brentq(lambda x: x * x + 1.0, -1.0, 1.0)
    with pytest.raises(ValueError, match="rtol"):
        brentq(lambda x: x, -1.0, 1.0, rtol=1e-17)
    with pytest.raises(RuntimeError, match="no convergence"):
        brentq(lambda x: math.atan(50 * (x - 0.3)), -1.0, 2.0, xtol=1e-15, maxiter=3)


def test_esba_path_does_not_import_scipy_optimize():
    """``scipy.optimize`` took 0.3 s of an ``esba path`` run's 0.7 s for one root finder."""
    code = (
        "import sys\n"
        "from esba.cli import main\n"
        "main(['path', '--param', 'pressure', '--from', '0', '--to', '0.3', '--payload', '2', '--no-out', '--no-plot'])\n"
        "print('scipy.optimize imported' if 'scipy.optimize' in sys.modules else 'scipy.optimize not imported')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "fold" in out.stdout  # it did locate the two folds
    assert out.stdout.strip().endswith("scipy.optimize not imported")

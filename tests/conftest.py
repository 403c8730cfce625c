"""Shared fixtures: the Table 1 actuator, a private model cache, and the slow-test policy.

Slow tests (large n, full sweeps) are marked ``@pytest.mark.slow``. They are skipped unless
``pytest --slow`` is given; in CI (``CI=true``) the ones also marked ``@pytest.mark.ci`` run, a
small honest subset that keeps CI under 10 minutes.
"""

from __future__ import annotations

import math
import os

import pytest

#: The paper's Table 1 actuator with E = 0.54 MPa (Section 4.2), in esba's units.
TABLE1 = {"L": 135.0, "r1": 8.0, "r2": 3.0, "d": 4.0, "rho": math.radians(10.0), "E": 0.54}


def pytest_addoption(parser):
    parser.addoption("--slow", action="store_true", help="also run the slow tests")


def pytest_collection_modifyitems(config, items):
    run_all = config.getoption("--slow")
    in_ci = os.environ.get("CI", "").lower() == "true"
    for item in items:
        # The markers themselves, not ``item.keywords``: keywords also hold the names of the folders
        # above the test, so a checkout inside a folder named ``ci`` or ``slow`` would match.
        if item.get_closest_marker("slow") is None or run_all:
            continue
        if in_ci and item.get_closest_marker("ci") is not None:
            continue
        item.add_marker(pytest.mark.skip(reason="slow test: run with --slow (CI runs the ones marked ci)"))


@pytest.fixture(scope="session", autouse=True)
def _private_cache(tmp_path_factory):
    """Models generated on demand during the tests go to a fresh folder, not the user's cache."""
    if "ESBA_CACHE_DIR" not in os.environ:
        os.environ["ESBA_CACHE_DIR"] = str(tmp_path_factory.mktemp("esba-cache"))
    yield


@pytest.fixture
def table1():
    return dict(TABLE1)

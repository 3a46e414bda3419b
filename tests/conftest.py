"""Shared fixtures: seeded generators, the benchmark data home, slow-test switch."""

import os
from pathlib import Path

import numpy as np
import pytest


def pytest_configure(config):
    # The README passes SINDYBENCH_DATA relative to the repository root; make it absolute
    # once, so tests that change directory or start subprocesses elsewhere still find it.
    path = os.environ.get("SINDYBENCH_DATA")
    if path:
        os.environ["SINDYBENCH_DATA"] = str(Path(path).resolve())


def pytest_addoption(parser):
    parser.addoption(
        "--runslow", action="store_true", default=False, help="run the full (slow) version of heavy checks"
    )


def pytest_collection_modifyitems(config, items):
    if config.getoption("--runslow"):
        return
    skip = pytest.mark.skip(reason="heavy check: run with --runslow (a quick version runs by default)")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def rng():
    """A seeded random generator (never the global numpy seed)."""
    return np.random.default_rng(0)


@pytest.fixture(scope="session")
def runslow(pytestconfig):
    """True when the full versions of heavy checks were asked for."""
    return pytestconfig.getoption("--runslow")


@pytest.fixture(scope="session")
def data_home():
    """The benchmark data folder named by SINDYBENCH_DATA.

    Skips with a reason when it is absent on a developer machine; on CI
    (``CI`` set) a missing folder is an error, never a skip.
    """
    path = os.environ.get("SINDYBENCH_DATA")
    if path and Path(path).is_dir():
        return Path(path)
    msg = f"benchmark data not found: set SINDYBENCH_DATA to the data folder (got {path!r})"
    if os.environ.get("CI"):
        pytest.fail(msg)
    pytest.skip(msg)

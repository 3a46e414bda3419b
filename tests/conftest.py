"""Shared fixtures: seeded generators, the benchmark data home, slow-test switch, a PostgreSQL server."""

import os
from pathlib import Path

import numpy as np
import pytest

import _postgres


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


@pytest.fixture(scope="session")
def postgres_server():
    """A real PostgreSQL server for this test session: ``(bindir, socket_dir, superuser)``.

    Started from the machine's binaries (:mod:`_postgres`: a fresh data folder in a
    temporary directory, a Unix socket there and no TCP port, as an unprivileged user
    when the tests run as root), stopped and removed at the end of the session, also
    when a test failed. Skips, saying so, only where no PostgreSQL server binaries
    exist; the driver (psycopg 3) comes with the ``test`` extra.
    """
    bindir = _postgres.find_bindir()
    if bindir is None:
        pytest.skip("no PostgreSQL server binaries (initdb, pg_ctl, createdb) found: not via pg_config, "
                    "not on PATH, not in /usr/lib/postgresql/*/bin; install the 'postgresql' package")
    with _postgres.postgres_server(bindir) as (socket_dir, superuser):
        yield bindir, socket_dir, superuser


@pytest.fixture
def postgres_url(postgres_server):
    """SQLAlchemy URL of a new, empty database on the session's PostgreSQL server."""
    bindir, socket_dir, superuser = postgres_server
    return _postgres.url(socket_dir, superuser, _postgres.create_database(bindir, socket_dir, superuser))

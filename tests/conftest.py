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


EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


class NotebookRunner:
    """Executes the example notebooks once per session, in a real Jupyter kernel, in quick mode.

    ``run(name)`` returns the executed notebook (also written to ``folder/<name>.ipynb``,
    where the documentation build picks up the outputs instead of executing again).
    """

    def __init__(self, folder, data_home):
        self.folder, self.data_home, self._done = Path(folder), data_home, {}

    def run(self, name):
        if name not in self._done:
            self._done[name] = self._execute(name)
        if isinstance(self._done[name], BaseException):
            raise self._done[name]
        return self._done[name]

    def _execute(self, name):
        jupytext = pytest.importorskip("jupytext", reason="the test extra (jupytext, nbclient, ipykernel) is missing")
        nbclient = pytest.importorskip("nbclient")
        import nbformat

        notebook = jupytext.read(EXAMPLES / f"{name}.py")
        env = {"SINDYBENCH_DATA": str(self.data_home), "SINDYBENCH_QUICK": "1", "SINDYBENCH_PROGRESS": "0"}
        saved = {k: os.environ.get(k) for k in (*env, "MPLBACKEND")}
        os.environ.update(env)
        os.environ.pop("MPLBACKEND", None)  # the kernel's inline backend puts the figures into the notebook
        work = self.folder / f"{name}.work"
        work.mkdir(parents=True, exist_ok=True)
        try:
            client = nbclient.NotebookClient(notebook, timeout=600, startup_timeout=120, kernel_name="python3",
                                             resources={"metadata": {"path": str(work)}})
            client.execute()
        except Exception as exc:  # noqa: BLE001 - kept and raised to every test that asks for this notebook
            return exc
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
        nbformat.write(notebook, self.folder / f"{name}.ipynb")
        return notebook


@pytest.fixture(scope="session")
def notebooks(tmp_path_factory, data_home):
    """The example notebooks, each executed at most once in the session (see :class:`NotebookRunner`)."""
    return NotebookRunner(tmp_path_factory.mktemp("notebooks"), data_home)


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

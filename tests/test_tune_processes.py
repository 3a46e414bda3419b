"""tune with real worker processes on a shared storage: kill and resume, two workers on one study.

The storages: an SQLite file, an Optuna journal file, and a real PostgreSQL server
(the ``postgres_url`` fixture of ``conftest.py``, on a Unix socket).
"""

import datetime
import functools
import json
import os
import signal
import socket
import subprocess
import sys
import time

import optuna
import pytest
from optuna.trial import TrialState

from sindybench.model_selection._storage import make_storage

# A worker: a cheap ARX whose fit sleeps ``delay`` seconds (a tuned float, so that
# every trial has distinct parameters). It prints "ready" once imported, then waits
# for the go file, so that two workers start their studies together.
WORKER = """
import sys, time, pathlib
import numpy as np
from sindybench.baselines import ARX
from sindybench.model_selection import IntRange, Uniform, tune


class SlowARX(ARX):
    def __init__(self, *, na=2, nb=2, nk=1, fit_intercept=True, delay=0.0):
        super().__init__(na=na, nb=nb, nk=nk, fit_intercept=fit_intercept)
        self.delay = delay

    def fit(self, X, y):
        time.sleep(self.delay)
        return super().fit(X, y)


storage, n_trials, go = sys.argv[1], int(sys.argv[2]), pathlib.Path(sys.argv[3])
rng = np.random.default_rng(0)
u = rng.standard_normal((300, 1))
y = np.zeros((300, 1))
for t in range(2, 300):
    y[t] = 1.5 * y[t - 1] - 0.7 * y[t - 2] + u[t - 1]
print("ready", flush=True)
while not go.exists():
    time.sleep(0.01)
space = {"na": IntRange(1, 4), "nb": IntRange(1, 3), "delay": Uniform(0.25, 0.3)}
tune(SlowARX(), space, u, y, n_trials=n_trials, storage=storage, study_name="shared", random_state=0)
print("done", flush=True)
"""

STORAGES = {
    "sqlite": lambda request, d: f"sqlite:///{d / 'study.db'}",
    "journal": lambda request, d: f"journal://{d / 'study.log'}",
    "postgresql": lambda request, d: request.getfixturevalue("postgres_url"),
}


def _kinds(*default):
    """Each test runs on the ``default`` storages, and on all of them with --runslow (process start-up is slow)."""
    return [kind if kind in default else pytest.param(kind, marks=pytest.mark.slow) for kind in sorted(STORAGES)]


def _start(script, storage, n_trials, go):
    proc = subprocess.Popen(
        [sys.executable, str(script), storage, str(n_trials), str(go)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout.readline().strip() == "ready", proc.stderr.read()
    return proc


def _finish(proc):
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert "done" in out


@functools.lru_cache(maxsize=None)
def _open(storage):
    return make_storage(storage)  # one connection pool per database for all the polls of a test


def _trials(storage):
    try:
        return optuna.load_study(study_name="shared", storage=_open(storage)).get_trials(deepcopy=False)
    except KeyError:  # the worker has not created the study yet
        return []


@pytest.fixture
def worker(tmp_path):
    script = tmp_path / "worker.py"
    script.write_text(WORKER)
    return script


@pytest.mark.parametrize("kind", _kinds("journal", "postgresql"))
def test_killed_worker_resumes_without_losing_finished_trials(kind, worker, tmp_path, request):
    """Two workers share a study; one is killed with SIGKILL in the middle of a trial and run again.

    The trial in flight at the kill is left RUNNING by the dead process; the first
    worker on this host to look (the survivor after its next trial, or the rerun when
    it starts) sees that its process is gone and marks it FAIL, which gives its place
    in the budget back. Together the survivor and the rerun finish the budget: exactly
    ``n_trials`` finished trials, every trial finished before the kill kept as it was.
    """
    storage, n_trials, go = STORAGES[kind](request, tmp_path), 16, tmp_path / "go"
    victim, survivor = (_start(worker, storage, n_trials, go) for _ in range(2))
    go.touch()
    deadline = time.monotonic() + 30
    # kill while a trial of the victim is fitting (its "params" are recorded), after a few have finished;
    # a kill in the middle of a journal write would leave the file lock for its 30 s grace period. The
    # trial must have started less than 0.1 s before the poll returned (its fit sleeps 0.25-0.3 s): a trial
    # that a slow poll still shows RUNNING may have ended before the kill, which then hits the next trial
    # before sindybench has tagged it with its worker
    victim_id = f"{socket.gethostname()}:{victim.pid}"
    while True:
        assert time.monotonic() < deadline and victim.poll() is None, "the worker ended before it could be killed"
        trials = _trials(storage)
        now = datetime.datetime.now()  # Optuna stamps trials with the local naive time
        complete = [t for t in trials if t.state == TrialState.COMPLETE]
        mine = [t for t in trials if t.user_attrs.get("worker") == victim_id]
        if len(complete) >= 4 and any(t.state == TrialState.COMPLETE for t in mine) and any(
            t.state == TrialState.RUNNING and "params" in t.user_attrs
            and (now - t.datetime_start).total_seconds() < 0.1 for t in mine
        ):
            break
        time.sleep(0.01)
    os.kill(victim.pid, signal.SIGKILL)
    victim.wait()
    before = {t.number: (t.params, t.value) for t in _trials(storage) if t.state == TrialState.COMPLETE}
    assert 4 <= len(before) < n_trials

    rerun = _start(worker, storage, n_trials, go)
    _finish(survivor)
    _finish(rerun)
    trials = _trials(storage)
    after = {t.number: (t.params, t.value) for t in trials if t.state == TrialState.COMPLETE}
    assert len(after) == n_trials
    assert {n: after[n] for n in before} == before
    # the trial the kill interrupted is FAIL (its place was run again), not left RUNNING
    states = [t.state for t in trials]
    assert states.count(TrialState.RUNNING) == 0
    killed = [t for t in trials if t.state == TrialState.FAIL and t.user_attrs["worker"] == victim_id]
    assert len(killed) == 1 and "params" in killed[0].user_attrs
    # any other FAIL trial is one that stood down because the budget was full, never a lost evaluation
    assert all("budget" in t.user_attrs.get("fail_reason", "") for t in trials if t.state == TrialState.FAIL
               and t.number != killed[0].number)
    assert {victim_id, f"{socket.gethostname()}:{survivor.pid}"} <= {t.user_attrs["worker"] for t in trials
                                                                      if t.state == TrialState.COMPLETE}


@pytest.mark.parametrize("kind", _kinds("sqlite"))
def test_two_workers_share_one_study(kind, worker, tmp_path, request):
    storage, n_trials, go = STORAGES[kind](request, tmp_path), 16, tmp_path / "go"
    procs = [_start(worker, storage, n_trials, go) for _ in range(2)]
    go.touch()
    for proc in procs:
        _finish(proc)
    trials = _trials(storage)
    # the shared budget is exact: a trial another worker runs holds its place
    complete = [t for t in trials if t.state == TrialState.COMPLETE]
    assert len(complete) == n_trials
    assert all("budget" in t.user_attrs["fail_reason"] for t in trials if t.state != TrialState.COMPLETE)
    trials = complete
    per_worker = {}
    for t in trials:
        per_worker.setdefault(t.user_attrs["worker"], []).append(t.number)
    assert len(per_worker) == 2 and all(len(numbers) >= 2 for numbers in per_worker.values())
    assert sum(len(numbers) for numbers in per_worker.values()) == len(trials)
    assert len({t.number for t in trials}) == len(trials)
    # same random_state in both workers, yet no point is evaluated twice
    points = {json.dumps(t.params, sort_keys=True) for t in trials}
    assert len(points) == len(trials)


def test_lost_database_mid_study_is_a_clear_error_and_the_study_resumes(tmp_path):
    """The quick version of the next test: an SQLite storage whose connection fails in the third trial."""
    import numpy as np
    from sqlalchemy.exc import OperationalError

    from sindybench.baselines import ARX
    from sindybench.model_selection import IntRange, tune

    rng = np.random.default_rng(0)
    u = rng.standard_normal((200, 1))
    y = 0.1 * np.cumsum(u, axis=0)
    space = {"na": IntRange(1, 4), "nb": IntRange(1, 3)}
    storage = make_storage(f"sqlite:///{tmp_path / 'study.db'}")
    real, calls = storage.set_trial_user_attr, []

    def failing(trial_id, key, value):
        if key == "params":
            calls.append(trial_id)
        if len(calls) == 3:
            orig = Exception("server closed the connection unexpectedly")
            error = OperationalError("UPDATE trial_user_attributes", {}, orig)
            raise optuna.exceptions.StorageInternalError("An exception is raised during the commit.") from error
        return real(trial_id, key, value)

    storage.set_trial_user_attr = failing
    with pytest.raises(ConnectionError, match=r"storage 'RDBStorage': the database stopped answering during the "
                                              r"study \(OperationalError: server closed.*run the same call again"):
        tune(ARX(), space, u, y, n_trials=5, storage=storage, study_name="s", random_state=0)
    storage.set_trial_user_attr = real
    _, study = tune(ARX(), space, u, y, n_trials=5, storage=storage, study_name="s", random_state=0)
    states = [t.state for t in study.trials]
    assert states[:2] == [TrialState.COMPLETE] * 2 and states[2] == TrialState.FAIL
    assert states.count(TrialState.COMPLETE) == 5 and TrialState.RUNNING not in states


@pytest.mark.slow
def test_postgresql_server_stopped_mid_study_is_a_clear_error_and_the_study_resumes():
    """Issue 18, case 14: the worker died of Optuna's StorageInternalError and an UnboundLocalError traceback.

    A server of its own (the session's is shared with other tests) is stopped in the
    middle of the third fit, then started again: ``tune`` raises a ``ConnectionError``
    saying what happened and what to do, and the same call then resumes the study
    with the two finished trials kept and the interrupted one marked FAIL.
    """
    import numpy as np

    import _postgres
    from sindybench.baselines import ARX
    from sindybench.model_selection import IntRange, tune

    bindir = _postgres.find_bindir()
    if bindir is None:
        pytest.skip("no PostgreSQL server binaries")
    user = _postgres._server_user()
    rng = np.random.default_rng(0)
    u = rng.standard_normal((200, 1))
    y = 0.1 * np.cumsum(u, axis=0)
    space = {"na": IntRange(1, 4), "nb": IntRange(1, 3)}
    with _postgres.postgres_server(bindir) as (sockets, superuser):
        url = _postgres.url(sockets, superuser, _postgres.create_database(bindir, sockets, superuser))
        data = os.path.join(os.path.dirname(sockets), "data")
        fits = []

        class StoppingARX(ARX):
            def fit(self, X, y):
                fits.append(1)
                if len(fits) == 3:
                    _postgres._run([f"{bindir}/pg_ctl", "-D", data, "-m", "immediate", "-w", "stop"], user)
                return super().fit(X, y)

        with pytest.raises(ConnectionError, match=r"(?s)storage 'postgresql\+psycopg://.*stopped answering during "
                                                  r"the study.*finished trials are kept.*run the same call again"):
            tune(StoppingARX(), space, u, y, n_trials=5, storage=url, study_name="s", random_state=0)
        options = f"-k {sockets} -p {_postgres._PORT} -c listen_addresses='' -c fsync=off"
        _postgres._run([f"{bindir}/pg_ctl", "-D", data, "-l", os.path.join(os.path.dirname(sockets), "restart.log"),
                        "-w", "-o", options, "start"], user)
        _, study = tune(StoppingARX(), space, u, y, n_trials=5, storage=url, study_name="s", random_state=0)
        states = [t.state for t in study.trials]
        assert states[:2] == [TrialState.COMPLETE] * 2 and states[2] == TrialState.FAIL
        assert states.count(TrialState.COMPLETE) == 5 and TrialState.RUNNING not in states

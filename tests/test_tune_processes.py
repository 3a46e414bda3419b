"""tune with a file storage and real worker processes: kill and resume, two workers on one study."""

import json
import os
import signal
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
space = {"na": IntRange(1, 4), "nb": IntRange(1, 3), "delay": Uniform(0.08, 0.12)}
tune(SlowARX(), space, u, y, n_trials=n_trials, storage=storage, study_name="shared", random_state=0)
print("done", flush=True)
"""

STORAGES = {"sqlite": lambda d: f"sqlite:///{d / 'study.db'}", "journal": lambda d: f"journal://{d / 'study.log'}"}


def _kinds(default):
    """Each test runs on one storage by default and on both with --runslow (process start-up is slow)."""
    return [kind if kind == default else pytest.param(kind, marks=pytest.mark.slow) for kind in sorted(STORAGES)]


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
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert "done" in out


def _trials(storage):
    try:
        return optuna.load_study(study_name="shared", storage=make_storage(storage)).get_trials(deepcopy=False)
    except KeyError:  # the worker has not created the study yet
        return []


@pytest.fixture
def worker(tmp_path):
    script = tmp_path / "worker.py"
    script.write_text(WORKER)
    return script


@pytest.mark.parametrize("kind", _kinds("journal"))
def test_killed_worker_resumes_without_losing_finished_trials(kind, worker, tmp_path):
    storage, n_trials, go = STORAGES[kind](tmp_path), 12, tmp_path / "go"
    go.touch()
    proc = _start(worker, storage, n_trials, go)
    deadline = time.monotonic() + 60
    # kill while a trial is fitting (its "params" are recorded), after a few have finished; a kill
    # in the middle of a journal write would leave the file lock for its 30 s grace period
    while True:
        assert time.monotonic() < deadline and proc.poll() is None, "the worker ended before it could be killed"
        trials = _trials(storage)
        complete = [t for t in trials if t.state == TrialState.COMPLETE]
        if len(complete) >= 4 and any(t.state == TrialState.RUNNING and "params" in t.user_attrs for t in trials):
            break
        time.sleep(0.1)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    before = {t.number: (t.params, t.value) for t in _trials(storage) if t.state == TrialState.COMPLETE}
    assert 4 <= len(before) < n_trials

    _finish(_start(worker, storage, n_trials, go))
    trials = _trials(storage)
    after = {t.number: (t.params, t.value) for t in trials if t.state == TrialState.COMPLETE}
    assert len(after) == n_trials
    assert {n: after[n] for n in before} == before
    # the trial the kill interrupted was marked FAIL on resume, not left RUNNING
    assert [t.state for t in trials].count(TrialState.RUNNING) == 0
    assert [t.state for t in trials].count(TrialState.FAIL) <= 1
    assert len(trials) <= n_trials + 1
    assert len({t.user_attrs["worker"] for t in trials if t.state == TrialState.COMPLETE}) == 2


@pytest.mark.parametrize("kind", _kinds("sqlite"))
def test_two_workers_share_one_study(kind, worker, tmp_path):
    storage, n_trials, go = STORAGES[kind](tmp_path), 16, tmp_path / "go"
    procs = [_start(worker, storage, n_trials, go) for _ in range(2)]
    go.touch()
    for proc in procs:
        _finish(proc)
    trials = _trials(storage)
    assert all(t.state == TrialState.COMPLETE for t in trials)
    # the shared budget: each worker may finish the trial it runs when it is reached
    assert n_trials <= len(trials) <= n_trials + 1
    per_worker = {}
    for t in trials:
        per_worker.setdefault(t.user_attrs["worker"], []).append(t.number)
    assert len(per_worker) == 2 and all(len(numbers) >= 2 for numbers in per_worker.values())
    assert sum(len(numbers) for numbers in per_worker.values()) == len(trials)
    assert len({t.number for t in trials}) == len(trials)
    # same random_state in both workers, yet no point is evaluated twice
    points = {json.dumps(t.params, sort_keys=True) for t in trials}
    assert len(points) == len(trials)

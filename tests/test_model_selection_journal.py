"""A journal-file study survives a write cut short: a torn last record, a full disk (issue 30, item 1)."""

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import optuna
import pytest
from optuna.trial import TrialState

import sindybench
from sindybench.baselines import ARX
from sindybench.model_selection import IntRange, tune
from sindybench.model_selection import _storage
from sindybench.model_selection._storage import make_storage, mend_journal_tail

SPACE = {"na": IntRange(1, 4), "nb": IntRange(1, 3)}


@pytest.fixture(scope="module")
def record():
    rng = np.random.default_rng(1)
    u = rng.standard_normal((200, 1))
    return u, np.cumsum(u, axis=0)[:, :1] * 0.1


@pytest.fixture(scope="module")
def journal(record, tmp_path_factory):
    """A study of 3 finished trials whose last line is the record that finishes the third."""
    path = tmp_path_factory.mktemp("journal") / "study.log"
    tune(ARX(), SPACE, *record, n_trials=3, storage=path, random_state=0)
    lines = path.read_bytes().splitlines(keepends=True)
    last = max(i for i, line in enumerate(lines) if json.loads(line)["op_code"] == 6)  # SET_TRIAL_STATE_VALUES
    return lines[: last + 1]


def _complete(path):
    study = optuna.load_study(study_name="tune-ARX", storage=make_storage(path))
    return sorted(t.number for t in study.trials if t.state == TrialState.COMPLETE)


def test_every_cut_of_the_last_record_is_mended_and_the_study_goes_on(journal, tmp_path):
    body, last = b"".join(journal[:-1]), journal[-1]
    (tmp_path / "body.log").write_bytes(body)
    before, all_three = _complete(tmp_path / "body.log"), [0, 1, 2]
    assert before == [0, 1]
    for cut in range(len(last)):
        path = tmp_path / f"cut{cut}.log"
        path.write_bytes(body + last[:cut])
        # a record cut before its newline is set aside; one that lost only its newline is kept
        expected = all_three if cut == len(last) - 1 else before
        assert _complete(path) == expected, cut
        assert path.read_bytes() in (body, body + last)
        study = optuna.load_study(study_name="tune-ARX", storage=make_storage(path))
        trial = study.ask()
        study.tell(trial, 1.0)  # the next write lands on a line of its own: the study reloads
        assert _complete(path) == expected + [trial.number], cut
        if 0 < cut < len(last) - 1:
            assert (tmp_path / f"cut{cut}.log.torn").read_bytes() == last[:cut] + b"\n"


@pytest.mark.parametrize("where", [1, 0.5, -2])
def test_resume_after_a_torn_record_finishes_the_budget(journal, record, tmp_path, where):
    body, last = b"".join(journal[:-1]), journal[-1]
    cut = where if where >= 1 else int(len(last) * where) if where > 0 else len(last) + where
    path = tmp_path / "study.log"
    path.write_bytes(body + last[:cut])
    _, study = tune(ARX(), SPACE, *record, n_trials=5, storage=path, random_state=0)
    states = [t.state for t in study.trials]
    assert states.count(TrialState.COMPLETE) == 5
    lines = path.read_bytes().splitlines()
    assert all(json.loads(line)["op_code"] is not None for line in lines)


def test_a_torn_record_that_cannot_be_set_aside_is_a_clear_error(tmp_path):
    path = tmp_path / "study.log"
    path.write_bytes(b'{"op_code":0,"worker_id":"w","study_name":"s","directions":[1]}\n{"op_co')
    (tmp_path / "study.log.torn").mkdir()  # what a full disk does to the side file: it cannot be written
    with pytest.raises(OSError, match=r"ends in a torn record \(7 bytes .*could not be set aside"):
        mend_journal_tail(str(path))
    assert path.read_bytes().endswith(b'{"op_co')  # nothing cut that was not set aside


FULL_DISK = textwrap.dedent("""
    import json, resource, signal, sys
    import numpy as np
    from sindybench.baselines import ARX
    from sindybench.model_selection import IntRange, tune

    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG, as on a full disk
    path, n_trials = sys.argv[1], int(sys.argv[2])
    rng = np.random.default_rng(1)
    u = rng.standard_normal((200, 1))
    y = np.cumsum(u, axis=0)[:, :1] * 0.1
    space = {"na": IntRange(1, 4), "nb": IntRange(1, 3)}
    errors = []
    for step in (700, 1500, 2900, 333, 1111):
        size = len(open(path, "rb").read()) if step != 700 else 0
        resource.setrlimit(resource.RLIMIT_FSIZE, (size + step, resource.RLIM_INFINITY))
        try:
            tune(ARX(), space, u, y, n_trials=n_trials, storage=path, random_state=0)
            errors.append(None)
        except OSError as exc:
            errors.append(str(exc))
        resource.setrlimit(resource.RLIMIT_FSIZE, (resource.RLIM_INFINITY, resource.RLIM_INFINITY))
        text = open(path, "rb").read()
        lines = text.splitlines()
        assert text.endswith(b"\\n") and all("op_code" in json.loads(line) for line in lines), step
    print(json.dumps(errors))
""")


def test_a_full_disk_never_loses_a_finished_trial(record, tmp_path, monkeypatch):
    path = tmp_path / "study.log"
    script = tmp_path / "full_disk.py"
    script.write_text(FULL_DISK)
    env = {**os.environ, "PYTHONPATH": os.path.dirname(os.path.dirname(sindybench.__file__))}  # this copy
    done = subprocess.run([sys.executable, str(script), str(path), "12"], capture_output=True, text=True,
                          timeout=300, env=env)
    assert done.returncode == 0, done.stderr[-3000:]
    errors = json.loads(done.stdout.strip().splitlines()[-1])
    assert sum(e is not None for e in errors) >= 4, errors  # the limits were hit, again and again
    assert all("the record was taken back and the finished trials are kept" in e for e in errors if e)
    # a trial whose worker could not even write its name is an orphan after a grace period: skip the wait
    monkeypatch.setattr(_storage, "UNTAGGED_GRACE", 0)
    _, study = tune(ARX(), SPACE, *record, n_trials=12, storage=path, random_state=0)
    assert TrialState.RUNNING not in [t.state for t in study.trials]
    assert [t.state for t in study.trials].count(TrialState.COMPLETE) == 12

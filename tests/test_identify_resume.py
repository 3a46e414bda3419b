"""``IdentifyCV(storage=..., study_name=...)``: every candidate a trial of an Optuna study; a stopped search resumes."""

import importlib

import numpy as np
import optuna
import pytest
from optuna.storages import JournalStorage
from optuna.storages.journal import JournalFileBackend

from sindybench.identify import IdentifyCV
from sindybench.simulate import simulate

# sindybench.identify is also the function: the module by its full name
stages_module = importlib.import_module("sindybench.identify._stages")
DT = 0.01
SEARCH = dict(dt=DT, families=["first_order", "order2"], libraries=["linear"], derivatives=["finite_difference"],
              n_refine=1, max_path=4, show_progress_bar=False)


@pytest.fixture(scope="module")
def record():
    rng = np.random.default_rng(3)
    t = np.arange(1500) * DT
    u = (np.sin(2 * np.pi * 0.4 * t) + np.sin(2 * np.pi * 1.1 * t + 1.0))[:, None]
    x = simulate(lambda x, u: np.array([x[1], -4.0 * x[0] - 0.4 * x[1] + 2.0 * u[0]]), [0.0, 0.0], u, dt=DT,
                 n_substeps=4, input_hold="linear")
    return u, x[:, :1] + 1e-4 * rng.standard_normal((1500, 1))


@pytest.fixture(scope="module")
def uninterrupted(record):
    return IdentifyCV(**SEARCH).fit(*record)


def _same_table(a, b):
    assert a.keys() == b.keys()
    for k in a:
        if k != "fit_time":  # the only column that depends on the run (a read-back row keeps its first time)
            assert [str(v) for v in a[k]] == [str(v) for v in b[k]], k  # str: NaN equals NaN, every digit kept


def _stop_after(monkeypatch, n):
    """Make the search stop (KeyboardInterrupt) at its ``n+1``-th candidate evaluation."""
    calls, real = [0], stages_module.evaluate

    def evaluate(*args, **kwargs):
        calls[0] += 1
        if calls[0] > n:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(stages_module, "evaluate", evaluate)


@pytest.mark.parametrize("storage", ["search.log", "sqlite:///search.db"])
def test_an_interrupted_search_resumes_to_the_same_result(record, uninterrupted, tmp_path, monkeypatch, storage):
    monkeypatch.chdir(tmp_path)
    with monkeypatch.context() as m:
        _stop_after(m, 5)
        with pytest.raises(KeyboardInterrupt):
            IdentifyCV(storage=storage, **SEARCH).fit(*record)
    resumed = IdentifyCV(storage=storage, **SEARCH).fit(*record)
    assert 0 < resumed.n_resumed_ < len(resumed.cv_results_["family"])
    _same_table(resumed.cv_results_, uninterrupted.cv_results_)
    assert resumed.best_params_ == uninterrupted.best_params_
    np.testing.assert_array_equal(resumed.best_estimator_.coef_, uninterrupted.best_estimator_.coef_)
    # a third fit reads every candidate back and evaluates none
    with monkeypatch.context() as m:
        _stop_after(m, 0)
        again = IdentifyCV(storage=storage, **SEARCH).fit(*record)
    assert again.n_resumed_ == len(again.cv_results_["family"])
    _same_table(again.cv_results_, uninterrupted.cv_results_)


def test_a_candidate_budget_then_the_full_search(record, uninterrupted, tmp_path):
    storage = f"sqlite:///{tmp_path / 'search.db'}"
    first = IdentifyCV(storage=storage, study_name="osc", max_candidates=20, **SEARCH).fit(*record)
    assert len(first.cv_results_["family"]) < len(uninterrupted.cv_results_["family"])
    full = IdentifyCV(storage=storage, study_name="osc", **SEARCH).fit(*record)
    _same_table(full.cv_results_, uninterrupted.cv_results_)
    study = optuna.load_study(study_name="osc", storage=storage)
    trials = study.get_trials(deepcopy=False)
    # one trial per candidate evaluated by either run (the budget also shortened the first run's paths), none twice
    assert len({t.user_attrs["key"] for t in trials}) == len(trials) >= len(full.cv_results_["family"])
    attrs = trials[0].user_attrs
    assert {"family", "library", "derivative", "stage", "errors", "n_terms", "fit_time", "status"} <= set(attrs)
    assert set(trials[0].params) == {"threshold", "input_delay"}


def test_a_study_of_other_data_or_settings_is_refused_and_kept(record, tmp_path):
    u, y = record
    storage = str(tmp_path / "search.log")
    IdentifyCV(storage=storage, max_candidates=6, **SEARCH).fit(u, y)
    before = optuna.load_study(study_name="identify", storage=JournalStorage(JournalFileBackend(storage)))
    with pytest.raises(ValueError, match="was made on other data .* Pass another study_name"):
        IdentifyCV(storage=storage, **SEARCH).fit(u, 2.0 * y)
    with pytest.raises(ValueError, match=r"was made with other settings \(n_blocks=3; got n_blocks=2\)"):
        IdentifyCV(storage=storage, n_blocks=2, **SEARCH).fit(u, y)
    after = optuna.load_study(study_name="identify", storage=JournalStorage(JournalFileBackend(storage)))
    assert len(after.trials) == len(before.trials) and after.user_attrs == before.user_attrs  # left as it is
    other = IdentifyCV(storage=storage, study_name="other", max_candidates=6, **SEARCH).fit(u, 2.0 * y)
    assert other.n_resumed_ == 0


def test_a_study_not_made_by_identify_is_refused(record, tmp_path):
    from sindybench import SINDy
    from sindybench.model_selection import Uniform, tune

    storage = f"sqlite:///{tmp_path / 'studies.db'}"
    u, y = record
    tune(SINDy(dt=DT), {"optimizer__threshold": Uniform(0.0, 0.1)}, u, y, n_trials=2, storage=storage,
         study_name="mine", show_progress_bar=False)
    with pytest.raises(ValueError, match="'mine' .* was not made by identify .*2 trials"):
        IdentifyCV(storage=storage, study_name="mine", **SEARCH).fit(u, y)
    assert len(optuna.load_study(study_name="mine", storage=storage).trials) == 2


@pytest.mark.parametrize("kwargs, match", [
    ({"storage": "study.csv"}, "is not understood"),
    ({"storage": "no_such_folder/s.log"}, "does not exist"),
    ({"study_name": 3}, "study_name must be None or a str"),
])
def test_bad_storage_arguments(record, kwargs, match):
    with pytest.raises(ValueError, match=match):
        IdentifyCV(**dict(SEARCH, **kwargs)).fit(*record)



@pytest.mark.slow
def test_worker_processes_resume_too(record, uninterrupted, tmp_path, monkeypatch):
    """With ``n_jobs=2`` the store stays in the search's process (slow: each worker compiles the kernels)."""
    storage = str(tmp_path / "search.log")
    first = IdentifyCV(storage=storage, n_jobs=2, max_candidates=20, **SEARCH).fit(*record)
    full = IdentifyCV(storage=storage, n_jobs=2, **SEARCH).fit(*record)
    assert first.n_resumed_ == 0 and full.n_resumed_ > 0
    _same_table(full.cv_results_, uninterrupted.cv_results_)


def test_searches_inside_shared_candidates_reuse_each_others_candidates_bit_for_bit(record, uninterrupted):
    # the equations-only search after the one with the lag family (run all's two identify rows): it computes only
    # the candidates the first did not, and returns what a search of its own returns
    from sindybench.identify._resume import CandidateStore, shared_candidates

    with_lag = dict(SEARCH, families=SEARCH["families"] + ["lag"])
    with shared_candidates():
        first = IdentifyCV(**with_lag).fit(*record)
        equations = IdentifyCV(**SEARCH).fit(*record)
    assert "lag" in first.cv_results_["family"]
    assert equations.n_resumed_ > 0 and "lag" not in equations.cv_results_["family"]
    _same_table(equations.cv_results_, uninterrupted.cv_results_)
    assert equations.best_params_ == uninterrupted.best_params_
    np.testing.assert_array_equal(equations.best_estimator_.coef_, uninterrupted.best_estimator_.coef_)
    np.testing.assert_array_equal(equations.predict(record[0][:300], y_init=record[1][:5]),
                                  uninterrupted.predict(record[0][:300], y_init=record[1][:5]))
    # outside a block a search reads nothing back, and the block's candidates are gone when it ends
    assert uninterrupted.n_resumed_ == 0
    with shared_candidates():
        store = CandidateStore(None, None, {"data": "x"})
        assert store.get("k") is None and store.put("k", {"errors": [1.0]}) is None and store.get("k") is not None
    assert CandidateStore(None, None, {"data": "x"}).get("k") is None

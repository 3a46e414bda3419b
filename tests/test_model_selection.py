"""HoldoutSplit, search spaces and tune; scikit-learn and Optuna searches scored by simulation."""

import math
import subprocess
import sys
import warnings

import numpy as np
import optuna
import pytest
from optuna.trial import TrialState
from scipy.special import ndtr
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.model_selection import GridSearchCV, RandomizedSearchCV, TimeSeriesSplit, cross_val_score

from sindybench import STLS, HiddenStateSINDy, SimulationError, SINDy
from sindybench.baselines import ARX
from sindybench.hidden import DerivativeHiddenState
from sindybench.libraries import PolynomialLibrary
from sindybench.metrics import make_simulation_scorer, rmse
from sindybench.model_selection import (
    AllTrialsFailedError,
    Categorical,
    HoldoutSplit,
    IntRange,
    LogNormal,
    LogUniform,
    Normal,
    Uniform,
    check_storage,
    tune,
)
from sindybench.search import check_search_space
from sindybench.model_selection._storage import make_storage, tag_trial, worker_id
from sindybench.simulate import simulate

optuna.logging.set_verbosity(optuna.logging.WARNING)
SCORER = make_simulation_scorer("rmse")
SPLITTERS = [HoldoutSplit(validation_size=100), TimeSeriesSplit(n_splits=3)]
ARX_SPACE = {"na": IntRange(1, 4), "nb": IntRange(1, 3)}


@pytest.fixture(scope="module")
def arx_data():
    """A second-order ARX system with a little output noise (400 samples)."""
    rng = np.random.default_rng(1)
    u = rng.standard_normal((400, 1))
    y = np.zeros((400, 1))
    for t in range(2, 400):
        y[t] = 1.5 * y[t - 1] - 0.7 * y[t - 2] + u[t - 1]
    return u, y + 0.01 * rng.standard_normal(y.shape)


@pytest.fixture(scope="module")
def sindy_data():
    """x' = -x + 2u - 0.3 x^3, sampled at 0.05 s (600 samples)."""
    t = np.arange(600) * 0.05
    u = (np.sin(0.7 * t) + np.sin(1.9 * t + 1) + 0.5 * np.sin(3.1 * t))[:, None]
    y = simulate(lambda x, v: -x + 2 * v - 0.3 * x**3, [0.0], u, 0.05, n_substeps=4, input_hold="linear")
    return u, y


def _sindy():
    return SINDy(library=PolynomialLibrary(degree=3), optimizer=STLS(threshold=0.05), dt=0.05, input_hold="linear")


def _holdout_rmse(model, u, y, n_val):
    model.fit(u[:-n_val], y[:-n_val])
    return rmse(y[-n_val:], model.predict(u[-n_val:], y_init=y[-n_val:]))


# --- HoldoutSplit ---------------------------------------------------------------------------------


@pytest.mark.parametrize("size, n_val", [(3, 3), (0.25, 3), (0.2, 2), (0.01, 1), (9, 9)])
def test_holdout_split_keeps_the_last_block(size, n_val):
    splitter = HoldoutSplit(validation_size=size)
    (train, val), *rest = list(splitter.split(np.zeros((10, 2))))
    assert rest == [] and splitter.get_n_splits() == 1
    np.testing.assert_array_equal(train, np.arange(10 - n_val))
    np.testing.assert_array_equal(val, np.arange(10 - n_val, 10))


@pytest.mark.parametrize(
    "size, match",
    [(0, r"validation_size=0 samples"), (10, r"expected an int in \[1, 9\]"), (1.0, "int >= 1"), (-0.5, "float in"),
     ("big", "got 'big'"), (True, "got True"), (0.95, "leaves no training data")],
)
def test_holdout_split_rejects_bad_sizes(size, match):
    with pytest.raises(ValueError, match=match):
        next(HoldoutSplit(validation_size=size).split(np.zeros((10, 1))))


# --- scikit-learn and Optuna searches, unchanged ----------------------------------------------------


@pytest.mark.parametrize("cv", SPLITTERS, ids=["holdout", "timeseries"])
def test_grid_and_randomized_search_choose_the_true_order(arx_data, cv):
    u, y = arx_data
    grid = GridSearchCV(ARX(nb=1), {"na": [1, 2]}, cv=cv, scoring=SCORER).fit(u, y)
    assert grid.best_params_ == {"na": 2}
    expected = np.mean([SCORER(ARX(na=2, nb=1).fit(u[tr], y[tr]), u[te], y[te]) for tr, te in cv.split(u)])
    assert grid.best_score_ == pytest.approx(expected)
    assert grid.best_score_ > -0.05 > grid.cv_results_["mean_test_score"][0]
    rand = RandomizedSearchCV(ARX(), {"na": [1, 2], "nb": [1, 2]}, n_iter=4, cv=cv, scoring=SCORER, random_state=0)
    assert rand.fit(u, y).best_params_["na"] == 2


@pytest.mark.parametrize("cv", SPLITTERS, ids=["holdout", "timeseries"])
def test_cross_val_score(arx_data, cv):
    u, y = arx_data
    scores = cross_val_score(ARX(na=2, nb=1), u, y, cv=cv, scoring=SCORER)
    assert len(scores) == cv.get_n_splits() and np.all(-0.05 < scores) and np.all(scores < 0)
    assert np.all(cross_val_score(ARX(na=1, nb=1), u, y, cv=cv, scoring=SCORER) < scores)


@pytest.mark.parametrize("cv", SPLITTERS, ids=["holdout", "timeseries"])
def test_optuna_search_cv(arx_data, cv):
    optuna_integration = pytest.importorskip("optuna_integration")
    u, y = arx_data
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # experimental-API and terminator warnings of optuna-integration
        search = optuna_integration.OptunaSearchCV(
            ARX(nb=1), {"na": optuna.distributions.IntDistribution(1, 3)}, cv=cv, scoring=SCORER, n_trials=6,
            random_state=0,
        ).fit(u, y)
    assert search.best_params_["na"] >= 2 and search.best_score_ > -0.05


@pytest.mark.parametrize("cv", SPLITTERS, ids=["holdout", "timeseries"])
def test_searches_over_sindy_threshold(sindy_data, cv):
    u, y = sindy_data
    grid = GridSearchCV(_sindy(), {"optimizer__threshold": [0.05, 3.0]}, cv=cv, scoring=SCORER).fit(u, y)
    assert grid.best_params_ == {"optimizer__threshold": 0.05}
    assert grid.cv_results_["mean_test_score"][0] > -0.01 > grid.cv_results_["mean_test_score"][1]
    assert np.all(cross_val_score(_sindy(), u, y, cv=cv, scoring=SCORER) > -0.01)
    best, study = tune(_sindy(), {"optimizer__threshold": LogUniform(1e-3, 10.0)}, u, y, cv=cv, n_trials=8,
                       random_state=0)
    assert best.optimizer.threshold < 1.0 and study.best_value < 0.01


def test_sindy_randomized_and_optuna_search(sindy_data):
    optuna_integration = pytest.importorskip("optuna_integration")
    u, y = sindy_data
    cv = HoldoutSplit(validation_size=150)
    rand = RandomizedSearchCV(_sindy(), {"optimizer__threshold": [0.01, 0.05, 3.0, 5.0]}, n_iter=3, cv=cv,
                              scoring=SCORER, random_state=0).fit(u, y)
    assert rand.best_params_["optimizer__threshold"] < 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        search = optuna_integration.OptunaSearchCV(
            _sindy(), {"optimizer__threshold": optuna.distributions.FloatDistribution(1e-3, 10.0, log=True)}, cv=cv,
            scoring=SCORER, n_trials=6, random_state=0,
        ).fit(u, y)
    assert search.best_score_ > -0.01


def test_one_optuna_space_serves_tune_and_optuna_search_cv(sindy_data):
    """Optuna's distributions in tune: the very dict OptunaSearchCV takes, on a default-constructed SINDy."""
    optuna_integration = pytest.importorskip("optuna_integration")
    u, y = sindy_data
    space = {
        "optimizer__threshold": optuna.distributions.FloatDistribution(1e-3, 10.0, log=True),
        "library__degree": optuna.distributions.IntDistribution(1, 3),
        "input_hold": optuna.distributions.CategoricalDistribution(["zoh", "linear"]),
    }
    cv = HoldoutSplit(validation_size=150)
    best, study = tune(SINDy(dt=0.05), space, u, y, cv=cv, n_trials=12, random_state=0)
    assert set(study.best_trial.params) == set(space)
    assert best.library.degree == 3 and best.optimizer.threshold < 1.0 and study.best_value < 0.01
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        search = optuna_integration.OptunaSearchCV(SINDy(dt=0.05), space, cv=cv, scoring=SCORER, n_trials=12,
                                                   random_state=0).fit(u, y)
    assert set(search.best_params_) == set(space) and search.best_score_ > -0.01


@pytest.mark.parametrize("estimator, grid", [
    (SINDy(dt=0.05, input_hold="linear"),
     {"optimizer__threshold": [0.05, 3.0], "library__degree": [3], "differentiation__accuracy": [4]}),
    (HiddenStateSINDy(dt=0.05, input_hold="linear", hidden=DerivativeHiddenState(order=1)),
     {"optimizer__threshold": [0.05, 3.0], "library": [PolynomialLibrary(degree=3)]}),
], ids=["SINDy", "HiddenStateSINDy"])
def test_grid_search_on_default_constructed_estimators(sindy_data, estimator, grid):
    """The default optimizer is a real STLS: optimizer__threshold nests without passing STLS()."""
    u, y = sindy_data
    search = GridSearchCV(estimator, grid, cv=HoldoutSplit(validation_size=150), scoring=SCORER).fit(u, y)
    scores = search.cv_results_["mean_test_score"]
    assert search.best_params_["optimizer__threshold"] == 0.05 and scores[0] > -0.01 > scores[1]
    assert type(estimator)().optimizer.threshold == type(estimator)().get_params()["optimizer__threshold"]


def test_search_space_refuses_other_optuna_objects():
    with pytest.raises(ValueError, match="expected Uniform, .* or optuna's FloatDistribution"):
        check_search_space({"na": optuna.samplers.RandomSampler()})


# --- tune ------------------------------------------------------------------------------------------


def test_tune_finds_the_order_and_refits_on_all_data(arx_data):
    u, y = arx_data
    best, study = tune(ARX(), ARX_SPACE, u, y, n_trials=20, random_state=0)
    assert best.na >= 2 and len(study.trials) == 20
    assert study.direction == optuna.study.StudyDirection.MINIMIZE
    # the value is the validation RMSE of the simulation (default cv: the last 20 %)
    trial = study.best_trial
    assert trial.value == pytest.approx(_holdout_rmse(ARX(**trial.params), u, y, 80))
    assert trial.user_attrs["params"] == trial.params and trial.user_attrs["worker"] == worker_id()
    np.testing.assert_allclose(best.coef_, ARX(**trial.params).fit(u, y).coef_)


def test_tune_without_refit_returns_the_best_unfitted(arx_data):
    u, y = arx_data
    best, study = tune(ARX(), ARX_SPACE, u, y, n_trials=8, random_state=0, refit=False)
    assert best.get_params() == ARX(**study.best_trial.params).get_params()
    assert not hasattr(best, "coef_")


def test_tune_is_reproducible_with_a_seed(arx_data):
    u, y = arx_data
    space = {**ARX_SPACE, "nk": IntRange(0, 2)}
    runs = [tune(ARX(), space, u, y, n_trials=15, random_state=seed)[1] for seed in (3, 3, 4)]
    params = [[t.params for t in study.trials] for study in runs]
    assert params[0] == params[1] != params[2]


def test_tune_scoring_and_cv_options(arx_data):
    u, y = arx_data
    _, study = tune(ARX(nb=1), {"na": IntRange(1, 3)}, u, y, scoring="r2", cv=3, n_trials=4, random_state=0)
    assert study.direction == optuna.study.StudyDirection.MAXIMIZE and 0.99 < study.best_value <= 1.0
    assert all(len(t.user_attrs["split_scores"]) == 3 for t in study.trials)
    scorer = make_simulation_scorer("fit_index", skip=5)
    _, study = tune(ARX(nb=1), {"na": IntRange(1, 3)}, u, y, scoring=scorer, n_trials=4, random_state=0)
    assert study.direction == optuna.study.StudyDirection.MAXIMIZE and 90 < study.best_value < 100


def test_tune_with_threads(arx_data):
    u, y = arx_data
    _, study = tune(ARX(), ARX_SPACE, u, y, n_trials=8, n_jobs=2, random_state=0)
    assert len(study.trials) == 8 and all(t.state == TrialState.COMPLETE for t in study.trials)


def test_search_space_dimensions():
    trial = optuna.trial.FixedTrial({"a": 0.3, "b": 1e-3, "c": 4, "d": "(16, 16)", "e:quantile": ndtr(1.0),
                                     "f:quantile": ndtr(-2.0)})
    assert Uniform(0.0, 1.0).suggest(trial, "a") == 0.3
    assert LogUniform(1e-4, 1.0).suggest(trial, "b") == 1e-3
    assert IntRange(1, 8).suggest(trial, "c") == 4
    assert Categorical([(8,), (16, 16)]).suggest(trial, "d") == (16, 16)
    assert LogNormal(math.log(5e4), 0.5).suggest(trial, "e") == pytest.approx(5e4 * math.exp(0.5))
    assert Normal(1.0, 0.1).suggest(trial, "f") == pytest.approx(0.8)


def test_lognormal_prior_is_followed_by_random_sampling():
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=0))
    prior = LogNormal(math.log(2.0), 0.5, n_sigma=3.0)
    values = []
    for _ in range(2000):
        trial = study.ask()
        values.append(prior.suggest(trial, "k"))
        study.tell(trial, 0.0)
    logs = np.log(values)
    assert abs(np.mean(logs) - math.log(2.0)) < 0.03 and abs(np.std(logs) - 0.5 * 0.986) < 0.03
    assert np.all(np.abs(logs - math.log(2.0)) <= 1.5 + 1e-9)  # truncated at 3 sigma


def test_tune_with_priors_categoricals_and_a_callable_space(arx_data):
    u, y = arx_data
    space = {"na": Categorical([1, 2, 3]), "nb": IntRange(1, 2), "fit_intercept": Categorical([True, False])}
    best, study = tune(ARX(), space, u, y, n_trials=10, random_state=0)
    assert best.na == study.best_trial.params["na"]

    def conditional(trial):
        na = trial.suggest_int("na", 1, 3)
        return {"na": na, "nb": trial.suggest_int("nb", 1, na)}

    best, study = tune(ARX(), conditional, u, y, n_trials=8, random_state=0)
    assert all(t.params["nb"] <= t.params["na"] for t in study.trials)
    assert (best.na, best.nb) == (study.best_trial.params["na"], study.best_trial.params["nb"])


class Fragile(RegressorMixin, BaseEstimator):
    """ARX(na=2, nb=1) that fails on purpose depending on ``mode``."""

    def __init__(self, *, mode="ok", scale=1.0):
        self.mode = mode
        self.scale = scale

    def fit(self, X, y):
        if self.mode == "fit":
            raise np.linalg.LinAlgError("singular matrix on purpose")
        self.arx_ = ARX(na=2, nb=1).fit(X, y)
        return self

    def predict(self, X, *, y_init=None):
        if self.mode == "raise":
            raise SimulationError("simulation diverged at step 7 on purpose", step=7)
        y = self.arx_.predict(X, y_init=y_init) * self.scale
        if self.mode == "nan":
            y[5:] = np.nan
        return y


def test_failed_trials_are_recorded_not_raised(arx_data):
    u, y = arx_data
    space = {"mode": Categorical(["ok", "fit", "raise", "nan"]), "scale": Uniform(0.9, 1.1)}
    best, study = tune(Fragile(), space, u, y, n_trials=24, random_state=0)
    reasons = {t.params["mode"]: t.user_attrs.get("fail_reason") for t in study.trials}
    assert set(reasons) == {"ok", "fit", "raise", "nan"}
    assert reasons["ok"] is None
    assert reasons["fit"] == "fit failed on split 0: LinAlgError: singular matrix on purpose"
    assert reasons["raise"].startswith("simulation failed on split 0: SimulationError: simulation diverged at step 7")
    assert reasons["nan"] == "simulation diverged on split 0 (non-finite prediction, score -inf)"
    for t in study.trials:
        assert t.state == (TrialState.COMPLETE if t.params["mode"] == "ok" else TrialState.PRUNED)
    assert best.mode == "ok" and abs(best.scale - 1.0) < 0.1


def test_all_trials_failing_raises_a_clear_error(arx_data):
    u, y = arx_data
    with pytest.raises(AllTrialsFailedError, match=r"no trial of study .* completed \(3 trials\).*3 x fit failed") as info:
        tune(Fragile(), {"mode": Categorical(["fit"])}, u, y, n_trials=3, random_state=0)
    assert len(info.value.study.trials) == 3


def test_resume_runs_only_the_missing_trials(arx_data, tmp_path):
    u, y = arx_data
    storage = tmp_path / "study.log"
    _, first = tune(ARX(), ARX_SPACE, u, y, n_trials=5, storage=storage, random_state=0)
    assert first.study_name == "tune-ARX" and len(first.trials) == 5
    done = [t.params for t in first.trials]
    _, second = tune(ARX(), ARX_SPACE, u, y, n_trials=8, storage=storage, random_state=0)
    assert len(second.trials) == 8
    assert [t.params for t in second.trials[:5]] == done
    _, third = tune(ARX(), ARX_SPACE, u, y, n_trials=8, storage=f"journal://{storage}", random_state=0)
    assert len(third.trials) == 8


@pytest.mark.filterwarnings("ignore:Heartbeat of storage is supposed to be used with Study.optimize")
def test_resume_fails_trials_of_dead_workers(arx_data, tmp_path):
    u, y = arx_data
    storage = f"sqlite:///{tmp_path / 'study.db'}"
    tune(ARX(), ARX_SPACE, u, y, n_trials=3, storage=storage, study_name="s", random_state=0)
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    study = optuna.load_study(study_name="s", storage=make_storage(storage))
    orphan = study.ask()
    orphan.set_user_attr("worker", f"{worker_id().rpartition(':')[0]}:{int(dead.stdout)}")
    alive = study.ask()
    tag_trial(alive)  # this process: still running
    _, study = tune(ARX(), ARX_SPACE, u, y, n_trials=5, storage=storage, study_name="s", random_state=0)
    states = [t.state for t in study.trials]
    assert states[orphan.number] == TrialState.FAIL and states[alive.number] == TrialState.RUNNING
    # the interrupted trial does not count; the live worker's running trial holds its place in the budget
    assert states.count(TrialState.COMPLETE) == 4


def test_resume_refuses_another_search(arx_data, tmp_path):
    u, y = arx_data
    storage = tmp_path / "study.db"
    tune(ARX(), ARX_SPACE, u, y, n_trials=2, storage=storage, random_state=0)
    with pytest.raises(ValueError, match="made by another call.*pass another study_name"):
        tune(ARX(), {"na": IntRange(1, 9)}, u, y, n_trials=2, storage=storage, random_state=0)
    with pytest.raises(ValueError, match="made by another call"):
        tune(ARX(), ARX_SPACE, u, y, scoring="r2", n_trials=2, storage=storage, random_state=0)


@pytest.mark.parametrize(
    "storage, kind",
    [(None, "InMemoryStorage"), ("x.db", "RDBStorage"), ("x.log", "JournalStorage"),
     ("journal://x.journal", "JournalStorage"), ("sqlite:///x.sqlite", "RDBStorage")],
)
def test_make_storage(storage, kind, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    made = make_storage(storage)
    assert type(made).__name__ == kind and make_storage(made) is made


def test_missing_database_driver_says_what_to_install():
    # pg8000 is not installed: the error names the extra and the URL of the driver that is, and no password
    with pytest.raises(ImportError, match=r"No module named 'pg8000'.*sindybench\[postgres\].*postgresql\+psycopg://") as info:
        make_storage("postgresql+pg8000://optuna:secret@db.example.org/studies")
    assert "secret" not in str(info.value)


def test_postgresql_storage_is_shared_and_persistent(postgres_url, arx_data):
    u, y = arx_data
    _, first = tune(ARX(), ARX_SPACE, u, y, n_trials=3, storage=postgres_url, study_name="s", random_state=0)
    first = [t.params for t in first.trials]
    _, again = tune(ARX(), ARX_SPACE, u, y, n_trials=5, storage=postgres_url, study_name="s", random_state=0)
    assert make_storage(postgres_url).engine.dialect.name == "postgresql"
    # the second call ran only the two missing trials, on top of the first call's three
    assert [t.number for t in again.trials] == [0, 1, 2, 3, 4]
    assert [t.params for t in again.trials[:3]] == first


def test_check_storage_opens_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for storage in ("x.db", "sqlite:///x.sqlite", "x.log", "journal://x.journal", "postgresql://u@127.0.0.1:1/db"):
        assert check_storage(storage) == storage
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError, match=r"folder '.*/sub' does not exist"):
        check_storage("sub/x.db")


@pytest.mark.parametrize(
    "kwargs, match",
    [(dict(n_trials=0), "n_trials must be an integer >= 1; got 0"),
     (dict(timeout=-1), "timeout must be None or a number of seconds > 0; got -1"),
     (dict(n_jobs=0), "n_jobs must be an integer >= 1, or -1"),
     (dict(random_state=1.5), r"random_state must be None or an integer seed in \[0, 2\*\*32 - 1\]; got 1.5"),
     (dict(random_state=-1), r"random_state must be None or an integer seed in \[0, 2\*\*32 - 1\]; got -1"),
     (dict(scoring="mse"), "scoring must be one of .*got 'mse'"),
     (dict(storage="x.csv"), "storage 'x.csv' is not understood"),
     (dict(refit="yes"), "refit must be True or False; got 'yes'"),
     (dict(storage="sqlite:///no_such_folder/x.db"), "folder 'no_such_folder' does not exist"),
     (dict(storage="journal:///no_such_folder/x.log"), "folder '/no_such_folder' does not exist"),
     (dict(search_space={"order": IntRange(1, 3)}), "search_space names 'order', which ARX has not"),
     (dict(search_space={"na": [1, 2]}), r"search_space\['na'\] is \[1, 2\]; expected Uniform"),
     (dict(search_space={}), "search_space must be a non-empty dict"),
     (dict(y=np.zeros((10, 1))), "X has 400 samples and y has 10")],
)
def test_tune_rejects_bad_arguments(arx_data, kwargs, match):
    u, y = arx_data
    args = dict(search_space=ARX_SPACE, y=y)
    args.update(kwargs)
    space, y = args.pop("search_space"), args.pop("y")
    with pytest.raises(ValueError, match=match):
        tune(ARX(), space, u, y, **args)


@pytest.mark.parametrize(
    "make, match",
    [(lambda: LogUniform(0.0, 1.0), "expected low > 0 on a log scale"),
     (lambda: Uniform(2.0, 1.0), "low=2.0 >= high=1.0"),
     (lambda: Uniform(0.0, float("inf")), "high must be a finite number"),
     (lambda: IntRange(1, 5, step=0), "step=0; expected step >= 1"),
     (lambda: IntRange(1.5, 5), "low must be an integer"),
     (lambda: IntRange(1, 8, step=2, log=True), "a log scale needs step=1"),
     (lambda: Categorical([]), "choices is empty"),
     (lambda: Normal(0.0, 0.0), "sigma must be > 0"),
     (lambda: LogNormal(0.0, 1.0, n_sigma=-1.0), "n_sigma must be > 0")],
)
def test_dimensions_reject_bad_arguments(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def _scorer_factory():
    def neg_rmse(model, X, y):  # a new function object, at a new address, on every call of the factory
        return -rmse(y, model.predict(X, y_init=y[:5]))

    return neg_rmse


def test_resume_with_a_callable_scoring(arx_data, tmp_path):
    # issue 18, case 7: the study recorded repr(scoring), whose memory address differs in every process
    u, y = arx_data
    storage = tmp_path / "study.log"
    first, second = _scorer_factory(), _scorer_factory()
    assert first is not second and repr(first) != repr(second)
    tune(ARX(), ARX_SPACE, u, y, scoring=first, n_trials=3, storage=storage, random_state=0)
    _, study = tune(ARX(), ARX_SPACE, u, y, scoring=second, n_trials=5, storage=storage, random_state=0)
    assert len(study.trials) == 5
    assert study.user_attrs["tune_call"]["scoring"] == f"{__name__}._scorer_factory.<locals>.neg_rmse"
    with pytest.raises(ValueError, match="made by another call"):
        tune(ARX(), ARX_SPACE, u, y, scoring=SCORER, n_trials=6, storage=storage, random_state=0)


@pytest.mark.parametrize("token", [None, "the worker before the container restarted"])
def test_restarted_worker_with_the_same_pid_reclaims_its_orphan(arx_data, tmp_path, token, caplog):
    # issue 18, case 8: a container restart gives the new worker the host name and PID of the dead one;
    # on a journal file (no heartbeat) its orphaned trial stayed RUNNING and the study ended one trial short
    u, y = arx_data
    storage = tmp_path / "study.log"
    tune(ARX(), ARX_SPACE, u, y, n_trials=3, storage=storage, random_state=0)
    study = optuna.load_study(study_name="tune-ARX", storage=make_storage(storage))
    orphan = study.ask()
    if token is not None:
        orphan.set_user_attr("worker_token", token)
    orphan.set_user_attr("worker", worker_id())  # this host, this very PID
    with caplog.at_level("WARNING", logger="sindybench.model_selection"):
        _, study = tune(ARX(), ARX_SPACE, u, y, n_trials=5, storage=storage, random_state=0)
    # issue 30, item 19: the warning named a function (<function owner at 0x...>), not the worker
    assert f"left RUNNING by worker {worker_id()}, which no longer runs" in caplog.text
    states = [t.state for t in study.trials]
    assert states[orphan.number] == TrialState.FAIL
    assert states.count(TrialState.COMPLETE) == 5 and TrialState.RUNNING not in states


def _garbage_journal(path):
    path.write_text("this is my shopping list\nnot a journal\n")


def _torn_journal(path):
    tune(ARX(), ARX_SPACE, *_arx_record(), n_trials=2, storage=path, random_state=0)
    with open(path, "a") as f:
        f.write("{not json}\n{\"op_code\": 0}\n")


def _arx_record():
    rng = np.random.default_rng(1)
    u = rng.standard_normal((200, 1))
    return u, np.cumsum(u, axis=0)[:, :1] * 0.1


@pytest.mark.parametrize("name, make, error, match", [
    ("foo://bar", None, ValueError, r"storage 'foo://bar': 'foo' is not a database kind SQLAlchemy knows"),
    ("x.db", lambda p: p.write_text("my notes\n"), ValueError, r"'.*x\.db' is not an SQLite database"),
    ("x.log", _garbage_journal, ValueError, r"'.*x\.log' is not an Optuna journal file \(line 1"),
    ("x.log", _torn_journal, ValueError, r"storage '.*x\.log': the journal file cannot be read \(JSONDecodeError"),
    ("x.db", lambda p: p.mkdir(), ValueError, r"'.*x\.db' is a folder"),
])
def test_tune_storage_errors_name_the_storage(arx_data, tmp_path, monkeypatch, name, make, error, match):
    # issue 18, case 14: these escaped as NoSuchModuleError, sqlite's DatabaseError or a bare JSONDecodeError
    monkeypatch.chdir(tmp_path)
    if make is not None:
        make(tmp_path / name)
    u, y = arx_data
    with pytest.raises(error, match=match):
        tune(ARX(), ARX_SPACE, u, y, n_trials=2, storage=name, random_state=0)


def test_postgresql_server_that_does_not_answer_is_a_connection_error():
    with pytest.raises(ConnectionError, match=r"storage 'postgresql\+psycopg://u:\*\*\*@/db\?host=/no/such/.*cannot reach"):
        make_storage("postgresql+psycopg://u:secret@/db?host=/no/such/folder&connect_timeout=2")


@pytest.mark.parametrize("seed", [2**32, 2**40])
def test_tune_rejects_seeds_numpy_cannot_take(arx_data, seed):
    u, y = arx_data
    with pytest.raises(ValueError, match=r"random_state must be None or an integer seed in \[0, 2\*\*32 - 1\]"):
        tune(ARX(), ARX_SPACE, u, y, n_trials=2, random_state=seed)

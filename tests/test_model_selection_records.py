"""Cross-validation over records: LeaveOneRecordOut, tune and the simulation scorer on lists of arrays."""

import numpy as np
import pytest
from sklearn.base import clone

from sindybench import SINDy, STLS
from sindybench.libraries import PolynomialLibrary
from sindybench.metrics import make_simulation_scorer, rmse
from sindybench.model_selection import LeaveOneRecordOut, LogUniform, tune
from sindybench.simulate import simulate

DT = 0.01


def _truth(x, u):
    return np.array([-x[0] + 0.5 * x[0] ** 2 + u[0]])


@pytest.fixture(scope="module")
def records():
    rng = np.random.default_rng(0)
    out = []
    for y0, u_mean, n in ((0.0, 0.0, 300), (1.5, 0.375, 250), (0.5, 0.2, 200)):
        t = np.arange(n) * DT
        u = (u_mean + 0.2 * np.sin(2 * t) + 0.1 * np.sin(5.3 * t))[:, None]
        y = simulate(_truth, [y0], u, dt=DT, input_hold="linear")
        out.append((u, y + 1e-3 * rng.standard_normal(y.shape)))
    return [u for u, _ in out], [y for _, y in out]


def _model():
    return SINDy(library=PolynomialLibrary(degree=2), optimizer=STLS(threshold=0.05), dt=DT)


def test_leave_one_record_out_splits_records():
    ys = [np.zeros((5, 1))] * 3
    splits = [(a.tolist(), b.tolist()) for a, b in LeaveOneRecordOut().split(None, ys)]
    assert splits == [([1, 2], [0]), ([0, 2], [1]), ([0, 1], [2])]
    assert LeaveOneRecordOut().get_n_splits(ys) == 3
    with pytest.raises(ValueError, match="at least 2 records"):
        LeaveOneRecordOut().get_n_splits([np.zeros((5, 1))])
    with pytest.raises(ValueError, match="splits records given as lists"):
        next(LeaveOneRecordOut().split(np.zeros((5, 1))))


def test_the_scorer_pools_the_records(records):
    us, ys = records
    model = _model().fit(us, ys)
    pred = model.predict(us, y_init=ys)
    expected = -rmse(np.vstack(ys), np.vstack(pred))
    assert make_simulation_scorer("rmse")(model, us, ys) == pytest.approx(expected, rel=1e-12)
    skipped = -rmse(np.vstack([y[10:] for y in ys]), np.vstack([p[10:] for p in pred]))
    assert make_simulation_scorer("rmse", skip=10)(model, us, ys) == pytest.approx(skipped, rel=1e-12)


def test_tune_cross_validates_over_records(records):
    us, ys = records
    space = {"optimizer__threshold": LogUniform(1e-3, 1.0)}
    best, study = tune(_model(), space, us, ys, n_trials=6, random_state=0, show_progress_bar=False)
    trial = study.best_trial
    assert len(trial.user_attrs["split_scores"]) == 3  # the default with lists: LeaveOneRecordOut
    # split 1: fitted on records 0 and 2, scored on record 1 from its own start
    held = clone(_model()).set_params(**trial.user_attrs["params"]).fit([us[0], us[2]], [ys[0], ys[2]])
    assert trial.user_attrs["split_scores"][1] == pytest.approx(
        make_simulation_scorer("rmse")(held, [us[1]], [ys[1]]), rel=1e-12)
    assert study.best_value == pytest.approx(-np.mean(trial.user_attrs["split_scores"]), rel=1e-12)
    assert best.score(us, ys) > 0.99  # refitted on every record
    _, kfold = tune(_model(), space, us, ys, cv=3, n_trials=2, random_state=0, show_progress_bar=False)
    assert len(kfold.best_trial.user_attrs["split_scores"]) == 3


def test_tune_refuses_bad_record_lists(records):
    us, ys = records
    space = {"optimizer__threshold": LogUniform(1e-3, 1.0)}
    with pytest.raises(ValueError, match="X must be None or a list of 3 input arrays; got a list of 2"):
        tune(_model(), space, us[:2], ys, n_trials=1, show_progress_bar=False)
    with pytest.raises(ValueError, match=r"record 1: X\[1\] has 249 samples and y\[1\] has 250"):
        tune(_model(), space, [us[0], us[1][:-1], us[2]], ys, n_trials=1, show_progress_bar=False)
    bad = ys[2].copy()
    bad[7] = np.nan
    with pytest.raises(ValueError, match=r"y\[2\] contains NaN or inf \(first at sample 7\)"):  # before: every trial
        tune(_model(), space, us, [ys[0], ys[1], bad], n_trials=1, show_progress_bar=False)
    with pytest.raises(ValueError, match="record 2 has 1 outputs and 2 inputs; expected 1 and 1 as in record 0"):
        tune(_model(), space, [us[0], us[1], np.hstack([us[2], us[2]])], ys, n_trials=1, show_progress_bar=False)
    with pytest.raises(ValueError, match=r"X could not be converted to an array: .*a list, not a tuple"):
        tune(_model(), space, tuple(us), tuple(ys), n_trials=1, show_progress_bar=False)


@pytest.mark.parametrize("cv, match", [
    ([(np.arange(200), np.arange(200, 250))], r"cv split 0: the training indices \[0, 1, 2, 3, 4, 5, ...\] are not "
                                              r"record indices; .* records 0..2"),
    ([(np.array([0, 1]), np.array([-1]))], r"the validation indices \[-1\] are not record indices"),
    ([(np.array([0.0, 1.0]), np.array([2]))], r"the training indices \[0., 1.\] are not record indices"),
    ([(np.array([], dtype=int), np.array([2]))], r"the training indices \[\] are not record indices"),
    ([(np.array([0]), np.array([1]), np.array([2]))], "cv split 0 is not a .train, validation. pair"),
    (5, "cv=5 asks for 5 folds of 3 records; expected at most 3"),
])
def test_tune_refuses_splits_that_do_not_pick_records(records, cv, match):
    # sample indices with lists: before, every trial failed with an IndexError (or, for -1, silently took
    # the last record); an int above the number of records: scikit-learn's message spoke of samples
    us, ys = records
    space = {"optimizer__threshold": LogUniform(1e-3, 1.0)}
    with pytest.raises(ValueError, match=match):
        tune(_model(), space, us, ys, cv=cv, n_trials=1, show_progress_bar=False)


def test_scikit_learn_searches_take_records_with_leave_one_record_out(records):
    """GridSearchCV and cross_val_score index the lists by record: each fold is a record-wise fit."""
    from sklearn.model_selection import GridSearchCV, cross_val_score

    us, ys = records
    scores = cross_val_score(_model(), us, ys, cv=LeaveOneRecordOut())
    for k, score in enumerate(scores):
        rest = [i for i in range(len(us)) if i != k]
        fold = _model().fit([us[i] for i in rest], [ys[i] for i in rest])
        assert score == pytest.approx(fold.score([us[k]], [ys[k]]), rel=1e-12)
    search = GridSearchCV(_model(), {"library__degree": [1, 2]}, cv=LeaveOneRecordOut()).fit(us, ys)
    assert search.best_params_ == {"library__degree": 2}  # the truth is quadratic
    assert search.cv_results_["mean_test_score"][1] > search.cv_results_["mean_test_score"][0]

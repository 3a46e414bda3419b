"""Metrics: agreement with scikit-learn, the fit-index relation, skip, scorers, bad input."""

import numpy as np
import pytest
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.metrics import r2_score, root_mean_squared_error
from sklearn.model_selection import GridSearchCV, cross_val_score

from sindybench import STLS, SINDy
from sindybench.libraries import PolynomialLibrary
from sindybench.metrics import fit_index, make_simulation_scorer, nrmse, r2, rmse


@pytest.fixture
def pair(rng):
    y = rng.normal(size=(200, 3)) * [1.0, 10.0, 0.1] + [0.0, 5.0, -1.0]
    return y, y + 0.3 * rng.normal(size=y.shape) * [1.0, 10.0, 0.1]


def test_rmse_and_r2_match_scikit_learn(pair):
    y, p = pair
    assert rmse(y, p) == pytest.approx(root_mean_squared_error(y, p), rel=1e-12)
    np.testing.assert_allclose(rmse(y, p, multioutput="raw_values"),
                               root_mean_squared_error(y, p, multioutput="raw_values"), rtol=1e-12)
    assert r2(y, p) == pytest.approx(r2_score(y, p), rel=1e-12)
    np.testing.assert_allclose(r2(y, p, multioutput="raw_values"), r2_score(y, p, multioutput="raw_values"), rtol=1e-12)


def test_fit_index_and_nrmse_relations(pair):
    y, p = pair
    r2_raw = r2(y, p, multioutput="raw_values")
    np.testing.assert_allclose(fit_index(y, p, multioutput="raw_values"), 100 * (1 - np.sqrt(1 - r2_raw)), rtol=1e-12)
    np.testing.assert_allclose(nrmse(y, p, multioutput="raw_values"), np.sqrt(1 - r2_raw), rtol=1e-12)
    np.testing.assert_allclose(nrmse(y, p, multioutput="raw_values"), rmse(y, p, multioutput="raw_values") / y.std(axis=0))
    assert 0 < fit_index(y, p) < 100


def test_perfect_and_mean_predictions(pair):
    y, _ = pair
    assert rmse(y, y) == 0.0 and r2(y, y) == 1.0 and fit_index(y, y) == 100.0
    mean = np.broadcast_to(y.mean(axis=0), y.shape)
    assert r2(y, mean) == pytest.approx(0.0, abs=1e-12)
    assert fit_index(y, mean) == pytest.approx(0.0, abs=1e-10)


@pytest.mark.parametrize("metric", [rmse, nrmse, r2, fit_index])
def test_skip_leaves_out_the_first_samples(pair, metric):
    y, p = pair
    p = p.copy()
    p[:10] += 100.0  # a bad transient
    assert metric(y, p, skip=10) == pytest.approx(metric(y[10:], p[10:]), rel=1e-12)
    assert metric(y, p, skip=10) != pytest.approx(metric(y, p))


def test_one_dimensional_inputs(rng):
    y = rng.normal(size=50)
    p = y + 0.1 * rng.normal(size=50)
    assert r2(y, p) == pytest.approx(r2_score(y, p), rel=1e-12)
    assert r2(y[:, None], p) == pytest.approx(r2_score(y, p), rel=1e-12)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(skip=-1), r"skip must be an integer in \[0, 199\]"),
        (dict(skip=200), r"skip must be an integer in \[0, 199\]"),
        (dict(skip=2.5), r"skip must be an integer in \[0, 199\]"),
        (dict(skip=True), r"skip must be an integer in \[0, 199\]"),
        (dict(multioutput="variance_weighted"), "multioutput must be one of"),
    ],
)
def test_bad_arguments(pair, kwargs, match):
    y, p = pair
    with pytest.raises(ValueError, match=match):
        rmse(y, p, **kwargs)


@pytest.mark.parametrize("metric", [rmse, nrmse, r2, fit_index])
@pytest.mark.parametrize("which", ["y_true", "y_pred"])
def test_complex_input_is_refused(pair, metric, which):
    # before: the imaginary part was dropped with only a ComplexWarning (issue 18, case 22)
    y_true, y_pred = pair
    args = {"y_true": y_true, "y_pred": y_pred}
    args[which] = args[which] + 1e-3j
    with pytest.raises(ValueError, match=f"{which} has complex values; expected real numbers"):
        metric(args["y_true"], args["y_pred"])
    args[which] = list(np.ravel(args[which]))  # a list of Python complex numbers too
    args["y_true" if which == "y_pred" else "y_pred"] = np.ravel(args["y_true" if which == "y_pred" else "y_pred"])
    with pytest.raises(ValueError, match=f"{which} has complex values"):
        metric(args["y_true"], args["y_pred"])


@pytest.mark.parametrize("bad", ["abc", ["a", "b", "c"], [1.0, [2.0], 3.0]])
def test_non_numeric_prediction_names_the_argument(bad):
    # before: "could not convert string to float: 'abc'", naming no argument
    with pytest.raises(ValueError, match="y_pred could not be converted to"):
        r2([1.0, 2.0, 4.0], bad)
    with pytest.raises(ValueError, match="y_true could not be converted to"):
        rmse(bad, [1.0, 2.0, 4.0])


def test_bad_predictions(pair):
    y, p = pair
    bad = p.copy()
    bad[3, 0] = np.nan
    with pytest.raises(ValueError, match="y_pred contains NaN or inf"):
        r2(y, bad)
    with pytest.raises(ValueError, match=r"y_pred has shape \(200, 2\); expected the shape of y_true, \(200, 3\)"):
        r2(y, p[:, :2])
    with pytest.raises(ValueError, match="y_true contains NaN or inf"):
        rmse(bad, p)
    with pytest.raises(ValueError, match="y_true is constant"):
        fit_index(np.ones((5, 1)), np.zeros((5, 1)))


# ------------------------------------------------------------------- scorers


class _Recorder(RegressorMixin, BaseEstimator):
    """Predicts ``y_init`` shifted by ``offset`` (or NaN), to see what the scorer passes."""

    def __init__(self, *, offset=0.0, diverge=False):
        self.offset = offset
        self.diverge = diverge

    def fit(self, X, y):
        self.fitted_ = True
        return self

    def predict(self, X, *, y_init=None):
        out = np.asarray(y_init, dtype=float) + self.offset
        if self.diverge:
            out[len(out) // 2 :] = np.nan
        return out


@pytest.mark.parametrize("name, func, sign", [("rmse", rmse, -1), ("nrmse", nrmse, -1), ("r2", r2, 1),
                                              ("fit_index", fit_index, 1)])
def test_scorer_passes_y_as_initial_samples(pair, name, func, sign):
    y, _ = pair
    est = _Recorder(offset=0.1).fit(None, y)
    scorer = make_simulation_scorer(name, skip=5)
    assert scorer(est, None, y) == pytest.approx(sign * func(y, y + 0.1, skip=5), rel=1e-12)


def test_scorer_diverged_is_minus_inf(pair):
    y, _ = pair
    assert make_simulation_scorer("r2")(_Recorder(diverge=True).fit(None, y), None, y) == -np.inf


def test_scorer_bad_arguments():
    with pytest.raises(ValueError, match="metric must be one of"):
        make_simulation_scorer("mae")
    with pytest.raises(ValueError, match="skip must be an integer >= 0"):
        make_simulation_scorer("rmse", skip=-2)


def test_scorer_in_a_search_with_sindy(rng):
    dt = 0.01
    t = np.arange(1200) * dt
    u = np.sin(1.3 * t)[:, None]
    y = np.empty((1200, 1))
    y[0] = 0.2
    for k in range(1199):  # y' = -y + u, exact for held input
        y[k + 1] = u[k] + (y[k] - u[k]) * np.exp(-dt)
    model = SINDy(library=PolynomialLibrary(degree=2), optimizer=STLS(), dt=dt)
    cv = [(np.arange(800), np.arange(800, 1200))]
    search = GridSearchCV(model, {"optimizer__threshold": [0.05, 2.0]}, scoring=make_simulation_scorer("rmse"), cv=cv)
    search.fit(u, y)
    assert search.best_params_["optimizer__threshold"] == 0.05
    assert -search.best_score_ < 0.01
    assert search.cv_results_["mean_test_score"][1] < 10 * search.best_score_  # 2.0 removes the dynamics
    scores = cross_val_score(model.set_params(optimizer__threshold=0.05), u, y, cv=cv,
                             scoring=make_simulation_scorer("fit_index"))
    assert scores[0] > 95.0


def test_simulation_scorer_checks_records_and_refuses_sample_weight():
    t = np.arange(0, 2, 0.01)
    u1, u2 = np.sin(t)[:, None], np.cos(t)[:, None]
    y1, y2 = 0.1 * np.cumsum(u1, axis=0), 0.1 * np.cumsum(u2, axis=0)
    model = SINDy(library=PolynomialLibrary(degree=1), dt=0.01).fit([u1, u2], [y1, y2])
    scorer = make_simulation_scorer("rmse")
    pred = model.predict([u1, u2], y_init=[y1, y2])
    assert scorer(model, [u1, u2], [y1, y2]) == pytest.approx(-rmse(np.vstack([y1, y2]), np.vstack(pred)), rel=1e-12)
    with pytest.raises(ValueError, match="X is a list of 2 records, so y must be a list of 2 output arrays"):
        scorer(model, [u1, u2], y1)
    with pytest.raises(ValueError, match="X must be None or a list of 2 input arrays; got a list of 1"):
        scorer(model, [u1], [y1, y2])
    with pytest.raises(ValueError, match=r"record 1: X\[1\] has 100 samples and y\[1\] has 200"):  # was a reshape error
        scorer(model, [u1, u2[:100]], [y1, y2])
    with pytest.raises(ValueError, match="sample_weight is not supported by the simulation scorers"):  # a TypeError
        scorer(model, u1, y1, sample_weight=np.ones(200))


def test_metrics_of_values_near_the_float_limit_are_finite():
    # before: rmse of +-1e300 was inf (the squares overflowed), r2 and fit_index NaN
    y_true, y_pred = np.array([1e300, -1e300, 0.5e300]), np.array([-1e300, 1e300, 0.4e300])
    unit_true, unit_pred = y_true / 1e300, y_pred / 1e300
    assert rmse(y_true, y_pred) == pytest.approx(rmse(unit_true, unit_pred) * 1e300, rel=1e-12)
    assert r2(y_true, y_pred) == pytest.approx(r2(unit_true, unit_pred), rel=1e-12)
    assert fit_index(y_true, y_pred) == pytest.approx(fit_index(unit_true, unit_pred), rel=1e-12)
    assert nrmse(y_true, y_pred) == pytest.approx(nrmse(unit_true, unit_pred), rel=1e-12)
    with pytest.raises(ValueError, match="the RMSE overflows a float"):
        rmse([1.7e308, -1.7e308], [-1.7e308, 1.7e308])
    with pytest.raises(ValueError, match="y_true is constant over the scored samples"):
        r2([1e300, 1e300], [1e300, 0.0])

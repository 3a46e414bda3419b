"""Conformal bands: the quantile rule (MAPIE's), coverage on new records, k-step bands, every estimator, bad input."""

import warnings

import numpy as np
import pytest

from sindybench import SINDy, STLS
from sindybench.baselines import ARX, NNARX
from sindybench.libraries import PolynomialLibrary
from sindybench.refine import OutputErrorRefinement
from sindybench.simulate import simulate
from sindybench.uncertainty import ConformalCalibration, ExtrapolationWarning, conformal_calibration, conformal_quantile

DT = 0.05


def first_order(seed, n, noise=0.05):
    """``y' = -y + 2 u - 0.3 y^3``: a model of degree 1 has a small structural error, so the band must hold it."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1, 1, n // 20), 20)[:, None]
    x = simulate(lambda x, u: np.array([-x[0] + 2 * u[0] - 0.3 * x[0] ** 3]), [0.0], u, dt=DT)
    return u, x + noise * rng.normal(size=x.shape)


@pytest.fixture(scope="module")
def sindy_model():
    u, y = first_order(0, 1000)
    return SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.1), dt=DT,
                 refine=OutputErrorRefinement()).fit(u, y)


def test_quantile_is_mapies_split_conformal_bound(rng):
    mapie = pytest.importorskip("mapie.regression")  # in the test extra: CI runs it
    from sklearn.base import BaseEstimator, RegressorMixin

    class Column(RegressorMixin, BaseEstimator):  # the precomputed prediction as the only feature
        def fit(self, X, y):
            self.fitted_ = True
            return self

        def predict(self, X):
            return np.asarray(X)[:, 0]

    pred = rng.normal(size=(57, 1))
    y = pred[:, 0] + rng.normal(size=57)
    for alpha in (0.05, 0.1, 0.3):
        split = mapie.SplitConformalRegressor(Column().fit(pred, y), confidence_level=1 - alpha, prefit=True)
        _, bounds = split.conformalize(pred, y).predict_interval(np.zeros((1, 1)))
        assert np.isclose(conformal_quantile(np.abs(y - pred[:, 0])[:, None], alpha)[0], bounds[0, 1, 0])


def test_free_run_band_covers_new_records(sindy_model):
    u, y = first_order(1, 1000)
    cal = sindy_model.conformal_calibration(u, y, block_length=200)
    assert (cal.n_blocks, cal.n_scores, cal.name) == (5, 1000, "conformal 95 % free-run band")
    coverage = []
    for seed in range(2, 7):
        u_new, y_new = first_order(seed, 600)
        band = cal.band(sindy_model, u_new, y_init=y_new[:10])
        coverage.append(band.coverage(y_new))
        assert np.allclose(band.upper - band.lower, 2 * cal.half_width)
    assert 0.9 <= np.mean(coverage) <= 0.99, coverage  # measured: 0.95


def test_k_step_band_is_narrower_and_covers(sindy_model):
    u, y = first_order(1, 1000)
    Q, R = np.eye(1) * 1e-6, np.eye(1) * 0.05**2
    free = sindy_model.conformal_calibration(u, y)
    step = sindy_model.conformal_calibration(u, y, horizon=5, block_length=250, Q=Q, R=R)
    assert step.name == "conformal 95 % 5-step band" and step.n_scores == 4 * 245
    assert step.half_width[0] < free.half_width[0]
    u_new, y_new = first_order(8, 1000)
    band = step.band(sindy_model, u_new, y=y_new, Q=Q, R=R)
    assert band.start == 5 and band.prediction.shape == (995, 1)
    assert 0.9 <= band.coverage(y_new) <= 0.99  # measured: 0.955
    assert ConformalCalibration.from_dict(step.to_dict()).name == step.name


@pytest.mark.parametrize("make", [lambda: ARX(na=2, nb=2),
                                  lambda: NNARX(na=2, nb=2, hidden_layer_sizes=(8,), max_iter=200, random_state=0)])
def test_lag_models_free_run_and_k_step(make):
    u, y = first_order(0, 1000)
    model = make().fit(u[:600], y[:600])
    u_new, y_new = first_order(3, 1000)
    for horizon in (None, 10):
        cal = model.conformal_calibration(u[600:], y[600:], horizon=horizon)
        band = cal.band(model, u_new, y_init=y_new, y=y_new)
        assert 0.85 <= band.coverage(y_new) <= 1.0
        assert band.mean_width() == pytest.approx(2 * cal.half_width[0])


@pytest.mark.parametrize("kwargs, match", [
    ({"alpha": 0.0}, "alpha must be in \\(0, 1\\)"),
    ({"alpha": 1.5}, "alpha must be in \\(0, 1\\)"),
    ({"horizon": 50, "block_length": 40}, "block_length = 40 is not longer than the horizon = 50"),
    ({"horizon": 300}, "is not longer than the horizon = 300"),
    ({"block_length": 5}, "not longer than n_init"),
    ({"alpha": 0.001, "block_length": 100}, "too few for alpha = 0.001"),
])
def test_bad_input(kwargs, match):
    u, y = first_order(0, 200)
    model = ARX(na=1, nb=1).fit(u, y)
    with pytest.raises(ValueError, match=match):
        conformal_calibration(model, u, y, n_init=10, **kwargs)


def test_nan_residuals_are_refused():
    u, y = first_order(0, 200)
    model = ARX(na=1, nb=1).fit(u, y)
    model.coef_ = model.coef_ * 0 + np.array([[1e3], [0.0]])  # an unstable model: its free run overflows
    with pytest.raises(ValueError, match="diverged: NaN errors"):
        conformal_calibration(model, u, y)
    with pytest.raises(ValueError, match="NaN or inf"):
        conformal_quantile(np.array([[1.0], [np.nan]]), 0.5)


def test_a_band_outside_its_calibration_range_warns_and_says_how_much(sindy_model):
    """Inputs in [-1, 1] calibrate; a test with inputs up to 3 (and outputs beyond the calibration's) warns."""
    u, y = first_order(1, 600)
    cal = conformal_calibration(sindy_model, u, y, n_init=1, block_length=150)
    assert cal.ranges["inputs"].shape == (2, 1) and cal.ranges["n_samples"] == 600
    u_test, y_test = first_order(2, 400)
    u_test[200:] *= 3.0
    expected = np.mean((u_test[:, 0] < u.min()) | (u_test[:, 0] > u.max()))
    with pytest.warns(ExtrapolationWarning, match=rf"% of the record's samples \(inputs {100 * expected:.1f} %, "
                                                  r"predicted outputs .*calibration record \(600 samples; inputs in \[-"):
        band = cal.band(sindy_model, u_test, y_init=y_test)
    assert band.extrapolation["fraction_inputs"] == pytest.approx(expected)
    assert band.extrapolation["fraction"] >= band.extrapolation["fraction_outputs"] > 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a record inside the range: no warning
        inside = cal.band(sindy_model, u[:150], y_init=y)  # the first calibration block itself
    assert inside.extrapolation["fraction"] == 0.0


def _unit_calibration():
    """A calibration whose predicted outputs spanned [0, 1] (no inputs), built directly."""
    from sindybench.uncertainty._conformal import calibration_ranges

    return ConformalCalibration(0.05, None, np.array([0.1]), 100, 1, 100, 1,
                                calibration_ranges(None, np.linspace(0.0, 1.0, 100)))


def test_a_sample_a_hair_outside_the_calibration_range_does_not_warn():
    """One sample of 500 a thousandth of the range beyond it: reported (a measurement), not warned (was: warned at any
    fraction above 0); ``max_outside=0, margin=0`` gives the former warning."""
    cal = _unit_calibration()
    prediction = np.linspace(0.0, 1.0, 500)
    prediction[250] = 1.001
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        band = cal.around(prediction)
    assert band.extrapolation["fraction"] == pytest.approx(1 / 500)
    with pytest.warns(ExtrapolationWarning, match=r"0\.2 % of the record's samples .* the farthest by 0\.1 % of the "
                                                  r"range's width.*max_outside = 0 of the samples or beyond margin = 0 "):
        cal.around(prediction, max_outside=0, margin=0)


@pytest.mark.parametrize("outside, value, match", [
    (1, 1.5, r"0\.2 % of the record's samples .*the farthest by 50 % of the range's width"),  # one, far beyond
    (10, 1.01, r"2\.0 % of the record's samples .*the farthest by 1 % of the range's width"),  # 2 % a little beyond
])
def test_far_or_many_samples_outside_warn(outside, value, match):
    cal = _unit_calibration()
    prediction = np.linspace(0.0, 1.0, 500)
    prediction[:outside] = value
    with pytest.warns(ExtrapolationWarning, match=match):
        cal.around(prediction)
    with warnings.catch_warnings():  # the tolerances are the caller's
        warnings.simplefilter("error")
        cal.around(prediction, max_outside=0.05, margin=1.0)


def test_a_constant_calibration_input_warns_at_any_distance_beyond_it():
    from sindybench.uncertainty._conformal import calibration_ranges

    cal = ConformalCalibration(0.05, None, np.array([0.1]), 100, 1, 100, 1,
                               calibration_ranges(np.ones((100, 1)), np.linspace(0.0, 1.0, 100)))
    X = np.ones((500, 1))
    X[0] = 1.0 + 1e-9  # a width of 0: any distance beyond it is infinitely far
    with pytest.warns(ExtrapolationWarning, match="the farthest by inf % of the range's width"):
        cal.around(np.linspace(0.0, 1.0, 500), X=X)


@pytest.mark.parametrize("kwargs, match", [
    (dict(max_outside=1.5), r"max_outside must be a fraction in \[0, 1\]; got 1\.5"),
    (dict(max_outside=-0.1), r"max_outside must be a finite number >= 0; got -0\.1"),
    (dict(margin="a"), r"margin must be a finite number >= 0; got 'a'"),
    (dict(margin=np.nan), r"margin must be a finite number >= 0; got nan"),
])
def test_bad_extrapolation_tolerances(kwargs, match):
    with pytest.raises(ValueError, match=match):
        _unit_calibration().around(np.linspace(0.0, 1.0, 50), **kwargs)


def test_the_calibration_range_survives_to_dict_and_old_dicts_load_without(sindy_model):
    u, y = first_order(1, 600)
    cal = conformal_calibration(sindy_model, u, y, n_init=1, block_length=150)
    back = ConformalCalibration.from_dict(cal.to_dict())
    np.testing.assert_array_equal(back.ranges["outputs"], cal.ranges["outputs"])
    old = {k: v for k, v in cal.to_dict().items() if k != "ranges"}
    legacy = ConformalCalibration.from_dict(old)
    assert legacy.ranges is None and legacy.around(np.zeros((5, 1))).extrapolation is None

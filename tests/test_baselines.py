"""ARX and NN-ARX: fitting, free-run simulation, initial conditions, errors, the cascaded tanks."""

import warnings

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import ConvergenceWarning

from sindybench import DivergenceWarning
from sindybench.baselines import ARX, NNARX
from sindybench.baselines._lags import free_run, lagged_regressors, n_lags
from sindybench.metrics import r2, rmse
from sindybench.model_selection import Categorical, HoldoutSplit, IntRange, LogUniform, tune


def _arx_system(rng, n=500, noise=0.0):
    """y[t] = 1.2 y[t-1] - 0.5 y[t-2] + 0.7 u[t-2] + 0.3 u[t-3] + 2 (orders na=2, nb=2, nk=2)."""
    u = rng.standard_normal((n, 1))
    y = np.zeros((n, 1))
    for t in range(3, n):
        y[t] = 1.2 * y[t - 1] - 0.5 * y[t - 2] + 0.7 * u[t - 2] + 0.3 * u[t - 3] + 2.0
    return u, y + noise * rng.standard_normal(y.shape)


def _nonlinear_system(rng, n=600):
    u = rng.uniform(-1, 1, (n, 1))
    y = np.zeros((n, 1))
    for t in range(1, n):
        y[t] = 0.6 * y[t - 1] + np.tanh(2.0 * u[t - 1]) + 0.2 * np.sin(2.0 * y[t - 1])
    return u, y


def test_arx_recovers_the_coefficients_and_simulates_exactly(rng):
    u, y = _arx_system(rng)
    model = ARX(na=2, nb=2, nk=2).fit(u, y)
    np.testing.assert_allclose(model.coef_.ravel(), [1.2, -0.5, 0.7, 0.3], atol=1e-10)
    np.testing.assert_allclose(model.intercept_, [2.0], atol=1e-9)
    assert model.n_lags_ == 3 and model.n_features_in_ == 1 and model.n_outputs_ == 1
    u_new, y_new = _arx_system(np.random.default_rng(5))
    y_sim = model.predict(u_new, y_init=y_new[:3])
    np.testing.assert_allclose(y_sim, y_new, atol=1e-8)
    assert model.score(u_new, y_new) == pytest.approx(1.0)


def test_arx_predict_is_the_free_run(rng):
    u, y = _arx_system(rng, noise=0.05)
    model = ARX(na=2, nb=2, nk=2).fit(u, y)
    phi, target = lagged_regressors(u, y, 2, 2, 2)
    one_step = phi @ model.coef_ + model.intercept_
    y_sim = model.predict(u, y_init=y)
    # predict is the free run: it sees only the first 3 measured samples, not the noisy past
    assert np.abs(y_sim[3:] - one_step).max() > 0.1
    np.testing.assert_array_equal(y_sim[:3], y[:3])
    assert rmse(y[3:], y_sim[3:]) < 0.06  # the measurement noise is 0.05


def test_arx_several_outputs_matches_the_loop(rng):
    n = 400
    u = rng.standard_normal((n, 2))
    y = np.zeros((n, 2))
    for t in range(1, n):
        y[t, 0] = 0.5 * y[t - 1, 0] + 0.2 * y[t - 1, 1] + u[t - 1, 0]
        y[t, 1] = -0.3 * y[t - 1, 0] + 0.4 * y[t - 1, 1] + u[t - 1, 1] - 0.5 * u[t - 1, 0]
    model = ARX(na=1, nb=1).fit(u, y)
    assert model.coef_.shape == (4, 2)
    np.testing.assert_allclose(model.predict(u, y_init=y), y, atol=1e-9)
    # one output through lfilter agrees with the generic loop
    single = ARX(na=2, nb=1).fit(u[:, :1], y[:, :1])
    coef = single.coef_
    loop = free_run(lambda past, i: past @ coef[:2] + u[i + 2 - 1, :1] @ coef[2:] + single.intercept_,
                    u[:, :1], y[:2, :1], 2, 1, 1)
    np.testing.assert_allclose(single.predict(u[:, :1], y_init=y[:, :1]), loop, atol=1e-9)


def test_initial_outputs(rng):
    u, y = _arx_system(rng)
    model = ARX(na=2, nb=2, nk=2).fit(u, y[:, 0])
    y_sim = model.predict(u, y_init=y[:3] + 1.0)
    assert y_sim.shape == (500,)  # 1-D y in fit, 1-D prediction
    np.testing.assert_array_equal(y_sim[:3], y[:3, 0] + 1.0)
    np.testing.assert_array_equal(model.predict(u)[:3], np.full(3, y.mean()))
    assert model.simulate(u[:2], y[:3]).shape == (2,)
    with pytest.raises(ValueError, match="y_init has 2 samples; expected at least 3"):
        model.predict(u, y_init=y[:2])
    with pytest.raises(ValueError, match="y_init has 2 outputs; expected 1"):
        model.predict(u, y_init=np.hstack([y, y]))
    with pytest.raises(ValueError, match="y_init contains NaN"):
        model.predict(u, y_init=np.full((3, 1), np.nan))


def test_feedthrough_and_pure_autoregression(rng):
    u = rng.standard_normal((200, 1))
    y = 3.0 * u + 1.0
    model = ARX(na=0, nb=1, nk=0).fit(u, y)
    assert model.n_lags_ == 0
    np.testing.assert_allclose(model.predict(u), y, atol=1e-10)
    y_ar = 0.9 ** np.arange(50)[:, None]
    ar = ARX(na=1, nb=0, fit_intercept=False).fit(np.zeros((50, 1)), y_ar)
    np.testing.assert_allclose(ar.predict(np.zeros((50, 1)), y_init=y_ar), y_ar, atol=1e-12)


def test_unstable_model_gives_non_finite_output_with_one_divergence_warning():
    u = np.zeros((2000, 1))
    y = 1.5 ** np.arange(40)[:, None]
    model = ARX(na=1, nb=1, fit_intercept=False).fit(u[:40], y)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        y_sim = model.predict(u, y_init=y)
    assert [type(w.message) for w in caught] == [DivergenceWarning]  # no overflow RuntimeWarning
    assert not np.all(np.isfinite(y_sim)) and np.isfinite(y_sim[:100]).all()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # score reports the divergence as -inf, without a warning
        assert model.score(u, np.ones((2000, 1))) == -np.inf


@pytest.mark.parametrize("Model", [ARX, NNARX])
@pytest.mark.parametrize(
    "params, match",
    [(dict(na=-1), "na must be an integer >= 0; got -1"), (dict(nb=1.5), "nb must be an integer >= 0; got 1.5"),
     (dict(nk=True), "nk must be an integer >= 0; got True"), (dict(na=0, nb=0), "na and nb are both 0")],
)
def test_bad_orders(Model, params, match, rng):
    u, y = _arx_system(rng, n=50)
    with pytest.raises(ValueError, match=match):
        Model(**params).fit(u, y)


def test_bad_settings_and_data(rng):
    u, y = _arx_system(rng, n=50)
    with pytest.raises(ValueError, match="fit_intercept must be True or False; got 'yes'"):
        ARX(fit_intercept="yes").fit(u, y)
    with pytest.raises(ValueError, match="activation must be one of .*got 'sigmoid'"):
        NNARX(activation="sigmoid").fit(u, y)
    with pytest.raises(ValueError, match="residual must be True or False; got 1"):
        NNARX(residual=1).fit(u, y)
    for bad in (0, 2.0, True):
        with pytest.raises(ValueError, match=f"n_estimators must be an integer >= 1; got {bad!r}"):
            NNARX(n_estimators=bad).fit(u, y)
    with pytest.raises(ValueError, match=r"dtype must be one of \['float32', 'float64'\]; got 'float16'"):
        NNARX(dtype="float16").fit(u, y)
    with pytest.raises(ValueError, match="got 3 samples; ARX.na=2, nb=2, nk=2. needs at least 4"):
        ARX(na=2, nb=2, nk=2).fit(u[:3], y[:3])
    with pytest.raises(ValueError, match="Expected 2D array"):
        ARX().fit(u[:, 0], y)


@pytest.mark.parametrize("Model", [ARX, NNARX])
@pytest.mark.parametrize("n, params", [(1, dict(na=0, nb=1, nk=5)), (3, dict(na=1, nb=1, nk=5)),
                                       (10, dict(na=20, nb=0)), (5, dict(na=40, nb=2))])
def test_orders_longer_than_the_record(Model, n, params, rng):
    # before: "negative dimensions are not allowed" or a numpy concatenation error
    u, y = _arx_system(rng, n=50)
    need = n_lags(params["na"], params["nb"], params.get("nk", 1)) + 1
    with pytest.raises(ValueError, match=f"got {n} samples; {Model.__name__}.* needs at least {need}"):
        Model(**params).fit(u[:n], y[:n])


@pytest.mark.parametrize("Model", [ARX, NNARX])
def test_inputs_none(Model, rng):
    # before: scikit-learn's "Expected 2D array, got scalar array instead: array=None"
    _, y = _arx_system(rng, n=50)
    with pytest.raises(ValueError, match=f"X is None; {Model.__name__} expects the inputs"):
        Model().fit(None, y)


@pytest.mark.parametrize("sizes", [(), [], (0,), (8, -1), (2.5,), "32", None, (True,), (2**70,)])
def test_nnarx_bad_hidden_layer_sizes(sizes, rng):
    # before: () fitted, then predict failed with a matmul error
    u, y = _arx_system(rng, n=50)
    with pytest.raises(ValueError, match=r"hidden_layer_sizes = .*expected a non-empty tuple of integers in \[1, 1000"):
        NNARX(hidden_layer_sizes=sizes).fit(u, y)


@pytest.mark.parametrize("sizes", [4, (3, 2), [5], (np.int64(4),)])
def test_nnarx_good_hidden_layer_sizes(sizes, rng):
    u, y = _arx_system(rng, n=60)
    model = NNARX(hidden_layer_sizes=sizes, max_iter=20, random_state=0).fit(u, y)
    assert np.isfinite(model.predict(u, y_init=y)).all()


def test_nnarx_beats_arx_on_a_nonlinear_system(rng):
    u, y = _nonlinear_system(rng, n=400)
    u_test, y_test = _nonlinear_system(np.random.default_rng(3), n=300)
    settings = dict(na=1, nb=1, hidden_layer_sizes=(8,), max_iter=200)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        nn, again, other = (NNARX(**settings, random_state=seed).fit(u, y) for seed in (0, 0, 1))
    arx = ARX(na=1, nb=1).fit(u, y)
    r2_nn = r2(y_test, nn.predict(u_test, y_init=y_test))
    assert r2_nn > 0.999 and r2_nn > r2(y_test, arx.predict(u_test, y_init=y_test)) + 0.05
    assert nn.n_iter_ >= 1 and nn.mlp_.n_features_in_ == 2
    # seeded: the same network twice, another seed another one
    np.testing.assert_array_equal(again.predict(u_test, y_init=y_test), nn.predict(u_test, y_init=y_test))
    assert not np.array_equal(other.predict(u_test, y_init=y_test), nn.predict(u_test, y_init=y_test))


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_nnarx_does_not_depend_on_the_blas_thread_count(dtype, rng):
    """Trained with one BLAS thread whatever the caller allows: 1 or 2 threads give the same network.

    (Matrices this large are split between OpenBLAS threads, and a split changes the
    rounding, which L-BFGS amplifies over its iterations.)
    """
    from threadpoolctl import threadpool_limits

    u, y = _nonlinear_system(rng, n=6000)
    u_test, y_test = _nonlinear_system(np.random.default_rng(3), n=300)
    fits = []
    for threads in (1, 2):
        with threadpool_limits(limits=threads, user_api="blas"), warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            fits.append(NNARX(na=2, nb=2, hidden_layer_sizes=(32,), max_iter=60, dtype=dtype, random_state=0).fit(u, y))
    np.testing.assert_array_equal(fits[0].mlp_.coefs_[0], fits[1].mlp_.coefs_[0])
    assert r2(y_test, fits[0].predict(u_test, y_init=y_test)) > 0.99


@pytest.mark.parametrize("residual, n_estimators", [(False, 1), (True, 1), (True, 3)])
def test_nnarx_simulation_matches_the_network(residual, n_estimators, rng):
    """The hand-rolled free run equals feeding linear part + mean of MLPRegressor.predict its own outputs."""
    u, y = _nonlinear_system(rng, n=120)
    model = NNARX(na=2, nb=2, nk=1, hidden_layer_sizes=(6, 5), activation="relu", random_state=0,
                  max_iter=50, residual=residual, n_estimators=n_estimators)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        model.fit(u, y)
    assert len(model.estimators_) == n_estimators and model.mlp_ is model.estimators_[0]
    assert np.any(model.linear_coef_ != 0) == residual
    y_sim = model.predict(u, y_init=y)
    ys = (y - model.y_mean_) / model.y_scale_
    us = (u - model.u_mean_) / model.u_scale_
    expected = ys.copy()
    for t in range(n_lags(2, 2, 1), len(u)):
        features = np.array([[expected[t - 1, 0], expected[t - 2, 0], us[t - 1, 0], us[t - 2, 0]]])
        networks = np.mean([net.predict(features) for net in model.estimators_], axis=0)
        expected[t] = networks + features @ model.linear_coef_[:, 0] + model.linear_intercept_
    np.testing.assert_allclose(y_sim, expected * model.y_scale_ + model.y_mean_, atol=1e-10)


def test_nnarx_residual_with_a_huge_penalty_is_the_arx(rng):
    """The networks of the residual structure only correct the linear ARX part."""
    u, y = _nonlinear_system(rng, n=300)
    arx = ARX(na=2, nb=2).fit(u, y)
    nn = NNARX(na=2, nb=2, hidden_layer_sizes=(4,), alpha=1e6, n_estimators=2, random_state=0).fit(u, y)
    y_arx = arx.predict(u, y_init=y)
    assert np.abs(nn.predict(u, y_init=y) - y_arx).max() < 1e-5 * np.ptp(y)
    # free networks do correct it: the nonlinear system is simulated better than by the ARX
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        free = NNARX(na=2, nb=2, hidden_layer_sizes=(8,), alpha=1e-4, max_iter=200, random_state=0).fit(u, y)
    assert rmse(y, free.predict(u, y_init=y)) < 0.2 * rmse(y, y_arx)


def test_orders_chosen_by_tune(rng):
    u, y = _arx_system(rng, noise=0.02)
    space = {"na": IntRange(1, 4), "nb": IntRange(1, 4), "nk": IntRange(0, 3)}
    best, study = tune(ARX(), space, u, y, n_trials=40, random_state=0)
    assert best.nk == 2 and best.na >= 2
    assert study.best_value < 0.03


def test_arx_on_the_cascaded_tanks(data_home):
    """The study's protocol: orders by tune on the last 256 estimation samples, test from 5 samples."""
    from sindybench.datasets import load_cascaded_tanks

    data = load_cascaded_tanks(data_home=data_home, download_if_missing=False)
    est, test = data.estimation, data.test
    space = {"na": IntRange(1, data.n_init), "nb": IntRange(1, data.n_init - 1), "nk": IntRange(0, 1)}
    best, study = tune(ARX(), space, est.u, est.y, cv=HoldoutSplit(validation_size=len(data.validation.y)),
                       n_trials=25, random_state=0)
    assert best.n_lags_ <= data.n_init
    test_rmse = rmse(test.y, best.predict(test.u, y_init=test.y[: data.n_init]))
    # the study reports 0.77 V; every order in the space stays below 0.9 V
    assert 0.5 < test_rmse < 0.85
    assert 0.7 < study.best_value < 1.0


def _tune_nnarx_on_the_tanks(data, space, n_trials, seed, **settings):
    """Tune on the last 256 estimation samples, refit on the first 768, test RMSE from 5 samples."""
    est, test = data.estimation, data.test
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        best, study = tune(NNARX(random_state=seed, **settings), space, est.u, est.y,
                           cv=HoldoutSplit(validation_size=len(data.validation.y)), n_trials=n_trials,
                           random_state=seed)
        trained = clone(best).fit(data.train.u, data.train.y)
    return study.best_value, rmse(test.y, trained.predict(test.u, y_init=test.y[: data.n_init]))


def test_nnarx_on_the_cascaded_tanks(data_home):
    """A small search of the residual NN-ARX beats the ARX (0.84 V validation, 0.70-0.75 V test)."""
    from sindybench.datasets import load_cascaded_tanks

    data = load_cascaded_tanks(data_home=data_home, download_if_missing=False)
    space = {"na": IntRange(1, data.n_init), "nb": IntRange(1, data.n_init), "alpha": LogUniform(0.1, 10.0)}
    validation, test_rmse = _tune_nnarx_on_the_tanks(data, space, 15, 0, hidden_layer_sizes=(16,))
    assert validation < 0.8
    assert test_rmse < 0.72  # the plain network of the same search: about 1 V


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_nnarx_on_the_cascaded_tanks_full_search(data_home, seed):
    """The search of examples/baselines_tanks.py (40 trials): the study reports 0.47 V, ARX 0.77 V."""
    from sindybench.datasets import load_cascaded_tanks

    data = load_cascaded_tanks(data_home=data_home, download_if_missing=False)
    space = {"na": IntRange(1, data.n_init), "nb": IntRange(1, data.n_init), "nk": IntRange(0, 1),
             "activation": Categorical(["tanh", "relu"]),
             "hidden_layer_sizes": Categorical([(4,), (8,), (16,), (32,)]), "alpha": LogUniform(0.1, 10.0)}
    validation, test_rmse = _tune_nnarx_on_the_tanks(data, space, 40, seed)
    assert validation < 0.8  # ARX: 0.84 V
    assert test_rmse < 0.72  # ARX: 0.70-0.75 V; a plain network (residual=False): 0.9-1.2 V


@pytest.mark.parametrize("model", [ARX(na=1, nb=1), NNARX(na=1, nb=1, random_state=0)], ids=["ARX", "NNARX"])
def test_predict_warns_when_the_free_run_diverges(model):
    # y[k+1] = 3 y[k] + u[k]: the fitted free run grows as 3^k, past the float range within 2000 samples
    u = np.ones((60, 1))
    y = np.zeros(60)
    for k in range(59):
        y[k + 1] = 3.0 * y[k] + u[k, 0] if k < 20 else 0.5 * y[k] + u[k, 0]
    model.fit(u[:20], y[:20])
    with pytest.warns(DivergenceWarning, match=f"{type(model).__name__}.predict: the simulation diverged at "
                      "sample") as record:
        y_pred = model.predict(np.ones((2000, 1)), y_init=y[:3])
    first = int(np.argmax(~np.isfinite(y_pred)))
    assert 3 < first < 2000 and np.isfinite(y_pred[:first]).all()
    assert f"at sample {first} of 2000;" in str(record[0].message)


@pytest.mark.parametrize("make", [lambda: ARX(na=2, nb=2, nk=1),
                                  lambda: NNARX(na=2, nb=2, nk=2, hidden_layer_sizes=(6,), n_estimators=2, max_iter=50,
                                                random_state=0)])
def test_k_step_prediction_is_the_free_run_from_each_origin(make):
    rng = np.random.default_rng(0)
    u = rng.uniform(-1, 1, (120, 2))
    y = np.zeros((120, 2))
    for t in range(2, 120):
        y[t] = 0.5 * y[t - 1] - 0.1 * y[t - 2] + np.tanh(u[t - 1]) + 0.1 * y[t - 1, ::-1]
    model = make().fit(u, y)
    k, n0 = 4, model.n_lags_
    pred = model.predict_k_step(u, y, k)
    for j in range(k, 120):
        s = max(j - k + 1, n0)  # the first simulated sample of the prediction of y[j]
        ref = y[j] if j < n0 else model.simulate(u[s - n0:j + 1], y_init=y[s - n0:s])[-1]
        assert np.allclose(pred[j - k], ref)
    one = model.predict_k_step(u, y, 1)  # the one-step predictor the model was fitted with
    phi, target = lagged_regressors(u, y, model.na, model.nb, model.nk)
    assert np.allclose(one[n0 - 1:], model._one_step(phi))
    with pytest.raises(ValueError, match="k must be"):
        model.predict_k_step(u, y, 0)
    with pytest.raises(ValueError, match="y has shape"):
        model.predict_k_step(u, y[:, :1], 2)

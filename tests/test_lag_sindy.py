"""LagSINDy: discrete-time SINDy on delay coordinates (a sparse polynomial NARX)."""

import numpy as np
import pytest

from sindybench import STLS, LagSINDy, load_model
from sindybench._lags import lag_dynamics, lag_states
from sindybench.estimation import extended_kalman_filter, predict_k_step
from sindybench.libraries import PolynomialLibrary
from sindybench.optimizers import ForwardOLS
from sindybench.refine import OutputErrorRefinement


def _narx(u, delay=1, n_samples=None):
    """``y[k+1] = 1.2 y[k] - 0.5 y[k-1] - 0.1 y[k]^2 + 0.3 u[k-delay] + 0.05 y[k] u[k-delay]``."""
    n = u.shape[0] if n_samples is None else n_samples
    y = np.zeros((n, 1))
    for k in range(1, n - 1):
        v = u[k - delay, 0] if k >= delay else u[0, 0]
        y[k + 1] = 1.2 * y[k] - 0.5 * y[k - 1] - 0.1 * y[k] ** 2 + 0.3 * v + 0.05 * y[k] * v
    return y


@pytest.fixture
def rng():
    return np.random.default_rng(0)


@pytest.fixture
def record(rng):
    u = rng.uniform(-1.0, 1.0, (600, 1))
    return u, _narx(u)


def _exact(**params):
    return LagSINDy(library=PolynomialLibrary(degree=2), optimizer=STLS(threshold=0.01), normalize=False, dt=0.1,
                    **params)


def test_recovers_a_sparse_narx_exactly(record):
    u, y = record
    model = _exact(output_lags=2, input_lags=2).fit(u, y)
    truth = {"y0[k]": 0.2, "y0[k-1]": -0.5, "y0[k]^2": -0.1, "u0[k-1]": 0.3, "y0[k] u0[k-1]": 0.05}
    found = {name: c for name, c in zip(model.feature_names_, model.coef_[0]) if c != 0}
    assert sorted(found) == sorted(truth)  # the increment y[k+1] - y[k]: 1.2 - 1 on y[k]
    np.testing.assert_allclose([found[k] for k in sorted(truth)], [truth[k] for k in sorted(truth)], atol=1e-9)
    assert model.equations(precision=2) == [
        "y0[k+1] = 1.20 y0[k] - 0.50 y0[k-1] + 0.30 u0[k-1] - 0.1 y0[k]^2 + 0.05 y0[k] u0[k-1]"]
    assert model.score(u, y) > 1 - 1e-12


def test_input_delay_names_the_lagged_input(rng):
    u = rng.uniform(-1.0, 1.0, (600, 1))
    y = _narx(u, delay=3)
    model = _exact(output_lags=2, input_lags=1, input_delay=3).fit(u, y)
    assert model.equations(precision=2) == [
        "y0[k+1] = 1.20 y0[k] - 0.50 y0[k-1] + 0.30 u0[k-3] - 0.1 y0[k]^2 + 0.05 y0[k] u0[k-3]"]
    np.testing.assert_allclose(model.predict(u, y_init=y[:5]), y, atol=1e-9)


def test_euler_form_is_the_difference_equation(rng):
    """One Euler step per sample with the input held: exactly the lag model's recursion (to rounding)."""
    na, nb, n_out, n_in, dt = 3, 3, 2, 2, 0.01
    n_states = n_out * na + n_in * (nb - 1)
    library = PolynomialLibrary(degree=2).fit(np.zeros((1, n_states + n_in)))
    coef = rng.normal(scale=0.01, size=(library.n_output_features_, n_out))
    dyn = lag_dynamics(library, coef, n_outputs=n_out, n_inputs=n_in, na=na, nb=nb, dt=dt)
    assert (dyn.method, dyn.n_substeps, dyn.input_hold, dyn.dt, dyn.compiled) == ("euler", 1, "zoh", dt, True)
    u = rng.uniform(-1.0, 1.0, (60, n_in))
    y = np.zeros((60, n_out))
    y[:3] = rng.uniform(-0.5, 0.5, (3, n_out))
    for k in range(2, 59):  # the recursion by hand from the delay coordinates
        z = np.hstack([lag_states(u[: k + 1], y[: k + 1], na, nb)[k], u[k]])
        y[k + 1] = y[k] + library.transform(z[None, :])[0] @ coef
    x = dyn.simulate(u[2:], lag_states(u[:3], y[:3], na, nb)[2])
    np.testing.assert_allclose(x[:, list(dyn.output_index)], y[2:], rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(x[:, [1, 4]], y[1:-1], rtol=1e-12, atol=1e-13)  # the delay line: y[k-1]


def test_auto_lags_choose_the_true_orders(record):
    u, y = record
    model = _exact(output_lags="auto", input_lags="auto", max_lags=3).fit(u, y)
    assert (model.output_lags_, model.input_lags_) == (2, 2)
    assert len(model.lag_search_) == 9
    errors = {(r["output_lags"], r["input_lags"]): r["error"] for r in model.lag_search_}
    assert errors[(2, 2)] < 1e-8 < errors[(1, 2)]


def test_model_file_round_trip(record, tmp_path):
    u, y = record
    model = _exact(output_lags=2, input_lags=2, refine=OutputErrorRefinement(max_nfev=5)).fit(u, y)
    path = tmp_path / "narx.json"
    model.to_json(path)
    loaded = load_model(path)
    assert isinstance(loaded, LagSINDy)
    assert loaded.equations() == model.equations()
    assert (loaded.output_lags_, loaded.input_lags_, loaded.dt_) == (2, 2, 0.1)
    np.testing.assert_array_equal(loaded.predict(u, y_init=y[:5]), model.predict(u, y_init=y[:5]))


def test_kalman_filter_and_k_step_prediction(record, rng):
    u, y = record
    model = _exact(output_lags=2, input_lags=2).fit(u, y)
    y_noisy = y + 0.001 * rng.standard_normal(y.shape)
    Q, R = 1e-8 * np.eye(model.n_states_), 1e-6 * np.eye(1)
    result = extended_kalman_filter(model, u, y_noisy, Q=Q, R=R)
    assert np.sqrt(np.mean((result.states[:, :1] - y) ** 2)) < 0.001  # the filter removes part of the noise
    y_pred = predict_k_step(model, u, y_noisy, 5, Q=Q, R=R)
    assert y_pred.shape == (595, 1)
    assert np.sqrt(np.mean((y_pred - y[5:]) ** 2)) < 0.002


def test_refinement_improves_the_free_run_on_noisy_data(rng):
    u = rng.uniform(-1.0, 1.0, (800, 1))
    y = _narx(u)
    y_noisy = y + 0.02 * np.std(y) * rng.standard_normal(y.shape)
    u_test = rng.uniform(-1.0, 1.0, (400, 1))
    y_test = _narx(u_test)
    params = dict(library=PolynomialLibrary(degree=2), output_lags=2, input_lags=2, dt=0.1)
    plain = LagSINDy(**params).fit(u, y_noisy)
    refined = LagSINDy(**params, refine=OutputErrorRefinement(max_nfev=20)).fit(u, y_noisy)
    error = lambda m: np.sqrt(np.mean((m.predict(u_test, y_init=y_test[:5]) - y_test) ** 2))  # noqa: E731
    assert refined.refinement_["status"] >= 0 and refined.refinement_["start"] == "one-step"
    assert error(refined) < error(plain)


def test_predict_from_y_init_starts_from_the_measured_lags(record):
    u, y = record
    model = _exact(output_lags=2, input_lags=3).fit(u, y)
    y_pred = model.predict(u[100:], y_init=y[100:103])
    np.testing.assert_array_equal(y_pred[:2], y[100:102])  # the first max(na, nb) - 1 samples are measured
    np.testing.assert_allclose(y_pred, y[100:], atol=1e-9)
    x0 = model.estimate_initial_state(u[100:], y[100:103])
    assert x0.tolist() == [y[100, 0], y[100, 0], u[100, 0], u[100, 0]]  # held before the first sample


@pytest.mark.parametrize("params, match", [
    ({"output_lags": 0}, "output_lags must be an integer >= 1 or 'auto'; got 0"),
    ({"input_lags": -1}, "input_lags must be an integer >= 1 or 'auto'; got -1"),
    ({"output_lags": 1.5}, "output_lags must be an integer >= 1 or 'auto'; got 1.5"),
    ({"max_lags": 0}, "max_lags must be an integer >= 1"),
    ({"validation_fraction": 0.8}, r"validation_fraction must be a number in \(0, 0.5\]; got 0.8"),
    ({"dt": -1.0}, "dt"),
])
def test_bad_parameters(record, params, match):
    u, y = record
    with pytest.raises(ValueError, match=match):
        LagSINDy(**params).fit(u, y)


def test_too_few_samples():
    u, y = np.zeros((3, 1)), np.ones((3, 1))
    with pytest.raises(ValueError, match="y has 3 samples; expected at least 4"):
        LagSINDy(output_lags=3, input_lags=1).fit(u, y)
    with pytest.raises(ValueError, match="y has 3 samples; expected at least 10 to choose the lags"):
        LagSINDy(output_lags="auto", max_lags=3).fit(u, y)


def test_linear_start_refits_the_supports_linear_terms(rng):
    from sindybench._lag_sindy import _linear_start

    Z = rng.normal(size=(200, 2))
    target = (1.0 + 2.0 * Z[:, 0] - 0.5 * Z[:, 1])[:, None]
    library = PolynomialLibrary(degree=2).fit(Z)  # 1, z0, z1, z0^2, z0 z1, z1^2
    coef = np.array([[0.3], [1.0], [0.2], [5.0], [0.0], [-2.0]])  # a support with two quadratic terms
    start = _linear_start(library, coef, Z, target)
    np.testing.assert_allclose(start[:, 0], [1.0, 2.0, -0.5, 0.0, 0.0, 0.0], atol=1e-12)


def test_library_input_is_the_regression_input(record):
    u, y = record
    model = _exact(output_lags=2, input_lags=2, input_delay=1).fit(u, y)
    Z = model.library_input(u, y)
    assert Z.shape == (600, 4)  # y[k], y[k-1], u[k-2], and the input u[k-1]
    np.testing.assert_array_equal(Z[5], [y[5, 0], y[4, 0], u[3, 0], u[4, 0]])
    increments = model.library_.transform(Z[1:-1]) @ model.coef_[0]
    np.testing.assert_allclose(increments, (y[2:] - y[1:-1])[:, 0], atol=1e-9)


def test_conformal_band_and_standard_errors(rng):
    from sindybench.uncertainty import conformal_calibration, standard_errors

    u = rng.uniform(-1.0, 1.0, (800, 1))
    y_noisy = _narx(u) + 0.01 * rng.standard_normal((800, 1))
    model = LagSINDy(library=PolynomialLibrary(degree=2), dt=0.1,
                     refine=OutputErrorRefinement(max_nfev=10)).fit(u[:600], y_noisy[:600])
    calibration = conformal_calibration(model, u[600:], y_noisy[600:], alpha=0.1)
    assert 0.01 < calibration.half_width[0] < 0.03  # about 1.645 times the noise's 0.01
    band = calibration.band(model, u[600:], y_init=y_noisy[600:610])
    assert band.lower.shape == (200, 1) and np.all(band.lower < band.upper)
    errors = standard_errors(model)
    assert "y0': u0[k-1]" in errors and 0 < errors["y0': u0[k-1]"] < 0.05  # the increment's over dt


def _narx_lead(u):
    """``y[k+1] = 1.2 y[k] - 0.5 y[k-1] - 0.1 y[k]^2 + 0.2 u[k+1] + 0.3 u[k]``: the next input drives it."""
    y = np.zeros((u.shape[0], 1))
    for k in range(1, u.shape[0] - 1):
        y[k + 1] = 1.2 * y[k] - 0.5 * y[k - 1] - 0.1 * y[k] ** 2 + 0.2 * u[k + 1, 0] + 0.3 * u[k, 0]
    return y


def _greedy(**params):
    return LagSINDy(library=PolynomialLibrary(degree=2), optimizer=ForwardOLS(n_terms=5, center=True),
                    normalize=False, dt=0.1, target="next", **params)


def test_next_target_fits_the_same_model_as_the_increment(record):
    u, y = record
    y_noisy = y + 0.01 * np.random.default_rng(1).standard_normal(y.shape)
    increment = _exact(output_lags=2, input_lags=2).set_params(optimizer=STLS(threshold=0.0)).fit(u, y_noisy)
    following = _exact(output_lags=2, input_lags=2, target="next").set_params(optimizer=STLS(threshold=0.0))
    np.testing.assert_allclose(following.fit(u, y_noisy).coef_, increment.coef_, atol=1e-9)


def test_lead_and_greedy_selection_recover_a_feedthrough_narx(rng):
    u = rng.uniform(-1.0, 1.0, (600, 1))
    y = _narx_lead(u)
    model = _greedy(output_lags=2, input_lags=2, input_delay=-1).fit(u, y)
    truth = {"1": 0.0, "y0[k]": 0.2, "y0[k-1]": -0.5, "y0[k]^2": -0.1, "u0[k]": 0.3, "u0[k+1]": 0.2}
    found = {name: c for name, c in zip(model.feature_names_, model.coef_[0]) if c != 0}
    assert set(found) <= set(truth) and set(truth) - set(found) <= {"1"}  # the intercept is kept beside the 5 terms
    np.testing.assert_allclose([found.get(k, 0.0) for k in truth], list(truth.values()), atol=1e-9)
    assert model.equations(precision=2)[0].endswith(
        "1.20 y0[k] - 0.50 y0[k-1] + 0.30 u0[k] + 0.20 u0[k+1] - 0.1 y0[k]^2")
    assert model.optimizer_.order_[0][0] == 1  # the output's own last sample is chosen first (target "next")
    np.testing.assert_allclose(model.predict(u, y_init=y[:5]), y, atol=1e-9)
    # without the lead the same selection cannot reach the truth
    assert _greedy(output_lags=2, input_lags=2).fit(u, y).score(u, y) < 1 - 1e-6


def test_lead_model_round_trip_filter_and_k_step(rng, tmp_path):
    u = rng.uniform(-1.0, 1.0, (600, 1))
    y = _narx_lead(u)
    model = _greedy(output_lags=2, input_lags=2, input_delay=-1, refine=OutputErrorRefinement(max_nfev=5)).fit(u, y)
    path = tmp_path / "lead.json"
    model.to_json(path)
    loaded = load_model(path)
    assert loaded.equations() == model.equations() and loaded.input_delay == -1
    assert loaded.optimizer_.order_ == model.optimizer_.order_
    np.testing.assert_array_equal(loaded.predict(u, y_init=y[:5]), model.predict(u, y_init=y[:5]))
    y_noisy = y + 0.001 * rng.standard_normal(y.shape)
    Q, R = 1e-8 * np.eye(model.n_states_), 1e-6 * np.eye(1)
    y_pred = predict_k_step(model, u, y_noisy, 5, Q=Q, R=R)
    assert np.sqrt(np.mean((y_pred - y[5:]) ** 2)) < 0.002  # the filter sees u[k+1] as the model does


@pytest.mark.parametrize("params, match", [
    ({"target": "level"}, r"target must be one of \['increment', 'next'\]; got 'level'"),
    ({"input_delay": -2}, "input_delay"),
])
def test_bad_target_and_lead(record, params, match):
    u, y = record
    with pytest.raises(ValueError, match=match):
        LagSINDy(**params).fit(u, y)


def test_next_target_needs_the_outputs_own_term(record):
    from sindybench.libraries import TermsLibrary

    u, y = record
    library = TermsLibrary(terms=[[[1, 0, 1, 0]], [[2, 0, 1, 0]]])  # y0[k-1] and u0[k-1], not y0[k]
    with pytest.raises(ValueError, match="target='next' needs a library with the linear term"):
        LagSINDy(library=library, output_lags=2, input_lags=2, target="next", normalize=False).fit(u, y)


def test_param_grid_searches_the_number_of_terms_with_the_lags(rng):
    u = rng.uniform(-1.0, 1.0, (800, 1))
    y = _narx_lead(u)
    model = _greedy(output_lags="auto", input_lags=2, input_delay=-1, max_lags=3,
                    param_grid={"n_terms": [3, 5, 8]}).fit(u, y)
    assert (model.output_lags_, model.optimizer_.n_terms) == (2, 5)  # the truth; 8 terms fit as well: 5 come first
    assert len(model.lag_search_) == 9 and {row["params"]["n_terms"] for row in model.lag_search_} == {3, 5, 8}
    errors = {(r["output_lags"], r["params"]["n_terms"]): r["error"] for r in model.lag_search_}
    assert errors[(2, 5)] < 1e-8 < errors[(2, 3)]


@pytest.mark.parametrize("grid, match", [
    ({"n_terms": []}, "param_grid must be a dict of non-empty lists"),
    ([8, 16], "param_grid must be a dict of non-empty lists"),
    ({"depth": [1]}, "depth"),
])
def test_bad_param_grid(rng, grid, match):
    u = rng.uniform(-1.0, 1.0, (200, 1))
    with pytest.raises(ValueError, match=match):
        _greedy(output_lags="auto", param_grid=grid).fit(u, _narx_lead(u))

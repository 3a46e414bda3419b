"""SINDy with control: recovery, simulation, scoring, searches, bad input."""

import pickle
import warnings

import numpy as np
import pysindy as ps
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.model_selection import GridSearchCV

from sindybench import STLS, DivergenceWarning, SimulationError, SINDy
from sindybench.libraries import CustomLibrary, PolynomialLibrary
from sindybench.libraries._terms import POW
from sindybench.metrics import r2
from sindybench.simulate import TermsRHS, simulate

DT = 0.01
Y0, Y1, U0 = ((0, POW, 1, 0),), ((1, POW, 1, 0),), ((2, POW, 1, 0),)
# y0' = -2 y0 + y1 + u0 ;  y1' = -y1 - 0.5 y0^2 + 0.8 u0
TRUE_RHS = TermsRHS.from_equations(
    [{Y0: -2.0, Y1: 1.0, U0: 1.0}, {Y1: -1.0, ((0, POW, 2, 0),): -0.5, U0: 0.8}]
)
# the same coefficients laid out on PolynomialLibrary(degree=2) over [y0, y1, u0]:
# 1, y0, y1, u0, y0^2, y0 y1, y0 u0, y1^2, y1 u0, u0^2
TRUE_COEF = np.zeros((2, 10))
TRUE_COEF[0, [1, 2, 3]] = [-2.0, 1.0, 1.0]
TRUE_COEF[1, [2, 3, 4]] = [-1.0, 0.8, -0.5]


def _inputs(rng, n):
    t = np.arange(n) * DT
    freqs = rng.uniform(0.2, 2.0, size=4)
    return (np.sin(np.outer(t, freqs) + rng.uniform(0, 6, size=4)).sum(axis=1))[:, None]


def _data(rng, n=3000):
    u = _inputs(rng, n)
    y = simulate(TRUE_RHS, [0.5, -0.2], u, dt=DT, n_substeps=4, input_hold="linear")
    return u, y


def _model(**kw):
    params = dict(library=PolynomialLibrary(degree=2), optimizer=STLS(threshold=0.05), dt=DT, input_hold="linear")
    params.update(kw)
    return SINDy(**params)


@pytest.fixture
def data(rng):
    return _data(rng)


def test_recovers_controlled_system(data):
    u, y = data
    model = _model().fit(u, y)
    assert model.coef_.shape == (2, 10)
    assert np.array_equal(model.coef_ != 0, TRUE_COEF != 0)
    np.testing.assert_allclose(model.coef_, TRUE_COEF, atol=2e-3)
    assert model.feature_names_[4] == "y0^2"
    assert model.terms_ == model.library_.terms_


def test_exact_derivatives_give_exact_coefficients(data):
    u, y = data
    x_dot = np.array([TRUE_RHS(x, v) for x, v in zip(y, u)])
    model = _model().fit(u, y, x_dot=x_dot)
    np.testing.assert_allclose(model.coef_, TRUE_COEF, atol=1e-9)


def test_simulation_on_new_inputs(rng, data):
    model = _model().fit(*data)
    u_test, y_test = _data(np.random.default_rng(7), n=2000)
    y_sim = model.predict(u_test, y_init=y_test)
    assert r2(y_test, y_sim) > 0.999
    assert model.score(u_test, y_test) == pytest.approx(r2(y_test, y_sim))
    np.testing.assert_array_equal(model.predict(u_test, x0=y_test[0]), y_sim)
    np.testing.assert_array_equal(model.simulate(u_test, x0=y_test[0]), y_sim)


@pytest.mark.parametrize("settings", [dict(integrator="euler"), dict(n_substeps=3), dict(input_hold="zoh"),
                                      dict(bounds=(-0.3, 0.3))])
def test_simulation_settings_reach_the_simulator(data, settings):
    u, y = data
    model = _model(**settings).fit(u, y)
    x0 = np.clip(y[0], -0.3, 0.3)
    expected = simulate(
        TermsRHS(model.coef_.T, model.terms_, 2), x0, u, dt=DT,
        n_substeps=model.n_substeps, method=model.integrator, input_hold=model.input_hold, bounds=model.bounds,
    )
    np.testing.assert_allclose(model.simulate(u, x0=x0), expected, rtol=1e-12, atol=1e-14)
    if "bounds" in settings:
        assert model.simulate(u, x0=x0).max() <= 0.3
        assert y.max() > 0.3


def test_custom_library_simulates_on_python_path(data):
    u, y = data
    lib = CustomLibrary(functions=[lambda a: a, lambda a: a**2], names=["{}", "{}^2"], compile=False)
    model = _model(library=lib).fit(u[:800], y[:800])
    assert model.terms_ is None
    reference = _model(library=PolynomialLibrary(degree=2, include_bias=False, interaction_only=False)).fit(u[:800], y[:800])
    assert model.score(u[:800], y[:800]) > 0.99
    assert model.score(u[:800], y[:800]) == pytest.approx(reference.score(u[:800], y[:800]), abs=1e-3)


def test_pysindy_library_and_differentiation_are_accepted(data):
    u, y = data
    model = _model(library=ps.PolynomialLibrary(degree=2), differentiation=ps.SmoothedFiniteDifference())
    model.fit(u[:600], y[:600])
    assert model.terms_ is None
    assert model.score(u[:600], y[:600]) > 0.99


def test_dt_t_and_fit_dt_agree(data):
    u, y = data
    by_ctor = _model().fit(u, y).coef_
    by_fit = _model(dt=None).fit(u, y, dt=DT).coef_
    by_t = _model(dt=123.0).fit(u, y, t=np.arange(len(y)) * DT).coef_
    np.testing.assert_allclose(by_fit, by_ctor, rtol=1e-12)
    np.testing.assert_allclose(by_t, by_ctor, rtol=1e-9, atol=1e-12)


def test_fit_dt_does_not_change_the_parameter(data):
    model = _model(dt=None).fit(*data, dt=DT)
    assert model.dt is None
    assert model.dt_ == DT


def test_nonuniform_t(rng):
    t = np.cumsum(rng.uniform(0.5, 1.5, size=2000)) * DT
    y = np.exp(-0.7 * t)[:, None]
    model = SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.05)).fit(None, y, t=t)
    assert model.dt_ is None
    np.testing.assert_allclose(model.coef_, [[0.0, -0.7]], atol=1e-3)
    np.testing.assert_allclose(model.simulate(None, x0=y[0], t=t), y, atol=1e-4)
    with pytest.raises(ValueError, match="dt is None"):
        model.simulate(np.zeros((10, 0)), x0=y[0])


def test_autonomous_system(rng):
    t = np.arange(1500) * DT
    y = np.column_stack([np.cos(2 * t), -2 * np.sin(2 * t)])  # y0' = y1, y1' = -4 y0
    model = _model().fit(np.zeros((len(t), 0)), y)
    assert model.n_inputs_ == 0
    assert model.equations(precision=2) == ["y0' = 1.00 y1", "y1' = -4.00 y0"]
    np.testing.assert_allclose(model.simulate(None, x0=y[0], t=t), y, atol=1e-2)
    np.testing.assert_allclose(model.predict(np.zeros((1500, 0)), y_init=y[:1]), model.simulate(None, x0=y[0], t=t),
                               rtol=1e-9)


def test_equations_format(data):
    model = _model(output_names=["p", "q"], input_names=["force"]).fit(*data)
    lines = model.equations(precision=1)
    assert lines == ["p' = -2.0 p + 1.0 q + 1.0 force", "q' = -1.0 q + 0.8 force - 0.5 p^2"]
    model.coef_ = np.zeros_like(model.coef_)
    model.coef_[0, 0] = 0.25
    assert model.equations(precision=2) == ["p' = 0.25", "q' = 0"]


def test_grid_search_over_threshold(data):
    u, y = data
    cv = [(np.arange(0, 2000), np.arange(2000, 3000))]
    search = GridSearchCV(_model(), {"optimizer__threshold": [0.05, 1.5]}, cv=cv).fit(u, y)
    assert search.best_params_ == {"optimizer__threshold": 0.05}
    assert search.cv_results_["mean_test_score"][0] > 0.999
    assert search.cv_results_["mean_test_score"][1] < 0.9
    assert np.count_nonzero(search.best_estimator_.coef_) == 6


def test_divergence(rng):
    t = np.arange(400) * DT
    y = np.exp(0.5 * t)[:, None]
    model = SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.05), dt=DT, max_abs=100.0)
    model.fit(None, y)
    long = np.zeros((2000, 0))
    with pytest.raises(SimulationError, match="diverged") as info:
        model.simulate(long, x0=y[0])
    assert 900 < info.value.step < 1000  # exp(0.5 t) passes 100 at t = 9.2
    with pytest.warns(DivergenceWarning, match=f"SINDy.predict: the simulation diverged at sample {info.value.step} "
                      "of 2000"):
        y_pred = model.predict(long, x0=y[0])
    assert np.isfinite(y_pred[: info.value.step]).all() and np.isnan(y_pred[info.value.step :]).all()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # score reports the divergence as -inf, without a warning
        assert model.score(long, np.ones((2000, 1)) + rng.normal(size=(2000, 1))) == -np.inf


def test_old_simulate_spelling_warns_and_gives_the_same(data):
    u, y = data
    model = _model().fit(u[:500], y[:500])
    with pytest.warns(FutureWarning, match=r"simulate\(X, x0=x0\)"):
        old = model.simulate(u[:300], y[0])
    np.testing.assert_array_equal(old, model.simulate(u[:300], x0=y[0]))
    np.testing.assert_array_equal(model.simulate(u[:300], y_init=y[:5]), old)  # y_init[0] starts it
    assert model.dynamics_.n_states == model.n_states_ == 2 and model.output_index_ == (0, 1)
    assert model.state_names_ == model.output_names_ == ["y0", "y1"]


def test_failed_fit_leaves_the_model_unfitted(data):
    u, y = data
    model = _model()
    with pytest.raises(ValueError, match="x_dot has 1 columns; expected 2"):
        model.fit(u, y, x_dot=np.zeros((len(y), 1)))
    assert not [k for k in vars(model) if k.endswith("_")]
    with pytest.raises(NotFittedError):
        model.predict(u, y_init=y)


def test_predict_initial_state(data):
    u, y = data
    model = _model().fit(u[:500], y[:500])
    with pytest.warns(UserWarning, match="predict without y_init or x0"):
        default = model.predict(u[:500])
    np.testing.assert_array_equal(default, model.predict(u[:500], x0=y[0]))
    with pytest.raises(ValueError, match="give x0 or y_init, not both"):
        model.predict(u, x0=y[0], y_init=y)
    with pytest.raises(ValueError, match="y_init has 1 columns; expected 2"):
        model.predict(u, y_init=y[:, :1])
    with pytest.raises(ValueError, match="x0 has 3 entries; expected 2"):
        model.predict(u, x0=[1.0, 2.0, 3.0])


def test_one_dimensional_output(rng):
    t = np.arange(800) * DT
    u = np.sin(t)[:, None]
    y = simulate(lambda x, v: -x + v, [0.0], u, dt=DT, input_hold="linear")[:, 0]
    model = SINDy(library=PolynomialLibrary(degree=1), dt=DT, input_hold="linear").fit(u, y)
    assert model.predict(u, y_init=y).shape == (800,)
    assert model.simulate(u, x0=y[:1]).shape == (800, 1)


def test_clone_pickle_and_refit_are_consistent(data):
    u, y = data
    model = _model().fit(u[:600], y[:600])
    again = pickle.loads(pickle.dumps(model))
    np.testing.assert_array_equal(again.predict(u[:600], y_init=y), model.predict(u[:600], y_init=y))
    refit = clone(model).fit(u[:600], y[:600])
    np.testing.assert_array_equal(refit.coef_, model.coef_)
    assert model.optimizer_ is not model.optimizer and model.library_ is not model.library


# ------------------------------------------------------------- bad input (item 7)


def test_bad_input_nan(data):
    u, y = data
    y = y.copy()
    y[5, 1] = np.nan
    with pytest.raises(ValueError, match=r"y contains NaN or inf \(first at sample 5\)"):
        _model().fit(u, y)


def test_bad_input_inf_in_inputs(data):
    u, y = data
    u = u.copy()
    u[7] = np.inf
    with pytest.raises(ValueError, match=r"X contains NaN or inf \(first at sample 7\)"):
        _model().fit(u, y)


def test_bad_input_wrong_dimensions(data):
    u, y = data
    with pytest.raises(ValueError, match=r"y has 3 dimensions"):
        _model().fit(u, y[:, :, None])
    with pytest.raises(ValueError, match=r"X is 1-D .* expected 2-D \(n_samples, n_inputs\)"):
        _model().fit(u[:, 0], y)


def test_bad_input_length_mismatch(data):
    u, y = data
    with pytest.raises(ValueError, match="X has 2999 samples and y has 3000; expected the same number"):
        _model().fit(u[1:], y)


@pytest.mark.parametrize("where", ["constructor", "fit"])
@pytest.mark.parametrize("dt", [0.0, -0.01])
def test_bad_input_dt(data, where, dt):
    model = _model(dt=dt) if where == "constructor" else _model(dt=None)
    kwargs = {} if where == "constructor" else {"dt": dt}
    with pytest.raises(ValueError, match=r"dt must be a finite number > 0"):
        model.fit(*data, **kwargs)


def test_bad_input_t_not_increasing(data):
    u, y = data
    t = np.arange(len(y)) * DT
    t[10] = t[9]
    with pytest.raises(ValueError, match=r"t must be strictly increasing; t\[10\]"):
        _model(dt=None).fit(u, y, t=t)


def test_bad_input_fewer_samples_than_terms(data):
    u, y = data
    with pytest.raises(ValueError, match="got 8 samples but 10 library terms"):
        _model().fit(u[:8], y[:8])


@pytest.mark.parametrize(
    "params, match",
    [
        (dict(n_substeps=0), "n_substeps must be an integer >= 1"),
        (dict(integrator="rk45"), "integrator must be one of"),
        (dict(input_hold="cubic"), "input_hold must be one of"),
        (dict(max_abs=0.0), "max_abs must be a number > 0"),
        (dict(bounds=(1.0, 0.0)), "lower bound 1 >= upper bound 0"),
        (dict(output_names=["a"]), "output_names must be a list of 2 strings"),
        (dict(input_names="u"), "input_names must be a list of 1 strings"),
        # before: y1' = ... u0 + ... u0, an input and an output under one name
        (dict(output_names=["a", "u0"]), r"output_names and input_names share 'u0' \(output 1 and input 0\)"),
        (dict(output_names=["a", "a"]), r"share 'a' \(output 0 and output 1\)"),
        (dict(output_names=["a", "b"], input_names=["b"]), r"share 'b' \(output 1 and input 0\)"),
    ],
)
def test_bad_params(data, params, match):
    with pytest.raises(ValueError, match=match):
        _model(**params).fit(*data)


def test_bad_time_arguments(data):
    u, y = data
    with pytest.raises(ValueError, match="give dt or t, not both"):
        _model().fit(u, y, dt=DT, t=np.arange(len(y)) * DT)
    with pytest.raises(ValueError, match="dt is None; pass dt"):
        _model(dt=None).fit(u, y)
    with pytest.raises(ValueError, match=r"x_dot has 1 columns; expected 2"):
        _model().fit(u, y, x_dot=y[:, :1])
    with pytest.raises(ValueError, match="requires y to be passed"):
        _model().fit(u, None)


def test_simulate_checks_inputs(data):
    u, y = data
    model = _model().fit(u[:500], y[:500])
    with pytest.raises(ValueError, match="X has 2 features, but SINDy is expecting 1 features"):
        model.simulate(np.hstack([u, u]), x0=y[0])
    with pytest.raises(ValueError, match="X is None"):
        model.simulate(None, x0=y[0])
    with pytest.raises(ValueError, match="Complex data not supported"):
        model.simulate(u + 1j, x0=y[0])


def test_pysindy_optimizer_is_accepted(data):
    u, y = data
    model = _model(optimizer=ps.STLSQ(threshold=0.05, alpha=0.0)).fit(u[:1500], y[:1500])
    reference = _model().fit(u[:1500], y[:1500])
    np.testing.assert_allclose(model.coef_, reference.coef_, rtol=1e-8, atol=1e-10)


def test_threshold_refits_reuse_the_stls_cache(data):
    from sindybench._stls import _shared, clear_stls_cache

    clear_stls_cache()
    u, y = data
    for threshold in (0.01, 0.05, 0.2):
        _model(optimizer=STLS(threshold=threshold)).fit(u, y)
    assert len(_shared) == 1  # Theta and y' recomputed identically: one factorization
    _model().fit(u, y * 1.01)
    assert len(_shared) == 2


def test_predict_clips_a_measured_start_into_bounds(data):
    u, y = data
    model = _model(bounds=(-0.3, 0.3)).fit(u[:600], y[:600])
    start = np.array([[0.35, -0.1]])  # a noisy sample above the bound
    np.testing.assert_array_equal(model.predict(u[:600], y_init=start), model.simulate(u[:600], x0=[0.3, -0.1]))
    with pytest.raises(ValueError, match="outside bounds"):
        model.simulate(u[:600], x0=start[0])

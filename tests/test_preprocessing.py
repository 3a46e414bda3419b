"""Tests of ``sindybench._preprocessing`` and of the estimator parameters built on it (``input_delay``, ``normalize``)."""

import inspect

import numpy as np
import pytest

from sindybench import STLS, HiddenStateSINDy, SINDy
from sindybench._preprocessing import delay_inputs, feature_map, operating_point
from sindybench.hidden import DerivativeHiddenState
from sindybench.io import model_from_dict, model_to_dict
from sindybench.libraries import PolynomialLibrary, SqrtLibrary
from sindybench.simulate import simulate

DT = 0.01


@pytest.fixture
def rng():
    return np.random.default_rng(0)


def _input(n, rng):
    t = np.arange(n) * DT
    return (np.sin(1.3 * t) + 0.6 * np.sin(3.1 * t + 1.0) + 0.2 * rng.standard_normal(n).cumsum() / np.sqrt(n))[:, None]


def _delayed_system(u, delay, offset=0.0):
    """``y' = -2 (y - offset) + u(t - delay dt)``, simulated exactly on the sample grid (ZOH of the delayed input)."""
    return simulate(lambda x, v: np.array([-2.0 * (x[0] - offset) + v[0]]), [offset], delay_inputs(u, delay), dt=DT,
                    n_substeps=4)


# ---------------------------------------------------------------- the functions
def test_delay_inputs_shifts_and_holds_the_first_sample():
    X = np.arange(12.0).reshape(6, 2)
    assert np.array_equal(delay_inputs(X, 0), X)
    assert np.array_equal(delay_inputs(X, 2), np.vstack([X[:1], X[:1], X[:4]]))
    assert np.array_equal(delay_inputs(X, 10), np.repeat(X[:1], 6, axis=0))
    assert delay_inputs(np.empty((6, 0)), 3).shape == (6, 0)


def test_feature_map_is_the_library_of_the_centred_scaled_data(rng):
    Z = rng.normal([97.0, -3.0], [0.5, 20.0], size=(200, 2))
    library = PolynomialLibrary(degree=3).fit(Z)
    mean, scale = operating_point(Z)
    theta = library.transform(Z)
    A = feature_map(library.terms_, mean, scale, theta)
    np.testing.assert_allclose(theta @ A.T, library.transform((Z - mean) / scale), rtol=1e-7, atol=1e-7)


def test_feature_map_scales_terms_it_cannot_expand(rng):
    Z = rng.uniform(0.5, 4.0, size=(100, 1))
    library = (PolynomialLibrary(degree=1) + SqrtLibrary()).fit(Z)
    theta = library.transform(Z)
    A = feature_map(library.terms_, *operating_point(Z), theta)
    j = len(library.terms_) - 1  # the square root: divided by its root mean square, not centred
    assert A[j, j] == pytest.approx(1.0 / np.sqrt(np.mean(theta[:, j] ** 2)))
    assert np.count_nonzero(A[j]) == 1
    # without terms (a custom library) every column is scaled by its root mean square
    assert np.allclose(feature_map(None, *operating_point(Z), theta), np.diag(1.0 / np.sqrt(np.mean(theta ** 2, 0))))


# ---------------------------------------------------------------- input_delay
@pytest.mark.parametrize("delay", [1, 3])
def test_sindy_input_delay_recovers_a_delayed_system(rng, delay):
    u = _input(1500, rng)
    y = _delayed_system(u, delay)
    right = SINDy(library=PolynomialLibrary(degree=1), dt=DT, input_delay=delay).fit(u, y)
    wrong = SINDy(library=PolynomialLibrary(degree=1), dt=DT).fit(u, y)
    np.testing.assert_allclose(right.coef_[0, 1:], [-2.0, 1.0], rtol=0.03)  # finite differences of a ZOH response
    assert right.score(u, y) > 0.9999 > wrong.score(u, y)
    assert right.equations()[-1] == f"input delay: {delay} samples; u stands for u(t - {delay} dt)"
    # simulate, predict and estimate_initial_state all see the delayed input
    x = right.simulate(u, y_init=y[:5])
    np.testing.assert_array_equal(x, right.dynamics_.simulate(delay_inputs(u, delay), y[0]))


def test_input_delay_is_saved_and_old_files_load_without_delay(rng):
    u = _input(600, rng)
    y = _delayed_system(u, 2)
    model = SINDy(library=PolynomialLibrary(degree=1), dt=DT, input_delay=2).fit(u, y)
    data = model_to_dict(model)
    assert data["params"]["input_delay"] == 2
    np.testing.assert_array_equal(model_from_dict(data).predict(u, y_init=y[:3]), model.predict(u, y_init=y[:3]))
    plain = SINDy(library=PolynomialLibrary(degree=1), dt=DT).fit(u, y)
    old = model_to_dict(plain)
    for name in ("input_delay", "normalize"):  # a file written before these parameters existed
        del old["params"][name]
    del old["fitted"]["scaling"]
    loaded = model_from_dict(old)
    assert (loaded.input_delay, loaded.normalize, loaded.scaling_) == (0, False, None)
    np.testing.assert_array_equal(loaded.predict(u, y_init=y[:3]), plain.predict(u, y_init=y[:3]))


def test_hidden_input_delay(rng):
    u = _input(1200, rng)
    y = _delayed_system(u, 3)
    kw = dict(hidden=DerivativeHiddenState(order=1), library=PolynomialLibrary(degree=1), dt=DT)
    right = HiddenStateSINDy(input_delay=3, **kw).fit(u, y)
    wrong = HiddenStateSINDy(**kw).fit(u, y)
    assert right.score(u, y) > 0.999
    assert 1 - wrong.score(u, y) > 5 * (1 - right.score(u, y))  # the unexplained variance, 5 times smaller


# ---------------------------------------------------------------- normalize
def test_normalize_makes_the_threshold_independent_of_units(rng):
    u = _input(1500, rng)
    y = _delayed_system(u, 0, offset=97.0)
    results = {}
    for normalize in (False, True):
        for unit in (1.0, 1e-3):  # the same record in degrees and in kilo-degrees
            model = SINDy(library=PolynomialLibrary(degree=2), optimizer=STLS(threshold=0.1), dt=DT,
                          normalize=normalize).fit(u, unit * y)
            results[normalize, unit] = model
    # normalized: the same model in either unit, in the user's units
    a, b = results[True, 1.0], results[True, 1e-3]
    assert a.score(u, y) > 0.999 and b.score(u, 1e-3 * y) > 0.999
    np.testing.assert_allclose(a.predict(u, y_init=y[:1]), b.predict(u, y_init=1e-3 * y[:1]) / 1e-3, rtol=1e-6)
    assert a.scaling_["mean"][0] == pytest.approx(y.mean())
    # not normalized: the threshold in kilo-degrees removes the state's own term (no y term at all)
    c = results[False, 1e-3]
    assert c.score(u, 1e-3 * y) < 0.9


def test_normalize_keeps_the_least_squares_solution(rng):
    """With threshold 0 the scaled regression is a change of basis: the same model, also for a square root."""
    Z = rng.uniform(0.5, 4.0, size=(300, 1))
    y = simulate(lambda x, v: np.array([1.0 - 0.8 * np.sqrt(x[0]) + 0.3 * v[0]]), [2.0], Z, dt=DT)
    kw = dict(library=PolynomialLibrary(degree=2) + SqrtLibrary(), optimizer=STLS(threshold=0.0), dt=DT)
    a = SINDy(**kw).fit(Z, y)
    b = SINDy(normalize=True, **kw).fit(Z, y)
    np.testing.assert_allclose(b.coef_, a.coef_, rtol=1e-5, atol=1e-6)


def test_hidden_normalize_in_user_units(rng):
    u = _input(1200, rng)
    y = _delayed_system(u, 0, offset=50.0)
    model = HiddenStateSINDy(hidden=DerivativeHiddenState(order=1), library=PolynomialLibrary(degree=2),
                             optimizer=STLS(threshold=0.05), dt=DT, normalize=True).fit(u, y)
    assert model.score(u, y) > 0.999
    assert len(model.scaling_["mean"]) == 2  # the state and the input
    loaded = model_from_dict(model_to_dict(model))
    np.testing.assert_array_equal(loaded.predict(u, y_init=y[:3]), model.predict(u, y_init=y[:3]))


# ---------------------------------------------------------------- shared parameters
def test_both_estimators_take_the_same_simulation_and_preprocessing_parameters():
    shared = {"n_substeps", "integrator", "input_hold", "bounds", "max_abs", "input_delay", "normalize", "refine",
              "optimizer", "library", "differentiation", "dt"}
    for cls in (SINDy, HiddenStateSINDy):
        params = inspect.signature(cls).parameters
        assert shared <= set(params), cls
        assert params["max_abs"].default == 1e6 and params["integrator"].default == "rk4"


@pytest.mark.parametrize("cls", [SINDy, HiddenStateSINDy])
@pytest.mark.parametrize("param, value, message", [
    ("input_delay", -1, r"input_delay must be an integer >= 0; got -1\."),
    ("input_delay", 1.5, r"input_delay must be an integer >= 0; got 1\.5\."),
    ("normalize", "yes", r"normalize must be True or False; got 'yes'\."),
    ("integrator", "rk45", r"integrator must be one of \('rk4', 'euler'\); got 'rk45'\."),
    ("max_abs", 0.0, r"max_abs must be a number > 0 \(inf allowed\); got 0\.0\."),
])
def test_bad_shared_parameters(cls, param, value, message):
    u = np.zeros((50, 1))
    y = np.linspace(0, 1, 50)[:, None]
    with pytest.raises(ValueError, match=message):
        cls(dt=DT, **{param: value}).fit(u, y)


def test_hidden_bounds_replace_the_strategys(rng):
    u = _input(600, rng)
    y = _delayed_system(u, 0)
    model = HiddenStateSINDy(hidden=DerivativeHiddenState(order=1), library=PolynomialLibrary(degree=1), dt=DT,
                             bounds=(-0.05, 0.05)).fit(u, y)
    assert np.all(np.abs(model.simulate(u, x0=[0.0])) <= 0.05)

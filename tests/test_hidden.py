"""HiddenStateSINDy: the estimator contract (fit, search, simulate, errors)."""

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError

from sindybench import STLS, DivergenceWarning, HiddenStateSINDy, SimulationError
from sindybench.hidden import (
    BoucWenHiddenState,
    DerivativeHiddenState,
    HiddenStrategy,
    InitialFit,
    LatentHiddenState,
    ParametricHiddenState,
)
from sindybench.differentiation import FiniteDifference
from sindybench.libraries import PolynomialLibrary
from sindybench.search import LogUniform, Normal, Uniform
from sindybench.simulate import TermsRHS, simulate

DT = 0.01


def _oscillator(rng, n=1500):
    """y'' = -4 y - 0.5 y' + 2 u, a known second-order truth."""
    t = np.arange(n) * DT
    u = (np.sin(1.3 * t) + np.sin(2.9 * t + 1.0) + 0.1 * rng.standard_normal(n).cumsum() / 30)[:, None]
    y, v = ((0, 0, 1, 0),), ((1, 0, 1, 0),)
    truth = TermsRHS.from_equations([{v: 1.0}, {y: -4.0, v: -0.5, ((2, 0, 1, 0),): 2.0}])
    x = simulate(truth, [0.3, 0.0], u, dt=DT, n_substeps=4, input_hold="linear")
    return u, x[:, :1], x


@pytest.fixture
def oscillator(rng):
    return _oscillator(rng)


def _model(**kw):
    params = dict(hidden=DerivativeHiddenState(order=2), library=PolynomialLibrary(degree=1),
                  optimizer=STLS(threshold=0.05), dt=DT, input_hold="zoh", refine=None,
                  differentiation=FiniteDifference(accuracy=4))  # nothing decided by "auto"
    params.update(kw)
    return HiddenStateSINDy(**params)


def test_fit_attributes_and_scores(oscillator):
    u, y, x = oscillator
    model = _model()
    assert model.fit(u, y) is model
    assert model.states_.shape == (len(y), 2)
    assert model.hidden_states_.shape == (len(y), 1)
    assert np.corrcoef(model.hidden_states_[:, 0], x[:, 1])[0, 1] > 0.999
    assert model.coef_.shape == (1, 4)
    assert model.best_params_ == {} and model.search_results_ == []
    assert model.score(u, y) > 0.99
    lines = model.equations()
    assert lines[0] == "y0' = 1.000 y0'"
    assert lines[1].startswith("y0'' = ")


class _RefinedDerivatives(DerivativeHiddenState):
    """A user strategy: the derivative guess, then the velocity alone fitted to the first 20 samples."""

    spec = InitialFit(20, free=(1,))

    def initial_fit(self, params, *, n_outputs, n_inputs):
        return self.spec


def test_a_strategy_initial_fit_refines_its_guess(oscillator, monkeypatch):
    u, y, x = oscillator
    guess = _model().fit(u, y).estimate_initial_state(u[500:], y[500:530])
    model = _model(hidden=_RefinedDerivatives(order=2)).fit(u, y)
    x0 = model.estimate_initial_state(u[500:], y[500:530])
    assert x0[0] == guess[0] and x0[1] != guess[1]  # only the free state moved

    def window_error(start):
        return np.sum((model.dynamics_.simulate(u[500:520], start)[:, 0] - y[500:520, 0]) ** 2)

    assert window_error(x0) < 0.5 * window_error(guess)
    for spec, match in [(InitialFit(20, free=(2,)), r"InitialFit.free = \(2,\); expected distinct state indices"),
                        (InitialFit(0), "InitialFit.n_samples = 0; expected an integer >= 1"),
                        ((20, None, None), "initial_fit returned .*; expected an InitialFit or None")]:
        monkeypatch.setattr(_RefinedDerivatives, "spec", spec)
        with pytest.raises(ValueError, match=match):
            model.predict(u[500:], y_init=y[500:530])


def test_simulate_and_initial_state(oscillator):
    u, y, x = oscillator
    model = _model().fit(u, y)
    x0 = model.estimate_initial_state(u[500:], y[500:520])
    np.testing.assert_allclose(x0, x[500], atol=2e-3)
    states = model.simulate(u[500:], y_init=y[500:])
    np.testing.assert_allclose(states[:, 0], y[500:, 0], atol=0.02)
    np.testing.assert_allclose(model.simulate(u[500:], x0=x[500])[:, 1], x[500:, 1], atol=0.05)
    pred = model.predict(u[500:], y_init=y[500:])
    assert pred.shape == (len(y) - 500, 1)
    with pytest.warns(UserWarning, match="without y_init"):
        assert model.predict(u).shape == (len(y), 1)


def test_one_dimensional_output_round_trip(oscillator):
    u, y, _ = oscillator
    model = _model().fit(u, y[:, 0])
    assert model.predict(u, y_init=y).shape == (len(y),)
    with pytest.raises(ValueError, match="X is 1-D"):
        model.fit(u[:, 0], y)


@pytest.mark.parametrize(
    "params, match",
    [
        ({"dt": None}, "dt is None"),
        ({"n_trials": 0}, "n_trials must be an integer >= 1"),
        ({"n_substeps": 1.5}, "n_substeps must be an integer >= 1"),
        ({"input_hold": "cubic"}, "input_hold must be one of"),
        ({"refit": "yes"}, "refit must be True or False"),
        ({"validation": "test"}, "validation must be one of"),
        ({"local_trials": -1}, "local_trials must be an integer in"),
        ({"local_trials": 50, "n_trials": 50}, "local_trials must be an integer in"),
        ({"max_abs": -1.0}, "max_abs must be a number > 0"),
        ({"hidden": "augment"}, "hidden must be a HiddenStrategy"),
        ({"search_params": {"nope__x": (0.0, 1.0)}}, "unknown parameters"),
        ({"search_params": {"hidden__order": (1, 3)}}, "name strategy parameters"),
        ({"search_params": {"optimizer__threshold": (1.0, 0.1)}}, "expected low < high"),
        ({"search_params": {"optimizer__threshold": (0.0, 1.0)}, "validation_size": 1.5}, "validation_size"),
        ({"search_params": {"optimizer__threshold": (0.0, 1.0)}, "validation_size": 5000}, "validation samples"),
        ({"hidden": DerivativeHiddenState(order=0)}, "order must be an integer >= 1"),
    ],
)
def test_bad_parameters(oscillator, params, match):
    u, y, _ = oscillator
    with pytest.raises(ValueError, match=match):
        _model(**params).fit(u, y)


def test_bad_calls_after_fit(oscillator):
    u, y, _ = oscillator
    model = _model().fit(u, y)
    with pytest.raises(ValueError, match="exactly one of x0 and y_init"):
        model.simulate(u)
    with pytest.raises(ValueError, match="exactly one of x0 and y_init"):
        model.simulate(u, x0=[0.0, 0.0], y_init=y)
    with pytest.raises(ValueError, match="x0 has 3 entries"):
        model.simulate(u, x0=[0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="X has 2 features, but HiddenStateSINDy is expecting 1"):
        model.simulate(np.hstack([u, u]), y_init=y)
    with pytest.raises(ValueError, match="y_init has 2 columns"):
        model.estimate_initial_state(u, np.hstack([y, y]))
    with pytest.raises(ValueError, match="sample_weight"):
        model.score(u, y, sample_weight=np.ones(len(y)))


def test_nested_parameters_reachable():
    model = HiddenStateSINDy(hidden=ParametricHiddenState(lambda xh, y, u, *, a: -a * xh, params={"a": (0.1, 1.0)},
                                                          x0_bounds=(0.0, 1.0)),
                             optimizer=STLS(threshold=0.1))
    model.set_params(hidden__x0_bounds=(0.0, 2.0), optimizer__threshold=0.3)
    assert model.hidden.x0_bounds == (0.0, 2.0) and model.optimizer.threshold == 0.3
    assert "hidden__params" in clone(model).get_params(deep=True)


def _leak(xh, y_, u_, *, a):
    # a <= 0 stands for an unstable candidate: its simulation fails (NaN)
    return -a * xh + y_ if a > 0 else np.full(1, np.nan)


def _leaky_model(a_range, **kw):
    hidden = ParametricHiddenState(_leak, params={"a": a_range}, x0_bounds=(-1.0, 1.0), n_substeps=1,
                                   grid_size=5, init_size=20)
    return HiddenStateSINDy(hidden=hidden, library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.0),
                            dt=DT, random_state=0, max_abs=1e3, **kw)


def test_search_params_jointly_and_diverging_trials(oscillator):
    u, y, _ = oscillator
    model = _leaky_model((-3.0, 3.0), n_trials=12, search_params={"optimizer__threshold": (1e-4, 1e-1, True)})
    model.fit(u[:600], y[:600])
    scores = np.array([s for _, s in model.search_results_])
    assert len(scores) == 12 and np.isfinite(scores).all()
    assert np.any(scores == 1e3) and scores.min() < 1.0  # bad trials were scored, good ones won
    assert model.params_["a"] > 0
    assert set(model.best_params_) == {"hidden__a", "hidden__x0", "optimizer__threshold", "input_hold"}  # "auto"
    assert 1e-4 <= model.best_params_["optimizer__threshold"] <= 1e-1
    assert model.optimizer_.threshold == model.best_params_["optimizer__threshold"]
    assert model.optimizer.threshold == 0.0  # fit never changes a hyperparameter


def test_all_candidates_failing_is_a_clear_error(oscillator):
    u, y, _ = oscillator
    model = _leaky_model((-3.0, -1.0), n_trials=3)
    with pytest.raises(ValueError, match="all 3 candidates of the inner search diverged"):
        model.fit(u[:300], y[:300])
    # a failed fit leaves the estimator unfitted (no best_params_ or search_results_ either)
    assert not [k for k in vars(model) if k.endswith("_")]
    with pytest.raises(NotFittedError):
        model.predict(u[:300], y_init=y[:300])


def test_predict_with_a_fitted_initial_state_of_a_diverging_model_fills_nan():
    """initial_state='fit' on outputs over which the model's simulation diverges: the least squares of the initial
    state cannot start, the guess stands and ``predict`` fills NaN from the divergence with a warning, as without
    the fit (was: SimulationError 'cannot refine: the starting model's simulation diverges', raised out of predict and
    out of identify's latent candidates)."""
    t = np.arange(1200) * DT
    y = np.exp(0.5 * t)[:, None]
    model = _model(max_abs=100.0, initial_state="fit").fit(None, y[:400])
    with pytest.warns(DivergenceWarning, match="HiddenStateSINDy.predict: the simulation diverged at sample"):
        y_pred = model.predict(np.zeros((1200, 0)), y_init=y)  # y passes max_abs = 100 at sample ~920
    assert np.isfinite(y_pred[0]).all() and np.isnan(y_pred[-1]).all()
    with pytest.raises(SimulationError, match="diverged"):
        model.simulate(np.zeros((1200, 0)), y_init=y)


def test_predict_warns_from_which_sample_it_diverged():
    t = np.arange(400) * DT
    y = np.exp(0.5 * t)[:, None]
    model = _model(max_abs=100.0).fit(None, y)
    long = np.zeros((2000, 0))
    with pytest.raises(SimulationError) as info:
        model.simulate(long, y_init=y[:5])
    with pytest.warns(DivergenceWarning, match=f"HiddenStateSINDy.predict: the simulation diverged at sample "
                      f"{info.value.step} of 2000"):
        y_pred = model.predict(long, y_init=y[:5])
    assert np.isfinite(y_pred[: info.value.step]).all() and np.isnan(y_pred[info.value.step :]).all()


def test_search_is_reproducible(oscillator):
    u, y, _ = oscillator
    kw = dict(search_params={"optimizer__threshold": (1e-3, 1.0, True)}, n_trials=5, validation_size=300)
    a = _model(random_state=3, **kw).fit(u, y)
    b = _model(random_state=3, **kw).fit(u, y)
    assert a.best_params_ == b.best_params_
    np.testing.assert_array_equal(a.coef_, b.coef_)


@pytest.mark.parametrize("validation", ["block", "continued", "full"])
def test_validation_modes_and_local_refinement(oscillator, validation):
    u, y, _ = oscillator
    model = _leaky_model((0.1, 3.0), n_trials=16, local_trials=6, validation=validation, validation_size=200)
    model.fit(u[:600], y[:600])
    scores = np.array([s for _, s in model.search_results_])
    assert len(scores) == 16 and np.isfinite(scores).all()
    best_tpe = scores[:10].min()
    assert np.min(np.abs(scores[10:] - best_tpe)) < 0.5 * best_tpe  # the refinement starts at the best trial
    assert model.search_results_[int(np.argmin(scores))][0] == model.best_params_
    assert model.params_["a"] == model.best_params_["hidden__a"]


def test_long_horizon_validation_scores_from_the_training_start(oscillator):
    """"continued" scores the validation block of a simulation started at sample 0, "full" the whole record."""
    u, y, _ = oscillator
    fits = {v: _leaky_model((0.5, 0.5 + 1e-9), n_trials=1, validation=v, validation_size=200).fit(u[:600], y[:600])
            for v in ("block", "continued", "full")}
    model = fits["full"]
    y_sim = model.simulate(u[:600], x0=model.states_[0], on_divergence="nan")[:, :1]
    assert np.isfinite(y_sim).all()
    scores = {v: m.search_results_[0][1] for v, m in fits.items()}
    assert len(set(scores.values())) == 3  # three different criteria


@pytest.mark.parametrize("local_trials", [0, 3])
def test_search_params_as_dimensions_search_as_the_tuples(oscillator, local_trials):
    u, y, _ = oscillator
    kw = dict(n_trials=7, local_trials=local_trials, validation_size=300, random_state=3)
    old = _model(search_params={"optimizer__threshold": (1e-3, 1.0, True)}, **kw).fit(u, y)
    new = _model(search_params={"optimizer__threshold": LogUniform(1e-3, 1.0)}, **kw).fit(u, y)
    assert new.best_params_ == old.best_params_ and new.search_results_ == old.search_results_
    np.testing.assert_array_equal(new.coef_, old.coef_)
    assert isinstance(new.search_params["optimizer__threshold"], LogUniform)  # fit never rewrites a parameter


def test_strategy_ranges_as_dimensions_search_as_the_tuples(oscillator):
    u, y, _ = oscillator
    old = _leaky_model((0.1, 3.0, True), n_trials=8, local_trials=3).fit(u[:600], y[:600])
    new = _leaky_model(LogUniform(0.1, 3.0), n_trials=8, local_trials=3).fit(u[:600], y[:600])
    assert new.best_params_ == old.best_params_
    assert new.search_results_ == old.search_results_


def test_a_normal_prior_inside_the_search(oscillator):
    u, y, _ = oscillator
    prior = Normal(1.0, 0.3)
    model = _leaky_model(prior, n_trials=10, local_trials=4).fit(u[:600], y[:600])
    low, high = prior.support()
    values = [v["hidden__a"] for v, _ in model.search_results_]
    assert len(values) == 10 and all(low <= a <= high for a in values)
    assert len(set(values[6:])) > 1  # the local search moved the prior's value (on its quantile)
    assert model.params_["a"] == model.best_params_["hidden__a"]
    assert min(s for _, s in model.search_results_) < 1.0


@pytest.mark.parametrize(
    "search_params, match",
    [({"optimizer__threshold": Uniform(0.0, 1.0), "hidden__a": (0.0, 1.0)}, "name strategy parameters"),
     ({"optimizer__threshold": "wide"}, r"search_params\['optimizer__threshold'\] = 'wide'; expected \(low, high\)"),
     (lambda trial: {}, "search_params must be a dict name -> dimension")],
)
def test_bad_search_params_say_what_is_expected(oscillator, search_params, match):
    u, y, _ = oscillator
    with pytest.raises(ValueError, match=match):
        _model(search_params=search_params, n_trials=2).fit(u[:300], y[:300])


def test_dimensions_in_the_parameters_are_saved_with_the_model(oscillator):
    from sindybench.io import model_from_dict, model_to_dict

    u, y, _ = oscillator
    model = _leaky_model(Normal(1.0, 0.3), n_trials=4, search_params={"optimizer__threshold": LogUniform(1e-4, 1e-1)})
    model.fit(u[:600], y[:600])
    loaded = model_from_dict(model_to_dict(model), allow_import=True)
    assert loaded.search_params == model.search_params and loaded.hidden.params == {"a": Normal(1.0, 0.3)}
    np.testing.assert_array_equal(loaded.predict(u[:600], y_init=y[:50]), model.predict(u[:600], y_init=y[:50]))


class _TwoParameters(HiddenStrategy):
    _physical = ("a", "b")

    def __init__(self, *, a=None, b=None, bounds=None):
        self.a, self.b, self.bounds = a, b, bounds


def test_search_space_reads_bounds_and_names_a_missing_entry():
    space = _TwoParameters(bounds={"a": (0.1, 10.0, True), "b": Uniform(1.0, 5.0)}).search_space()
    assert space == {"a": LogUniform(0.1, 10.0), "b": Uniform(1.0, 5.0)}
    assert _TwoParameters(a=1.0, bounds={"b": (1, 5)}).search_space() == {"b": Uniform(1.0, 5.0)}
    with pytest.raises(ValueError, match=r"b=None asks for a search but bounds has no entry 'b'"):
        _TwoParameters(a=1.0, bounds={"a": (0.1, 10.0)}).search_space()


@pytest.mark.parametrize("strategy, match", [
    (_TwoParameters(bounds={"a": (0.1, 1.0), "B": (1, 5)}), "unknown key 'B'; _TwoParameters accepts 'a', 'b'"),
    (LatentHiddenState(bounds={"Tau": (100, 200)}), "unknown key 'Tau'; LatentHiddenState accepts 'tau', 'gain'"),
    (BoucWenHiddenState(bounds={"M": (1, 3)}), "unknown key 'M'; BoucWenHiddenState accepts 'm', 'c', 'k'"),
    (LatentHiddenState(bounds=[(1, 2)]), "bounds must be a dict name -> dimension"),
    (_TwoParameters(bounds=[(1, 2)]), "bounds must be a dict name -> dimension"),
])
def test_an_unknown_bounds_key_is_an_error_naming_the_accepted_ones(strategy, match):
    # before: the misspelled key was ignored and the default range searched
    with pytest.raises(ValueError, match=match):
        strategy.search_space()


def _noisy_oscillator(input_kind, seed):
    """y'' = -4 y - 0.5 y' + 2 u, 1500 samples at 0.01 s, 0.2 % output noise; a multisine or a filtered-noise input."""
    from scipy.signal import butter, lfilter, lsim, lti

    rng = np.random.default_rng(seed)
    t = np.arange(1500) * 0.01
    if input_kind == "multisine":
        u = sum(np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi)) for f in (0.1, 0.23, 0.37, 0.55, 0.8))
    else:  # white noise through a second-order 1 Hz low-pass
        u = lfilter(*butter(2, 2 * 1.0 * 0.01), rng.standard_normal(t.size))
        u = u / np.std(u)
    y = lsim(lti([2.0], [1.0, 0.5, 4.0]), u, t)[1]
    return u[:, None], (y + 0.002 * np.std(y) * rng.standard_normal(t.size))[:, None]


@pytest.mark.parametrize("input_kind, seed", [("multisine", 0), ("filtered noise", 3)])
def test_default_derivative_recovers_a_noisy_oscillator(input_kind, seed):
    # every default: the derivative is chosen from the record's bandwidth (a Savitzky-Golay window), the library
    # and hold on the validation block, then the refinement; before (FiniteDifference(accuracy=4), the 0.2
    # default) the filtered-noise record fitted y0' and u0 152 % off, unstable, and the refinement was skipped
    u, y = _noisy_oscillator(input_kind, seed)
    model = HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), dt=0.01, show_progress_bar=False).fit(u, y)
    assert type(model.differentiation_).__name__ == "SavitzkyGolay" and model.differentiation_.window_length > 20
    assert model.refinement_["status"] >= 1, model.refinement_["message"]  # run and converged, not skipped
    coef = dict(zip(model.library_.get_feature_names_out(["y0", "y0'", "u0"]), model.coef_[0]))
    np.testing.assert_allclose([coef["y0"], coef["y0'"], coef["u0"]], [-4.0, -0.5, 2.0], rtol=0.02)
    assert model.score(u, y) > 0.999  # started from 20 samples, fewer than the window: the start's own fit


def test_searching_the_parameters_of_the_auto_derivative_is_refused_with_the_way_out():
    t = np.arange(200) * 0.01
    model = HiddenStateSINDy(dt=0.01, refine=None, n_trials=2, show_progress_bar=False,
                             search_params={"differentiation__window_length": [7, 11]})
    with pytest.raises(ValueError, match="differentiation='auto' has no parameters: pass a method"):
        model.fit(np.sin(t)[:, None], np.sin(0.9 * t)[:, None])

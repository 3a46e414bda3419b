"""Tests for BoucWenHiddenState: structural iteration on the Bouc-Wen hysteretic system."""

import pickle

import numpy as np
import pytest

from sindybench import STLS, HiddenStateSINDy
from sindybench.differentiation import SavitzkyGolay
from sindybench.hidden import BoucWenHiddenState, InitialFit
from sindybench.metrics import rmse
from sindybench.search import LogNormal, LogUniform, Normal, Uniform
from sindybench.systems import BoucWen, multisine

DT = 1.0 / 750.0
TRUE = {"m": 2.0, "c": 10.0, "k": 5e4}
ALPHA, BETA, GAMMA, DELTA = 5e4, 1e3, 0.8, -1.1
TRUE_TERMS = {"v": ALPHA, "|v| z": -BETA * GAMMA, "v |z|": -BETA * DELTA}
# plausible physical guesses for the benchmark (a factor of a few around the truth)
BOUNDS = {"m": (1.0, 5.0, True), "c": (1.0, 100.0, True), "k": (1e4, 1e5, True)}


def _threshold(n_rows, fraction=0.1, rate=1.3e4):
    """STLS threshold on normalized columns: ``fraction`` of a z' of RMS ``rate`` (N/s)."""
    return fraction * rate * np.sqrt(n_rows)


def _model(hidden, n_rows, *, window_length=5, **kwargs):
    return HiddenStateSINDy(
        hidden=hidden,
        optimizer=STLS(threshold=_threshold(n_rows), normalize_columns=True),
        differentiation=SavitzkyGolay(window_length=window_length, polyorder=4),
        dt=DT,
        n_substeps=2,
        input_hold="linear",
        **{"refine": None, **kwargs},  # the equation-error fit, as these tests compare it
    )


def _z_equation(model):
    names = model.library_.get_feature_names_out(model.state_names_ + ["u"])
    return {name: c for name, c in zip(names, model.coef_[0]) if c != 0}


@pytest.fixture(scope="module")
def synthetic():
    """Noise-free periodic steady state of the true system under a multisine."""
    u = multisine(4096, random_state=np.random.default_rng(7))
    system = BoucWen()
    return u, system.simulate(u, periodic=True), system.simulate_states(u, periodic=True)


def test_structure_rows():
    s = BoucWenHiddenState(**TRUE)
    st = s.structure(s.resolve_params(), n_outputs=1, n_inputs=1)
    assert st.learned == (2,) and st.output_index == (0,)
    x, u = np.array([1e-3, 0.2, 30.0]), np.array([40.0])
    dx = st.fixed_coef.T @ np.array([x[1], x[0], x[2], u[0]])
    assert dx[0] == pytest.approx(0.2)
    assert dx[1] == pytest.approx((40.0 - 10.0 * 0.2 - 5e4 * 1e-3 - 30.0) / 2.0)
    assert dx[2] == 0.0


def test_search_space_uses_default_bounds():
    space = BoucWenHiddenState(m=2.0, bounds={"k": (1e4, 1e5)}).search_space()
    assert space["k"] == Uniform(1e4, 1e5)
    assert space["c"] == LogUniform(0.1, 1000.0) and set(space) == {"c", "k"}


def test_bounds_as_dimensions_search_as_the_tuples():
    assert BoucWenHiddenState(m=2.0, bounds={"k": LogNormal(np.log(5e4), 0.5)}).search_space() == {
        "c": LogUniform(0.1, 1000.0), "k": LogNormal(np.log(5e4), 0.5)}
    u = multisine(512, random_state=np.random.default_rng(0))
    y = BoucWen().simulate(u, periodic=True)
    fits = [_model(BoucWenHiddenState(m=2.0, c=10.0, bounds={"k": k}), len(u), n_trials=4, random_state=0).fit(u, y)
            for k in ((1e4, 1e5, True), LogUniform(1e4, 1e5))]
    assert fits[0].best_params_ == fits[1].best_params_ and set(fits[0].best_params_) == {"hidden__k"}
    np.testing.assert_array_equal(fits[0].coef_, fits[1].coef_)
    with pytest.raises(ValueError, match=r"bounds\['k'\] starts at -5.*expected a range of positive values"):
        BoucWenHiddenState(k=None, bounds={"k": Normal(5.0, 2.5)})._validate()


def test_true_parameters_recover_the_bouc_wen_law(synthetic):
    u, y, states = synthetic
    model = _model(BoucWenHiddenState(**TRUE), len(u)).fit(u, y)
    eq = _z_equation(model)
    assert set(eq) == set(TRUE_TERMS)
    for name, value in TRUE_TERMS.items():
        assert eq[name] == pytest.approx(value, rel=0.05)
    z_err = rmse(states[100:-100, 2], model.hidden_states_[100:-100, 1])
    assert z_err < 0.03 * np.std(states[:, 2])


def test_fitted_model_pickles(synthetic):
    u, y, _ = synthetic
    model = _model(BoucWenHiddenState(**TRUE), len(u)).fit(u, y)
    clone = pickle.loads(pickle.dumps(model))
    np.testing.assert_allclose(clone.predict(u, y_init=y[:10]), model.predict(u, y_init=y[:10]))


def test_filtered_regression_beats_raw_features(synthetic):
    # a wider window smooths the target more: raw features then pick up a spurious relaxation term z
    u, y, _ = synthetic
    raw = _model(BoucWenHiddenState(**TRUE, filter_features=None), len(u), window_length=7).fit(u, y)
    filtered = _model(BoucWenHiddenState(**TRUE), len(u), window_length=7).fit(u, y)
    assert set(_z_equation(filtered)) == set(TRUE_TERMS)
    err = {name: abs(_z_equation(m)["|v| z"] / TRUE_TERMS["|v| z"] - 1) for name, m in [("raw", raw), ("f", filtered)]}
    assert err["f"] < 0.1 < err["raw"]


def test_initial_state_from_first_samples(synthetic):
    u, y, states = synthetic
    model = _model(BoucWenHiddenState(**TRUE), len(u)).fit(u, y)
    start = 1500
    x0 = model.estimate_initial_state(u[start:], y[start : start + 10])
    scale = np.std(states, axis=0)
    np.testing.assert_array_less(np.abs(x0 - states[start]) / scale, [0.01, 0.05, 0.1])
    coarse = _model(BoucWenHiddenState(**TRUE, refine_init=False), len(u)).fit(u, y)
    x0_coarse = coarse.estimate_initial_state(u[start:], y[start : start + 10])
    assert np.abs(x0 - states[start])[2] < np.abs(x0_coarse - states[start])[2]


def test_initial_state_is_the_guess_refined_by_the_one_estimator(synthetic, monkeypatch):
    """The strategy gives the local-fit guess; estimate_initial_state refines all three states on n_init samples."""
    import sindybench.hidden._refinement as refinement

    u, y, _ = synthetic
    model = _model(BoucWenHiddenState(**TRUE, n_init=12), len(u)).fit(u, y)
    coarse = _model(BoucWenHiddenState(**TRUE, n_init=12, refine_init=False), len(u)).fit(u, y)
    assert model.hidden_.initial_fit(model.params_, n_outputs=1, n_inputs=1) == InitialFit(12)
    assert coarse.hidden_.initial_fit(coarse.params_, n_outputs=1, n_inputs=1) is None
    real, calls = refinement.estimate_initial_state, []

    def spy(*args, **kwargs):
        calls.append((args, kwargs))
        return real(*args, **kwargs)

    monkeypatch.setattr(refinement, "estimate_initial_state", spy)
    start = 1500
    x0 = model.estimate_initial_state(u[start:], y[start : start + 20])
    guess = coarse.estimate_initial_state(u[start:], y[start : start + 20])
    assert len(calls) == 1  # the coarse model keeps its guess
    (dynamics, u_w, y_w), kwargs = calls[0]
    assert dynamics is model.dynamics_
    assert u_w.shape == y_w.shape == (12, 1) and kwargs["free_x0"].tolist() == [0, 1, 2]
    np.testing.assert_array_equal(kwargs["x0"], guess)
    assert kwargs["solver"].output_scale.tolist() == [np.abs(y_w).max()]
    cost = {name: rmse(y_w, model.dynamics_.simulate(u_w, x)[:, :1]) for name, x in (("x0", x0), ("guess", guess))}
    assert cost["x0"] < 0.01 * cost["guess"]


def test_search_recovers_the_mass(synthetic):
    u, y, _ = synthetic
    hidden = BoucWenHiddenState(c=10.0, k=5e4, bounds={"m": (0.5, 8.0, True)})
    model = _model(hidden, len(u), validation_size=600, n_trials=12, random_state=0).fit(u, y)
    assert model.params_["m"] == pytest.approx(2.0, rel=0.05)
    assert len(model.search_results_) == 12


@pytest.mark.parametrize(
    "params, match",
    [
        ({"m": 0.0}, "m must be a number > 0"),
        ({"c": -1.0}, "c must be a number >= 0"),
        ({"k": "stiff"}, "k must be"),
        ({"n_init": 0}, "n_init must be an integer >= 1"),
        ({"trim": -1}, "trim must be an integer >= 0"),
        ({"trim": 5000}, "trim=5000 leaves no sample"),
        ({"refine_init": "yes"}, "refine_init must be True or False"),
        ({"filter_features": "spline"}, "filter_features must be one of"),
        ({"bounds": [(1, 2)]}, "bounds must be a dict"),
        ({"m": None, "bounds": {"m": (0.0, 2.0)}}, "expected a range of positive values"),
        ({"k": None, "bounds": {"k": (2.0, 1.0)}}, "expected low < high"),
    ],
)
def test_bad_parameters(params, match):
    u = multisine(512, random_state=np.random.default_rng(0))
    y = BoucWen().simulate(u, periodic=True)
    with pytest.raises(ValueError, match=match):
        _model(BoucWenHiddenState(**{**TRUE, **params}), len(u), n_trials=2).fit(u, y)


def test_one_input_one_output_only():
    u = multisine(512, random_state=np.random.default_rng(0))
    y = BoucWen().simulate(u, periodic=True)
    with pytest.raises(ValueError, match="one force input and one displacement output"):
        _model(BoucWenHiddenState(**TRUE), len(u)).fit(u, np.hstack([y, y]))


@pytest.fixture(scope="module")
def benchmark_model(data_home):
    from sindybench.datasets import load_bouc_wen

    data = load_bouc_wen(data_home=data_home)
    est = data.estimation
    n_val = data.validation.u.shape[0]
    model = _model(BoucWenHiddenState(bounds=BOUNDS), est.u.shape[0] - n_val, window_length=7,
                   validation_size=n_val, n_trials=30, random_state=0)
    return data, model.fit(est.u, est.y)


def test_benchmark_multisine_rmse(benchmark_model):
    data, model = benchmark_model
    test = data.test.multisine
    y_pred = model.predict(test.u, y_init=test.y[: data.n_init])
    assert rmse(test.y, y_pred) <= 2.5e-4
    assert model.params_["m"] == pytest.approx(2.0, rel=0.15)


def test_benchmark_sine_hysteresis_loop(benchmark_model):
    data, model = benchmark_model
    test = data.test.sine
    y_pred = model.predict(test.u, y_init=test.y[: data.n_init])
    assert np.all(np.isfinite(y_pred))
    assert np.ptp(y_pred) == pytest.approx(np.ptp(test.y), rel=0.2)

    def loop_area(y):  # area enclosed by the force-displacement curve over one period
        return abs(np.sum(0.5 * (y[1:, 0] + y[:-1, 0]) * np.diff(test.u[:, 0])))

    assert loop_area(y_pred) == pytest.approx(loop_area(test.y), rel=0.5)
    assert loop_area(y_pred) > 0.05 * np.ptp(test.y) * np.ptp(test.u)


def test_true_parameters_on_benchmark_keep_the_true_terms(data_home):
    from sindybench.datasets import load_bouc_wen

    data = load_bouc_wen(data_home=data_home)
    model = _model(BoucWenHiddenState(**TRUE), data.train.u.shape[0], window_length=7).fit(data.train.u, data.train.y)
    assert set(_z_equation(model)) == set(TRUE_TERMS)
    test = data.test.multisine
    assert rmse(test.y, model.predict(test.u, y_init=test.y[: data.n_init])) <= 1e-4


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_benchmark_multisine_rmse_other_seeds(data_home, seed):
    from sindybench.datasets import load_bouc_wen

    data = load_bouc_wen(data_home=data_home)
    est, n_val = data.estimation, data.validation.u.shape[0]
    model = _model(BoucWenHiddenState(bounds=BOUNDS), est.u.shape[0] - n_val, window_length=7,
                   validation_size=n_val, n_trials=30, random_state=seed).fit(est.u, est.y)
    test = data.test.multisine
    assert rmse(test.y, model.predict(test.u, y_init=test.y[: data.n_init])) <= 2.5e-4

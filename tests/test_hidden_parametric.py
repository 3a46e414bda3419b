"""ParametricHiddenState on a system of known truth: a hidden first-order lag feeding the output.

The output's cubic damping makes the lag identifiable (for a linear output the two
poles could swap between the hidden and the output equation). These models run
on the Python-callable simulation path, so the data sets are kept small.
"""

import numpy as np
import pytest

from sindybench import STLS, HiddenStateSINDy
from sindybench.differentiation import SavitzkyGolay
from sindybench.hidden import ParametricHiddenState
from sindybench.libraries import PolynomialLibrary
from sindybench.simulate import TermsRHS, simulate

DT = 0.02
A_TRUE, X0_TRUE = 2.0, 0.6


def _lag(xh, y, u, *, a, b):
    """Hidden actuator lag: h' = -a h + b u."""
    return -a * xh + b * u[:1]


@pytest.fixture
def lag_data(rng):
    """h' = -2 h + u (hidden), y' = -0.5 y - y^3 + 1.5 h (measured)."""
    n = 500
    t = np.arange(n) * DT
    u = (2.0 * np.sin(1.7 * t + rng.uniform(0, 6)) + 1.5 * np.sin(4.1 * t) + np.sin(0.6 * t))[:, None]
    y_, h_, u_, y3 = ((0, 0, 1, 0),), ((1, 0, 1, 0),), ((2, 0, 1, 0),), ((0, 0, 3, 0),)
    truth = TermsRHS.from_equations([{y_: -0.5, y3: -1.0, h_: 1.5}, {h_: -A_TRUE, u_: 1.0}])
    x = simulate(truth, [0.0, X0_TRUE], u, dt=DT, n_substeps=4, input_hold="linear")
    return u, x[:, :1], x


def _model(**hidden_kw):
    kw = dict(params={"a": (0.5, 8.0, True), "b": 1.0}, x0_bounds=(-2.0, 2.0), n_substeps=1, grid_size=7,
              init_size=30)
    kw.update(hidden_kw)
    return HiddenStateSINDy(hidden=ParametricHiddenState(_lag, **kw), library=PolynomialLibrary(degree=3),
                            optimizer=STLS(threshold=0.05), dt=DT, differentiation=SavitzkyGolay(window_length=9), input_hold="linear", n_trials=25, random_state=0,
                            validation_size=100)


def test_recovers_hidden_parameter_and_state(lag_data):
    u, y, x = lag_data
    model = _model().fit(u, y)
    assert model.params_["a"] == pytest.approx(A_TRUE, rel=0.1)
    assert model.params_["x0"] == pytest.approx(X0_TRUE, abs=0.15)
    assert model.params_["b"] == 1.0
    np.testing.assert_allclose(model.hidden_states_[:, 0], x[:, 1], atol=0.15)
    names = list(model.library_.get_feature_names_out(model.state_names_ + ["u0"]))
    coef = dict(zip(names, model.coef_[0]))
    assert coef["y0"] == pytest.approx(-0.5, rel=0.25) and coef["h0"] == pytest.approx(1.5, rel=0.1)
    assert coef["y0^3"] == pytest.approx(-1.0, rel=0.1)
    assert model.equations()[1] == "h0' = (fixed: ParametricHiddenState)"


@pytest.mark.parametrize("init", ["simulation", "derivative"])
def test_initial_hidden_state_on_new_data(lag_data, init):
    u, y, x = lag_data
    model = _model(init=init, params={"a": A_TRUE, "b": 1.0}).fit(u[:300], y[:300])
    x0 = model.estimate_initial_state(u[300:], y[300:])
    assert x0[0] == y[300, 0]
    assert x0[1] == pytest.approx(x[300, 1], abs=0.15 if init == "simulation" else 0.3)
    assert model.score(u[300:], y[300:]) > (0.95 if init == "simulation" else 0.85)


def test_initial_fit_frees_the_hidden_states_within_their_ranges():
    s = ParametricHiddenState(_lag, params={"a": 1.0, "b": 1.0}, x0_bounds=[(-2.0, 2.0), (0.0, 1.0)], init_size=30)
    fit = s.initial_fit(s.resolve_params({"x0_0": 0.0, "x0_1": 0.5}), n_outputs=2, n_inputs=1)
    assert fit.n_samples == 30 and fit.free == (2, 3)
    assert fit.bounds[0].tolist() == [-np.inf, -np.inf, -2.0, 0.0]
    assert fit.bounds[1].tolist() == [np.inf, np.inf, 2.0, 1.0]
    assert s.set_params(init="derivative").initial_fit({}, n_outputs=2, n_inputs=1) is None


def test_everything_fixed_needs_no_search(lag_data):
    u, y, _ = lag_data
    model = _model(params={"a": A_TRUE, "b": 1.0}, x0_bounds=[(X0_TRUE, X0_TRUE + 1e-9)])
    model.set_params(n_trials=1).fit(u, y)
    assert model.params_["a"] == A_TRUE and len(model.search_results_) == 1


@pytest.mark.parametrize(
    "hidden_kw, match",
    [
        ({"rhs": "not callable"}, "rhs must be a callable"),
        ({"x0_bounds": None}, "x0_bounds is None"),
        ({"x0_bounds": (1.0, 0.0)}, "expected low < high"),
        ({"params": {"a": (0.0, 1.0, True)}}, "log-scaled"),
        ({"params": [("a", 1.0)]}, "params must be a dict"),
        ({"init": "guess"}, "init must be one of"),
        ({"grid_size": 1}, "grid_size must be an integer >= 2"),
        ({"hidden_names": ["p", "q"]}, "hidden_names has 2 names"),
        ({"bounds": (1.0, 0.0)}, "lower bound"),
    ],
)
def test_bad_parameters(lag_data, hidden_kw, match):
    u, y, _ = lag_data
    rhs = hidden_kw.pop("rhs", None)
    model = _model(**hidden_kw)
    if rhs is not None:
        model.hidden.set_params(rhs=rhs)
    with pytest.raises(ValueError, match=match):
        model.fit(u, y)


def _two_values(xh, y, u, *, a, b):
    return np.r_[-a * xh, b]


def _needs_c(xh, y, u, *, a, b, c):
    return -a * xh + b * c * u[:1]


def _no_keywords(xh, y, u):
    return -xh


@pytest.mark.parametrize("rhs, match", [
    # before: "all 25 candidates of the inner search diverged or failed on the validation block"
    (_two_values, r"rhs _two_values returned shape \(2,\) for the first sample .*expected 1 value"),
    # before: the user's own TypeError "missing 1 required keyword-only argument: 'c'"
    (_needs_c, r"rhs _needs_c\(xh, y, u, \*, a, b, c\) cannot be called as rhs\(x_h, y, u, a=..., b=...\) "
               r"\(missing a required argument: 'c'\)"),
    (_no_keywords, r"rhs _no_keywords\(xh, y, u\) cannot be called .*unexpected keyword argument 'a'"),
    (lambda xh, y, u, *, a, b: "fast", r"rhs .*<lambda> returned 'fast' for the first sample; expected 1 numbers"),
])
def test_user_rhs_checked_once_before_the_search(lag_data, rhs, match):
    u, y, _ = lag_data
    model = _model()
    model.hidden.rhs = rhs
    with pytest.raises(ValueError, match=match):
        model.fit(u, y)


def test_rhs_check_calls_it_once_at_the_middle_of_the_ranges(lag_data):
    u, y, _ = lag_data
    calls = []

    def spy(xh, y, u, *, a, b):
        calls.append((xh.copy(), a, b))
        raise RuntimeError("stop after the check")

    model = _model(params={"a": (0.5, 8.0, True), "b": 1.0})
    model.hidden.rhs = spy
    with pytest.raises(RuntimeError, match="stop after the check"):
        model.fit(u, y)
    assert len(calls) == 1
    np.testing.assert_allclose(calls[0][0], [0.0])
    assert calls[0][1] == pytest.approx(2.0) and calls[0][2] == 1.0

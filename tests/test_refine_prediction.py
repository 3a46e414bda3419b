"""Prediction-error refinement: the predictor's sensitivities, its checks, and plants output error cannot fit."""

import warnings

import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning

from sindybench import STLS, HiddenStateSINDy, SINDy, load_model
from sindybench.io import save_model
from sindybench.differentiation import FiniteDifference
from sindybench.hidden import DerivativeHiddenState
from sindybench.libraries import ConcatLibrary, CustomLibrary, PolynomialLibrary
from sindybench.dynamics import Dynamics
from sindybench.refine import (
    FreeParameters,
    LeastSquares,
    OutputErrorRefinement,
    Physical,
    PredictionErrorRefinement,
    predict_sensitivity,
    refine_prediction_error,
    refine_simulation_error,
)
from sindybench.simulate import SimulationError, TermsRHS, simulate

Y, V, U = ((0, 0, 1, 0),), ((1, 0, 1, 0),), ((2, 0, 1, 0),)
# y'' = -4 y - 0.5 y' + 2 u - y^3 (a Duffing oscillator), states (y, y')
DUFFING = [Y, V, U, ((0, 0, 3, 0),)]
DUFFING_COEF = np.array([[0.0, -4.0], [1.0, -0.5], [0.0, 2.0], [0.0, -1.0]])
DUFFING_FREE = np.zeros((4, 2), dtype=bool)
DUFFING_FREE[:, 1] = True  # y' = v held: freeing it too would leave the scale of v unidentified


def _start(factor):
    coef = DUFFING_COEF.copy()
    coef[:, 1] *= factor
    return coef


def _duffing(rng, n=300, dt=0.05, noise=0.0):
    u = np.repeat(rng.uniform(-1, 1, n // 20 + 1), 20)[:n, None]
    x = simulate(TermsRHS(DUFFING_COEF, DUFFING, 2), [0.5, 0.0], u, dt)
    return u, x[:, :1] + noise * rng.normal(size=(n, 1)), x


# ----------------------------------------------------------------- sensitivities
@pytest.mark.parametrize("horizon", [1, 4])
@pytest.mark.parametrize("method, hold", [("rk4", "zoh"), ("euler", "linear")])
def test_sensitivities_match_finite_differences(rng, horizon, method, hold):
    """Coefficients, initial state and gain: the kernel's derivative is that of the discrete predictor."""
    u, y, _ = _duffing(rng, n=60, noise=0.05)
    gain = np.array([[0.3], [0.8]])
    D = np.zeros((4,) + DUFFING_COEF.shape)
    for k, (j, i) in enumerate([(0, 1), (1, 1), (2, 1), (3, 1)]):
        D[k, j, i] = 1.0
    settings = dict(horizon=horizon, output_index=[0], method=method, input_hold=hold)

    def pred(C, x0, K):
        return predict_sensitivity(TermsRHS(C, DUFFING, 2), x0, u, y, 0.05, gain=K, sensitivities=False,
                                   **settings)[0][:, 0]

    C0, x00 = DUFFING_COEF * 1.1, np.array([0.4, 0.1])
    x, S, bad = predict_sensitivity(TermsRHS(C0, DUFFING, 2), x00, u, y, 0.05, gain=gain, directions=D,
                                    free_x0=[0, 1], free_gain=True, **settings)
    assert bad == -1 and S.shape == (60, 1, 4 + 2 + 2)
    np.testing.assert_array_equal(x[:, 0], pred(C0, x00, gain))  # the state-only kernel: the same predictions
    eps, fd = 1e-6, []
    for k in range(4):
        fd.append((pred(C0 + eps * D[k], x00, gain) - pred(C0 - eps * D[k], x00, gain)) / (2 * eps))
    for i in range(2):
        e = np.eye(2)[i] * eps
        fd.append((pred(C0, x00 + e, gain) - pred(C0, x00 - e, gain)) / (2 * eps))
    for i in range(2):
        e = np.zeros((2, 1))
        e[i, 0] = eps
        fd.append((pred(C0, x00, gain + e) - pred(C0, x00, gain - e)) / (2 * eps))
    np.testing.assert_allclose(S[:, 0, :], np.column_stack(fd), rtol=1e-5, atol=1e-7)


def test_long_horizon_is_the_open_loop_simulation(rng):
    """horizon = record length: every prediction starts from x0, i.e. output error's simulation."""
    u, y, _ = _duffing(rng, n=80, noise=0.05)
    rhs = TermsRHS(DUFFING_COEF * 0.9, DUFFING, 2)
    x, _, _ = predict_sensitivity(rhs, [0.4, 0.0], u, y, 0.05, gain=[[0.5], [1.0]], horizon=80,
                                  sensitivities=False)
    np.testing.assert_array_equal(x, simulate(rhs, [0.4, 0.0], u, 0.05))
    one, _, _ = predict_sensitivity(rhs, [0.4, 0.0], u, y, 0.05, gain=[[0.5], [1.0]], sensitivities=False)
    assert np.abs(one[:, 0] - y[:, 0]).mean() < np.abs(x[:, 0] - y[:, 0]).mean()


# ------------------------------------------------------------------------ checks
@pytest.mark.parametrize(
    "kw, match",
    [
        ({"horizon": 0}, r"horizon must be an integer in \[1, 300\] .*got 0"),
        ({"horizon": 301}, r"at most the record's 300 samples\); got 301"),
        ({"horizon": 2.0}, "horizon must be an integer"),
        ({"noise": ([-1.0, 1.0], [1.0])}, "noise Q has the eigenvalue -1; expected a positive semidefinite"),
        ({"noise": ([1.0, 1.0], [0.0])}, "noise R has the eigenvalue 0; expected a positive definite"),
        ({"noise": ([[1.0, 2.0], [0.0, 1.0]], [1.0])}, "noise Q is not symmetric"),
        ({"noise": ([1.0], [1.0])}, r"noise Q has shape \(1, 1\); expected a finite \(2, 2\)"),
        ({"noise": "high"}, "noise must be a pair"),
        ({"gain": [1.0, 2.0, 3.0]}, r"gain has shape \(3,\); expected a finite \(2, 1\)"),
    ],
)
def test_bad_arguments(rng, kw, match):
    u, y, _ = _duffing(rng)
    with pytest.raises(ValueError, match=match):
        refine_prediction_error(Dynamics.from_terms(DUFFING, DUFFING_COEF, dt=0.05, output_index=(0,)), u, y,
                                x0=[0.5, 0.0], **kw)


def test_python_model_is_refused(rng):
    u, y, _ = _duffing(rng)
    model = Dynamics.from_terms(DUFFING, DUFFING_COEF, dt=0.05, output_index=(0,))
    python_map = Physical(names=(), values=np.zeros(0), lower=np.zeros(0), upper=np.zeros(0), coef=lambda v: 0.0,
                          make_rhs=lambda C, v: TermsRHS(C, DUFFING, 2))
    with pytest.raises(ValueError, match="needs a compiled model"):
        refine_prediction_error(model, u, y, x0=[0.5, 0.0], free=FreeParameters(physical=python_map))
    python = SINDy(library=CustomLibrary(functions=[np.tanh], compile=False), dt=0.05).fit(u, y).dynamics_
    assert not python.compiled
    with pytest.raises(ValueError, match="needs a compiled model"):
        PredictionErrorRefinement().run(python, u, y, x0=[0.5])


def test_diverging_predictor_names_the_sample(rng):
    """A predictor that cannot follow the record (no correction, an exploding model) is refused with its sample."""
    u, y, _ = _duffing(rng)
    exploding = DUFFING_COEF.copy()
    exploding[3, 1] = 5.0  # + 5 y^3
    with pytest.raises(SimulationError, match=r"the starting predictor diverges at sample \d+") as info:
        refine_prediction_error(Dynamics.from_terms(DUFFING, exploding, dt=0.05, output_index=(0,), max_abs=1e6), u,
                                y * 10, x0=[5.0, 0.0], gain=np.zeros((2, 1)), free_gain=False)
    assert info.value.step > 0


# -------------------------------------------------------------- what it recovers
@pytest.mark.filterwarnings("ignore:the refinement stopped on its evaluation budget")
def test_recovers_duffing_from_a_biased_start_with_errors(rng):
    u, y, _ = _duffing(rng, n=400, noise=0.02)
    res = refine_prediction_error(Dynamics.from_terms(DUFFING, _start(0.8), dt=0.05, output_index=(0,)), u, y,
                                  x0=[0.5, 0.0], free=FreeParameters(coef=DUFFING_FREE),
                                  solver=LeastSquares(max_nfev=100))
    np.testing.assert_allclose(res.coef[[0, 1, 2, 3], [1, 1, 1, 1]], [-4.0, -0.5, 2.0, -1.0], rtol=0.05)
    assert res.cost < res.initial_cost and res.horizon == 1 and res.gain.shape == (2, 1)
    se = res.standard_errors()
    assert se.shape == (len(res.parameters),) and res.parameters[-2:] == (("gain", 0, 0), ("gain", 1, 0))
    assert np.all(np.isfinite(se)) and np.all(se[:5] > 0)
    summary = res.summary()
    assert summary["criterion"]["horizon"] == 1 and np.shape(summary["criterion"]["gain"]) == (2, 1)


A_TRUE, C_TRUE, B_TRUE, DT_PEND = 10.0, 0.5, 4.0, 0.02


def _inverted_pendulum(n, seed, noise=0.02):
    """theta'' = a sin(theta) - c theta' + b u (open-loop unstable) under u = -8 y - 1.5 theta' + r, y noisy."""
    rng = np.random.default_rng(seed)
    x, u, y = np.zeros((n, 2)), np.zeros(n), np.zeros(n)
    r = np.repeat(rng.uniform(-5, 5, n // 50 + 1), 50)[:n]

    def f(s, v):
        return np.array([s[1], A_TRUE * np.sin(s[0]) - C_TRUE * s[1] + B_TRUE * v])

    for k in range(n):
        y[k] = x[k, 0] + noise * rng.normal()
        u[k] = -8.0 * y[k] - 1.5 * x[k, 1] + r[k]  # the controller sees the noisy output
        if k + 1 < n:
            s, h = x[k].copy(), DT_PEND / 4
            for _ in range(4):
                k1 = f(s, u[k])
                k2 = f(s + h / 2 * k1, u[k])
                k3 = f(s + h / 2 * k2, u[k])
                k4 = f(s + h * k3, u[k])
                s = s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            x[k + 1] = s
    return u[:, None], y[:, None]


def _pendulum_model(refine):
    library = ConcatLibrary([PolynomialLibrary(degree=1, include_bias=False),
                             CustomLibrary(functions=[np.sin], names=["sin({})"], variables=[0])])
    return HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=library, optimizer=STLS(threshold=0.1),
                            dt=DT_PEND, refine=refine, input_hold="zoh", differentiation=FiniteDifference())


def _row(model):
    names = list(model.library_.get_feature_names_out(model.state_names_ + ["u0"]))
    return dict(zip(names, model.coef_[-1]))


def test_unstable_plant_in_closed_loop():
    """Prediction error recovers every physical coefficient within 5 %; output error from the same start is biased."""
    u, y = _inverted_pendulum(3000, seed=0)
    pem = _pendulum_model(PredictionErrorRefinement(max_nfev=50, prune=0.01)).fit(u, y)
    row = _row(pem)
    assert row["sin(y0)"] == pytest.approx(A_TRUE, rel=0.05)
    assert row["y0'"] == pytest.approx(-C_TRUE, rel=0.05)
    assert row["u0"] == pytest.approx(B_TRUE, rel=0.05)
    assert row["y0"] == 0.0  # pruned: not in the truth
    assert pem.refinement_["criterion"]["name"] == "prediction error"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a skipped refinement warns; either outcome is the point
        oe = _pendulum_model(OutputErrorRefinement(max_nfev=50, prune=0.01)).fit(u, y)
    row = _row(oe)
    refused = oe.refinement_["status"] == -1
    biased = any(abs(row[k] / v - 1) > 0.05 for k, v in (("sin(y0)", A_TRUE), ("y0'", -C_TRUE), ("u0", B_TRUE)))
    assert refused or biased


@pytest.mark.filterwarnings("ignore:the refinement stopped on its evaluation budget")
def test_van_der_pol_with_hidden_velocity():
    """A self-excited oscillator, position measured with 2 % noise: the true support, coefficients within 5 %."""
    rng = np.random.default_rng(0)
    truth = TermsRHS.from_equations([{V: 1.0}, {Y: -1.0, V: 1.0, ((0, 0, 2, 0), (1, 0, 1, 0)): -1.0, U: 0.5}])
    u = np.repeat(rng.uniform(-1, 1, 2000 // 40 + 1), 40)[:2000, None]
    x = simulate(truth, [2.0, 0.0], u, dt=0.05, n_substeps=4)
    y = x[:, :1] + 0.02 * np.std(x[:, 0]) * rng.normal(size=(2000, 1))
    model = HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=PolynomialLibrary(degree=3),
                             optimizer=STLS(threshold=0.1), dt=0.05,
                             refine=PredictionErrorRefinement(max_nfev=100, prune=0.02),
                             input_hold="zoh", differentiation=FiniteDifference()).fit(u, y)
    row = {k: v for k, v in _row(model).items() if v != 0}
    assert set(row) == {"y0", "y0'", "u0", "y0^2 y0'"}
    for name, value in (("y0", -1.0), ("y0'", 1.0), ("u0", 0.5), ("y0^2 y0'", -1.0)):
        assert row[name] == pytest.approx(value, rel=0.05), name


# ------------------------------------------------------------ estimator support
def test_sindy_model_file_equations_and_errors(rng, tmp_path):
    u, _, x = _duffing(rng, n=400)
    y = x + 0.01 * rng.normal(size=x.shape)
    model = SINDy(library=PolynomialLibrary(degree=3), optimizer=STLS(threshold=0.2), dt=0.05,
                  refine=PredictionErrorRefinement(prune=0.01, max_nfev=20))
    with pytest.warns(ConvergenceWarning, match="max_nfev=20"):
        model.fit(u, y)
    assert np.shape(model.refinement_["criterion"]["gain"]) == (2, 2)
    assert model.refinement_["cost"] < model.refinement_["initial_cost"]
    errors = model.standard_errors()
    assert "K[y0, 1]" in errors and all(np.isfinite(v) for v in errors.values())
    assert "±" in model.equations(errors=True)[1]
    path = tmp_path / "model.json"
    save_model(model, path)
    loaded = load_model(path)
    assert loaded.refine.get_params() == model.refine.get_params()
    assert loaded.refinement_["criterion"] == model.refinement_["criterion"]
    np.testing.assert_array_equal(loaded.predict(u, y_init=y), model.predict(u, y_init=y))


def test_output_error_unchanged_by_the_shared_solver(rng):
    """The output-error path through the shared rounds gives the exact optimum as before (no criterion fields)."""
    u, _, x = _duffing(rng, n=200)
    res = refine_simulation_error(Dynamics.from_terms(DUFFING, _start(0.9), dt=0.05, output_index=(0,)), u, x[:, :1],
                                  x0=[0.5, 0.0], free=FreeParameters(coef=DUFFING_FREE))
    np.testing.assert_allclose(res.coef, DUFFING_COEF, atol=1e-6)
    assert res.gain is None and "criterion" not in res.summary()


def _first_order_closed_loop(n=1500, noise=0.05, seed=1):
    """x' = 1.5 x + u (unstable) under u = r - 3 y with y = x + noise: the controller reacts to the noise."""
    rng = np.random.default_rng(seed)
    terms = [((0, 0, 1, 0),), ((1, 0, 1, 0),)]
    plant = TermsRHS([[1.5], [1.0]], terms, 1)
    r = np.repeat(rng.uniform(-1, 1, n // 50 + 1), 50)[:n]
    x, y, u = np.zeros(n), np.zeros(n), np.zeros(n)
    for k in range(n):
        y[k] = x[k] + noise * rng.normal()
        u[k] = r[k] - 3.0 * y[k]
        if k + 1 < n:
            x[k + 1] = simulate(plant, [x[k]], [[u[k]], [u[k]]], 0.05)[1, 0]
    return terms, u[:, None], y[:, None]


def test_closed_loop_assumptions():
    """Under feedback: the fitted gain gives the truth; a gain held at 0 is output error, which cannot follow."""
    terms, u, y = _first_order_closed_loop()
    start = [[1.2], [0.8]]
    res = refine_prediction_error(Dynamics.from_terms(terms, start, dt=0.05, output_index=(0,)), u, y, x0=[0.0])
    np.testing.assert_allclose(res.coef.ravel(), [1.5, 1.0], rtol=0.05)
    zero = np.zeros((1, 1))
    x, _, _ = predict_sensitivity(TermsRHS(start, terms, 1), [0.0], u[:50], y[:50], 0.05, gain=zero,
                                  sensitivities=False)
    np.testing.assert_array_equal(x, simulate(TermsRHS(start, terms, 1), [0.0], u[:50], 0.05))  # K = 0: open loop
    with pytest.raises(SimulationError, match="the starting predictor diverges at sample"):
        refine_prediction_error(Dynamics.from_terms(terms, start, dt=0.05, max_abs=1e6), u, y, x0=[0.0], gain=zero,
                                free_gain=False)
    with pytest.raises(SimulationError, match="cannot refine: the starting model's simulation diverges"):
        refine_simulation_error(Dynamics.from_terms(terms, start, dt=0.05, output_index=(0,), max_abs=1e6), u, y,
                                x0=[0.0])


@pytest.mark.filterwarnings("ignore:the refinement stopped on its evaluation budget")
def test_several_records_share_the_model(rng):
    """Two records: shared coefficients and gain, one first predicted state each, errors stacked."""
    u, y, _ = _duffing(rng, n=300, noise=0.02)
    u2, y2, _ = _duffing(np.random.default_rng(5), n=200, noise=0.02)
    res = refine_prediction_error(Dynamics.from_terms(DUFFING, _start(0.8), dt=0.05, output_index=(0,)), [u, u2],
                                  [y, y2], x0=[[0.5, 0.0], [0.5, 0.0]],
                                  free=FreeParameters(coef=DUFFING_FREE), solver=LeastSquares(max_nfev=100))
    np.testing.assert_allclose(res.coef[:, 1], DUFFING_COEF[:, 1], rtol=0.05)
    assert res.initial_states.shape == (2, 2) and res.record_samples == (300, 200)
    assert res.jac.shape[0] == 500 and ("x0", 1, 1) in res.parameters and res.gain.shape == (2, 1)

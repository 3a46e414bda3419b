"""TanksHiddenState: the simulated cascaded tanks (known truth) and the real benchmark."""

import numpy as np
import pytest

from sindybench import STLS, HiddenStateSINDy
from sindybench.datasets import load_cascaded_tanks
from sindybench.hidden import TanksHiddenState
from sindybench.libraries import SqrtLibrary
from sindybench.metrics import rmse
from sindybench.simulate import TermsRHS
from sindybench.systems import CascadedTanks

DT = 4.0


@pytest.fixture
def tanks_data(rng):
    n = 1000
    u = np.repeat(rng.uniform(1.0, 5.5, n // 50), 50)[:, None]
    system = CascadedTanks()
    x = system.simulate_states(u, dt=DT, x0=(3.0, 4.0))
    y = x[:, 1:2] + 0.005 * rng.standard_normal((n, 1))
    return system, u, y, x


def test_recovers_tank_coefficients(tanks_data):
    system, u, y, x = tanks_data
    model = HiddenStateSINDy(hidden=TanksHiddenState(), library=SqrtLibrary(variables=[0, 1]), dt=DT,
                             n_substeps=4, n_trials=60, random_state=0).fit(u, y)
    assert model.params_["k1"] == pytest.approx(system.k1, rel=0.15)
    assert model.params_["k2"] == pytest.approx(system.k2, rel=0.15)
    assert np.corrcoef(model.hidden_states_[:, 0], x[:, 0])[0, 1] > 0.98
    np.testing.assert_allclose(model.coef_[0], [-system.k4, system.k3], rtol=0.15)
    assert isinstance(model.rhs_, TermsRHS)  # the preset hidden rhs runs on the compiled path
    assert model.equations()[1].startswith("x1' = -0.0")
    i = 500 + int(np.argmax((x[500:, 0] > 2.0) & (x[500:, 0] < 8.0)))  # a start below the overflow
    x0 = model.estimate_initial_state(u[i:], y[i:i + 50])
    assert x0[1] == pytest.approx(x[i, 0], abs=1.0)


def test_fixed_coefficients_search_only_the_start_level(tanks_data):
    system, u, y, x = tanks_data
    hidden = TanksHiddenState(k1=system.k1, k2=system.k2, init="derivative")
    model = HiddenStateSINDy(hidden=hidden, library=SqrtLibrary(variables=[0, 1]), dt=DT, n_substeps=4,
                             n_trials=15, random_state=0).fit(u, y)
    assert set(model.best_params_) == {"hidden__x0"}
    assert 0.0 <= model.params_["x0"] <= 10.0
    assert model.score(u[500:], y[500:]) > 0.95


@pytest.mark.parametrize(
    "params, match",
    [
        ({"bounds": (-1.0, 10.0)}, "bounds must be"),
        ({"bounds": (0.0, None)}, "bounds must be"),
        ({"k1": -0.1}, "k1 must be a finite number > 0"),
        ({"k2": "big"}, "k2 must be a finite number > 0"),
        ({"k_bounds": (0.0, 0.1)}, "log-scaled"),
        ({"x0": 12.0}, "x0 must be a number within bounds"),
        ({"init": "guess"}, "init must be one of"),
    ],
)
def test_bad_parameters(tanks_data, params, match):
    _, u, y, _ = tanks_data
    with pytest.raises(ValueError, match=match):
        HiddenStateSINDy(hidden=TanksHiddenState(**params), dt=DT, n_trials=2).fit(u, y)


def test_one_input_one_output_only(tanks_data):
    _, u, y, _ = tanks_data
    with pytest.raises(ValueError, match="one input and one output"):
        HiddenStateSINDy(hidden=TanksHiddenState(k1=0.04, k2=0.03, x0=3.0), dt=DT).fit(u, np.hstack([y, y]))


# ------------------------------------------------------------------ real benchmark
def _fit_benchmark(data_home, *, k_bounds, n_trials, random_state):
    data = load_cascaded_tanks(data_home=data_home)
    train, val, test = data.train, data.validation, data.test
    model = HiddenStateSINDy(
        hidden=TanksHiddenState(k_bounds=k_bounds, output_bounds=(0.0, 10.0)), optimizer=STLS(threshold=0.0),
        dt=train.dt, validation_size=len(val.y), n_trials=n_trials, random_state=random_state, n_substeps=4,
    ).fit(np.vstack([train.u, val.u]), np.vstack([train.y, val.y]))
    return rmse(test.y, model.predict(test.u, y_init=test.y))


def test_cascaded_tanks_beats_bar(data_home):
    """Study: 0.55 V (naive SINDy 1.09 V); bar 0.60 V. Physically narrowed k range, 60 trials, seed 0."""
    assert _fit_benchmark(data_home, k_bounds=(0.02, 0.08), n_trials=60, random_state=0) <= 0.60


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cascaded_tanks_beats_bar_wide_search(data_home, seed):
    """The default k range (0.005, 0.2) needs a larger budget: 300 trials."""
    assert _fit_benchmark(data_home, k_bounds=(0.005, 0.2), n_trials=300, random_state=seed) <= 0.60

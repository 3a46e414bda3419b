"""TanksHiddenState: the simulated cascaded tanks (known truth) and the real benchmark."""

import numpy as np
import pytest

from sindybench import STLS, HiddenStateSINDy
from sindybench.datasets import load_cascaded_tanks
from sindybench.differentiation import FiniteDifference
from sindybench.hidden import ModelView, TanksHiddenState
from sindybench.libraries import ConcatLibrary, PolynomialLibrary, SqrtLibrary
from sindybench.metrics import rmse
from sindybench.search import Normal, Uniform
from sindybench.simulate import TermsRHS
from sindybench.systems import CascadedTanks

#: the settings these strategy tests were written with (HiddenStateSINDy's defaults before 0.2: no "auto")
BEFORE_AUTO = {"input_hold": "zoh", "refine": None, "differentiation": FiniteDifference()}

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
    model = HiddenStateSINDy(**BEFORE_AUTO, hidden=TanksHiddenState(), library=SqrtLibrary(variables=[0, 1]), dt=DT,
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
    model = HiddenStateSINDy(**BEFORE_AUTO, hidden=hidden, library=SqrtLibrary(variables=[0, 1]), dt=DT, n_substeps=4,
                             n_trials=15, random_state=0).fit(u, y)
    assert set(model.best_params_) == {"hidden__x0"}
    assert 0.0 <= model.params_["x0"] <= 10.0
    assert model.score(u[500:], y[500:]) > 0.95


@pytest.fixture(scope="module")
def smooth_tanks():
    """A model with the true k1, k2 fitted on a smooth record (its learned row close to the truth)."""
    t = np.arange(3000.0)
    u = (3.0 + 1.5 * np.sin(2 * np.pi * t / 500) + 0.8 * np.sin(2 * np.pi * t / 170))[:, None]
    system = CascadedTanks()
    y = system.simulate_states(u, dt=1.0, x0=(3.0, 4.0))[:, 1:2]
    model = HiddenStateSINDy(**BEFORE_AUTO, hidden=TanksHiddenState(k1=system.k1, k2=system.k2, x0=3.0),
                             library=SqrtLibrary(variables=[0, 1]), dt=1.0, n_substeps=4).fit(u, y)
    return system, u, y, model


def _new_record(system, level):
    """A record starting with the upper tank at ``level``: 30 samples without inflow, then a step."""
    u = np.r_[np.zeros(30), np.full(70, 3.0)][:, None]
    return u, system.simulate_states(u, dt=1.0, x0=(level, 5.0))[:, 1:2]


@pytest.mark.parametrize("level", [0.1, 0.2, 3.3, 7.1])
def test_hidden_start_level_recovered_from_the_grid_guess(smooth_tanks, level):
    # the guess is the best point of a 0.25-wide grid over [0, 10] (0.0 for the level 0.1: a start on the
    # bound at zero); the one estimator refines it within [0, 10] to the level that made the record
    system, _, _, model = smooth_tanks
    u, y = _new_record(system, level)
    fit = model.hidden_.initial_fit(model.params_, n_outputs=1, n_inputs=1)
    assert fit.n_samples == 50 and fit.free == (1,)
    assert fit.bounds[0].tolist() == [-np.inf, 0.0] and fit.bounds[1].tolist() == [np.inf, 10.0]
    x0 = model.estimate_initial_state(u, y[:50])
    guess = model.hidden_.initial_state(
        u[:50], y[:50], 1.0, derivative=model._candidate_.derivative, params=model.params_,
        model=ModelView(rhs=model.rhs_, simulate=lambda x, v: model.dynamics_.simulate(v, x)))
    assert guess[1] in np.linspace(0.0, 10.0, 41) and abs(guess[1] - level) > 0.01
    assert x0[0] == y[0, 0] and x0[1] == pytest.approx(level, abs=1e-3)


def test_search_and_predict_refine_through_the_one_estimator(smooth_tanks, monkeypatch):
    """Every validation block of the search and every start in ``predict`` go through estimate_initial_state."""
    import sindybench.hidden._refinement as refinement

    system, u, y, _ = smooth_tanks
    real, calls = refinement.estimate_initial_state, []

    def spy(*args, **kwargs):
        calls.append(kwargs)
        return real(*args, **kwargs)

    monkeypatch.setattr(refinement, "estimate_initial_state", spy)
    model = HiddenStateSINDy(**BEFORE_AUTO,
                             hidden=TanksHiddenState(k1=system.k1, k2=system.k2), library=SqrtLibrary(variables=[0, 1]),
                             dt=1.0, n_substeps=4, validation="block", n_trials=4, random_state=0).fit(u, y)
    assert len(calls) == 4 and all(c["free_x0"].tolist() == [1] for c in calls)
    calls.clear()
    u_new, y_new = _new_record(system, 3.3)
    y_pred = model.predict(u_new, y_init=y_new[:50])
    assert len(calls) == 1 and calls[0]["x0"][1] in np.linspace(0.0, 10.0, 41)  # refined from the grid's guess
    assert np.abs(y_pred - y_new).max() < 1e-2


@pytest.mark.parametrize(
    "params, match",
    [
        ({"bounds": (-1.0, 10.0)}, "bounds must be"),
        ({"bounds": (0.0, None)}, "bounds must be"),
        ({"k1": -0.1}, "k1 must be a finite number > 0"),
        ({"k2": "big"}, "k2 must be a finite number > 0"),
        ({"k_bounds": (0.0, 0.1)}, "log-scaled"),
        ({"ratio_bounds": (0.0, 3.0)}, r"ratio_bounds = \(0.0, 3.0\) is log-scaled; expected low > 0"),
        ({"ratio_bounds": (3.0, 0.3)}, "expected low < high"),
        ({"k_bounds": Uniform(-1.0, 1.0)}, r"k_bounds = Uniform\(low=-1.0, high=1.0\) reaches -1.0; expected positive"),
        ({"ratio_bounds": Normal(0.1, 0.1)}, "ratio_bounds = Normal.* expected positive values only"),
        ({"x0": 12.0}, "x0 must be a number within bounds"),
        ({"init": "guess"}, "init must be one of"),
    ],
)
def test_bad_parameters(tanks_data, params, match):
    _, u, y, _ = tanks_data
    with pytest.raises(ValueError, match=match):
        HiddenStateSINDy(**BEFORE_AUTO, hidden=TanksHiddenState(**params), dt=DT, n_trials=2).fit(u, y)


def test_negative_levels_are_refused(tanks_data):
    # before: a fit on levels shifted 5 V down was accepted (square roots of negative levels clipped to 0)
    _, u, y, _ = tanks_data
    with pytest.raises(ValueError, match=r"y has levels below the tanks' lower bound 0 \(first at sample \d+: -"):
        HiddenStateSINDy(**BEFORE_AUTO, hidden=TanksHiddenState(k1=0.04, k2=0.03, x0=3.0), dt=DT).fit(u, y - 5.0)


def test_one_input_one_output_only(tanks_data):
    _, u, y, _ = tanks_data
    with pytest.raises(ValueError, match="one input and one output"):
        HiddenStateSINDy(**BEFORE_AUTO,
                         hidden=TanksHiddenState(k1=0.04, k2=0.03, x0=3.0), dt=DT).fit(u, np.hstack([y, y]))


def test_ratio_search(tanks_data):
    """k1 and k2 / k1 searched (the valley of good (k1, k2) along one axis), whole-record validation."""
    system, u, y, x = tanks_data
    hidden = TanksHiddenState(ratio_bounds=(0.3, 3.0), k_bounds=(0.01, 0.1))
    model = HiddenStateSINDy(**BEFORE_AUTO,
                             hidden=hidden, library=SqrtLibrary(variables=[0, 1]), dt=DT, n_substeps=4, n_trials=40,
                             local_trials=10, validation="full", random_state=0).fit(u, y)
    assert set(model.best_params_) == {"hidden__k1", "hidden__ratio", "hidden__x0"}
    assert set(model.params_) == {"k1", "k2", "x0"}
    assert model.params_["k2"] == pytest.approx(model.params_["k1"] * model.best_params_["hidden__ratio"])
    assert model.params_["k2"] / model.params_["k1"] == pytest.approx(system.k2 / system.k1, rel=0.1)
    assert model.score(u[500:], y[500:]) > 0.95
    # a fixed k1 leaves k2 to k_bounds
    fixed = TanksHiddenState(k1=system.k1, ratio_bounds=(0.3, 3.0), k_bounds=(0.01, 0.1))
    assert sorted(fixed.search_space()) == ["k2", "x0"]


# ------------------------------------------------------------------ real benchmark
_LIBRARIES = {
    "polynomial": lambda: PolynomialLibrary(degree=2),
    "square root": lambda: ConcatLibrary([PolynomialLibrary(degree=1), SqrtLibrary(lower=0.0)]),
    "polynomial + square root": lambda: None,  # the strategy's default library
}


def _fit_benchmark(data_home, *, library="polynomial + square root", k_bounds=(0.02, 0.08), n_trials=60,
                   random_state=0, **kw):
    data = load_cascaded_tanks(data_home=data_home)
    train, val, test = data.train, data.validation, data.test
    hidden_kw = {k: kw.pop(k) for k in ("ratio_bounds",) if k in kw}
    model = HiddenStateSINDy(**BEFORE_AUTO, 
        hidden=TanksHiddenState(k_bounds=k_bounds, output_bounds=(0.0, 10.0), **hidden_kw),
        library=_LIBRARIES[library](), optimizer=STLS(threshold=0.0), dt=train.dt, validation_size=len(val.y),
        n_trials=n_trials, random_state=random_state, n_substeps=4, **kw,
    ).fit(np.vstack([train.u, val.u]), np.vstack([train.y, val.y]))
    # started from the first n_init = 5 test samples, as in the benchmark
    return rmse(test.y, model.predict(test.u, y_init=test.y[: data.n_init]))


def test_cascaded_tanks_beats_bar(data_home):
    """Study: 0.55 V (naive SINDy 1.09 V); bar 0.60 V. Physically narrowed k range, 60 trials, seed 0."""
    assert _fit_benchmark(data_home, n_trials=60, random_state=0) <= 0.60


# the settings of ``sindybench run cascaded-tanks --quick``: whole-record validation, (k1, k2 / k1) searched
_ROBUST = dict(validation="full", ratio_bounds=(0.3, 3.0), n_trials=60, local_trials=20)


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("library", ["polynomial", "polynomial + square root"])
def test_cascaded_tanks_robust_across_seeds(data_home, library, seed):
    """Every seed under the bar. Scored on the 256-sample validation block alone, the polynomial library at
    seed 0 drained the lower tank on the test (5.97 V): ``validation="full"`` rejects such candidates."""
    assert _fit_benchmark(data_home, library=library, random_state=seed, **_ROBUST) <= 0.60


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cascaded_tanks_square_root_library_is_not_far_off(data_home, seed):
    """The study's square-root library (study: 0.56 V) lands at 0.58-0.70 V here, never far off."""
    assert _fit_benchmark(data_home, library="square root", random_state=seed, **_ROBUST) <= 0.75


def test_block_validation_can_pick_a_drifting_model(data_home):
    """The failure the whole-record validation fixes (a known outcome, kept as a check of the diagnosis)."""
    assert _fit_benchmark(data_home, library="polynomial", n_trials=60, random_state=0) > 1.0


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cascaded_tanks_beats_bar_wide_search(data_home, seed):
    """The default k range (0.005, 0.2) needs a larger budget: 300 trials."""
    assert _fit_benchmark(data_home, k_bounds=(0.005, 0.2), n_trials=300, random_state=seed) <= 0.60

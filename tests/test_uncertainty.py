"""Uncertainty: calibration of the refined models' intervals, block-bootstrap ensembles, prediction bands.

Calibration runs on synthetic systems with the truth written here, one per
strategy family: plain SINDy (``y' = -y + 2 u``) and a hidden-state strategy
(the cascaded tanks, ``TanksHiddenState``: physical k1, k2 and the learned
lower-tank row). The quick versions (default) use 20 noise realizations and
assert a band that 20 runs can honestly hold (>= 80 %); ``--runslow`` uses 100
and asserts 90-99 %.
"""

import warnings

import numpy as np
import pytest
from scipy.signal import lfilter
from sklearn.utils.estimator_checks import parametrize_with_checks

from sindybench import STLS, DivergenceWarning, HiddenStateSINDy, SINDy, load_model
from sindybench.baselines import ARX, NNARX
from sindybench.differentiation import FiniteDifference
from sindybench.hidden import DerivativeHiddenState, TanksHiddenState
from sindybench.libraries import POW, PolynomialLibrary, SqrtLibrary
from sindybench.refine import OutputErrorRefinement
from sindybench.simulate import TermsRHS, simulate
from sindybench.systems import CascadedTanks
from sindybench.uncertainty import BootstrapEnsemble, circular_block_indices, prediction_band

DT = 0.05
TRUTH = {"y0': y0": -1.0, "y0': u0": 2.0}


def first_order_record(n=400):
    """``y' = -y + 2 u`` under a random staircase input (noise-free)."""
    u = np.repeat(np.random.default_rng(1).uniform(-1, 1, n // 20), 20)[:, None]
    x = simulate(TermsRHS([[-1.0], [2.0]], [((0, POW, 1, 0),), ((1, POW, 1, 0),)], 1), [0.5], u, DT)
    return u, x


def noise(rng, n, std, phi=0.0):
    """White (``phi = 0``) or AR(1) colored noise of standard deviation ``std``."""
    e = lfilter([1.0], [1.0, -phi], rng.standard_normal(n))
    return (std * e / np.std(e) if phi else std * e)[:, None]


def sindy(refine=True):
    return SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.2), dt=DT,
                 refine=OutputErrorRefinement(max_nfev=50) if refine else None)


def coverage(intervals, truth):
    return [intervals[name][0] <= value <= intervals[name][1] for name, value in truth.items()]


@pytest.fixture
def n_runs(runslow):
    return 100 if runslow else 20


def assert_calibrated(hits, runslow):
    rate = float(np.mean(hits))
    if runslow:
        assert 0.90 <= rate <= 0.99, rate
    else:
        assert rate >= 0.80, rate


# ------------------------------------------------------------------ calibration: plain SINDy
def test_plain_sindy_intervals_cover_the_truth_under_white_noise(n_runs, runslow):
    u, x = first_order_record()
    hits = []
    for k in range(n_runs):
        y = x + noise(np.random.default_rng(1000 + k), len(x), 0.05)
        hits += coverage(sindy().fit(u, y).confidence_intervals(0.05), TRUTH)
    assert_calibrated(hits, runslow)  # measured: 0.94 (y0), 0.99 (u0) over 100 runs


def test_colored_noise_lowers_the_white_coverage_and_the_hac_estimate_restores_it(n_runs, runslow):
    """AR(1) noise, phi = 0.9: the white intervals are too narrow; Newey-West (``kind="hac"``) widens them."""
    u, x = first_order_record()
    white, hac = [], []
    for k in range(n_runs):
        y = x + noise(np.random.default_rng(1000 + k), len(x), 0.05, phi=0.9)
        model = sindy().fit(u, y)
        white += coverage(model.confidence_intervals(0.05), TRUTH)
        hac += coverage(model.confidence_intervals(0.05, kind="hac"), TRUTH)
    # measured over 100 runs: white 0.37 / 0.44, hac 0.86 / 0.89
    assert np.mean(white) < 0.6
    assert np.mean(hac) >= (0.82 if runslow else 0.75)
    assert np.mean(hac) > np.mean(white) + 0.25


@pytest.mark.slow
def test_block_bootstrap_covers_under_colored_noise():
    """The percentile intervals of 40-member block-bootstrap ensembles, AR(1) noise phi = 0.9 (100 runs)."""
    u, x = first_order_record()
    hits = []
    for k in range(100):
        y = x + noise(np.random.default_rng(1000 + k), len(x), 0.05, phi=0.9)
        lower, upper = BootstrapEnsemble(sindy(), n_members=40, random_state=k).fit(u, y).coefficient_intervals()
        hits += [lower[0, 1] <= -1.0 <= upper[0, 1], lower[0, 2] <= 2.0 <= upper[0, 2]]
    assert np.mean(hits) >= 0.8  # measured 0.85 / 0.90 over the first 20 runs


def test_block_bootstrap_widens_with_colored_noise():
    """Quick check of the correction: under colored noise the bootstrap spread exceeds the white standard error."""
    u, x = first_order_record()
    y = x + noise(np.random.default_rng(7), len(x), 0.05, phi=0.9)
    ens = BootstrapEnsemble(sindy(), n_members=30, random_state=0).fit(u, y)
    white = ens.estimator_.standard_errors()
    assert ens.block_length_ > 10  # the residuals' correlation sets the blocks (n^(1/3) = 7.4)
    assert np.std(ens.coef_[:, 0, 1]) > 2 * white["y0': y0"]


# ------------------------------------------------------------------ calibration: hidden states (tanks)
TANKS_DT = 4.0


def tanks_record(n=500):
    rng = np.random.default_rng(0)
    u = np.repeat(rng.uniform(1.0, 6.5, n // 40 + 1), 40)[:n, None]
    system = CascadedTanks(k3=0.05)
    return system, u, system.simulate_states(u, dt=TANKS_DT, x0=(3.0, 2.0))


def tanks_model(system, max_nfev=60):
    hidden = TanksHiddenState(k1=system.k1 * 1.1, k2=system.k2 * 0.95, x0=5.0, output_bounds=(0.0, 10.0))
    return HiddenStateSINDy(hidden=hidden, library=SqrtLibrary(variables=[0, 1]), dt=TANKS_DT, n_substeps=4,
                            refine=OutputErrorRefinement(max_nfev=max_nfev, n_segments=5),
                            input_hold="zoh", differentiation=FiniteDifference())


def test_tanks_intervals_cover_the_physical_parameters_and_coefficients(n_runs, runslow):
    system, u, x = tanks_record()
    truth = {"k1": system.k1, "k2": system.k2, "y0': sqrt(y0)": -system.k4, "y0': sqrt(x1)": system.k3}
    hits = []
    for k in range(n_runs):
        y = x[:, 1:2] + noise(np.random.default_rng(100 + k), len(x), 0.01 * np.std(x[:, 1]))
        model = tanks_model(system).fit(u, y)
        assert not model.refinement_["budget_exhausted"]
        hits += coverage(model.confidence_intervals(0.05), truth)
    assert_calibrated(hits, runslow)


# ------------------------------------------------------------------ inclusion probabilities
def test_inclusion_probabilities_separate_true_from_spurious_terms():
    u, x = first_order_record()
    y = x + noise(np.random.default_rng(3), len(x), 0.005)
    model = SINDy(library=PolynomialLibrary(degree=2), optimizer=STLS(threshold=0.2), dt=DT,
                  refine=OutputErrorRefinement(max_nfev=50))
    ens = BootstrapEnsemble(model, n_members=30, random_state=0).fit(u, y)
    names = ens.estimator_.feature_names_  # 1, y0, u0, y0^2, y0 u0, u0^2
    p = dict(zip(names, ens.inclusion_probabilities_[0]))
    assert p["y0"] >= 0.9 and p["u0"] >= 0.9
    assert all(p[n] <= 0.2 for n in names if n not in ("y0", "u0")), p
    np.testing.assert_allclose(ens.median_coef()[0, [1, 2]], [-1.0, 2.0], rtol=0.01)


# ------------------------------------------------------------------ reporting on the estimators
def test_standard_errors_names_equations_and_saved_models(tmp_path):
    u, x = first_order_record()
    y = x + noise(np.random.default_rng(0), len(x), 0.05)
    model = sindy().fit(u, y)
    se = model.standard_errors()
    assert list(se) == ["y0': y0", "y0': u0", "y0(0)"]
    assert 0.005 < se["y0': y0"] < 0.05
    (line,) = model.equations(errors=True)
    slope = se["y0': y0"]
    assert line.startswith("y0' = -(1.0") and f"± {slope:.2g}"[:5] in line
    assert model.equations() == sindy().fit(u, y).equations()  # the default is unchanged
    assert r"\pm" in model.equations(errors=True, latex=True)[0]
    path = tmp_path / "model.json"
    model.to_json(path)
    assert load_model(path).standard_errors() == se
    with pytest.raises(ValueError, match="fitted without refine"):
        sindy(refine=False).fit(u, y).standard_errors()
    with pytest.raises(ValueError, match="kind must be one of"):
        model.standard_errors(kind="bayes")
    model.refinement_.pop("covariance")  # as in a file written before covariances were recorded
    with pytest.raises(ValueError, match="a model file written before covariances were recorded"):
        model.standard_errors()


# ------------------------------------------------------------------ ensembles of a hidden-state model, bands, files
def test_tanks_ensemble_bands_and_json_round_trip(tmp_path):
    system, u, x = tanks_record()
    y = x[:, 1:2] + noise(np.random.default_rng(5), len(x), 0.01 * np.std(x[:, 1]))
    ens = BootstrapEnsemble(tanks_model(system), n_members=12, random_state=0).fit(u, y)
    assert len(ens.members_) + ens.n_failed_ == 12 and ens.coef_.shape == (len(ens.members_), 1, 2)
    lower, upper = ens.parameter_intervals()["k1"]
    assert lower < system.k1 < upper and upper - lower < 0.02 * system.k1
    assert isinstance(ens.median_model(), HiddenStateSINDy)
    learned, fixed = ens.estimator_.equations(errors=True)
    assert learned.count("±") == 2 and fixed == ens.estimator_.equations()[1]  # the fixed row has no free entry
    band = prediction_band(ens, u, y_init=y[:5], states=True)
    assert band.names == ["y0", "x1"] and band.outputs == [0] and band.samples.shape == (len(ens.members_), 500, 2)
    assert np.all(band.lower <= band.median) and np.all(band.median <= band.upper)
    truth = x[:, [1, 0]]  # the model's states: the measured lower level, then the hidden upper one
    assert np.mean(np.abs(band.median - truth), axis=0).max() < 0.05
    measured = prediction_band(ens, u, y_init=y[:5], noise=True, random_state=0)
    assert measured.coverage(y) > 0.7  # model and noise (measured 0.86); the model alone is narrower
    model_only = prediction_band(ens, u, y_init=y[:5])
    assert measured.coverage(y) > model_only.coverage(y)
    # the noise added to a band already simulated: the same band, without simulating the members again
    again = model_only.with_noise(ens, random_state=0)
    for field in ("median", "lower", "upper", "samples"):
        np.testing.assert_array_equal(getattr(again, field), getattr(measured, field))
    assert again.n_diverged == measured.n_diverged and not np.array_equal(model_only.samples, measured.samples)
    path = tmp_path / "ensemble.json"
    ens.to_json(path)
    loaded = load_model(path)
    np.testing.assert_array_equal(loaded.coef_, ens.coef_)
    np.testing.assert_array_equal(prediction_band(loaded, u, y_init=y[:5], states=True).samples, band.samples)


def test_ensemble_of_a_derivative_hidden_state_model():
    """A second strategy: the velocity of ``y'' = -4 y - 0.5 y' + 2 u`` as a hidden state, refined."""
    t = np.arange(400) * DT
    u = (np.sin(0.9 * t) + 0.6 * np.sin(2.3 * t + 1.0))[:, None]
    rhs = TermsRHS([[1.0, -0.5], [0.0, -4.0], [0.0, 2.0]], [((1, POW, 1, 0),), ((0, POW, 1, 0),), ((2, POW, 1, 0),)],
                   2)
    x = simulate(rhs, [0.0, 0.0], u, DT)
    y = x[:, :1] + noise(np.random.default_rng(2), len(x), 0.001 * np.std(x[:, 0]))
    model = HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=PolynomialLibrary(degree=1),
                             optimizer=STLS(threshold=0.05), dt=DT, refine=OutputErrorRefinement(max_nfev=30),
                             input_hold="zoh", differentiation=FiniteDifference())
    ens = BootstrapEnsemble(model, n_members=8, random_state=0).fit(u, y)
    names = list(ens.estimator_.library_.get_feature_names_out(["y0", "y0'", "u0"]))
    p = dict(zip(names, ens.inclusion_probabilities_[0]))
    assert p["y0"] == p["y0'"] == p["u0"] == 1.0 and p["1"] <= 0.25
    median = dict(zip(names, ens.median_coef()[0]))
    np.testing.assert_allclose([median["y0"], median["y0'"], median["u0"]], [-4.0, -0.5, 2.0], rtol=0.05)
    band = prediction_band(ens, u, y_init=y[:10], states=True)
    assert band.names == ["y0", "y0'"] and np.mean(np.abs(band.median - x)) < 0.05 * np.std(x)


@pytest.mark.slow
def test_parallel_ensemble_equals_the_serial_one():
    u, x = first_order_record()
    y = x + noise(np.random.default_rng(0), len(x), 0.05)
    serial = BootstrapEnsemble(sindy(), n_members=6, random_state=0).fit(u, y)
    parallel = BootstrapEnsemble(sindy(), n_members=6, random_state=0, n_jobs=2).fit(u, y)
    np.testing.assert_array_equal(serial.coef_, parallel.coef_)


def test_circular_blocks_wrap_and_cover_every_sample_equally():
    idx = np.concatenate([circular_block_indices(50, 7, np.random.default_rng(k)) for k in range(400)])
    counts = np.bincount(idx, minlength=50)
    assert counts.min() > 0.8 * counts.mean() and counts.max() < 1.2 * counts.mean()
    one = circular_block_indices(50, 7, np.random.default_rng(0))
    steps = np.diff(one) % 50
    assert set(np.unique(steps[np.arange(49) % 7 != 6])) == {1}  # consecutive (on the circle) within a block


@pytest.mark.parametrize("params, match", [
    ({"n_members": 1}, "n_members must be an integer >= 2"),
    ({"block_length": 0}, "block_length must be an integer >= 1"),
    ({"block_length": 10_000}, "block_length=10000 exceeds the 400 samples"),
])
def test_ensemble_bad_params(params, match):
    u, x = first_order_record()
    with pytest.raises(ValueError, match=match):
        BootstrapEnsemble(sindy(refine=False), **params).fit(u, x)


def test_ensemble_refuses_several_records():
    # before: the estimator was fitted on the lists, then a numpy "inhomogeneous shape" or "3 dimensions" error
    t = np.arange(0, 2, 0.01)
    y1, y2 = np.exp(-t)[:, None], 2 * np.exp(-t[:150])[:, None]
    ens = BootstrapEnsemble(SINDy(library=PolynomialLibrary(degree=1), dt=0.01), n_members=2)
    with pytest.raises(ValueError, match="resamples the residuals of one record; got a list of 2 records"):
        ens.fit(None, [y1, y2])


def test_prediction_band_bad_input():
    u, x = first_order_record()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ens = BootstrapEnsemble(sindy(refine=False), n_members=3, random_state=0).fit(u, x + 0.01)
    with pytest.raises(ValueError, match="give exactly one of x0 and y_init"):
        prediction_band(ens, u)
    with pytest.raises(ValueError, match="alpha must be in"):
        prediction_band(ens, u, x0=[0.5], alpha=2.0)
    # the intervals check alpha as the bands do (before: numpy's "Quantiles must be in the range [0, 1]", or
    # alpha=0 silently gave the members' minimum and maximum)
    for bad in (0.0, 1.5, "0.05", True):
        with pytest.raises(ValueError, match=r"alpha must be in \(0, 1\) \(0.05 gives 95 % intervals\)"):
            ens.coefficient_intervals(alpha=bad)
        with pytest.raises(ValueError, match=r"alpha must be in \(0, 1\)"):
            ens.parameter_intervals(alpha=bad)
    lo, hi = ens.coefficient_intervals(alpha=np.float64(0.1))
    assert np.all(lo <= hi)


@pytest.mark.filterwarnings("ignore::UserWarning")
# scikit-learn's checks draw random data whose fitted first-order model grows past SINDy's default
# divergence level (max_abs=1e6, shared with HiddenStateSINDy): these checks are about the API, so no limit
@parametrize_with_checks(
    [BootstrapEnsemble(SINDy(dt=0.1, library=PolynomialLibrary(degree=1), max_abs=np.inf), n_members=3,
                       random_state=0)],
    expected_failed_checks=lambda estimator: {
        "check_estimators_empty_data_messages": "X with zero columns is valid: an autonomous system has no inputs"},
)
def test_ensemble_is_a_scikit_learn_estimator(estimator, check):
    check(estimator)


# ------------------------------------------------------------------ diverging members, bands of other ensembles
_FITTED = {}


def _ensemble_with_diverging_members(n_diverging, n_members=5):
    """A fitted 5-member ensemble of ``y' = -y + 2 u`` whose first ``n_diverging`` members are made to blow up."""
    import copy

    u, x = first_order_record()
    y = x + noise(np.random.default_rng(3), len(x), 0.02)
    if n_members not in _FITTED:  # fitted once per size; each caller edits its own copy
        _FITTED[n_members] = BootstrapEnsemble(sindy(refine=False), n_members=n_members, random_state=0).fit(u, y)
    ens = copy.deepcopy(_FITTED[n_members])
    for member in ens.members_[:n_diverging]:
        member.coef_ = member.coef_.copy()
        member.coef_[0, 1] = 50.0  # y' = +50 y + ...: e^1000 over the record
        member._rebuild_model()
    return ens, u, y


def test_a_band_with_a_few_diverging_members_warns_and_says_how_many():
    ens, u, y = _ensemble_with_diverging_members(1)
    with pytest.warns(DivergenceWarning, match="1 of 5 ensemble members diverged .* the band is over the 4 others"):
        band = prediction_band(ens, u, y_init=y[:5], alpha=0.5)
    assert band.n_diverged == 1 and np.all(np.isfinite(band.lower)) and np.all(band.upper[1:] - band.lower[1:] > 0)  # all start at y_init[0]


@pytest.mark.parametrize("n_diverging, alpha", [(1, 0.05), (4, 0.05), (4, 0.9), (5, 0.5)])
def test_a_band_is_refused_when_too_few_members_survive(n_diverging, alpha):
    # before: 4 of 5 diverged gave the survivor as a band of width 0.0; 5 of 5 NaN at 383 of 400 samples, silently
    ens, u, y = _ensemble_with_diverging_members(n_diverging)
    with pytest.raises(ValueError, match=f"{n_diverging} of 5 ensemble members diverged on these inputs .*: a .* band may leave out at most"):
        prediction_band(ens, u, y_init=y[:5], alpha=alpha)


def test_band_coverage_and_with_noise_check_their_arguments():
    ens, u, y = _ensemble_with_diverging_members(0)
    band = prediction_band(ens, u, y_init=y[:5])
    assert 0.0 <= band.coverage(y) <= 1.0
    y_nan = y.copy()
    y_nan[3] = np.nan
    with pytest.raises(ValueError, match=r"y contains NaN or inf"):  # before: 0.0
        band.coverage(y_nan)
    with pytest.raises(ValueError, match=r"y has shape \(399, 1\); expected \(400, 1\)"):
        band.coverage(y[1:])
    other, _, _ = _ensemble_with_diverging_members(0, n_members=2)
    other.residuals_ = other.residuals_ * 3.0
    with pytest.raises(ValueError, match="not the BootstrapEnsemble that made this band"):  # before: its residuals
        band.with_noise(other)


def test_bands_and_ensembles_name_what_they_take():
    u, x = first_order_record()
    model = sindy(refine=False).fit(u, x)
    with pytest.raises(ValueError, match="ensemble must be a fitted BootstrapEnsemble; got SINDy"):
        prediction_band(model, u, y_init=x[:5])  # before: 'SINDy' object has no attribute 'members_'
    for est in (ARX(), NNARX()):  # before: AttributeError: 'ARX' object has no attribute 'x0_'
        with pytest.raises(ValueError, match=f"estimator must be a SINDy or HiddenStateSINDy .*got {type(est).__name__}"):
            BootstrapEnsemble(est, n_members=2).fit(u, x)
    ens, _, _ = _ensemble_with_diverging_members(0, n_members=2)
    for bad in (np.nan, -0.1, 1.5, "0.5", None):  # before: nan gave all zeros
        with pytest.raises(ValueError, match="min_inclusion must be a number in"):
            ens.median_coef(min_inclusion=bad)

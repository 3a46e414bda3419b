"""STLS core: agreement with pysindy.STLSQ, the Gram cache, the estimator, bad input."""

import warnings

import numpy as np
import pytest
from pysindy.optimizers import STLSQ
from sklearn.exceptions import ConvergenceWarning
from sklearn.model_selection import GridSearchCV

from sindybench import STLS, stls
from sindybench._stls import GramCache, _shared, clear_stls_cache


def _problem(rng, kind, n=300, p=12, n_targets=3):
    X = rng.normal(size=(n, p))
    if kind == "collinear":
        X[:, 1] = X[:, 0] + 1e-3 * rng.normal(size=n)  # nearly collinear
        X[:, 3] = X[:, 2] - X[:, 4] + 1e-3 * rng.normal(size=n)
    elif kind == "duplicate":
        X[:, 5] = X[:, 4]  # exactly collinear: only well posed with a ridge penalty
    elif kind == "scaled":
        X = X * 10.0 ** rng.uniform(-3, 3, size=p)
    W = rng.normal(size=(p, n_targets)) * (rng.random((p, n_targets)) < 0.4)
    if kind == "scaled":
        W = W / np.abs(X).mean(axis=0)[:, None]
    y = X @ W + 0.01 * rng.normal(size=(n, n_targets))
    return X, y


SETTINGS = [
    dict(threshold=0.1, alpha=0.0, normalize_columns=False, unbias=True),
    dict(threshold=0.2, alpha=0.05, normalize_columns=False, unbias=False),
    dict(threshold=0.3, alpha=0.5, normalize_columns=True, unbias=True),
    dict(threshold=0.05, alpha=0.1, normalize_columns=True, unbias=False),
    dict(threshold=0.1, alpha=0.0, normalize_columns=False, unbias=True, max_iter=1),
]


@pytest.mark.parametrize("kind", ["random", "collinear", "duplicate", "scaled"])
@pytest.mark.parametrize("settings", SETTINGS, ids=lambda s: "-".join(f"{k}={v}" for k, v in s.items()))
def test_agrees_with_pysindy(rng, kind, settings):
    if kind == "duplicate" and settings["alpha"] == 0:
        pytest.skip("exactly collinear columns without ridge: no unique solution to agree on")
    X, y = _problem(rng, kind)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # pysindy's and our convergence warnings
        ref = STLSQ(**settings).fit(X, y).coef_.T
        coef, n_iter = stls(X, y, **settings)
    assert coef.shape == (X.shape[1], y.shape[1])
    assert np.array_equal(coef != 0, ref != 0)
    assert 0 < np.count_nonzero(coef) < coef.size  # a real selection happened
    np.testing.assert_allclose(coef, ref, rtol=1e-8, atol=1e-8 * np.abs(ref).max())
    assert 1 <= n_iter <= settings.get("max_iter", 20)


def test_recovers_sparse_truth(rng):
    X = rng.normal(size=(500, 8))
    W = np.zeros((8, 2))
    W[[0, 3], 0] = [1.5, -0.7]
    W[[1, 6], 1] = [2.0, 0.4]
    coef, _ = stls(X, X @ W, threshold=0.1)
    np.testing.assert_allclose(coef, W, atol=1e-10)


def test_one_dimensional_target_gives_one_dimensional_coef(rng):
    X, y = _problem(rng, "random", n_targets=1)
    coef_1d, _ = stls(X, y[:, 0], threshold=0.1)
    coef_2d, _ = stls(X, y, threshold=0.1)
    assert coef_1d.shape == (X.shape[1],)
    np.testing.assert_allclose(coef_1d, coef_2d[:, 0])


def test_large_threshold_eliminates_everything(rng):
    X, y = _problem(rng, "random")
    coef, n_iter = stls(X, y, threshold=1e6)
    assert not coef.any()
    assert n_iter == 1


def test_max_iter_reached_warns(rng):
    X, y = _problem(rng, "random", p=20)
    with pytest.warns(ConvergenceWarning, match="max_iter=1"):
        stls(X, y, threshold=0.5, max_iter=1)


def test_normalize_columns_is_scale_invariant(rng):
    X, y = _problem(rng, "random")
    scale = 10.0 ** rng.uniform(-2, 2, size=X.shape[1])
    coef, _ = stls(X, y, threshold=0.3, normalize_columns=True)
    coef_scaled, _ = stls(X * scale, y, threshold=0.3, normalize_columns=True)
    np.testing.assert_allclose(coef_scaled * scale[:, None], coef, rtol=1e-9, atol=1e-12)


# ---------------------------------------------------------------- Gram cache


def test_cache_gives_same_result_over_a_grid(rng):
    X, y = _problem(rng, "random")
    cache = GramCache(X, y)
    np.testing.assert_allclose(cache.gram, X.T @ X, rtol=1e-10)
    np.testing.assert_allclose(cache.projected_target, X.T @ y, rtol=1e-10, atol=1e-9)
    for threshold in (0.0, 0.05, 0.3, 1.0):
        for alpha in (0.0, 0.2):
            with_cache, _ = stls(X, y, threshold=threshold, alpha=alpha, cache=cache)
            without, _ = stls(X, y, threshold=threshold, alpha=alpha)
            np.testing.assert_allclose(with_cache, without, rtol=1e-12, atol=1e-14)


def test_cache_from_other_data_is_refused(rng):
    X, y = _problem(rng, "random")
    cache = GramCache(X, y)
    X2 = X.copy()
    X2[7, 3] += 1e-6
    with pytest.raises(ValueError, match="cache was built from other data"):
        stls(X2, y, threshold=0.1, cache=cache)
    with pytest.raises(ValueError, match="cache was built from other data"):
        stls(X[::-1], y[::-1] + 1.0, threshold=0.1, cache=cache)
    with pytest.raises(ValueError, match="cache must be a GramCache"):
        stls(X, y, threshold=0.1, cache="yes")


def test_estimator_cache_hits_on_equal_content(rng):
    clear_stls_cache()
    X, y = _problem(rng, "random")
    STLS(threshold=0.1).fit(X, y)
    assert len(_shared) == 1
    STLS(threshold=0.3, alpha=0.1).fit(X.copy(), y.copy())  # new objects, same content
    assert len(_shared) == 1
    STLS(threshold=0.3, cache=False).fit(X, y)
    assert len(_shared) == 1


def test_estimator_never_returns_stale_result(rng):
    clear_stls_cache()
    X, y = _problem(rng, "random")
    model = STLS(threshold=0.1)
    first = model.fit(X, y).coef_.copy()
    X[:, 2] *= 3.0  # in place: same object, same shape, other content
    y[10:20] = y[20:30].copy()
    second = model.fit(X, y).coef_
    expected, _ = stls(X, y, threshold=0.1)
    np.testing.assert_allclose(second, expected.T, rtol=1e-12)
    assert not np.allclose(second, first)
    assert len(_shared) == 2


def test_rows_swapped_is_other_data(rng):
    X, y = _problem(rng, "random")
    cache = GramCache(X, y)
    Xs = X.copy()
    Xs[[0, 1]] = Xs[[1, 0]]
    assert cache.matches(X, y)
    assert not cache.matches(Xs, y)


# ---------------------------------------------------------------- estimator


def test_estimator_matches_function(rng):
    X, y = _problem(rng, "scaled")
    model = STLS(threshold=0.2, alpha=0.05, normalize_columns=True).fit(X, y)
    coef, n_iter = stls(X, y, threshold=0.2, alpha=0.05, normalize_columns=True)
    np.testing.assert_allclose(model.coef_, coef.T, rtol=1e-12)
    assert model.n_iter_ == n_iter
    assert np.array_equal(model.ind_, coef.T != 0)
    np.testing.assert_allclose(model.predict(X), X @ coef, rtol=1e-12)


def test_grid_search_selects_threshold(rng):
    X = rng.normal(size=(400, 6))
    y = X @ [1.0, 0.0, -0.5, 0.0, 0.0, 0.0] + 0.3 * rng.normal(size=400)
    search = GridSearchCV(STLS(), {"threshold": [0.0, 0.1, 0.8]}, cv=3).fit(X, y)
    assert search.best_params_["threshold"] == 0.1
    assert np.count_nonzero(search.best_estimator_.coef_) == 2


@pytest.mark.parametrize(
    "params, match",
    [
        (dict(threshold=-0.1), "threshold must be a finite number >= 0"),
        (dict(threshold=np.nan), "threshold must be a finite number >= 0"),
        (dict(alpha=-1.0), "alpha must be a finite number >= 0"),
        (dict(max_iter=0), "max_iter must be an integer >= 1"),
        (dict(max_iter=2.5), "max_iter must be an integer >= 1"),
        (dict(normalize_columns="yes"), "normalize_columns must be True or False"),
        (dict(unbias=None), "unbias must be True or False"),
        (dict(cache=1), "cache must be True or False"),
    ],
)
def test_estimator_bad_params(rng, params, match):
    X, y = _problem(rng, "random")
    with pytest.raises(ValueError, match=match):
        STLS(**params).fit(X, y)


def test_function_bad_data(rng):
    X, y = _problem(rng, "random")
    bad = X.copy()
    bad[3, 1] = np.inf
    with pytest.raises(ValueError, match="theta contains NaN or inf"):
        stls(bad, y, threshold=0.1)
    with pytest.raises(ValueError, match="target has 299 samples; expected 300"):
        stls(X, y[1:], threshold=0.1)
    with pytest.raises(ValueError, match="theta has 3 dimensions"):
        stls(X[:, :, None], y, threshold=0.1)


# --- data far from unit magnitude (issue 18, case 6) ---------------------------------------------

def _with_constant(rng, n=200):
    theta = rng.normal(size=(n, 3))
    theta[:, 0] = 1.0
    return theta, theta @ np.array([0.3, 2.0, -0.5])


@pytest.mark.parametrize("scale", [1e-16, 1e-20, 1e-200, 1e-300])
@pytest.mark.parametrize("threshold", [0.0, 0.1])
def test_tiny_columns_beside_a_constant_are_not_dropped(rng, scale, threshold):
    # before: lstsq's rank cut-off treated the tiny columns as zero, and every coefficient was 0
    theta, target = _with_constant(rng)
    theta[:, 1:] *= scale
    coef, _ = stls(theta, target, threshold=threshold)
    np.testing.assert_allclose(coef, [0.3, 2.0 / scale, -0.5 / scale], rtol=1e-10)


@pytest.mark.parametrize("scale", [1e150, 1e300, 1e307])
@pytest.mark.parametrize("normalize_columns", [False, True])
def test_huge_library_matrix(rng, scale, normalize_columns):
    # before: the coefficients ~1/scale fell under the unbias support cut (all zero), and with
    # normalize_columns the column norms overflowed
    theta, target = _with_constant(rng)
    coef, _ = stls(theta * scale, target, threshold=0.0, normalize_columns=normalize_columns)
    np.testing.assert_allclose(coef * scale, [0.3, 2.0, -0.5], rtol=1e-10)
    coef, _ = stls(theta * scale, target * scale, threshold=0.1, alpha=1e-3, normalize_columns=normalize_columns)
    np.testing.assert_allclose(coef, [0.3, 2.0, -0.5], rtol=1e-3)


def test_threshold_and_ridge_stay_in_original_units(rng):
    theta, target = _with_constant(rng)
    theta[:, 1:] *= 1e-20
    # the true coefficients are 0.3, 2e20 and -5e19: a threshold of 1.0 removes only the constant's
    coef, _ = stls(theta, target, threshold=1.0)
    assert coef[0] == 0.0 and coef[1] != 0.0 and coef[2] != 0.0
    # the ridge penalty alpha ||coef||^2 is on the coefficients of about 1e20: negligible for alpha = 1e-46
    # (n_samples = 200 against alpha * 4e40), dominant for alpha = 1e-30
    ridge, _ = stls(theta, target, threshold=0.0, alpha=1e-46, unbias=False)
    np.testing.assert_allclose(ridge, [0.3, 2e20, -5e19], rtol=1e-6)
    ridge, _ = stls(theta, target, threshold=0.0, alpha=1e-30, unbias=False)
    assert np.all(np.abs(ridge[1:]) < 1e-3 * np.array([2e20, 5e19]))


def test_rescaling_leaves_ordinary_data_bit_identical(rng):
    # column magnitudes within 2**40 of each other are not touched: the same arithmetic as before
    X, y = _problem(rng, "scaled")
    cache = GramCache(X, y)
    assert np.all(cache._theta_scale == 1.0) and np.all(cache._target_scale == 1.0)
    ref = np.linalg.qr(np.hstack([X, y]), mode="r")
    np.testing.assert_array_equal(cache._a, ref[: X.shape[1], : X.shape[1]])


def test_overflowing_coefficients_are_refused(rng):
    theta, target = _with_constant(rng)
    with pytest.raises(ValueError, match="STLS coefficients overflow"):
        stls(theta * 1e-300, target * 1e300, threshold=0.0)


@pytest.mark.parametrize("scale", [1e-16, 1e-100])
def test_sindy_on_tiny_data(scale):
    from sindybench import SINDy
    from sindybench.libraries import PolynomialLibrary
    from sindybench.simulate import simulate

    t = np.arange(0, 10, 0.01)
    u = np.sin(t)[:, None]
    y = simulate(lambda x, u: np.array([-2.0 * x[0] + u[0]]), [0.5], u, dt=0.01, input_hold="linear")
    ref = SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.0), dt=0.01).fit(u, y)
    model = SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.0), dt=0.01)
    model.fit(u * scale, y * scale)  # before: an all-zero model
    np.testing.assert_allclose(model.coef_[0, 1:], ref.coef_[0, 1:], rtol=1e-9)
    np.testing.assert_allclose(model.coef_[0, 1:], [-2.0, 1.0], rtol=1e-4)


def test_huge_ridge_on_rescaled_columns_pins_them_to_zero():
    # found by tests/test_fuzz_estimators.py: the ridge rows sqrt(alpha) / scale overflowed to inf
    # and lstsq failed ("SVD did not converge") instead of returning the fully penalized zero
    theta, target = np.array([[0.0], [1e-301]]), np.array([0.84, 0.89])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        coef, _ = stls(theta, target, threshold=0.0, alpha=1e300, max_iter=1, unbias=False)
    assert coef.tolist() == [0.0]


@pytest.mark.parametrize("scale", [1e150, 1e300])
def test_a_threshold_in_other_units_than_the_library_warns(rng, scale):
    # before: theta * 1e300 with a threshold of 0.1 gave an all-zero model without a word
    theta, target = _with_constant(rng)
    with pytest.warns(UserWarning, match=r"threshold=0.1 removed every coefficient of target 0 .* at most "
                                         r".*e-\d+, far below the threshold .* or normalize_columns=True"):
        coef, _ = stls(theta * scale, target, threshold=0.1)
    assert np.all(coef == 0)
    coef, _ = stls(theta * scale, target, threshold=0.1, normalize_columns=True)  # what the warning advises
    np.testing.assert_allclose(coef * scale, [0.3, 2.0, -0.5], rtol=1e-10)


def test_a_threshold_that_empties_a_model_of_its_own_units_does_not_warn(rng):
    theta, target = _with_constant(rng)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        coef, _ = stls(theta, target, threshold=10.0)  # coefficients 0.3, 2, -0.5: a deliberate empty model
    assert np.all(coef == 0)

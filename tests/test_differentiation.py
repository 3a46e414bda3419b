"""Tests of sindybench.differentiation: exactness, accuracy, noise, interface, errors."""

import warnings

import numpy as np
import pytest
from derivative import Kalman as DerivativeKalman
from pysindy.differentiation import FiniteDifference as PySINDyFD
from pysindy.differentiation import SmoothedFiniteDifference
from scipy.interpolate import make_smoothing_spline
from scipy.optimize import minimize
from sklearn.base import clone
from sklearn.exceptions import ConvergenceWarning

from sindybench.differentiation import (
    FiniteDifference,
    Kalman,
    PySINDyDifferentiation,
    SavitzkyGolay,
    SmoothingSpline,
    TotalVariation,
    as_differentiation,
    tv_smooth,
)

DT = 0.01


@pytest.fixture
def nonuniform_t(rng):
    return np.cumsum(rng.uniform(0.5, 1.5, 60)) * 0.05


@pytest.fixture
def noisy_sine(rng):
    """sin(t) over two periods at dt=0.01, plus Gaussian noise of std 0.01 (1% of the amplitude)."""
    t = np.arange(0.0, 4 * np.pi, DT)
    return t, np.sin(t) + 0.01 * rng.standard_normal(t.size)


# Parameters tuned on the noisy sine (dt=0.01, noise std 0.01).
TUNED = [
    SavitzkyGolay(window_length=51, polyorder=3),
    SmoothingSpline(smoothing=1e-2),
    TotalVariation(gamma=1e-2),
    Kalman(alpha=1e-4),
]


def rmse(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)))


@pytest.mark.parametrize("method", TUNED, ids=lambda m: type(m).__name__)
def test_regularized_first_derivative_beats_finite_differences_5x(method, noisy_sine):
    t, y = noisy_sine
    fd = rmse(FiniteDifference().derivative(y, dt=DT), np.cos(t))
    err = rmse(method.derivative(y, dt=DT), np.cos(t))
    assert fd > 0.5  # plain differences amplify the noise by about 1 / (sqrt(2) dt)
    assert err * 5 < fd, (err, fd)


@pytest.mark.parametrize(
    "method, tol",
    [
        (SavitzkyGolay(window_length=101, polyorder=3), 0.1),
        (SmoothingSpline(smoothing=0.1), 0.05),
        (TotalVariation(gamma=1e-3), 0.15),
        (Kalman(alpha=1e-4), 0.15),
    ],
    ids=lambda m: type(m).__name__ if not isinstance(m, float) else str(m),
)
def test_regularized_second_derivative_of_noisy_sine(method, tol, noisy_sine):
    t, y = noisy_sine
    assert rmse(method.derivative(y, dt=DT, order=2), -np.sin(t)) < tol
    # plain second differences are useless at this noise level
    assert rmse(FiniteDifference().derivative(y, dt=DT, order=2), -np.sin(t)) > 50 * tol


@pytest.mark.parametrize("order", [1, 2])
def test_finite_difference_exact_on_quadratics_nonuniform(order, nonuniform_t):
    t = nonuniform_t
    y = 2.0 - t + 3.0 * t**2
    expected = -1.0 + 6.0 * t if order == 1 else np.full_like(t, 6.0)
    np.testing.assert_allclose(FiniteDifference().derivative(y, t=t, order=order), expected, atol=1e-9)


@pytest.mark.parametrize("order", [1, 2])
def test_finite_difference_accuracy_4_exact_on_quartics(order):
    t = np.arange(30) * 0.1
    y = t**4 - 2 * t**3
    expected = 4 * t**3 - 6 * t**2 if order == 1 else 12 * t**2 - 12 * t
    np.testing.assert_allclose(FiniteDifference(accuracy=4).derivative(y, dt=0.1, order=order), expected, atol=1e-8)
    # accuracy 2 is not exact here: the test can tell the two apart
    assert np.max(np.abs(FiniteDifference().derivative(y, dt=0.1, order=order) - expected)) > 1e-3


def test_finite_difference_on_sine_within_truncation_error():
    t = np.arange(0.0, 2 * np.pi, DT)
    err2 = np.max(np.abs(FiniteDifference().derivative(np.sin(t), dt=DT) - np.cos(t)))
    err4 = np.max(np.abs(FiniteDifference(accuracy=4).derivative(np.sin(t), dt=DT) - np.cos(t)))
    assert err2 < DT**2 / 2  # h^2/6 inside, h^2/3 at the one-sided ends
    assert err4 < DT**4
    err_dd = np.max(np.abs(FiniteDifference().derivative(np.sin(t), dt=DT, order=2) + np.sin(t)))
    assert err_dd < 2 * DT**2


@pytest.mark.parametrize("order", [1, 2])
def test_savitzky_golay_exact_on_polynomials_up_to_polyorder(order):
    t = np.arange(40) * 0.05
    y = 1.0 + t - 2 * t**2 + 0.5 * t**3
    expected = 1 - 4 * t + 1.5 * t**2 if order == 1 else -4 + 3 * t
    d = SavitzkyGolay(window_length=9, polyorder=3).derivative(y, dt=0.05, order=order)
    np.testing.assert_allclose(d, expected, atol=1e-9)
    # polyorder 2 cannot follow the cubic term
    d2 = SavitzkyGolay(window_length=9, polyorder=2).derivative(y, dt=0.05, order=order)
    assert np.max(np.abs(d2 - expected)) > 1e-3


def test_smoothing_spline_matches_scipy_on_nonuniform_t(rng, nonuniform_t):
    t = nonuniform_t
    y = np.sin(3 * t) + 0.01 * rng.standard_normal(t.size)
    ref = make_smoothing_spline(t, y, lam=1e-3)
    method = SmoothingSpline(smoothing=1e-3)
    np.testing.assert_allclose(method.derivative(y, t=t), ref.derivative(1)(t), atol=1e-8)
    np.testing.assert_allclose(method.derivative(y, t=t, order=2), ref.derivative(2)(t), atol=1e-6)


def test_smoothing_spline_matches_derivative_package_kalman(rng):
    t = np.arange(50) * 0.1
    y = np.cos(t) + 0.05 * rng.standard_normal(t.size)
    ref = DerivativeKalman(alpha=0.01).d(y, t)
    np.testing.assert_allclose(SmoothingSpline(smoothing=0.01).derivative(y, t=t), ref, atol=1e-8)


def test_smoothing_spline_exact_on_lines_and_close_on_sines():
    t = np.arange(0.0, 2 * np.pi, DT)
    np.testing.assert_allclose(SmoothingSpline(smoothing=1.0).derivative(3.0 - 2.0 * t, dt=DT), -2.0, atol=1e-9)
    np.testing.assert_allclose(SmoothingSpline(smoothing=1.0).derivative(3.0 - 2.0 * t, dt=DT, order=2), 0.0, atol=1e-7)
    d = SmoothingSpline(smoothing=1e-8).derivative(np.sin(t), dt=DT)
    assert np.max(np.abs(d - np.cos(t))) < 1e-4


def _reference_rts(y, t, alpha, p0=1e12):
    """Textbook Kalman filter + Rauch-Tung-Striebel smoother, constant-acceleration model."""
    n = len(t)
    h = np.diff(t)
    xs, ps, xp, pp, fs = [np.zeros(3)], [np.eye(3) * p0], [], [], []
    x, p = np.zeros(3), np.eye(3) * p0
    hvec = np.array([1.0, 0.0, 0.0])
    for k in range(n):
        if k > 0:
            d = h[k - 1]
            f = np.array([[1, d, d**2 / 2], [0, 1, d], [0, 0, 1]])
            q = np.array([[d**5 / 20, d**4 / 8, d**3 / 6], [d**4 / 8, d**3 / 3, d**2 / 2], [d**3 / 6, d**2 / 2, d]])
            x, p = f @ x, f @ p @ f.T + q / alpha
            fs.append(f)
        xp.append(x)
        pp.append(p)
        gain = p @ hvec / (hvec @ p @ hvec + 1.0)
        x = x + gain * (y[k] - x[0])
        p = p - np.outer(gain, hvec @ p)
        xs.append(x)
        ps.append(p)
    xs, ps = xs[1:], ps[1:]
    out = [xs[-1]]
    for k in range(n - 2, -1, -1):
        c = ps[k] @ fs[k].T @ np.linalg.inv(pp[k + 1])
        out.append(xs[k] + c @ (out[-1] - xp[k + 1]))
    return np.array(out[::-1])


def test_kalman_matches_textbook_rts_smoother(rng):
    t = np.cumsum(rng.uniform(0.5, 1.5, 40)) * 0.1
    y = np.sin(t) + 0.02 * rng.standard_normal(t.size)
    ref = _reference_rts(y, t, alpha=1e-3)
    method = Kalman(alpha=1e-3)
    np.testing.assert_allclose(method.derivative(y, t=t), ref[:, 1], atol=1e-5)
    np.testing.assert_allclose(method.derivative(y, t=t, order=2), ref[:, 2], atol=1e-4)


@pytest.mark.parametrize("order", [1, 2])
def test_kalman_exact_on_quadratics(order, nonuniform_t):
    t = nonuniform_t
    y = 1.0 + 2.0 * t - 0.7 * t**2
    expected = 2.0 - 1.4 * t if order == 1 else np.full_like(t, -1.4)
    np.testing.assert_allclose(Kalman(alpha=1e-4).derivative(y, t=t, order=order), expected, atol=1e-6)


def test_total_variation_exact_on_its_polynomials(nonuniform_t):
    t = nonuniform_t
    np.testing.assert_allclose(TotalVariation(gamma=1.0).derivative(1.0 + 2.0 * t, t=t), 2.0, atol=1e-7)
    y = 1.0 + 2.0 * t - 0.7 * t**2
    method = TotalVariation(gamma=1.0, tv_order=2)
    np.testing.assert_allclose(method.derivative(y, t=t), 2.0 - 1.4 * t, atol=1e-6)
    np.testing.assert_allclose(method.derivative(y, t=t, order=2), -1.4, atol=1e-5)


def test_total_variation_recovers_piecewise_constant_derivative(rng):
    t = np.arange(0.0, 2.0, DT)
    slope = np.where(t < 1.0, 1.0, -1.0)
    y = np.concatenate([[0.0], np.cumsum(slope[:-1] * DT)]) + 0.001 * rng.standard_normal(t.size)
    d = TotalVariation(gamma=1e-2).derivative(y, dt=DT)
    away = np.abs(t - 1.0) > 0.1
    assert np.max(np.abs(d[away] - slope[away])) < 0.05
    # a smoothing spline of comparable noise suppression blurs the corner much more widely
    s = SmoothingSpline(smoothing=1e-3).derivative(y, dt=DT)
    assert rmse(d, slope) < rmse(s, slope)


def test_total_variation_second_derivative_is_from_one_fit_with_tv_order_2(noisy_sine):
    t, y = noisy_sine
    method = TotalVariation(gamma=1e-3, tv_order=2)
    d1, d2 = method.derivative(y, dt=DT), method.derivative(y, dt=DT, order=2)
    # d2 is the derivative of d1 (same fit), up to the discretization
    inner = slice(5, -5)
    assert rmse(np.gradient(d1, DT)[inner], d2[inner]) < 0.05


def test_total_variation_warns_when_not_converged(noisy_sine):
    t, y = noisy_sine
    with pytest.warns(ConvergenceWarning, match="did not converge in 1 iterations"):
        TotalVariation(gamma=1e-2, max_iter=1).derivative(y, dt=DT)


def _tv_objective(t, y, gamma, tv_order, epsilon):
    """The objective of tv_smooth written out with dense divided differences."""
    n = t.size
    jumps = np.eye(n)
    for q in range(1, tv_order + 1):  # divided differences of order 1..tv_order
        jumps = q * np.diff(jumps, axis=0) / (t[q:] - t[:-q])[:, None]
    jumps = np.diff(jumps, axis=0)  # jumps between neighbouring derivative estimates
    e = epsilon * np.ptp(y) / (t[-1] - t[0]) ** tv_order

    def fun(x):
        j = jumps @ x
        root = np.sqrt(j**2 + e**2)
        return 0.5 * np.sum((x - y) ** 2) + gamma * np.sum(root), x - y + gamma * jumps.T @ (j / root)

    def hess(x):
        root = np.sqrt((jumps @ x) ** 2 + e**2)
        return np.eye(n) + gamma * jumps.T @ ((e**2 / root**3)[:, None] * jumps)

    return fun, hess


# a sharper rounding (smaller epsilon) costs the reference solver thousands of steps for tv_order=2
@pytest.mark.parametrize("tv_order, epsilon", [(1, 0.3), (1, 1e-3), (2, 0.3), (2, 1e-2)])
def test_tv_smooth_minimizes_its_objective(tv_order, epsilon, rng, nonuniform_t):
    t = nonuniform_t
    y = np.sin(3 * t) + np.abs(t - 1.5) + 0.02 * rng.standard_normal(t.size)
    gamma = 1e-3 if tv_order == 1 else 1e-4
    fun, hess = _tv_objective(t, y, gamma, tv_order, epsilon)
    x, _ = tv_smooth(y[:, None], t, gamma=gamma, tv_order=tv_order, epsilon=epsilon)
    ref = minimize(fun, y, jac=True, hess=hess, method="trust-exact", options=dict(gtol=1e-10)).x
    # the same point as a general-purpose trust-region Newton solver
    np.testing.assert_allclose(x[:, 0], ref, atol=1e-6)
    assert fun(x[:, 0])[0] <= fun(ref)[0] + 1e-12


@pytest.mark.parametrize("tv_order, gamma", [(1, 1e-2), (2, 1e-3)])
def test_tv_smooth_newton_steps_hardly_grow_with_the_number_of_samples(tv_order, gamma, rng):
    steps = []
    for n in (500, 20_000):
        t = np.arange(n) * DT
        y = np.sin(t) + 0.01 * rng.standard_normal(n)
        with warnings.catch_warnings():
            warnings.simplefilter("error", ConvergenceWarning)
            steps.append(tv_smooth(y[:, None], t, gamma=gamma, tv_order=tv_order)[1])
    assert max(steps) <= 40, steps  # without continuation in the rounding: 51 (tv_order=1), 112 (2)


ALL = [
    FiniteDifference(),
    FiniteDifference(accuracy=4),
    SavitzkyGolay(window_length=7, polyorder=3),
    SmoothingSpline(),
    TotalVariation(),
    Kalman(),
    PySINDyDifferentiation(method=PySINDyFD()),
]


@pytest.mark.parametrize("method", ALL, ids=lambda m: repr(m))
@pytest.mark.parametrize("order", [1, 2])
def test_shapes_columns_and_finite_ends(method, order, rng):
    t = np.arange(40) * 0.1
    y = np.column_stack([np.sin(t), np.cos(2 * t)]) + 0.01 * rng.standard_normal((40, 2))
    out = method.derivative(y, dt=0.1, order=order)
    assert out.shape == (40, 2)
    assert np.all(np.isfinite(out))
    single = method.derivative(y[:, 1], dt=0.1, order=order)
    assert single.shape == (40,)
    np.testing.assert_allclose(out[:, 1], single, atol=1e-10)
    # t equal to the uniform grid gives the same result as dt
    np.testing.assert_allclose(method.derivative(y, t=t, order=order), out, atol=1e-8)


def test_set_params_and_clone():
    method = clone(TotalVariation(gamma=1.0)).set_params(gamma=2.0, tv_order=2)
    assert (method.gamma, method.tv_order) == (2.0, 2)
    wrapped = as_differentiation(PySINDyFD(order=2)).set_params(method__order=4)
    assert wrapped.method.order == 4
    assert wrapped.get_params()["method__order"] == 4


def test_as_differentiation():
    assert isinstance(as_differentiation(None), FiniteDifference)
    method = Kalman(alpha=2.0)
    assert as_differentiation(method) is method
    wrapped = as_differentiation(SmoothedFiniteDifference())
    t = np.arange(30) * 0.1
    np.testing.assert_allclose(wrapped.derivative(3 * t, dt=0.1), 3.0, atol=1e-9)
    # order 2 applies the pysindy method twice
    np.testing.assert_allclose(as_differentiation(PySINDyFD()).derivative(t**2, dt=0.1, order=2), 2.0, atol=1e-8)
    with pytest.raises(ValueError, match="differentiation must be None"):
        as_differentiation("spline")


def test_wrapper_rejects_nan_ends():
    method = as_differentiation(PySINDyFD(drop_endpoints=True))
    with pytest.raises(ValueError, match="returned NaN or inf .*drop_endpoints=False"):
        method.derivative(np.arange(10.0), dt=1.0)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(), "got neither dt nor t"),
        (dict(dt=0.1, t=np.arange(10.0)), "got both dt and t"),
        (dict(dt=-1.0), "dt must be a finite number > 0"),
        (dict(t=np.arange(9.0)), "t has 9 samples; expected 10"),
        (dict(t=np.r_[0.0, np.arange(9.0)]), "t must be strictly increasing"),
        (dict(dt=0.1, order=3), "order must be 1 or 2"),
        (dict(dt=0.1, order=True), "order must be 1 or 2"),
    ],
)
def test_bad_time_and_order(kwargs, match):
    with pytest.raises(ValueError, match=match):
        FiniteDifference().derivative(np.arange(10.0), **kwargs)


@pytest.mark.parametrize(
    "method, match",
    [
        (FiniteDifference(accuracy=3), "accuracy must be 2 or 4"),
        (SavitzkyGolay(window_length=8), "window_length must be odd"),
        (SavitzkyGolay(window_length=2.5), "window_length must be an integer"),
        (SavitzkyGolay(window_length=5, polyorder=5), r"polyorder must be an integer in \[0, 4\]"),
        (SmoothingSpline(smoothing=0.0), "smoothing must be a finite number > 0"),
        (Kalman(alpha=-1.0), "alpha must be a finite number > 0"),
        (TotalVariation(gamma=np.inf), "gamma must be a finite number > 0"),
        (TotalVariation(tv_order=3), r"tv_order must be an integer in \[1, 2\]"),
        (TotalVariation(max_iter=0), "max_iter must be an integer >= 1"),
        (PySINDyDifferentiation(method=3), "method must be a pysindy differentiation object"),
    ],
    ids=repr,
)
def test_bad_parameters(method, match):
    with pytest.raises(ValueError, match=match):
        method.derivative(np.arange(20.0), dt=0.1)


def test_method_specific_errors(nonuniform_t):
    y = np.sin(nonuniform_t)
    with pytest.raises(ValueError, match="SavitzkyGolay needs uniformly sampled data"):
        SavitzkyGolay(window_length=5, polyorder=2).derivative(y, t=nonuniform_t)
    with pytest.raises(ValueError, match="polyorder=1 cannot give a derivative of order 2"):
        SavitzkyGolay(window_length=5, polyorder=1).derivative(y, dt=0.1, order=2)
    with pytest.raises(ValueError, match="train of spikes; expected tv_order=2 or None"):
        TotalVariation(tv_order=1).derivative(y, dt=0.1, order=2)
    with pytest.raises(ValueError, match="y has 3 samples; FiniteDifference needs at least 4"):
        FiniteDifference().derivative(np.arange(3.0), dt=0.1, order=2)
    with pytest.raises(ValueError, match="y has 5 samples; SavitzkyGolay needs at least 11"):
        SavitzkyGolay().derivative(np.arange(5.0), dt=0.1)
    with pytest.raises(ValueError, match="y contains NaN or inf"):
        Kalman().derivative(np.r_[1.0, np.nan, 2.0], dt=0.1)


@pytest.mark.parametrize("dt", [1e-300, 1e-200])
def test_a_step_the_stencil_cannot_resolve_is_a_value_error(dt):
    # before: numpy's LinAlgError "Singular matrix" from inside pysindy's finite differences (issue 18, case 15)
    from sindybench import SINDy

    rng = np.random.default_rng(0)
    u, y = rng.normal(size=(10, 1)), rng.normal(size=(10, 1))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # pysindy's overflow in the stencil's powers
        with pytest.raises(ValueError, match=f"FiniteDifference could not differentiate y with dt = {dt:g}"):
            FiniteDifference().derivative(y, dt=dt)
        with pytest.raises(ValueError, match="rescale the time unit"):
            SINDy(dt=dt).fit(u, y)
        # scipy's Savitzky-Golay divides by dt ** 2 for a second derivative (ZeroDivisionError before)
        with pytest.raises(ValueError, match=f"SavitzkyGolay could not differentiate y with dt = {dt:g}"):
            SavitzkyGolay(window_length=5).derivative(y, dt=dt, order=2)
        # weights that overflow give inf or NaN (a NaN "strategy states" error before)
        with pytest.raises(ValueError, match="FiniteDifference gave NaN or inf derivatives of the finite y"):
            FiniteDifference().derivative(y, dt=1e300)


def test_data_differentiation_follows_the_bandwidth():
    from sindybench.differentiation import as_differentiation, bandwidth, data_differentiation

    t = np.arange(3000) * 0.01
    slow, fast = np.sin(2 * np.pi * 0.2 * t)[:, None], np.sin(2 * np.pi * 5.0 * t)[:, None]
    assert bandwidth(slow, 0.01) < bandwidth(fast, 0.01)
    w_slow, w_fast = data_differentiation(slow, 0.01).window_length, data_differentiation(fast, 0.01).window_length
    assert w_fast < w_slow and w_slow % 2 == 1 and w_fast % 2 == 1
    assert data_differentiation(slow[:100], 0.01).window_length <= 20  # at most a fifth of the record
    assert isinstance(data_differentiation(slow[:10], 0.01), FiniteDifference)  # too short for a window
    assert as_differentiation("auto", slow, 0.01).window_length == w_slow
    with pytest.raises(ValueError, match="differentiation must be None, 'auto'"):
        as_differentiation("spline")


def test_sindy_resolves_auto_differentiation_from_the_record():
    from sindybench import SINDy
    from sindybench.differentiation import data_differentiation

    t = np.arange(1500) * 0.01
    y = np.c_[np.sin(t), np.cos(t)]
    model = SINDy(differentiation="auto", dt=0.01).fit(None, y)
    assert model.differentiation_.window_length == data_differentiation(y, 0.01).window_length

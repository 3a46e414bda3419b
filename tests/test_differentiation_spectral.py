"""Tests of sindybench.differentiation.Spectral: exactness, band limit, edges, noise, errors."""

import numpy as np
import pytest
from pysindy.differentiation import SpectralDerivative
from sklearn.base import clone

from sindybench import SINDy
from sindybench.differentiation import FiniteDifference, Spectral, as_differentiation, spectral_derivative
from sindybench.differentiation._spectral import band_gain

DT = 0.01


def rmse(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)))


def _periodic(n=400, dt=DT):
    """Two tones, 3 and 11 cycles per record of n samples (the record is one period)."""
    t = np.arange(n) * dt
    w1, w2 = 2 * np.pi * 3 / (n * dt), 2 * np.pi * 11 / (n * dt)
    y = np.sin(w1 * t + 0.3) + 0.5 * np.cos(w2 * t)
    d1 = w1 * np.cos(w1 * t + 0.3) - 0.5 * w2 * np.sin(w2 * t)
    d2 = -(w1**2) * np.sin(w1 * t + 0.3) - 0.5 * w2**2 * np.cos(w2 * t)
    return t, y, d1, d2, (w1 / (2 * np.pi), w2 / (2 * np.pi))


@pytest.mark.parametrize("cutoff", [None, 5.0])
def test_periodic_exact_on_band_limited_periodic_sines(cutoff):
    t, y, d1, d2, (f1, f2) = _periodic()
    assert f2 < 5.0  # both tones inside the band
    method = Spectral(cutoff=cutoff, edge="periodic")
    np.testing.assert_allclose(method.derivative(y, dt=DT), d1, atol=1e-10 * np.abs(d1).max())
    np.testing.assert_allclose(method.derivative(y, dt=DT, order=2), d2, atol=1e-10 * np.abs(d2).max())
    # the plain periodic FFT derivative of pysindy agrees without band limit
    ref = SpectralDerivative(d=1)._differentiate(y, DT)
    np.testing.assert_allclose(method.derivative(y, dt=DT), ref, atol=1e-10 * np.abs(d1).max())


@pytest.mark.parametrize("order", [1, 2])
def test_band_limit_removes_the_tone_above_the_cutoff_exactly(order):
    t, y, _, _, (f1, f2) = _periodic()
    cutoff = 0.5 * (f1 + f2)
    w1 = 2 * np.pi * f1
    expected = w1 * np.cos(w1 * t + 0.3) if order == 1 else -(w1**2) * np.sin(w1 * t + 0.3)
    d = Spectral(cutoff=cutoff, edge="periodic").derivative(y, dt=DT, order=order)
    np.testing.assert_allclose(d, expected, atol=1e-9 * w1**order)
    # a cutoff above the second tone keeps it: the test can tell the two apart
    kept = Spectral(cutoff=2 * f2, edge="periodic").derivative(y, dt=DT, order=order)
    assert np.max(np.abs(kept - expected)) > 0.4 * (2 * np.pi * f2) ** order


@pytest.mark.parametrize("order", [1, 2])
def test_mirror_exact_on_a_line_plus_a_sine_series(order):
    n = 301
    t = np.arange(n) * DT
    period = 2 * (n - 1) * DT  # the period of the odd continuation
    k1, k2 = 2 * np.pi * 3 / period, 2 * np.pi * 20 / period
    y = 1.0 - 2.0 * t + np.sin(k1 * t) - 0.3 * np.sin(k2 * t)
    if order == 1:
        expected = -2.0 + k1 * np.cos(k1 * t) - 0.3 * k2 * np.cos(k2 * t)
    else:
        expected = -(k1**2) * np.sin(k1 * t) + 0.3 * k2**2 * np.sin(k2 * t)
    d = Spectral().derivative(y, dt=DT, order=order)
    np.testing.assert_allclose(d, expected, atol=1e-9 * k2**order)


def test_second_derivative_is_the_first_differentiated_with_the_same_spectrum():
    t, y, _, _, _ = _periodic()
    noisy = y + 0.01 * np.random.default_rng(1).standard_normal(y.size)
    method = Spectral(cutoff=4.0, taper=0.5, edge="periodic")
    d1 = method.derivative(noisy, dt=DT)
    twice = Spectral(edge="periodic").derivative(d1, dt=DT)
    np.testing.assert_allclose(method.derivative(noisy, dt=DT, order=2), twice, atol=1e-9)


def test_mirror_second_derivative_matches_the_slope_of_the_first_inside(rng):
    t = np.arange(0.0, 10.0, DT)
    y = np.cos(1.3 * t + 0.5) + 0.01 * rng.standard_normal(t.size)
    method = Spectral(cutoff=1.0, taper=0.5)
    d1, d2 = method.derivative(y, dt=DT), method.derivative(y, dt=DT, order=2)
    inner = slice(300, -300)
    assert rmse(np.gradient(d1, DT)[inner], d2[inner]) < 1e-3


# better_than_periodic: how much smaller the mirror's errors are than a periodic
# transform's (less when the cutoff is close to the tone: both then smear the ends)
@pytest.mark.parametrize(
    "cutoff, taper, better_than_periodic", [(None, 0.0, 100), (5.0, 0.0, 2), (5.0, 0.5, 3), (10.0, 0.0, 8)]
)
def test_mirror_edges_are_bounded_on_a_non_periodic_record(cutoff, taper, better_than_periodic):
    """A cosine over 2.63 periods: the documented bounds of what remains at the ends."""
    t = np.arange(877) * DT
    w = 2 * np.pi * 3.0
    y = np.cos(w * t + 0.7)
    d1, d2 = -w * np.sin(w * t + 0.7), -(w**2) * np.cos(w * t + 0.7)
    acc_end = max(abs(d2[0]), abs(d2[-1]))
    band = cutoff or 0.5 / DT
    method = Spectral(cutoff=cutoff, taper=taper)
    e1 = np.abs(method.derivative(y, dt=DT) - d1)
    e2 = np.abs(method.derivative(y, dt=DT, order=2) - d2)
    assert np.all(np.isfinite(e1)) and np.all(np.isfinite(e2))
    assert e1.max() < 0.15 * acc_end / band  # first derivative: no ringing, a small edge error
    assert e2.max() < 1.05 * acc_end  # second derivative: pulled towards 0 at the ends only
    inner = slice(int(10 / band / DT) + 1, -int(10 / band / DT) - 1)
    assert e2[inner].max() < 0.05 * w**2
    assert e1[inner].max() < 0.01 * w
    # the plain periodic transform of the same record rings over the whole record
    e1_periodic = np.abs(Spectral(cutoff=cutoff, taper=taper, edge="periodic").derivative(y, dt=DT) - d1)
    assert e1_periodic.max() > better_than_periodic * e1.max()
    assert e1_periodic[inner].max() > better_than_periodic * e1[inner].max()


def test_taper_shortens_the_ringing_inside():
    t = np.arange(1000) * DT
    w = 2 * np.pi * 1.0
    y = np.cos(w * t + 0.7)
    inner = slice(60, -60)  # 3 / cutoff away from the ends
    brick = Spectral(cutoff=5.0).derivative(y, dt=DT, order=2)
    tapered = Spectral(cutoff=5.0, taper=0.5).derivative(y, dt=DT, order=2)
    truth = -(w**2) * np.cos(w * t + 0.7)
    assert np.abs(tapered - truth)[inner].max() * 10 < np.abs(brick - truth)[inner].max()


def test_band_gain():
    f = np.array([0.0, 1.0, 1.1, 1.2, 1.3, 5.0])
    np.testing.assert_allclose(band_gain(f, 1.0, 0.0), [1, 1, 0, 0, 0, 0])
    np.testing.assert_allclose(band_gain(f, 1.0, 0.2), [1, 1, 0.5, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(band_gain(f, None, 0.2), 1.0)


def test_noisy_sine_first_derivative_beats_finite_differences_5x(rng):
    t = np.arange(0.0, 4 * np.pi, DT)
    y = np.sin(t) + 0.01 * rng.standard_normal(t.size)
    fd = rmse(FiniteDifference().derivative(y, dt=DT), np.cos(t))
    method = Spectral(cutoff=0.5)  # sin(t) is at 0.16 Hz
    err = rmse(method.derivative(y, dt=DT), np.cos(t))
    assert fd > 0.5
    assert err * 5 < fd, (err, fd)
    # the band limit is what helps: without it the noise comes through
    assert rmse(Spectral().derivative(y, dt=DT), np.cos(t)) > fd
    inner = slice(100, -100)
    assert rmse(method.derivative(y, dt=DT, order=2)[inner], -np.sin(t)[inner]) < 0.05


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("edge", ["mirror", "periodic"])
def test_shapes_columns_and_time_grid(order, edge, rng):
    t = np.arange(40) * 0.1
    y = np.column_stack([np.sin(t), np.cos(2 * t)]) + 0.01 * rng.standard_normal((40, 2))
    method = Spectral(cutoff=2.0, edge=edge)
    out = method.derivative(y, dt=0.1, order=order)
    assert out.shape == (40, 2) and np.all(np.isfinite(out))
    single = method.derivative(y[:, 1], dt=0.1, order=order)
    assert single.shape == (40,)
    np.testing.assert_allclose(out[:, 1], single, atol=1e-12)
    np.testing.assert_allclose(method.derivative(y, t=t + 5.0, order=order), out, atol=1e-8)
    np.testing.assert_allclose(spectral_derivative(y, 0.1, order=order, cutoff=2.0, edge=edge), out)


@pytest.mark.parametrize("n", [3, 4, 5])
def test_short_records(n):
    y = 2.0 + 0.5 * np.arange(n)
    np.testing.assert_allclose(Spectral().derivative(y, dt=0.5), 1.0, atol=1e-12)
    np.testing.assert_allclose(Spectral().derivative(y, dt=0.5, order=2), 0.0, atol=1e-12)


def test_params_clone_and_plug_in(rng):
    method = clone(Spectral(cutoff=1.0)).set_params(cutoff=2.0, taper=0.25, edge="periodic")
    assert method.get_params() == {"cutoff": 2.0, "taper": 0.25, "edge": "periodic"}
    assert as_differentiation(method) is method
    with pytest.raises(TypeError):
        Spectral(150.0)  # keyword-only
    # SINDy accepts it: x' = -x + u from a noisy record
    t = np.arange(2000) * DT
    u = np.sin(2 * t)[:, None]
    x = np.zeros(t.size)
    for i in range(1, t.size):  # exact zero-order-hold discretization
        x[i] = x[i - 1] * np.exp(-DT) + (1 - np.exp(-DT)) * u[i - 1, 0]
    y = x[:, None] + 1e-4 * rng.standard_normal((t.size, 1))
    model = SINDy(differentiation=Spectral(cutoff=2.0), dt=DT).fit(u, y)
    assert model.differentiation_ is not None
    assert model.score(u, y) > 0.99


@pytest.mark.parametrize(
    "method, match",
    [
        (Spectral(cutoff=0.0), "cutoff must be a finite number > 0"),
        (Spectral(cutoff=-1.0), "cutoff must be a finite number > 0"),
        (Spectral(cutoff=np.inf), "cutoff must be a finite number > 0"),
        (Spectral(cutoff="150"), "cutoff must be a finite number > 0"),
        (Spectral(taper=-0.1), "taper must be a finite number >= 0"),
        (Spectral(taper=np.nan), "taper must be a finite number >= 0"),
        (Spectral(edge="zero"), r"edge must be one of \['mirror', 'periodic'\]"),
        (Spectral(edge=None), r"edge must be one of \['mirror', 'periodic'\]"),
    ],
    ids=repr,
)
def test_bad_parameters(method, match):
    with pytest.raises(ValueError, match=match):
        method.derivative(np.arange(20.0), dt=0.1)


def test_bad_inputs(rng):
    t = np.cumsum(rng.uniform(0.5, 1.5, 30)) * 0.1
    with pytest.raises(ValueError, match="Spectral needs uniformly sampled data but t is not uniform"):
        Spectral().derivative(np.sin(t), t=t)
    with pytest.raises(ValueError, match="y contains NaN or inf"):
        Spectral().derivative(np.r_[1.0, np.nan, 2.0, 3.0], dt=0.1)
    with pytest.raises(ValueError, match="order must be 1 or 2"):
        Spectral().derivative(np.arange(10.0), dt=0.1, order=3)
    with pytest.raises(ValueError, match="got neither dt nor t"):
        Spectral().derivative(np.arange(10.0))
    with pytest.raises(ValueError, match="y has 2 samples; Spectral needs at least 3"):
        Spectral().derivative(np.arange(2.0), dt=0.1)

"""Tests of sindybench.systems: Bouc-Wen and cascaded-tanks simulators, signals, resampling."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.io import loadmat

from sindybench.systems import BoucWen, CascadedTanks, decimate_fir, low_frequency_sine, multisine, upsample


def _rel_rmse(a, b):
    a, b = np.ravel(a), np.ravel(b)
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.std(b))


def _load_test(data_home, name):
    u = loadmat(data_home / "bouc_wen" / f"uval_{name}.mat")[f"uval_{name}"].ravel()
    y = loadmat(data_home / "bouc_wen" / f"yval_{name}.mat")[f"yval_{name}"].ravel()
    return u, y


# --- the benchmark bar -------------------------------------------------------------------------


def test_bouc_wen_reproduces_official_multisine(data_home):
    u, y = _load_test(data_home, "multisine")
    y_sim = BoucWen().simulate(u, periodic=True, n_periods=2)
    err = _rel_rmse(y_sim, y)
    assert err <= 0.01  # the bar
    # Newmark + trapezoidal z + FIR stages (2, 2, 5): the benchmark's own computation
    assert err <= 1e-8


def test_bouc_wen_reproduces_official_sinesweep(data_home):
    u, y = _load_test(data_home, "sinesweep")
    # one-stage decimation (20,) is how the official sweep output was decimated
    err_single = _rel_rmse(BoucWen(decimation=(20,)).simulate(u), y)
    assert err_single <= 1e-5
    # the documented chain (2, 2, 5) differs only by its passband droop: still within the bar
    err_stages = _rel_rmse(BoucWen().simulate(u), y)
    assert err_single < err_stages <= 0.01


def test_bouc_wen_matches_training_record_within_noise(data_home):
    record = np.loadtxt(data_home / "bouc_wen" / "train_data.csv", delimiter=",", skiprows=1)
    y_meas, u = record[:, 0], record[:, 1]
    # 5 periods simulated from rest plus one extra period, as the benchmark did
    y_sim = BoucWen().simulate(np.concatenate([u, u[:8192]]))[:40960, 0]
    resid = y_meas - y_sim
    # the residual is the measurement noise: about 7.4e-6 m and independent between periods
    assert 6.5e-6 < resid.std() < 8.0e-6
    by_period = resid.reshape(5, 8192)
    assert abs(np.corrcoef(by_period[1], by_period[2])[0, 1]) < 0.05


# --- Bouc-Wen without data ------------------------------------------------------------------------


def _bouc_wen_rhs(t, x, f, p):
    y, v, z = x
    dz = p["alpha"] * v - p["beta"] * (p["gamma"] * abs(v) * z + p["delta"] * v * abs(z))
    return [v, (f(t) - p["c"] * v - p["k"] * y - z) / p["m"], dz]


def test_newmark_agrees_with_adaptive_reference():
    p = dict(m=2.0, c=10.0, k=5e4, alpha=5e4, beta=1e3, gamma=0.8, delta=-1.1)
    fs, n = 750.0, 600

    def force(t):
        return 60.0 * np.sin(2 * np.pi * 23.0 * t) + 30.0 * np.sin(2 * np.pi * 7.0 * t + 0.3)

    t = np.arange(n) / fs
    states = BoucWen(**p).simulate_states(force(t))
    ref = solve_ivp(_bouc_wen_rhs, (0, t[-1]), [0.0, 0.0, 0.0], t_eval=t, args=(force, p), rtol=1e-10, atol=1e-13,
                    max_step=1e-4)
    # away from the last samples (the interpolated input there depends on the padding)
    sl = slice(0, n - 20)
    for j in range(3):
        assert _rel_rmse(states[sl, j], ref.y[j, sl]) < 1e-3


def test_sine_test_shows_hysteresis_loop():
    u = low_frequency_sine()
    system = BoucWen()
    x = system.simulate_states(u)
    y = system.simulate(u)
    assert x.shape == (1000, 3) and y.shape == (1000, 1)
    assert np.all(x[0] == 0.0)
    # the filtered output follows the displacement state at 0.75 Hz
    assert _rel_rmse(y[10:-10, 0], x[10:-10, 0]) < 1e-3
    # the force-displacement loop encloses a positive area (energy dissipated by z)
    area = np.sum(x[1:, 2] * np.diff(x[:, 0]))
    assert area > 0
    # z is not a function of y: at half the peak displacement it differs between the up and down strokes
    k = int(np.argmax(x[:, 0]))
    half = 0.5 * x[k, 0]
    i_up = np.flatnonzero(x[:k, 0] >= half)[0]
    i_down = k + np.flatnonzero(x[k:, 0] <= half)[0]
    assert x[i_up, 1] > 0 > x[i_down, 1]
    assert x[i_up, 2] - x[i_down, 2] > 10.0


def test_periodic_simulation_is_a_steady_state():
    u = multisine(1024, random_state=3)[:, 0]
    system = BoucWen()
    y2 = system.simulate(u, periodic=True, n_periods=2)
    y4 = system.simulate(u, periodic=True, n_periods=4)
    np.testing.assert_allclose(y2, y4, rtol=0, atol=1e-9 * np.abs(y4).max())
    # simulated once from rest, the record starts with a transient
    y_once = system.simulate(u)
    assert _rel_rmse(y_once[:50], y4[:50]) > 1e-3


def test_noise_is_band_limited_and_seeded():
    u = multisine(4096, random_state=1)
    system = BoucWen()
    clean = system.simulate(u, periodic=True)
    noisy_a = system.simulate(u, periodic=True, noise=True, random_state=7)
    noisy_b = system.simulate(u, periodic=True, noise=True, random_state=7)
    noisy_c = system.simulate(u, periodic=True, noise=True, random_state=8)
    np.testing.assert_array_equal(noisy_a, noisy_b)
    e = (noisy_a - clean)[:, 0]
    assert not np.allclose(noisy_a, noisy_c)
    # std 8e-6 before the decimation filter, about 0.92 of it after
    assert 0.85 * 8e-6 < e.std() < 0.99 * 8e-6
    power = np.abs(np.fft.rfft(e)) ** 2
    f = np.fft.rfftfreq(e.size, 1 / 750)
    assert power[f > 330].mean() < 0.6 * power[f < 250].mean()
    # noise_std=0 -> no noise
    np.testing.assert_array_equal(BoucWen(noise_std=0.0).simulate(u, periodic=True, noise=True), clean)


@pytest.mark.parametrize(
    ("params", "match"),
    [
        ({"nu": 0.5}, "nu must be"),
        ({"m": 0.0}, "m must be"),
        ({"decimation": (2, 5)}, "multiply to 10"),
        ({"decimation": 20}, "tuple of integer"),
        ({"upsampling": 0}, "upsampling must be"),
        ({"gamma": float("nan")}, "gamma must be"),
        ({"max_newton": 0}, "max_newton"),
    ],
)
def test_bouc_wen_rejects_bad_parameters(params, match):
    with pytest.raises(ValueError, match=match):
        BoucWen(**params).simulate(np.zeros(100))


def test_bouc_wen_rejects_bad_arguments():
    system = BoucWen()
    with pytest.raises(ValueError, match="expected 1"):
        system.simulate(np.zeros((100, 2)))
    with pytest.raises(ValueError, match="x0 must hold 3"):
        system.simulate(np.zeros(100), x0=[0.0, 0.0])
    with pytest.raises(ValueError, match="n_periods must be"):
        system.simulate(np.zeros(100), periodic=True, n_periods=1)
    with pytest.raises(ValueError, match="NaN"):
        system.simulate(np.full(100, np.nan))


# --- signals ---------------------------------------------------------------------------------------


def test_multisine_design():
    u = multisine(8192, n_periods=3, random_state=0)[:, 0]
    assert u.shape == (3 * 8192,)
    np.testing.assert_allclose(u[:8192], u[8192:16384])
    assert u[:8192].std(ddof=1) == pytest.approx(50.0)
    spectrum = np.abs(np.fft.rfft(u[:8192]))
    lines = np.flatnonzero(spectrum > 1e-6 * spectrum.max())
    # the benchmark's lines: floor(5 / df) .. ceil(150 / df), df = 750 / 8192
    assert lines[0] == 54 and lines[-1] == 1639 and lines.size == 1586
    # equal amplitudes, random phases
    assert np.ptp(spectrum[lines]) < 1e-8 * spectrum.max()
    assert not np.allclose(u[:8192], multisine(8192, random_state=1)[:, 0])
    np.testing.assert_array_equal(multisine(512, random_state=5), multisine(512, random_state=5))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"f_max": 400.0}, "f_max < fs / 2"),
        ({"f_min": 200.0, "f_max": 100.0}, "f_min <= f_max"),
        ({"n_periods": 0}, "n_periods"),
        ({"std": -1.0}, "std must be"),
    ],
)
def test_multisine_rejects_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        multisine(1024, **kwargs)


def test_low_frequency_sine():
    u = low_frequency_sine()[:, 0]
    assert u.shape == (1000,)
    np.testing.assert_allclose(u, 150 * np.sin(2 * np.pi * 0.75 * np.arange(1000) / 750))
    assert low_frequency_sine(n_periods=2, frequency=1.5).shape == (1000, 1)
    with pytest.raises(ValueError, match="frequency must be"):
        low_frequency_sine(frequency=0.0)


# --- resampling ------------------------------------------------------------------------------------


def test_upsample_keeps_samples_and_is_band_limited(rng):
    t = np.arange(300) / 750
    x = 3 * np.sin(2 * np.pi * 40 * t + 0.4) + np.sin(2 * np.pi * 90 * t)
    xu = upsample(x, 20)
    assert xu.shape == (6000,)
    np.testing.assert_allclose(xu[::20], x, atol=1e-9)
    tf = np.arange(6000) / 15000
    exact = 3 * np.sin(2 * np.pi * 40 * tf + 0.4) + np.sin(2 * np.pi * 90 * tf)
    inner = slice(400, 5400)
    assert np.max(np.abs(xu[inner] - exact[inner])) < 1e-3
    # periodic: exact for a multisine
    p = multisine(256, f_min=10, f_max=100, random_state=rng)[:, 0]
    pu = upsample(p, 4, periodic=True)
    np.testing.assert_allclose(pu[::4], p, atol=1e-9)
    np.testing.assert_allclose(np.fft.rfft(pu)[129:], 0, atol=1e-8)


def test_decimate_fir_passes_low_and_stops_high_frequencies():
    n = 20000
    t = np.arange(n) / 15000
    low = np.sin(2 * np.pi * 30 * t)
    high = np.sin(2 * np.pi * 6000 * t)
    out = decimate_fir(low + high, 2)
    assert out.shape == (n // 2,)
    np.testing.assert_allclose(out[100:-100], low[::2][100:-100], atol=2e-3)
    circ = decimate_fir(low[:15000] + high[:15000], 5, periodic=True)
    np.testing.assert_allclose(circ, low[:15000:5], atol=2e-3)
    # records shorter than the filter are still decimated (ends continued)
    np.testing.assert_allclose(decimate_fir(np.ones(10), 2), np.ones(5))
    np.testing.assert_allclose(decimate_fir(np.arange(12.0), 3), [0.0, 3.0, 6.0, 9.0], atol=0.05)


# --- cascaded tanks --------------------------------------------------------------------------------


def test_tanks_agree_with_adaptive_reference():
    tanks = CascadedTanks()
    u = np.repeat([2.0, 3.5, 2.5, 3.0], 50)
    dt = 4.0
    x = tanks.simulate_states(u, dt=dt, x0=(2.0, 3.0))

    def rhs(t, s):
        ui = u[min(int(t // dt), u.size - 1)]
        s1, s2 = np.sqrt(max(s[0], 0)), np.sqrt(max(s[1], 0))
        return [-tanks.k1 * s1 + tanks.k2 * ui, tanks.k3 * s1 - tanks.k4 * s2]

    ref = solve_ivp(rhs, (0, dt * (u.size - 1)), [2.0, 3.0], t_eval=dt * np.arange(u.size), rtol=1e-9, atol=1e-11,
                    max_step=1.0)
    assert np.all(x < 10)  # no overflow on this input: the reference applies
    np.testing.assert_allclose(x, ref.y.T, atol=2e-4)


def test_tanks_overflow_and_empty():
    tanks = CascadedTanks(x_max=8.0)
    x = tanks.simulate_states(np.full(400, 10.0), x0=(7.0, 7.0))
    assert x.max() == 8.0 and x.min() >= 0.0
    assert np.all(x[-50:, 0] == 8.0)  # the upper tank overflows and stays full
    drained = tanks.simulate_states(np.zeros(2000), x0=(1.0, 1.0))
    assert drained.min() >= 0.0 and drained[-1].max() < 1e-6


def test_tanks_output_noise_and_default_start():
    tanks = CascadedTanks()
    u = np.full(200, 4.0)
    x = tanks.simulate_states(u)
    np.testing.assert_allclose(x, np.tile(tanks.equilibrium(4.0), (200, 1)), atol=1e-9)
    y = tanks.simulate(u)
    np.testing.assert_array_equal(y[:, 0], x[:, 1])
    y1 = tanks.simulate(u, noise=True, random_state=0)
    y2 = tanks.simulate(u, noise=True, random_state=0)
    np.testing.assert_array_equal(y1, y2)
    assert (y1 - y).std() == pytest.approx(0.02, rel=0.15)


@pytest.mark.parametrize(
    ("params", "kwargs", "match"),
    [
        ({"k1": -1.0}, {}, "k1 must be"),
        ({"n_substeps": 0}, {}, "n_substeps"),
        ({}, {"dt": 0.0}, "dt must be"),
        ({}, {"x0": (1.0,)}, "x0 must hold 2"),
    ],
)
def test_tanks_reject_bad_arguments(params, kwargs, match):
    with pytest.raises(ValueError, match=match):
        CascadedTanks(**params).simulate(np.ones(10), **kwargs)

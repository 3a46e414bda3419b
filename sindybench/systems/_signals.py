"""Excitation signals of the Bouc-Wen benchmark: random-phase multisine, low-frequency sine."""

import numpy as np
from sklearn.utils import check_random_state

from .._validation import check_integer, check_positive

__all__ = ["check_rng", "low_frequency_sine", "multisine"]


def check_rng(random_state):
    """A numpy ``Generator`` is used as is; anything else goes through ``check_random_state``."""
    if isinstance(random_state, np.random.Generator):
        return random_state
    return check_random_state(random_state)


def multisine(n_samples=8192, *, n_periods=1, fs=750.0, f_min=5.0, f_max=150.0, std=50.0, random_state=None):
    """Random-phase multisine, the excitation of the Bouc-Wen benchmark.

    All DFT lines of one period from ``floor(f_min / df)`` to ``ceil(f_max / df)``
    (``df = fs / n_samples``) get unit amplitude and a uniform random phase; the
    period is scaled to the sample standard deviation ``std`` (``ddof=1``) and
    repeated ``n_periods`` times. This is the design of the benchmark's
    training data (5 periods of 8192 samples, 5-150 Hz, 50 N).

    Parameters
    ----------
    n_samples : int, default=8192
        Samples per period.
    n_periods : int, default=1
        Number of identical periods.
    fs : float, default=750.0
        Sampling frequency in Hz.
    f_min, f_max : float, default=5.0, 150.0
        Excited band in Hz (``0 <= f_min <= f_max < fs / 2``).
    std : float, default=50.0
        Standard deviation of the signal (N for the Bouc-Wen system).
    random_state : int, RandomState, Generator or None
        Seed of the phases.

    Returns
    -------
    u : ndarray of shape (n_samples * n_periods, 1)

    Examples
    --------
    >>> u = multisine(1024, n_periods=2, random_state=0)
    >>> u.shape, bool(np.allclose(u[:1024], u[1024:])), round(float(u[:1024].std(ddof=1)), 6)
    ((2048, 1), True, 50.0)
    """
    n_samples = check_integer(n_samples, "n_samples", low=4)
    n_periods = check_integer(n_periods, "n_periods")
    fs = check_positive(fs, "fs")
    std = check_positive(std, "std")
    f_min = check_positive(f_min, "f_min", strict=False)
    f_max = check_positive(f_max, "f_max")
    if not f_min <= f_max < fs / 2:
        raise ValueError(f"the band must satisfy 0 <= f_min <= f_max < fs / 2 = {fs / 2:g} Hz; got [{f_min:g}, {f_max:g}].")
    rng = check_rng(random_state)
    df = fs / n_samples
    lines = np.arange(max(int(np.floor(f_min / df)), 1), min(int(np.ceil(f_max / df)), n_samples // 2 - 1) + 1)
    if lines.size == 0:
        raise ValueError(f"no DFT line lies in [{f_min:g}, {f_max:g}] Hz with {n_samples} samples at {fs:g} Hz.")
    spectrum = np.zeros(n_samples // 2 + 1, dtype=complex)
    spectrum[lines] = np.exp(2j * np.pi * rng.uniform(size=lines.size))
    period = np.fft.irfft(spectrum, n_samples)
    period *= std / period.std(ddof=1)
    return np.tile(period, n_periods).reshape(-1, 1)


def low_frequency_sine(*, amplitude=150.0, frequency=0.75, fs=750.0, n_periods=1):
    """Sine test input: ``amplitude * sin(2 pi frequency t)`` from ``t = 0``.

    With the defaults this is the third Bouc-Wen test of the study: 150 N at
    0.75 Hz, one period = 1000 samples at 750 Hz, slow enough for the
    displacement-force plot to show the hysteresis loop.

    Returns
    -------
    u : ndarray of shape (round(n_periods * fs / frequency), 1)

    Examples
    --------
    >>> u = low_frequency_sine()
    >>> u.shape, float(u[0, 0]), round(float(u.max()), 3)
    ((1000, 1), 0.0, 150.0)
    """
    amplitude = check_positive(amplitude, "amplitude")
    frequency = check_positive(frequency, "frequency")
    fs = check_positive(fs, "fs")
    n_periods = check_integer(n_periods, "n_periods")
    n = int(round(n_periods * fs / frequency))
    if n < 2:
        raise ValueError(f"the sine gives {n} samples at fs={fs:g} Hz; expected at least 2 (lower the frequency).")
    t = np.arange(n) / fs
    return (amplitude * np.sin(2 * np.pi * frequency * t)).reshape(-1, 1)

"""The derivative the data choose: a Savitzky-Golay filter whose window follows the outputs' bandwidth.

One home for what :func:`~sindybench.identify.identify` and the estimators'
``differentiation="auto"`` (``HiddenStateSINDy``'s default since 0.3) both use: the frequency below which
99.99 % of the detrended outputs' power lies, and the odd Savitzky-Golay
window whose -3 dB cutoff is near it (Schafer's rule for a cubic).
"""

import numpy as np

from ._local import FiniteDifference, SavitzkyGolay

__all__ = ["bandwidth", "data_differentiation", "savgol_window"]

_CUTOFF = 4.0  # the default derivative's cutoff, in bandwidths


def bandwidth(y, dt):
    """The frequency below which 99.99 % of the power of the detrended outputs lies (clamped to the band).

    Parameters
    ----------
    y : ndarray of shape (n_samples, n_outputs)
    dt : float

    Returns
    -------
    float
        In cycles per time unit of ``dt``, between ``1 / (400 dt)`` and ``1 / (4 dt)``.

    Examples
    --------
    >>> t = np.arange(4000) * 0.01
    >>> round(bandwidth(np.sin(2 * np.pi * 2.0 * t)[:, None], 0.01), 1)
    2.0
    """
    y = np.asarray(y, dtype=float)
    y = y[:, None] if y.ndim == 1 else y
    fs = 1.0 / dt
    n = y.shape[0]
    t = np.arange(n)
    power = np.zeros(n // 2 + 1)
    for col in y.T:
        resid = col - np.polyval(np.polyfit(t, col, 1), t)
        power += np.abs(np.fft.rfft(resid * np.hanning(n))) ** 2
    freqs = np.fft.rfftfreq(n, dt)
    cum = np.cumsum(power)
    if cum[-1] <= 0:
        return fs / 4
    f_c = float(freqs[np.searchsorted(cum, (1.0 - 1e-4) * cum[-1])])
    return float(np.clip(f_c, fs / 400, fs / 4))


def savgol_window(f_c, dt, polyorder=3):
    """Odd Savitzky-Golay window whose -3 dB cutoff is near ``f_c`` (Schafer's rule), 5 to 201 samples.

    Examples
    --------
    >>> savgol_window(1.0, 0.01)
    127
    """
    w = ((polyorder + 1) / (f_c * dt) + 4.6) / 3.2
    w = int(np.clip(round(w), polyorder + 2, 201))
    return w if w % 2 else w + 1


def data_differentiation(y, dt):
    """The derivative method the record ``y`` chooses: Savitzky-Golay (cubic) with the window of its bandwidth.

    The filter's cutoff is four times the bandwidth (:func:`bandwidth`), so
    that its bias on the signal's band stays small (a wider window biases the
    derivatives, and the initial velocities estimated from a record's first
    samples, by percents); the window is at most a fifth of the record (odd).
    A record shorter than 25 samples gets finite differences.

    Examples
    --------
    >>> t = np.arange(1500) * 0.01
    >>> data_differentiation(np.sin(t)[:, None], 0.01)
    SavitzkyGolay(window_length=95)
    """
    y = np.asarray(y, dtype=float)
    n = y.shape[0]
    if n < 25:
        return FiniteDifference()
    window = min(savgol_window(_CUTOFF * bandwidth(y, dt), dt), n // 5)
    window = window if window % 2 else window - 1
    return SavitzkyGolay(window_length=max(window, 5), polyorder=3)

"""Band-limited upsampling and MATLAB-style FIR decimation.

These two operations frame every benchmark simulation: the input, given at the
working rate, is interpolated to the integration rate without adding content
above the working Nyquist frequency, and the integrated output is brought back
with the low-pass FIR decimation of the Bouc-Wen benchmark (MATLAB
``decimate(y, r, 'fir')``: a 30th-order Hamming-window FIR with cut-off
``1/r``, applied without phase delay, keeping samples ``0, r, 2r, ...``).
"""

import numpy as np
from scipy import fft as sp_fft
from scipy.signal import firwin

__all__ = ["decimate_fir", "upsample"]

_MAX_PAD = 4096


def _reflect_pad(x, n_pad):
    """Extend ``x`` (1-D) at both ends by point reflection about its end samples.

    The odd extension ``2 x[0] - x[k]`` keeps the signal and its slope continuous
    at the ends, so filtering or interpolating the extension adds no step.
    """
    left = 2.0 * x[0] - x[n_pad:0:-1]
    right = 2.0 * x[-1] - x[-2 : -n_pad - 2 : -1]
    return np.concatenate([left, x, right])


def _fft_interpolate(x, factor):
    """Interpolate a periodic 1-D signal by zero-padding its spectrum."""
    n = x.shape[0]
    m = n * factor
    spec = sp_fft.rfft(x)
    if n % 2 == 0:
        # the Nyquist bin of the short signal stands for two bins of the long one
        spec[-1] *= 0.5
    padded = np.zeros(m // 2 + 1, dtype=complex)
    padded[: spec.shape[0]] = spec
    return sp_fft.irfft(padded, m) * factor


def upsample(x, factor, *, periodic=False):
    """Band-limited interpolation of a signal by an integer factor.

    Parameters
    ----------
    x : array-like of shape (n_samples,)
        Signal at the working rate.
    factor : int
        Upsampling factor (>= 1).
    periodic : bool, default=False
        Treat ``x`` as exactly one period: the interpolation is then exact for a
        signal with no content at or above the Nyquist frequency (a multisine).
        Otherwise the signal is extended by point reflection at both ends before
        the (FFT) interpolation, which avoids the ringing of a wrapped-around step.

    Returns
    -------
    ndarray of shape (n_samples * factor,)
        Sample ``k * factor`` of the result equals ``x[k]`` up to rounding.

    Examples
    --------
    >>> t = np.arange(64) / 64
    >>> x = np.sin(2 * np.pi * 3 * t)
    >>> xu = upsample(x, 4, periodic=True)
    >>> bool(np.allclose(xu, np.sin(2 * np.pi * 3 * np.arange(256) / 256)))
    True
    """
    x = np.asarray(x, dtype=float)
    factor = int(factor)
    if factor == 1:
        return x.copy()
    n = x.shape[0]
    if periodic or n < 3:
        return _fft_interpolate(x, factor)
    n_pad = min(n - 1, _MAX_PAD)
    extended = _reflect_pad(x, n_pad)
    # pad on the right up to a fast FFT length (the padding is discarded)
    n_fast = sp_fft.next_fast_len(extended.shape[0], real=True)
    if n_fast > extended.shape[0]:
        extended = np.concatenate([extended, np.full(n_fast - extended.shape[0], extended[-1])])
    fine = _fft_interpolate(extended, factor)
    return fine[n_pad * factor : (n_pad + n) * factor]


def _fir(factor, order):
    return firwin(order + 1, 1.0 / factor, window="hamming")


def decimate_fir(x, factor, *, order=30, periodic=False):
    """Low-pass FIR filter and keep every ``factor``-th sample (MATLAB ``decimate(x, r, 'fir')``).

    Parameters
    ----------
    x : array-like of shape (n_samples,)
    factor : int
        Decimation factor (>= 1).
    order : int, default=30
        FIR order (the number of taps is ``order + 1``; order must be even so
        that the delay is a whole number of samples).
    periodic : bool, default=False
        Filter circularly (``x`` is one period of a periodic steady state);
        otherwise the ends are extended by point reflection as MATLAB does.

    Returns
    -------
    ndarray of shape (ceil(n_samples / factor),)
        Filtered samples ``0, factor, 2 factor, ...``.

    Examples
    --------
    >>> decimate_fir(np.ones(40), 4).round(12).tolist()
    [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]
    """
    x = np.asarray(x, dtype=float)
    factor = int(factor)
    if factor == 1:
        return x.copy()
    b = _fir(factor, order)
    half = order // 2
    n = x.shape[0]
    if periodic:
        kernel = np.zeros(n)
        np.add.at(kernel, (np.arange(order + 1) - half) % n, b)
        filtered = sp_fft.irfft(sp_fft.rfft(x) * sp_fft.rfft(kernel), n)
        return filtered[::factor]
    n_pad = order + 1
    n_reflect = min(n_pad, n - 1)
    extended = _reflect_pad(x, n_reflect)
    if n_reflect < n_pad:
        # a record shorter than the filter: continue the reflected ends with their last values
        extra = n_pad - n_reflect
        extended = np.concatenate([np.full(extra, extended[0]), extended, np.full(extra, extended[-1])])
    filtered = np.convolve(extended, b, mode="same")[n_pad : n_pad + n]
    return filtered[::factor]

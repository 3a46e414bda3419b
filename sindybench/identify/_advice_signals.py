"""The data advice's checks of the signals themselves: the record's magnitude, the input hold, the
persistent excitation, saturation, trend and bandwidth (see :mod:`sindybench.identify._advice`)."""

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from .._validation import check_inputs_outputs, check_integer, check_positive, check_signal

__all__ = ["MAX_MAGNITUDE", "check_magnitude", "check_record", "detect_input_hold", "detect_saturation",
           "excitation_order", "noise_std", "output_bandwidth", "trend_share"]


#: the largest magnitude a record may reach: the ARX fits and the candidates' cubic terms square and cube it
MAX_MAGNITUDE = 1e100


def check_magnitude(X, y):
    """Refuse a record whose inputs or outputs reach beyond :data:`MAX_MAGNITUDE` (their squares overflow).

    Examples
    --------
    >>> check_magnitude(np.ones((3, 1)), 1e200 * np.ones((3, 1)))
    Traceback (most recent call last):
    ...
    ValueError: y reaches 1e+200 (output column 0): beyond 1e+100, where squares and cubes of it overflow float64; expected a record in units where it stays below 1e+100 (rescale it, e.g. y / 1e+200).
    """
    for name, values, kind in (("X", X, "input"), ("y", y, "output")):
        if values.size == 0:
            continue
        peak = np.max(np.abs(values), axis=0)
        j = int(np.argmax(peak))
        if peak[j] > MAX_MAGNITUDE:
            raise ValueError(f"{name} reaches {peak[j]:.3g} ({kind} column {j}): beyond {MAX_MAGNITUDE:.0e}, where "
                             f"squares and cubes of it overflow float64; expected a record in units where it stays "
                             f"below {MAX_MAGNITUDE:.0e} (rescale it, e.g. {name} / {peak[j]:.3g}).")


def check_record(X, y, dt):
    """``(X, y)`` of one record as 2-D float arrays, ``dt`` positive, values within :data:`MAX_MAGNITUDE`."""
    X, y = check_inputs_outputs(X, y)
    check_positive(dt, "dt")
    check_magnitude(X, y)
    return X, y


# ------------------------------------------------------------------------ hold
def detect_input_hold(X):
    """``"zoh"`` or ``"linear"`` for each input column, from its shape.

    Piecewise constant (over half of the steps repeat the previous value, or
    the second differences are as large as the first: a new value every
    sample, as a zero-order hold of a random sequence) is ``"zoh"``; smooth
    at the sample rate (second differences under half the first) is
    ``"linear"``.

    Examples
    --------
    >>> t = np.arange(500) * 0.01
    >>> detect_input_hold(np.column_stack([np.sin(t), np.repeat(np.arange(50.0) % 3, 10)]))
    ['linear', 'zoh']
    """
    X = check_signal(X, "X")
    holds = []
    for u in X.T:
        d1 = np.diff(u)
        if d1.size < 3 or not np.any(d1):
            holds.append("zoh")
            continue
        repeats = np.mean(np.abs(d1) <= 1e-12 * (np.ptp(u) or 1.0))
        roughness = np.sqrt(np.mean(np.diff(d1) ** 2) / np.mean(d1 ** 2))
        holds.append("zoh" if repeats > 0.5 or roughness >= 0.5 else "linear")
    return holds


# ------------------------------------------------------------------ excitation
def excitation_order(X, *, max_order=50, tol=1e-9):
    """Persistent-excitation order of each input: the rank of the matrix of its windows of ``max_order`` samples.

    The windows ``u[t:t + max_order]`` span a space whose dimension is the
    order (numerical rank: eigenvalues of their Gram matrix above ``tol``
    times the largest): a sum of ``k`` sines excites order ``2 k``, a
    constant order 1 (the offset), white noise every order, zero none. A
    model with more poles than the order cannot be told apart from others
    on this record.

    Examples
    --------
    >>> t = np.arange(2000) * 0.01
    >>> excitation_order(np.column_stack([np.sin(t) + np.sin(3.7 * t), np.ones_like(t)]), max_order=20)
    [4, 1]
    """
    X = check_signal(X, "X")
    max_order = check_integer(max_order, "max_order")
    tol = check_positive(tol, "tol", strict=False)
    if X.shape[0] < 2:
        raise ValueError(f"X has {X.shape[0]} sample(s); the excitation order of an input needs at least 2.")
    orders = []
    for u in X.T:
        if not np.any(u):
            orders.append(0)
            continue
        m = max(1, min(max_order, u.size // 2))
        u = u / np.max(np.abs(u))  # the rank does not depend on scale: no Gram matrix overflows or underflows
        windows = sliding_window_view(u, m)  # every window of m samples: their span has the order's dimension
        eig = np.linalg.eigvalsh(windows.T @ windows)
        orders.append(int(np.sum(eig > tol * eig[-1])))
    return orders


# ------------------------------------------------------------------ saturation
def noise_std(y):
    """Measurement-noise estimate from second differences (an upper bound for smooth signals)."""
    return np.sqrt(np.mean(np.diff(y, 2) ** 2) / 6) if y.size > 2 else 0.0


def detect_saturation(y, *, min_fraction=0.005, ratio=4.0):
    """Levels where an output's samples pile up at the top or bottom of its range.

    For each output and each end of its range, the fraction of samples within
    ``tol`` of the extreme (``tol``: 0.1 % of the range, or 3 noise standard
    deviations if larger) is compared with the fraction in the next band of
    the same width: a smooth signal (a sine near its peak) has at most about
    2.4 times as many at its extreme; a saturated one has a point mass there.
    The extreme of a noisy saturated output is a noise sample about ``tol``
    beyond the level, so bands twice as wide are compared too; a pile-up found
    only so is reported at the median of the samples within ``2 tol`` of the extreme.

    Parameters
    ----------
    y : array-like of shape (n_samples, n_outputs)
    min_fraction : float, default=0.005
        Smallest fraction of samples at the level to report, in (0, 1].
    ratio : float, default=4.0
        Least ratio (``>= 1``) of the fraction at the extreme to the fraction in the next band of the same width.

    Returns
    -------
    list of (int, str, float, float)
        ``(output, "upper" or "lower", level, fraction)``.

    Examples
    --------
    >>> t = np.arange(2000) * 0.01
    >>> detect_saturation(np.column_stack([np.minimum(np.sin(t), 0.8), np.sin(t)]))
    [(0, 'upper', 0.8, 0.2...)]
    """
    y = check_signal(y, "y")
    if check_positive(min_fraction, "min_fraction") > 1:
        raise ValueError(f"min_fraction must be a fraction in (0, 1]; got {min_fraction!r}.")
    if check_positive(ratio, "ratio") < 1:
        raise ValueError(f"ratio must be a finite number >= 1 (a pile-up has more samples at the extreme than in the "
                         f"next band); got {ratio!r}.")
    found = []
    for j, v in enumerate(y.T):
        span = np.ptp(v)
        if span == 0:
            continue
        tol = max(1e-3 * span, 3 * noise_std(v) if v.size > 2 else 0.0)
        for side, extreme, dist in (("upper", v.max(), v.max() - v), ("lower", v.min(), v - v.min())):
            for width in (tol, 2 * tol):  # the extreme itself, then a noisy level (the extreme ~ tol beyond it)
                band = dist <= width
                at = np.mean(band)
                if at >= min_fraction and at > ratio * np.mean((dist > width) & (dist <= 2 * width)):
                    found.append((j, side, float(extreme if width == tol else np.median(v[band])), float(at)))
                    break
    return found


# --------------------------------------------------------- trend and bandwidth
def trend_share(v):
    """Share of the variance of ``v`` that a straight line in time explains."""
    t = np.arange(v.size, dtype=float)
    var = np.var(v)
    if var == 0:
        return 0.0
    slope = np.polyfit(t, v, 1)[0]
    return float(min(1.0, slope ** 2 * np.var(t) / var))


def output_bandwidth(y, dt, share=0.95):
    """Per output, the frequency below which ``share`` of its detrended power lies."""
    out = []
    for v in y.T:
        v = v - np.polyval(np.polyfit(np.arange(v.size), v, 1), np.arange(v.size))
        power = np.abs(np.fft.rfft(v)) ** 2
        freq = np.fft.rfftfreq(v.size, dt)
        cumulative = np.cumsum(power[1:])
        if cumulative.size == 0 or cumulative[-1] == 0:
            out.append(float(freq[-1]) if freq.size else 0.0)
            continue
        out.append(float(freq[1:][np.searchsorted(cumulative, share * cumulative[-1])]))
    return np.array(out)

"""Error-centred figures: the measured output and each model's simulation error, a zoom window, the error spectrum."""

import numpy as np

from .._validation import check_integer, check_positive
from ._common import MAX_POINTS, _check_axes, _column, _new_axes, _predictions, _signals, _time


def envelope(t, v, max_points=MAX_POINTS):
    """``(t, v)`` decimated for drawing: per bucket its minimum and maximum, so that peaks stay visible.

    Records of at most ``max_points`` samples are returned as they are;
    longer ones as about ``max_points`` points (two per bucket, in time
    order). Only what is drawn is decimated: scores use the full record.

    Examples
    --------
    >>> t = np.arange(10_000.0)
    >>> v = np.zeros(10_000); v[5_003] = 7.0
    >>> td, vd = envelope(t, v, max_points=100)
    >>> len(td), float(vd.max())
    (100, 7.0)
    """
    t, v = np.asarray(t, dtype=float), np.asarray(v, dtype=float)
    max_points = check_integer(max_points, "max_points", low=2)
    n = len(v)
    if n <= max_points:
        return t, v
    k = int(np.ceil(n / (max_points // 2)))  # samples per bucket
    n_buckets = int(np.ceil(n / k))
    padded = np.full(n_buckets * k, np.nan)
    padded[:n] = v
    blocks = padded.reshape(n_buckets, k)
    finite = np.isfinite(blocks)
    any_finite = finite.any(axis=1)
    lo = np.argmin(np.where(finite, blocks, np.inf), axis=1)
    hi = np.argmax(np.where(finite, blocks, -np.inf), axis=1)
    first, second = np.minimum(lo, hi), np.maximum(lo, hi)  # in time order within each bucket
    base = np.arange(n_buckets) * k
    index = np.column_stack([base + first, base + second]).ravel()
    index = np.minimum(index, n - 1)
    vv = v[index].astype(float)
    vv[np.repeat(~any_finite, 2)] = np.nan  # a bucket that diverged stays a gap
    return t[index], vv


def zoom_window(errors, width):
    """``(start, stop)`` of the ``width`` samples where the errors are largest, each relative to its own mean square.

    Each error's moving mean square is divided by its mean square over the
    record, so a model with large errors everywhere does not decide alone;
    the window centres on the largest sum.

    Examples
    --------
    >>> e = np.zeros((1000, 2)); e[600:620, 0] = 1.0; e[610:630, 1] = 0.1
    >>> zoom_window(e, 100)
    (565, 665)
    """
    e = np.asarray(errors, dtype=float)
    e = e.reshape(len(e), -1)
    n = len(e)
    width = check_integer(width, "width", low=1)
    if width >= n:
        return 0, n
    sq = np.where(np.isfinite(e), e, 0.0) ** 2
    mean = sq.mean(axis=0)
    sq = sq[:, mean > 0] / mean[mean > 0]
    if sq.shape[1] == 0:
        return 0, width
    c = np.concatenate([[0.0], np.cumsum(sq.sum(axis=1))])
    sums = c[width:] - c[:-width]
    best = np.flatnonzero(sums >= sums.max() * (1 - 1e-12))  # ties: the middle one, so the peak sits centred
    start = int(best[len(best) // 2])
    return start, start + width


def _errors(X, y, models, n_init, output):
    X, y = _signals(X, y)
    y_col = _column(y, output, "output")
    sims = _predictions(models, X, y, n_init)
    # each model keeps its colour (its place among the models) in every panel, drawn or not
    return y_col, [(label, y_col - pred[:, output], f"C{i}") for i, (label, pred) in enumerate(sims)]


def _rms(e):
    e = e[np.isfinite(e)]
    return float(np.sqrt(np.mean(e ** 2))) if e.size else float("nan")


def plot_output_error(X, y, models, *, n_init=1, dt=None, output=0, output_label="output", zoom=None,
                      max_error=0.5, max_points=MAX_POINTS, ax=None):
    """The measured output and each model's simulation error on one axis, and a zoomed window of the same.

    The error ``y - y_sim`` of each model is drawn over the measured output
    (black), as the nonlinear benchmark papers draw it: models whose outputs
    would overlap differ visibly in their errors. The second panel zooms on
    a window where the errors are largest (:func:`zoom_window`), shaded on
    the first. Long records are drawn decimated (:func:`envelope`); the RMSE
    in each label is computed on every sample (from ``n_init`` on).

    Parameters
    ----------
    X : array-like of shape (n_samples, n_inputs) or None
        Inputs (to simulate fitted estimators).
    y : array-like of shape (n_samples, n_outputs)
        Measured outputs.
    models : estimator, array-like, list or dict
        Fitted estimators or arrays of simulated outputs shaped like ``y``
        (as in :func:`plot_simulation`); a dict gives the labels.
    n_init : int, default=1
        Samples of ``y`` handed to the estimators as ``y_init``; the RMSE
        skips them.
    dt : float, optional
        Sampling interval (time in seconds on the x axis; default samples).
    output : int, default=0
        Column of ``y`` to draw.
    output_label : str, default="output"
        The y axis label (with its unit, ``"y [V]"``).
    zoom : (int, int) or None, default=None
        ``(start, stop)`` samples of the zoom window; None: chosen by
        :func:`zoom_window` with a width of a hundredth of the record (at
        least 200 samples); ``False``: no zoom panel. When the errors in the
        window are far smaller than the output, the zoom's y axis is theirs.
    max_error : float, default=0.5
        A model whose error RMSE is at least ``max_error`` times the
        output's standard deviation (it explains at most about three
        quarters of the output's variance) is named in the legend's title,
        not drawn: its error would cover the output and the other errors.
    max_points : int, default=6000
        Most points drawn per curve.
    ax : Axes or sequence of two Axes, optional
        One Axes (no zoom) or ``(full, zoom)``.

    Returns
    -------
    list of Axes

    Examples
    --------
    >>> t = np.linspace(0, 20, 2000)
    >>> y = np.sin(t)[:, None]
    >>> axes = plot_output_error(None, y, {"good": y + 0.01, "poor": 1.2 * y}, dt=t[1])
    >>> [line.get_label() for line in axes[0].get_lines() if not line.get_label().startswith("_")]
    ['measured output', 'error of good (RMSE 0.01)', 'error of poor (RMSE 0.14)']
    """
    y_col, errors = _errors(X, y, models, n_init, output)
    n_init = check_integer(n_init, "n_init")
    max_points = check_integer(max_points, "max_points", low=2)
    max_error = check_positive(max_error, "max_error")
    t, t_label = _time(len(y_col), dt)
    # an error as large as the output hides the output and every other error: named, not drawn
    level = float(np.std(y_col[n_init:])) if len(y_col) > n_init else 0.0
    hidden = [label for label, e, _ in errors if level > 0 and not _rms(e[n_init:]) < max_error * level]
    if len(hidden) < len(errors):
        errors = [(label, e, c) for label, e, c in errors if label not in hidden]
    else:
        hidden = []
    if zoom is None:
        width = min(len(y_col), max(200, len(y_col) // 100))
        zoom = zoom_window(np.column_stack([e[n_init:] for _, e, _ in errors]) if errors else y_col[n_init:], width)
        zoom = (zoom[0] + n_init, min(zoom[1] + n_init, len(y_col)))
    if ax is None:
        axes = _new_axes(2 if zoom is not False else 1, figsize=(10, 6 if zoom is not False else 3.5), sharex=False)
    else:
        axes = _check_axes(ax, 1, 2)
        if len(axes) == 1:
            zoom = False
    if zoom is not False:
        a, b = (check_integer(v, "zoom", low=0) for v in zoom)
        if not a < b <= len(y_col):
            raise ValueError(f"zoom = {zoom!r}; expected (start, stop) samples with 0 <= start < stop <= {len(y_col)}.")
    zoomed_on_errors = False
    panels = [(axes[0], slice(None))] + ([(axes[1], slice(a, b))] if zoom is not False else [])
    for k, (panel, window) in enumerate(panels):
        tw = t[window]
        span = float(np.ptp(y_col[window])) if len(y_col[window]) else 1.0
        lo, hi = float(np.min(y_col[window])), float(np.max(y_col[window]))
        finite = np.concatenate([e[window][np.isfinite(e[window])] for _, e, _ in errors] or [np.zeros(0)])
        diverged = finite.size and (finite.min() < lo - span or finite.max() > hi + span)
        # errors far smaller than the output: the zoom's y axis is theirs, the output on a right-hand axis
        on_errors = k == 1 and not diverged and finite.size and 0 < np.abs(finite).max() < 0.125 * span
        if on_errors:
            right = panel.twinx()
            right.plot(*envelope(tw, y_col[window], max_points), color="0.55", lw=0.9)
            right.set_ylabel(f"{output_label} (grey)")
            panel.set_zorder(right.get_zorder() + 1)  # the errors above the output
            panel.patch.set_visible(False)
            zoomed_on_errors = True
        else:
            panel.plot(*envelope(tw, y_col[window], max_points), color="black", lw=1.0, label="measured output")
        for label, e, color in errors:
            e_drawn = e.copy()
            e_drawn[:n_init] = np.nan  # the start samples are given, not simulated
            text = f"error of {label} (RMSE {_rms(e[n_init:]):.3g})" if k == 0 else None
            panel.plot(*envelope(tw, e_drawn[window], max_points), lw=0.8, color=color, alpha=0.9, label=text)
        panel.set_ylabel(f"error, {output_label}" if on_errors else output_label)
        panel.axhline(0.0, color="0.6", lw=0.5)
        if diverged:
            panel.set_ylim(lo - span, hi + span)  # a diverged model does not flatten the others
        elif on_errors:
            top = 1.15 * float(np.abs(finite).max())
            panel.set_ylim(-top, top)
    legend = axes[0].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    if hidden:
        legend.set_title("not drawn, error as large as the output:\n" + "\n".join(hidden), prop={"size": 7})
    axes[0].set_title("measured output and simulation errors", fontsize=9)
    if zoom is not False:
        axes[0].axvspan(t[a], t[b - 1], color="tab:orange", alpha=0.15, lw=0)
        axes[1].set_title(f"zoom: {t_label.split(' ')[0]} {t[a]:.4g} to {t[b - 1]:.4g}"
                          + (": the errors on the left axis, the output (grey) on the right" if zoomed_on_errors else ""),
                          fontsize=9)
        axes[1].set_xlabel(t_label)
    axes[0].set_xlabel(t_label)
    return axes


def error_spectrum(e, dt=None, *, nperseg=None):
    """``(frequency, power in dB)`` of a signal by Welch's method (Hann windows, half overlap).

    Parameters
    ----------
    e : array-like of shape (n_samples,)
    dt : float, optional
        Sampling interval (frequency in Hz); default 1 (cycles per sample).
    nperseg : int, optional
        Samples per segment; default ``min(n, 1024)``.

    Examples
    --------
    >>> t = np.arange(4096)
    >>> f, p = error_spectrum(np.sin(2 * np.pi * 0.125 * t))
    >>> float(f[np.argmax(p)])
    0.125
    """
    from scipy.signal import welch

    e = np.asarray(e, dtype=float)
    e = e[np.isfinite(e)]
    fs = 1.0 if dt is None else 1.0 / float(dt)
    n = len(e)
    if n < 2:
        raise ValueError(f"the signal has {n} finite sample(s); expected at least 2 for a spectrum.")
    f, p = welch(e, fs=fs, nperseg=min(n, 1024) if nperseg is None else nperseg)
    return f, 10.0 * np.log10(np.maximum(p, 1e-300))


def plot_error_spectrum(X, y, models, *, n_init=1, dt=None, output=0, ax=None):
    """The spectra in dB of the measured output and of each model's simulation error (Welch's method).

    A model whose error lies far below the output over the excited band
    explains the output there; where an error reaches the output's level the
    model misses that band (Schoukens' benchmark figures).

    Parameters
    ----------
    X, y, models, n_init, dt, output
        As in :func:`plot_output_error`.
    ax : Axes, optional

    Returns
    -------
    Axes

    Examples
    --------
    >>> t = np.linspace(0, 20, 2000)
    >>> y = np.sin(t)[:, None]
    >>> ax = plot_error_spectrum(None, y, {"model": y + 0.01 * np.cos(5 * t)[:, None]}, dt=t[1])
    >>> [line.get_label() for line in ax.get_lines()]
    ['measured output', 'error of model']
    """
    y_col, errors = _errors(X, y, models, n_init, output)
    n_init = check_integer(n_init, "n_init")
    (ax,) = _check_axes(ax, 1) or _new_axes(1, figsize=(7, 4))
    f, p = error_spectrum(y_col[n_init:], dt)
    ax.plot(f, p, color="black", lw=1.2, label="measured output")
    for label, e, color in errors:
        if np.isfinite(e[n_init:]).sum() < 2:
            continue
        ax.plot(*error_spectrum(e[n_init:], dt), lw=0.9, color=color, label=f"error of {label}")
    ax.set_xlabel("frequency [Hz]" if dt is not None else "frequency [cycles / sample]")
    ax.set_ylabel("power spectral density [dB]")
    ax.set_xlim(0, f[-1])
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title("spectra of the output and of the errors", fontsize=9)
    return ax

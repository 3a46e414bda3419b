"""Prediction bands of an ensemble or a sampled covariance."""

import numpy as np

from .._validation import check_integer
from ._common import MAX_POINTS, _stacked_axes, _stride, _time


def plot_prediction_band(band, y=None, *, dt=None, columns=None, max_points=MAX_POINTS, ax=None):
    """A :class:`~sindybench.uncertainty.PredictionBand` over time: median and shaded band, one Axes per column.

    Parameters
    ----------
    band : PredictionBand
        From :func:`sindybench.uncertainty.prediction_band` (outputs, or
        every state with ``states=True``).
    y : array-like of shape (n_samples, n_outputs), optional
        Measured outputs, drawn on the output columns with the fraction of
        samples inside the band.
    dt : float, optional
        Sampling interval (time on the x axis); default samples.
    columns : list of str, optional
        Names of the columns to draw (default: all).
    max_points : int, default=6000
    ax : Axes or sequence of Axes, optional
        One Axes per drawn column.

    Returns
    -------
    list of Axes

    Examples
    --------
    >>> from sindybench.uncertainty import PredictionBand
    >>> s = np.random.default_rng(0).normal(size=(20, 50, 1)).cumsum(axis=1)
    >>> lo, med, hi = np.quantile(s, [0.025, 0.5, 0.975], axis=0)
    >>> band = PredictionBand(med, lo, hi, s, ["y0"], [0], 0.05, 0)
    >>> (ax,) = plot_prediction_band(band, y=s[0])
    >>> ax.get_ylabel(), len(ax.collections)
    ('y0', 1)
    """
    names = list(band.names)
    index = list(range(len(names))) if columns is None else [names.index(c) for c in columns if c in names]
    if columns is not None and len(index) != len(columns):
        raise ValueError(f"columns {list(columns)} are not all in the band's columns {names}.")
    axes = _stacked_axes(ax, len(index))
    n = band.median.shape[0]
    t, t_label = _time(n, dt)
    k = _stride(n, check_integer(max_points, "max_points"))
    level = round(100 * (1 - band.alpha))
    measured = None if y is None else np.asarray(y, dtype=float).reshape(n, -1)
    for a, i in zip(axes, index):
        line = a.plot(t[::k], band.median[::k, i], lw=1.2, label="ensemble median")[0]
        a.fill_between(t[::k], band.lower[::k, i], band.upper[::k, i], color=line.get_color(), alpha=0.25,
                       label=f"{level} % band")
        if measured is not None and i in band.outputs:
            m = measured[:, band.outputs.index(i)]
            inside = np.mean((m >= band.lower[:, i]) & (m <= band.upper[:, i]))
            a.plot(t[::k], m[::k], "k", lw=0.6, alpha=0.7, label=f"measured ({100 * inside:.0f} % inside)")
        a.set_ylabel(names[i])
        a.legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel(t_label)
    return axes

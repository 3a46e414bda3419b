"""The warning every ``predict`` gives when its simulation diverged (shared by all estimators)."""

import warnings

import numpy as np

__all__ = ["DivergenceWarning", "warn_divergence"]


class DivergenceWarning(UserWarning):
    """A prediction diverged: its output is NaN (or inf) from some sample on."""


def warn_divergence(y_pred, owner, *, stacklevel=3):
    """Warn when ``y_pred`` is not finite from some sample on; return ``y_pred`` unchanged.

    Parameters
    ----------
    y_pred : ndarray of shape (n_samples,) or (n_samples, n_outputs)
    owner : str
        The estimator's name, for the message.
    stacklevel : int, default=3
        Points the warning at the caller of ``predict``.

    Returns
    -------
    ndarray
        ``y_pred`` itself.

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _ = warn_divergence(np.array([1.0, 2.0, np.nan, np.nan]), "SINDy")
    >>> print(caught[0].message)
    SINDy.predict: the simulation diverged at sample 2 of 4; the prediction is NaN (or inf) from there on.
    """
    y = np.asarray(y_pred)
    bad = ~np.isfinite(y.reshape(y.shape[0], -1)).all(axis=1) if y.size else np.zeros(0, dtype=bool)
    if bad.any():
        step = int(np.argmax(bad))
        warnings.warn(f"{owner}.predict: the simulation diverged at sample {step} of {len(bad)}; the prediction is "
                      "NaN (or inf) from there on.", DivergenceWarning, stacklevel=stacklevel)
    return y_pred

"""Error metrics for open-loop simulations, each under its own name.

``r2`` is the coefficient of determination ``1 - SSE/SST`` (what the study's
"BFR" column reports); ``fit_index`` is the system-identification best fit ratio
``100 (1 - ||e|| / ||y - mean(y)||)``. They are different numbers: for a model
with R^2 = 0.75 the fit index is 50 %.
"""

import warnings

import numpy as np

from ._divergence import DivergenceWarning
from ._validation import check_integer, check_option, check_signal, is_records
from ._records import check_record_lists

__all__ = ["fit_index", "make_simulation_scorer", "nrmse", "r2", "rmse"]

_MULTIOUTPUT = ("uniform_average", "raw_values")


def _real_array(a, name):
    """``a`` as an array of real numbers; a complex or non-numeric ``a`` is a ``ValueError`` naming ``name``."""
    try:
        arr = np.asarray(a)
    except ValueError as exc:  # ragged nested sequences
        raise ValueError(f"{name} could not be converted to an array: {exc}") from exc
    if np.iscomplexobj(arr) or (arr.dtype == object and any(isinstance(v, complex) for v in arr.ravel())):
        raise ValueError(f"{name} has complex values; expected real numbers (take .real or abs() first if meant).")
    if arr.dtype.kind not in "biuf":
        try:
            arr = arr.astype(float)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name} could not be converted to a float array: {exc}") from exc
    return arr


def _prepare(y_true, y_pred, skip, multioutput):
    check_option(multioutput, "multioutput", _MULTIOUTPUT)
    y_true = check_signal(_real_array(y_true, "y_true"), "y_true")
    y_pred = np.asarray(_real_array(y_pred, "y_pred"), dtype=float)
    if y_pred.ndim == 1:
        y_pred = y_pred.reshape(-1, 1)
    if y_pred.shape != y_true.shape:
        raise ValueError(f"y_pred has shape {y_pred.shape}; expected the shape of y_true, {y_true.shape}.")
    if not np.all(np.isfinite(y_pred)):
        raise ValueError("y_pred contains NaN or inf (a diverged simulation?); expected finite values.")
    skip = check_integer(skip, "skip", low=0, high=y_true.shape[0] - 1)  # int(2.5) would score from sample 2
    return y_true[skip:], y_pred[skip:]


def _reduce(values, multioutput):
    return values if multioutput == "raw_values" else float(np.mean(values))


def _column_scale(y_true, y_pred):
    """Per-output powers of two near the largest magnitude: squares of the scaled values cannot overflow."""
    big = np.maximum(np.max(np.abs(y_true), axis=0, initial=0.0), np.max(np.abs(y_pred), axis=0, initial=0.0))
    return np.exp2(np.floor(np.log2(np.where(big > 0, big, 1.0))))


def _unscaled_or_scaled(compute, y_true, y_pred):
    """``compute(y_true, y_pred, scale)`` on the data as given, or, where a square overflowed, on the data
    divided by :func:`_column_scale` (values near the float limit: +-1e300). Ordinary data takes the first
    path, bit for bit."""
    with np.errstate(over="ignore", invalid="ignore"):
        out = compute(y_true, y_pred, np.ones(y_true.shape[1]))
    if np.all(np.isfinite(out)):
        return out
    scale = _column_scale(y_true, y_pred)
    with np.errstate(over="ignore", invalid="ignore"):
        return compute(y_true / scale, y_pred / scale, scale)


def _relative_sse(y_true, y_pred, skip, multioutput):
    """``SSE / SST`` per output: nrmse is its root, r2 is 1 minus it, fit_index 100 (1 - root)."""
    y_true, y_pred = _prepare(y_true, y_pred, skip, multioutput)
    if np.any(np.all(y_true == y_true[:1], axis=0)):
        raise ValueError("y_true is constant over the scored samples; R^2 and fit index are undefined.")

    def ratio(t, p, scale):  # SSE / SST: the same in any scale
        sst = np.sum((t - t.mean(axis=0)) ** 2, axis=0)
        return np.where(sst > 0, np.sum((t - p) ** 2, axis=0) / np.where(sst > 0, sst, 1.0), np.inf)

    out = _unscaled_or_scaled(ratio, y_true, y_pred)
    if np.any(np.isinf(out)):  # a spread that rounds to zero beside its magnitude
        raise ValueError("y_true varies less than floating point resolves over the scored samples; R^2 and fit "
                         "index are undefined.")
    return out


def rmse(y_true, y_pred, *, skip=0, multioutput="uniform_average"):
    """Root-mean-square error.

    Parameters
    ----------
    y_true, y_pred : array-like of shape (n_samples,) or (n_samples, n_outputs)
    skip : int, default=0
        Leave out the first ``skip`` samples (e.g. a transient).
    multioutput : {"uniform_average", "raw_values"}

    Returns
    -------
    float or ndarray

    Examples
    --------
    >>> rmse([0.0, 1.0, 2.0], [0.0, 1.0, 3.0])
    0.577...
    """
    y_true, y_pred = _prepare(y_true, y_pred, skip, multioutput)
    out = _unscaled_or_scaled(lambda t, p, scale: scale * np.sqrt(np.mean((t - p) ** 2, axis=0)), y_true, y_pred)
    if not np.all(np.isfinite(out)):
        raise ValueError(f"the RMSE overflows a float (y_true and y_pred differ by more than {np.finfo(float).max:.3g} "
                         "on average); expected values whose differences fit in a float.")
    return _reduce(out, multioutput)


def nrmse(y_true, y_pred, *, skip=0, multioutput="uniform_average"):
    """RMSE divided by the standard deviation of ``y_true``.

    Parameters
    ----------
    y_true, y_pred : array-like of shape (n_samples,) or (n_samples, n_outputs)
    skip : int, default=0
        Leave out the first ``skip`` samples (e.g. a transient).
    multioutput : {"uniform_average", "raw_values"}

    Returns
    -------
    float or ndarray

    Examples
    --------
    >>> nrmse([0.0, 1.0, 2.0], [0.0, 1.0, 3.0])
    0.707...
    """
    return _reduce(np.sqrt(_relative_sse(y_true, y_pred, skip, multioutput)), multioutput)


def r2(y_true, y_pred, *, skip=0, multioutput="uniform_average"):
    """Coefficient of determination ``1 - SSE / SST``.

    This is what ``sklearn.metrics.r2_score`` returns, and what the benchmarking
    study reports under the name "BFR". It is not the fit index.

    Parameters
    ----------
    y_true, y_pred : array-like of shape (n_samples,) or (n_samples, n_outputs)
    skip : int, default=0
        Leave out the first ``skip`` samples (e.g. a transient).
    multioutput : {"uniform_average", "raw_values"}

    Returns
    -------
    float or ndarray

    Examples
    --------
    >>> r2([0.0, 1.0, 2.0], [0.0, 1.0, 3.0])
    0.5
    """
    return _reduce(1.0 - _relative_sse(y_true, y_pred, skip, multioutput), multioutput)


def fit_index(y_true, y_pred, *, skip=0, multioutput="uniform_average"):
    """Best fit ratio in percent, ``100 (1 - ||y - y_hat|| / ||y - mean(y)||)``.

    The system-identification literature's BFR (MATLAB's ``compare`` fit).
    Related to R^2 by ``fit = 100 (1 - sqrt(1 - R^2))``.

    Parameters
    ----------
    y_true, y_pred : array-like of shape (n_samples,) or (n_samples, n_outputs)
    skip : int, default=0
        Leave out the first ``skip`` samples (e.g. a transient).
    multioutput : {"uniform_average", "raw_values"}

    Returns
    -------
    float or ndarray

    Examples
    --------
    >>> fit_index([0.0, 1.0, 2.0], [0.0, 1.0, 3.0])
    29.28...
    """
    return _reduce(100.0 * (1.0 - np.sqrt(_relative_sse(y_true, y_pred, skip, multioutput))), multioutput)


_METRICS = {"rmse": (rmse, False), "nrmse": (nrmse, False), "r2": (r2, True), "fit_index": (fit_index, True)}


class _SimulationScorer:
    """Callable ``scorer(estimator, X, y)`` that scores an open-loop simulation."""

    def __init__(self, name, skip):
        self.name = name
        self.skip = skip

    def __call__(self, estimator, X, y, sample_weight=None):
        if sample_weight is not None:
            raise ValueError("sample_weight is not supported by the simulation scorers; expected None.")
        several = is_records(y) or is_records(X)
        if several:
            check_record_lists(X, y)
        func, greater_is_better = _METRICS[self.name]
        with warnings.catch_warnings():  # a diverged simulation scores -inf, no warning
            warnings.simplefilter("ignore", DivergenceWarning)
            y_pred = estimator.predict(X, y_init=y)  # the shapes the estimator was given: any estimator scores
        if not several:  # one record is a list of one from here on
            y_pred, y = [y_pred], [check_signal(_real_array(y, "y_true"), "y_true")]
        skip = check_integer(self.skip, "skip", low=0, high=min(len(r) for r in y) - 1)
        # each record simulated from its own start: the samples pooled
        y_pred = np.vstack([np.asarray(p, dtype=float).reshape(len(r), -1)[skip:] for p, r in zip(y_pred, y)])
        y = np.vstack([np.asarray(r, dtype=float).reshape(len(r), -1)[skip:] for r in y])
        if not np.all(np.isfinite(y_pred)):
            return -np.inf
        value = func(y, y_pred)
        return value if greater_is_better else -value

    def __repr__(self):
        return f"make_simulation_scorer({self.name!r}, skip={self.skip})"


def make_simulation_scorer(metric="rmse", *, skip=0):
    """Make a scikit-learn scorer that scores open-loop simulation.

    The scorer calls ``estimator.predict(X, y_init=y)``: the simulation is driven
    by the inputs ``X`` and initialised from the start of the measured ``y``,
    then compared with all of ``y``. Error metrics are negated so that greater
    is better, as scikit-learn expects; a diverged simulation scores ``-inf``.
    With several records (``X`` and ``y`` lists of arrays) each record is
    simulated from its own start and the metric pools the samples of all
    records (``skip`` leaves out the first samples of each).

    Parameters
    ----------
    metric : {"rmse", "nrmse", "r2", "fit_index"}
    skip : int, default=0
        Leave out the first ``skip`` samples.

    Returns
    -------
    callable
        ``scorer(estimator, X, y) -> float``, usable as ``scoring=``.

    Examples
    --------
    >>> make_simulation_scorer("fit_index")
    make_simulation_scorer('fit_index', skip=0)
    """
    check_option(metric, "metric", sorted(_METRICS))
    return _SimulationScorer(metric, check_integer(skip, "skip", low=0))

"""Calibrated prediction bands: split conformal prediction on held-out blocks of a record.

The band of a fitted model's prediction is ``prediction +- q``, ``q`` (one per
output) the conformal quantile of the model's absolute errors on calibration
data it was not chosen on (a validation block): of the ``n`` calibration
scores, the ``ceil((n + 1)(1 - alpha))``-th smallest, the finite-sample rule
of split conformal prediction. It believes nothing about the model: when the
errors on new data are distributed as on the calibration data, the band holds
``1 - alpha`` of the samples, whatever the model got wrong.

Adapted to time series in two ways:

* **block-wise**: the calibration record is cut into blocks of
  ``block_length`` samples and each block is predicted as a test record is,
  its free run started from its own first ``n_init`` samples (the k-step
  prediction filtered from the block's start), so the scores include the
  start-up errors a test record has;
* **by horizon**: a k-step band is calibrated on the errors of the k-step
  predictions (the errors grow with the horizon; each horizon has its own
  quantile), a free-run band on the free run's.

What it assumes: the calibration errors are representative of the new ones
(the same kind of input and operating range). The guarantee of split conformal
prediction needs exchangeable scores; the errors of a simulation are
correlated in time, so the band's coverage is a long-run fraction of samples,
reached over records long compared with the errors' correlation time, not a
per-sample promise. Calibrating on data the model was fitted on gives a band
too narrow (the fit made those errors small: on the cascaded tanks, a refined
model's band from its own validation-block errors covered 0.875 of the test
samples, from those of the same model refitted without that block 0.958).

Why not MAPIE: its regressors (``SplitConformalRegressor``, and
``TimeSeriesRegressor`` for EnbPI / ACI) call ``estimator.predict(X_conf)``
on rows taken as independent samples; an open-loop prediction at sample ``t``
depends on every input before ``t`` and on the initial state from the record's
first outputs, which that interface cannot pass, and EnbPI refits
bootstrap models (what this band avoids), ACI updates with the test outputs.
What MAPIE would add here is the quantile rule above, a few lines; the tests
check it gives MAPIE's ``SplitConformalRegressor`` bounds on the same scores.
"""

import math
import warnings
from typing import NamedTuple

import numpy as np

from .._validation import check_alpha, check_integer, check_positive
from ._residuals import check_record, free_run_prediction, k_step_prediction

__all__ = ["ConformalBand", "ConformalCalibration", "ExtrapolationWarning", "conformal_calibration", "conformal_quantile"]


#: The extrapolation warning's default tolerances: the fraction of samples outside the calibration's range, and the
#: distance beyond it (a fraction of the range's width), that do not warn (see :meth:`ConformalCalibration.around`).
MAX_OUTSIDE, MARGIN = 0.01, 0.1


def conformal_quantile(scores, alpha):
    """The split-conformal quantile of each column of ``scores``: the ``ceil((n + 1)(1 - alpha))``-th smallest.

    Parameters
    ----------
    scores : ndarray of shape (n, n_columns)
    alpha : float in (0, 1)

    Returns
    -------
    ndarray of shape (n_columns,)

    Raises
    ------
    ValueError
        When ``n`` is too small for ``alpha`` (``ceil((n + 1)(1 - alpha)) > n``:
        the band would be infinite), or on NaN scores.

    Examples
    --------
    >>> conformal_quantile(np.arange(1.0, 20.0)[:, None], 0.1).tolist()
    [18.0]
    """
    alpha = check_alpha(alpha, "bands")
    try:
        scores = np.asarray(scores, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"scores must be an array of real numbers (the calibration errors); got {exc}.") from None
    if not np.all(np.isfinite(scores)):
        raise ValueError("scores (the calibration errors) contain NaN or inf; expected a prediction that did not "
                         "diverge.")
    n = scores.shape[0]
    rank = math.ceil((n + 1) * (1.0 - alpha))
    if rank > n:
        raise ValueError(f"{n} calibration errors are too few for alpha = {alpha:g}: the band would be infinite; "
                         f"expected at least {math.ceil(1.0 / alpha - 1.0)} (a longer calibration record or a "
                         "larger alpha).")
    return np.sort(scores, axis=0)[rank - 1]


class ConformalBand(NamedTuple):
    """A calibrated band around one prediction of a record.

    Attributes
    ----------
    prediction, lower, upper : ndarray of shape (n_samples - start, n_outputs)
        The prediction of ``y[start:]`` and the band around it.
    start : int
        The first sample predicted (0 for the free run, the horizon ``k`` for
        a k-step prediction, whose first ``k`` samples have no prediction).
    name : str
        The band's name in reports (``"conformal 95 % free-run band"``).
    extrapolation : dict or None
        Where the record leaves the range the band was calibrated on
        (:func:`extrapolation`): the fractions of its samples whose inputs,
        predicted outputs, or either lie outside the calibration record's, and
        that record; ``None`` when the calibration kept no range.
    """

    prediction: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    start: int
    name: str
    extrapolation: dict = None

    def _measured(self, y, first):
        y = np.asarray(y, dtype=float).reshape(len(y), -1)
        if y.shape != (self.prediction.shape[0] + self.start, self.prediction.shape[1]):
            raise ValueError(f"y has shape {y.shape}; expected {(self.prediction.shape[0] + self.start,)} + "
                             f"({self.prediction.shape[1]},) (the record the band was made for).")
        skip = max(int(first) - self.start, 0)
        return y[self.start + skip:], skip

    def coverage(self, y, first=0):
        """Fraction of the measured ``y`` (the whole record) inside the band, over the samples from ``first`` on."""
        y, skip = self._measured(y, first)
        return float(np.mean((y >= self.lower[skip:]) & (y <= self.upper[skip:])))

    def mean_width(self, first=0):
        """Mean of ``upper - lower`` over the samples from ``first`` on."""
        skip = max(int(first) - self.start, 0)
        return float(np.mean(self.upper[skip:] - self.lower[skip:]))


class ConformalCalibration(NamedTuple):
    """The calibration of a conformal band (:func:`conformal_calibration`); ``band`` applies it to a record.

    Attributes
    ----------
    alpha : float
    horizon : int or None
        ``None`` for the free-run band, ``k`` for the k-step band.
    half_width : ndarray of shape (n_outputs,)
        The conformal quantile of the absolute errors, one per output.
    n_scores : int
        Calibration errors per output.
    n_blocks : int
    block_length : int
    n_init : int
        Samples that start a free run (``y_init``).
    ranges : dict or None
        The calibration record's range (:func:`calibration_ranges`): of its
        inputs and of the model's predicted outputs; a band of a record
        outside it warns (:class:`ExtrapolationWarning`). ``None`` for a
        calibration saved before the ranges were kept.
    """

    alpha: float
    horizon: int
    half_width: np.ndarray
    n_scores: int
    n_blocks: int
    block_length: int
    n_init: int
    ranges: dict = None

    @property
    def name(self):
        """``"conformal 95 % free-run band"`` or ``"conformal 95 % 10-step band"``."""
        what = "free-run" if self.horizon is None else f"{self.horizon}-step"
        return f"conformal {100 * (1 - self.alpha):g} % {what} band"

    def band(self, model, X, *, y_init=None, y=None, Q=None, R=None, max_outside=MAX_OUTSIDE, margin=MARGIN):
        """The calibrated band of ``model``'s prediction of a new record.

        Warns (:class:`ExtrapolationWarning`) when the record leaves the range
        of the calibration record by more than ``max_outside`` and ``margin``
        allow (see :meth:`around`).

        Parameters
        ----------
        model : fitted estimator
            The model that was calibrated.
        X : array-like of shape (n_samples, n_inputs) or None
        y_init : array-like of shape (>= n_init, n_outputs), optional
            Free-run band: the first measured outputs (``n_init`` are used).
        y : array-like of shape (n_samples, n_outputs), optional
            k-step band: the measured outputs the prediction filters (each
            prediction uses those ``k`` samples before it and earlier); a
            free-run band takes its first ``n_init`` samples as ``y_init``.
        Q, R : array-like, optional
            Noise covariances of a state-space model's k-step prediction
            (default: estimated on ``(X, y)``, as in the calibration).
        max_outside, margin : float, default=0.01, 0.1
            The extrapolation warning's tolerances (see :meth:`around`).

        Returns
        -------
        ConformalBand
        """
        if self.horizon is None:
            if y_init is None:
                if y is None:
                    raise ValueError("a free-run band needs y_init (the first measured outputs of the record).")
                y_init = y
            y_init = np.asarray(y_init, dtype=float)
            y_init = y_init.reshape(len(y_init), -1)
            if y_init.shape[0] < self.n_init:
                raise ValueError(f"y_init has {y_init.shape[0]} samples; expected at least n_init = {self.n_init}.")
            n = len(X) if X is not None else y_init.shape[0]
            pred = np.asarray(model.predict(X, y_init=y_init[:self.n_init]), dtype=float).reshape(n, -1)
            start = 0
        else:
            if y is None:
                raise ValueError(f"a {self.horizon}-step band needs y, the measured outputs of the record.")
            X, y = check_record(X, y, "ConformalCalibration.band")
            pred, start = k_step_prediction(model, X, y, self.horizon, Q=Q, R=R), self.horizon
        return self._around(pred, start, X, (max_outside, margin), stacklevel=3)

    def around(self, prediction, start=0, *, X=None, max_outside=MAX_OUTSIDE, margin=MARGIN):
        """The band around a prediction already made (the free run, or the k-step prediction of ``y[start:]``).

        Warns (:class:`ExtrapolationWarning`) when the record's inputs ``X`` or
        the prediction leave the range of the calibration record: when more
        than ``max_outside`` of the samples lie outside it, or any sample lies
        beyond it by more than ``margin`` of its width (per column). A few
        samples a little outside (noise on a test input that reaches the same
        peaks) cannot move the coverage by more than their fraction, and the
        errors at the range's edge are calibrated; a sample far beyond it is
        a regime the calibration never saw. ``max_outside=0, margin=0`` warns
        at any sample outside. The band's ``extrapolation`` reports the
        fractions outside whether it warns or not.

        Parameters
        ----------
        prediction : array-like of shape (n_predicted, n_outputs)
        start : int, default=0
            The first sample predicted (``horizon`` for a k-step prediction).
        X : array-like of shape (n_samples, n_inputs), optional
            The record's inputs (checked against the calibration's input range).
        max_outside : float in [0, 1], default=0.01
            Largest fraction of the samples outside the range that does not warn.
        margin : float >= 0, default=0.1
            Largest distance beyond the range, as a fraction of its width,
            that does not warn.

        Returns
        -------
        ConformalBand

        Examples
        --------
        >>> cal = ConformalCalibration(0.05, None, np.array([0.1]), 100, 1, 100, 1,
        ...                            calibration_ranges(None, np.linspace(0.0, 1.0, 100)))
        >>> band = cal.around(np.linspace(0.0, 1.001, 200))  # one sample 0.1 % of the range beyond it: no warning
        >>> band.extrapolation["fraction"]
        0.005
        >>> import warnings
        >>> with warnings.catch_warnings(record=True) as caught:
        ...     warnings.simplefilter("always")
        ...     band = cal.around(np.linspace(0.0, 1.001, 200), max_outside=0, margin=0)
        >>> [w.category.__name__ for w in caught]
        ['ExtrapolationWarning']
        """
        return self._around(prediction, start, X, (max_outside, margin), stacklevel=3)

    def _around(self, prediction, start, X, tolerance, *, stacklevel):
        """:meth:`around`; its warning points ``stacklevel`` frames up (at the user's call of ``band`` or ``around``)."""
        max_outside, margin = tolerance
        if check_positive(max_outside, "max_outside", strict=False) > 1:
            raise ValueError(f"max_outside must be a fraction in [0, 1]; got {max_outside!r}.")
        margin = check_positive(margin, "margin", strict=False)
        pred = np.asarray(prediction, dtype=float)
        pred = pred.reshape(len(pred), -1)
        if pred.shape[1] != self.half_width.shape[0]:
            raise ValueError(f"the prediction has {pred.shape[1]} outputs; the calibration has "
                             f"{self.half_width.shape[0]} (another model?).")
        if not np.all(np.isfinite(pred)):
            raise ValueError("the prediction contains NaN or inf (a diverged simulation); expected a finite one.")
        X = None if X is None else X[int(start):]
        found = None if self.ranges is None else extrapolation(self.ranges, X, pred)
        beyond = 0.0 if found is None or found["fraction"] == 0 else excursion(self.ranges, X, pred)
        if found is not None and (found["fraction"] > max_outside or beyond > margin):
            warnings.warn(f"the {self.name} extrapolates: {100 * found['fraction']:.1f} % of the record's samples "
                          f"(inputs {100 * found['fraction_inputs']:.1f} %, predicted outputs "
                          f"{100 * found['fraction_outputs']:.1f} %) lie outside the range of its calibration record "
                          f"({found['calibration']}), the farthest by {100 * beyond:.3g} % of the range's width; the "
                          f"band is not calibrated there (warns above max_outside = {max_outside:g} of the samples "
                          f"or beyond margin = {margin:g} of the width).", ExtrapolationWarning, stacklevel=stacklevel)
        return ConformalBand(pred, pred - self.half_width, pred + self.half_width, int(start), self.name, found)

    def to_dict(self):
        """JSON-able dict; :meth:`from_dict` inverts it."""
        return {"alpha": self.alpha, "horizon": self.horizon, "half_width": self.half_width.tolist(),
                "n_scores": self.n_scores, "n_blocks": self.n_blocks, "block_length": self.block_length,
                "n_init": self.n_init, "name": self.name,
                "ranges": None if self.ranges is None else {k: np.asarray(v).tolist() if k != "n_samples" else v
                                                            for k, v in self.ranges.items()}}

    @classmethod
    def from_dict(cls, data):
        """Rebuild from :meth:`to_dict`'s output."""
        horizon = data["horizon"]
        return cls(float(data["alpha"]), None if horizon is None else int(horizon),
                   np.asarray(data["half_width"], dtype=float).reshape(-1), int(data["n_scores"]),
                   int(data["n_blocks"]), int(data["block_length"]), int(data["n_init"]),
                   _ranges_from_dict(data.get("ranges")))  # absent in dicts written before the ranges were kept


class ExtrapolationWarning(UserWarning):
    """A band is asked for a record outside the range it was calibrated on (its coverage is not calibrated there)."""


def calibration_ranges(X, prediction):
    """The range (per column, min and max) of a calibration record's inputs and of the model's prediction of it.

    Examples
    --------
    >>> r = calibration_ranges(np.array([[0.0], [2.0]]), np.array([[1.0], [-1.0]]))
    >>> r["inputs"].tolist(), r["outputs"].tolist(), r["n_samples"]
    ([[0.0], [2.0]], [[-1.0], [1.0]], 2)
    """
    pred = np.asarray(prediction, dtype=float)
    pred = pred.reshape(len(pred), -1)
    X = np.zeros((len(pred), 0)) if X is None else np.asarray(X, dtype=float).reshape(len(X), -1)
    return {"inputs": np.vstack([X.min(axis=0), X.max(axis=0)]) if len(X) else np.zeros((2, X.shape[1])),
            "outputs": np.vstack([pred.min(axis=0), pred.max(axis=0)]), "n_samples": int(len(pred))}


def _ranges_from_dict(data):
    if data is None:
        return None
    return {"inputs": np.asarray(data["inputs"], dtype=float).reshape(2, -1),
            "outputs": np.asarray(data["outputs"], dtype=float).reshape(2, -1), "n_samples": int(data["n_samples"])}


def _outside(values, bounds):
    if values.shape[1] == 0 or values.shape[1] != bounds.shape[1]:
        return np.zeros(len(values), dtype=bool)
    return np.any((values < bounds[0]) | (values > bounds[1]), axis=1)


def _beyond(values, bounds):
    """The largest distance of ``values`` outside ``bounds``, per column as a fraction of its width (inf for a
    column of width 0 left)."""
    if values.size == 0 or values.shape[1] != bounds.shape[1]:
        return 0.0
    distance = np.max(np.maximum(np.maximum(bounds[0] - values, values - bounds[1]), 0.0), axis=0)
    width = bounds[1] - bounds[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        relative = np.where(distance > 0, distance / np.where(width > 0, width, 0.0), 0.0)
    return float(np.max(relative))


def excursion(ranges, X, prediction):
    """How far a record goes beyond a calibration's ranges: the largest distance of an input or a predicted output
    outside its range, as a fraction of the range's width (0 inside; inf beyond a range of width 0).

    Examples
    --------
    >>> r = calibration_ranges(np.array([[0.0], [2.0]]), np.array([[1.0], [-1.0]]))
    >>> excursion(r, np.array([[1.0], [2.5]]), np.array([[0.0], [0.0]]))
    0.25
    """
    pred = np.asarray(prediction, dtype=float)
    pred = pred.reshape(len(pred), -1)
    beyond = _beyond(pred, ranges["outputs"])
    if X is not None:
        X = np.asarray(X, dtype=float).reshape(len(X), -1)[:len(pred)]
        beyond = max(beyond, _beyond(X, ranges["inputs"]))
    return beyond


def _interval_text(bounds):
    return ", ".join(f"[{lo:.3g}, {hi:.3g}]" for lo, hi in zip(*bounds))


def extrapolation(ranges, X, prediction):
    """Where a record leaves a calibration's ranges (:func:`calibration_ranges`): fractions of its samples.

    Parameters
    ----------
    ranges : dict
    X : array-like of shape (n_samples, n_inputs) or None
        The record's inputs, row for row with ``prediction``.
    prediction : array-like of shape (n_samples, n_outputs)

    Returns
    -------
    dict
        ``fraction_inputs``, ``fraction_outputs`` (samples with an input, or
        a predicted output, outside the calibration's range), ``fraction``
        (either), ``n_samples`` and ``calibration`` (the calibration record in
        words: its length and ranges).

    Examples
    --------
    >>> r = calibration_ranges(np.array([[0.0], [2.0]]), np.array([[1.0], [-1.0]]))
    >>> e = extrapolation(r, np.array([[1.0], [3.0], [1.0], [1.0]]), np.array([[0.0], [0.0], [5.0], [0.5]]))
    >>> e["fraction_inputs"], e["fraction_outputs"], e["fraction"]
    (0.25, 0.25, 0.5)
    """
    pred = np.asarray(prediction, dtype=float)
    pred = pred.reshape(len(pred), -1)
    out_u = np.zeros(len(pred), dtype=bool)
    if X is not None:
        X = np.asarray(X, dtype=float).reshape(len(X), -1)[:len(pred)]
        out_u[:len(X)] = _outside(X, ranges["inputs"])
    out_y = _outside(pred, ranges["outputs"])
    n = max(len(pred), 1)
    calibration = (f"{ranges['n_samples']} samples; inputs in {_interval_text(ranges['inputs']) or 'none'}, "
                   f"predicted outputs in {_interval_text(ranges['outputs'])}")
    return {"fraction_inputs": float(out_u.sum() / n), "fraction_outputs": float(out_y.sum() / n),
            "fraction": float((out_u | out_y).sum() / n), "n_samples": int(len(pred)), "calibration": calibration}


def _blocks(n, block_length, need, what):
    """``(start, stop)`` of the blocks of ``block_length`` samples; a last shorter block joins the one before."""
    if block_length is None:
        block_length = n
    block_length = check_integer(block_length, "block_length", low=1)
    if block_length > n:
        raise ValueError(f"block_length = {block_length} exceeds the {n} samples of the calibration record.")
    if block_length <= need:
        raise ValueError(f"block_length = {block_length} is not longer than {what} = {need}; expected calibration "
                         "blocks longer than that (each block must leave errors to score).")
    starts = list(range(0, n - block_length + 1, block_length))
    stops = starts[1:] + [n]
    return list(zip(starts, stops)), block_length


def conformal_calibration(model, X, y, *, alpha=0.05, horizon=None, block_length=None, n_init=None, score_from=0,
                          Q=None, R=None):
    """Calibrate a conformal band of a fitted model's free run or k-step prediction on held-out data.

    Parameters
    ----------
    model : fitted estimator
        SINDy, HiddenStateSINDy, ARX, NN-ARX, or what ``identify`` returns.
    X : array-like of shape (n_samples, n_inputs) or None
    y : array-like of shape (n_samples, n_outputs) or (n_samples,)
        The calibration record: data the model was not fitted or chosen on
        (a validation block), never the test data.
    alpha : float, default=0.05
        ``1 - alpha`` bands.
    horizon : int, optional
        ``None``: the free-run band; ``k``: the k-step-ahead band.
    block_length : int, optional
        Samples per calibration block (default: the whole record, one block);
        a shorter last block joins the one before.
    n_init : int, optional
        Free run: the first samples of each block that start it (``y_init``);
        default the lags of a lag model (``n_lags_``), else 10.
    score_from : int, default=0
        Free run: score the errors from this sample of each block on (as a
        test protocol that scores after a start-up period).
    Q, R : array-like, optional
        k-step prediction of a state-space model: the filter's noise
        covariances (default: :func:`~sindybench.estimation.estimate_noise` on
        each block).

    Returns
    -------
    ConformalCalibration

    Raises
    ------
    ValueError
        For ``alpha`` outside (0, 1), a block not longer than the horizon (or
        than ``n_init``), too few errors for ``alpha``, or a prediction that
        diverged (NaN errors).

    Examples
    --------
    >>> from sindybench.baselines import ARX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(4000, 1))
    >>> y = np.zeros((4000, 1))
    >>> for t in range(1, 4000):
    ...     y[t] = 0.9 * y[t - 1] + u[t - 1]
    >>> y = y + 0.1 * rng.normal(size=y.shape)
    >>> model = ARX(na=1, nb=1).fit(u[:2000], y[:2000])
    >>> cal = conformal_calibration(model, u[2000:3000], y[2000:3000], block_length=250)
    >>> cal.name, cal.n_blocks
    ('conformal 95 % free-run band', 4)
    >>> band = cal.band(model, u[3000:], y_init=y[3000:])
    >>> 0.9 < band.coverage(y[3000:]) < 0.99
    True
    """
    alpha = check_alpha(alpha, "bands")
    X, y = check_record(X, y, "conformal_calibration")
    n = y.shape[0]
    if horizon is None:
        n_init = max(getattr(model, "n_lags_", 10), 1) if n_init is None else check_integer(n_init, "n_init", low=1)
        score_from = check_integer(score_from, "score_from", low=0)
        blocks, length = _blocks(n, block_length, max(n_init, score_from), "n_init (and score_from)")
    else:
        horizon = check_integer(horizon, "horizon", low=1)
        n_init = 0
        blocks, length = _blocks(n, block_length, horizon, "the horizon")
    scores, inputs, predictions = [], [], []
    for i, (a, b) in enumerate(blocks):
        Xb = None if X is None else X[a:b]
        if horizon is None:
            pred = free_run_prediction(model, Xb, y[a:b], n_init)
            err = (y[a:b] - pred)[score_from:]
        else:
            pred = k_step_prediction(model, Xb, y[a:b], horizon, Q=Q, R=R)
            err = y[a + horizon:b] - pred
        predictions.append(pred)
        if Xb is not None:
            inputs.append(Xb)
        if not np.all(np.isfinite(err)):
            raise ValueError(f"the {'free run' if horizon is None else f'{horizon}-step prediction'} of calibration "
                             f"block {i} (samples {a}-{b}) diverged: NaN errors; expected a model that predicts "
                             "the calibration record.")
        scores.append(np.abs(err))
    scores = np.vstack(scores)
    q = conformal_quantile(scores, alpha)
    ranges = calibration_ranges(np.vstack(inputs) if inputs else None, np.vstack(predictions))
    return ConformalCalibration(alpha, horizon, q, int(scores.shape[0]), len(blocks), int(length), int(n_init), ranges)

"""The functional core of ``identify``: validation blocks, candidate scores, the parsimony rule, the Pareto front.

Every candidate is an ordinary estimator (built by
:func:`~sindybench.identify._space.make_estimator`), fitted on the samples
before a validation block and scored by the RMSE of its open-loop simulation of
that block divided by the output's standard deviation over the record (one
scale for every block, so a quiet block does not weigh more), started from
the block's first ``n_init`` samples as new data is started. A candidate that fails (an exception, a diverged
simulation) is a result with its reason, never the end of the search.
"""

import time
import warnings

import numpy as np

from ..metrics import rmse
from ._criterion import k_step_error

__all__ = ["describe_blocks", "evaluate", "pareto_front", "parsimonious_index", "path_thresholds", "record_folds",
           "segments", "stls_threshold", "validation_blocks"]


def validation_blocks(n_samples, n_blocks, block_size, min_train, min_block=10):
    """Forward-chaining folds: ``n_blocks`` consecutive blocks at the end of the record, each trained on all before it.

    Parameters
    ----------
    n_samples : int
    n_blocks : int
    block_size : float
        Each block's length as a fraction of the record.
    min_train : int
        Fewest training samples the first fold may have.
    min_block : int, default=10
        Fewest samples of a block.

    Returns
    -------
    list of (int, int)
        ``(start, stop)`` of each validation block, the last block last; a
        fold trains on ``[0, start)``.

    Examples
    --------
    >>> validation_blocks(1000, 3, 0.15, 100)
    [(550, 700), (700, 850), (850, 1000)]
    >>> validation_blocks(100, 3, 0.15, 80)
    Traceback (most recent call last):
    ...
    ValueError: 100 samples are too few for 3 validation blocks of 15 samples after at least 80 training samples; expected at least 125 samples (or fewer blocks).
    """
    size = max(int(round(block_size * n_samples)), min_block)
    first = n_samples - n_blocks * size
    if first < min_train:
        raise ValueError(
            f"{n_samples} samples are too few for {n_blocks} validation blocks of {size} samples after at least "
            f"{min_train} training samples; expected at least {min_train + n_blocks * size} samples "
            "(or fewer blocks).")
    return [(first + k * size, first + (k + 1) * size) for k in range(n_blocks)]


def record_folds(lengths, n_blocks, block_size, min_train, *, min_block=10, validation="blocks"):
    """The folds of one record or several: ``(train, validation)`` lists of ``(record, start, stop)``.

    Parameters
    ----------
    lengths : list of int
        Samples of each record.
    n_blocks, block_size, min_train, min_block
        As in :func:`validation_blocks`.
    validation : {"blocks", "records"}, default="blocks"
        ``"blocks"``: fold ``k`` validates the ``k``-th of the ``n_blocks``
        forward-chaining blocks at the end of every record, trained on every
        record before its block. ``"records"``: the last ``min(n_blocks,
        n_records)`` records are left out in turn, each validated whole and
        trained on all the other records (leave one record out).

    Returns
    -------
    list of (list, list)

    Examples
    --------
    >>> record_folds([1000], 2, 0.1, 100)
    [([(0, 0, 800)], [(0, 800, 900)]), ([(0, 0, 900)], [(0, 900, 1000)])]
    >>> record_folds([300, 200], 3, 0.1, 50, validation="records")
    [([(1, 0, 200)], [(0, 0, 300)]), ([(0, 0, 300)], [(1, 0, 200)])]
    """
    if validation == "records":
        if len(lengths) < 2:
            raise ValueError(f"validation='records' needs several records; got {len(lengths)}. Expected a list of "
                             "records, or validation='blocks'.")
        for r, n in enumerate(lengths):
            if n < min_block:
                raise ValueError(f"record {r} has {n} samples, too few to validate a candidate on it whole; "
                                 f"expected at least {min_block} (n_init + 2).")
        left_out = range(len(lengths) - min(n_blocks, len(lengths)), len(lengths))
        return [([(i, 0, n) for i, n in enumerate(lengths) if i != r], [(r, 0, lengths[r])]) for r in left_out]
    blocks = []
    for r, n in enumerate(lengths):
        try:
            blocks.append(validation_blocks(n, n_blocks, block_size, min_train, min_block=min_block))
        except ValueError as exc:
            if len(lengths) == 1:
                raise
            raise ValueError(f"record {r}: {exc}") from None
    return [([(r, 0, b[k][0]) for r, b in enumerate(blocks)], [(r, *b[k]) for r, b in enumerate(blocks)])
            for k in range(n_blocks)]


def path_thresholds(estimator, X, y, max_levels):
    """The pruning path of a dense fit: levels between its terms' sorted RMS contributions.

    A term's contribution is its coefficient times the RMS of its column,
    in the units of its target. Each level lies halfway (on a log scale)
    between two consecutive contributions of the dense fit, so each level
    drops about one more term; at most ``max_levels`` levels, spread evenly
    along the path. A level is a threshold on RMS contributions, the same
    for any number of samples (see :func:`stls_threshold`).

    Returns
    -------
    list of float
        Increasing levels, starting with 0 (the dense fit).
    """
    states = getattr(estimator, "states_", None)
    if hasattr(estimator, "library_input"):  # a lag model: its delay coordinates, record by record
        Z = np.vstack([estimator.library_input(X_r, y_r) for X_r, y_r in (zip(X, y) if isinstance(X, list)
                                                                          else [(X, y)])])
    else:
        if isinstance(X, list):  # several records: their rows stacked, as the estimator stacks its states
            X, y = np.vstack(X), np.vstack(y)
        Z = np.hstack([y if states is None else states, X])
    theta = np.asarray(estimator.library_.transform(Z), dtype=float)
    rms = np.sqrt(np.mean(theta**2, axis=0))
    w = np.abs(np.asarray(estimator.coef_)) * rms[None, :]
    w = np.unique(w[np.isfinite(w) & (w > 0)])
    if w.size < 2:
        return [0.0]
    mids = np.sqrt(w[:-1] * w[1:])
    if mids.size > max_levels - 1:
        mids = mids[np.unique(np.round(np.linspace(0, mids.size - 1, max_levels - 1)).astype(int))]
    return [0.0] + [float(m) for m in mids]


def block_error(estimator, X, y, n_init, scale, horizon=None):
    """RMSE of the simulation of ``X`` from ``y[:n_init]`` over ``scale`` (per output, averaged); inf if it diverged.

    With a ``horizon``, the RMSE of the k-step predictions instead (:func:`~._criterion.k_step_error`).
    """
    if horizon is not None:
        return k_step_error(estimator, X, y, n_init, scale, horizon)
    y_pred = np.asarray(estimator.predict(X, y_init=y[:n_init]), dtype=float).reshape(y.shape)
    if not np.all(np.isfinite(y_pred)):
        return np.inf
    return float(np.mean(rmse(y, y_pred, multioutput="raw_values") / scale))


def stls_threshold(level, n_samples):
    """The STLS threshold on unit-norm columns (``normalize_columns=True``) of an RMS-contribution ``level``.

    A column of ``n`` samples with RMS ``r`` has norm ``r sqrt(n)``, so the
    threshold is ``level * sqrt(n)``.

    Examples
    --------
    >>> stls_threshold(0.5, 400)
    10.0
    """
    return float(level) * float(np.sqrt(n_samples))


def segments(X, y, parts):
    """The samples of ``parts`` (a list of ``(record, start, stop)``): arrays for one part, lists for several."""
    Xs = [X[r][lo:hi] for r, lo, hi in parts]
    ys = [y[r][lo:hi] for r, lo, hi in parts]
    return (Xs[0], ys[0]) if len(parts) == 1 else (Xs, ys)


def evaluate(make, X, y, folds, *, n_init, scale, train_window=None, horizon=None):
    """Fit ``make()`` on each fold's training samples and score its simulation of the fold's validation blocks.

    Parameters
    ----------
    make : callable
        ``make(n_samples) -> unfitted estimator`` for ``n_samples`` training samples.
    X, y : list of ndarray
        The records (one record is a list of one).
    folds : list of (list, list)
        ``(train, validation)`` of each fold, each a list of ``(record, start, stop)``
        (see :func:`record_folds`); one training part is fitted as arrays, several as records.
    n_init : int
        First samples of a block that start its simulation.
    scale : ndarray of shape (n_outputs,)
        The outputs' standard deviations over the estimation data.
    train_window : int, optional
        Fit on the last ``train_window`` samples of each training part only (screening).
    horizon : int, optional
        Score the ``horizon``-step predictions instead of the free run (:func:`block_error`).

    Returns
    -------
    dict
        ``errors`` (per fold, the RMSE over ``scale`` averaged over its
        blocks, inf where it failed), ``n_terms``, ``max_row_terms`` (of
        the fit of the last fold), ``fit_time`` (seconds), ``status``
        (``"ok"`` or the first failure's reason) and ``model`` (the fit of
        the last fold, or None).
    """
    from ._space import n_terms

    errors, status, model, terms = [], "ok", None, (None, None)
    start = time.perf_counter()
    for train, validation in folds:
        if train_window is not None:
            train = [(r, max(lo, hi - train_window), hi) for r, lo, hi in train]
        try:
            with warnings.catch_warnings(), np.errstate(all="ignore"):
                warnings.simplefilter("ignore")
                est = make(sum(hi - lo for _, lo, hi in train)).fit(*segments(X, y, train))
                terms = n_terms(est)
                if terms[2] == 0:
                    raise ValueError("a learned row has no terms left")
                err = float(np.mean([block_error(est, X[r][lo:hi], y[r][lo:hi], n_init, scale, horizon)
                                     for r, lo, hi in validation]))
        except Exception as exc:  # a failing candidate is recorded, never ends the search
            errors.append(np.inf)
            if status == "ok":
                status = f"failed: {type(exc).__name__}: {exc}"
            continue
        if not np.isfinite(err):
            err = np.inf
            if status == "ok":
                status = f"diverged on the validation block {describe_blocks(validation)}"
        errors.append(float(err))
        model = est
    return {"errors": errors, "n_terms": terms[0], "max_row_terms": terms[1],
            "fit_time": time.perf_counter() - start, "status": status, "model": model}


def describe_blocks(parts, named=None):
    """``(record, start, stop)`` parts as text: ``[550, 700)``, or with the record named ``record 1 [0, 900)``.

    ``named`` None names the records unless the parts are one part of record 0.

    Examples
    --------
    >>> describe_blocks([(0, 550, 700)]), describe_blocks([(0, 0, 90), (1, 10, 30)])
    ('[550, 700)', 'record 0 [0, 90), record 1 [10, 30)')
    >>> describe_blocks([(0, 550, 700)], named=True)
    'record 0 [550, 700)'
    """
    if named is None:
        named = len(parts) > 1 or parts[0][0] != 0
    if not named:
        return ", ".join(f"[{lo}, {hi})" for _, lo, hi in parts)
    return ", ".join(f"record {r} [{lo}, {hi})" for r, lo, hi in parts)


def parsimonious_index(mean_errors, std_errors, n_terms, n_blocks):
    """The sparsest candidate within one standard error of the best mean validation error.

    The standard error is the best candidate's spread across the blocks
    divided by ``sqrt(n_blocks)``. Among the candidates within it, the one
    with the fewest terms; ties go to the lower error.

    Examples
    --------
    >>> parsimonious_index([0.10, 0.11, 0.30], [0.03, 0.01, 0.0], [12, 4, 2], 3)
    1
    >>> parsimonious_index([np.inf, np.inf], [0.0, 0.0], [1, 2], 3)
    Traceback (most recent call last):
    ...
    ValueError: no candidate has a finite validation error on every block.
    """
    mean = np.asarray(mean_errors, dtype=float)
    ok = np.isfinite(mean)
    if not ok.any():
        raise ValueError("no candidate has a finite validation error on every block.")
    best = int(np.argmin(np.where(ok, mean, np.inf)))
    tol = mean[best] + float(std_errors[best]) / np.sqrt(max(n_blocks, 1))
    within = [i for i in np.flatnonzero(ok) if mean[i] <= tol]
    return int(min(within, key=lambda i: (n_terms[i], mean[i])))


def pareto_front(mean_errors, n_terms):
    """Indices of the candidates on the front of (number of terms, mean validation error), sparsest first.

    A candidate is on the front when no other one has as few terms or fewer
    and a lower error.

    Examples
    --------
    >>> pareto_front([0.5, 0.2, 0.3, 0.1, np.inf], [2, 5, 5, 9, 1])
    [0, 1, 3]
    """
    order = sorted((i for i, e in enumerate(mean_errors) if np.isfinite(e) and n_terms[i] is not None),
                   key=lambda i: (n_terms[i], mean_errors[i]))
    front, best = [], np.inf
    for i in order:
        if mean_errors[i] < best:
            front.append(i)
            best = mean_errors[i]
    return front

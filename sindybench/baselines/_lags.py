"""Lagged regressors and the free-run loop shared by the ARX-type baselines.

A model of orders ``(na, nb, nk)`` predicts the output at sample ``t`` from
``y[t-1], ..., y[t-na]`` and ``u[t-nk], ..., u[t-nk-nb+1]``. The first
``n_lags(na, nb, nk)`` samples have an incomplete history: fitting starts
after them and a simulation copies them from the measured output.
"""

import numpy as np

__all__ = ["free_run", "input_lags", "lagged_regressors", "n_lags", "output_lags"]


def n_lags(na, nb, nk):
    """Number of leading samples needed before the first prediction.

    Examples
    --------
    >>> n_lags(2, 3, 1)
    3
    >>> n_lags(4, 0, 1)
    4
    """
    return max(na, nk + nb - 1) if nb > 0 else na


def output_lags(y, na, start):
    """Columns ``[y[t-1], ..., y[t-na]]`` for ``t = start .. n_samples - 1``."""
    n = y.shape[0]
    if na == 0:
        return np.empty((n - start, 0))
    return np.hstack([y[start - i : n - i] for i in range(1, na + 1)])


def input_lags(u, nb, nk, start):
    """Columns ``[u[t-nk], ..., u[t-nk-nb+1]]`` for ``t = start .. n_samples - 1``."""
    n = u.shape[0]
    if nb == 0:
        return np.empty((n - start, 0))
    return np.hstack([u[start - nk - j : n - nk - j] for j in range(nb)])


def lagged_regressors(u, y, na, nb, nk):
    """Regressor matrix and one-step targets of an ARX-type model.

    Parameters
    ----------
    u : ndarray of shape (n_samples, n_inputs)
    y : ndarray of shape (n_samples, n_outputs)
    na, nb, nk : int
        Output order, input order and input delay.

    Returns
    -------
    phi : ndarray of shape (n_samples - n0, na * n_outputs + nb * n_inputs)
        Output lags first (most recent first), then input lags.
    target : ndarray of shape (n_samples - n0, n_outputs)
        ``y[n0:]`` with ``n0 = n_lags(na, nb, nk)``.

    Examples
    --------
    >>> u = np.arange(5.0).reshape(-1, 1)
    >>> y = 10 * u
    >>> phi, target = lagged_regressors(u, y, 1, 2, 1)
    >>> phi[0].tolist(), target[0].tolist()
    ([10.0, 1.0, 0.0], [20.0])
    """
    start = n_lags(na, nb, nk)
    phi = np.hstack([output_lags(y, na, start), input_lags(u, nb, nk, start)])
    return phi, y[start:]


def free_run(step, u, y_start, na, nb, nk):
    """Simulate ``y[t] = step(y[t-1], ..., y[t-na], t)`` in free run.

    Parameters
    ----------
    step : callable
        ``step(past, i) -> ndarray (n_outputs,)`` where ``past`` is the flat
        vector ``[y[t-1], ..., y[t-na]]`` and ``i = t - n0`` indexes the
        precomputed input part (the inputs are known in advance).
    u : ndarray of shape (n_samples, n_inputs)
    y_start : ndarray of shape (n0, n_outputs)
        The first ``n0 = n_lags(na, nb, nk)`` outputs, copied into the result.

    Returns
    -------
    ndarray of shape (n_samples, n_outputs)
    """
    n0 = y_start.shape[0]
    n, n_outputs = u.shape[0], y_start.shape[1]
    y = np.empty((n, n_outputs))
    y[:n0] = y_start
    for t in range(n0, n):
        past = y[t - na : t][::-1].ravel()
        y[t] = step(past, t - n0)
    return y

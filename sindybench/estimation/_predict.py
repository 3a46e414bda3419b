"""Prediction modes beside the free run: k-step-ahead prediction and a smoothed initial state."""

import numpy as np
from numba import njit

from .._validation import check_integer, check_signal
from .._records import check_one_record
from ..dynamics import SimulationError, step_workspace
from ..dynamics._kernels import run_state_into
from ..metrics import rmse
from ._kalman import ONE_RECORD_ADVICE, check_filter_args, filter_checked, rts_smoother

__all__ = ["k_step_rmse", "predict_k_step", "smooth_initial_state"]


@njit(cache=True)
def _k_step(xf, u, dt, k, sm, oidx, work, out):
    """``out[t] = x[t + k][oidx]`` simulated from ``xf[t]``; -1 or the first ``t`` whose run diverged.

    ``work``: the integrator's ``(z, theta, K)``, allocated by NumPy (``step_workspace`` run as Python:
    called from here it was one more compiled function, about 0.4 s of the first call).
    """
    z, theta, K = work
    n = xf.shape[1]
    x = np.empty(n)
    window = np.empty((k + 1, u.shape[1]))
    h = np.full(k, dt)
    xs = np.empty((k + 1, n))
    for t in range(out.shape[0]):
        for i in range(n):  # loops, not x[:] = xf[t]: numba's shape check compiles string formatting
            x[i] = xf[t, i]
        for i in range(k + 1):
            for j in range(u.shape[1]):
                window[i, j] = u[t + i, j]
        # the free run's compiled loop (shared with simulate and step): k samples from xf[t]
        if run_state_into(x, window, h, sm.n_sub, sm.offsets, sm.weights, sm.linear, sm.lo, sm.hi, sm.max_abs,
                          sm.model, sm.user, z, theta, K, xs) >= 0:
            return t
        for a in range(oidx.shape[0]):
            out[t, a] = x[oidx[a]]
    return -1


def predict_k_step(model, X, y, k, *, Q, R, x0=None, P0=None):
    """k-step-ahead prediction: filter up to each sample ``t``, then simulate ``k`` samples ahead.

    For every ``t``, the extended Kalman filter's state ``x[t|t]`` (all
    measurements up to and including ``t``) starts an open-loop simulation
    driven by the known inputs ``X[t:t+k+1]``; its output at ``t + k`` is the
    prediction of ``y[t + k]``. ``k = 1`` is the one-step-ahead predictor; a
    large ``k`` approaches the free-run simulation.

    Parameters
    ----------
    model : SINDy, HiddenStateSINDy or ModelStep
    X : array-like of shape (n_samples, n_inputs)
    y : array-like of shape (n_samples, n_outputs)
    k : int
        Horizon in samples, ``1 <= k < n_samples``.
    Q, R, x0, P0
        As in :func:`extended_kalman_filter`.

    Returns
    -------
    ndarray of shape (n_samples - k, n_outputs)
        The predictions of ``y[k:]``.

    Raises
    ------
    SimulationError
        When a k-step run diverges.

    See Also
    --------
    k_step_rmse

    Examples
    --------
    >>> import numpy as np
    >>> from sindybench.simulate import TermsRHS, simulate
    >>> from sindybench.estimation import ModelStep
    >>> rhs = TermsRHS.from_equations([{((1, 0, 1, 0),): 1.0}, {((0, 0, 1, 0),): -4.0}])
    >>> m = ModelStep.from_rhs(rhs, 0.05)
    >>> y = simulate(rhs, [1.0, 0.0], np.zeros((100, 0)), 0.05)[:, :1]
    >>> y_pred = predict_k_step(m, None, y, 5, Q=0.0, R=1e-8, x0=[1.0, 0.0], P0=1e-8)
    >>> y_pred.shape, bool(np.allclose(y_pred, y[5:], atol=1e-6))
    ((95, 1), True)
    """
    m, X, y, Q, R, x0, P0 = check_filter_args(model, X, y, Q, R, x0, P0)  # X delayed by the model's input_delay
    n_samples = y.shape[0]
    k = check_integer(k, "k", low=1, high=max(n_samples - 1, 1))
    if k >= n_samples:
        raise ValueError(f"k = {k} leaves no sample to predict in a record of {n_samples}; expected k < n_samples.")
    states = filter_checked(m, X, y, Q, R, x0, P0)[0]["xf"]
    out = np.empty((n_samples - k, len(m.output_index)))
    oidx = np.asarray(m.output_index, dtype=np.int64)
    sm = m.step_model()
    t = _k_step(states, X, m.dt, k, sm, oidx, step_workspace.py_func(sm, X.shape[1])[1:4], out)
    if t >= 0:
        raise SimulationError(f"the {k}-step prediction from sample {t} diverged.", step=int(t))
    return out


def k_step_rmse(model, X, y, k, *, Q, R, x0=None, P0=None, multioutput="uniform_average"):
    """RMSE of the k-step-ahead prediction over ``y[k:]`` (see :func:`predict_k_step`).

    Returns
    -------
    float or ndarray of shape (n_outputs,)
        As :func:`sindybench.metrics.rmse` with ``multioutput``.

    Examples
    --------
    >>> import numpy as np
    >>> from sindybench.simulate import TermsRHS, simulate
    >>> from sindybench.estimation import ModelStep
    >>> rhs = TermsRHS.from_equations([{((0, 0, 1, 0),): -1.0}])
    >>> m = ModelStep.from_rhs(rhs, 0.1, x0=np.ones(1))
    >>> y = simulate(rhs, [1.0], np.zeros((50, 0)), 0.1)[:, :1]
    >>> k_step_rmse(m, None, y, 3, Q=0.0, R=1e-6, x0=[1.0], P0=1e-6) < 1e-6
    True
    """
    y_pred = predict_k_step(model, X, y, k, Q=Q, R=R, x0=x0, P0=P0)
    return rmse(np.asarray(y, dtype=float).reshape(len(y), -1)[k:], y_pred, multioutput=multioutput)


def smooth_initial_state(model, X, y_init, *, Q, R, x0=None, P0=None):
    """Initial state of a record from its first measured samples, by the RTS smoother.

    Only the ``n_init = len(y_init)`` given samples (and the inputs over them)
    are used: the smoothed state at the first sample, all of them
    considered. Start a free run from it with the estimator's ``simulate(X,
    x0=...)``.

    Parameters
    ----------
    model : SINDy, HiddenStateSINDy or ModelStep
    X : array-like of shape (n_samples, n_inputs), n_samples >= n_init
        Inputs of the record (only the first ``n_init`` rows are read).
    y_init : array-like of shape (n_init, n_outputs)
    Q, R, x0, P0
        As in :func:`extended_kalman_filter`; ``x0``, ``P0`` describe what is
        known of the first state before the samples are seen.

    Returns
    -------
    ndarray of shape (n_states,)

    Examples
    --------
    >>> import numpy as np
    >>> from sindybench.simulate import TermsRHS, simulate
    >>> from sindybench.estimation import ModelStep
    >>> rhs = TermsRHS.from_equations([{((1, 0, 1, 0),): 1.0}, {((0, 0, 1, 0),): -4.0}])
    >>> m = ModelStep.from_rhs(rhs, 0.05)
    >>> y = simulate(rhs, [0.3, -1.0], np.zeros((40, 0)), 0.05)[:, :1]
    >>> np.round(smooth_initial_state(m, None, y[:20], Q=0.0, R=1e-8, P0=10.0), 4).tolist()
    [0.3, -1.0]
    """
    check_one_record("smooth_initial_state", X, y_init, advice=ONE_RECORD_ADVICE)
    y_init = check_signal(y_init, "y_init")
    n_init = y_init.shape[0]
    if X is not None:
        X = np.asarray(X, dtype=float)
        X = X.reshape(-1, 1) if X.ndim == 1 else X
        if X.ndim != 2:
            raise ValueError(f"X has {X.ndim} dimensions (shape {X.shape}); expected (n_samples, n_inputs).")
        if X.shape[0] < n_init:
            raise ValueError(f"X has {X.shape[0]} rows; expected at least n_init = {n_init} (one per sample of "
                             "y_init).")
        X = X[:n_init]
    return rts_smoother(model, X, y_init, Q=Q, R=R, x0=x0, P0=P0).states[0].copy()

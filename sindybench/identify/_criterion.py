"""How ``identify`` scores a candidate on a validation block: its free run, or its k-step prediction.

A free run of a plant that is open-loop unstable drifts whatever the model, so
it cannot rank candidates there; the k-step prediction restarts the model from
the measured output every ``horizon`` samples (each window's state from its
first ``n_init`` samples, as a test protocol starts a free run) and scores the
``horizon`` samples after that start. :func:`choose_criterion` decides from the
data advice, :func:`k_step_error` scores one block.
"""

import numpy as np

from ..metrics import rmse

__all__ = ["CRITERIA", "choose_criterion", "k_step_error"]

#: what a user may ask for: the data decides ("auto"), or one of the two scores
CRITERIA = ("auto", "free_run", "k_step")
_MIN_HORIZON = 5


def choose_criterion(criterion, advice, *, horizon=None, block_length):
    """``(name, horizon, reason)``: the score that ranks the candidates, its horizon in samples and why.

    ``"auto"`` takes the k-step prediction when the advice found an output
    with a pole that grows within half the record (an open-loop unstable
    plant), else the free run. The horizon (when not given) is a quarter of a
    period of the outputs' 95 % bandwidth, at least 5 samples and at most a
    quarter of a validation block.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> unstable = SimpleNamespace(unstable=[0], samples_per_period=np.array([40.0]))
    >>> choose_criterion("auto", unstable, block_length=300)[:2]
    ('k_step', 10)
    >>> choose_criterion("auto", SimpleNamespace(unstable=[]), block_length=300)[:2]
    ('free_run', None)
    """
    if criterion == "free_run" or (criterion == "auto" and (advice is None or not advice.unstable)):
        return "free_run", None, ("asked for" if criterion == "free_run" else
                                  "no output of the record is open-loop unstable (data advice)")
    if horizon is None:
        spp = getattr(advice, "samples_per_period", None) if advice is not None else None
        spp = float(np.min(spp)) if spp is not None and np.all(np.isfinite(spp)) else 4.0 * _MIN_HORIZON
        horizon = int(np.clip(round(spp / 4), _MIN_HORIZON, max(_MIN_HORIZON, block_length // 4)))
    reason = "asked for" if criterion == "k_step" else (
        f"the data advice finds an open-loop unstable output ({['y%d' % j for j in advice.unstable]}): a free run "
        "of such a plant drifts whatever the model, so it cannot rank the candidates")
    return "k_step", int(horizon), reason


def k_step_error(estimator, X, y, n_init, scale, horizon):
    """RMSE over ``scale`` of the ``horizon``-step predictions of a block (per output, averaged); inf if one diverged.

    The block is cut into windows of ``n_init + horizon`` samples, one every
    ``horizon`` samples; each window is simulated from its first ``n_init``
    samples and its last ``horizon`` samples are scored, pooled over windows.

    Examples
    --------
    >>> from sindybench import SINDy
    >>> t = np.arange(600) * 0.01
    >>> u = np.sin(t)[:, None]
    >>> y = np.exp(0.5 * t)[:, None]  # y' = 0.5 y: unstable
    >>> model = SINDy().fit(u, y, dt=0.01)
    >>> round(k_step_error(model, u, y, 5, np.ones(1), 20), 6)
    0.0
    """
    window = n_init + horizon
    if y.shape[0] < window:
        raise ValueError(f"a validation block of {y.shape[0]} samples is shorter than n_init + horizon = {window}; "
                         "expected a shorter horizon or longer blocks.")
    errors, truth = [], []
    for start in range(0, y.shape[0] - window + 1, horizon):
        part = slice(start, start + window)
        y_pred = np.asarray(estimator.predict(X[part], y_init=y[part][:n_init]), dtype=float).reshape(window, -1)
        if not np.all(np.isfinite(y_pred)):
            return np.inf
        errors.append(y_pred[n_init:])
        truth.append(y[part][n_init:])
    return float(np.mean(rmse(np.vstack(truth), np.vstack(errors), multioutput="raw_values") / scale))

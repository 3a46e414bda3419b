"""Process and measurement noise covariances from a training record, by the innovations' likelihood."""

import numpy as np
from scipy.optimize import minimize

from .._validation import check_integer
from ..simulate import SimulationError, simulate
from ._kalman import FilterDivergenceError, check_prior, check_record, filter_checked
from ._model_step import model_step, state_spread

__all__ = ["estimate_noise"]

_SAMPLES_PER_VARIANCE = 10
"""The fewest samples per estimated variance that :func:`estimate_noise` takes."""


def _difference_noise(y):
    """Noise variance of each column from third differences (white noise: ``var(diff3) = 20 sigma^2``)."""
    d3 = np.diff(y, n=3, axis=0)
    var = np.mean(d3**2, axis=0) / 20.0 if d3.shape[0] else np.zeros(y.shape[1])
    floor = 1e-6 * np.maximum(np.var(y, axis=0), 1e-300)
    return np.maximum(var, floor)


def _state_scale(m, X, y):
    try:
        x = simulate(m.rhs, m.x0, X, m.dt, n_substeps=m.n_substeps, method=m.method, input_hold=m.input_hold,
                     bounds=(m.lower, m.upper), max_abs=m.max_abs)
    except SimulationError:
        return m.state_scale
    return state_spread(x, m.state_scale)


def estimate_noise(model, X, y, *, max_samples=20000, max_iter=None):
    """Diagonal ``Q`` and ``R`` that maximise the likelihood of the filter's innovations on a training record.

    The parameters are the logarithms of the diagonal entries: ``Q_ii =
    exp(a_i) s_i^2`` with ``s_i`` the spread of state ``i`` in the model's
    simulation of the record, and ``R_jj = exp(b_j) r_j`` with ``r_j`` the
    noise variance of output ``j`` seen in its third differences (at least
    ``(1e-3 std(y_j))^2``). From ``a = log(1e-4)`` and ``b = 0``, within
    ``Q_ii <= s_i^2`` and ``R_jj`` within a factor 100 of ``r_j`` (the
    likelihood alone cannot tell noise on a measured state from noise on
    its measurement), Nelder-Mead maximises the Gaussian
    log-likelihood of the innovations of the extended Kalman filter over the
    first ``max_samples`` samples, started at the model's first training state
    (``x0_``). A filter that diverges for some trial values scores as the worst.

    Parameters
    ----------
    model : SINDy, HiddenStateSINDy or ModelStep
        The fitted model; ``X``, ``y`` should be its training record.
    X : array-like of shape (n_samples, n_inputs)
    y : array-like of shape (n_samples, n_outputs)
    max_samples : int, default=20000
    max_iter : int, optional
        Nelder-Mead iterations (default ``200 * n_parameters``).

    Returns
    -------
    Q : ndarray of shape (n_states, n_states)
    R : ndarray of shape (n_outputs, n_outputs)

    Examples
    --------
    >>> import numpy as np
    >>> from sindybench.simulate import TermsRHS, simulate
    >>> from sindybench.estimation import ModelStep
    >>> rhs = TermsRHS.from_equations([{((1, 0, 1, 0),): 1.0}, {((0, 0, 1, 0),): -4.0, ((1, 0, 1, 0),): -0.2}])
    >>> m = ModelStep.from_rhs(rhs, 0.05, x0=np.array([1.0, 0.0]))
    >>> y = simulate(rhs, [1.0, 0.0], np.zeros((400, 0)), 0.05)[:, :1]
    >>> y = y + 0.01 * np.random.default_rng(0).standard_normal(y.shape)
    >>> Q, R = estimate_noise(m, None, y)
    >>> bool(0.5e-4 < R[0, 0] < 2e-4)
    True
    """
    m = model_step(model)
    X, y = check_record(m, X, y)
    max_samples = check_integer(max_samples, "max_samples", low=10)
    X, y = X[:max_samples], y[:max_samples]
    n, n_out = m.n_states, y.shape[1]
    need = _SAMPLES_PER_VARIANCE * (n + n_out)
    if y.shape[0] < need:  # 3 samples gave R = 1.27e-14: no third difference, a likelihood of nothing
        raise ValueError(f"estimate_noise needs at least {need} samples ({_SAMPLES_PER_VARIANCE} per estimated "
                         f"variance: {n} of Q, {n_out} of R); got {y.shape[0]}.")
    scale2 = _state_scale(m, X, y) ** 2
    r0 = _difference_noise(y)

    def covariances(theta):
        return np.diag(np.exp(theta[:n]) * scale2), np.diag(np.exp(theta[n:]) * r0)

    x0, P0 = check_prior(m, None, None)
    sm = m.step_model()

    def cost(theta):  # Q, R diagonal and positive by construction: no checks per run
        Q, R = covariances(theta)
        try:
            return -filter_checked(m, X, y, Q, R, x0, P0, sm=sm)[1] / y.shape[0]
        except FilterDivergenceError:
            return 1e300

    start = np.concatenate([np.full(n, np.log(1e-4)), np.zeros(n_out)])
    simplex = np.vstack([start, start + np.log(10.0) * np.eye(start.size)])
    bounds = [(np.log(1e-12), 0.0)] * n + [(np.log(1e-2), np.log(1e2))] * n_out
    max_iter = 200 * start.size if max_iter is None else check_integer(max_iter, "max_iter")
    res = minimize(cost, start, method="Nelder-Mead", bounds=bounds,
                   options=dict(initial_simplex=simplex, maxiter=max_iter, xatol=1e-2, fatol=1e-6))
    if not np.isfinite(res.fun) or res.fun >= 1e300:
        raise FilterDivergenceError("estimate_noise: the filter diverged for every trial value; check the model "
                                    "on this record.", step=-1)
    return covariances(res.x)

"""Residual analysis of a fitted model: autocorrelation, cross-correlation with past inputs, tests.

What MATLAB's ``resid`` and Ljung's book (section 16.6) check: a model that has
captured the dynamics leaves residuals that are white (nothing left to predict
from their own past) and independent of past inputs (nothing left to explain
by the input). Which residuals to test:

``"free_run"``
    the measured output minus the model's open-loop simulation (from the first
    ``n_init`` samples): the residuals of an *output-error* model, such as one
    refined by simulation error; white when the structure is right and the
    noise is white measurement noise.
``"one_step"``
    the measured output minus the one-step-ahead prediction (the extended
    Kalman filter for the state-space models, the measured lags for ARX and
    NN-ARX): the residuals of an *equation-error* (prediction-error) model;
    white when the structure is right and the noise enters the equation. The
    one-step residuals of an output-error model are not white even with the
    right structure (the prediction from measured outputs carries the noise
    of two samples), so test a model on the residuals of its own criterion.

The statistics are those of :func:`sindybench._residual_tests.residual_test`
(FFT correlations; Ljung-Box, a low-frequency statistic and the
cross-correlation test corrected for a coloured input, each at three lag
windows, calibrated together and Holm-corrected so that the whole test has
level ``alpha``).
"""

from typing import NamedTuple

import numpy as np
from scipy import stats

from .._residual_tests import ResidualTest, correlation, residual_test
from .._validation import check_integer, check_option, check_signal
from .._records import check_one_record

__all__ = ["ResidualAnalysis", "k_step_prediction", "residual_analysis"]

NOISE_SAMPLES = 2000
"""Samples on which ``Q`` and ``R`` are estimated when a state-space model's one-step prediction needs them."""


class ResidualAnalysis(NamedTuple):
    """Correlations of a model's residuals and their tests.

    Attributes
    ----------
    kind : {"free_run", "one_step"}
    residuals : ndarray of shape (n_samples, n_outputs)
        Measured minus predicted, from the first scored sample on.
    lags : ndarray of int of shape (2 * max_lag + 1,)
        ``-max_lag .. max_lag``.
    autocorrelation : ndarray of shape (2 * max_lag + 1, n_outputs)
        Of each output's residuals (symmetric; 1 at lag 0).
    cross_correlation : ndarray of shape (2 * max_lag + 1, n_outputs, n_inputs)
        Of the residuals with the inputs; lag ``k > 0``: the residual ``k``
        samples after the input.
    bound : float
        Half-width of the ``1 - alpha`` band of a correlation estimate under
        the null hypothesis (``z_{1 - alpha/2} / sqrt(n)``).
    test : ResidualTest
        The whiteness and independence tests (``white``, ``independent``,
        p-values, ``message()``).
    """

    kind: str
    residuals: np.ndarray
    lags: np.ndarray
    autocorrelation: np.ndarray
    cross_correlation: np.ndarray
    bound: float
    test: ResidualTest

    @property
    def white(self):
        """The residuals pass the whiteness test."""
        return self.test.white

    @property
    def independent(self):
        """The residuals pass the test of independence from past inputs."""
        return self.test.independent

    def message(self):
        """One sentence: what failed, or that both tests passed."""
        return self.test.message()


def k_step_prediction(model, X, y, k, *, Q=None, R=None):
    """The k-step-ahead prediction of ``y[k:]`` by any fitted estimator of the package.

    ARX and NN-ARX step their lags (``model.predict_k_step``); a state-space
    model (SINDy, HiddenStateSINDy, what ``identify`` returns) runs the extended
    Kalman filter (:func:`sindybench.estimation.predict_k_step`) with ``Q`` and
    ``R``, by default those :func:`~sindybench.estimation.estimate_noise` finds
    on the first 2000 samples of ``(X, y)``.

    Returns
    -------
    ndarray of shape (n_samples - k, n_outputs)
    """
    if hasattr(model, "predict_k_step"):
        return np.asarray(model.predict_k_step(X, y, k), dtype=float).reshape(len(y) - k, -1)
    from ..estimation import estimate_noise, predict_k_step

    if Q is None or R is None:
        Q0, R0 = estimate_noise(model, X, y, max_samples=NOISE_SAMPLES, max_iter=120)
        Q, R = Q0 if Q is None else Q, R0 if R is None else R
    return predict_k_step(model, X, y, k, Q=Q, R=R)


def free_run_prediction(model, X, y, n_init):
    """The model's free run of ``X`` started from ``y[:n_init]`` (outputs, 2-D)."""
    y_pred = model.predict(X, y_init=y[:n_init])
    return np.asarray(y_pred, dtype=float).reshape(len(y), -1)


def check_record(X, y, what):
    """``X`` (2-D or None) and ``y`` (2-D, finite) of one record."""
    check_one_record(what, X, y, advice="call it once per record")
    y = check_signal(y, "y")
    if X is not None:
        X = check_signal(X, "X")
        if X.shape[0] != y.shape[0]:
            raise ValueError(f"X has {X.shape[0]} rows and y {y.shape[0]}; expected one row of X per sample of y.")
    return X, y


def residual_analysis(model, X, y, *, kind="free_run", n_init=None, max_lag=25, alpha=0.05, Q=None, R=None):
    """Autocorrelation of a fitted model's residuals on ``(X, y)``, cross-correlation with the inputs, tests.

    Parameters
    ----------
    model : fitted estimator
        SINDy, HiddenStateSINDy, ARX, NN-ARX (anything with ``predict(X,
        y_init=...)``; ``"one_step"`` also needs ``predict_k_step`` or a
        state-space model).
    X : array-like of shape (n_samples, n_inputs) or None
    y : array-like of shape (n_samples, n_outputs) or (n_samples,)
        A record not used to fit the model (a validation block) says more
        than the training record, whose residuals the fit made small.
    kind : {"free_run", "one_step"}, default="free_run"
        See the module's description.
    n_init : int, optional
        Free run: samples that start the simulation (``y_init``), left out of
        the residuals; default the lags of a lag model (``n_lags_``), else 10.
    max_lag : int, default=25
        The middle lag window of the tests (the others ``max_lag // 5`` and
        ``4 max_lag``) and the lags of the correlations returned.
    alpha : float, default=0.05
        Level of the whole test (whiteness and independence together) and
        of the correlation bounds.
    Q, R : array-like, optional
        Noise covariances of a state-space model's one-step prediction
        (default: :func:`~sindybench.estimation.estimate_noise` on the record).

    Returns
    -------
    ResidualAnalysis

    Raises
    ------
    ValueError
        When the prediction diverged (NaN residuals), or on a bad argument.

    Examples
    --------
    An ARX system with noise in its equation: the right orders leave white
    one-step residuals, too low an order does not.

    >>> from sindybench.baselines import ARX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(3000, 1))
    >>> y = np.zeros((3000, 1))
    >>> for t in range(2, 3000):
    ...     y[t] = 1.5 * y[t - 1] - 0.7 * y[t - 2] + u[t - 1] + 0.1 * rng.normal()
    >>> residual_analysis(ARX(na=2, nb=1).fit(u, y), u, y, kind="one_step").white
    True
    >>> residual_analysis(ARX(na=1, nb=1).fit(u, y), u, y, kind="one_step").message()
    'not white (smallest whiteness p-value 0) and correlated with past inputs (smallest p-value 0)
     at level 0.05 (lag windows 5, 25, 100, 2999 samples)'
    """
    check_option(kind, "kind", ["free_run", "one_step"])
    X, y = check_record(X, y, "residual_analysis")
    if kind == "free_run":
        n_init = max(getattr(model, "n_lags_", 10), 1) if n_init is None else check_integer(n_init, "n_init", low=1)
        if n_init >= y.shape[0]:
            raise ValueError(f"n_init = {n_init} leaves no residual in a record of {y.shape[0]} samples.")
        e = (y - free_run_prediction(model, X, y, n_init))[n_init:]
        first = n_init
    else:
        e = y[1:] - k_step_prediction(model, X, y, 1, Q=Q, R=R)
        first = 1
        if hasattr(model, "n_lags_"):  # the first samples are copied, not predicted
            e, first = e[max(model.n_lags_ - 1, 0):], max(model.n_lags_, 1)
    u = None if X is None or X.shape[1] == 0 else X[first:]
    test = residual_test(e, u, max_lag=max_lag, alpha=alpha)
    M = test.max_lag
    auto = correlation(e, max_lag=M)
    auto = np.stack([auto[:, i, i] for i in range(e.shape[1])], axis=1)
    cross = correlation(e, u, max_lag=M) if u is not None else np.zeros((2 * M + 1, e.shape[1], 0))
    bound = float(stats.norm.ppf(1 - alpha / 2) / np.sqrt(e.shape[0]))
    return ResidualAnalysis(kind, e, np.arange(-M, M + 1), auto, cross, bound, test)

"""ARX: linear autoregressive model with exogenous inputs, least squares."""

import numpy as np
from scipy.signal import lfilter, lfiltic

from .._validation import check_bool
from ..io import SaveLoadMixin, register_model
from ._base import LagModel
from ._lags import free_run, input_lags
from ._persist import arx_from_dict, arx_to_dict

__all__ = ["ARX", "least_squares"]


def least_squares(phi, target, *, fit_intercept=True):
    """Least squares ``target ~ phi @ coef + intercept``: ``(coef, intercept, residual)``.

    The minimum-norm solution of ``numpy.linalg.lstsq``; ``intercept`` is zero
    without ``fit_intercept``.

    Examples
    --------
    >>> phi = np.arange(4.0).reshape(-1, 1)
    >>> coef, intercept, residual = least_squares(phi, 2 * phi + 1)
    >>> np.round(coef, 6).tolist(), np.round(intercept, 6).tolist(), bool(np.allclose(residual, 0))
    ([[2.0]], [1.0], True)
    """
    design = np.hstack([phi, np.ones((phi.shape[0], 1))]) if fit_intercept else phi
    theta = np.linalg.lstsq(design, target, rcond=None)[0]
    residual = target - design @ theta
    if fit_intercept:
        return theta[:-1], theta[-1], residual
    return theta, np.zeros(target.shape[1]), residual


class ARX(SaveLoadMixin, LagModel):
    """Linear ARX model fitted by least squares, evaluated in free run.

    ``y[t] = a_1 y[t-1] + ... + a_na y[t-na] + b_0 u[t-nk] + ... + b_{nb-1} u[t-nk-nb+1] + c``,
    with matrices ``a_i`` (outputs x outputs) and ``b_j`` (outputs x inputs)
    for several outputs. The coefficients minimise the one-step-ahead error;
    :meth:`simulate` runs the model on its own past outputs (``scipy.signal.lfilter``
    for one output).

    Parameters
    ----------
    na : int, default=2
        Number of past outputs.
    nb : int, default=2
        Number of input samples.
    nk : int, default=1
        Input delay in samples (0: the current input acts at once).
    fit_intercept : bool, default=True
        Fit the constant ``c`` (needed for signals with an offset).

    Attributes
    ----------
    coef_ : ndarray of shape (na * n_outputs + nb * n_inputs, n_outputs)
        Output-lag rows first (``y[t-1]`` first), then input-lag rows.
    intercept_ : ndarray of shape (n_outputs,)
    n_lags_ : int
        Samples taken from ``y_init`` to start a simulation.
    n_features_in_ : int
        Number of inputs.
    n_outputs_ : int
    y_mean_ : ndarray of shape (n_outputs,)
        Mean training output (the start of a simulation without ``y_init``).

    See Also
    --------
    NNARX : the same lags feeding a neural network.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((300, 1))
    >>> y = np.zeros((300, 1))
    >>> for t in range(1, 300):
    ...     y[t] = 0.8 * y[t - 1] + 0.5 * u[t - 1] + 1.0
    >>> model = ARX(na=1, nb=1).fit(u, y)
    >>> np.round(model.coef_.ravel(), 3).tolist(), np.round(model.intercept_, 3).tolist()
    ([0.8, 0.5], [1.0])
    >>> round(model.score(u, y), 6)
    1.0
    """

    def __init__(self, *, na=2, nb=2, nk=1, fit_intercept=True):
        self.na = na
        self.nb = nb
        self.nk = nk
        self.fit_intercept = fit_intercept

    def fit(self, X, y):
        """Fit by linear least squares on the one-step-ahead regressors.

        With fewer equations than unknowns, the minimum-norm solution is
        returned (as by ``numpy.linalg.lstsq``).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs)
            Inputs.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Measured outputs.

        Returns
        -------
        self
        """
        check_bool(self.fit_intercept, "fit_intercept")
        phi, target = self._fit_lags(X, y)
        self.coef_, self.intercept_, _ = least_squares(phi, target, fit_intercept=self.fit_intercept)
        return self

    def _one_step(self, phi):
        return phi @ self.coef_ + self.intercept_

    def _simulate(self, u, y_start):
        na, nb, nk = int(self.na), int(self.nb), int(self.nk)
        n_y = na * self.n_outputs_
        n0 = y_start.shape[0]
        # the input part of every prediction is known in advance
        drive = input_lags(u, nb, nk, n0) @ self.coef_[n_y:] + self.intercept_
        if self.n_outputs_ == 1:
            a = np.concatenate([[1.0], -self.coef_[:n_y, 0]])
            zi = lfiltic([1.0], a, y_start[::-1, 0])
            out = lfilter([1.0], a, drive[:, 0], zi=zi)[0] if na > 0 else drive[:, 0]
            return np.concatenate([y_start[:, 0], out]).reshape(-1, 1)
        coef_y = self.coef_[:n_y]
        return free_run(lambda past, i: past @ coef_y + drive[i], u, y_start, na, nb, nk)


register_model(ARX, to_dict=arx_to_dict, from_dict=arx_from_dict)

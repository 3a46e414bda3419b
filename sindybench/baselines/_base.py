"""What the ARX-type baselines share: orders, data checks, initial outputs, scoring."""

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from .._divergence import warn_divergence
from .._uncertainty_methods import ModelChecksMixin
from .._validation import check_integer, check_signal, validate_named
from ..metrics import make_simulation_scorer
from ._lags import input_lags, lagged_regressors, n_lags

__all__ = ["LagModel"]


class LagModel(ModelChecksMixin, RegressorMixin, BaseEstimator):
    """Base class of models ``y[t] = f(y[t-1..t-na], u[t-nk..t-nk-nb+1])``.

    Subclasses implement ``fit(X, y)``, which starts with ``_fit_lags(X, y)``
    (checks the orders and data, sets ``n_outputs_``, ``n_lags_``, ``y_mean_``
    and returns the lagged regressors ``(phi, target)`` of
    :func:`lagged_regressors`), and ``_simulate(u, y_start)``, the free run
    from the first ``n_lags_`` outputs ``y_start``.
    """

    def _check_orders(self):
        na = check_integer(self.na, "na", low=0)
        nb = check_integer(self.nb, "nb", low=0)
        nk = check_integer(self.nk, "nk", low=0)
        if na + nb == 0:
            raise ValueError("na and nb are both 0; expected at least one output or input lag.")
        return na, nb, nk

    def _fit_lags(self, X, y):
        """Validate, set the common fitted attributes, return ``(phi, target)``."""
        na, nb, nk = self._check_orders()
        if X is None:
            raise ValueError(
                f"X is None; {type(self).__name__} expects the inputs, an array of shape (n_samples, n_inputs)."
            )
        u, y = validate_named(self, X, y, multi_output=True, y_numeric=True)
        y = np.asarray(y, dtype=float)
        self.y_ndim_ = y.ndim
        y = y.reshape(-1, 1) if y.ndim == 1 else y
        u = np.asarray(u, dtype=float)
        self.n_outputs_ = y.shape[1]
        self.n_lags_ = n_lags(na, nb, nk)
        self.y_mean_ = y.mean(axis=0)
        if y.shape[0] <= self.n_lags_:
            raise ValueError(
                f"got {y.shape[0]} samples; {type(self).__name__}(na={na}, nb={nb}, nk={nk}) needs at least "
                f"{self.n_lags_ + 1} (the {self.n_lags_} first samples only start the lags)."
            )
        return lagged_regressors(u, y, na, nb, nk)

    def _initial_outputs(self, y_init, n_samples):
        n0 = min(self.n_lags_, n_samples)
        if y_init is None:
            return np.tile(self.y_mean_, (n0, 1))
        y_init = check_signal(y_init, "y_init")
        if y_init.shape[1] != self.n_outputs_:
            raise ValueError(f"y_init has {y_init.shape[1]} outputs; expected {self.n_outputs_} (as in fit).")
        if y_init.shape[0] < n0:
            raise ValueError(
                f"y_init has {y_init.shape[0]} samples; expected at least {n0} "
                f"(the lags na={self.na}, nb={self.nb}, nk={self.nk})."
            )
        return y_init[:n0]

    def simulate(self, X, y_init=None):
        """Free-run simulation driven by the inputs ``X``.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs)
            Inputs.
        y_init : array-like of shape (>= n_lags_, n_outputs), optional
            Measured outputs whose first ``n_lags_`` samples start the
            simulation (they are copied into the result). ``None`` starts
            from the mean training output.

        Returns
        -------
        ndarray of shape (n_samples,) or (n_samples, n_outputs)
            One column per output; 1-D when ``y`` was 1-D in ``fit``. An
            unstable model gives inf or NaN, never an exception.
        """
        check_is_fitted(self)
        u = np.asarray(validate_named(self, X, reset=False), dtype=float)
        y_start = self._initial_outputs(y_init, u.shape[0])
        with np.errstate(over="ignore", invalid="ignore"):
            y = self._simulate(u, y_start) if u.shape[0] > y_start.shape[0] else y_start.copy()
        return y.ravel() if self.y_ndim_ == 1 else y

    def predict(self, X, *, y_init=None):
        """Simulated output (the free run of :meth:`simulate`); warns when it diverged."""
        return warn_divergence(self.simulate(X, y_init), type(self).__name__)

    def predict_k_step(self, X, y, k):
        """k-step-ahead prediction: the measured outputs up to ``t``, then ``k`` steps of the model's own.

        The same protocol as :func:`sindybench.estimation.predict_k_step` for
        the state-space models (``k = 1`` is the one-step predictor the model
        was fitted with; a large ``k`` approaches the free run). All origins
        are stepped together, ``k`` vectorized steps in all.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs)
        y : array-like of shape (n_samples, n_outputs) or (n_samples,)
            The measured outputs.
        k : int
            Horizon in samples, ``1 <= k < n_samples``.

        Returns
        -------
        ndarray of shape (n_samples - k, n_outputs)
            The predictions of ``y[k:]``; a sample before ``n_lags_`` is its
            measured value (as in the free run), a sample before ``n_lags_ + k
            - 1`` is predicted from the first ``n_lags_`` samples, with fewer
            than ``k`` steps.

        Examples
        --------
        >>> from sindybench.baselines import ARX
        >>> u = np.random.default_rng(0).normal(size=(200, 1))
        >>> y = np.zeros((200, 1))
        >>> for t in range(1, 200):
        ...     y[t] = 0.9 * y[t - 1] + u[t - 1]
        >>> model = ARX(na=1, nb=1, fit_intercept=False).fit(u, y)
        >>> bool(np.allclose(model.predict_k_step(u, y, 5), y[5:]))
        True
        """
        check_is_fitted(self)
        u = np.asarray(validate_named(self, X, reset=False), dtype=float)
        y = check_signal(y, "y")
        n = y.shape[0]
        if y.shape[1] != self.n_outputs_ or u.shape[0] != n:
            raise ValueError(f"y has shape {y.shape}; expected ({u.shape[0]}, {self.n_outputs_}) (one row per "
                             "row of X, one column per output).")
        k = check_integer(k, "k", low=1, high=max(n - 1, 1))
        if k >= n:
            raise ValueError(f"k = {k} leaves no sample to predict in a record of {n}; expected k < n_samples.")
        na, nb, nk, n0 = int(self.na), int(self.nb), int(self.nk), self.n_lags_
        target = np.arange(k, n)
        times = target[:, None] - (na + k - 1) + np.arange(na + k)[None, :]  # the window of each target
        window = y[np.clip(times, 0, None)]  # (n - k, na + k, n_outputs): measured, predictions written over
        drive = np.zeros((n, nb * u.shape[1]))
        if n > n0:
            drive[n0:] = input_lags(u, nb, nk, n0)
        with np.errstate(over="ignore", invalid="ignore"):
            for s in range(k):
                tau = times[:, na + s]
                rows = tau >= n0  # samples before n0 stay measured, as in the free run
                if not rows.any():
                    continue
                past = window[rows, s:na + s][:, ::-1].reshape(int(rows.sum()), -1)
                window[rows, na + s] = self._one_step(np.hstack([past, drive[tau[rows]]]))
        return window[:, -1]

    def _one_step(self, phi):
        """The model's prediction from regressor rows ``phi`` (output lags first, as :func:`lagged_regressors`)."""
        raise NotImplementedError

    def score(self, X, y, sample_weight=None):
        """R^2 of the simulation started from the first samples of ``y``.

        A diverged simulation (non-finite output) scores ``-inf``.
        """
        if sample_weight is not None:
            raise ValueError("sample_weight is not supported; expected None.")
        return make_simulation_scorer("r2")(self, X, y)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        # scored by free-run simulation: i.i.d. test data of the common checks are no system
        tags.regressor_tags.poor_score = True
        return tags

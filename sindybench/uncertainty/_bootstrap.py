"""Block-bootstrap ensembles of a fitted model (E-SINDy's bagging, for models identified from one record).

What is resampled: the **residuals of the fitted model's simulation**, in
circular blocks. The fitted model simulates the training record from its
initial state, ``y_hat``; the residuals ``e = y - y_hat`` are cut into blocks
of ``block_length`` consecutive samples (all outputs together), blocks are
drawn with replacement with a uniform start on the circle (``e`` wraps
around, so that every sample is drawn equally often) and laid end to end;
each member is a :func:`~sklearn.base.clone` of the estimator fitted to
``(X, y_hat + e*)``. Why residuals and not record segments: a model
identified by simulation error, or with hidden states reconstructed along
the record, needs one contiguous record driven by the true input; glued
segments of the record would put jumps in the state that no model can
follow. Why blocks: the residuals of a simulation are correlated in time
(colored measurement noise, a slow model error), and blocks keep that
correlation, so the spread of the members reflects it where single-row
resampling would make it falsely narrow.

Every member is fitted by the whole pipeline of the estimator: the
strategy's design and inner search, STLS (so terms may enter or leave: the
inclusion probabilities) and the refinement when the estimator has one.
"""

import numbers

import numpy as np
from sklearn.base import BaseEstimator, clone
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted

from .._base import DynamicsEstimator
from .._limits import check_memory
from .._validation import check_alpha, check_integer, is_records
from ..io import SaveLoadMixin, register_model
from .._covariance import insignificant_lag
from ..simulate import SimulationError
from ._persist import ensemble_from_dict, ensemble_to_dict

__all__ = ["BootstrapEnsemble", "circular_block_indices"]


def circular_block_indices(n, block_length, rng, n_source=None):
    """Indices of a circular block bootstrap sample of ``n`` rows (of a source of ``n_source`` rows).

    Parameters
    ----------
    n : int
    block_length : int
    rng : numpy.random.Generator or RandomState
    n_source : int, optional
        Rows of the resampled series (default ``n``).

    Returns
    -------
    ndarray of int of shape (n,)

    Examples
    --------
    >>> idx = circular_block_indices(10, 4, np.random.default_rng(0))
    >>> idx.shape, bool(np.all(np.diff(idx[:4]) % 10 == 1))
    ((10,), True)
    """
    n_source = n if n_source is None else n_source
    n_blocks = -(-n // block_length)
    starts = rng.integers(0, n_source, n_blocks) if hasattr(rng, "integers") else rng.randint(0, n_source, n_blocks)
    length = min(block_length, n)  # a longer block is cut at n anyway: never allocate past it
    return ((starts[:, None] + np.arange(length)[None, :]) % n_source).ravel()[:n]


def _auto_block_length(e):
    """``max(n^(1/3), 2 L)``, L the first lag at which every output's residual autocorrelation is insignificant."""
    n = e.shape[0]
    return int(min(max(np.ceil(n ** (1.0 / 3.0)), 2 * insignificant_lag(e)), max(n // 4, 1)))


def fitted_output(model, X):
    """The fitted model's simulation of its training record from its first state ``x0_`` (outputs only)."""
    return model.simulate(X, x0=model.x0_, on_divergence="nan")[:, list(model.output_index_)]


def _fit_member(estimator, X, y, y_1d):
    try:
        return clone(estimator).fit(X, y[:, 0] if y_1d else y)
    except (SimulationError, ValueError, np.linalg.LinAlgError) as exc:
        return f"{type(exc).__name__}: {exc}"


class BootstrapEnsemble(SaveLoadMixin, BaseEstimator):
    """Ensemble of refits on circular-block bootstraps of a model's simulation residuals.

    Parameters
    ----------
    estimator : estimator
        A :class:`~sindybench.SINDy` or :class:`~sindybench.HiddenStateSINDy`
        (any strategy, with or without ``refine``), unfitted; it is cloned.
    n_members : int, default=50
    block_length : int or None, default=None
        Samples per block; None: ``max(n^(1/3), 2 L)`` with ``L`` the lag at
        which the residuals' autocorrelation becomes insignificant.
    n_jobs : int or None, default=None
        Members fitted in parallel with joblib (None or 1: serially).
    random_state : int, RandomState or None, default=None

    Attributes
    ----------
    estimator_ : estimator
        The estimator fitted to the record itself.
    members_ : list of estimators
        The fitted members (failed fits left out).
    n_failed_ : int
        Members whose fit failed (a diverging simulation, an empty support).
    block_length_ : int
    n_features_in_ : int
        Inputs, as the estimator's.
    residuals_ : ndarray of shape (n_samples, n_outputs)
        ``y - y_hat`` of ``estimator_``.
    coef_ : ndarray of shape (n_members, ...)
        The members' ``coef_``.
    inclusion_probabilities_ : ndarray
        Fraction of members in which each coefficient is nonzero (shape of
        one ``coef_``).
    params_ : dict
        The members' refined physical parameters (``params_`` of a
        hidden-state model), name -> array of shape (n_members,).

    Examples
    --------
    >>> from sindybench import SINDy, STLS
    >>> from sindybench.libraries import PolynomialLibrary
    >>> from sindybench.refine import OutputErrorRefinement
    >>> rng = np.random.default_rng(0)
    >>> u = np.repeat(rng.uniform(-1, 1, 20), 20)[:, None]
    >>> y = np.zeros((400, 1))
    >>> for k in range(399):
    ...     y[k + 1] = y[k] + 0.05 * (-y[k] + 2 * u[k])
    >>> model = SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.3), dt=0.05)
    >>> ens = BootstrapEnsemble(model, n_members=10, random_state=0).fit(u, y + 0.01 * rng.normal(size=y.shape))
    >>> ens.inclusion_probabilities_.round(1).tolist()  # [1, y0, u0]
    [[0.0, 1.0, 1.0]]
    """

    def __init__(self, estimator, *, n_members=50, block_length=None, n_jobs=None, random_state=None):
        self.estimator = estimator
        self.n_members = n_members
        self.block_length = block_length
        self.n_jobs = n_jobs
        self.random_state = random_state

    def _validate(self, n, n_outputs):
        n_members = check_integer(self.n_members, "n_members", low=2)
        if self.block_length is not None and check_integer(self.block_length, "block_length") > n:
            raise ValueError(f"block_length={self.block_length} exceeds the {n} samples of the record.")
        check_memory(f"BootstrapEnsemble(n_members={n_members}): the members' records", (n_members, n, n_outputs),
                     advice="Use fewer members (50-200 give stable bands) or a shorter record.")

    def fit(self, X, y):
        """Fit the estimator, then ``n_members`` clones to block-bootstrapped records.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs) or None
        y : array-like of shape (n_samples, n_outputs) or (n_samples,)

        Returns
        -------
        self
        """
        if not isinstance(self.estimator, DynamicsEstimator):
            raise ValueError(f"estimator must be a SINDy or HiddenStateSINDy (a model that simulates from an initial "
                             f"state, which the residual bootstrap needs); got {type(self.estimator).__name__}. "
                             "ARX and NNARX start from past outputs and are not supported.")
        n = next((len(a) for a in (X, y) if is_records(a)), None)
        if n is not None:
            raise ValueError(f"BootstrapEnsemble resamples the residuals of one record; got a list of {n} records. "
                             "Expected one array each (fit it on one record).")
        shape = np.shape(y)
        if len(shape) in (1, 2):  # sizes before any work; the estimator checks X and y themselves
            self._validate(shape[0], shape[1] if len(shape) == 2 else 1)
        base = clone(self.estimator).fit(X, y)
        y_1d = np.asarray(y).ndim == 1
        y2 = np.asarray(y, dtype=float).reshape(len(y), -1)
        self._validate(*y2.shape)
        rng = check_random_state(self.random_state)
        y_hat = fitted_output(base, X)
        if not np.all(np.isfinite(y_hat)):
            raise SimulationError("the fitted model's simulation of its training record diverges; a residual "
                                  "bootstrap expects a model that simulates the record.", step=-1)
        e = y2 - y_hat
        block = self.block_length if self.block_length is not None else _auto_block_length(e)
        records = (y_hat + e[circular_block_indices(e.shape[0], block, rng)] for _ in range(self.n_members))
        if self.n_jobs in (None, 1):
            fits = [_fit_member(self.estimator, X, r, y_1d) for r in records]
        else:
            import joblib  # a base dependency

            fits = joblib.Parallel(n_jobs=self.n_jobs)(joblib.delayed(_fit_member)(self.estimator, X, r, y_1d)
                                                       for r in records)
        members = [m for m in fits if not isinstance(m, str)]
        if len(members) < 2:
            raise ValueError(f"{len(fits) - len(members)} of {len(fits)} bootstrap fits failed (first: "
                             f"{next(m for m in fits if isinstance(m, str))}); expected a model that refits.")
        self.estimator_, self.members_, self.n_failed_ = base, members, len(fits) - len(members)
        self.block_length_, self.residuals_ = int(block), e
        self._summarize()
        return self

    def _summarize(self):
        self.n_features_in_ = self.estimator_.n_features_in_
        shapes = {np.shape(m.coef_) for m in self.members_}
        if len(shapes) > 1:
            raise ValueError(f"the members' coef_ differ in shape {sorted(shapes)}; expected one library.")
        self.coef_ = np.array([m.coef_ for m in self.members_])
        self.inclusion_probabilities_ = np.mean(self.coef_ != 0, axis=0)
        params = [getattr(m, "params_", {}) for m in self.members_]
        names = [k for k, v in params[0].items() if isinstance(v, numbers.Real) and not isinstance(v, bool)]
        self.params_ = {k: np.array([float(p[k]) for p in params]) for k in names}

    def median_coef(self, *, min_inclusion=0.5):
        """E-SINDy's bagged coefficients: the median over members, zero where inclusion < ``min_inclusion``."""
        check_is_fitted(self)
        if isinstance(min_inclusion, bool) or not isinstance(min_inclusion, numbers.Real) \
                or not 0.0 <= min_inclusion <= 1.0:
            raise ValueError(f"min_inclusion must be a number in [0, 1] (a share of the members); got "
                             f"{min_inclusion!r}.")
        return np.where(self.inclusion_probabilities_ >= min_inclusion, np.median(self.coef_, axis=0), 0.0)

    def median_model(self):
        """The member nearest the members' median (coefficients and physical parameters, each scaled by its spread).

        A fitted model of the estimator's own class, so it simulates, predicts
        and saves like any other, whatever its strategy.
        """
        check_is_fitted(self)
        flat = [self.coef_.reshape(len(self.members_), -1)] + [v[:, None] for v in self.params_.values()]
        A = np.hstack(flat)
        spread = A.std(axis=0)
        d = np.sum(((A - np.median(A, axis=0)) / np.where(spread > 0, spread, 1.0)) ** 2, axis=1)
        return self.members_[int(np.argmin(d))]

    def coefficient_intervals(self, alpha=0.05):
        """Percentile intervals ``(lower, upper)`` of the members' coefficients (shape of one ``coef_``)."""
        check_is_fitted(self)
        alpha = check_alpha(alpha, "intervals")
        return (np.quantile(self.coef_, alpha / 2, axis=0), np.quantile(self.coef_, 1 - alpha / 2, axis=0))

    def parameter_intervals(self, alpha=0.05):
        """Percentile intervals of the members' physical parameters: ``{name: (lower, upper)}``."""
        check_is_fitted(self)
        alpha = check_alpha(alpha, "intervals")
        return {k: (float(np.quantile(v, alpha / 2)), float(np.quantile(v, 1 - alpha / 2)))
                for k, v in self.params_.items()}


register_model(BootstrapEnsemble, to_dict=ensemble_to_dict, from_dict=ensemble_from_dict)

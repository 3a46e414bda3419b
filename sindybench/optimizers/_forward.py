"""Greedy forward selection by orthogonal least squares (the error-reduction ratio of NARX term selection).

The numerical core is :func:`forward_ols`; :class:`ForwardOLS` is a thin
scikit-learn regressor on top of it, usable as the ``optimizer`` of any
estimator of the library (see :mod:`sindybench.optimizers`).

Each step adds, for one target, the column whose part orthogonal to the
columns already chosen explains the most of the target's remaining sum of
squares (its *error-reduction ratio*); the other columns are then
orthogonalized against it (modified Gram-Schmidt). The ratio of a column does
not depend on its scale, so no normalization is needed. The selection stops
after ``n_terms`` columns, or earlier when the chosen columns explain all but
``tol`` of the target's sum of squares; the coefficients are the least
squares of the target on the chosen columns. Cost: O(n_samples n_features
n_terms) per target.

Where thresholding (:class:`~sindybench.STLS`) keeps every term above a
coefficient size, the greedy selection keeps the ``n_terms`` terms that
explain the most: on collinear candidate terms (the lagged outputs of a
polynomial NARX) it gives far fewer terms for the same one-step fit.
"""

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin

from .._validation import check_bool, check_integer, check_signal, validate_named
from ..io import SaveLoadMixin, check_params, encode_array, register_model
from ._predict import LinearPredictMixin

__all__ = ["ForwardOLS", "forward_ols"]

#: a column whose orthogonal part is below this fraction of its norm is a combination of the chosen ones
_DEPENDENT = 1e-9


def _check_params(n_terms, tol):
    n_terms = check_integer(n_terms, "n_terms", low=1)
    if isinstance(tol, bool) or not isinstance(tol, (int, float, np.floating)) or not 0.0 <= tol < 1.0:
        raise ValueError(f"tol must be a number in [0, 1); got {tol!r}.")
    return n_terms, float(tol)


def _select(theta, y, n_terms, tol, center):
    """The indices chosen for one target, in the order of selection, and their error-reduction ratios."""
    W = theta - theta.mean(axis=0) if center else theta.copy()
    y = y - y.mean() if center else y
    norms = np.einsum("ij,ij->j", W, W)
    total = float(y @ y)
    chosen, ratios = [], []
    if total == 0.0:
        return chosen, ratios
    active = norms > 0.0
    explained = 0.0
    for _ in range(min(n_terms, theta.shape[1])):
        ww = np.einsum("ij,ij->j", W, W)
        ok = active & (ww > _DEPENDENT**2 * norms)
        if not np.any(ok):
            break
        wy = W.T @ y
        err = np.where(ok, wy**2 / np.where(ok, ww, 1.0), -1.0) / total
        best = int(np.argmax(err))
        chosen.append(best)
        ratios.append(float(err[best]))
        explained += err[best]
        q = W[:, best] / np.sqrt(ww[best])
        active[best] = False
        W -= np.outer(q, q @ W)
        if 1.0 - explained <= tol:
            break
    return chosen, ratios


def forward_ols(theta, target, *, n_terms, tol=0.0, center=False):
    """Coefficients of the ``n_terms`` columns chosen greedily by orthogonal least squares, for each target.

    Parameters
    ----------
    theta : ndarray of shape (n_samples, n_features)
    target : ndarray of shape (n_samples,) or (n_samples, n_targets)
    n_terms : int >= 1
        Largest number of columns per target.
    tol : float in [0, 1), default=0.0
        Stop earlier when the chosen columns leave at most this fraction of
        the target's sum of squares unexplained.
    center : bool, default=False
        Select on the centred columns and target (the ratios of canonical
        correlation); a constant column of ``theta`` is then kept as the
        intercept, beside the ``n_terms`` chosen columns.

    Returns
    -------
    coef : ndarray of shape (n_features,) or (n_features, n_targets)
        Zero outside the chosen columns.
    order : list of list of int
        For each target, the chosen columns in the order of selection.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> theta = rng.normal(size=(200, 5))
    >>> coef, order = forward_ols(theta, theta @ [0.0, 3.0, 0.0, -1.0, 0.0], n_terms=2)
    >>> coef.round(6).tolist(), order
    ([0.0, 3.0, 0.0, -1.0, 0.0], [[1, 3]])
    """
    n_terms, tol = _check_params(n_terms, tol)
    theta = check_signal(np.asarray(theta, dtype=float), "theta")
    target = check_signal(np.asarray(target, dtype=float), "target", ensure_2d=False)
    if theta.ndim != 2 or target.shape[0] != theta.shape[0]:
        raise ValueError(f"theta must be 2-D with as many rows as target; got shapes {theta.shape} and "
                         f"{target.shape}.")
    target_1d = target.ndim == 1
    target2 = target.reshape(-1, 1) if target_1d else target
    coef = np.zeros((theta.shape[1], target2.shape[1]))
    order = []
    constant = []
    if center:
        spread = np.ptp(theta, axis=0) if theta.shape[0] else np.zeros(theta.shape[1])
        constant = [int(i) for i in np.flatnonzero((spread == 0) & (theta[0] != 0))][:1] if theta.shape[0] else []
    for j in range(target2.shape[1]):
        chosen, _ = _select(theta, target2[:, j], n_terms, tol, center)
        cols = sorted(set(chosen) | set(constant))
        if cols:
            coef[cols, j] = np.linalg.lstsq(theta[:, cols], target2[:, j], rcond=None)[0]
        order.append(chosen)
    return (coef[:, 0] if target_1d else coef), order


class ForwardOLS(LinearPredictMixin, SaveLoadMixin, RegressorMixin, BaseEstimator):
    """Greedy forward selection of terms by orthogonal least squares (see :func:`forward_ols`).

    Parameters
    ----------
    n_terms : int >= 1, default=10
        Largest number of terms per target.
    tol : float in [0, 1), default=0.0
        Stop earlier when the terms leave at most this fraction of the
        target's sum of squares unexplained.
    center : bool, default=False
        Select on centred columns and targets; a constant column is kept as
        the intercept beside the ``n_terms`` terms.

    Attributes
    ----------
    coef_ : ndarray of shape (n_targets, n_features) or (n_features,)
    intercept_ : float
        Always 0.0 (a constant belongs in the library).
    ind_ : ndarray of bool, shape of ``coef_``
    order_ : list of list of int
        For each target, the chosen terms in the order of selection.
    n_features_in_ : int

    See Also
    --------
    sindybench.STLS : selection by a threshold on the coefficients.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> X = rng.normal(size=(100, 4))
    >>> y = X @ [2.0, 0.0, -0.5, 0.0]
    >>> ForwardOLS(n_terms=2).fit(X, y).coef_.round(6)
    array([ 2. ,  0. , -0.5,  0. ])
    """

    def __init__(self, *, n_terms=10, tol=0.0, center=False):
        self.n_terms = n_terms
        self.tol = tol
        self.center = center

    def fit(self, X, y):
        """Choose the terms and fit their coefficients.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        y : array-like of shape (n_samples,) or (n_samples, n_targets)

        Returns
        -------
        self
        """
        n_terms, tol = _check_params(self.n_terms, self.tol)
        X, y = validate_named(self, X, y, multi_output=True, y_numeric=True, dtype=float)
        y = check_signal(y, "y", ensure_2d=False)
        check_bool(self.center, "center")
        coef, self.order_ = forward_ols(X, y, n_terms=n_terms, tol=tol, center=self.center)
        self.coef_ = coef.T.copy() if coef.ndim == 2 else coef
        self.ind_ = self.coef_ != 0
        self.intercept_ = 0.0
        return self


def _to_dict(model):
    return {"coef": encode_array(model.coef_), "order": [list(map(int, o)) for o in model.order_],
            "n_features_in": int(model.n_features_in_)}


def _from_dict(model, fitted):
    check_params(_check_params, model.n_terms, model.tol)
    n_features = fitted.int("n_features_in", low=1)
    coef = fitted.array("coef")
    if coef.ndim not in (1, 2) or coef.shape[-1] != n_features:
        raise ValueError(f"{fitted.where('coef')}: expected an array of shape (n_features_in,) or (n_targets, "
                         f"n_features_in) with n_features_in = {n_features}; got shape {coef.shape}.")
    model.coef_, model.n_features_in_ = coef, n_features
    order = fitted.get("order", "a list of lists of column indices")
    if not (isinstance(order, list) and all(isinstance(o, list) and all(isinstance(i, int) and 0 <= i < n_features
                                                                         for i in o) for o in order)):
        raise ValueError(f"{fitted.where('order')}: expected a list of lists of column indices below {n_features}.")
    model.order_ = order
    model.ind_ = model.coef_ != 0
    model.intercept_ = 0.0


register_model(ForwardOLS, to_dict=_to_dict, from_dict=_from_dict)

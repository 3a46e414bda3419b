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

import threading

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


class _Selection:
    """One target's greedy selection, resumable: its orthogonalized columns and the terms chosen so far.

    The first ``k`` steps of a selection do not depend on how many follow, so a selection of more terms on
    the same columns and target resumes one of fewer (a search over ``n_terms``) instead of starting again.
    """

    def __init__(self, theta, y, tol, center):
        self.W = theta - theta.mean(axis=0) if center else theta.copy()
        self.y = y - y.mean() if center else y.copy()
        self.norms = np.einsum("ij,ij->j", self.W, self.W)
        self.total = float(self.y @ self.y)
        self.tol = tol
        self.chosen, self.ratios = [], []
        self.active = self.norms > 0.0
        self.explained = 0.0
        self.done = self.total == 0.0

    def run(self, n_terms):
        """Take steps until ``n_terms`` are chosen (or the selection stops); the first ``n_terms`` chosen and ratios."""
        W = self.W
        while not self.done and len(self.chosen) < min(n_terms, W.shape[1]):
            ww = np.einsum("ij,ij->j", W, W)
            ok = self.active & (ww > _DEPENDENT**2 * self.norms)
            if not np.any(ok):
                self.done = True
                break
            wy = W.T @ self.y
            err = np.where(ok, wy**2 / np.where(ok, ww, 1.0), -1.0) / self.total
            best = int(np.argmax(err))
            self.chosen.append(best)
            self.ratios.append(float(err[best]))
            self.explained += err[best]
            q = W[:, best] / np.sqrt(ww[best])
            self.active[best] = False
            _subtract_outer(W, q, q @ W)
            if 1.0 - self.explained <= self.tol:
                self.done = True
        return self.chosen[:n_terms], self.ratios[:n_terms]


def _subtract_outer(W, q, v, rows=2048):
    """``W -= np.outer(q, v)`` in place, a block of rows at a time (the same numbers, without an array of W's size)."""
    work = np.empty((min(rows, W.shape[0]), W.shape[1]))
    for start in range(0, W.shape[0], rows):
        stop = min(start + rows, W.shape[0])
        block = work[: stop - start]
        np.multiply(q[start:stop, None], v[None, :], out=block)
        W[start:stop] -= block


# the selections of this thread's last forward_ols call, with a copy of its columns and targets (see _Selection)
_LAST = threading.local()


def forget_selections():
    """Drop this thread's kept selection (its copies of the last design and targets: tens of MB on long records)."""
    _LAST.value = None


def _selections(theta, target, tol, center):
    """The resumable selections of ``target``'s columns on ``theta``: the last call's when its data are the same."""
    last = getattr(_LAST, "value", None)
    if (last is not None and last["tol"] == tol and last["center"] == center
            and last["theta"].shape == theta.shape and last["target"].shape == target.shape
            and np.array_equal(last["theta"], theta) and np.array_equal(last["target"], target)):
        return last["selections"]
    _LAST.value = None  # the old copies go before the new ones are made
    selections = [None] * target.shape[1]
    _LAST.value = {"theta": theta.copy(), "target": target.copy(), "tol": tol, "center": center,
                   "selections": selections}
    return selections


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
    selections = _selections(theta, target2, tol, center)
    for j in range(target2.shape[1]):
        if selections[j] is None:
            selections[j] = _Selection(theta, target2[:, j], tol, center)
        chosen, _ = selections[j].run(n_terms)
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

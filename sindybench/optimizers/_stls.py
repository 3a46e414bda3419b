"""Sequentially thresholded least squares (STLS), with a cache for refits.

The numerical core is :func:`stls`; :class:`STLS` is a thin scikit-learn
regressor on top of it. Both follow the semantics of ``pysindy.STLSQ``:

* each iteration solves, for every target and on that target's current support
  ``S``, the ridge problem ``min ||theta[:, S] w - target||^2 + alpha ||w||^2``;
* coefficients with ``|w| < threshold`` leave the support (per target);
* the iterations stop when no target's support changes (or nothing was removed
  in the first iteration), or after ``max_iter`` iterations
  (:class:`~sklearn.exceptions.ConvergenceWarning`);
* ``unbias=True`` refits plain least squares on the final support
  (coefficients with ``|w| > 1e-14``);
* ``normalize_columns=True`` divides every column of ``theta`` by its L2 norm
  first, so ``threshold`` and ``alpha`` act on the normalized problem, and the
  coefficients are scaled back at the end.

Cost. All the O(n_samples n_features^2) work is one QR factorization of
``[theta | target]``; its triangular factor ``R`` holds the Gram matrix
(``R^T R``) and the projected target, and is kept in a :class:`GramCache`.
Each least-squares problem on a support ``S`` is then a small problem on the
columns ``S`` of ``R`` (O(n_features^3)), solved by an orthogonal method, so
the accuracy matches a least-squares solve on ``theta`` itself (no squaring of
the condition number as with the normal equations).

Scale. Data far from unit magnitude (columns of ``theta`` whose magnitudes
differ by more than ``2**40``, or any value beyond ``2**+-400``, where
squares overflow or ``lstsq``'s rank cut-off drops the small columns) is
rescaled column by column by powers of two before the factorization, and the
thresholds, the ridge penalty and the returned coefficients are expressed in
the original units. Powers of two are exact, and data within these limits is
not touched at all, so results on ordinary data are bit for bit those of the
unscaled algorithm.
"""

import logging
import threading
import warnings
from collections import OrderedDict
from functools import lru_cache

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.exceptions import ConvergenceWarning

from .._validation import check_bool, check_integer, check_positive, check_signal, validate_named
from ..io import SaveLoadMixin, check_params, encode_array, register_model
from ._predict import LinearPredictMixin

__all__ = ["GramCache", "STLS", "clear_stls_cache", "stls"]

logger = logging.getLogger(__name__)

_SUPPORT_TOL = 1e-14  # pysindy's cut for the support refitted by ``unbias``
_QR_CHUNK = 200_000  # rows factorized at a time (bounded memory for long records)
_SHARED_CACHE_SIZE = 8
_SCALE_RATIO = 2.0**40  # column magnitudes further apart are equilibrated (lstsq's rank cut-off is ~1e-15)
_SAFE_RANGE = (2.0**-400, 2.0**400)  # magnitudes whose squares and sums neither overflow nor underflow
_MAX_WEIGHT = 2.0**500  # largest ridge row weight (its square still fits in a float)


@lru_cache(maxsize=4)
def _weights(n):
    # Distinct positive weights (golden-ratio sequence): a weighted column sum
    # changes when any entry changes or two rows are swapped.
    w = 1.0 + (np.arange(n) * 0.6180339887498949) % 1.0
    w.setflags(write=False)
    return w


def _fingerprint(a):
    """Cheap O(size) summary of an array's content (shape, dtype, weighted column sums)."""
    a2 = a.reshape(a.shape[0], -1)
    with np.errstate(over="ignore", invalid="ignore"):  # near the float limit the sums saturate (still a key)
        sums = _weights(a.shape[0]) @ a2
    return (a.shape, a.dtype.str, sums.tobytes())


def _data_key(theta, target):
    return (_fingerprint(theta), _fingerprint(target))


def _power_of_two(m):
    """The largest power of two <= ``m`` (1 where ``m`` is 0): an exact scale."""
    _, e = np.frexp(m)
    return np.where(m > 0, np.ldexp(1.0, e - 1), 1.0)


def _scales(theta, target):
    """Power-of-two scales of the columns of ``theta`` and ``target``, or ``None`` when none is needed."""
    if theta.shape[0] == 0:
        return None
    col = np.max(np.abs(theta), axis=0)
    tcol = np.max(np.abs(target), axis=0)
    low, high = _SAFE_RANGE
    big, small = col[col > 0], np.r_[col[col > 0], tcol[tcol > 0]]
    if small.size == 0:
        return None
    spread = big.size > 0 and big.max() / _SCALE_RATIO > big.min()
    if not (spread or small.min() < low or small.max() > high):
        return None
    return _power_of_two(col), _power_of_two(tcol)


def _check_data(theta, target):
    theta = check_signal(theta, "theta")
    target_1d = np.ndim(target) == 1
    target = check_signal(target, "target", n_samples=theta.shape[0])
    return theta, target, target_1d


class GramCache:
    """Everything STLS needs from ``(theta, target)``, computed once.

    Holds the triangular factor ``R`` of the QR factorization of
    ``[theta | target]``: ``R^T R`` is the Gram matrix of ``[theta | target]``
    (``theta^T theta``, ``theta^T target``), and least squares on any subset of
    the columns of ``theta`` reduces to the same problem on the columns of
    ``R``. Building it is the only O(n_samples n_features^2) step; every
    :func:`stls` call given this cache costs O(n_features^3) for the solves
    plus one O(n_samples n_features) pass to check the data (finite values,
    fingerprint).

    A cache remembers a fingerprint of the data it was built from (shape,
    dtype and weighted column sums); :func:`stls` refuses a cache that does not
    match the data it is given, so a cache can never silently answer for other
    data (changes below the rounding of a column sum are the only blind spot).

    Parameters
    ----------
    theta : array-like of shape (n_samples, n_features)
        Library matrix.
    target : array-like of shape (n_samples,) or (n_samples, n_targets)
        Targets (e.g. state derivatives).

    Attributes
    ----------
    n_samples, n_features, n_targets : int
    col_norms : ndarray of shape (n_features,)
        L2 norms of the columns of ``theta``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> theta = rng.normal(size=(100, 3))
    >>> target = theta @ [1.0, 0.0, -2.0]
    >>> cache = GramCache(theta, target)
    >>> np.allclose(cache.gram, theta.T @ theta), np.allclose(cache.projected_target, theta.T @ target[:, None])
    (True, True)
    >>> cache.matches(theta, target), cache.matches(theta + 1.0, target)
    (True, False)
    """

    def __init__(self, theta, target):
        theta, target, _ = _check_data(theta, target)
        self._init_from_checked(theta, target)

    def _init_from_checked(self, theta, target, key=None):
        n, p = theta.shape
        self.n_samples, self.n_features, self.n_targets = n, p, target.shape[1]
        self._key = _data_key(theta, target) if key is None else key
        scales = _scales(theta, target)
        if scales is None:
            self._theta_scale, self._target_scale = np.ones(p), np.ones(target.shape[1])
        else:
            self._theta_scale, self._target_scale = scales
            theta, target = theta / self._theta_scale, target / self._target_scale
            logger.debug("STLS rescales the data (column scales %s)", self._theta_scale)
        r = None
        for start in range(0, n, _QR_CHUNK):
            block = np.hstack([theta[start : start + _QR_CHUNK], target[start : start + _QR_CHUNK]])
            if r is not None:
                block = np.vstack([r, block])
            r = np.linalg.qr(block, mode="r")
        m = min(r.shape[0], p)
        self._a = np.ascontiguousarray(r[:m, :p])
        self._c = np.ascontiguousarray(r[:m, p:])
        self._norms = np.sqrt(np.sum(self._a**2, axis=0))  # of the (rescaled) columns
        with np.errstate(over="ignore"):
            self.col_norms = self._norms * self._theta_scale

    @classmethod
    def _from_checked(cls, theta, target, key=None):
        """Build from arrays already checked by :func:`_check_data` (``key``: their :func:`_data_key`)."""
        self = cls.__new__(cls)
        self._init_from_checked(theta, target, key)
        return self

    @property
    def gram(self):
        """``theta^T theta``, shape (n_features, n_features)."""
        a = self._a * self._theta_scale
        return a.T @ a

    @property
    def projected_target(self):
        """``theta^T target``, shape (n_features, n_targets)."""
        return (self._a * self._theta_scale).T @ (self._c * self._target_scale)

    def matches(self, theta, target):
        """True when ``(theta, target)`` has the shape and fingerprint this cache was built from."""
        theta = np.asarray(theta, dtype=float)
        target = np.asarray(target, dtype=float)
        if target.ndim == 1:
            target = target.reshape(-1, 1)
        return _data_key(theta, target) == self._key

    def __repr__(self):
        return f"GramCache(n_samples={self.n_samples}, n_features={self.n_features}, n_targets={self.n_targets})"


_shared = OrderedDict()
_shared_lock = threading.Lock()


def _shared_cache(theta, target):
    """Return a :class:`GramCache` for checked arrays from a small content-keyed LRU."""
    key = _data_key(theta, target)
    with _shared_lock:
        cache = _shared.get(key)
        if cache is not None:
            _shared.move_to_end(key)
            logger.debug("STLS Gram cache hit (%d x %d)", *theta.shape)
            return cache
    cache = GramCache._from_checked(theta, target, key)
    with _shared_lock:
        _shared[key] = cache
        while len(_shared) > _SHARED_CACHE_SIZE:
            _shared.popitem(last=False)
    return cache


def clear_stls_cache():
    """Empty the shared cache that :class:`STLS` (with ``cache=True``) keeps.

    Examples
    --------
    >>> clear_stls_cache()
    """
    with _shared_lock:
        _shared.clear()


def _check_params(threshold, alpha, max_iter, normalize_columns, unbias):
    threshold = check_positive(threshold, "threshold", strict=False)
    alpha = check_positive(alpha, "alpha", strict=False)
    max_iter = check_integer(max_iter, "max_iter")
    check_bool(normalize_columns, "normalize_columns")
    check_bool(unbias, "unbias")
    return threshold, alpha, max_iter


def _solve_groups(a, c, ind, rows, alpha, units):
    """Least squares (ridge if ``alpha > 0``) for each target in ``rows`` on its support.

    Targets sharing a support are solved together. The penalty is
    ``alpha ||w / units||^2`` (``units``: one scale per column). Returns
    ``{row: (support, w)}``.
    """
    out = {}
    groups = {}
    for i in rows:
        groups.setdefault(ind[i].tobytes(), []).append(i)
    for members in groups.values():
        support = np.flatnonzero(ind[members[0]])
        lhs = a[:, support]
        rhs = c[:, members]
        if alpha > 0:
            with np.errstate(over="ignore"):
                weights = np.sqrt(alpha) / units[support]
            # a penalty beyond the float range pins its coefficient to zero as well as 2**500 does
            lhs = np.vstack([lhs, np.diag(np.minimum(weights, _MAX_WEIGHT))])
            rhs = np.vstack([rhs, np.zeros((support.size, len(members)))])
        try:
            w = np.linalg.lstsq(lhs, rhs, rcond=None)[0]
        except np.linalg.LinAlgError as exc:
            raise ValueError(
                f"STLS could not solve the least-squares problem on theta ({exc}); expected theta and target "
                "without extreme values."
            ) from exc
        for k, i in enumerate(members):
            out[i] = (support, w[:, k])
    return out


def _warn_unit_mismatch(coef, first, threshold, cache, normalize_columns):
    """Warn when the threshold emptied a target whose least-squares coefficients were all far below it.

    Coefficients a million times smaller than the threshold mean a threshold
    in other units than the library's columns (a library scaled by 1e300):
    the empty row is then no sparse model but a unit mismatch.
    """
    lost = np.flatnonzero(~coef.any(axis=1) & (first > 0) & (first < _UNIT_MISMATCH * threshold))
    if lost.size:
        i = int(lost[0])
        warnings.warn(
            f"STLS: threshold={threshold:g} removed every coefficient of target {i} (of {lost.size} such "
            f"target{'s' * (lost.size > 1)}): its least-squares coefficients were at most {first[i]:.3g}, far below "
            f"the threshold (the library's column norms span {np.min(cache.col_norms):.3g} to "
            f"{np.max(cache.col_norms):.3g}). Expected a threshold in the coefficients' units"
            f"{'' if normalize_columns else ', or normalize_columns=True'}.",
            UserWarning, stacklevel=4)


_UNIT_MISMATCH = 1e-6
"""Least-squares coefficients below this fraction of the threshold: a threshold in other units."""


def _stls_core(cache, threshold, alpha, max_iter, normalize_columns, unbias):
    """STLS on a :class:`GramCache`; returns ``coef`` (n_targets, n_features) and ``n_iter``."""
    # Working units: ``a`` holds the columns of theta / theta_scale (/ their norms with normalize_columns),
    # ``c`` the targets / target_scale; a working coefficient w is w * target_scale / units in the units
    # in which it is thresholded and penalized, and w * target_scale / (norms * theta_scale) in the end.
    # Without rescaling every scale is 1.0, and multiplying or dividing by 1.0 is exact.
    a, c = cache._a, cache._c
    n_targets, n_features = cache.n_targets, cache.n_features
    t_scale, y_scale = cache._theta_scale, cache._target_scale
    norms = np.ones(n_features)
    units = t_scale
    if normalize_columns:
        norms = np.where(cache._norms > 0, cache._norms, 1.0)
        a = a / norms
        units = np.ones(n_features)
    ind = np.ones((n_targets, n_features), dtype=bool)
    coef = np.zeros((n_targets, n_features))
    pattern = np.ones_like(ind)
    todo = np.ones(n_targets, dtype=bool)
    first = np.zeros(n_targets)  # the largest least-squares coefficient of each target before any threshold
    n_iter = 0
    for _ in range(max_iter):
        if not ind.any():
            logger.debug("threshold %g eliminated every coefficient", threshold)
            coef[:] = 0.0
            break
        new_ind = ind.copy()
        for i in np.flatnonzero(~ind.any(axis=1)):
            coef[i] = 0.0
        rows = np.flatnonzero(todo & ind.any(axis=1))
        for i, (support, w) in _solve_groups(a, c, ind, rows, alpha, units).items():
            full = np.zeros(n_features)
            full[support] = w
            with np.errstate(over="ignore"):  # an overflowing coefficient is reported at the end
                magnitude = np.abs(full * (y_scale[i] / units))
                big = magnitude >= threshold
            if n_iter == 0:
                first[i] = np.max(magnitude, initial=0.0)
            full[~big] = 0.0
            coef[i] = full
            new_ind[i] = big
        n_iter += 1
        new_pattern = coef != 0
        done = new_ind.all() or np.array_equal(new_pattern, pattern)
        todo = np.any(new_ind != ind, axis=1)
        ind, pattern = new_ind, new_pattern
        if done:
            break
    else:
        warnings.warn(
            f"STLS did not converge after max_iter={max_iter} iterations; "
            "increase max_iter or the threshold.",
            ConvergenceWarning,
            stacklevel=3,
        )
    if unbias:
        support = np.abs(coef) > _SUPPORT_TOL
        rows = np.flatnonzero(support.any(axis=1))
        coef = np.zeros_like(coef)
        for i, (cols, w) in _solve_groups(a, c, support, rows, 0.0, units).items():
            coef[i, cols] = w
    _warn_unit_mismatch(coef, first, threshold, cache, normalize_columns)
    with np.errstate(over="ignore"):
        coef = coef / norms * (y_scale[:, None] / t_scale)
    if not np.all(np.isfinite(coef)):
        raise ValueError(
            "the STLS coefficients overflow: the magnitudes of theta and target are too far apart "
            f"(theta's column norms span {np.min(cache.col_norms):.3g} to {np.max(cache.col_norms):.3g}, "
            f"the target's scale is {np.max(y_scale):.3g}); expected data whose coefficients fit in a float."
        )
    return coef, n_iter


def stls(theta, target, *, threshold, alpha=0.0, max_iter=20, normalize_columns=False, unbias=True, cache=None):
    """Sequentially thresholded least squares (the ``pysindy.STLSQ`` algorithm).

    Parameters
    ----------
    theta : array-like of shape (n_samples, n_features)
        Library matrix (candidate terms evaluated on the data).
    target : array-like of shape (n_samples,) or (n_samples, n_targets)
        Targets, e.g. the state derivatives.
    threshold : float >= 0
        Coefficients with ``|coef| < threshold`` are removed (per target).
    alpha : float >= 0, default=0.0
        Ridge penalty ``alpha ||w||^2`` in the thresholding iterations.
    max_iter : int >= 1, default=20
        Maximum number of thresholding iterations.
    normalize_columns : bool, default=False
        Divide the columns of ``theta`` by their L2 norms before the regression
        (``threshold`` and ``alpha`` then act on the normalized problem); the
        returned coefficients are in the original units. All-zero columns are
        left unscaled (pysindy would divide by zero).
    unbias : bool, default=True
        Refit unpenalized least squares on the final support.
    cache : GramCache, optional
        A cache built from this very ``(theta, target)``; skips the
        O(n_samples n_features^2) factorization. A cache built from other data
        raises ``ValueError``.

    Returns
    -------
    coef : ndarray of shape (n_features, n_targets), or (n_features,) for 1-D ``target``
    n_iter : int
        Thresholding iterations performed.

    See Also
    --------
    STLS : the scikit-learn estimator.
    GramCache : the precomputed factorization for repeated fits.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> theta = rng.normal(size=(200, 4))
    >>> target = theta @ np.array([[1.5, 0.0], [0.0, -2.0], [0.2, 0.0], [0.0, 0.0]])
    >>> target += 0.01 * rng.normal(size=target.shape)
    >>> coef, n_iter = stls(theta, target, threshold=0.1)
    >>> coef.round(2)
    array([[ 1.5,  0. ],
           [ 0. , -2. ],
           [ 0.2,  0. ],
           [ 0. ,  0. ]])
    >>> cache = GramCache(theta, target)  # reused for every threshold below
    >>> [int(np.count_nonzero(stls(theta, target, threshold=t, cache=cache)[0])) for t in (0.0, 0.1, 1.8)]
    [8, 3, 1]
    """
    threshold, alpha, max_iter = _check_params(threshold, alpha, max_iter, normalize_columns, unbias)
    theta, target, target_1d = _check_data(theta, target)
    if cache is None:
        cache = GramCache._from_checked(theta, target)
    elif not isinstance(cache, GramCache):
        raise ValueError(f"cache must be a GramCache or None; got {type(cache).__name__}.")
    elif not cache.matches(theta, target):
        raise ValueError(
            "cache was built from other data than the given theta and target "
            f"({cache!r}); build a new GramCache for this data."
        )
    coef, n_iter = _stls_core(cache, threshold, alpha, max_iter, normalize_columns, unbias)
    coef = coef.T
    return (coef[:, 0] if target_1d else coef), n_iter


class STLS(LinearPredictMixin, SaveLoadMixin, RegressorMixin, BaseEstimator):
    """Sequentially thresholded least squares regressor (``pysindy.STLSQ`` semantics).

    A scikit-learn regressor around :func:`stls`, usable as the ``optimizer``
    of :class:`sindybench.SINDy`. With ``cache=True`` the factorization of
    ``(X, y)`` is kept in a small shared cache keyed by the content of the data
    (shape, dtype and a fingerprint, not object identity), so refitting the
    same data with another ``threshold`` or ``alpha`` -- also from a clone, as
    in ``GridSearchCV`` -- skips the O(n_samples n_features^2) work. Changed
    data always gets a new factorization.

    Parameters
    ----------
    threshold : float >= 0, default=0.1
        Coefficients with ``|coef| < threshold`` are removed.
    alpha : float >= 0, default=0.0
        Ridge penalty used during the thresholding iterations.
    max_iter : int >= 1, default=20
    normalize_columns : bool, default=False
        Threshold on the column-normalized problem.
    unbias : bool, default=True
        Refit least squares on the final support.
    cache : bool, default=True
        Reuse factorizations of identical data across fits.

    Attributes
    ----------
    coef_ : ndarray of shape (n_targets, n_features) or (n_features,)
        Coefficients, in scikit-learn's layout (transpose of :func:`stls`'s);
        1-D when ``y`` was 1-D.
    intercept_ : float
        Always 0.0 (a constant belongs in the library).
    ind_ : ndarray of bool, shape of ``coef_``
        Support (non-zero coefficients).
    n_iter_ : int
        Thresholding iterations performed.
    n_features_in_ : int

    See Also
    --------
    stls : the function doing the work.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> X = rng.normal(size=(100, 3))
    >>> y = X @ [2.0, 0.0, -0.5]
    >>> model = STLS(threshold=0.1).fit(X, y)
    >>> model.coef_.round(6)
    array([ 2. ,  0. , -0.5])
    >>> model.set_params(threshold=1.0).fit(X, y).coef_.round(3)
    array([1.998, 0.   , 0.   ])
    """

    def __init__(self, *, threshold=0.1, alpha=0.0, max_iter=20, normalize_columns=False, unbias=True, cache=True):
        self.threshold = threshold
        self.alpha = alpha
        self.max_iter = max_iter
        self.normalize_columns = normalize_columns
        self.unbias = unbias
        self.cache = cache

    def fit(self, X, y):
        """Fit the sparse coefficients.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Library matrix ``theta``.
        y : array-like of shape (n_samples,) or (n_samples, n_targets)
            Targets.

        Returns
        -------
        self
        """
        threshold, alpha, max_iter = _check_params(
            self.threshold, self.alpha, self.max_iter, self.normalize_columns, self.unbias
        )
        check_bool(self.cache, "cache")
        X, y = validate_named(self, X, y, multi_output=True, y_numeric=True, dtype=float)
        y = check_signal(y, "y", ensure_2d=False)  # strings pass validate_data as they are
        target_1d = y.ndim == 1
        y2 = y.reshape(-1, 1) if target_1d else y
        gram = _shared_cache(X, y2) if self.cache else GramCache._from_checked(X, y2)
        coef, self.n_iter_ = _stls_core(gram, threshold, alpha, max_iter, self.normalize_columns, self.unbias)
        self.coef_ = coef[0] if target_1d else coef
        self.ind_ = self.coef_ != 0
        self.intercept_ = 0.0
        return self


def _stls_to_dict(model):
    return {"coef": encode_array(model.coef_), "n_iter": int(model.n_iter_),
            "n_features_in": int(model.n_features_in_)}


def _stls_from_dict(model, fitted):
    check_params(_check_params, model.threshold, model.alpha, model.max_iter, model.normalize_columns, model.unbias)
    n_features = fitted.int("n_features_in", low=1)
    coef = fitted.array("coef")
    if coef.ndim not in (1, 2) or coef.shape[-1] != n_features:
        raise ValueError(
            f"{fitted.where('coef')}: expected an array of shape (n_features_in,) or (n_targets, n_features_in) with "
            f"n_features_in = {n_features}; got shape {coef.shape}."
        )
    model.coef_, model.n_iter_, model.n_features_in_ = coef, fitted.int("n_iter"), n_features
    model.ind_ = model.coef_ != 0
    model.intercept_ = 0.0


register_model(STLS, to_dict=_stls_to_dict, from_dict=_stls_from_dict)

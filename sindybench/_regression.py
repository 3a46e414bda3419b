"""The regression step shared by ``SINDy`` and ``HiddenStateSINDy``: library features, then the sparse optimizer."""

import numpy as np

from ._preprocessing import feature_map, operating_point
from ._validation import check_n_samples, check_signal

__all__ = ["fit_sparse"]


def fit_sparse(library, optimizer, Z, target, *, rows=None, feature_filter=None, what="library output",
               normalize=False):
    """Fit ``library`` on ``Z`` and ``optimizer`` on ``(Theta(Z), target)``; return the coefficients.

    Parameters
    ----------
    library : transformer
        Fitted here, on the selected rows of ``Z``.
    optimizer : regressor
        Fitted here; exposes ``coef_`` of shape (n_targets, n_terms) (see
        :mod:`sindybench.optimizers`).
    Z : ndarray of shape (n_samples, n_variables)
        Library input ``[states, inputs]``.
    target : ndarray of shape (n_samples, n_targets)
        Time derivatives of the learned states.
    rows : ndarray of bool of shape (n_samples,), optional
        The rows of the regression (default: all).
    feature_filter : callable, optional
        ``f(Theta) -> Theta`` applied to the features of all rows before the
        rows are taken (see :class:`~sindybench.hidden.Design`).
    what : str
        Name of the features in error messages.
    normalize : bool, default=False
        Fit the optimizer on the features of the centred, scaled ``Z`` (mean
        and standard deviation of the regression rows) and on the targets
        divided by their root mean square, so that its threshold does not
        depend on the data's units; the coefficients are mapped back to the
        user's units exactly (:func:`~sindybench._preprocessing.feature_map`).

    Returns
    -------
    coef : ndarray of shape (n_terms, n_targets)
        Column ``k``: the coefficients of target ``k``.

    Raises
    ------
    ValueError
        When the optimizer's coefficients are not finite.

    Examples
    --------
    >>> from sindybench import STLS
    >>> from sindybench.libraries import PolynomialLibrary
    >>> Z = np.linspace(0.0, 1.0, 20)[:, None]
    >>> fit_sparse(PolynomialLibrary(degree=1), STLS(threshold=0.1), Z, 3.0 * Z).round(6).tolist()
    [[0.0], [3.0]]

    In other units the threshold keeps its meaning only with ``normalize``:

    >>> fit_sparse(PolynomialLibrary(degree=1), STLS(threshold=0.1), 1e3 * Z, 3.0 * Z).round(6).tolist()
    [[0.0], [0.0]]
    >>> fit_sparse(PolynomialLibrary(degree=1), STLS(threshold=0.1), 1e3 * Z, 3.0 * Z, normalize=True).round(6).tolist()
    [[0.0], [0.003]]
    """
    Zr = Z if rows is None else Z[rows]
    library.fit(Zr)
    if feature_filter is None:
        theta = library.transform(Zr)
    else:
        theta = check_signal(feature_filter(library.transform(Z)), "filtered features")
        theta = theta if rows is None else theta[rows]
    check_n_samples(Zr.shape[0], theta.shape[1])
    theta = check_signal(theta, what)
    target = target if rows is None else target[rows]
    if normalize:
        A = feature_map(getattr(library, "terms_", None), *operating_point(Zr), theta)
        target_scale = np.sqrt(np.mean(target ** 2, axis=0))
        target_scale = np.where(np.isfinite(target_scale) & (target_scale > 0), target_scale, 1.0)
        optimizer.fit(theta @ A.T, target / target_scale)
        xi = np.asarray(optimizer.coef_, dtype=float).reshape(target.shape[1], theta.shape[1]).T
        coef = (A.T @ xi) * target_scale
    else:
        optimizer.fit(theta, target)
        coef = np.asarray(optimizer.coef_, dtype=float).reshape(target.shape[1], theta.shape[1]).T
    if not np.all(np.isfinite(coef)):
        raise ValueError("the optimizer returned NaN or inf coefficients; check the data and its settings.")
    return coef

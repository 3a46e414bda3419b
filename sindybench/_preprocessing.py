"""Preprocessing applied inside the estimators' ``fit`` and undone in what the user sees.

* :func:`delay_inputs` shifts the inputs by a whole number of samples (the
  estimators' ``input_delay``): the model sees ``u(t - delay dt)``.
* :func:`operating_point` and :func:`feature_map` centre and scale the
  regression (the estimators' ``normalize``): the library's features are
  taken of ``(z - mean) / scale`` and the targets divided by their scale, so
  the sparse optimizer's threshold is a fraction of the target's spread per
  unit spread of a feature, whatever the data's units. The coefficients are
  then mapped back to the user's units *exactly*: a product of integer powers
  of ``(z - mean) / scale`` is a polynomial in ``z`` whose monomials are in
  the library whenever the library holds every lower-degree monomial (as
  :class:`~sindybench.libraries.PolynomialLibrary` with its bias does), so the
  fitted model is the same kind of model, simulated, refined, filtered,
  exported and saved in the user's units with no substitution left to print.
  A term that cannot be expanded that way (a sign, a square root, an
  indicator, a user operation, or a monomial whose lower-degree monomials are
  missing) is scaled but not centred (a column divided by its root mean
  square, or a monomial by its scales), which is exact too.
"""

from math import comb, prod

import numpy as np

from .dynamics import POW

__all__ = ["delay_inputs", "feature_map", "operating_point", "scaling_record"]


def delay_inputs(X, delay):
    """The inputs delayed by ``delay`` samples: row ``k`` holds ``X[k - delay]`` (``X[0]`` before the start).

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_inputs)
    delay : int
        A negative delay is a lead: row ``k`` holds ``X[k - delay]``, the last
        row held after the end (a lag model driven by ``u[k+1]``, see
        :class:`~sindybench.LagSINDy`).

    Returns
    -------
    ndarray of shape (n_samples, n_inputs)
        ``X`` itself when ``delay`` is 0 or there is no input column.

    Examples
    --------
    >>> delay_inputs(np.arange(5.0)[:, None], 2).ravel().tolist()
    [0.0, 0.0, 0.0, 1.0, 2.0]
    >>> delay_inputs(np.arange(5.0)[:, None], -1).ravel().tolist()
    [1.0, 2.0, 3.0, 4.0, 4.0]
    """
    if delay == 0 or X.shape[1] == 0 or X.shape[0] == 0:
        return X
    if delay < 0:
        d = min(-delay, X.shape[0])
        return np.concatenate([X[d:], np.repeat(X[-1:], d, axis=0)])
    d = min(delay, X.shape[0])
    return np.concatenate([np.repeat(X[:1], d, axis=0), X[: X.shape[0] - d]])


def _spread(values, center):
    """Root mean square of ``values - center`` per column; 1 where it is 0 or not finite."""
    spread = np.sqrt(np.mean((values - center) ** 2, axis=0)) if values.shape[0] else np.ones(values.shape[1])
    return np.where(np.isfinite(spread) & (spread > 0), spread, 1.0)


def operating_point(Z):
    """Mean and standard deviation of the columns of ``Z`` (a constant column gets scale 1).

    Examples
    --------
    >>> mean, scale = operating_point(np.array([[1.0, 5.0], [3.0, 5.0]]))
    >>> mean.tolist(), scale.tolist()
    ([2.0, 5.0], [1.0, 1.0])
    """
    Z = np.asarray(Z, dtype=float)
    mean = Z.mean(axis=0) if Z.shape[0] else np.zeros(Z.shape[1])
    return mean, _spread(Z, mean)


def scaling_record(Z):
    """An estimator's ``scaling_``: the operating point of its regression's ``Z`` as JSON-able lists.

    Examples
    --------
    >>> scaling_record(np.array([[1.0, 5.0], [3.0, 5.0]]))
    {'mean': [2.0, 5.0], 'scale': [1.0, 1.0]}
    """
    mean, scale = operating_point(Z)
    return {"mean": mean.tolist(), "scale": scale.tolist()}


def _monomial(term):
    """``{col: power}`` of a product of non-negative integer powers, else None."""
    powers = {}
    for col, op, a, _ in term:
        if op != POW or a < 0 or a != int(a):
            return None
        powers[col] = powers.get(col, 0) + int(a)
    return {c: k for c, k in powers.items() if k}


def _lower(powers):
    """Every monomial ``{col: m}`` with ``m <= powers`` (the terms of the expansion), as ``(key, factor index)``."""
    out = [{}]
    for col, k in powers.items():
        out = [{**m, col: j} if j else dict(m) for m in out for j in range(k + 1)]
    return out


def _key(powers):
    return tuple(sorted(powers.items()))


def feature_map(terms, mean, scale, theta):
    """The matrix ``A`` with ``Theta_scaled = Theta @ A.T``: each feature of the centred, scaled data.

    Parameters
    ----------
    terms : list of term tuples or None
        The library's symbolic terms (None for a library without them: every
        column is scaled by its root mean square).
    mean, scale : ndarray of shape (n_variables,)
        The operating point of ``Z`` (:func:`operating_point`).
    theta : ndarray of shape (n_samples, n_terms)
        The features in the user's units (for the root mean squares).

    Returns
    -------
    ndarray of shape (n_terms, n_terms)
        Row ``j``: feature ``j`` of ``(z - mean) / scale`` as a combination
        of the features of ``z``. Coefficients ``xi`` fitted on the scaled
        features are ``A.T @ xi`` in the user's units.

    Examples
    --------
    ``(z - 2)^2 / 4 = (z^2 - 4 z + 4) / 4`` over the terms ``1, z, z^2``:

    >>> terms = [(), ((0, POW, 1.0, 0.0),), ((0, POW, 2.0, 0.0),)]
    >>> feature_map(terms, np.array([2.0]), np.array([2.0]), np.ones((1, 3)))[2].tolist()
    [1.0, -1.0, 0.25]
    """
    n_terms = theta.shape[1]
    A = np.zeros((n_terms, n_terms))
    monomials = [None] * n_terms if terms is None else [_monomial(t) for t in terms]
    index = {_key(m): j for j, m in enumerate(monomials) if m is not None}
    rms = None
    for j, powers in enumerate(monomials):
        lower = None if powers is None else _lower(powers)
        if powers is not None and all(_key(m) in index for m in lower):  # centred and scaled, expanded
            for m in lower:
                A[j, index[_key(m)]] += prod(comb(k, m.get(c, 0)) * (-mean[c]) ** (k - m.get(c, 0)) / scale[c] ** k
                                             for c, k in powers.items())
        elif powers is not None:  # scaled only
            A[j, j] = 1.0 / prod(scale[c] ** k for c, k in powers.items())
        else:  # a column without a polynomial form: divided by its root mean square
            rms = _spread(theta, 0.0) if rms is None else rms
            A[j, j] = 1.0 / rms[j]
    return A

"""Common machinery of the feature libraries.

A library is a scikit-learn transformer applied to ``Z = [states, inputs]``.
Built-in libraries describe every output column as a symbolic term (see
:mod:`sindybench.libraries._terms`); they set ``terms_`` at ``fit`` and
evaluate exactly those terms in ``transform``.
"""

import numbers
from collections import defaultdict

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import _check_feature_names_in, check_is_fitted, validate_data

from ._terms import ABS_POW, POW, evaluate_terms, term_name

__all__ = ["BaseLibrary", "canonical_term", "check_variables"]


def check_variables(variables, n_features, *, name="variables"):
    """Return the selected column indices of ``Z`` as a list (``None`` -> all).

    Examples
    --------
    >>> check_variables(None, 3)
    [0, 1, 2]
    >>> check_variables([2, 0], 3)
    [2, 0]
    >>> check_variables([3], 3)
    Traceback (most recent call last):
    ...
    ValueError: variables contains 3; expected column indices in [0, 2] of Z = [states, inputs].
    """
    if variables is None:
        return list(range(n_features))
    if isinstance(variables, (str, bytes)) or not hasattr(variables, "__iter__"):
        raise ValueError(f"{name} must be None or a sequence of column indices; got {variables!r}.")
    out = []
    for v in variables:
        if isinstance(v, bool) or not isinstance(v, numbers.Integral):
            raise ValueError(f"{name} must hold integer column indices; got {v!r}.")
        if not 0 <= v < n_features:
            raise ValueError(
                f"{name} contains {v}; expected column indices in [0, {n_features - 1}] of Z = [states, inputs]."
            )
        out.append(int(v))
    if not out:
        raise ValueError(f"{name} is empty; expected at least one column index (or None for all).")
    if len(set(out)) != len(out):
        raise ValueError(f"{name} has repeated entries {out}; expected distinct column indices.")
    return out


def canonical_term(term):
    """Merge the powers of repeated ``POW`` / ``ABS_POW`` factors and sort the factors.

    Examples
    --------
    >>> canonical_term(((1, POW, 1, 0), (0, POW, 1, 0), (1, POW, 2, 0)))
    ((0, 0, 1.0, 0.0), (1, 0, 3.0, 0.0))
    >>> canonical_term(((0, ABS_POW, 1, 0), (0, POW, 1, 0)))
    ((0, 0, 1.0, 0.0), (0, 1, 1.0, 0.0))
    """
    powers = defaultdict(float)
    others = []
    for col, op, a, b in term:
        if op in (POW, ABS_POW):
            powers[(int(col), int(op))] += float(a)
        else:
            others.append((int(col), int(op), float(a), float(b)))
    merged = [(col, op, a, 0.0) for (col, op), a in powers.items() if a != 0]
    return tuple(sorted(merged + others))


class BaseLibrary(TransformerMixin, BaseEstimator):
    """Base class: validation, ``transform`` from ``terms_`` and feature names.

    Subclasses implement ``_make_terms(n_features)`` (validating their
    parameters) and get ``fit``, ``transform`` and ``get_feature_names_out``.
    ``lib1 + lib2`` is a :class:`ConcatLibrary`, ``lib1 * lib2`` a
    :class:`ProductLibrary`.

    Examples
    --------
    A library of the signs of all columns, in one method (terms as in
    :mod:`sindybench.libraries._terms`):

    >>> from sindybench.libraries import SIGN
    >>> class SignLibrary(BaseLibrary):
    ...     def _make_terms(self, n_features):
    ...         return [((col, SIGN, 0.0, 0.0),) for col in range(n_features)]
    >>> Z = np.array([[-2.0, 3.0], [0.5, -1.0]])
    >>> lib = SignLibrary().fit(Z)
    >>> lib.get_feature_names_out(["y0", "u0"]).tolist()
    ['sign(y0)', 'sign(u0)']
    >>> lib.transform(Z)
    array([[-1.,  1.],
           [ 1., -1.]])
    """

    def _validate_Z(self, Z, *, reset):
        return validate_data(self, Z, reset=reset, dtype=float, ensure_min_features=1)

    def fit(self, Z, y=None):
        """Build the terms for the columns of ``Z``.

        Parameters
        ----------
        Z : array-like of shape (n_samples, n_variables)
            Library input ``[states, inputs]``.
        y : ignored

        Returns
        -------
        self
        """
        self._validate_Z(Z, reset=True)
        terms = list(self._make_terms(self.n_features_in_))
        if not terms:
            raise ValueError(f"{type(self).__name__} with these parameters has no terms; expected at least one.")
        self.terms_ = terms
        self.n_output_features_ = len(terms)
        return self

    def transform(self, Z):
        """Evaluate the library on the rows of ``Z``.

        Returns
        -------
        ndarray of shape (n_samples, ``n_output_features_``)
        """
        check_is_fitted(self)
        Z = self._validate_Z(Z, reset=False)
        return self._transform(Z)

    def _transform(self, Z):
        return evaluate_terms(self.terms_, Z)

    def get_feature_names_out(self, input_features=None):
        """Names of the output features, e.g. ``'y0^2 u0'``.

        Parameters
        ----------
        input_features : sequence of str, optional
            Names of the columns of ``Z``; default ``x0, x1, ...``.

        Returns
        -------
        ndarray of str objects
        """
        check_is_fitted(self)
        names = list(_check_feature_names_in(self, input_features))
        return np.asarray(self._feature_names(names), dtype=object)

    def _feature_names(self, names):
        return [term_name(t, names) for t in self.terms_]

    def __add__(self, other):
        from ._compose import ConcatLibrary

        return ConcatLibrary([self, other])

    def __mul__(self, other):
        from ._compose import ProductLibrary

        return ProductLibrary(self, other)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.transformer_tags.preserves_dtype = ["float64"]
        return tags

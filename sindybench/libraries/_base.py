"""Common machinery of the feature libraries: the base class, the adapter of external ones, their compositions.

A library is a scikit-learn transformer applied to ``Z = [states, inputs]``.
``lib1 + lib2`` (:class:`ConcatLibrary`) and ``lib1 * lib2``
(:class:`ProductLibrary`) live here, beside :class:`BaseLibrary`, as do
:class:`ExternalLibrary` and :func:`as_component` that they need: this module
imports no other library module.
Built-in libraries describe every output column as a symbolic term (see
:mod:`sindybench.libraries._terms`); they set ``terms_`` at ``fit`` and
evaluate exactly those terms in ``transform``.
"""

import numbers
from collections import defaultdict

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin, clone
from sklearn.utils.validation import _check_feature_names_in, check_is_fitted, validate_data

from ..io import register_model
from ._terms import ABS_POW, POW, evaluate_terms, term_name

__all__ = ["BaseLibrary", "ConcatLibrary", "ExternalLibrary", "ProductLibrary", "as_component", "canonical_term",
           "check_variables"]


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
        return ConcatLibrary([self, other])

    def __mul__(self, other):
        return ProductLibrary(self, other)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.transformer_tags.preserves_dtype = ["float64"]
        return tags


class ExternalLibrary(BaseLibrary):
    """Adapter for a pysindy feature library or a scikit-learn transformer.

    The wrapped object is cloned and fitted on ``Z``; names come from its
    ``get_feature_names`` (pysindy) or ``get_feature_names_out``
    (scikit-learn). Use :func:`as_library` rather than this class directly.

    Parameters
    ----------
    library : object
        Has ``fit`` and ``transform``.

    Attributes
    ----------
    library_ : object
        The fitted clone.
    terms_ : None

    Examples
    --------
    >>> import numpy as np, pysindy as ps
    >>> lib = ExternalLibrary(ps.PolynomialLibrary(degree=2)).fit(np.zeros((3, 1)))
    >>> lib.get_feature_names_out(["y"]).tolist()
    ['1', 'y', 'y^2']
    """

    def __init__(self, library=None):
        self.library = library

    def fit(self, Z, y=None):
        """Fit a clone of the wrapped library on ``Z``."""
        Z = self._validate_Z(Z, reset=True)
        if not (hasattr(self.library, "fit") and hasattr(self.library, "transform")):
            raise ValueError(f"library must have fit and transform methods; got {self.library!r}.")
        self.library_ = clone(self.library).fit(Z)
        self.terms_ = None
        self.n_output_features_ = np.asarray(self.library_.transform(Z[:1])).shape[1]
        return self

    def _transform(self, Z):
        return np.asarray(self.library_.transform(Z), dtype=float)

    def _feature_names(self, names):
        check_is_fitted(self)
        if hasattr(self.library_, "get_feature_names"):
            return list(self.library_.get_feature_names(names))
        return list(self.library_.get_feature_names_out(names))


def _check_clonable(obj):
    """A library is cloned at every fit; one whose ``get_params`` fails cannot be (pysindy's CustomLibrary)."""
    try:
        if hasattr(obj, "get_params"):
            obj.get_params(deep=False)
    except AttributeError as exc:
        name = f"{type(obj).__module__}.{type(obj).__qualname__}"
        hint = ("; use sindybench.libraries.CustomLibrary(functions=[...]), which holds the same functions"
                if type(obj).__name__ == "CustomLibrary" else "")
        raise ValueError(
            f"library {name} cannot be used: its get_params() fails ({exc}), so it cannot be cloned as "
            f"scikit-learn estimators are at every fit (its constructor arguments are not kept as attributes of "
            f"the same name){hint}."
        ) from exc


def as_component(obj):
    """``obj`` as a sindybench library: returned as is, or wrapped in :class:`ExternalLibrary`.

    What :func:`~sindybench.libraries.as_library` does for everything but ``None``.

    Examples
    --------
    >>> import pysindy as ps
    >>> type(as_component(ps.FourierLibrary())).__name__
    'ExternalLibrary'
    """
    if isinstance(obj, BaseLibrary):
        return obj
    if hasattr(obj, "fit") and hasattr(obj, "transform"):
        _check_clonable(obj)
        return ExternalLibrary(obj)
    raise ValueError(
        f"library must be a sindybench library, a pysindy feature library or a transformer; got {obj!r}."
    )


# ------------------------------------------------ compositions (lib1 + lib2, lib1 * lib2)
def _fit_clone(library, Z, name):
    if library is None:
        raise ValueError(f"{name} is None; expected a library.")
    return clone(as_component(library)).fit(Z)


class ConcatLibrary(BaseLibrary):
    """The columns of several libraries side by side (``lib1 + lib2``).

    Parameters
    ----------
    libraries : sequence of library
        Fitted as clones, in order; pysindy libraries are accepted (see
        :func:`as_library`).

    Attributes
    ----------
    libraries_ : list
        The fitted clones.
    terms_ : list of tuple or None
        The concatenated terms when every part is compilable (each term once),
        else None.

    Notes
    -----
    A term that an earlier part already holds is dropped (as in
    :class:`AbsProductLibrary`): ``PolynomialLibrary(degree=3) +
    PolynomialLibrary(degree=1)`` has ``x0`` once, not two collinear
    columns whose coefficient a regression would split between them. Terms
    are compared in canonical form (``x0 x0`` is ``x0^2``). When a part is
    not compilable (``terms_`` is None) the columns are kept as they are.

    Parameters of the parts are reachable as ``libraries__<i>__<param>``
    (e.g. ``library__libraries__0__degree`` inside a ``SINDy``).

    Examples
    --------
    >>> import numpy as np
    >>> from sindybench.libraries import PolynomialLibrary, SqrtLibrary
    >>> lib = ConcatLibrary([PolynomialLibrary(degree=1), SqrtLibrary()]).fit(np.zeros((1, 2)))
    >>> lib.get_feature_names_out().tolist()
    ['1', 'x0', 'x1', 'sqrt(x0)', 'sqrt(x1)']
    >>> lib.set_params(libraries__0__degree=2).libraries[0].degree
    2
    >>> (PolynomialLibrary(degree=2) + PolynomialLibrary(degree=1)).fit(np.zeros((1, 1))).get_feature_names_out()
    array(['1', 'x0', 'x0^2'], dtype=object)
    """

    def __init__(self, libraries=None):
        self.libraries = libraries

    def fit(self, Z, y=None):
        """Fit a clone of every part on ``Z``."""
        Z = self._validate_Z(Z, reset=True)
        if self.libraries is None or isinstance(self.libraries, BaseLibrary) or len(self.libraries) == 0:
            raise ValueError(f"libraries must be a non-empty sequence of libraries; got {self.libraries!r}.")
        self.libraries_ = [_fit_clone(lib, Z, f"libraries[{i}]") for i, lib in enumerate(self.libraries)]
        parts = [lib.terms_ for lib in self.libraries_]
        if any(p is None for p in parts):
            self.terms_, self._kept = None, None
            self.n_output_features_ = sum(lib.n_output_features_ for lib in self.libraries_)
            return self
        terms, seen, self._kept = [], set(), []
        for i, term in enumerate(t for p in parts for t in p):
            key = canonical_term(term)
            if key not in seen:
                seen.add(key)
                terms.append(term)
                self._kept.append(i)
        self.terms_ = terms
        self.n_output_features_ = len(terms)
        return self

    def _transform(self, Z):
        if self.terms_ is not None:
            return super()._transform(Z)
        return np.hstack([lib._transform(Z) for lib in self.libraries_])

    def _feature_names(self, names):
        out = [n for lib in self.libraries_ for n in lib.get_feature_names_out(names)]
        return out if self._kept is None else [out[i] for i in self._kept]

    def get_params(self, deep=True):
        """Parameters, with those of the parts as ``libraries__<i>__<param>``."""
        params = super().get_params(deep=False)
        if deep and isinstance(self.libraries, (list, tuple)):
            for i, lib in enumerate(self.libraries):
                if hasattr(lib, "get_params"):
                    for key, value in lib.get_params(deep=True).items():
                        params[f"libraries__{i}__{key}"] = value
        return params

    def set_params(self, **params):
        """Set parameters; ``libraries__<i>__<param>`` reaches part ``i``."""
        nested = {}
        for key in list(params):
            if key.startswith("libraries__"):
                index, _, sub = key[len("libraries__"):].partition("__")
                if (not index.isdigit() or not sub or not isinstance(self.libraries, (list, tuple))
                        or int(index) >= len(self.libraries)):
                    raise ValueError(f"invalid parameter {key!r} for {type(self).__name__}; "
                                     "expected libraries__<index>__<param>.")
                nested.setdefault(int(index), {})[sub] = params.pop(key)
        super().set_params(**params)
        if nested:
            libraries = list(self.libraries)
            for i, sub in nested.items():
                libraries[i] = clone(libraries[i]).set_params(**sub)
            self.libraries = libraries
        return self


class ProductLibrary(BaseLibrary):
    """Every product of a column of ``left`` with a column of ``right`` (``left * right``).

    Columns are ordered left-major. When both sides are compilable the
    products are terms (powers of the same variable merge: ``x0 * x0`` is
    ``x0^2``), else the product is computed column by column and
    ``terms_`` is None. No deduplication of repeated products.

    Parameters
    ----------
    left, right : library
        pysindy libraries are accepted (see :func:`as_library`).

    Attributes
    ----------
    left_, right_ : library
        Fitted clones.
    terms_ : list of tuple or None

    Examples
    --------
    >>> import numpy as np
    >>> from sindybench.libraries import PolynomialLibrary, AbsProductLibrary
    >>> lib = ProductLibrary(PolynomialLibrary(degree=1, variables=[0]), PolynomialLibrary(degree=1))
    >>> lib.fit(np.zeros((1, 2))).get_feature_names_out(["y", "u"]).tolist()
    ['1', 'y', 'u', 'y', 'y^2', 'y u']
    """

    def __init__(self, left=None, right=None):
        self.left = left
        self.right = right

    def fit(self, Z, y=None):
        """Fit clones of both sides on ``Z``."""
        Z = self._validate_Z(Z, reset=True)
        self.left_ = _fit_clone(self.left, Z, "left")
        self.right_ = _fit_clone(self.right, Z, "right")
        if self.left_.terms_ is None or self.right_.terms_ is None:
            self.terms_ = None
        else:
            self.terms_ = [canonical_term(a + b) for a in self.left_.terms_ for b in self.right_.terms_]
        self.n_output_features_ = self.left_.n_output_features_ * self.right_.n_output_features_
        return self

    def _transform(self, Z):
        if self.terms_ is not None:
            return super()._transform(Z)
        a, b = self.left_._transform(Z), self.right_._transform(Z)
        return (a[:, :, None] * b[:, None, :]).reshape(Z.shape[0], -1)

    def _feature_names(self, names):
        if self.terms_ is not None:
            return super()._feature_names(names)
        out = []
        for a in self.left_.get_feature_names_out(names):
            for b in self.right_.get_feature_names_out(names):
                out.append(" ".join(n for n in (a, b) if n != "1") or "1")
        return out


register_model(ConcatLibrary)
register_model(ProductLibrary)

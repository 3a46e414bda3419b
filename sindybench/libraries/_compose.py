"""Sums and products of libraries."""

import numpy as np
from sklearn.base import clone

from ..io import register_model
from ._base import BaseLibrary, canonical_term
from ._custom import as_library

__all__ = ["ConcatLibrary", "ProductLibrary"]


def _fit_clone(library, Z, name):
    if library is None:
        raise ValueError(f"{name} is None; expected a library.")
    return clone(as_library(library)).fit(Z)


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

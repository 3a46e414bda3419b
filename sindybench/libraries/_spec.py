"""Plain JSON-able description of an (unfitted) built-in library.

``library_to_spec`` turns a library into ``{"class": name, "params": {...}}``
with the parameters encoded as in model files (:func:`sindybench.io.encode_value`);
``library_from_spec`` rebuilds it. For a fitted model, the terms alone
(``terms_to_json`` of ``library.terms_``) suffice to rebuild a compiled
predictor through :class:`TermsLibrary`; the spec keeps the library's parameters.
"""

import inspect

import numpy as np

from ..io import decode_value, encode_value
from ._base import BaseLibrary
from ._terms import check_terms, terms_to_json

__all__ = ["count_terms", "fitted_library_from_dict", "fitted_library_to_dict", "library_from_spec", "library_to_spec"]

MAX_COLUMNS = 100_000  # columns of Z a model file may ask a library to be fitted on


def library_to_spec(library):
    """JSON-able dict ``{"class": ..., "params": {...}}`` of a built-in library.

    Raises ValueError for custom and external libraries (Python callables
    and foreign objects cannot be stored as plain data).

    Examples
    --------
    >>> from sindybench.libraries import PolynomialLibrary, SqrtLibrary
    >>> spec = library_to_spec(PolynomialLibrary(degree=3) + SqrtLibrary())
    >>> spec["class"], spec["params"]["libraries"][1]
    ('ConcatLibrary', {'estimator': {'class': 'SqrtLibrary', 'params': {'lower': 0.0, 'upper': {'float': 'inf'}, 'variables': None}}})
    >>> library_from_spec(spec)
    ConcatLibrary(libraries=[PolynomialLibrary(degree=3), SqrtLibrary()])
    """
    spec = encode_value(library, "library")
    if not isinstance(library, BaseLibrary):
        raise ValueError(f"library_to_spec takes a sindybench library; got {type(library).__name__}.")
    return spec["estimator"]


def library_from_spec(spec):
    """Rebuild the (unfitted) library described by ``spec``; see :func:`library_to_spec`."""
    library = decode_value({"estimator": spec}, "library")
    if not isinstance(library, BaseLibrary):
        raise ValueError(f"library spec names {type(library).__name__}; expected a library class.")
    return library


def fitted_library_to_dict(library):
    """``{"library": ..., "terms": ...}`` of a fitted built-in library, for model files.

    The library is stored by its parameters; its terms (which depend only on
    the number of columns of ``Z``) are stored too, to be checked at loading.
    """
    if getattr(library, "terms_", None) is None:
        raise ValueError(
            f"the model cannot be saved as JSON: its library ({type(library).__name__}) has no symbolic terms "
            "(custom Python functions or an external library); use built-in libraries to save models."
        )
    return {"library": encode_value(library, "fitted.library"), "terms": terms_to_json(library.terms_)}


def fitted_library_from_dict(fields, n_columns):
    """The fitted library of :func:`fitted_library_to_dict`, fitted on ``n_columns`` columns of ``Z``.

    Parameters
    ----------
    fields : sindybench.io.Fields
        The stored dict.
    n_columns : int
        Number of columns of ``Z`` (states and inputs) at ``fit``.

    Returns
    -------
    library
        Fitted, with the very terms of the saved library.
    """
    library = fields.value("library")
    if not isinstance(library, BaseLibrary):
        raise ValueError(f"{fields.where('library')}: expected a sindybench library; got {type(library).__name__}.")
    if n_columns > MAX_COLUMNS:
        raise ValueError(f"{fields.where('library')}: fitted on {n_columns} columns of Z = [states, inputs]; a model "
                         f"file may ask for at most {MAX_COLUMNS}.")
    terms = check_terms(fields.get("terms", "a list of terms"), n_columns, name=fields.where("terms"))
    # the cheap checks first: a file of a few bytes can name a library of billions of terms (degree=100)
    limit = 4 * len(terms) + 1000
    size = count_terms(library, n_columns, limit)
    if size is not None and size > limit:
        text = _short(library)
        raise ValueError(
            f"{fields.where('library')}: {text[:200]}{'...' if len(text) > 200 else ''} would build more than "
            f"{limit} terms on {n_columns} columns; the file stores {len(terms)}. Refused before building them."
        )
    try:
        library.fit(np.zeros((1, n_columns)))
    except (ValueError, TypeError) as exc:  # parameters a library refuses when it builds its terms
        raise ValueError(f"{fields.where('library')}: {_short(library)[:200]} refused its parameters on "
                         f"{n_columns} columns: {exc}") from exc
    if library.terms_ != terms:
        raise ValueError(
            f"{fields.where('terms')}: expected the {len(library.terms_)} terms of {library!r} on {n_columns} "
            f"columns; got {len(terms)} other terms."
        )
    return library


def _short(value, depth=3):
    """A short description of a library for messages (scikit-learn's repr of nested estimators is exponential).

    Examples
    --------
    >>> from sindybench.libraries import PolynomialLibrary, SqrtLibrary
    >>> _short(PolynomialLibrary(degree=100) + SqrtLibrary())
    'ConcatLibrary(libraries=[PolynomialLibrary(degree=100), SqrtLibrary()])'
    """
    if isinstance(value, BaseLibrary):
        if depth == 0:
            return f"{type(value).__name__}(...)"
        defaults = {k: p.default for k, p in inspect.signature(type(value).__init__).parameters.items()}
        changed = []
        for k, v in value.get_params(deep=False).items():
            default = defaults.get(k, inspect.Parameter.empty)
            same = v is default or (type(v) is type(default) and isinstance(v, (int, float, str, bool)) and v == default)
            if not same:
                changed.append(f"{k}={_short(v, depth - 1)}")
        return f"{type(value).__name__}({', '.join(changed)})"
    if isinstance(value, (list, tuple)):
        inner = ", ".join(_short(v, depth) for v in value[:3]) + (", ..." if len(value) > 3 else "")
        return f"[{inner}]" if isinstance(value, list) else f"({inner})"
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _count(values, default):
    return len(values) if isinstance(values, (list, tuple)) else default


def count_terms(library, n_columns, limit):
    """At least the number of terms ``library.fit`` builds on ``n_columns`` columns, counted without building them.

    Counting stops once it passes ``limit``. None for a class whose size is
    not known here (it is fitted as it is). Parameters of the wrong type count
    as one term: ``fit`` refuses them at once.

    Examples
    --------
    >>> from sindybench.libraries import PolynomialLibrary, SqrtLibrary
    >>> count_terms(PolynomialLibrary(degree=2) + SqrtLibrary(), 3, 1000)
    13
    >>> count_terms(PolynomialLibrary(degree=100), 2, 1000) > 1000
    True
    """
    from ._builtin import AbsProductLibrary, IndicatorLibrary, PolynomialLibrary, SqrtLibrary, TermsLibrary
    from ._compose import ConcatLibrary, ProductLibrary

    kind = type(library)
    if kind is PolynomialLibrary:
        n, degree = _count(library.variables, n_columns), library.degree
        if not isinstance(degree, int) or isinstance(degree, bool) or degree < 0:
            return 1
        total = count = 1  # the bias, and the number of monomials of degree k (k = 0)
        for k in range(1, degree + 1):
            count = count * (n - k + 1) // k if library.interaction_only is True else count * (n + k - 1) // k
            total += count
            if count == 0 or total > limit:
                break
        return total
    if kind is SqrtLibrary:
        return _count(library.variables, n_columns)
    if kind is IndicatorLibrary:
        return _count(library.variables, 1) * (1 + _count(library.times, 0))
    if kind is AbsProductLibrary:
        n = _count(library.variables, n_columns)
        pairs = _count(library.pairs, n * (n - 1) // 2)
        return pairs * _count(library.products, 1) + (2 * pairs if library.include_abs is True else 0)
    if kind is TermsLibrary:
        return _count(library.terms, 1)
    if kind is ConcatLibrary:
        if not isinstance(library.libraries, (list, tuple)):
            return 1
        sizes = [count_terms(part, n_columns, limit) for part in library.libraries]
        return None if None in sizes else sum(sizes)
    if kind is ProductLibrary:
        left, right = count_terms(library.left, n_columns, limit), count_terms(library.right, n_columns, limit)
        return None if left is None or right is None else left * right
    return None

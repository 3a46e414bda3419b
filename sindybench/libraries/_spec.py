"""Plain JSON-able description of an (unfitted) built-in library.

``library_to_spec`` turns a library into ``{"class": name, "params": {...}}``
with the parameters encoded as in model files (:func:`sindybench.io.encode_value`);
``library_from_spec`` rebuilds it. For a fitted model, the terms alone
(``terms_to_json`` of ``library.terms_``) suffice to rebuild a compiled
predictor through :class:`TermsLibrary`; the spec keeps the library's parameters.
"""

import numpy as np

from ..io import decode_value, encode_value
from ._base import BaseLibrary
from ._terms import check_terms, terms_to_json

__all__ = ["fitted_library_from_dict", "fitted_library_to_dict", "library_from_spec", "library_to_spec"]


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
    terms = check_terms(fields.get("terms", "a list of terms"), n_columns, name=fields.where("terms"))
    library.fit(np.zeros((1, n_columns)))
    if library.terms_ != terms:
        raise ValueError(
            f"{fields.where('terms')}: expected the {len(library.terms_)} terms of {library!r} on {n_columns} "
            f"columns; got {len(terms)} other terms."
        )
    return library

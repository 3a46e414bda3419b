"""Plain JSON-able description of a (unfitted) built-in library.

``library_to_spec`` turns a library into nested dicts and lists of plain
numbers and strings (infinite values as ``"inf"``); ``library_from_spec``
rebuilds it. For a fitted model, the terms alone (``terms_to_json`` of
``library.terms_``) suffice to rebuild a compiled predictor through
:class:`TermsLibrary`; the spec additionally keeps the library's parameters.
"""

import numpy as np

from ._builtin import AbsProductLibrary, IndicatorLibrary, PolynomialLibrary, SqrtLibrary, TermsLibrary
from ._compose import ConcatLibrary, ProductLibrary
from ._terms import terms_to_json

__all__ = ["library_from_spec", "library_to_spec"]

_SIMPLE = {cls.__name__: cls for cls in (AbsProductLibrary, IndicatorLibrary, PolynomialLibrary, SqrtLibrary)}


def _plain(value):
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return v if np.isfinite(v) else ("inf" if v > 0 else ("-inf" if v < 0 else "nan"))
    if isinstance(value, (str, type(None))):
        return value
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    raise ValueError(f"parameter value {value!r} is not JSON-able; expected numbers, strings or lists.")


def _unplain(value):
    if value in ("inf", "-inf"):
        return float(value)
    if isinstance(value, list):
        return [_unplain(v) for v in value]
    return value


def library_to_spec(library):
    """JSON-able dict ``{"class": ..., "params": {...}}`` of a built-in library.

    Raises ValueError for custom and external libraries (Python callables
    and foreign objects cannot be stored as plain data).

    Examples
    --------
    >>> spec = library_to_spec(PolynomialLibrary(degree=3) + SqrtLibrary())
    >>> spec["class"], spec["params"]["libraries"][1]
    ('ConcatLibrary', {'class': 'SqrtLibrary', 'params': {'lower': 0.0, 'upper': 'inf', 'variables': None}})
    >>> library_from_spec(spec)
    ConcatLibrary(libraries=[PolynomialLibrary(degree=3), SqrtLibrary()])
    """
    name = type(library).__name__
    if name in _SIMPLE and isinstance(library, _SIMPLE[name]):
        params = {k: _plain(v) for k, v in library.get_params(deep=False).items()}
    elif isinstance(library, TermsLibrary):
        params = {"terms": terms_to_json(library.terms) if library.terms is not None else None}
    elif isinstance(library, ConcatLibrary):
        params = {"libraries": [library_to_spec(lib) for lib in library.libraries]}
    elif isinstance(library, ProductLibrary):
        params = {"left": library_to_spec(library.left), "right": library_to_spec(library.right)}
    else:
        raise ValueError(
            f"{name} cannot be stored as a plain spec (custom functions or external objects); "
            "store the fitted terms_ instead, or use a built-in library."
        )
    return {"class": name, "params": params}


def library_from_spec(spec):
    """Rebuild the (unfitted) library described by ``spec``; see :func:`library_to_spec`."""
    try:
        name, params = spec["class"], dict(spec["params"])
    except (TypeError, KeyError) as exc:
        raise ValueError(f"a library spec is a dict with keys 'class' and 'params'; got {spec!r}.") from exc
    if name in _SIMPLE:
        return _SIMPLE[name](**{k: _unplain(v) for k, v in params.items()})
    if name == "TermsLibrary":
        return TermsLibrary(**params)
    if name == "ConcatLibrary":
        return ConcatLibrary([library_from_spec(s) for s in params["libraries"]])
    if name == "ProductLibrary":
        return ProductLibrary(library_from_spec(params["left"]), library_from_spec(params["right"]))
    raise ValueError(f"unknown library class {name!r} in spec; expected one of "
                     f"{sorted([*_SIMPLE, 'ConcatLibrary', 'ProductLibrary', 'TermsLibrary'])}.")

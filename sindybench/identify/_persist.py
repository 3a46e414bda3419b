"""``identification_`` in model files: the record of :func:`~sindybench.identify` kept beside the fitted model.

A model file keeps the record under ``records.identification_`` (see
:func:`sindybench.io.register_record`), so that a model loaded back can still
say how it was chosen (and a report can be written from the file later). The
record is stored with :func:`~sindybench.io.encode_value` (arrays exact,
``inf`` and ``nan`` tagged) and read back as the same structure: the
candidates' table (``cv_results``, arrays as arrays), the chosen settings, the
front, the blocks, and the data advice as a :class:`DataAdvice` again (its
proposed terms as :class:`ProposedTerm`). What the plain encoding cannot
hold is written in three marked forms, read back here only: a dict with
non-text keys (``{"__pairs__": [[key, value], ...]}``), complex numbers
(``{"__complex__": [real, imaginary]}``) and the advice's dataclasses
(``{"__DataAdvice__": {...}}``, ``{"__ProposedTerm__": {...}}``).
"""

import dataclasses

import numpy as np

from .._limits import shown
from ..io import decode_value, encode_value, register_record
from ._advice import DataAdvice, ProposedTerm

__all__ = ["identification_from_data", "identification_to_data"]

_CLASSES = {"DataAdvice": DataAdvice, "ProposedTerm": ProposedTerm}


def _plain(value):
    """``value`` with the dataclasses, complex numbers and non-text keys in their marked forms."""
    if dataclasses.is_dataclass(value) and type(value).__name__ in _CLASSES:
        fields = {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
        return {f"__{type(value).__name__}__": fields}
    if isinstance(value, dict):
        if all(isinstance(k, str) for k in value):
            return {k: _plain(v) for k, v in value.items()}
        return {"__pairs__": [[_plain(k), _plain(v)] for k, v in value.items()]}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if isinstance(value, tuple):
        return tuple(_plain(v) for v in value)
    if isinstance(value, (complex, np.complexfloating)) or (isinstance(value, np.ndarray)
                                                             and np.iscomplexobj(value)):
        return {"__complex__": [np.real(value), np.imag(value)]}
    return value


def _restore(value, field):
    """Inverse of :func:`_plain` (on decoded values)."""
    if isinstance(value, list):
        return [_restore(v, f"{field}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, tuple):
        return tuple(_restore(v, f"{field}[{i}]") for i, v in enumerate(value))
    if not isinstance(value, dict):
        return value
    if len(value) == 1:
        (key, inner), = value.items()
        if key == "__pairs__":
            if not isinstance(inner, list) or not all(isinstance(p, list) and len(p) == 2 for p in inner):
                raise ValueError(f"{field}.__pairs__: expected a list of [key, value] pairs.")
            return {_hashable(_restore(k, field)): _restore(v, f"{field}[{shown(k)}]") for k, v in inner}
        if key == "__complex__":
            if not isinstance(inner, list) or len(inner) != 2:
                raise ValueError(f"{field}.__complex__: expected [real part, imaginary part].")
            try:
                parts = np.asarray(inner[0], dtype=float), np.asarray(inner[1], dtype=float)
                return parts[0] + 1j * parts[1] if parts[0].ndim else complex(parts[0], parts[1])
            except (TypeError, ValueError) as exc:
                raise ValueError(f"{field}.__complex__: expected numbers or arrays of one shape ({exc}).") from None
        name = key[2:-2] if key.startswith("__") and key.endswith("__") else None
        if name in _CLASSES:
            return _dataclass(_CLASSES[name], inner, f"{field}.{key}")
    return {k: _restore(v, f"{field}[{shown(k)}]") for k, v in value.items()}


def _hashable(key):
    return tuple(key) if isinstance(key, list) else key


def _dataclass(cls, fields, field):
    """``cls(**fields)``: fields this version does not know are left out, missing ones take their defaults."""
    if not isinstance(fields, dict):
        raise ValueError(f"{field}: expected an object of {cls.__name__}'s fields; got {type(fields).__name__}.")
    known = {f.name for f in dataclasses.fields(cls)}
    kwargs = {k: _restore(v, f"{field}.{k}") for k, v in fields.items() if k in known}
    try:
        return cls(**kwargs)
    except TypeError as exc:  # a required field missing
        raise ValueError(f"{field}: not a {cls.__name__} ({exc}).") from None


def identification_to_data(record):
    """The JSON data of an ``identification_`` record (see the module text).

    Examples
    --------
    >>> data = identification_to_data({"best_index": 1, "cv_results": {"mean_validation_error": np.array([np.inf, 0.1])},
    ...                                "data": {"derivatives": {0: "finite_difference"}}})
    >>> data["dict"]["cv_results"]["dict"]["mean_validation_error"]["array"]["data"]
    ['inf', 0.1]
    >>> identification_from_data(data, "records.identification_")["data"]["derivatives"]
    {0: 'finite_difference'}
    """
    return encode_value(_plain(record), "records.identification_", function_ok=False)


def identification_from_data(data, field):
    """The ``identification_`` record from its JSON data, as it was (a dict); ``ValueError`` naming ``field``."""
    record = _restore(decode_value(data, field, function_ok=False), field)
    if not isinstance(record, dict):
        raise ValueError(f"{field}: expected the identification record (an object); got {type(record).__name__}.")
    return record


register_record("identification_", to_data=identification_to_data, from_data=identification_from_data)

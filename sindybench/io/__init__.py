"""Save and load fitted estimators as plain JSON (never pickle).

A model file is one JSON object (the *envelope*)::

    {"format": "sindybench-model", "format_version": 2, "sindybench_version": "0.2.0",
     "class": "HiddenStateSINDy", "params": {...}, "fitted": {...}}

An optional ``records`` object keeps what a model says about how it was
made (``records.identification_``: the record of :func:`sindybench.identify`),
for the classes that register one with :func:`register_record`.

``params`` holds the estimator's constructor parameters (``get_params(deep=False)``),
encoded generically (see :func:`encode_value`), so a loaded model clones,
refits and searches like the saved one. ``fitted`` holds the fitted state that
each class lists explicitly (coefficients, symbolic terms, state trajectory,
network weights ...). Arrays keep their dtype and shape, and floats are
written with Python's shortest round-trip representation, so a loaded model
simulates bit for bit like the saved one. The full schema is in the
documentation (``docs/persistence.rst``).

This package holds only the format: versions, the envelope and its checks, the
atomic write, and a registry that classes join with :func:`register_model`
from their own modules. It imports no estimator: an estimator module imports
it, never the other way round. A class name in a file is looked up in the
registry only; nothing is imported because a file names it, except a
module-level function stored by its import path (a
``ParametricHiddenState``'s ``rhs``), and only when the caller passes
``allow_import=True``, and only for a parameter its class declares
(``register_model(..., functions=...)``).

Loading checks the cheap things first: the nesting depth and integer sizes of
the JSON (:func:`check_plain`), then each field, then what it builds. A file
may not ask for more than the limits below, so that a small file loads in a
fraction of a second or is refused with a ``ValueError``: nesting 100 levels,
arrays of 32 dimensions below ``2**31`` each, integers of 64 bits, 1000 sub-steps
per sample, libraries fitted on 100,000 columns, and no library that would
build more than ``4 n + 1000`` terms where the file stores ``n``.
"""

from ._files import (
    FORMAT_VERSION,
    SaveLoadMixin,
    load_model,
    model_from_dict,
    model_to_dict,
    save_model,
    write_text_atomic,
)
from ._checks import check_fitted_kind, check_limit, check_params, check_plain
from ._registry import register_model, register_record
from ._values import (
    Fields,
    decode_array,
    decode_value,
    encode_array,
    encode_value,
    fitted_from_dict,
    fitted_to_dict,
)

# load_model is exported from the top-level package (sindybench.load_model), importable here too
__all__ = [
    "FORMAT_VERSION",
    "Fields",
    "SaveLoadMixin",
    "check_fitted_kind",
    "check_limit",
    "check_params",
    "check_plain",
    "decode_array",
    "decode_value",
    "encode_array",
    "encode_value",
    "fitted_from_dict",
    "fitted_to_dict",
    "model_from_dict",
    "model_to_dict",
    "register_model",
    "register_record",
    "save_model",
    "write_text_atomic",
]

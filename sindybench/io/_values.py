"""Model-file values: parameters, arrays and the checked reading of stored fields."""

import importlib
import math
import types

import numpy as np

from .._validation import shown
from ._registry import _REGISTRY, _function_params, _lookup, _registered

__all__ = [
    "Fields",
    "decode_array",
    "decode_value",
    "encode_array",
    "encode_value",
    "fitted_from_dict",
    "fitted_to_dict",
]

_TAGS = ("array", "dict", "estimator", "float", "function", "tuple")
MAX_NDIM, MAX_DIM = 32, 2**31  # array dimensions a file may declare
_DTYPES = {"float64": np.float64, "float32": np.float32, "int64": np.int64, "bool": bool}
_SPECIAL = {"inf": math.inf, "-inf": -math.inf, "nan": math.nan}


def _repr(value):
    """``repr(value)``, or ``<module.Class>`` when its ``repr`` fails (pysindy's CustomLibrary)."""
    try:
        return repr(value)
    except Exception:  # noqa: BLE001 - a foreign object's repr may raise anything; the message must not
        return f"<{type(value).__module__}.{type(value).__qualname__} object>"


def _kind(value):
    """Short description of a decoded JSON value, for messages."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return f"a boolean ({value})"
    if isinstance(value, (int, float)):
        return f"a number ({shown(value)})"
    if isinstance(value, str):
        return f"a string ({shown(value, 40)})"
    if isinstance(value, list):
        return f"a list of {len(value)}"
    return f"an object with keys {sorted(value)[:6]}"


def encode_array(a):
    """A numpy array as ``{"dtype", "shape", "data"}``, exact (non-finite floats as strings).

    Examples
    --------
    >>> encode_array(np.array([[1.5, np.inf]]))
    {'dtype': 'float64', 'shape': [1, 2], 'data': [1.5, 'inf']}
    >>> decode_array(encode_array(np.array([0.1, -0.0])), "x").tolist()
    [0.1, -0.0]
    >>> decode_array(encode_array(np.array([0.1], dtype=np.float32)), "x").dtype
    dtype('float32')
    """
    a = np.asarray(a)
    if a.dtype == bool:
        dtype, data = "bool", [bool(v) for v in a.ravel()]
    elif np.issubdtype(a.dtype, np.integer):
        dtype, data = "int64", [int(v) for v in a.ravel()]
    elif np.issubdtype(a.dtype, np.floating):  # float32 values are exact float64 numbers too
        dtype = "float32" if a.dtype == np.float32 else "float64"
        data = [v if math.isfinite(v) else repr(v) for v in a.astype(float).ravel().tolist()]
    else:
        raise ValueError(f"cannot store an array of dtype {a.dtype}; expected float, int or bool.")
    return {"dtype": dtype, "shape": list(a.shape), "data": data}


def decode_array(value, field, shape=None):
    """Inverse of :func:`encode_array`; ``shape`` entries ``None`` match any length.

    Raises ``ValueError`` naming ``field`` for anything that is not such an
    array, or whose shape differs from ``shape``.

    Examples
    --------
    >>> decode_array({"dtype": "float64", "shape": [2], "data": [1.0, 2.0]}, "fitted.x0", shape=(3,))
    Traceback (most recent call last):
    ...
    ValueError: fitted.x0: expected an array of shape (3,); got shape (2,).
    """
    if not isinstance(value, dict) or set(value) != {"dtype", "shape", "data"}:
        raise ValueError(f"{field}: expected an array {{'dtype', 'shape', 'data'}}; got {_kind(value)}.")
    dtype, dims, data = value["dtype"], value["shape"], value["data"]
    if dtype not in _DTYPES:
        raise ValueError(f"{field}.dtype: expected one of {sorted(_DTYPES)}; got {shown(dtype)}.")
    if (not isinstance(dims, list) or len(dims) > MAX_NDIM
            or not all(isinstance(d, int) and not isinstance(d, bool) and 0 <= d < MAX_DIM for d in dims)):
        raise ValueError(f"{field}.shape: expected a list of at most {MAX_NDIM} integers in [0, {MAX_DIM}); "
                         f"got {_kind(dims)}.")
    if not isinstance(data, list) or len(data) != math.prod(dims):
        raise ValueError(f"{field}.data: expected a list of {math.prod(dims)} values (shape {dims}); got {_kind(data)}.")
    if dtype in ("float64", "float32"):
        ok = all((isinstance(v, (int, float)) and not isinstance(v, bool)) or (isinstance(v, str) and v in _SPECIAL)
                 for v in data)
        values = [_SPECIAL.get(v, v) if isinstance(v, str) else v for v in data] if ok else None
    elif dtype == "int64":
        ok = all(isinstance(v, int) and not isinstance(v, bool) and -2**63 <= v < 2**63 for v in data)
        values = data
    else:
        ok, values = all(isinstance(v, bool) for v in data), data
    if not ok:
        raise ValueError(f"{field}.data: expected {dtype} values; got {[_kind(v) for v in data[:5]]}...")
    a = np.array(values, dtype=_DTYPES[dtype]).reshape(dims)
    if shape is not None and (a.ndim != len(shape) or any(s is not None and s != d for s, d in zip(shape, a.shape))):
        want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
        raise ValueError(f"{field}: expected an array of shape {want}; got shape {tuple(a.shape)}.")
    return a


def _function_path(func, field):
    qualname = getattr(func, "__qualname__", "")
    if not isinstance(func, types.FunctionType) or "<lambda>" in qualname or "<locals>" in qualname:
        raise ValueError(
            f"{field} = {shown(func)} cannot be stored: only a module-level function can be saved (by its import "
            "path); move it to the top level of an importable module (no lambda, no function defined inside "
            "another function)."
        )
    if func.__module__ == "__main__":
        raise ValueError(
            f"{field} = {func.__qualname__} is defined in __main__ (a script or notebook), which another "
            "process cannot import; move it to an importable module."
        )
    path = f"{func.__module__}:{qualname}"
    try:
        found = _import_function(path, field)
    except ValueError:
        found = None
    if found is not func:
        raise ValueError(f"{field} = {shown(func)} is not importable as {shown(path)}; expected a module-level function.")
    return path


def _import_function(path, field):
    module, _, qualname = path.partition(":")
    if not all(part.isidentifier() for part in (*module.split("."), *qualname.split("."))):
        # importlib reads '../x' as a relative import (TypeError) and 'a/b' as a module name
        raise ValueError(f"{field}: expected a function path 'module:name' of dotted Python names "
                         f"('my_models.laws:leak'); got {shown(path)}.")
    try:
        obj = importlib.import_module(module)
        for part in qualname.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as exc:
        raise ValueError(f"{field}: cannot import the function {shown(path)} ({exc}); expected an installed module.") from None
    if not isinstance(obj, types.FunctionType):
        raise ValueError(f"{field}: {shown(path)} is a {type(obj).__name__}; expected a Python function.")
    return obj


def encode_value(value, field="value", *, function_ok=True):
    """A parameter value as JSON-able data; see :func:`decode_value`.

    ``None``, bool, int, str, finite floats and lists stay as they are; every
    other value becomes a one-key object: ``{"float": "inf"}``,
    ``{"tuple": [...]}``, ``{"dict": {...}}`` (string keys),
    ``{"array": {...}}`` (:func:`encode_array`), ``{"estimator": {"class":
    name, "params": {...}}}`` for an instance of a registered class (its
    ``get_params(deep=False)``, recursively), and ``{"function":
    "module:qualname"}`` for a module-level function.

    Raises ``ValueError`` naming ``field`` for anything else (lambdas, local
    functions, unregistered classes, foreign objects). A function is stored
    only as ``value`` itself with ``function_ok=True`` or as a constructor
    parameter that its class declares (``register_model(..., functions=...)``),
    never inside a list, tuple or dict: the places where loading accepts one.

    Examples
    --------
    >>> from sindybench import STLS
    >>> encode_value((1, 2.5, np.inf))
    {'tuple': [1, 2.5, {'float': 'inf'}]}
    >>> encode_value(STLS(threshold=0.2))["estimator"]["params"]["threshold"]
    0.2
    >>> encode_value(lambda x: x, "params.rhs")
    Traceback (most recent call last):
    ...
    ValueError: params.rhs = <function <lambda> at ...> cannot be stored: only a module-level function ...
    """
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return v if math.isfinite(v) else {"float": repr(v)}
    if isinstance(value, list):
        return [encode_value(v, f"{field}[{i}]", function_ok=False) for i, v in enumerate(value)]
    if isinstance(value, tuple):
        return {"tuple": [encode_value(v, f"{field}[{i}]", function_ok=False) for i, v in enumerate(value)]}
    if isinstance(value, dict):
        bad = [k for k in value if not isinstance(k, str)]
        if bad:
            raise ValueError(f"{field} has the key {shown(bad[0])}; expected string keys only.")
        return {"dict": {k: encode_value(v, f"{field}[{shown(k)}]", function_ok=False) for k, v in value.items()}}
    if isinstance(value, np.ndarray):
        return {"array": encode_array(value)}
    if isinstance(value, types.FunctionType):
        if not function_ok:
            raise ValueError(f"{field} = {shown(value)} cannot be stored: a Python function is stored only as one of "
                             f"{_function_params()}.")
        return {"function": _function_path(value, field)}
    name = type(value).__name__
    entry = _REGISTRY.get(name)
    if entry is not None and type(value) is entry.cls:
        return {"estimator": {"class": name, "params": _encode_params(value, field)}}
    raise ValueError(_unstorable(value, field))


# pysindy classes and the sindybench classes that store the same thing
_PYSINDY_EQUIVALENTS = {
    "PolynomialLibrary": "sindybench.libraries.PolynomialLibrary",
    "ConcatLibrary": "sindybench.libraries.ConcatLibrary (lib1 + lib2 of sindybench libraries)",
    "GeneralizedLibrary": "sindybench.libraries.ConcatLibrary (lib1 + lib2 of sindybench libraries)",
    "TensoredLibrary": "sindybench.libraries.ProductLibrary (lib1 * lib2 of sindybench libraries)",
    "STLSQ": "sindybench.STLS",
    "FiniteDifference": "sindybench.differentiation.FiniteDifference",
    "SmoothedFiniteDifference": "sindybench.differentiation.SavitzkyGolay",
    "SpectralDerivative": "sindybench.differentiation.Spectral",
}


def _unstorable(value, field):
    """The message for a value that cannot be stored, with the sindybench class to use where there is one."""
    cls = type(value)
    name, module = cls.__name__, cls.__module__
    if module.partition(".")[0] == "pysindy":
        hint = _PYSINDY_EQUIVALENTS.get(name)
        use = (f"use {hint} instead" if hint else
               "sindybench has no equivalent to store; use the sindybench classes (sindybench.libraries, "
               "sindybench.differentiation, sindybench.STLS) to save the model")
        return (f"{field} = {_repr(value)} cannot be stored as JSON: it is pysindy's {name} ({module}.{name}), "
                f"not a sindybench class; {use}.")
    if name in _REGISTRY:
        known = _REGISTRY[name].cls
        return (f"{field} = {_repr(value)} cannot be stored as JSON: it is {module}.{cls.__qualname__}, not the "
                f"registered {known.__module__}.{known.__qualname__}; expected the registered class.")
    return (f"{field} = {_repr(value)} cannot be stored as JSON: {name} is not a registered class (custom Python "
            f"functions or foreign objects); expected plain values or one of {_registered()}.")


def _encode_params(estimator, field):
    functions = _REGISTRY[type(estimator).__name__].functions if type(estimator).__name__ in _REGISTRY else ()
    return {k: encode_value(v, f"{field}.{k}", function_ok=k in functions)
            for k, v in estimator.get_params(deep=False).items()}


def decode_value(value, field="value", *, allow_import=False, function_ok=True):
    """Inverse of :func:`encode_value`; ``ValueError`` naming ``field`` for malformed data.

    Parameters
    ----------
    value : JSON data
    field : str
        Where ``value`` sits in the file (``"params.optimizer"``), for messages.
    allow_import : bool, default=False
        Import the module-level functions the data names (``{"function":
        "module:qualname"}``); otherwise such a value is refused.
    function_ok : bool, default=True
        Whether ``value`` itself may name a function. Inside lists, tuples
        and dicts, and in the parameters of an estimator other than those its
        class declares (``register_model(..., functions=...)``), a function
        is refused before anything is imported.

    Examples
    --------
    >>> decode_value({"tuple": [1, {"float": "-inf"}]})
    (1, -inf)
    >>> decode_value({"estimator": {"class": "os.system", "params": {}}}, "params.optimizer")
    Traceback (most recent call last):
    ...
    ValueError: params.optimizer.estimator.class: unknown class 'os.system'; expected one of [...].
    """
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, list):
        return [decode_value(v, f"{field}[{i}]", allow_import=allow_import, function_ok=False)
                for i, v in enumerate(value)]
    if not isinstance(value, dict) or len(value) != 1 or next(iter(value)) not in _TAGS:
        raise ValueError(f"{field}: expected a plain value or a one-key object tagged {list(_TAGS)}; got {_kind(value)}.")
    tag, inner = next(iter(value.items()))
    if tag == "float":
        if not isinstance(inner, str) or inner not in _SPECIAL:
            raise ValueError(f"{field}.float: expected one of {sorted(_SPECIAL)}; got {_kind(inner)}.")
        return _SPECIAL[inner]
    if tag == "tuple":
        if not isinstance(inner, list):
            raise ValueError(f"{field}.tuple: expected a list; got {_kind(inner)}.")
        return tuple(decode_value(v, f"{field}[{i}]", allow_import=allow_import, function_ok=False)
                     for i, v in enumerate(inner))
    if tag == "dict":
        if not isinstance(inner, dict):
            raise ValueError(f"{field}.dict: expected an object; got {_kind(inner)}.")
        return {k: decode_value(v, f"{field}[{shown(k)}]", allow_import=allow_import, function_ok=False)
                for k, v in inner.items()}
    if tag == "array":
        return decode_array(inner, f"{field}.array")
    if tag == "function":
        if not isinstance(inner, str):
            raise ValueError(f"{field}.function: expected 'module:name'; got {_kind(inner)}.")
        if not function_ok:  # checked before anything is imported
            raise ValueError(f"{field} names the Python function {shown(inner, 80)}, which is not expected here; a "
                             f"model file may name a function only as one of {_function_params()}.")
        if not allow_import:
            raise ValueError(
                f"{field} is the Python function {shown(inner)}; loading it imports that module: pass "
                "allow_import=True if you trust this file."
            )
        return _import_function(inner, field)
    return _decode_estimator(Fields(inner, f"{field}.estimator"), allow_import=allow_import)


def _construct(cls, params, field, allow_import):
    """``cls(**params)`` from encoded parameters; absent parameters take their defaults."""
    params = Fields(params, field)
    valid = cls._get_param_names()
    unknown = sorted(set(params.data) - set(valid))
    if unknown:
        raise ValueError(f"{field}: unknown parameter(s) {unknown} of {cls.__name__}; expected some of {valid}.")
    functions = _REGISTRY[cls.__name__].functions if cls.__name__ in _REGISTRY else ()
    kwargs = {k: decode_value(v, f"{field}.{k}", allow_import=allow_import, function_ok=k in functions)
              for k, v in params.data.items()}
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{field}: {cls.__name__}(...) refused these parameters: {exc}") from exc


def _decode_estimator(spec, *, allow_import):
    entry = _lookup(spec.data.get("class"), f"{spec.path}.class")
    return _construct(entry.cls, spec.get("params"), f"{spec.path}.params", allow_import)


# ------------------------------------------------------------------ fields
class Fields:
    """Typed, checked access to one JSON object of a model file.

    Every accessor raises ``ValueError`` naming the field (``fitted.coef``)
    and what was expected, for a missing or null entry and for a value of the
    wrong type or shape.

    Parameters
    ----------
    data : dict
    path : str
        Where ``data`` sits in the file, e.g. ``"fitted"``.
    allow_import : bool, default=False
        Passed on to :func:`decode_value`.

    Examples
    --------
    >>> f = Fields({"n_states": 2, "names": ["a", 3]}, "fitted")
    >>> f.int("n_states")
    2
    >>> f.strings("names")
    Traceback (most recent call last):
    ...
    ValueError: fitted.names: expected a list of strings; got a list of 2.
    >>> f.float("dt")
    Traceback (most recent call last):
    ...
    ValueError: fitted.dt: missing or null; expected a number.
    """

    def __init__(self, data, path, *, allow_import=False):
        if not isinstance(data, dict):
            raise ValueError(f"{path}: expected a JSON object; got {_kind(data)}.")
        self.data, self.path, self.allow_import = data, path, allow_import

    def where(self, name):
        """Where entry ``name`` sits in the file, for messages (``fitted.coef``)."""
        return f"{self.path}.{name}" if self.path else name

    def get(self, name, expected="a value", *, allow_none=False):
        """The raw JSON value of ``name``."""
        value = self.data.get(name)
        if value is None and not (allow_none and name in self.data):
            raise ValueError(f"{self.where(name)}: missing or null; expected {expected}.")
        return value

    def _typed(self, name, expected, check, allow_none):
        value = self.get(name, expected, allow_none=allow_none)
        if value is None or check(value):
            return value
        raise ValueError(f"{self.where(name)}: expected {expected}; got {_kind(value)}.")

    def int(self, name, *, low=0, high=None):
        """An integer ``>= low`` (and ``<= high`` when given)."""
        expected = f"an integer >= {low}" if high is None else f"an integer in [{low}, {high}]"
        return self._typed(name, expected, lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= low
                           and (high is None or v <= high), False)

    def float(self, name, *, allow_none=False):
        """A number (``{"float": "inf"}`` for non-finite values)."""
        value = self.get(name, "a number", allow_none=allow_none)
        if value is None:
            return None
        if isinstance(value, dict):
            value = decode_value(value, self.where(name), function_ok=False)
            if not isinstance(value, float):
                raise ValueError(f"{self.where(name)}: expected a number; got {_kind(value)}.")
            return value
        return float(self._typed(name, "a number", lambda v: isinstance(v, (int, float)) and not isinstance(v, bool),
                                 False))

    def bool(self, name):
        """``true`` or ``false``."""
        return self._typed(name, "true or false", lambda v: isinstance(v, bool), False)

    def str(self, name):
        """A string."""
        return self._typed(name, "a string", lambda v: isinstance(v, str), False)

    def strings(self, name, n=None):
        """A list of ``n`` strings (any number when ``n`` is None)."""
        expected = "a list of strings" if n is None else f"a list of {n} strings"
        return list(self._typed(name, expected, lambda v: isinstance(v, list) and all(isinstance(s, str) for s in v)
                                and (n is None or len(v) == n), False))

    def ints(self, name, *, high=None):
        """A list of integers in ``[0, high)``."""
        expected = "a list of integers >= 0" + ("" if high is None else f" and < {high}")
        return [int(v) for v in self._typed(
            name, expected, lambda v: isinstance(v, list) and all(
                isinstance(i, int) and not isinstance(i, bool) and 0 <= i and (high is None or i < high) for i in v),
            False)]

    def array(self, name, shape=None, *, finite=False, positive=False):
        """An array stored by :func:`encode_array`, of ``shape`` (``None`` = any length).

        With ``finite`` every entry must be finite, with ``positive`` finite and > 0.
        """
        a = decode_array(self.get(name, "an array"), self.where(name), shape)
        bad = ~(np.isfinite(a) & (a > 0)) if positive else ~np.isfinite(a) if finite else None
        if bad is not None and bad.any():
            i = tuple(int(k) for k in np.argwhere(bad)[0])
            want = "finite values > 0" if positive else "finite values"
            raise ValueError(f"{self.where(name)}: expected {want}; got {shown(a[i].item())} at index {list(i)}.")
        return a

    def _list(self, name, n, what):
        value = self.get(name, f"a list of {n} {what}")
        if not isinstance(value, list) or len(value) != n:
            raise ValueError(f"{self.where(name)}: expected a list of {n} {what}; got {_kind(value)}.")
        return value

    def arrays(self, name, shapes):
        """A list of arrays, one per entry of ``shapes``."""
        return [decode_array(a, f"{self.where(name)}[{i}]", shape)
                for i, (a, shape) in enumerate(zip(self._list(name, len(shapes), "arrays"), shapes))]

    def items(self, name, n):
        """A list of ``n`` objects, each as :class:`Fields`."""
        return [Fields(v, f"{self.where(name)}[{i}]", allow_import=self.allow_import)
                for i, v in enumerate(self._list(name, n, "objects"))]

    def mapping(self, name, *, allow_none=False):
        """A dict stored by :func:`encode_value` (``None`` too with ``allow_none``)."""
        value = self.value(name, allow_none=allow_none)
        if not isinstance(value, dict) and not (allow_none and value is None):
            raise ValueError(f"{self.where(name)}: expected a dict {{name: value}}; got {type(value).__name__}.")
        return value

    def value(self, name, *, allow_none=False):
        """A value stored by :func:`encode_value` (estimators, dicts, tuples ...)."""
        raw = self.get(name, "a value", allow_none=allow_none)
        return decode_value(raw, self.where(name), allow_import=self.allow_import, function_ok=False)

    def fields(self, name):
        """The nested object ``name`` as :class:`Fields`."""
        return Fields(self.get(name, "an object"), self.where(name), allow_import=self.allow_import)


# ------------------------------------------------------ fitted estimators
def fitted_to_dict(estimator, field="fitted"):
    """``{"class", "params", "fitted"}`` of a fitted estimator of a registered class.

    For a fitted estimator held by another one (``optimizer_``); a class
    registered without ``to_dict`` stores its parameters only.
    """
    entry = _lookup(type(estimator).__name__, f"{field}.class")
    out = {"class": type(estimator).__name__, "params": _encode_params(estimator, f"{field}.params")}
    if entry.to_dict is not None:
        out["fitted"] = entry.to_dict(estimator)
    return out


def fitted_from_dict(fields):
    """Inverse of :func:`fitted_to_dict`, from a :class:`Fields` view."""
    entry = _lookup(fields.data.get("class"), fields.where("class"))
    model = _construct(entry.cls, fields.get("params", "an object"), fields.where("params"), fields.allow_import)
    if entry.from_dict is not None:
        entry.from_dict(model, fields.fields("fitted"))
    return model

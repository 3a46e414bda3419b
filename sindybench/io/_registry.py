"""The registry of classes whose instances may appear in model files."""

from typing import Callable, NamedTuple

import numpy as np  # noqa: F401  (used by the doctest)

from .._limits import shown

__all__ = ["register_model", "register_record"]


class _Entry(NamedTuple):
    cls: type
    to_dict: Callable
    from_dict: Callable
    functions: tuple = ()


_REGISTRY = {}


class _Record(NamedTuple):
    to_data: Callable
    from_data: Callable


# records a fitted model may carry beside its fitted state (``identification_``): attribute name -> codec
_RECORDS = {}


def register_model(cls, *, to_dict=None, from_dict=None, functions=()):
    """Let instances of ``cls`` be stored in model files.

    Every class whose instances appear in a file (as the saved model or inside
    its parameters: optimizer, library, differentiation, strategy) must be
    registered; a file can only name registered classes. Files name a class
    by ``cls.__name__``.

    Parameters
    ----------
    cls : type
        A scikit-learn style estimator: ``__init__`` stores its arguments and
        ``get_params(deep=False)`` returns them.
    to_dict : callable, optional
        ``to_dict(model) -> dict``: the fitted state of a fitted ``model`` as
        JSON-able data (use :func:`encode_array` and :func:`encode_value`);
        raise ``ValueError`` when it cannot be stored. Without ``to_dict`` and
        ``from_dict`` the class can be a parameter of a saved model, but not be
        saved on its own.
    from_dict : callable, optional
        ``from_dict(model, fitted)``: set the fitted attributes of ``model``
        (constructed from the stored parameters) from ``fitted``, a
        :class:`Fields` view of the stored dict.
    functions : tuple of str, default=()
        The constructor parameters that may hold a module-level Python
        function (stored by its import path). A file that names a function
        anywhere else is refused before anything is imported.

    Returns
    -------
    cls

    Examples
    --------
    >>> from sklearn.base import BaseEstimator
    >>> from sindybench.io import model_from_dict, model_to_dict
    >>> class Gain(BaseEstimator):
    ...     def __init__(self, *, k=1.0):
    ...         self.k = k
    ...     def fit(self, X, y):
    ...         self.gain_ = self.k * float(np.mean(y))
    ...         return self
    >>> def gain_from_dict(model, fitted):
    ...     model.gain_ = fitted.float("gain")
    >>> _ = register_model(Gain, to_dict=lambda m: {"gain": m.gain_}, from_dict=gain_from_dict)
    >>> data = model_to_dict(Gain(k=2.0).fit(None, [1.0, 2.0]))
    >>> data["class"], data["params"], data["fitted"]
    ('Gain', {'k': 2.0}, {'gain': 3.0})
    >>> model_from_dict(data).gain_
    3.0
    >>> _ = _REGISTRY.pop("Gain")  # unregister the example class again
    """
    if (to_dict is None) != (from_dict is None):
        raise ValueError("register_model needs both to_dict and from_dict, or neither.")
    name = cls.__name__
    old = _REGISTRY.get(name)
    if old is not None and (old.cls.__module__, old.cls.__qualname__) != (cls.__module__, cls.__qualname__):
        raise ValueError(
            f"another class named {shown(name)} is registered ({old.cls.__module__}.{old.cls.__qualname__}); "
            "expected one class per name."
        )
    valid = cls._get_param_names() if hasattr(cls, "_get_param_names") else []
    if isinstance(functions, str) or any(f not in valid for f in functions):
        raise ValueError(f"functions = {shown(functions)}; expected a tuple of constructor parameters of {name} {valid}.")
    _REGISTRY[name] = _Entry(cls, to_dict, from_dict, tuple(functions))
    return cls


def register_record(attribute, *, to_data, from_data):
    """Let a model file keep the record ``attribute`` that a fitted model may carry (``identification_``).

    A record is what a model says about how it was made, not what it
    computes: it is written under ``records.<attribute>`` of the envelope
    when the model has it (not None), and set again on the loaded model.
    Files without it load as before (the attribute is then absent).

    Parameters
    ----------
    attribute : str
        The attribute's name, ending with ``_``.
    to_data : callable
        ``to_data(value) -> JSON data`` (use :func:`encode_value`); raise
        ``ValueError`` when it cannot be stored.
    from_data : callable
        ``from_data(data, field) -> value``; raise ``ValueError`` naming ``field``
        for malformed data. It must not import or run anything the data names.

    Examples
    --------
    >>> register_record("origin_", to_data=str, from_data=lambda data, field: data)
    >>> _ = _RECORDS.pop("origin_")  # unregister the example again
    """
    if not isinstance(attribute, str) or not attribute.endswith("_"):
        raise ValueError(f"attribute = {shown(attribute)}; expected the name of a fitted attribute (ending with '_').")
    _RECORDS[attribute] = _Record(to_data, from_data)


def _registered(models_only=False):
    return sorted(n for n, e in _REGISTRY.items() if not models_only or e.to_dict is not None)


def _function_params():
    """Where a model file may name a function: ``['ParametricHiddenState.rhs']``."""
    return sorted(f"{n}.{p}" for n, e in _REGISTRY.items() for p in e.functions)


def _lookup(name, field, *, model=False):
    if not isinstance(name, str) or name not in _REGISTRY or (model and _REGISTRY[name].to_dict is None):
        raise ValueError(f"{field}: unknown class {shown(name)}; expected one of {_registered(model)}.")
    return _REGISTRY[name]

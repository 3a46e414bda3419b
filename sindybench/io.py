"""Save and load fitted models as plain JSON (never pickle).

A model file is one JSON object::

    {"format": "sindybench-model", "format_version": 1, "sindybench_version": "...",
     "class": "SINDy", "params": {...}, "fitted": {...}}

``params`` holds the constructor settings that matter for simulation (``dt``,
``n_substeps``, ``integrator``, ``input_hold``, ``bounds``, ``max_abs``, names)
and plain descriptions of the library, optimizer and differentiation;
``fitted`` holds the coefficients, the symbolic library terms, the feature
names and the training ``dt``. Infinite numbers are stored as ``"inf"``.

Other estimators plug in with :func:`register_model`: a class name, a
``to_dict(model) -> (params, fitted)`` and a ``from_dict(params, fitted) ->
model``, both on plain JSON data. This module sits above the estimators
(it imports them); an estimator's ``to_json`` imports it lazily.
"""

import importlib
import json
import os
import tempfile
from pathlib import Path

import numpy as np

from ._sindy import SINDy
from .libraries import TermsLibrary, library_from_spec, library_to_spec, terms_from_json, terms_to_json
from .libraries._spec import _plain, _unplain

__all__ = ["load_model", "model_from_dict", "model_to_dict", "register_model", "save_model"]

FORMAT = "sindybench-model"
FORMAT_VERSION = 1
_REGISTRY = {}


def register_model(cls, *, to_dict, from_dict):
    """Make ``cls`` savable with :func:`save_model` and loadable with :func:`load_model`.

    Parameters
    ----------
    cls : type
        Estimator class; files name it by ``cls.__name__``.
    to_dict : callable
        ``to_dict(model) -> (params, fitted)``, two JSON-able dicts; raise
        ``ValueError`` for a model that cannot be stored as plain data.
    from_dict : callable
        ``from_dict(params, fitted) -> model``, the fitted model.

    Examples
    --------
    >>> from sklearn.base import BaseEstimator
    >>> class Gain(BaseEstimator):
    ...     def __init__(self, *, k=1.0):
    ...         self.k = k
    ...     def fit(self, X, y):
    ...         self.gain_ = self.k * float(np.mean(y))
    ...         return self
    >>> def gain_from_dict(params, fitted):
    ...     model = Gain(**params)
    ...     model.gain_ = fitted["gain"]
    ...     return model
    >>> register_model(Gain, to_dict=lambda m: ({"k": m.k}, {"gain": m.gain_}), from_dict=gain_from_dict)
    >>> data = model_to_dict(Gain(k=2.0).fit(None, [1.0, 2.0]))
    >>> data["class"], data["params"], data["fitted"]
    ('Gain', {'k': 2.0}, {'gain': 3.0})
    >>> model_from_dict(data).gain_
    3.0
    >>> _ = _REGISTRY.pop("Gain")  # unregister the example class again
    """
    _REGISTRY[cls.__name__] = (cls, to_dict, from_dict)


# ------------------------------------------------------------ plain helpers
def estimator_spec(obj):
    """``{"class": name, "params": {...}}`` of an estimator with plain parameters, else None.

    Examples
    --------
    >>> from sindybench import STLS
    >>> estimator_spec(STLS(threshold=0.2))["params"]["threshold"]
    0.2
    """
    if obj is None or not hasattr(obj, "get_params"):
        return None
    try:
        params = {k: _plain(v) for k, v in obj.get_params(deep=False).items()}
    except ValueError:
        return None
    return {"class": type(obj).__name__, "params": params}


def _rebuild_estimator(spec, module):
    """The estimator ``spec`` describes if ``module`` (a sindybench module name) exports its class."""
    if spec is None:
        return None
    try:
        found = importlib.import_module(module)
    except ModuleNotFoundError:
        return None
    name = spec.get("class")
    if name not in getattr(found, "__all__", ()):
        return None
    return getattr(found, name)(**{k: _unplain(v) for k, v in spec["params"].items()})


# ------------------------------------------------------------------- SINDy
_SIM_PARAMS = ("dt", "n_substeps", "integrator", "input_hold", "bounds", "max_abs", "output_names", "input_names")


def _sindy_to_dict(model):
    if model.terms_ is None:
        raise ValueError(
            f"this {type(model).__name__} cannot be saved as JSON: its library "
            f"({type(model.library_).__name__}) has no symbolic terms (custom Python functions or an "
            "external library); use built-in libraries to save models."
        )
    try:
        library = library_to_spec(model.library if model.library is not None else model.library_)
    except ValueError:
        library = None
    params = {name: _plain(getattr(model, name)) for name in _SIM_PARAMS}
    params["library"] = library
    params["optimizer"] = estimator_spec(model.optimizer)
    params["differentiation"] = estimator_spec(model.differentiation)
    fitted = {
        "coef": model.coef_.tolist(),
        "terms": terms_to_json(model.terms_),
        "feature_names": list(model.feature_names_),
        "output_names": list(model.output_names_),
        "input_names": list(model.input_names_),
        "n_states": int(model.n_states_),
        "n_inputs": int(model.n_inputs_),
        "dt": model.dt_,
        "x0": model.x0_.tolist(),
        "output_1d": bool(getattr(model, "_y_1d", False)),
    }
    return params, fitted


def _sindy_from_dict(params, fitted):
    kwargs = {name: _unplain(params.get(name)) for name in _SIM_PARAMS}
    if isinstance(kwargs["bounds"], list):
        kwargs["bounds"] = tuple(kwargs["bounds"])
    library = params.get("library")
    model = SINDy(
        library=library_from_spec(library) if library is not None else None,
        optimizer=_rebuild_estimator(params.get("optimizer"), "sindybench"),
        differentiation=_rebuild_estimator(params.get("differentiation"), "sindybench.differentiation"),
        **kwargs,
    )
    n_states, n_inputs = int(fitted["n_states"]), int(fitted["n_inputs"])
    terms = terms_from_json(fitted["terms"])
    coef = np.asarray(fitted["coef"], dtype=float)
    if coef.shape != (n_states, len(terms)):
        raise ValueError(f"coef has shape {coef.shape}; expected ({n_states}, {len(terms)}) (states, terms).")
    model.library_ = TermsLibrary(terms=terms).fit(np.zeros((1, n_states + n_inputs)))
    model.coef_ = coef
    model.terms_ = model.library_.terms_
    model.feature_names_ = list(fitted["feature_names"])
    model.output_names_ = list(fitted["output_names"])
    model.input_names_ = list(fitted["input_names"])
    model.n_states_ = n_states
    model.n_inputs_ = n_inputs
    model.n_features_in_ = n_inputs
    model.dt_ = fitted["dt"]
    model.x0_ = np.asarray(fitted["x0"], dtype=float)
    model._y_1d = bool(fitted["output_1d"])
    return model


register_model(SINDy, to_dict=_sindy_to_dict, from_dict=_sindy_from_dict)


# ---------------------------------------------------------------- public API
def model_to_dict(model):
    """The JSON-able dict :func:`save_model` writes.

    Parameters
    ----------
    model : fitted estimator of a registered class (e.g. :class:`~sindybench.SINDy`)

    Returns
    -------
    dict
        ``format``, ``format_version``, ``sindybench_version``, ``class``,
        ``params`` and ``fitted`` (see the module docstring).

    Raises
    ------
    ValueError
        For an unfitted model, an unregistered class, or a model that cannot be
        stored as plain data (e.g. custom library functions).

    Examples
    --------
    >>> from sindybench import STLS
    >>> from sindybench.libraries import PolynomialLibrary
    >>> y = np.exp(-np.arange(0, 5, 0.01))[:, None]
    >>> model = SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.1), dt=0.01).fit(None, y)
    >>> data = model_to_dict(model)
    >>> data["class"], data["fitted"]["terms"]
    ('SINDy', [[], [[0, 0, 1.0, 0.0]]])
    >>> model_from_dict(data).equations()
    ["y0' = -1.000 y0"]
    """
    name = type(model).__name__
    if name not in _REGISTRY or not isinstance(model, _REGISTRY[name][0]):
        raise ValueError(f"cannot save a {name}; expected one of {sorted(_REGISTRY)}.")
    from sklearn.utils.validation import check_is_fitted

    from . import __version__

    check_is_fitted(model)
    params, fitted = _REGISTRY[name][1](model)
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "sindybench_version": __version__,
        "class": name,
        "params": params,
        "fitted": fitted,
    }


def model_from_dict(data):
    """Rebuild a fitted model from the dict of :func:`model_to_dict`.

    Parameters
    ----------
    data : dict
        As written by :func:`model_to_dict` (or read back from a model file).

    Returns
    -------
    fitted estimator

    Examples
    --------
    >>> model_from_dict({"format": "sindybench-model", "format_version": 2})
    Traceback (most recent call last):
    ...
    ValueError: model file format_version 2 is not supported; expected 1.
    """
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ValueError(f"not a sindybench model: expected a JSON object with format = {FORMAT!r}.")
    version = data.get("format_version")
    if version != FORMAT_VERSION:
        raise ValueError(f"model file format_version {version!r} is not supported; expected {FORMAT_VERSION}.")
    name = data.get("class")
    if name not in _REGISTRY:
        raise ValueError(f"unknown model class {name!r} in the file; expected one of {sorted(_REGISTRY)}.")
    try:
        return _REGISTRY[name][2](data["params"], data["fitted"])
    except (KeyError, TypeError) as exc:
        raise ValueError(f"the {name} model data is incomplete or malformed: {exc!r}.") from exc


def save_model(model, path):
    """Write ``model`` to ``path`` as JSON, atomically.

    The text is built completely before anything is written, then written to a
    temporary file in the same folder and moved over ``path``: an error never
    leaves a partial or truncated file behind.

    Parameters
    ----------
    model : fitted estimator of a registered class (e.g. :class:`~sindybench.SINDy`)
    path : str or path-like

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from sindybench import STLS
    >>> from sindybench.libraries import PolynomialLibrary
    >>> t = np.arange(0, 5, 0.01)
    >>> y = np.exp(-t)[:, None]
    >>> model = SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.1), dt=0.01).fit(None, y)
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "model.json"
    >>> save_model(model, path)
    >>> load_model(path).equations()
    ["y0' = -1.000 y0"]
    """
    text = json.dumps(model_to_dict(model), indent=1, allow_nan=False)
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def load_model(path):
    """Load a model saved by :func:`save_model` (or ``model.to_json``).

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    fitted estimator
        Simulates exactly like the saved one.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from sindybench import STLS
    >>> from sindybench.libraries import PolynomialLibrary
    >>> y = np.exp(-np.arange(0, 5, 0.01))[:, None]
    >>> model = SINDy(library=PolynomialLibrary(degree=1), dt=0.01).fit(None, y)
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     model.to_json(pathlib.Path(folder) / "model.json")
    ...     loaded = load_model(pathlib.Path(folder) / "model.json")
    >>> loaded.equations() == model.equations(), bool(np.array_equal(loaded.coef_, model.coef_))
    (True, True)
    """
    with open(path, encoding="utf-8") as f:
        try:
            data = json.load(f)
        except json.JSONDecodeError as exc:
            raise ValueError(f"{path} is not valid JSON: {exc}") from exc
    return model_from_dict(data)

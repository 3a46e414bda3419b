"""Model files: the envelope, its version and checks, the atomic write."""

import json
import os
import tempfile
from pathlib import Path

import numpy as np  # noqa: F401  (used by the doctests)
from sklearn.utils.validation import check_is_fitted

from .._limits import shown
from .._version import __version__
from ._registry import _RECORDS, _REGISTRY, _lookup, _registered
from ._checks import check_plain
from ._values import Fields, _construct, _encode_params

__all__ = ["SaveLoadMixin", "load_model", "model_from_dict", "model_to_dict", "save_model", "write_text_atomic"]

FORMAT = "sindybench-model"
FORMAT_VERSION = 2


def model_to_dict(model):
    """The JSON-able dict :func:`save_model` writes.

    Parameters
    ----------
    model : fitted estimator of a class registered with ``to_dict``
        (:class:`~sindybench.SINDy`, :class:`~sindybench.HiddenStateSINDy`,
        :class:`~sindybench.STLS`, :class:`~sindybench.baselines.ARX`,
        :class:`~sindybench.baselines.NNARX`)

    Returns
    -------
    dict
        ``format``, ``format_version``, ``sindybench_version``, ``class``,
        ``params`` and ``fitted``; ``records`` too when the model carries a
        registered record (``identification_``, see :func:`register_record`).

    Raises
    ------
    ValueError
        For an unregistered class, or a model that cannot be stored as plain
        data (e.g. custom library functions, a lambda).
    sklearn.exceptions.NotFittedError
        For an unfitted model.

    Examples
    --------
    >>> from sindybench import SINDy, STLS
    >>> from sindybench.libraries import PolynomialLibrary
    >>> y = np.exp(-np.arange(0, 5, 0.01))[:, None]
    >>> model = SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.1), dt=0.01).fit(None, y)
    >>> data = model_to_dict(model)
    >>> data["class"], data["params"]["optimizer"], data["fitted"]["library"]["terms"]
    ('SINDy', {'estimator': {'class': 'STLS', 'params': {..., 'threshold': 0.1, ...}}}, [[], [[0, 0, 1.0, 0.0]]])
    >>> model_from_dict(data).equations()
    ["y0' = -1.000 y0"]
    """
    name = type(model).__name__
    entry = _REGISTRY.get(name)
    if entry is None or entry.to_dict is None or type(model) is not entry.cls:
        raise ValueError(f"cannot save a {name}; expected one of {_registered(True)}.")
    check_is_fitted(model)
    params = _encode_params(model, "params")
    data = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "sindybench_version": __version__,
        "class": name,
        "params": params,
        "fitted": entry.to_dict(model),
    }
    records = {attribute: record.to_data(getattr(model, attribute)) for attribute, record in _RECORDS.items()
               if getattr(model, attribute, None) is not None}
    if records:  # optional: files without it (and readers that do not know it) are unchanged
        data["records"] = records
    return data


def model_from_dict(data, *, allow_import=False):
    """Rebuild a fitted model from the dict of :func:`model_to_dict`.

    Parameters
    ----------
    data : dict
        As written by :func:`model_to_dict` (or read back from a model file).
    allow_import : bool, default=False
        Import the module-level functions the file names (see :func:`load_model`).

    Returns
    -------
    fitted estimator

    Raises
    ------
    ValueError
        Naming the first field that is missing, null, of the wrong type or
        shape, or an unknown class.

    Examples
    --------
    >>> model_from_dict({"format": "sindybench-model", "format_version": 3})
    Traceback (most recent call last):
    ...
    ValueError: format_version: model file version 3 is not supported; expected 2.
    """
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ValueError(f"format: not a sindybench model; expected a JSON object with format = {FORMAT!r}.")
    version = data.get("format_version")
    if version != FORMAT_VERSION:
        raise ValueError(f"format_version: model file version {shown(version)} is not supported; expected {FORMAT_VERSION}.")
    check_plain(data)  # bounded nesting and integers before any recursive reading
    envelope = Fields(data, "", allow_import=allow_import)  # top-level fields are named bare: "fitted.coef"
    entry = _lookup(data.get("class"), "class", model=True)
    model = _construct(entry.cls, envelope.get("params", "an object"), "params", allow_import)
    try:
        entry.from_dict(model, envelope.fields("fitted"))
    except (KeyError, TypeError, IndexError, AttributeError) as exc:  # a hook without a check of its own
        raise ValueError(f"fitted: the {entry.cls.__name__} data is malformed: {shown(exc)}.") from exc
    _load_records(model, data)
    return model


def _load_records(model, data):
    """Set the records the file keeps (``records.identification_``) on ``model``; a file without them has none."""
    if "records" not in data:
        return
    records = data["records"]
    if not isinstance(records, dict):
        raise ValueError(f"records: expected an object {{attribute: record}}; got {type(records).__name__}.")
    for attribute, value in records.items():
        record = _RECORDS.get(attribute)
        if record is None:
            raise ValueError(f"records: unknown record {shown(attribute)}; expected some of {sorted(_RECORDS)}.")
        setattr(model, attribute, record.from_data(value, f"records.{attribute}"))


def save_model(model, path):
    """Write ``model`` to ``path`` as JSON, atomically.

    The text is built completely before anything is written, then written to a
    temporary file in the same folder and moved over ``path``: an error never
    leaves a partial or truncated file behind.

    Parameters
    ----------
    model : fitted estimator of a registered class (see :func:`model_to_dict`)
    path : str or path-like

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from sindybench import SINDy, STLS
    >>> from sindybench.libraries import PolynomialLibrary
    >>> y = np.exp(-np.arange(0, 5, 0.01))[:, None]
    >>> model = SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.1), dt=0.01).fit(None, y)
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "model.json"
    >>> save_model(model, path)
    >>> load_model(path).equations()
    ["y0' = -1.000 y0"]
    """
    write_text_atomic(json.dumps(model_to_dict(model), allow_nan=False), path)


def _file_mode(path):
    """Permissions for ``path``: those of the file it replaces, else as ``open`` would create it."""
    try:
        return os.stat(path).st_mode & 0o7777
    except OSError:  # no such file (yet): 0o666 less the umask
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def write_text_atomic(text, path):
    """Write ``text`` to ``path`` through a temporary file in the same folder (no partial file).

    A new file gets the permissions ``open(path, "w")`` would give it, a
    replaced file keeps its own (the temporary file's are owner-only). An
    ``OSError`` (missing or read-only folder, full disk) names ``path``, not
    the temporary file.

    Examples
    --------
    >>> write_text_atomic("{}", "/no/such/folder/model.json")
    Traceback (most recent call last):
    ...
    FileNotFoundError: [Errno 2] cannot write the file (No such file or directory): '/no/such/folder/model.json'
    """
    path = Path(path)
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, _file_mode(path))
        os.replace(tmp, path)
    except BaseException as exc:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OSError) and exc.errno is not None:
            raise type(exc)(exc.errno, f"cannot write the file ({exc.strerror})", str(path)) from exc
        raise


def load_model(path, *, allow_import=False):
    """Load a model saved by :func:`save_model` (or ``model.to_json``).

    Parameters
    ----------
    path : str or path-like
    allow_import : bool, default=False
        A :class:`~sindybench.hidden.ParametricHiddenState` stores its ``rhs``
        as the import path of a module-level function. Loading such a file
        imports that module and takes the function from it, which runs the
        module's code: only with ``allow_import=True``. Without it the file is
        refused with a message naming the function. No other code is run.

    Returns
    -------
    fitted estimator
        Simulates and predicts exactly like the saved one; ``get_params()``
        returns the saved hyperparameters (it clones, refits and searches).

    Raises
    ------
    ValueError
        For a file that is not valid JSON or not a valid model file; the
        message names the field and what was expected.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from sindybench import SINDy
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
            data = json.load(f, parse_constant=_refuse_constant)
        except RecursionError:  # the parser's own recursion: thousands of nested brackets
            raise ValueError(f"{path} is not a model file: its JSON is nested thousands of levels deep; expected "
                             "a model file (about 15 levels).") from None
        except ValueError as exc:  # JSONDecodeError, UnicodeDecodeError, integers beyond 4300 digits
            raise ValueError(f"{path} is not valid JSON: {exc}") from exc
    return model_from_dict(data, allow_import=allow_import)


def _refuse_constant(name):
    raise ValueError(f"the bare constant {name} (model files write {{\"float\": \"nan\"}}, {{\"float\": \"inf\"}})")


class SaveLoadMixin:
    """Adds ``to_json(path)`` to an estimator registered with :func:`register_model`."""

    def to_json(self, path):
        """Save the fitted model as plain JSON (atomically); load it with :func:`sindybench.load_model`.

        Parameters
        ----------
        path : str or path-like
        """
        save_model(self, path)

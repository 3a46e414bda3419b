"""Argument checks shared by the whole package.

Every check raises :class:`ValueError` naming the argument, what was given and
what was expected, so that bad input never turns into a silent NaN.
"""

import numbers

import numpy as np
import scipy.sparse as sp

from ._limits import shown

__all__ = [
    "check_array_like",
    "check_bool",
    "check_bounds",
    "check_dt",
    "check_estimator_param",
    "check_inputs_outputs",
    "check_integer",
    "check_model_inputs",
    "check_n_samples",
    "check_option",
    "check_positive",
    "check_signal",
    "check_time",
    "is_records",
    "real_scalar",
    "records_hint",
    "uniform_step",
    "validate_named",
]

# Relative spread of the sampling steps below which sample times count as uniform.
UNIFORM_RTOL = 1e-6

def is_records(y):
    """Whether ``y`` holds several records: a non-empty Python list of NumPy arrays (pysindy's convention).

    A list of numbers or of lists stays one record (one array), as scikit-learn passes it.
    """
    return isinstance(y, list) and len(y) > 0 and all(isinstance(r, np.ndarray) for r in y)


def records_hint(a):
    """A sentence on how to pass several records when ``a`` looks like them (else ``""``).

    Several records are a Python list of arrays; a tuple of arrays, a 3-D
    array, a NumPy object array of arrays or a list of nested lists are
    refused (scikit-learn passes tuples and arrays as one data set, and a 3-D
    array holds only records of equal lengths), with this hint in the message.

    Examples
    --------
    >>> records_hint(np.zeros((2, 5, 1)))
    ' Several records go in a Python list of 2-D arrays (list(a) of a 3-D array), where the method takes them.'
    >>> records_hint(np.zeros((5, 1)))
    ''
    """
    hint = " Several records go in a Python list of 2-D arrays ({}), where the method takes them."
    if isinstance(a, np.ndarray):
        if a.ndim == 3:
            return hint.format("list(a) of a 3-D array")
        if a.dtype == object and a.ndim == 1 and a.size and all(isinstance(r, (np.ndarray, list)) for r in a):
            return hint.format("list(a) of an object array")
        return ""
    if not (isinstance(a, (list, tuple)) and a and all(isinstance(r, (np.ndarray, list, tuple)) for r in a)):
        return ""
    if isinstance(a, tuple):
        return hint.format("a list, not a tuple")
    if is_records(a):
        return f" A list of arrays is {len(a)} records; here one record (one array) is expected."
    return hint.format("each record a NumPy array, not a nested list") if any(_ndim(r) >= 2 for r in a) else ""


def _ndim(a):
    try:
        return np.ndim(a)
    except ValueError:  # ragged nested lists: at least 2-D
        return 2


def check_signal(a, name, *, allow_none=False, n_samples=None, ensure_2d=True):
    """Return ``a`` as a finite float array with samples along axis 0.

    Parameters
    ----------
    a : array-like or None
        The signal, shape ``(n_samples,)`` or ``(n_samples, n_channels)``.
    name : str
        Argument name used in error messages.
    allow_none : bool, default=False
        Return ``None`` for ``None`` instead of raising.
    n_samples : int, optional
        Required number of samples.
    ensure_2d : bool, default=True
        Reshape a 1-D signal into one column.

    Returns
    -------
    ndarray or None

    Examples
    --------
    >>> check_signal([1.0, 2.0], "y").shape
    (2, 1)
    >>> check_signal([1.0, float("nan")], "y")
    Traceback (most recent call last):
    ...
    ValueError: y contains NaN or inf (first at sample 1); expected finite values.
    """
    if a is None:
        if allow_none:
            return None
        raise ValueError(f"{name} is None; expected an array of shape (n_samples, n_channels).")
    try:
        arr = np.asarray(a, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} could not be converted to a float array: {exc}") from exc
    if arr.ndim == 0:
        raise ValueError(f"{name} is a scalar; expected an array of shape (n_samples, n_channels).")
    if arr.ndim == 1 and ensure_2d:
        arr = arr.reshape(-1, 1)
    if arr.ndim > 2:
        raise ValueError(
            f"{name} has {arr.ndim} dimensions (shape {arr.shape}); "
            f"expected shape (n_samples,) or (n_samples, n_channels).{records_hint(a)}"
        )
    if arr.shape[0] == 0:
        raise ValueError(f"{name} has 0 samples; expected at least one.")
    bad = ~np.isfinite(arr)
    if bad.any():
        first = int(np.argwhere(bad)[0][0])
        raise ValueError(f"{name} contains NaN or inf (first at sample {first}); expected finite values.")
    if n_samples is not None and arr.shape[0] != n_samples:
        raise ValueError(f"{name} has {arr.shape[0]} samples; expected {n_samples}.")
    return arr


def check_array_like(a, name):
    """Reject what ``np.asarray(a, dtype=float)`` would silently mangle: sparse, complex, 1-D inputs.

    ``None`` passes; a 1-D array is rejected only for ``name == "X"`` (inputs are
    2-D, a 1-D output ``y`` is one column).

    Examples
    --------
    >>> check_array_like([[1.0], [2.0]], "X")
    >>> check_array_like([1.0, 2.0], "X")
    Traceback (most recent call last):
    ...
    ValueError: X is 1-D (shape (2,)); expected 2-D (n_samples, n_inputs). Reshape ...
    >>> check_array_like([1j], "y")
    Traceback (most recent call last):
    ...
    ValueError: y is complex. Complex data not supported; expected real values.
    """
    if a is None:
        return
    if isinstance(a, (list, tuple)) and len(a) == 0:
        raise ValueError(f"{name} is an empty {type(a).__name__}; expected an array with one row per sample, or a "
                         "non-empty list of arrays (one per record) where several records are taken.")
    if sp.issparse(a):
        raise ValueError(f"{name} is a sparse matrix; sparse input is not supported, expected a dense array.")
    try:
        arr = np.asarray(a)
    except ValueError as exc:  # ragged nested lists
        raise ValueError(f"{name} could not be converted to an array: {exc}{records_hint(a)}") from exc
    if arr.dtype == object and records_hint(arr):
        raise ValueError(f"{name} is a NumPy object array of {arr.shape[0]} arrays; expected one 2-D array."
                         f"{records_hint(arr)}")
    if np.iscomplexobj(arr):
        raise ValueError(f"{name} is complex. Complex data not supported; expected real values.")
    if (name == "X" or name.startswith("X[")) and arr.ndim == 1:
        raise ValueError(
            f"{name} is 1-D (shape {arr.shape}); expected 2-D (n_samples, n_inputs). "
            f"Reshape your data with {name}.reshape(-1, 1) for a single input."
        )


def check_model_inputs(X, n_inputs, owner, *, n_samples=None):
    """Return the inputs ``X`` of a fitted model as a float array with ``n_inputs`` columns.

    ``X=None`` means no inputs: ``n_samples`` rows and 0 columns (an error
    when ``n_samples`` is None). ``owner`` names the model in the messages.

    Examples
    --------
    >>> check_model_inputs(None, 0, "SINDy", n_samples=3).shape
    (3, 0)
    >>> check_model_inputs([[1.0, 2.0]], 1, "SINDy")
    Traceback (most recent call last):
    ...
    ValueError: X has 2 features, but SINDy is expecting 1 features as input (the inputs seen in fit).
    """
    if X is None:
        if n_samples is None:
            raise ValueError("X is None; expected inputs of shape (n_samples, n_inputs) (0 columns if none).")
        X = np.zeros((n_samples, 0))
    check_array_like(X, "X")
    X = check_signal(X, "X")  # (n_samples, 0) passes: no inputs
    if X.shape[1] != n_inputs:
        raise ValueError(
            f"X has {X.shape[1]} features, but {owner} is expecting {n_inputs} "
            "features as input (the inputs seen in fit)."
        )
    return X


def check_inputs_outputs(X, y, *, x_name="X", y_name="y"):
    """Check inputs ``X`` (may have zero columns) and outputs ``y`` together.

    Returns
    -------
    X : ndarray of shape (n_samples, n_inputs)
    y : ndarray of shape (n_samples, n_outputs)

    Examples
    --------
    >>> X, y = check_inputs_outputs(None, [[1.0], [2.0]])
    >>> X.shape, y.shape
    ((2, 0), (2, 1))
    >>> check_inputs_outputs([1.0, 2.0, 3.0], [1.0, 2.0])
    Traceback (most recent call last):
    ...
    ValueError: X has 3 samples and y has 2; expected the same number of samples.
    """
    y = check_signal(y, y_name)
    if X is None:
        X = np.zeros((y.shape[0], 0))
    else:
        arr = np.asarray(X, dtype=float)
        X = arr if (arr.ndim == 2 and arr.shape[1] == 0) else check_signal(X, x_name)
    if X.shape[0] != y.shape[0]:
        raise ValueError(
            f"{x_name} has {X.shape[0]} samples and {y_name} has {y.shape[0]}; "
            "expected the same number of samples."
        )
    return X, y


def check_positive(value, name, *, allow_none=False, strict=True, allow_inf=False):
    """Return ``value`` as a float after checking that it is positive (and finite, unless ``allow_inf``).

    Examples
    --------
    >>> check_positive(0.5, "dt")
    0.5
    >>> check_positive(0.0, "dt")
    Traceback (most recent call last):
    ...
    ValueError: dt must be a finite number > 0; got 0.0.
    >>> check_positive(float("inf"), "max_abs", allow_inf=True)
    inf
    >>> check_positive(np.array(0.1), "dt")  # a 0-d array, as np.load gives a number
    0.1
    """
    if value is None and allow_none:
        return None
    value = real_scalar(value)
    op = ">" if strict else ">="
    expected = f"a number {op} 0 (inf allowed)" if allow_inf else f"a finite number {op} 0"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be {expected}; got {shown(value)}.")
    value = float(value)
    if np.isnan(value) or (np.isinf(value) and not allow_inf) or value < 0 or (strict and value == 0):
        raise ValueError(f"{name} must be {expected}; got {shown(value)}.")
    return value


def real_scalar(value):
    """``value``, or its NumPy scalar when it is a 0-d real array (what ``np.load`` gives for a number)."""
    is_real = isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf"
    return value[()] if is_real else value


def check_integer(value, name, *, low=1, high=None):
    """Return ``value`` as an int after checking that it is an integer in ``[low, high]``.

    ``bool`` is rejected (``True`` is not a count); ``low=None`` / ``high=None`` mean no
    lower / upper limit.

    Examples
    --------
    >>> check_integer(3, "n_substeps")
    3
    >>> check_integer(2.0, "n_substeps")
    Traceback (most recent call last):
    ...
    ValueError: n_substeps must be an integer >= 1; got 2.0.
    >>> check_integer(5, "order", low=1, high=2)
    Traceback (most recent call last):
    ...
    ValueError: order must be an integer in [1, 2]; got 5.
    >>> check_integer(-3, "low", low=None)
    -3
    """
    ok = isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))
    if not ok or (low is not None and value < low) or (high is not None and value > high):
        if high is None:
            expected = "" if low is None else f" >= {low}"
        else:
            expected = f" <= {high}" if low is None else f" in [{low}, {high}]"
        raise ValueError(f"{name} must be an integer{expected}; got {shown(value)}.")
    if abs(int(value)) >= 2**63:  # would overflow the compiled code's 64-bit integers
        raise ValueError(f"{name} = {shown(value)} does not fit in a 64-bit integer; expected a smaller count.")
    return int(value)


def check_bool(value, name):
    """Return ``value`` as a bool after checking that it is ``True`` or ``False``.

    Examples
    --------
    >>> check_bool(1, "unbias")
    Traceback (most recent call last):
    ...
    ValueError: unbias must be True or False; got 1.
    """
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False; got {shown(value)}.")
    return bool(value)


def check_option(value, name, options):
    """Return ``value`` after checking that it is one of ``options`` (shown as given in the message).

    Examples
    --------
    >>> check_option("rk4", "method", ("rk4", "euler"))
    'rk4'
    >>> check_option("rk2", "method", ("rk4", "euler"))
    Traceback (most recent call last):
    ...
    ValueError: method must be one of ('rk4', 'euler'); got 'rk2'.
    """
    try:
        known = value in options
    except TypeError:  # unhashable value, dict options
        known = False
    if not known:
        raise ValueError(f"{name} must be one of {shown(options)}; got {shown(value)}.")
    return value


def check_dt(dt, *, allow_none=False):
    """Check a sampling interval (a finite number > 0)."""
    return check_positive(dt, "dt", allow_none=allow_none)


def check_time(t, n_samples=None, *, name="t"):
    """Return ``t`` as a 1-D float array, finite and strictly increasing.

    Examples
    --------
    >>> check_time([0.0, 0.1, 0.1])
    Traceback (most recent call last):
    ...
    ValueError: t must be strictly increasing; t[2] = 0.1 <= t[1] = 0.1.
    """
    t = np.asarray(t, dtype=float)
    if t.ndim != 1:
        raise ValueError(f"{name} has shape {t.shape}; expected a 1-D array of sample times.")
    if not np.all(np.isfinite(t)):
        raise ValueError(f"{name} contains NaN or inf; expected finite sample times.")
    if n_samples is not None and t.shape[0] != n_samples:
        raise ValueError(f"{name} has {t.shape[0]} samples; expected {n_samples} (one per sample).")
    d = np.diff(t)
    if np.any(d <= 0):
        i = int(np.argmax(d <= 0)) + 1
        raise ValueError(
            f"{name} must be strictly increasing; {name}[{i}] = {t[i]:g} <= {name}[{i - 1}] = {t[i - 1]:g}."
        )
    return t


def uniform_step(t):
    """The sampling interval of checked sample times ``t`` if uniform (within ``UNIFORM_RTOL``), else None.

    Examples
    --------
    >>> uniform_step(np.array([0.0, 0.5, 1.0]))
    0.5
    >>> uniform_step(np.array([0.0, 1.0, 3.0])) is None
    True
    """
    if t.shape[0] < 2:
        return None
    mean = (t[-1] - t[0]) / (t.shape[0] - 1)
    return float(mean) if np.max(np.abs(np.diff(t) - mean)) <= UNIFORM_RTOL * mean else None


def check_n_samples(n_samples, n_features, *, what="library terms"):
    """Raise when there are fewer samples than unknowns to fit.

    Examples
    --------
    >>> check_n_samples(3, 5)
    Traceback (most recent call last):
    ...
    ValueError: got 3 samples but 5 library terms; expected at least as many samples as library terms.
    """
    if n_samples < n_features:
        raise ValueError(
            f"got {n_samples} samples but {n_features} {what}; "
            f"expected at least as many samples as {what}."
        )


def check_bounds(bounds, n_states, *, name="bounds"):
    """Return ``(lower, upper)`` arrays of length ``n_states`` (``None`` -> unbounded).

    ``bounds`` may be ``None``, a pair of scalars, or a pair of sequences with one
    entry per state (``None`` entries mean unbounded).

    Examples
    --------
    >>> lo, hi = check_bounds((0.0, None), 2)
    >>> lo.tolist(), hi.tolist()
    ([0.0, 0.0], [inf, inf])
    """
    if bounds is None:
        return np.full(n_states, -np.inf), np.full(n_states, np.inf)
    try:
        lo, hi = bounds
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a pair (lower, upper); got {shown(bounds)}.") from exc

    def side(v, default):
        if v is None:
            return np.full(n_states, default)
        arr = np.array(
            [default if e is None else e for e in np.atleast_1d(np.asarray(v, dtype=object))],
            dtype=float,
        )
        if arr.size == 1:
            arr = np.full(n_states, arr[0])
        if arr.shape != (n_states,):
            raise ValueError(f"{name} has {arr.size} entries per side; expected 1 or {n_states} (one per state).")
        if np.any(np.isnan(arr)):
            raise ValueError(f"{name} contains NaN; use None or inf for an unbounded side.")
        return arr

    lo, hi = side(lo, -np.inf), side(hi, np.inf)
    if np.any(lo >= hi):
        i = int(np.argmax(lo >= hi))
        raise ValueError(f"{name}: lower bound {lo[i]:g} >= upper bound {hi[i]:g} for state {i}; expected lower < upper.")
    return lo, hi


def validate_named(estimator, X, y="no_validation", **kwargs):
    """scikit-learn's ``validate_data``, with the argument at fault named in its errors.

    scikit-learn's messages ("Expected 2D array, got 1D array instead") do not say
    which argument they are about; this prefixes ``X:``, ``y:`` or ``X and y:``
    and keeps the rest of the text (the common estimator checks match it).

    Examples
    --------
    >>> from sklearn.linear_model import LinearRegression
    >>> validate_named(LinearRegression(), [1.0, 2.0], [1.0, 2.0])
    Traceback (most recent call last):
    ...
    ValueError: X: Expected 2D array, got 1D array instead: ...
    """
    from sklearn.utils import check_array
    from sklearn.utils.validation import validate_data

    for a, name in ((X, "X"), (y, "y")):  # scikit-learn raises TypeError for a scalar y
        if a is None or isinstance(a, str):
            continue
        try:
            ndim = np.asarray(a).ndim  # not np.ndim: scikit-learn's checks pass objects that refuse it
        except ValueError as exc:  # ragged nested lists
            raise ValueError(f"{name} could not be converted to an array: {exc}") from exc
        if ndim == 0:
            raise ValueError(f"{name} is a scalar ({shown(a)}); expected an array with one row per sample.")
    try:
        return validate_data(estimator, X, y, **kwargs)
    except ValueError as exc:
        culprit = "X"
        if not (isinstance(y, str) and y == "no_validation"):
            try:
                check_array(X, dtype=kwargs.get("dtype", "numeric"), ensure_2d=True)
            except ValueError:
                culprit = "X"
            else:
                culprit = "X and y" if "inconsistent numbers of samples" in str(exc) else "y"
        raise ValueError(f"{culprit}: {exc}") from exc


def check_estimator_param(value, name, expected):
    """Check that a parameter holding an estimator is one (``fit`` and ``get_params``) or None.

    Examples
    --------
    >>> check_estimator_param("stls", "optimizer", "a regressor such as STLS()")
    Traceback (most recent call last):
    ...
    ValueError: optimizer must be a regressor such as STLS() or None; got 'stls'.
    """
    if value is not None and not all(callable(getattr(value, m, None)) for m in ("fit", "get_params")):
        raise ValueError(f"{name} must be {expected} or None; got {shown(value)}.")
    return value


def check_alpha(alpha, what):
    """``alpha`` as a float in (0, 1): ``1 - alpha`` ``what`` (bands, intervals)."""
    if isinstance(alpha, bool) or not isinstance(alpha, numbers.Real) or not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1) (0.05 gives 95 % {what}); got {alpha!r}.")
    return float(alpha)


def check_column_names(names, n, prefix, name):
    """``names`` as a list of ``n`` strings; ``prefix0, prefix1, ...`` when None (``name`` is the parameter's)."""
    if names is None:
        return [f"{prefix}{i}" for i in range(n)]
    if isinstance(names, str) or not hasattr(names, "__len__") or len(names) != n or not all(
            isinstance(s, str) for s in names):
        raise ValueError(f"{name} must be a list of {n} strings; got {names!r}.")
    return list(names)


def check_distinct_names(out_names, in_names):
    """Outputs and inputs name the columns of ``Z = [y, u]``: one name for two columns is a ``ValueError``.

    Examples
    --------
    >>> check_distinct_names(["u0"], ["u0"])
    Traceback (most recent call last):
    ...
    ValueError: output_names and input_names share 'u0' (output 0 and input 0); expected distinct names ...
    """
    seen = {}
    for kind, names in (("output", out_names), ("input", in_names)):
        for i, name in enumerate(names):
            if name in seen:
                raise ValueError(f"output_names and input_names share {name!r} ({seen[name]} and {kind} {i}); expected "
                                 "distinct names (the equations and the library's features name the columns by them).")
            seen[name] = f"{kind} {i}"

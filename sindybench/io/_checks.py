"""Checks of model files before and while they are read: size limits, kinds, parameter checks."""

import numpy as np

__all__ = ["check_fitted_kind", "check_limit", "check_params", "check_plain"]

MAX_DEPTH = 100  # nesting of JSON lists and objects in a model file (real files: about 15)
MAX_SUBSTEPS = 1000  # integration sub-steps per sample a file may ask for (each one costs a step of every run)


def check_plain(data, field=""):
    """Check that JSON ``data`` is plain and bounded: nesting and integers.

    Lists and objects may nest at most ``MAX_DEPTH`` (100) levels and
    integers must fit in 64 bits; a deeper or larger value (a file built to
    exhaust the recursion limit or the float conversion) is refused with a
    ``ValueError`` naming where it sits. Runs without recursion, in one pass.

    Examples
    --------
    >>> check_plain({"a": [1, 2.5, "x", None]})
    >>> nested = []
    >>> for _ in range(200):
    ...     nested = [nested]
    >>> check_plain({"params": {"bounds": nested}})
    Traceback (most recent call last):
    ...
    ValueError: params.bounds[0][0]...: nested more than 100 levels deep; expected a model file (about 15 levels).
    >>> check_plain({"fitted": {"n_states": 10**30}})
    Traceback (most recent call last):
    ...
    ValueError: fitted.n_states: an integer of 31 digits; expected a 64-bit integer.
    """
    stack = [(data, 0, field)]
    while stack:
        value, depth, where = stack.pop()
        if depth > MAX_DEPTH:
            raise ValueError(f"{where[:60]}...: nested more than {MAX_DEPTH} levels deep; expected a model file "
                             "(about 15 levels).")
        items = value.items() if isinstance(value, dict) else enumerate(value)
        for key, v in items:
            if isinstance(v, (dict, list)):
                stack.append((v, depth + 1, _child(where, key)))
            elif isinstance(v, int) and not -2**63 <= v < 2**63:
                digits = int(v.bit_length() * 0.30103)  # str(v) itself is refused beyond 4300 digits
                digits += abs(v) >= 10**digits
                raise ValueError(f"{_child(where, key)}: an integer of {digits} digits; expected a 64-bit integer.")
            elif not isinstance(v, (int, float, str)) and v is not None:
                raise ValueError(f"{_child(where, key)}: a {type(v).__name__}; expected JSON data.")


def _child(where, key):
    if isinstance(key, str):
        return f"{where}.{key}" if where else key
    return f"{where}[{key}]"


def check_fitted_kind(value, expected, field):
    """Refuse a fitted part (optimizer, differentiation) of another class than the parameters give.

    Returns ``value``.

    Examples
    --------
    >>> from sindybench import STLS
    >>> check_fitted_kind(STLS(), STLS, "fitted.optimizer")
    STLS()
    >>> check_fitted_kind([], STLS, "fitted.optimizer")
    Traceback (most recent call last):
    ...
    ValueError: fitted.optimizer: expected a fitted STLS (the class the parameters name); got list.
    """
    if type(value) is not expected:
        raise ValueError(f"{field}: expected a fitted {expected.__name__} (the class the parameters name); "
                         f"got {type(value).__name__}.")
    return value


def check_limit(value, field, high=MAX_SUBSTEPS):
    """Refuse a stored count (sub-steps, grid points) larger than a model file may ask for.

    A setting such as ``n_substeps = 10**9`` loads in no time and then makes
    every simulation hang; such a file is refused at loading instead.

    Parameters
    ----------
    value : int
        The (already validated) setting.
    field : str
        Where it sits in the file, for the message.
    high : int, default=1000

    Examples
    --------
    >>> check_limit(4, "params.n_substeps")
    >>> check_limit(10**9, "params.n_substeps")
    Traceback (most recent call last):
    ...
    ValueError: params.n_substeps = 1000000000; a model file may ask for at most 1000.
    """
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool) and value > high:
        raise ValueError(f"{field} = {value}; a model file may ask for at most {high}.")


def check_params(check, *args):
    """Run an estimator's parameter check at loading; its ``ValueError`` (or ``TypeError``) names ``params``."""
    try:
        return check(*args)
    except (ValueError, TypeError) as exc:  # a stored value of the wrong type may fail a conversion
        raise ValueError(f"params: {exc}") from exc

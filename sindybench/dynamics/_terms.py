"""The term data structure: checking terms and flattening them for the compiled kernels."""

import numpy as np

from ._ops import BUILTIN_OPS, USER, evaluate_jacobian_kernel, evaluate_kernel, no_user_ops
from ._user import UserOp, user_op, user_table

__all__ = ["check_terms", "evaluate_terms", "evaluate_terms_jacobian", "terms_to_arrays", "user_ops_of"]


def check_terms(terms, n_variables=None, *, name="terms"):
    """Return ``terms`` as a list of tuples of ``(int, int, float, float)`` factors.

    Accepts the JSON form too (lists; ``"inf"`` / ``"-inf"`` strings for
    infinite clip values). A user operation (:func:`~sindybench.dynamics.register_op`)
    keeps its :class:`~sindybench.dynamics.UserOp` code.

    Parameters
    ----------
    terms : sequence of sequence of (col, op, a, b)
    n_variables : int, optional
        Number of columns of ``Z``; every ``col`` must be below it.

    Examples
    --------
    >>> check_terms([[], [[1, 2, 0, "inf"]]])
    [(), ((1, 2, 0.0, inf),)]
    >>> check_terms([[[2, 0, 1, 0]]], 2)
    Traceback (most recent call last):
    ...
    ValueError: terms[0] uses column 2 of Z; expected columns in [0, 1].
    """
    if isinstance(terms, (str, bytes)) or not hasattr(terms, "__iter__"):
        raise ValueError(f"{name} must be a sequence of terms; got {terms!r}.")
    out = []
    for j, term in enumerate(terms):
        factors = []
        try:
            for col, op, a, b in term:
                factors.append((int(col), op if isinstance(op, UserOp) else int(op), float(a), float(b)))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name}[{j}] = {term!r} is not a sequence of (col, op, a, b) factors.") from exc
        for col, op, a, b in factors:
            if op not in BUILTIN_OPS:
                if op < USER:
                    raise ValueError(f"{name}[{j}] has unknown operation {op}; expected one of {BUILTIN_OPS} "
                                     f"or a registered user operation (>= {USER}).")
                try:
                    user_op(op)
                except ValueError as exc:
                    raise ValueError(f"{name}[{j}]: {exc}") from exc
            if col < 0 or (n_variables is not None and col >= n_variables):
                hi = "" if n_variables is None else f" in [0, {n_variables - 1}]"
                raise ValueError(f"{name}[{j}] uses column {col} of Z; expected columns{hi}.")
            if np.isnan(a) or np.isnan(b):
                raise ValueError(f"{name}[{j}] has a NaN parameter; expected numbers.")
        out.append(tuple(factors))
    return out


def terms_to_arrays(terms):
    """Flatten terms into arrays for compiled evaluation.

    Returns
    -------
    ptr : ndarray of int64, shape (n_terms + 1,)
        Factors of term ``j`` are ``ptr[j]:ptr[j + 1]``.
    col, op : ndarray of int64
    a, b : ndarray of float64

    Examples
    --------
    >>> ptr, col, op, a, b = terms_to_arrays([(), ((1, 0, 2, 0),)])
    >>> ptr.tolist(), col.tolist()
    ([0, 0, 1], [1])
    """
    flat = [f for term in terms for f in term]
    ptr = np.zeros(len(terms) + 1, dtype=np.int64)
    ptr[1:] = np.cumsum([len(term) for term in terms])
    col = np.array([f[0] for f in flat], dtype=np.int64)
    op = np.array([int(f[1]) for f in flat], dtype=np.int64)
    a = np.array([f[2] for f in flat], dtype=float)
    b = np.array([f[3] for f in flat], dtype=float)
    return ptr, col, op, a, b


def _has_user_ops(terms):
    return any(f[1] >= USER for t in terms for f in t)


def user_ops_of(terms):
    """The compiled user table the kernels need for ``terms`` (a no-op table without user operations)."""
    return user_table() if _has_user_ops(terms) else no_user_ops


_FLAT = {}  # terms -> (checked terms, flattened arrays, highest column, has user ops): evaluation is often per sample


def _arrays(terms, Z):
    try:
        key = tuple(terms)
        hit = _FLAT.get(key)
    except TypeError:  # the JSON form (lists)
        key = hit = None
    if hit is None:
        checked = check_terms(terms)
        hit = (checked, terms_to_arrays(checked), max((f[0] for t in checked for f in t), default=-1),
               _has_user_ops(checked))
        if key is not None:
            if len(_FLAT) >= 256:
                _FLAT.clear()
            _FLAT[key] = hit
    terms, arrays, used, has_user = hit
    Z = np.asarray(Z, dtype=float)
    if Z.ndim != 2:
        raise ValueError(f"Z has shape {Z.shape}; expected (n_samples, n_variables).")
    if used >= Z.shape[1]:
        raise ValueError(f"terms use column {used} of Z, which has {Z.shape[1]} columns.")
    return terms, Z, arrays, user_table() if has_user else no_user_ops  # the table may grow: asked each time


def evaluate_terms(terms, Z):
    """Evaluate ``terms`` on the rows of ``Z`` (compiled, the simulator's arithmetic).

    Parameters
    ----------
    terms : sequence of tuple of (col, op, a, b)
    Z : ndarray of shape (n_samples, n_variables)

    Returns
    -------
    ndarray of shape (n_samples, len(terms))

    Examples
    --------
    >>> from sindybench.dynamics import ABS_POW, POW
    >>> Z = np.array([[2.0, -3.0]])
    >>> evaluate_terms([(), ((0, POW, 2, 0),), ((0, POW, 1, 0), (1, ABS_POW, 1, 0))], Z)
    array([[1., 4., 6.]])
    """
    terms, Z, arrays, user = _arrays(terms, Z)
    out = np.empty((Z.shape[0], len(terms)))
    evaluate_kernel(Z, *arrays, user, out)
    return out


def evaluate_terms_jacobian(terms, Z):
    """Derivatives of ``terms`` with respect to the columns of ``Z`` (arguments as :func:`evaluate_terms`).

    Returns
    -------
    ndarray of shape (n_samples, len(terms), n_variables)
        ``out[k, j, c]`` is the derivative of term ``j`` with respect to
        ``Z[:, c]`` at sample ``k`` (product rule over the term's factors).

    Examples
    --------
    >>> from sindybench.dynamics import ABS_POW, POW, SQRT
    >>> Z = np.array([[2.0, -3.0]])
    >>> evaluate_terms_jacobian([((0, POW, 2, 0), (1, ABS_POW, 1, 0))], Z)[0]
    array([[12., -4.]])
    >>> evaluate_terms_jacobian([((0, SQRT, 0.0, 1.0),)], np.array([[0.25], [4.0]]))[:, 0, 0]
    array([1., 0.])
    """
    terms, Z, arrays, user = _arrays(terms, Z)
    out = np.zeros((Z.shape[0], len(terms), Z.shape[1]))
    evaluate_jacobian_kernel(Z, *arrays, user, np.empty(arrays[1].shape[0]), out)
    return out
